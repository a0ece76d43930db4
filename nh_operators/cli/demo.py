"""``nh-operators demo``: every shipped network and the classical solvers on the five
physical potentials, their accuracy and their cost per trajectory in a batch.

The table is printed and written to ``OUT/table.md``; the figures go to ``OUT`` too.
The library is imported inside the command, so that ``--help`` loads neither torch nor
numba.
"""

import argparse
import os
import warnings
from collections.abc import Callable, Mapping

import numpy as np

from ._options import positive_int

__all__ = ["register", "markdown_table", "DEFAULT_BATCH", "REPEATS"]

#: Trajectories per timed call: the five physical potentials repeated.
DEFAULT_BATCH = 200
#: Timed calls per method after one warm-up call; the table gives their median.
REPEATS = 3
_EXACT = "rk4_exact_16"  # integrates each exact formula alone: no batch to time


def _batch_seconds(run: Callable, V: np.ndarray, t: np.ndarray) -> float:
    """Median seconds per trajectory of ``run(V, t)`` over :data:`REPEATS` calls, after
    a warm-up call. ``V`` (B, 100) sensor values, ``t`` (M,) times."""
    from ..evaluation import time_call

    with warnings.catch_warnings():  # the accuracy pass has reported them already
        warnings.simplefilter("ignore")
        seconds = time_call(lambda: run(V, t), repeats=REPEATS, warmup=1,
                            synchronize=getattr(run, "synchronize", None))
    return float(np.median(seconds)) / len(V)


def _exact_seconds(t: np.ndarray) -> float:
    """Median seconds of RK4 with 16 substeps on each exact formula, one potential per
    call (after a warm-up), averaged over the five potentials."""
    from ..evaluation import time_call
    from ..potentials import PHYSICAL_POTENTIALS
    from ..solvers import integrate

    per = []
    with warnings.catch_warnings():  # MFF's kink warns; the row shows that cost
        warnings.simplefilter("ignore")
        for pot in PHYSICAL_POTENTIALS.values():
            per.append(np.median(time_call(lambda pot=pot: integrate(pot, t, "rk4", 16),
                                           repeats=REPEATS, warmup=1)))
    return float(np.mean(per))


def markdown_table(table: Mapping[str, Mapping[str, Mapping[str, float]]],
                   micro: Mapping[str, float], batch: int, where: str) -> str:
    """The demo's table as Markdown.

    Args:
        table: ``{method: {potential: {"L_tot": float, ...}}}`` (as
            :func:`~nh_operators.evaluation.classical_physical_table` returns).
        micro: µs per trajectory of each method.
        batch: trajectories per timed call (in the cost column's header).
        where: device and threads the costs were measured with.

    Returns:
        the Markdown text: a title, what was measured, one row per method.

    Example:
        >>> text = markdown_table({"rk4": {"sho": {"L_tot": 1e-12}}}, {"rk4": 2.5}, 1000,
        ...                       "cpu")
        >>> text.splitlines()[4]
        '| method | sho | µs / trajectory, batch 1000 |'
    """
    names = list(next(iter(table.values())))
    lines = ["# nh-operators demo: the physical potentials", "",
             f"L_tot against the exact solution (SHO, MFF) or DOP853 at 1e-13; sensor methods "
             f"and networks see V at the 100 sensors only. Cost: µs per trajectory in a batch "
             f"of {batch} (the five potentials repeated), median of {REPEATS} calls after a "
             f"warm-up; {_EXACT} integrates each exact formula alone, one per call. "
             f"Measured on {where}.", "",
             "| method | " + " | ".join(names) + f" | µs / trajectory, batch {batch} |",
             "|---|" + "---:|" * (len(names) + 1)]
    for method, row in table.items():
        cells = [f"{row[n]['L_tot']:.2e}" for n in names]
        lines.append(f"| {method} | " + " | ".join(cells) + f" | {micro[method]:,.1f} |")
    return "\n".join(lines) + "\n"


