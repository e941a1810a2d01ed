"""Provenance and safe output: software versions, git revision, config hash, atomic file writes.

Every result file is written to a temporary name in its destination folder
and renamed into place only when complete (``os.replace`` is atomic on one
file system), so an interrupted job never leaves a truncated file that a
later run could take for a finished one: ``atomic_path`` (any writer),
``atomic_h5``, ``write_json``, ``write_text``, ``write_csv`` (the CSV
tables, formatted by ``csv_text``) and ``savefig`` (figures) are the project's
only atomic writers.

Every output file carries its provenance: the record ``provenance()``, {config_hash,
config_hash_from, git, versions} (``versions()`` holds the git revision too).  How, by kind
(``read_provenance`` reads each back):

* HDF5 (body, reduction, load-ranking, reduced-model, simulation files): their writers'
  attributes ``config_hash`` and ``versions`` (JSON) or ``version_*``;
* JSON (``write_json``): the key ``provenance``;
* Markdown (``write_text``, ``.md``): a last line ``<!-- provenance: {...} -->`` (invisible
  when rendered);
* PNG and PDF figures (``savefig``): PNG text chunk ``Provenance``, PDF ``/Subject``
  ``provenance {...}``; the Typst reports set the same ``/Subject`` (``typst_metadata``);
* the state-space export's .mat and .npz (``gimbal_reduction.solver.dynamics.export``): a field ``provenance``
  (JSON text);
* everything else (CSV, VTU; ``write_text``, ``write_sidecar``): a sidecar
  ``{file}.provenance.json`` beside it, so every CSV stays a plain table for every reader.
  (A mesh's sidecar is its metadata JSON, ``results/mesh/body{n}.json``.)

The config hash is the hash of the configuration values the output depends on: the stage's
own where it has one (a body file's, ``inputs_hash`` of the values it reads); else the config
hashes of the files it was made from (``sources``), one if they agree, else a hash of them
all; else the hash of the whole configuration file of the run (``run_config``).

Every HDF5 file also carries a content hash of its numbers: the attribute ``content_hashes``
(JSON, {dataset path: blake2b digest of its dtype, shape and bytes}, 16 hex digits each),
written by ``atomic_h5`` over every numeric dataset and checked by ``check_content`` when a
reader opens the file, so a number changed by hand (a scaled ``body4/momentum``, an edited
``estimate/global``) is refused naming the file and the dataset.  Hashing is a read of the
bytes, ~1 GB/s: a body file of ~100 MB costs ~0.1 s, the others nothing to speak of.

``check_record`` makes the one shape of a verification check,
``{name, value, tolerance, passed, **details}``.
"""
from __future__ import annotations

import contextlib
import copy
import csv
import functools
import hashlib
import io
import json
import math
import os
import platform
import re
import struct
import subprocess
import time
import zlib
from importlib import metadata
from pathlib import Path

import h5py
import numpy as np

from gimbal_reduction.workflow import config as cfgmod

ROOT = Path(__file__).resolve().parents[2]
SIDECAR = ".provenance.json"


def versions() -> dict:
    """Versions of the software that produced a result (a fresh dict; looked up once per
    process: the metadata look-ups and the two git calls cost ~35 ms, and a study process
    writes ~100 files)."""
    return copy.deepcopy(_versions())


@functools.lru_cache(maxsize=1)
def _versions() -> dict:
    out = {"python": platform.python_version()}
    # DOLFINx ships in the distribution that installs its import package: dolfinx-solver-real
    # (the PyPI wheel, versioned as the DOLFINx release it builds) or another of DOLFINX_DISTS;
    # asked of the package metadata, so that recording it never imports (and initialises MPI for)
    # DOLFINx.  The known names are asked first: scanning every installed distribution for the
    # one that ships ``dolfinx`` (``packages_distributions``) costs ~0.7 s, in every job.
    for module in ("dolfinx", "numpy", "scipy", "petsc4py", "slepc4py", "gmsh", "h5py", "snakemake"):
        try:
            dists = _dolfinx_distributions() if module == "dolfinx" else [module]
            if not dists:
                raise metadata.PackageNotFoundError(module)
            out[module] = metadata.version(dists[0])
        except metadata.PackageNotFoundError:
            try:
                out[module] = __import__(module).__version__
            except Exception:  # noqa: BLE001 - optional package
                pass
    out["git"] = git_revision()
    return out


