"""The output location: checked before the work; a full disk while writing gives one line and
leaves nothing (no file, no temporary file, no folder made for it), in the modal, reduction,
reduced-model and simulation stages; stale temporary files of killed writers are removed by the
next write of their target."""
import contextlib
import errno
import os
import signal
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from gimbal_reduction.reduction import models, stage
from gimbal_reduction.results.bench.oracle import synthetic_body
from gimbal_reduction.solver.bodydata import BODY_KEYS, read_body_file
from gimbal_reduction.solver.dynamics import chainfile, simfile, simulate
from gimbal_reduction.solver.fe import modes
from gimbal_reduction.workflow import provenance

from tests.reduction.test_models import project_body_hash

from .conftest import body_args

MODEL = ("models", "scene", "xmx-2.h5")
ROOT = Path(__file__).resolve().parents[2]


def sim(work, out):
    return ["--scene", work / "scene.yaml", "--model-file", work.joinpath(*MODEL), "--out", out]


def test_output_parent_is_a_file(work, refused):
    (work / "out" / "blocker").write_text("")
    refused(simulate.main, sim(work, work / "out" / "blocker" / "s.h5"), ("blocker", "is a file"), work / "out")


def test_output_is_a_folder(work, refused):
    (work / "out" / "s.h5").mkdir()
    refused(simulate.main, sim(work, work / "out" / "s.h5"), ("s.h5", "folder"), work / "out")


def test_models_output_parent_is_a_file(work, refused):
    (work / "out" / "blocker").write_text("")
    refused(models.main, ["--model", "freq-2", "--scene", work / "scene.yaml", *body_args(work),
                          "--out", work / "out" / "blocker" / "m.h5"], ("blocker",), work / "out")


def full_disk_after(module, monkeypatch, written=2):
    """Make ``module.atomic_h5`` fail with ENOSPC after ``written`` datasets, as a full disk does."""
    real = provenance.atomic_h5

    @contextlib.contextmanager
    def failing(path):
        with real(path) as h5:
            count = {"n": 0}
            create = h5.__class__.__setitem__

            class Full(h5.__class__):
                def __setitem__(self, key, value):
                    count["n"] += 1
                    if count["n"] > written:
                        raise OSError(errno.ENOSPC, "No space left on device")
                    create(self, key, value)

                def create_group(self, name, *args, **kwargs):
                    count["n"] += 1
                    if count["n"] > written:
                        raise OSError(errno.ENOSPC, "No space left on device")
                    return super().create_group(name, *args, **kwargs)
            h5.__class__ = Full
            try:
                yield h5
            finally:
                h5.__class__ = Full.__mro__[1]
    monkeypatch.setattr(module, "atomic_h5", failing)


def test_full_disk_while_simulating_leaves_nothing(work, refused, monkeypatch):
    full_disk_after(simfile, monkeypatch)
    out = work / "out" / "new" / "s.h5"
    refused(simulate.main, sim(work, out), (str(out), "no space left"), work / "out")
    assert not (work / "out" / "new").exists()


def test_full_disk_while_reducing_leaves_nothing(work, refused, monkeypatch):
    full_disk_after(chainfile, monkeypatch)
    out = work / "out" / "m.h5"
    refused(models.main, ["--model", "freq-2", "--scene", work / "scene.yaml", *body_args(work),
                          "--out", out], (str(out), "no space left"), work / "out")


def test_full_disk_keeps_the_previous_result(work, refused, monkeypatch):
    out = work / "out" / "s.h5"
    assert simulate.main([str(a) for a in sim(work, out)]) == 0
    full_disk_after(simfile, monkeypatch)
    refused(simulate.main, sim(work, out), ("no space left",), work / "out")    # s.h5 unchanged


class _FullDisk:
    """A file open for writing on a disk with ``room`` bytes left: the bytes that fit are written,
    then ENOSPC, as the kernel does."""

    def __init__(self, f, room):
        self.f, self.room = f, room

    def write(self, data):
        data = bytes(data)
        self.f.write(data[:self.room])
        self.f.flush()
        if len(data) > self.room:
            raise OSError(errno.ENOSPC, "No space left on device")
        self.room -= len(data)
        return len(data)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.f.close()


def disk_full(monkeypatch, room=4096):
    """The disk under the atomic HDF5 writer (gimbal_reduction.workflow.provenance.atomic_h5: the file built in memory,
    then written in one piece) holds only ``room`` more bytes."""
    def opener(path, mode="r", *args, **kwargs):
        f = open(path, mode, *args, **kwargs)
        return _FullDisk(f, room) if "w" in mode else f
    monkeypatch.setattr(provenance, "open", opener, raising=False)


