"""The pipeline end to end on the tiny test configuration (.test, issue 16), run with --directory on a
copy of it, as CI runs it: coarse meshes, 12 modes per body, a 3 ms scene. ~75 s on 2 cores (meshes,
modal solutions, reductions, four reduced models and simulations, mode shapes, the body-file spectra
and the thin-ring check). The study's error tables are not in it: the study's 51 models need 100 modes
per body and its scenes take minutes (`snakemake --cores 2 all` on the real configuration).
"""
import json
import shutil
import subprocess
import sys
from pathlib import Path

import h5py
import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
BODIES = (2, 3, 4, 5)
TARGETS = ["mesh", "modes", "reduction", "results/sim/short/needs.done", "mode_shapes",
           *[f"results/verification/parts/spectra_body{n}.json" for n in BODIES],
           "results/verification/parts/ring.json"]


def snakemake(workdir, *args, timeout=600):
    return subprocess.run([sys.executable, "-m", "snakemake", "--cores", "2", "--snakefile", str(ROOT / "Snakefile"),
                           "--directory", str(workdir), *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout)


@pytest.fixture(scope="module")
def test_run(tmp_path_factory):
    work = tmp_path_factory.mktemp("pipeline") / "work"
    shutil.copytree(ROOT / ".test", work)
    run = snakemake(work, *TARGETS)
    assert run.returncode == 0, (run.stdout + run.stderr)[-4000:]
    return work


def test_the_test_configuration_runs_end_to_end_with_directory(test_run):
    scene = yaml.safe_load((ROOT / ".test" / "config" / "scenes" / "short.yaml").read_text())
    models = scene["needs"]["models"]["value"]
    for n in BODIES:
        with h5py.File(test_run / f"results/modes/body{n}.h5", "r") as f:
            assert f["eigenvalues"].shape == (12,)   # modes.count of .test/config/config.yaml
        with h5py.File(test_run / f"results/reduction/body{n}.h5", "r") as f:
            # provenance like a body file's (issue 16): versions, git revision, config hash
            assert json.loads(f.attrs["versions"])["git"] and f.attrs["config_hash"]
            assert json.loads(f.attrs["body_versions"])["dolfinx"]
        assert (test_run / f"results/figures/mode_shapes_body{n}.png").is_file()
        assert (test_run / f"logs/modes/body{n}.log").is_file()   # logs in the working directory
    for model in models:
        with h5py.File(test_run / f"results/sim/short/{model}.h5", "r") as f:
            assert f.attrs["scene"] == "short" and f["t"][-1] == pytest.approx(0.003)
            assert f.attrs["version_git"] and f.attrs["version_numba"] and f.attrs["config_hash"]
    # nothing is written beside the workflow
    assert not (ROOT / "results" / "sim" / "short").exists()


def test_a_second_run_has_nothing_to_do(test_run):
    run = snakemake(test_run, "--dry-run", *TARGETS)
    assert run.returncode == 0, run.stderr[-2000:]
    assert "Nothing to be done" in run.stdout + run.stderr


def test_every_output_carries_provenance(test_run):
    """Issue 16: every file the run wrote under results/ carries versions, git revision and config
    hash (gimbal_reduction.workflow.provenance.read_provenance: HDF5 attributes, JSON key, PNG metadata, a sidecar
    for the VTU); a gmsh mesh through its metadata JSON (results/mesh/body{n}.json).  Not outputs of
    the stages: Snakemake's benchmark records (results/benchmarks/rules/) and the scene's flag file."""
    from gimbal_reduction.workflow.provenance import SIDECAR, read_provenance
    results = test_run / "results"
    checked, missing = [], []
    for path in sorted(results.rglob("*")):
        rel = path.relative_to(results).as_posix()
        if not path.is_file() or rel.endswith(SIDECAR) or rel.startswith("benchmarks/rules/") \
                or rel.endswith("needs.done"):
            continue
        carrier = path.with_suffix(".json") if path.suffix == ".msh" else path
        rec = read_provenance(carrier)
        checked.append(rel)
        if not (rec.get("config_hash") and rec.get("git") and "numpy" in (rec.get("versions") or {})):
            missing.append(rel)
    kinds = {p.rsplit(".", 1)[-1] for p in checked}
    assert {"msh", "json", "h5", "png", "vtu"} <= kinds, kinds
    assert not missing, missing
