"""The project's import graph, read from the source with ``ast``: what code a stage runs.

Every stage is run as ``python -m <module>``. The code it runs is that module and,
transitively, every project module it imports (with the ``__init__.py`` of each
package on the way), plus the data files that code reads (:data:`DATA_FILES`).
:func:`code_hash` hashes that code with comments and docstrings left out (a
normalised ``ast`` dump), so a Snakemake rule that carries
``params: code=code_hash("gimbal_reduction.solver.fe.modes")`` reruns when, and only when, code its
stage runs changes in substance.

The same graph checks the layering of the packages (:func:`violations`): imports
point only downward in :data:`LAYERS`; ``gimbal_reduction.solver.fe`` and ``gimbal_reduction.solver.dynamics`` never
import each other; there is no import cycle between files; and no project module
is imported inside a function.

``python -m gimbal_reduction.workflow.imports gimbal_reduction.solver.fe.modes``  lists the files a stage runs;
``python -m gimbal_reduction.workflow.imports --check``          lists the layering violations.
"""
from __future__ import annotations

import argparse
import ast
import functools
import hashlib
import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = "gimbal_reduction"
PACKAGES = (PACKAGE,)

# Non-Python files that a module reads, as paths relative to the project root: they are
# part of the code of every stage that imports the module.
DATA_FILES = {"gimbal_reduction.workflow.config": ("gimbal_reduction/workflow/config.schema.yaml",)}

# The layers, lowest first; a module belongs to the longest prefix listed here (names relative
# to the package: "solver.fe" is gimbal_reduction.solver.fe).  The package's own __init__ is
# the lowest; its notebook API (gimbal_reduction.api) and command line (gimbal_reduction.commands)
# sit on top of every stage.
_LAYERS = (
    ("",),
    ("workflow",),
    ("geometry",),
    ("solver", "solver.bodydata"),
    ("solver.fe", "solver.dynamics"),
    ("reduction",),
    ("results", "results.study", "results.bench"),
    ("api", "commands"),
)
LAYERS = tuple(tuple(f"{PACKAGE}.{p}" if p else PACKAGE for p in layer) for layer in _LAYERS)
# Engines of one layer that must not import each other.
EXCLUSIVE = (("gimbal_reduction.solver.fe", "gimbal_reduction.solver.dynamics"),)


@dataclass(frozen=True)
class Import:
    """One import statement's project target, as written in ``source``."""

    source: str      # importing module
    target: str      # imported project module (the deepest one named)
    line: int
    local: bool      # inside a function (or lambda)


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


@functools.lru_cache(maxsize=None)
def module_files(root: Path = ROOT) -> dict[str, Path]:
    """Every project module -> its file; only folders that are packages (hold ``__init__.py``)."""
    out = {}

    def walk(folder: Path):
        if not (folder / "__init__.py").is_file():
            return
        for path in sorted(folder.iterdir()):
            if path.is_dir():
                walk(path)
            elif path.suffix == ".py":
                out[_module_name(path, root)] = path

    for package in PACKAGES:
        walk(root / package)
    return out


def _resolve(module: str, is_package: bool, node: ast.ImportFrom) -> str:
    """The absolute module name of a (possibly relative) ``from ... import``."""
    if not node.level:
        return node.module or ""
    base = module.split(".")
    base = base if is_package else base[:-1]
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _project_target(name: str, modules) -> str | None:
    """The deepest project module a dotted name names (``a.b.c`` -> ``a.b`` if only that exists)."""
    parts = name.split(".")
    for i in range(len(parts), 0, -1):
        candidate = ".".join(parts[:i])
        if candidate in modules:
            return candidate
    return None


@functools.lru_cache(maxsize=None)
def _parse(path: str, mtime_ns: int, size: int) -> ast.Module:
    """A file's syntax tree, parsed once per file version (callers must not change it)."""
    return ast.parse(Path(path).read_text(), filename=path)


def parse_tree(path: Path) -> ast.Module:
    stat = Path(path).stat()
    return _parse(str(path), stat.st_mtime_ns, stat.st_size)


