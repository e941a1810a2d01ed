"""Results of deterministic reading steps kept between invocations of the workflow.

Every ``snakemake`` invocation, a no-op included, reads the configuration and the scene
files before it builds the DAG: each ``{value, unit}`` entry goes through pint
(:mod:`gimbal_reduction.workflow.units`) and the configuration through its JSON schema
(:mod:`gimbal_reduction.workflow.config`).  Importing pint and jsonschema and building the
unit registry costs ~0.3-0.5 s of a no-op's ~2 s, for answers that depend only on their
inputs and on the code that computes them.

A :class:`DiskMemo` keeps such answers in a JSON file beside Snakemake's own metadata,
``.snakemake/gimbal_reduction-memo-NAME.json`` of the working directory, and only when that
folder exists (a Snakemake project): elsewhere (a test's temporary folder, an installed
package) nothing is written and every answer is computed.  The file holds a ``salt``: the
digest of everything the answers depend on besides their keys (the computing modules'
sources, the schema, the library versions); a file with another salt is ignored and
replaced.  Only successful answers are kept, so an error is always computed and reported
afresh.  Writes are atomic (a temporary file renamed over the old one); two processes
writing at once lose at most one another's new entries, which are computed again later.
"""
from __future__ import annotations

import hashlib
import json
import os
from importlib import metadata
from pathlib import Path

FOLDER = Path(".snakemake")


def salt(*parts: str, files: tuple[Path, ...] = (), distributions: tuple[str, ...] = ()) -> str:
    """sha256 of ``parts``, the bytes of ``files`` and the versions of the installed
    ``distributions``: what a memo's answers depend on besides their keys."""
    digest = hashlib.sha256()
    for part in parts:
        digest.update(part.encode() + b"\0")
    for path in files:
        digest.update(Path(path).read_bytes() + b"\0")
    for name in distributions:
        try:
            digest.update(f"{name}=={metadata.version(name)}\0".encode())
        except metadata.PackageNotFoundError:
            digest.update(f"{name} missing\0".encode())
    return digest.hexdigest()


class DiskMemo:
    """A persistent mapping key (str) -> JSON value, valid for one ``salt`` (module docstring).

    ``salt`` is a callable, evaluated once, on first use: a memo that is never consulted
    reads no file."""

    def __init__(self, name: str, salt_of):
        self.name = name
        self._salt_of = salt_of
        self._entries: dict | None = None
        self._salt: str | None = None

    @property
    def path(self) -> Path:
        return FOLDER / f"gimbal_reduction-memo-{self.name}.json"

    def _load(self) -> dict:
        if self._entries is None:
            self._salt = self._salt_of()
            self._entries = {}
            try:
                data = json.loads(self.path.read_text())
            except (OSError, ValueError):
                data = None
            if isinstance(data, dict) and data.get("salt") == self._salt \
                    and isinstance(data.get("entries"), dict):
                self._entries = data["entries"]
        return self._entries

    def get(self, key: str):
        """The kept answer for ``key``, or None."""
        return self._load().get(key)

    def put(self, key: str, value) -> None:
        """Keep ``value`` (JSON) for ``key``, and write the file if the folder exists."""
        entries = self._load()
        if entries.get(key) == value:
            return
        entries[key] = value
        if not FOLDER.is_dir():
            return
        tmp = self.path.with_name(f".{self.path.name}.{os.getpid()}.tmp")
        try:
            tmp.write_text(json.dumps({"salt": self._salt, "entries": entries}))
            os.replace(tmp, self.path)
        except OSError:
            tmp.unlink(missing_ok=True)


__all__ = ["DiskMemo", "FOLDER", "salt"]
