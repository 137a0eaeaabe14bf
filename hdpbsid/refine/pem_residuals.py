"""The parametrisation of the refinement and its prediction errors with their Jacobian.

Parametrisation (:mod:`hdpbsid.refine.pem`).  ``theta`` packs ``A, B, C, [D], K``
(:class:`_Layout`) of the model for inputs and outputs scaled to unit RMS
(:func:`_scale`, so that the parameters are comparable); the search moves in the local
coordinates ``theta_c + Q beta`` that change the predictor (:func:`_ddlc_basis`).

Prediction errors.  For the parameters ``theta`` and a uniformly sampled record, the
sampled innovation predictor of
:mod:`hdpbsid.refine.pem_predictor`,

    xi_{k+1} = F xi_k + G u_k + Kd y_k,   yhat_k = C xi_k + Du u_k,

gives the one-step errors ``e_k(theta, x0) = y_k - yhat_k``.  They are affine in the
initial state ``x0``: ``e_k = e_k(theta, 0) - C F^k x0``, so ``x0`` is eliminated by least
squares at every evaluation (variable projection; Golub & Pereyra, *Inverse Problems* 19
(2003)), and the residual vector is

    r(theta) = (I - P_F) vec(W E(theta, 0)),   P_F = F_r (F_r^T F_r)^{-1} F_r^T,

with ``W`` the output weighting (an inverse Cholesky factor of the innovation covariance)
and ``F_r`` the stacked weighted free response ``W C F^k``.  Its Jacobian is the exact
derivative of the errors, from the sensitivity recursions of
:mod:`hdpbsid.refine.pem_predictor`, projected by ``I - P_F`` (Kaufman's form of the
variable-projection Jacobian; ``J^T J`` is then the Schur complement of the joint
``(theta, x0)`` information, so ``s^2 (J^T J)^+`` is the covariance of ``theta`` with
``x0`` marginalised).

Two evaluations agree to rounding: the compiled passes of
:mod:`hdpbsid.refine.pem_kernels` (:func:`_residuals_compiled`, used when numba is
installed) and the numpy evaluation in modal coordinates with
:func:`scipy.signal.lfilter` (:func:`_residuals_numpy`, the fallback and the oracle of
the tests).  An unstable predictor (its errors grow without bound) returns the constant
residual :attr:`~hdpbsid.refine.pem_settings.RefinementSettings.unstable_penalty`, far
above any attainable cost, so that Levenberg-Marquardt rejects the step.
"""

from __future__ import annotations

from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.recursion import select_kernels
from hdpbsid.refine.pem_predictor import (
    Predictor,
    conjugate_representatives,
    modal_filter,
    sampled_predictor,
)
from hdpbsid.refine.pem_settings import DEFAULT_SETTINGS, RefinementSettings

__all__: list[str] = []

Array = NDArray[np.float64]

#: the free-response columns (modes) are resolved when ``cond(V) eps < 1``: beyond it the
#: modal coordinates carry no correct digit (Higham, *Accuracy and Stability*, ch. 7)
_MAX_MODAL_COND = 1.0 / np.finfo(float).eps


class _Layout:
    """Where ``A, B, C, D, K`` sit in the parameter vector ``theta`` (row-major blocks
    ``vec A, vec B, vec C, [vec D], vec K``; ``D`` only when it is a parameter), and
    which of them the search moves (``free``: ``"all"``; ``"plant"``, ``K`` held;
    ``"noise"``, only ``K``; :func:`_ddlc_basis`)."""

    def __init__(self, n: int, m: int, l: int, feedthrough: bool, free: str = "all") -> None:
        self.n, self.m, self.l, self.feedthrough, self.free = n, m, l, feedthrough, free
        sizes = [n * n, n * m, l * n, l * m if feedthrough else 0, n * l]
        self.stops = np.cumsum([0, *sizes])

    def pack(self, A: Array, B: Array, C: Array, D: Array, K: Array) -> Array:
        """``theta`` of the matrices (``D`` dropped when it is not a parameter)."""
        parts = [A, B, C, D if self.feedthrough else np.zeros(0), K]
        return np.concatenate([np.ravel(p) for p in parts])

    def unpack(self, theta: Array) -> tuple[Array, Array, Array, Array, Array]:
        """``A, B, C, D, K`` of ``theta`` (views; ``D`` zero when it is not a parameter)."""
        n, m, l = self.n, self.m, self.l
        s = self.stops
        A = theta[s[0] : s[1]].reshape(n, n)
        B = theta[s[1] : s[2]].reshape(n, m)
        C = theta[s[2] : s[3]].reshape(l, n)
        D = theta[s[3] : s[4]].reshape(l, m) if self.feedthrough else np.zeros((l, m))
        K = theta[s[4] : s[5]].reshape(n, l)
        return A, B, C, D, K


