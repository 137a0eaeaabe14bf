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

from hdpbsid.core.varx import LagOperator, SampleShift, VarxResult, varx
from hdpbsid.runtime import library_call

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
    """Build ``Gamma_f L_p`` (``f l x p (m + l)``) from the VARX coefficients.

    ``coef = [Xi_p, ..., Xi_1]``.  Row block ``i`` (``0 <= i < f``) is
    ``C At^i [At^{p-1} Bt, ..., Bt] ~= [0 (i blocks), Xi_p, ..., Xi_{i+1}]``: the terms
    ``Xi_j`` with ``j > p`` are negligible (``At^p ~= 0``) and set to zero, so no future
    data are needed (Chiuso 2007, eq. (21); toolbox ``dordvarx`` with ``weight=0``).
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
    column per sample) by R-SVD: ``M^T = Q R`` (Householder QR), ``R^T = U diag(s) W^T``,
    so ``M = U diag(s) (Q W)^T`` (Golub & Van Loan, *Matrix Computations*, 4th ed., sec.
    8.6.3): the same backward-stable factorisation, whose long dimension only meets one
    QR and one product (``numpy.linalg.svd`` of a ``120 x 7880`` matrix was measured 3.5x
    slower than this, and never faster on wide shapes).  Singular vectors are defined up
    to a common sign per pair.

    Parameters
    ----------
    M : ndarray, shape (r, c)

    Returns
    -------
    U : ndarray, shape (r, k)
    s : ndarray, shape (k,)
        Descending, ``k = min(r, c)``.
    Vt : ndarray, shape (k, c)

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
    """SVD ``Gamma L Zp = U S V^T`` (:func:`thin_svd`); state ``X = S_n^{1/2} V_n^T``
    (toolbox ``dmodx``).

    Returns ``(X, s, U)`` with all singular values ``s``; ``X`` has ``order`` rows (all
    ``len(s)`` rows when ``order`` is None, to be cut by the caller).
    """
    U, s, Vt = thin_svd(LK @ Zp)
    n = s.size if order is None else order
    X = np.sqrt(s[:n])[:, None] * Vt[:n, :]
    return X, s, U


def select_order(s: Array, max_order: int | None = None) -> tuple[int, dict]:
    """Choose the model order from the singular values of ``Gamma L Zp``.

    Criterion: the largest gap on a log scale, ``n = argmax_i log(s_i / s_{i+1})`` over
    ``1 <= i <= min(max_order, len(s) - 1)``.  Singular values below
    ``s_1 * len(s) * eps`` are treated as exact zeros (floored there), so a noise-free
    record picks its true order.  Returns ``(n, info)``; ``info`` records the criterion
    and the gaps.
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
    """The order: ``order`` as given, or :func:`select_order` on the singular values
    ``s``; ``ValueError`` when it exceeds the ``rank`` available (default ``s.size``).
    Returns ``(n, info)`` (``info`` empty for a given order)."""
    rank = s.size if rank is None else rank
    n, info = select_order(s, max_order) if order is None else (order, {})
    if n > rank:
        raise ValueError(
            f"order={n} exceeds the rank available ({rank} singular values); "
            f"increase f or supply more data"
        )
    return n, info


