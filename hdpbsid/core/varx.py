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
(:mod:`hdpbsid.core.ridge`; Golub, Heath & Wahba 1979; Hansen, *Rank-deficient and
discrete ill-posed problems*, sec. 7.4).  The past window is a policy
(:class:`PastWindowPolicy`: the criterion and its growing search) whose choice
(:class:`PastWindowChoice`) carries its inputs and reason.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from hdpbsid.core.ridge import parse_regularize, r_factor, ridge_gcv, ridge_gcv_r, two_stage_ls
from hdpbsid.models.report import Choice

__all__ = [
    "LagOperator",
    "is_strictly_causal",
    "CachedPowers",
    "SampleShift",
    "MatrixLag",
    "past_blocks",
    "r_factor",
    "parse_regularize",
    "VarxResult",
    "ridge_gcv",
    "ridge_gcv_r",
    "varx",
    "two_stage_ls",
    "select_past_window",
    "choose_past_window",
    "PastWindowPolicy",
    "PastWindowChoice",
    "DEFAULT_PAST_WINDOW",
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


def is_strictly_causal(lag: LagOperator) -> bool:
    """Whether ``lag`` is known to be strictly causal: every column of ``apply(W, 1)`` is
    a combination of earlier columns of ``W`` only, as the sample shift is.

    What it decides.  The VARX regresses each column of the output on the lagged data.
    With a strictly causal lag a lagged column holds only earlier samples, so white
    innovations are uncorrelated with every regressor and least squares is consistent.
    A lag with a nonzero diagonal (the integrator lag ``M = D'^{-1}`` of the basis
    domain, whose matrix is full) mixes the current column into its own regressor:
    projected white noise ``E`` gives ``E[E (E M)^T] = sigma^2 tr(M) != 0``
    (:mod:`hdpbsid.methods.hermite_iv`), and the part of the output driven by noise
    biases the estimate.

    Parameters
    ----------
    lag : LagOperator
        The lag operator; one that does not say (no ``strictly_causal`` attribute) is
        not known to be strictly causal.

    Returns
    -------
    bool
        The operator's ``strictly_causal``, False when it has none.

    Examples
    --------
    >>> is_strictly_causal(SampleShift()), is_strictly_causal(MatrixLag(np.eye(2)))
    (True, False)
    >>> is_strictly_causal(MatrixLag(np.diag([1.0], 1)))  # "one column back"
    True
    """
    return bool(getattr(lag, "strictly_causal", False))


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

    #: every lagged column holds only earlier samples (:func:`is_strictly_causal`)
    strictly_causal = True

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

    @property
    def strictly_causal(self) -> bool:
        """Whether column ``k`` of ``W M`` holds only columns before ``k`` of ``W``:
        ``M[i, k] = 0`` for ``i >= k`` (:func:`is_strictly_causal`)."""
        return not np.any(np.tril(self.M))

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
    if instruments is not None:
        Psi = _instrument_rows(instruments, exogenous, Z, Zp, cols, p, m + l)
        theta, lam_used, gcv_val, extra = two_stage_ls(
            Phi,
            Yc,
            Psi,
            lam if kind == "fixed" else (None if kind == "gcv" else 0.0),
            floor=ridge_floor if kind == "gcv" else 0.0,
        )
        R = None
    else:
        R = _regression_factor(Z, Phi, Yc, p, m, lag, feedthrough)  # kept for the states
        theta, lam_used, gcv_val = _least_squares(R, Phi, nreg, cols.size, kind, lam, ridge_floor)
        extra = {}
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


def _instrument_rows(
    instruments: Array, exogenous: Sequence[int], Z: Array, Zp: Array, cols: Array, p: int, d: int
) -> Array:
    """The instruments of :func:`varx` on its columns ``cols``, followed by the lagged
    blocks of the ``exogenous`` rows of ``Z`` (``d = m + l`` rows), which are their own
    instruments."""
    Psi = np.asarray(instruments, dtype=float)
    if Psi.ndim != 2 or Psi.shape[1] != Z.shape[1]:
        raise ValueError(
            f"instruments must be a 2-D array with {Z.shape[1]} columns (one per data "
            f"column), got shape {Psi.shape}"
        )
    exo = [int(i) for i in exogenous]
    if any(i < 0 or i >= d for i in exo):
        raise ValueError(f"exogenous must index rows of [U; Y] (0..{d - 1}), got {exo}")
    exo_rows = [b * d + i for b in range(p) for i in exo]
    return np.vstack([Psi[:, cols], Zp[exo_rows]])


def _least_squares(
    R: Array, Phi: Array, nreg: int, ncols: int, kind: str, lam: float | None, ridge_floor: float
) -> tuple[Array, float, float | None]:
    """The VARX coefficients ``theta`` from the triangular factor ``R`` of
    ``[Phi^T, Yc^T]``: minimum-norm least squares (``kind == "none"``, the ``rcond`` of
    :func:`numpy.linalg.lstsq`) or ridge (:func:`ridge_gcv_r`); with the ridge parameter
    used and the GCV value (None when not computed)."""
    if kind == "none":
        rcond = np.finfo(float).eps * max(Phi.shape)
        theta = np.linalg.lstsq(R[:nreg, :nreg], R[:nreg, nreg:], rcond=rcond)[0].T
        return theta, 0.0, None
    return ridge_gcv_r(
        R,
        nreg,
        ncols,
        lam if kind == "fixed" else None,
        floor=ridge_floor if kind == "gcv" else 0.0,
    )


@dataclass(frozen=True)
class PastWindowPolicy:
    """How the past window ``p`` of the VARX is chosen (:func:`select_past_window`).

    An information criterion of the nested VARX fits ``p = p_min..p_max``, searched on a
    growing factorisation: the lags up to ``p_max / growth`` first, then more until the
    lags factored reach ``growth`` times the best window so far (or ``p_max``).

    Attributes
    ----------
    criterion : {"aic", "bic"}
        Akaike's or Schwarz's criterion.
    growth : float or None
        The growth factor of the search (the reason at the field); None searches every
        ``p``.
    rel_floor : float
        Floor added to the residual covariance of outputs scaled to unit RMS.
    gram : bool
        With the sample shift, search on the Gram matrix of the lagged samples first
        (:mod:`hdpbsid.core.lag_gram`), keeping its choice only when certified.

    Raises
    ------
    ValueError
        If ``criterion`` is not ``"aic"``/``"bic"`` or ``growth`` is not ``> 1`` or None.

    Examples
    --------
    >>> policy = PastWindowPolicy()
    >>> policy.first_target(1, 30), policy.next_target(10, 2, 30)
    (10, None)
    """

    #: Akaike's criterion: the predictor's Markov parameters decay, so the window is a
    #: bias-variance trade-off, which AIC weighs (BIC aims at a true finite order)
    criterion: str = "aic"
    #: AIC trades the fit a longer past adds -- the Markov parameters ``C At^{j-1} Bt``
    #: beyond lag ``p``, which decay with the predictor's poles -- against a penalty
    #: linear in ``p``; once the lags up to three times the best window have not paid for
    #: themselves, the ones beyond carry what is left of a decaying tail.  A dead time or
    #: a long-period disturbance is no decaying tail, which is why the first block is a
    #: third of the cap (a dead time up to ``p_max / 3`` samples is seen).  A rule of
    #: thumb, not a bound (the AIC of a noisy record has local minima): the factor 3
    #: leaves a margin over the largest factor the regression records need to find the
    #: full search's window, and a record whose best window is short needs a fraction of
    #: the factorisation, whose cost grows with the square of the window searched.
    growth: float | None = 3.0
    #: a noise-free record fits to rounding level for every ``p >= n``: the floor (far
    #: above the round-off of unit-RMS outputs, far below any noise) stops round-off from
    #: choosing among exact fits, so the smallest exact ``p`` wins
    rel_floor: float = 1e-12
    #: the Gram matrix costs ``O(N d^2 p)`` instead of the QR's ``O(N d^2 p^2)``
    gram: bool = True

    def __post_init__(self) -> None:
        if self.criterion not in ("aic", "bic"):
            raise ValueError(f"criterion must be 'aic' or 'bic', got {self.criterion!r}")
        if self.growth is not None and not self.growth > 1.0:
            raise ValueError(
                f"growth must be a number > 1 or None (search every p), got {self.growth!r}"
            )

    def penalty(self, n: int) -> float:
        """The criterion's penalty per parameter on ``n`` columns.

        Parameters
        ----------
        n : int
            Columns of the regression.

        Returns
        -------
        float
            2 (AIC) or ``log n`` (BIC).
        """
        return {"aic": 2.0, "bic": np.log(n)}[self.criterion]

    def first_target(self, p_min: int, p_max: int) -> int:
        """The lags factored by the first step of the search.

        Parameters
        ----------
        p_min : int
            Smallest window considered.
        p_max : int
            Largest window considered.

        Returns
        -------
        int
            ``p_max / growth`` rounded up (``p_max`` without growth), at least ``p_min``.
        """
        lo = max(p_min, 1)
        step = p_max if self.growth is None else max(1, int(np.ceil(p_max / self.growth)))
        return min(p_max, max(step, lo))

    def next_target(self, done: int, best: int, p_max: int) -> int | None:
        """The lags the search factors next, or None when the ``done`` lags settle it.

        Parameters
        ----------
        done : int
            Lags factored so far.
        best : int
            The best window among them.
        p_max : int
            Largest window considered.

        Returns
        -------
        int or None
            ``growth * best`` rounded up (at least one more lag, at most ``p_max``);
            None once ``p_max`` or ``growth * best`` lags are factored.
        """
        if done >= p_max or self.growth is None or done >= self.growth * best:
            return None
        return min(p_max, max(int(np.ceil(self.growth * best)), done + 1))


#: the default policy of :func:`select_past_window`
DEFAULT_PAST_WINDOW = PastWindowPolicy()
#: the growth factor of the default past-window search (the reason at
#: :attr:`PastWindowPolicy.growth`)
WINDOW_SEARCH_GROWTH = DEFAULT_PAST_WINDOW.growth


@dataclass(frozen=True)
class PastWindowChoice:
    """The past window chosen by a :class:`PastWindowPolicy`, with its inputs.

    Attributes
    ----------
    p : int
        The window chosen.
    criterion_values : ndarray, shape (p_max,)
        ``criterion_values[p - 1]`` the criterion value; ``inf`` for ``p < p_min`` and
        for the windows not searched.
    p_min : int
        Smallest window considered.
    p_max : int
        Largest window considered.
    policy : PastWindowPolicy
        The rule that chose it.

    Examples
    --------
    >>> crit = np.array([3.0, 1.0, 2.0, 2.5, 2.6, 2.7, np.inf])
    >>> choice = PastWindowChoice(2, crit, 1, 7, PastWindowPolicy())
    >>> choice.searched, choice.choice().value
    (6, 2)
    >>> choice.reason()
    'min AIC of the VARX fit over p in [1, 7], searched up to p = 6 (3 x the best window)'
    """

    p: int
    criterion_values: Array
    p_min: int
    p_max: int
    policy: PastWindowPolicy

    @property
    def searched(self) -> int:
        """The largest window whose criterion was evaluated (:func:`windows_searched`)."""
        return windows_searched(self.criterion_values)

    def reason(self, bounds: str = "") -> str:
        """Why ``p``: the criterion, the range and how far the search went.

        Parameters
        ----------
        bounds : str, optional
            The rule of ``p_min`` and ``p_max``, shown in parentheses after the range.

        Returns
        -------
        str
            E.g. ``"min AIC of the VARX fit over p in [1, 30], searched up to p = 12
            (3 x the best window)"``.
        """
        searched = self.searched
        return (
            f"min {self.policy.criterion.upper()} of the VARX fit over p in "
            f"[{self.p_min}, {self.p_max}]{f' ({bounds})' if bounds else ''}, "
            f"searched up to p = {searched}"
            + ("" if searched == self.p_max else f" ({self.policy.growth:g} x the best window)")
        )

    def choice(self, bounds: str = "") -> Choice[int]:
        """The window and its reason as a :class:`~hdpbsid.models.report.Choice`.

        Parameters
        ----------
        bounds : str, optional
            The rule of ``p_min`` and ``p_max`` (:meth:`reason`).

        Returns
        -------
        Choice of int
            ``Choice(p, reason(bounds))``.
        """
        return Choice(self.p, self.reason(bounds))


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
    (:attr:`PastWindowPolicy.growth`, the reason there).

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
    rel_floor: float = DEFAULT_PAST_WINDOW.rel_floor,
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
    policy = PastWindowPolicy(criterion, growth, rel_floor, gram)
    choice = choose_past_window(U, Y, p_max, p_min, lag, feedthrough, policy)
    return choice.p, choice.criterion_values


def choose_past_window(
    U: Array,
    Y: Array,
    p_max: int,
    p_min: int = 1,
    lag: LagOperator | None = None,
    feedthrough: bool = False,
    policy: PastWindowPolicy = DEFAULT_PAST_WINDOW,
) -> PastWindowChoice:
    """The past window chosen by ``policy`` (:func:`select_past_window`, its Notes).

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
    policy : PastWindowPolicy, optional
        The criterion and the search.

    Returns
    -------
    PastWindowChoice
        The window, the criterion values and the policy.

    Raises
    ------
    ValueError
        If the usable columns are not more than the regressors of ``p_max``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((1, 300))
    >>> y = np.zeros((1, 300))
    >>> for k in range(1, 300):
    ...     y[0, k] = 0.8 * y[0, k - 1] + u[0, k - 1]
    >>> choose_past_window(u, y, p_max=6).p
    1
    """
    lag = SampleShift() if lag is None else lag
    m, l = U.shape[0], Y.shape[0]
    Z = np.vstack([U, Y])
    cols = _columns_valid_for(lag, Z.shape[1], p_max)
    N = cols.size
    d0 = m if (feedthrough and m > 0) else 0
    dtot = d0 + p_max * (m + l)
    if N <= dtot + l:
        raise ValueError(f"p_max={p_max} needs {dtot} VARX regressors but only {N} usable columns")
    got = None
    if policy.gram and type(lag) is SampleShift:
        got = _window_search_by_gram(
            U, Y, p_max, p_min, d0, policy.criterion, policy.rel_floor, policy.growth
        )
    if got is None:
        got = _window_search_by_qr(U, Y, Z, cols, lag, p_max, p_min, d0, policy)
    return PastWindowChoice(got[0], got[1], p_min, p_max, policy)


def _columns_valid_for(lag: LagOperator, ncols: int, p_max: int) -> NDArray[np.intp]:
    """The columns on which every lag ``1..p_max`` of ``lag`` is determined."""
    all_valid = np.ones(ncols, dtype=bool)
    valid = all_valid.copy()
    for j in range(1, p_max + 1):
        valid &= lag.valid_columns(all_valid, j)
    return np.flatnonzero(valid)


def _lag_block(
    U: Array, Z: Array, cols: Array, lag: LagOperator, first: int, last: int, d0: int
) -> Array:
    """The regressor columns of the lags ``first..last`` on ``cols`` (one row per
    column), with ``u_k`` ahead of them when ``first == 1`` and ``d0`` (feedthrough): the
    models for ``p = 1..p_max`` are nested; each column scaled to unit RMS (keeps the QR
    well conditioned, does not change the fit)."""
    d = Z.shape[0]
    lead = d0 if first == 1 else 0
    block = np.empty((cols.size, lead + (last - first + 1) * d), order="F")
    cs = np.empty(block.shape[1])
    if lead:
        block[:, :lead] = U[:, cols].T
        cs[:lead] = np.sqrt(np.mean(block[:, :lead] ** 2, axis=0))
    n = cols.size
    # the sample shift on consecutive columns: lag j of column k is Z[:, k - j], so
    # each regressor column is a contiguous slice of a row of Z (no shifted copy of Z)
    slices = type(lag) is SampleShift and n and cols[0] >= last and cols[-1] - cols[0] == n - 1
    for i, j in enumerate(range(first, last + 1)):
        a = lead + i * d
        if slices:
            for r in range(d):
                block[:, a + r] = Z[r, cols[0] - j : cols[0] - j + n]
        else:
            block[:, a : a + d] = lag.apply(Z, j)[:, cols].T
        # each column's RMS while it is in cache (the same per-column reduction as over
        # the whole block, without a temporary of its size)
        cs[a : a + d] = np.sqrt(np.mean(block[:, a : a + d] ** 2, axis=0))
    cs[cs == 0] = 1.0
    block /= cs[None, :]
    return block


def _window_search_by_qr(
    U: Array,
    Y: Array,
    Z: Array,
    cols: Array,
    lag: LagOperator,
    p_max: int,
    p_min: int,
    d0: int,
    policy: PastWindowPolicy,
) -> tuple[int, Array]:
    """:func:`select_past_window` by the growing QR (:class:`_GrowingQR`) of the lagged
    regressors on the columns ``cols`` valid for ``p_max``; ``Sigma_p`` of the outputs
    scaled to unit RMS."""
    m, l = U.shape[0], Y.shape[0]
    N = cols.size
    scale = np.sqrt(np.mean(Y[:, cols] ** 2, axis=1))
    scale[scale == 0] = 1.0
    qr = _GrowingQR((Y[:, cols] / scale[:, None]).T)
    crit = np.full(p_max, np.inf)
    pen = policy.penalty(N)
    lo = max(p_min, 1)
    done, target = 0, policy.first_target(p_min, p_max)
    while target is not None:
        qr.add(_lag_block(U, Z, cols, lag, done + 1, target, d0))
        for p in range(max(lo, done + 1), target + 1):
            q = d0 + p * (m + l)
            sigma = qr.residual_gram(q) / N + policy.rel_floor * np.eye(l)
            crit[p - 1] = N * np.linalg.slogdet(sigma)[1] + pen * l * q
        done = target
        best = int(np.argmin(crit)) + 1
        target = policy.next_target(done, best, p_max)
    return best, crit


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
    policy = PastWindowPolicy(criterion, growth, rel_floor)
    pen = policy.penalty(n)
    crit = np.full(p_max, np.inf)
    lo = max(p_min, 1)
    done, target = 0, policy.first_target(p_min, p_max)
    floor = rel_floor * np.eye(l)
    while target is not None:
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
        target = policy.next_target(done, best, p_max)
    return best, crit
