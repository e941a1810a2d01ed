# Shared set-up: validate the config (one-line error naming the key), the
# interpreter that runs every stage, and the rerun triggers: the hash of the code
# each stage runs and of the config values it reads.
import importlib
import os
import sys

import snakemake
from pathlib import Path

sys.path.insert(0, str(Path(workflow.basedir)))
# First: is this the project's Snakemake and interpreter (the rules run {PY} = sys.executable)?
# Debian's /usr/bin/snakemake or a python without Numba/Typst stops here in one line saying how to
# run the workflow (workflow/environment.py, standard library only), before anything is imported.
_environment_problem = importlib.import_module("workflow.environment").problem(snakemake.__version__)
if _environment_problem:
    sys.stderr.write(f"{_environment_problem}\n")
    sys.stderr.flush()
    os._exit(1)
cfgmod = importlib.import_module("workflow.config")  # not "import workflow...": Snakemake owns that name

# the file the stages read; pass another with --configfile (not --config key=value)
CONFIG = (workflow.overwrite_configfiles or ["config/config.yaml"])[-1]

try:
    # Snakemake's own YAML reading keeps the last of duplicate keys: re-read each file strictly
    for _path in (workflow.overwrite_configfiles or ["config/config.yaml"]):
        cfgmod.read_config_file(_path)
    # the values in the units their keys are read in, as the stages read them (load_config)
    config.update(cfgmod.validate(config))
except cfgmod.ConfigError as exc:
    # one line naming the key, and nothing else (Snakemake would wrap it in a traceback)
    sys.stderr.write(f"{exc}\n")
    sys.stderr.flush()
    os._exit(1)

PY = sys.executable
BODIES = [2, 3, 4, 5]

wildcard_constraints:
    n="[2-5]",


def config_hash(*keys):
    """A Snakemake params function: the hash of the config sections a rule reads (all of it if none)."""
    return lambda wildcards: cfgmod.section_hash(config, *keys)


def body_hash(part=None, body=None, mesh_size=None):
    """A params function: the hash of a body's resolved inputs (workflow.config.body_inputs, which the
    mesh and modal stages read), or of one part of them ("mesh"); the body is the wildcard n unless given."""
    def inputs_hash(wildcards):
        inputs = cfgmod.body_inputs(config, body or wildcards.n, mesh_size)
        return cfgmod.inputs_hash(inputs[part] if part else inputs)
    return inputs_hash


def check_hash(check=None, body=None):
    """A params function: the hash of what an FE check reads (workflow.config.check_inputs); the check
    and the body are the wildcards check and n unless given."""
    return lambda wildcards: cfgmod.inputs_hash(cfgmod.check_inputs(
        config, check or wildcards.check, body or getattr(wildcards, "n", None)))


# The code a rule runs: the hash of its stage's module (python -m X), of the project modules it
# imports, transitively, and of the data files they read (workflow/imports.py); comments and
# docstrings left out. A rule carries it as params.code, so editing a module reruns exactly the
# rules whose stages import it, and editing a comment reruns nothing.
code_hash = importlib.import_module("workflow.imports").code_hash
