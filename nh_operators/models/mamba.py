"""A Mamba-1 block in pure PyTorch, weight-compatible with ``mamba_ssm``.

:class:`Mamba` has exactly the parameters (names, shapes, initialisation) of
``mamba_ssm.modules.mamba_simple.Mamba``, so a ``state_dict`` moves between the two with
``strict=True``. The selective scan runs, at forward time, on ``mamba_ssm``'s CUDA kernel
when the input is on a GPU in float32/float16/bfloat16 and ``mamba_ssm`` can be imported
(tried once, lazily: importing it takes seconds and needs CUDA), and otherwise on
:func:`~nh_operators.models._scan.selective_scan`, a custom autograd function that is
fast on a CPU.
"""

import importlib
import math
from typing import Any, cast

import torch
import torch.nn.functional as F
from torch import nn

from ._scan import selective_scan

__all__ = ["Mamba", "cuda_kernel_available"]

_KERNEL = {}  # "fn": mamba_ssm's selective_scan_fn, or None once its import failed


def _cuda_selective_scan_fn():
    """``mamba_ssm``'s ``selective_scan_fn``, imported on first use; None if unavailable."""
    if "fn" not in _KERNEL:
        try:
            # an optional CUDA package, absent where the types are checked: by name
            module = importlib.import_module("mamba_ssm.ops.selective_scan_interface")
            selective_scan_fn = module.selective_scan_fn
        except (ImportError, AttributeError, OSError, RuntimeError):
            # not installed, or its CUDA extension cannot load (no CUDA, ABI mismatch)
            selective_scan_fn = None
        _KERNEL["fn"] = selective_scan_fn
    return _KERNEL["fn"]


def cuda_kernel_available():
    """Whether ``mamba_ssm``'s CUDA selective scan can be used.

    Tries the import once (lazily, only when CUDA is present) and caches the answer.

    Returns:
      True if CUDA is available and
      ``mamba_ssm.ops.selective_scan_interface.selective_scan_fn`` imports.

    Example:
      >>> isinstance(cuda_kernel_available(), bool)
      True
    """
    return torch.cuda.is_available() and _cuda_selective_scan_fn() is not None


_KERNEL_DTYPES = (torch.float32, torch.float16, torch.bfloat16)


