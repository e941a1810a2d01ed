"""Provenance and safe output: software versions, git revision, atomic file writes.

Every result file is written to a temporary name in its destination folder
and renamed into place only when complete (``os.replace`` is atomic on one
file system), so an interrupted job never leaves a truncated file that a
later run could take for a finished one: ``atomic_path`` (any writer),
``atomic_h5``, ``write_json``, ``write_text`` and ``write_csv`` (the CSV
tables, formatted by ``csv_text``) are the project's only atomic writers.

``check_record`` makes the one shape of a verification check,
``{name, value, tolerance, passed, **details}``.
"""
from __future__ import annotations

import contextlib
import csv
import io
import json
import math
import os
import platform
import subprocess
from importlib import metadata
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def versions() -> dict:
    """Versions of the software that produced a result."""
    out = {"python": platform.python_version()}
    for module in ("dolfinx", "numpy", "scipy", "petsc4py", "slepc4py", "gmsh", "h5py", "snakemake"):
        try:
            out[module] = metadata.version(module if module != "dolfinx" else "fenics-dolfinx")
        except metadata.PackageNotFoundError:
            try:
                out[module] = __import__(module).__version__
            except Exception:  # noqa: BLE001 - optional package
                pass
    out["git"] = git_revision()
    return out


def git_revision() -> str:
    try:
        rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, timeout=5).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=5).stdout.strip()
        return rev + ("-dirty" if dirty else "") if rev else "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:          # another user's process: alive
        return True
    except OSError:
        return True
    return True


def remove_stale_parts(path: str | Path) -> list[Path]:
    """Remove the temporary files ``.{name}.part{pid}`` of ``path`` left by writers that died
    (killed during a write: their pid no longer runs); a live writer's file is left alone.
    Returns the removed paths.  Called by ``atomic_path`` on every write of ``path``, so the
    next run of the rule that makes ``path`` cleans up after an interrupted one."""
    path = Path(path)
    removed = []
    if not path.parent.is_dir():
        return removed
    prefix = f".{path.name}.part"
    for sibling in path.parent.iterdir():
        name = sibling.name
        if not name.startswith(prefix) or not name[len(prefix):].isdigit():
            continue
        pid = int(name[len(prefix):])
        if pid != os.getpid() and not _pid_alive(pid):
            try:
                sibling.unlink()
                removed.append(sibling)
            except FileNotFoundError:
                pass
    return removed


@contextlib.contextmanager
def atomic_path(path: str | Path):
    """Yield a temporary path beside ``path``; rename it into place on success.  Stale
    temporary files of ``path`` from writers that died are removed first
    (``remove_stale_parts``); on any failure (a full disk included) the temporary file is
    removed and ``path`` is left as it was, with any folder made for it."""
    path = Path(path)
    made = []                                   # folders created here, innermost first
    folder = path.parent.absolute()
    while not folder.exists():
        made.append(folder)
        folder = folder.parent
    path.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_parts(path)
    tmp = path.with_name(f".{path.name}.part{os.getpid()}")
    done = False
    try:
        yield tmp
        os.replace(tmp, path)
        done = True
    finally:
        if tmp.exists():
            tmp.unlink()
        if not done:
            for folder in made:
                try:
                    folder.rmdir()              # only if still empty
                except OSError:
                    break


@contextlib.contextmanager
def atomic_h5(path: str | Path):
    """An h5py File open for writing that appears at ``path`` only when closed successfully.

    The file is built in memory (HDF5's core driver without a backing store) and written to the
    temporary file in one piece by Python's own I/O, so a full disk (or a quota) is a plain
    OSError from that write, and the temporary file is removed (``atomic_path``).  HDF5 itself
    never writes to the disk here: a flush or close that fails on a full disk is reported by h5py
    as RuntimeErrors, printed as ignored exceptions from every object it frees, and can end the
    process with a segmentation fault at exit (issue 15)."""
    with atomic_path(path) as tmp:
        h5 = h5py.File(str(tmp), "w", driver="core", backing_store=False)
        try:
            yield h5
            h5.flush()
            image = h5.id.get_file_image()
        finally:
            h5.close()
        with open(tmp, "wb") as f:
            f.write(image)


def write_json(path: str | Path, data: dict) -> None:
    """Write JSON atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(json.dumps(data, indent=2, default=_jsonable) + "\n")


def _jsonable(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, (np.floating, np.integer, np.bool_)):
        return obj.item()
    raise TypeError(f"not JSON serialisable: {type(obj)}")


def read_h5_checked(path: str | Path, required: tuple[str, ...] = ()) -> h5py.File:
    """Open an intermediate HDF5 file, with a one-line error if it is missing, corrupt or incomplete."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"'{path}' not found (run the stage that makes it)")
    try:
        h5 = h5py.File(path, "r")
    except OSError:
        raise ValueError(f"'{path}' is not a readable HDF5 file (corrupt or truncated): delete it and rerun") from None
    missing = [key for key in required if key not in h5]
    if missing:
        h5.close()
        raise ValueError(f"'{path}' lacks {', '.join(missing)}: it is stale or incomplete; delete it and rerun")
    return h5


def write_text(path: str | Path, text: str) -> None:
    """Write text atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def csv_text(rows: list[dict], columns, digits: int = 8) -> str:
    """CSV text of dict rows in the given columns: floats with ``digits`` significant
    digits, None or a missing key as an empty cell, other keys ignored (every CSV table
    of the project is written by this)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(columns), lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{r[k]:.{digits}g}" if isinstance(r.get(k), float) else
                        ("" if r.get(k) is None else r.get(k))) for k in columns})
    return buf.getvalue()


def write_csv(path: str | Path, rows: list[dict], columns, digits: int = 8) -> None:
    """Write dict rows as a CSV table atomically (format: ``csv_text``)."""
    write_text(path, csv_text(rows, columns, digits))


def check_record(name: str, value: float, tolerance: float | None, passed: bool | None = None,
                 **details) -> dict:
    """One verification check, JSON-ready: ``{name, value, tolerance, passed, **details}``.

    value: the measured number (made a float); tolerance: its bound (a float), or None
    for a measured report without a bound.  passed: by default value is finite and at
    most the tolerance (finite is enough without one); a check judged otherwise (a
    two-sided bound, an extra condition) passes its own verdict.  details: further
    JSON-ready keys stored beside the four (e.g. ``details={...}`` nests them).
    """
    value = float(value)
    tolerance = None if tolerance is None else float(tolerance)
    if passed is None:
        passed = math.isfinite(value) and (tolerance is None or value <= tolerance)
    return {"name": name, "value": value, "tolerance": tolerance, "passed": bool(passed), **details}
