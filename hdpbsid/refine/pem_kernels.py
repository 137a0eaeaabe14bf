"""Compiled (numba) passes over the samples for the prediction-error refinement.

Two loops over the ``Ns`` samples of a record replace the modal filters
(:func:`scipy.signal.lfilter`) and the ``(q n_modes) x Ns`` complex products of the
numpy evaluation in :mod:`hdpbsid.refine.pem_residuals`; the refinement calls them through
``_residuals`` when numba is installed (the extra ``fast``) and not switched off by
``SLBASIS_NO_NUMBA``, and the numpy evaluation is the fallback and the oracle of the tests.

Prediction errors (:func:`weighted_errors`).  The predictor of
:mod:`hdpbsid.refine.pem_predictor`, ``xi_{k+1} = F xi_k + G u_k + Kd y_k``, run from
``xi_0 = 0`` in real arithmetic (``n^2 + n (m + l)`` operations a sample), with the
weighted errors ``W (y_k - C xi_k - Du u_k)`` and the weighted free response
``W C F^k`` (the columns of the initial state, eliminated by least squares by the
caller), ``F^k`` carried as ``P_{k+1} = P_k F`` from ``P_0 = W C``.

Sensitivities (:func:`sensitivity_regressors`).  Along a direction ``i`` of the
parameters the state sensitivity obeys (Ljung, *System Identification*, 2nd ed.,
sec. 10.3)

    s_{k+1} = F s_k + D_i w_k,   s_0 = 0,   w_k = [xi_k; u_k; y_k],
    D_i = [dF_i, dG_i, dKd_i]   (n x p, p = n + m + l),

so ``s_k = sum_j F^j D_i w_{k-1-j}`` is *linear in* ``D_i``.  With
``F = V diag(lam) V^{-1}``,

    C s_k = sum_{a, b} (C V)_{:, a} z^{(b)}_{a, k} (V^{-1} D_i)_{a b},
    z^{(b)}_{a, k+1} = lam_a z^{(b)}_{a, k} + w_{k, b},   z^{(b)}_{a, 0} = 0,

i.e. the ``n p`` scalar modal filters ``z`` of the ``p`` signals in ``w`` carry the
sensitivities of *every* direction; the ``q`` directions enter only through the
coefficients ``(C V)_{:, a} (V^{-1} D_i)_{a b}``, a ``(p n) x q`` matrix product done by
the caller.  The filtering costs ``O(n p Ns)`` instead of ``O(q n Ns)`` filters and
``O(q n^2 Ns)`` products.  Complex modes come in conjugate pairs (``z`` of the
conjugate eigenvalue is the conjugate signal), so one mode per pair is filtered and its
real and imaginary parts are stored; a real mode stores its real part only.

Rounding: both passes are plain recursions in IEEE double precision, compiled without
fast-math flags; they differ from the numpy evaluation (modal coordinates throughout)
by the rounding of the change of coordinates, of order ``cond(V) eps`` relative
(Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed., 2002, ch. 7).

Functions compile on first call and are cached on disk (``cache=True``).
"""

from __future__ import annotations

import numba
import numpy as np

from slbasis.numeric.jit import array as _array

__all__ = ["weighted_errors", "sensitivity_regressors"]

_jit = numba.njit(cache=True, nogil=True)
#: the per-sample steps, inlined into the passes by numba (its IR, before LLVM): a call
#: per sample otherwise passes every array as a reference-counted structure, which cost
#: more than the few multiply-adds of a step; the operations and their order are the same
_jit_step = numba.njit(cache=True, nogil=True, inline="always")


@_jit_step
def _predictor_step(
    F: np.ndarray,
    G: np.ndarray,
    Kd: np.ndarray,
    xi: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    k: int,
    xn: np.ndarray,
) -> None:
    """One predictor step in place, ``xi <- F xi + G u_k + Kd y_k`` (``xn``: scratch)."""
    n, m, l = xi.shape[0], G.shape[1], Kd.shape[1]
    for i in range(n):
        s = 0.0
        for j in range(n):
            s += F[i, j] * xi[j]
        for j in range(m):
            s += G[i, j] * u[k, j]
        for j in range(l):
            s += Kd[i, j] * y[k, j]
        xn[i] = s
    for i in range(n):
        xi[i] = xn[i]


