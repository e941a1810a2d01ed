"""Rerun precision: each rule's rerun triggers are derived, not hand-kept.

The workflow is loaded in-process (Snakemake's API) and its rules' params are evaluated:

* ``params.code`` is the hash of the code the rule's stage runs (``python -m X`` and what X
  imports, gimbal_reduction/workflow/imports.py), so editing gimbal_reduction/reduction/report.py reruns no simulation;
* ``params.cfg`` is the hash of the config values the stage reads. Every leaf of
  config/config.yaml is changed in turn, and exactly the rules whose stages read it must see
  their hash change (the body rules through gimbal_reduction.workflow.config.body_inputs, which the mesh and
  modal stages read their parameters through; the stages that check their body files against the
  configuration, through the body files' config hashes).
"""
import copy
import re
from pathlib import Path

import pytest
from snakemake.api import SnakemakeApi
from snakemake.iocontainers import Wildcards  # Snakemake 9 moved it out of snakemake.io
from snakemake.settings.types import ConfigSettings, OutputSettings, ResourceSettings

from gimbal_reduction import commands
from gimbal_reduction.workflow import config as cfgmod
from gimbal_reduction.workflow import imports

ROOT = Path(__file__).resolve().parents[2]
BODIES = (2, 3, 4, 5)
NAMES = dict(zip(BODIES, cfgmod.BODY_NAMES))
# rules whose params.cfg hashes the whole config (they record or print all of it)
WHOLE_CONFIG = {"verify_fe", "verify_fe_fast", "verify_fe_all", "report_scene", "model_report"}
# rules whose stage checks the body files it reads (directly, or through the reduction, ranking and
# reduced-model files made from them) against the configuration (--config {CONFIG},
# gimbal_reduction/solver/bodyconfig.py): params.cfg is what it compares them with, every body file's config hash
BODY_CHECKERS = {"reduction_report", "reduction_benchmark", "load_ranking", "load_ranking_first", "study_scene_first", "reduced_model", "plain_models", "simulate", "study_scene", "truth_basis", "runtime",
                 "reference_simulation", "dynamics_verification", "stability", "pareto", "selection",
                 "exponential_bench", "exponential_accuracy", "integrator_tables", "control_export",
                 "simulate_modal", "reference_exponential", "exponential_accuracy_all", "exponential_bench_all",
                 "pareto_all", "stability_all", "selection_all", "integrator_tables_all",
                 "dynamics_verification_all", "pareto_errors_all"}
# ... and those that check one body's files (params.cfg = that body file's config hash)
PER_BODY_CHECKERS = ("reduction_body", "cb_stage", "mode_shapes_body")
# a stage the rule runs besides its shell's python -m modules
EXTRA_CODE = {"verify_mpi": ("gimbal_reduction.solver.fe.modes",)}   # gimbal_reduction.solver.fe.verify mpi runs gimbal_reduction.solver.fe.modes under mpirun


@pytest.fixture(scope="module")
def workflow():
    with SnakemakeApi(OutputSettings(quiet=True)) as api:
        api_workflow = api.workflow(resource_settings=ResourceSettings(cores=1), config_settings=ConfigSettings(),
                                    snakefile=ROOT / "Snakefile", workdir=ROOT)
        yield api_workflow._workflow


def stage_modules(rule):
    """The modules of the `gimbal` stages a rule's shell command runs."""
    return sorted({commands.module_of(stage) for stage in re.findall(r"\{GIMBAL\} ([\w-]+)", rule.shellcmd or "")})


def test_every_stage_rule_carries_the_hash_of_its_code(workflow):
    checked = set()
    for rule in workflow.rules:
        modules = stage_modules(rule)
        if not modules:
            continue
        assert "code" in rule.params.keys(), f"rule {rule.name} runs {modules} but has no params.code"
        assert rule.params.code == imports.code_hash(*modules, *EXTRA_CODE.get(rule.name, ())), rule.name
        # no code file is an input any more (an mtime trigger would rerun on a comment)
        code_inputs = [f for f in rule.input if str(f).endswith(".py")]
        assert not code_inputs, (rule.name, code_inputs)
        checked.add(rule.name)
    assert {"mesh_body", "modes_body", "reduced_model", "simulate", "reduction_body", "report_scene", "study_scene", "study_report", "verify_mpi"} <= checked