class _Record:
    """:func:`_residuals` of one record for one input hold, ``(theta, W, jac=False,
    directions=None)``, remembering the last ``settings.record_memory`` residual vectors, and
    the buffers of the compiled evaluation (:class:`_Workspace`).

    An evaluation is a pure function of its arguments, and the fit asks for the same
    residuals again: every re-centred Levenberg-Marquardt run starts where the previous
    one ended, and the fit evaluates the cost at a run's end point.  Jacobians are not
    asked twice by :func:`scipy.optimize.least_squares`, which keeps its last one, but
    the Gauss-Newton screens of the starting points and of the other input hold ask for
    the Jacobian at the point and in the directions a run then starts from, so the last
    ``settings.jacobian_memory`` are remembered too (one per starting point).  A
    remembered result is returned read-only, so no caller can alter it.
    """

    def __init__(
        self,
        lay: _Layout,
        u: Array,
        y: Array,
        h: float,
        hold: str,
        settings: RefinementSettings = DEFAULT_SETTINGS,
    ) -> None:
        self.lay, self.h, self.hold, self.settings = lay, h, hold, settings
        self.u = np.ascontiguousarray(u, dtype=float)
        self.y = np.ascontiguousarray(y, dtype=float)
        self._memory: dict[tuple[Any, ...], Any] = {}
        self._jacobians: list[tuple[tuple[Any, ...], Any]] = []
        self._workspace = _Workspace()

    def __call__(
        self, theta: Array, W: Array, jac: bool = False, directions: Array | None = None
    ) -> Array | tuple[Array, Array]:
        theta = np.asarray(theta, dtype=float)
        key = (theta.tobytes(), np.asarray(W, dtype=float).tobytes())
        if not jac and key in self._memory:
            return self._memory[key]
        if jac:
            jkey = (*key, None if directions is None else np.asarray(directions).tobytes())
            for k, out in self._jacobians:
                if k == jkey:
                    return out
        out = _residuals(
            theta,
            self.lay,
            self.u,
            self.y,
            self.h,
            self.hold,
            W,
            jac,
            directions,
            workspace=self._workspace,
            penalty=self.settings.unstable_penalty,
        )
        r = out[0] if jac else out
        r.setflags(write=False)
        if key not in self._memory:
            if len(self._memory) >= self.settings.record_memory:
                del self._memory[next(iter(self._memory))]  # the oldest
            self._memory[key] = r
        if jac:
            out[1].setflags(write=False)
            self._jacobians = [
                *self._jacobians[-(self.settings.jacobian_memory - 1) :],
                (jkey, out),
            ]
        return out


def _ddlc_basis(lay: _Layout, theta: Array) -> Array:
    """Orthonormal basis of the directions that change the input-output behaviour.

    A similarity ``x -> (I + T) x`` moves ``(A, B, C, D, K)`` by ``(TA - AT, TB, -CT, 0,
    TK)`` to first order without changing the predictor; the ``n^2`` such directions are
    removed ("data-driven local coordinates", McKelvey, Helmersson & Ribarits, Automatica
    40 (2004); the parametrisation of MATLAB's ``ssest``), leaving
    ``n (m + 2 l) + l m [feedthrough]`` free parameters.

    With ``lay.free == "plant"`` (``K`` held at zero: the output-error fit) the ``K``
    rows of that basis are dropped and the rest orthonormalised again: at ``K = 0`` the
    similarity directions do not move ``K``, so the result spans the plant's directions
    that change its input-output behaviour, ``n (m + l) + l m [feedthrough]`` of them.
    With ``lay.free == "noise"`` the basis is the ``n l`` coordinates of ``K`` (the plant
    held: no similarity direction is left to remove).
    """
    s = lay.stops
    if lay.free == "noise":
        Q = np.zeros((s[-1], s[5] - s[4]))
        Q[s[4] : s[5]] = np.eye(s[5] - s[4])
        return Q
    Q = _full_ddlc_basis(lay, theta)
    if lay.free == "plant":
        Q[s[4] : s[5]] = 0.0
        U, sv, _ = np.linalg.svd(Q, full_matrices=False)
        return U[:, : _rank(sv, Q.shape[0])]
    return Q


