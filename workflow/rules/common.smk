# Shared set-up: validate the config (one-line error naming the key), the
# interpreter that runs every stage, and the rerun triggers: the hash of the code
# each stage runs and of the config values it reads.
import functools
import importlib
import os
import sys
from pathlib import Path

import snakemake

sys.path.insert(0, str(Path(workflow.basedir)))
# the jobs run `python -m <stage>` in the working directory, which is not the project's with
# --directory: the project's packages go on their PYTHONPATH too (set here, not required of the
# user, so no `envvars:` directive)
os.environ.update(
    PYTHONPATH=os.pathsep.join(
        [str(Path(workflow.basedir))] + [p for p in [os.environ.get("PYTHONPATH")] if p]
    )
)
# First: is this the project's Snakemake and interpreter (the rules run {GIMBAL} beside sys.executable)?
# Another Snakemake (a system one, an older pin) or a python without Numba/Typst stops here in one line saying how to
# run the workflow (gimbal_reduction/workflow/environment.py, standard library only), before anything is imported.
_environment_problem = importlib.import_module(
    "gimbal_reduction.workflow.environment"
).problem(snakemake.__version__)
if _environment_problem:
    sys.stderr.write(f"{_environment_problem}\n")
    sys.stderr.flush()
    os._exit(1)
# not "import workflow...": Snakemake owns that name
cfgmod = importlib.import_module("gimbal_reduction.workflow.config")

# Then: does another run hold this directory's files, and can its output folders be written? One
# line each, before the DAG (gimbal_reduction/workflow/runlock.py), for a dry run too (Snakemake
# sets it only after reading this file); a job's own Snakemake process (is_main_process False)
# belongs to the run.
_runlock = importlib.import_module("gimbal_reduction.workflow.runlock")
if workflow.is_main_process:
    _holder = _runlock.holder()
    _problem = _runlock.holder_message(_holder) if _holder else _runlock.unwritable()
    if _problem:
        sys.stderr.write(f"{_problem}\n")
        sys.stderr.flush()
        os._exit(1)


onstart:
    _runlock.claim()


onsuccess:
    _runlock.release()


onerror:
    _runlock.release()


# the file the stages read; pass another with --configfile (not --config key=value); used in the
# rules' shell commands as {CONFIG} (a justified lint, see GIMBAL below)
CONFIG = (workflow.overwrite_configfiles or ["config/config.yaml"])[-1]

try:
    # Snakemake's own YAML reading keeps the last of duplicate keys: re-read each file strictly
    for _path in workflow.overwrite_configfiles or ["config/config.yaml"]:
        cfgmod.read_config_file(_path)
    # the values in the units their keys are read in, as the stages read them (load_config)
    config.update(cfgmod.validate(config))
except cfgmod.ConfigError as exc:
    # one line naming the key, and nothing else (Snakemake would wrap it in a traceback)
    sys.stderr.write(f"{exc}\n")
    sys.stderr.flush()
    os._exit(1)

# Justified lints (`snakemake --lint`; tests/workflow/test_conventions.py allows exactly these):
# * "Shell command directly uses variable GIMBAL / CONFIG / COARSE_SIZE from outside of the rule" (every
#   rule that runs a stage). GIMBAL is the `gimbal` command beside the interpreter running Snakemake, the one with the project's
#   packages (checked above); CONFIG is the config file the stage reads (--configfile), whose values
#   the stage reads are hashed in params.cfg, and COARSE_SIZE (reduction.smk) is hashed there too.
#   Making them params or inputs would change every job's params or shell command, so Snakemake's
#   params and code triggers would rerun every existing result once, for no change of any output;
#   and the config file as an input would rerun every stage on any edit (params.cfg is the precise
#   trigger). They are workflow-wide constants like a shell prefix.
# * "Specify a conda environment or container for each rule" (every rule): the software environment
#   is the project's .venv (workflow/envs/install.sh: every pin of workflow/envs/requirements.txt
#   from PyPI, DOLFINx 0.11 with PETSc, SLEPc and MPICH included), checked at DAG build above. A conda
#   environment or a container per rule would be a second software stack that nothing here
#   verifies (and no container image can be fetched on this project's machines).
PY = sys.executable
# the `gimbal` command (gimbal_reduction/commands.py, an entry point of pyproject.toml) of the
# environment running Snakemake: every stage runs as `gimbal STAGE ...`, what a user types
GIMBAL = str(Path(sys.executable).with_name("gimbal"))
BODIES = [2, 3, 4, 5]
RINGS = [2, 3, 4]  # the bodies with an output interface (Craig-Bampton stage files)


