"""The import graph (workflow.imports): a stage's code is what its module imports, and its hash
ignores comments and docstrings but not code."""
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from workflow import imports

ROOT = Path(__file__).resolve().parents[2]


def loaded_project_modules(entry):
    """The project modules that importing ``entry`` really loads (in a fresh interpreter)."""
    code = (f"import importlib, json, sys; importlib.import_module({entry!r}); "
            f"print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in {imports.PACKAGES!r})))")
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    return set(json.loads(run.stdout.strip().splitlines()[-1]))


@pytest.mark.parametrize("entry", ["geometry.mesh", "solver.fe.modes", "solver.fe.verify", "reduction.stage"])
def test_closure_is_what_python_loads(entry):
    """The ast closure of a stage equals the project modules Python loads when it imports the
    stage (so nothing is imported in a way the graph cannot see)."""
    assert set(imports.closure(entry)) == loaded_project_modules(entry)


def test_simulation_code_holds_no_fe_nor_reduction_report():
    files = imports.files("solver.dynamics.simulate")
    assert "solver/dynamics/simulate.py" in files and "solver/bodydata.py" in files
    assert "reduction/report.py" not in files
    assert not [f for f in files if f.startswith(("solver/fe/", "reduction/", "results/", "geometry/"))], files


def test_stage_code_sets():
    mesh = imports.files("geometry.mesh")
    assert {"geometry/mesh.py", "geometry/gimbal.py", "workflow/config.py",
            "workflow/schemas/config.schema.yaml"} <= set(mesh)
    assert not [f for f in mesh if f.startswith(("solver/", "reduction/", "results/"))], mesh
    modes = imports.files("solver.fe.modes")
    assert {"solver/fe/forms.py", "solver/fe/bearings.py", "solver/fe/eigen.py", "solver/bodydata.py",
            "geometry/gimbal.py"} <= set(modes)
    assert not [f for f in modes if f.startswith(("solver/dynamics/", "reduction/", "results/"))], modes
    # the reduction stage does not run the load-aware ranking, nor the report
    stage = imports.files("reduction.stage")
    assert "reduction/load_aware.py" not in stage and "reduction/report.py" not in stage


@pytest.fixture
def tree(tmp_path):
    """A copy of the project's packages, to edit."""
    for package in imports.PACKAGES:
        shutil.copytree(ROOT / package, tmp_path / package,
                        ignore=lambda folder, names: [n for n in names if not (n.endswith((".py", ".yaml"))
                                                                               or (Path(folder) / n).is_dir())
                                                      or n == "__pycache__"])
    return tmp_path


def test_hash_ignores_comments_and_docstrings_but_not_code(tree):
    before = imports.code_hash("geometry.mesh", root=tree)
    path = tree / "geometry" / "gimbal.py"
    source = path.read_text()
    path.write_text("# a new comment\n" + source.replace('"""Gmsh geometry', '"""Edited docstring. Gmsh geometry', 1)
                    .replace("    gmsh.initialize()\n", "    gmsh.initialize()  # start gmsh\n\n", 1))
    imports.module_files.cache_clear()
    imports.all_imports.cache_clear()
    assert imports.code_hash("geometry.mesh", root=tree) == before
    # the modal stage imports gimbal too; the reduction stage does not
    unrelated = imports.code_hash("reduction.stage", root=tree)
    path.write_text(source.replace("Mesh.Algorithm\", 6", "Mesh.Algorithm\", 5", 1))
    assert imports.code_hash("geometry.mesh", root=tree) != before
    assert imports.code_hash("reduction.stage", root=tree) == unrelated
    # the config schema is data that workflow.config reads: part of the code of every stage importing it
    schema = tree / "workflow" / "schemas" / "config.schema.yaml"
    changed = imports.code_hash("geometry.mesh", root=tree)
    schema.write_text(schema.read_text() + "\n# edited\n")
    assert imports.code_hash("geometry.mesh", root=tree) != changed


def test_violations_are_found(tmp_path):
    """An upward import, a function-local project import, an import between the engines and a cycle."""
    for package in ("workflow", "geometry", "solver", "solver/fe", "solver/dynamics", "reduction", "results"):
        (tmp_path / package).mkdir(parents=True, exist_ok=True)
        (tmp_path / package / "__init__.py").write_text("")
    (tmp_path / "geometry" / "a.py").write_text("from reduction import b\n")
    (tmp_path / "reduction" / "b.py").write_text("def f():\n    from geometry import a\n")
    (tmp_path / "solver" / "fe" / "c.py").write_text("import solver.dynamics.d\n")
    (tmp_path / "solver" / "dynamics" / "d.py").write_text("from ..bodydata import x\n")
    (tmp_path / "solver" / "bodydata.py").write_text("")
    found = imports.violations(tmp_path)
    assert any("geometry/a.py:1: upward import of reduction.b" in v for v in found), found
    assert any("reduction/b.py:2: function-local import of geometry.a" in v for v in found), found
    assert any("solver/fe/c.py:1: solver.fe.c imports solver.dynamics.d" in v for v in found), found
    assert "import cycle: geometry.a -> reduction.b" in found, found
    # relative imports resolve; the package __init__ files are part of a closure
    assert imports.closure("solver.dynamics.d", root=tmp_path) == [
        "solver", "solver.bodydata", "solver.dynamics", "solver.dynamics.d"]
