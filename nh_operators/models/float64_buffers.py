"""A module of constant float64 tensors that ``.to()`` moves but never rounds.

A network's quadrature rule and spline maps are functions of the input alone, computed in
float64 whatever the network's own dtype. As buffers of a plain module they would follow
the network's casts (``net.float()``, ``cast_network``, DeepXDE's default float) and lose
their digits; kept in a dict outside the module they would miss ``.to(device)``.
:class:`Float64Buffers` keeps them as non-persistent buffers (so the ``state_dict`` does
not change) whose device follows every ``Module._apply`` and whose dtype stays float64.
"""

from collections.abc import Callable

import numpy as np
import torch

__all__ = ["Float64Buffers"]


class Float64Buffers(torch.nn.Module):
    """Abstract holder of constant float64 buffers: moved by ``.to(device)``, never cast.

    Subclasses register their tensors with :meth:`constant`; they hold no parameters.

    Example:
        >>> class Rule(Float64Buffers):
        ...     def __init__(self):
        ...         super().__init__()
        ...         self.constant("nodes", np.array([0.25, 0.75]))
        >>> rule = Rule().float()
        >>> rule.nodes.dtype, len(rule.state_dict())
        (torch.float64, 0)
    """

    def constant(self, name: str, value: np.ndarray | torch.Tensor) -> None:
        """Register ``value`` as the non-persistent float64 buffer ``name``.

        Args:
            name: the attribute name.
            value: an array (copied, strides kept) or a tensor, as float64.
        """
        tensor = (value.to(torch.float64) if isinstance(value, torch.Tensor)
                  else torch.tensor(value, dtype=torch.float64))
        self.register_buffer(name, tensor, persistent=False)

    def _apply(self, fn: Callable[[torch.Tensor], torch.Tensor],
               recurse: bool = True) -> "Float64Buffers":
        # The device a cast or move would send a float64 tensor to, asked of an empty one;
        # the buffer then goes there unrounded.
        if recurse:
            for module in self.children():
                module._apply(fn)
        for name, buffer in self._buffers.items():
            if buffer is not None:
                probe = torch.empty(0, dtype=torch.float64, device=buffer.device)
                self._buffers[name] = buffer.to(fn(probe).device)
        return self
