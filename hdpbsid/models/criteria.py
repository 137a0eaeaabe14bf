"""Model-based criteria that compare identified models on a record (order and method choice).

The question "which of these models describes the record best?" must be asked of the
*models*, identically for every method and order, not of a by-product of one method such
as a gap in singular values.  The criterion used here is the **windowed simulation
error**, the quantity a user judges a model by (MATLAB ``compare``):

* the record is cut into ``W`` consecutive windows of equal length;
* in each window the model is simulated from the measured input with its initial state
  fitted by least squares (the output is affine in it:
  ``y_w = O_w x_w + y_w^forced``, ``O_w`` the window's observability matrix), so
  transients, slow drifts of the state and an unstable plant (whose free simulation over
  a whole record diverges) are all handled;
* the residual sum of squares of window ``w``, with every output weighted by the inverse
  of its variance (each output counts equally, whatever its unit), is ``r_w``.

The window errors ``r_w`` also give the resolution of the held-out data: the standard
error of the best model's total error is ``sqrt(W) std(r_w)``.
:func:`choose_smallest_adequate` keeps the smallest model whose error is within one such
standard error of the best -- the "one standard error" rule of cross-validation (Hastie,
Tibshirani & Friedman, *The Elements of Statistical Learning*, 2nd ed., sec. 7.10).  No
threshold is a fixed number of fit points: it scales with the noise of the held-out
record, so a longer record resolves smaller improvements (a weak mode is kept once the
data show it beyond their own spread).  Each window's residual energy is divided by its
degrees of freedom (samples minus the fitted initial-state entries), so the per-window
initial state does not favour models with more states.

The same windows score the **one-step prediction error** of the model's innovation
predictor (:func:`windowed_prediction_error`): the recursion runs on
``Phi - Gk C`` and is driven by the measured output as well, and the window's initial
state enters through ``C (Phi - Gk C)^k`` instead of ``C Phi^k``.  With ``K = 0`` it is
the simulation error.  Only a stable predictor (spectral radius of ``Phi - Gk C`` at
most one) is scored: for an unstable one the fitted initial state cancels the growing
modes with the window's *later* outputs, which turns the predictor into a two-sided
smoother that sees ``y_k`` itself (:func:`predictor_is_stable`).  The innovation
predictor of a model identified with its Kalman gain is stable (Ljung, *System
Identification*, 2nd ed., sec. 4.3: ``A - K C`` stable is the condition for the
predictor to exist), so only models whose estimated ``K`` is unusable lose this score.

Simulation uses the exact sampled model for the hold of the input (``zoh``: held
between samples, ``foh``: linear), as :meth:`hdpbsid.models.model.StateSpaceModel.simulate`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from hdpbsid.data.checks import is_uniform
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.recursion import forced_responses, matrix_powers

__all__ = [
    "CriteriaSettings",
    "CRITERIA",
    "WindowedError",
    "windowed_simulation_error",
    "windowed_prediction_error",
    "predictor_is_stable",
    "default_windows",
    "choose_smallest_adequate",
    "SIGNIFICANCE_Z",
    "MIN_WINDOWS",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class CriteriaSettings:
    """How held-out records are cut into windows and how their errors are compared.

    Attributes
    ----------
    significance_z : float
        Standard errors within which a model ties with the best.
    max_windows : int
        Most windows per record.
    min_windows : int
        Fewest windows a held-out score is taken on.
    reliable_windows : int
        Fewest windows whose standard error resolves the orders; on fewer the selection
        warns (:func:`hdpbsid.selection.auto.select_model`).
    predictor_stability_tol : float
        Spectral radius beyond ``1 + tol`` counts as unstable.
    samples_per_state : int
        Samples per window per initial-state entry.
    """

    #: the "one standard error" rule: models within this many standard errors of the best
    #: held-out error are indistinguishable from it at the resolution of the held-out data
    significance_z: float = 1.0
    #: windows per record: enough for a standard error of the paired differences (a t
    #: statistic on fewer than ~8 differences is too noisy to test anything)
    max_windows: int = 16
    #: fewest windows a held-out score is taken on: below, a record is too short to score
    min_windows: int = 4
    #: fewest windows whose standard error can tell the orders apart: the one-standard-error
    #: rule's standard error is estimated from the per-window errors, and a t statistic on
    #: fewer than ~8 paired differences is too noisy to test anything (see max_windows)
    reliable_windows: int = 8
    #: a predictor eigenvalue counts as unstable beyond ``1 + tol``: eigenvalues of a sampled
    #: matrix exponential carry rounding of ~1e-15 relative, far below this; a unit
    #: eigenvalue (an integrator) is not a growing mode (:func:`predictor_is_stable`)
    predictor_stability_tol: float = 1e-8
    #: samples per window per fitted initial-state entry: the least-squares initial state of
    #: a window must be determined by many more samples than it has entries
    samples_per_state: int = 3


#: The settings in force.
CRITERIA = CriteriaSettings()
#: :attr:`CriteriaSettings.significance_z` of :data:`CRITERIA`
SIGNIFICANCE_Z = CRITERIA.significance_z
#: :attr:`CriteriaSettings.min_windows` of :data:`CRITERIA`
MIN_WINDOWS = CRITERIA.min_windows
#: :attr:`CriteriaSettings.samples_per_state` of :data:`CRITERIA`
SAMPLES_PER_STATE = CRITERIA.samples_per_state


@dataclass
class WindowedError:
    """Windowed simulation (or prediction) error of one model on one record.

    Parameters
    ----------
    per_window : ndarray, shape (W,)
        Variance-weighted residual sum of squares of each window, divided by its degrees of
        freedom (module docstring).
    total : float
        Their sum divided by the weighted sum of squares of the detrended windows' outputs
        (0 = perfect, 1 = no better than each window's mean).
    fit : float
        ``100 (1 - sqrt(total))``, a MATLAB-style fit percent pooled over the outputs.
    finite : bool
        False when the simulation overflowed or the predictor is unstable (a model unusable
        on this record); then the errors are ``inf``.
    """

    per_window: Array
    total: float
    fit: float
    finite: bool


def default_windows(ns: int, max_states: int) -> int:
    """Number of windows a record of ``ns`` samples is cut into.

    Parameters
    ----------
    ns : int
        Samples of the record.
    max_states : int
        The largest state dimension among the models compared.

    Returns
    -------
    int
        :attr:`CriteriaSettings.max_windows` if every window keeps at least
        ``SAMPLES_PER_STATE * max_states`` samples, fewer otherwise, at least 1: each
        window's least-squares initial state must be determined by many more samples than
        it has entries, and the standard error of :func:`choose_smallest_adequate` wants as
        many windows as that allows.

    Examples
    --------
    >>> default_windows(10_000, 8), default_windows(60, 10)
    (16, 2)
    """
    per = SAMPLES_PER_STATE * max(max_states, 1)
    return int(max(1, min(CRITERIA.max_windows, ns // per)))


def _sampled(
    model: StateSpaceModel, h: float, hold: str
) -> tuple[Array, Array, Array | None, Array]:
    """Exact one-step matrices ``(Phi, G1, G2, Gk)`` for step ``h`` (``G2`` only for foh;
    ``Gk`` multiplies the innovation held over the step, the convention of
    :meth:`hdpbsid.models.model.StateSpaceModel.predict`)."""
    n, m, l = model.n, model.m, model.l
    mu = m + (m if hold == "foh" else 0)
    size = n + mu + l
    M = np.zeros((size, size))
    M[:n, :n] = model.A * h
    M[:n, n : n + m] = model.B * h
    if hold == "foh":
        M[n : n + m, n + m : n + 2 * m] = np.eye(m)
    M[:n, n + mu :] = model.K * h
    E = expm(M)
    G2 = E[:n, n + m : n + 2 * m] if hold == "foh" else None
    return E[:n, :n], E[:n, n : n + m], G2, E[:n, n + mu :]


def windowed_simulation_error(
    model: StateSpaceModel,
    t: Array,
    u: Array,
    y: Array,
    windows: int,
    hold: str | None = None,
    weights: Array | None = None,
) -> WindowedError:
    """Windowed simulation error of a model on a uniformly sampled record (module docstring).

    Parameters
    ----------
    model : StateSpaceModel
        The model scored.
    t : ndarray, shape (Ns,)
        Sample times (already checked); non-uniform times are simulated window by window
        with :meth:`StateSpaceModel.fit`.
    u : ndarray, shape (Ns, m)
        Input.
    y : ndarray, shape (Ns, l)
        Output.
    windows : int
        Number of consecutive windows of ``Ns // windows`` samples (the remainder at the end
        is not scored).
    hold : {"zoh", "foh"} or None, optional
        Input between samples; ``None``: the model's ``report.hold``, ``"zoh"`` if
        it has none.
    weights : ndarray, shape (l,), optional
        Per-output weights of the squared residuals, default ``1 / var(y)`` (each output
        counts equally, whatever its unit).

    Returns
    -------
    WindowedError
        Per-window and total errors.

    Raises
    ------
    ValueError
        If a window has no more samples than the model has states.
    """
    return _windowed_error(model, t, u, y, windows, hold, weights, predict=False)


def windowed_prediction_error(
    model: StateSpaceModel,
    t: Array,
    u: Array,
    y: Array,
    windows: int,
    hold: str | None = None,
    weights: Array | None = None,
    carry_state: bool = False,
) -> WindowedError:
    r"""Windowed one-step-ahead prediction error of a model (module docstring).

    As :func:`windowed_simulation_error`, but the output is predicted one sample ahead by
    the model's sampled innovation predictor.

    Parameters
    ----------
    model : StateSpaceModel
        The model scored.
    t : ndarray, shape (Ns,)
        Uniform sample times.
    u : ndarray, shape (Ns, m)
        Input.
    y : ndarray, shape (Ns, l)
        Output.
    windows : int
        Number of consecutive windows.
    hold : {"zoh", "foh"} or None, optional
        As in :func:`windowed_simulation_error`.
    weights : ndarray, shape (l,), optional
        As in :func:`windowed_simulation_error`.
    carry_state : bool, optional
        Fit the initial state once, at the start of the scored samples, and run the
        predictor through every window; the windows then only split the residuals for the
        standard error.  This is the score of a model whose prediction is all it has, a
        time series: fitted per window, the initial state of a predictor with slow modes
        (``|eig(Phi - Gk C)|`` near 1) is a fit of slow curves to each window's own later
        outputs, not a prediction of them, and it favours models with spurious slow modes.

    Returns
    -------
    WindowedError
        ``finite=False`` when the sampled predictor ``Phi - Gk C`` is unstable
        (:func:`predictor_is_stable`): with the window's initial state fitted it would not
        be a predictor.

    Raises
    ------
    ValueError
        If ``t`` is not uniform or a window has no more samples than the model has states.

    Notes
    -----
    The sampled innovation predictor (Ljung, *System Identification*, 2nd ed., 1999,
    eq. 4.87; the innovation held over each step as in
    :meth:`hdpbsid.models.model.StateSpaceModel.predict`)

    .. math::

        \hat x_{k+1|k} = \Phi \hat x_{k|k-1} + G_1 u_k\,[+\,G_2 (u_{k+1} - u_k)]
        + G_k (y_k - C \hat x_{k|k-1} - D u_k),
        \qquad \hat y_k = C \hat x_{k|k-1} + D u_k;

    the predictions are affine in the window's initial state through
    :math:`C (\Phi - G_k C)^k`, fitted by least squares as in the simulation error.
    """
    if carry_state and windows > 1:
        L = y.shape[0] // windows
        if L <= model.n:
            raise ValueError(
                f"windows={windows} leaves {L} samples per window for a model with "
                f"{model.n} states; use fewer windows or a longer record"
            )
        s = slice(0, windows * L)
        return _windowed_error(model, t[s], u[s], y[s], 1, hold, weights, True, split=windows)
    return _windowed_error(model, t, u, y, windows, hold, weights, predict=True)


def predictor_is_stable(F: Array) -> bool:
    r"""Whether the sampled predictor matrix ``F = Phi - Gk C`` is stable.

    Parameters
    ----------
    F : ndarray, shape (n, n)
        The predictor's state matrix.

    Returns
    -------
    bool
        Spectral radius at most ``1 + CRITERIA.predictor_stability_tol`` and every entry finite.

    Notes
    -----
    An unstable ``F`` makes the windowed prediction error meaningless.  The predictions are
    affine in the window's initial state through :math:`C F^k`; the least-squares initial
    state cancels the growing modes of the data-driven part, i.e. it subtracts
    :math:`\sum_j \lambda^{k-1-j}\cdots` over *all* samples ``j`` of the window, so what
    is left of the prediction of :math:`y_k` depends on :math:`y_k` and later outputs
    through :math:`\lambda^{-(j-k)}`, a stable anti-causal filter: a smoother, not a
    predictor, which can score below the noise floor where no predictor can.  A unit
    eigenvalue (an integrator the gain leaves alone) is allowed: its free response is a
    constant, not a growing mode.

    Examples
    --------
    >>> import numpy as np
    >>> predictor_is_stable(np.diag([0.9, 1.0])), predictor_is_stable(np.diag([0.9, 1.3]))
    (True, False)
    """
    if F.size == 0:
        return True
    with np.errstate(all="ignore"):
        if not np.all(np.isfinite(F)):
            return False
        rho = float(np.max(np.abs(np.linalg.eigvals(F))))
    return rho <= 1.0 + CRITERIA.predictor_stability_tol


def _windowed_error(
    model: StateSpaceModel,
    t: Array,
    u: Array,
    y: Array,
    windows: int,
    hold: str | None,
    weights: Array | None,
    predict: bool,
    split: int = 1,
) -> WindowedError:
    """The windowed error (public wrappers); ``split`` (with ``windows=1``): the one
    window's residuals and output deviations are summed over ``split`` equal parts, the
    per-window errors of :func:`windowed_prediction_error` with ``carry_state``."""
    ns, l = y.shape
    L = ns // windows
    if windows < 1 or L <= model.n:
        raise ValueError(
            f"windows={windows} leaves {L} samples per window for a model with {model.n} "
            f"states; use fewer windows or a longer record"
        )
    hold = _hold(model) if hold is None else hold
    h = float((t[-1] - t[0]) / (ns - 1))
    if not is_uniform(t):
        if predict:
            raise ValueError("t: the windowed prediction error needs uniformly sampled times")
        return _windowed_nonuniform(model, t, u, y, windows, hold, weights)
    wgt = 1.0 / np.maximum(np.var(y, axis=0), np.finfo(float).tiny) if weights is None else weights
    sw = np.sqrt(wgt)
    n = model.n
    yw = y[: windows * L].reshape(windows, L, l)
    uw = u[: windows * L].reshape(windows, L, -1)
    Phi, G1, G2, Gk = _sampled(model, h, hold)
    C, D = model.C, model.D
    F = Phi - Gk @ C if predict else Phi
    if predict and n and not predictor_is_stable(F):
        # not a predictor on held-out data (module docstring): no score
        return WindowedError(np.full(max(windows, split), np.inf), np.inf, -np.inf, False)
    # forced response in every window from a zero state, all windows at once, and the
    # free response C F^k of the window's initial state (hdpbsid.models.recursion)
    with np.errstate(over="ignore", invalid="ignore"):
        X = forced_responses(F, _drive(uw, yw, G1, G2, Gk, D, predict))  # (W, L, n)
        Yf = X @ C.T + uw @ D.T
        O = C @ matrix_powers(F, L)  # (L, l, n)
        R = (yw - Yf) * sw  # (W, L, l)
        Ow = (O * sw[None, :, None]).reshape(L * l, n)
        finite = bool(np.all(np.isfinite(R)) and np.all(np.isfinite(Ow)))
        Rf, dof = _initial_states_removed(R, Ow, windows, finite and n > 0)
        if split > 1:
            # one initial state, its residuals cut into `split` windows (sample-major)
            Rf = Rf.reshape(split, -1)
            yw = yw.reshape(split, -1, l)
        per = np.sum(Rf**2, axis=1) * dof
    return _scored(per, finite, yw, sw)


def _scored(per: Array, finite: bool, yw: Array, sw: Array) -> WindowedError:
    """The :class:`WindowedError` of the per-window sums ``per``: relative to the weighted
    output deviations of the windows ``yw``; an infinite error when anything overflowed."""
    if not (finite and np.all(np.isfinite(per))):
        return WindowedError(np.full(per.size, np.inf), np.inf, -np.inf, False)
    dev = (yw - yw.mean(axis=1, keepdims=True)) * sw
    total = float(per.sum() / max(np.sum(dev**2), np.finfo(float).tiny))
    return WindowedError(per, total, 100.0 * (1.0 - np.sqrt(total)), True)


def _hold(model: StateSpaceModel) -> str:
    """The input hold the model was identified with (its report), ``"zoh"`` when unknown."""
    hold = model.report.hold
    return hold if hold in ("zoh", "foh") else "zoh"


def _drive(
    uw: Array, yw: Array, G1: Array, G2: Array | None, Gk: Array, D: Array, predict: bool
) -> Array:
    """What drives the state in every window, ``(W, L - 1, n)``: the input through the
    hold's matrices and, for the predictor, the innovations ``y - D u`` through ``Gk``."""
    drive = uw[:, :-1] @ G1.T
    if G2 is not None:
        drive += np.diff(uw, axis=1) @ G2.T
    if predict:
        drive += (yw[:, :-1] - uw[:, :-1] @ D.T) @ Gk.T
    return drive


