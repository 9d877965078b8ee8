"""Check the package's layout rules from its source, without importing it.

Rules
-----
* A method module (``<pkg>/methods/<name>.py``, or anything under ``<pkg>/methods/<name>/``) imports
  stages and building blocks only: never another method module, never the ``<pkg>.methods`` package
  itself, never a scenario (``<pkg>.scenarios`` or anything under it) and never a module named
  ``simulate``. The registry ``<pkg>/methods/__init__.py`` may import its methods but not scenarios or
  simulators.
* No import cycles between modules of the package. Every import statement counts, including those inside
  functions and under ``if TYPE_CHECKING:``.
* No file of the command-line package (``<pkg>/cli/``, or ``<pkg>/cli.py``) is longer than
  :data:`MAX_CLI_LINES` lines.
* Every import of a module inside the package names a module that exists.
* Floors (:data:`FLOORS`, for the package named :data:`FLOORS_PACKAGE`): every module sits on one floor,
  and imports only modules on its own floor or below. An import that runs up is a violation, and so is
  a module on no floor.
* No module imports a private (underscore) name of another module: ``from X import _f`` is a
  violation unless ``_f`` is a submodule of a package holding the importer (``cli._common`` for the
  modules of ``cli``); a private module (``a._b``) is imported only from inside its package ``a``.

Imports of modules outside the package are ignored. An import ``from X import name`` depends on the
submodule ``X.name`` when that module exists, else on ``X``; importing ``a.b.c`` depends on ``a.b.c`` only
(parent packages are not added).

Usage::

    python tools/check_layout.py [--floors] [PACKAGE_DIR]

prints one line per violation and exits 1, or prints ``layout ok: N modules, M imports`` and exits 0;
``--floors`` prints the table of floors first.
``PACKAGE_DIR`` defaults to ``src/imucalib`` of the repository holding this script.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections import deque
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["FLOORS", "FLOORS_PACKAGE", "MAX_CLI_LINES", "Import", "Layout", "check", "find_cycles", "floor_of",
           "floor_table", "main", "scan", "strongly_connected"]

#: longest allowed file in the command-line package, in lines
MAX_CLI_LINES = 400

#: the package :data:`FLOORS` describes
FLOORS_PACKAGE = "imucalib"

#: The floors of the package, lowest first: (name, what lives there, modules and packages relative to the
#: package; ``""`` is the package's own ``__init__``). A module is on the floor of its longest listed
#: prefix (``methods.x`` is on the floor of ``methods``). A module imports its own floor and those below.
FLOORS: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("foundations", "units, records, models, rotations, solvers, residuals, pose plans, method declarations, "
     "the fit report's fields",
     ("constants", "presets", "methodinfo", "fitreport", "reportfields", "recording", "conventions", "models",
      "kinematics", "solve", "residuals", "plans", "progress", "printable")),
    ("readers", "files and streams in and out", ("io",)),
    ("records", "the calibration record: its models, its file and its temperature model",
     ("calibration", "calibfile", "thermalmodel")),
    ("fits", "the estimators and the fit figures every method reports", ("metrics", "fit")),
    ("segmentation", "poses and motions found (their threshold scan runs the fits), thermal models, noise, verdict",
     ("segment", "thermal", "verdict", "noise")),
    ("results", "the methods' shared ending, the exports and reports", ("assembly", "export", "report", "upright")),
    ("sessions", "the simulated sessions (their truth is a calibration); reading any input the command line takes",
     ("sessions", "reading")),
    ("simulators", "simulated sessions with their truth", ("scenarios",)),
    ("methods", "the published methods over the shared stages", ("methods",)),
    ("services", "validation, comparison, guided recording, batch runs and the calibration store",
     ("comparison", "crossval", "validation", "record", "batch", "batch_manifest", "rowerrors", "store")),
    ("experiments", "the papers' experiments and studies: methods run on simulated sessions",
     ("experiments",)),
    ("interface", "the package's API and the command line", ("", "cli")),
)

REPO_ROOT = Path(__file__).resolve().parent.parent
DEFAULT_PACKAGE = REPO_ROOT / "src" / "imucalib"


@dataclass(frozen=True)
class Import:
    """One resolved import of a package module by another.

    Attributes
    ----------
    source : str
        Dotted name of the importing module.
    target : str
        Dotted name of the imported module (may not exist; see :attr:`Layout.modules`).
    path : Path
        File holding the import statement.
    line : int
        Line of the import statement.
    type_only : bool
        True when the statement sits under ``if TYPE_CHECKING:``.
    name : str or None
        For ``from target import name`` where ``target.name`` is not a module: the name imported.
    """

    source: str
    target: str
    path: Path
    line: int
    type_only: bool = False
    name: str | None = None


@dataclass
class Layout:
    """The modules of a package and the imports between them.

    Attributes
    ----------
    root : Path
        The package directory.
    name : str
        The package's dotted name (the directory's name).
    modules : dict[str, Path]
        Dotted module name → file (``__init__.py`` for packages).
    packages : set[str]
        Names in :attr:`modules` that are packages.
    imports : list[Import]
        Every import of a module inside the package, in file and line order.
    errors : list[str]
        Files that could not be parsed.
    """

    root: Path
    name: str
    modules: dict[str, Path] = field(default_factory=dict)
    packages: set[str] = field(default_factory=set)
    imports: list[Import] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)

    def graph(self) -> dict[str, set[str]]:
        """Module → modules it imports (existing modules only, no self-imports)."""
        g: dict[str, set[str]] = {m: set() for m in self.modules}
        for imp in self.imports:
            if imp.target in self.modules and imp.target != imp.source:
                g[imp.source].add(imp.target)
        return g

    def where(self, source: str, target: str) -> Import:
        """The first import of ``target`` by ``source``."""
        return next(i for i in self.imports if i.source == source and i.target == target)


def _display(path: Path) -> str:
    """``path`` relative to the working directory when below it, else as given."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def _module_files(root: Path) -> Iterator[Path]:
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if any(part == "__pycache__" or part.startswith(".") for part in rel.parts):
            continue
        yield path


