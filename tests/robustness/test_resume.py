"""Kill and resume, for the stages a run reaches after the bodies: each is killed (SIGKILL) after its
output is complete in its temporary file and before the rename, then rerun as Snakemake would. The
killed run leaves no output, only its ``.part<pid>``; the rerun removes that and writes the file a
run never interrupted writes: the same numbers (every dataset's content hash; the export's arrays).
"""
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from .conftest import body_args, reduction_args

ROOT = Path(__file__).resolve().parents[2]

# the stage, run by `gimbal` (gimbal_reduction/commands.py), with every atomic write dying before its rename
DYING = """
import contextlib, os, signal, sys
from gimbal_reduction.workflow import provenance
real = provenance.atomic_path

@contextlib.contextmanager
def dying(path):
    with real(path) as tmp:
        yield tmp
        os.kill(os.getpid(), signal.SIGKILL)

provenance.atomic_path = dying
from gimbal_reduction.commands import main
sys.exit(main(sys.argv[1:]))
"""


def stage_args(stage, work, out):
    scene = work / "scene.yaml"
    model = work / "models" / "scene" / "xmx-2.h5"
    return {
        "model": ["model", "--model", "xmx-2", "--scene", scene, *body_args(work), *reduction_args(work),
                  "--out", out],
        "simulate": ["simulate", "--scene", scene, "--model-file", model, "--out", out],
        "load-ranking": ["load-ranking", "--scene", scene, *body_args(work), *reduction_args(work),
                         "--pool", "24", "--curve", "6", "--drop-fraction", "0", "--quiet", "--out", out],
        "export": ["export", "--model-file", model, "--scene", scene, "--out", out],
    }[stage]


def numbers(path):
    """What a file says, without its dates and run times: the content hashes of an HDF5 file's
    datasets, the arrays of an export's .npz."""
    if path.suffix == ".h5":
        with h5py.File(path, "r") as f:
            return json.loads(f.attrs["content_hashes"])
    with np.load(path.with_suffix(".npz"), allow_pickle=False) as z:
        return {k: z[k].tolist() for k in z.files if k != "provenance"}


def gimbal(argv, dying=False):
    code = ["-c", DYING] if dying else ["-m", "gimbal_reduction.commands"]
    return subprocess.run([sys.executable, *code, *map(str, argv)], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)


@pytest.mark.parametrize("stage, name", [("model", "m.h5"), ("simulate", "s.h5"),
                                         ("load-ranking", "l.h5"), ("export", "e.mat")])
def test_killed_before_the_rename_then_resumed(stage, name, work, tmp_path):
    out = work / "out" / name
    killed = gimbal(stage_args(stage, work, out), dying=True)
    assert killed.returncode == -signal.SIGKILL, killed.stderr[-2000:]
    left = os.listdir(work / "out")
    assert left and all(n.startswith(f".{name}.part") or n.startswith(f".{Path(name).stem}") for n in left), left
    resumed = gimbal(stage_args(stage, work, out))
    assert resumed.returncode == 0, resumed.stderr[-2000:]
    clean = tmp_path / "clean" / name
    assert gimbal(stage_args(stage, work, clean)).returncode == 0
    expected = sorted(os.listdir(clean.parent))
    assert sorted(n for n in os.listdir(work / "out") if not n.startswith(".")) == expected
    assert not [n for n in os.listdir(work / "out") if n.startswith(".")]      # no .part left
    assert numbers(out) == numbers(clean)