def _initial_states_removed(
    R: Array, Ow: Array, windows: int, fit_state: bool
) -> tuple[Array, float]:
    """Each window's weighted residuals ``R (W, L, l)`` less the part its least-squares
    initial state explains (free responses ``Ow (L l, n)``), ``(W, L l)``, and the factor
    that makes their sum of squares unbiased; ``R`` as it is with ``fit_state`` False."""
    if not fit_state:
        return R.reshape(windows, -1), 1.0
    # least-squares initial state of each window: residual of the projection of
    # R_w onto the complement of the column space of O (one SVD for all windows)
    Uo, so, _ = np.linalg.svd(Ow, full_matrices=False)
    keep = so > so[0] * Ow.shape[0] * np.finfo(float).eps if so.size and so[0] > 0 else []
    Q = Uo[:, keep]
    Ll = Ow.shape[0]
    Rf = R.reshape(windows, Ll)
    Rf = Rf - (Rf @ Q) @ Q.T
    # degrees of freedom: the fitted initial state removes Q.shape[1] of them, so
    # RSS / (L l - rank) is the unbiased residual variance (without it a model with
    # more states fits each window's noise better by ~rank/(L l), which made a
    # spurious slow state "win" on held-out data)
    return Rf, Ll / (Ll - Q.shape[1])


