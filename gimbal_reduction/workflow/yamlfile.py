"""Reading the project's YAML files (config, scenes) strictly: a duplicate key is refused.

PyYAML's ``safe_load`` keeps the last of two equal keys of a mapping and says nothing,
so a value edited in one place and left in another silently wins or loses.
:class:`StrictLoader` is a SafeLoader that, before it builds the Python objects,
walks the document's node tree and raises :class:`DuplicateKeyError` (the dotted key,
the file, the line) on the first mapping that holds a key twice.

The scanner and parser are libyaml's (``yaml.CSafeLoader``, part of Debian's python3-yaml;
the pure-Python SafeLoader where it is missing): 5x faster on the config file, the same
documents.  :func:`load_file` keeps each parsed file in process, keyed by its path, size and
modification time, and hands out deep copies: a study process reads the config and the
scene ~150 times (``gimbal_reduction.results.study.run_scene`` runs ~50 models through the per-model
command lines), which cost it ~10 s of parsing.
"""
from __future__ import annotations

import copy
import os
from pathlib import Path

import yaml

_BASE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)


class DuplicateKeyError(ValueError):
    """A mapping holding one key twice: ``key`` (dotted), ``path`` (file), ``line`` (1-based)."""

    def __init__(self, key: str, path: str, line: int):
        super().__init__(f"{path} line {line}: duplicate key '{key}' (the last value would silently win)")
        self.key, self.path, self.line = key, path, line


class StrictLoader(_BASE_LOADER):
    """SafeLoader (libyaml's where available) that refuses duplicate mapping keys
    (``DuplicateKeyError``)."""

    origin = "<yaml>"

    def get_single_data(self):
        node = self.get_single_node()
        if node is None:
            return None
        self._check_keys(node, ())
        return self.construct_document(node)

    def _check_keys(self, node, where):
        if isinstance(node, yaml.MappingNode):
            seen = set()
            for key_node, value_node in node.value:
                if isinstance(key_node, yaml.ScalarNode):
                    key = key_node.value
                    if key != "<<" and key in seen:
                        raise DuplicateKeyError(".".join((*where, key)), self.origin,
                                                key_node.start_mark.line + 1)
                    seen.add(key)
                    child = (*where, key)
                else:
                    child = (*where, "?")
                self._check_keys(value_node, child)
        elif isinstance(node, yaml.SequenceNode):
            for i, item in enumerate(node.value):
                self._check_keys(item, (*where, f"[{i}]") if where else (f"[{i}]",))


def load_text(text: str, origin: str = "<yaml>"):
    """The YAML document in ``text``; DuplicateKeyError (naming ``origin``) or yaml.YAMLError."""
    loader = StrictLoader(text)
    loader.origin = str(origin)
    try:
        return loader.get_single_data()
    finally:
        loader.dispose()


_FILE_CACHE: dict = {}


def file_key(path: str | Path):
    """(absolute path, size, modification time in ns) of an existing file: a rewritten file
    gets a new key.  OSError if it cannot be read."""
    st = os.stat(path)
    return (os.path.abspath(path), st.st_size, st.st_mtime_ns)


def load_file(path: str | Path):
    """The YAML document of file ``path`` (a deep copy of the one parsed in this process, if
    the file is unchanged); DuplicateKeyError, yaml.YAMLError or OSError."""
    key = file_key(path)
    if key not in _FILE_CACHE:
        document = load_text(Path(path).read_text(), origin=str(path))
        if len(_FILE_CACHE) >= 64:
            _FILE_CACHE.clear()
        _FILE_CACHE[key] = document
    return copy.deepcopy(_FILE_CACHE[key])


__all__ = ["DuplicateKeyError", "StrictLoader", "file_key", "load_file", "load_text"]
