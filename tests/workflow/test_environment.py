"""Issue 16: the literal `snakemake` command, and a Snakemake without the project's packages stopping
at once in one line (gimbal_reduction/workflow/environment.py, checked first in workflow/rules/common.smk)."""
import os
import shutil
import subprocess
import sys
from pathlib import Path
import pytest

from gimbal_reduction.workflow import environment
from tests.robustness.test_dag_names import PROFILE_NOTE

ROOT = Path(__file__).resolve().parents[2]
LAUNCHER = ROOT / "workflow" / "envs" / "snakemake-launcher.sh"


def test_the_pinned_snakemake_with_every_package_passes():
    assert environment.problem(environment.pinned("snakemake")) is None


def test_another_snakemake_without_the_packages_gets_one_line_saying_how_to_run_it():
    """E.g. the previous pin (8.20.5) from an old environment, without the project's packages."""
    line = environment.problem("8.20.5", find_spec=lambda module: None)
    assert "\n" not in line
    assert line.startswith("environment error: Snakemake 8.20.5 (the project pins 9.27.1); no numba, typst")
    assert ". .venv/bin/activate" in line and ".venv/bin/python -m snakemake --cores 2 all" in line


def _hide(tmp_path, *modules):
    """A PYTHONPATH whose sitecustomize makes ``modules`` unimportable (as on an interpreter without them)."""
    (tmp_path / "sitecustomize.py").write_text(
        "import sys\n" + "".join(f"sys.modules[{m!r}] = None\n" for m in modules))
    return {**os.environ, "PYTHONPATH": str(tmp_path)}


def test_a_python_without_numba_and_typst_stops_the_dag_build_in_one_line(tmp_path):
    run = subprocess.run([sys.executable, "-m", "snakemake", "--dry-run", "--cores", "2", "all"], cwd=ROOT,
                         env=_hide(tmp_path, "numba", "typst"), capture_output=True, text=True, timeout=120)
    assert run.returncode == 1
    lines = [line for line in (run.stdout + run.stderr).splitlines()   # less Snakemake's profile note
             if line.strip() and not line.startswith(PROFILE_NOTE)]
    assert len(lines) == 1 and lines[0].startswith("environment error: no numba, typst for "), lines


def test_a_missing_numba_is_an_error_not_a_numpy_fallback(tmp_path):
    code = "import gimbal_reduction.solver.dynamics.problem"
    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=_hide(tmp_path, "numba"),
                         capture_output=True, text=True, timeout=120)
    assert run.returncode != 0 and "ModuleNotFoundError" in run.stderr, run.stderr[-500:]


def test_the_launcher_runs_the_projects_snakemake(tmp_path):
    """`snakemake` on PATH (what install.sh puts in /usr/local/bin) runs .venv's pinned Snakemake in
    the project (and in any folder below it); outside a project, with no other snakemake, one line."""
    bindir = tmp_path / "bin"
    bindir.mkdir()
    shutil.copy(LAUNCHER, bindir / "snakemake")
    env = {**os.environ, "PATH": f"{bindir}:/usr/bin:/bin"}
    for cwd in (ROOT, ROOT / "docs"):
        run = subprocess.run(["snakemake", "--version"], cwd=cwd, env=env, capture_output=True, text=True,
                             timeout=120)
        assert run.returncode == 0 and run.stdout.strip() == environment.pinned("snakemake"), run.stderr
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    run = subprocess.run(["snakemake", "--version"], cwd=outside, env=env, capture_output=True, text=True,
                         timeout=60)
    assert run.returncode == 127 and len(run.stderr.strip().splitlines()) == 1, run.stderr


def test_the_slurm_executor_is_on_the_path_of_cluster_runs_only(tmp_path):
    """Snakemake imports every installed executor plugin when it starts, and the Slurm one imports
    pandas: it lives in .venv/cluster (workflow/envs/cluster-requirements.txt), which the launcher
    puts on the path when an argument names slurm, and only then."""
    python = ROOT / ".venv" / "bin" / "python"
    if not (ROOT / ".venv" / "cluster").is_dir():
        pytest.skip("no .venv/cluster (make install)")
    plain = subprocess.run([str(python), "-c", "import snakemake_executor_plugin_slurm"], capture_output=True,
                           text=True, env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"}, timeout=60)
    assert plain.returncode != 0 and "No module named 'snakemake_executor_plugin_slurm'" in plain.stderr
    bindir = tmp_path / "bin"
    bindir.mkdir()
    shutil.copy(LAUNCHER, bindir / "snakemake")
    env = {**{k: v for k, v in os.environ.items() if k != "PYTHONPATH"}, "PATH": f"{bindir}:/usr/bin:/bin"}
    run = subprocess.run(["snakemake", "--executor", "slurm", "--help"], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0 and "--slurm-" in run.stdout, run.stderr[-2000:]
