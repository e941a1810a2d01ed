# Two commands do everything (see README):
#   make all   - install what is missing, then run the whole study: snakemake --cores 2 all
#   make test  - install what is missing, then run the test suite
#   make cluster-test - a one-node Slurm on localhost: mesh, modes (MPI) and simulations through
#                       --executor slurm, compared with a local run (workflow/cluster/slurm_localhost.sh)
PY := .venv/bin/python
CORES ?= 2

.PHONY: all test test-all install clean cluster-test
all: install
	$(PY) -m snakemake --cores $(CORES) all

test: install
	$(PY) -m pytest -m "not slow" -q

test-all: install
	$(PY) -m pytest -q

install:
	bash workflow/envs/install.sh

cluster-test: install
	bash workflow/cluster/slurm_localhost.sh

clean:
	rm -rf results/*/ logs .snakemake
