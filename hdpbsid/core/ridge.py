"""Ridge and instrumental-variable least squares of the VARX (:mod:`hdpbsid.core.varx`).

The regression ``Yc = Theta Phi`` is solved from the triangular factor of
``[Phi^T, Yc^T]`` (:func:`r_factor`, a tall-skinny QR over column chunks): minimum-norm
least squares, Tikhonov (ridge) least squares whose parameter minimises the generalised
cross-validation function (the toolbox's ``regress(..., 'tikh', 'gcv')``; Golub, Heath &
Wahba 1979; Hansen, *Rank-deficient and discrete ill-posed problems*, sec. 7.4), or
two-stage least squares with instruments (Soderstrom & Stoica 1983).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

__all__ = ["r_factor", "ridge_gcv", "ridge_gcv_r", "two_stage_ls", "parse_regularize"]

Array = NDArray[np.float64]


def r_factor(Phi: Array, Y: Array, chunk: int = 8192) -> Array:
    """Triangular factor ``R`` of ``[Phi^T, Y^T] = Q R``, computed over column chunks.

    Tall-skinny QR: ``R`` is updated with ``qr([R; next chunk])``, so memory stays at
    ``O((d + l)(d + l + chunk))`` beyond the data.  ``R`` is ``(d + l) x (d + l)``
    (zero-padded when there are fewer columns than unknowns); ``R[:d, :d]`` has the
    singular values of ``Phi``, ``R[:d, d:] = Q_1^T Y^T`` and ``||R[d:, d:]||_F^2`` is the
    least-squares residual.

    Parameters
    ----------
    Phi : ndarray, shape (d, N)
        Regressors (one column per equation).
    Y : ndarray, shape (l, N)
        Regressands.
    chunk : int, optional
        Columns per QR update (bounds the memory).

    Returns
    -------
    ndarray, shape (d + l, d + l)
        The upper-triangular factor.

    Examples
    --------
    >>> Phi = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 1.0]])
    >>> Y = np.array([[1.0, 2.0, 3.0]])
    >>> R = r_factor(Phi, Y)
    >>> W = np.vstack([Phi, Y])
    >>> np.allclose(R.T @ R, W @ W.T)  # the Gram matrix of [Phi; Y]
    True
    """
    d, N = Phi.shape
    w = d + Y.shape[0]
    R = np.zeros((0, w))
    for a in range(0, N, chunk):
        b = min(N, a + chunk)
        # [R; Phi^T; Y^T] of this chunk, written once in the column-major order LAPACK's
        # Householder QR works in (numpy.linalg.qr copies a row-major input first: the
        # same factorisation, slower)
        blk = np.empty((R.shape[0] + b - a, w), order="F")
        blk[: R.shape[0]] = R
        blk[R.shape[0] :, :d] = Phi[:, a:b].T
        blk[R.shape[0] :, d:] = Y[:, a:b].T
        # "raw": the triangle of geqrf's output without the full-height copy of "r"
        R = scipy.linalg.qr(blk, mode="raw", overwrite_a=True, check_finite=False)[1]
        # a chunk with fewer rows than columns gives a (rows x w) trapezoid, kept whole
        R = R[: min(R.shape)]
    if R.shape[0] < w:
        R = np.vstack([R, np.zeros((w - R.shape[0], w))])
    return R


def _ridge_from_svd(Ur: Array, s: Array, Vt: Array, QtY: Array, lam: float) -> Array:
    """Tikhonov solution ``Theta^T = V diag(s / (s^2 + lam^2)) (Q Ur)^T Y^T``."""
    filt = s / (s**2 + lam**2)
    return Vt.T @ (filt[:, None] * (Ur.T @ QtY))


def ridge_gcv(
    Phi: Array, Y: Array, lam: float | None = None, floor: float = 0.0
) -> tuple[Array, float, float | None]:
    r"""Tikhonov least squares ``min ||Y - Theta Phi||_F^2 + lam^2 ||Theta||_F^2``.

    With ``lam=None`` the parameter minimises the generalised cross-validation function,
    which estimates the prediction error of the regularised fit without a hold-out and
    needs no noise level (Golub, Heath & Wahba 1979): a log-grid search over ``[s_min /
    1e3, s_max]`` refined by a bounded scalar minimisation on ``log lam``; ``lam = 0``
    (least squares on the numerical range) is a candidate too, since on exact data GCV
    decreases to 0 and any ``lam > 0`` would only add bias.

    Parameters
    ----------
    Phi : ndarray, shape (d, N)
        Regressors.
    Y : ndarray, shape (l, N)
        Targets.
    lam : float, optional
        The ridge parameter, ``>= 0``; ``None`` chooses it by GCV.
    floor : float, optional
        Lower bound of the GCV choice, relative to the largest singular value of ``Phi``:
        data known only to a relative precision (quadrature of projected data) make the
        exact-fit solution meaningless along the near-null directions of ``Phi``.

    Returns
    -------
    Theta : ndarray, shape (l, d)
        The solution.
    lam : float
        The parameter used.
    G : float or None
        The GCV function at ``lam`` (``None`` for a given ``lam``).

    Raises
    ------
    ValueError
        If ``lam`` is negative or not finite (from :func:`ridge_gcv_r`).

    Notes
    -----
    With the SVD :math:`\Phi^\top = U S V^\top` and filter factors
    :math:`f_i = s_i^2 / (s_i^2 + \lambda^2)`,

    .. math::

        G(\lambda) = \frac{\lVert Y - \Theta_\lambda \Phi \rVert_F^2}
                          {\bigl(N - \sum_i f_i\bigr)^2} .

    The SVD is taken of the triangular factor of ``[Phi^T, Y^T]`` (:func:`ridge_gcv_r`),
    so the long dimension ``N`` meets one QR only.

    References
    ----------
    .. [1] G. H. Golub, M. Heath and G. Wahba, "Generalized cross-validation as a method
       for choosing a good ridge parameter", *Technometrics* 21(2), 215-223, 1979.
    .. [2] P. C. Hansen, *Rank-Deficient and Discrete Ill-Posed Problems*, SIAM, 1998,
       sec. 7.4.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> Phi = rng.standard_normal((3, 200))
    >>> Y = np.array([[1.0, -2.0, 0.5]]) @ Phi + 0.1 * rng.standard_normal((1, 200))
    >>> Theta, lam, G = ridge_gcv(Phi, Y)
    >>> Theta.round(1)
    array([[ 1. , -2. ,  0.5]])
    """
    d, N = Phi.shape
    return ridge_gcv_r(r_factor(Phi, Y), d, N, lam, floor)


def _gcv_grid(grid: Array, s: Array, beta2: Array, out_of_range: float, N: int) -> Array:
    """The GCV function of :func:`ridge_gcv_r` at every ``log lam`` of ``grid`` in one
    array operation (60 Python-level evaluations cost more than the arithmetic): the
    same elementwise operations and, per grid point, the same reduction over the
    singular values (numpy reduces each row of a C-ordered array along its last axis as
    it reduces a 1-D array); the square of the degrees of freedom is Python's float
    power, as in the scalar function (``numpy.square`` may differ from it in the last
    bit), so each value equals the scalar evaluation's bit for bit."""
    lam2 = np.exp(2.0 * grid)[:, None]
    f = s[None, :] ** 2 / (s[None, :] ** 2 + lam2)
    rss = out_of_range + np.sum((1.0 - f) ** 2 * beta2[None, :], axis=1)
    dof = N - np.sum(f, axis=1)
    return rss / np.array([v**2 for v in dof.tolist()])


