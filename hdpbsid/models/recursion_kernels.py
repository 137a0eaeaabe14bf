"""Compiled (numba) state recursions for :mod:`hdpbsid.models.recursion`.

The plain recursions ``x_{k+1} = F x_k + w_k`` and ``P_k = F^k`` written as loops over
the samples and compiled: ``n^2`` multiply-adds a step, no change of coordinates, so
they are the loop of the module's docstring in IEEE double precision (compiled without
fast-math flags) and need no condition test.  :mod:`hdpbsid.models.recursion` calls them when
numba is installed (the extra ``fast``) and not switched off by ``SLBASIS_NO_NUMBA``;
the modal filters there are the fallback.  On the short windows of the held-out scores
the loop wins: a call of :func:`scipy.signal.lfilter` per mode costs more than the few
``n^2`` multiply-adds of a window.

Functions compile on first call and are cached on disk (``cache=True``).
"""

from __future__ import annotations

import numba
import numpy as np

from slbasis.numeric.jit import array as _array

__all__ = ["recursions", "powers"]

_jit = numba.njit(cache=True, nogil=True)


@_jit
def recursions(F: np.ndarray, W: np.ndarray, X0: np.ndarray, X: np.ndarray) -> None:
    """Batched recursions ``X[b, k + 1] = F X[b, k] + W[b, k]``, written in place.

    Parameters
    ----------
    F : ndarray, shape (n, n)
        Recursion matrix (C-contiguous float64).
    W : ndarray, shape (B, K, n)
        The drives.
    X0 : ndarray, shape (B, n)
        Initial states.
    X : ndarray, shape (B, K + 1, n)
        Output, overwritten: ``X[b, 0] = X0[b]`` and the recursion.
    """
    nb, nk, n = W.shape
    for b in range(nb):
        for i in range(n):
            X[b, 0, i] = X0[b, i]
        for k in range(nk):
            for i in range(n):
                s = 0.0
                for j in range(n):
                    s += F[i, j] * X[b, k, j]
                X[b, k + 1, i] = s + W[b, k, i]


@_jit
def powers(F: np.ndarray, P: np.ndarray) -> None:
    """The powers ``P[k] = F^k`` (``P[k] = F P[k - 1]``), written in place.

    Parameters
    ----------
    F : ndarray, shape (n, n)
        The matrix (C-contiguous float64).
    P : ndarray, shape (K, n, n)
        Output, overwritten.
    """
    nk, n = P.shape[0], P.shape[1]
    for i in range(n):
        for j in range(n):
            P[0, i, j] = 1.0 if i == j else 0.0
    for k in range(1, nk):
        for i in range(n):
            for j in range(n):
                s = 0.0
                for a in range(n):
                    s += F[i, a] * P[k - 1, a, j]
                P[k, i, j] = s


_F8 = numba.types.float64
_M, _T = _array(_F8, 2), _array(_F8, 3)
#: the argument types :mod:`hdpbsid.models.recursion` passes, compiled ahead of the first call
#: by :mod:`slbasis.numeric.jit`
WARM_SIGNATURES = {"recursions": [(_M, _T, _M, _T)], "powers": [(_M, _T)]}
