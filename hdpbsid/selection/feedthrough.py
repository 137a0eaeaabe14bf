"""``feedthrough="auto"`` (the default of :func:`hdpbsid.identify`): whether the model has
a direct term ``D``, decided from the data.

The direct term is a structural choice like the order, and it is judged on the same
held-out part (:mod:`hdpbsid.selection.auto`), in two steps.

Whether ``D`` is offered (:func:`feedthrough_offered`).  ``D`` is identifiable from
``(u, y)`` when ``u_k`` does not depend on the innovation ``e_k`` of ``y_k``: in open loop,
and in a loop whose controller has at least one sample of delay (``u_k`` computed from
``y_{k-1}, y_{k-2}, ...``).  With a controller that reacts to ``y_k`` within the sample
it is not: a free ``D`` then lets ``D u_k`` predict ``e_k`` through the controller
(Ljung, *System Identification*, 2nd ed., sec. 13.4; Forssell & Ljung, "Closed-loop
identification revisited", Automatica 35(7), 1999).  No test on ``(u, y)`` alone tells
the two lag-0 paths apart: both appear only as a correlation of the innovations of
``u_k`` and ``y_k`` at lag 0, which is symmetric ("instantaneous causality" has no
direction: Geweke, JASA 77 (1982), sec. 2; Lutkepohl, *New Introduction to Multiple
Time Series Analysis*, 2005, sec. 2.3.1), so a regression of ``u_k`` on ``y_k`` fires for
a direct term in open loop as well.  What the data do tell:

* whether there is a loop at all, by the feedback test at positive lags
  (:func:`hdpbsid.selection.feedback.feedback_statistics`, on the residuals of a strictly
  causal ARX predictor, :func:`arx_residuals`).  In open loop only the plant links
  ``u_k`` to ``y_k``: ``D`` is offered;
* in closed loop, how much a controller's instantaneous path can imitate a direct term.
  Let ``v`` be white output noise (variance ``s_v^2``) and ``u_k = -F y_k + ...`` a
  controller reacting within the sample, with no direct term in the plant.  A model's
  simulated output is ``y_k = G(past u) + D u_k``; the ``D`` that best simulates ``y``
  (the output-error fit, which the prediction-error fit is with white output noise) is
  ``D_oe = cov(v_k, a_k) / var(a_k)``, ``a_k`` the part of ``u_k`` that the model's
  other regressors (past inputs) do not explain, and it lowers the mean squared
  simulation error ``s_v^2`` by the share ``cov(v_k, a_k)^2 / (s_v^2 var(a_k))``.  Now
  ``u_k`` meets ``v_k`` only through ``-F v_k``, which neither past ``u`` nor past ``y``
  predicts: it is part of the innovation ``w_k`` of ``u_k`` given past ``u`` *and*
  ``y``, so ``cov(v_k, a_k)^2 = F^2 s_v^4 <= s_v^2 var(w)``; and ``var(a_k) >=
  var(w^u)``, the innovation of ``u_k`` given its own past only.  So the share is at
  most ``var(w) / var(w^u)`` (:func:`controller_share`; model errors in the candidate
  without ``D`` only enlarge the denominator), while a real direct term lowers the
  error by ``D^2 var(a_k)``, whatever the controller.  In closed loop ``D`` must
  therefore lower the held-out simulation error by a larger share
  (:func:`feedthrough_offered` returns it, :func:`judge_direct_term` applies it).  The
  stronger the loop, the more of the input the past outputs predict and the smaller
  the share; with weak feedback it nears 1 and only a direct term that dominates the
  noise is told from a controller's path -- the data cannot do better, and
  ``feedthrough=True`` is the user's statement that the loop has at least one sample
  of delay.

What tells ``D`` at all is the innovation ``w_k`` of ``u_k`` given past ``u`` and ``y``:
in the one-step predictor ``yhat_k = f(past) + D u_k`` the part of ``u_k`` that the past
predicts makes ``D u_k`` a function of the past, which dynamics can give as well.  Two
cases follow (:func:`feedthrough_offered`):

* ``w`` is a part of ``u``'s variance (:func:`input_innovation`): ``D = 0`` predicts the
  innovation ``e_k`` of ``y_k`` no worse than any ``D`` unless ``e_k`` and ``w_k`` are
  linked at lag 0 -- by a direct term or by a controller reacting within the sample.
  Bartlett's test of their independence (:func:`lag0_link`, the score test of
  ``D = 0`` on model-free innovations) screens: without a link no candidate with ``D``
  is fitted (it could only win by chance, and it costs a sweep);
* ``u`` is deterministic to working precision (a sum of sinusoids, a sweep, or a loop
  whose reference is one; the share below
  :attr:`FeedthroughPolicy.innovation_floor`): ``D`` is identified only through the
  model structure -- a ``D`` and a fast mode or a controller's state are alternatives
  of one model class -- and the one-step criterion has no power of its own on it.  The
  candidates are offered (a plant with a large direct term is still told: its models
  without ``D`` fail), and besides the tests above ``D`` must lower the held-out
  simulation error by more than half -- the structure without it *much worse*, by the
  ratio (:attr:`~hdpbsid.selection.policy.SelectionPolicy.much_worse_ratio`, 2) that
  the held-out selection resolves whatever the spread of its windows.  A paired test
  of a few standard errors is no evidence here: it measures how two structures fit the
  one input the record has, not a parameter the input identifies, and a model told
  from a sweep is used on other inputs.

How ``D`` is chosen (:func:`judge_direct_term`, :class:`FeedthroughChoice`).  The best
candidates with and without ``D`` (each chosen among its own structure's orders and
methods by the one-standard-error rule) are compared on the held-out part by the
windowed one-step prediction error **and** the windowed simulation error, paired over
the same windows: ``D`` is estimated only when it is better on the one-step error by
more than :data:`FEEDTHROUGH_Z` standard errors of the paired difference and on the
simulation error by more than :data:`SIMULATION_Z` (:func:`paired_z`, on the per-window
log ratios; the per-window losses are batch means of the per-sample losses, nearly
independent between windows: Law & Kelton, *Simulation Modeling and Analysis*, 3rd
ed., sec. 9.5.3), and when its
simulation over the whole held-out part from one initial state is not worse either (the
errors slower than a window, :func:`hdpbsid.selection.auto.break_tie`).  The one-step
criterion alone admits a ``D`` that predicts noise (in open loop on a short record, by
chance; in closed loop, through the controller); the simulation criterion alone is
biased in closed loop (:mod:`hdpbsid.selection.auto`); a direct term that is there
improves both.  The burden of proof is on the extra parameters, as on an extra state.

Where the feedback test cannot be computed (non-uniform samples, no input, several
records, a diverging predictor) no ``D`` is offered.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from enum import Enum
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from hdpbsid.core.normal_equations import lstsq_residuals
from hdpbsid.data.checks import is_uniform
from hdpbsid.models.criteria import (
    WindowedError,
    windowed_prediction_error,
    windowed_simulation_error,
)
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import DirectTerm
from hdpbsid.selection.policy import MUCH_WORSE_RATIO

if TYPE_CHECKING:  # the candidates import this rule; the type is for annotations only
    from hdpbsid.selection.candidates import CandidateRow

__all__ = [
    "FEEDTHROUGH_CHOICES",
    "FeedthroughPolicy",
    "FEEDTHROUGH_POLICY",
    "FEEDTHROUGH_Z",
    "SIMULATION_Z",
    "FeedthroughReason",
    "FeedthroughChoice",
    "controller_share",
    "paired_z",
    "judge_direct_term",
    "check_feedthrough",
    "honours_feedthrough",
    "without_own_d",
    "with_d_asked",
    "feedthrough_offered",
    "Offer",
    "input_innovation",
    "lag0_link",
    "structure_key",
    "with_d",
    "arx_residuals",
    "arx_innovations",
    "takes_feedthrough",
]

#: the values of ``feedthrough=``: estimate ``D``, keep ``D = 0``, or decide from the data
FEEDTHROUGH_CHOICES = (True, False, "auto")


@dataclass(frozen=True)
class FeedthroughPolicy:
    """The margins by which the candidate with ``D`` must beat the one without
    (:func:`judge_direct_term`), in standard errors of the paired held-out difference.

    The one-step prediction error decides: three standard errors, a one-sided
    false-alarm probability of about 0.13 % for nearly normal batch means.  Not two: the
    rule runs on every record a user identifies, nearly all without a direct term, and a
    spurious ``D`` makes a closed-loop model worse (the refinement then frees it); a
    direct term that is there wins by far more (its log ratios are large in every
    window).  The simulation error confirms, at the conventional two standard errors
    (about 2.3 %): it is biased in closed loop (:mod:`hdpbsid.selection.auto`) and, with
    its initial state fitted per window, blind to slow errors, so it is asked to agree
    beyond its noise, not to decide; the whole held-out simulation and, in closed loop,
    the controller bound check it further.

    Attributes
    ----------
    z_prediction : float
        The margin on the windowed one-step prediction error.
    z_simulation : float
        The margin on the windowed simulation error.
    innovation_floor : float
        The share of the input's variance left unpredicted by its own and the output's
        past at or below which the input is deterministic (:func:`input_innovation`):
        ``D`` must then halve the simulation error (module docstring).
    link_level : float
        The false-alarm probability of the lag-0 screen (:func:`lag0_link`).
    linear_hold_level : float
        The false-alarm probability of the likelihood-ratio test of the linear hold
        without ``D`` against the held input with ``D``
        (:func:`hdpbsid.selection.direct_term.linear_hold_or_direct_term`).

    Examples
    --------
    >>> FeedthroughPolicy().z_prediction
    3.0
    """

    #: the criterion that decides: a one-sided false alarm of about 0.13 %
    z_prediction: float = 3.0
    #: the criterion that confirms: the conventional two standard errors (about 2.3 %)
    z_simulation: float = 2.0
    #: an input whose innovation share is below ``sqrt(eps)`` (a residual RMS under
    #: 1.2e-4 of the input's) is deterministic to working precision: rounding leaves
    #: shares near ``eps``, an input with a random component at its sample rate keeps
    #: one of order ``h_0^2 / sum h_j^2`` of its shaping filter, far above
    innovation_floor: float = float(np.sqrt(np.finfo(float).eps))
    #: the lag-0 screen's false-alarm probability: a false alarm costs the fits with
    #: ``D`` and nothing else (the judgement decides); one in a hundred
    link_level: float = 0.01
    #: the level of the lag-0 screen that offered ``D``: the smaller structure is
    #: rejected on the evidence the larger one was admitted on
    linear_hold_level: float = 0.01


#: the policy ``feedthrough="auto"`` applies
FEEDTHROUGH_POLICY = FeedthroughPolicy()
#: the margin on the one-step prediction error (:attr:`FeedthroughPolicy.z_prediction`)
FEEDTHROUGH_Z = FEEDTHROUGH_POLICY.z_prediction
#: the margin on the simulation error (:attr:`FeedthroughPolicy.z_simulation`)
SIMULATION_Z = FEEDTHROUGH_POLICY.z_simulation


class FeedthroughReason(str, Enum):
    """Why ``feedthrough="auto"`` decided as it did (:class:`FeedthroughChoice`)."""

    #: the candidate with ``D`` won on every criterion
    WON = "won"
    #: no better by the stated margin on the one-step prediction error
    LOST_PREDICTION = "lost on the one-step prediction error"
    #: no better by the stated margin on the windowed simulation error
    LOST_SIMULATION = "lost on the simulation error"
    #: worse on the simulation of the whole held-out part from one initial state
    LOST_WHOLE_SIMULATION = "lost on the whole held-out simulation"
    #: closed loop: the simulation improved by no more than a controller's
    #: instantaneous path can give (module docstring)
    WITHIN_CONTROLLER_BOUND = "no larger than a controller reacting within the sample could give"
    #: deterministic input: the structure with ``D`` did not halve the simulation error
    NOT_IDENTIFIED = "deterministic input, and the simulation error not halved by D"
    #: not offered (no input, several records, not testable)
    NOT_OFFERED = "not offered"
    #: one of the two candidates could not be fitted or scored
    NO_CANDIDATE = "no candidate"


@dataclass(frozen=True)
class FeedthroughChoice:
    """The direct-term decision and its reason (reported in
    ``options["feedthrough_rule"]``).

    Parameters
    ----------
    value : bool
        Whether ``D`` is estimated.
    reason : FeedthroughReason
        Why (typed).
    z_prediction, z_simulation : float or None
        How many standard errors of the paired difference the candidate with ``D`` is
        better by (positive: better) on the held-out one-step prediction and windowed
        simulation errors; ``None`` where not compared.
    whole_simulation : tuple of float or None
        The whole-held-out simulation errors ``(without D, with D)``.
    gain, bound : float or None
        The relative improvement of the windowed simulation error by ``D``, and the
        largest a controller's instantaneous path could give (0 in open loop).
    min_gain : float
        The improvement asked for whatever the loop (a deterministic input), else 0.
    """

    value: bool
    reason: FeedthroughReason
    z_prediction: float | None = None
    z_simulation: float | None = None
    whole_simulation: tuple[float, float] | None = None
    gain: float | None = None
    bound: float | None = None
    min_gain: float = 0.0

    def text(self) -> str:
        """One line for the report: the decision, the reason and the statistics.

        Returns
        -------
        str
            The line, e.g. ``"D = 0 (lost on the one-step prediction error; ...)"``.
        """
        out = f"{'D estimated' if self.value else 'D = 0'} ({self.reason.value}"
        if self.z_prediction is not None and self.z_simulation is not None:
            out += (
                f"; with D better by {self.z_prediction:.2f} standard errors on the one-step "
                f"prediction, {self.z_simulation:.2f} on the simulation; needs more than "
                f"{FEEDTHROUGH_Z:g} and {SIMULATION_Z:g}"
            )
        if self.gain is not None and self.bound:
            out += (
                f"; simulation error {100 * self.gain:.3g} % lower with D, needs more than "
                f"{100 * self.bound:.3g} % in closed loop"
            )
        if self.gain is not None and self.min_gain:
            out += (
                f"; simulation error {100 * self.gain:.3g} % lower with D, needs more than "
                f"{100 * self.min_gain:.3g} % with a deterministic input"
            )
        if self.whole_simulation is not None:
            out += (
                f"; whole held-out simulation error {self.whole_simulation[0]:.4g} without D, "
                f"{self.whole_simulation[1]:.4g} with D"
            )
        return out + ")"


def paired_z(without: WindowedError, with_: WindowedError) -> float:
    """How many standard errors ``with_`` is better than ``without`` on the same windows:
    the paired t statistic ``mean(d) / (std(d) / sqrt(W))`` of the per-window log ratios
    ``d_w = log(a_w / b_w)`` (positive: ``with_`` better).  Paired, because the two share
    each window's noise; on logs, because a window's error is a sum of squares whose
    spread grows with its size, so the windows with the most output energy (or where a
    poor model is worst) would otherwise dominate the mean and the spread alike (the
    log is the variance-stabilising transform of a scaled chi-square, and ``log(a_w /
    b_w)`` is the per-window F statistic on the log scale).  ``-inf`` when ``with_`` is
    not finite, ``inf`` when only ``without`` is not; with one window or no spread the
    sign of the mean times ``inf`` (or 0).

    Parameters
    ----------
    without : WindowedError
        The held-out score of the candidate without ``D``.
    with_ : WindowedError
        The held-out score of the candidate with ``D``, on the same windows.

    Returns
    -------
    float
        The paired statistic (positive: ``with_`` better).

    Examples
    --------
    >>> import numpy as np
    >>> a = WindowedError(np.array([1.0, 1.2, 0.9, 1.1]), 4.2, 0.0, True)
    >>> b = WindowedError(np.array([0.5, 0.8, 0.4, 0.5]), 2.2, 0.0, True)
    >>> round(paired_z(a, b), 2)
    7.23
    """
    if not with_.finite:
        return -np.inf
    if not without.finite:
        return np.inf
    tiny = np.finfo(float).tiny
    a = np.maximum(np.asarray(without.per_window, dtype=float), tiny)
    b = np.maximum(np.asarray(with_.per_window, dtype=float), tiny)
    with np.errstate(all="ignore"):
        d = np.log(a) - np.log(b)
    if not np.all(np.isfinite(d)):
        return float(np.sign(np.sum(np.sign(d))) * np.inf)
    mean = float(np.mean(d))
    sd = float(np.std(d, ddof=1)) if d.size > 1 else 0.0
    if sd <= 0.0:
        return float(np.sign(mean) * np.inf) if mean != 0 else 0.0
    return float(mean / (sd / np.sqrt(d.size)))


def judge_direct_term(
    without: StateSpaceModel,
    with_: StateSpaceModel,
    scores: tuple[WindowedError, WindowedError],
    val: tuple,
    windows: int,
    z: float = FEEDTHROUGH_Z,
    bound: float = 0.0,
    z_simulation: float = SIMULATION_Z,
    min_gain: float = 0.0,
) -> FeedthroughChoice:
    """Whether the candidate ``with_`` (``D`` estimated) replaces ``without`` (``D = 0``):
    better on the held-out record ``val = (t, u, y)`` by more than ``z`` standard errors
    of the paired difference on the windowed one-step prediction error (each model's
    predictor with its ``K``; where one of them does not run, or the samples are not
    uniform, on ``scores``, the selection's scores of :func:`hdpbsid.selection.auto.
    score_model`), by more than ``z_simulation`` on the windowed simulation error over
    ``windows`` windows, and no
    worse on the simulation of the whole held-out part from one initial state (module
    docstring), and in closed loop lower the
    windowed simulation error by a larger share than ``bound``.  The whole simulation of
    an unstable plant's model diverges whatever its fit: there the check is passed only
    when the candidate without ``D`` diverges as well (or further), so a ``D`` is then
    estimated only against a model that cannot simulate the record either.

    Parameters
    ----------
    without, with_ : StateSpaceModel
        The candidates without and with ``D``, fitted on the estimation part.
    scores : tuple of WindowedError
        Their held-out one-step scores ``(without, with_)`` on the same windows.
    val : tuple
        The held-out record ``(t, u, y)`` (checked arrays).
    windows : int
        The windows of ``scores``.
    z : float
        The margin on the one-step prediction error, in standard errors
        (:data:`FEEDTHROUGH_Z`).
    bound : float
        The share by which ``D`` must lower the windowed simulation error: in closed loop
        the most a controller's instantaneous path could give (:func:`feedthrough_offered`);
        0 in open loop.
    z_simulation : float
        The margin on the windowed simulation error (:data:`SIMULATION_Z`).
    min_gain : float
        The share by which ``D`` must lower the windowed simulation error whatever the
        loop: with a deterministic input, ``1 - 1 / much_worse_ratio``
        (:func:`feedthrough_offered`); else 0.

    Returns
    -------
    FeedthroughChoice
        The decision, its typed reason and the statistics.
    """
    t, u, y = val
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore")
        preds = (
            [windowed_prediction_error(m, t, u, y, windows) for m in (without, with_)]
            if is_uniform(t)
            else []
        )
        sims = [windowed_simulation_error(m, t, u, y, windows) for m in (without, with_)]
        whole = [windowed_simulation_error(m, t, u, y, 1) for m in (without, with_)]
    z_sim = paired_z(*sims)
    # the one-step criterion proper (with each model's K) where both predictors run;
    # else the selection's scores, which fall back to the simulation for a bad K
    z_pred = paired_z(*preds) if preds and all(p.finite for p in preds) else paired_z(*scores)
    wh = (float(whole[0].total), float(whole[1].total))
    gain = 1.0 - sims[1].total / sims[0].total if sims[0].total > 0 else 0.0
    whole_kept = whole[1].finite and (not whole[0].finite or wh[1] <= wh[0])
    # the tests in the order the module docstring gives them; the first failed one says why
    tests = (
        (z_pred > z, FeedthroughReason.LOST_PREDICTION),
        (z_sim > z_simulation, FeedthroughReason.LOST_SIMULATION),
        (whole_kept, FeedthroughReason.LOST_WHOLE_SIMULATION),
        (gain > bound, FeedthroughReason.WITHIN_CONTROLLER_BOUND),
        (gain > min_gain, FeedthroughReason.NOT_IDENTIFIED),
    )
    reason = next((why for passed, why in tests if not passed), FeedthroughReason.WON)
    won = reason is FeedthroughReason.WON
    return FeedthroughChoice(
        won, reason, z_pred, z_sim, wh, float(gain), float(bound), float(min_gain)
    )


def controller_share(u: Any, y: Any, lags: int) -> float:
    """``var(w) / var(w^u)``, the largest share of the simulation error that a
    controller reacting within the sample can let a free ``D`` explain (module
    docstring): ``w`` the residuals of the least-squares VARX of ``u_k`` on ``u`` and
    ``y`` at lags ``1..lags``, ``w^u`` those of the AR of ``u_k`` on its own lags
    ``1..lags``; the largest over the input channels, at most 1.  ``1`` for a channel the
    AR already predicts exactly (nothing is left to tell the paths apart).

    Parameters
    ----------
    u : array_like
        The inputs, ``(Ns, m)``.
    y : array_like
        The outputs, ``(Ns, l)``.
    lags : int
        The lags of the two regressions.

    Returns
    -------
    float
        The share, in ``(0, 1]``.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> y = rng.standard_normal((4000, 1))
    >>> u = np.r_[0.0, y[:-1, 0]][:, None] + 0.1 * rng.standard_normal((4000, 1))
    >>> round(controller_share(u, y, 4), 2)  # u_k = y_{k-1} + small: past y predicts u
    0.01
    >>> round(controller_share(rng.standard_normal((4000, 1)), y, 4), 1)  # open loop
    1.0
    """
    u = np.asarray(u, dtype=float)
    w = arx_residuals(y, u, lags)[lags:]  # u_k from its own and y's past
    wu = arx_residuals(np.zeros((u.shape[0], 0)), u, lags)[lags:]  # from its own past
    shares = []
    for j in range(u.shape[1]):
        den = float(np.sum(wu[:, j] ** 2))
        shares.append(min(float(np.sum(w[:, j] ** 2)) / den, 1.0) if den > 0 else 1.0)
    return max(shares, default=1.0)


def check_feedthrough(value: Any) -> bool | str:
    """``value`` as one of :data:`FEEDTHROUGH_CHOICES` (``numpy.bool_`` accepted).

    Parameters
    ----------
    value : bool or str
        The user's ``feedthrough=``.

    Returns
    -------
    bool or str
        ``True``, ``False`` or ``"auto"``.

    Raises
    ------
    ValueError
        When ``value`` is none of them.
    """
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, str) and value == "auto":
        return "auto"
    raise ValueError(f"feedthrough must be True, False or 'auto', got {value!r}")


def honours_feedthrough(model: StateSpaceModel) -> bool:
    """Whether the method that fitted ``model`` takes ``feedthrough=`` as the choice of
    ``D``: it reports the boolean ``feedthrough`` option (the PBSID core does), typed in
    ``model.report.feedthrough``.  A method that estimates ``D`` as part of its own
    algebra whatever it is asked (the Laguerre-domain ``D_d``, reported as a text:
    ``by_method``) has no candidate with ``D`` to add.

    Parameters
    ----------
    model : StateSpaceModel
        A model fitted by a method.

    Returns
    -------
    bool
        Whether ``D`` was the method's choice by ``feedthrough=`` (False without inputs).
    """
    fd = model.report.feedthrough
    return fd is not None and not fd.by_method and model.m > 0


def with_d_asked(model: StateSpaceModel) -> StateSpaceModel:
    """Mark ``model`` as fitted with ``D`` asked for, in place: ``D`` a parameter of the
    model structure and so of the prediction-error refinement
    (:mod:`hdpbsid.refine.pem`), whatever its method says of its own ``D`` (kept in
    ``options["feedthrough_method"]``).

    A method that estimates ``D`` in its own algebra whatever it is asked (the
    Laguerre-domain ``D_d``, :func:`honours_feedthrough` False) reports it as its own,
    and the refinement then keeps ``D`` at zero (the structure every method assumes by
    default).  Where ``D`` was asked for -- by the user (``feedthrough=True``) or by the
    held-out judgement of the direct term -- that is the structure, and this mark says
    so.  A model whose method took ``feedthrough=True`` as the choice of ``D``, one
    without inputs, or anything but a :class:`StateSpaceModel` is left as it is.

    Parameters
    ----------
    model : StateSpaceModel
        A model fitted by a method with ``D`` asked for.

    Returns
    -------
    StateSpaceModel
        ``model`` itself, marked when it needs it.

    Examples
    --------
    >>> from hdpbsid import StateSpaceModel
    >>> from hdpbsid.models.report import DirectTerm
    >>> m = StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.2]], [[0.0]])
    >>> m.report = m.report.but(feedthrough=DirectTerm(True, True, "own D"))
    >>> with_d_asked(m).report.feedthrough.asked, m.options["feedthrough_method"]
    (True, 'own D')
    """
    if not isinstance(model, StateSpaceModel) or not model.m or honours_feedthrough(model):
        return model
    own = model.report.feedthrough
    model.options["feedthrough_method"] = None if own is None else own.reason
    model.options["feedthrough"] = True
    model.report = model.report.but(feedthrough=DirectTerm(True, False))
    return model


def without_own_d(model: StateSpaceModel) -> StateSpaceModel:
    """``model`` with the direct term its method estimated of its own accord set to zero
    (:func:`honours_feedthrough` False: the Laguerre-domain ``D_d`` mapped back), as a
    structure without ``D``: ``options["feedthrough"]`` False, reported as not
    estimated, the method's own description kept in ``options["feedthrough_method"]``.

    Where the judgement refused a direct term in closed loop, a candidate whose method
    estimates one anyway would compete with the candidates without it on a term the
    decision refused; with a controller that reacts within the sample that term
    predicts the measurement noise through the controller (module docstring), and
    the candidate wins by it.  Its dynamics are kept: for a plant without a direct term
    the mapped-back ``D`` is estimation error, and the refinement refits ``B``, ``C``
    without it.

    Parameters
    ----------
    model : StateSpaceModel
        A model whose ``D`` its method estimated whatever it was asked.

    Returns
    -------
    StateSpaceModel
        A copy with ``D = 0``; ``model`` itself when it has no input.
    """
    import dataclasses

    if model.m == 0:
        return model
    own = model.report.feedthrough
    options = {
        **model.options,
        "feedthrough": False,
        "feedthrough_method": None if own is None else own.reason,
    }
    return dataclasses.replace(
        model,
        D=np.zeros_like(model.D),
        options=options,
        report=model.report.but(feedthrough=DirectTerm(False, False)),
    )


def takes_feedthrough(method: str) -> bool:
    """Whether the registered method ``method`` is a built-in one of the library
    (:data:`~hdpbsid.methods.registry.LAZY_METHODS`, not replaced by the user), whose
    ``feedthrough=`` setting is known.  A user's own method is never called with a
    setting it did not ask for: ``feedthrough="auto"`` keeps ``D = 0`` for it.

    Parameters
    ----------
    method : str
        A registered method name.

    Returns
    -------
    bool
        Whether it is the library's own function for that name.
    """
    from hdpbsid.methods.registry import LAZY_METHODS, get_method

    func = get_method(method)
    return any(
        getattr(func, "__module__", None) == mod and getattr(func, "__name__", None) == name
        for mod, name in LAZY_METHODS.get(method, ())
    )


def with_d(row: CandidateRow) -> bool:
    """Whether the selection candidate ``row`` was fitted with ``D`` asked for by the
    judgement (its ``settings``).

    Parameters
    ----------
    row : CandidateRow
        A candidate of the selection.

    Returns
    -------
    bool
        Whether ``row.settings`` asks for ``feedthrough=True``.
    """
    return bool(row.settings.get("feedthrough", False))


def structure_key(row: CandidateRow) -> tuple[int, bool, float]:
    """The ranking of scored candidates for the one-standard-error rule: order first,
    then without ``D`` before with ``D`` (module docstring), then held-out error.

    Parameters
    ----------
    row : CandidateRow
        A scored candidate (``order``, ``criterion``, ``settings``).

    Returns
    -------
    tuple of (int, bool, float)
        The order, whether it has ``D``, and its held-out error.
    """
    return (row.order, with_d(row), row.criterion.total)


def arx_residuals(u: Any, y: Any, lags: int, regressors: Any = None) -> Any:
    """Residuals ``(Ns, l)`` of the least-squares ARX predictor of ``y_k`` from ``y`` and
    ``u`` at lags ``1..lags`` (no ``u_k``: strictly causal, no direct term); the first
    ``lags`` rows are zero.  A causal predictor's errors depend on ``u_j, j <= k`` and
    the noise only, which is all the feedback test needs in open loop, and they do not
    depend on any candidate model being sound (a candidate without ``D`` fitted to a
    loop that reacts within the sample can diverge, and its errors then test nothing).

    Parameters
    ----------
    u : array_like
        The inputs, ``(Ns, m)``.
    y : array_like
        The outputs, ``(Ns, l)``.
    lags : int
        The number of past samples of each signal.
    regressors : array_like, optional
        The signals whose past predicts ``y`` (default ``[y, u]``).

    Returns
    -------
    numpy.ndarray
        The residuals, ``(Ns, l)``.
    """
    ns = u.shape[0]
    z = np.hstack([y, u]) if regressors is None else regressors
    zt, d = np.ascontiguousarray(np.asarray(z, dtype=float).T), z.shape[1]
    # the regressors' transpose, row by row (contiguous copies), then a constant
    XT = np.ones((lags * d + 1, ns - lags))
    for i in range(1, lags + 1):
        XT[(i - 1) * d : i * d] = zt[:, lags - i : ns - i]
    out = np.zeros_like(y)
    out[lags:] = lstsq_residuals(XT.T, y[lags:])
    return out


def arx_innovations(u: Any, y: Any, lags: int) -> tuple[Any, Any]:
    """The residuals of the least-squares ARX predictors of ``y_k`` and of ``u_k`` from
    ``y`` and ``u`` at lags ``1..lags`` (:func:`arx_residuals` of both, from one
    factorisation: the two predictors share their regressors).

    Parameters
    ----------
    u : array_like
        The inputs, ``(Ns, m)``.
    y : array_like
        The outputs, ``(Ns, l)``.
    lags : int
        The number of past samples of each signal.

    Returns
    -------
    tuple of numpy.ndarray
        The output's residuals ``(Ns, l)`` and the input's ``(Ns, m)``; the first ``lags``
        rows are zero.
    """
    l, z = y.shape[1], np.hstack([y, u])
    both = arx_residuals(u, z, lags, regressors=z)
    return both[:, :l], both[:, l:]


class Offer(NamedTuple):
    """Whether candidates with ``D`` are offered (:func:`feedthrough_offered`), why, and
    the terms of their judgement (:func:`judge_direct_term`).

    Attributes
    ----------
    offered : bool
        Whether candidates with ``D`` are fitted.
    why : str
        The reason, for ``options["feedthrough_rule"]``.
    bound : float
        The share by which ``D`` must lower the simulation error in closed loop (the
        controller bound), else 0.
    min_gain : float
        The share by which ``D`` must lower it with a deterministic input, else 0.
    """

    #: whether candidates with ``D`` are fitted
    offered: bool
    #: the reason, for ``options["feedthrough_rule"]``
    why: str
    #: the share by which ``D`` must lower the simulation error (closed loop), else 0
    bound: float = 0.0
    #: the share by which ``D`` must lower the simulation error when the input is
    #: deterministic (:func:`input_innovation`), else 0
    min_gain: float = 0.0


def input_innovation(w: Any, u: Any) -> float:
    """The share of the input's variance that no strictly causal predictor explains:
    ``sum(w_j^2) / sum((u_j - mean)^2)`` for the residuals ``w`` of the least-squares
    VARX of ``u_k`` on past ``u`` and ``y`` (:func:`arx_residuals`), the largest over
    the input channels.  ``D`` is identified from the data through this part of ``u_k``
    alone: what the past predicts of ``u_k``, ``D`` turns into a function of the past
    that the model's dynamics can represent as well (the one-step predictor
    ``yhat_k = f(past) + D u_k``).  Near 0 for a deterministic input (a sum of
    sinusoids, a sweep; Wold's decomposition: Brockwell & Davis, *Time Series: Theory
    and Methods*, 2nd ed., 1991, sec. 5.7) and for a loop whose reference is one.

    Parameters
    ----------
    w : array_like
        The input's residuals, ``(N, m)`` (the rows after the lags).
    u : array_like
        The inputs on the same rows, ``(N, m)``.

    Returns
    -------
    float
        The share, in ``[0, 1]`` (1 for a constant input: nothing to predict).

    Examples
    --------
    >>> import numpy as np
    >>> u = np.random.default_rng(0).standard_normal((500, 1))
    >>> round(input_innovation(u, u), 1)
    1.0
    """
    w, u = np.asarray(w, dtype=float), np.asarray(u, dtype=float)
    shares = [1.0]
    for j in range(u.shape[1]):
        den = float(np.sum((u[:, j] - np.mean(u[:, j])) ** 2))
        shares.append(min(float(np.sum(w[:, j] ** 2)) / den, 1.0) if den > 0 else 1.0)
    return max(shares[1:], default=1.0)


def lag0_link(e: Any, w: Any) -> tuple[float, float]:
    """Bartlett's test of independence of the innovations ``e`` of ``y`` and ``w`` of
    ``u`` at lag 0: the statistic ``-(N - 1 - (l + m + 1) / 2) sum log(1 - r_i^2)`` of
    their canonical correlations ``r_i``, chi-square with ``l m`` degrees of freedom
    when they are independent (Anderson, *An Introduction to Multivariate Statistical
    Analysis*, 3rd ed., 2003, sec. 12.4), and its ``1 - link_level`` quantile.  A
    direct term (``e_k = D w_k + v_k``) and a controller reacting within the sample
    (``w_k = -F e_k + ...``) both link them; without either, no candidate with ``D`` can
    predict better than the noise lets it by chance.  A score test of ``D = 0``
    (Rao's): ``e`` are the one-step errors of the model without ``D``, ``w`` the part of
    ``D``'s regressor that the past does not already give.

    Parameters
    ----------
    e : array_like
        The output's innovations, ``(N, l)``.
    w : array_like
        The input's innovations on the same rows, ``(N, m)``.

    Returns
    -------
    tuple of (float, float)
        The statistic and the threshold.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> w = rng.standard_normal((2000, 1))
    >>> s, thr = lag0_link(rng.standard_normal((2000, 1)), w)
    >>> bool(s < thr), bool(lag0_link(0.2 * w + rng.standard_normal((2000, 1)), w)[0] > thr)
    (True, True)
    """
    from scipy.stats import chi2  # here: scipy.stats is slow to import

    e = np.asarray(e, dtype=float)
    w = np.asarray(w, dtype=float)
    n, l, m = e.shape[0], e.shape[1], w.shape[1]
    qe = np.linalg.qr(e - e.mean(axis=0))[0]
    qw = np.linalg.qr(w - w.mean(axis=0))[0]
    r = np.clip(np.linalg.svd(qe.T @ qw, compute_uv=False), 0.0, 1.0 - np.finfo(float).eps)
    stat = -(n - 1 - (l + m + 1) / 2) * float(np.sum(np.log1p(-(r**2))))
    return stat, float(chi2.ppf(1.0 - FEEDTHROUGH_POLICY.link_level, l * m))


def feedthrough_offered(model: StateSpaceModel | None, rec: tuple) -> Offer:
    """Whether candidates with ``D`` are offered for the record ``rec = (t, u, y)``
    (module docstring), the reason, the share by which ``D`` must lower the held-out
    simulation error (:func:`judge_direct_term`'s ``bound``) and the margin on it.
    Offered for a uniformly sampled record with an input whose innovations link to the
    output's at lag 0 (:func:`lag0_link`), or whose innovation is too small to tell
    (:func:`input_innovation`; then the simulation margin is the deciding one,
    :data:`FEEDTHROUGH_Z`).  When the feedback test finds no loop the share is 0; when
    it finds one, it is :func:`controller_share`, the most a controller reacting
    within the sample could give.  The feedback test correlates the residuals of a
    strictly causal least-squares ARX predictor (:func:`arx_residuals`, lags up to
    :data:`~hdpbsid.selection.feedback.AR_ORDER`, at least ten samples per regressor)
    with the prewhitened input: every statistic is model-free, so the screen can run
    before any candidate is fitted.

    Parameters
    ----------
    model : StateSpaceModel or None
        A candidate of the record (its number of inputs), or None (read from ``u``).
    rec : tuple
        The estimation record ``(t, u, y)`` (a list of records: not judged).

    Returns
    -------
    Offer
        Whether ``D`` is offered, why, the share ``D`` must lower the simulation error
        by, and the margin on the simulation error.
    """
    from hdpbsid.selection.feedback import AR_ORDER, feedback_statistics

    t, u, y = rec
    if isinstance(t, list | tuple):
        return Offer(False, "not judged: several estimation records; D = 0")
    m = model.m if model is not None else (0 if u is None else np.size(u) // len(t))
    if m == 0:
        return Offer(False, "no input, no direct term")
    if not is_uniform(np.asarray(t, dtype=float)):
        return Offer(False, (
            "not judged: the feedback test that tells whether D is identifiable needs "
            "uniformly sampled times; D = 0"
        ))  # fmt: skip
    u = np.asarray(u, dtype=float).reshape(len(t), -1)
    y = np.asarray(y, dtype=float).reshape(len(t), -1)
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            lags = max(min(AR_ORDER, len(t) // (10 * (u.shape[1] + y.shape[1]))), 1)
            errors, w = arx_innovations(u, y, lags)
            st = feedback_statistics(model, t, u, y, errors=errors)
            w = w[lags:]
            share = input_innovation(w, u[lags:])
            link = lag0_link(errors[lags:], w)
            bound = controller_share(u, y, lags) if st["feedback"] else 0.0
    except (ValueError, np.linalg.LinAlgError):
        return Offer(False, "not judged: the feedback test cannot be computed")
    return _offer(st, share, link, bound)


def _offer(st: dict, share: float, link: tuple[float, float], bound: float) -> Offer:
    """:func:`feedthrough_offered` from its statistics: the feedback test ``st``, the
    input's innovation ``share``, the lag-0 ``link`` (statistic, threshold) and the
    closed-loop ``bound``."""
    loop = "closed loop" if st["feedback"] else "open loop"
    test = f"{loop} (feedback test S = {st['statistic']:.4g} vs {st['threshold']:.4g})"
    min_gain = 0.0
    if share <= FEEDTHROUGH_POLICY.innovation_floor:
        min_gain = 1.0 - 1.0 / MUCH_WORSE_RATIO
        test += (
            f"; the input is deterministic (its innovation is {share:.2g} of its variance): "
            f"D is told only by the model structure, and must lower the simulation error "
            f"by more than {100 * min_gain:.3g} %"
        )
    elif not link[0] > link[1]:
        return Offer(False, (
            f"not offered: {test}; no lag-0 link between the innovations of u and y "
            f"(chi2 = {link[0]:.3g} vs {link[1]:.3g}); D = 0"
        ))  # fmt: skip
    if not st["feedback"]:
        return Offer(True, f"offered: {test}", 0.0, min_gain)
    bound = float(bound) if np.isfinite(bound) else 1.0
    return Offer(True, (
        f"offered: {test}; a controller reacting within the sample could "
        f"let D explain at most {bound:.2f} of the simulation error (the input's "
        f"innovation given past u and y over that given past u)"
    ), bound, min_gain)  # fmt: skip
