"""The speed/accuracy study: work-precision rows and where a network beats every solver.

A target accuracy ε means "test-set mean L_tot ≤ ε". At ε, the classical cost is the
time of the cheapest classical method that meets ε. A network with mean loss L and
time τ is *faster than every classical method at ε* when L ≤ ε and τ is below that
cost. With the classical methods ordered, this holds exactly for

    L ≤ ε < ε_max,  ε_max = min{L_c : classical c with τ_c ≤ τ}  (∞ if none is as fast),

an interval that is empty when a classical method is at once as fast and as accurate.
"""

import math
from typing import Any

__all__ = ["work_precision_rows", "faster_interval", "faster_statements",
           "work_precision_markdown"]

REGIMES = {"batched": "large batch", "batch_1": "batch 1"}


def work_precision_rows(results, regime="batched"):
    """One row per method: name, kind, family, seconds per trajectory, mean L_tot.

    Args:
        results: the ``report.json`` dict of :func:`~nh_operators.evaluation.evaluate_methods`.
        regime: ``"batched"`` or ``"batch_1"``.

    Returns:
        list of dicts ``name, kind, family, seconds, mean_L_tot, n, device``, sorted by
        time; methods without a finite time or loss are left out.

    Raises:
        ValueError: for an unknown regime.
    """
    if regime not in REGIMES:
        raise ValueError(f"regime must be one of {sorted(REGIMES)}, got {regime!r}")
    rows = []
    for name, m in results["methods"].items():
        seconds = (m.get("seconds_per_trajectory") or {}).get(regime)
        loss = m["test"]["mean"]
        if seconds is None or not (math.isfinite(seconds) and math.isfinite(loss)):
            continue
        rows.append({"name": name, "kind": m["kind"], "family": m["family"],
                     "seconds": float(seconds), "mean_L_tot": float(loss),
                     "n": m["test"]["n"], "device": m["device"]})
    return sorted(rows, key=lambda r: r["seconds"])


def faster_interval(row: dict[str, Any], classical: list[dict[str, Any]]
                    ) -> tuple[float | None, float | None, dict[str, Any] | None]:
    """Target accuracies at which ``row`` is faster than every classical method.

    Args:
        row: a work-precision row (``seconds``, ``mean_L_tot``).
        classical: the classical rows.

    Returns:
        (low, high, blocker): the half-open interval [low, high) of ε (``high`` may be
        ``inf``), or ``None`` for low/high when it is empty; ``blocker`` is the
        classical row that bounds it (as fast and at least as accurate), or None.

    Example:
        >>> net = {"seconds": 1e-4, "mean_L_tot": 1e-5}
        >>> slow = {"name": "rk4", "seconds": 1e-3, "mean_L_tot": 1e-9}
        >>> fast = {"name": "euler", "seconds": 1e-5, "mean_L_tot": 1e-2}
        >>> faster_interval(net, [slow, fast])[:2]
        (1e-05, 0.01)
    """
    as_fast = [c for c in classical if c["seconds"] <= row["seconds"]]
    blocker = min(as_fast, key=lambda c: c["mean_L_tot"]) if as_fast else None
    high = blocker["mean_L_tot"] if blocker else math.inf
    if high <= row["mean_L_tot"]:
        return None, None, blocker
    return row["mean_L_tot"], high, blocker


def _us(seconds):
    return f"{seconds * 1e6:,.1f} µs" if seconds < 1e-3 else f"{seconds * 1e3:,.1f} ms"


def faster_statements(rows, regime="batched"):
    """One sentence per network: at which accuracies it beats every classical method.

    Args:
        rows: rows of :func:`work_precision_rows` (one regime).
        regime: the regime's key, for the wording.

    Returns:
        list of sentences (strings).
    """
    classical = [r for r in rows if r["kind"] == "classical"]
    where = REGIMES[regime]
    out = []
    for row in (r for r in rows if r["kind"] == "neural"):
        head = (f"{row['name']} ({where}, {_us(row['seconds'])} per trajectory, mean "
                f"L_tot {row['mean_L_tot']:.2e})")
        low, high, blocker = faster_interval(row, classical)
        if low is None or high is None:  # both or neither
            assert blocker is not None  # an empty interval has a blocker
            out.append(f"{head} is faster than every classical method at no accuracy: "
                       f"{blocker['name']} takes {_us(blocker['seconds'])} and reaches "
                       f"{blocker['mean_L_tot']:.2e}.")
        elif math.isinf(high):
            out.append(f"{head} is faster than every classical method at every accuracy "
                       f"target ≥ {low:.2e}: no classical method here is as fast.")
        else:
            assert blocker is not None  # a finite bound is a blocker's accuracy
            out.append(f"{head} is faster than every classical method for targets in "
                       f"[{low:.2e}, {high:.2e}); for targets of {high:.2e} or looser, "
                       f"{blocker['name']} ({_us(blocker['seconds'])}) is both faster and "
                       f"accurate enough.")
    if not out:
        out.append("No network was evaluated, so no network is faster than every "
                   "classical method.")
    return out


def work_precision_markdown(results):
    """The work-precision table (both regimes) and the statements, as markdown."""
    lines = ["| method | kind | test n | mean L_tot | s/traj, batch 1 | s/traj, large batch "
             "| device |",
             "|---|---|---:|---:|---:|---:|---|"]
    methods = sorted(results["methods"].items(), key=lambda kv: kv[1]["test"]["mean"])
    for name, m in methods:
        s = m.get("seconds_per_trajectory") or {}
        cells = [f"{s[k]:.3e}" if s.get(k) is not None else "–" for k in ("batch_1", "batched")]
        lines.append(f"| {name} | {m['kind']} | {m['test']['n']} | {m['test']['mean']:.3e} | "
                     f"{cells[0]} | {cells[1]} | {m['device']} |")
    for regime in REGIMES:
        lines += ["", f"**{REGIMES[regime].capitalize()}.**", ""]
        lines += [f"- {s}" for s in faster_statements(work_precision_rows(results, regime),
                                                      regime)]
    return "\n".join(lines)
