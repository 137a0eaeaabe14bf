"""VARX least squares in predictor form, generic over the "past" operator.

Step 1 of the PBSID pipeline (PBSID toolbox ``dordvarx``; Chiuso 2007, Automatica 43(6),
eq. (8)): with ``z = [u; y]`` estimate

    y_k = sum_{j=1..p} Xi_j z_{k-j} + D u_k + e_k,        Xi_j = C At^{j-1} Bt,

where ``At = A - K C`` and ``Bt = [B - K D, K]`` are the predictor matrices.

Data are matrices with one row per signal and one column per "time" index (a sample for
sampled data, a basis index for basis-domain data).  "Shift back ``j`` times" is a
:class:`LagOperator`: :class:`SampleShift` for sampled data (``z_{k-j}``) and
:class:`MatrixLag` for coefficient sequences (``Z M^j`` with an operator matrix ``M``,
e.g. the integrator of HD-PBSID).  Everything downstream only sees the lagged blocks, so
the same code serves both.

Regularisation follows the toolbox's ``regress(..., 'tikh', 'gcv')``: Tikhonov (ridge)
least squares whose parameter minimises the generalised cross-validation function
(Golub, Heath & Wahba 1979; Hansen, *Rank-deficient and discrete ill-posed problems*,
sec. 7.4).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

__all__ = [
    "LagOperator",
    "CachedPowers",
    "SampleShift",
    "MatrixLag",
    "past_blocks",
    "VarxResult",
    "ridge_gcv",
    "ridge_gcv_r",
    "varx",
    "two_stage_ls",
    "select_past_window",
    "search_is_complete",
    "windows_searched",
    "WINDOW_SEARCH_GROWTH",
]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]


@runtime_checkable
class LagOperator(Protocol):
    """The operator that replaces "one sample back" (the backward shift ``q^{-1}``).

    ``apply(W, j)`` maps a data matrix ``W`` (signals x columns) to the matrix lagged
    ``j`` times, same shape.  ``valid_columns(valid, j)`` says which output columns are
    fully determined when only the input columns flagged in ``valid`` are known (the
    others are zero-filled before ``apply``).  ``apply(W, j)`` must equal ``j``
    applications of ``apply(., 1)`` (a linear operator and its powers).

    Examples
    --------
    >>> isinstance(SampleShift(), LagOperator), isinstance(MatrixLag(np.eye(2)), LagOperator)
    (True, True)
    """

    def apply(self, W: Array, j: int) -> Array:
        """The data matrix ``W`` lagged ``j`` times (``j`` applications of one lag).

        Parameters
        ----------
        W : ndarray, shape (rows, N)
            Data matrix (rows = signals, columns = samples or basis index).
        j : int
            Number of lags, ``j >= 0`` (``0`` returns ``W``).

        Returns
        -------
        ndarray, shape (rows, N)
            ``W`` lagged ``j`` times.
        """
        ...

    def valid_columns(self, valid: Mask, j: int) -> Mask:
        """Which output columns of ``apply(., j)`` the known input columns determine.

        Parameters
        ----------
        valid : ndarray of bool, shape (N,)
            The input columns that are known (the others zero-filled before ``apply``).
        j : int
            Number of lags.

        Returns
        -------
        ndarray of bool, shape (N,)
            The output columns of ``apply(W, j)`` fully determined by the known ones.
        """
        ...


class CachedPowers:
    """Base of lag operators whose ``j``-th power is ``j`` one-step applications.

    Subclasses define ``_once(W)`` (one lag of a ``(rows, N)`` array).  The powers of the
    last argument are cached, so :func:`past_blocks` (``j = p, ..., 1``) costs ``p``
    one-step applications instead of ``p (p + 1) / 2``.  The cache is keyed on the
    argument's identity and checked against its contents.
    """

    def __init__(self) -> None:
        self._key: tuple[int, tuple[int, ...]] | None = None
        self._cache: list[Array] = []

    def _once(self, W: Array) -> Array:  # pragma: no cover - defined by subclasses
        raise NotImplementedError

    def apply(self, W: Array, j: int) -> Array:
        """``W`` lagged ``j`` times, from the cached powers of the last argument.

        Repeated calls with the same ``W`` and growing ``j`` (as :func:`past_blocks` makes)
        reuse the lags computed before; the cache is checked against ``W``'s contents, so a
        modified array is never served stale results.

            Parameters
            ----------
            W : ndarray, shape (rows, N)
                Data matrix (rows = signals, columns = samples or basis index).
            j : int
                Number of lags, ``j >= 0`` (``0`` returns ``W``).

            Returns
            -------
            ndarray, shape (rows, N)
                ``W`` lagged ``j`` times.
        """
        W = np.asarray(W, dtype=float)
        key = (id(W), W.shape)
        if self._key != key or not self._cache or not np.array_equal(self._cache[0], W):
            self._key = key
            self._cache = [W.copy()]
        while len(self._cache) <= j:
            self._cache.append(self._once(self._cache[-1]))
        return self._cache[j].copy()


class SampleShift:
    """Backward shift on sampled data: ``apply(W, j)[:, k] = W[:, k - j]``.

    The first ``j`` output columns would need samples before the record; they are
    zero-filled and reported invalid by :meth:`valid_columns`.

    Examples
    --------
    >>> shift = SampleShift()
    >>> shift.apply(np.array([[1.0, 2.0, 3.0]]), 2)
    array([[0., 0., 1.]])
    """

    def apply(self, W: Array, j: int) -> Array:
        """``W`` shifted ``j`` samples back: ``out[:, k] = W[:, k - j]``, zeros for ``k < j``.

        Parameters
        ----------
        W : ndarray, shape (rows, N)
            Data matrix (rows = signals, columns = samples or basis index).
        j : int
            Number of lags, ``j >= 0`` (``0`` returns ``W``).

        Returns
        -------
        ndarray, shape (rows, N)
            ``W`` lagged ``j`` times.

        Examples
        --------
        >>> SampleShift().apply(np.arange(4.0)[None], 1)
        array([[0., 0., 1., 2.]])
        """
        out = np.zeros_like(W)
        if j == 0:
            out[...] = W
        elif j < W.shape[1]:
            out[:, j:] = W[:, :-j]
        return out

    def valid_columns(self, valid: Mask, j: int) -> Mask:
        """The columns ``k >= j`` whose sample ``k - j`` is known.

        Parameters
        ----------
        valid : ndarray of bool, shape (N,)
            The input columns that are known (the others zero-filled before ``apply``).
        j : int
            Number of lags.

        Returns
        -------
        ndarray of bool, shape (N,)
            The output columns of ``apply(W, j)`` fully determined by the known ones.

        Examples
        --------
        >>> SampleShift().valid_columns(np.ones(4, dtype=bool), 1)
        array([False,  True,  True,  True])
        """
        out = np.zeros_like(valid)
        if j == 0:
            out[...] = valid
        elif j < valid.shape[0]:
            out[j:] = valid[:-j]
        return out

    def cache_key(self) -> tuple:
        """The key of the operator for memoisation: the shift has no parameters.

        Returns
        -------
        tuple
            The empty tuple.
        """
        return ()

    def __repr__(self) -> str:
        return "SampleShift()"


class MatrixLag:
    """Lag by right-multiplication with an operator matrix: ``apply(W, j) = W @ M^j``.

    Use for coefficient sequences (columns = basis index), e.g. ``M = D'^{-1}`` in the
    integrator form of HD-PBSID, where "one step back" is the projection of integration on
    the basis.  An output column is valid when every input column that contributes to it
    through the sparsity pattern of ``M^j`` is valid.  Powers are cached.

    Parameters
    ----------
    M : array_like, shape (N, N)
        The operator matrix, finite.

    Attributes
    ----------
    M : ndarray, shape (N, N)
        The operator matrix (float).

    Raises
    ------
    ValueError
        If ``M`` is not square or not finite.

    Examples
    --------
    >>> lag = MatrixLag(np.diag([0.5, 0.25]))
    >>> lag.apply(np.ones((1, 2)), 2)
    array([[0.25  , 0.0625]])
    >>> lag.valid_columns(np.array([True, False]), 1)
    array([ True, False])
    """

    def __init__(self, M: Array) -> None:
        M = np.asarray(M, dtype=float)
        if M.ndim != 2 or M.shape[0] != M.shape[1]:
            raise ValueError(f"M must be a square matrix, got shape {M.shape}")
        if not np.all(np.isfinite(M)):
            raise ValueError("M must be finite (no NaN/inf)")
        self.M = M
        self._powers: dict[int, Array] = {0: np.eye(M.shape[0]), 1: M}

    def power(self, j: int) -> Array:
        """``M^j``, computed by repeated multiplication and cached.

        Parameters
        ----------
        j : int
            The power, ``j >= 0``.

        Returns
        -------
        ndarray, shape (N, N)
            ``M^j`` (the identity for ``j = 0``).
        """
        if j not in self._powers:
            self._powers[j] = self.power(j - 1) @ self.M
        return self._powers[j]

    def apply(self, W: Array, j: int) -> Array:
        """``W @ M^j``.

        Parameters
        ----------
        W : ndarray, shape (rows, N)
            Data matrix (rows = signals, columns = samples or basis index).
        j : int
            Number of lags, ``j >= 0`` (``0`` returns ``W``).

        Returns
        -------
        ndarray, shape (rows, N)
            ``W`` lagged ``j`` times.
        """
        return W @ self.power(j)

    def valid_columns(self, valid: Mask, j: int) -> Mask:
        """The columns of ``W @ M^j`` that no unknown column of ``W`` reaches through ``M^j``.

        Parameters
        ----------
        valid : ndarray of bool, shape (N,)
            The input columns that are known (the others zero-filled before ``apply``).
        j : int
            Number of lags.

        Returns
        -------
        ndarray of bool, shape (N,)
            The output columns of ``apply(W, j)`` fully determined by the known ones.
        """
        if valid.all():
            return valid.copy()
        touches_invalid = (np.abs(self.power(j))[~valid, :] > 0).any(axis=0)
        return ~touches_invalid

    def cache_key(self) -> Array:
        """The key of the operator for memoisation: ``M`` defines it.

        Returns
        -------
        ndarray
            ``M``.
        """
        return self.M

    def __repr__(self) -> str:
        return f"MatrixLag(M of shape {self.M.shape})"


def past_blocks(Z: Array, p: int, lag: LagOperator) -> tuple[Array, Mask]:
    """Stack the past ``Zp = [Z_p; Z_{p-1}; ...; Z_1]`` with ``Z_j = lag^j Z``.

    Oldest block first, as in the toolbox's ``dordvarx``, so that ``coef @ Zp`` is the
    VARX prediction with ``coef = [Xi_p, ..., Xi_1]``.

    Parameters
    ----------
    Z : ndarray, shape (d, N)
        The data ``[U; Y]`` (rows = signals).
    p : int
        Number of lags.
    lag : LagOperator
        The "one step back" operator.

    Returns
    -------
    Zp : ndarray, shape (p d, N)
        The stacked lags, on all columns.
    valid : ndarray of bool, shape (N,)
        The columns on which every block is determined by the data.

    Examples
    --------
    >>> Zp, valid = past_blocks(np.arange(8.0).reshape(2, 4), 2, SampleShift())
    >>> Zp
    array([[0., 0., 0., 1.],
           [0., 0., 4., 5.],
           [0., 0., 1., 2.],
           [0., 4., 5., 6.]])
    >>> valid
    array([False, False,  True,  True])
    """
    d, ncols = Z.shape
    all_valid = np.ones(ncols, dtype=bool)
    valid = all_valid.copy()
    Zp = np.empty((p * d, ncols))
    for i, j in enumerate(range(p, 0, -1)):
        Zp[i * d : (i + 1) * d] = lag.apply(Z, j)
        valid &= lag.valid_columns(all_valid, j)
    return Zp, valid


def r_factor(Phi: Array, Y: Array, chunk: int = 8192) -> Array:
    """Triangular factor ``R`` of ``[Phi^T, Y^T] = Q R``, computed over column chunks.

    Tall-skinny QR: ``R`` is updated with ``qr([R; next chunk])``, so memory stays at
    ``O((d + l)(d + l + chunk))`` beyond the data.  ``R`` is ``(d + l) x (d + l)``
    (zero-padded when there are fewer columns than unknowns); ``R[:d, :d]`` has the
    singular values of ``Phi``, ``R[:d, d:] = Q_1^T Y^T`` and ``||R[d:, d:]||_F^2`` is the
    least-squares residual.
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
        R = scipy.linalg.qr(blk, mode="r", overwrite_a=True, check_finite=False)[0]
        R = R[: min(R.shape)]  # the (full-shape) zero rows below the triangle dropped
    if R.shape[0] < w:
        R = np.vstack([R, np.zeros((w - R.shape[0], w))])
    return R