class Mamba(nn.Module):
    """Mamba-1 block (selective state-space model), parameters as in ``mamba_ssm``.

    Maps (batch, L, d_model) to (batch, L, d_model), causally along L: an input
    projection to x and a gate z (d_inner = expand * d_model each), a causal depthwise
    convolution and SiLU on x, input-dependent step sizes delta and matrices B, C from x,
    the selective scan with a diagonal A = -exp(A_log) and skip D, gating by SiLU(z) and
    an output projection.

    Args:
      d_model: width of the input and output (the paper: 128).
      d_state: size of the SSM state per channel, N (16 is the usual value; 8-16 is
        enough for short sequences).
      d_conv: width of the causal depthwise convolution (4).
      expand: d_inner / d_model (2).
      dt_rank: rank of the delta projection, or "auto" for ceil(d_model / 16).
      dt_min, dt_max: range of the initial step sizes, drawn log-uniformly (0.001, 0.1).
      dt_init_floor: lower clamp of the initial step sizes (1e-4).
      conv_bias: whether the convolution has a bias (True).
      bias: whether ``in_proj`` and ``out_proj`` have biases (False).
      layer_idx: index of the block in a stack; stored only, as in ``mamba_ssm``.
      fp32_A: take A = -exp(A_log) in float32 whatever the module's dtype, as the
        pure-PyTorch Mamba of the paper's reference code does (default False: in the
        working dtype). It changes float64 results only (by ~1e-12 here).
      device, dtype: factory arguments of the parameters. ``A_log`` and ``D`` are always
        float32 (until the module is cast, e.g. by ``.double()``).

    Attributes:
      in_proj: Linear(d_model, 2 * d_inner).
      conv1d: Conv1d(d_inner, d_inner, d_conv, groups=d_inner, padding=d_conv - 1).
      x_proj: Linear(d_inner, dt_rank + 2 * d_state), no bias.
      dt_proj: Linear(dt_rank, d_inner), with bias (inverse softplus of the initial dt).
      A_log: (d_inner, d_state), row i = log(1, ..., d_state); marked
        ``_no_weight_decay``.
      D: (d_inner,), ones; marked ``_no_weight_decay``.
      out_proj: Linear(d_inner, d_model).

    Example:
      >>> import torch
      >>> block = Mamba(d_model=16, d_state=4)
      >>> block(torch.randn(2, 10, 16)).shape
      torch.Size([2, 10, 16])
    """

    def __init__(self, d_model, d_state=16, d_conv=4, expand=2, dt_rank="auto",
                 dt_min=0.001, dt_max=0.1, dt_init_floor=1e-4, conv_bias=True,
                 bias=False, layer_idx=None, fp32_A=False, device=None, dtype=None):
        super().__init__()
        if not 0 < dt_min <= dt_max:
            raise ValueError(f"need 0 < dt_min <= dt_max, got {dt_min}, {dt_max}")
        factory: dict[str, Any] = {"device": device, "dtype": dtype}
        self.d_model = d_model
        self.d_state = d_state
        self.d_conv = d_conv
        self.expand = expand
        self.d_inner = int(expand * d_model)
        self.dt_rank = math.ceil(d_model / 16) if dt_rank == "auto" else int(dt_rank)
        self.layer_idx = layer_idx
        self.fp32_A = bool(fp32_A)
        d_inner = self.d_inner

        self.in_proj = nn.Linear(d_model, 2 * d_inner, bias=bias, **factory)
        self.conv1d = nn.Conv1d(d_inner, d_inner, kernel_size=d_conv, groups=d_inner,
                                padding=d_conv - 1, bias=conv_bias, **factory)
        self.x_proj = nn.Linear(d_inner, self.dt_rank + 2 * d_state, bias=False, **factory)
        self.dt_proj = nn.Linear(self.dt_rank, d_inner, bias=True, **factory)

        std = self.dt_rank ** -0.5
        nn.init.uniform_(self.dt_proj.weight, -std, std)
        log_dt = (torch.rand(d_inner, device=device) * (math.log(dt_max) - math.log(dt_min))
                  + math.log(dt_min))
        dt = torch.exp(log_dt).clamp(min=dt_init_floor)
        inv_softplus_dt = dt + torch.log(-torch.expm1(-dt))  # softplus(this) == dt
        with torch.no_grad():
            self.dt_proj.bias.copy_(inv_softplus_dt)

        rows = torch.arange(1, d_state + 1, dtype=torch.float32, device=device)
        self.A_log = nn.Parameter(torch.log(rows).repeat(d_inner, 1))
        cast(Any, self.A_log)._no_weight_decay = True  # mamba_ssm's optimiser flag
        self.D = nn.Parameter(torch.ones(d_inner, device=device))
        cast(Any, self.D)._no_weight_decay = True

        self.out_proj = nn.Linear(d_inner, d_model, bias=bias, **factory)

    def forward(self, hidden_states):
        """Apply the block.

        Args:
          hidden_states: (batch, L, d_model).

        Returns:
          (batch, L, d_model), same dtype; output t depends on inputs 0..t only.
        """
        if hidden_states.dim() != 3 or hidden_states.shape[-1] != self.d_model:
            raise ValueError(f"expected (batch, L, {self.d_model}), "
                             f"got {tuple(hidden_states.shape)}")
        length = hidden_states.shape[1]
        x, z = self.in_proj(hidden_states).chunk(2, dim=-1)  # (batch, L, d_inner) each
        x = self.conv1d(x.transpose(1, 2))[..., :length]  # causal: drop the right padding
        x = F.silu(x).transpose(1, 2)  # (batch, L, d_inner)
        dt, B, C = self.x_proj(x).split([self.dt_rank, self.d_state, self.d_state], dim=-1)
        dt_raw = F.linear(dt, self.dt_proj.weight)  # (batch, L, d_inner), bias added later

        kernel = None
        if hidden_states.is_cuda and hidden_states.dtype in _KERNEL_DTYPES:
            kernel = _cuda_selective_scan_fn()
        if kernel is not None:
            A = -torch.exp(self.A_log.float())
            y = kernel(x.transpose(1, 2), dt_raw.transpose(1, 2), A,
                       B.transpose(1, 2).contiguous(), C.transpose(1, 2).contiguous(),
                       self.D.float(), z=z.transpose(1, 2),
                       delta_bias=self.dt_proj.bias.float(), delta_softplus=True)
            return self.out_proj(y.transpose(1, 2))

        # float32 at least for the scan (half precision would lose the state)
        work = torch.promote_types(x.dtype, torch.float32)
        A_log = self.A_log.float() if self.fp32_A else self.A_log.to(work)
        A = -torch.exp(A_log).to(work)
        delta = F.softplus(dt_raw.to(work) + self.dt_proj.bias.to(work))
        x_w = x.to(work)
        y = selective_scan(x_w, delta, A, B.to(work), C.to(work))
        y = torch.addcmul(y, x_w, self.D.to(work))
        y = (y * F.silu(z.to(work))).to(x.dtype)
        return self.out_proj(y)