def estimate_cd(X: Array, U: Array, Y: Array, feedthrough: bool) -> tuple[Array, Array, Array]:
    """Least squares ``Y = C X + D U + E`` (toolbox ``dx2abcdk``, first step).

    ``X, U, Y`` are restricted to the same columns.  Returns ``(C, D, E)``; ``E`` is the
    innovation estimate (the residual).  ``D = 0`` when ``feedthrough`` is False.
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
    in a basis domain with ``lag = M`` it is ``X = A X M + B U M + K E M``.  ``X, E`` live
    on ``columns`` of an ``ncols``-column record, ``U`` on all columns.  Returns
    ``(A, B, K, W, V)`` where ``W = X - A lag(X) - B lag(U)`` and ``V = lag(E)`` on the
    columns used (for :func:`riccati_gain`).
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
    """Kalman predictor gain from residual covariances (toolbox ``dx2abcdk`` 'stable').

    With the process residual ``w = x_+ - A x - B u`` and the innovation ``v`` (aligned),
    ``Q = cov(w)``, ``R = cov(v)``, ``S = cov(w, v)``; solve the filter DARE

        P = A P A^T + Q - (A P C^T + S)(C P C^T + R)^{-1}(A P C^T + S)^T

    (``scipy.linalg.solve_discrete_are(A^T, C^T, Q, R, s=S)``) and return
    ``K = (A P C^T + S)(C P C^T + R)^{-1}``, which makes ``A - K C`` stable.
    """
    N = W.shape[1]
    Q = W @ W.T / N
    R = V @ V.T / N
    S = W @ V.T / N
    P = solve_discrete_are(A.T, C.T, Q, R, s=S)
    return np.linalg.solve(C @ P @ C.T + R, (A @ P @ C.T + S).T).T


def stable_gain(A: Array, C: Array, W: Array, V: Array, K: Array) -> tuple[Array, str]:
    """``stable_k``: the Riccati gain (:func:`riccati_gain`) in place of the least-squares
    ``K``, or ``K`` unchanged with a ``RuntimeWarning`` when no stabilising solution
    exists.  Returns ``(K, how)``."""
    try:
        return riccati_gain(A, C, W, V), "riccati"
    except (np.linalg.LinAlgError, ValueError) as exc:
        warnings.warn(
            f"stable_k: the Riccati equation has no stabilising solution ({exc}); "
            f"keeping the least-squares K",
            RuntimeWarning,
            stacklevel=3,
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
    }
    if info:
        options["order_criterion"] = info["criterion"]
        options["max_order"] = max_order
    return options


@dataclass
class CoreResult:
    """Model in the index domain (sampled or basis) and everything the core computed."""

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
    """Steps 1-2 of :func:`pbsid_core`, which do not depend on the order: the VARX fit
    ``varx``, the SVD ``M = Gamma_f L_p Z_p = U S V^T`` (``left = U``,
    ``singular_values = S``) and the state rows ``S^{1/2} V^T`` (:meth:`state_rows`).  An
    order only truncates them, so the orders of an order selection can share one stage
    (``pbsid_core(..., stage=)``).

    When the VARX kept the triangular factor of its regressors (``Z_p^T = Q R``,
    :attr:`~hdpbsid.core.varx.VarxResult.zp_factor`), ``M = (Gamma L R^T) Q^T`` with ``Q``
    orthonormal, so ``U`` and ``S`` are those of the small ``Gamma L R^T`` (``f l x
    p (m + l)``): the long dimension of ``M`` (one column per sample) never meets a
    factorisation.  The first ``n`` state rows are then ``S_n^{1/2} V_n^T = S_n^{-1/2}
    U_n^T M``, one product of ``n`` rows, while ``s_n`` is not below
    :data:`STATE_ROWS_RTOL` times ``s_1``; rows past that, and a stage without the factor,
    come from the thin SVD of ``M`` itself (:func:`state_sequence`), as every row did
    before the factor was kept.
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
        """The first ``n`` state rows ``S_n^{1/2} V_n^T`` (class docstring)."""
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
    """The order-independent steps 1-2 of :func:`pbsid_core` (:class:`SubspaceStage`)."""
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
    """Identify ``(A, B, C, D, K)`` of the innovation model in the lag-operator domain.

    ``U`` (m x N) and ``Y`` (l x N) are data matrices (rows = signals).  Steps:

    1. VARX ``Y = sum_j Xi_j lag^j(Z) + D U + E`` (:func:`hdpbsid.core.varx.varx`);
    2. ``Gamma L`` (:func:`gamma_l`), SVD of ``Gamma L Zp``, order from the singular
       values when ``order`` is None (:func:`select_order`), ``X = S_n^{1/2} V_n^T``;
    3. ``C, D`` and the innovations ``E`` (:func:`estimate_cd`), then ``A, B, K``
       (:func:`estimate_abk`); with ``stable_k`` the gain is replaced by the Riccati
       (Kalman) gain from the residual covariances (:func:`riccati_gain`).

    ``f`` defaults to ``p`` (``f <= p`` is required).  The returned ``noise_covariance``
    is the sample covariance of ``E``.

    ``instruments`` (rows on the columns of ``U, Y``; ``exogenous``: rows of ``[U; Y]``
    that are their own instruments) makes the estimator consistent when the regressors
    are correlated with the innovations (:func:`hdpbsid.core.varx.varx`):

    1. the VARX by instrumental variables;
    2. unchanged;
    3. ``C`` is read from the extended observability matrix instead of regressed:
       ``Gamma L Zp = U S V^T`` with ``X = S_n^{1/2} V_n^T`` means ``Gamma = U_n S_n^{1/2}``,
       whose first block row is ``C`` (Verhaegen & Verdult, *Filtering and System
       Identification*, 2007, sec. 9.2.4).  The regression ``Y = C X + E`` would be
       biased again, since ``X`` is built from the same noisy past as the VARX; ``C``
       from ``Gamma`` inherits the consistency of the IV VARX.  ``A, B, K`` then solve
       ``X = A lag(X) + B lag(U) + K lag(E)`` with ``E = Y - C X``: substituting
       ``lag(Y) = C lag(X) + lag(E)`` this is the predictor recursion
       ``X = At lag(X) + Bt lag(Z)``, which the state ``X = L Zp`` satisfies up to the
       truncation ``At^p`` without any noise term, so least squares is consistent there.
       ``D`` (with ``feedthrough``) is the VARX's.

    ``stage``: steps 1-2 computed before by :func:`subspace_stage` with the same
    arguments (the caller's responsibility), e.g. shared by the orders of a selection.
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
    vx, s, Ug = stage.varx, stage.singular_values, stage.left
    n, info = resolve_order(s, order, max_order, s.size)
    X = stage.state_rows(n)
    cols = vx.columns
    if instruments is None:
        C, D, E = estimate_cd(X, U[:, cols], Y[:, cols], feedthrough)
    else:
        C = Ug[:l, :n] * np.sqrt(s[:n])[None, :]
        D = vx.D
        E = Y[:, cols] - C @ X - D @ U[:, cols]
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