@dataclass
class VarxResult:
    """Output of :func:`varx`.

    Attributes
    ----------
    Xi : ndarray, shape (p, l, m + l)
        ``Xi[j - 1] = Xi_j``, the coefficient of ``z_{k-j}``.
    coef : ndarray, shape (l, p (m + l))
        The toolbox layout ``[Xi_p, ..., Xi_1]``.
    D : ndarray, shape (l, m)
        Feedthrough (zeros without it).
    Zp : ndarray, shape (p (m + l), len(columns))
        The stacked past (:func:`past_blocks`) on ``columns``.
    columns : ndarray of int
        The columns used (every lag determined).
    residuals : ndarray, shape (l, len(columns))
        ``Y - Xi Zp - D U`` on ``columns``.
    ridge : float
        The ridge parameter used (0 for plain least squares).
    regularize : str
        ``"none"``, ``"gcv"`` or ``"fixed"``.
    gcv : float or None
        The GCV function at ``ridge`` (``None`` when not computed).
    extra : dict
        Estimator details (``{"estimator": "iv", "instruments": r}`` for IV).
    zp_factor : ndarray, shape (p (m + l), p (m + l)), or None
        The triangular factor ``R`` of ``Zp^T = Q R`` when the least-squares fit computed
        it (``None`` otherwise, e.g. for instrumental variables): the singular values and
        left singular vectors of any ``L Zp`` are those of ``L R^T``
        (:class:`hdpbsid.core.pbsid.SubspaceStage`).
    """

    Xi: Array
    coef: Array
    D: Array
    Zp: Array
    columns: NDArray[np.intp]
    residuals: Array
    ridge: float
    regularize: str
    gcv: float | None = None
    extra: dict = field(default_factory=dict)
    zp_factor: Array | None = None


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
    """Map the user option to ``(kind, lam)``: kind in {"none", "gcv", "fixed"}."""
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


