"""
Our architectures on your own operator problem
===============================================

The networks of this package are DeepXDE networks: they take DeepXDE's pair (branch
input, query points) for any number m of sensors, k of outputs and d of query
coordinates. Built with ``query_coupled=False``, each prediction depends on its own
query point only, so DeepXDE's ``dde.grad`` gives pointwise derivatives and a
physics-informed data object (``PDEOperatorCartesianProd``) can train them.

Here: the 1-D Poisson problem −u'' = f on [0, 1], u(0) = u(1) = 0, with f drawn from
a Gaussian random field, trained on the PDE residual alone (no solution data) for a
few hundred iterations with our FNO and with DeepXDE's own ``DeepONetCartesianProd``.
The benchmark ``benchmarks/problems/deepxde_problems.py`` runs this and three other
problems with every network (docs page "Our architectures on your own operator
problem").
"""

# %%
# The input functions
# -------------------
# A DeepXDE ``FunctionSpace`` needs ``random(n)`` (features of n functions) and
# ``eval_batch(features, points)``. Ours: a squared-exponential Gaussian random field
# sampled on a grid of 201 points (Cholesky factor of the kernel matrix), linear in
# between, with its own seeded generator.
import deepxde as dde
import matplotlib.pyplot as plt
import numpy as np
import torch

import nh_operators as nh  # selects DeepXDE's PyTorch backend before deepxde loads

torch.set_num_threads(1)


class SmallGRF(dde.data.function_spaces.FunctionSpace):
    def __init__(self, length_scale=0.2, n_grid=201, seed=0):
        self.x = np.linspace(0, 1, n_grid)
        K = np.exp(-0.5 * (self.x[:, None] - self.x) ** 2 / length_scale ** 2)
        self.L = np.linalg.cholesky(K + 1e-10 * np.eye(n_grid))
        self.rng = np.random.default_rng(seed)

    def random(self, size):
        return (self.L @ self.rng.standard_normal((len(self.x), size))).T

    def eval_one(self, feature, x):
        return np.interp(x, self.x, feature)

    def eval_batch(self, features, xs):
        return np.stack([np.interp(xs[:, 0], self.x, f) for f in features]).astype("float32")


space = SmallGRF()

# %%
# The physics-informed data
# -------------------------
# The residual −u'' − f at 40 points of [0, 1]; f enters as DeepXDE's auxiliary
# variable (the input function at the same points). The boundary conditions are hard:
# the output transform multiplies the network's output by x (1 − x). 32 sensors
# v(x_j) feed the branch; each step uses 8 of the 100 training functions.
geom = dde.geometry.Interval(0, 1)


def pde(x, u, f):
    return -dde.grad.hessian(u, x) - f


pde_data = dde.data.PDE(geom, pde, [], num_domain=38, num_boundary=2,
                        train_distribution="uniform")
sensors = np.linspace(0, 1, 32)[:, None]
data = dde.data.PDEOperatorCartesianProd(pde_data, space, sensors, 100, num_test=8,
                                         batch_size=8)


def hard_bc(inputs, u):
    x = inputs[1][:, 0]
    return u * (x * (1 - x))


# %%
# The networks
# ------------
# ``nh.build_model(name, preset="cpu", n_sensors=m, n_outputs=k, query_dim=d,
# query_coupled=False, ...)``. The FNO reads the sensors on its grid and returns a
# grid of ``n_grid`` points over ``query_range``; a query point is read off by a cubic
# spline, twice differentiable. Next to it, DeepXDE's own DeepONet.
torch.manual_seed(0)
ours = nh.build_model("fno", "cpu", n_sensors=32, n_outputs=1, query_dim=1,
                      query_coupled=False, query_range=(0.0, 1.0), n_grid=40,
                      n_modes=12, hidden_channels=16, n_layers=3)
torch.manual_seed(0)
theirs = dde.nn.DeepONetCartesianProd([32, 64, 64], [1, 64, 64], "tanh", "Glorot normal")
histories = {}
for name, net in (("FNO (ours)", ours), ("DeepONetCartesianProd", theirs)):
    net.apply_output_transform(hard_bc)
    model = dde.Model(data, net)
    model.compile("adam", lr=3e-3)
    histories[name], _ = model.train(iterations=300, display_every=50, verbose=0)
    print(f"{name}: {nh.count_parameters(net):,} parameters, PDE loss "
          f"{np.sum(histories[name].loss_train[0]):.3g} -> "
          f"{np.sum(histories[name].loss_train[-1]):.3g}")

# %%
# Against the reference
# ---------------------
# The reference solves −u'' = f by second-order finite differences on the GRF's grid
# (201 points), independently of any network. The metric is the mean relative l2
# error over 20 fresh test functions.
test_f = space.random(20)
h = space.x[1] - space.x[0]
n = len(space.x) - 2
A = (np.diag(2.0 * np.ones(n)) - np.diag(np.ones(n - 1), 1) - np.diag(np.ones(n - 1), -1))
u_ref = np.pad(np.linalg.solve(A, h * h * test_f[:, 1:-1].T).T, ((0, 0), (1, 1)))
v = torch.as_tensor(space.eval_batch(test_f, sensors))
x = torch.as_tensor(space.x[:, None], dtype=torch.float32)
fig, ax = plt.subplots(figsize=(6, 3.5))
ax.plot(space.x, u_ref[0], "k", lw=3, alpha=0.4, label="reference (finite differences)")
for name, net in (("FNO (ours)", ours), ("DeepONetCartesianProd", theirs)):
    with torch.no_grad():
        pred = net.eval()((v, x)).numpy()
    err = np.linalg.norm(pred - u_ref, axis=1) / np.linalg.norm(u_ref, axis=1)
    print(f"{name}: mean relative l2 error {err.mean():.3f}")
    ax.plot(space.x, pred[0], "--", label=name)
ax.set_xlabel("x")
ax.set_ylabel("u(x)")
ax.set_title("−u'' = f, one test function, after 300 iterations")
ax.legend()
fig.tight_layout()

# %%
# A few hundred iterations only show the machinery. The benchmark's table (the docs
# page) gives both networks the same iterations and the same wall clock on four
# problems, with every network of this package.
