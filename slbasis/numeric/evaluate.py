"""Stable evaluation of the orthonormal functions by the normalised three-term recurrence.

Algorithm. With ``phi_{-1} = 0`` and ``phi_0`` from ``kernel.log_phi0``,

    phi_{n+1}(x) = ((x - b_n) phi_n(x) - A_n phi_{n-1}(x)) / A_{n+1}

(the orthonormal recurrence, e.g. Gautschi, *Orthogonal Polynomials: Computation and
Approximation*, 2004, eq. 1.3.2 applied to ``sqrt(w) p_n``). In float64 the plain
recurrence dies where ``phi_0`` underflows (Hermite functions: ``|x| > ~38``, i.e.
``N > ~700``; Laguerre functions: ``x > ~1480``) although ``phi_n`` itself is O(1)
there. We therefore carry a *mantissa* ``m_n`` and a per-sample base-2 exponent ``e``,
``phi_n = m_n 2^e``: ``phi_0`` is split exactly from its logarithm (Cody–Waite reduction),
the recurrence runs on the mantissas (it is linear and homogeneous, so a common scale
per sample does not change it), and the pair ``(m_{n-1}, m_n)`` is renormalised with
``frexp``/``ldexp`` (exact power-of-two scalings, no rounding) before it can overflow.
The renormalisation points are chosen from the a-priori growth bound

    max(|m_{n+1}|, |m_n|) <= g_n max(|m_n|, |m_{n-1}|),
    g_n = max(1, (max_x |x - b_n| + |A_n|) / |A_{n+1}|),

so no overflow is possible; values that are below the float64 range come out as 0 (or a
subnormal) only at the very end (``ldexp``), never in the middle of the recurrence.

Accuracy: the recurrence is forward-stable in the direction of increasing ``n`` for
these (dominant) solutions; the remaining error is the relative error of ``phi_0``
itself, ``~ |log phi_0| * eps`` (about ``5e-13`` relative at ``x = 100`` for Hermite
functions, where ``x^2/2`` is already rounded in float64).
"""

from __future__ import annotations

import numpy as np

from . import engine as _engine
from .kernel import Kernel

__all__ = ["evaluate", "evaluate_derivative", "polynomial_newton_ratio", "recurrence"]

# Cody–Waite split of ln 2 (fdlibm): LN2_HI has 21 trailing zero bits, so k * LN2_HI is
# exact for |k| < 2^21.
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_INV_LN2 = 1.4426950408889634074
_GROWTH_BUDGET = 900.0  # log2 of the largest growth allowed between renormalisations
_MAX_STEPS = 64  # renormalise at least this often (protects against slow decay)
_DEFAULT_CHUNK = 8192  # samples per block: amortises the per-step Python overhead


class Recurrence:
    """Recurrence coefficients of a kernel in the form used by the evaluator.

    ``m_{n+1} = ((x - b_n) m_n - A_n m_{n-1}) / A_{n+1}`` (dividing, not multiplying by a
    rounded reciprocal: Laguerre functions at x = 0, N = 2000 keep 2e-13 instead of 3e-12).
    """

    __slots__ = ("N", "b", "A_prev", "A_next", "inv_A_next", "has_b", "abs_A_prev", "abs_inv_A")

    def __init__(self, kernel: Kernel, N: int) -> None:
        diag, off = kernel.jacobi(N)
        diag = np.asarray(diag, dtype=float)
        off = np.asarray(off, dtype=float)
        if diag.shape != (N,) or off.shape != (N,):
            raise ValueError(f"kernel.jacobi({N}) must return two arrays of shape ({N},)")
        if np.any(off == 0) or not np.all(np.isfinite(off)):
            raise ValueError(f"kernel.jacobi({N}): off-diagonal must be finite and nonzero")
        self.N = N
        self.b = diag
        self.A_prev = np.concatenate(([0.0], off[:-1]))  # A_n for n = 0..N-1
        self.A_next = off  # A_{n+1}
        self.inv_A_next = 1.0 / off
        self.has_b = bool(np.any(diag != 0))
        self.abs_A_prev = np.abs(self.A_prev)
        self.abs_inv_A = np.abs(self.inv_A_next)

    def schedule(self, xmin: float, xmax: float, nsteps: int) -> list[int]:
        """Indices ``n`` after which the mantissa pair is renormalised (growth bound)."""
        b = self.b[:nsteps]
        dist = np.maximum(np.abs(xmax - b), np.abs(xmin - b))
        with np.errstate(divide="ignore"):
            g = np.log2(
                np.maximum(1.0, (dist + self.abs_A_prev[:nsteps]) * self.abs_inv_A[:nsteps])
            )
        # a block of steps start..n is closed *before* step n when its growth g[start..n]
        # exceeds the budget or it reaches _MAX_STEPS steps; the next block starts at n.
        # Found block by block from the cumulative growth (a search per block, not a
        # Python step per row); the values do not depend on where the blocks end
        # (renormalisation by powers of two is exact), only the growth bound does
        G = np.concatenate(([0.0], np.cumsum(g)))  # G[n + 1] = g[0] + ... + g[n]
        points = []
        start = 0
        while True:
            # first n >= start with G[n + 1] - G[start] > budget (n = start is never closed
            # by the budget alone: a block always takes its first step)
            n_budget = int(np.searchsorted(G, G[start] + _GROWTH_BUDGET, side="right")) - 1
            n = min(max(n_budget, start + 1), start + _MAX_STEPS - 1)
            if n >= nsteps:
                return points
            points.append(n)  # renormalise *before* step n (after rows up to n)
            start = n

    def renorm_mask(self, x: np.ndarray, nrows: int) -> np.ndarray:
        """``mask[n]``: renormalise the pair ``(n - 1, n)`` before row ``n`` (``n >= 1``),
        from :meth:`schedule` over the finite range of ``x`` (valid for any subset of it)."""
        fin = np.isfinite(x)
        xmin = float(np.min(x[fin])) if fin.any() else 0.0
        xmax = float(np.max(x[fin])) if fin.any() else 0.0
        mask = np.zeros(nrows, dtype=np.bool_)
        points = [n for n in self.schedule(xmin, xmax, nrows - 1) if n > 0]
        mask[points] = True
        return mask


