"""The generator's Gaussian draw in plain floating-point loops: the same bits on any CPU.

:class:`~nh_operators.potentials.BoundedPotentialSpace` draws its GRF values as
X = L z, with L the lower Cholesky factor of the squared-exponential covariance K and
z standard normals. Through NumPy, both K and L depend on the CPU: ``np.exp`` has its
own AVX-512 code path (it differs from the scalar one in the last bit of about 5 % of
arguments), and ``np.linalg.cholesky`` / ``@`` run whichever OpenBLAS kernel suits the
CPU (SkylakeX, Haswell, Zen, ...), each summing in its own order. The last bits of the
control values, and so every sensor value and label of a dataset, then depend on the
machine that made it.

Here every step is a loop over Python floats with only +, -, ×, ÷ and the square root,
all of which IEEE 754 rounds exactly, in a fixed order: :func:`portable_exp` (exp
from those operations), :func:`se_covariance`, :func:`cholesky_lower` and
:func:`lower_times`. The same inputs give the same bits on any IEEE-754 machine,
whatever its vector units, BLAS or C library. With n ≤ 7 the cost is a few tens of µs
per potential, next to milliseconds for its labels.

:data:`DRAW_VERSION` numbers the draw; a dataset records it in its ``generator``
attribute (``"draw"``). Draw 1 (nh-operators 0.x before this module, no ``"draw"``
key) computed K with ``np.exp`` and X with ``np.linalg.cholesky(K) @ z``; draw 2 is this
module. Both consume the generator's random numbers identically and agree but for the
last bits (control values, of size at most 2, by up to 7e-14).
"""

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["DRAW_VERSION", "DRAW_VERSIONS", "JITTER", "cholesky_lower", "grf_values",
           "lower_times", "portable_exp", "se_covariance"]

#: The version of the Gaussian draw that :class:`BoundedPotentialSpace` uses.
DRAW_VERSION = 2
#: What each draw version computed (datasets record the number as ``generator["draw"]``).
DRAW_VERSIONS = {
    1: "np.exp and BLAS Cholesky: last bits depend on the CPU",
    2: "plain-loop exp and Cholesky: the same bits on any CPU",
}
#: Added to the covariance's diagonal (keeps K positive definite at long length scales).
JITTER = 1e-12

# ln 2 split so that k · _LN2_HI is exact for |k| < 2**21 (its low 21 bits are zero)
_LN2_HI = float.fromhex("0x1.62e42fee00000p-1")
_LN2_LO = float.fromhex("0x1.a39ef35793c76p-33")
_INV_LN2 = float.fromhex("0x1.71547652b82fep0")
# 1/k! for k = 2..13: the Taylor tail of exp(r) - 1 - r on |r| <= ln(2)/2 (remainder
# below 2**-60 relative)
_TAYLOR = tuple(1.0 / math.factorial(k) for k in range(2, 14))
_EXP_MAX = 709.782712893384  # exp overflows above
_EXP_MIN = -745.1332191019412  # exp rounds to 0 below


def portable_exp(x: float) -> float:
    """e**x from +, -, ×, ÷ and ldexp only: the same bits on any IEEE-754 machine.

    x = k ln 2 + r with |r| <= ln(2)/2 (Cody and Waite's two-part ln 2), exp(r) - 1 by
    its Taylor series to degree 13 in Horner form, then 1 + that, scaled by 2**k. Within
    1 ulp of the true value (measured on 2,900 arguments in [-745, 709]: at most 0.88
    ulp); it differs from ``math.exp`` by 1 ulp on about 10 % of arguments.

    Args:
        x: the exponent.

    Returns:
        e**x as a float (0.0 below about -745.13, inf above about 709.78, NaN for NaN).

    Example:
        >>> portable_exp(0.0), portable_exp(-800.0), portable_exp(1.0) - math.e
        (1.0, 0.0, 4.440892098500626e-16)
    """
    x = float(x)
    if x != x:
        return x
    if x > _EXP_MAX:
        return math.inf
    if x < _EXP_MIN:
        return 0.0
    k = math.floor(x * _INV_LN2 + 0.5)
    r = (x - k * _LN2_HI) - k * _LN2_LO
    s = _TAYLOR[-1]
    for c in _TAYLOR[-2::-1]:
        s = c + r * s
    return math.ldexp(1.0 + (r + (r * r) * s), k)


