"""Prediction-error refinement of an identified continuous-time model (``refine="pem"``).

Subspace methods give consistent but not efficient estimates; the standard remedy
(Ljung, *System Identification*, 2nd ed., 1999, sec. 7.3 and 10.6; the ``n4sid`` then
``ssest`` path of MATLAB) is to use them as the initial point of a prediction-error fit.
The parameters ``theta`` are the continuous-time ``A, B, C`` (``D`` too when the model
has a feedthrough, :func:`_fits_feedthrough`) and ``K``.

Criterion.  With ``eps_k(theta) = y_k - yhat(t_k | t_{k-1}; theta)`` the one-step
prediction errors of the sampled innovation model (:mod:`hdpbsid.refine.pem_predictor`;
the predictor uses only past samples, so the criterion is exact for sampled data and
consistent in closed loop, Ljung sec. 13.4, "direct approach"), the refinement minimises

    V(theta) = 1 / n_r  sum_k || W eps_k(theta) ||^2,    n_r = l Ns,

with the unknown initial state eliminated by least squares at every evaluation
(variable projection, :mod:`hdpbsid.refine.pem_residuals`) and ``W`` the inverse
Cholesky factor of the innovation covariance of the first starting point.  For Gaussian
innovations with that covariance, ``V`` is the negative log-likelihood up to constants
(Ljung sec. 7.4), so ``n_r log(V_1 / V_2)`` is the ``-2 log`` likelihood ratio of two
fits under one weighting: the evidence scale of
:class:`~hdpbsid.refine.pem_settings.RefinementSettings`.  With several outputs the
weighting is then set again from the end point's errors until the determinant of their
covariance stops dropping (:mod:`hdpbsid.refine.pem_weighting`): the estimate is the
minimiser of that determinant, the likelihood with the innovation covariance unknown.

Step.  Levenberg-Marquardt (:func:`scipy.optimize.least_squares`, ``method="lm"``) on
the residual vector ``r(theta)`` with its exact Jacobian ``J`` (sensitivity recursions,
not finite differences): the step solves the damped linear least-squares problem

    min_delta || r + J delta ||^2 + mu || D delta ||^2,

the Gauss-Newton step at ``mu = 0`` (Nocedal & Wright, *Numerical Optimization*, 2nd ed.,
2006, sec. 10.3), whose predicted cost ``(||r||^2 - ||P_J r||^2) / n_r`` (``P_J`` the
projection on the columns of ``J``) also ranks the starting points and screens the other
input hold (:func:`_gauss_newton_cost`).  The parametrisation is full, so the ``n^2``
similarity directions along which ``V`` is constant are removed: the search runs in the
data-driven local coordinates ``theta = theta_c + Q beta`` (:func:`_ddlc_basis`;
McKelvey, Helmersson & Ribarits, *Automatica* 40 (2004)), re-centred after every run of
:attr:`~hdpbsid.refine.pem_settings.RefinementSettings.run_nfev` evaluations.

The refinement as a procedure (:func:`refine_pem`):

* inputs (:class:`_Task`): the start model and the record, scaled to unit RMS; the input
  holds to fit (:func:`~hdpbsid.refine.pem_starts._candidate_holds`); the starting
  points -- the model's ``K``, the Kalman gain of a sensor-noise-only model
  (:func:`_kalman_gain`) and an optional warm start; the evaluation budget;
* search (:func:`_search`): the start whose Gauss-Newton step predicts the lowest cost is
  fitted first and a further start only when its own prediction could beat that minimum
  (:func:`_fit_starts`); from the converged end point the other input hold is screened
  by one Gauss-Newton step, fitted when it predicts evidence for it, and kept when its
  cost is lower by a likelihood ratio significant at 1 % with every mode resolved by the
  sampling (:func:`_other_hold`, :func:`_modes_resolved`); when the first hold's fit ran
  out of budget, the other hold is fitted from the starting points on the same terms
  (:func:`_search`);
* weighting (:func:`_reweighted`): with several outputs, the converged fit continues
  under the weighting of its own errors while the determinant of their covariance drops
  by more than the evidence;
* stopping rule (:func:`_run_end`): a run that converges at once in a re-centred chart, a
  run stopped by the cost test where the Gauss-Newton model of its centre predicted, or
  a run that moves the estimate by less than a tenth of its standard deviation ends the
  fit; the budget ends it unconverged;
* outcome: the refined model with a :class:`~hdpbsid.models.report.Refinement` in its
  report (converged, evaluations, hold, start, costs, eigenvalue standard deviations), or
  the start model unchanged with a ``RuntimeWarning`` when no start has a stable
  predictor or the fit does not lower the cost (:class:`_Kept`).

Input hold.  The innovation is held over each interval as in
:mod:`hdpbsid.models.conversion`; the input with the hold the method detected (``"zoh"``,
or ``"foh"``: linear between samples, Franklin, Powell & Workman, *Digital Control of
Dynamic Systems*, 3rd ed., 1998, sec. 6.3).  The two holds differ, to first order in
``|lambda| h``, by half a sample of input delay, which a model of fixed order can absorb
by moving its fast modes; the two sampled predictors have the same parameters, so their
costs under one weighting compare as a likelihood ratio of two structures of equal
dimension (Ljung sec. 16.4).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import Any, Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

# is_uniform: the package's one uniformity test (hdpbsid.data.checks), re-exported here
from hdpbsid.core.normal_equations import lstsq_residuals
from hdpbsid.data.checks import check_data, is_uniform
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import WARM_START_OPTION, Choice, Refinement, WarmStart
from hdpbsid.models.simulation import output_weights
from hdpbsid.models.uncertainty import ParameterCovariance
from hdpbsid.refine.pem_covariance import _abcd_factor, _eigenvalue_std
from hdpbsid.refine.pem_focus import FOCUSES, simulation_focus
from hdpbsid.refine.pem_predictor import sampled_predictor
from hdpbsid.refine.pem_residuals import (
    _ddlc_basis,
    _is_stable,
    _Layout,
    _Record,
    _residuals,
    _scale,
    _unscale,
)
from hdpbsid.refine.pem_settings import DEFAULT_SETTINGS, RefinementSettings
from hdpbsid.refine.pem_starts import (
    HOLDS,
    _candidate_holds,
    _check_warm_start,
    _hold_was_given,
    _kalman_gain,
    _warm_first,
    _warm_name,
    _warm_start,
    warm_start_option,
)
from hdpbsid.refine.pem_weighting import error_covariance, relax_weighting, weighting
from hdpbsid.runtime import library_call, user_stacklevel

__all__ = [
    "refine_pem",
    "one_step_errors",
    "prediction_log_det",
    "warm_start_option",
    "is_uniform",
    "REFINE_CHOICES",
    "FOCUSES",
    "RefinementSettings",
    "DEFAULT_SETTINGS",
]

Array = NDArray[np.float64]

#: accepted values of the ``refine`` option of :func:`hdpbsid.identify`
REFINE_CHOICES = ("auto", "pem", None)
#: statuses of :func:`scipy.optimize.least_squares` (``method="lm"``) of the cost
#: reduction test at ``ftol`` (2; 4 with the step test too): such a run ends the fit when
#: it ended where the Gauss-Newton model at its centre predicted (:func:`_run_end`)
FTOL_STATUS = (2, 4)
#: the option that carried a further starting point in earlier versions (now the
#: ``warm_start`` argument of :func:`refine_pem`), and the default name of that start in
#: ``options["refine_start"]``
WARM_START = WARM_START_OPTION


class _Fit(NamedTuple):
    """One Levenberg-Marquardt fit (:func:`_lm_fit`): its end point, its mean squared
    residual, the evaluations it spent, why it stopped, and whether it converged (False:
    the budget ran out first)."""

    theta: Array
    cost: float
    nfev: int
    message: str
    converged: bool


@dataclass(frozen=True)
class _Task:
    """The inputs of one refinement: the start ``model``, the input ``holds`` to fit (the
    first fitted first), the step ``h``, the parameter layout, the output and input
    scales ``ys, us`` and the scaled record ``un, yn``, the starting points (scaled
    parameters by name), the evaluation ``budget`` per hold and the number of residuals
    ``n_r``."""

    model: StateSpaceModel
    holds: tuple[str, ...]
    h: float
    lay: _Layout
    ys: Array
    us: Array
    un: Array
    yn: Array
    starts: dict[str, Array]
    budget: int
    n_r: int


@dataclass(frozen=True)
class _Search:
    """The outcome of the search (:func:`_search`): the end point ``theta`` and its cost,
    the cost of the best start, the hold and start it came from, the stop ``status`` and
    ``converged``, the evaluations, the fits of the starts, their predicted costs, the
    cost of each hold tried, the output weighting ``W`` and the record's evaluation for
    the chosen hold."""

    theta: Array
    cost: float
    cost0: float
    hold: str
    start: str
    status: str
    converged: bool
    nfev: int
    fits: dict[str, _Fit]
    predicted: dict[str, float]
    hold_costs: dict[str, Any]
    W: Array
    record: _Record


class _Kept(NamedTuple):
    """Why the start model is returned unrefined: no start has a stable sampled
    predictor, or the fit did not lower the cost of the best start; ``message`` is the
    warning's text."""

    reason: Literal["no stable start", "cost not lowered"]
    message: str


