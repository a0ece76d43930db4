"""The selective scan of Mamba-1 in plain PyTorch, with a hand-written reverse pass.

The recurrence, per batch element b and channel d, with a state of size ``d_state``::

    h_0 = 0
    h_t = exp(delta_t * A) * h_{t-1} + (delta_t * u_t) * B_t
    y_t = sum_n C_{t,n} h_{t,n}

A naive autograd loop over time records a dozen small nodes per step and keeps every
intermediate; a parallel scan materialises (batch, L, d_inner, d_state) tensors several
times. Here the forward walks time in (batch, d_inner, d_state) slices and keeps, of the
history, only the state every ~sqrt(L) steps (checkpoints, in one preallocated buffer).
The backward walks the chunks between checkpoints last to first: it recomputes the
chunk's states and ``exp(delta_t * A)`` into two reused (~sqrt(L)-slice) buffers, then
walks them in reverse, accumulating the gradients of u, delta, A, B and C by hand. That
is about 3 sqrt(L) state slices instead of L + 1 (for L = 100: 30 instead of 101), and,
as reused buffers stay mapped and cached, faster as well. Without gradients no history
is kept at all.
"""

import math

import torch

__all__ = ["selective_scan", "selective_scan_reference"]

# exp(x) is computed as exp2(x * log2(e)): torch's exp2 is several times faster on CPUs
_LOG2E = 1.4426950408889634


def _check(u, delta, A, B, C):
    if u.dim() != 3 or delta.shape != u.shape:
        raise ValueError(f"u and delta must both be (batch, L, d_inner), got {tuple(u.shape)} "
                         f"and {tuple(delta.shape)}")
    batch, length, d_inner = u.shape
    if length == 0:
        raise ValueError("the sequence length L must be at least 1")
    if A.dim() != 2 or A.shape[0] != d_inner:
        raise ValueError(f"A must be (d_inner={d_inner}, d_state), got {tuple(A.shape)}")
    want = (batch, length, A.shape[1])
    if tuple(B.shape) != want or tuple(C.shape) != want:
        raise ValueError(f"B and C must both be {want}, got {tuple(B.shape)} and {tuple(C.shape)}")
    tensors = (u, delta, A, B, C)
    if len({t.dtype for t in tensors}) != 1 or len({t.device for t in tensors}) != 1:
        raise ValueError("u, delta, A, B and C must share one dtype and one device")
    if not u.is_floating_point():
        raise ValueError(f"selective_scan needs floating-point inputs, got {u.dtype}")


def _time_major(x):
    """(batch, L, k) -> contiguous (L, batch, k)."""
    return x.transpose(0, 1).contiguous()


def _batch_major(x):
    """(L, batch, k) -> (batch, L, k) view; None stays None."""
    return None if x is None else x.transpose(0, 1)


def _checkpoint_every(length):
    """Steps per chunk between stored states: about sqrt(L) balances the two buffers."""
    return max(1, math.isqrt(length - 1) + 1) if length > 1 else 1


def _scan_forward(u, delta, A2, B, C, h0=None, states=None, decays=None,
                  checkpoints=None, every=0, want_y=True):
    """Forward recurrence on time-major inputs.

    Args:
      u, delta: (L, batch, d_inner), contiguous.
      A2: A * log2(e), (d_inner, d_state).
      B, C: (L, batch, d_state), contiguous.
      h0: state before the first step, (batch, d_inner, d_state); None for zeros.
      states, decays: optional (L, batch, d_inner, d_state) buffers receiving the state
        after each step and exp(delta_t A) (the latter left unset where h0 is None, t = 0).
        Without ``states`` two slices are reused.
      checkpoints, every: optional (n, batch, d_inner, d_state) buffer receiving the state
        after steps ``every``, 2 ``every``, ..., n ``every`` (1-based).
      want_y: whether to compute the output.

    Returns:
      y, (L, batch, d_inner), or None.
    """
    length, batch, d_inner = u.shape
    d_state = A2.shape[1]
    du = delta * u
    y = u.new_empty(length, batch, d_inner) if want_y else None
    # without the caller's buffers: exp(delta_t A) in one reused slice, h in two
    scratch = u.new_empty(batch, d_inner, d_state) if decays is None else decays[0]
    slots = u.new_empty(2, batch, d_inner, d_state) if states is None else states
    h_prev = h0
    for t in range(length):
        h = states[t] if states is not None else slots[t % 2]
        if h_prev is None:  # zero state: only the input term
            torch.mul(du[t].unsqueeze(-1), B[t].unsqueeze(1), out=h)
        else:
            dA = decays[t] if decays is not None else scratch
            torch.mul(delta[t].unsqueeze(-1), A2, out=dA)
            torch.exp2(dA, out=dA)
            torch.mul(dA, h_prev, out=h)
            h.addcmul_(du[t].unsqueeze(-1), B[t].unsqueeze(1))
        if y is not None:  # y_t = C_t . h_t, as a row vector times h_t^T (fast batched matmul)
            torch.bmm(C[t].unsqueeze(1), h.transpose(1, 2), out=y[t].unsqueeze(1))
        if checkpoints is not None and (t + 1) % every == 0:
            slot = (t + 1) // every - 1  # the state after the last step needs no slot
            if slot < len(checkpoints):
                checkpoints[slot].copy_(h)
        h_prev = h
    return y


