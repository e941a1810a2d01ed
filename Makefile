# Two commands do everything (see README):
#   make all   - install what is missing, then run the whole study: snakemake --cores 2 all
#   make test  - install what is missing, then run the test suite
PY := .venv/bin/python
CORES ?= 2

.PHONY: all test test-all install clean
all: install
	$(PY) -m snakemake --cores $(CORES) all

test: install
	$(PY) -m pytest -m "not slow" -q

test-all: install
	$(PY) -m pytest -q

install:
	bash workflow/envs/install.sh

clean:
	rm -rf results/*/ logs .snakemake