@library_call
def refine_pem(
    model: StateSpaceModel,
    t: Any,
    u: Any,
    y: Any,
    *,
    hold: str | None = None,
    max_nfev: int | None = None,
    warm_start: WarmStart | None = None,
    settings: RefinementSettings | None = None,
    focus: str = "prediction",
) -> StateSpaceModel:
    """Prediction-error refinement of ``model`` on the record ``t, u, y`` (module docstring).

    Minimises the mean squared whitened one-step prediction error ``V(theta)`` of the
    sampled innovation model over ``A, B, C, [D], K`` by Levenberg-Marquardt with the
    exact Jacobian, from several starting points, with the input hold chosen by the
    same criterion.  Starting points: the model; the model with the gain of a
    measurement-noise Kalman predictor; and ``warm_start`` when it holds a model of the
    same dimensions (a prediction-error fit on part of the record is a consistent
    estimate close to the fit on all of it, where one Gauss-Newton step is already
    efficient; :func:`hdpbsid.selection.auto.rejudge_refined`).  The most promising
    start is fitted first (:func:`_fit_starts`).

    Parameters
    ----------
    model : StateSpaceModel
        The start model (any method's).
    t : array_like
        Sample times, uniformly sampled (relative spread ``<= 1e-6``).
    u : array_like or None
        Inputs, ``(Ns, m)``.
    y : array_like
        Outputs, ``(Ns, l)``.
    hold : {"zoh", "foh"} or None, optional
        How ``u`` behaves between samples.  Default: both are fitted and the smaller
        prediction-error cost decides, unless the method was given its hold
        (:func:`~hdpbsid.refine.pem_starts._candidate_holds`).
    max_nfev : int or None, optional
        Bound on the Levenberg-Marquardt cost evaluations over all starts of one input
        hold together (the other hold, when fitted, has its own).  Default
        ``settings.max_nfev``.
    warm_start : WarmStart or None, optional
        A further starting point (:func:`warm_start_option`); its ``input_hold`` is then
        fitted first and its ``name`` names it in ``options["refine_start"]`` (default:
        that of a prediction-error fit on part of the record).  Not carried to the result.
    settings : RefinementSettings or None, optional
        Budget, stopping rule and evidence thresholds; default :data:`DEFAULT_SETTINGS`.
    focus : {"prediction", "simulation"}, optional
        ``"prediction"`` (default): ``A, B, C, [D], K`` together by the one-step
        prediction error.  ``"simulation"``: the plant by its simulation error, then
        ``K`` with the plant held (:mod:`hdpbsid.refine.pem_focus`: consistent in open
        loop whatever the disturbance, biased in closed loop).

    Returns
    -------
    StateSpaceModel
        A new model with the refined ``A, B, C, D, K``, the start model's options plus
        ``refine="pem"``, ``input_hold`` (the refined hold; the method's in
        ``input_hold_before_refine``), ``refine_cost`` (initial and final mean squared
        weighted prediction error), ``refine_nfev``, ``refine_status``,
        ``refine_converged`` (False when ``max_nfev`` ran out first; the other hold is
        then not fitted) and ``eigenvalues_before_refine``, its parameter covariance and
        a :class:`~hdpbsid.models.report.Refinement` in its report.  When no start has a
        stable predictor or the fit does not lower the cost, ``model`` itself (with a
        ``RuntimeWarning``).

    Raises
    ------
    TypeError
        When ``model`` is not a :class:`StateSpaceModel` or ``warm_start`` not a
        :class:`~hdpbsid.models.report.WarmStart`.
    ValueError
        When the record does not match the model, ``t`` is not uniformly sampled, or
        ``hold`` is not one of :data:`HOLDS`.

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import identify
    >>> t = np.arange(0.0, 20.0, 0.01)
    >>> u = np.sign(np.sin(1.3 * t))
    >>> y = np.convolve(u, 0.01 * np.exp(-t))[: t.size] + 0.01 * np.cos(37.0 * t)
    >>> m = identify(t, u, y, 1, method="hermite", refine=None)
    >>> refine_pem(m, t, u, y).options["refine"]  # doctest: +SKIP
    'pem'
    """
    settings = DEFAULT_SETTINGS if settings is None else settings
    if focus not in FOCUSES:
        raise ValueError(f"focus must be one of {FOCUSES}, got {focus!r}")
    t, u, y = _checked_record(model, t, u, y, hold)
    if focus == "simulation":

        def fit(start: StateSpaceModel, hd: str | None, free: str) -> StateSpaceModel:
            return _refine(_task(start, t, u, y, hd, None, max_nfev, settings, free), settings)

        return simulation_focus(fit, model, hold)
    return _refine(_task(model, t, u, y, hold, warm_start, max_nfev, settings), settings)