@_jit_step
def _weighted_maps(W: np.ndarray, C: np.ndarray, Du: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``W C`` and ``W Du``, each entry summed over the outputs in order."""
    l, n, m = C.shape[0], C.shape[1], Du.shape[1]
    WC = np.zeros((l, n))
    WDu = np.zeros((l, m))
    for c in range(l):
        for d in range(l):
            for j in range(n):
                WC[c, j] += W[c, d] * C[d, j]
            for j in range(m):
                WDu[c, j] += W[c, d] * Du[d, j]
    return WC, WDu


@_jit_step
def _error_sample(
    W: np.ndarray,
    WC: np.ndarray,
    WDu: np.ndarray,
    P: np.ndarray,
    xi: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    k: int,
    Ew: np.ndarray,
    Fr: np.ndarray,
) -> None:
    """Sample ``k`` of the weighted errors ``W y_k - W C xi_k - W Du u_k`` and of the
    weighted free response ``P = W C F^k``."""
    l, n, m = WC.shape[0], WC.shape[1], WDu.shape[1]
    for c in range(l):
        s = 0.0
        for d in range(l):
            s += W[c, d] * y[k, d]
        for j in range(n):
            s -= WC[c, j] * xi[j]
        for j in range(m):
            s -= WDu[c, j] * u[k, j]
        Ew[c, k] = s
        for j in range(n):
            Fr[c, k, j] = P[c, j]


@_jit_step
def _power_step(P: np.ndarray, F: np.ndarray, Pn: np.ndarray) -> None:
    """``P <- P F`` in place (``Pn``: scratch)."""
    l, n = P.shape[0], P.shape[1]
    for c in range(l):
        for j in range(n):
            s = 0.0
            for i in range(n):
                s += P[c, i] * F[i, j]
            Pn[c, j] = s
    for c in range(l):
        for j in range(n):
            P[c, j] = Pn[c, j]


@_jit
def weighted_errors(
    F: np.ndarray,
    G: np.ndarray,
    Kd: np.ndarray,
    C: np.ndarray,
    Du: np.ndarray,
    W: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    Ew: np.ndarray,
    Fr: np.ndarray,
) -> None:
    """Weighted one-step errors and weighted free response of the predictor.

    Runs ``xi_{k+1} = F xi_k + G u_k + Kd y_k`` from ``xi_0 = 0`` and writes
    ``Ew[c, k] = (W (y_k - C xi_k - Du u_k))_c`` and ``Fr[c, k, :] = (W C F^k)_c``
    (module docstring).

    Parameters
    ----------
    F, G, Kd : ndarray
        The predictor's matrices, ``(n, n)``, ``(n, m)``, ``(n, l)``.
    C, Du : ndarray
        Its output matrices, ``(l, n)``, ``(l, m)``.
    W : ndarray
        Output weighting, ``(l, l)``.
    u, y : ndarray
        The record, ``(Ns, m)`` and ``(Ns, l)``, C-contiguous.
    Ew : ndarray
        Output, ``(l, Ns)``: the weighted errors.
    Fr : ndarray
        Output, ``(l, Ns, n)``: the weighted free response.
    """
    ns, l, n = u.shape[0], y.shape[1], F.shape[0]
    WC, WDu = _weighted_maps(W, C, Du)
    P = WC.copy()
    Pn = np.empty((l, n))
    xi = np.zeros(n)
    xn = np.empty(n)
    for k in range(ns):
        _error_sample(W, WC, WDu, P, xi, u, y, k, Ew, Fr)
        _power_step(P, F, Pn)
        _predictor_step(F, G, Kd, xi, u, y, k, xn)


@_jit_step
def _load_w(w: np.ndarray, xi: np.ndarray, u: np.ndarray, y: np.ndarray, k: int) -> None:
    """``w <- [xi; u_k; y_k]``."""
    n, m, l = xi.shape[0], u.shape[1], y.shape[1]
    for j in range(n):
        w[j] = xi[j]
    for j in range(m):
        w[n + j] = u[k, j]
    for j in range(l):
        w[n + m + j] = y[k, j]


@_jit_step
def _write_row(
    Z: np.ndarray,
    k: int,
    zr: np.ndarray,
    zi: np.ndarray,
    pair: np.ndarray,
    w: np.ndarray,
    Fr: np.ndarray,
    ncols: int,
) -> None:
    """Row ``k`` of ``Z``: the modal filters (real parts, imaginary parts of a pair),
    then ``w``, then the weighted free response of each output."""
    p, l, n = w.shape[0], Fr.shape[0], Fr.shape[2]
    col = 0
    for a in range(zr.shape[0]):
        for b in range(p):
            Z[k, col + b] = zr[a, b]
        col += p
        if pair[a]:
            for b in range(p):
                Z[k, col + b] = zi[a, b]
            col += p
    for b in range(p):
        Z[k, ncols + b] = w[b]
    for c in range(l):
        for j in range(n):
            Z[k, ncols + p + c * n + j] = Fr[c, k, j]


@_jit_step
def _modal_step(
    zr: np.ndarray,
    zi: np.ndarray,
    lam_re: np.ndarray,
    lam_im: np.ndarray,
    pair: np.ndarray,
    w: np.ndarray,
) -> None:
    """``z_a <- lam_a z_a + w`` for every kept mode, in real arithmetic for a pair."""
    p = w.shape[0]
    for a in range(lam_re.size):
        lr, li = lam_re[a], lam_im[a]
        if pair[a]:
            for b in range(p):
                re, im = zr[a, b], zi[a, b]
                zr[a, b] = lr * re - li * im + w[b]
                zi[a, b] = lr * im + li * re
        else:
            for b in range(p):
                zr[a, b] = lr * zr[a, b] + w[b]


@_jit
def sensitivity_regressors(
    F: np.ndarray,
    G: np.ndarray,
    Kd: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    x0: np.ndarray,
    lam_re: np.ndarray,
    lam_im: np.ndarray,
    pair: np.ndarray,
    Fr: np.ndarray,
    Z: np.ndarray,
) -> None:
    """The regressors of the projected Jacobian: modal filters of ``w``, ``w``, ``Fr``.

    Row ``k`` of ``Z`` holds, for each kept mode ``a`` in order, the ``p`` real parts of
    ``z^{(b)}_{a, k}`` (module docstring) and, for a conjugate pair (``pair[a]``), their
    ``p`` imaginary parts; then the ``p`` entries of ``w_k = [xi_k; u_k; y_k]``, with
    ``xi`` run from ``xi_0 = x0``; then the ``l n`` entries ``Fr[c, k, :]`` for ``c = 0
    .. l-1`` (the weighted free response of :func:`weighted_errors`, copied so that one
    matrix product per output gives the projected Jacobian).

    Parameters
    ----------
    F, G, Kd : ndarray
        The predictor's matrices, ``(n, n)``, ``(n, m)``, ``(n, l)``.
    u, y : ndarray
        The record, ``(Ns, m)`` and ``(Ns, l)``, C-contiguous.
    x0 : ndarray
        The fitted initial state, ``(n,)``.
    lam_re, lam_im : ndarray
        Real and imaginary parts of one eigenvalue of ``F`` per conjugate pair and of
        every real one.
    pair : ndarray of bool
        Whether each kept eigenvalue stands for a conjugate pair.
    Fr : ndarray
        The weighted free response, ``(l, Ns, n)``.
    Z : ndarray
        Output, ``(Ns, n p + p + l n)`` (``n p`` counting two columns per pair).
    """
    ns, m, l, n = u.shape[0], u.shape[1], y.shape[1], F.shape[0]
    p = n + m + l
    nk = lam_re.size
    ncols = 0
    for a in range(nk):
        ncols += 2 * p if pair[a] else p
    zr = np.zeros((nk, p))
    zi = np.zeros((nk, p))
    xi = x0.copy()
    xn = np.empty(n)
    w = np.empty(p)
    for k in range(ns):
        _load_w(w, xi, u, y, k)
        _write_row(Z, k, zr, zi, pair, w, Fr, ncols)
        _modal_step(zr, zi, lam_re, lam_im, pair, w)
        _predictor_step(F, G, Kd, xi, u, y, k, xn)


_F8, _B1 = numba.types.float64, numba.types.boolean
_M, _V = _array(_F8, 2), _array(_F8, 1)
#: the argument types :mod:`hdpbsid.refine.pem_residuals` passes, compiled ahead of the first
#: call by :mod:`slbasis.numeric.jit` (``lam_im`` is read-only when every mode is real:
#: numpy's ``.imag`` of a real array)
WARM_SIGNATURES = {
    "weighted_errors": [(_M,) * 9 + (_array(_F8, 3),)],
    "sensitivity_regressors": [
        (_M,) * 5 + (_V, _V, _array(_F8, 1, readonly=ro), _array(_B1, 1), _array(_F8, 3), _M)
        for ro in (False, True)
    ],
}
