"""
Solve a potential typed as a formula, with a solver or a shipped network
========================================================================

:func:`nh_operators.solve` takes a potential in many forms (a formula in ``q``, a
callable, 100 sensor values, the name of a physical potential) and returns the
trajectory at exactly the times asked, with an error estimate and the reason for the
method it chose. :func:`nh_operators.pretrained` loads a shipped network offline.
"""

# %%
# A formula, to a tolerance
# -------------------------
# The text is parsed with a whitelist (numbers, ``q``, ``pi``, ``e``, arithmetic and
# elementary functions), never ``eval``; the potential must be bounded
# (V(0) = V(1) = 2, V < 2 inside).
import matplotlib.pyplot as plt
import numpy as np

import nh_operators as nh

formula = "2 - 12*q*(1 - q)*(1 + 0.5*q)"
times = [0.25, 0.5, 1.0, 1.9]
sol = nh.solve(formula, times, tol=1e-8)
print("q:", np.round(sol.q, 6))
print("p:", np.round(sol.p, 6))
print(f"method {sol.method} ({sol.kind}), estimated L_tot {sol.error_estimate:.1e}")
print("why:", sol.reason)

# %%
# The same potential with the shipped DeepONet
# --------------------------------------------
# A shipped model is a :class:`nh_operators.NeuralMethod`: call it with sensor values
# (N, 100) and times (M,). It sees the potential only at :data:`nh_operators.SENSORS`.
# The shipped DeepONet is a small network trained for minutes on a CPU (its test-set
# score is in ``model.metrics``), so it is far less accurate than the solver.
model = nh.pretrained("deeponet")
print("shipped models:", nh.available_pretrained())
evaluation = model.metrics.get("evaluation", {})
if "test" in evaluation:
    print(f"its test-set mean L_tot: {evaluation['test']['mean']:.2e}")

potential = nh.parse_potential(formula)
V = potential.V(nh.SENSORS)[None, :]  # (1, 100)
q_net, p_net = model(V, nh.TIMES)  # (1, 100) each
reference = nh.solve(formula, nh.TIMES, tol=1e-10)  # the classical solve on the grid
error = np.mean((q_net[0] - reference.q) ** 2 + (p_net[0] - reference.p) ** 2) / 2
print(f"DeepONet against the solver: L_tot = {error:.2e}")

fig, axes = plt.subplots(1, 3, figsize=(12, 3.6), layout="constrained")
grid = np.linspace(0, 1, 300)
axes[0].plot(grid, potential.V(grid), "k")
axes[0].plot(nh.SENSORS, V[0], ".", markersize=3, label="sensors")
axes[0].set(xlabel="q", ylabel="V(q)", title=formula)
axes[0].legend()
for ax, true, pred, name in ((axes[1], reference.q, q_net[0], "q"),
                             (axes[2], reference.p, p_net[0], "p")):
    ax.plot(nh.TIMES, true, "k", label="solver, tol 1e-10")
    ax.plot(nh.TIMES, pred, "--", label="shipped DeepONet")
    ax.set(xlabel="t", ylabel=f"{name}(t)")
    ax.legend()

# %%
# Forcing a method
# ----------------
# ``method=`` names an integrator of :data:`nh_operators.METHODS` or a shipped model.
# A forced network still reports its estimate (here far above the tolerance, hence a
# warning).
import warnings

sol_y8 = nh.solve(formula, times, tol=1e-10, method="yoshida8")
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    sol_net = nh.solve(formula, times, tol=1e-6, method="deeponet")
print(f"yoshida8: {sol_y8.error_estimate:.1e}; deeponet: {sol_net.error_estimate:.1e}")
for w in caught:
    print(f"{w.category.__name__}: {w.message}")