def _regression_factor(
    Z: Array, Phi: Array, Yc: Array, p: int, m: int, lag: LagOperator, feedthrough: bool
) -> Array:
    """The triangular factor of ``[Phi^T, Yc^T]`` for :func:`varx`: from the lagged Gram
    matrix with the sample shift when it is certified to be as good as the data
    (:func:`hdpbsid.core.lag_gram.regression_factor`: ``O(N d^2 p)`` operations instead
    of the QR's ``O(N d^2 p^2)``), otherwise the QR factorisation (:func:`r_factor`)."""
    if type(lag) is SampleShift:
        from hdpbsid.core.lag_gram import regression_factor

        R = regression_factor(Z, p, m, feedthrough)
        if R is not None:
            return R
    return r_factor(Phi, Yc)


def varx(
    U: Array,
    Y: Array,
    p: int,
    lag: LagOperator | None = None,
    feedthrough: bool = False,
    regularize: bool | str | float | None = False,
    ridge_floor: float = 0.0,
    instruments: Array | None = None,
    exogenous: Sequence[int] = (),
) -> VarxResult:
    r"""Estimate the VARX predictor ``y_k = sum_j Xi_j z_{k-j} + D u_k + e_k``.

    Step 1 of PBSID: with ``z = [u; y]`` the innovation model's predictor has the Markov
    parameters ``Xi_j = C At^{j-1} Bt``, ``At = A - K C``, ``Bt = [B - K D, K]``, which
    decay with the predictor's poles; truncated at ``p`` lags they are the coefficients of
    a linear regression of ``y_k`` on the past.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Inputs (rows = signals).
    Y : ndarray, shape (l, N)
        Outputs.
    p : int
        Past window (number of lags).
    lag : LagOperator, optional
        The "one step back" operator (default :class:`SampleShift`).
    feedthrough : bool, optional
        Include ``D u_k`` (the toolbox's ``noD=0``).  Leave it out in closed loop when the
        controller has direct feedthrough: then ``u_k`` is correlated with ``e_k``.
    regularize : bool, str, float or None, optional
        Plain least squares (False, None, ``"none"``), ridge with GCV (True,
        ``"gcv"``) or ridge with the given parameter (a float ``>= 0``);
        see :func:`ridge_gcv`.
    ridge_floor : float, optional
        Lower bound of the GCV ridge, relative to the largest singular value.
    instruments : ndarray, shape (k, N), optional
        Instrument rows on the same columns as ``U, Y``: switches to instrumental
        variables (:func:`two_stage_ls`).
    exogenous : sequence of int, optional
        Rows of ``Z = [U; Y]`` whose lagged blocks join the instruments (signals known to
        be uncorrelated with ``e``, e.g. pseudo-inputs, which are their own instruments).

    Returns
    -------
    VarxResult
        Coefficients, feedthrough, the stacked past and residuals on the columns used.

    Raises
    ------
    ValueError
        If the usable columns are not more than the regressors (reduce ``p``), if
        ``instruments`` has the wrong shape, if ``exogenous`` indexes no row of ``[U; Y]``,
        or if ``regularize`` is a negative number or an unknown string.
    TypeError
        If ``regularize`` is not a bool, string or number.

    Notes
    -----
    .. math::

        y_k = \sum_{j=1}^{p} \Xi_j z_{k-j} + D u_k + e_k, \qquad
        \Xi_j = C \tilde A^{j-1} \tilde B .

    Least squares is consistent only when every regressor is uncorrelated with ``e_k``;
    with a lag that is not strictly causal in the index (a basis-domain operator) or with
    fed-back noise that fails, and IV with instruments independent of the noise restores
    consistency (Soderstrom & Stoica 1983, ch. 3).

    References
    ----------
    .. [1] A. Chiuso, "The role of vector autoregressive modeling in predictor-based
       subspace identification", *Automatica* 43(6), 1034-1048, 2007, eq. (8).
    .. [2] T. Soderstrom and P. Stoica, *Instrumental Variable Methods for System
       Identification*, Springer, 1983.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((1, 300))
    >>> y = np.zeros((1, 300))
    >>> for k in range(1, 300):
    ...     y[0, k] = 0.8 * y[0, k - 1] + u[0, k - 1]
    >>> vx = varx(u, y, p=1)
    >>> vx.Xi.round(6)  # [b, a] of y_k = a y_{k-1} + b u_{k-1}
    array([[[1. , 0.8]]])
    """
    lag = SampleShift() if lag is None else lag
    m, l = U.shape[0], Y.shape[0]
    Z = np.vstack([U, Y])
    Zp_all, valid = past_blocks(Z, p, lag)
    cols = np.flatnonzero(valid)
    Zp = Zp_all[:, cols]
    Yc = Y[:, cols]
    Phi = np.vstack([Zp, U[:, cols]]) if (feedthrough and m > 0) else Zp
    nreg = Phi.shape[0]
    if cols.size <= nreg:
        raise ValueError(
            f"the VARX regression has {nreg} regressors (p*(m+l) = {p}*({m}+{l})"
            f"{' + m' if feedthrough and m else ''}) but only {cols.size} usable columns: "
            f"reduce p (past window) or supply more data"
        )
    kind, lam = parse_regularize(regularize)
    gcv_val = None
    extra: dict = {}
    R = None
    if instruments is not None:
        Psi = np.asarray(instruments, dtype=float)
        if Psi.ndim != 2 or Psi.shape[1] != Z.shape[1]:
            raise ValueError(
                f"instruments must be a 2-D array with {Z.shape[1]} columns (one per data "
                f"column), got shape {Psi.shape}"
            )
        exo = [int(i) for i in exogenous]
        if any(i < 0 or i >= m + l for i in exo):
            raise ValueError(f"exogenous must index rows of [U; Y] (0..{m + l - 1}), got {exo}")
        exo_rows = [b * (m + l) + i for b in range(p) for i in exo]
        Psi = np.vstack([Psi[:, cols], Zp[exo_rows]])
        theta, lam_used, gcv_val, extra = two_stage_ls(
            Phi,
            Yc,
            Psi,
            lam if kind == "fixed" else (None if kind == "gcv" else 0.0),
            floor=ridge_floor if kind == "gcv" else 0.0,
        )
    elif kind == "none":
        # minimum-norm least squares from the R factor (same rcond as numpy.linalg.lstsq)
        R = _regression_factor(Z, Phi, Yc, p, m, lag, feedthrough)
        rcond = np.finfo(float).eps * max(Phi.shape)
        theta = np.linalg.lstsq(R[:nreg, :nreg], R[:nreg, nreg:], rcond=rcond)[0].T
        lam_used = 0.0
    else:
        R = _regression_factor(Z, Phi, Yc, p, m, lag, feedthrough)  # kept for the states
        theta, lam_used, gcv_val = ridge_gcv_r(
            R,
            nreg,
            cols.size,
            lam if kind == "fixed" else None,
            floor=ridge_floor if kind == "gcv" else 0.0,
        )
    coef = theta[:, : p * (m + l)]
    D = theta[:, p * (m + l) :] if (feedthrough and m > 0) else np.zeros((l, m))
    # coef = [Xi_p, ..., Xi_1]  ->  Xi[j-1] = Xi_j
    Xi = np.stack([coef[:, (p - j) * (m + l) : (p - j + 1) * (m + l)] for j in range(1, p + 1)])
    residuals = Yc - theta @ Phi
    return VarxResult(
        Xi=Xi,
        coef=coef,
        D=D,
        Zp=Zp,
        columns=cols,
        residuals=residuals,
        ridge=lam_used,
        regularize=kind,
        gcv=gcv_val,
        extra=extra,
        # the regressors come first in Phi = [Zp; U]: R's leading block is Zp^T's factor
        zp_factor=None if R is None else R[: p * (m + l), : p * (m + l)],
    )