def test_simulation_code_is_what_the_dynamics_imports(workflow):
    """Editing gimbal_reduction/reduction/report.py or the FE stage must not rerun simulations."""
    simulate = workflow.get_rule("simulate")
    modules = stage_modules(simulate)
    assert modules == ["gimbal_reduction.solver.dynamics.simulate"]
    files = imports.files(*modules)
    assert "gimbal_reduction/reduction/report.py" not in files
    assert not [f for f in files if f.startswith(("gimbal_reduction/solver/fe/", "gimbal_reduction/geometry/"))], files
    # the FE verification's code is not the modal stage's: editing a check reruns no modal solution
    assert "gimbal_reduction/solver/fe/checks.py" in imports.files("gimbal_reduction.solver.fe.verify")
    assert "gimbal_reduction/solver/fe/checks.py" not in imports.files("gimbal_reduction.solver.fe.modes")


def test_every_rule_reading_the_config_carries_its_hash(workflow):
    for rule in workflow.rules:
        if "{CONFIG}" in (rule.shellcmd or ""):
            assert "cfg" in rule.params.keys(), f"rule {rule.name} reads the config but has no params.cfg"


def rule_instances(workflow):
    """(label, rule, wildcards) of every job whose params.cfg hashes config values."""
    checks = workflow.globals["GLOBAL_CHECKS"]
    out = []
    for rule in workflow.rules:
        if "cfg" not in rule.params.keys():
            continue
        if "n" in rule.wildcard_names:
            out += [(f"{rule.name}[{n}]", rule, {"n": str(n)}) for n in BODIES]
        elif "check" in rule.wildcard_names:
            out += [(f"{rule.name}[{c}]", rule, {"check": c}) for c in checks]
        else:
            out.append((rule.name, rule, {}))
    return out


def hashes(instances):
    return {label: rule.params.cfg(Wildcards(fromdict=wildcards)) for label, rule, wildcards in instances}


def leaves(node, path=()):
    if isinstance(node, dict):
        for key, child in node.items():
            yield from leaves(child, path + (key,))
    else:
        yield path


def changed_value(path, value):
    if path[-2:] == ("motor_side", "value"):
        return -value
    if isinstance(value, bool):
        return not value
    if isinstance(value, int):
        return value + 1
    if isinstance(value, float):
        return value * 1.5 + 0.25
    return value + "_changed"


# ----------------------------------------------------------------------------------- the spec
# Who reads what, from the stages' code (gimbal_reduction/geometry/mesh.py, gimbal_reduction/solver/fe/modes.py, gimbal_reduction/solver/fe/checks.py).

def full(n):
    """Readers of a body's resolved inputs beyond its mesh (gimbal_reduction.workflow.config.body_inputs(n))."""
    out = {f"modes_body[{n}]", f"modes_body_large[{n}]"} | convergence(n)
    if n == 4:   # the coarse body of the Hughes identities: body 4 at COARSE_SIZE (0.75 in); the
        out |= {"coarse_body_all_modes"}      # check itself reads only that file (its input)
    if n == 2:   # the connection study and the MPI check use body 2
        out |= {"verify_check[connection]", "verify_mpi"}
    return out


def convergence(n):
    """The convergence checks of a body: `verify`'s and `all`'s (coarser levels)."""
    return {f"verify_convergence[{n}]", f"verify_convergence_all[{n}]"}


def mesh_part(n):
    """Readers of the part of body_inputs(n) that shapes the mesh (all but the size)."""
    out = full(n) | {f"mesh_body[{n}]"}
    if n == 4:
        out.add("coarse_mesh")
    if n == 5:   # the platform check meshes the platform as the stage does
        out.add("verify_check[platform]")
    return out


def mesh_size(n):
    """Readers of the body's configured mesh size (the coarse rules use COARSE_SIZE instead)."""
    return mesh_part(n) - {"coarse_mesh", "coarse_body_all_modes"}


