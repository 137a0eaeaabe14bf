"""The past-window criterion of sampled data from the lagged Gram matrix, certified.

:func:`hdpbsid.core.varx.select_past_window` compares the VARX fits of every past window
``p = 1..p_max``.  With the sample shift the regressors ``z_{k-1}, ..., z_{k-p}`` on the
columns ``k = p_max..N-1`` are a block-Toeplitz matrix, so their Gram matrix follows from
``p_max + 1`` lagged products and a recursion along its diagonals
(:func:`shift_gram`: ``O(N d^2 p_max)`` operations instead of the ``O(N d^2 p_max^2)``
of a QR factorisation of the regressors), and the residual covariance of every nested
fit is read off one Cholesky factor of it: with the regressors ordered by lag and the
outputs last, ``R^T R = G`` gives

    Sigma_p = sum_{r >= q} R[r, y]^T R[r, y],        q = p (m + l) (+ m with feedthrough),

the Schur complement of the first ``q`` regressors (Golub & Van Loan, *Matrix
Computations*, 4th ed., sec. 5.3.3 for the QR form; the Cholesky factor of ``G`` is the
``R`` of that QR up to signs).

The Gram matrix squares the condition number of the regressors, so its criterion is
accepted only when it is **certified** to choose the window the exact criterion chooses
(:func:`criterion_error_bounds`): the rounding of the Gram matrix and of its Cholesky
factor is a backward error ``E`` (``R^T R = G + E``) bounded a priori (Higham,
*Accuracy and Stability of Numerical Algorithms*, 2nd ed., sec. 3.1 and Thm 10.3); the
Schur complement then moves by exactly ``[-theta_B^T, I] E [-theta_A; I]`` (``theta``
the regression coefficients of the perturbed and the exact problem), so by at most
``2 ||E|| (1 + ||theta_B||)^2`` once ``||E|| ||G_xx^{-1}|| <= 1/2``, and ``log det`` by
at most ``-l log(1 - eta)`` with ``eta`` that bound over the smallest eigenvalue of the
computed ``Sigma_p``.  When the best window's margin over every other window exceeds the
two bounds, the exact criterion has the same minimiser; otherwise the caller factors the
regressors by QR (:class:`hdpbsid.core.varx._GrowingQR`), as without this module.  A
noise-free record (``Sigma_p`` at its floor) is never certified, so it keeps the QR's
choice of the smallest exact window.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

__all__ = [
    "shift_gram",
    "nested_residual_covariances",
    "criterion_error_bounds",
    "regression_factor",
]

Array = NDArray[np.float64]

_U = np.finfo(float).eps / 2  # unit roundoff


def _gamma(n: float) -> float:
    """Higham's ``gamma_n = n u / (1 - n u)``: the relative error bound of ``n`` roundings."""
    return n * _U / (1.0 - n * _U)


def shift_gram(Z: Array, first: int, lags: int) -> Array:
    """The Gram matrix of the lagged samples ``z_{k-i}``, ``i = 0..lags``, over the columns
    ``k = first..N-1``.

    ``M[i d + a, j d + b] = sum_{k=first}^{N-1} Z[a, k - i] Z[b, k - j]``.  The block
    ``(i, i + delta)`` is the block ``(0, delta)`` with the window moved back ``i``
    samples: ``i`` products enter at its start and ``i`` leave at its end, so every block
    costs ``O(d^2)`` after the ``lags + 1`` products of the first block row
    (``O(N d^2 lags)`` in all, against ``O(N d^2 lags^2)`` for the products one by one).

    Parameters
    ----------
    Z : ndarray, shape (d, N)
        The signals, one per row.
    first : int
        The first column of the window; ``lags <= first < N``.
    lags : int
        The largest lag.

    Returns
    -------
    ndarray, shape ((lags + 1) d, (lags + 1) d)
        The symmetric Gram matrix, blocks ordered by lag.

    Raises
    ------
    ValueError
        Unless ``0 <= lags <= first < N``.

    Examples
    --------
    >>> Z = np.arange(12.0).reshape(2, 6)
    >>> M = shift_gram(Z, 2, 2)
    >>> float(M[1, 4]), float(Z[1, 2:] @ Z[0, 0:4])
    (62.0, 62.0)
    """
    d, N = Z.shape
    if not 0 <= lags <= first < N:
        raise ValueError(f"need 0 <= lags <= first < N, got lags={lags}, first={first}, N={N}")
    L = lags
    head = Z[:, first:]
    # c[delta] = sum_k z_k z_{k-delta}^T: the first block row
    c = np.stack([head @ Z[:, first - delta : N - delta].T for delta in range(L + 1)])
    # D[i, delta] = sum_{r=1..i} (z_{first-r} z_{first-r-delta}^T - z_{N-r} z_{N-r-delta}^T),
    # needed for i + delta <= L, where first - r - delta >= first - L >= 0
    r = np.arange(1, L + 1)[:, None]
    delta = np.arange(L + 1)[None, :]
    ok = r + delta <= L
    start = np.where(ok, first - r - delta, 0)
    end = np.where(ok, N - r - delta, 0)
    P = np.einsum("ar,brs->rsab", Z[:, first - r[:, 0]], Z[:, start]) - np.einsum(
        "ar,brs->rsab", Z[:, N - r[:, 0]], Z[:, end]
    )
    P[~ok] = 0.0
    D = np.concatenate([np.zeros((1, L + 1, d, d)), np.cumsum(P, axis=0)])
    i = np.arange(L + 1)[:, None]
    j = np.arange(L + 1)[None, :]
    lo, gap = np.minimum(i, j), np.abs(j - i)
    blocks = c[gap] + D[lo, gap]  # the block (min, max) of every pair
    below = np.broadcast_to(i > j, blocks.shape[:2])
    blocks[below] = np.swapaxes(blocks[below], -1, -2)
    return blocks.transpose(0, 2, 1, 3).reshape((L + 1) * d, (L + 1) * d)