#: the past-window search (:func:`select_past_window`) factors the lags up to
#: ``p_max / WINDOW_SEARCH_GROWTH`` first and grows the window searched until it is
#: ``WINDOW_SEARCH_GROWTH`` times the best window found so far (or ``p_max``).  Why it may
#: stop there: AIC trades the fit a longer past adds -- the predictor's Markov parameters
#: ``C At^{j-1} Bt`` beyond lag ``p``, which decay with the predictor's poles -- against a
#: penalty linear in ``p``; once the lags up to three times the best window have not paid
#: for themselves, the ones beyond carry what is left of a decaying tail.  A dead time
#: or a long-period disturbance is no decaying tail, which is why the first block is a
#: third of the cap (a dead time up to ``p_max / 3`` samples is seen).  It is a rule of
#: thumb, not a bound (the AIC of a noisy record has local minima): the factor 3 leaves a
#: margin over the largest factor the records of ``bench/regression.py`` need to find the
#: full search's window.  A record whose best window is short needs a fraction of the
#: factorisation, whose cost grows with the square of the window searched.
WINDOW_SEARCH_GROWTH = 3.0


def windows_searched(crit: Array) -> int:
    """The largest past window whose criterion :func:`select_past_window` evaluated.

    Parameters
    ----------
    crit : ndarray, shape (p_max,)
        Criterion values, ``inf`` where not evaluated.

    Returns
    -------
    int
        One plus the index of the last finite entry; 0 when none is finite.

    Examples
    --------
    >>> windows_searched(np.array([3.0, 1.0, 2.0, np.inf]))
    3
    """
    finite = np.flatnonzero(np.isfinite(crit))
    return int(finite[-1]) + 1 if finite.size else 0