def _full_ddlc_basis(lay: _Layout, theta: Array) -> Array:
    """:func:`_ddlc_basis` of every parameter."""
    A, B, C, D, K = lay.unpack(theta)
    n = lay.n
    cols = []
    for i in range(n):
        for j in range(n):
            T = np.zeros((n, n))
            T[i, j] = 1.0
            cols.append(lay.pack(T @ A - A @ T, T @ B, -C @ T, np.zeros_like(D), T @ K))
    S = np.array(cols).T
    U, sv, _ = np.linalg.svd(S, full_matrices=True)
    rank = _rank(sv, S.shape[0])
    return U[:, rank:]


def _rank(sv: Array, rows: int) -> int:
    """The numerical rank of a matrix of ``rows`` rows with singular values ``sv``: those
    above the rounding level of its SVD (Golub & Van Loan, sec. 5.4.1)."""
    return int(np.sum(sv > sv[0] * rows * np.finfo(float).eps)) if sv.size else 0


def _scale(model: StateSpaceModel, ys: Array, us: Array) -> tuple[Array, ...]:
    """The model for inputs ``u / us`` and outputs ``y / ys`` (same state)."""
    B = model.B * us[None, :] if model.m else model.B
    C = model.C / ys[:, None]
    D = (model.D * us[None, :]) / ys[:, None] if model.m else model.D
    K = model.K * ys[None, :]
    return model.A, B, C, D, K


def _unscale(p: tuple[Array, ...], ys: Array, us: Array) -> tuple[Array, ...]:
    """Inverse of :func:`_scale`."""
    A, B, C, D, K = p
    B = B / us[None, :] if B.shape[1] else B
    C = C * ys[:, None]
    D = (D / us[None, :]) * ys[:, None] if D.shape[1] else D
    K = K / ys[None, :]
    return A, B, C, D, K


def _is_stable(lam: NDArray[np.complex128]) -> bool:
    """Whether every eigenvalue ``lam`` is finite and strictly inside the unit circle."""
    return bool(np.all(np.isfinite(lam)) and np.max(np.abs(lam)) < 1.0)


def _residuals(
    theta: Array,
    lay: _Layout,
    u: Array,
    y: Array,
    h: float,
    hold: str,
    W: Array,
    jac: bool = False,
    directions: Array | None = None,
    engine: str = "auto",
    workspace: _Workspace | None = None,
    penalty: float = DEFAULT_SETTINGS.unstable_penalty,
) -> Array | tuple[Array, Array]:
    """Weighted one-step prediction errors, initial state eliminated (module docstring),
    and with ``jac=True`` their Jacobian (:func:`_residuals_numpy`).

    ``engine``: ``"numba"`` runs the passes over the samples compiled
    (:mod:`hdpbsid.refine.pem_kernels`, :func:`_residuals_compiled`), ``"numpy"`` with
    :func:`scipy.signal.lfilter` (:func:`_residuals_numpy`); ``"auto"`` is ``"numba"``
    when numba is installed and not switched off (``SLBASIS_NO_NUMBA``).  The two agree
    to rounding.  ``workspace``: buffers the compiled evaluation reuses between calls
    (:class:`_Workspace`; default: new ones).  ``penalty``: every residual when the
    predictor is unstable (the Jacobian is then zero).
    """
    kernels = _kernels(engine)
    if kernels is None:
        return _residuals_numpy(theta, lay, u, y, h, hold, W, jac, directions, penalty)
    ws = _Workspace() if workspace is None else workspace
    return _residuals_compiled(theta, lay, u, y, h, hold, W, jac, directions, kernels, ws, penalty)