def _refine(task: _Task, settings: RefinementSettings) -> StateSpaceModel:
    """:func:`refine_pem` of the prepared ``task`` (:func:`_task`)."""
    model = task.model
    if not task.starts:
        return _keep(
            model,
            _Kept(
                "no stable start",
                "refine='pem': the initial model's sampled predictor is unstable and no "
                "stabilising gain exists; keeping the unrefined model",
            ),
        )
    search = _search(task, settings)
    if not (np.isfinite(search.cost) and search.cost < search.cost0):
        return _keep(
            model,
            _Kept(
                "cost not lowered",
                f"refine='pem' did not lower the prediction-error cost ({search.cost0:.4g} "
                f"-> {search.cost:.4g}); keeping the unrefined model",
            ),
        )
    return _refined_model(task, _reweighted(task, search, settings))


def _keep(model: StateSpaceModel, kept: _Kept) -> StateSpaceModel:
    """``model`` unchanged, with the warning of ``kept``."""
    warnings.warn(kept.message, RuntimeWarning, stacklevel=user_stacklevel())
    return model


def _checked_record(
    model: StateSpaceModel, t: Any, u: Any, y: Any, hold: str | None
) -> tuple[Array, Array, Array]:
    """The record of :func:`refine_pem`, checked against ``model`` (``TypeError`` and
    ``ValueError`` as documented there)."""
    if not isinstance(model, StateSpaceModel):
        raise TypeError(f"model must be a StateSpaceModel, got {type(model).__name__}")
    t, u, y = check_data(t, u, y, min_samples=model.n + 2)
    if u.shape[1] != model.m or y.shape[1] != model.l:
        raise ValueError(
            f"u and y must have {model.m} and {model.l} columns (the model's inputs and "
            f"outputs), got {u.shape[1]} and {y.shape[1]}"
        )
    if not is_uniform(t):
        raise ValueError(
            "t must be uniformly sampled for refine='pem' (the sampled predictor has one "
            "step); resample the record or use refine=None"
        )
    if hold is not None and hold not in HOLDS:
        raise ValueError(f"hold must be 'zoh' or 'foh', got {hold!r}")
    return t, u, y


