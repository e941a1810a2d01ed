"""The output location: checked before the work; a full disk while writing gives one line and
leaves nothing (no file, no temporary file, no folder made for it); stale temporary files of
killed writers are removed by the next write of their target."""
import contextlib
import errno
import os
import subprocess
import sys

import h5py
import pytest

from reduction import models
from solver.dynamics import chainfile, simfile, simulate
from workflow import provenance

from .conftest import body_args

MODEL = ("models", "scene", "xmx-2.h5")


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
        assert "synthetic" in f.attrs["body_config_hashes"]