def nested_residual_covariances(R: Array, l: int) -> Array:
    r"""The residual Gram matrices of the last ``l`` columns on every leading set of columns.

    With ``R`` the ``K x K`` Cholesky factor of the Gram matrix (outputs last), the Schur
    complement of the first ``q`` regressors is the sum of the squares of the rows ``r >=
    q`` of ``R``'s output columns -- a sum of positive semi-definite terms, so it is
    computed by one reversed cumulative sum (Golub & Van Loan, sec. 5.3.3).

    Parameters
    ----------
    R : ndarray, shape (K, K)
        Upper-triangular Cholesky factor, ``R^T R = G``, the ``l`` outputs last.
    l : int
        Number of outputs.

    Returns
    -------
    ndarray, shape (K - l + 1, l, l)
        ``Sigma[q] = sum_{r >= q} R[r, -l:]^T R[r, -l:]`` for ``q = 0..K - l``.

    Notes
    -----
    .. math:: \Sigma_q = \sum_{r \ge q} R_{r,y}^\top R_{r,y} .

    References
    ----------
    .. [1] G. H. Golub and C. F. Van Loan, *Matrix Computations*, 4th ed., 2013, sec. 5.3.3.

    Examples
    --------
    >>> R = np.linalg.cholesky(np.array([[2.0, 1.0], [1.0, 2.0]])).T
    >>> nested_residual_covariances(R, 1)[:, 0, 0]  # 2, then 2 - 1**2 / 2
    array([2. , 1.5])
    """
    T = R[:, -l:]
    outer = T[:, :, None] * T[:, None, :]
    return np.cumsum(outer[::-1], axis=0)[::-1][: R.shape[0] - l + 1]


def _leading_coefficient_norms(Rinv: Array, Rxy: Array) -> Array:
    """``||R[:q, :q]^{-1} R[:q, y]||_F`` for ``q = 1..k`` from the triangular inverse
    ``Rinv`` (``k x k``): ``theta_q[i] = sum_{i <= j < q} Rinv[i, j] R[j, y]``, a
    cumulative sum along each row of ``Rinv`` weighted by ``R[j, y]``."""
    C = np.cumsum(Rinv[:, :, None] * Rxy[None, :, :], axis=1)  # C[i, q - 1] = theta_q[i]
    sq = np.triu(np.sum(C * C, axis=2))  # row i counts for q - 1 >= i
    return np.sqrt(np.sum(sq, axis=0))