def _task(
    model: StateSpaceModel,
    t: Array,
    u: Array,
    y: Array,
    hold: str | None,
    warm_start: Any,
    max_nfev: int | None,
    settings: RefinementSettings,
    free: str = "all",
) -> _Task:
    """The inputs of the refinement of ``model`` on the checked record (:class:`_Task`);
    ``free``: the parameters moved (:class:`~hdpbsid.refine.pem_residuals._Layout`;
    with the plant alone, the one start with ``K = 0``)."""
    warm_start = _check_warm_start(warm_start)
    holds = _warm_first(_candidate_holds(model, hold), warm_start)
    h = float((t[-1] - t[0]) / (t.size - 1))
    lay = _Layout(model.n, model.m, model.l, _fits_feedthrough(model), free)
    # scale outputs and inputs to unit RMS so the parameters are comparable; tiny: an
    # all-zero signal keeps a finite scale
    ys = np.sqrt(np.mean(y**2, axis=0)) + np.finfo(float).tiny
    us = np.sqrt(np.mean(u**2, axis=0)) + np.finfo(float).tiny if model.m else np.ones(0)
    starts = _starts(model, lay, h, holds[0], warm_start, ys, us, settings)
    if free == "plant":  # the output-error fit: K stays at the model's zero
        starts = {k: v for k, v in starts.items() if k == "model K"}
    budget = settings.max_nfev if max_nfev is None else int(max_nfev)
    return _Task(model, holds, h, lay, ys, us, u / us, y / ys, starts, budget, model.l * t.size)


def _starts(
    model: StateSpaceModel,
    lay: _Layout,
    h: float,
    hold: str,
    warm_start: WarmStart | None,
    ys: Array,
    us: Array,
    settings: RefinementSettings,
) -> dict[str, Array]:
    """The scaled starting points whose sampled predictor (with ``hold``) is stable: the
    model's ``K``, the Kalman gain of a measurement-noise model, the warm start."""
    A0, B0, C0, D0, K0 = _scale(model, ys, us)
    try:
        K_oe: Array | None = _kalman_gain(A0, C0, h, settings.oe_process_noise)
    except (np.linalg.LinAlgError, ValueError):
        K_oe = None

    def predicts(p: tuple[Array, ...]) -> bool:
        """Whether the sampled predictor of the parameters ``p`` is stable (a start)."""
        return _is_stable(np.linalg.eigvals(sampled_predictor(*p, h, hold, lay.feedthrough).F))

    starts: dict[str, Array] = {}
    if predicts((A0, B0, C0, D0, K0)):
        starts["model K"] = lay.pack(A0, B0, C0, D0, K0)
    if K_oe is not None:  # stable by construction (the Kalman predictor)
        starts["Kalman gain, measurement noise only"] = lay.pack(A0, B0, C0, D0, K_oe)
    warm = _warm_start(model, warm_start, ys, us)
    if warm is not None and predicts(warm):
        starts[_warm_name(warm_start)] = lay.pack(*warm)
    return starts


def _search(task: _Task, settings: RefinementSettings) -> _Search:
    """Fit the starts with the first hold, then screen and fit the other hold from the
    converged end point (module docstring).  The output weighting ``W`` is fixed from the
    first start's errors, one for both holds so that their costs compare.

    When the first hold's fit spent its budget without converging there is no minimum to
    screen the other hold at, and the first hold's priority -- the method's choice, made
    on the least-squares VARX residuals
    (:func:`~hdpbsid.refine.pem_starts._candidate_holds`) -- is the weaker evidence: the
    other hold is then fitted from the same starting points with its own budget (the
    budget is per hold) and replaces the first on the terms of a converged one
    (:func:`_switches_hold`).  A wrong hold shifts the input by half a sample, which
    a model of fixed order absorbs only by moving its modes, often far (a fast mode), so
    a crawl is more often the wrong hold's; the cost is at most one more budget, paid
    only by a fit that ran out of it."""
    lay, hold, l = task.lay, task.holds[0], task.model.l
    record = {hd: _Record(lay, task.un, task.yn, task.h, hd, settings) for hd in task.holds}
    W = weighting(error_covariance(record[hold], next(iter(task.starts.values())), l)[0])
    weighted = {hd: partial(record[hd], W=W) for hd in task.holds}
    kw = _lm_options(task, settings)
    fits, start_costs, predicted, nfev = _fit_starts(
        task.starts, lay, weighted[hold], kw, task.budget, task.n_r, settings
    )
    k_start = min(fits, key=lambda k: fits[k].cost)
    nfev += sum(f.nfev for f in fits.values())
    best = fits[k_start]
    hold_costs: dict[str, Any] = {hold: best.cost}
    for other in task.holds[1:]:
        if best.converged:  # screened at the first hold's minimum
            fit = _other_hold(
                best.theta, best.cost, lay, weighted[other], kw, task.budget, task.starts,
                settings,
            )  # fmt: skip
        else:  # no minimum to screen at: the other hold's own fit from the starts
            points = tuple(task.starts.values())
            fit = _fit_points(points, lay, weighted[other], kw, task.budget, settings)
        nfev += fit.nfev
        hold_costs[other] = fit.cost if np.isfinite(fit.cost) else fit.message
        if _switches_hold(fit, best.cost, lay, task.h, task.n_r, settings):
            best, hold = fit, other
    return _Search(
        best.theta,
        best.cost,
        min(start_costs.values()),
        hold,
        k_start,
        best.message,
        best.converged,
        nfev,
        fits,
        predicted,
        hold_costs,
        W,
        record[hold],
    )


