"""The PBSID core (VARX form): VARX -> Gamma L -> SVD/state -> (C, D) -> (A, B, K).

Steps 2 and 3 of the discrete core (docs/theory.md, "PBSID: the discrete core"), after the
toolbox pipeline ``dordvarx -> dmodx -> dx2abcdk`` (Houtzager's PBSID toolbox; Chiuso 2007,
Automatica 43(6), sec. 4; van Wingerden & Verhaegen 2009). Everything is generic over the
:class:`~hdpbsid.core.varx.LagOperator`, so the same code identifies a sampled model
(``SampleShift``) or a "system in the basis index" (``MatrixLag``).

Notation (rows = signals, columns = time/basis index): ``z = [u; y]``, predictor
``x_{k+1} = At x_k + Bt z_k``, ``y_k = C x_k + D u_k + e_k``, ``At = A - K C``,
``Bt = [B - K D, K]``, VARX coefficients ``Xi_j = C At^{j-1} Bt``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import qr, solve_discrete_are

from hdpbsid.core.varx import (
    LagOperator,
    SampleShift,
    VarxResult,
    is_strictly_causal,
    varx,
)
from hdpbsid.runtime import library_call, user_stacklevel

__all__ = [
    "gamma_l",
    "thin_svd",
    "state_sequence",
    "select_order",
    "resolve_order",
    "estimate_cd",
    "estimate_abk",
    "riccati_gain",
    "stable_gain",
    "CoreResult",
    "SubspaceStage",
    "subspace_stage",
    "pbsid_core",
]

Array = NDArray[np.float64]


def gamma_l(coef: Array, p: int, f: int, m: int, l: int) -> Array:
    r"""Build ``Gamma_f L_p`` (``f l x p (m + l)``) from the VARX coefficients.

    Row block ``i`` (``0 <= i < f``) of the product of the extended observability matrix
    of the predictor and its extended controllability matrix is ``C At^i [At^{p-1} Bt, ...,
    Bt]``.  Its entries are Markov parameters ``Xi_j = C At^{j-1} Bt`` of the VARX, except
    the terms with ``j > p``, which are negligible when the past window is long enough for
    ``At^p ~= 0`` and are set to zero: so no future data are needed (the toolbox's
    ``dordvarx`` with ``weight=0``).

    Parameters
    ----------
    coef : ndarray, shape (l, p (m + l))
        VARX coefficients in the toolbox layout ``[Xi_p, ..., Xi_1]``
        (``coef`` of :class:`~hdpbsid.core.varx.VarxResult`).
    p : int
        Past window (number of VARX lags).
    f : int
        Future window, ``1 <= f <= p``.
    m : int
        Number of inputs.
    l : int
        Number of outputs.

    Returns
    -------
    ndarray, shape (f l, p (m + l))
        ``Gamma_f L_p``, block upper triangular in the sense above.

    Raises
    ------
    ValueError
        If ``f > p`` (the blocks would need coefficients beyond the past window).

    Notes
    -----
    Block ``(i, b)`` (row block ``i < f``, column block ``b < p``) is

    .. math::

        (\Gamma_f L_p)_{ib} \approx \begin{cases} \Xi_{p - b + i} & b \ge i \\
        0 & b < i \end{cases},
        \qquad \Xi_j = C \tilde A^{j-1} \tilde B .

    References
    ----------
    .. [1] A. Chiuso, "The role of vector autoregressive modeling in predictor-based
       subspace identification", *Automatica* 43(6), 1034-1048, 2007, eq. (21).
    .. [2] J.-W. van Wingerden and M. Verhaegen, "Subspace identification of bilinear and
       LPV systems for open- and closed-loop data", *Automatica* 45(2), 372-381, 2009.

    Examples
    --------
    >>> coef = np.arange(6.0).reshape(1, 6)  # l = 1, m = 1, p = 3: [Xi_3, Xi_2, Xi_1]
    >>> gamma_l(coef, p=3, f=2, m=1, l=1)
    array([[0., 1., 2., 3., 4., 5.],
           [0., 0., 0., 1., 2., 3.]])
    """
    if f > p:
        raise ValueError(f"the future window f must satisfy f <= p, got f={f} > p={p}")
    d = m + l
    LK = np.zeros((f * l, p * d))
    for i in range(f):
        LK[i * l : (i + 1) * l, i * d :] = coef[:, : (p - i) * d]
    return LK


def thin_svd(M: Array) -> tuple[Array, Array, Array]:
    """Thin SVD ``M = U diag(s) Vt`` (as ``numpy.linalg.svd(M, full_matrices=False)``).

    A wide ``M`` (more than twice as many columns as rows, e.g. ``Gamma L Zp`` with one
    column per sample) is factored by the R-SVD: ``M^T = Q R`` (Householder QR), ``R^T = U
    diag(s) W^T``, so ``M = U diag(s) (Q W)^T``.  It is the same backward-stable
    factorisation, but the long dimension only meets one QR and one product instead of the
    bidiagonalisation, which is why it is faster on wide shapes.  Singular vectors are
    defined up to a common sign per pair.

    Parameters
    ----------
    M : ndarray, shape (r, c)
        The matrix to factor.

    Returns
    -------
    U : ndarray, shape (r, k)
        Left singular vectors, ``k = min(r, c)``.
    s : ndarray, shape (k,)
        Singular values, descending.
    Vt : ndarray, shape (k, c)
        Right singular vectors (rows).

    References
    ----------
    .. [1] G. H. Golub and C. F. Van Loan, *Matrix Computations*, 4th ed., Johns Hopkins
       University Press, 2013, sec. 8.6.3 (the R-SVD).

    Examples
    --------
    >>> M = np.arange(24.0).reshape(2, 12)
    >>> U, s, Vt = thin_svd(M)
    >>> bool(np.allclose(U * s @ Vt, M)), Vt.shape
    (True, (2, 12))
    """
    r, c = M.shape
    if c <= 2 * r:
        return np.linalg.svd(M, full_matrices=False)
    Q, R = qr(M.T, mode="economic", check_finite=False)
    U, s, Wt = np.linalg.svd(R.T)
    return U, s, Wt @ Q.T


def state_sequence(LK: Array, Zp: Array, order: int | None) -> tuple[Array, Array, Array]:
    r"""State sequence from the SVD of ``Gamma L Zp`` (the toolbox's ``dmodx``).

    ``Gamma_f L_p Z_p = U S V^T`` (:func:`thin_svd`) and the state is ``X = S_n^{1/2}
    V_n^T``: ``L_p Z_p`` is the state of the predictor up to the truncation ``At^p``, and
    any factorisation of ``Gamma L Zp`` into a rank-``n`` product gives it up to a
    similarity transform, which the balanced split fixes.

    Parameters
    ----------
    LK : ndarray, shape (f l, p (m + l))
        ``Gamma_f L_p`` (:func:`gamma_l`).
    Zp : ndarray, shape (p (m + l), N)
        The stacked past (:func:`hdpbsid.core.varx.past_blocks`) on the columns used.
    order : int or None
        Rows of ``X`` kept; ``None`` keeps all ``len(s)`` rows, to be cut by the caller.

    Returns
    -------
    X : ndarray, shape (n, N)
        The state sequence, ``n = order`` (or ``len(s)``).
    s : ndarray, shape (min(f l, N),)
        All singular values of ``Gamma L Zp``, descending.
    U : ndarray, shape (f l, min(f l, N))
        The left singular vectors (``U_n S_n^{1/2}`` estimates ``Gamma_f``).

    Notes
    -----
    .. math:: \Gamma_f L_p Z_p = U S V^\top, \qquad X = S_n^{1/2} V_n^\top .

    References
    ----------
    .. [1] A. Chiuso, "The role of vector autoregressive modeling in predictor-based
       subspace identification", *Automatica* 43(6), 1034-1048, 2007, sec. 4.
    """
    U, s, Vt = thin_svd(LK @ Zp)
    n = s.size if order is None else order
    X = np.sqrt(s[:n])[:, None] * Vt[:n, :]
    return X, s, U


def select_order(s: Array, max_order: int | None = None) -> tuple[int, dict]:
    """Choose the model order from the singular values of ``Gamma L Zp``.

    The order is the largest gap on a log scale, ``n = argmax_i log(s_i / s_{i+1})`` over
    ``1 <= i <= min(max_order, len(s) - 1)``: the ``n`` singular values of the state
    stand above those of the noise and of the truncation, and a ratio (not a difference)
    is invariant to the scaling of the data.  Singular values below ``s_1 len(s) eps``
    (rounding level of the SVD, Golub & Van Loan sec. 8.6) are floored there, so the zeros
    of a noise-free record form one flat tail and its true order is picked.

    Parameters
    ----------
    s : array_like, shape (k,)
        Singular values, descending.
    max_order : int, optional
        Largest order considered (default ``len(s) - 1``).

    Returns
    -------
    n : int
        The order chosen, ``1 <= n <= min(max_order, len(s) - 1)``.
    info : dict
        ``criterion`` (its name) and ``log_gaps`` (the gaps compared).

    Raises
    ------
    ValueError
        If ``s`` has fewer than 2 values (no gap to compare; increase ``p`` and ``f``).

    References
    ----------
    .. [1] G. H. Golub and C. F. Van Loan, *Matrix Computations*, 4th ed., 2013, sec. 5.4.1
       (numerical rank).

    Examples
    --------
    >>> select_order(np.array([10.0, 5.0, 1e-3, 5e-4]))[0]
    2
    """
    s = np.asarray(s, dtype=float)
    if s.size < 2:
        raise ValueError(
            "order selection needs at least 2 singular values; increase the windows p and f"
        )
    kmax = s.size - 1 if max_order is None else min(max_order, s.size - 1)
    floor = max(s[0], np.finfo(float).tiny) * s.size * np.finfo(float).eps
    ls = np.log(np.maximum(s, floor))
    gaps = ls[:kmax] - ls[1 : kmax + 1]
    n = int(np.argmax(gaps)) + 1
    return n, {"criterion": "largest log gap of singular values", "log_gaps": gaps}


def resolve_order(
    s: Array, order: int | None, max_order: int | None, rank: int | None = None
) -> tuple[int, dict]:
    """The model order: ``order`` as given, or :func:`select_order` on the singular values.

    Parameters
    ----------
    s : ndarray, shape (k,)
        Singular values of ``Gamma L Zp``, descending.
    order : int or None
        The order asked for; ``None`` selects it from ``s``.
    max_order : int or None
        Largest order the selection considers (:func:`select_order`).
    rank : int, optional
        Number of state rows available (default ``s.size``).

    Returns
    -------
    n : int
        The order.
    info : dict
        The selection's record (:func:`select_order`); empty for a given order.

    Raises
    ------
    ValueError
        If the order exceeds ``rank`` (more states than singular values), or from
        :func:`select_order`.
    """
    rank = s.size if rank is None else rank
    n, info = select_order(s, max_order) if order is None else (order, {})
    if n > rank:
        raise ValueError(
            f"order={n} exceeds the rank available ({rank} singular values); "
            f"increase f or supply more data"
        )
    return n, info


def estimate_cd(X: Array, U: Array, Y: Array, feedthrough: bool) -> tuple[Array, Array, Array]:
    """Least squares ``Y = C X + D U + E`` (the toolbox's ``dx2abcdk``, first step).

    With the state known, the output equation is linear in ``(C, D)``; its residual
    estimates the innovation, which the state equation needs next (:func:`estimate_abk`).

    Parameters
    ----------
    X : ndarray, shape (n, N)
        State sequence on the columns used.
    U : ndarray, shape (m, N)
        Inputs on the same columns.
    Y : ndarray, shape (l, N)
        Outputs on the same columns.
    feedthrough : bool
        Estimate ``D``; when False ``D = 0`` and ``U`` is not a regressor.

    Returns
    -------
    C : ndarray, shape (l, n)
        Output matrix.
    D : ndarray, shape (l, m)
        Feedthrough (zeros without ``feedthrough``).
    E : ndarray, shape (l, N)
        The residual, the innovation estimate.
    """
    m = U.shape[0]
    reg = np.vstack([X, U]) if (feedthrough and m > 0) else X
    theta = np.linalg.lstsq(reg.T, Y.T, rcond=None)[0].T
    n = X.shape[0]
    C = theta[:, :n]
    D = theta[:, n:] if (feedthrough and m > 0) else np.zeros((Y.shape[0], m))
    E = Y - theta @ reg
    return C, D, E


def _lag_on_columns(
    W: Array, valid: NDArray[np.bool_], lag: LagOperator
) -> tuple[Array, NDArray[np.bool_]]:
    """Lag a matrix known only on ``valid`` columns (zero-filled elsewhere) once."""
    Wf = np.where(valid[None, :], W, 0.0)
    return lag.apply(Wf, 1), lag.valid_columns(valid, 1)


def estimate_abk(
    X: Array,
    U: Array,
    E: Array,
    columns: NDArray[np.intp],
    ncols: int,
    lag: LagOperator,
) -> tuple[Array, Array, Array, Array, Array]:
    """Least squares ``X = A lag(X) + B lag(U) + K lag(E)`` (``dx2abcdk``, second step).

    For sampled data ``lag`` is one sample back, i.e. ``x_{k+1} = A x_k + B u_k + K e_k``;
    in a basis domain with ``lag = M`` it is ``X = A X M + B U M + K E M``.  The columns
    used are those where the state, the innovations and their lags are all known.

    Parameters
    ----------
    X : ndarray, shape (n, len(columns))
        State sequence on ``columns``.
    U : ndarray, shape (m, ncols)
        Inputs on all columns of the record.
    E : ndarray, shape (l, len(columns))
        Innovations on ``columns`` (:func:`estimate_cd`).
    columns : ndarray of int
        Indices of the record's columns where ``X`` and ``E`` are known.
    ncols : int
        Number of columns of the record.
    lag : LagOperator
        The "one step back" operator (:class:`~hdpbsid.core.varx.LagOperator`).

    Returns
    -------
    A : ndarray, shape (n, n)
        State matrix.
    B : ndarray, shape (n, m)
        Input matrix.
    K : ndarray, shape (n, l)
        Least-squares predictor gain.
    W : ndarray, shape (n, N_used)
        Process residual ``X - A lag(X) - B lag(U)`` on the columns used.
    V : ndarray, shape (l, N_used)
        ``lag(E)`` on the same columns (with ``W`` for :func:`riccati_gain`).

    Raises
    ------
    ValueError
        If the usable columns are not more than the ``n + m + l`` regressors per state.
    """
    n, m, l = X.shape[0], U.shape[0], E.shape[0]
    known = np.zeros(ncols, dtype=bool)
    known[columns] = True
    Xf = np.zeros((n, ncols))
    Xf[:, columns] = X
    Ef = np.zeros((l, ncols))
    Ef[:, columns] = E
    LX, vx = _lag_on_columns(Xf, known, lag)
    LE, ve = _lag_on_columns(Ef, known, lag)
    LU, vu = _lag_on_columns(U, np.ones(ncols, dtype=bool), lag)
    use = np.flatnonzero(known & vx & ve & vu)
    if use.size <= n + m + l:
        raise ValueError(
            f"too few usable columns ({use.size}) to estimate A, B, K with "
            f"{n + m + l} regressors per state; supply more data or reduce p/order"
        )
    reg = np.vstack([LX[:, use], LU[:, use], LE[:, use]])
    target = Xf[:, use]
    theta = np.linalg.lstsq(reg.T, target.T, rcond=None)[0].T
    A, B, K = theta[:, :n], theta[:, n : n + m], theta[:, n + m :]
    W = target - A @ LX[:, use] - B @ LU[:, use]
    V = LE[:, use]
    return A, B, K, W, V


def riccati_gain(A: Array, C: Array, W: Array, V: Array) -> Array:
    r"""Kalman predictor gain from the residual covariances (the toolbox's ``dx2abcdk``
    'stable' option).

    The least-squares ``K`` need not make ``A - K C`` stable; the gain of the steady-state
    Kalman predictor of the model with noise covariances estimated from the residuals does,
    when the filter Riccati equation has a stabilising solution (detectable ``(A, C)``,
    positive definite ``R``).

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix.
    C : ndarray, shape (l, n)
        Output matrix.
    W : ndarray, shape (n, N)
        Process residual ``x_+ - A x - B u``.
    V : ndarray, shape (l, N)
        Innovation, aligned with ``W``.

    Returns
    -------
    ndarray, shape (n, l)
        ``K = (A P C^T + S)(C P C^T + R)^{-1}``.

    Notes
    -----
    With ``Q = cov(w)``, ``R = cov(v)``, ``S = cov(w, v)`` the filter DARE

    .. math::

        P = A P A^\top + Q - (A P C^\top + S)(C P C^\top + R)^{-1}(A P C^\top + S)^\top

    is solved by ``scipy.linalg.solve_discrete_are(A.T, C.T, Q, R, s=S)``.

    References
    ----------
    .. [1] B. D. O. Anderson and J. B. Moore, *Optimal Filtering*, Prentice-Hall, 1979,
       ch. 4 and 5.
    """
    N = W.shape[1]
    Q = W @ W.T / N
    R = V @ V.T / N
    S = W @ V.T / N
    P = solve_discrete_are(A.T, C.T, Q, R, s=S)
    return np.linalg.solve(C @ P @ C.T + R, (A @ P @ C.T + S).T).T


def stable_gain(A: Array, C: Array, W: Array, V: Array, K: Array) -> tuple[Array, str]:
    """The Riccati gain in place of the least-squares ``K`` (``stable_k``).

    Falls back to ``K`` unchanged, with a ``RuntimeWarning``, when the Riccati equation has
    no stabilising solution, so that a run never fails for the sake of the gain.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix.
    C : ndarray, shape (l, n)
        Output matrix.
    W : ndarray, shape (n, N)
        Process residual (:func:`estimate_abk`).
    V : ndarray, shape (l, N)
        Lagged innovation (:func:`estimate_abk`).
    K : ndarray, shape (n, l)
        The least-squares gain, kept on failure.

    Returns
    -------
    K : ndarray, shape (n, l)
        The gain.
    how : str
        ``"riccati"`` or ``"least squares"``.
    """
    try:
        return riccati_gain(A, C, W, V), "riccati"
    except (np.linalg.LinAlgError, ValueError) as exc:
        warnings.warn(
            f"stable_k: the Riccati equation has no stabilising solution ({exc}); "
            f"keeping the least-squares K",
            RuntimeWarning,
            stacklevel=user_stacklevel(),
        )
        return K, "least squares"


def core_options(
    p: int,
    f: int,
    n: int,
    order: int | None,
    feedthrough: bool,
    vx: VarxResult,
    ridge_floor: float,
    stable_k: bool,
    k_method: str,
    lag: LagOperator,
    info: dict,
    max_order: int | None,
) -> dict:
    """The settings a core run reports in ``options`` (windows, order and how it was
    chosen, VARX regularisation, how ``K`` was obtained, the lag operator)."""
    options = {
        "p": p,
        "f": f,
        "order": n,
        "order_selected": order is None,
        "feedthrough": feedthrough,
        "regularize": vx.regularize,
        "ridge": vx.ridge,
        "ridge_floor": ridge_floor,
        "stable_k": stable_k,
        "k_method": k_method,
        "lag": repr(lag),
        "lag_strictly_causal": is_strictly_causal(lag),
    }
    if info:
        options["order_criterion"] = info["criterion"]
        options["max_order"] = max_order
    return options


@dataclass
class CoreResult:
    """Model in the index domain (sampled or basis) and everything the core computed.

    Attributes
    ----------
    A, B, C, D, K : ndarray
        The innovation model ``x_+ = A x + B u + K e``, ``y = C x + D u + e`` in the lag
        operator's domain, shapes ``(n, n)``, ``(n, m)``, ``(l, n)``, ``(l, m)``, ``(n, l)``.
    order : int
        The model order ``n``.
    singular_values : ndarray
        All singular values of ``Gamma L Zp``, descending.
    states : ndarray, shape (n, N)
        The state sequence on ``columns``.
    innovations : ndarray, shape (l, N)
        The innovation estimate on ``columns``.
    columns : ndarray of int
        The record's columns on which the VARX is defined.
    varx : VarxResult
        The VARX fit (step 1).
    noise_covariance : ndarray, shape (l, l)
        Sample covariance of ``innovations``.
    options : dict
        The settings of the run (windows, order and how chosen, regularisation, gain).
    """

    A: Array
    B: Array
    C: Array
    D: Array
    K: Array
    order: int
    singular_values: Array
    states: Array
    innovations: Array
    columns: NDArray[np.intp]
    varx: VarxResult
    noise_covariance: Array
    options: dict = field(default_factory=dict)

    @property
    def eigenvalues(self) -> NDArray[np.complex128]:
        """Eigenvalues of ``A``."""
        return np.linalg.eigvals(self.A)


#: the state rows ``S_n^{-1/2} U_n^T M`` of :class:`SubspaceStage` are computed from the
#: left singular vectors while ``s_n >= STATE_ROWS_RTOL s_1``: the rounding of ``U_n^T M``
#: (about ``eps s_1`` in each entry) is then at most ``sqrt(eps)`` relative to row ``n``
STATE_ROWS_RTOL = float(np.sqrt(np.finfo(float).eps))


@dataclass
class SubspaceStage:
    """Steps 1-2 of :func:`pbsid_core`, which do not depend on the order.

    The VARX fit, the SVD ``M = Gamma_f L_p Z_p = U S V^T`` and the state rows ``S^{1/2}
    V^T`` (:meth:`state_rows`).  An order only truncates them, so the orders of an order
    selection can share one stage (``pbsid_core(..., stage=)``).

    When the VARX kept the triangular factor of its regressors (``Z_p^T = Q R``,
    :attr:`~hdpbsid.core.varx.VarxResult.zp_factor`), ``M = (Gamma L R^T) Q^T`` with ``Q``
    orthonormal, so ``U`` and ``S`` are those of the small ``Gamma L R^T`` (``f l x
    p (m + l)``): the long dimension of ``M`` (one column per sample) never meets a
    factorisation.  The first ``n`` state rows are then ``S_n^{1/2} V_n^T = S_n^{-1/2}
    U_n^T M``, one product of ``n`` rows, while ``s_n`` is not below
    :data:`STATE_ROWS_RTOL` times ``s_1``; rows past that, and a stage without the factor,
    come from the thin SVD of ``M`` itself (:func:`state_sequence`).

    Attributes
    ----------
    varx : VarxResult
        The VARX fit.
    singular_values : ndarray, shape (k,)
        ``S``, descending.
    left : ndarray, shape (f l, k)
        ``U`` (its first block row times ``S^{1/2}`` is ``C``).
    gamma_l : ndarray, shape (f l, p (m + l))
        ``Gamma_f L_p``, the VARX's estimate of the product the SVD factors.
    states : ndarray, shape (k, N)
        Every state row ``S^{1/2} V^T`` (from the thin SVD of ``M``, computed on first use).
    """

    varx: VarxResult
    singular_values: Array
    left: Array
    gamma_l: Array
    _states: Array | None = None

    @property
    def states(self) -> Array:
        """Every state row ``S^{1/2} V^T`` (from the thin SVD of ``M``, computed once)."""
        if self._states is None:
            self._states = state_sequence(self.gamma_l, self.varx.Zp, None)[0]
        return self._states

    def state_rows(self, n: int) -> Array:
        """The first ``n`` state rows ``S_n^{1/2} V_n^T`` (class docstring).

        Parameters
        ----------
        n : int
            The order: how many rows.

        Returns
        -------
        ndarray, shape (n, N)
            ``S_n^{1/2} V_n^T``: from ``S_n^{-1/2} U_n^T M`` while ``s_n >=``
            :data:`STATE_ROWS_RTOL` ``s_1`` and the VARX kept its factor, else from the thin
            SVD of ``M``.
        """
        s = self.singular_values
        if (
            self._states is not None
            or not 0 < n <= s.size
            or not s[n - 1] >= STATE_ROWS_RTOL * s[0]
        ):
            return self.states[:n]
        M_n = (self.left[:, :n].T @ self.gamma_l) @ self.varx.Zp
        return M_n / np.sqrt(s[:n])[:, None]


def subspace_stage(
    U: Array,
    Y: Array,
    p: int,
    f: int,
    lag: LagOperator,
    feedthrough: bool,
    regularize: bool | str | float | None,
    ridge_floor: float = 0.0,
    instruments: Array | None = None,
    exogenous: tuple[int, ...] = (),
) -> SubspaceStage:
    """The order-independent steps 1-2 of :func:`pbsid_core` (:class:`SubspaceStage`).

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Inputs (rows = signals, columns = index).
    Y : ndarray, shape (l, N)
        Outputs.
    p : int
        Past window.
    f : int
        Future window, ``f <= p``.
    lag : LagOperator
        The "one step back" operator.
    feedthrough : bool
        Include ``D u_k`` in the VARX.
    regularize : bool, str, float or None
        VARX regularisation (:func:`hdpbsid.core.varx.varx`).
    ridge_floor : float, optional
        Lower bound of the GCV ridge, relative to the largest singular value.
    instruments : ndarray, shape (k, N), optional
        Instrument rows (IV VARX).
    exogenous : tuple of int, optional
        Rows of ``[U; Y]`` that are their own instruments.

    Returns
    -------
    SubspaceStage
        The VARX, singular values, left singular vectors and all state rows.
    """
    vx = varx(
        U,
        Y,
        p,
        lag=lag,
        feedthrough=feedthrough,
        regularize=regularize,
        ridge_floor=ridge_floor,
        instruments=instruments,
        exogenous=exogenous,
    )
    LK = gamma_l(vx.coef, p, f, U.shape[0], Y.shape[0])
    if vx.zp_factor is None:
        Xall, s, Ug = state_sequence(LK, vx.Zp, None)
        return SubspaceStage(vx, s, Ug, LK, Xall)
    Ug, s, _ = np.linalg.svd(LK @ vx.zp_factor.T, full_matrices=False)
    return SubspaceStage(vx, s, Ug, LK)


@library_call
def _output_equation(
    stage: SubspaceStage, X: Array, U: Array, Y: Array, n: int, feedthrough: bool, iv: bool
) -> tuple[Array, Array, Array]:
    """``C``, ``D`` and the innovations ``E = Y - C X - D U`` on the stage's columns: by
    least squares on the states (:func:`estimate_cd`), or with instruments (``iv``) from
    the first block row of ``Gamma`` and the VARX's ``D``, both estimated consistently by
    the two-stage least squares (:mod:`hdpbsid.methods.hermite_iv`)."""
    vx, s, cols = stage.varx, stage.singular_values, stage.varx.columns
    if not iv:
        return estimate_cd(X, U[:, cols], Y[:, cols], feedthrough)
    l = Y.shape[0]
    C = stage.left[:l, :n] * np.sqrt(s[:n])[None, :]
    D = vx.D
    return C, D, Y[:, cols] - C @ X - D @ U[:, cols]


def pbsid_core(
    U: Array,
    Y: Array,
    p: int,
    f: int | None = None,
    order: int | None = None,
    lag: LagOperator | None = None,
    feedthrough: bool = False,
    regularize: bool | str | float | None = False,
    ridge_floor: float = 0.0,
    stable_k: bool = False,
    max_order: int | None = None,
    instruments: Array | None = None,
    exogenous: tuple[int, ...] = (),
    stage: SubspaceStage | None = None,
) -> CoreResult:
    r"""Identify ``(A, B, C, D, K)`` of the innovation model in the lag-operator domain.

    Predictor-based subspace identification (PBSID): the innovation form is rewritten as
    its predictor ``x_+ = At x + Bt z``, whose Markov parameters are the coefficients of a
    VARX model; the VARX is linear least squares, and the state follows from an SVD of the
    predicted future.  Because the predictor, not the system, is estimated, the method is
    consistent in closed loop when the VARX is (Chiuso 2007).  Everything is generic over
    the lag operator, so the same code identifies a sampled model (``SampleShift``) or a
    model in a basis index (``MatrixLag``).

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Inputs (rows = signals, columns = samples or basis index).
    Y : ndarray, shape (l, N)
        Outputs on the same columns.
    p : int
        Past window (VARX lags).
    f : int, optional
        Future window, ``f <= p`` (default ``p``).
    order : int, optional
        Model order; ``None`` chooses it from the singular values (:func:`select_order`).
    lag : LagOperator, optional
        The "one step back" operator (default :class:`~hdpbsid.core.varx.SampleShift`).
    feedthrough : bool, optional
        Estimate ``D`` (leave False in closed loop when the controller has direct
        feedthrough: then ``u_k`` is correlated with ``e_k``).
    regularize : bool, str, float or None, optional
        VARX regularisation: False/None plain least squares, True/``"gcv"`` ridge by
        generalised cross-validation, a float the ridge parameter.
    ridge_floor : float, optional
        Lower bound of the GCV ridge, relative to the largest singular value of the
        regressors (data known to a relative precision only).
    stable_k : bool, optional
        Replace the least-squares gain by the Kalman gain (:func:`riccati_gain`).
    max_order : int, optional
        Largest order the selection considers.
    instruments : ndarray, shape (k, N), optional
        Instrument rows: the VARX by instrumental variables (see Notes).
    exogenous : tuple of int, optional
        Rows of ``[U; Y]`` that are their own instruments (e.g. pseudo-inputs).
    stage : SubspaceStage, optional
        Steps 1-2 computed before by :func:`subspace_stage` with the same arguments (the
        caller's responsibility), e.g. shared by the orders of a selection.

    Returns
    -------
    CoreResult
        The model, the singular values, states, innovations, the VARX and the options.

    Raises
    ------
    ValueError
        If ``f > p``, if ``order > f l`` (more states than rows of ``Gamma L``), or from
        the steps (too few columns for the VARX or for ``A, B, K``).

    Notes
    -----
    With ``z = [u; y]``, ``At = A - K C`` and ``Bt = [B - K D, K]``:

    1. VARX :math:`y_k = \sum_{j=1}^{p} \Xi_j z_{k-j} + D u_k + e_k`,
       :math:`\Xi_j = C \tilde A^{j-1} \tilde B` (:func:`hdpbsid.core.varx.varx`);
    2. ``Gamma L`` (:func:`gamma_l`), the SVD of ``Gamma L Zp``, the order, and
       :math:`X = S_n^{1/2} V_n^\top` (:func:`state_sequence`);
    3. ``C, D`` and the innovations ``E`` (:func:`estimate_cd`), then ``A, B, K``
       (:func:`estimate_abk`); with ``stable_k`` the Riccati gain.

    With ``instruments`` the estimator stays consistent when the regressors are correlated
    with the innovations: the VARX is solved by instrumental variables; ``C`` is read from
    the extended observability matrix, :math:`\Gamma_f = U_n S_n^{1/2}`, whose first block
    row is ``C`` (Verhaegen & Verdult 2007, sec. 9.2.4) -- the regression ``Y = C X + E``
    would be biased again, since ``X`` is built from the same noisy past; ``D`` is the
    VARX's; ``A, B, K`` solve ``X = A lag(X) + B lag(U) + K lag(E)`` with ``E = Y - C X``,
    which is the predictor recursion ``X = At lag(X) + Bt lag(Z)`` that ``X = L Zp``
    satisfies without a noise term, so least squares is consistent there.

    References
    ----------
    .. [1] A. Chiuso, "The role of vector autoregressive modeling in predictor-based
       subspace identification", *Automatica* 43(6), 1034-1048, 2007.
    .. [2] J.-W. van Wingerden and M. Verhaegen, "Subspace identification of bilinear and
       LPV systems for open- and closed-loop data", *Automatica* 45(2), 372-381, 2009.
    .. [3] M. Verhaegen and V. Verdult, *Filtering and System Identification*, Cambridge
       University Press, 2007, sec. 9.2.4.

    Examples
    --------
    A noise-free second-order discrete system, identified from 400 samples:

    >>> rng = np.random.default_rng(0)
    >>> A = np.array([[0.9, 0.2], [0.0, 0.7]])
    >>> B, C = np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]])
    >>> u, y, x = rng.standard_normal((1, 400)), np.zeros((1, 400)), np.zeros(2)
    >>> for k in range(400):
    ...     y[:, k] = C @ x
    ...     x = A @ x + B @ u[:, k]
    >>> res = pbsid_core(u, y, p=6)
    >>> res.order, np.sort(res.eigenvalues.real).round(6)
    (2, array([0.7, 0.9]))
    """
    lag = SampleShift() if lag is None else lag
    l = Y.shape[0]
    f = p if f is None else f
    if f > p:
        raise ValueError(f"the future window f must satisfy f <= p, got f={f} > p={p}")
    if order is not None and order > f * l:
        raise ValueError(
            f"order={order} exceeds f*l = {f}*{l} = {f * l}, the number of rows of Gamma L; "
            f"increase f (and p) or reduce the order"
        )
    if stage is None:
        stage = subspace_stage(
            U, Y, p, f, lag, feedthrough, regularize, ridge_floor, instruments, exogenous
        )
    vx, s = stage.varx, stage.singular_values
    n, info = resolve_order(s, order, max_order, s.size)
    X = stage.state_rows(n)
    cols = vx.columns
    C, D, E = _output_equation(stage, X, U, Y, n, feedthrough, iv=instruments is not None)
    A, B, K, W, V = estimate_abk(X, U, E, cols, Y.shape[1], lag)
    K, k_method = stable_gain(A, C, W, V, K) if stable_k else (K, "least squares")
    noise_cov = E @ E.T / E.shape[1]
    options = core_options(
        p, f, n, order, feedthrough, vx, ridge_floor, stable_k, k_method, lag, info, max_order
    )
    options["estimator"] = "iv" if instruments is not None else "ls"
    if instruments is not None:
        options["instruments"] = vx.extra.get("instruments")
        options["c_method"] = "first block row of Gamma"
    return CoreResult(
        A=A,
        B=B,
        C=C,
        D=D,
        K=K,
        order=n,
        singular_values=s,
        states=X,
        innovations=E,
        columns=cols,
        varx=vx,
        noise_covariance=noise_cov,
        options=options,
    )