def _penalised(
    size: int, theta: Array, jac: bool, directions: Array | None, penalty: float
) -> Array | tuple[Array, Array]:
    """The residuals (and zero Jacobian) of an unstable predictor: ``size`` entries
    ``penalty``."""
    r = np.full(size, penalty)
    q = theta.size if directions is None else directions.shape[1]
    return (r, np.zeros((r.size, q))) if jac else r


class _Workspace:
    """Buffers of the compiled evaluation kept between calls, one per name and shape.

    The passes write ``(Ns, n p + p + l n)`` and ``(l, Ns, n)`` arrays (about 2 MB at
    7500 samples); allocated afresh at every evaluation, they are returned to the
    operating system and faulted in again at every call."""

    def __init__(self) -> None:
        self._buffers: dict[str, Array] = {}
        #: ``(key, results)`` of the last error pass, whose free response the buffers
        #: hold: a Jacobian at the point of the last residual evaluation (each one
        #: Levenberg-Marquardt asks for) starts from it instead of repeating the pass
        self.error_pass: tuple[tuple[Any, ...], tuple[Any, ...]] | None = None

    def get(self, name: str, shape: tuple[int, ...]) -> Array:
        """An uninitialised float array of ``shape`` owned by this workspace."""
        buf = self._buffers.get(name)
        if buf is None or buf.shape != shape:
            buf = np.empty(shape)
            self._buffers[name] = buf
            if name == "free response":
                self.error_pass = None  # it was in the old buffer
        return buf


def _load_kernels() -> ModuleType:
    from hdpbsid.refine import pem_kernels

    return pem_kernels


def _kernels(engine: str) -> ModuleType | None:
    """The refinement's compiled kernels for ``engine`` (``None``: the numpy evaluation)."""
    return select_kernels(engine, _load_kernels)


def _finite_predictor(pr: Predictor) -> bool:
    """Whether the sampled predictor's matrices are finite.  A step of the search far out
    of the stable region overflows the matrix exponential; such a predictor is treated as
    an unstable one (penalised), not as an error that ends the refinement."""
    return all(np.all(np.isfinite(a)) for a in (pr.F, pr.G, pr.Kd, pr.Du))


def _gram_solve(FtF: Array, rhs: Array) -> Array:
    """``FtF^-1 rhs`` for the free response's normal equations, the minimum-norm least-squares
    solution when ``FtF`` is singular.

    The initial state is eliminated by least squares: only the projection of the errors on
    the complement of the free response's column space enters the cost, and every
    least-squares solution gives the same projection.  ``FtF`` is singular when a mode of
    the predictor leaves no trace in the weighted outputs (a drifting time series whose
    predictor has a pole at 1 to rounding, or a decoupled state), which must not end the
    refinement: the other modes' free response is still eliminated.
    """
    try:
        return np.linalg.solve(FtF, rhs)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(FtF, rhs, rcond=None)[0]


