"""What the workflow checks of its working directory before it builds anything: that no other run
holds its files, and that its output folders can be written.

Snakemake locks the files of a run (``.snakemake/locks``), but a second instance started during a
run meets the first run's jobs, marked incomplete while they run, before it looks at the locks,
and is told to ``--rerun-incomplete``: advice that, followed, would rebuild the files the first
run is writing.  So the workflow records its own run: ``claim`` (Snakemake's ``onstart``) writes
``.snakemake/gimbal-run.json`` with the process id of the Snakemake that runs, ``release``
(``onsuccess``, ``onerror``) removes it, and ``holder`` tells a later instance, when its Snakefile
is read, which live Snakemake process holds the directory.  A record left by a run that was
killed names a process that no longer runs (or no longer runs Snakemake) and is ignored.

``unwritable`` names the first output folder (``results``, ``logs`` and every folder under them)
the run could not write, so that a read-only folder is one line before any job, not a traceback
from Snakemake's own log or output handling.  Standard library only: it runs when the Snakefile
is read.
"""
from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

RECORD = Path(".snakemake") / "gimbal-run.json"
OUTPUT_FOLDERS = ("results", "logs", ".snakemake")


def _runs_snakemake(pid: int) -> bool:
    """Whether process ``pid`` is alive and runs Snakemake (its command line names it)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:         # another user's process: alive, command line unknown
        return True
    try:
        cmdline = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:                 # no /proc: alive is all that is known
        return True
    return b"snakemake" in cmdline


def holder(directory: str | Path = ".") -> dict | None:
    """The record ({pid, started, command}) of another live Snakemake run of ``directory``, or None
    (no record, a stale one, or this process's own)."""
    try:
        record = json.loads((Path(directory) / RECORD).read_text())
        pid = int(record["pid"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if pid == os.getpid() or not _runs_snakemake(pid):
        return None
    return record


def holder_message(record: dict) -> str:
    """The one line that tells a second instance who holds the files."""
    return (f"another run holds these files (Snakemake pid {record['pid']}, started "
            f"{record.get('started', '?')}): wait for it to finish, or stop it (kill {record['pid']}) and "
            f"rerun; nothing was run")


def claim(directory: str | Path = ".") -> None:
    """Record this process as the run of ``directory``."""
    path = Path(directory) / RECORD
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}")
    tmp.write_text(json.dumps({"pid": os.getpid(), "started": time.strftime("%Y-%m-%d %H:%M:%S"),
                               "command": " ".join(sys.argv)}) + "\n")
    os.replace(tmp, path)


def release(directory: str | Path = ".") -> None:
    """Remove the record of ``directory`` if it is this process's."""
    path = Path(directory) / RECORD
    try:
        if int(json.loads(path.read_text())["pid"]) == os.getpid():
            path.unlink()
    except (OSError, ValueError, KeyError, TypeError):
        pass


def unwritable(directory: str | Path = ".", folders=OUTPUT_FOLDERS) -> str | None:
    """The one-line message for the first existing output folder under ``directory`` (``folders``
    and every folder below them) that this process cannot write, or None."""
    for top in folders:
        root = Path(directory) / top
        if not root.is_dir():
            continue
        for dirpath, dirnames, _ in os.walk(root):
            dirnames[:] = [d for d in dirnames if d not in ("conda", "singularity", "__pycache__")]
            if not os.access(dirpath, os.W_OK | os.X_OK):
                return (f"output folder {os.path.relpath(dirpath, directory)} is not writable: make it "
                        f"writable (chmod u+w) or run in another directory (--directory); nothing was run")
    return None
