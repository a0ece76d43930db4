"""
Classical solvers: convergence orders and the information floor
===============================================================

The networks are compared with classical integrators that see the same information:
the potential at the 100 sensors. This script measures two things.

1. On a smooth potential with a known solution (the harmonic oscillator), each
   fixed-step method converges at its order: RK4 and Yoshida-4 at 4, Verlet at 2,
   Yoshida-6 and -8 at 6 and 8.
2. On the generator's potentials, known only at the sensors, the error stops falling
   at a floor set by the cubic spline of the 100 sensor values, not by the step: more
   substeps buy nothing below it.
"""

# %%
# Orders on the harmonic oscillator
# ---------------------------------
# V(q) = 8 (q - 1/2)^2 has the exact solution q(t) = (1 - cos 4t) / 2. The error is the
# paper's per-sample loss L_tot (mean squared error of q and p over the 100 query
# times, averaged), so it falls like h^(2 * order).
import matplotlib.pyplot as plt
import numpy as np

import nh_operators as nh
from nh_operators.evaluation import loss_per_sample

sho = nh.PHYSICAL_POTENTIALS["sho"]
q_true, p_true = sho.exact(nh.TIMES)
substeps = np.array([1, 2, 4, 8])

fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
for method in ("verlet", "rk4", "yoshida4", "yoshida6", "yoshida8"):
    errors = []
    for k in substeps:
        q, p = nh.integrate(sho, nh.TIMES, method, substeps=int(k))
        errors.append(float(loss_per_sample(q, p, q_true, p_true)["L_tot"]))
    errors = np.array(errors)
    usable = errors > 1e-26  # round-off floor of float64 for this loss
    slope = np.polyfit(np.log(substeps[usable]), np.log(errors[usable]), 1)[0]
    print(f"{method:9s} L_tot {errors[0]:.1e} -> {errors[-1]:.1e}, fitted order {-slope / 2:.1f}")
    ax.loglog(substeps, errors, "o-", label=f"{method} (order {-slope / 2:.1f})")
ax.set(xlabel="steps per output interval", ylabel="L_tot against the exact solution",
       title="harmonic oscillator")
ax.legend()

# %%
# The information floor on generator potentials
# ---------------------------------------------
# RK4 on the exact curve keeps converging; RK4 on the spline of the sensors levels off.
# The floor is the distance between the true potential and the spline of its samples.
# At one step per interval a few steep potentials make RK4 warn
# (:class:`nh_operators.ResolutionWarning`, printed below) and names the substeps that
# suffice.
space = nh.BoundedPotentialSpace(seed=42)
potentials = space.potentials(space.random(200))
q_ref, p_ref = nh.reference_solve(potentials, nh.TIMES)
V = potentials.V(nh.SENSORS)

import warnings

rows = {"RK4 on the exact V": [], "RK4 on the sensor spline": []}
steps = [1, 2, 4, 8, 16]
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    for k in steps:
        q, p = nh.integrate(potentials, nh.TIMES, "rk4", substeps=k)
        rows["RK4 on the exact V"].append(loss_per_sample(q, p, q_ref, p_ref)["L_tot"].mean())
        q, p = nh.integrate_sensors(V, nh.TIMES, "rk4", substeps=k)
        rows["RK4 on the sensor spline"].append(
            loss_per_sample(q, p, q_ref, p_ref)["L_tot"].mean())
for w in caught:
    print(f"{w.category.__name__}: {w.message}")

fig, ax = plt.subplots(figsize=(6.4, 4.4), layout="constrained")
for label, errors in rows.items():
    ax.loglog(steps, errors, "o-", label=label)
    print(f"{label:25s}", " ".join(f"{e:.1e}" for e in errors))
ax.set(xlabel="steps per output interval", ylabel="mean L_tot over 200 potentials",
       title="generator potentials")
ax.legend()

# %%
# The paper's RK4 row used one step per output interval and a PCHIP force; done
# correctly (:func:`nh_operators.paper_rk4`) it is still far above RK4 with a cubic
# spline at a few substeps. Over 4,000 test potentials the sensor-spline floor is a
# mean L_tot of about 3.5e-6 (``python benchmarks/cost/classical_speed_accuracy.py``).
q, p = nh.paper_rk4(V, nh.TIMES)
print(f"paper-replica RK4: mean L_tot {loss_per_sample(q, p, q_ref, p_ref)['L_tot'].mean():.1e}")