def _where() -> str:
    """Device and threads of the timings, and a warning when the machine was busy."""
    from ..evaluation import busy_machine_warning, device_info

    info = device_info()
    busy = busy_machine_warning(info)
    return (f"{info['device']}; torch {info['torch_threads']} thread(s), numba "
            f"{info['numba_threads']} thread(s)" + (f" ({busy})" if busy else ""))


def _demo(args: argparse.Namespace) -> None:
    from .._constants import SENSORS, TIMES
    from ..evaluation import (CLASSICAL_BASELINES, classical_physical_table,
                              physical_reference, plot_physical_potentials, plot_trajectory,
                              save_figure)
    from ..potentials import PHYSICAL_POTENTIALS
    from ..solving import available_pretrained, pretrained, solve

    os.makedirs(args.out, exist_ok=True)
    networks = {name: pretrained(name) for name in available_pretrained()}
    methods = {**CLASSICAL_BASELINES, **networks}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        table = classical_physical_table(baselines=methods, repeats=1)
    outside = sorted({str(w.message).split(":")[0] for w in caught
                      if type(w.message).__name__ == "OutOfDomainWarning"})
    names = list(PHYSICAL_POTENTIALS)
    one_each = np.stack([pot.V(SENSORS) for pot in PHYSICAL_POTENTIALS.values()])
    V = np.tile(one_each, (-(-args.batch // len(names)), 1))[:args.batch]
    where = _where()
    micro = {m: 1e6 * _batch_seconds(run, V, TIMES) for m, run in methods.items()}
    micro[_EXACT] = 1e6 * _exact_seconds(TIMES)
    text = markdown_table(table, micro, args.batch, where)
    print("The shipped networks and the classical solvers on the physical potentials: L_tot")
    print("against the exact solution (SHO, MFF) or DOP853 at 1e-13; sensor methods and")
    print(f"networks see V at the 100 sensors only. Cost: µs per trajectory in a batch of "
          f"{args.batch},\nmedian of {REPEATS} calls after a warm-up ({_EXACT}: one exact "
          f"formula per call).\nMeasured on {where}.\n")
    width = max(map(len, table)) + 2
    cost = f"µs/traj, batch {args.batch}"
    print(f"{'method':<{width}}" + "".join(f"{n:>13}" for n in names) + f"{cost:>22}")
    for method, row in table.items():
        print(f"{method:<{width}}" + "".join(f"{row[n]['L_tot']:>13.3e}" for n in names)
              + f"{micro[method]:>22,.1f}")
    if outside:
        print(f"\nOutside the training domain (extrapolation): {'; '.join(outside)}")
    path = os.path.join(args.out, "table.md")
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    print(f"\ntable: {path}")
    trajectories = {n: physical_reference(n) for n in names}
    path = os.path.join(args.out, "physical_potentials.png")
    save_figure(plot_physical_potentials(PHYSICAL_POTENTIALS, trajectories), path)
    print(f"figure: {path}")
    if networks:
        best = min(networks, key=lambda m: table[m]["double_well"]["L_tot"])
        pot = PHYSICAL_POTENTIALS["double_well"]
        sol = solve(pot, TIMES, method=best)
        q, p = trajectories["double_well"]
        path = os.path.join(args.out, f"double_well_{best}.png")
        save_figure(plot_trajectory(pot, TIMES, q, p, sol.q, sol.p, label=best,
                                    title=f"double well: {best} (estimated L_tot "
                                    f"{sol.error_estimate:.2g})"), path)
        print(f"figure: {path} (nh.solve('double_well', t, method={best!r}))")


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``demo`` to the subparsers ``sub``."""
    demo = sub.add_parser("demo", help="the shipped networks and the classical solvers on "
                          "five physical potentials: accuracy and cost per trajectory")
    demo.add_argument("--out", default="demo", help="folder for the table (table.md) and "
                      "the figures (default: demo)")
    demo.add_argument("--batch", type=positive_int, default=DEFAULT_BATCH,
                      help=f"trajectories per timed call (default {DEFAULT_BATCH})")
    demo.set_defaults(run=_demo)
