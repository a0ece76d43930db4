"""DeepONet: DeepXDE's own ``DeepONetCartesianProd``, configured for (q, p)."""

from typing import Any, Optional

import torch as _torch

from .._backend import ensure_pytorch_backend
from ._layers import match_default_float, split_inputs

_dde: Any = ensure_pytorch_backend()  # deepxde ships no type information

__all__ = ["DeepONet"]


class DeepONet(_dde.nn.pytorch.DeepONetCartesianProd):
    """DeepXDE's ``DeepONetCartesianProd`` with the paper's layout (§2.1).

    Not a re-implementation: this only turns the paper's three parameters into
    DeepXDE's layer lists. Branch: V (B, m) → ``hidden_layers`` × ``hidden_size`` →
    k · ``branches`` for k = ``n_outputs``; trunk: x (M, d) → the same; with DeepXDE's
    ``split_both`` strategy output i uses the i-th group of ``branches`` features
    (for the paper's problem the first gives q, the second p), each an inner product
    plus a learned bias.

    **Query points.** The trunk is a plain MLP whose first layer reads the d =
    ``query_dim`` coordinates of a point as they come, with no encoding and no scaling:
    keep them of order 1 (the paper's t ∈ [0, 2] is), or rescale them with DeepXDE's
    ``net.apply_feature_transform``. Each point goes through the trunk on its own, so
    the network is never query-coupled and ``dde.grad`` derivatives are pointwise
    (smooth activations, e.g. the default GELU, give non-zero second derivatives; ReLU's
    are zero).

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
        query_dim: number d of coordinates of a query point (default 1: the time).
        query_coupled: accepted for a common interface; only False (the default) is
            possible.
        regularization: DeepXDE's regularizer, e.g. ``("l2", 1e-5)`` (default None),
            passed to ``DeepONetCartesianProd``.

    Raises:
        ValueError: ``query_coupled=True``, or ``query_dim`` below 1.

    References:
        L. Lu, P. Jin, G. Pang, Z. Zhang and G. E. Karniadakis, "Learning nonlinear
        operators via DeepONet based on the universal approximation theorem of operators",
        Nature Machine Intelligence 3, 218-229 (2021). T.-G. Kim and S. C. Park,
        "Neural Hamilton: Can A.I. Understand Hamiltonian Mechanics?" (2024), §2.1.

    Example:
        >>> import torch
        >>> net = DeepONet(hidden_size=16, hidden_layers=2, branches=4)
        >>> net((torch.zeros(3, 100), torch.linspace(0, 2, 7)[:, None])).shape
        torch.Size([3, 7, 2])
    """

    #: Each query point goes through the trunk on its own.
    query_coupled = False

    def __init__(self, hidden_size: int = 128, hidden_layers: int = 3, branches: int = 10,
                 activation: str = "gelu", initializer: str = "Glorot normal",
                 n_sensors: int = 100, n_outputs: int = 2,
                 trunk_output_activation: bool = True, initial_state: bool = False,
                 query_dim: int = 1, query_coupled: Optional[bool] = False,
                 regularization=None):
        if query_coupled:
            raise ValueError("DeepONet cannot couple its query points (query_coupled=True): "
                             "its trunk reads each point on its own")
        if not isinstance(query_dim, int) or query_dim < 1:
            raise ValueError(f"query_dim must be a positive integer, got {query_dim!r}")
        hidden = [hidden_size] * hidden_layers
        extra = 2 if initial_state else 0
        width = n_outputs * branches
        torch_init = initializer == "torch"
        super().__init__(
            [n_sensors + extra, *hidden, width], [query_dim, *hidden, width], activation,
            "Glorot normal" if torch_init else initializer,
            num_outputs=n_outputs,
            multi_output_strategy="split_both" if n_outputs > 1 else None,
            regularization=regularization)
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
        self.query_dim = query_dim
        match_default_float(self)

    def forward(self, inputs):
        split_inputs(inputs, self.n_sensors, self.initial_state, self.query_dim)
        return super().forward(inputs)


def _identity(x):
    return x
