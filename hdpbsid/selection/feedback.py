"""The ``refine="auto"`` rule, and a data-driven test for feedback that it reports.

Why the default refines.  The subspace estimate (PBSID, in any basis domain) is
consistent in open loop but not efficient: its covariance is larger than the
Cramer-Rao bound, by a factor that does not shrink with the record length or the SNR.
In closed loop the basis-domain least squares is also biased (docs/theory.md, "Closed
loop in the basis domain").  The prediction-error estimate
(:func:`hdpbsid.refine.pem.refine_pem`) is consistent in open and closed loop (Ljung,
*System Identification*, 2nd ed., sec. 8.3 and 13.4, the direct approach) and
asymptotically efficient for Gaussian innovations (sec. 9.3), and Gauss-Newton started at
a consistent estimate converges to it in a few iterations (from a ``sqrt(Ns)``-consistent
start one Newton step is already efficient: Lehmann and Casella, *Theory of Point
Estimation*, 2nd ed., sec. 6.4).  So the subspace model is the start, the prediction-error
model the answer, at the price of a few more evaluations of the predictor per fit (the
effect is measured in the regression table, ``bench/regression.py``).

Rule (:func:`refine_decision`): refine when the data are one record (the front end
skips lists) sampled uniformly (the sampled predictor has one step) and the first-pass
model's one-step predictor does not diverge on the record (a start whose prediction
errors overflow is not a prediction-error start).  A diverging predictor condemns the
model's noise model ``K``, not its plant: the refinement has a second start, the same
plant with the Kalman gain of a measurement-noise model (stable by construction,
:mod:`hdpbsid.refine.pem`), so such a model is refined from it when neither the ``dt``
model's residuals nor its plant's own errors, its simulation errors, show feedback
(:func:`refine_plan`; in closed loop a basis-domain plant can be biased far from the
system, and the ``dt`` start decides, below).  A refinement that does not converge
within its budget is dropped by the front end (:func:`hdpbsid.identify`).  The feedback
test below does not change the decision; its result says whether the record looks
closed loop, i.e. whether the refinement also removes a bias, and is reported in
``options["refine_statistics"]``.

Closed-loop test (Ljung, sec. 13.4 and 16.6, "testing for feedback").  Let ``e_k`` be the
one-step prediction errors of the first-pass model and ``w_k`` the input prewhitened by
a least-squares AR model of order :data:`AR_ORDER` (``w_k = u_k - sum_i a_i u_{k-i}``,
per input channel).  In open loop ``u`` is independent of the noise, and ``e_k``
depends on the noise and on ``u_j, j <= k`` only (the predictor is causal, model errors
included), while ``w_{k+tau}``, ``tau >= 1``, is the part of ``u_{k+tau}`` not explained by
its own past: so ``E[e_k w_{k+tau}] = 0`` for ``tau >= 1`` whatever the model error.  With
feedback, ``u_{k+tau}`` responds to ``y_k`` and therefore to ``e_k``, and the correlation
at positive lags is the controller's response to the noise.  With the normalised cross
correlations ``r_ij(tau)`` of ``e_i`` and ``w_j`` over ``Ns`` samples
(:func:`hdpbsid.models.assessment.correlation`) and ``w`` white,
``Ns r_ij(tau)^2`` are asymptotically independent ``chi^2(1)`` under open loop
(Bartlett's formula: the variance of a cross-correlation is ``(1/Ns) sum_k rho_e(k)
rho_w(k)``, ``1/Ns`` when one of the two is white), so

    S = Ns sum_{tau=1..M} sum_{i,j} r_ij(tau)^2  ~  chi^2(M m l)

and feedback is declared when ``S`` exceeds the ``1 - FEEDBACK_LEVEL`` quantile.  The
argument holds for any causal error of the model, so also for its simulation errors
(``K = 0``), however coloured: ``w`` is white, so their cross correlations keep the
variance ``1/Ns``.

A grossly misfit first-pass model can fire the test in open loop as well: its error
has a memory longer than the prewhitening order, so ``w`` is no longer orthogonal to it
(the second-order benchmark identified with ``alpha`` twenty times too small, 80 %
eigenvalue error); the report then says "closed loop" where "misfit" would be accurate.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from hdpbsid.bases.basis_core import WindowReason
from hdpbsid.core.normal_equations import NORMAL_EQUATIONS, lstsq_residuals
from hdpbsid.models.assessment import correlation
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import WarmStart

__all__ = [
    "FeedbackTest",
    "FEEDBACK_TEST",
    "RefineReason",
    "RefineChoice",
    "decide_refine",
    "AR_ORDER",
    "CLOSED_LOOP_START_METHOD",
    "FEEDBACK_LAGS",
    "FEEDBACK_LEVEL",
    "closed_loop_start",
    "retry_start",
    "retried",
    "refine_plan",
    "feedback_statistics",
    "plant_decision",
    "refine_decision",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class FeedbackTest:
    """The settings of the closed-loop test (module docstring), each with its reason.

    Attributes
    ----------
    ar_order : int
        Order of the input's prewhitening AR model.
    lags : int
        Positive lags ``tau = 1..M`` tested.
    level : float
        False-alarm probability of the chi-square test in open loop.
    gram_rcond : float
        Smallest squared Cholesky pivot of a Gram matrix, relative to its largest
        diagonal entry, at which the normal equations are solved
        (:func:`lstsq_residuals`; about ``1 / cond(X^T X)``).

    Examples
    --------
    >>> FeedbackTest().lags
    20
    """

    #: the normal equations make ``w_k`` orthogonal to ``u_{k-1..k-40}`` in the sample,
    #: so a causal model error of that memory cannot leak into the positive-lag correlations
    ar_order: int = 40
    #: feedback shows from the first sample after the noise entered the controller; more
    #: lags add degrees of freedom and dilute the test
    lags: int = 20
    #: one false alarm in a thousand open-loop records
    level: float = 1e-3
    #: :attr:`~hdpbsid.core.normal_equations.NormalEquations.gram_rcond`
    gram_rcond: float = NORMAL_EQUATIONS.gram_rcond


#: the settings :func:`feedback_statistics` applies
FEEDBACK_TEST = FeedbackTest()
#: :attr:`FeedbackTest.ar_order`
AR_ORDER = FEEDBACK_TEST.ar_order
#: :attr:`FeedbackTest.lags`
FEEDBACK_LAGS = FEEDBACK_TEST.lags
#: :attr:`FeedbackTest.level`
FEEDBACK_LEVEL = FEEDBACK_TEST.level
#: :attr:`FeedbackTest.gram_rcond`
GRAM_RCOND = FEEDBACK_TEST.gram_rcond


def _prewhiten(u: Array, order: int) -> Array:
    """Least-squares AR(``order``) residuals of each column of ``u`` (mean removed);
    the first ``order`` samples are zero (:func:`lstsq_residuals`: ``w`` orthogonal to
    the ``order`` lags in the sample, as the module docstring needs)."""
    ns, m = u.shape
    w = np.zeros_like(u)
    for j in range(m):
        x = u[:, j] - u[:, j].mean()
        if ns <= 2 * order + 1:
            w[:, j] = x
            continue
        # X[k, i] = x[order - 1 + k - i]: lags 1..order of x[order:], newest first
        X = sliding_window_view(x[:-1], order)[:, ::-1]
        w[order:, j] = lstsq_residuals(X, x[order:], FEEDBACK_TEST.gram_rcond)
    return w


def feedback_statistics(
    model: StateSpaceModel | None,
    t: Any,
    u: Any,
    y: Any,
    *,
    lags: int = FEEDBACK_LAGS,
    ar_order: int = AR_ORDER,
    errors: Any = None,
) -> dict[str, Any]:
    """The closed-loop test and the residual-to-output ratio of ``model`` on ``t, u, y``.

    ``errors``: the model's one-step prediction errors on the record, ``(Ns, l)``, when
    the caller has them (the front end computes them with the refinement's compiled
    predictor, :func:`hdpbsid.refine.pem.one_step_errors`); default: from
    :meth:`~hdpbsid.models.model.StateSpaceModel.predict`.

    Returns ``{"statistic": S, "threshold": chi2 quantile, "dof": lags m l,
    "feedback": S > threshold, "residual_ratio": rho, "residual_ratio_x_samples":
    rho Ns}`` (module docstring).  Without inputs there is no feedback to test
    (``feedback=False``).  The one-step predictions use the model's detected input hold.

    Parameters
    ----------
    model : StateSpaceModel or None
        The model whose one-step prediction errors are tested; None when ``errors`` are
        given (the test needs the model only to predict).
    t, u, y : array_like
        The record (``u`` None: a time series, nothing to test).
    lags : int
        The positive lags tested (:attr:`FeedbackTest.lags`).
    ar_order : int
        The order of the input's prewhitening (:attr:`FeedbackTest.ar_order`).
    errors : array_like, optional
        The model's one-step prediction errors on the record.

    Returns
    -------
    dict
        The statistic, threshold, degrees of freedom, decision and residual ratios.

    Raises
    ------
    TypeError
        When ``model`` is not a :class:`~hdpbsid.models.model.StateSpaceModel` and no
        ``errors`` are given.
    ValueError
        When ``lags`` or ``ar_order`` is not a positive integer.
    """
    if errors is None and not isinstance(model, StateSpaceModel):
        raise TypeError(f"model must be a StateSpaceModel, got {type(model).__name__}")
    for name, v in (("lags", lags), ("ar_order", ar_order)):
        if isinstance(v, bool) or not isinstance(v, int | np.integer) or v < 1:
            raise ValueError(f"{name} must be a positive integer, got {v!r}")
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float).reshape(t.size, -1)
    u_arr = np.zeros((t.size, 0)) if u is None else np.asarray(u, dtype=float).reshape(t.size, -1)
    if errors is not None:
        e = np.asarray(errors, dtype=float).reshape(y.shape)
    else:
        hold = model.report.hold
        hold = hold if hold in ("zoh", "foh") else "zoh"
        e = y - model.predict(t, u_arr, y, k=1, method=hold)
    yc = y - y.mean(axis=0)
    py = np.sum(yc**2, axis=0)
    rho = float(np.mean(np.sum(e**2, axis=0) / np.where(py > 0, py, np.inf)))
    ns = t.size
    out: dict[str, Any] = {
        "residual_ratio": rho,
        "residual_ratio_x_samples": rho * ns,
        "lags": lags,
        "ar_order": ar_order,
    }
    m, l = u_arr.shape[1], y.shape[1]
    if m == 0 or ns <= 2 * (ar_order + lags):
        out.update(statistic=0.0, threshold=np.inf, dof=0, feedback=False)
        return out
    w = _prewhiten(u_arr, ar_order)[ar_order:]
    ec = e[ar_order:] - e[ar_order:].mean(axis=0)
    neg = -np.arange(1, lags + 1)  # R_ew(-tau) = (1/n) sum_k e_k w_{k+tau}
    stat = 0.0
    for i in range(l):
        for j in range(m):
            scale = np.sqrt(np.mean(ec[:, i] ** 2) * np.mean(w[:, j] ** 2))
            if scale > 0:
                stat += float(np.sum((correlation(ec[:, i], w[:, j], neg) / scale) ** 2))
    stat *= w.shape[0]
    dof = lags * m * l
    from scipy.stats import chi2  # here: scipy.stats is slow to import

    thr = float(chi2.ppf(1.0 - FEEDBACK_TEST.level, dof))
    out.update(statistic=stat, threshold=thr, dof=dof, feedback=bool(stat > thr))
    return out


class RefineReason(str, Enum):
    """Why ``refine="auto"`` decided as it did (:class:`RefineChoice`)."""

    #: one uniformly sampled record whose first-pass predictor runs: refined
    SINGLE_UNIFORM_RECORD = "single uniformly sampled record"
    #: the sampled predictor has one step only on uniformly sampled times
    NOT_UNIFORM = "t is not uniformly sampled"
    #: the first-pass one-step predictor diverges: no prediction-error start
    PREDICTOR_DIVERGES = "the model's one-step predictor diverges on the record"
    #: the first-pass predictor diverges, its plant simulates the record with no sign of
    #: feedback: refined from that plant with a measurement-noise predictor
    PLANT_START = (
        "the model's one-step predictor diverges on the record, its plant's simulation "
        "errors show no feedback"
    )


@dataclass(frozen=True)
class RefineChoice:
    """The ``refine="auto"`` decision for one record: whether the first-pass model is
    refined, the typed reason, and the feedback test it reports.

    Attributes
    ----------
    value : bool
        Whether the model is refined.
    reason : RefineReason
        Why.
    statistics : dict or None
        :func:`feedback_statistics` of the first-pass model on the record (None: not
        computed).

    Examples
    --------
    >>> RefineChoice(False, RefineReason.NOT_UNIFORM).text()
    'auto: t is not uniformly sampled, no refinement'
    """

    value: bool
    reason: RefineReason
    statistics: dict[str, Any] | None = None

    def text(self) -> str:
        """The rule's text (``options["refine_rule"]``).

        Returns
        -------
        str
            The decision, its reason and, when refined, the feedback test.
        """
        if self.reason is RefineReason.NOT_UNIFORM:
            return f"auto: {self.reason.value}, no refinement"
        if self.reason is RefineReason.PREDICTOR_DIVERGES or self.statistics is None:
            return f"auto: {self.reason.value}"
        st = self.statistics
        loop = "closed" if st["feedback"] else "open"
        test = (
            f"(chi2 of the residuals against the prewhitened input at lags 1..{st['lags']}): "
            f"S = {st['statistic']:.4g} vs {st['threshold']:.4g}, {loop} loop"
        )
        if self.reason is RefineReason.PLANT_START:
            return (
                f"auto: {self.reason.value} {test}: refined from its plant with the Kalman "
                "gain of a measurement-noise model"
            )
        return (
            f"auto: refine every single uniformly sampled record (the prediction-error "
            f"estimate is efficient, and consistent in closed loop); feedback test {test}: "
            "refined"
        )


def decide_refine(
    model: StateSpaceModel, t: Any, u: Any, y: Any, uniform: bool, errors: Any = None
) -> RefineChoice:
    """The ``refine="auto"`` rule (module docstring) for ``model`` identified from the
    single record ``t, u, y``.

    Refined when ``t`` is uniformly sampled (the sampled predictor has one step) and the
    model's one-step predictor does not diverge on the record (a start whose prediction
    errors overflow is not a prediction-error start); the feedback test does not change
    the decision, it says whether the refinement also removes a closed-loop bias.

    Parameters
    ----------
    model : StateSpaceModel
        The first-pass model.
    t, u, y : array_like
        The record it was identified from.
    uniform : bool
        Whether ``t`` is uniformly sampled.
    errors : array_like, optional
        ``model``'s one-step prediction errors, as in :func:`feedback_statistics`.

    Returns
    -------
    RefineChoice
        The decision, its typed reason and the feedback test.
    """
    if not uniform:
        return RefineChoice(False, RefineReason.NOT_UNIFORM)
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            st = feedback_statistics(model, t, u, y, errors=errors)
    except np.linalg.LinAlgError:
        # the model's one-step predictor diverges on the record (its residuals overflow):
        # the test cannot be computed, and a refinement started there is not a PEM start
        return RefineChoice(False, RefineReason.PREDICTOR_DIVERGES)
    return RefineChoice(True, RefineReason.SINGLE_UNIFORM_RECORD, st)


def refine_decision(
    model: StateSpaceModel, t: Any, u: Any, y: Any, uniform: bool, errors: Any = None
) -> tuple[bool, str, dict[str, Any] | None]:
    """Whether ``refine="auto"`` refines ``model`` identified from the single record
    ``t, u, y`` (:func:`decide_refine`), as a tuple.

    Parameters
    ----------
    model : StateSpaceModel
        The first-pass model.
    t, u, y : array_like
        The record it was identified from.
    uniform : bool
        Whether ``t`` is uniformly sampled.
    errors : array_like, optional
        ``model``'s one-step prediction errors, as in :func:`feedback_statistics`.

    Returns
    -------
    tuple
        ``(refine, rule text, statistics or None)``.
    """
    choice = decide_refine(model, t, u, y, uniform, errors=errors)
    return choice.value, choice.text(), choice.statistics


def plant_decision(model: StateSpaceModel, t: Any, u: Any, y: Any) -> RefineChoice:
    """The ``refine="auto"`` decision for a first-pass model whose one-step predictor
    diverges on the uniformly sampled record ``t, u, y``, judged on its plant alone.

    The refinement starts from the model's ``K`` only where that predictor is stable, and
    also from the same plant with the Kalman gain of a measurement-noise model, which is
    stable by construction (:mod:`hdpbsid.refine.pem`): a diverging predictor rules out
    the first start, not the second.  What it does rule out is the feedback test on the
    model's one-step errors; the test is computed on the plant's simulation errors
    (``K = 0``), valid however coloured they are (module docstring).  Refined
    (:attr:`RefineReason.PLANT_START`) when that test finds no feedback: in open loop
    the prediction-error estimate is consistent from any start in its basin, and the
    basis-domain plant is consistent too.  Not refined
    (:attr:`RefineReason.PREDICTOR_DIVERGES`) when the plant itself diverges on the
    record or the test fires: in closed loop the basis-domain plant can be biased far
    from the system (:func:`refine_plan` asks the ``dt`` model first).

    Parameters
    ----------
    model : StateSpaceModel
        The first-pass model.
    t, u, y : array_like
        The single uniformly sampled record it was identified from.

    Returns
    -------
    RefineChoice
        The decision, with the plant's feedback test when it was computed.

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> rng = np.random.default_rng(0)
    >>> t = 0.1 * np.arange(2000)
    >>> u = rng.standard_normal((2000, 1))
    >>> true = StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]])
    >>> y = true.simulate(t, u) + 0.01 * rng.standard_normal((2000, 1))
    >>> noisy = StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[-50.0]])
    >>> plant_decision(noisy, t, u, y).reason.name
    'PLANT_START'
    """
    plant = dataclasses.replace(model, K=np.zeros_like(model.K))
    st = decide_refine(plant, t, u, y, True).statistics  # None: the plant diverges too
    if st is None or st["feedback"]:
        return RefineChoice(False, RefineReason.PREDICTOR_DIVERGES, st)
    return RefineChoice(True, RefineReason.PLANT_START, st)


#: the method whose model is offered as a further starting point in closed loop
#: (:func:`closed_loop_start`): PBSID on the samples, consistent in closed loop
CLOSED_LOOP_START_METHOD = "dt"
#: that start's name in the refined model's ``options["refine_start"]``
CLOSED_LOOP_START_NAME = "dt model (closed loop: consistent under feedback)"


def refine_plan(
    model: StateSpaceModel, t: Any, u: Any, y: Any, uniform: bool, errors: Any = None
) -> tuple[bool, str, dict[str, Any] | None, StateSpaceModel]:
    """:func:`refine_decision`, and the model the refinement starts from:
    ``(refine, rule text, statistics or None, start)``.

    ``start`` is ``model`` offering the ``dt`` model as a further starting point when the
    record is closed loop (:func:`closed_loop_start`).  A first-pass model whose one-step
    predictor diverges is no prediction-error start (:func:`refine_decision`).  In closed
    loop that is what a basis-domain estimate biased far from the system looks like, so
    the ``dt`` model is fitted and tested first: when its residuals show feedback, the
    record is refined from it (the decision and statistics are the ``dt`` model's, the
    rule says so).  Otherwise the first pass's plant may still be a start: when its
    simulation errors show no feedback either (:func:`plant_decision`), the record is
    refined from that plant with the measurement-noise Kalman gain (the refinement's own
    second start; the decision and statistics are the plant's).  The ``dt`` test comes
    first because its model is consistent in closed loop, so its residuals are nearly
    white and its test sharp, while a biased plant's simulation errors carry its bias:
    on the closed-loop fast-mode records the plant test alone missed loops the ``dt``
    test finds, and the refinement from the biased plant ended in other minima.

    Parameters
    ----------
    model : StateSpaceModel
        The first-pass model.
    t, u, y : array_like
        The single record it was identified from (the front end's detrended signals).
    uniform : bool
        Whether ``t`` is uniformly sampled.
    errors : array_like, optional
        ``model``'s one-step prediction errors, as in :func:`feedback_statistics`.

    Returns
    -------
    tuple
        ``(refine, rule, statistics, start)``.
    """
    do, rule, stats = refine_decision(model, t, u, y, uniform, errors=errors)
    if do:
        return do, rule, stats, closed_loop_start(model, t, u, y, stats)
    if stats is not None or not uniform or u is None or model.m == 0:
        return do, rule, stats, model
    start = _closed_loop_model(model, t, u, y)
    stats_dt = None if start is None else refine_decision(start, t, u, y, uniform)[2]
    if stats_dt is not None and stats_dt["feedback"]:
        rule = (
            f"{rule}; the dt model of order {model.n} shows feedback (chi2 of its residuals "
            f"against the prewhitened input: S = {stats_dt['statistic']:.4g} vs "
            f"{stats_dt['threshold']:.4g}), closed loop: refined, from it as well"
        )
        return True, rule, stats_dt, _offer(model, start)
    plant = plant_decision(model, t, u, y)
    if plant.value:
        return True, plant.text(), plant.statistics, model
    return do, rule, stats, model


def closed_loop_start(
    model: StateSpaceModel, t: Any, u: Any, y: Any, statistics: dict[str, Any] | None
) -> StateSpaceModel:
    """``model``, offering the refinement a closed-loop-consistent starting point when
    the feedback test (``statistics`` of :func:`feedback_statistics`) found feedback.

    Why.  In closed loop the basis-domain least squares is biased (module docstring),
    and the bias is not small when the loop is fast against the modes: the start can then
    lie far from the prediction-error minimum, where Levenberg-Marquardt either runs out
    of its evaluation budget (and the front end keeps the biased start) or stops at
    another local minimum.  PBSID on the samples (``method="dt"``) is consistent in closed
    loop (Chiuso, Automatica 43 (2007); the predictor form removes the feedback's
    correlation), so its model is near the minimum on a long enough record.  It is
    offered as the refinement's warm start (``report.warm_start``) at
    the model's order and direct term; the refinement's screen fits the most promising
    start first (:func:`hdpbsid.refine.pem.refine_pem`), so a start that is not better
    costs one evaluation.  Nothing changes in open loop (the basis estimate is consistent
    there), for a ``dt`` model (one whose past window was kept from its held-out
    candidate gets the record's own ``dt`` model only when its refinement falls short:
    :func:`retry_start`), or when a warm start is already offered (``method="auto"``
    passes its own).  The ``dt`` model carries no input hold into the offer: no
    prediction-error fit chose one.

    Parameters
    ----------
    model : StateSpaceModel
        The first-pass model the refinement starts from.
    t, u, y : array_like
        The record it was identified from (the front end's detrended signals).
    statistics : dict or None
        :func:`feedback_statistics` of ``model`` on the record (None: not computed).

    Returns
    -------
    StateSpaceModel
        ``model`` itself when nothing is offered (also when ``dt`` cannot fit the
        record), else a copy with ``report.warm_start`` set (the ``warm_start`` its
        caller passes to :func:`~hdpbsid.refine.pem.refine_pem`).
    """
    if not _closed_loop_with_input(model, u, statistics):
        return model
    if model.report.method == CLOSED_LOOP_START_METHOD or model.report.warm_start is not None:
        return model
    start = _closed_loop_model(model, t, u, y)
    return model if start is None else _offer(model, start)


def _closed_loop_with_input(
    model: StateSpaceModel, u: Any, statistics: dict[str, Any] | None
) -> bool:
    """Whether the feedback test (``statistics``) found the record closed loop and
    ``model`` has an input: where a ``dt`` start is offered at all."""
    return bool(statistics and statistics.get("feedback")) and u is not None and model.m > 0


def retry_start(
    model: StateSpaceModel, t: Any, u: Any, y: Any, statistics: dict[str, Any] | None
) -> StateSpaceModel | None:
    """A second starting point for the refinement of ``model`` when the first did not
    converge: the record's own ``dt`` model (its past window chosen by its criterion on
    the whole record), when ``model`` is a ``dt`` model whose window was chosen on part
    of the record -- refitted with the window its held-out candidate chose
    (:attr:`~hdpbsid.bases.basis_core.WindowReason.KEPT`), or that candidate itself,
    returned when no refit held (``report.selection_fallback``) -- and the feedback test
    found the record closed loop; else None.

    Why.  PBSID on the samples is consistent in closed loop only as far as its past
    window covers the predictor's memory (:func:`closed_loop_start`); the window
    criterion takes longer windows on longer records, so the window chosen on two
    thirds of the record can be short for the whole of it, and its truncation can leave
    the start far from the minimum, where the refinement runs out of its budget.  The
    held-out selection's refit chooses the window on the whole record when its feedback
    test sees the loop (:func:`~hdpbsid.selection.candidates.closed_loop_refit`); a
    window chosen on part of the record reaches the refinement of a closed-loop record
    when no refit held (the candidate itself) or when that test, on the candidate's
    errors, did not see the loop the first-pass model's test sees.  Fitted only when
    the refinement falls short: where it converges, nothing is spent.

    Parameters
    ----------
    model : StateSpaceModel
        The first-pass model the refinement started from.
    t, u, y : array_like
        The record (the front end's detrended signals).
    statistics : dict or None
        :func:`feedback_statistics` of ``model`` on the record.

    Returns
    -------
    StateSpaceModel or None
        The ``dt`` model to refine from, or None.
    """
    if not _closed_loop_with_input(model, u, statistics):
        return None
    window = model.report.past_window
    kept = window is not None and window.rule is WindowReason.KEPT
    if model.report.method != CLOSED_LOOP_START_METHOD or not (
        kept or model.report.selection_fallback
    ):
        return None
    return _closed_loop_model(model, t, u, y)


def retried(
    start: StateSpaceModel, refined: StateSpaceModel, t: Any, u: Any, y: Any, stats: Any
) -> tuple[StateSpaceModel, str]:
    """``refined`` (the prediction-error refinement of ``start`` on the record ``t, u,
    y``), or the refinement from a second start when the one from ``start`` ran out of
    its budget and the record offers one (:func:`retry_start`; ``stats`` the feedback
    test's), and the note for the refinement's rule.  The second is taken only when it
    converges: a minimum of the cost is the consistent estimate, an iterate cut off on
    its way is not.

    Parameters
    ----------
    start : StateSpaceModel
        The model the refinement started from.
    refined : StateSpaceModel
        Its refinement (:func:`hdpbsid.refine.pem.refine_pem`).
    t, u, y : array_like
        The record (the front end's detrended signals).
    stats : dict or None
        :func:`feedback_statistics` of ``start`` on the record.

    Returns
    -------
    tuple of (StateSpaceModel, str)
        The refined model kept and what the rule adds (``""`` when ``refined``).
    """
    from hdpbsid.refine.pem import refine_pem

    fit = refined.report.refinement
    if fit is None or fit.converged:
        return refined, ""
    other = retry_start(start, t, u, y, stats)
    if other is None:
        return refined, ""
    again = refine_pem(_in_place_of(start, other), t, u, y)
    if again.report.refinement is None or not again.report.refinement.converged:
        return refined, ""
    return again, (
        "; the refinement from the dt model whose past window was chosen on part of "
        "the record did not converge: refined from the dt model with its window chosen "
        "on the whole record, which converged"
    )


def _in_place_of(start: StateSpaceModel, other: StateSpaceModel) -> StateSpaceModel:
    """``other``'s matrices and windows with ``start``'s options and report otherwise
    (what the selection decided and why stays with the model returned), as a model
    fitted on the whole record (no selection fallback)."""
    report = start.report.but(windows=other.report.windows, past_window=None, selection_fallback="")
    options = {k: v for k, v in start.options.items() if k != "selection_fallback"}
    options.update(other.report.windows)
    return dataclasses.replace(
        start, A=other.A, B=other.B, C=other.C, D=other.D, K=other.K, options=options,
        report=report,
    )  # fmt: skip


def _closed_loop_model(model: StateSpaceModel, t: Any, u: Any, y: Any) -> StateSpaceModel | None:
    """The ``dt`` model of ``model``'s order and direct term on the record, or None when
    it cannot be fitted (no continuous-time model of that order) or differs in shape."""
    from hdpbsid.data.records import Dataset
    from hdpbsid.methods.registry import call_method, get_method

    feedthrough = model.report.feedthrough is not None and model.report.feedthrough.estimated
    func, data = get_method(CLOSED_LOOP_START_METHOD), functools.partial(Dataset.of, t, u, y)
    try:
        with np.errstate(all="ignore"):
            start = call_method(func, (t, u, y), data, order=model.n, feedthrough=feedthrough)
    except (ValueError, np.linalg.LinAlgError):
        return None
    return start if (start.n, start.m, start.l) == (model.n, model.m, model.l) else None


def _offer(model: StateSpaceModel, start: StateSpaceModel) -> StateSpaceModel:
    """A copy of ``model`` offering ``start`` as the refinement's warm start."""
    offered = copy.copy(model)
    offered.options = dict(model.options)
    offered.report = model.report.but(warm_start=WarmStart.of(start, None, CLOSED_LOOP_START_NAME))
    return offered