wildcard_constraints:
    n="[2-5]",


def config_hash(*keys):
    """A Snakemake params function: the hash of the config sections a rule reads (all of it if none)."""
    return lambda wildcards: cfgmod.section_hash(config, *keys)


def body_hash(part=None, body=None, mesh_size=None):
    """A params function: the hash of a body's resolved inputs (gimbal_reduction.workflow.config.body_inputs, which the
    mesh and modal stages read), or of one part of them ("mesh"); the body is the wildcard n unless given.
    """

    def inputs_hash(wildcards):
        inputs = cfgmod.body_inputs(config, body or wildcards.n, mesh_size)
        return cfgmod.inputs_hash(inputs[part] if part else inputs)

    return inputs_hash


def check_hash(check=None, body=None):
    """A params function: the hash of what an FE check reads (gimbal_reduction.workflow.config.check_inputs); the check
    and the body are the wildcards check and n unless given."""
    return lambda wildcards: cfgmod.inputs_hash(
        cfgmod.check_inputs(
            config, check or wildcards.check, body or getattr(wildcards, "n", None)
        )
    )


def body_files_hash(wildcards):
    """params.cfg of a rule whose stage checks the body files it reads (directly, or through the
    reduction, ranking and reduced-model files made from them) against the configuration
    (--config {CONFIG}, gimbal_reduction/solver/bodyconfig.py): what it compares them with, the config hash the
    configuration gives every body file."""
    return cfgmod.inputs_hash(
        [cfgmod.inputs_hash(cfgmod.body_inputs(config, n)) for n in BODIES]
    )


# The code of a rule's stage: the hash of its stage's module (`gimbal STAGE`, gimbal_reduction/commands.py), of the modules it
# imports, transitively, and of the data files they read (gimbal_reduction/workflow/imports.py); comments and
# docstrings left out. A rule carries it as params.code, so editing a module reruns exactly the
# rules whose stages import it, and editing a comment reruns nothing.
_imports = importlib.import_module("gimbal_reduction.workflow.imports")
_commands = importlib.import_module("gimbal_reduction.commands")


def code_hash(*stages):
    """The hash of the code the `gimbal` stages ``stages`` run (their modules and what they import)."""
    return _imports.code_hash(*map(_commands.module_of, stages))


# ---- The rule files' helpers, here so that no rule file mixes rules and functions (Snakemake's
# lint); each is used by the rule file named above it.
selection_mod = importlib.import_module("gimbal_reduction.reduction.selection")
names_mod = importlib.import_module("gimbal_reduction.reduction.names")
scenes_mod = importlib.import_module("gimbal_reduction.solver.dynamics.scenes")


# ---- A bad scene or model name (a target's, or in a scene's needs.models) stops the DAG build in one
# line naming the culprit, before any job runs (a mesh or a modal solve included): an exception in an
# input or params function would reach the user as Snakemake's multi-line InputFunctionException.
def dag_refuse(message):
    """Stop the DAG build with one line on stderr (the config's errors above do the same)."""
    sys.stderr.write(" ".join(str(message).split()) + "\n")
    sys.stderr.flush()
    os._exit(1)


@functools.lru_cache(maxsize=None)
def dag_scene(name):
    """The scene ``name`` (its file: scene_path), or a one-line refusal naming it."""
    try:
        return scenes_mod.load_scene(scene_path(name))
    except ValueError as exc:  # SceneError: unknown scene, bad YAML, bad key or value
        dag_refuse(exc)


def checked_model(model, where):
    """``model`` if it names a model the configuration can build (gimbal_reduction.reduction.selection.check_name, with
    modes.count modes per body), else a one-line refusal naming ``where`` (the target or the scene).
    """
    count = cfgmod.value(config, "modes.count")
    try:
        selection_mod.check_name(model, count)
    except names_mod.ModelError as exc:
        dag_refuse(
            f"{where}: {exc} (model names: gimbal_reduction/reduction/models.py; modes.count = {count} in "
            f"{CONFIG}); nothing was run"
        )
    return model


