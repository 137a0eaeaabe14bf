"""``method="auto"``: choose the method and the order by their out-of-sample error.

Every candidate ``(method, order)`` is identified on the first part of the record
(``1 - holdout`` of the samples) and scored on the rest by the **windowed one-step
prediction error of the candidate's own predictor** (:mod:`hdpbsid.models.criteria`: initial
state fitted in each window, outputs weighted by their variance), computed identically
for every method:

* every candidate is an innovation model ``dx/dt = A x + B u + K e``; its one-step
  predictor with the gain ``K`` is the predictor of the prediction-error method, whose
  criterion is minimised by the true system also in closed loop, where ``u`` depends on
  past noise (the "direct method" of closed-loop identification: Forssell & Ljung,
  "Closed-loop identification revisited", Automatica 35(7), 1999).  The simulation
  error (the predictor with ``K = 0``) is not: in closed loop the simulated output
  ignores the noise fed back through ``u``, and a model that absorbs the correlation
  of ``u`` with the noise simulates the record better than the true system (on the
  PBSID toolbox's closed-loop example it chose a wrong order on some records);
* but ``K`` is an estimate, and a poor one (a basis-domain method's on white output
  noise, for instance) makes the predictor worse than none.  So each candidate is
  scored by the better of its two predictors on the held-out data (:func:`score_model`):
  with ``K``, or with ``K = 0``, i.e. its simulation error, the right criterion when the
  noise is white output noise.  A model is worth its best predictor; a bad noise
  estimate does not count against a good plant model, and in closed loop the models
  whose noise model matters are judged with it.  (The predictor is chosen on the
  held-out part, not on the estimation part where ``K`` was fitted: there ``K`` always
  looks useful, also for models it makes worse on new data.)
  A predictor ``A - K C`` that is unstable in sampled form is not scored with ``K``
  (:func:`hdpbsid.models.criteria.predictor_is_stable`: with each window's fitted initial state
  it would use the window's later outputs); such a model is scored by its simulation.

The rule of :func:`hdpbsid.models.criteria.choose_smallest_adequate` keeps, among all
candidates ordered by order, the first one whose error is within one standard error of
the best candidate's.  Among the candidates of that order within one standard error
(ties at the resolution of the held-out data), the one with the smallest simulation
error over the whole held-out part from one initial state wins (:func:`break_tie`: it
sees the slow errors that each window's fitted initial state hides).  That
``(method, order)`` is then identified on the whole record, after a check that passes
the choice to the next candidate when it fails: its refit on the whole record must score
on the held-out part within one standard error of the candidate (:func:`refit_holds`)
and pass the same floor as the candidate.  Held-out data judge the
models, so a method that is biased on this record, or an order the data do not support,
loses by the measure a user would apply to the result.

No model the checks reject is returned quietly (:func:`_choose`).  The floor includes
:func:`instability_problem`: an unstable candidate is rejected when a stable candidate
of no larger order predicts the held-out part as well (within one standard error), i.e.
when the record does not need the growth.  When no refit of an adequate candidate holds,
the refit of the next candidate that is not much worse on the held-out part, by the
windowed score and by the simulation over the whole part (:func:`much_worse`, the bound
beyond which a returned model draws a warning), is tried, in order of held-out error;
only when none of those holds either, the first adequate candidate itself (fitted on the
estimation part, the model the held-out part judged) is returned with a warning, or is
the start of the refinement on the whole record; candidates that fail the floor leave
the ranking and the one-standard-error rule is applied again to the rest, so a candidate
the rule rejected against a better one is never the fallback while that one stands.  A
model returned that is much worse on the held-out part than a candidate the checks
rejected (:func:`much_worse`) draws a :class:`SelectionWarning` naming it, the reason
and the ``order=``/``method=`` to pass.  A time series (no input) is scored by its
one-step prediction error with one initial state for the whole held-out part, and only
stationary models (stable ``A``, :func:`stationarity_problem`) are candidates.

When the chosen model will be refined by the prediction-error method (``refine="auto"``,
the default, on a single uniformly sampled record), the order is decided again between
refined candidates where the subspace candidates' bias could have decided it
(:func:`rejudge_refined`): a smaller order replaces the chosen one when, refined, it
predicts the held-out part at least as well.

A method that judges a data-driven setting of its own on held-out data (HD-PBSID's
operator scale ``alpha``; :func:`accepts_held_out`) has its candidates fitted with the
first-pass settings it declares (:func:`sweep_settings`), and the setting is judged for
the candidate that is about to be chosen only (:func:`settle_candidate`): that candidate
is fitted again with the held-out part given, and the refit on the whole record is given
the settings it took (``options["refit_settings"]``), as it is given its order -- one
judge for the order, the method and those settings, instead of a second split of the
estimation part inside the method, and one judgement instead of one per order.

A method may also list data-driven settings that the refit keeps from the candidate
(:func:`refit_keeps`; ``dt``: its past and future windows, whose criterion is most of a
refit's cost): the held-out part judged the candidate's predictor with them.  Not in
closed loop (:func:`closed_loop_refit`): there ``dt`` is consistent only as its past
window grows with the record, so the refit chooses it on the whole record.

The expensive order-independent steps of the methods (projection of the record, basis
operators, the past-window criterion of ``dt``) are memoised
(:mod:`hdpbsid.bases.memo`), so the orders of one method share them.

The comparison is reported in ``model.options["selection"]``: one row per candidate
with ``method``, ``order``, ``error`` (held-out residual energy relative to the output
variance), ``fit`` (percent), ``z`` (statistic against the best), ``whole_simulation``
(the tie-break's error, for the tied candidates only, else ``None``), ``predictor``
(``"innovation (K)"`` or ``"output error (K = 0)"``), ``first_pass_error`` (for a
candidate whose held-out-judged settings were settled, :func:`settle_candidate`, the
error of its sweep fit; ``error`` is then the settled fit's), ``time`` (seconds of the
sweep fit) and ``status`` (``"ok"`` or the error message).

Where each step lives: this module splits the record and runs the steps
(:func:`select_model`); the candidates and their settings are
:mod:`hdpbsid.selection.candidates`, the scores and checks
:mod:`hdpbsid.selection.scoring`, the order and method choices
:mod:`hdpbsid.selection.order_rule`, the re-judgement between refined candidates
:mod:`hdpbsid.selection.rejudge`, the refit and the fallbacks
:mod:`hdpbsid.selection.refits`, the direct term :mod:`hdpbsid.selection.direct_term`,
and the numbers :mod:`hdpbsid.selection.policy`.  Every name listed in ``__all__`` is
importable from here.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Sequence
from typing import Any

from hdpbsid.data.checks import check_data, check_positive_int, is_uniform
from hdpbsid.data.records import Dataset
from hdpbsid.models.criteria import (
    CRITERIA,
    MIN_WINDOWS,
    SAMPLES_PER_STATE,
    SIGNIFICANCE_Z,
    default_windows,
)
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import Candidate
from hdpbsid.runtime import library_call, user_stacklevel
from hdpbsid.selection.candidates import (
    CandidateRow,
    FitRecord,
    _sweep,
    accepts_held_out,
    closed_loop_refit,
    refit_keeps,
    settle_candidate,
    sweep_settings,
)
from hdpbsid.selection.direct_term import (
    _choose_structure,
    _feedthrough_candidates,
    _feedthrough_report,
    decide_feedthrough,
)
from hdpbsid.selection.feedthrough import check_feedthrough, structure_key, with_d
from hdpbsid.selection.order_rule import (
    MethodChoice,
    MethodReason,
    OrderChoice,
    OrderReason,
    choose_order,
    rank_candidates,
)
from hdpbsid.selection.policy import (
    AUTO_MAX_ORDER,
    AUTO_METHODS,
    HOLDOUT,
    MUCH_WORSE_RATIO,
    REJUDGE_Z,
    NoCandidate,
    SelectionWarning,
)
from hdpbsid.selection.refits import _choose, _unscored, _warn_if_much_worse
from hdpbsid.selection.rejudge import rejudge_order, rejudge_refined
from hdpbsid.selection.restarts import same_order_starts
from hdpbsid.selection.scoring import (
    beats_the_mean,
    break_tie,
    grows,
    instability_problem,
    looks_closed_loop,
    much_worse,
    refinement_instability,
    refit_holds,
    score_model,
    stationarity_problem,
    whole_held_out_error,
)

__all__ = [
    "identify_auto",
    "fit_auto",
    "select_order",
    "select_model",
    "score_model",
    "refit_holds",
    "beats_the_mean",
    "stationarity_problem",
    "instability_problem",
    "refinement_instability",
    "grows",
    "much_worse",
    "whole_held_out_error",
    "SelectionWarning",
    "MUCH_WORSE_RATIO",
    "rejudge_refined",
    "looks_closed_loop",
    "accepts_held_out",
    "sweep_settings",
    "settle_candidate",
    "refit_keeps",
    "closed_loop_refit",
    "REJUDGE_Z",
    "decide_feedthrough",
    "NoCandidate",
    "AUTO_METHODS",
    "HOLDOUT",
    "AUTO_MAX_ORDER",
    "break_tie",
    "OrderChoice",
    "OrderReason",
    "MethodChoice",
    "MethodReason",
    "choose_order",
    "rank_candidates",
    "rejudge_order",
    "_warn_if_much_worse",
]


@library_call
def select_model(
    t: Any,
    u: Any,
    y: Any,
    methods: Sequence[str],
    orders: Sequence[int],
    *,
    holdout: float = HOLDOUT,
    n_jobs: int | None = None,
    method_options: dict[str, dict[str, Any]] | None = None,
    refined: bool = False,
    judge_feedthrough: bool = False,
    order_given: bool = False,
    trim_orders: bool = False,
) -> tuple[StateSpaceModel, list[dict[str, Any]], str]:
    """Score every ``(method, order)`` on held-out data and identify the chosen one on
    the whole record (module docstring).  Returns ``(model, table, rule)``.
    ``refined``: the model will be refined by the prediction-error method, so the order
    is decided again between refined candidates where the subspace bias could flip it
    (:func:`rejudge_refined`).  ``judge_feedthrough``: candidates with a direct term
    ``D`` join the ranking where the record allows it
    (:mod:`hdpbsid.selection.feedthrough`, :func:`_feedthrough_candidates`); the
    decision is in ``model.options["feedthrough_rule"]``.  ``order_given``: the user
    asked for the one order of ``orders``: when no candidate answers with the methods'
    default settings (:class:`NoCandidate`), the selection runs again with every basis
    method whose default past window cannot reach the order given the smallest window
    that does (:func:`_fit_at_order`), so that a method that cannot answer (``dt`` with
    no continuous-time logarithm) does not leave the order without a model; the failing
    candidates stay in the table with their reason (``status``).  Not before: the
    default window's precision rule stands wherever some method answers with it.

    Parameters
    ----------
    t, u, y : array_like or list
        One record (a list of records: the last one is held out, the others identify the
        candidates).
    methods : sequence of str
        The registered methods of the candidates.
    orders : sequence of int
        Their orders.
    holdout : float
        The held-out share at the end of a single record, ``0 < holdout < 1``.
    n_jobs : int or None
        Sweep the methods in parallel (joblib); the result is the serial run's.
    method_options : dict or None
        Settings per method.
    refined : bool
        Whether the model will be refined by the prediction-error method.
    judge_feedthrough : bool
        Whether candidates with ``D`` join the ranking.
    order_given : bool
        Whether the user asked for the one order of ``orders``. When the held-out part
        is too short to score that order (fewer than ``MIN_WINDOWS * SAMPLES_PER_STATE``
        samples per state), the methods are not compared: the first of ``methods`` that
        answers at the order on the whole record is returned, with a
        :class:`SelectionWarning` (:func:`~hdpbsid.selection.refits._unscored`).
    trim_orders : bool
        ``orders`` is a default range, not the user's: the orders the held-out part is
        too short to score are left out (the rule says so), instead of refusing the
        record. Only a record too short to score order 1 is refused.

    Returns
    -------
    tuple of (StateSpaceModel, list of dict, str)
        The model identified on the whole record, the table of every candidate, and the
        rule with what was not kept and why.

    Raises
    ------
    ValueError
        When ``holdout`` is not in ``(0, 1)``, when the held-out part is too short to
        score the orders (not for an order given, ``order_given``), or when a time series
        is not uniformly sampled
        (:class:`~hdpbsid.selection.policy.NoCandidate`, a ``ValueError``, when no
        candidate can be identified).
    """
    from hdpbsid.methods.registry import get_method

    if not (isinstance(holdout, float | int) and 0.0 < float(holdout) < 1.0):
        raise ValueError(f"holdout must be a number in (0, 1), got {holdout!r}")
    t, u, y, est, val, where = _split(t, u, y, holdout)
    n_val = val[0].size
    opts = method_options or {}
    whole = FitRecord((t, u, y))
    orders, windows, trimmed = _held_out_orders(orders, n_val, where, trim_orders, order_given)
    _warn_if_few_windows(orders, windows, n_val, where, order_given)
    if windows < MIN_WINDOWS:  # the order given, which the held-out part cannot score
        reason = (
            f"{where} ({n_val} samples) is too short to score order {orders[0]} "
            f"({MIN_WINDOWS} windows of {SAMPLES_PER_STATE} samples per state need "
            f"{MIN_WINDOWS * SAMPLES_PER_STATE * orders[0]})"
        )
        return _unscored(get_method, methods, orders[0], whole, opts, reason)
    time_series = val[1].shape[1] == 0
    if time_series and not is_uniform(val[0]):
        raise ValueError(
            "t: choosing the "
            + ("method" if order_given else "order")
            + " of a time series (no input) scores the one-step prediction error on "
            "held-out data, which needs uniformly sampled times; resample the record "
            "uniformly or give the "
            + (f"method (one of {', '.join(methods)})" if order_given else "order")
        )
    args = (get_method, methods, sorted(orders), est, whole, val, windows, where, opts)
    try:
        model, table, rule = _select(*args, n_jobs, refined, judge_feedthrough, relax=False)
    except NoCandidate:
        if not order_given:
            raise
        # no method answers at the order the user asked for with its default settings:
        # the basis methods that can, at a less precise past window, answer (_fit_at_order)
        model, table, rule = _select(*args, n_jobs, refined, judge_feedthrough, relax=True)
    return model, table, trimmed + rule


def _split(t: Any, u: Any, y: Any, holdout: float) -> tuple[Any, Any, Any, FitRecord, tuple, str]:
    """``(t, u, y, est, val, where)``: the record (checked, when one), the part that
    identifies the candidates, the held-out part ``(t, u, y)`` and where it is.  Several
    records: the last one is held out, the others identify the candidates; one record:
    its last ``holdout`` share."""
    from hdpbsid.data.records import as_records, is_record_list

    if is_record_list(t) and len(t) > 1:
        recs = as_records(t, u, y)
        last = recs[-1]
        est_list = [(r.t, r.u, r.y) for r in recs[:-1]]
        est = FitRecord((est_list, None, None) if len(est_list) > 1 else est_list[0])
        return t, u, y, est, (last.t, last.u, last.y), "the last record"
    t, u, y = check_data(t, u, y)
    split = int(round(t.size * (1.0 - float(holdout))))
    est = FitRecord((t[:split], u[:split], y[:split]))
    val = (t[split:], u[split:], y[split:])
    return t, u, y, est, val, f"the last {holdout:.0%} of the record"


def _warn_if_few_windows(
    orders: Sequence[int], windows: int, n_val: int, where: str, order_given: bool
) -> None:
    """A :class:`SelectionWarning` when the order is chosen (several ``orders``, none
    given) on fewer than :attr:`~hdpbsid.models.criteria.CriteriaSettings.
    reliable_windows` held-out windows.  The one-standard-error rule estimates its
    standard error from the per-window errors; on so few windows that estimate is itself
    noisy, a wide one puts much smaller orders "within one standard error", and the
    rule then takes the smallest: an order the record would reject on more data can
    be returned, and nothing in its score shows it."""
    if order_given or len(orders) < 2 or not MIN_WINDOWS <= windows < CRITERIA.reliable_windows:
        return
    warnings.warn(
        f"the order was chosen on {where} ({n_val} samples) cut into {windows} windows: "
        f"with fewer than {CRITERIA.reliable_windows} the standard error of the "
        f"one-standard-error rule is too noisy to tell the orders apart, and a too small "
        f"order can be chosen; validate the model on other data, supply a longer "
        f"record, or give the order",
        SelectionWarning,
        stacklevel=user_stacklevel(),
    )


def _held_out_orders(
    orders: Sequence[int], n_val: int, where: str, trim: bool, order_given: bool
) -> tuple[list[int], int, str]:
    """``(orders, windows, text)``: the orders the held-out part of ``n_val`` samples
    scores, its number of windows (:func:`default_windows`) and the rule's note when
    the default range was cut (``trim``).  A held-out score needs ``MIN_WINDOWS`` windows
    of ``SAMPLES_PER_STATE`` samples per state, so it scores orders up to ``n_val //
    (MIN_WINDOWS * SAMPLES_PER_STATE)``.  Fewer windows are returned only for an order
    given (the caller does not compare the methods then); otherwise a held-out part too
    short for the orders raises ``ValueError``."""
    orders = list(orders)
    scorable = n_val // (MIN_WINDOWS * SAMPLES_PER_STATE)
    text = ""
    if trim and max(orders) > scorable >= min(orders):
        orders = [n for n in orders if n <= scorable]
        text = (
            f"orders up to {scorable}, the largest {where} can score ({n_val} samples, "
            f"{MIN_WINDOWS} windows of {SAMPLES_PER_STATE} samples per state); "
        )
    windows = default_windows(n_val, max(orders))
    if windows < MIN_WINDOWS and not order_given:
        raise ValueError(
            f"choosing the order scores candidates on {where} ({n_val} samples) cut into "
            f"at least {MIN_WINDOWS} windows of {SAMPLES_PER_STATE * max(orders)} samples "
            f"({SAMPLES_PER_STATE} per state of the largest order {max(orders)}), i.e. "
            f"{MIN_WINDOWS * SAMPLES_PER_STATE * max(orders)} held-out samples; supply a "
            f"longer record, a smaller max_order, or give the order"
        )
    return orders, windows, text


def _select(
    get_method: Any,
    methods: Sequence[str],
    orders: list[int],
    est: FitRecord,
    whole: FitRecord,
    val: tuple,
    windows: int,
    where: str,
    opts: dict,
    n_jobs: int | None,
    refined: bool,
    judge_feedthrough: bool,
    relax: bool,
) -> tuple[StateSpaceModel, list[dict[str, Any]], str]:
    """:func:`select_model` on the split record: sweep, rank, choose (module docstring);
    ``relax``: a basis method may take the smallest past window that reaches the order
    (:func:`_fit_at_order`)."""
    time_series = val[1].shape[1] == 0
    rows = _sweep(get_method, methods, orders, est, val, windows, opts, n_jobs, relax)
    ok = _scored(rows, time_series)
    ok.sort(key=structure_key)
    order = choose_order(ok)
    ft_rule = ""
    if judge_feedthrough:
        extra, offer = _feedthrough_candidates(
            get_method, ok, ok[order.index], methods, orders, est, val, windows, opts,
            n_jobs, relax,
        )  # fmt: skip
        rows = rows + extra
        ok, ft_rule = _choose_structure(ok, order.index, extra, val, windows, offer)
        order = choose_order(ok)
    for r, z in zip(ok, order.stats, strict=True):
        r.z = z
    queue = list(rank_candidates(ok, order, val).queue)
    if refined:
        queue, order = _rejudged_queue(ok, order, queue, est, val, windows, n_jobs)
    model, failures, note = _choose(
        get_method, ok, queue, est, whole, val, windows, opts, where, refined
    )
    if refined and len(orders) == 1:
        # the order given: nothing was refined before the final refinement, which may end
        # in a spurious minimum (hdpbsid.selection.restarts); an order chosen here offers
        # the final refinement the chosen candidate's refinement as a warm start where the
        # order decision refined it, and restarts at the orders above the plant's would
        # be paid for and not used (their extra modes are undriven from any start)
        model.report = model.report.but(restarts=same_order_starts(ok, model))
    rule = _rule_text(where, windows, time_series) + order.rule
    if failures:
        rule += "; not kept: " + "; ".join(why[1] for why in failures)
    if judge_feedthrough:
        model.options["feedthrough_rule"] = _feedthrough_report(model, ok, ft_rule)
    return model, [r.as_row() for r in rows], rule + note


def _scored(rows: list[CandidateRow], time_series: bool) -> list[CandidateRow]:
    """The candidates of ``rows`` with a finite held-out score; raises
    :class:`NoCandidate` naming every failure when there is none."""
    ok = [r for r in rows if r.criterion is not None and r.criterion.finite]
    if ok:
        return ok
    detail = "; ".join(f"{r.method} order {r.order}: {r.status}" for r in rows)
    hint = (
        "; a time series needs a stationary model with a stable one-step predictor: "
        "detrend or difference a drifting record, or try another method"
        if time_series
        else ""
    )
    raise NoCandidate(f"no candidate model could be identified and scored ({detail}){hint}")


def _rejudged_queue(
    ok: list[CandidateRow],
    order: OrderChoice,
    queue: list[CandidateRow],
    est: FitRecord,
    val: tuple,
    windows: int,
    n_jobs: int | None,
) -> tuple[list[CandidateRow], OrderChoice]:
    """The ranking ``queue`` with the order decided again between refined candidates
    (:func:`~hdpbsid.selection.rejudge.rejudge_order`) at its head, and that decision.
    Only candidates of the chosen structure (with or without ``D``, as the candidate of
    ``order``) take part: the preference for no ``D`` is not traded for a refined
    error."""
    k = order.index
    same = [i for i, r in enumerate(ok) if with_d(r) == with_d(ok[k])]
    within = OrderChoice(same.index(k), tuple(order.stats[i] for i in same))
    again = rejudge_order([ok[i] for i in same], within, est.arrays, val, windows, n_jobs)
    k2 = same[again.index]
    if k2 != k:
        queue = [ok[k2]] + [r for r in queue if r is not ok[k2]]
    return queue, OrderChoice(k2, order.stats, again.reason, again.rule)


def _rule_text(where: str, windows: int, time_series: bool) -> str:
    """The selection rule's text (``options["selection_rule"]``), before what the
    re-judgement and the checks add."""
    return (
        f"held-out windowed one-step prediction error on {where} ({windows} windows; "
        + (
            "one-step predictor with K: a time series, no input to simulate"
            if time_series
            else "each candidate's better predictor: with its K or with K = 0"
        )
        + f"); smallest order within {SIGNIFICANCE_Z:g} standard error of the best held-out "
        f"error (one-standard-error rule); among that order's candidates within it, the "
        f"smallest simulation error over the whole held-out part"
    )


@library_call
def identify_auto(
    t: Any,
    u: Any,
    y: Any,
    order: int | None = None,
    *,
    methods: Sequence[str] | None = None,
    max_order: int | None = None,
    holdout: float = HOLDOUT,
    n_jobs: int | None = None,
    method_options: dict[str, dict[str, Any]] | None = None,
    refined: bool = False,
    feedthrough: bool | str | None = None,
    **shared: Any,
) -> StateSpaceModel:
    """``method="auto"``: every method of ``methods`` with orders ``1..max_order`` (or the
    given ``order``), the best by held-out prediction error (module docstring).

    ``methods``: default :data:`AUTO_METHODS` that are available (``dt`` is skipped for
    non-uniform ``t``); ``max_order``: default 8; ``holdout``: the scored share at the
    end of the record (``0 < holdout < 1``); ``n_jobs``: sweep the methods in parallel
    with joblib (results are identical to the serial run); ``method_options``: extra
    options per method, e.g. ``{"hermite": {"N": 400}}``; any other keyword (``shared``)
    is a setting every method is given, e.g. ``feedthrough=True`` for an output with a
    direct term (``method_options`` override it per method; a method that does not take
    it raises ``TypeError``).  ``feedthrough="auto"`` decides the direct
    term from the data (:mod:`hdpbsid.selection.feedthrough`: candidates with ``D``
    join the ranking in open loop; ``options["feedthrough_rule"]`` says what was decided
    and why); ``True``/``False`` is given to every method.
    ``model.options["selection"]`` lists every candidate (its ``feedthrough`` column:
    fitted with ``D`` by the judgement), ``options["order_selection"]`` the chosen
    method's.

    Parameters
    ----------
    t, u, y : array_like or list
        The record, or a list of records (the last one held out).
    order : int or None
        The order of every candidate, or None for ``1..max_order``.
    methods : sequence of str or None
        The methods compared.
    max_order : int or None
        The largest order (default :data:`AUTO_MAX_ORDER`).
    holdout : float
        The held-out share at the end of a single record.
    n_jobs : int or None
        Sweep the methods in parallel (joblib).
    method_options : dict or None
        Settings per method.
    refined : bool
        Whether the model will be refined (:func:`rejudge_refined`).
    feedthrough : bool or str or None
        ``True``/``False`` for every method, ``"auto"`` to decide ``D`` from the data.
    **shared
        Settings every method is given.

    Returns
    -------
    StateSpaceModel
        The chosen candidate identified on the whole record, with the comparison in
        ``options["selection"]`` and ``report.candidates``.
    """
    return fit_auto(
        Dataset.of(t, u, y), order, methods=methods, max_order=max_order, holdout=holdout,
        n_jobs=n_jobs, method_options=method_options, refined=refined, feedthrough=feedthrough,
        **shared,
    )  # fmt: skip


@library_call
def fit_auto(
    data: Dataset,
    order: int | None = None,
    *,
    methods: Sequence[str] | None = None,
    max_order: int | None = None,
    holdout: float = HOLDOUT,
    n_jobs: int | None = None,
    method_options: dict[str, dict[str, Any]] | None = None,
    refined: bool = False,
    feedthrough: bool | str | None = None,
    **shared: Any,
) -> StateSpaceModel:
    """``method="auto"`` on the records of ``data``: :func:`identify_auto` in the
    registry's call shape (:func:`hdpbsid.methods.registry.get_fit`).  One record is
    selected on its relative times (as :func:`identify_auto` always did).

    Parameters
    ----------
    data : Dataset
        The records (several: the last one held out).
    order : int or None
        The order of every candidate, or None for ``1..max_order``.
    methods : sequence of str or None
        The methods compared.
    max_order : int or None
        The largest order (default :data:`AUTO_MAX_ORDER`).
    holdout : float
        The held-out share at the end of a single record.
    n_jobs : int or None
        Sweep the methods in parallel (joblib).
    method_options : dict or None
        Settings per method.
    refined : bool
        Whether the model will be refined (:func:`rejudge_refined`).
    feedthrough : bool or str or None
        ``True``/``False`` for every method, ``"auto"`` to decide ``D`` from the data.
    **shared
        Settings every method is given.

    Returns
    -------
    StateSpaceModel
        As :func:`identify_auto` returns it.
    """
    first = data.records[0]
    t, u, y = (first.t, first.u, first.y) if len(data) == 1 else (data, None, None)
    mo = AUTO_MAX_ORDER if max_order is None else check_positive_int(max_order, "max_order")
    orders = [check_positive_int(order, "order")] if order is not None else list(range(1, mo + 1))
    methods = _auto_methods(methods, data)
    feedthrough = None if feedthrough is None else check_feedthrough(feedthrough)
    if feedthrough is not None and feedthrough != "auto":
        shared["feedthrough"] = feedthrough
    per_method = {m: {**shared, **(method_options or {}).get(m, {})} for m in methods}
    judge = feedthrough == "auto" and not any("feedthrough" in o for o in per_method.values())
    model, table, rule = select_model(
        t,
        u,
        y,
        methods,
        orders,
        holdout=holdout,
        n_jobs=n_jobs,
        method_options=per_method,
        refined=refined,
        judge_feedthrough=judge,
        order_given=order is not None,
        trim_orders=order is None and max_order is None,
    )
    chosen = model.report.method
    model.options["selection"] = table
    model.options["order_selection"] = [r for r in table if r["method"] == chosen]
    model.options["selection_rule"] = rule
    model.report = model.report.but(
        candidates=tuple(Candidate.from_dict(r) for r in table), selection_rule=rule
    )
    return model


identify_auto.fit = fit_auto  # type: ignore[attr-defined]


def _auto_methods(methods: Sequence[str] | None, data: Dataset) -> list[str]:
    """The methods of ``method="auto"``: ``methods`` when given (each name checked by the
    registry, which raises for unknown ones), else the available ones of
    :data:`AUTO_METHODS`, without ``dt`` when a record of ``data`` is not uniformly
    sampled."""
    from hdpbsid.methods.registry import get_method, is_available

    if methods is None:
        uniform = data.uniform
        return [m for m in AUTO_METHODS if (uniform or m != "dt") and is_available(m)]
    methods = list(methods)
    for m in methods:
        get_method(m)  # raises for unknown names
    return methods


@library_call
def select_order(
    method: str,
    t: Any,
    u: Any,
    y: Any,
    *,
    max_order: int | None = None,
    holdout: float = HOLDOUT,
    refined: bool = False,
    **options: Any,
) -> StateSpaceModel:
    """The order of ``method`` chosen by held-out prediction error (module docstring).

    Orders ``1..max_order`` (default 8) are identified on the first ``1 - holdout`` of
    the record and scored on the rest; the chosen order is identified on the whole
    record.  When the record is too short to score, the method chooses the order itself
    (from its singular values) and ``options["order_selection"]`` says so.
    ``feedthrough="auto"`` (not the default: without it ``D = 0``) judges the direct term
    with the order (:mod:`hdpbsid.selection.feedthrough`); a record too short to score
    keeps ``D = 0``.

    Parameters
    ----------
    method : str
        A registered method name.
    t, u, y : array_like
        The record.
    max_order : int or None
        The largest order (default :data:`AUTO_MAX_ORDER`).
    holdout : float
        The held-out share at the end of the record.
    refined : bool
        Whether the model will be refined (:func:`rejudge_refined`).
    **options
        The method's settings (``feedthrough="auto"`` judges ``D``).

    Returns
    -------
    StateSpaceModel
        The model of the chosen order identified on the whole record, with every order's
        score in ``options["order_selection"]``.
    """
    mo = AUTO_MAX_ORDER if max_order is None else check_positive_int(max_order, "max_order")
    from hdpbsid.methods.registry import call_method, get_method

    given_ft = options.pop("feedthrough", None)
    ft = None if given_ft is None else check_feedthrough(given_ft)
    judge = ft == "auto"
    if ft is not None and not judge:
        options["feedthrough"] = ft

    try:
        model, table, rule = select_model(
            t,
            u,
            y,
            [method],
            list(range(1, mo + 1)),
            holdout=holdout,
            method_options={method: options},
            refined=refined,
            judge_feedthrough=judge,
        )
    except ValueError as exc:
        if "longer record" not in str(exc):
            raise
        data = functools.partial(Dataset.of, t, u, y)  # made only for a Dataset function
        model = call_method(get_method(method), (t, u, y), data, max_order=mo, **options)
        model.options["order_selection"] = f"singular values of the method ({exc})"
        if judge:
            model.options["feedthrough_rule"] = "auto: not judged (too short to score); D = 0"
        return model
    model.options["order_selection"] = table
    model.options["order_selection_rule"] = rule
    model.report = model.report.but(
        candidates=tuple(Candidate.from_dict(r) for r in table), selection_rule=rule
    )
    return model
