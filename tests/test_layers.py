"""The package layering, read from the source (gimbal_reduction.workflow.imports builds the import graph with ast).

Imports point only downward:

    workflow  <  geometry  <  gimbal_reduction.solver.bodydata  <  gimbal_reduction.solver.fe, gimbal_reduction.solver.dynamics  <  reduction  <  gimbal_reduction.results.study, gimbal_reduction.results.bench

gimbal_reduction.solver.fe and gimbal_reduction.solver.dynamics never import each other; no two files import each other, directly or
through others; and no project module is imported inside a function (optional heavy third-party
packages such as jax, matplotlib or typst may be, each with a comment saying why).
"""
from gimbal_reduction.workflow import imports


def _lines(found):
    return "\n".join(found)


def test_no_import_cycle_between_files():
    found = [f"import cycle: {' -> '.join(c)}" for c in imports.cycles()]
    assert not found, _lines(found)


def test_imports_point_only_downward():
    found = [v for v in imports.violations() if "upward import" in v or "never import each other" in v]
    assert not found, _lines(found)


def test_no_function_local_project_imports():
    found = [v for v in imports.violations() if "function-local import" in v]
    assert not found, _lines(found)


def test_every_project_module_has_a_layer():
    for module in imports.module_files():
        imports.layer(module)  # raises if a module lies outside LAYERS
