"""Draw the package's architecture from its code when the docs are built.

At ``builder-inited`` this reads every import of ``nh_operators`` with
:mod:`nh_operators._architecture` (the same reader that ``tests/test_layers.py`` uses) and
writes, under ``docs/generated/``:

- ``architecture.png``: the wings by level, with an arrow per pair of wings that import
  one another, labelled with the number of imports;
- ``architecture_wings.inc``: a table of the wings, their modules with line counts, and
  the wings each imports from;
- ``architecture_rule.inc``: the result of the layering check on this checkout.

``docs/architecture.rst`` includes them, so the page cannot go stale.
"""

from pathlib import Path

import nh_operators
from nh_operators._architecture import (WINGS, import_cycles, import_graph, layer_violations,
                                        wing_imports, wing_of)

PACKAGE = Path(nh_operators.__file__).resolve().parent


def _lines(module):
    parts = module.split(".")[1:]
    path = PACKAGE.joinpath(*parts)
    path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    return sum(1 for _ in path.open(encoding="utf-8"))


def wing_table(graph):
    """RST list-table: level, wing, role, modules (lines), imports from."""
    counts = wing_imports(graph)
    rows = []
    for wing, (level, role) in sorted(WINGS.items(), key=lambda kv: (kv[1][0], kv[0])):
        mods = sorted(m for m in graph if wing_of(m) == wing)
        names = ", ".join(f"``{m.rsplit('.', 1)[1] if m.count('.') > 1 else '__init__'}`` "
                          f"({_lines(m)})" for m in mods)
        total = sum(_lines(m) for m in mods)
        deps = sorted((t, n) for (f, t), n in counts.items() if f == wing)
        uses = ", ".join(f"{'root helpers' if t == '_' else t} ({n})" for t, n in deps) or "—"
        rows.append((str(level), f"``{wing}/``", role, f"{names}; {total} lines", uses))
    root = sorted(m for m in graph if wing_of(m) is None)
    rows.append(("—", "root", "private helpers, imported by any wing, importing none",
                 ", ".join(f"``{m.rsplit('.', 1)[1]}`` ({_lines(m)})" for m in root), "—"))
    out = [".. list-table::", "   :header-rows: 1", "   :widths: 6 14 30 40 20", "",
           "   * - level", "     - wing", "     - role", "     - modules (lines)",
           "     - imports from (count)"]
    for row in rows:
        out.append(f"   * - {row[0]}")
        out += [f"     - {cell}" for cell in row[1:]]
    return "\n".join(out) + "\n"


def rule_status(graph):
    problems = layer_violations(graph) + import_cycles(graph)
    n = sum(len(a) for a in graph.values())
    if not problems:
        return (f"On this checkout: {len(graph)} modules, {n} imports between them, no import "
                "that runs upward or sideways, and no cycle.\n")
    return "On this checkout the rule is broken:\n\n" + "\n".join(f"- {p}" for p in problems) + "\n"


def draw(graph, path):
    """Left: the wings stacked by level, one arc per pair that imports (count on it).
    Right: the same counts as a matrix, rows importing from columns."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    import numpy as np
    from matplotlib.figure import Figure
    from matplotlib.patches import FancyArrowPatch

    counts = wing_imports(graph)
    order = sorted(WINGS, key=lambda w: (WINGS[w][0], w))
    y = {w: i for i, w in enumerate(order)}  # models, potentials, solvers, ..., cli
    fig = Figure(figsize=(11, 6), layout="constrained")
    ax, mx = fig.subplots(1, 2, width_ratios=[1.1, 1])
    for w in order:
        n_mod = sum(1 for m in graph if wing_of(m) == w)
        ax.text(0, y[w], f"{w}/  ({n_mod})", ha="right", va="center", fontsize=10,
                bbox=dict(boxstyle="round,pad=0.3", fc="#e8f0fa", ec="#4a6fa5"))
        ax.text(-2.9, y[w], f"level {WINGS[w][0]}", ha="left", va="center", fontsize=8,
                color="0.4")
    for (src, dst), n in sorted(counts.items()):
        if "_" in (src, dst):
            continue
        span = y[src] - y[dst]
        arrow = FancyArrowPatch((0.05, y[src]), (0.05, y[dst]), arrowstyle="-|>",
                                mutation_scale=9, lw=0.5 + 0.25 * n ** 0.5, color="#4a6fa5",
                                alpha=0.75, connectionstyle=f"arc3,rad={-0.55 - 0.02 * span}")
        ax.add_patch(arrow)
    ax.set_xlim(-3.0, 4.8)
    ax.set_ylim(-0.8, len(order) - 0.2)
    ax.set_axis_off()
    ax.set_title("each wing imports only the wings beneath it", fontsize=10)
    cols = order + ["_"]
    m = np.array([[counts.get((r, c), 0) for c in cols] for r in order], dtype=float)
    mx.imshow(np.where(m > 0, m, np.nan), cmap="Blues", vmin=0, vmax=max(m.max(), 1) * 1.3,
              origin="lower")
    for i in range(len(order)):
        for j in range(len(cols)):
            if m[i, j]:
                mx.text(j, i, f"{int(m[i, j])}", ha="center", va="center", fontsize=8)
    labels = [c if c != "_" else "root" for c in cols]
    mx.set_xticks(range(len(cols)), labels, rotation=60, fontsize=8)
    mx.set_yticks(range(len(order)), order, fontsize=8)
    mx.set_xlabel("imported wing")
    mx.set_ylabel("importing wing")
    mx.set_title("imports between wings (count): a row uses only lower wings and root", fontsize=10)
    fig.savefig(path, dpi=110)


def _build(app):
    out = Path(app.srcdir) / "generated"
    out.mkdir(exist_ok=True)
    graph = import_graph(PACKAGE)
    draw(graph, out / "architecture.png")
    (out / "architecture_wings.inc").write_text(wing_table(graph), encoding="utf-8")
    (out / "architecture_rule.inc").write_text(rule_status(graph), encoding="utf-8")


def setup(app):
    app.connect("builder-inited", _build)
    return {"parallel_read_safe": True}