# models.smk
def scene_path(name):
    """A scene's file: config/scenes/{name}.yaml of the working directory if it has one (the project's
    own, a deployment's or .test's), else the workflow's, so a run with --directory finds the scenes.
    """
    local = os.path.join("config", "scenes", f"{name}.yaml")
    shipped = os.path.join(workflow.basedir, local)
    return local if os.path.exists(local) or not os.path.exists(shipped) else shipped


def scene_file(wildcards):
    dag_scene(wildcards.scene)  # it exists and is valid, or one line
    return scene_path(wildcards.scene)


def model_inputs(wildcards):
    """What one reduced model needs, and nothing else: every body file (mass properties),
    the reduction files only if the model's selection reads a ranking (xmx, xmgmx, load,
    global), and the scene's load-aware ranking for load-* and global-*.  So the DAG of
    results/sim/thesis/freq-10.h5 is four meshes, four modal solutions, one reduced model
    and one simulation."""
    dag_scene(wildcards.scene)
    checked_model(
        wildcards.model, f"results/models/{wildcards.scene}/{wildcards.model}.h5"
    )
    needed = {"bodies": [f"results/modes/body{n}.h5" for n in BODIES]}
    if names_mod.needs_reduction_rankings(wildcards.model):
        needed["reductions"] = [f"results/reduction/body{n}.h5" for n in BODIES]
    if names_mod.needs_load_ranking(wildcards.model):
        needed["load_ranking"] = f"results/reduction/load/{wildcards.scene}.h5"
    if names_mod.needs_basis_stage(wildcards.model):
        needed["cb"] = [f"results/reduction/cb/body{n}.h5" for n in RINGS]
    return needed


def ranking_options(wildcards, input):
    """The reduction and load-ranking files of a model, as options of gimbal_reduction.reduction.models."""
    options = []
    if "reductions" in input.keys():
        options.append("--reductions " + " ".join(input.reductions))
    if "load_ranking" in input.keys():
        options.append(f"--load-ranking {input.load_ranking}")
    if "cb" in input.keys():
        options.append("--cb-bases " + " ".join(input.cb))
    return " ".join(options)


def scene_elastic_bodies(wildcards):
    """What a reduced model reads from its scene: the elastic bodies (needs.bodies)."""
    return list(dag_scene(wildcards.scene).elastic_bodies)


# dynamics.smk
# The compiled kernels' record (made by the kernels job) is an input of every job that simulates, as ancient(),
# so it orders them after the one compilation and its date never reruns them.  The scenes it
# compiles on: undamped and damped (the damped paths).
KERNELS = "results/verification/kernels.json"
WARMUP_SCENES = ("thesis", "damped")


def scene_physics_hash(wildcards):
    return dag_scene(wildcards.scene).config_hash()


def model_file(wildcards):
    """A simulation's reduced-model file, once its scene and model name are checked (one line)."""
    dag_scene(wildcards.scene)
    checked_model(
        wildcards.model, f"results/sim/{wildcards.scene}/{wildcards.model}.h5"
    )
    return f"results/models/{wildcards.scene}/{wildcards.model}.h5"


def integrator_options(wildcards):
    """The command-line options of the configured integrator (simulation.tolerance is the
    exponential integrator's, or the scene's exponential_tolerance where it is tighter: a
    scene states the accuracy it needs; rk4 runs at its default, half its stability limit).
    """
    if cfgmod.value(config, "simulation.integrator") == "exponential":
        tol = cfgmod.value(config, "simulation.tolerance")
        scene = wildcards.get("scene") if hasattr(wildcards, "get") else None
        return f"--tol {(dag_scene(scene).tighter_tolerance(tol) if scene else tol)!r}"
    return ""


def scene_simulations(scene):
    """The simulations a scene's results use (its needs.models), each name checked (one line)."""
    models = dag_scene(scene).models
    for m in models:
        checked_model(m, f"{scene_path(scene)}: needs.models")
    return [f"results/sim/{scene}/{m}.h5" for m in models]