def _switches_hold(
    fit: _Fit, cost: float, lay: _Layout, h: float, n_r: int, settings: RefinementSettings
) -> bool:
    """Whether the other hold's ``fit`` replaces the first hold's minimum ``cost``: lower
    by ``settings.hold_evidence`` units of ``-2 log`` likelihood ratio, with every mode
    resolved by the sampling (:func:`_modes_resolved`)."""
    decisive = fit.cost < cost * np.exp(-settings.hold_evidence / n_r)
    return bool(decisive and _modes_resolved(lay, fit.theta, h))


def _refined_model(task: _Task, search: _Search) -> StateSpaceModel:
    """The refined model of ``search`` in the record's units, with its options, its
    noise and parameter covariances and its report."""
    model, lay, theta, cost = task.model, task.lay, search.theta, search.cost
    Q = _ddlc_basis(lay, theta)
    A, B, C, D, K = _unscale(lay.unpack(theta), task.ys, task.us)
    E = search.record(theta, W=np.eye(model.l)).reshape(model.l, -1)
    Jq = search.record(theta, W=search.W, jac=True, directions=Q)[1]
    eig_std = _eigenvalue_std(lay, theta, Q, Jq, cost)
    noise_cov = (task.ys[:, None] * (E @ E.T / E.shape[1])) * task.ys[None, :]
    refinement = Refinement(
        search.converged, search.nfev, search.hold, search.start, (search.cost0, cost), eig_std
    )
    return StateSpaceModel(
        A,
        B,
        C,
        D,
        K,
        singular_values=model.singular_values,
        options=_options(task, search, int(Q.shape[1]), eig_std),
        noise_covariance=noise_cov,
        parameter_covariance=ParameterCovariance(
            _abcd_factor(lay, Q, Jq, cost, task.ys, task.us), "refine_pem"
        ),
        report=_refined_report(model, refinement),
    )


def _options(task: _Task, search: _Search, n_parameters: int, eig_std: Array) -> dict:
    """The refined model's options: the start model's, without the warm start, plus the
    refinement's record (keys documented in :func:`refine_pem`)."""
    model = task.model
    options = dict(model.options)
    options.pop(WARM_START, None)
    options.update(
        input_hold=search.hold,
        input_hold_before_refine=model.report.hold,
        refine="pem",
        refine_hold=search.hold,
        refine_holds_tried=task.holds,
        refine_start=search.start,
        refine_start_costs={k: f.cost for k, f in search.fits.items()},
        refine_start_predicted=search.predicted,
        refine_hold_costs=search.hold_costs,
        refine_cost={"initial": search.cost0, "final": search.cost},
        refine_nfev=search.nfev,
        refine_status=search.status,
        refine_converged=search.converged,
        refine_parameters=n_parameters,
        eigenvalues_before_refine=model.eigenvalues,
        eigenvalue_std=eig_std,
    )
    return options


def _lm_options(task: _Task, settings: RefinementSettings) -> dict[str, Any]:
    """The options of :func:`scipy.optimize.least_squares` every fit of ``task`` runs
    with: Levenberg-Marquardt, Jacobian scaling, the stall's cost test and the step
    tolerance."""
    return {
        "method": "lm",
        "x_scale": "jac",
        "ftol": settings.stall_sd**2 / task.n_r,
        "xtol": settings.xtol,
    }


def _reweighted(task: _Task, search: _Search, settings: RefinementSettings) -> _Search:
    """``search`` continued under the weighting of its own errors while the determinant
    of their covariance drops by the evidence (:mod:`hdpbsid.refine.pem_weighting`:
    the maximum-likelihood criterion with unknown innovation covariance); several
    outputs and a converged fit only, within the evaluation budget."""
    if task.model.l < 2 or not search.converged:
        return search
    kw = _lm_options(task, settings)

    def fit(theta: Array, residuals: Callable[..., Any], budget: int) -> _Fit:
        return _lm_fit(theta, task.lay, residuals, kw, budget, settings)

    out = relax_weighting(
        search.theta, search.record, fit, task.model.l, task.budget, settings.evidence
    )
    if out is None:
        return search
    start = task.starts.get(search.start, search.theta)
    cost0 = float(np.mean(search.record(start, W=out.W) ** 2))
    return replace(
        search, theta=out.theta, cost=out.cost, cost0=cost0, status=out.message,
        nfev=search.nfev + out.nfev, W=out.W,
    )  # fmt: skip


