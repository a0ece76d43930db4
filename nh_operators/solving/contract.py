"""Measure :func:`~nh_operators.solve`'s tolerance contract and the time it saves.

The contract, per call: the true L_tot of ``solve(potential, t, tol=tol)`` is ≤ tol
(tested on unseen inputs in ``tests/solving/test_network_contract.py`` and
``tests/solvers/test_evidence.py``). :func:`contract_cases` draws inputs — test-set
potentials (exact B-spline curves, truth = the stored labels) and potentials from outside
the training distribution (:mod:`nh_operators.potentials.ood` and the physical ones,
truth = the reference solver) — each with its own random set of query times.
:func:`measure_contract` runs ``solve`` and, as the baseline, always the classical solver
at the same tolerance, and
:func:`network_estimates` checks each network's a-posteriori estimate on its own:
how often it would accept, and how often an accepted prediction is in fact worse than
the tolerance. ``benchmarks/promise/solve_contract.py`` prints the tables.
"""

import time
import warnings
from dataclasses import dataclass

import numpy as np

from .._constants import TIMES
from .._metrics import loss_per_sample

__all__ = ["Case", "contract_cases", "measure_contract", "network_estimates"]


@dataclass
class Case:
    """One input: a potential, the times asked, and the true trajectory there."""

    group: str
    potential: object
    t: np.ndarray
    q: np.ndarray
    p: np.ndarray


def _grid_subset(rng):
    k = int(rng.integers(1, TIMES.size + 1))
    return rng.permutation(TIMES.size)[:k]


def contract_cases(test_set, n_test, n_ood, seed=0):
    """Test-set and out-of-distribution inputs with random query times.

    Args:
        test_set: a labelled :class:`~nh_operators.data.Dataset` (or its path); its first
            ``n_test`` potentials are used, each at a random subset of :data:`TIMES`
            in random order (the labels are there).
        n_test: how many test-set inputs.
        n_ood: how many from :func:`~nh_operators.potentials.ood_potentials` (seed ``seed``),
            each at 1–100 uniform random times in [0, 2]; the five physical potentials
            are added.
        seed: seed of the times and of the OOD potentials.

    Returns:
        list of :class:`Case` (group ``"test"`` or ``"ood"``).
    """
    from ..data import load_dataset
    from ..potentials import PHYSICAL_POTENTIALS, ood_potentials
    from ..solvers import reference_solve

    if not hasattr(test_set, "V"):
        test_set = load_dataset(test_set)
    if not 0 <= n_test <= len(test_set):
        raise ValueError(f"n_test must be in [0, {len(test_set)}], got {n_test}")
    rng = np.random.default_rng(seed)
    cases = []
    for i in range(n_test):
        idx = _grid_subset(rng)
        cases.append(Case("test", test_set.potential(i), TIMES[idx],
                          np.asarray(test_set.q[i])[idx], np.asarray(test_set.p[i])[idx]))
    for pot in ood_potentials(n_ood, seed) + list(PHYSICAL_POTENTIALS.values()):
        t = rng.uniform(0.0, 2.0, int(rng.integers(1, 101)))
        q, p = reference_solve(pot, t)
        cases.append(Case("ood", pot, t, q, p))
    return cases


def _true(q, p, case):
    return float(loss_per_sample(q, p, case.q, case.p)["L_tot"])


def measure_contract(cases, tols, *, progress=False):
    """Run ``solve(..., tol)`` and the classical solver on every case.

    Args:
        cases: from :func:`contract_cases`.
        tols: tolerances.
        progress: a progress bar.

    Returns:
        list of dicts, one per (group, tol): ``n``, ``met`` (share with true L_tot ≤
        tol), ``worst`` (max true L_tot / tol), ``neural`` (share solved by a network),
        ``auto_s`` / ``classical_s`` (mean seconds per call; ``*_median_s`` the
        medians; the two run in alternating order) and ``saved`` (1 − total
        auto time / total classical time; negative when auto costs more).
    """
    from tqdm.auto import tqdm

    from ..solvers import solve_classical
    from .auto_solve import solve

    if cases:  # load the networks and compile before the clock runs
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            for tol in tols:
                solve(cases[0].potential, cases[0].t, tol=tol)
                solve_classical(cases[0].potential, cases[0].t, tol=tol)
    records = []
    for tol in tols:
        for case in tqdm(cases, desc=f"tol {tol:g}", disable=not progress):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                for order in ((0, 1) if len(records) % 2 else (1, 0)):  # alternate
                    t0 = time.perf_counter()
                    if order == 0:
                        sol = solve(case.potential, case.t, tol=tol)
                        auto_s = time.perf_counter() - t0
                    else:
                        solve_classical(case.potential, case.t, tol=tol)
                        classical_s = time.perf_counter() - t0
            records.append((case.group, tol, _true(sol.q, sol.p, case), sol.kind, auto_s,
                            classical_s))
    rows = []
    for group in sorted({r[0] for r in records}, reverse=True):
        for tol in tols:
            sel = [r for r in records if r[0] == group and r[1] == tol]
            err = np.array([r[2] for r in sel])
            auto_s, cls_s = np.array([r[4] for r in sel]), np.array([r[5] for r in sel])
            rows.append({"group": group, "tol": tol, "n": len(sel),
                         "met": float(np.mean(err <= tol)), "worst": float(err.max() / tol),
                         "neural": float(np.mean([r[3] == "neural" for r in sel])),
                         "auto_s": float(auto_s.mean()), "classical_s": float(cls_s.mean()),
                         "auto_median_s": float(np.median(auto_s)),
                         "classical_median_s": float(np.median(cls_s)),
                         "saved": float(1.0 - auto_s.sum() / cls_s.sum())})
    return rows


def network_estimates(cases, names, tols):
    """Each network's estimate as a test on its own (what ``auto`` would accept).

    Returns:
        list of dicts per (network, group, tol): ``accepted`` (share with estimate ≤
        tol), ``false`` (share of the accepted whose true L_tot > tol; NaN when none
        is accepted), ``median_true`` and ``median_estimate``.
    """
    from ..potentials import as_potential
    from .network_pass import neural_solve

    rows = []
    for name in names:
        out = []
        for case in cases:
            if case.t.max() > TIMES[-1]:
                continue
            pot, info = as_potential(case.potential)
            q, p, est = neural_solve(name, pot, info, case.t)
            out.append((case.group, _true(q, p, case), est))
        for group in sorted({o[0] for o in out}, reverse=True):
            err = np.array([o[1] for o in out if o[0] == group])
            est = np.array([o[2] for o in out if o[0] == group])
            for tol in tols:
                ok = est <= tol
                rows.append({"network": name, "group": group, "tol": tol, "n": int(err.size),
                             "accepted": float(ok.mean()),
                             "false": float(np.mean(err[ok] > tol)) if ok.any() else float("nan"),
                             "median_true": float(np.median(err)),
                             "median_estimate": float(np.median(est))})
    return rows