def recurrence(kernel: Kernel, N: int) -> Recurrence:
    """Precompute the recurrence coefficients of the first ``N + 1`` functions.

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions.

    Returns
    -------
    Recurrence
        The coefficients in the evaluator's form (reusable by :func:`evaluate`).

    Raises
    ------
    ValueError
        If the kernel's recurrence coefficients have the wrong shape, or an off-diagonal is
        zero or not finite.
    """
    return Recurrence(kernel, N)


def _split_log(logabs: np.ndarray, sign: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact-as-possible split ``sign * exp(logabs) = m * 2^e`` with ``|m|`` in [1, 2)."""
    logabs = np.asarray(logabs, dtype=float)
    finite = np.isfinite(logabs)
    la = np.where(finite, logabs, 0.0)
    k = np.floor(la * _INV_LN2)
    r = (la - k * _LN2_HI) - k * _LN2_LO
    m = np.exp(r) * np.sign(sign)
    m = np.where(finite, m, np.where(logabs > 0, np.sign(sign) * np.inf, 0.0))
    return m, k.astype(np.int64)


def _pow2_split(e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exponents ``(e1, e2)``, ``e1 + e2 = e``, with ``(m 2^e1) 2^e2 = round(m 2^e)``.

    In the normal range ``e2 = 0``. Below it ``e1 = e + 1022`` (exact scaling, or an
    underflow of a value whose result is 0 anyway) and ``e2 = -1022`` (one rounding into
    the subnormals); above it, symmetrically. ``e1`` is clipped to the normal range, where
    the result under- or overflows anyway.
    """
    low, high = e < -1022, e > 1023
    e1 = np.where(low, np.maximum(e + 1022, -1022), np.where(high, np.minimum(e - 1023, 1023), e))
    e2 = np.where(low, -1022, np.where(high, 1023, 0))
    return e1, e2


def _scale_rows(block: np.ndarray, e: np.ndarray) -> None:
    """``block *= 2^e`` (per column) in place, correctly rounded.

    ``np.ldexp`` costs ~5 ns per element; multiplying by the float ``2^e`` costs ~0.2 ns and
    is exact whenever ``2^e`` and the result are normal numbers. Columns outside the
    normal exponent range get two multiplications (:func:`_pow2_split`); the result is
    still ``m 2^e`` rounded once (only subnormal results are rounded at all).
    """
    if block.shape[0] == 0:
        return
    if e.min() >= -1022 and e.max() <= 1023:
        block *= np.ldexp(1.0, e)
        return
    e1, e2 = _pow2_split(e)
    block *= np.ldexp(1.0, e1)
    block *= np.ldexp(1.0, e2)


def _fill(rec: Recurrence, nrows: int, x: np.ndarray, out: np.ndarray, m0, e0) -> None:
    """Fill ``out[:nrows]`` (shape ``(nrows, len(x))``) with phi_0..phi_{nrows-1} at ``x``."""
    e = e0.copy()
    out[0] = m0
    if nrows == 1:
        _scale_rows(out[:1], e)
        return
    fin = np.isfinite(x)
    xmin = float(np.min(x[fin])) if fin.any() else 0.0
    xmax = float(np.max(x[fin])) if fin.any() else 0.0
    sched = set(rec.schedule(xmin, xmax, nrows - 1))
    tmp = np.empty_like(x)
    tmp2 = np.empty_like(x)
    b, Ap, A_next = rec.b, rec.A_prev, rec.A_next
    start = 0  # first row of the current block (rows start..n share the exponent e)
    # row 1: m_1 = (x - b_0) m_0 / A_1
    for n in range(nrows - 1):
        if n in sched and n > 0:
            # rows start..n-1 are final for exponent e; renormalise the pair (n-1, n) and
            # keep row n as a mantissa of the next block (exponent e + k)
            prev = out[n - 1].copy()
            cur = out[n]
            _scale_rows(out[start:n], e)
            big = np.maximum(np.abs(prev), np.abs(cur))
            _, k = np.frexp(big)
            k = np.where(np.isfinite(big), k, 0)
            np.ldexp(prev, -k, out=prev)
            np.ldexp(cur, -k, out=cur)
            e += k
            start = n
            mprev, mcur = prev, cur
        else:
            mcur = out[n]
            mprev = out[n - 1] if n > 0 else None
        if rec.has_b:
            np.subtract(x, b[n], out=tmp)
            np.multiply(tmp, mcur, out=tmp)
        else:
            np.multiply(x, mcur, out=tmp)
        if mprev is not None:
            np.multiply(mprev, Ap[n], out=tmp2)
            np.subtract(tmp, tmp2, out=tmp)
        np.divide(tmp, A_next[n], out=out[n + 1])  # division: 1 rounding, not 2
    _scale_rows(out[start:nrows], e)


def _check_x(x) -> np.ndarray:
    xa = np.asarray(x, dtype=float)
    if xa.ndim != 1:
        raise ValueError(f"x: expected a 1-D array of sample points, got shape {xa.shape}")
    if np.any(np.isnan(xa)):
        raise ValueError("x: contains NaN")
    return xa


def evaluate(
    kernel: Kernel,
    N: int,
    x: np.ndarray,
    *,
    out: np.ndarray | None = None,
    chunk: int = _DEFAULT_CHUNK,
    rec: Recurrence | None = None,
    engine: str = "auto",
) -> np.ndarray:
    """The ``(N, len(x))`` matrix ``[phi_n(x_j)]`` of the first ``N`` orthonormal functions.

    Mantissa/exponent three-term recurrence (module docstring): no overflow or underflow in
    the middle of the recurrence, forward-stable for these dominant solutions; vectorised
    over samples in blocks of ``chunk``.  Both engines give the same values bit for bit (the
    same operations in the same order; renormalisation is exact and the final scaling by
    ``2^e`` correctly rounded, so neither the block size nor the renormalisation points
    change a value).

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions, ``>= 1``.
    x : array_like, shape (k,)
        Points of the family's variable (no NaN).
    out : ndarray, shape (N, k), optional
        Filled in place if given.
    chunk : int, optional
        Samples per block.
    rec : Recurrence, optional
        Precomputed coefficients for at least ``N`` functions (:func:`recurrence`).
    engine : {"auto", "numpy", "numba"}, optional
        The engine (:mod:`slbasis.numeric.engine`).

    Returns
    -------
    ndarray, shape (N, k)
        The values (``out`` when given).

    Raises
    ------
    ValueError
        If ``N`` is not a positive integer, ``x`` is not 1-D or has NaN, ``rec`` is too
        short, ``out`` has the wrong shape, or ``engine`` is unknown.

    References
    ----------
    .. [1] W. Gautschi, *Orthogonal Polynomials: Computation and Approximation*, Oxford
       University Press, 2004, sec. 1.3.

    Examples
    --------
    >>> import slbasis
    >>> evaluate(slbasis.kernel("legendre"), 3, np.array([0.0, 1.0])).round(4)
    array([[ 0.7071,  0.7071],
           [ 0.    ,  1.2247],
           [-0.7906,  1.5811]])
    """
    if int(N) != N or N < 1:
        raise ValueError(f"N: expected an integer >= 1, got {N!r}")
    N = int(N)
    xa = _check_x(x)
    if rec is None:
        rec = Recurrence(kernel, N)
    elif rec.N < N:
        raise ValueError(f"rec: precomputed for {rec.N} < N = {N} functions")
    if out is None:
        out = np.empty((N, xa.size))
    elif out.shape != (N, xa.size):
        raise ValueError(f"out: expected shape {(N, xa.size)}, got {out.shape}")
    if xa.size == 0:
        return out
    use = _engine.resolve(engine, _engine.work(N, xa.size))
    logabs, sign = kernel.log_phi0(xa)
    m0, e0 = _split_log(np.asarray(logabs, dtype=float), np.asarray(sign, dtype=float))
    if use == "numba":
        target = out if out.flags.c_contiguous else np.empty((N, xa.size))
        xc = np.ascontiguousarray(xa)
        with np.errstate(invalid="ignore"):
            _engine.evaluate_compiled(rec, xc, m0, e0, rec.renorm_mask(xc, N), target)
        if target is not out:
            out[...] = target
        return out
    chunk = max(1, int(chunk))
    # singular endpoints (phi_0 = inf, e.g. Chebyshev-T functions at x = +-1) give inf/nan
    # there by design; do not warn about it
    with np.errstate(invalid="ignore"):
        for s in range(0, xa.size, chunk):
            sl = slice(s, min(s + chunk, xa.size))
            _fill(rec, N, xa[sl], out[:, sl], m0[sl], e0[sl])
    return out


def evaluate_derivative(
    kernel: Kernel, N: int, x: np.ndarray, *, chunk: int = _DEFAULT_CHUNK
) -> tuple[np.ndarray, np.ndarray]:
    """The functions and their ``x``-derivatives.

    Uses the banded operator ``2 p0 phi_n' = sub[n] phi_{n-1} + diag[n] phi_n + sup[n]
    phi_{n+1}`` (one extra row ``phi_N``), so it is undefined (inf/nan) where ``p0(x) = 0``.

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions.
    x : array_like, shape (k,)
        Points of the family's variable.
    chunk : int, optional
        Samples per block of :func:`evaluate`.

    Returns
    -------
    phi : ndarray, shape (N, k)
        The functions.
    dphi : ndarray, shape (N, k)
        Their derivatives with respect to ``x``.

    Examples
    --------
    >>> import slbasis
    >>> phi, dphi = evaluate_derivative(slbasis.kernel("legendre"), 3, np.array([0.5]))
    >>> dphi.round(4)  # sqrt(3/2) and sqrt(5/2) 3 x
    array([[0.    ],
           [1.2247],
           [2.3717]])
    """
    xa = _check_x(x)
    full = evaluate(kernel, N + 1, xa, chunk=chunk)
    sub, dia, sup = (np.asarray(v, dtype=float) for v in kernel.derivative_bands(N))
    c0, c1, c2 = (float(c) for c in kernel.p0)
    two_p0 = 2.0 * (c0 + xa * (c1 + c2 * xa))
    d = dia[:, None] * full[:N] + sup[:, None] * full[1 : N + 1]
    d[1:] += sub[1:, None] * full[: N - 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        d /= two_p0
    return full[:N], d


def polynomial_newton_ratio(kernel: Kernel, N: int, x: np.ndarray) -> np.ndarray:
    """``p_N(x) / p_N'(x)`` for the orthonormal polynomial ``p_N`` (the Newton step).

    Runs the recurrence for ``p_n`` and its derivative ``A_{n+1} p'_{n+1} = (x - b_n) p'_n +
    p_n - A_n p'_{n-1}`` on scaled values (the ratio is scale invariant; pairs are
    renormalised by powers of two every 16 steps).  The zeros of ``phi_N = sqrt(w) p_N``
    inside ``(a, b)`` are those of ``p_N``.

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        The degree.
    x : array_like, shape (k,)
        Points.

    Returns
    -------
    ndarray, shape (k,)
        The ratio.

    Examples
    --------
    >>> import slbasis
    >>> polynomial_newton_ratio(slbasis.kernel("legendre"), 2, np.array([0.5])).round(6)
    array([-0.083333])
    """
    xa = _check_x(x)
    diag, off = (np.asarray(v, dtype=float) for v in kernel.jacobi(N))
    pm, p = np.zeros_like(xa), np.ones_like(xa)
    dm, d = np.zeros_like(xa), np.zeros_like(xa)
    Aprev = 0.0
    for n in range(N):
        t = xa - diag[n]
        pn = (t * p - Aprev * pm) / off[n]
        dn = (t * d + p - Aprev * dm) / off[n]
        pm, p, dm, d = p, pn, d, dn
        Aprev = off[n]
        if n % 16 == 15:
            big = np.maximum.reduce([np.abs(pm), np.abs(p), np.abs(dm), np.abs(d)])
            _, k = np.frexp(big)
            pm, p, dm, d = (np.ldexp(v, -k) for v in (pm, p, dm, d))
    return p / d
