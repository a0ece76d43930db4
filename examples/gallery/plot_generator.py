"""
The generator: random bounded potentials and their exact trajectories
=====================================================================

A neural operator here learns the map from a potential V(q) on [0, 1] to the
trajectory (q(t), p(t)) of a unit mass released at rest at q = 0. Its training data
come from :class:`nh_operators.BoundedPotentialSpace`, the paper's Algorithm 1: a
Gaussian random field drawn at 2 to 7 nodes, turned into the control points of a
clamped cubic B-spline that starts and ends at V0 = 2 and stays below it inside.

This script draws a few potentials, checks that they are bounded, labels them with the
reference solver and shows what a network sees (the 100 sensor values) next to the
truth (the smooth curve).
"""

# %%
# Draw potentials
# ---------------
# The space owns a ``numpy.random.Generator``: the same seed gives the same
# potentials, whatever the batch size. Features hold n_GRF and the control points.
import matplotlib.pyplot as plt
import numpy as np

import nh_operators as nh

space = nh.BoundedPotentialSpace(seed=0)
features = space.random(6)
potentials = space.potentials(features)  # one batched BoundedPotential
print("interior control points per potential:", features[:, 0].astype(int).tolist())

# %%
# Every potential is bounded: V(0) = V(1) = V0 and V < V0 inside. The interior control
# values are at most V0 (1 - 2 * margin) = 1.8, so the particle always starts moving
# (the paper's normalisation put one of them exactly at V0).
q_fine = np.linspace(0.0, 1.0, 400)
values = potentials.V(q_fine)
print("V(0), V(1):", values[:, 0].round(12).tolist(), values[:, -1].round(12).tolist())
print(f"largest interior value: {values[:, 1:-1].max():.3f}")
print(f"largest interior control value: {np.nanmax(features[:, 8:]):.3f}")
nh.check_bounded(potentials.V(nh.SENSORS))  # raises if a row breaks the conditions

# %%
# Label them
# ----------
# :func:`nh_operators.reference_solve` integrates Hamilton's equations on the exact
# curve with an adaptive Dormand-Prince method at 1e-15; the energy stays at V0 to
# about 1e-11.
q, p, info = nh.reference_solve(potentials, nh.TIMES, full_output=True)
print("largest energy error:", f"{info['energy_error'].max():.1e}")

fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), layout="constrained")
for i in range(len(potentials)):
    (line,) = axes[0].plot(q_fine, values[i])
    axes[0].plot(nh.SENSORS[::3], potentials[i].V(nh.SENSORS[::3]), ".",
                 color=line.get_color(), markersize=3)
    axes[1].plot(nh.TIMES, q[i], color=line.get_color())
    axes[2].plot(q[i], p[i], color=line.get_color())
axes[0].axhline(nh.V0, color="k", linewidth=0.6, linestyle=":")
axes[0].set(xlabel="q", ylabel="V(q)", title="potentials (dots: every 3rd sensor)")
axes[1].set(xlabel="t", ylabel="q(t)", title="position")
axes[2].set(xlabel="q", ylabel="p", title="phase portrait")

# %%
# A dataset
# ---------
# :func:`nh_operators.data.generate_dataset` does the same in chunks, drops and counts
# the rare samples whose labels fail a check, and (with ``path=``) streams to an HDF5
# file that keeps the control points, so each true potential can be rebuilt.
from nh_operators.data import generate_dataset

ds = generate_dataset(50, seed=1, progress=False)
print(len(ds), "samples; V", ds.V.shape, "q", ds.q.shape, "dropped:", ds.attrs["n_dropped"])
exact = ds.potential(0)  # the smooth curve behind the first row of ds.V
print("sensors are samples of the curve:", np.allclose(exact.V(nh.SENSORS), ds.V[0]))