def search_is_complete(
    crit: Array, p_max: int, growth: float | None = WINDOW_SEARCH_GROWTH
) -> bool:
    """Whether the evaluated criterion values settle the past window.

    The search has settled it when it reached ``p_max`` or ``growth`` times the best window
    (:data:`WINDOW_SEARCH_GROWTH`, the reason there).

    Parameters
    ----------
    crit : ndarray, shape (p_max,)
        Criterion values of :func:`select_past_window`, ``inf`` where not evaluated.
    p_max : int
        The largest window allowed.
    growth : float or None, optional
        The growth factor of the search; ``None`` means every window was searched.

    Returns
    -------
    bool
        True when the windows searched settle the choice.

    Examples
    --------
    >>> search_is_complete(np.array([3.0, 1.0, 2.0, np.inf, np.inf, np.inf, np.inf]), 7)
    False
    >>> search_is_complete(np.array([3.0, 1.0, 2.0, 2.5, 2.6, 2.7, np.inf]), 7)
    True
    """
    searched = windows_searched(crit)
    if searched == 0:
        return False
    best = int(np.argmin(crit)) + 1
    return searched >= p_max or growth is None or searched >= growth * best


class _GrowingQR:
    """Householder QR of ``[Phi, Y]`` (``N x (d + l)``, one row per sample) grown by blocks
    of regressor columns: a block's columns get the reflectors of the blocks before it,
    then their own, which are applied to ``Y`` (LAPACK ``ormqr``, ``geqrf``).  The
    reflectors are those of the QR of all columns at once, so after the columns
    ``0..c - 1`` the least-squares residual of ``Y`` on them has the Gram matrix
    ``Y[c:]^T Y[c:]`` (Golub & Van Loan, *Matrix Computations*, 4th ed., sec. 5.3.3) --
    every nested regression from one factorisation, computed only as far as needed."""

    def __init__(self, Y: Array) -> None:
        self.Y = np.array(Y, dtype=float, order="F")
        self.blocks: list[tuple[int, Array, Array]] = []
        self.ncols = 0

    def add(self, cols: Array) -> None:
        """Factor the next regressor columns ``cols`` (``N x k``; overwritten when it is a
        Fortran-ordered float array, as the blocks :func:`select_past_window` builds)."""
        from scipy.linalg.lapack import dgeqrf, dormqr

        C = np.asfortranarray(cols, dtype=float)  # factored in place (a copy if not F)
        for c0, refl, tau in self.blocks:
            C[c0:] = dormqr("L", "T", refl, tau, C[c0:], max(1, 64 * C.shape[1]))[0]
        c0 = self.ncols
        refl, tau, _, info = dgeqrf(C[c0:], lwork=max(1, 64 * C.shape[1]))
        if info != 0:  # pragma: no cover - argument errors only
            raise ValueError(f"LAPACK geqrf failed (info = {info})")
        self.Y[c0:] = dormqr("L", "T", refl, tau, self.Y[c0:], max(1, 64 * self.Y.shape[1]))[0]
        self.blocks.append((c0, refl, tau))
        self.ncols += C.shape[1]

    def residual_gram(self, c: int) -> Array:
        """Gram matrix of the residual of ``Y`` on the first ``c <= ncols`` columns."""
        res = self.Y[c:]
        return res.T @ res


