"""The samples that calibrate a shipped network for :func:`~nh_operators.solve`: families
of inputs, each at random asked times, with the true L_tot and the raw estimate of every
row (:func:`calibration_families`; :mod:`~nh_operators.solving.calibrate` turns them
into factors)."""

import numpy as np

from .._constants import SENSORS, TIMES
from .._metrics import loss_per_sample
from .acceptance import EARLY_HORIZON, SENSOR_FAMILIES
from .estimate import exact_force, sensor_force
from .loader import load
from .network_pass import neural_raw
from .refine import fine_estimate, refines

__all__ = ["SENSOR_PASSES", "calibration_families"]


def _asked_times(rng):
    """A random call's times: one time (30 %) or 2–100 uniform times in [0, h], h = 2
    for a third of the calls, log-uniform in [:data:`EARLY_HORIZON`, 2] for a third and
    in [0.02, :data:`EARLY_HORIZON`] for the last third (early calls, calibrated apart)."""
    m = 1 if rng.random() < 0.3 else int(rng.integers(2, 101))
    lo, hi = ((TIMES[-1], TIMES[-1]), (EARLY_HORIZON, TIMES[-1]),
              (0.02, EARLY_HORIZON))[int(rng.integers(3))]
    return rng.uniform(0.0, float(np.exp(rng.uniform(np.log(lo), np.log(hi)))), m)


def _states(values, n, rng):
    """Starting states stratified by energy (:func:`~nh_operators.solvers.energy_states`)
    of n rows whose V at row i's positions is ``values(x)``: (q0, p0), each (n,)."""
    from ..solvers import STATE_UNIFORMS, energy_states

    q0, p0, _ = energy_states(values, rng.random((n, STATE_UNIFORMS)))
    return q0, p0


def _batch_ratios(name, pots, sensors, rng, group=20, states=None):
    """true L_tot and raw estimate of model ``name`` on the rows of a batched B-spline
    ``pots`` inside its domain, each group of rows at one random set of asked times;
    ``sensors``: the input is the sensor values (force and truth: their spline; ``pots``
    may then be the sensor values themselves, (N, 100));
    ``states``: the rows' starting states (q0, p0), for a network that reads one."""
    from ..models import predict
    from ..potentials import in_domain
    from ..solvers import integrate_sensors, reference_solve
    from ..solvers.rows import row_source
    from .catalog import network_domain
    from .estimate import estimate_at

    V = pots if isinstance(pots, np.ndarray) else pots.V(SENSORS)
    if sensors:
        exact = None
    elif isinstance(pots, np.ndarray):
        raise ValueError("exact inputs (sensors=False) need a batched BoundedPotential, "
                         "not an array of sensor values")
    else:
        exact = pots
    keep = np.flatnonzero(in_domain(V, network_domain(name)))
    shipped = load(name)
    net, fine = shipped.net, refines(name)
    q0s, p0s = (np.zeros(len(V)), np.zeros(len(V))) if states is None else states
    true, raw, early, true_fine, raw_fine = [], [], [], [], []
    for lo in range(0, keep.size, group):
        rows = keep[lo:lo + group]
        t = _asked_times(rng)
        early.append(np.full(rows.size, t.max() <= EARLY_HORIZON))
        state = {"q0": q0s[rows], "p0": p0s[rows]}
        q, p = predict(net, shipped.input_rows(V[rows], **state), TIMES)
        if exact is None:
            q_ref, p_ref = integrate_sensors(V[rows], t, substeps=512, check_resolution=False,
                                             **state)
            force = sensor_force(V[rows])
        else:
            sub = type(exact)(exact.control_q[rows], exact.control_V[rows])
            q_ref, p_ref = reference_solve(sub, t, **state)
            src = row_source(sub, "exact V")
            force = (src.values_at, lambda x, src=src: -src.forces_at(x))
        qa, pa, r = estimate_at(q, p, *force, t, **state)
        true.append(loss_per_sample(qa, pa, q_ref, p_ref)["L_tot"])
        raw.append(r)
        # the finer look serves calls of the whole orbit only (.refine)
        qa, pa, r = (fine_estimate(name, V[rows], *force, t, **state)
                     if fine and t.max() > EARLY_HORIZON
                     else (qa, pa, np.full(rows.size, np.nan)))
        true_fine.append(loss_per_sample(qa, pa, q_ref, p_ref)["L_tot"])
        raw_fine.append(r)
    if not true:
        return (np.zeros(0), np.zeros(0), 0, np.zeros(0, dtype=bool), np.zeros(0),
                np.zeros(0))
    return (np.concatenate(true), np.concatenate(raw), int(V.shape[0]),
            np.concatenate(early), np.concatenate(true_fine), np.concatenate(raw_fine))