# nodes that can hold statements (an import is a statement: no expression holds one)
_BLOCKS = (ast.stmt, ast.excepthandler, ast.match_case)


def _raw_imports(tree: ast.Module) -> list[tuple]:
    """The import statements of a syntax tree as plain data: (level, module, names, line, local),
    level and module as in ``ast.ImportFrom`` (level None for ``import a.b``)."""
    found = []

    def visit(node, local):
        for child in ast.iter_child_nodes(node):
            if not isinstance(child, _BLOCKS):
                continue
            if isinstance(child, ast.Import):
                found.append((None, None, [alias.name for alias in child.names], child.lineno, local))
            elif isinstance(child, ast.ImportFrom):
                found.append((child.level, child.module, [alias.name for alias in child.names],
                              child.lineno, local))
            else:
                visit(child, local or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)))

    visit(tree, False)
    return found


def parse_imports(module: str, path: Path, modules, root: Path | None = None) -> list[Import]:
    """The project imports of one file, each marked local when it sits inside a function."""
    is_package = path.name == "__init__.py"
    found = []
    for level, base_module, aliases, line, local in _facts(path, root)["imports"]:
        if level is None:
            names = aliases
        else:
            base = _resolve(module, is_package, ast.ImportFrom(module=base_module, names=[], level=level))
            # "from a.b import c": the submodule a.b.c if it is one, else the module a.b
            names = [f"{base}.{alias}" if f"{base}.{alias}" in modules else base for alias in aliases]
        for name in dict.fromkeys(names):
            target = _project_target(name, modules)
            if target is not None:
                found.append(Import(module, target, line, local))
    return found


@functools.lru_cache(maxsize=None)
def all_imports(root: Path = ROOT) -> tuple[Import, ...]:
    """Every project import of every project module."""
    modules = module_files(root)
    found = tuple(imp for name, path in modules.items()
                  for imp in parse_imports(name, path, modules, root.resolve()))
    _CACHE.save(root.resolve())
    return found


def graph(root: Path = ROOT) -> dict[str, set[str]]:
    """module -> the project modules it imports (module level and function level)."""
    return {name: set(targets) for name, targets in _graph(root).items()}


# Results derived from one version of the import list, keyed by (what, arguments) and kept with
# that list: ``all_imports`` is itself cached, so a cleared cache (a changed tree) gives a new
# list object, and an entry made from another object is made again (an identity test: hashing
# the ~450 imports on every lookup would cost a Snakefile most of its ~50 code hashes).
_DERIVED: dict = {}


def _derived(what: str, key: tuple, root: Path, make):
    found = all_imports(root)
    kept = _DERIVED.get((what, key, root))
    if kept is None or kept[0] is not found:
        kept = (found, make(found))
        _DERIVED[(what, key, root)] = kept
    return kept[1]


def _graph(root: Path) -> dict[str, frozenset[str]]:
    """``graph`` once per version of the import list (a Snakefile asks it for every rule's code hash)."""
    def make(found):
        out = {name: set() for name in module_files(root)}
        for imp in found:
            out[imp.source].add(imp.target)
        return {name: frozenset(targets) for name, targets in out.items()}
    return _derived("graph", (), root, make)


def _parents(module: str) -> list[str]:
    parts = module.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts))]


def closure(*entries: str, root: Path = ROOT) -> list[str]:
    """The project modules that running ``entries`` executes, sorted: the entries, everything they
    import, transitively, and the package ``__init__`` of each on the way."""
    modules, edges = module_files(root), _graph(root)
    unknown = [e for e in entries if e not in modules]
    if unknown:
        raise ValueError(f"unknown project module(s): {', '.join(unknown)}")
    seen, todo = set(), list(entries)
    while todo:
        module = todo.pop()
        if module in seen:
            continue
        seen.add(module)
        todo.extend(edges[module])
        todo.extend(p for p in _parents(module) if p in modules)
    return sorted(seen)