def _windowed_nonuniform(
    model: StateSpaceModel,
    t: Array,
    u: Array,
    y: Array,
    windows: int,
    hold: str,
    weights: Array | None,
) -> WindowedError:
    """:func:`windowed_simulation_error` for non-uniform times.

    Each window is simulated with :meth:`StateSpaceModel.fit` (exact steps for every
    spacing, fitted initial state), its residual energy divided by its degrees of freedom
    as on a uniform grid (``L l - n``: the fitted initial state takes ``n``; without it a
    model with more states fits each held-out window's noise better by about
    ``n / (L l)``, and order selection would favour extra states).
    """
    ns, l = y.shape
    L = ns // windows
    dof = L * l / (L * l - min(model.n, L * l - 1))
    wgt = 1.0 / np.maximum(np.var(y, axis=0), np.finfo(float).tiny) if weights is None else weights
    per = np.empty(windows)
    dev = 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        for w in range(windows):
            s = slice(w * L, (w + 1) * L)
            # the window's initial state unweighted, as the order rule was validated
            # with (weighted by the score's own weights it absorbs more of a short
            # window with more states, and the order chosen moves up)
            res = model._fit(t[s], u[s], y[s], "estimate", hold, np.ones(l))
            per[w] = float(np.sum((y[s] - res.y_sim) ** 2 * wgt)) * dof
            dev += float(np.sum((y[s] - y[s].mean(axis=0)) ** 2 * wgt))
    if not np.all(np.isfinite(per)):
        return WindowedError(np.full(windows, np.inf), np.inf, -np.inf, False)
    total = float(per.sum() / max(dev, np.finfo(float).tiny))
    return WindowedError(per, total, 100.0 * (1.0 - np.sqrt(total)), True)