# Distributions that install the import package ``dolfinx``, the PyPI wheels first
DOLFINX_DISTS = ("dolfinx-solver-real", "dolfinx-solver-complex", "fenics-dolfinx")


def _dolfinx_distributions() -> list[str]:
    """The installed distributions that ship ``dolfinx``: a known name if one is installed, else
    a scan of every distribution's files."""
    for name in DOLFINX_DISTS:
        try:
            metadata.version(name)
            return [name]
        except metadata.PackageNotFoundError:
            continue
    return metadata.packages_distributions().get("dolfinx", [])


@functools.lru_cache(maxsize=1)
def git_revision() -> str:
    """The project's git revision (short hash, ``-dirty`` with uncommitted changes to tracked
    files), once per process: the code a process runs is the code it started with."""
    try:
        rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True, timeout=5).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=5).stdout.strip()
        return rev + ("-dirty" if dirty else "") if rev else "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def other_revision(path: str | Path) -> str | None:
    """The git revision ``path`` was made at (its provenance, ``read_provenance``) if it is not the
    revision of this process's code, else None (the same revision, or none recorded).  A report
    that shows a file made by another target (``bench``, ``verify``) says so: the file may be stale.
    A ``-dirty`` suffix is ignored (uncommitted edits cannot be compared)."""
    made = str(read_provenance(path).get("git") or "unknown").removesuffix("-dirty")
    now = git_revision().removesuffix("-dirty")
    return None if "unknown" in (made, now) or made == now else made


def run_config() -> Path:
    """The configuration file of the run: ``config/config.yaml`` of the working directory (the
    workflow's convention, with ``--directory`` too), else the project's."""
    here = Path("config") / "config.yaml"
    return here if here.is_file() else cfgmod.DEFAULT_CONFIG


def combined_hash(hashes) -> str | None:
    """One config hash for several: the hash itself if they agree, else a hash of them all."""
    distinct = sorted({str(h) for h in hashes if h})
    if not distinct:
        return None
    return distinct[0] if len(distinct) == 1 else cfgmod.inputs_hash(distinct)


def provenance(config_hash: str | None = None, sources=()) -> dict:
    """The provenance record of an output: {config_hash, config_hash_from, git, versions}.

    config_hash: the hash of the configuration values the output depends on, if the stage has
    it; else that of the files it was made from (``sources``: paths, ``read_provenance``;
    ``combined_hash``); else that of the whole configuration file of the run (``run_config``)."""
    if config_hash is not None:
        source = "stage"
    else:
        sources = [str(p) for p in sources]
        config_hash = combined_hash(read_provenance(p).get("config_hash") for p in sources
                                    if os.path.exists(p))
        source = f"{len(sources)} input file{'s' if len(sources) != 1 else ''}"
        if config_hash is None:
            path = run_config()
            try:
                config_hash = cfgmod.section_hash(cfgmod.load_config(path))
                source = f"configuration file {path}"
            except (OSError, ValueError):
                config_hash, source = "unknown", f"unreadable configuration file {path}"
    v = versions()
    return {"config_hash": str(config_hash), "config_hash_from": source, "git": v.get("git", "unknown"),
            "versions": v}


def sidecar_path(path: str | Path) -> Path:
    """The provenance sidecar of a file without room for it inside: ``{path}.provenance.json``."""
    return Path(str(path) + SIDECAR)


def write_sidecar(path: str | Path, record: dict | None = None) -> None:
    """Write the provenance sidecar of ``path`` (``sidecar_path``) atomically."""
    with atomic_path(sidecar_path(path)) as tmp:
        tmp.write_text(json.dumps(record or provenance(), indent=2, sort_keys=True) + "\n")


def _record_text(record: dict) -> str:
    return json.dumps(record, sort_keys=True, separators=(", ", ": "))


def markdown_comment(record: dict) -> str:
    """The provenance line of a Markdown file (an HTML comment, invisible when rendered)."""
    return f"<!-- provenance: {_record_text(record).replace('--', '- -')} -->\n"