def _module_name(root: Path, name: str, path: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join([name, *parts])


def _is_type_checking(test: ast.expr) -> bool:
    if isinstance(test, ast.Name):
        return test.id == "TYPE_CHECKING"
    return isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"


def _import_nodes(tree: ast.AST) -> Iterator[tuple[ast.Import | ast.ImportFrom, bool]]:
    """Every import statement of ``tree`` (at any depth) and whether it is under ``if TYPE_CHECKING:``."""
    stack: list[tuple[ast.AST, bool]] = [(tree, False)]
    while stack:
        node, type_only = stack.pop()
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node, type_only
            continue
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            stack.extend((child, True) for child in node.body)
            stack.extend((child, type_only) for child in node.orelse)
            stack.append((node.test, type_only))
            continue
        stack.extend((child, type_only) for child in ast.iter_child_nodes(node))


def _resolve(layout: Layout, module: str, node: ast.Import | ast.ImportFrom) -> list[tuple[str, str | None]]:
    """Modules inside the package that ``node`` (a statement of ``module``) imports, each with the name it
    takes from that module (``from X import name`` where ``X.name`` is no module), else None."""
    if isinstance(node, ast.Import):
        return [(alias.name, None) for alias in node.names if alias.name.split(".")[0] == layout.name]
    if node.level:
        base = module.split(".") if module in layout.packages else module.split(".")[:-1]
        up = node.level - 1
        if up >= len(base):
            # above the top of the package: kept as written, so that it is reported as a missing module
            return [("." * node.level + (node.module or ""), None)]
        target = ".".join([*base[: len(base) - up], *(node.module.split(".") if node.module else [])])
    else:
        target = node.module or ""
        if target.split(".")[0] != layout.name:
            return []
    out = []
    for alias in node.names:
        sub = f"{target}.{alias.name}"
        if alias.name != "*" and sub in layout.modules:
            out.append((sub, None))
        else:
            out.append((target, None if alias.name == "*" else alias.name))
    return list(dict.fromkeys(out))


def scan(package_dir: Path) -> Layout:
    """Read every module of ``package_dir`` and the imports between them.

    Parameters
    ----------
    package_dir : Path
        The package directory (holding ``__init__.py``); its name is the package's name.

    Returns
    -------
    Layout
        Modules, packages and resolved in-package imports.
    """
    root = Path(package_dir)
    layout = Layout(root=root, name=root.resolve().name)
    files = list(_module_files(root))
    for path in files:
        name = _module_name(root, layout.name, path)
        layout.modules[name] = path
        if path.name == "__init__.py":
            layout.packages.add(name)
    for path in files:
        source = _module_name(root, layout.name, path)
        try:
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        except (SyntaxError, UnicodeDecodeError, ValueError) as exc:
            layout.errors.append(f"unreadable: {_display(path)}: {exc}")
            continue
        found = []
        for node, type_only in _import_nodes(tree):
            for target, name in _resolve(layout, source, node):
                found.append(Import(source, target, path, node.lineno, type_only, name))
        layout.imports.extend(sorted(found, key=lambda i: (i.line, i.target)))
    return layout


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of ``graph`` (Tarjan's algorithm, iterative).

    Parameters
    ----------
    graph : dict[str, set[str]]
        Node → successors; every successor must be a key.

    Returns
    -------
    list[list[str]]
        The components, each sorted, in reverse topological order.
    """
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    components: list[list[str]] = []
    counter = 0
    for start in sorted(graph):
        if start in index:
            continue
        work: list[tuple[str, Iterator[str]]] = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter
        counter += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, successors = work[-1]
            for succ in successors:
                if succ not in index:
                    index[succ] = low[succ] = counter
                    counter += 1
                    stack.append(succ)
                    on_stack.add(succ)
                    work.append((succ, iter(sorted(graph[succ]))))
                    break
                if succ in on_stack:
                    low[node] = min(low[node], index[succ])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    components.append(sorted(component))
    return components


def _shortest_cycle(graph: dict[str, set[str]], start: str, members: set[str]) -> list[str]:
    """Shortest path ``start → … → start`` inside ``members`` (breadth-first)."""
    previous: dict[str, str] = {}
    queue = deque([start])
    seen = {start}
    while queue:
        node = queue.popleft()
        for succ in sorted(graph[node] & members):
            if succ == start:
                path = [node]
                while path[-1] != start:
                    path.append(previous[path[-1]])
                return [*reversed(path), start]
            if succ not in seen:
                seen.add(succ)
                previous[succ] = node
                queue.append(succ)
    return []


def find_cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Import cycles of ``graph``: for each strongly connected component, shortest cycles covering it.

    Parameters
    ----------
    graph : dict[str, set[str]]
        Node → successors (self-loops are ignored).

    Returns
    -------
    list[list[str]]
        Cycles as node chains whose last node repeats the first, e.g. ``["a", "b", "a"]``.
    """
    cycles = []
    for component in strongly_connected(graph):
        if len(component) < 2:
            continue
        members = set(component)
        covered: set[str] = set()
        for node in component:
            if node in covered:
                continue
            cycle = _shortest_cycle(graph, node, members)
            covered.update(cycle)
            if cycle:
                # start each chain at its smallest name so that equal cycles read the same
                ring = cycle[:-1]
                k = ring.index(min(ring))
                ring = ring[k:] + ring[:k]
                chain = [*ring, ring[0]]
                if chain not in cycles:
                    cycles.append(chain)
    return cycles


def _method_of(layout: Layout, module: str) -> str | None:
    """The method a module belongs to (``<pkg>.methods.<name>``), ``""`` for the registry, else None."""
    prefix = f"{layout.name}.methods"
    if module == prefix:
        return ""
    if module.startswith(prefix + "."):
        return module[len(prefix) + 1:].split(".")[0]
    return None


def _method_violations(layout: Layout) -> Iterable[str]:
    scenarios = f"{layout.name}.scenarios"
    for imp in layout.imports:
        method = _method_of(layout, imp.source)
        if method is None:
            continue
        at = f"({_display(imp.path)}:{imp.line})"
        target = imp.target
        if target == scenarios or target.startswith(scenarios + ".") or target.split(".")[-1] == "simulate":
            kind = "registry imports scenario" if method == "" else "method imports scenario"
            yield f"{kind}: {imp.source} → {target} {at}"
            continue
        if method == "":
            continue
        other = _method_of(layout, target)
        if other is not None and other != method:
            what = "the methods package" if other == "" else "another method"
            yield f"method imports {what}: {imp.source} → {target} {at}"


def _cycle_violations(layout: Layout) -> Iterable[str]:
    graph = layout.graph()
    for chain in find_cycles(graph):
        edges = []
        for a, b in zip(chain, chain[1:], strict=False):
            imp = layout.where(a, b)
            note = " type-checking only" if imp.type_only else ""
            edges.append(f"{_display(imp.path)}:{imp.line}{note}")
        yield f"import cycle: {' → '.join(chain)} ({'; '.join(edges)})"


def _cli_files(layout: Layout) -> list[Path]:
    files = []
    single = layout.root / "cli.py"
    if single.is_file():
        files.append(single)
    folder = layout.root / "cli"
    if folder.is_dir():
        files.extend(_module_files(folder))
    return files


def _cli_violations(layout: Layout, max_lines: int = MAX_CLI_LINES) -> Iterable[str]:
    for path in _cli_files(layout):
        n = len(path.read_text(encoding="utf-8").splitlines())
        if n > max_lines:
            yield f"cli file too long: {_display(path)} has {n} lines (max {max_lines})"


def _missing_violations(layout: Layout) -> Iterable[str]:
    for imp in layout.imports:
        if imp.target not in layout.modules:
            yield f"missing module: {imp.source} imports {imp.target} ({_display(imp.path)}:{imp.line})"


def floor_of(layout: Layout, module: str, floors=FLOORS) -> int | None:
    """Index in ``floors`` of ``module``'s floor (its longest listed prefix), or None when on no floor."""
    rel = module[len(layout.name) + 1:] if module != layout.name else ""
    best, where = -1, None
    for index, (_, _, members) in enumerate(floors):
        for member in members:
            if member == "" and rel != "":
                continue
            if rel == member or rel.startswith(member + ".") and member != "":
                if len(member) > best:
                    best, where = len(member), index
    return where


def floor_table(floors=FLOORS) -> str:
    """The floors as a text table, highest first."""
    rows = [(str(i), name, ", ".join(m or "(package)" for m in members), what)
            for i, (name, what, members) in enumerate(floors)][::-1]
    head = ("#", "floor", "modules", "what lives there")
    widths = [max(len(r[k]) for r in [*rows, head]) for k in range(3)]
    lines = [f"{head[0]:>{widths[0]}}  {head[1]:<{widths[1]}}  {head[2]:<{widths[2]}}  {head[3]}"]
    lines += [f"{r[0]:>{widths[0]}}  {r[1]:<{widths[1]}}  {r[2]:<{widths[2]}}  {r[3]}" for r in rows]
    return "\n".join(lines)


def _floor_violations(layout: Layout, floors) -> Iterable[str]:
    if not floors:
        return
    for module in sorted(layout.modules):
        if floor_of(layout, module, floors) is None:
            yield f"module on no floor: {module} ({_display(layout.modules[module])}); add it to FLOORS"
    for imp in layout.imports:
        if imp.target not in layout.modules or imp.target == imp.source:
            continue
        low, high = floor_of(layout, imp.source, floors), floor_of(layout, imp.target, floors)
        if low is not None and high is not None and high > low:
            yield (f"import runs up: {imp.source} ({floors[low][0]}) → {imp.target} ({floors[high][0]}) "
                   f"({_display(imp.path)}:{imp.line})")


def _private(part: str) -> bool:
    return part.startswith("_") and not (part.startswith("__") and part.endswith("__"))


def _private_violations(layout: Layout) -> Iterable[str]:
    for imp in layout.imports:
        at = f"({_display(imp.path)}:{imp.line})"
        parts = imp.target.split(".")
        for k, part in enumerate(parts[1:], start=1):
            inside = ".".join(parts[:k])  # the package holding the private module
            if _private(part) and not (imp.source == inside or imp.source.startswith(inside + ".")):
                yield f"private module imported from outside its package: {imp.source} → {imp.target} {at}"
                break
        if imp.name is not None and _private(imp.name) and imp.target != imp.source:
            yield f"private name imported from another module: {imp.source} → {imp.target}.{imp.name} {at}"


def check(package_dir: Path, floors=None) -> list[str]:
    """Every layout violation of the package at ``package_dir``.

    Parameters
    ----------
    package_dir : Path
        The package directory, e.g. ``src/imucalib``.
    floors : tuple, optional
        Floors as in :data:`FLOORS`; default :data:`FLOORS` for the package named :data:`FLOORS_PACKAGE`,
        none for any other (``()`` checks none).

    Returns
    -------
    list[str]
        One readable message per violation (kind, modules, ``file:line`` where applicable); empty when
        the layout is clean.
    """
    return violations(scan(Path(package_dir)), floors)


def violations(layout: Layout, floors=None) -> list[str]:
    """Every layout violation of a package already scanned (:func:`scan`); ``floors`` as in :func:`check`."""
    if floors is None:
        floors = FLOORS if layout.name == FLOORS_PACKAGE else ()
    return [
        *layout.errors,
        *_method_violations(layout),
        *_cycle_violations(layout),
        *_cli_violations(layout),
        *_missing_violations(layout),
        *_floor_violations(layout, floors),
        *dict.fromkeys(_private_violations(layout)),
    ]


def main(argv: list[str] | None = None) -> int:
    """Command-line entry point; returns the exit status."""
    parser = argparse.ArgumentParser(description="Check the package's import and size rules.")
    parser.add_argument("package_dir", nargs="?", type=Path, default=DEFAULT_PACKAGE,
                        help=f"package directory (default: {_display(DEFAULT_PACKAGE)})")
    parser.add_argument("--floors", action="store_true", help="print the table of floors first")
    args = parser.parse_args(argv)
    if args.floors:
        print(floor_table())
    if not args.package_dir.is_dir():
        print(f"not a directory: {args.package_dir}", file=sys.stderr)
        return 2
    layout = scan(args.package_dir)
    found = violations(layout)
    if found:
        for message in found:
            print(message)
        return 1
    edges = sum(len(targets) for targets in layout.graph().values())
    print(f"layout ok: {len(layout.modules)} modules, {edges} imports")
    return 0


if __name__ == "__main__":
    sys.exit(main())
