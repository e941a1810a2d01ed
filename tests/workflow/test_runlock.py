"""The workflow's checks of its working directory before the DAG (gimbal_reduction/workflow/runlock.py):
another live run holds the files -> one line naming it; a stale record is ignored; a read-only
output folder -> one line naming it.  Each Snakemake case is a real run of the tiny test
configuration (.test) on a private copy, refused before any job: nothing written."""
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gimbal_reduction.workflow import runlock
from tests.robustness.test_dag_names import snakemake_own

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def fake_snakemake():
    """A live process whose command line names Snakemake (as a running Snakemake's does)."""
    proc = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(120)", "snakemake"])
    for _ in range(100):                    # until it runs its own command line (after exec)
        if b"snakemake" in Path(f"/proc/{proc.pid}/cmdline").read_bytes():
            break
        time.sleep(0.05)
    yield proc.pid
    proc.kill()
    proc.wait()


def record(directory, pid):
    path = Path(directory) / runlock.RECORD
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f'{{"pid": {pid}, "started": "2026-01-01 00:00:00"}}\n')


def test_holder_is_a_live_snakemake_other_than_this_process(tmp_path, fake_snakemake):
    assert runlock.holder(tmp_path) is None                      # no record
    record(tmp_path, fake_snakemake)
    assert runlock.holder(tmp_path)["pid"] == fake_snakemake
    message = runlock.holder_message(runlock.holder(tmp_path))
    assert "another run holds these files" in message and f"kill {fake_snakemake}" in message
    record(tmp_path, os.getpid())                                 # this process's own record
    assert runlock.holder(tmp_path) is None


def test_a_record_left_by_a_killed_run_is_ignored(tmp_path):
    proc = subprocess.Popen([sys.executable, "-c", "pass", "snakemake"])
    proc.wait()                                                   # its pid no longer runs
    record(tmp_path, proc.pid)
    assert runlock.holder(tmp_path) is None
    sleeper = subprocess.Popen(["sleep", "30"])                  # alive, but not Snakemake
    try:
        record(tmp_path, sleeper.pid)
        assert runlock.holder(tmp_path) is None
    finally:
        sleeper.kill()
        sleeper.wait()


def test_claim_and_release(tmp_path):
    runlock.claim(tmp_path)
    assert (tmp_path / runlock.RECORD).is_file()
    runlock.release(tmp_path)
    assert not (tmp_path / runlock.RECORD).exists()


def test_an_unwritable_output_folder_is_named(tmp_path, monkeypatch):
    (tmp_path / "results" / "sim" / "thesis").mkdir(parents=True)
    (tmp_path / "logs").mkdir()
    assert runlock.unwritable(tmp_path) is None
    blocked = str(tmp_path / "results" / "sim")
    real = os.access
    # (the tests may run as root, for whom a chmod'ed folder stays writable: the access is simulated)
    monkeypatch.setattr(runlock.os, "access", lambda p, mode: False if str(p) == blocked else real(p, mode))
    message = runlock.unwritable(tmp_path)
    assert message.startswith("output folder results/sim is not writable") and "nothing was run" in message


def snakemake(workdir, *args):
    run = subprocess.run([sys.executable, "-m", "snakemake", "--cores", "1", "--snakefile", str(ROOT / "Snakefile"),
                          "--directory", str(workdir), *args], cwd=ROOT, capture_output=True, text=True,
                         timeout=300)
    lines = [line for line in (run.stdout + run.stderr).splitlines() if line.strip() and not snakemake_own(line)]
    return run.returncode, lines


@pytest.fixture
def workdir(tmp_path):
    root = tmp_path / "work"
    shutil.copytree(ROOT / ".test", root)
    return root


def test_a_second_instance_is_told_another_run_holds_the_files(workdir, fake_snakemake):
    record(workdir, fake_snakemake)
    rc, lines = snakemake(workdir, "results/mesh/body2.msh")
    assert rc != 0 and len(lines) == 1, lines
    assert lines[0].startswith("another run holds these files") and str(fake_snakemake) in lines[0]
    assert not (workdir / "results").exists() and not (workdir / "logs").exists()    # nothing run
    (workdir / runlock.RECORD).unlink()                             # the run ended
    rc, lines = snakemake(workdir, "-n", "results/mesh/body2.msh")
    assert rc == 0, lines


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes to a read-only folder")
def test_a_read_only_results_folder_is_one_line_before_the_work(workdir):
    (workdir / "results").mkdir()
    (workdir / "results").chmod(0o555)
    try:
        rc, lines = snakemake(workdir, "results/mesh/body2.msh")
    finally:
        (workdir / "results").chmod(0o755)
    assert rc != 0 and len(lines) == 1 and lines[0].startswith("output folder results is not writable"), lines


@pytest.mark.slow
def test_a_second_instance_during_a_real_run(workdir):
    """Two real instances: the second, started while the first runs (a mesh and a modal solve), is
    refused in one line (not told to --rerun-incomplete), and the first finishes."""
    first = subprocess.Popen([sys.executable, "-m", "snakemake", "--cores", "1", "--snakefile",
                              str(ROOT / "Snakefile"), "--directory", str(workdir), "results/modes/body2.h5"],
                             cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        for _ in range(600):
            if (workdir / runlock.RECORD).is_file() or first.poll() is not None:
                break
            time.sleep(0.1)
        assert first.poll() is None, "the first run ended before the second could start"
        rc, lines = snakemake(workdir, "results/modes/body2.h5")
        assert rc != 0 and len(lines) == 1 and "another run holds these files" in lines[0], lines
    finally:
        assert first.wait(timeout=600) == 0
    assert not (workdir / runlock.RECORD).exists()