def figure_metadata(fmt: str, record: dict | None = None) -> dict:
    """matplotlib ``savefig(metadata=...)`` of a figure: PNG text chunk ``Provenance``, PDF
    ``Subject`` (``provenance {...}``); {} for other formats."""
    record = record or provenance()
    fmt = fmt.lower().lstrip(".")
    if fmt == "png":
        return {"Provenance": _record_text(record)}
    if fmt == "pdf":
        return {"Subject": "provenance " + _record_text(record)}
    return {}


def savefig(fig, path: str | Path, record: dict | None = None, **kwargs) -> None:
    """``fig.savefig`` to ``path`` atomically, with the provenance in the file's metadata
    (``figure_metadata``; other formats get a sidecar)."""
    fmt = kwargs.pop("format", None) or Path(path).suffix.lstrip(".") or "png"
    record = record or provenance()
    meta = figure_metadata(fmt, record)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=fmt, metadata={**meta, **kwargs.pop("metadata", {})}, **kwargs)
    if not meta:
        write_sidecar(path, record)


def typst_metadata(record: dict | None = None) -> str:
    """A Typst line that puts the provenance into a PDF's ``/Subject`` (document description)."""
    text = "provenance " + _record_text(record or provenance())
    return '#set document(description: "' + text.replace("\\", "\\\\").replace('"', '\\"') + '")\n'


# ------------------------------------------------------------------ reading provenance back
def _pdf_string(data: bytes, start: int) -> str:
    """The PDF string object at data[start] (literal ``(...)`` or hex ``<...>``) as text."""
    if data[start:start + 1] == b"<":
        raw = bytes.fromhex(data[start + 1:data.index(b">", start)].decode())
    else:
        out, depth, i = bytearray(), 0, start
        escapes = {ord("n"): b"\n", ord("r"): b"\r", ord("t"): b"\t", ord("b"): b"\b", ord("f"): b"\f"}
        while True:
            c = data[i]
            if c == ord("\\"):
                nxt = data[i + 1]
                if nxt in escapes:
                    out += escapes[nxt]
                    i += 2
                elif ord("0") <= nxt <= ord("7"):
                    digits = re.match(rb"[0-7]{1,3}", data[i + 1:i + 4]).group()
                    out.append(int(digits, 8) & 0xFF)
                    i += 1 + len(digits)
                else:
                    out.append(nxt)
                    i += 2
                continue
            if c == ord("("):
                depth += 1
                if depth == 1:
                    i += 1
                    continue
            elif c == ord(")"):
                depth -= 1
                if depth == 0:
                    break
            out.append(c)
            i += 1
        raw = bytes(out)
    if raw.startswith(b"\xfe\xff"):
        return raw[2:].decode("utf-16-be")
    return raw.decode("latin-1")


def _png_text(path: Path) -> dict:
    """The text chunks (tEXt, zTXt, iTXt) of a PNG file."""
    out = {}
    with open(path, "rb") as f:
        if f.read(8) != b"\x89PNG\r\n\x1a\n":
            return out
        while True:
            head = f.read(8)
            if len(head) < 8:
                return out
            length, kind = struct.unpack(">I4s", head)
            body = f.read(length)
            f.read(4)                                   # CRC
            if kind == b"tEXt":
                key, _, value = body.partition(b"\0")
                out[key.decode("latin-1")] = value.decode("latin-1")
            elif kind == b"zTXt":
                key, _, value = body.partition(b"\0")
                out[key.decode("latin-1")] = zlib.decompress(value[1:]).decode("latin-1")
            elif kind == b"iTXt":
                key, _, rest = body.partition(b"\0")
                compressed, rest = rest[0], rest[2:]
                _, _, rest = rest.partition(b"\0")      # language tag
                _, _, value = rest.partition(b"\0")     # translated keyword
                out[key.decode("latin-1")] = (zlib.decompress(value) if compressed else value).decode()
            elif kind == b"IEND":
                return out


def _from_text(text: str | None) -> dict:
    """The record of ``provenance {...}`` / ``{...}`` text, {} if there is none."""
    if not text:
        return {}
    start = text.find("{")
    try:
        return json.loads(text[start:]) if start >= 0 else {}
    except ValueError:
        return {}