def criterion_error_bounds(
    R: Array, l: int, n_terms: int, energy_ratio: Array, sigma_min: Array
) -> Array | None:
    r"""Bounds on the rounding error of ``log det(Sigma_q + floor I)`` for every leading
    regressor count ``q = 0..K - l``.

    A criterion read off the Gram matrix is accepted only when its minimiser is certified
    to be the exact criterion's; these are the bounds the margins are compared with.

    Parameters
    ----------
    R : ndarray, shape (K, K)
        The computed Cholesky factor of the unit-diagonal Gram matrix (outputs last).
    l : int
        Number of outputs.
    n_terms : int
        The largest number of products summed into an entry of the Gram matrix.
    energy_ratio : ndarray, shape (K,)
        ``sqrt`` of the ratio of each signal's whole energy to its window's: the absolute
        values summed into ``G[i, j]`` are at most ``energy_ratio[i] energy_ratio[j]`` times
        the geometric mean of the two diagonal entries (:func:`shift_gram` sums each product
        once in the window and once more at most as a boundary term).
    sigma_min : ndarray, shape (K - l + 1,)
        Smallest eigenvalue of each computed ``Sigma_q`` plus the floor.

    Returns
    -------
    ndarray, shape (K - l + 1,) or None
        The bound for every ``q``; ``None`` when the rounding can move a Schur complement by
        more than the first-order analysis covers (``||E|| ||G_xx^{-1}|| > 1/2``, or a
        relative move ``>= 1``).

    Notes
    -----
    The backward error ``E`` of ``R^T R = G + E``: forming and scaling ``G``, :math:`|E_{ij}|
    \le 2 \gamma_{n+3} \rho_i \rho_j`; the Cholesky factorisation, :math:`|E| \le
    \gamma_{K+1} |R|^\top |R|` (Higham, Thm 10.3), whose Frobenius norm is at most
    :math:`\gamma_{K+1} \operatorname{tr}(R^\top R)`.  With :math:`\theta_q` the regression
    coefficients of the ``q`` regressors read off ``R``,

    .. math::

        \lVert \Sigma_q - \Sigma_q^{\mathrm{exact}} \rVert \le
        2 \lVert E \rVert (1 + \lVert \theta_q \rVert)^2 ,

    plus the summation of :func:`nested_residual_covariances`; with :math:`\eta_q` that
    bound over ``sigma_min[q]``, :math:`|\Delta \log\det| \le -l \log(1 - \eta_q)`.
    The norms :math:`\lVert\theta_q\rVert = \lVert R_{xx}^{-1} R_{xy}\rVert` and
    :math:`\lVert G_{xx}^{-1}\rVert \le \lVert R_{xx}^{-1}\rVert_F^2` of every leading block
    are read off one triangular inverse.

    References
    ----------
    .. [1] N. J. Higham, *Accuracy and Stability of Numerical Algorithms*, 2nd ed., SIAM,
       2002, sec. 3.1, Thm 9.3 and Thm 10.3.
    """
    K = R.shape[0]
    k = K - l
    rho = np.asarray(energy_ratio, dtype=float)
    # ||E||_F: forming and scaling G (||rho rho^T||_F = rho . rho), then Cholesky
    eps = 2.0 * _gamma(n_terms + 3) * float(rho @ rho) + _gamma(K + 1) * float(np.sum(R * R))
    if k:
        Rinv = scipy.linalg.solve_triangular(R[:k, :k], np.eye(k), check_finite=False)
        # ||R_xx^{-1}||_F^2 of every leading block: R^{-1} is upper triangular, so its
        # leading q x q block is the inverse of R's and holds its first q columns whole
        inv_sq = np.concatenate([[0.0], np.cumsum(np.sum(Rinv * Rinv, axis=0))])
        theta = np.concatenate([[0.0], _leading_coefficient_norms(Rinv, R[:k, k:])])
    else:
        inv_sq = theta = np.zeros(1)
    if not np.all(np.isfinite(inv_sq)) or np.any(eps * inv_sq > 0.5):
        return None
    # the Schur complement's move, the cumulative sums (each ||R[:, y_a]||^2 = 1 + E_aa),
    # and the LU of slogdet on a matrix of trace at most l (Higham, Thm 9.3)
    d_sigma = 2.0 * eps * (1.0 + theta) ** 2 + (_gamma(K + 1) + _gamma(3 * l)) * l * l * (1 + eps)
    eta = d_sigma / np.asarray(sigma_min, dtype=float)
    if not np.all(eta < 1.0):
        return None
    return -l * np.log1p(-eta)


@dataclass(frozen=True)
class GramCertificate:
    """When :func:`regression_factor` keeps the factor from the Gram matrix.

    Attributes
    ----------
    coefficient_resolution : float
        The largest move of a least-squares coefficient by the Gram matrix's rounding,
        relative to the coefficient's standard error.

    Examples
    --------
    >>> GramCertificate().coefficient_resolution
    0.001
    """

    #: a change the data cannot resolve, by three orders of magnitude
    coefficient_resolution: float = 1e-3


#: :func:`regression_factor` keeps the factor from the Gram matrix when its rounding moves
#: every least-squares coefficient by at most this fraction of the coefficient's standard
#: error (:class:`GramCertificate`)
COEFFICIENT_RESOLUTION = GramCertificate().coefficient_resolution


