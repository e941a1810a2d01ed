"""The project as a package: `pip install .` gives every module, the schema and the `gimbal`
command, importable from anywhere; the command knows every stage the workflow runs."""
import importlib
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from gimbal_reduction import commands

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    out = tmp_path_factory.mktemp("wheel")
    run = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                          "--disable-pip-version-check", "-q", "-w", str(out), str(ROOT)],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    (path,) = out.glob("gimbal_reduction-*.whl")
    return path


def test_the_wheel_holds_every_module_the_schema_and_the_command(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    tree = {str(p.relative_to(ROOT)) for p in (ROOT / "gimbal_reduction").rglob("*.py")
            if "__pycache__" not in p.parts}
    assert tree and tree <= names, sorted(tree - names)
    assert "gimbal_reduction/workflow/config.schema.yaml" in names
    (entry_points,) = [n for n in names if n.endswith(".dist-info/entry_points.txt")]
    assert "gimbal = gimbal_reduction.commands:main" in zipfile.ZipFile(wheel).read(entry_points).decode()


def test_the_installed_package_imports_outside_the_checkout(wheel, tmp_path):
    target = tmp_path / "site"
    run = subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--disable-pip-version-check",
                          "-q", "--target", str(target), str(wheel)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    code = ("import gimbal_reduction, gimbal_reduction.api, gimbal_reduction.commands as c;"
            "from gimbal_reduction.workflow import config;"
            "print(gimbal_reduction.__file__); print(config.SCHEMA.is_file()); print(len(c.STAGES))")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    run = subprocess.run([sys.executable, "-c", code], cwd=elsewhere, capture_output=True, text=True,
                         timeout=300, env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin",
                                           "HOME": str(tmp_path)})
    assert run.returncode == 0, run.stderr[-2000:]
    where, schema, stages = run.stdout.split()
    assert where.startswith(str(target)) and schema == "True" and int(stages) == len(commands.STAGES)


@pytest.mark.parametrize("stage", sorted(commands.STAGES))
def test_every_stage_has_a_main(stage):
    assert callable(importlib.import_module(commands.module_of(stage)).main)


def test_the_command_lists_the_stages_and_refuses_an_unknown_one(capsys):
    assert commands.main([]) == 2
    listing = capsys.readouterr().out
    assert all(f"  {name} " in listing for name in commands.STAGES)
    assert commands.main(["mesj"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("gimbal: no stage 'mesj'")


def test_gimbal_runs_its_stages_single_threaded_unless_told_otherwise():
    """The answer never depends on the thread count: `gimbal` pins the BLAS and OpenMP pools to
    one thread before the stage loads them, as the workflow's rules do; a value the caller set wins."""
    import subprocess
    import sys
    from gimbal_reduction import commands
    env = {"OPENBLAS_NUM_THREADS": "4"}
    commands.single_threaded(env)
    assert env == {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "4", "MKL_NUM_THREADS": "1"}
    clean = {k: v for k, v in __import__("os").environ.items() if k not in commands.SINGLE_THREADED}
    code = ("import sys, os; from gimbal_reduction import commands; commands.STAGES['env'] = ('workflow.cli', '');"
            "import gimbal_reduction.workflow.cli as c; c.main = lambda argv: print(os.environ['OMP_NUM_THREADS']);"
            "commands.main(['env'])")
    out = subprocess.run([sys.executable, "-c", code], env=clean, capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "1", out.stderr