def select_past_window(
    U: Array,
    Y: Array,
    p_max: int,
    p_min: int = 1,
    lag: LagOperator | None = None,
    feedthrough: bool = False,
    criterion: str = "aic",
    rel_floor: float = 1e-12,
    growth: float | None = WINDOW_SEARCH_GROWTH,
    gram: bool = True,
) -> tuple[int, Array]:
    r"""Choose the past window ``p`` by an information criterion on the VARX fit.

    For ``p = 1..p_max`` the VARX models are nested, so one QR factorisation of
    ``[Phi_{p_max}^T, Y^T]`` (regressors ordered ``u_k, z_{k-1}, z_{k-2}, ...``) on the
    columns valid for ``p_max`` gives every residual covariance ``Sigma_p``: the residual
    of ``Y`` on the first ``c`` columns of a QR has the Gram matrix of the last rows of
    ``Q^T Y`` (Golub & Van Loan, sec. 5.3.3).  ``Sigma_p`` is computed on outputs scaled
    to unit RMS and floored at ``rel_floor``: a noise-free record fits to rounding level for
    every ``p >= n``, and the floor stops round-off from choosing among exact fits, so the
    smallest exact ``p`` wins.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Inputs.
    Y : ndarray, shape (l, N)
        Outputs.
    p_max : int
        Largest window considered.
    p_min : int, optional
        Smallest window considered.
    lag : LagOperator, optional
        The "one step back" operator (default :class:`SampleShift`).
    feedthrough : bool, optional
        Include ``D u_k`` in every VARX.
    criterion : {"aic", "bic"}, optional
        Akaike's or Schwarz's criterion.
    rel_floor : float, optional
        Floor added to the scaled residual covariance.
    growth : float or None, optional
        Grow the factorisation lag by lag from ``p_max / growth`` lags until the lags
        factored reach ``growth`` times the best window so far or ``p_max``
        (:data:`WINDOW_SEARCH_GROWTH`); ``None`` searches every ``p``.
    gram : bool, optional
        With the sample shift, search on the Gram matrix of the lagged samples first
        (:mod:`hdpbsid.core.lag_gram`), keeping its choice only when it is certified to be
        the exact criterion's; otherwise the QR decides.

    Returns
    -------
    p : int
        The window chosen.
    crit : ndarray, shape (p_max,)
        ``crit[p - 1]`` the criterion value; ``inf`` for ``p < p_min`` and for the windows
        not searched (:func:`search_is_complete`).

    Raises
    ------
    ValueError
        If ``criterion`` is not ``"aic"``/``"bic"``, ``growth`` is not ``> 1`` or None, or
        the usable columns are not more than the regressors of ``p_max``.

    Notes
    -----
    With ``d_p = p (m + l)`` (``+ m`` with feedthrough) regressors per output,

    .. math::

        \mathrm{AIC}(p) = N \log\det\Sigma_p + 2\, l\, d_p, \qquad
        \mathrm{BIC}(p) = N \log\det\Sigma_p + l\, d_p \log N .

    Every ``p`` is evaluated on the same columns (those valid for ``p_max``), so a longer
    search only adds values.

    References
    ----------
    .. [1] H. Akaike, "A new look at the statistical model identification", *IEEE Trans.
       Automatic Control* 19(6), 716-723, 1974.
    .. [2] G. Schwarz, "Estimating the dimension of a model", *Ann. Statist.* 6(2),
       461-464, 1978.
    .. [3] G. H. Golub and C. F. Van Loan, *Matrix Computations*, 4th ed., 2013, sec. 5.3.3.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((1, 300))
    >>> y = np.zeros((1, 300))
    >>> for k in range(1, 300):
    ...     y[0, k] = 0.8 * y[0, k - 1] + u[0, k - 1]
    >>> p, crit = select_past_window(u, y, p_max=6)
    >>> p
    1
    """
    lag = SampleShift() if lag is None else lag
    if criterion not in ("aic", "bic"):
        raise ValueError(f"criterion must be 'aic' or 'bic', got {criterion!r}")
    if growth is not None and not growth > 1.0:
        raise ValueError(f"growth must be a number > 1 or None (search every p), got {growth!r}")
    m, l = U.shape[0], Y.shape[0]
    Z = np.vstack([U, Y])
    ncols = Z.shape[1]
    all_valid = np.ones(ncols, dtype=bool)
    valid = all_valid.copy()
    for j in range(1, p_max + 1):
        valid &= lag.valid_columns(all_valid, j)
    cols = np.flatnonzero(valid)
    N = cols.size
    d0 = m if (feedthrough and m > 0) else 0
    dtot = d0 + p_max * (m + l)
    if N <= dtot + l:
        raise ValueError(f"p_max={p_max} needs {dtot} VARX regressors but only {N} usable columns")
    if gram and type(lag) is SampleShift:
        got = _window_search_by_gram(U, Y, p_max, p_min, d0, criterion, rel_floor, growth)
        if got is not None:
            return got
    scale = np.sqrt(np.mean(Y[:, cols] ** 2, axis=1))
    scale[scale == 0] = 1.0
    qr = _GrowingQR((Y[:, cols] / scale[:, None]).T)

    def regressors(first: int, last: int) -> Array:
        # u_k (first block, with feedthrough), then z_{k-first} ... z_{k-last}: the models
        # for p = 1..p_max are nested; each column scaled to unit RMS (keeps the QR well
        # conditioned, does not change the fit)
        lead = m if (d0 and first == 1) else 0
        block = np.empty((N, lead + (last - first + 1) * (m + l)), order="F")
        if lead:
            block[:, :lead] = U[:, cols].T
        for i, j in enumerate(range(first, last + 1)):
            a = lead + i * (m + l)
            block[:, a : a + m + l] = lag.apply(Z, j)[:, cols].T
        cs = np.sqrt(np.mean(block**2, axis=0))
        cs[cs == 0] = 1.0
        block /= cs[None, :]
        return block

    crit = np.full(p_max, np.inf)
    pen = {"aic": 2.0, "bic": np.log(N)}
    lo = max(p_min, 1)
    step = p_max if growth is None else max(1, int(np.ceil(p_max / growth)))
    done, target = 0, min(p_max, max(step, lo))
    while True:
        qr.add(regressors(done + 1, target))
        for p in range(max(lo, done + 1), target + 1):
            q = d0 + p * (m + l)
            sigma = qr.residual_gram(q) / N + rel_floor * np.eye(l)
            crit[p - 1] = N * np.linalg.slogdet(sigma)[1] + pen[criterion] * l * q
        done = target
        best = int(np.argmin(crit)) + 1
        if done >= p_max or growth is None or done >= growth * best:
            return best, crit
        target = min(p_max, max(int(np.ceil(growth * best)), done + 1))