def regression_factor(Z: Array, p: int, m: int, feedthrough: bool) -> Array | None:
    """The triangular factor ``R`` of ``[Phi^T, Y^T] = Q R`` of the sample-shift VARX of
    past window ``p`` (:func:`hdpbsid.core.varx.varx`) from the lagged Gram matrix, or
    ``None`` when it is not certified.

    ``Z = [U; Y]`` (``m`` inputs first, one row per signal); the regression's columns
    are ``k = p..N-1``, its regressors ``Phi = [z_{k-p}; ...; z_{k-1}]`` (oldest first),
    with ``u_k`` below them when ``feedthrough``, its targets ``y_k``.  The Gram matrix of
    ``[Phi; Y]`` is read off :func:`shift_gram` (``O(N d^2 p)`` operations instead of the
    ``O(N d^2 p^2)`` of a QR of the regressors), and its Cholesky factor is ``R`` up to the
    signs of its rows, which no least-squares or ridge solution from ``R`` depends on.

    Certified when the rounding cannot be resolved by the data: the backward error ``E``
    of forming and factoring the (unit-diagonal) Gram matrix is bounded as in
    :func:`criterion_error_bounds`; it moves the least-squares coefficients ``theta`` by at
    most ``2 ||G_xx^{-1}|| ||E|| (1 + ||theta||)`` (the perturbed normal equations, once
    ``||E|| ||G_xx^{-1}|| <= 1/2``; a ridge solution, whose filter factors are below one,
    by no more), and the standard error of coefficient ``(i, j)`` is ``sqrt(Sigma_jj
    [G_xx^{-1}]_ii)`` (``Cov(theta) = Sigma (x) G_xx^{-1}``, ``Sigma`` the residual
    covariance per sample; its diagonal taken less the rounding's share, the diagonal of
    ``G_xx^{-1}`` the squared row norms of ``R_xx^{-1}``).  The factor is kept when the
    move is at most :data:`COEFFICIENT_RESOLUTION` times the smallest standard error; a
    noise-free record (no residual) or an ill-conditioned one is left to the QR
    factorisation.

    Parameters
    ----------
    Z : ndarray, shape (m + l, N)
        Inputs above outputs.
    p : int
        The past window, ``1 <= p < N``.
    m : int
        The number of inputs (the first rows of ``Z``).
    feedthrough : bool
        Whether ``u_k`` is a regressor.

    Returns
    -------
    ndarray or None
        ``R`` (``(p (m + l) + m_ft + l)`` square, ``m_ft = m`` with feedthrough), or None.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(500)
    >>> y = np.convolve(u, [0.0, 1.0, 0.5])[:500] + 0.1 * rng.standard_normal(500)
    >>> R = regression_factor(np.vstack([u, y]), 3, 1, False)
    >>> Phi = np.vstack([np.vstack([u, y])[:, 3 - j : 500 - j] for j in (3, 2, 1)])
    >>> G = np.vstack([Phi, y[3:]]) @ np.vstack([Phi, y[3:]]).T
    >>> bool(np.allclose(R.T @ R, G))
    True
    """
    d, N = Z.shape
    l = d - m
    lead = list(range(m)) if (feedthrough and m > 0) else []
    idx = [j * d + a for j in range(p, 0, -1) for a in range(d)] + lead + [m + c for c in range(l)]
    M = shift_gram(Z, p, p)[np.ix_(idx, idx)]
    diag = np.diag(M).copy()
    if not np.all(np.isfinite(M)) or np.any(diag <= 0):
        return None
    s = np.sqrt(diag)
    try:
        Rs = np.linalg.cholesky(M / s[:, None] / s[None, :]).T
    except np.linalg.LinAlgError:
        return None
    K = Rs.shape[0]
    k = K - l
    n = N - p
    rho = np.sqrt(np.sum(Z * Z, axis=1)[np.asarray(idx) % d] / diag)
    eps = 2.0 * _gamma(n + 2 * p + 3) * float(rho @ rho) + _gamma(K + 1) * float(np.sum(Rs * Rs))
    Rinv = scipy.linalg.solve_triangular(Rs[:k, :k], np.eye(k), check_finite=False)
    if not np.all(np.isfinite(Rinv)):
        return None
    g_inv = float(np.linalg.norm(Rinv, 2)) ** 2  # ||G_xx^{-1}||_2 = ||R_xx^{-1}||_2^2
    if eps * g_inv > 0.5:
        return None
    theta_term = (1.0 + float(np.linalg.norm(Rinv @ Rs[:k, k:]))) ** 2
    move = 2.0 * g_inv * eps * np.sqrt(theta_term)
    # the residual sums of squares (diagonal of the Schur complement), less what the
    # rounding can add to them (module docstring), per sample; and the smallest diagonal
    # entry of G_xx^{-1} = R^{-1} R^{-T} (the squared row norms of R^{-1})
    rss = np.sum(Rs[k:, k:] ** 2, axis=0) - 2.0 * eps * theta_term
    se_min = np.sqrt(max(float(np.min(rss)), 0.0) / n * float(np.min(np.sum(Rinv**2, axis=1))))
    if not move <= COEFFICIENT_RESOLUTION * se_min:
        return None
    return Rs * s[None, :]
