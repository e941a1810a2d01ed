"""The import graph (gimbal_reduction.workflow.imports): a stage's code is what its module imports, and its hash
ignores comments and docstrings but not code."""
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from gimbal_reduction.workflow import imports

ROOT = Path(__file__).resolve().parents[2]


def loaded_project_modules(entry):
    """The project modules that importing ``entry`` really loads (in a fresh interpreter)."""
    code = (f"import importlib, json, sys; importlib.import_module({entry!r}); "
            f"print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in {imports.PACKAGES!r})))")
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    return set(json.loads(run.stdout.strip().splitlines()[-1]))


@pytest.mark.parametrize("entry", ["gimbal_reduction.geometry.mesh", "gimbal_reduction.solver.fe.modes", "gimbal_reduction.solver.fe.verify", "gimbal_reduction.reduction.stage"])
def test_closure_is_what_python_loads(entry):
    """The ast closure of a stage equals the project modules Python loads when it imports the
    stage (so nothing is imported in a way the graph cannot see)."""
    assert set(imports.closure(entry)) == loaded_project_modules(entry)


def test_simulation_code_holds_no_fe_nor_reduction_report():
    files = imports.files("gimbal_reduction.solver.dynamics.simulate")
    assert "gimbal_reduction/solver/dynamics/simulate.py" in files and "gimbal_reduction/solver/bodydata.py" in files
    assert "gimbal_reduction/reduction/report.py" not in files
    assert not [f for f in files if f.startswith(("gimbal_reduction/solver/fe/", "gimbal_reduction/reduction/", "gimbal_reduction/results/", "gimbal_reduction/geometry/"))], files


def test_stage_code_sets():
    mesh = imports.files("gimbal_reduction.geometry.mesh")
    assert {"gimbal_reduction/geometry/mesh.py", "gimbal_reduction/geometry/gimbal.py", "gimbal_reduction/workflow/config.py",
            "gimbal_reduction/workflow/config.schema.yaml"} <= set(mesh)
    assert not [f for f in mesh if f.startswith(("gimbal_reduction/solver/", "gimbal_reduction/reduction/", "gimbal_reduction/results/"))], mesh
    modes = imports.files("gimbal_reduction.solver.fe.modes")
    assert {"gimbal_reduction/solver/fe/forms.py", "gimbal_reduction/solver/fe/bearings.py", "gimbal_reduction/solver/fe/eigen.py", "gimbal_reduction/solver/bodydata.py",
            "gimbal_reduction/geometry/gimbal.py"} <= set(modes)
    assert not [f for f in modes if f.startswith(("gimbal_reduction/solver/dynamics/", "gimbal_reduction/reduction/", "gimbal_reduction/results/"))], modes
    # the reduction stage does not run the load-aware ranking, nor the report
    stage = imports.files("gimbal_reduction.reduction.stage")
    assert "gimbal_reduction/reduction/load_aware.py" not in stage and "gimbal_reduction/reduction/report.py" not in stage


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
    before = imports.code_hash("gimbal_reduction.geometry.mesh", root=tree)
    path = tree / "gimbal_reduction" / "geometry" / "gimbal.py"
    source = path.read_text()
    path.write_text("# a new comment\n" + source.replace('"""Gmsh geometry', '"""Edited docstring. Gmsh geometry', 1)
                    .replace("    gmsh.initialize()\n", "    gmsh.initialize()  # start gmsh\n\n", 1))
    imports.module_files.cache_clear()
    imports.all_imports.cache_clear()
    assert imports.code_hash("gimbal_reduction.geometry.mesh", root=tree) == before
    # the modal stage imports gimbal too; the reduction stage does not
    unrelated = imports.code_hash("gimbal_reduction.reduction.stage", root=tree)
    path.write_text(source.replace("Mesh.Algorithm\", 6", "Mesh.Algorithm\", 5", 1))
    assert imports.code_hash("gimbal_reduction.geometry.mesh", root=tree) != before
    assert imports.code_hash("gimbal_reduction.reduction.stage", root=tree) == unrelated
    # the config schema is data that gimbal_reduction.workflow.config reads: part of the code of every stage importing it
    schema = tree / "gimbal_reduction" / "workflow" / "config.schema.yaml"
    changed = imports.code_hash("gimbal_reduction.geometry.mesh", root=tree)
    schema.write_text(schema.read_text() + "\n# edited\n")
    assert imports.code_hash("gimbal_reduction.geometry.mesh", root=tree) != changed


def test_violations_are_found(tmp_path):
    """An upward import, a function-local project import, an import between the engines and a cycle."""
    pkg = tmp_path / "gimbal_reduction"
    for package in ("", "workflow", "geometry", "solver", "solver/fe", "solver/dynamics", "reduction", "results"):
        (pkg / package).mkdir(parents=True, exist_ok=True)
        (pkg / package / "__init__.py").write_text("")
    (pkg / "geometry" / "a.py").write_text("from gimbal_reduction.reduction import b\n")
    (pkg / "reduction" / "b.py").write_text("def f():\n    from gimbal_reduction.geometry import a\n")
    (pkg / "solver" / "fe" / "c.py").write_text("import gimbal_reduction.solver.dynamics.d\n")
    (pkg / "solver" / "dynamics" / "d.py").write_text("from ..bodydata import x\n")
    (pkg / "solver" / "bodydata.py").write_text("")
    found = imports.violations(tmp_path)
    assert any("gimbal_reduction/geometry/a.py:1: upward import of gimbal_reduction.reduction.b" in v
               for v in found), found
    assert any("gimbal_reduction/reduction/b.py:2: function-local import of gimbal_reduction.geometry.a" in v
               for v in found), found
    assert any("gimbal_reduction/solver/fe/c.py:1: gimbal_reduction.solver.fe.c imports "
               "gimbal_reduction.solver.dynamics.d" in v for v in found), found
    assert "import cycle: gimbal_reduction.geometry.a -> gimbal_reduction.reduction.b" in found, found
    # relative imports resolve; the package __init__ files are part of a closure
    assert imports.closure("gimbal_reduction.solver.dynamics.d", root=tmp_path) == [
        "gimbal_reduction", "gimbal_reduction.solver", "gimbal_reduction.solver.bodydata",
        "gimbal_reduction.solver.dynamics", "gimbal_reduction.solver.dynamics.d"]


def test_the_facts_cache_spares_a_rerun_every_parse_and_notices_an_edit(tree, monkeypatch):
    """A fresh process (a new cache object) with the cache file of an earlier one parses nothing
    and gives the same hash; an edited file is parsed again; a corrupt cache file is ignored."""
    entry = "gimbal_reduction.geometry.mesh"
    first = imports.code_hash(entry, root=tree)
    assert (tree / imports.CACHE_FILE).is_file()

    def no_parse(path):
        raise AssertionError(f"parsed {path}")
    monkeypatch.setattr(imports, "_CACHE", imports._FactsCache())
    monkeypatch.setattr(imports, "parse_tree", no_parse)
    imports.module_files.cache_clear()
    imports.all_imports.cache_clear()
    assert imports.code_hash(entry, root=tree) == first
    monkeypatch.undo()
    path = tree / "gimbal_reduction" / "geometry" / "mesh.py"
    path.write_text(path.read_text() + "\nEDITED = 1\n")
    imports.all_imports.cache_clear()
    assert imports.code_hash(entry, root=tree) != first
    (tree / imports.CACHE_FILE).write_text("{not json")
    monkeypatch.setattr(imports, "_CACHE", imports._FactsCache())
    imports.all_imports.cache_clear()
    assert imports.code_hash(entry, root=tree) != first
