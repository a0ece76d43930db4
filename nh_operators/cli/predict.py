"""``nh-operators predict``: the trajectory of one potential typed as a formula or named.

The library is imported inside the commands, so that ``--help`` and argument errors load
neither torch nor numba.
"""

import os

from ._options import figure_file, positive_float, positive_int


def _predict(args):
    import numpy as np

    from .._constants import TIMES
    from .._metrics import loss_per_sample
    from ..potentials import as_potential
    from ..solvers import solve_classical
    from ..solving import solve

    times = TIMES if args.times is None else np.asarray(args.times, dtype=np.float64)
    pot, _ = as_potential(args.potential)  # safe parse and the bounded checks
    state = dict(q0=args.q0, p0=args.p0)
    sol = solve(pot, times, tol=args.tol, method=args.model, **state)
    ref_tol = 1e-12 if times.max() <= 2 else 1e-10  # far times: the period's phase bound
    ref = solve_classical(pot, times, tol=ref_tol, method="yoshida8", **state)
    true = float(loss_per_sample(sol.q, sol.p, ref.q, ref.p)["L_tot"])
    formula = getattr(pot, "formula", args.potential)
    print(f"V(q) = {formula}")
    print(f"method: {sol.method} ({sol.kind}; {sol.reason}), {1e3 * sol.seconds:.2f} ms")
    print(f"estimated L_tot {sol.error_estimate:.3g}; L_tot against a Yoshida-8 solve at "
          f"{ref_tol:g}: {true:.3g}" + ("" if args.tol is None else f"; tol {args.tol:g}"))
    rows = np.arange(times.size)
    if rows.size > args.rows:
        rows = np.unique(np.linspace(0, times.size - 1, args.rows).round().astype(int))
        print(f"({rows.size} of {times.size} times shown; --rows changes it)")
    print(f"{'t':>8} {'q':>12} {'p':>12} {'|q - ref|':>11} {'|p - ref|':>11}")
    for i in rows:
        print(f"{times[i]:8.4f} {sol.q[i]:12.6f} {sol.p[i]:12.6f} "
              f"{abs(sol.q[i] - ref.q[i]):11.2e} {abs(sol.p[i] - ref.p[i]):11.2e}")
    if args.out:  # the plotting modules (matplotlib, scipy) load only for a figure
        from ..evaluation import plot_trajectory, save_figure

        order = np.argsort(times, kind="stable")
        fig = plot_trajectory(pot, times[order], ref.q[order], ref.p[order],
                              sol.q[order], sol.p[order], label=sol.method,
                              title=f"V(q) = {formula}: {sol.method}, L_tot {true:.2g}")

        save_figure(fig, args.out)
        print(f"figure: {args.out}")
        _orbit_figure(pot, formula, times, sol, ref, args)


def _orbit_figure(pot, formula, times, sol, ref, args):
    """The whole orbit in the phase plane, the asked times marked: FILE_orbit.EXT."""
    import numpy as np

    from ..evaluation import save_figure
    from ..evaluation.orbit_plot import plot_orbit
    from ..solvers import solve_classical
    from ..solvers.periodic import orbit_periods
    from ..solvers.rows import row_source

    out, status = orbit_periods(row_source(pot, "exact V"), np.array([0]),
                                np.array([args.q0]), np.array([args.p0]))
    period = float(out[0, 0]) if status[0] == 0 and out[0, 1] < 1e-6 * out[0, 0] else None
    span = period if period else max(float(times.max()), 1e-3)
    orbit = solve_classical(pot, np.linspace(0.0, span, 400), tol=1e-10, q0=args.q0,
                            p0=args.p0)
    stem, ext = os.path.splitext(args.out)
    path = f"{stem}_orbit{ext or '.png'}"
    what = f"period T = {period:.6g}" if period else f"t ∈ [0, {span:g}]"
    save_figure(plot_orbit(orbit.q, orbit.p, times, sol.q, sol.p,
                           title=f"V(q) = {formula}: orbit from ({args.q0:g}, {args.p0:g}), "
                           f"{what}"), path)
    print(f"figure: {path}")


def register(sub):
    """Add this module's commands to the subparsers ``sub``."""
    pr = sub.add_parser("predict", help="one potential typed as a formula: the trajectory "
                        "table and figure")
    pr.add_argument("--potential", required=True, help="an expression in q, e.g. "
                    "'8*(q-0.5)**2', or a physical potential's name (sho, ...)")
    pr.add_argument("--model", default="auto", help="auto (default), classical, an "
                    "integrator, or a shipped model (deeponet, traonet, ...)")
    pr.add_argument("--times", type=float, nargs="+", help="query times (default: the "
                    "100-point grid on [0, 2])")
    pr.add_argument("--tol", type=positive_float, help="target L_tot (auto picks the method)")
    pr.add_argument("--q0", type=float, default=0.0, help="starting position in [0, 1] "
                    "(default 0)")
    pr.add_argument("--p0", type=float, default=0.0, help="starting momentum (default 0); "
                    "the energy p0²/2 + V(q0) must be at most V0 = 2")
    pr.add_argument("--rows", type=positive_int, default=20, help="table rows at most (default 20)")
    pr.add_argument("--out", type=figure_file, help="figure file; its suffix names the format "
                    "(.png, .pdf, .svg, ...)")
    pr.set_defaults(run=_predict)
