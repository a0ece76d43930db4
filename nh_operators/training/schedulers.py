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
the same one, sampled finer. The trainer in :mod:`nh_operators.training.trainer` does this.
Add ``per_epoch=True`` to step per iteration but move the rate only at epoch ends
(x = whole epochs done): the reference code's per-epoch schedule inside DeepXDE's loop.
"""

import math

import torch
from torch.optim.lr_scheduler import LRScheduler

__all__ = ["HyperbolicLR", "ExpHyperbolicLR", "adjusted_infimum_lr"]


class _Hyperbolic(LRScheduler):
    """Shared validation and the hyperbola h(x); subclasses give the rate."""

    def __init__(self, optimizer, upper_bound, max_iter, infimum_lr, *,
                 steps_per_epoch=1, per_epoch=False, last_epoch=-1):
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
        self.per_epoch = bool(per_epoch)
        super().__init__(optimizer, last_epoch)

    def _h(self, x):
        n, u = self.max_iter, self.upper_bound
        x = min(x, n)  # held at the end value after max_iter epochs
        return math.sqrt(max((n - x) / u * (2.0 - (n + x) / u), 0.0))

    def _rate(self, lr0: float | torch.Tensor, dh: float) -> float | torch.Tensor:
        """The rate at h(x) − h(0) = dh from the initial rate lr0 (each schedule's own)."""
        raise NotImplementedError

    def epoch_position(self):
        """Fractional epoch x of the current step; with ``per_epoch`` the whole epochs
        done, so that the lr holds within an epoch and moves at its end (a scheduler
        stepped once per epoch, as the paper's reference code ran it)."""
        if self.per_epoch:
            return float(self.last_epoch // self.steps_per_epoch)
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
        per_epoch: with ``steps_per_epoch`` > 1, hold the rate within an epoch (x =
            whole epochs done) instead of moving it every iteration.

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


def adjusted_infimum_lr(lr, infimum_lr, upper_bound, epochs):
    """The paper's infimum for ExpHyperbolicLR on a larger dataset (its appendix).

    With more steps per epoch, a schedule tuned for ``epochs`` epochs ends at a learning
    rate η_N(N) below its asymptote l(N) = η0 (η_inf/η0)^(N/U); sensitive models then
    diverge. The adjusted schedule keeps η0, U and N and moves the infimum so that its
    asymptote at N is the geometric mean of the two:

        log η̃_inf = ½ [log η0 + log η_inf + (U/N)(log η_N(N) − log η0)],

    with log η_N(N) = log η0 − h(0) log(η0/η_inf), h(0) = sqrt(N/U (2 − N/U)).

    Args:
        lr: initial learning rate η0.
        infimum_lr: the tuned infimum η_inf.
        upper_bound: U (≥ epochs).
        epochs: N, the epochs the schedule was tuned for (the paper's N1).

    Returns:
        η̃_inf, the infimum to train the larger dataset with.

    Raises:
        ValueError: for non-positive rates, or U < N.

    Example:
        >>> round(adjusted_infimum_lr(1e-3, 1e-5, 300, 250), 10)
        6.5582e-06
    """
    if not (lr > 0 and infimum_lr > 0):
        raise ValueError(f"learning rates must be positive, got {lr} and {infimum_lr}")
    if not (epochs >= 1 and upper_bound >= epochs):
        raise ValueError(f"need 1 ≤ epochs ≤ upper_bound, got epochs={epochs}, "
                         f"upper_bound={upper_bound}")
    n, u = float(epochs), float(upper_bound)
    h0 = math.sqrt(n / u * (2.0 - n / u))
    log_end = math.log(lr) - h0 * math.log(lr / infimum_lr)  # log η_N(N)
    return math.exp(0.5 * (math.log(lr) + math.log(infimum_lr)
                           + u / n * (log_end - math.log(lr))))