# bench.smk
def reference_arguments(wildcards, input):
    """--reference SCENE=FILE of every reference file (the scene is the file's folder)."""
    files = list(input.references) + list(input.long_reference)
    return " ".join(f"'{os.path.basename(os.path.dirname(f))}={f}'" for f in files)


def scene_file_arguments(files):
    """SCENE=FILE of each file of a folder named after its scene (results/.../{scene}/truth.h5)."""
    return " ".join(f"'{os.path.basename(os.path.dirname(f))}={f}'" for f in files)


# results.smk
def study_sims(scene):
    return expand(
        "results/study/{scene}/sim/{model}.h5", scene=scene, model=SCENE_MODELS
    )


def all_version(path):
    """`all`'s version of a check's file (results/all/ and its path below results/)."""
    return os.path.join("results", "all", os.path.relpath(path, "results"))


def shown_version(path):
    """What a report shows of a check: its extended version (`verify`, `bench`) where made, else `all`'s."""
    return path if os.path.exists(path) else all_version(path)


def extended_report_inputs(wildcards):
    """The extended versions made so far: inputs of the reports, so that a new one reruns them."""
    return [
        p
        for p in [*REPORT_OPTIONAL.values(), *REPORT_BENCH_FIGURES]
        if os.path.exists(p)
    ]


def optional_report_inputs(wildcards):
    return " ".join(
        f"--{k.replace('_', '-')} {shown_version(v)}"
        for k, v in REPORT_OPTIONAL.items()
    )


def report_bench_figures(wildcards):
    return " ".join(shown_version(p) for p in REPORT_BENCH_FIGURES)


# outputs.smk
def checked_model_file(target):
    """An input function: the reduced-model file of the wildcards scene and model, once both are
    checked (a bad name stops the DAG build in one line naming ``target``, filled with them).
    """

    def model_input(wildcards):
        dag_scene(wildcards.scene)
        checked_model(
            wildcards.model, target.format(scene=wildcards.scene, model=wildcards.model)
        )
        return f"results/models/{wildcards.scene}/{wildcards.model}.h5"

    return model_input


# ---- Cluster resources: every rule that runs a job states mem_mb and runtime from its
# measured benchmark records (results/benchmarks/rules/*.tsv: max_rss [MB], s), with a margin: memory
# 1.5 x the largest peak + 200 MB (at least 500 MB), runtime 2 x the longest run (at least 5 min). The
# largest record and its file are quoted beside each rule; a rule without records says so and where
# its estimate comes from.
def mem_mb(peak_mb):
    """Memory to request [MB] for a measured peak resident size [MB]."""
    return max(500, int(-(-(1.5 * peak_mb + 200) // 100) * 100))


def runtime_min(seconds):
    """Wall time to request [min] for a measured run time [s]."""
    return max(5, int(-(-2 * seconds // 60)))


# ---- Timing jobs run alone. A rule whose stage reports medians of repeated runs in one process
# takes every core of the run, threads: TIMING_CORES (= --cores): every other job takes at least one,
# so Snakemake's scheduler starts none beside it, and the timed runs are not measured against the
# workflow's own load. BLAS stays pinned to one thread in their shell commands (Snakemake sets
# OPENBLAS_NUM_THREADS to a job's threads). On a cluster (--executor slurm: no --cores, every job on
# its own allocation) the cores are not the limit; there the job asks for a node of its own
# (TIMING_RESOURCES, slurm's --exclusive), so nothing else runs on its node.
try:
    TIMING_CORES = workflow.cores  # a WorkflowError without --cores (a cluster run)
except Exception:  # snakemake.exceptions.WorkflowError
    TIMING_CORES = 1
TIMING_RESOURCES = {"slurm_extra": "'--exclusive'"}
# `all`'s timing jobs: the 5 runs of a case within this [s]; a slower case is timed over a prefix of
# its scene and scaled by its steps, or (the exponential integrator, whose steps differ in cost) runs
# whole as often as fits, at least once (gimbal_reduction/results/bench/timing.py)
ALL_CASE_BUDGET_S = 0.5


localrules:
    mesh,
    modes,
    reduction,
    mode_shapes,
    modes_benchmark,
    scene,
    error_tables,
    findings,
    report_scene,
    study_report,
    study,
    report,
    verify_fe,
    verify_fe_fast,
    dynamics,
    bench,
    verify,
    all,