def read_provenance(path: str | Path) -> dict:
    """The provenance an output file carries (the module docstring says where), as a dict with at
    least config_hash, git and versions where the file has them; {} if it carries none."""
    path = Path(path)
    suffix = path.suffix.lower()
    try:
        if suffix == ".h5":
            with h5py.File(path, "r") as f:
                attrs = dict(f.attrs)
            out = {}
            if "config_hash" in attrs:
                out["config_hash"] = str(attrs["config_hash"])
            if "versions" in attrs:
                out["versions"] = json.loads(attrs["versions"])
            elif any(k.startswith("version_") for k in attrs):
                out["versions"] = {k[len("version_"):]: str(v) for k, v in attrs.items()
                                   if k.startswith("version_")}
            if "versions" in out:
                out["git"] = out["versions"].get("git", "unknown")
            return out
        if suffix == ".json" and not path.name.endswith(SIDECAR):
            data = json.loads(path.read_text())
            if isinstance(data, dict):          # else (a list): the sidecar, below
                out = dict(data.get("provenance") or {})
                for key in ("config_hash", "versions"):
                    if key not in out and key in data:
                        out[key] = data[key]
                if "git" not in out and isinstance(out.get("versions"), dict) and "git" in out["versions"]:
                    out["git"] = out["versions"]["git"]
                return out
        if suffix == ".md":
            found = re.findall(r"<!-- provenance: (.*) -->", path.read_text())
            return _from_text(found[-1]) if found else {}
        if suffix == ".typ":                    # a report's Typst source (``typst_metadata``)
            found = re.search(r'^#set document\(description: "(provenance .*)"\)$', path.read_text(), re.M)
            return _from_text(re.sub(r"\\(.)", r"\1", found.group(1))) if found else {}
        if suffix == ".png":
            return _from_text(_png_text(path).get("Provenance"))
        if suffix == ".npz":                    # the state-space export (gimbal_reduction.solver.dynamics.export)
            with np.load(path, allow_pickle=False) as z:
                return _from_text(str(z["provenance"])) if "provenance" in z.files else {}
        if suffix == ".mat":
            import scipy.io  # optional heavy dependency: imported only to read a .mat export
            text = scipy.io.loadmat(path, variable_names=["provenance"]).get("provenance")
            return _from_text(str(text[0])) if text is not None and len(text) else {}
        if suffix == ".pdf":
            data = path.read_bytes()
            at = data.rfind(b"/Subject")
            if at < 0:
                return {}
            start = at + len(b"/Subject")
            while data[start:start + 1].isspace():
                start += 1
            return _from_text(_pdf_string(data, start))
    except (OSError, ValueError, KeyError, IndexError, AttributeError, zlib.error):
        return {}
    side = sidecar_path(path)
    return json.loads(side.read_text()) if side.is_file() else {}


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
    process with a segmentation fault at exit."""
    with atomic_path(path) as tmp:
        h5 = h5py.File(str(tmp), "w", driver="core", backing_store=False)
        try:
            yield h5
            h5.attrs[CONTENT_ATTR] = json.dumps(content_hashes(h5), sort_keys=True)
            h5.flush()
            image = h5.id.get_file_image()
        finally:
            h5.close()
        with open(tmp, "wb") as f:
            f.write(image)


CONTENT_ATTR = "content_hashes"


def dataset_digest(value) -> str:
    """The content hash of one numeric array: blake2b (8 bytes, 16 hex digits) of its dtype,
    shape and bytes (C order)."""
    value = np.ascontiguousarray(value)
    h = hashlib.blake2b(digest_size=8)
    h.update(f"{value.dtype.str}{value.shape}".encode())
    h.update(value.tobytes())
    return h.hexdigest()


def content_hashes(h5) -> dict:
    """{dataset path: ``dataset_digest``} of every numeric dataset of an open HDF5 file
    (strings and compound types are left out: the numbers are what a reader computes with)."""
    out = {}

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "biufc":
            out[name] = dataset_digest(obj[()])
    h5.visititems(visit)
    return out


class VerifiedContent:
    """The files whose content hashes this process has found intact, each as (file, object
    name, size, mtime [ns], the stored hashes): a reader in a loop (the study reduces ~70 models
    from the same body, reduction and ranking files in one process; 0.35 s of hashing a model on
    long) hashes a file once.  A file written again since has another mtime (or size) and is
    hashed again; so that this holds with a file system's coarse timestamps (a write within the
    same few ms can keep the mtime), a file is remembered only once its mtime is over
    ``SETTLED_NS`` old when it is verified."""

    SETTLED_NS = 1_000_000_000

    def __init__(self):
        self.seen = set()

    @staticmethod
    def key(h5, stored):
        """The identity of an open HDF5 object's content, or None when its file has no path."""
        try:
            name = os.path.realpath(h5.file.filename)
            st = os.stat(name)
        except (AttributeError, OSError, TypeError):
            return None
        return (name, h5.name, st.st_size, st.st_mtime_ns, str(stored))


