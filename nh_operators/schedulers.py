"""HyperbolicLR and ExpHyperbolicLR (Kim 2024, arXiv:2407.15200) as PyTorch schedulers.

With initial rate η₀ (the optimiser's ``lr``), infimum η_inf, epoch count N
(``max_iter``) and upper bound U ≥ N, both follow the hyperbola

    h(x) = sqrt((N − x)/U · (2 − (N + x)/U)),     0 ≤ x ≤ N,

which falls from h(0) = sqrt(N/U · (2 − N/U)) to h(N) = 0:

    HyperbolicLR:     η(x) = η₀ + (η₀ − η_inf) · (h(x) − h(0))
    ExpHyperbolicLR:  η(x) = η₀ · (η₀ / η_inf) ** (h(x) − h(0))

Its early slope does not depend on N, which is what makes the schedule "epoch
insensitive"; with N = U the last rate is exactly η_inf.

**Stepping.** ``x`` is measured in epochs. With the default ``steps_per_epoch=1``
the scheduler is stepped once per epoch, as in the paper. DeepXDE's training loop
steps a scheduler once per *iteration*; pass ``steps_per_epoch`` (iterations per
epoch) and x = iteration / steps_per_epoch becomes a fractional epoch, so the curve is
the same one, sampled finer. The trainer in :mod:`nh_operators.train` does this.
"""

import math

from torch.optim.lr_scheduler import LRScheduler

__all__ = ["HyperbolicLR", "ExpHyperbolicLR"]


class _Hyperbolic(LRScheduler):
    """Shared validation and the hyperbola h(x); subclasses give the rate."""

    def __init__(self, optimizer, upper_bound, max_iter, infimum_lr, *,
                 steps_per_epoch=1, last_epoch=-1):
        if not max_iter > 0:
            raise ValueError(f"max_iter must be positive, got {max_iter}")
        if upper_bound < max_iter:
            raise ValueError(
                f"upper_bound ({upper_bound}) must be at least max_iter ({max_iter})")
        if not infimum_lr > 0:
            raise ValueError(f"infimum_lr must be positive, got {infimum_lr}")
        if int(steps_per_epoch) != steps_per_epoch or steps_per_epoch < 1:
            raise ValueError(
                f"steps_per_epoch must be an integer ≥ 1, got {steps_per_epoch}")
        for group in optimizer.param_groups:
            lr0 = group.get("initial_lr", group["lr"])
            if not infimum_lr < lr0:
                raise ValueError(
                    f"infimum_lr ({infimum_lr}) must be below the initial lr ({lr0})")
        self.upper_bound = float(upper_bound)
        self.max_iter = float(max_iter)
        self.infimum_lr = float(infimum_lr)
        self.steps_per_epoch = int(steps_per_epoch)
        super().__init__(optimizer, last_epoch)

    def _h(self, x):
        n, u = self.max_iter, self.upper_bound
        x = min(x, n)  # held at the end value after max_iter epochs
        return math.sqrt(max((n - x) / u * (2.0 - (n + x) / u), 0.0))

    def epoch_position(self):
        """Fractional epoch x of the current step."""
        return self.last_epoch / self.steps_per_epoch

    def get_lr(self):
        dh = self._h(self.epoch_position()) - self._h(0.0)
        return [self._rate(lr0, dh) for lr0 in self.base_lrs]


class HyperbolicLR(_Hyperbolic):
    """η(x) = η₀ + (η₀ − η_inf) · (h(x) − h(0)), see the module docstring.

    Args:
        optimizer: a ``torch.optim.Optimizer``; its ``lr`` is η₀.
        upper_bound: U, at least ``max_iter`` (the paper uses 300–400).
        max_iter: N, the number of epochs of the run.
        infimum_lr: η_inf, below η₀; reached at x = N only when U = N.
        steps_per_epoch: scheduler steps per epoch (1: step per epoch; iterations per
            epoch: step per iteration with fractional epochs).

    Raises:
        ValueError: if U < N, η_inf ≥ η₀, or a count is not positive.

    Example:
        >>> import torch
        >>> opt = torch.optim.AdamW([torch.nn.Parameter(torch.zeros(1))], lr=1e-3)
        >>> sched = HyperbolicLR(opt, upper_bound=300, max_iter=50, infimum_lr=1e-6)
        >>> round(opt.param_groups[0]["lr"], 6)
        0.001
    """

    def _rate(self, lr0, dh):
        return lr0 + (lr0 - self.infimum_lr) * dh


class ExpHyperbolicLR(_Hyperbolic):
    """η(x) = η₀ · (η₀ / η_inf) ** (h(x) − h(0)), see the module docstring.

    The hyperbola in log space: log η falls from log η₀ along a curve whose
    asymptote is log η₀ − (log η₀ − log η_inf) · x / U. Arguments as
    :class:`HyperbolicLR`.

    Example:
        >>> import torch
        >>> opt = torch.optim.AdamW([torch.nn.Parameter(torch.zeros(1))], lr=1e-3)
        >>> sched = ExpHyperbolicLR(opt, upper_bound=300, max_iter=300, infimum_lr=1e-6)
        >>> for _ in range(300):
        ...     opt.step(); sched.step()
        >>> f"{opt.param_groups[0]['lr']:.1e}"
        '1.0e-06'
    """

    def _rate(self, lr0, dh):
        return lr0 * (lr0 / self.infimum_lr) ** dh
