"""Bad model and scene names reaching the workflow (a Snakemake target, or a scene's needs.models):
refused when the DAG is built, before any mesh or modal solve, in one line naming the culprit, and
nothing written (workflow/rules/common.smk: dag_scene, checked_model; gimbal_reduction.reduction.models.check_name).

Each case is a real run (not a dry run) of the tiny test configuration (.test: 12 modes per body)
with --directory on a private copy; Snakemake's own progress lines ("Building DAG of jobs...",
"Assuming unrestricted shared filesystem usage.", and Snakemake 9's run header: "SNAKEMAKE",
"=========" and its "  Key: value" lines, where Snakemake 8 printed "host: ...") are the only other
output."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
SNAKEMAKE_PROGRESS = ("host: ", "Building DAG of jobs", "Assuming unrestricted shared filesystem usage")
# Snakemake 9's header of a run (snakemake.logging: format_workflow_started), printed before the DAG
HEADER_KEYS = ("Date", "Workflow ID", "Platform", "Host", "User", "Snakemake version", "Python version",
               "Command", "Snakefile", "Base directory", "Run directory", "Working directory",
               "Config file(s)", "Config MD5")


# Snakemake's note that it reads the workflow's own profile (profiles/default), on every run
PROFILE_NOTE = "Using workflow specific profile "


def snakemake_own(line):
    """Whether ``line`` is Snakemake's own progress or run-header output (not the workflow's)."""
    return (line.startswith(SNAKEMAKE_PROGRESS) or line in ("SNAKEMAKE", "=========")
            or line.startswith(PROFILE_NOTE) or any(line.startswith(f"  {key}: ") for key in HEADER_KEYS))

CASES = {
    "unknown model as a simulation target": (
        "results/sim/short/nonsense-3.h5",
        ("results/sim/short/nonsense-3.h5", "unknown model 'nonsense-3'", "gimbal_reduction/reduction/models.py")),
    "unknown model as a reduced-model target": (
        "results/models/short/freq-x.h5",
        ("results/models/short/freq-x.h5", "unknown model 'freq-x'")),
    "more modes than the configuration computes": (
        "results/sim/short/freq-13.h5",
        ("results/sim/short/freq-13.h5", "13 modes", "modes.count = 12")),
    "the truth on 12 modes per body": (
        "results/sim/short/truth.h5", ("results/sim/short/truth.h5", "100 modes", "modes.count = 12")),
    "static mode on a missing bearing": (
        "results/sim/short/static-2@5:output_motor_fz.h5",
        ("static-2@5:output_motor_fz", "no output bearings")),
    "malformed tolerance": ("results/sim/short/tol-x.h5", ("tol-x", "tol-EPS")),
    "unknown model in a scene's needs": (
        "results/sim/badneeds/needs.done",
        ("config/scenes/badneeds.yaml: needs.models", "unknown model 'nonsense-3'")),
    "unknown scene": ("results/sim/nosuch/freq-4.h5", ("unknown scene", "nosuch")),
    "scene name with a space": ("results/sim/my scene/freq-4.h5",
                                ("scene name 'my scene' refused", "ASCII letters, digits")),
    "scene name with a non-ASCII letter": ("results/sim/szene_\u00fc/freq-4.h5",
                                           ("scene name 'szene_\u00fc' refused", "ASCII letters, digits")),
    "tolerance below the truth's own error": ("results/sim/short/tol-1e-300.h5",
                                              ("tol-1e-300", "below 1e-08", "the truth's own error")),
    "scene grid not dividing the duration": (
        "results/sim/badgrid/freq-4.h5", ("badgrid.yaml", "output_interval", "divide")),
}


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    """A copy of .test with a scene whose needs.models names a model that does not exist, and one whose
    output interval does not divide its duration."""
    root = tmp_path_factory.mktemp("dag") / "work"
    shutil.copytree(ROOT / ".test", root)
    scene = yaml.safe_load((root / "config" / "scenes" / "short.yaml").read_text())
    scene["name"] = "badneeds"
    scene["needs"]["models"]["value"] = ["freq-4", "nonsense-3"]
    (root / "config" / "scenes" / "badneeds.yaml").write_text(yaml.safe_dump(scene))
    scene["name"] = "badgrid"
    scene["output_interval"]["value"] = 7e-4             # 3 ms is not a whole number of 0.7 ms
    (root / "config" / "scenes" / "badgrid.yaml").write_text(yaml.safe_dump(scene))
    return root


def files(root):
    """Every file under root but Snakemake's own records (.snakemake)."""
    out = set()
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = [d for d in dirnames if d != ".snakemake"]
        out |= {os.path.join(dirpath, f) for f in filenames}
    return out


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_name_refused_when_the_dag_is_built(case, workdir):
    target, words = CASES[case]
    before = files(workdir)
    run = subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--snakefile",
                          str(ROOT / "Snakefile"), "--directory", str(workdir), target],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    lines = [line for line in (run.stdout + run.stderr).splitlines()
             if line.strip() and not snakemake_own(line)]
    assert run.returncode != 0, run.stdout[-2000:]
    assert len(lines) == 1, lines
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert files(workdir) == before                    # nothing written: no log, no result
    assert not (workdir / "results").exists() and not (workdir / "logs").exists()
