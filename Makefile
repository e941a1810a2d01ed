# Two commands do everything (see README):
#   make all   - install what is missing, then run the whole study: snakemake --cores 2 all
#   make test  - install what is missing, then run the test suite
#   make cluster-test - a one-node Slurm on localhost: mesh, modes (MPI) and simulations through
#                       --executor slurm, compared with a local run (workflow/cluster/slurm_localhost.sh)
#   make benchmark-all - clean clones' `snakemake --cores 2 all`, timed, with their critical path
#                        (workflow/benchmark-all.sh; a quiet machine, ~25 min)
PY := .venv/bin/python
CORES ?= 2

.PHONY: all test test-all install clean cluster-test benchmark-all
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

benchmark-all:
	bash workflow/benchmark-all.sh

clean:
	rm -rf results/*/ logs .snakemake