def _ood_ratios(name, n, seed, rng, states=False):
    """Like :func:`_batch_ratios` on :func:`~nh_operators.potentials.ood_potentials`
    (``states``: each from a state stratified by energy)."""
    from ..potentials import in_domain, ood_potentials
    from ..solvers import reference_solve
    from .catalog import network_domain

    true, raw, early, true_fine, raw_fine = [], [], [], [], []
    fine = refines(name)
    for pot in ood_potentials(n, seed):
        if not in_domain(pot.V(SENSORS), network_domain(name)):
            continue
        t = _asked_times(rng)
        early.append(t.max() <= EARLY_HORIZON)
        state = {}
        if states:
            q0, p0 = _states(lambda x, pot=pot: pot.V(x), 1, rng)
            state = {"q0": float(q0[0]), "p0": float(p0[0])}
        q, p, r = neural_raw(name, pot, "exact V", t, **state)
        ref = reference_solve(pot, t, **state)
        true.append(float(loss_per_sample(q, p, *ref)["L_tot"]))
        raw.append(r)
        fine_call = fine and t.max() > EARLY_HORIZON  # the finer look's calls (.refine)
        if fine_call:
            force = exact_force(pot)
            q, p, r = (a[0] for a in fine_estimate(name, pot.V(SENSORS)[None], *force, t,
                                                   **state))
            r = float(r) if np.isfinite(r) else np.inf
        true_fine.append(float(loss_per_sample(q, p, *ref)["L_tot"]) if fine_call else np.nan)
        raw_fine.append(r if fine_call else np.nan)
    return (np.array(true), np.array(raw), n, np.array(early, dtype=bool),
            np.array(true_fine), np.array(raw_fine))


def calibration_families(name, dataset, *, other=None, n_ood=600, ood_seed=2719,
                         n_sensors=None, seed=0):
    """The samples that calibrate model ``name``: {family: (true, raw, drawn, early,
    true_fine, raw_fine)}, ``early`` marking the samples of calls whose latest time is at
    most :data:`EARLY_HORIZON`, ``*_fine`` the same on the finer grid of
    :mod:`~nh_operators.solving.refine` (NaN for early calls and for a network that does
    not refine).

    Exact potentials: ``in distribution`` (the dataset's), ``other distribution``
    (``other``, a batched B-spline of the other generator, if given), ``out of
    distribution`` (:func:`~nh_operators.potentials.ood_potentials`); the same as sensor
    values (:data:`~nh_operators.solving.acceptance.SENSOR_FAMILIES`: force and truth
    from their spline; ``sensors``: the first ``n_sensors``, default all), each row at
    :data:`SENSOR_PASSES` sets of times. Each only where the network's domain admits it
    (what ``auto`` would hand it), at random asked times (:func:`_asked_times`). A network
    that reads a state starts from the dataset's own or, elsewhere, from states
    stratified by energy (:func:`~nh_operators.solvers.energy_states`).
    """
    from ..potentials import ood_potentials
    from ..solvers.rows import row_source
    from .catalog import reads_state

    rng = np.random.default_rng(seed)
    pots = dataset.potentials()
    states = reads_state(name)
    if states and getattr(dataset, "q0", None) is None:
        raise ValueError(f"{name} reads a starting state: calibrate it on a dataset with "
                         "states (nh-operators generate --states energy)")
    own = (dataset.q0, dataset.p0) if states else None
    out = {"in distribution": _batch_ratios(name, pots, False, rng, states=own)}
    if other is not None:
        drawn = _states(row_source(other, "exact V").values_at, len(other.control_q),
                        rng) if states else None
        out["other distribution"] = _batch_ratios(name, other, False, rng, states=drawn)
    if n_ood:
        out["out of distribution"] = _ood_ratios(name, n_ood, ood_seed, rng, states)
    head = slice(0, n_sensors)
    out["sensors"] = _sensor_family(name, dataset.V[head], rng, states,
                                    own and (own[0][head], own[1][head]))
    if other is not None:
        out[SENSOR_FAMILIES["other distribution"]] = _sensor_family(
            name, other.V(SENSORS), rng, states)
    if n_ood:
        V = np.stack([pot.V(SENSORS) for pot in ood_potentials(n_ood, ood_seed)])
        out[SENSOR_FAMILIES["out of distribution"]] = _sensor_family(name, V, rng, states)
    return out


#: Sets of asked times per row in a family of sensor values.
SENSOR_PASSES = 3


def _sensor_family(name, V, rng, states, own=None):
    """:func:`_batch_ratios` on sensor values V (N, 100), :data:`SENSOR_PASSES` times;
    ``states``: the rows' own (``own``) or drawn stratified by energy on their splines."""
    from ..solvers.rows import row_source

    V = np.asarray(V, dtype=np.float64)
    if states and own is None:
        own = _states(row_source(V, "sensors").values_at, len(V), rng)
    parts = [_batch_ratios(name, V, True, rng, states=own) for _ in range(SENSOR_PASSES)]
    true, raw, early, true_fine, raw_fine = (np.concatenate([p[k] for p in parts])
                                             for k in (0, 1, 3, 4, 5))
    return true, raw, len(V), early.astype(bool), true_fine, raw_fine
