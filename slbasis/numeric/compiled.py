"""Compiled (numba) kernels of the mantissa/exponent three-term recurrence.

The same algorithm as :mod:`slbasis.numeric.evaluate` (read its docstring for the maths),
written as loops that numba compiles to machine code, so that nothing is materialised but
two mantissa rows of a block of ``B`` samples:

    m_{n+1} = ((x - b_n) m_n - A_n m_{n-1}) / A_{n+1},     phi_n = m_n 2^e,

vectorised over the ``B`` samples of a block (SIMD lanes), with the pair
``(m_{n-1}, m_n)`` renormalised by exact powers of two at the rows of a precomputed
schedule (:meth:`~slbasis.numeric.evaluate.Recurrence.schedule`, the a-priori growth
bound). The recurrence is compiled without fast-math flags: the same IEEE operations in
the same order as the numpy evaluator, so :func:`eval_range` reproduces it bit for bit.

:func:`project_range` fuses the recurrence with the quadrature sums

    c[n, j] += sum_i phi_n(x_i) wy[j, i],     phi_n(x_i) wy[j, i] = m_n(x_i) (2^e_i wy[j, i]),

(the exponent is folded into the block's weighted signals when it changes, and a block
of ``wy`` stays in L1 cache for all ``N`` rows); only the sums over ``i`` are compiled
with reassociation allowed (``fastmath={"reassoc", "contract"}``), which lets them run as
SIMD partial sums: a different but equally bounded summation order
(``|error| <= (B - 1) eps sum_i |phi_n(x_i) wy[j, i]|`` per block; Higham, *Accuracy and
Stability of Numerical Algorithms*, 2nd ed., 2002, eq. 4.4).

Scaling by ``2^e`` is correctly rounded for every ``e`` (:func:`_factors`); ``frexp`` and
``ldexp`` are replaced by the IEEE exponent field and a table of powers of two (exact).

Functions compile on first call and are cached on disk (``cache=True``); importing this
module imports numba but compiles nothing.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .jit import array as _array

__all__ = ["BLOCK", "eval_range", "project_range"]

BLOCK = 256  # samples per block: 2 mantissa rows, x and 8 weighted signals use 22 kB of L1
_EMIN, _EMAX = -1022, 1023  # exponents of the normal powers of two
_POW2 = np.ldexp(1.0, np.arange(_EMIN, _EMAX + 1))  # _POW2[k - _EMIN] = 2^k, exact
_TINY = 2.2250738585072014e-308  # smallest normal double
_SUM_FLAGS = {"reassoc", "contract"}
_jit = numba.njit(cache=True, nogil=True)
#: the steps of the passes, inlined by numba (its IR, before LLVM): a call per block and
#: row otherwise passes every array as a reference-counted structure; the operations and
#: their order are the same
_jit_step = numba.njit(cache=True, nogil=True, inline="always")
_jit_sum = numba.njit(cache=True, nogil=True, fastmath=_SUM_FLAGS)


@_jit_step
def _factors(e: int, pow2: np.ndarray) -> tuple[float, float]:
    """``(s1, s2)``, powers of two with ``(m * s1) * s2 = round(m 2^e)`` for every ``m``.

    For ``e`` in the normal range ``s2 = 1``. Below it, ``s1 = 2^(e + 1022)`` scales
    exactly (or underflows a value whose final result is 0 anyway) and ``s2 = 2^-1022``
    rounds once into the subnormals; above it, symmetrically.
    """
    if e < _EMIN:
        return pow2[max(e - _EMIN, _EMIN) - _EMIN], pow2[0]
    if e > _EMAX:
        return pow2[min(e - _EMAX, _EMAX) - _EMIN], pow2[_EMAX - _EMIN]
    return pow2[e - _EMIN], 1.0


@_jit_step
def _renormalise(mp: np.ndarray, mc: np.ndarray, e: np.ndarray, pow2: np.ndarray) -> None:
    """``(mp, mc) *= 2^-k``, ``e += k`` per sample, ``k = frexp(max(|mp|, |mc|))[1]``.

    Exactly ``numpy.frexp``/``ldexp`` (``k = 0`` where the pair is not finite): ``k`` from
    the exponent field of normal numbers, ``math.frexp``/``ldexp`` for the rare rest.
    """
    bits_p = mp.view(np.uint64)
    bits_c = mc.view(np.uint64)
    for i in range(mc.size):
        fp = (bits_p[i] >> np.uint64(52)) & np.uint64(0x7FF)
        fc = (bits_c[i] >> np.uint64(52)) & np.uint64(0x7FF)
        if fp == 0x7FF or fc == 0x7FF:
            continue  # inf or nan: numpy leaves k = 0
        field = max(fp, fc)
        if field == 0:  # both zero or subnormal
            k = math.frexp(max(abs(mp[i]), abs(mc[i])))[1]
            mp[i] = math.ldexp(mp[i], -k)
            mc[i] = math.ldexp(mc[i], -k)
        else:
            k = np.int64(field) - 1022
            if -k < _EMIN:
                mp[i] = math.ldexp(mp[i], -k)
                mc[i] = math.ldexp(mc[i], -k)
            else:
                s = pow2[-k - _EMIN]
                mp[i] = mp[i] * s
                mc[i] = mc[i] * s
        e[i] += k


@_jit_step
def _step(x: np.ndarray, mp: np.ndarray, mc: np.ndarray, b: float, a: float, a_next: float) -> None:
    """One row of the recurrence in place: ``(mp, mc) <- (mc, ((x - b) mc - a mp) / a_next)``.

    ``x - 0.0 == x`` bit for bit, so one loop serves kernels with and without ``b_n``.
    """
    for i in range(x.size):
        new = ((x[i] - b) * mc[i] - mp[i] * a) / a_next
        mp[i] = mc[i]
        mc[i] = new


@_jit_step
def _step_write(
    x: np.ndarray,
    mp: np.ndarray,
    mc: np.ndarray,
    b: float,
    a: float,
    a_next: float,
    f1: np.ndarray,
    f2: np.ndarray,
    row: np.ndarray,
) -> None:
    """:func:`_step`, then ``row = round(mc 2^e)`` (``f1, f2`` from :func:`_factors`)."""
    for i in range(x.size):
        new = ((x[i] - b) * mc[i] - mp[i] * a) / a_next
        mp[i] = mc[i]
        mc[i] = new
        row[i] = (new * f1[i]) * f2[i]


@_jit_step
def _scale_factors(e: np.ndarray, s1: np.ndarray, s2: np.ndarray, pow2: np.ndarray) -> None:
    for i in range(e.size):
        s1[i], s2[i] = _factors(e[i], pow2)


@_jit
def eval_range(
    x: np.ndarray,
    m0: np.ndarray,
    e0: np.ndarray,
    b: np.ndarray,
    a_prev: np.ndarray,
    a_next: np.ndarray,
    renorm: np.ndarray,
    out: np.ndarray,
    col: int,
) -> None:
    """``out[:, col:col + len(x)] = [phi_n(x_i)]`` for ``n < out.shape[0]`` (compiled).

    The mantissa/exponent recurrence of :mod:`slbasis.numeric.evaluate`, the same
    operations in the same order, over blocks of ``BLOCK`` samples.

    Parameters
    ----------
    x : ndarray, shape (k,)
        Points of the family's variable.
    m0 : ndarray, shape (k,)
        Mantissas of ``phi_0(x)`` (``phi_0 = m0 2^e0``, ``evaluate._split_log``).
    e0 : ndarray of int, shape (k,)
        Base-2 exponents of ``phi_0(x)``.
    b : ndarray, shape (N,)
        Recurrence diagonal (``Recurrence.b``).
    a_prev : ndarray, shape (N,)
        ``A_n`` (``Recurrence.A_prev``).
    a_next : ndarray, shape (N,)
        ``A_{n+1}`` (``Recurrence.A_next``).
    renorm : ndarray of bool, shape (N,)
        ``renorm[n]``: renormalise the pair ``(n - 1, n)`` before row ``n`` (``n >= 1``).
    out : ndarray, shape (N, total)
        Output, written in place.
    col : int
        The first column of ``out`` written.
    """
    N = out.shape[0]
    pow2 = _POW2
    mp = np.empty(BLOCK)
    mc = np.empty(BLOCK)
    e = np.empty(BLOCK, dtype=np.int64)
    s1 = np.empty(BLOCK)
    s2 = np.empty(BLOCK)
    for start in range(0, x.size, BLOCK):
        w = min(BLOCK, x.size - start)
        xb = x[start : start + w]
        p, c, eb, f1, f2 = mp[:w], mc[:w], e[:w], s1[:w], s2[:w]
        p[:] = 0.0
        c[:] = m0[start : start + w]
        eb[:] = e0[start : start + w]
        _scale_factors(eb, f1, f2, pow2)
        c0 = col + start
        row = out[0, c0 : c0 + w]
        for i in range(w):
            row[i] = (c[i] * f1[i]) * f2[i]
        for n in range(N - 1):
            if n > 0 and renorm[n]:
                _renormalise(p, c, eb, pow2)
                _scale_factors(eb, f1, f2, pow2)
            _step_write(xb, p, c, b[n], a_prev[n], a_next[n], f1, f2, out[n + 1, c0 : c0 + w])


@_jit_step
def _weigh(wy: np.ndarray, e: np.ndarray, ws: np.ndarray, pow2: np.ndarray) -> None:
    """``ws[j, i] = round(wy[j, i] 2^e[i])`` (correctly rounded, :func:`_factors`), with
    results below the smallest normal number set to 0.

    A subnormal ``ws`` belongs to a sample far out in the tail of the low rows
    (``phi_0 ~ 2^e`` with ``e`` below -1022); its products with the mantissas run through
    the processor's slow subnormal path (the outer half of a Hermite record cost 1.3x
    the inner half) and each contributes less than ``2^-1022 |m|`` to a sum, ``|m|``
    bounded by the renormalisation schedule: far below the rounding of any sum that is
    not itself at the underflow level."""
    for i in range(e.size):
        f1, f2 = _factors(e[i], pow2)
        for j in range(wy.shape[0]):
            v = (wy[j, i] * f1) * f2
            ws[j, i] = v if abs(v) >= _TINY else 0.0


@_jit_sum
def _madd(s: float, a: float, b: float) -> float:
    """``s + a b`` with reassociation allowed: LLVM inlines it into the loops below and may
    then split the running sums into SIMD partial sums (the only fast-math in this module)."""
    return s + a * b


@_jit_step
def _sum(m: np.ndarray, ws: np.ndarray, j: int, c: np.ndarray, n: int) -> int:
    """``c[n, j:j+g] += ws[j:j+g] @ m`` for the next group of ``g <= 4`` columns; returns ``g``."""
    g = min(4, ws.shape[0] - j)
    s0 = s1 = s2 = s3 = 0.0
    if g == 4:
        w0, w1, w2, w3 = ws[j], ws[j + 1], ws[j + 2], ws[j + 3]
        for i in range(m.size):
            v = m[i]
            s0 = _madd(s0, v, w0[i])
            s1 = _madd(s1, v, w1[i])
            s2 = _madd(s2, v, w2[i])
            s3 = _madd(s3, v, w3[i])
        c[n, j + 3] += s3
        c[n, j + 2] += s2
    elif g == 3:
        w0, w1, w2 = ws[j], ws[j + 1], ws[j + 2]
        for i in range(m.size):
            v = m[i]
            s0 = _madd(s0, v, w0[i])
            s1 = _madd(s1, v, w1[i])
            s2 = _madd(s2, v, w2[i])
        c[n, j + 2] += s2
    elif g == 2:
        w0, w1 = ws[j], ws[j + 1]
        for i in range(m.size):
            v = m[i]
            s0 = _madd(s0, v, w0[i])
            s1 = _madd(s1, v, w1[i])
    else:
        w0 = ws[j]
        for i in range(m.size):
            s0 = _madd(s0, m[i], w0[i])
    if g >= 2:
        c[n, j + 1] += s1
    c[n, j] += s0
    return g


@_jit_step
def _step_sum(
    x: np.ndarray,
    mp: np.ndarray,
    mc: np.ndarray,
    b: float,
    a: float,
    a_next: float,
    ws: np.ndarray,
    c: np.ndarray,
    n: int,
) -> int:
    """:func:`_step` fused with the sums of the new row into ``c[n]`` for the first ``g``
    columns, ``g`` the largest of 8, 6, 4, 3, 2, 1 not above ``k`` (one pass over the
    block; measured 20 % faster than passes of 4 for 6 and 8 columns); returns ``g``.

    The new row overwrites ``mp`` (the row it no longer needs), not ``mc``: the caller
    swaps the two names, so the pair moves without a copy (one store per sample instead
    of two; the same values, measured 5 % faster with three columns)."""
    k = ws.shape[0]
    g = 8 if k >= 8 else (6 if k >= 6 else min(k, 4))
    s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = 0.0
    if g == 8:
        w0, w1, w2, w3, w4, w5, w6, w7 = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5], ws[6], ws[7]
        for i in range(x.size):
            v = ((x[i] - b) * mc[i] - mp[i] * a) / a_next
            mp[i] = v
            s0 = _madd(s0, v, w0[i])
            s1 = _madd(s1, v, w1[i])
            s2 = _madd(s2, v, w2[i])
            s3 = _madd(s3, v, w3[i])
            s4 = _madd(s4, v, w4[i])
            s5 = _madd(s5, v, w5[i])
            s6 = _madd(s6, v, w6[i])
            s7 = _madd(s7, v, w7[i])
    elif g == 6:
        w0, w1, w2, w3, w4, w5 = ws[0], ws[1], ws[2], ws[3], ws[4], ws[5]
        for i in range(x.size):
            v = ((x[i] - b) * mc[i] - mp[i] * a) / a_next
            mp[i] = v
            s0 = _madd(s0, v, w0[i])
            s1 = _madd(s1, v, w1[i])
            s2 = _madd(s2, v, w2[i])
            s3 = _madd(s3, v, w3[i])
            s4 = _madd(s4, v, w4[i])
            s5 = _madd(s5, v, w5[i])
    elif g == 4:
        w0, w1, w2, w3 = ws[0], ws[1], ws[2], ws[3]
        for i in range(x.size):
            v = ((x[i] - b) * mc[i] - mp[i] * a) / a_next
            mp[i] = v
            s0 = _madd(s0, v, w0[i])
            s1 = _madd(s1, v, w1[i])
            s2 = _madd(s2, v, w2[i])
            s3 = _madd(s3, v, w3[i])
    elif g == 3:
        w0, w1, w2 = ws[0], ws[1], ws[2]
        for i in range(x.size):
            v = ((x[i] - b) * mc[i] - mp[i] * a) / a_next
            mp[i] = v
            s0 = _madd(s0, v, w0[i])
            s1 = _madd(s1, v, w1[i])
            s2 = _madd(s2, v, w2[i])
    elif g == 2:
        w0, w1 = ws[0], ws[1]
        for i in range(x.size):
            v = ((x[i] - b) * mc[i] - mp[i] * a) / a_next
            mp[i] = v
            s0 = _madd(s0, v, w0[i])
            s1 = _madd(s1, v, w1[i])
    else:
        w0 = ws[0]
        for i in range(x.size):
            v = ((x[i] - b) * mc[i] - mp[i] * a) / a_next
            mp[i] = v
            s0 = _madd(s0, v, w0[i])
    sums = (s0, s1, s2, s3, s4, s5, s6, s7)
    for j in range(g):
        c[n, j] += sums[j]
    return g


@_jit
def project_range(
    x: np.ndarray,
    m0: np.ndarray,
    e0: np.ndarray,
    wy: np.ndarray,
    b: np.ndarray,
    a_prev: np.ndarray,
    a_next: np.ndarray,
    renorm: np.ndarray,
    c: np.ndarray,
) -> int:
    """``c[n, j] += sum_i phi_n(x_i) wy[r(n) k + j, i]`` for ``n < c.shape[0]``, ``j < k``
    (compiled, fused with the recurrence).

    ``k = c.shape[1]`` columns and ``r = wy.shape[0] // k`` sets of signals that the rows
    take in turn, ``r(n) = n mod r``: ``r = 1`` projects every row on the same ``k``
    signals; ``r = 2`` gives even rows the first ``k`` and odd rows the last ``k``
    (:func:`slbasis.numeric.projection.project_alternating`).  Row ``n + 1`` is computed
    and summed in one pass (up to 8 columns; further columns in passes of 4), so no block
    of function values is stored.

    Parameters
    ----------
    x : ndarray, shape (k,)
        Points of the family's variable.
    m0 : ndarray, shape (k,)
        Mantissas of ``phi_0(x)`` (``phi_0 = m0 2^e0``, ``evaluate._split_log``).
    e0 : ndarray of int, shape (k,)
        Base-2 exponents of ``phi_0(x)``.
    wy : ndarray, shape (r k, len(x))
        The weighted signals.
    b : ndarray, shape (N,)
        Recurrence diagonal (``Recurrence.b``).
    a_prev : ndarray, shape (N,)
        ``A_n`` (``Recurrence.A_prev``).
    a_next : ndarray, shape (N,)
        ``A_{n+1}`` (``Recurrence.A_next``).
    renorm : ndarray of bool, shape (N,)
        ``renorm[n]``: renormalise the pair ``(n - 1, n)`` before row ``n`` (``n >= 1``).
    c : ndarray, shape (N, k)
        Sums, accumulated in place.

    Returns
    -------
    int
        The number of samples where ``phi_{N-1}`` is not finite.
    """
    N = c.shape[0]
    k = c.shape[1]
    r = wy.shape[0] // k
    nw = r * k
    pow2 = _POW2
    mp = np.empty(BLOCK)
    mc = np.empty(BLOCK)
    e = np.empty(BLOCK, dtype=np.int64)
    ws_full = np.empty((nw, BLOCK))
    bad = 0
    for start in range(0, x.size, BLOCK):
        w = min(BLOCK, x.size - start)
        xb = x[start : start + w]
        p, q, eb = mp[:w], mc[:w], e[:w]
        ws = ws_full if w == BLOCK else np.empty((nw, w))
        wyb = wy[:nw, start : start + w]
        p[:] = 0.0
        q[:] = m0[start : start + w]
        eb[:] = e0[start : start + w]
        _weigh(wyb, eb, ws, pow2)
        wsn = ws[:k]
        j = 0
        while j < k:
            j += _sum(q, wsn, j, c, 0)
        for n in range(N - 1):
            if n > 0 and renorm[n]:
                _renormalise(p, q, eb, pow2)
                _weigh(wyb, eb, ws, pow2)
            first = ((n + 1) % r) * k
            wsn = ws[first : first + k]
            j = _step_sum(xb, p, q, b[n], a_prev[n], a_next[n], wsn, c, n + 1)
            p, q = q, p  # the new row was written over the previous one (_step_sum)
            while j < k:
                j += _sum(q, wsn, j, c, n + 1)
        for i in range(w):
            f1, f2 = _factors(eb[i], pow2)
            if not math.isfinite((q[i] * f1) * f2):
                bad += 1
    return bad


_F8, _I8, _B1 = numba.types.float64, numba.types.int64, numba.types.boolean
_V = _array(_F8, 1)
#: the argument types the engine (:mod:`slbasis.numeric.engine`) passes, compiled ahead
#: of the first call by :mod:`slbasis.numeric.jit`: ``wy`` is a column range of the
#: weighted signals, contiguous on one thread ("C") and strided on several ("A")
WARM_SIGNATURES = {
    "eval_range": [(_V, _V, _array(_I8, 1), _V, _V, _V, _array(_B1, 1), _array(_F8, 2), _I8)],
    "project_range": [
        (_V, _V, _array(_I8, 1), _array(_F8, 2, layout), _V, _V, _V, _array(_B1, 1), _array(_F8, 2))
        for layout in ("C", "A")
    ],
}
