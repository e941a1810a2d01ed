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

Before libyaml sees a text, :func:`check_limits` bounds what it may hold, so that no input can
hang or crash the loader: at most ``MAX_BYTES`` of UTF-8, nesting at most ``MAX_DEPTH`` deep
(libyaml composes nodes recursively in C: a document nested 100,000 deep overflows its stack),
and no aliases (``*name``: each one is a reference that later code follows as a copy, so nine
nested aliases of nine make 9^9 values, the "billion laughs"; the project's files need none).
The check runs PyYAML's pure-Python scanner, which keeps its state in lists, not on the stack,
and stops at the first token past a limit.
"""
from __future__ import annotations

import copy
import os
from pathlib import Path

import yaml

_BASE_LOADER = getattr(yaml, "CSafeLoader", yaml.SafeLoader)

MAX_BYTES = 1 << 20          # 1 MiB: the config file is ~6 kB, a scene < 2 kB
MAX_DEPTH = 32               # nested collections: the config nests 4 deep


class YAMLInputError(ValueError):
    """A YAML file that is not read at all: not UTF-8, too large, too deeply nested, or holding
    an alias (one-line message naming the file, the line and the limit)."""

_OPEN = (yaml.BlockMappingStartToken, yaml.BlockSequenceStartToken, yaml.FlowMappingStartToken,
         yaml.FlowSequenceStartToken)
_CLOSE = (yaml.BlockEndToken, yaml.FlowMappingEndToken, yaml.FlowSequenceEndToken)


def check_limits(text: str, origin: str = "<yaml>") -> None:
    """YAMLInputError unless ``text`` is at most MAX_BYTES, nests at most MAX_DEPTH collections
    and holds no alias; yaml.YAMLError for a text the scanner cannot read."""
    size = len(text.encode("utf-8", "surrogatepass"))
    if size > MAX_BYTES:
        raise YAMLInputError(f"{origin}: {size} bytes, more than the {MAX_BYTES} a YAML file of "
                             f"this project may hold")
    depth = 0
    for token in yaml.scan(text, Loader=yaml.SafeLoader):
        if isinstance(token, _OPEN):
            depth += 1
            if depth > MAX_DEPTH:
                raise YAMLInputError(f"{origin} line {token.start_mark.line + 1}: nested more than "
                                     f"{MAX_DEPTH} deep (the limit of this project's YAML files)")
        elif isinstance(token, _CLOSE):
            depth -= 1
        elif isinstance(token, yaml.AliasToken):
            raise YAMLInputError(f"{origin} line {token.start_mark.line + 1}: alias '*{token.value}' "
                                 f"(aliases are not allowed in this project's YAML files: write the "
                                 f"value out)")


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
    """The YAML document in ``text``; YAMLInputError or DuplicateKeyError (naming ``origin``), or
    yaml.YAMLError."""
    check_limits(text, str(origin))
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
    the file is unchanged); YAMLInputError, DuplicateKeyError, yaml.YAMLError or OSError."""
    key = file_key(path)
    if key not in _FILE_CACHE:
        if key[1] > MAX_BYTES:      # not read at all
            raise YAMLInputError(f"{path}: {key[1]} bytes, more than the {MAX_BYTES} a YAML file "
                                 f"of this project may hold")
        try:
            text = Path(path).read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise YAMLInputError(f"{path}: not UTF-8 text (byte {exc.start})") from None
        document = load_text(text, origin=str(path))
        if len(_FILE_CACHE) >= 64:
            _FILE_CACHE.clear()
        _FILE_CACHE[key] = document
    return copy.deepcopy(_FILE_CACHE[key])


__all__ = ["DuplicateKeyError", "StrictLoader", "YAMLInputError", "check_limits", "file_key", "load_file",
           "load_text"]
