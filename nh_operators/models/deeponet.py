"""DeepONet: DeepXDE's own ``DeepONetCartesianProd``, configured for (q, p)."""

import torch as _torch

from ._layers import _dde, split_inputs

__all__ = ["DeepONet"]


class DeepONet(_dde.nn.pytorch.DeepONetCartesianProd):
    """DeepXDE's ``DeepONetCartesianProd`` with the paper's layout (§2.1).

    Not a re-implementation: this only turns the paper's three parameters into
    DeepXDE's layer lists. Branch: V (B, m) → ``hidden_layers`` × ``hidden_size`` →
    2 · ``branches``; trunk: t (M, 1) → the same; with DeepXDE's ``split_both``
    strategy the first ``branches`` features give q and the last give p, each an
    inner product plus a learned bias.

    Args:
        hidden_size: width of the hidden layers (paper: 128).
        hidden_layers: hidden layers of branch and trunk (paper: 3).
        branches: basis functions per output, l (paper: 10).
        activation: DeepXDE activation name (default "gelu").
        initializer: DeepXDE initializer name (default "Glorot normal", with zero
            biases), or "torch" for PyTorch's own ``nn.Linear`` initialisation
            (uniform weights and biases of scale 1/√fan_in).
        trunk_output_activation: apply ``activation`` to the trunk's last layer too,
            as DeepXDE does (default True). False leaves the trunk's basis linear.
        n_sensors: length m of V (default 100).
        n_outputs: outputs per time (2: q and p; 1 gives shape (B, M)).
        initial_state: True: V carries (q0, p0) after the sensors, (B, m + 2), and the
            branch reads all m + 2 numbers (default False: rest at q = 0).

    Example:
        >>> import torch
        >>> net = DeepONet(hidden_size=16, hidden_layers=2, branches=4)
        >>> net((torch.zeros(3, 100), torch.linspace(0, 2, 7)[:, None])).shape
        torch.Size([3, 7, 2])
    """

    def __init__(self, hidden_size=128, hidden_layers=3, branches=10,
                 activation="gelu", initializer="Glorot normal", n_sensors=100,
                 n_outputs=2, trunk_output_activation=True, initial_state=False):
        hidden = [hidden_size] * hidden_layers
        extra = 2 if initial_state else 0
        width = n_outputs * branches
        torch_init = initializer == "torch"
        super().__init__(
            [n_sensors + extra, *hidden, width], [1, *hidden, width], activation,
            "Glorot normal" if torch_init else initializer,
            num_outputs=n_outputs,
            multi_output_strategy="split_both" if n_outputs > 1 else None)
        if torch_init:
            for layer in self.modules():
                if isinstance(layer, _torch.nn.Linear):
                    layer.reset_parameters()
        if not trunk_output_activation:
            # DeepXDE applies activation_trunk to the trunk's output only through this
            # attribute; the trunk's hidden layers keep their own activation.
            self.activation_trunk = _identity
        self.trunk_output_activation = bool(trunk_output_activation)
        self.n_sensors = n_sensors
        self.initial_state = bool(initial_state)

    def forward(self, inputs):
        split_inputs(inputs, self.n_sensors, self.initial_state)
        return super().forward(inputs)


def _identity(x):
    return x