def _other_hold(
    theta: Array,
    cost: float,
    lay: _Layout,
    residuals: Callable[..., Any],
    kw: dict,
    budget: int,
    starts: dict[str, Array],
    settings: RefinementSettings = DEFAULT_SETTINGS,
) -> _Fit:
    """The other input hold's fit, given the first hold's end point ``theta`` (cost
    ``cost``) and the refinement's starting points ``starts``.

    One Gauss-Newton step from ``theta`` screens it (:func:`_gauss_newton_cost`): without
    a predicted drop below ``cost`` by at least ``settings.evidence`` (in units of ``-2
    log`` likelihood ratio) the data give no evidence for the other hold, and it is
    dropped after that one evaluation (returned with an infinite cost).  With evidence,
    the structure the first hold was fitted in is in question, and so is the path it
    took: the other hold is fitted to convergence from ``theta`` *and* from every
    starting point (the first hold's optimum can lie in the basin of a poor minimum of
    the other hold's cost), and the lowest cost among the converged fits is returned.
    The starting points go first, and the fits share the evaluation ``budget``.  Records
    whose holds the data cannot tell apart (the common case: modes slow against the
    sampling) pay only the screen."""
    _, predicted = _gauss_newton_cost(theta, lay, residuals)
    n_r = residuals(theta).size
    if not predicted < cost * (1.0 - settings.evidence / n_r):
        message = (
            f"not fitted: one Gauss-Newton step predicts {predicted:.6g}, not below "
            f"{cost:.6g} by {settings.evidence:g}/{n_r} of it (no evidence for this hold)"
        )
        return _Fit(theta, float("inf"), 1, message, True)
    return _fit_points((*starts.values(), theta), lay, residuals, kw, budget, settings, spent=1)


def _fit_points(
    points: tuple[Array, ...],
    lay: _Layout,
    residuals: Callable[..., Any],
    kw: dict,
    budget: int,
    settings: RefinementSettings = DEFAULT_SETTINGS,
    spent: int = 0,
) -> _Fit:
    """Levenberg-Marquardt from each of ``points`` in turn, sharing the evaluation
    ``budget`` (``spent`` of it already used): the converged fit of lowest cost, else the
    unconverged one of lowest cost, with the evaluations spent."""
    best: _Fit | None = None
    for th in points:
        if spent >= budget:
            break
        fit = _lm_fit(th, lay, residuals, kw, budget - spent, settings)
        spent += fit.nfev
        # a converged fit beats an unconverged one; then the lower cost wins
        if best is None or (fit.converged, -fit.cost) > (best.converged, -best.cost):
            best = fit
    assert best is not None
    return best._replace(nfev=spent)


def _fit_starts(
    starts: dict[str, Array],
    lay: _Layout,
    residuals: Callable[..., Any],
    kw: dict,
    budget: int,
    n_r: int,
    settings: RefinementSettings = DEFAULT_SETTINGS,
) -> tuple[dict[str, _Fit], dict[str, float], dict[str, float], int]:
    """Levenberg-Marquardt from the starting points, the most promising first.

    Each start is ranked by the cost one Gauss-Newton step from it predicts
    (:func:`_gauss_newton_cost`) and fitted to convergence in that order; a later start
    is fitted only when its prediction is below the best converged cost so far by
    ``settings.evidence`` (``-2 log`` likelihood-ratio units), i.e. when its own local
    model says it may reach a better minimum.  Returns ``(fits by start, start costs,
    predictions, extra evaluations)`` with the skipped starts left out of the fits (the
    screen costs one evaluation per start, counted in the extra evaluations).

    Why a prediction and not a probe of a few iterations from every start: the start
    nearer a minimum is in the region where the Gauss-Newton model is accurate, and its
    prediction is then close to where it converges, while a probe of the other start is
    spent for nothing.  The prediction is not a bound: from a start far from the minimum
    the fit can also go lower than one step predicts, so a start skipped on its
    prediction can, rarely, have led lower (``bench/regression.py`` guards the rule).
    """
    screen = {name: _gauss_newton_cost(th, lay, residuals) for name, th in starts.items()}
    predicted = {name: sc[1] for name, sc in screen.items()}
    fits: dict[str, _Fit] = {}
    spent = 0
    for name in sorted(starts, key=lambda k: predicted[k]):
        best = min((f.cost for f in fits.values()), default=np.inf)
        if fits and not predicted[name] < best * (1.0 - settings.evidence / n_r):
            continue
        fit = _lm_fit(starts[name], lay, residuals, kw, budget - spent, settings)
        spent += fit.nfev
        fits[name] = fit
    return fits, {name: sc[0] for name, sc in screen.items()}, predicted, len(starts)


def _gauss_newton_cost(
    theta: Array, lay: _Layout, residuals: Callable[..., Any], Q: Array | None = None
) -> tuple[float, float]:
    """Mean squared residual at ``theta`` and at the minimum of the Gauss-Newton model
    of ``residuals`` around ``theta`` (in the local coordinates of :func:`_ddlc_basis`):
    ``(||r||^2 - ||P_J r||^2) / n_r`` with ``P_J`` the projection on the Jacobian's
    columns (Nocedal and Wright, *Numerical Optimization*, 2nd ed., sec. 10.3).  Near a
    minimum with noise-like residuals the neglected second-order term of the Hessian is
    small and this is the cost one step reaches.  ``Q``: the local coordinates at
    ``theta`` when the caller has them already."""
    Q = _ddlc_basis(lay, theta) if Q is None else Q
    r, J = residuals(theta, jac=True, directions=Q)
    cost = float(np.mean(r**2))
    if not np.all(np.isfinite(J)):
        return cost, float("-inf")  # nothing can be concluded: let the fit decide
    return cost, float(np.mean(lstsq_residuals(J, r) ** 2))