def files(*entries: str, root: Path = ROOT) -> list[str]:
    """The files (relative to the root) that running ``entries`` reads as code: modules and data files."""
    def make(found):
        modules, executed = module_files(root), closure(*entries, root=root)
        prefix = os.path.join(str(root), "")        # module_files joins onto root: a string cut
        out = [str(modules[m])[len(prefix):] if str(modules[m]).startswith(prefix)
               else str(modules[m].relative_to(root)) for m in executed]
        out += [f for m in executed for f in DATA_FILES.get(m, ())]
        return tuple(sorted(set(out)))
    return list(_derived("files", entries, root, make))


def normalised_source(path: Path) -> str:
    """The ``ast`` dump of a file with every docstring left out: blind to comments, docstrings and layout."""
    tree = parse_tree(path)
    docstrings, todo = [], [tree]
    while todo:   # docstrings open module, class and function bodies: statements only are searched
        node = todo.pop()
        todo.extend(child for child in ast.iter_child_nodes(node) if isinstance(child, _BLOCKS))
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
                    and isinstance(body[0].value.value, str):
                docstrings.append((node, body))
                node.body = body[1:]
    try:
        return ast.dump(tree, annotate_fields=True, include_attributes=False)
    finally:
        for node, body in docstrings:   # the cached tree stays as parsed
            node.body = body


# What each file version gives (its imports, the digest of its normalised source) is kept
# between invocations in a cache file beside Snakemake's own metadata, keyed by the file's path,
# size and modification time: a rerun that changed nothing parses nothing.  The key also holds
# the Python version (the ast dump is the interpreter's) and FACTS_VERSION (this module's format).
FACTS_VERSION = 1
CACHE_FILE = Path(".snakemake") / "gimbal_reduction-code-facts.json"


def _file_facts(path: Path) -> dict:
    """{"imports": _raw_imports, "digest": sha256 of the normalised source} of a code file, or
    {"imports": [], "digest": sha256 of the text} of a data file."""
    if path.suffix == ".py":
        return {"imports": _raw_imports(parse_tree(path)),
                "digest": hashlib.sha256(normalised_source(path).encode()).hexdigest()}
    return {"imports": [], "digest": hashlib.sha256(path.read_text().encode()).hexdigest()}


class _FactsCache:
    """The facts of every file read in this process, loaded from and saved to ``CACHE_FILE``."""

    def __init__(self):
        self.entries: dict[str, dict] = {}
        self.loaded: set[Path] = set()
        self.dirty: set[Path] = set()
        self.key = f"{FACTS_VERSION} {sys.version_info[:3]}"

    def _load(self, root: Path):
        self.loaded.add(root)
        try:
            data = json.loads((root / CACHE_FILE).read_text())
        except (OSError, ValueError):
            return
        if isinstance(data, dict) and data.get("key") == self.key and isinstance(data.get("files"), dict):
            for path, entry in data["files"].items():
                self.entries.setdefault(path, entry)

    def get(self, path: Path, root: Path) -> dict:
        return self.get_str(str(path), root)

    def get_str(self, key: str, root: Path) -> dict:
        """``get`` of the file named ``key`` (a string: no Path objects on the no-op's path)."""
        if root not in self.loaded:
            self._load(root)
        stat = os.stat(key)
        entry = self.entries.get(key)
        if entry is None or entry.get("stamp") != [stat.st_mtime_ns, stat.st_size]:
            entry = {"stamp": [stat.st_mtime_ns, stat.st_size], **_file_facts(Path(key))}
            entry["imports"] = [list(i) for i in entry["imports"]]
            self.entries[key] = entry
            self.dirty.add(root)
        return entry

    def save(self, root: Path):
        """Write the cache of ``root`` (atomically; a read-only tree is simply not cached)."""
        if root not in self.dirty:
            return
        prefix = str(root) + "/"
        files = {p: e for p, e in self.entries.items() if p.startswith(prefix)}
        target = root / CACHE_FILE
        try:
            target.parent.mkdir(exist_ok=True)
            tmp = target.with_name(f".{target.name}.{os.getpid()}.tmp")
            tmp.write_text(json.dumps({"key": self.key, "files": files}))
            os.replace(tmp, target)
        except OSError:
            return
        self.dirty.discard(root)


