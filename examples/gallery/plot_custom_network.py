"""
Plug your own DeepXDE network into the benchmark
================================================

Any network that follows the package's contract can be trained with DeepXDE and
scored next to the shipped networks and the classical solvers:

* it is a ``deepxde.nn.pytorch.NN`` whose ``forward`` takes the pair ``(V, t)``, with
  V of shape (batch, 100) (the potential at :data:`nh_operators.SENSORS`) and t of
  shape (M, 1), and returns (batch, M, 2) holding q and p;
* it applies DeepXDE's input transform (to t) and output transform itself, as
  DeepXDE's own ``DeepONetCartesianProd`` does.

Wrapped in :class:`nh_operators.NeuralMethod`, it goes to
:func:`nh_operators.evaluate_methods` like any other method.
"""

# %%
# A network
# ---------
# A small example: an MLP reads the 100 sensor values and returns the coefficients of
# a fixed Fourier basis in t, one set for q and one for p. (Not a good operator; the
# point is the contract.)
import math

import deepxde as dde
import numpy as np
import torch

import nh_operators as nh  # selects DeepXDE's PyTorch backend before deepxde loads


class FourierONet(dde.nn.pytorch.NN):
    """V (B, 100), t (M, 1) -> (B, M, 2): q and p as sums of cos/sin(k pi t / 2)."""

    query_coupled = False  # each time is predicted on its own (see nh.predict)

    def __init__(self, width=64, n_modes=8, n_sensors=100):
        super().__init__()
        self.n_modes = n_modes
        n_coef = 2 * n_modes + 1
        self.branch = torch.nn.Sequential(
            torch.nn.Linear(n_sensors, width), torch.nn.GELU(),
            torch.nn.Linear(width, width), torch.nn.GELU(),
            torch.nn.Linear(width, 2 * n_coef))

    def basis(self, t):
        k = torch.arange(1, self.n_modes + 1, dtype=t.dtype, device=t.device)
        angle = t * k * (math.pi / 2)  # (M, n_modes): periods 4/k on t in [0, 2]
        return torch.cat([torch.ones_like(t), torch.cos(angle), torch.sin(angle)], dim=1)

    def forward(self, inputs):
        V, t = inputs
        if self._input_transform is not None:
            t = self._input_transform(t)
        coef = self.branch(V).reshape(V.shape[0], 2, -1)  # (B, 2, n_coef)
        y = torch.einsum("bof,mf->bmo", coef, self.basis(t))  # (B, M, 2)
        if self._output_transform is not None:
            y = self._output_transform(inputs, y)
        return y


torch.manual_seed(0)
net = FourierONet()
out = net((torch.zeros(3, 100), torch.linspace(0, 2, 7)[:, None]))
print("output shape:", tuple(out.shape), "parameters:", nh.count_parameters(net))

# %%
# Train it with DeepXDE
# ---------------------
# ``Dataset.to_deepxde()`` gives DeepXDE's ``TripleCartesianProd`` data (the
# package's :class:`nh_operators.OperatorData`): branch input V (N, 100), trunk input
# t (100, 1), targets (N, 100, 2), with an 80/20 train/validation split. Without a
# batch size, DeepXDE takes the whole training part at every step.
from nh_operators.data import generate_dataset

train_set = generate_dataset(200, seed=8407, progress=False)
test_set = generate_dataset(100, seed=42, progress=False)

model = dde.Model(train_set.to_deepxde(), net)
model.compile("adam", lr=3e-3)
loss_history, _ = model.train(iterations=600, display_every=200, verbose=0)
print("training loss, every 200 steps:", np.round(np.sum(loss_history.loss_train, axis=1), 4))

# %%
# With 160 training potentials and full batches it overfits: its test loss below is
# well above its training loss.

# %%
# Score it next to the others
# ---------------------------
# ``NeuralMethod`` predicts in batches without a graph, checks that inputs are inside
# the generator's range (``OutOfDomainWarning`` otherwise) and reports its device.
# Here it meets the shipped DeepONet and two classical baselines on the same 100 test
# potentials. Without ``cache_dir`` nothing is cached; with one, give your network a
# new name (or ``fresh=True``) after changing it: a method that is not loaded from a
# run directory is cached under its name alone.
from nh_operators.evaluation import plot_work_precision, work_precision_rows

methods = {
    "fourier_onet": nh.NeuralMethod(net, "fourier_onet"),
    "deeponet (shipped)": nh.pretrained("deeponet"),
    "rk4_sensors_1": nh.CLASSICAL_METHODS["rk4_sensors_1"],
    "rk4_sensors_4": nh.CLASSICAL_METHODS["rk4_sensors_4"],
}
settings = nh.EvaluationSettings(n_single=5, n_batched=100, repeats=3)
results, arrays = nh.evaluate_methods(methods, test_set, settings, progress=False)

for name, entry in results["methods"].items():
    print(f"{name:19s} test mean L_tot {entry['test']['mean']:.2e}   SHO "
          f"{entry['physical']['sho']:.1e}   "
          f"{entry['seconds_per_trajectory']['batched'] * 1e6:7.1f} µs/trajectory")

fig = plot_work_precision(work_precision_rows(results),
                          title="your network in the speed/accuracy plane")