def _modes_resolved(lay: _Layout, theta: Array, h: float) -> bool:
    """Whether every eigenvalue of ``A`` satisfies ``|lambda| h < pi``: a mode faster
    than the sampling resolves (beyond the Nyquist frequency, or decaying within a
    fraction of a sample) acts on the sampled data like a delay or a direct term, and
    that is how a model with the wrong hold can absorb the half-sample shift of the
    input (Franklin, Powell & Workman, *Digital Control of Dynamic Systems*, sec. 6.3)."""
    lam = np.linalg.eigvals(lay.unpack(theta)[0])
    return bool(np.all(np.abs(lam) * h < np.pi))


def _lm_fit(
    theta: Array,
    lay: _Layout,
    residuals: Callable[..., Any],
    kw: dict,
    budget: int,
    settings: RefinementSettings = DEFAULT_SETTINGS,
) -> _Fit:
    """Levenberg-Marquardt on ``residuals(theta)`` from ``theta`` with the analytic
    Jacobian ``residuals(theta, jac=True, directions=Q)``, in local coordinates ``Q``
    re-centred after every run of at most ``settings.run_nfev`` evaluations, until a run
    ends the fit (:func:`_run_end`) or ``budget`` evaluations are spent (then the fit is
    not converged)."""
    nfev, message, converged = 0, "no evaluation budget", False
    while nfev < budget:
        Q = _ddlc_basis(lay, theta)
        centre = theta
        # the Gauss-Newton prediction at the centre (its Jacobian is the run's first one)
        _, predicted = _gauss_newton_cost(theta, lay, residuals, Q)
        trace: list[float] = []  # cost of every evaluation of this run, in order
        fun, jac = _chart(residuals, centre, Q, trace)
        run = min(settings.run_nfev, budget - nfev)
        from scipy.optimize import least_squares  # here: scipy.optimize is slow to import

        sol = least_squares(fun, np.zeros(Q.shape[1]), jac=jac, max_nfev=run, **kw)
        theta = centre + Q @ sol.x
        nfev += int(sol.nfev)
        message = sol.message
        end = _run_end(sol, predicted, trace, settings)
        if end is not None:
            message, converged = end, True
            break
    cost = float(np.mean(residuals(theta) ** 2))
    return _Fit(theta, cost, nfev, message, converged)


def _chart(
    residuals: Callable[..., Any], centre: Array, Q: Array, trace: list[float]
) -> tuple[Callable[[Array], Array], Callable[[Array], Array]]:
    """The residuals and their Jacobian in the local coordinates ``beta`` of the chart
    ``theta = centre + Q beta``; every residual evaluation appends its cost to ``trace``."""

    def fun(beta: Array) -> Array:
        r = residuals(centre + Q @ beta)
        trace.append(float(np.mean(r**2)))
        return r

    def jac(beta: Array) -> Array:
        return residuals(centre + Q @ beta, jac=True, directions=Q)[1]

    return fun, jac


def _run_end(
    sol: Any, predicted: float, trace: list[float], settings: RefinementSettings
) -> str | None:
    """Why the fit ends after the Levenberg-Marquardt run ``sol`` (its message), or None
    to re-centre the chart and run again.

    The fit ends when

    * the run converged within ``settings.converged_nfev`` evaluations: the re-centred
      chart did not move;
    * the run stopped on the cost test at ``ftol`` (:data:`FTOL_STATUS`) where the
      Gauss-Newton model of its centre predicted (``predicted``, within
      ``settings.evidence`` units): the centre was in the quadratic region of the
      minimum, where the chart's directions ``Q`` and the similarity directions (along
      which the cost is constant) together span the parameter space, so a minimum along
      ``Q`` is one of the full parametrisation;
    * the run, from its first evaluation (``trace[0]``) to its end point, lowered the
      cost by less than ``stall_sd^2 / n_r`` relative: it moved the estimate by less than
      ``stall_sd`` of its own standard deviation (the Levenberg-Marquardt tolerances
      alone never stop at a minimum where rounding makes the last rejected steps look
      productive).
    """
    cost = float(np.mean(sol.fun**2))
    if (sol.status > 0 and sol.nfev <= settings.converged_nfev) or (
        sol.status in FTOL_STATUS and cost <= predicted * (1.0 + settings.evidence / sol.fun.size)
    ):
        return str(sol.message)
    if trace and trace[0] - cost < settings.stall_sd**2 * cost / sol.fun.size:
        return (
            f"a run lowered the cost by less than ({settings.stall_sd} standard deviation)^2 / "
            f"{sol.fun.size} residuals"
        )
    return None