VERIFIED = VerifiedContent()


def content_problem(h5, path, kind: str = "") -> str | None:
    """The one-line message (naming the file and the dataset) if a numeric dataset of an open HDF5
    file is not what its writer hashed (``content_hashes``: changed, or removed), else None.  A
    file without the attribute (written by hand, or by a tool outside the project) is not judged
    here; its reader's own checks apply.  Readers ask after their structural checks, so a NaN or a
    wrong shape is named as such, and a plausible changed number by this.  kind: what the file is,
    to begin the message ("load-aware ranking")."""
    stored = h5.attrs.get(CONTENT_ATTR)
    if stored is None:
        return None
    key = VERIFIED.key(h5, stored)
    if key is not None and key in VERIFIED.seen:
        return None
    where = f"{kind} {path}" if kind else str(path)
    remedy = f"rerun its target: snakemake --cores 2 --forcerun {path}"
    try:
        stored = json.loads(stored)
    except (TypeError, ValueError):
        return f"{where}: attribute {CONTENT_ATTR} unreadable (the file was edited): {remedy}"
    for name, digest in stored.items():
        if name not in h5:
            return f"{where}: dataset '{name}' missing (the file was edited after it was written): {remedy}"
        if dataset_digest(h5[name][()]) != digest:
            return (f"{where}: dataset '{name}' was changed after the file was written (its content "
                    f"hash differs): {remedy}")
    if key is not None and time.time_ns() - key[3] > VERIFIED.SETTLED_NS:
        VERIFIED.seen.add(key)
    return None


def check_content(h5, path) -> None:
    """ValueError with ``content_problem``'s message, if any."""
    problem = content_problem(h5, path)
    if problem:
        raise ValueError(problem)


def write_json(path: str | Path, data: dict, record: dict | None = None) -> None:
    """Write JSON atomically, with the provenance record (default ``provenance()``) under the key
    ``provenance`` (merged into a dict already there; a JSON list gets a sidecar)."""
    record = record or provenance()
    if isinstance(data, dict):
        data = {**data, "provenance": {**record, **(data.get("provenance") or {})}}
    else:
        write_sidecar(path, record)
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


def write_text(path: str | Path, text: str, record: dict | None = None) -> None:
    """Write text atomically, with the provenance record (default ``provenance()``): a last
    line ``<!-- provenance: ... -->`` in Markdown (``.md``), else a sidecar ``{path}.provenance.json``
    (``write_sidecar``; both files appear together, or neither)."""
    record = record or provenance()
    if Path(path).suffix.lower() == ".md":
        with atomic_path(path) as tmp:
            tmp.write_text(text + ("" if text.endswith("\n") else "\n") + markdown_comment(record))
        return
    with atomic_path(sidecar_path(path)) as side, atomic_path(path) as tmp:
        tmp.write_text(text)
        side.write_text(json.dumps(record, indent=2, sort_keys=True) + "\n")


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


def write_csv(path: str | Path, rows: list[dict], columns, digits: int = 8,
              record: dict | None = None) -> None:
    """Write dict rows as a CSV table atomically (format: ``csv_text``), its provenance in a
    sidecar (``write_text``)."""
    write_text(path, csv_text(rows, columns, digits), record)


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
