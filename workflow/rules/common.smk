# Shared set-up: validate the config (one-line error naming the key), the
# interpreter that runs every stage, and the code each stage depends on.
import importlib
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(workflow.basedir)))
cfgmod = importlib.import_module("workflow.config")  # not "import workflow...": Snakemake owns that name

try:
    cfgmod.validate(config)
except cfgmod.ConfigError as exc:
    # one line naming the key, and nothing else (Snakemake would wrap it in a traceback)
    sys.stderr.write(f"{exc}\n")
    sys.stderr.flush()
    os._exit(1)

PY = sys.executable
# the file the stages read; pass another with --configfile (not --config key=value)
CONFIG = (workflow.overwrite_configfiles or ["config/config.yaml"])[-1]
BODIES = [2, 3, 4, 5]

wildcard_constraints:
    n="[2-5]",


def config_hash(*keys):
    """A Snakemake params function: the hash of the config sections a rule reads."""
    return lambda wildcards: cfgmod.section_hash(config, *keys)


def body_hash(wildcards):
    return cfgmod.section_hash(config, *cfgmod.body_config_keys(wildcards.n))


COMMON_CODE = ["workflow/config.py", "workflow/provenance.py", "workflow/schemas/config.schema.yaml"]
GEOMETRY_CODE = COMMON_CODE + ["geometry/gimbal.py", "geometry/mesh.py"]
MODES_CODE = COMMON_CODE + ["solver/fe/forms.py", "solver/fe/bearings.py", "solver/fe/eigen.py", "solver/fe/modes.py", "solver/bodydata.py",
                            "reduction/modal_integrals.py", "reduction/errors.py"]
