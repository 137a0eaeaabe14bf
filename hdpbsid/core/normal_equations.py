"""Least-squares residuals from the normal equations when they are well conditioned
(:func:`lstsq_residuals`).

Tall least-squares problems whose residuals are all a caller needs (the prewhitening and
the ARX predictors of the closed-loop and direct-term tests, the Gauss-Newton prediction
of the refinement) are solved from the Gram matrix when it is well conditioned, which
is one level-3 product instead of an orthogonal factorisation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import cho_factor, cho_solve

__all__ = ["NORMAL_EQUATIONS", "NormalEquations", "lstsq_residuals"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class NormalEquations:
    """When :func:`lstsq_residuals` solves the normal equations.

    Attributes
    ----------
    gram_rcond : float
        Smallest squared Cholesky pivot of the Gram matrix, relative to its largest
        diagonal entry (about ``1 / cond(X^T X)``), at which the normal equations are
        solved.

    Examples
    --------
    >>> NormalEquations().gram_rcond
    1e-08
    """

    #: the residuals then keep ~8 of the 16 digits, far more than their users read
    gram_rcond: float = 1e-8


#: the setting :func:`lstsq_residuals` applies
NORMAL_EQUATIONS = NormalEquations()


def lstsq_residuals(X: Array, target: Array, rcond: float | None = None) -> Array:
    """Residuals ``target - X a`` of the least-squares fit of ``target`` on the columns
    of ``X`` (a tall matrix).

    When the Gram matrix ``X^T X`` is well enough conditioned (its smallest squared
    Cholesky pivot above ``rcond`` times its largest diagonal entry, i.e. ``cond(X^T X)``
    below about ``1 / rcond``), from the normal equations by Cholesky: one level-3
    product of ``N k^2`` operations, where an orthogonal factorisation takes ``2 N k^2``
    in mostly level-2 steps and the SVD-based ``lstsq`` more.  Their residuals differ from
    the exact ones by about ``eps cond(X^T X) |target|`` (Bjorck, *Numerical Methods for
    Least Squares Problems*, SIAM, 1996, sec. 2.2; Higham, *Accuracy and Stability of
    Numerical Algorithms*, 2nd ed., 2002, sec. 20.4), at most ~1e-8 relative at the
    default bound: far below what the correlation tests, the innovation share (whose
    floor is ``sqrt(eps)``, and an error ``delta`` in the residuals moves it by about
    ``2 sqrt(share) delta``) and the Gauss-Newton prediction read from them.  Otherwise
    (nearly collinear columns: a smooth or deterministic input, whose residuals must be
    resolved to near rounding) by :func:`numpy.linalg.lstsq`.

    Parameters
    ----------
    X : ndarray, shape (N, k)
        The regressors.
    target : ndarray, shape (N,) or (N, j)
        The fitted signal(s).
    rcond : float, optional
        The conditioning bound (default: :data:`NORMAL_EQUATIONS`'s ``gram_rcond``).

    Returns
    -------
    ndarray
        The residuals, the shape of ``target``.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = rng.standard_normal((200, 3))
    >>> r = lstsq_residuals(X, X @ [1.0, 2.0, 3.0] + rng.standard_normal(200))
    >>> bool(np.allclose(X.T @ r, 0.0, atol=1e-9))
    True
    """
    rcond = NORMAL_EQUATIONS.gram_rcond if rcond is None else rcond
    if not (X.flags.c_contiguous or X.flags.f_contiguous):
        X = np.ascontiguousarray(X)  # a strided view makes the products skip BLAS
    G = X.T @ X
    d = np.diag(G)
    if X.shape[0] > X.shape[1] and np.all(d > 0) and np.all(np.isfinite(G)):
        try:
            c = cho_factor(G, check_finite=False)
        except np.linalg.LinAlgError:
            c = None
        if c is not None and np.min(np.abs(np.diag(c[0]))) ** 2 > rcond * np.max(d):
            return target - X @ cho_solve(c, X.T @ target, check_finite=False)
    return target - X @ np.linalg.lstsq(X, target, rcond=None)[0]