def _residuals_numpy(
    theta: Array,
    lay: _Layout,
    u: Array,
    y: Array,
    h: float,
    hold: str,
    W: Array,
    jac: bool = False,
    directions: Array | None = None,
    penalty: float = DEFAULT_SETTINGS.unstable_penalty,
) -> Array | tuple[Array, Array]:
    """Weighted one-step prediction errors, initial state eliminated (module docstring).

    With ``jac=True`` also their Jacobian with respect to ``theta`` (``(l Ns, P)``), or
    along the columns of ``directions`` (``P x q``: ``(l Ns, q)``, the derivative matrices
    are combined first, so only ``q`` sensitivities are filtered):
    the exact derivative of the errors at the fitted initial state ``x0``
    (:mod:`hdpbsid.refine.pem_predictor`), projected on the orthogonal complement of the
    free-response columns.  That is Kaufman's form of the variable-projection Jacobian
    (Golub & Pereyra, *Inverse Problems* 19 (2003), sec. 3), and ``J^T J`` equals the
    Schur complement of the joint ``(theta, x0)`` information, so the covariance of
    ``theta`` with ``x0`` marginalised is ``s^2 (J^T J)^+``.
    """
    A, B, C, D, K = lay.unpack(theta)
    pr = sampled_predictor(A, B, C, D, K, h, hold, lay.feedthrough, derivatives=jac)
    ns, n, l = y.shape[0], lay.n, lay.l
    if not _finite_predictor(pr):
        return _penalised(ns * l, theta, jac, directions, penalty)
    lam, V = np.linalg.eig(pr.F)
    if not _is_stable(lam) or np.linalg.cond(V) > _MAX_MODAL_COND:
        return _penalised(ns * l, theta, jac, directions, penalty)
    Vi = np.linalg.inv(V)
    # a real signal is sum_a V[:, a] z_a over the modes; the conjugate of a complex mode
    # carries the conjugate coordinate, so one mode per pair is filtered and counted twice
    keep, fac = conjugate_representatives(lam)
    lk, Vk, Vik = lam[keep], V[:, keep], Vi[keep]
    uT, yT = u.T, y.T
    Zk = modal_filter(lk, _cr(Vik @ pr.G, uT) + _cr(Vik @ pr.Kd, yT))  # from xi_0 = 0
    CVk = (C @ Vk) * fac[None, :]
    E = yT - _cr(CVk, Zk).real - pr.Du @ uT
    # free response to xi_0 (eliminated by least squares): y_k = C V diag(lam^k) Vi xi_0
    pw = np.cumprod(np.hstack([np.ones((lk.size, 1)), np.repeat(lk[:, None], ns - 1, 1)]), 1)
    F = np.matmul(((W @ CVk)[:, :, None] * pw[None]).transpose(0, 2, 1), Vik).real
    Ew = W @ E
    Fr = F.reshape(-1, n)  # (l Ns, n), rows ordered like Ew.ravel()
    FtF = Fr.T @ Fr
    x0 = _gram_solve(FtF, Fr.T @ Ew.ravel())
    r = Ew.ravel() - Fr @ x0
    if not jac:
        return r
    assert pr.dF is not None and pr.dG is not None and pr.dKd is not None
    assert pr.dC is not None and pr.dDu is not None
    xi = ((Vk * fac[None, :]) @ (Zk + pw * (Vik @ x0)[:, None])).real  # with x0, (n, Ns)
    dF, dG, dKd, dC, dDu = pr.dF, pr.dG, pr.dKd, pr.dC, pr.dDu
    if directions is not None:
        dF, dG, dKd, dC, dDu = (
            np.tensordot(directions.T, d, axes=1) for d in (dF, dG, dKd, dC, dDu)
        )
    q, nk, m = dF.shape[0], lk.size, u.shape[1]
    # modal drive of the sensitivities, Vi (dF xi + dG u + dKd y), as 2-D products
    drive = (
        _cr((Vik @ dF).reshape(q * nk, n), xi)
        + _cr((Vik @ dG).reshape(q * nk, m), uT)
        + _cr((Vik @ dKd).reshape(q * nk, l), yT)
    )
    S = modal_filter(lk, drive.reshape(q, nk, ns))
    dE = (dC.reshape(q * l, n) @ xi + dDu.reshape(q * l, m) @ uT).reshape(q, l, ns)
    for a in range(nk):  # C d(xi) = sum over modes of C V[:, a] s_a
        dE += (CVk[None, :, a, None] * S[:, None, a, :]).real
    J = -(W @ dE).reshape(q, -1).T  # (l Ns, q)
    J = J - Fr @ _gram_solve(FtF, Fr.T @ J)
    return r, J


def _cr(M: NDArray, X: Array) -> NDArray:
    """``M @ X`` for a complex ``M`` as two products; for a real ``X`` written into
    the real and imaginary parts of the result (the same numbers as ``M.real @ X + 1j *
    (M.imag @ X)`` without its two complex temporaries)."""
    if not np.iscomplexobj(M):
        return M @ X
    if np.iscomplexobj(X):
        return M.real @ X + 1j * (M.imag @ X)
    Z = np.empty((M.shape[0], X.shape[1]), dtype=complex)
    Z.real = M.real @ X
    Z.imag = M.imag @ X
    return Z


