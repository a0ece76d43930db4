"""Training losses by name (``TrainConfig.loss``): the paper's MSE, and LogCosh.

Validation always reports the paper's metric (the mean per-sample L_tot, an MSE),
whatever loss the optimiser follows; only ``train_loss`` in the history changes meaning.
"""

import math

import torch

__all__ = ["LOSSES", "log_cosh"]

_LOG2 = math.log(2.0)


def log_cosh(y_true, y_pred):
    """Mean of log(cosh(y_pred − y_true)) over all elements.

    Computed as x + softplus(−2x) − log 2, which does not overflow for large errors. For
    small errors it is x²/2 (half the MSE); for large ones abs(x) − log 2, so single bad
    samples pull less than under the MSE. This is the training loss of the reference
    code's later versions.

    Args:
        y_true, y_pred: tensors of the same shape.

    Returns:
        A scalar tensor.

    Example:
        >>> import torch
        >>> err = torch.tensor([0.0, 1e-3, -1e-3], dtype=torch.float64)
        >>> round(3 * float(log_cosh(torch.zeros(3, dtype=torch.float64), err)), 9)
        1e-06
    """
    x = y_pred - y_true
    return torch.mean(x + torch.nn.functional.softplus(-2.0 * x) - _LOG2)


#: Losses by name; the value is what ``dde.Model.compile(loss=...)`` takes.
LOSSES = {"mse": "mse", "logcosh": log_cosh}