def _window_search_by_gram(
    U: Array,
    Y: Array,
    p_max: int,
    p_min: int,
    d0: int,
    criterion: str,
    rel_floor: float,
    growth: float | None,
) -> tuple[int, Array] | None:
    """:func:`select_past_window` with the sample shift from the lagged Gram matrix
    (:mod:`hdpbsid.core.lag_gram`): the same windows searched, the same growth, and
    ``None`` unless every step's best window is certified to be the exact criterion's
    (its margin over every other window searched exceeds both error bounds), or when
    the Gram matrix is not finite or has a zero column."""
    from hdpbsid.core.lag_gram import (
        criterion_error_bounds,
        nested_residual_covariances,
        shift_gram,
    )

    m, l = U.shape[0], Y.shape[0]
    d = m + l
    Z = np.vstack([U, Y])
    n = Z.shape[1] - p_max  # the columns valid for p_max
    energy = np.sum(Z * Z, axis=1)
    lead = list(range(m)) if d0 else []  # u_k, with feedthrough
    outputs = [m + c for c in range(l)]  # y_k
    pen = {"aic": 2.0, "bic": np.log(n)}[criterion]
    crit = np.full(p_max, np.inf)
    lo = max(p_min, 1)
    step = p_max if growth is None else max(1, int(np.ceil(p_max / growth)))
    done, target = 0, min(p_max, max(step, lo))
    floor = rel_floor * np.eye(l)
    while True:
        # the lags searched so far only: a record the Gram cannot serve (its Cholesky
        # fails) costs a fraction of the QR's first step
        idx = lead + list(range(d, (target + 1) * d)) + outputs
        M = shift_gram(Z, p_max, target)[np.ix_(idx, idx)]
        diag = np.diag(M).copy()
        if not np.all(np.isfinite(M)) or np.any(diag <= 0):
            return None
        s = np.sqrt(diag)
        try:
            R = np.linalg.cholesky(M / s[:, None] / s[None, :]).T
        except np.linalg.LinAlgError:
            return None
        sigma = nested_residual_covariances(R, l) + floor
        sign, logdet = np.linalg.slogdet(sigma)
        # sqrt(whole energy / window energy) of every column: lag_gram's formation bound
        rho = np.sqrt(energy[np.asarray(idx) % d] / diag)
        bound = criterion_error_bounds(R, l, n + 2 * p_max, rho, np.linalg.eigvalsh(sigma)[:, 0])
        if bound is None or np.any(sign <= 0):
            return None
        ps = np.arange(lo, target + 1)
        q = d0 + ps * d
        crit[ps - 1] = n * logdet[q] + pen * l * q
        best = int(np.argmin(crit)) + 1
        margin = crit[ps - 1] - crit[best - 1]
        slack = n * (bound[q] + bound[d0 + best * d])
        if np.any((margin <= slack) & (ps != best)):
            return None
        done = target
        if done >= p_max or growth is None or done >= growth * best:
            return best, crit
        target = min(p_max, max(int(np.ceil(growth * best)), done + 1))
