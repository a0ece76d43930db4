"""Exact labels of drawn potentials, and the stream that draws, labels and filters them.

:func:`label_potentials` labels a batch by the reference solve and names why an invalid
sample fails; :class:`SampleSource` is the resumable stream :func:`~.generate.generate_dataset`
writes from; :class:`StateStream` draws the starting states of a dataset with states.
"""

import numpy as np

from .._constants import SENSORS, TIMES
from ..potentials import BoundedPotential
from ..solvers import reference_solve
from ..solvers.rows import row_source
from ..solvers.states import STATE_UNIFORMS, energy_states

__all__ = ["ENERGY_TOL", "LABEL_RTOL", "StateStream", "label_potentials"]

#: Label tolerances: reference solve, energy drift and excursion beyond [0, 1] allowed.
LABEL_RTOL = 1e-15
ENERGY_TOL = 1e-10
BOUNDS_TOL = 1e-9


def label_potentials(potentials, t=TIMES, *, rtol=LABEL_RTOL, energy_tol=ENERGY_TOL,
                     q0=0.0, p0=0.0):
    """Exact labels of a batch of potentials, with the reason each invalid one fails.

    Args:
        potentials: a batched :class:`BoundedPotential` of N potentials.
        t: query times, shape (M,).
        rtol: tolerance of the reference solve (also its atol).
        energy_tol: largest ``|p²/2 + V(q) - E|`` accepted, E the starting energy.
        q0, p0: starting states, scalars or (N,) (default: the paper's (0, 0)).

    Returns:
        (q, p, reasons): q and p of shape (N, M); reasons a list of N strings, empty for
        a valid sample, else one of "non-finite", "left [0, 1]", "energy drift",
        "step budget".
    """
    q, p, info = reference_solve(potentials, t, q0=q0, p0=p0, rtol=rtol, atol=rtol,
                                 full_output=True)
    reasons = []
    for qi, pi, energy, steps in zip(q, p, info["energy_error"], info["steps"], strict=True):
        if steps < 0:
            reasons.append("step budget")
        elif not (np.all(np.isfinite(qi)) and np.all(np.isfinite(pi))):
            reasons.append("non-finite")
        elif qi.min() < -BOUNDS_TOL or qi.max() > 1 + BOUNDS_TOL:
            reasons.append("left [0, 1]")
        elif not energy <= energy_tol:
            reasons.append("energy drift")
        else:
            reasons.append("")
    return q, p, reasons



class StateStream:
    """The starting states of a dataset with states: :func:`energy_states` fed by its own
    generator (seeded from the dataset's seed), :data:`STATE_UNIFORMS` numbers per drawn
    potential, so the states do not depend on the chunk size and resume exactly."""

    def __init__(self, seed, separatrix_share):
        if not 0.0 <= separatrix_share <= 1.0:
            raise ValueError(f"separatrix_share must be in [0, 1], got {separatrix_share}")
        self.rng = np.random.default_rng([int(seed), 1])
        self.separatrix_share = float(separatrix_share)

    def params(self):
        """What the HDF5 attributes record."""
        return {"distribution": "energy", "separatrix_share": self.separatrix_share,
                "near_separatrix_gap": [1e-4, 1e-1], "stream": "PCG64([seed, 1])"}

    def state(self):
        return self.rng.bit_generator.state

    def set_state(self, state):
        self.rng.bit_generator.state = state

    def draw(self, pots):
        """(q0, p0, near) of a batched :class:`BoundedPotential`."""
        u = self.rng.random((len(pots), STATE_UNIFORMS))
        return energy_states(row_source(pots, "exact V").values_at, u,
                             separatrix_share=self.separatrix_share)


class SampleSource:
    """Draws, labels and filters potentials; remembers how many were dropped and why."""

    def __init__(self, space, rtol, energy_tol, skip=0, states=None):
        self.space = space
        self.states = states
        self.rtol = rtol
        self.energy_tol = energy_tol
        self.skip_left = skip

    def state(self):
        """Where the stream stands (JSON-able), for a resume."""
        out = {"space": self.space.state(), "skip_left": self.skip_left}
        if self.states is not None:
            out["states"] = self.states.state()
        return out

    def set_state(self, state):
        self.space.set_state(state["space"])
        if self.states is not None:
            self.states.set_state(state["states"])
        self.skip_left = int(state["skip_left"])

    def take(self, n, drops=None):
        """The next n valid samples as a dict of arrays, and the drop counts."""
        drops = {} if drops is None else drops
        if self.skip_left:  # valid samples drawn and discarded first (skip)
            skip, self.skip_left = self.skip_left, 0
            _, drops = self.take(skip, drops)
        parts = []
        kept = 0
        while kept < n:
            skipped = self.space.skipped
            feats, scales = self.space.random_with_scales(n - kept)
            at_v0 = self.space.skipped - skipped
            if at_v0:
                drops[_AT_V0] = drops.get(_AT_V0, 0) + at_v0
            cq, cv = self.space.controls(feats)
            pots = BoundedPotential(cq, cv)
            start = {}
            if self.states is not None:
                q0, p0, near = self.states.draw(pots)
                start = {"q0": q0, "p0": p0}
            q, p, reasons = label_potentials(pots, TIMES, rtol=self.rtol,
                                             energy_tol=self.energy_tol, **start)
            ok = np.array([r == "" for r in reasons])
            for r in reasons:
                if r:
                    drops[r] = drops.get(r, 0) + 1
            parts.append({
                "V": pots[ok].V(SENSORS) if ok.any() else np.empty((0, SENSORS.size)),
                "q": q[ok], "p": p[ok], "n_grf": feats[ok, 0].astype(np.int8),
                "control_q": cq[ok], "control_V": cv[ok], "length_scale": scales[ok],
            })
            if start:
                parts[-1].update(q0=q0[ok], p0=p0[ok], near_separatrix=near[ok].astype(np.int8))
            kept += int(ok.sum())
        arrays = {k: np.concatenate([part[k] for part in parts]) for k in parts[0]}
        arrays["x"] = np.array(SENSORS)
        arrays["t"] = np.array(TIMES)
        return arrays, drops


#: Drop reason of a batch-normalised candidate whose interior control value is V0 itself
#: (the pool's minimum GRF value): its force at the wall can vanish, so it is skipped.
_AT_V0 = "interior control value at V0"