def choose_smallest_adequate(
    errors: Sequence[WindowedError], z: float = SIGNIFICANCE_Z
) -> tuple[int, list[float]]:
    r"""The smallest model whose windowed error is within ``z`` standard errors of the best's.

    Parameters
    ----------
    errors : sequence of WindowedError
        Ordered by complexity (e.g. orders 1, 2, ...), each on the same windows.
    z : float, optional
        The number of standard errors (:data:`SIGNIFICANCE_Z`, the "one standard error"
        rule).

    Returns
    -------
    chosen : int
        Index of the first model within ``z`` standard errors of the best.
    stats : list of float
        Every model's excess over the best in standard errors (``inf`` for a model that
        could not be simulated).

    Raises
    ------
    ValueError
        If no model could be simulated on the record.

    Notes
    -----
    The standard error of the best model's total is estimated from its per-window errors,
    :math:`\mathrm{SE} = \sqrt W \operatorname{std}(r_w)` (the sum of ``W`` window
    errors); a model's statistic is :math:`(\sum r_w - \sum r_w^{\mathrm{best}}) /
    \mathrm{SE}`.  This is the "one standard error" rule of cross-validation (Breiman et
    al., *Classification and Regression Trees*, 1984; Hastie, Tibshirani & Friedman, *The
    Elements of Statistical Learning*, 2nd ed., 2009, sec. 7.10): among models whose
    held-out error cannot be told apart from the best's at the resolution of the held-out
    data, the simplest.

    Examples
    --------
    >>> import numpy as np
    >>> e = [WindowedError(np.full(4, r), 4 * r, 0.0, True) for r in (5.0, 1.0, 1.0)]
    >>> e[1].per_window[:] = [0.9, 1.1, 0.9, 1.1]  # the best has a spread
    >>> choose_smallest_adequate(e)[0]  # order 2: order 3 is no better beyond its spread
    1
    """
    finite = [i for i, e in enumerate(errors) if e.finite]
    if not finite:
        raise ValueError("no candidate model could be simulated on the record")
    best = min(finite, key=lambda i: float(np.sum(errors[i].per_window)))
    ref = errors[best].per_window
    W = ref.size
    se = float(np.std(ref, ddof=1)) * np.sqrt(W) if W > 1 else 0.0
    se = max(se, np.finfo(float).tiny)
    total = float(np.sum(ref))
    stats = [(float(np.sum(e.per_window)) - total) / se if e.finite else np.inf for e in errors]
    chosen = next(i for i, s in enumerate(stats) if s <= z)
    return chosen, stats