RINGS = (2, 3, 4)
# the solid ring: `verify`'s and `all`'s (a coarser solid)
SOLID_RING = {"verify_check[solid-ring]", "verify_solid_ring_all"}
RING_CHECKS = {"verify_check[ring]"} | SOLID_RING   # bare ring of body 2 (shell and solid)
ALL = BODIES


def union(function, bodies):
    return set().union(*(function(n) for n in bodies))


# Leaves no stage reads (only the whole-config records see them), with the reason.
UNREAD = {
    "unit": "units are documentation: the stages compute in inch, lbf, s and read values only",
    "source": "sources are provenance, printed by the report, read by no stage",
    "number": "validation pins each body's number; the stages take the number from the rule's wildcard",
}


def expected_readers(path):
    """The rule instances whose params.cfg must change when the leaf at ``path`` changes."""
    if path[-1] in UNREAD:
        return set()
    section, rest = path[0], path[1:]
    key = rest[-2] if rest[-1] == "value" else rest[-1]
    if section == "bodies":
        n = cfgmod.BODY_NUMBERS[rest[0]]
        ring = n in RINGS
        if key in ("diameter", "width"):
            return mesh_part(n) | (RING_CHECKS if n == 2 else set())
        if key == "thickness":
            return (full(n) | (RING_CHECKS if n == 2 else set())) if ring else mesh_part(n)
        if key == "hole_diameter":
            return mesh_part(n)
        if key in ("outer_bearing_distance", "inner_bearing_distance"):
            return full(n)
        if key == "motor_side":
            # the previous body's output bearings sit at this body's motor side (body_inputs(n - 1))
            return mesh_part(n) | (mesh_part(n - 1) if n > 2 else set())
        if key == "shape":   # a ring's shape also decides its model (shell)
            return mesh_part(n) | (RING_CHECKS if n == 2 else set())
        if key == "model":
            return full(n) | {"verify_check[platform]"}
    if section == "material":
        return union(full, ALL) | RING_CHECKS | {"verify_check[platform]"}
    if section == "eccentric_mass":
        if key == "mass_fraction":
            return union(full, ALL)
        if key == "angle":
            return union(mesh_part, ALL)
        if key == "platform_patch_half_angle":
            return mesh_part(5)
    if section == "bearing_connection":
        if key == "platform_patch_half_angle":
            return mesh_part(5)
        if key == "rotation_weight_length":
            return union(full, ALL)
    if section == "shell":
        return union(full, RINGS) | RING_CHECKS | {"verify_check[plate]", "verify_check[platform]"}
    if section == "solid":
        return full(5) | SOLID_RING | {"verify_check[platform]"}
    if section == "mesh":
        if key == "ring_size":
            return union(mesh_size, RINGS) | RING_CHECKS
        if key == "platform_size":
            return mesh_size(5)
        if key == "refinement_ratio":
            return union(convergence, ALL) | {"verify_check[connection]"}
    if section == "modes":
        # modes_body_large (200 modes, the truth's larger basis) hashes the body's inputs too
        count = {f"modes_body[{n}]" for n in ALL} | {"coarse_body_all_modes"} | \
            {f"modes_body_large[{n}]" for n in ALL}
        if key == "count":      # the convergence check reports every study mode's deviation
            return count | union(convergence, ALL)
        return count | union(convergence, ALL) | {"verify_mpi"}
    if section == "verification":
        if key == "convergence_modes":
            return union(convergence, ALL)
        return {f"verify_body[{n}]" for n in ALL}
    if section == "simulation":
        # read by the simulate rule only (its params integrator and options, one instance per
        # scene and model, not enumerated here: tests/workflow checks them in the dry run)
        return set()
    raise AssertionError(f"config leaf {'.'.join(path)} is not in the test's spec: add it")


def checkers(readers):
    """The checking rules whose params.cfg changes with the readers': those of a body whose modal
    stage's hash (the body file's config hash) changes."""
    bodies = [n for n in BODIES if f"modes_body[{n}]" in readers]
    return (BODY_CHECKERS if bodies else set()) | {f"{r}[{n}]" for r in PER_BODY_CHECKERS for n in bodies}