@library_call
def one_step_errors(
    model: StateSpaceModel, t: Any, u: Any, y: Any, hold: str | None = None
) -> Array | None:
    """One-step prediction errors ``y_k - yhat(t_k | t_{k-1})`` of ``model`` on a
    uniformly sampled record, the initial state fitted by least squares.

    The numbers of :meth:`~hdpbsid.models.model.StateSpaceModel.predict` (``k=1``,
    ``x0="estimate"``, ``method=hold``), computed by the compiled passes of the
    refinement (:mod:`hdpbsid.refine.pem_residuals`): the errors ``eps_k`` of the
    criterion of :func:`refine_pem`, the initial state fitted with each output divided
    by its spread (:func:`~hdpbsid.models.simulation.output_weights`) so that the errors
    of one output do not depend on the units of the others.

    Parameters
    ----------
    model : StateSpaceModel
        The model whose predictor is run (its operating point is removed first).
    t : array_like
        Uniform sample times, ``(Ns,)``.
    u : array_like or None
        Absolute inputs, ``(Ns, m)``.
    y : array_like
        Absolute outputs, ``(Ns, l)``.
    hold : {"zoh", "foh"} or None, optional
        The input hold of the sampled predictor; default the model's
        ``options["input_hold"]`` (``"zoh"`` when it has none of :data:`HOLDS`).

    Returns
    -------
    ndarray or None
        The errors, ``(Ns, l)``; None when the sampled predictor is unstable (its errors
        grow without bound; ``predict`` overflows there).

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> m = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.5]])
    >>> t = np.arange(0.0, 1.0, 0.1)
    >>> one_step_errors(m, t, np.ones(t.size), np.zeros(t.size)).shape
    (10, 1)
    """
    if hold is None:
        hold = model.report.hold
        hold = hold if hold in HOLDS else "zoh"
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float).reshape(t.size, -1)
    u = np.zeros((t.size, 0)) if u is None else np.asarray(u, dtype=float).reshape(t.size, -1)
    U0, Y0 = model.operating_point(t)  # absolute signals, as predict takes them
    u, y = u - U0, y - Y0
    feedthrough = bool(np.any(model.D != 0)) and model.m > 0
    lay = _Layout(model.n, model.m, model.l, feedthrough)
    theta = lay.pack(model.A, model.B, model.C, model.D, model.K)
    h = float((t[-1] - t[0]) / (t.size - 1))
    pr = sampled_predictor(model.A, model.B, model.C, model.D, model.K, h, hold, feedthrough)
    if not _is_stable(np.linalg.eigvals(pr.F)):
        return None
    w = output_weights(y)  # the initial state fitted as predict fits it
    r = _residuals(theta, lay, u, y, h, hold, np.diag(w))
    return (np.asarray(r).reshape(model.l, -1) / w[:, None]).T


def prediction_log_det(
    model: StateSpaceModel, t: Any, u: Any, y: Any, hold: str | None = None
) -> float | None:
    """``N log det S``, ``S`` the covariance of ``model``'s one-step errors on the record.

    ``-2`` times the Gaussian log-likelihood with unknown innovation covariance, up to a
    constant (the determinant criterion of :func:`refine_pem`): the difference of two
    models' values on one record is their ``-2 log`` likelihood ratio.

    Parameters
    ----------
    model : StateSpaceModel
        The model whose predictor is run (:func:`one_step_errors`).
    t : array_like
        Uniform sample times, ``(Ns,)``.
    u : array_like or None
        Absolute inputs, ``(Ns, m)``.
    y : array_like
        Absolute outputs, ``(Ns, l)``.
    hold : {"zoh", "foh"} or None, optional
        The input hold of the sampled predictor (as in :func:`one_step_errors`).

    Returns
    -------
    float or None
        ``N log det S``; None when the sampled predictor is unstable.
    """
    errors = one_step_errors(model, t, u, y, hold)
    if errors is None:
        return None
    n = errors.shape[0]
    return float(n * np.linalg.slogdet(errors.T @ errors / n)[1])


def _fits_feedthrough(model: StateSpaceModel) -> bool:
    """Whether ``D`` is a parameter of the refinement: only when the method was asked for
    a direct term (``model.report.feedthrough.asked``).

    A method that estimates ``D`` as part of its own algebra without being asked (the
    Laguerre-domain ``D_d``, reported as a string) does not make ``D`` a parameter: the
    refinement fixes it at zero, the structure every method assumes by default.  In
    closed loop this matters beyond parsimony: with a controller that reacts to ``y_k``
    within the sample, a free ``D`` lets ``D u_k`` predict the innovation ``e_k`` through
    the controller, the loop is not well posed for the direct approach (Ljung, *System
    Identification*, 2nd ed., sec. 13.4: a delay in the loop is required) and the
    prediction-error minimum is not the system: it can lie below the innovation variance,
    with the direct term predicting what the plant does not.
    """
    fd = model.report.feedthrough
    return fd is not None and fd.asked and model.m > 0


def _refined_report(model: StateSpaceModel, refinement: Refinement) -> Any:
    """The report of the refinement of ``model``: its own, with the hold fitted (given
    when the method was told it) and the refinement's outcome, and no warm start."""
    why = "given" if _hold_was_given(model) else "the smaller prediction-error cost"
    return model.report.but(
        input_hold=Choice(refinement.hold, why), refinement=refinement, warm_start=None
    )
