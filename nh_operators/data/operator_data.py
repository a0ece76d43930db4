"""DeepXDE training data for the operators: reproducible batches, a KL column, batched
validation.

:class:`OperatorData` is a ``deepxde.data.TripleCartesianProd`` (so it is what
``dde.Model`` expects) with three changes DeepXDE has no hook for:

* batches come from a per-epoch permutation drawn from ``(shuffle_seed, epoch)``
  instead of NumPy's global generator, so a run is reproducible and can resume at any
  epoch boundary;
* a network with a ``kl`` attribute (VaRONet) gets β · kl / (2M) as a second loss
  column (DeepXDE sums the columns for the gradient and reports them separately):
  the paper's loss, Σ over the 2M outputs of the squared error plus β · KL, divided
  by 2M to match DeepXDE's mean-squared data loss;
* with ``physics`` (a :class:`~nh_operators.data.PhysicsTerms`), the training loss is
  the residual of Hamilton's equations (plus optional energy and label terms, the
  labels kept on ``physics.label_fraction`` of the rows) instead of the data loss;
* :meth:`validation_loss` evaluates the whole validation set in batches, while
  :meth:`test` (which DeepXDE evaluates in one forward) returns a small monitor batch.
"""

import math
from typing import Any

import numpy as np
import torch

from .._backend import ensure_pytorch_backend
from ..models import batched_forward
from .physics_loss import PhysicsTerms

dde: Any = ensure_pytorch_backend()  # deepxde ships no type information

__all__ = ["OperatorData"]