def _residuals_compiled(
    theta: Array,
    lay: _Layout,
    u: Array,
    y: Array,
    h: float,
    hold: str,
    W: Array,
    jac: bool,
    directions: Array | None,
    kernels: ModuleType,
    ws: _Workspace,
    penalty: float = DEFAULT_SETTINGS.unstable_penalty,
) -> Array | tuple[Array, Array]:
    """:func:`_residuals_numpy` with the passes over the samples compiled
    (:mod:`hdpbsid.refine.pem_kernels`): the same predictor, the same stability rule,
    the same variable projection; the sensitivities of all directions from the ``n p``
    modal filters of ``w = [xi; u; y]`` and one ``(Ns, n p + p) x (n p + p, q)`` product
    per output (the factorisation in :mod:`hdpbsid.refine.pem_kernels`)."""
    A, B, C, D, K = lay.unpack(theta)
    ns, l = y.shape[0], lay.l
    u = np.ascontiguousarray(u, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    C = np.ascontiguousarray(C, dtype=float)
    W = np.ascontiguousarray(W, dtype=float)
    # the error pass of this point, when the workspace's buffers still hold it
    key = (theta.tobytes(), W.tobytes(), hold, h, u.ctypes.data, y.ctypes.data, u.shape, y.shape)
    done = ws.error_pass[1] if ws.error_pass is not None and ws.error_pass[0] == key else None
    if done is not None and not jac:
        return done[0]
    pr = sampled_predictor(A, B, C, D, K, h, hold, lay.feedthrough, derivatives=jac)
    if done is None:
        done = _error_pass(pr, C, W, u, y, kernels, ws)
        if done is None:
            return _penalised(ns * l, theta, jac, directions, penalty)
        ws.error_pass = (key, done)
    r = done[0]
    if not jac:
        return r
    return r, _compiled_jacobian(pr, lay, u, y, W, done, directions, kernels, ws)


def _error_pass(
    pr: Predictor, C: Array, W: Array, u: Array, y: Array, kernels: ModuleType, ws: _Workspace
) -> tuple[Any, ...] | None:
    """The compiled error pass of the predictor ``pr``: ``(r, F, G, Kd, lam, V, FtF,
    x0)`` (residuals, predictor, eigen-decomposition of ``F``, normal matrix of the free
    response, initial state), the weighted free response left in the workspace; None when
    the predictor is unstable or its modes are not resolved."""
    ns, n, l = y.shape[0], C.shape[1], C.shape[0]
    if not _finite_predictor(pr):
        return None
    lam, V = np.linalg.eig(pr.F)
    if not _is_stable(lam) or np.linalg.cond(V) > _MAX_MODAL_COND:
        return None
    F, G, Kd, Du = (np.ascontiguousarray(a, dtype=float) for a in (pr.F, pr.G, pr.Kd, pr.Du))
    Ew, Fr3 = ws.get("errors", (l, ns)), ws.get("free response", (l, ns, n))
    kernels.weighted_errors(F, G, Kd, C, Du, W, u, y, Ew, Fr3)
    Fr = Fr3.reshape(-1, n)  # (l Ns, n), rows ordered like Ew.ravel()
    FtF = Fr.T @ Fr
    x0 = _gram_solve(FtF, Fr.T @ Ew.ravel())
    r = Ew.ravel() - Fr @ x0
    return r, F, G, Kd, lam, V, FtF, x0


def _compiled_jacobian(
    pr: Predictor,
    lay: _Layout,
    u: Array,
    y: Array,
    W: Array,
    done: tuple[Any, ...],
    directions: Array | None,
    kernels: ModuleType,
    ws: _Workspace,
) -> Array:
    """The projected Jacobian ``(l Ns, q)`` of the compiled evaluation, from the error
    pass ``done`` (:func:`_error_pass`): the regressors of the sensitivity kernel times
    the coefficients of every direction (:func:`_direction_coefficients`)."""
    _, F, G, Kd, lam, V, FtF, x0 = done
    ns, n, l = y.shape[0], lay.n, lay.l
    assert pr.dF is not None and pr.dG is not None and pr.dKd is not None
    assert pr.dC is not None and pr.dDu is not None
    Fr3 = ws.get("free response", (l, ns, n))
    keep, fac = conjugate_representatives(lam)
    lk = lam[keep]
    cplx = lk.imag != 0  # modes whose imaginary part is stored
    # columns: modal filters of w (2 p per pair, p per real mode), w itself (p), then the
    # weighted free response of each output (l n)
    p = n + lay.m + l
    nz = p * int(np.sum(np.where(cplx, 2, 1))) + p
    Z = ws.get("regressors", (ns, nz + l * n))
    kernels.sensitivity_regressors(
        F,
        G,
        Kd,
        u,
        y,
        x0,
        np.ascontiguousarray(lk.real),
        np.ascontiguousarray(lk.imag),
        cplx,
        Fr3,
        Z,
    )
    Tw = _direction_coefficients(pr, pr.C, W, V, keep, fac, cplx, directions)
    return _projected_product(Z, Tw, FtF, nz, l, n)


def _direction_coefficients(
    pr: Predictor,
    C: Array,
    W: Array,
    V: NDArray[np.complex128],
    keep: NDArray[np.intp],
    fac: Array,
    cplx: NDArray[np.bool_],
    directions: Array | None,
) -> Array:
    """``(l, nz, q)``: the weighted, negated coefficient of each regressor column (modal
    filters, then ``w``) for each output and direction: ``J = -W (Dd w + C s)``."""
    assert pr.dF is not None and pr.dG is not None and pr.dKd is not None
    assert pr.dC is not None and pr.dDu is not None
    l = C.shape[0]
    P = pr.dF.shape[0]
    Dm = np.concatenate([pr.dF, pr.dG, pr.dKd], axis=2)  # (P, n, p): drive of s
    Dd = np.concatenate([pr.dC, pr.dDu, np.zeros((P, l, l))], axis=2)  # (P, l, p): direct
    if directions is not None:
        Dm = np.tensordot(directions.T, Dm, axes=1)
        Dd = np.tensordot(directions.T, Dd, axes=1)
    CVf = (C @ V[:, keep]) * fac[None, :]  # (l, nk)
    VD = np.matmul(np.linalg.inv(V)[keep], Dm)  # (q, nk, p)
    # coefficient of column (a, b) of Z for output c and direction i:
    # fac_a (C V)[c, a] (V^-1 D_i)[a, b]; real part on Re z, minus imaginary on Im z
    T = CVf[None, :, :, None] * VD[:, None, :, :]  # (q, l, nk, p)
    blocks = []
    for a in range(keep.size):
        blocks.append(T[:, :, a, :].real)
        if cplx[a]:
            blocks.append(-T[:, :, a, :].imag)
    blocks.append(Dd)
    # J = -W (Dd w + C s): weighted and negated coefficients, (l, nz, q)
    return -np.einsum("cd,qdj->cjq", W, np.concatenate(blocks, axis=2))


def _projected_product(Z: Array, Tw: Array, FtF: Array, nz: int, l: int, n: int) -> Array:
    """``J (l Ns, q)``: output ``c``'s rows ``Z Tw[c]`` projected on the complement of
    the free response, ``J_c - Fr_c M`` with ``M = FtF^-1 sum_c Fr_c^T J_c``, folded into
    the coefficients of the ``Fr_c`` columns of ``Z``."""
    ns, q = Z.shape[0], Tw.shape[2]
    FZ = (Z[:, nz:].T @ Z[:, :nz]).reshape(l, n, nz)
    M = _gram_solve(FtF, np.einsum("cjz,czq->jq", FZ, Tw))
    coef = np.zeros((l, Z.shape[1], q))
    coef[:, :nz] = Tw
    J = np.empty((l * ns, q))
    for c in range(l):
        coef[c, nz + c * n : nz + (c + 1) * n] = -M
        np.matmul(Z, coef[c], out=J[c * ns : (c + 1) * ns])
    return J