def se_covariance(n: int, length_scale: float) -> list[list[float]]:
    """The squared-exponential covariance of the generator's n nodes, with jitter.

    K_ij = exp(-(y_i - y_j)² / (2 l²)) + JITTER δ_ij at y_i = i / (n + 1), i = 1..n,
    by :func:`portable_exp`.

    Args:
        n: number of nodes (≥ 1).
        length_scale: l (> 0).

    Returns:
        K as n lists of n floats (symmetric).

    Example:
        >>> K = se_covariance(2, 1.0)
        >>> K[0][0], K[0][1] == K[1][0] == portable_exp(-1 / 18)
        (1.000000000001, True)
    """
    y = [i / (n + 1) for i in range(1, n + 1)]
    two_l2 = 2.0 * (length_scale * length_scale)
    out = [[0.0] * n for _ in range(n)]
    for i in range(n):
        out[i][i] = 1.0 + JITTER
        for j in range(i):
            d = y[i] - y[j]
            out[i][j] = out[j][i] = portable_exp(-(d * d) / two_l2)
    return out


def cholesky_lower(cov: Sequence[Sequence[float]] | np.ndarray) -> np.ndarray:
    """The lower Cholesky factor L of a symmetric positive definite matrix, L Lᵀ = cov.

    The textbook column-by-column recurrence in plain float loops (no BLAS), each sum
    taken in index order, so the result does not depend on the CPU.

    Args:
        cov: (n, n) symmetric positive definite matrix (only its lower triangle is read).

    Returns:
        (n, n) float64 array, zero above the diagonal.

    Raises:
        ValueError: if cov is not square, or not positive definite (a pivot ≤ 0 or NaN).

    Example:
        >>> cholesky_lower([[4.0, 2.0], [2.0, 5.0]]).tolist()
        [[2.0, 0.0], [1.0, 2.0]]
    """
    a = np.asarray(cov, dtype=np.float64)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"cholesky_lower needs a square matrix, got shape {a.shape}")
    rows = a.tolist()
    n = len(rows)
    low = [[0.0] * n for _ in range(n)]
    for j in range(n):
        s = rows[j][j]
        for k in range(j):
            s -= low[j][k] * low[j][k]
        if not s > 0.0:
            raise ValueError(f"cholesky_lower: the matrix is not positive definite "
                             f"(pivot {j} is {s!r})")
        pivot = math.sqrt(s)
        low[j][j] = pivot
        for i in range(j + 1, n):
            s = rows[i][j]
            for k in range(j):
                s -= low[i][k] * low[j][k]
            low[i][j] = s / pivot
    return np.array(low, dtype=np.float64).reshape(n, n)


def lower_times(low: Sequence[Sequence[float]] | np.ndarray,
                z: Sequence[float] | np.ndarray) -> np.ndarray:
    """L z for a lower-triangular L, each row's sum in index order (no BLAS).

    Args:
        low: (n, n) lower-triangular matrix (entries above the diagonal are not read).
        z: (n,) vector.

    Returns:
        (n,) float64 array.

    Raises:
        ValueError: if the shapes do not match.

    Example:
        >>> lower_times([[2.0, 0.0], [1.0, 2.0]], [1.0, -1.0]).tolist()
        [2.0, -1.0]
    """
    rows = np.asarray(low, dtype=np.float64)
    vec = np.asarray(z, dtype=np.float64).reshape(-1)
    n = vec.size
    if rows.shape != (n, n):
        raise ValueError(f"lower_times: L of shape {rows.shape} and z of {n} entries")
    lows, zs = rows.tolist(), vec.tolist()
    out = []
    for i in range(n):
        s = 0.0
        for k in range(i + 1):
            s += lows[i][k] * zs[k]
        out.append(s)
    return np.array(out, dtype=np.float64)


def grf_values(n: int, length_scale: float, z: Sequence[float] | np.ndarray) -> np.ndarray:
    """GRF values X = L z at the generator's n nodes (draw 2): L the Cholesky factor of
    :func:`se_covariance`, z the standard normals already drawn.

    Args:
        n: number of nodes.
        length_scale: the kernel's length scale.
        z: (n,) standard normals.

    Returns:
        (n,) float64 array.

    Example:
        >>> x = grf_values(3, 0.1, [1.0, 0.0, 0.0])
        >>> bool(x[0] == math.sqrt(1 + JITTER)), x.shape
        (True, (3,))
    """
    return lower_times(cholesky_lower(se_covariance(n, length_scale)), z)