def ridge_gcv_r(
    R: Array, d: int, N: int, lam: float | None = None, floor: float = 0.0
) -> tuple[Array, float, float | None]:
    """:func:`ridge_gcv` from the triangular factor ``R`` of ``[Phi^T, Y^T]``.

    The GCV function and the Tikhonov solution need ``R`` and ``N`` only: ``Phi^T = Q
    R11`` and ``R11 = Ur S V^T`` give the SVD ``Phi^T = (Q Ur) S V^T`` without forming
    ``Q``, ``R12 = Q^T Y^T`` and the residual outside the range of ``Phi^T`` is
    ``||R22||_F^2``.  So ``R`` may be accumulated over batches of columns
    (:mod:`hdpbsid.core.streamed`).

    Parameters
    ----------
    R : ndarray, shape (d + l, d + l)
        Upper-triangular factor of ``[Phi^T, Y^T]`` (``r_factor``), zero-padded.
    d : int
        Number of regressors (rows of ``Phi``).
    N : int
        Number of columns of ``Phi`` (the GCV's degrees of freedom).
    lam : float, optional
        The ridge parameter, ``>= 0``; ``None`` chooses it by GCV.
    floor : float, optional
        Lower bound of the GCV choice, relative to the largest singular value.

    Returns
    -------
    Theta : ndarray, shape (l, d)
        The solution.
    lam : float
        The parameter used.
    G : float or None
        The GCV function at ``lam`` (``None`` for a given ``lam``).

    Raises
    ------
    ValueError
        If ``lam`` is negative or not finite.
    """
    # Phi^T = Q R11 and R11 = Ur S V^T give the SVD Phi^T = (Q Ur) S V^T without forming Q
    Ur, s, Vt = np.linalg.svd(R[:d, :d])
    QtY = R[:d, d:]  # Q^T Y^T (d x l)
    beta = Ur.T @ QtY  # (Q Ur)^T Y^T
    beta2 = np.sum(beta**2, axis=1)
    out_of_range = float(np.sum(R[d:, d:] ** 2))

    def gcv(loglam: float) -> float:
        lam2 = np.exp(2.0 * loglam)
        f = s**2 / (s**2 + lam2)
        rss = out_of_range + float(np.sum((1.0 - f) ** 2 * beta2))
        dof = N - float(np.sum(f))
        return rss / dof**2

    if lam is not None:
        if not np.isfinite(lam) or lam < 0:
            raise ValueError(f"regularize (the ridge parameter) must be >= 0, got {lam}")
        return _ridge_from_svd(Ur, s, Vt, QtY, float(lam)).T, float(lam), None
    smax = float(s[0]) if s.size else 1.0
    smin = float(s[s > 0][-1]) if np.any(s > 0) else smax
    lo, hi = np.log(max(smin * 1e-3, smax * 1e-14)), np.log(smax)
    grid = np.linspace(lo, hi, 60)
    vals = _gcv_grid(grid, s, beta2, out_of_range, N)
    i = int(np.argmin(vals))
    a, b = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    if b > a:
        from scipy.optimize import minimize_scalar  # here: scipy.optimize is slow to import

        res = minimize_scalar(gcv, bounds=(a, b), method="bounded", options={"xatol": 1e-4})
        best = float(res.x) if res.fun <= vals[i] else float(grid[i])
    else:
        best = float(grid[i])
    g_best = gcv(best)
    # lam = 0 (plain least squares on the numerical range) is a candidate as well: on
    # exact data GCV decreases all the way to 0 and any lam > 0 would only add bias
    rank_tol = smax * max(d, N) * np.finfo(float).eps
    r = int(np.sum(s > rank_tol))
    rss0 = out_of_range + float(np.sum(beta2[r:]))
    g0 = rss0 / (N - r) ** 2 if N > r else np.inf
    lam_floor = floor * smax
    if g0 <= g_best and lam_floor == 0:
        return _ridge_from_svd(Ur[:, :r], s[:r], Vt[:r], QtY, 0.0).T, 0.0, g0
    lam_opt = max(float(np.exp(best)), lam_floor)
    if lam_opt == lam_floor:
        g_best = gcv(np.log(lam_floor))
    return _ridge_from_svd(Ur, s, Vt, QtY, lam_opt).T, lam_opt, g_best


