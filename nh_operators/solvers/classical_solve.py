"""A classical solve to a tolerance: only the times asked for, substeps doubled until met.

:func:`solve_classical` integrates Hamilton's equations for one potential given as a
name, a text expression, a callable (with or without its derivative), a
:class:`BoundedPotential` or 100 sensor values, and doubles the substeps until an error
estimate of L_tot at the requested times is below ``tol``.

**Error estimate.** With solutions y_k, y_2k and y_4k at k, 2k and 4k substeps, the
estimate for the returned y_4k is max(L(y_4k − y_2k), L(y_2k − y_k) / R), R = 4^p for
a method of order p (256 for RK4; L is L_tot of a difference). A level is accepted when
this is ≤ tol: no safety factor, and never on one difference alone.

Why not less. On the generator's potentials (splines: the force's second derivative
jumps at every knot) the error at one time is not a smooth C·h^p: each step that
crosses a knot adds a term that depends on where in the step the knot falls, so the
error at successive levels fluctuates by orders of magnitude and two levels can agree
by chance (a scan of 99,000 single-time queries on 1,000 potentials, seed 777: RK4 at 1
and 2 substeps both 3e-8 from the truth but 4e-11 apart). A Richardson estimate from
the observed rate (the difference over 15²) is right at the median but 10–1,000× low in
the tail. Coarse steps can also step over a narrow feature of V alike at every level.
So:

* the doubling starts at a step of at most :data:`~.start_level.RESOLVED_STEP` (1/8 of the
  spacing of :data:`~nh_operators.TIMES`: the particle moves less than the sensor
  spacing per step; from tol :data:`~.start_level.COARSE_START_TOL` (``COARSER_START_TOL``,
  ``COARSEST_START_TOL``) up, one (two, three) levels coarser for a row whose orbit is
  inside the envelope of :mod:`.start_envelope` (never slow, never past the spline's
  guard), whose coarsest only floors the estimate: :func:`~.start_level.start_levels`),
  and
* the difference of the last two levels must be below tol, and so must the one before
  it shrunk at the method's rate (a chance agreement of the last two is caught by the
  earlier pair); on a potential with a kink both, unshrunk, times
  :data:`~.level_grid.KINK_SAFETY`, and on an orbit past a spline's guard the last
  :data:`~.level_grid.DEEP_GAPS` of them.

``benchmarks/promise/classical_estimate.py`` measures it: on 242,000 queries (four sets of
potentials and starting states, tol 1e-2 to 1e-11) no accepted answer missed tol
(worst true/tol 0.85); the estimate is 100–300× above the true error at the median,
the price of that tail.
"""

import functools
import time
from dataclasses import dataclass, field

import numpy as np

from .._backend import single_threaded
from ..potentials.coerce import as_potential
from .rows import row_source, solve_rows
from .start_level import RESOLVED_STEP
from .schemes import ORDERS, check_times
from .states import check_states, state_arrays

__all__ = ["ClassicalSolution", "solve_classical", "adaptive_solve", "RESOLVED_STEP",
           "coerce_potential"]


@functools.lru_cache(maxsize=64)
def _parsed(text):
    return as_potential(text)


def coerce_potential(potential, dV=None):
    """:func:`~nh_operators.potentials.as_potential`, with the parse and checks of a text
    cached (a typed formula is then solved as fast as a B-spline on every later call).

    Example:
        >>> coerce_potential("8*(q-0.5)**2")[0] is coerce_potential("8*(q-0.5)**2")[0]
        True
    """
    if isinstance(potential, str) and dV is None:
        return _parsed(potential)
    return as_potential(potential, dV)



@dataclass
class ClassicalSolution:
    """What :func:`solve_classical` returns.

    Attributes:
        q, p: float64 arrays (M,) at the requested times, in their order.
        method: the integrator, e.g. ``"rk4"``.
        substeps: steps per output interval of the returned solution.
        error_estimate: the L_tot estimate described in the module docstring.
        seconds: wall time of the whole solve.
        information: ``"exact V"`` or ``"sensors"`` (then the truth is the spline of
            the sensors, and the distance to any other potential with the same sensor
            values is not part of the estimate).
        history: (substeps, estimate) of every level tried.
        period: the period T of the orbit when the times were answered from one period
            (:mod:`.periodic`), else None.
    """

    q: np.ndarray
    p: np.ndarray
    method: str
    substeps: int
    error_estimate: float
    seconds: float
    information: str
    history: list = field(default_factory=list)
    period: float | None = None


def solve_classical(potential, t, *, tol=1e-8, method="rk4", dV=None, max_substeps=4096,
                    q0=0.0, p0=0.0):
    """Solve at exactly the times ``t`` to an estimated L_tot ≤ ``tol``, from (q0, p0).

    Times beyond :data:`~nh_operators.solvers.periodic.PERIODIC_FROM` are answered from
    one period of the orbit, at a cost that does not grow with t; the estimate then
    includes the phase error of the period (:mod:`nh_operators.solvers.periodic`).

    Args:
        potential: see :func:`~nh_operators.potentials.as_potential`.
        t: query times, any order, ≥ 0.
        tol: target L_tot (mean over the times of the squared errors of q and p,
            averaged); > 0.
        method: a key of :data:`~nh_operators.METHODS`.
        dV: derivative of a callable V.
        max_substeps: give up (with a warning) beyond this many steps per interval.
        q0, p0: the starting state (floats); its energy p0²/2 + V(q0) must be ≤ V0 and
            q0 in [0, 1] (:func:`~nh_operators.solvers.states.check_states`).

    Returns:
        :class:`ClassicalSolution`.

    Raises:
        ValueError: for a bad potential, times, method, tolerance or state, or a time
            beyond what float64 resolves.
        PeriodError: a far horizon on an orbit whose period cannot be found (a
            separatrix).

    Example:
        >>> sol = solve_classical("sho", [0.5, 1.0], tol=1e-10)
        >>> sol.error_estimate <= 1e-10, round(float(sol.q[0]), 6)
        (True, 0.708073)
    """
    start = time.perf_counter()
    if not (isinstance(tol, (int, float)) and tol > 0):
        raise ValueError(f"tol must be a positive number, got {tol!r}")
    if method not in ORDERS:
        raise ValueError(f"unknown method {method!r}; choose one of {sorted(ORDERS)}")
    with single_threaded():
        pot, information = coerce_potential(potential, dV)
    t = check_times(np.asarray(t, dtype=np.float64).reshape(-1))
    return adaptive_solve(pot, information, t, tol, method, max_substeps, start, q0=q0, p0=p0)


def adaptive_solve(pot, information, t, tol, method, max_substeps=4096, start=None, *,
                   q0=0.0, p0=0.0):
    """The doubling loop of :func:`solve_classical` on an already checked potential
    (the output of :func:`~nh_operators.potentials.as_potential`) and already checked
    times ``t`` ((M,) float64, finite, ≥ 0: :func:`~.schemes.check_times`); ``start`` is
    the perf_counter at which the solve's clock started (default: now). Runs on one
    thread (:func:`~nh_operators._backend.single_threaded`)."""
    start = time.perf_counter() if start is None else start
    with single_threaded():
        src = row_source(pot, information)
        q0s, p0s = state_arrays(q0, p0, 1)
        check_states(q0s, p0s, src.values_at)
        out = solve_rows(src, t, q0s, p0s, np.array([float(tol)]), method, max_substeps)
    period = float(out.period[0])
    return ClassicalSolution(out.q[0], out.p[0], method, int(out.substeps[0]),
                             float(out.estimate[0]), time.perf_counter() - start,
                             information, out.history,
                             None if np.isnan(period) else period)