_CACHE = _FactsCache()


def _facts(path: Path, root: Path | None = None) -> dict:
    """The facts of ``path``; given ``root`` (resolved), ``path`` lies under it as given."""
    if root is None:
        path = Path(path).resolve()
        root = next((p for p in path.parents if (p / PACKAGE).is_dir()), path.parent)
    return _CACHE.get(Path(path), root)


def _file_digest(path: Path, root: Path) -> str:
    """sha256 of a code file's normalised source (of a data file's text), per file version."""
    return _facts(path, root)["digest"]


def code_hash(*entries: str, root: Path = ROOT) -> str:
    """Stable 12-hex-digit hash of the code that running ``entries`` executes (:func:`files`)."""
    digest, resolved = hashlib.sha256(), root.resolve()
    for rel in files(*entries, root=root):
        digest.update(json.dumps([rel, _CACHE.get_str(f"{resolved}/{rel}", resolved)["digest"]]).encode())
    _CACHE.save(resolved)
    return digest.hexdigest()[:12]


# ---------------------------------------------------------------------------- layering

def layer(module: str) -> tuple[int, str]:
    """(layer index, the layer's prefix) of a module: the longest prefix named in LAYERS."""
    best = None
    for index, prefixes in enumerate(LAYERS):
        for prefix in prefixes:
            if (module == prefix or module.startswith(prefix + ".")) and (best is None or len(prefix) > len(best[1])):
                best = (index, prefix)
    if best is None:
        raise ValueError(f"module '{module}' is in no layer")
    return best


def cycles(root: Path = ROOT) -> list[list[str]]:
    """Import cycles between files: the strongly connected components of more than one module
    (or a module importing itself), each sorted."""
    edges = graph(root)
    index, low, on_stack, stack, out = {}, {}, set(), [], []

    def strongconnect(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges[v]):
            if w not in index:
                strongconnect(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1 or v in edges[v]:
                out.append(sorted(component))

    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(max(limit, 10 * len(edges) + 100))
    try:
        for v in sorted(edges):
            if v not in index:
                strongconnect(v)
    finally:
        sys.setrecursionlimit(limit)
    return sorted(out)


def violations(root: Path = ROOT) -> list[str]:
    """One line per layering violation: upward imports, imports between the exclusive engines,
    function-local project imports and import cycles."""
    modules = module_files(root)
    out = []
    for imp in all_imports(root):
        where = f"{modules[imp.source].relative_to(root)}:{imp.line}"
        (src_layer, src_prefix), (dst_layer, dst_prefix) = layer(imp.source), layer(imp.target)
        if dst_layer > src_layer:
            out.append(f"{where}: upward import of {imp.target} ({dst_prefix}) from {imp.source} ({src_prefix})")
        for group in EXCLUSIVE:
            if src_prefix in group and dst_prefix in group and src_prefix != dst_prefix:
                out.append(f"{where}: {imp.source} imports {imp.target}: {' and '.join(group)} "
                           "never import each other")
        if imp.local:
            out.append(f"{where}: function-local import of {imp.target}")
    for component in cycles(root):
        out.append(f"import cycle: {' -> '.join(component)}")
    return out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="The project's import graph: a stage's code, or the layering check.")
    parser.add_argument("entries", nargs="*", help="entry modules (python -m X): list their code files and hash")
    parser.add_argument("--check", action="store_true", help="list layering violations; exit 1 if any")
    args = parser.parse_args(argv)
    if args.check:
        found = violations()
        print("\n".join(found) if found else "no layering violations")
        return 1 if found else 0
    if not args.entries:
        parser.error("name entry modules or pass --check")
    try:
        print("\n".join(files(*args.entries)))
        print(f"code hash {code_hash(*args.entries)}")
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