def test_each_config_leaf_reruns_exactly_its_readers(workflow):
    config = workflow.globals["config"]
    instances = rule_instances(workflow)
    per_body = {f"{rule}[{n}]" for rule in ("mesh_body", "modes_body", "verify_convergence",
                                            "verify_convergence_all", "verify_body",
                                            "modes_body_large", *PER_BODY_CHECKERS) for n in BODIES}
    per_check = {f"verify_check[{c}]" for c in workflow.globals["GLOBAL_CHECKS"]}
    assert {label for label, _, _ in instances} == (per_body | per_check | WHOLE_CONFIG | BODY_CHECKERS
                                                     | {"verify_mpi", "coarse_mesh", "coarse_body_all_modes",
                                                        "verify_solid_ring_all"})
    before = hashes(instances)
    pristine = copy.deepcopy(config)
    seen = 0
    try:
        for path in leaves(pristine):
            node = config
            for key in path[:-1]:
                node = node[key]
            original = node[path[-1]]
            node[path[-1]] = changed_value(path, original)
            after = hashes(instances)
            node[path[-1]] = original
            changed = {label for label in before if after[label] != before[label]}
            readers = expected_readers(path)
            expected = readers | checkers(readers) | WHOLE_CONFIG
            assert changed == expected, (".".join(path), sorted(changed - expected), sorted(expected - changed))
            seen += 1
    finally:
        config.clear()
        config.update(pristine)
    assert hashes(instances) == before
    assert seen > 100


def test_next_bodys_motor_side_changes_the_body_hashes(workflow):
    """Body 3's motor side places body 2's output bearings: body 2's mesh and modes must rerun."""
    config = workflow.globals["config"]
    mesh, modes = workflow.get_rule("mesh_body"), workflow.get_rule("modes_body")
    body2 = Wildcards(fromdict={"n": "2"})
    before = mesh.params.cfg(body2), modes.params.cfg(body2)
    regions = cfgmod.body_inputs(config, 2)["mesh"]["body"]["output_motor_side"]
    side = config["bodies"]["middle_gimbal"]["motor_side"]
    side["value"] = -side["value"]
    try:
        assert cfgmod.body_inputs(config, 2)["mesh"]["body"]["output_motor_side"] == -regions
        assert mesh.params.cfg(body2) != before[0] and modes.params.cfg(body2) != before[1]
    finally:
        side["value"] = -side["value"]


def test_modes_rule_hash_is_the_body_files_config_hash(workflow, config):
    """The modal stage writes cfgmod.inputs_hash(body_inputs) into the body file: the same value
    as its rule's trigger, so a body file names the inputs it was made from."""
    modes = workflow.get_rule("modes_body")
    for n in BODIES:
        assert modes.params.cfg(Wildcards(fromdict={"n": str(n)})) == cfgmod.inputs_hash(cfgmod.body_inputs(config, n))


def test_the_longest_scenes_chain_has_the_priority(workflow):
    """The scene with the longest duration (`long`) is made by the *_first copies of load_ranking and
    study_scene, whose priority is higher, and only that scene (results.smk, FIRST_SCENE)."""
    scenes = workflow.globals["STUDY_SCENES"]
    durations = {s: workflow.globals["dag_scene"](s).duration for s in scenes}
    assert workflow.globals["FIRST_SCENE"] == max(durations, key=durations.get) == "long"
    for name in ("load_ranking", "study_scene"):
        general, first = workflow.get_rule(name), workflow.get_rule(f"{name}_first")
        assert first.priority > general.priority
        assert first.wildcard_constraints == {"scene": "long"}
        # both could make long's files: the ruleorder picks the first copy (compare > 0: preferred)
        output = "results/reduction/load/long.h5" if name == "load_ranking" else "results/study/long/sim/truth.h5"
        assert first.is_producer(output) and general.is_producer(output)
        assert workflow._ruleorder.compare(first, general) > 0
        assert not first.is_producer(output.replace("long", "thesis"))
