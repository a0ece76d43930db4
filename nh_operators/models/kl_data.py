"""Keep VaRONet's KL term in any DeepXDE data object: :class:`KLData`."""

from __future__ import annotations

from typing import Any

from .._backend import ensure_pytorch_backend

dde: Any = ensure_pytorch_backend()  # deepxde ships no type information

__all__ = ["KLData"]


class KLData(dde.data.Data):
    """A DeepXDE data object plus a network's KL term as an extra loss column.

    DeepXDE computes a loss from its data object alone, so a variational network's
    own term (VaRONet's ``net.kl``) is lost in ``TripleCartesianProd``,
    ``PDEOperatorCartesianProd`` or any other data object. Wrapping the data object
    keeps it: every training and test loss list gets one more column,
    β · kl / (k M), where k M is the number of outputs per sample (M query points, k
    outputs), so that the total is the paper's per-sample loss, Σ error² + β KL,
    divided by k M, as DeepXDE's mean-squared loss is. DeepXDE sums the columns for
    the gradient and reports them separately; with ``loss_weights`` in
    ``dde.Model.compile``, give one more weight, for this column, last.

    Everything else (batches, test data, attributes such as ``train_x``) is the
    wrapped object's.

    Args:
        data: any ``deepxde.data.Data``.
        beta: the KL weight β (non-negative; the paper tunes it per run).

    Raises:
        ValueError: for a negative beta.
        TypeError: at the first loss, if the network has no ``kl`` attribute or has
            not set it.

    Example:
        >>> import numpy as np, deepxde as dde
        >>> from nh_operators.models import VaRONet
        >>> t = np.linspace(0, 2, 5, dtype=np.float32)[:, None]
        >>> V, y = np.zeros((4, 100), np.float32), np.zeros((4, 5, 2), np.float32)
        >>> data = KLData(dde.data.TripleCartesianProd((V, t), y, (V, t), y), beta=0.1)
        >>> data.train_x[1].shape, data.beta  # the wrapped object's data
        ((5, 1), 0.1)
        >>> model = dde.Model(data, VaRONet(hidden_size=8, num_layers=1, latent_dim=2))
    """

    def __init__(self, data: Any, beta: float = 1.0) -> None:
        if beta < 0:
            raise ValueError(f"beta must be non-negative, got {beta}")
        self.data = data
        self.beta = float(beta)

    def __getattr__(self, name: str) -> Any:
        if name == "data":  # not set yet (e.g. while unpickling)
            raise AttributeError(name)
        return getattr(self.data, name)

    @staticmethod
    def _kl(model) -> Any:
        kl = getattr(model.net, "kl", None)
        if kl is None:
            raise TypeError(f"KLData needs a network that sets a kl attribute in its "
                            f"forward (VaRONet); {type(model.net).__name__} has none")
        return kl

    def _with_kl(self, losses, kl, outputs) -> list:
        losses = list(losses) if isinstance(losses, (list, tuple)) else [losses]
        per_sample = outputs[0].numel()  # k M outputs of one sample
        return losses + [self.beta * kl / per_sample]

    def losses_train(self, targets, outputs, loss_fn, inputs, model, aux=None) -> list:
        """The wrapped object's training losses, then β · kl / (k M)."""
        kl = self._kl(model)
        losses = self.data.losses_train(targets, outputs, loss_fn, inputs, model, aux=aux)
        return self._with_kl(losses, kl, outputs)

    def losses_test(self, targets, outputs, loss_fn, inputs, model, aux=None) -> list:
        """The wrapped object's test losses, then β · kl / (k M)."""
        kl = self._kl(model)
        losses = self.data.losses_test(targets, outputs, loss_fn, inputs, model, aux=aux)
        return self._with_kl(losses, kl, outputs)

    def train_next_batch(self, batch_size=None):
        """The wrapped object's next training batch."""
        return self.data.train_next_batch(batch_size)

    def test(self):
        """The wrapped object's test data."""
        return self.data.test()