def two_stage_ls(
    Phi: Array,
    Y: Array,
    Psi: Array,
    lam: float | None = None,
    floor: float = 0.0,
) -> tuple[Array, float, float | None, dict]:
    r"""Instrumental-variable estimate of ``Y = Theta Phi + E`` (two-stage least squares).

    Least squares is biased when a regressor is correlated with ``E``; instruments
    uncorrelated with ``E`` and correlated with ``Phi`` restore consistency.  With ``Q``
    (``N x r``) an orthonormal basis of the row space of ``Psi`` (``r`` its numerical rank),
    the regressors are replaced by their projection ``Phi Q Q^T`` on the instruments:
    ``Y Q = Theta Phi Q + E Q`` and ``E Q -> 0`` relative to ``Phi Q`` when ``Psi`` is
    uncorrelated with ``E``.  The projected regression (``r`` columns) goes through
    :func:`ridge_gcv`.

    Parameters
    ----------
    Phi : ndarray, shape (d, N)
        Regressors.
    Y : ndarray, shape (l, N)
        Targets.
    Psi : ndarray, shape (k, N)
        Instruments, ``k >= d`` independent rows (rows of zeros are dropped, the others
        scaled to unit RMS).
    lam : float, optional
        The ridge parameter (``0`` plain IV); ``None`` chooses it by GCV.
    floor : float, optional
        Lower bound of the GCV choice (:func:`ridge_gcv`).

    Returns
    -------
    Theta : ndarray, shape (l, d)
        The estimate.
    lam : float
        The ridge parameter used.
    G : float or None
        The GCV function at ``lam``.
    info : dict
        ``{"estimator": "iv", "instruments": r}``.

    Raises
    ------
    ValueError
        If the instruments' numerical rank ``r`` is below the number of regressors ``d``.

    Notes
    -----
    The estimate is the generalised IV estimator with weighting
    :math:`(\Psi \Psi^\top)^{-1}`:

    .. math::

        \Theta = (Y Q)(\Phi Q)^\top \bigl[(\Phi Q)(\Phi Q)^\top\bigr]^{-1} .

    References
    ----------
    .. [1] T. Soderstrom and P. Stoica, *Instrumental Variable Methods for System
       Identification*, Springer, 1983, ch. 3, eq. (3.9).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> Phi = rng.standard_normal((3, 200))
    >>> Y = np.array([[1.0, -2.0, 0.5]]) @ Phi + 0.1 * rng.standard_normal((1, 200))
    >>> Psi = np.vstack([Phi, rng.standard_normal((2, 200))])
    >>> Theta, lam, G, info = two_stage_ls(Phi, Y, Psi, lam=0.0)
    >>> Theta.round(1), info["instruments"]
    (array([[ 1. , -2. ,  0.5]]), 5)
    """
    d = Phi.shape[0]
    scale = np.sqrt(np.mean(Psi**2, axis=1))
    Psi = Psi[scale > 0] / scale[scale > 0, None]
    Uq, sq, _ = np.linalg.svd(Psi.T, full_matrices=False)
    r = int(np.sum(sq > sq[0] * max(Psi.shape) * np.finfo(float).eps)) if sq.size else 0
    if r < d:
        raise ValueError(
            f"instrumental variables need at least as many independent instruments as "
            f"regressors: {r} instruments (numerical rank) for {d} regressors; supply more "
            f"instrument rows (e.g. more lags of the reference)"
        )
    Q = Uq[:, :r]
    theta, lam_used, g = ridge_gcv(Phi @ Q, Y @ Q, lam, floor=floor)
    return theta, lam_used, g, {"estimator": "iv", "instruments": r}