def _scan_backward(gy, u, delta, A, B, C, checkpoints, every, needs):
    """Reverse pass on time-major tensors; ``needs`` flags (u, delta, A, B, C).

    Time is cut into chunks of ``every`` steps. For each chunk, last first, the states
    and decays exp(delta_t A) are recomputed from the chunk's checkpoint into two reused
    buffers, then walked in reverse. With ``gh`` the gradient of the loss with respect to
    h_t, each step adds the read-out ``gy_t C_t``, takes the gradients of C_t, (delta u)_t
    and B_t from it, and carries ``gh * exp(delta_t A)`` to h_{t-1}; with
    ``W_t = gh_t * exp(delta_t A) * h_{t-1}``, d delta_t += sum_n W_t A and
    dA += sum_b W_t delta_t.
    """
    length, batch, d_inner = u.shape
    d_state = A.shape[1]
    need_u, need_delta, need_A, need_B, need_C = needs
    A2 = A * _LOG2E
    du = delta * u
    span = min(every, length)
    states = u.new_empty(span, batch, d_inner, d_state)
    decays = u.new_empty(span, batch, d_inner, d_state)
    gh = u.new_zeros(batch, d_inner, d_state)
    w = u.new_empty(batch, d_inner, d_state)
    gdu = u.new_empty(length, batch, d_inner)
    gB = u.new_empty(length, batch, d_state) if need_B else None
    gC = u.new_empty(length, batch, d_state) if need_C else None
    gdelta_A = u.new_zeros(length, batch, d_inner) if need_delta else None
    gA_acc = u.new_zeros(batch, d_inner, d_state) if need_A else None
    ones = u.new_ones(d_state)
    for j in range((length - 1) // every, -1, -1):
        start, stop = j * every, min((j + 1) * every, length)
        h0 = checkpoints[j - 1] if j > 0 else None
        _scan_forward(u[start:stop], delta[start:stop], A2, B[start:stop], C[start:stop],
                      h0=h0, states=states, decays=decays, want_y=False)
        for t in range(stop - 1, start - 1, -1):
            i = t - start
            gh.addcmul_(gy[t].unsqueeze(-1), C[t].unsqueeze(1))
            if gC is not None:
                torch.bmm(gy[t].unsqueeze(1), states[i], out=gC[t].unsqueeze(1))
            torch.bmm(B[t].unsqueeze(1), gh.transpose(1, 2), out=gdu[t].unsqueeze(1))
            if gB is not None:
                torch.bmm(du[t].unsqueeze(1), gh, out=gB[t].unsqueeze(1))
            if t == 0:
                break  # h_{-1} = 0: nothing flows through exp(delta_0 A) nor further back
            gh.mul_(decays[i])
            if gdelta_A is not None or gA_acc is not None:
                h_before = states[i - 1] if i > 0 else h0
                assert h_before is not None  # t > 0 here, so h_{t-1} is a stored state
                torch.mul(gh, h_before, out=w)
                if gA_acc is not None:
                    gA_acc.addcmul_(w, delta[t].unsqueeze(-1))
                if gdelta_A is not None:  # sum over n as a matrix-vector product: faster than sum
                    w.mul_(A)
                    torch.mv(w.view(-1, d_state), ones, out=gdelta_A[t].view(-1))
    gu = gdu * delta if need_u else None
    gdelta = torch.addcmul(gdelta_A, gdu, u) if gdelta_A is not None else None
    gA = gA_acc.sum(0) if gA_acc is not None else None
    return gu, gdelta, gA, gB, gC


class _SelectiveScan(torch.autograd.Function):
    @staticmethod
    def forward(ctx, u, delta, A, B, C):
        u_t, delta_t, B_t, C_t = map(_time_major, (u, delta, B, C))
        length, batch, d_inner = u_t.shape
        every = _checkpoint_every(length)
        checkpoints = u.new_empty((length - 1) // every, batch, d_inner, A.shape[1])
        y = _scan_forward(u_t, delta_t, A * _LOG2E, B_t, C_t, checkpoints=checkpoints,
                          every=every)
        assert y is not None  # want_y
        ctx.save_for_backward(u_t, delta_t, A, B_t, C_t)
        ctx.checkpoints, ctx.every = checkpoints, every  # internal, never handed out
        return y.transpose(0, 1)

    @staticmethod
    @torch.autograd.function.once_differentiable
    def backward(ctx, gy):
        u_t, delta_t, A, B_t, C_t = ctx.saved_tensors
        grads = _scan_backward(_time_major(gy), u_t, delta_t, A, B_t, C_t, ctx.checkpoints,
                               ctx.every, ctx.needs_input_grad)
        gu, gdelta, gA, gB, gC = grads
        return _batch_major(gu), _batch_major(gdelta), gA, _batch_major(gB), _batch_major(gC)


def selective_scan(u, delta, A, B, C):
    """Selective scan of Mamba-1 (no D skip, no gating), differentiable in all inputs.

    Computes, from h_0 = 0, ``h_t = exp(delta_t * A) * h_{t-1} + (delta_t * u_t)[..., None]
    * B_t[:, None, :]`` and ``y_t = sum_n C_{t,n} h_{t,n}``. With gradients, memory is
    about 3 sqrt(L) (batch, d_inner, d_state) slices (checkpoints, recomputed in the
    backward); under ``torch.no_grad()`` (or when no input requires grad) two slices.
    Plain torch ops: any device, float32 or float64 (use float32 for half-precision
    inputs). Not twice differentiable.

    Args:
      u: input, (batch, L, d_inner).
      delta: step sizes, (batch, L, d_inner), already positive (softplus applied).
      A: state matrix diagonal, (d_inner, d_state), negative reals.
      B: input matrix, (batch, L, d_state).
      C: output matrix, (batch, L, d_state).

    Returns:
      y, (batch, L, d_inner), same dtype and device as u.

    Raises:
      ValueError: on inconsistent shapes, dtypes or devices.

    Example:
      >>> import torch
      >>> u, delta = torch.randn(2, 5, 3), torch.rand(2, 5, 3)
      >>> A = -torch.arange(1.0, 5.0).repeat(3, 1)
      >>> B, C = torch.randn(2, 5, 4), torch.randn(2, 5, 4)
      >>> selective_scan(u, delta, A, B, C).shape
      torch.Size([2, 5, 3])
    """
    _check(u, delta, A, B, C)
    if torch.is_grad_enabled() and any(t.requires_grad for t in (u, delta, A, B, C)):
        return _SelectiveScan.apply(u, delta, A, B, C)
    u_t, delta_t, B_t, C_t = map(_time_major, (u, delta, B, C))
    y = _scan_forward(u_t, delta_t, A * _LOG2E, B_t, C_t)
    assert y is not None  # want_y
    return y.transpose(0, 1)


def selective_scan_reference(u, delta, A, B, C):
    """The same scan as :func:`selective_scan` as a plain autograd loop over time.

    Slow and memory-hungry; it exists as the reference for the tests and benchmarks.

    Args:
      u: (batch, L, d_inner).
      delta: (batch, L, d_inner), positive.
      A: (d_inner, d_state).
      B: (batch, L, d_state).
      C: (batch, L, d_state).

    Returns:
      y, (batch, L, d_inner).

    Example:
      >>> import torch
      >>> u, delta = torch.randn(1, 4, 2), torch.rand(1, 4, 2)
      >>> A, B, C = -torch.ones(2, 3), torch.randn(1, 4, 3), torch.randn(1, 4, 3)
      >>> torch.allclose(selective_scan_reference(u, delta, A, B, C),
      ...                selective_scan(u, delta, A, B, C), atol=1e-6)
      True
    """
    _check(u, delta, A, B, C)
    batch, length, d_inner = u.shape
    h = u.new_zeros(batch, d_inner, A.shape[1])
    ys = []
    for t in range(length):
        dA = torch.exp(delta[:, t, :, None] * A)
        h = dA * h + (delta[:, t] * u[:, t])[..., None] * B[:, t, None, :]
        ys.append((h * C[:, t, None, :]).sum(-1))
    return torch.stack(ys, dim=1)