def modal_payload(body=2):
    """What the modal stage's solve returns (gimbal_reduction.solver.fe.modes.compute_body), from a synthetic body."""
    d = synthetic_body(np.random.default_rng(body), body, n_nodes=8, rotations=True, n_modes=6,
                       omega_max=3e3)
    return {**{k: d[k] for k in BODY_KEYS if k != "frequencies_hz"},
            "frequencies_hz": np.sqrt(d["eigenvalues"]) / (2 * np.pi), "residuals": np.zeros(6),
            "attrs": {"body": body, "name": "outer_gimbal"}, "timings": {}}


def modal_stage(work, monkeypatch, out):
    """gimbal_reduction.solver.fe.modes' command line with its solve replaced by a synthetic body (the writer is real)."""
    monkeypatch.setattr(modes, "compute_body", lambda *args, **kwargs: modal_payload())
    mesh = work / "b.msh"
    mesh.write_text("")
    return ["--body", "2", "--mesh", mesh, "--out", out]


def test_full_disk_in_the_modal_stage_leaves_nothing(work, refused, monkeypatch):
    out = work / "out" / "modes" / "body2.h5"
    argv = modal_stage(work, monkeypatch, out)
    disk_full(monkeypatch)
    refused(modes.main, argv, (str(out), "no space left", "nothing was written"), work / "out")
    assert not (work / "out" / "modes").exists()            # no file, no temporary file, no folder


def test_full_disk_keeps_the_previous_body_file(work, refused, monkeypatch):
    out = work / "out" / "body2.h5"
    argv = modal_stage(work, monkeypatch, out)
    assert modes.main([str(a) for a in argv]) == 0
    read_body_file(out)                                       # the writer's file passes the contract
    disk_full(monkeypatch, room=100)
    refused(modes.main, argv, ("no space left",), work / "out")   # body2.h5 unchanged, no .part


def test_full_disk_while_writing_a_simulation_file(work, refused, monkeypatch):
    out = work / "out" / "s.h5"
    disk_full(monkeypatch)
    refused(simulate.main, sim(work, out), (str(out), "no space left"), work / "out")


def test_full_disk_in_the_reduction_stage_leaves_nothing(work, refused, monkeypatch):
    out = work / "out" / "r.h5"
    disk_full(monkeypatch)
    refused(stage.main, ["--body-file", work / "modes" / "body2.h5", "--out", out, "--quiet",
                         "--static-kept", "2"],
            (str(out), "no space left"), work / "out")


def test_killed_modal_write_leaves_no_part_file_after_the_next_run(work, monkeypatch):
    """A writer killed (SIGKILL) while writing the body file leaves its .part<pid>; the next run of
    the modal stage on that target removes it."""
    out = work / "out" / "body2.h5"
    killed = subprocess.Popen([sys.executable, "-c", (
        "import os, signal, sys\n"
        "from gimbal_reduction.workflow.provenance import atomic_path\n"
        "with atomic_path(sys.argv[1]) as tmp:\n"
        "    tmp.write_bytes(bytes(10**6))\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n"), str(out)], cwd=ROOT)
    assert killed.wait() == -signal.SIGKILL
    assert [p.name for p in (work / "out").iterdir()] == [f".body2.h5.part{killed.pid}"]
    assert modes.main([str(a) for a in modal_stage(work, monkeypatch, out)]) == 0
    assert sorted(os.listdir(work / "out")) == ["body2.h5"]


def dead_pid():
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


def test_stale_part_file_of_a_killed_writer_removed_on_the_next_run(work):
    out = work / "out" / "s.h5"
    stale = work / "out" / f".s.h5.part{dead_pid()}"
    stale.write_bytes(b"x" * 1000)
    assert simulate.main([str(a) for a in sim(work, out)]) == 0
    assert sorted(os.listdir(work / "out")) == ["s.h5"]


def test_part_file_of_a_live_writer_kept(work):
    out = work / "out" / "s.h5"
    live = work / "out" / f".s.h5.part{os.getppid()}"
    live.write_bytes(b"x")
    provenance.write_text(out, "x")
    assert live.exists()


def test_unrelated_hidden_file_kept(work):
    other = work / "out" / ".other.h5.part1"
    other.write_bytes(b"x")
    provenance.write_text(work / "out" / "s.h5", "x")
    assert other.exists()


def test_interrupted_write_leaves_no_folder(work):
    target = work / "out" / "a" / "b" / "f.txt"
    with pytest.raises(RuntimeError):
        with provenance.atomic_path(target) as tmp:
            tmp.write_text("half")
            raise RuntimeError("killed")
    assert sorted(os.listdir(work / "out")) == []


def test_simulation_file_holds_the_body_hashes(work):
    out = work / "out" / "s.h5"
    assert simulate.main([str(a) for a in sim(work, out)]) == 0
    with h5py.File(out, "r") as f:
        assert project_body_hash(2) in f.attrs["body_config_hashes"]
