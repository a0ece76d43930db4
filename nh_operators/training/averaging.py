"""An exponential moving average of a network's weights, with warm-up.

After optimiser step n the average moves towards the weights with the decay
d_n = min(decay, (1 + n) / (10 + n)): early on it follows the weights closely (d_1 ≈ 0.18),
and it reaches the cap ``decay`` after about 10 / (1 − decay) steps. A plain EMA at
0.999 from the first step would remember the random initial weights for thousands of
steps, which makes it useless in a short run.
"""

import contextlib

import torch

__all__ = ["WeightAverage"]


class WeightAverage:
    """EMA of every floating-point tensor of a network's ``state_dict``.

    Integer buffers are copied, not averaged.

    Args:
        net: the network whose weights are averaged (read, never changed, by
            :meth:`update`).
        decay: the cap of the decay, in (0, 1); 0.999 is a good value for runs of
            thousands of steps.

    Raises:
        ValueError: if ``decay`` is not in (0, 1).

    Example:
        >>> import torch
        >>> net = torch.nn.Linear(1, 1)
        >>> with torch.no_grad():
        ...     _ = net.weight.fill_(0.0)
        >>> avg = WeightAverage(net, 0.999)
        >>> with torch.no_grad():
        ...     _ = net.weight.fill_(1.0)
        >>> avg.update(net)  # d_1 = 2/11: the average moves 9/11 of the way
        >>> round(float(avg.shadow["weight"]), 6)
        0.818182
    """

    def __init__(self, net, decay):
        if not 0.0 < decay < 1.0:
            raise ValueError(f"the EMA decay must lie in (0, 1), got {decay}")
        self.decay = float(decay)
        self.steps = 0
        self.shadow = {k: v.detach().clone() for k, v in net.state_dict().items()}

    def rate(self, step):
        """The decay d_n used at step n (1-based)."""
        return min(self.decay, (1.0 + step) / (10.0 + step))

    @torch.no_grad()
    def update(self, net):
        """Fold the network's current weights into the average (after an optimiser step)."""
        self.steps += 1
        d = self.rate(self.steps)
        for key, value in net.state_dict().items():
            shadow = self.shadow[key]
            if shadow.is_floating_point():
                shadow.lerp_(value.detach(), 1.0 - d)
            else:
                shadow.copy_(value)

    @contextlib.contextmanager
    def applied(self, net):
        """Within the block ``net`` holds the averaged weights; its own come back after."""
        own = {k: v.detach().clone() for k, v in net.state_dict().items()}
        net.load_state_dict(self.shadow)
        try:
            yield net
        finally:
            net.load_state_dict(own)

    def state_dict(self):
        return {"decay": self.decay, "steps": self.steps, "shadow": self.shadow}

    def load_state_dict(self, state):
        self.decay = float(state["decay"])
        self.steps = int(state["steps"])
        for key, value in state["shadow"].items():
            self.shadow[key].copy_(value)