class OperatorData(dde.data.TripleCartesianProd):
    """``TripleCartesianProd`` with reproducible batches, a KL term and batched validation.

    Args:
        X_train: (V_train (N, m), t (M, 1)).
        y_train: (N, M, 2) targets (q, p), or (N, M).
        X_test: (V_val, t) for validation.
        y_test: validation targets.
        beta: weight β of a network's KL term (VaRONet), default 0.
        shuffle_seed: seed of the batch order.
        monitor_size: validation samples DeepXDE's own display evaluates (default 100).
        physics: a :class:`~nh_operators.data.PhysicsTerms` for physics-informed
            training (default None: the data loss). The network must be pointwise in
            time (``query_coupled`` False) and carry the starting state as an output
            transform (:func:`~nh_operators.data.state_transform`). Unlabelled rows'
            targets become NaN.

    Raises:
        TypeError: for a Dataset (use ``ds.to_deepxde()``) or missing arrays.

    The batch size is the one given to ``dde.Model.train``; an integer only
    (DeepXDE's tuple batch size indexes the targets wrongly).

    Attributes:
        cursor: iterations taken; advanced by the trainer after each step (see
            :meth:`advance`). Iteration k uses batch k mod steps of epoch
            k // steps.
        last_loss: the data loss of the last training step, as a float.
    """

    def __init__(self, X_train, y_train=None, X_test=None, y_test=None, *, beta=0.0,
                 shuffle_seed=0, monitor_size=100, physics=None):
        if hasattr(X_train, "to_deepxde"):
            raise TypeError("OperatorData takes arrays; a Dataset (generate_dataset, "
                            "load_dataset) makes its own: ds.to_deepxde()")
        if y_train is None or X_test is None or y_test is None:
            raise TypeError("OperatorData needs X_train, y_train, X_test and y_test")
        if physics is not None:
            if not isinstance(physics, PhysicsTerms):
                raise TypeError(f"physics must be a PhysicsTerms, got {type(physics).__name__}")
            y_train = np.array(y_train, dtype=np.result_type(y_train, np.float32))
            y_train[~physics.labelled(len(y_train))] = np.nan
        super().__init__(X_train, y_train, X_test, y_test)
        self.physics = physics
        if beta < 0:
            raise ValueError(f"beta must be non-negative, got {beta}")
        self.beta = float(beta)
        self.shuffle_seed = int(shuffle_seed)
        self.monitor_size = int(monitor_size)
        self.cursor = 0
        self.last_loss = None
        self._record = False
        self._perm: tuple[int | None, np.ndarray | None] = (None, None)

    @property
    def n_train(self):
        return len(self.train_x[0])

    def steps_per_epoch(self, batch_size):
        """Iterations per epoch (the last batch of an epoch may be smaller)."""
        return math.ceil(self.n_train / batch_size)

    def _permutation(self, epoch: int) -> np.ndarray:
        cached, perm = self._perm
        if perm is None or cached != epoch:
            rng = np.random.default_rng([self.shuffle_seed, epoch])
            perm = rng.permutation(self.n_train)
            self._perm = (epoch, perm)
        return perm

    def train_next_batch(self, batch_size=None):
        if batch_size is None:
            return self.train_x, self.train_y
        if isinstance(batch_size, (tuple, list)):
            raise ValueError("OperatorData takes an integer batch size (DeepXDE's tuple "
                             "batch size pairs the targets wrongly)")
        steps = self.steps_per_epoch(batch_size)
        epoch, k = divmod(self.cursor, steps)
        idx = self._permutation(epoch)[k * batch_size:(k + 1) * batch_size]
        self._record = True
        return (self.train_x[0][idx], self._trunk()), self.train_y[idx]

    def _trunk(self):
        """The query times of this iteration (with physics: plus its extra times)."""
        if self.physics is None:
            return self.train_x[1]
        return self.physics.times(self.train_x[1], self.cursor)

    def advance(self):
        """Move to the next batch; called once per training iteration."""
        self.cursor += 1

    def test(self):
        n = min(self.monitor_size, len(self.test_x[0]))
        return (self.test_x[0][:n], self.test_x[1]), self.test_y[:n]

    def _losses(self, targets, outputs, loss_fn, model, inputs=None):
        if self.physics is not None and inputs is not None:
            losses = self.physics.losses(inputs, outputs, targets,
                                         getattr(model.net, "n_sensors", inputs[0].shape[1]),
                                         iteration=self.cursor)
        else:
            losses = [loss_fn(targets, outputs)]
        kl = getattr(model.net, "kl", None)
        if hasattr(model.net, "kl") and kl is not None:
            # The paper's per-sample loss is Σ (error²) over the 2M outputs + β KL;
            # DeepXDE's data loss is the mean, so the KL column is β KL / (2M).
            return [*losses, self.beta * kl * (outputs.shape[0] / outputs.numel())]
        return losses

    def losses_train(self, targets, outputs, loss_fn, inputs, model, aux=None):
        losses = self._losses(targets, outputs, loss_fn, model, inputs)
        if self._record:  # the optimiser's call, not DeepXDE's display
            self.last_loss = float(sum(loss.detach() for loss in losses))
            self._record = False
        return losses

    def losses_test(self, targets, outputs, loss_fn, inputs, model, aux=None):
        return self._losses(targets, outputs, loss_fn, model, inputs)

    def validation_loss(self, net, batch_size=100):
        """Mean per-sample L_tot on the whole validation set, in batches.

        Args:
            net: the network (set to eval mode for the pass, then restored).
            batch_size: samples per forward.

        Returns:
            float: mean over samples of (L_q + L_p) / 2 (= the MSE over all entries).
        """
        total, count = self.validation_sums(net, batch_size)
        return total / count

    def validation_sums(self, net, batch_size=100):
        """Sum of the per-sample L_tot over this object's validation rows, and their number.

        A distributed run adds these over the ranks (each holds a share of the
        validation set) before dividing; :meth:`validation_loss` divides at once.

        Returns:
            (float, int): the sum and the number of samples.
        """
        V, t = self.test_x
        total = 0.0
        for start, out in batched_forward(net, V, t, batch_size):
            y = torch.as_tensor(self.test_y[start:start + len(out)], device=out.device,
                                dtype=out.dtype)
            err = (out - y) ** 2
            total += float(err.mean(dim=tuple(range(1, err.ndim))).sum())
        return total, len(V)
