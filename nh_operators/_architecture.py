"""The package's layout as data: its wings, their order, and the imports between modules.

The package is laid out in *wings*, one folder per role. A wing imports only the wings
beneath it (a lower level) and the private helpers at the root (``_backend``,
``_constants``, ...); the root helpers import no wing; ``nh_operators/__init__.py`` is the
curated API on top. No two modules import each other, directly or around a loop.

Everything here reads source files with :mod:`ast` (nothing is imported), so the same
functions check a deliberately broken tree in the tests, check the package itself in
``tests/test_layers.py``, and draw ``docs/architecture.rst`` at build time. An import
inside a function counts like one at the top of a module.
"""

import ast
from dataclasses import dataclass
from pathlib import Path

__all__ = ["WINGS", "Import", "import_graph", "layer_violations", "import_cycles",
           "wing_of", "wing_imports"]

#: wing -> (level, role). A wing may import the wings of a lower level only.
WINGS = {
    "potentials": (0, "potentials: the generator's B-splines, physical and typed potentials, "
                      "their checks and domain"),
    "models": (0, "networks: DeepONet, TraONet, VaRONet, MambONet, FNO; batched prediction"),
    "solvers": (1, "classical integrators, the reference solve, the adaptive classical solve"),
    "data": (2, "datasets with exact labels: generation, HDF5, DeepXDE's operator data"),
    "training": (3, "DeepXDE's training loop, schedules, checkpoints, tuning"),
    "evaluation": (4, "methods, metrics, timing, reports, work precision, stability, figures"),
    "solving": (5, "solve to a tolerance: estimate, calibration, contract, shipped weights"),
    "cli": (6, "the nh-operators command, one module per command family"),
}


@dataclass(frozen=True)
class Import:
    """One import statement's arrow: ``source`` imports ``target`` at ``line``."""

    source: str
    target: str
    line: int


def _modules(root, package):
    mods = {}
    for path in sorted(Path(root).rglob("*.py")):
        parts = path.relative_to(root).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        mods[".".join((package,) + parts)] = path
    return mods


def _is_package(path):
    return path.name == "__init__.py"


def import_graph(root, package="nh_operators"):
    """Every import between the modules of a package, read from its source.

    Args:
        root: the package folder (holding ``__init__.py``).
        package: its import name.

    Returns:
        dict module -> list of :class:`Import` (to modules of the same package only). A
        wing's ``__init__`` is the module named after the wing. ``from .x import y``
        points at ``x.y`` when that is a module, else at ``x``.

    Example:
        >>> from pathlib import Path
        >>> import nh_operators
        >>> graph = import_graph(Path(nh_operators.__file__).parent)
        >>> edges = graph["nh_operators.solvers.resolution"]
        >>> "nh_operators.solvers.schemes" in {i.target for i in edges}
        True
    """
    mods = _modules(root, package)
    graph = {}
    for name, path in mods.items():
        here = name if _is_package(path) else name.rpartition(".")[0]
        arrows = []
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = here.split(".")
                    base = base[:len(base) - node.level + 1]
                    module = ".".join(base + ([node.module] if node.module else []))
                else:
                    module = node.module or ""
                for alias in node.names:
                    sub = f"{module}.{alias.name}"
                    target = sub if sub in mods else module
                    if target in mods:
                        arrows.append(Import(name, target, node.lineno))
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name in mods:
                        arrows.append(Import(name, alias.name, node.lineno))
        graph[name] = [a for a in arrows if a.target != name]
    return graph


def wing_of(module, package="nh_operators"):
    """The wing a module belongs to, ``None`` for a root helper, ``""`` for the package."""
    parts = module.split(".")[1:]
    if not parts or parts == ["__main__"]:  # the package itself and ``python -m`` are on top
        return ""
    return parts[0] if len(parts) > 1 or not parts[0].startswith("_") else None


def layer_violations(graph, wings=None, package="nh_operators"):
    """The imports that break the layering rule, as messages.

    Args:
        graph: from :func:`import_graph`.
        wings: wing -> (level, role), default :data:`WINGS`.
        package: the package's import name.

    Returns:
        list of strings, one per offending import, naming both modules, the line and the
        rule; empty when the layout holds. A folder that is not a declared wing is
        reported too.
    """
    wings = WINGS if wings is None else wings
    problems = []
    for source, arrows in graph.items():
        w = wing_of(source, package)
        if w and w not in wings:
            problems.append(f"{source} is in folder {w!r}, which is not a declared wing")
            continue
        for a in arrows:
            t = wing_of(a.target, package)
            if w == "" or t == w:
                continue  # the curated API on top; imports inside a wing
            if t == "":
                problems.append(f"{source} imports the package itself ({package}) at line "
                                f"{a.line}: import from the wing that owns the name")
            elif w is None and t is not None:
                problems.append(f"{source} (a root helper) imports {a.target} at line "
                                f"{a.line}: root helpers import no wing")
            elif t is not None and w is not None:
                if t not in wings:
                    continue  # reported once, for the folder's own modules
                if wings[t][0] >= wings[w][0]:
                    where = "above" if wings[t][0] > wings[w][0] else "beside"
                    problems.append(f"{source} imports {a.target} at line {a.line}: wing "
                                    f"{w!r} (level {wings[w][0]}) may not import wing {t!r} "
                                    f"(level {wings[t][0]}, {where} it)")
    return problems


def import_cycles(graph):
    """Import cycles between modules, each named by the pair that closes it.

    Args:
        graph: from :func:`import_graph`.

    Returns:
        list of strings like ``"a <-> b (a -> b -> a)"``, one per strongly connected
        group of modules (Tarjan's algorithm); empty when there is none.
    """
    edges = {m: sorted({a.target for a in arrows if a.target in graph})
             for m, arrows in graph.items()}
    index, low, stack, on_stack, groups, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                groups.append(sorted(group))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return [_name_cycle(group, edges) for group in groups]


def _name_cycle(group, edges):
    members = set(group)
    start = group[0]
    path, seen = [start], {start}
    while True:  # walk inside the group until a module repeats: that loop is a cycle
        nxt = next(w for w in edges[path[-1]] if w in members)
        if nxt in seen:
            loop = path[path.index(nxt):] + [nxt]
            break
        path.append(nxt)
        seen.add(nxt)
    return f"{loop[0]} <-> {loop[1]} ({' -> '.join(loop)})"


def wing_imports(graph, package="nh_operators"):
    """Counts of imports between wings: ``{(from_wing, to_wing): n}`` (root helpers: ``"_"``)."""
    counts = {}
    for source, arrows in graph.items():
        w = wing_of(source, package)
        if w == "":
            continue
        for a in arrows:
            t = wing_of(a.target, package)
            if t != w and t != "":
                key = (w or "_", t or "_")
                counts[key] = counts.get(key, 0) + 1
    return counts