def parse_regularize(regularize: bool | str | float | None) -> tuple[str, float | None]:
    """Map the user option to ``(kind, lam)``: kind in {"none", "gcv", "fixed"}.

    Parameters
    ----------
    regularize : bool, str, float or None
        False/None/``"none"`` (plain least squares), True/``"gcv"`` (ridge with GCV) or a
        ridge parameter ``>= 0``.

    Returns
    -------
    kind : str
        ``"none"``, ``"gcv"`` or ``"fixed"``.
    lam : float or None
        The fixed ridge parameter (None otherwise).

    Raises
    ------
    ValueError
        For an unknown string or a negative or non-finite parameter.
    TypeError
        For any other type.

    Examples
    --------
    >>> parse_regularize("gcv"), parse_regularize(0.5)
    (('gcv', None), ('fixed', 0.5))
    """
    if regularize is None or regularize is False:
        return "none", None
    if regularize is True or (isinstance(regularize, str) and regularize.lower() == "gcv"):
        return "gcv", None
    if isinstance(regularize, str):
        if regularize.lower() == "none":
            return "none", None
        raise ValueError(
            f"regularize must be False/'none', True/'gcv' or a ridge parameter >= 0, "
            f"got {regularize!r}"
        )
    if isinstance(regularize, int | float | np.floating | np.integer):
        lam = float(regularize)
        if not np.isfinite(lam) or lam < 0:
            raise ValueError(f"regularize (the ridge parameter) must be >= 0, got {regularize}")
        return "fixed", lam
    raise TypeError(
        f"regularize must be a bool, 'none', 'gcv' or a float, got {type(regularize).__name__}"
    )
