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
  whose noise model matters are judged with it.  (Choosing the predictor on the
  estimation part instead, where ``K`` was fitted, kept ``K`` for models it then made
  worse on the held-out part: the closed-loop quadrotor's order 3 lost to order 4.)
  A predictor ``A - K C`` that is unstable in sampled form is not scored with ``K``
  (:func:`hdpbsid.models.criteria.predictor_is_stable`: with each window's fitted initial state
  it would use the window's later outputs); such a model is scored by its simulation.

The rule of :func:`hdpbsid.models.criteria.choose_smallest_adequate` keeps, among all
candidates ordered by order, the first one whose error is within one standard error of
the best candidate's.  Among the candidates of that order within one standard error
(ties at the resolution of the held-out data), the one with the smallest simulation
error over the whole held-out part from one initial state wins (:func:`break_tie`: it
sees the slow errors that each window's fitted initial state hides).  That
``(method, order)`` is then identified on the whole record, after two checks that pass
the choice to the next candidate when they fail: the candidate must predict the whole
held-out part from one initial state better than its mean (:func:`beats_the_mean`), and
its refit on the whole record must score on the held-out part within one standard error
of the candidate (:func:`refit_holds`) and pass the same floor.  Held-out data judge the
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
refit's cost): the held-out part judged the candidate's predictor with them.

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
"""

from __future__ import annotations

import inspect
import time
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from hdpbsid.bases.basis_domain import BasisTooSmall
from hdpbsid.data.checks import check_data, check_positive_int, is_uniform
from hdpbsid.models.criteria import (
    MIN_WINDOWS,
    SAMPLES_PER_STATE,
    SIGNIFICANCE_Z,
    WindowedError,
    choose_smallest_adequate,
    default_windows,
    windowed_prediction_error,
    windowed_simulation_error,
)
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import Candidate, Choice, DirectTerm
from hdpbsid.runtime import library_call, user_stacklevel
from hdpbsid.selection.feedthrough import (
    check_feedthrough,
    feedthrough_offered,
    honours_feedthrough,
    judge_direct_term,
    structure_key,
    takes_feedthrough,
    with_d,
)

__all__ = [
    "identify_auto",
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
    "REJUDGE_Z",
    "decide_feedthrough",
    "NoCandidate",
    "AUTO_METHODS",
    "HOLDOUT",
]

#: methods tried by ``method="auto"`` (in this order; ``dt`` only on uniform samples)
AUTO_METHODS = ("hermite", "laguerre", "legendre", "dt")
#: share of the record held out for scoring (the last third, as users validate)
HOLDOUT = 1.0 / 3.0
#: largest order tried by default
AUTO_MAX_ORDER = 8


#: :func:`much_worse`: the returned model leaves more than this many times the held-out
#: residual energy of a rejected candidate, the smallest ratio the one-standard-error
#: rule resolves for any spread of the held-out windows (see there)
MUCH_WORSE_RATIO = 2.0


class SelectionWarning(UserWarning):
    """The held-out selection took a decision the user should know of: it returned a
    candidate fitted on part of the record, a model much worse on the held-out part than
    one it rejected, or a model no candidate of which passed its checks.  The message
    says what was rejected, why, and what to pass (``order=``, ``method=``) instead."""


#: with ``refined=True``, the best candidate of every order up to the chosen one whose
#: held-out error is within this many standard errors of the best is refined before the
#: order is decided (:func:`rejudge_refined`): a judgement, three times the
#: one-standard-error rule's margin (measured: the closed-loop bias of the subspace
#: candidates put the true order 1.4-2.2 SE behind a larger one on the Table-2 plant)
REJUDGE_Z = 3.0


def score_model(model: StateSpaceModel, rec: tuple, windows: int) -> tuple[WindowedError, bool]:
    """The held-out score of ``model`` on the record ``rec = (t, u, y)`` (module
    docstring): the smaller of its windowed one-step prediction error with its gain
    ``K`` and with ``K = 0`` (the simulation error), and whether that is the one with
    ``K``.  Non-uniform samples: the simulation error.

    A time series (``u`` with no columns) is scored by the prediction error with ``K``
    only: with no input the simulated output is the free response of the initial state
    fitted to each window, a fit of ``n`` exponentials to the window, not a prediction
    (more states always fit more of it: on a stationary second-order process observed
    in noise it chose 4-8 states).  The one-step prediction error is the criterion of
    time-series models (Ljung, *System Identification*, 2nd ed., sec. 7.2), computed
    with one initial state for the whole held-out part (``carry_state``): fitted per
    window, the initial state of a slow predictor fits the window's own later outputs.
    A non-uniformly sampled time series has no such score here (``finite=False``).
    """
    t, u, y = check_data(*rec)
    if u.shape[1] == 0:
        if not is_uniform(t):
            return WindowedError(np.full(windows, np.inf), np.inf, -np.inf, False), True
        return windowed_prediction_error(model, t, u, y, windows, carry_state=True), True
    sim = windowed_simulation_error(model, t, u, y, windows)
    if not is_uniform(t):
        return sim, False
    pred = windowed_prediction_error(model, t, u, y, windows)
    if pred.finite and (not sim.finite or pred.total < sim.total):
        return pred, True
    return sim, False


def accepts_held_out(func: Any) -> bool:
    """Whether the method ``func`` takes ``held_out=(t, u, y)``: data kept out of its
    record on which it judges its own data-driven settings (HD-PBSID's operator scale),
    reporting what it chose in ``options["refit_settings"]``.  The candidates of
    :func:`select_model` get the held-out part, and the refit of the chosen one gets
    its ``refit_settings``: one judge for the order, the method and those settings, and
    no second split of the estimation part inside a method."""
    try:
        return "held_out" in inspect.signature(func).parameters
    except (TypeError, ValueError):
        return False


def sweep_settings(func: Any, given: dict[str, Any]) -> dict[str, Any]:
    """The settings the candidates of method ``func`` are fitted with in a sweep: the
    ``given`` ones (the user's), and for a method that judges a setting of its own on
    held-out data (:func:`accepts_held_out`), the first-pass values it declares in its
    ``sweep_settings`` attribute for every such setting the user did not give.

    Why: such a judgement fits the candidate again at the setting the data ask for
    (HD-PBSID: one to two more fits at an operator scale of their own per order, which
    no other order shares), and only the chosen candidate's setting reaches the result;
    it is judged for that candidate by :func:`settle_candidate`.  Measured on 80 records
    of random stable systems (orders 1-4, open and closed loop, 20 dB): the true order
    picked on 58 against 57 with the judgement in every candidate, in 14 % less CPU time.
    """
    first = getattr(func, "sweep_settings", None) if accepts_held_out(func) else None
    return {**(first or {}), **given}


def refit_keeps(func: Any, model: StateSpaceModel, given: dict[str, Any]) -> dict[str, Any]:
    """The data-driven settings of candidate ``model`` that its refit on the whole
    record keeps: those the method ``func`` lists in its ``refit_keeps`` attribute
    (``dt``: the past and future windows), with the values the candidate used, except
    the ones the user gave (``given``, passed as they are).

    Why: the held-out part judged the candidate's predictor as it was built, windows
    included; the refit re-estimates that structure on more data (as it keeps the
    order), instead of asking the data again for a setting the judgement did not test.
    A method lists a setting here when choosing it again would be costly (``dt``'s
    past-window criterion: a QR over up to 200 lags, most of a refit's time); the
    settings that can be kept are the core's windows ``"p"`` and ``"f"``, which the
    model reports (``model.report.windows``).
    """
    keys = getattr(func, "refit_keeps", ())
    used = model.report.windows
    return {k: used[k] for k in keys if k not in given and k in used}


def _refit_settings(model: StateSpaceModel) -> dict[str, Any]:
    """The settings ``model``'s method chose on held-out data for a refit of it
    (``model.report.refit_settings``; empty when none)."""
    chosen = model.report.refit_settings
    return {} if chosen is None else dict(chosen.value)


def settle_candidate(
    get_method: Any, row: dict[str, Any], est: tuple, val: tuple, windows: int, options: dict
) -> dict[str, Any]:
    """The candidate ``row`` with the settings its method judges on held-out data
    (:func:`sweep_settings`) judged: fitted again on ``est`` with the user's settings
    and ``held_out=val``, scored (:func:`score_model`), and that fit replaces the row's
    model and score (``row["settled"] = True``; the sweep's first-pass fit is kept in
    ``row["first_pass"]``).  A candidate whose method declares no such settings, whose
    settings the user gave, or whose second fit fails or cannot be scored is returned as
    it is, its refit then given the first-pass settings it was fitted with.  Idempotent."""
    func = get_method(row["method"])
    given = _given(row, options)
    first = sweep_settings(func, given)
    if row.get("settled") or first == given:
        return row
    row["settled"] = True
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = func(*est, order=row["order"], **given, held_out=val)
            if stationarity_problem(model):
                raise ValueError(stationarity_problem(model))
            err, use_k = score_model(model, val, windows)
    except (ValueError, np.linalg.LinAlgError):
        err = None
    if err is None or not err.finite:
        # the first-pass fit stands; its refit on the whole record gets its settings
        carried = {k: v for k, v in first.items() if k not in given}
        row["model"].options["refit_settings"] = carried
        row["model"].report = row["model"].report.but(
            refit_settings=Choice(
                carried, "the first pass's (its fit judged on held-out data failed)"
            )
        )
        return row
    row["first_pass"] = {"model": row["model"], "criterion": row["criterion"]}
    if "p_rule" in row:
        model.options["p_rule"] = row["p_rule"]
    row.update(
        model=model,
        criterion=err,
        predictor="innovation (K)" if use_k else "output error (K = 0)",
    )
    return row


def stationarity_problem(model: StateSpaceModel) -> str:
    """Why ``model``, a model of a time series (no input), cannot describe a stationary
    process, or ``""``.

    The output of ``dx/dt = A x + K e``, ``y = C x + e`` driven by white ``e`` is
    stationary only when every mode that ``e`` excites decays, i.e. when ``A`` is stable
    (``Re lambda < 0`` for every eigenvalue of a minimal model; an eigenvalue at 0 is a
    random walk, whose variance grows with time).  A time series is identified as a
    stationary process -- its held-out one-step prediction error judges a spectrum, the
    same for a stable and a mirrored unstable pole -- so a model with an unstable ``A``
    describes a process the record, bounded and stationary, is not.  Such a model is not
    a candidate (:func:`select_model`); a non-stationary record (a trend, a random walk)
    should be differenced or detrended first.
    """
    if model.m > 0 or model.n == 0:
        return ""
    lam = np.linalg.eigvals(model.A)
    bad = lam[~(lam.real < 0.0)]
    if bad.size == 0:
        return ""
    shown = ", ".join(f"{z:.3g}" for z in bad[:4])
    return (
        f"not stationary: A has eigenvalue(s) {shown} with Re >= 0, but a time series "
        f"(no input) is modelled as a stationary process, which needs a stable A"
    )


def _among(row: dict[str, Any], rows: Sequence[dict[str, Any]]) -> bool:
    """Whether the candidate ``row`` is one of ``rows`` (by identity: two candidates of
    one method and order, with and without ``D``, are different rows)."""
    return any(r is row for r in rows)


def _index(rows: Sequence[dict[str, Any]], row: dict[str, Any]) -> int:
    """The position of the candidate ``row`` in ``rows``, by identity (:func:`_among`)."""
    return next(i for i, r in enumerate(rows) if r is row)


def _given(row: dict[str, Any], options: dict) -> dict[str, Any]:
    """The settings candidate ``row`` of a sweep is fitted with: its method's in
    ``options`` (the user's), and the row's own (``row["settings"]``: ``feedthrough``
    for a candidate with ``D`` of :mod:`hdpbsid.selection.feedthrough`)."""
    return {**options.get(row["method"], {}), **row.get("settings", {})}


def _fit_at_order(
    func: Any, rec: tuple, order: int, settings: dict[str, Any], order_given: bool
) -> tuple[StateSpaceModel, dict[str, Any], str]:
    """``func`` fitted on ``rec`` at ``order`` with ``settings``, and the settings it took
    beyond them.  When the user gave the order (``order_given``) and the method's default
    past window cannot reach it on this basis (:class:`~hdpbsid.bases.basis_domain.
    BasisTooSmall`: the precision rule ``p (m + q + l) <= N / 6`` caps the window below
    the ``f l >= n`` rows the order needs), the smallest window that reaches it is
    passed, if the VARX is determined there: a less precise model of the order asked
    for instead of none.  In a sweep over orders the rule stands, so that an imprecise
    large order does not compete with the orders the basis supports.  The third value is
    the reason for the window passed (empty when none was)."""
    try:
        return func(*rec, order=order, **settings), {}, ""
    except BasisTooSmall as exc:
        if not order_given or "p" in settings or exc.p_needed > exc.p_max:
            raise
        extra = {"p": exc.p_needed}
        model = func(*rec, order=order, **settings, **extra)
        rule = (
            f"p = {exc.p_needed}, the smallest window that reaches the order asked for, "
            f"above the precision rule (the VARX is determined up to p = {exc.p_max}; "
            f"less precise than a basis that holds the default window)"
        )
        model.options["p_rule"] = rule
        return model, extra, rule


def _fit_one(
    get_method: Any,
    method: str,
    order: int,
    est: tuple,
    val: tuple,
    windows: int,
    options: dict,
    order_given: bool = False,
) -> dict[str, Any]:
    t0 = time.perf_counter()
    row: dict[str, Any] = {"method": method, "order": order}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            func = get_method(method)
            settings = sweep_settings(func, options.get(method, {}))
            model, extra, p_rule = _fit_at_order(func, est, order, settings, order_given)
            if extra:
                row["settings"] = extra
                row["p_rule"] = p_rule
            if not isinstance(model, StateSpaceModel):
                raise TypeError(
                    f"method {method!r} returned {type(model).__name__}, expected StateSpaceModel"
                )
            why = stationarity_problem(model)
            if why:
                raise ValueError(why)
            err, use_k = score_model(model, val, windows)
        row.update(
            status="ok"
            if err.finite
            else "not scored: its one-step predictor is unstable or its simulation overflows",
            criterion=err,
            predictor="innovation (K)" if use_k else "output error (K = 0)",
            model=model,
        )
    except (ValueError, np.linalg.LinAlgError) as exc:
        row.update(status=f"{type(exc).__name__}: {exc}", criterion=None, predictor=None)
    row["time"] = time.perf_counter() - t0
    return row


def _sweep_method(
    get_method: Any,
    method: str,
    orders: list[int],
    est: tuple,
    val: tuple,
    windows: int,
    options: dict,
    order_given: bool = False,
) -> list[dict[str, Any]]:
    """Every order of one method, upwards (the orders share the method's memoised
    order-independent steps, :mod:`hdpbsid.bases.memo`)."""
    return [
        _fit_one(get_method, method, n, est, val, windows, options, order_given) for n in orders
    ]


def _sweep(
    get_method: Any,
    methods: Sequence[str],
    orders: list[int],
    est: tuple,
    val: tuple,
    windows: int,
    options: dict,
    n_jobs: int | None,
    order_given: bool = False,
) -> list[dict[str, Any]]:
    """Every ``(method, order)`` candidate, listed orders upwards and, within an order, in
    the order of ``methods`` (``order_given``: the user asked for the one order, see
    :func:`_fit_at_order`).  With ``n_jobs`` the methods are swept in parallel
    (joblib), each method's orders in one worker, where they share its memoised
    projection and operators; the candidates, and so the result, are those of the
    serial run (bit for bit when that runs with one BLAS thread, as the workers do).

    Every order is fitted: a larger order that does not beat the best by a standard
    error cannot be chosen, but it can become the best and so move the reference of the
    one-standard-error rule (the closed-loop quadrotor's order 3 against 2 depends on
    its order 7), so stopping the sweep early would change the choice.
    """
    args = (orders, est, val, windows, options, order_given)
    if n_jobs is not None and n_jobs != 1 and len(methods) > 1:
        from joblib import Parallel, delayed

        # one BLAS thread per worker: the candidates are small problems (threads only
        # oversubscribe the cores), and the workers' arithmetic is then that of a serial
        # run with one BLAS thread, bit for bit (with several, BLAS sums split
        # differently and the last digits differ)
        per_method = Parallel(n_jobs=n_jobs, inner_max_num_threads=1)(
            delayed(_sweep_method)(get_method, m, *args) for m in methods
        )
    else:
        per_method = [_sweep_method(get_method, m, *args) for m in methods]
    return [rows[i] for i in range(len(orders)) for rows in per_method]


def _refine_and_score(
    model: StateSpaceModel, est: tuple, val: tuple, windows: int
) -> tuple[StateSpaceModel | None, WindowedError]:
    """``model`` refined on ``est`` (:func:`hdpbsid.refine.pem.refine_pem`; None when
    the refinement fails or does not converge) and the held-out score
    (:func:`score_model`) of the refined model, or of ``model`` itself without one."""
    from hdpbsid.refine.pem import refine_pem

    refined = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            fit = refine_pem(model, *est)
            if fit.report.converged:
                refined = fit
        except (ValueError, np.linalg.LinAlgError):
            pass
        err, _ = score_model(model if refined is None else refined, val, windows)
    return refined, err


def _refined_error(r: dict[str, Any], est: tuple, val: tuple, windows: int) -> WindowedError:
    """The held-out score of candidate ``r``'s model refined on ``est``
    (:func:`_refine_and_score`), kept in ``r["refined_criterion"]`` (and the refined
    model in ``r["refined_model"]``)."""
    if r.get("refined_criterion") is None:
        _refine_rows([r], est, val, windows, None)
    return r["refined_criterion"]


def _refine_rows(
    rows: list[dict[str, Any]], est: tuple, val: tuple, windows: int, n_jobs: int | None
) -> None:
    """:func:`_refined_error` of every row of ``rows`` not refined yet, in parallel with
    joblib when ``n_jobs`` is given (one BLAS thread per worker, as in :func:`_sweep`: the
    same numbers as the serial run)."""
    todo = list({id(r): r for r in rows if r.get("refined_criterion") is None}.values())
    if n_jobs is not None and n_jobs != 1 and len(todo) > 1:
        from joblib import Parallel, delayed

        out = Parallel(n_jobs=n_jobs, inner_max_num_threads=1)(
            delayed(_refine_and_score)(r["model"], est, val, windows) for r in todo
        )
    else:
        out = [_refine_and_score(r["model"], est, val, windows) for r in todo]
    for r, (refined, err) in zip(todo, out, strict=True):
        if refined is not None:
            r["refined_model"] = refined
        r["refined_criterion"] = err


def looks_closed_loop(model: StateSpaceModel, rec: tuple) -> bool:
    """Whether the feedback test (:func:`hdpbsid.selection.feedback.feedback_statistics`: the
    one-step prediction errors of ``model`` on ``rec = (t, u, y)`` correlated with the
    prewhitened input at positive lags) declares the record closed loop; False when it
    cannot be computed (the predictor diverges on the record)."""
    from hdpbsid.refine.pem import one_step_errors
    from hdpbsid.selection.feedback import feedback_statistics

    t, u, y = rec
    try:
        with warnings.catch_warnings(), np.errstate(over="ignore", invalid="ignore"):
            warnings.simplefilter("ignore")
            errors = one_step_errors(model, t, u, y)
            return bool(feedback_statistics(model, t, u, y, errors=errors)["feedback"])
    except (ValueError, np.linalg.LinAlgError):
        return False


def rejudge_refined(
    ok: list[dict[str, Any]],
    stats: list[float],
    k: int,
    est: tuple,
    val: tuple,
    windows: int,
    n_jobs: int | None = None,
) -> tuple[int, str]:
    """The order decided again between refined candidates; returns ``(index into ok,
    rule text)`` (``k`` and ``""`` when there is nothing to decide).

    The candidates are subspace estimates, and a subspace estimate is biased where the
    noise is correlated with its regressors (closed loop, most of all); the bias can move
    the held-out ranking of the orders both ways.  The model returned is refined by the
    prediction-error method (``refine="auto"``), which is consistent also in closed
    loop; so the order should be decided between refined candidates.  Refining all of
    them would cost a refinement per candidate; only the decisions the bias can flip are
    taken again, each candidate refined on the estimation part and scored on the held-out
    part (:func:`_refined_error`).  Only the best candidate of an order whose error is
    within :data:`REJUDGE_Z` standard errors of the best takes part.

    *Down.*  Extra states can absorb part of the bias, so a larger order can score better
    than the true one although the true one, fitted efficiently, would not be beaten.
    The orders up to the chosen order ``n*`` are refined and the one with the smallest
    refined error is taken.  Not the one-standard-error rule again: its preference for
    the smaller order was applied once, to choose ``n*``; here a smaller order replaces
    ``n*`` only when, refined, it predicts at least as well as ``n*`` refined -- the bias
    correction, not a second discount for parsimony (with the rule applied twice the
    closed-loop quadrotor's order 3, an unstable pole that adds little output variance,
    lost to a refined order 2 within one standard error on 4 of 10 seeds).  Measured on
    the Table-2 closed loop (rate and acceleration, 20 dB, ``feedthrough=True``, seeds
    0-4): the unrefined candidates chose order 5-6 on every seed; with this step order 4,
    the plant's, on 2 of 5.

    *Up.*  The bias can also make a too small order look adequate: on the Table-2 plant
    with the rate output only (20 dB, seeds 0-4) the subspace order-3 candidate scored
    better on held-out data than its own prediction-error refit (0.0086-0.0092 against
    0.0094-0.0102, 3.2-5.3 standard errors) and tied with order 4, so the
    one-standard-error rule chose 3, while refined, order 4 beats order 3 by 4.3-6.3
    standard errors.  That symptom -- the consistent refit of the chosen structure
    predicting worse than its biased estimate, by more than one standard error -- is what
    the step looks for, when the feedback test declares the record closed loop
    (:func:`looks_closed_loop`, on the chosen candidate's errors over the estimation part;
    in open loop the subspace candidates are consistent and the ranking is not biased):
    then the next larger order is refined too and replaces the decision when it beats it
    by more than one standard error (:func:`~hdpbsid.models.criteria.choose_smallest_adequate`
    with the smaller order listed first: the burden of proof on the larger order), and so
    on upwards.  Without the symptom no larger order is refined (closed-loop quadrotor,
    seeds 0-5: the refit of the chosen order 3 within 0.22 standard errors of its subspace
    estimate).

    Each refined candidate's score is added to its row (``refined_error``,
    ``refined_fit``).  ``n_jobs``: the refinements known to be needed at the start (the
    orders down, and the chosen order in closed loop) run in parallel (joblib); the
    decision is that of the serial run.
    """
    if isinstance(est[0], list | tuple) or not is_uniform(np.asarray(est[0], dtype=float)):
        return k, ""
    n_star = ok[k]["order"]
    best_of: dict[int, dict[str, Any]] = {}
    for r, z in zip(ok, stats, strict=True):
        n = r["order"]
        if z <= REJUDGE_Z:
            if n not in best_of or r["criterion"].total < best_of[n]["criterion"].total:
                best_of[n] = r
    chosen, rule = ok[k], ""
    lower = [best_of[n] for n in sorted(best_of) if n <= n_star]
    n_up = n_star + 1
    upward = n_up in best_of and looks_closed_loop(ok[k]["model"], est)
    needed = (lower if len(lower) >= 2 else []) + ([ok[k]] if upward else [])
    _refine_rows(needed, est, val, windows, n_jobs)
    if upward:
        # the symptom of a choice the bias made: refined, the chosen candidate predicts
        # the held-out part worse than its subspace estimate did, by more than one SE
        e_ref, e_sub = _refined_error(ok[k], est, val, windows), ok[k]["criterion"]
        upward = e_ref.finite and choose_smallest_adequate([e_ref, e_sub])[1][0] > SIGNIFICANCE_Z
    if len(lower) >= 2:
        errors = [_refined_error(r, est, val, windows) for r in lower]
        finite = [i for i, e in enumerate(errors) if e.finite]
        if finite:
            j = min(finite, key=lambda i: (errors[i].total, i))
            chosen = lower[j]
            names = ", ".join(f"{r['method']} {r['order']}" for r in lower)
            rule = (
                f"; order decided again between refined candidates ({names}; within "
                f"{REJUDGE_Z:g} SE of the best), the smallest refined error: "
                f"{chosen['method']} order {chosen['order']}"
            )
    if upward:
        while n_up in best_of:
            e_now = _refined_error(chosen, est, val, windows)
            e_up = _refined_error(best_of[n_up], est, val, windows)
            if not (e_now.finite and e_up.finite):
                break
            step, z = choose_smallest_adequate([e_now, e_up])
            if step != 1:
                break
            chosen = best_of[n_up]
            rule += (
                f"; closed loop (feedback test): refined, {chosen['method']} order "
                f"{chosen['order']} beats order {chosen['order'] - 1} by {z[0]:.1f} SE"
            )
            n_up += 1
    return _index(ok, chosen), rule


def break_tie(tied: list[dict[str, Any]], val: tuple) -> list[dict[str, Any]]:
    """The candidates ``tied`` (one order, every one within one standard error of the
    best held-out error) ordered by their simulation error over the whole held-out
    record ``val`` from one fitted initial state (windows = 1), best first; each row
    gets ``"whole_simulation"`` (that error, relative).

    Why: the windowed criterion fits an initial state in every window, and a model's
    free response over a window can imitate any error that is slow compared with the
    window, so errors at time scales beyond a window (a wrong slow or unstable mode, a
    wrong static gain) are invisible to it; held-out windows must be short to give the
    several windows a standard error needs.  Among candidates that the windowed
    criterion cannot tell apart, the one-window simulation -- what a user validating
    on the held-out part computes (MATLAB ``compare``) -- sees those errors.  Only
    candidates of the chosen order compete (equal state dimension, so equal numbers of
    parameters: the one-standard-error rule's choice of complexity is unchanged), so
    the closed-loop bias of a simulation criterion (module docstring) can move the
    method, not the order.  On the ball-and-beam record (DaISy) the windowed scores of
    ``laguerre`` and ``legendre`` at order 4 were 0.12 standard errors apart and their
    one-window simulation errors 5x apart, the order of their validation fits.
    """
    if len(tied) < 2:
        return tied
    for r in tied:
        e = whole_held_out_error(r["model"], val)
        r["whole_simulation"] = e.total if e.finite else np.inf
    return sorted(tied, key=lambda r: r["whole_simulation"])


def whole_held_out_error(model: StateSpaceModel, val: tuple) -> WindowedError:
    """The simulation error of ``model`` over the whole held-out record ``val`` from one
    fitted initial state (one window; :func:`break_tie`): the validation a user runs on
    it.  A time series has no simulation to run (:func:`score_model`): its one-step
    prediction over the whole held-out part from one initial state."""
    t, u, y = check_data(*val)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if u.shape[1] == 0:
            return score_model(model, val, 1)[0]
        return windowed_simulation_error(model, t, u, y, 1)


def beats_the_mean(model: StateSpaceModel, val: tuple) -> tuple[bool, str]:
    """Whether ``model`` predicts the whole held-out record ``val`` better than its mean:
    the better of its two predictors (:func:`score_model`) run over the whole held-out
    part from one fitted initial state (one window, the validation a user runs) has a
    relative error below 1, i.e. a fit above 0 %.

    A floor, not a ranking: a model that does worse than the mean of the data it is
    validated on is no model of them, whatever its windowed score.  The windowed
    criterion fits an initial state in every short window, which hides errors slower
    than a window (:func:`break_tie`), in particular a spurious fast-growing mode: within
    a window its free response can cancel the growth of the forced response, over the
    whole held-out part no initial state can (in floating point, a growth beyond
    ``1/eps``), and the simulation diverges.  On the robot-arm record (DaISy),
    ``method="hermite"`` had chosen order 7, a pair at ``Re = +1.06`` per sample that won
    the windowed score with a 96.5 % fit and simulated the held-out part with a relative
    error of 1e174.  An unstable plant in closed loop passes through its stable
    innovation predictor.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole, _ = score_model(model, val, 1)
    if whole.finite and whole.total < 1.0:
        return True, ""
    return False, (
        "over the whole held-out part (one initial state) it predicts worse than the mean "
        f"(relative error {whole.total:.3g})"
    )


def grows(model: StateSpaceModel) -> bool:
    """Whether ``model`` has a growing mode: an eigenvalue of ``A`` with ``Re > 0``
    (compared with 0 exactly; a mode at ``Re = +1e-12`` is one, and is judged as one)."""
    return model.n > 0 and bool(np.any(np.linalg.eigvals(model.A).real > 0.0))


def _worst_eigenvalue(model: StateSpaceModel) -> complex:
    lam = np.linalg.eigvals(model.A)
    return complex(lam[int(np.argmax(lam.real))])


def instability_problem(row: dict[str, Any], pool: Sequence[dict[str, Any]]) -> str:
    """Why the held-out record does not support the growth of candidate ``row``, or
    ``""`` (a stable candidate, or a growth the record supports).  ``pool``: the
    candidates the one-standard-error rule admits (rows with ``model``, ``order`` and
    held-out ``criterion``; :func:`select_model` passes those within one standard error
    of the best).

    The rule: an unstable candidate is rejected when a *stable* candidate of no larger
    order, itself admitted, predicts the held-out part as well -- within one standard
    error of it by the held-out score that ranks the candidates (:func:`score_model`;
    :func:`~hdpbsid.models.criteria.choose_smallest_adequate` with the stable one listed first,
    so the burden of proof is on the growth).  Then the record does not need the growth:
    a stable model, no more complex and as good by the selection's own rule, explains
    what it shows, and it is the one chosen instead.  A stable rival the rule does not
    admit is no rival: rejecting the growth for it would hand the choice to a larger
    candidate, not to it.  A time series (no input)
    is modelled as a stationary process: :func:`stationarity_problem`.

    Why not judge the unstable candidate alone.  A bounded record of an unstable plant
    is only possible inside a feedback loop, where the input holds the growth back; the
    feedback test (:func:`looks_closed_loop`) sees the loop only in the part of the output
    the controller reacts to that the model cannot predict, and a loop driven by its
    reference with little noise leaves none.  Without it, no test of
    one model separates a true unstable plant from a spurious growing mode: over a
    horizon ``T`` any error of the state estimated from the past grows as
    ``e^(sigma T)``, so a free run from the state fitted on the record's start diverges
    for the true plant too (a rule built on it rejected every candidate of a measured
    record of a plant in such a loop and fell back to a first-order model); and with the
    initial state fitted on the judged horizon itself, the later inputs cancel any
    growth up to ``1/eps``, so it passes a spurious mode too.  A comparison with the stable
    alternatives needs neither: it asks what the held-out data prefer, at the resolution
    of the held-out data, as the order is chosen (Hastie, Tibshirani & Friedman, *The
    Elements of Statistical Learning*, 2nd ed., sec. 7.10).  A growing mode that the data
    cannot tell from a stable model is not supported; one that every stable candidate of
    its size predicts worse than, beyond the spread of the held-out windows, is.  Larger
    stable candidates are not rivals: the order is chosen first, by the same rule, and
    stability is not bought with states the data do not ask for.
    """
    model = row["model"]
    if model.m == 0:
        return stationarity_problem(model)
    if not grows(model):
        return ""
    err = row["criterion"]
    for r in pool:
        c = r.get("criterion")
        if r is row or c is None or not c.finite or r["order"] > row["order"]:
            continue
        if grows(r["model"]) or c.per_window.size != err.per_window.size:
            continue
        k, stats = choose_smallest_adequate([c, err])
        if k == 0:
            return (
                f"unstable (eigenvalue {_worst_eigenvalue(model):.3g}) where the record does "
                f"not need the growth: the stable {r['method']} order {r['order']} predicts "
                f"the held-out part at least as well by the one-standard-error rule (the two "
                f"differ by {abs(stats[0] - stats[1]):.2g} standard errors)"
            )
    return ""


def refinement_instability(start: StateSpaceModel, refined: StateSpaceModel, rec: tuple) -> str:
    """Why the refinement ``refined`` of ``start`` on the record ``rec = (t, u, y)``
    grew a mode the record does not support, or ``""``.

    The prediction-error refinement judges the predictor ``A - K C``, stable either way,
    so by itself it does not keep ``A`` stable.  A refinement that makes a stable
    ``start`` unstable is kept only when the record asks for the growth, by the rule of
    :func:`instability_problem` with ``start`` as the stable rival of equal order: the
    windowed simulation error on the record
    (:func:`~hdpbsid.models.criteria.windowed_simulation_error`, the deterministic
    response whose growth is in question; the refinement did not fit it) of the refined
    model must beat the start's by more than one standard error.  A
    time series' refined model must be stationary (:func:`stationarity_problem`).
    """
    if not grows(refined) or grows(start):
        return ""
    if refined.m == 0:
        return stationarity_problem(refined)
    t, u, y = check_data(*rec)
    windows = max(1, default_windows(t.size, refined.n))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            e_ref = windowed_simulation_error(refined, t, u, y, windows)
            e_start = windowed_simulation_error(start, t, u, y, windows)
        except (ValueError, np.linalg.LinAlgError):
            return ""
    why = f"unstable (eigenvalue {_worst_eigenvalue(refined):.3g}) where the start was stable"
    if not e_ref.finite:
        return why + ", and its simulation of the record overflows"
    if e_start.finite and choose_smallest_adequate([e_start, e_ref])[0] == 0:
        return (
            why + ": the stable start simulates the record as well (within one standard "
            "error), so the record does not need the growth"
        )
    return ""


def refit_holds(
    model: StateSpaceModel, held_out: WindowedError, val: tuple, windows: int
) -> tuple[bool, str]:
    """Whether ``model``, a candidate identified again on the whole record, is as good on
    the held-out part ``val`` as the candidate was, and why not.

    The refit has seen the held-out samples, so its error there (the same criterion,
    :func:`score_model`) is an in-sample error, and a correct refit of the same model
    structure scores no worse than the candidate did out of sample, up to the noise of
    the criterion.  More than one standard error of the candidate's held-out windows
    worse (the one-standard-error rule of :func:`~hdpbsid.models.criteria.choose_smallest_adequate`
    with the refit listed first) means the refit is not the model that was chosen: the
    method's data-driven settings (operator scale, past window, basis size, input hold)
    are chosen again on the whole record and can change with it.  Such a refit is not
    returned; the next candidate is tried, as when the refit raises.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        refit, _ = score_model(model, val, windows)
    if not refit.finite:
        return False, "the refit on the whole record cannot be simulated on the held-out part"
    k, stats = choose_smallest_adequate([refit, held_out])
    if k == 0:
        return True, ""
    return False, (
        f"the refit on the whole record scores {stats[0]:.1f} standard errors worse on the "
        f"held-out part than the candidate did without seeing it"
    )


def _first_that_holds(
    get_method: Any,
    candidates: list[dict[str, Any]],
    est: tuple,
    whole: tuple,
    val: tuple,
    windows: int,
    opts: dict,
    floor: bool = True,
    pool: Sequence[dict[str, Any]] = (),
) -> tuple[StateSpaceModel | None, list[tuple[str, str, dict[str, Any]]], dict[str, Any] | None]:
    """The first of ``candidates`` that, with its held-out-judged settings settled
    (:func:`settle_candidate`, fitted on ``est``), passes the floor (unless ``floor`` is
    False): :func:`beats_the_mean`, and :func:`instability_problem` against the scored
    candidates ``pool``; and whose refit on the ``whole`` record passes
    :func:`refit_holds` and :func:`beats_the_mean`, refitted, and grows no mode the
    candidate did not have (the held-out part judged a stable model; the growth of the
    refit was never judged); or None.  Returns ``(model, failures, row)``, ``row`` the
    candidate whose refit is returned.  The floor for the refit:
    the windowed score of :func:`refit_holds` fits an initial state per window, so a
    refit with a spurious growing mode can pass it and still diverge over the held-out
    part it was fitted on (robot arm, DaISy, ``method="chebyshev"``: the order-8 refit
    had a pair at ``+0.59 +- 1.5i`` rad/s and a validation fit below -100 %).  Also
    every failure as ``(kind, text, row)``, kind ``"floor"`` or ``"refit"``; a candidate that
    passed the floor is marked ``passed_floor`` (its own model, fitted on ``est``, is then
    a sound answer when no refit holds: :func:`select_model`)."""
    failures: list[tuple[str, str, dict[str, Any]]] = []
    for chosen in candidates:
        settle_candidate(get_method, chosen, est, val, windows, opts)
        name = f"{chosen['method']} order {chosen['order']}"
        if floor:
            useful, how = beats_the_mean(chosen["model"], val)
            how = how or instability_problem(chosen, pool)
            if how:
                failures.append(("floor", f"{name}: {how}", chosen))
                continue
            chosen["passed_floor"] = True
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                func = get_method(chosen["method"])
                given = _given(chosen, opts)
                kept = refit_keeps(func, chosen["model"], given)
                settings = {**given, **kept, **_refit_settings(chosen["model"])}
                model = func(*whole, order=chosen["order"], **settings)
                if with_d(chosen) and not honours_feedthrough(model) and model.m:
                    # judged as a structure with D: D is a parameter of the refinement
                    # (hdpbsid.refine.pem), whatever the method says of its own D
                    _with_d_asked(model)
                if "p_rule" in chosen:
                    model.options["p_rule"] = chosen["p_rule"]
                holds, how = refit_holds(model, chosen["criterion"], val, windows)
                if holds and floor:
                    # the floor the candidate passed, for the model returned: a refit
                    # whose windowed score holds can still diverge over the whole part
                    holds, how = beats_the_mean(model, val)
                    if not how and grows(model) and not grows(chosen["model"]):
                        how = (
                            f"it has a growing mode (eigenvalue {_worst_eigenvalue(model):.3g}) "
                            f"that the candidate judged on the held-out part did not have"
                        )
                    holds = not how
                    how = f"the refit on the whole record: {how}" if how else how
                why = stationarity_problem(model) if holds else ""
                if why:
                    holds, how = False, f"the refit on the whole record: {why}"
        except (ValueError, np.linalg.LinAlgError) as exc:
            holds, how = False, str(exc)
        if holds:
            warm = chosen.get("refined_model")
            if warm is not None:
                from hdpbsid.refine.pem import warm_start_option

                # the candidate refined on the estimation part: a starting point of the
                # refinement of the refit (hdpbsid.refine.pem.refine_pem)
                model.report = model.report.but(warm_start=warm_start_option(warm))
            _carry_refit_settings(model, chosen["model"])
            if kept:
                model.options["refit_kept"] = kept
                model.options["refit_kept_rule"] = (
                    "the candidate's own values, judged with it on the held-out part "
                    "(hdpbsid.selection.auto.refit_keeps)"
                )
            return model, failures, chosen
        failures.append(("refit", f"{name}: {how}", chosen))
    return None, failures, None


def _with_d_asked(model: StateSpaceModel) -> None:
    """Mark the refit ``model`` of a candidate judged as a structure with ``D`` as asked
    for ``D``: a parameter of the refinement (:mod:`hdpbsid.refine.pem`), whatever the
    method says of its own ``D`` (kept in ``options["feedthrough_method"]``)."""
    own = model.report.feedthrough
    model.options["feedthrough_method"] = None if own is None else own.reason
    model.options["feedthrough"] = True
    model.report = model.report.but(feedthrough=DirectTerm(True, False))


def _carry_refit_settings(model: StateSpaceModel, candidate: StateSpaceModel) -> None:
    """Report on the refit ``model`` the settings its ``candidate`` chose on the held-out
    part and the refit was given (``report.refit_settings``)."""
    carried = candidate.report.refit_settings
    if carried is None or not carried.value:
        return
    model.options["refit_settings"] = carried.value
    model.options["refit_settings_rule"] = (
        "chosen with the candidate on the held-out part (its options "
        f"{sorted(carried.value)}: {carried.reason}); given to the refit on the whole record"
    )
    model.report = model.report.but(refit_settings=carried)


def _rows_table(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    table = []
    for r in rows:
        c = r["criterion"]
        table.append(
            {
                "method": r["method"],
                "order": r["order"],
                "feedthrough": with_d(r),
                "error": c.total if c is not None else None,
                "fit": c.fit if c is not None else None,
                "z": r.get("z"),
                "whole_simulation": r.get("whole_simulation"),
                "refined_error": r["refined_criterion"].total
                if r.get("refined_criterion") is not None
                else None,
                "refined_fit": r["refined_criterion"].fit
                if r.get("refined_criterion") is not None
                else None,
                "predictor": r.get("predictor"),
                "first_pass_error": r["first_pass"]["criterion"].total
                if r.get("first_pass") is not None
                else None,
                "time": r["time"],
                "status": r["status"],
            }
        )
    return table


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

    Raises ``ValueError`` when the record is too short to hold out enough scoring windows
    (the message says what would work) or when no candidate can be identified.
    """
    from hdpbsid.data.records import as_records, is_record_list
    from hdpbsid.methods.registry import get_method

    if not (isinstance(holdout, float | int) and 0.0 < float(holdout) < 1.0):
        raise ValueError(f"holdout must be a number in (0, 1), got {holdout!r}")
    several = is_record_list(t) and len(t) > 1
    if several:
        # several records: the last one is held out, the others identify the candidates
        recs = as_records(t, u, y)
        last = recs[-1]
        val = (last.t, last.u, last.y)
        est_list = [(r.t, r.u, r.y) for r in recs[:-1]]
        est: tuple = (est_list, None, None) if len(est_list) > 1 else est_list[0]
        n_val, where = last.t.size, "the last record"
    else:
        t, u, y = check_data(t, u, y)
        split = int(round(t.size * (1.0 - float(holdout))))
        est = (t[:split], u[:split], y[:split])
        val = (t[split:], u[split:], y[split:])
        n_val, where = t.size - split, f"the last {holdout:.0%} of the record"
    windows = default_windows(n_val, max(orders))
    if windows < MIN_WINDOWS:
        raise ValueError(
            f"choosing the order scores candidates on {where} ({n_val} samples) cut into "
            f"at least {MIN_WINDOWS} windows of {SAMPLES_PER_STATE * max(orders)} samples "
            f"({SAMPLES_PER_STATE} per state of the largest order {max(orders)}), i.e. "
            f"{MIN_WINDOWS * SAMPLES_PER_STATE * max(orders)} held-out samples; supply a "
            f"longer record, a smaller max_order, or give the order"
        )
    time_series = val[1].shape[1] == 0
    if time_series and not is_uniform(val[0]):
        raise ValueError(
            "t: choosing the order of a time series (no input) scores the one-step "
            "prediction error on held-out data, which needs uniformly sampled times; "
            "resample the record uniformly or give the order"
        )
    opts = method_options or {}
    args = (get_method, methods, sorted(orders), est, (t, u, y), val, windows, where, opts)
    try:
        return _select(*args, n_jobs, refined, judge_feedthrough, relax=False)
    except NoCandidate:
        if not order_given:
            raise
    # no method answers at the order the user asked for with its default settings: the
    # basis methods that can, at a less precise past window, answer (_fit_at_order)
    return _select(*args, n_jobs, refined, judge_feedthrough, relax=True)


class NoCandidate(ValueError):
    """No candidate of the held-out selection can be identified and scored, or no
    scored candidate's refit on the whole record holds (:func:`select_model`)."""


def _select(
    get_method: Any,
    methods: Sequence[str],
    orders: list[int],
    est: tuple,
    whole: tuple,
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
    ok = [r for r in rows if r["criterion"] is not None and r["criterion"].finite]
    if not ok:
        detail = "; ".join(f"{r['method']} order {r['order']}: {r['status']}" for r in rows)
        hint = (
            "; a time series needs a stationary model with a stable one-step predictor: "
            "detrend or difference a drifting record, or try another method"
            if time_series
            else ""
        )
        raise NoCandidate(f"no candidate model could be identified and scored ({detail}){hint}")
    ok.sort(key=structure_key)
    k, stats = choose_smallest_adequate([r["criterion"] for r in ok])
    ft_rule = ""
    if judge_feedthrough:
        extra, ft_rule, bound = _feedthrough_candidates(
            get_method, ok, ok[k], methods, orders, est, val, windows, opts, n_jobs, relax
        )
        rows = rows + extra
        ok, ft_rule = _choose_structure(ok, k, extra, val, windows, ft_rule, bound)
        k, stats = choose_smallest_adequate([r["criterion"] for r in ok])
    for r, z in zip(ok, stats, strict=True):
        r["z"] = z
    queue = _ranked(ok, k, stats, val)
    rejudged = ""
    if refined:
        # the order decided again among candidates of the chosen structure (with or
        # without D): the preference for no D is not traded for a refined error
        same = [i for i, r in enumerate(ok) if with_d(r) == with_d(ok[k])]
        k2, rejudged = rejudge_refined(
            [ok[i] for i in same], [stats[i] for i in same], same.index(k), est, val,
            windows, n_jobs,
        )  # fmt: skip
        k2 = same[k2]
        if k2 != k:
            queue = [ok[k2]] + [r for r in queue if r is not ok[k2]]
    model, failures, note = _choose(
        get_method, ok, queue, est, whole, val, windows, opts, where, refined
    )
    rule = (
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
    rule += rejudged
    if failures:
        rule += "; not kept: " + "; ".join(why[1] for why in failures)
    if judge_feedthrough:
        model.options["feedthrough_rule"] = _feedthrough_report(model, ok, ft_rule)
    return model, _rows_table(rows), rule + note


def _feedthrough_candidates(
    get_method: Any,
    ok: list[dict[str, Any]],
    chosen: dict[str, Any],
    swept: Sequence[str],
    orders: list[int],
    est: tuple,
    val: tuple,
    windows: int,
    opts: dict,
    n_jobs: int | None,
    order_given: bool = False,
) -> tuple[list[dict[str, Any]], str, float]:
    """The candidates with ``D`` for :func:`select_model` (``judge_feedthrough``), and
    the reason they are or are not offered and the closed-loop bound on the simulation
    gain (:func:`~hdpbsid.selection.feedthrough.feedthrough_offered`, tested with
    ``chosen``, the candidate without ``D`` the one-standard-error rule takes, on the
    estimation part): every built-in method of
    ``swept`` (:func:`~hdpbsid.selection.feedthrough.takes_feedthrough`) whose candidates
    do not estimate ``D`` of their own (:func:`~hdpbsid.selection.feedthrough.
    honours_feedthrough`) is fitted with ``feedthrough=True`` at every order of the
    sweep.  Every order: without ``D`` a direct term can cost states (a fast mode
    imitates it) or remove them (a plant whose output is dominated by ``D u`` looks
    static), so the order without ``D`` bounds nothing."""
    offered, why, bound = feedthrough_offered(chosen["model"], est)
    if not offered:
        return [], why, bound
    # every built-in method of the sweep but those whose candidates showed they estimate
    # D whatever they are asked; a method with no candidate without D (dt with no
    # continuous-time model at an order) may have one with D
    own = {r["method"] for r in ok if not honours_feedthrough(r["model"])}
    methods = [m for m in swept if takes_feedthrough(m) and m not in own]
    if not methods:
        return [], why + "; no method here takes feedthrough=, so no candidate with D", bound
    d_opts = {m: {**opts.get(m, {}), "feedthrough": True} for m in methods}
    extra = _sweep(get_method, methods, orders, est, val, windows, d_opts, n_jobs, order_given)
    for r in extra:
        r["settings"] = {**r.get("settings", {}), "feedthrough": True}
    return extra, why + f"; candidates with D of {', '.join(methods)} at every order", bound


def _choose_structure(
    ok: list[dict[str, Any]],
    k: int,
    extra: list[dict[str, Any]],
    val: tuple,
    windows: int,
    why: str,
    bound: float = 0.0,
) -> tuple[list[dict[str, Any]], str]:
    """The pool the selection goes on with: the candidates without ``D`` (``ok``, where
    the one-standard-error rule takes ``ok[k]``) or those with ``D`` (the scored rows of
    ``extra``), and the rule's text.  Each structure is represented by the candidate the
    one-standard-error rule takes among its own orders and methods -- the model a user
    would get with ``feedthrough=False`` and with ``feedthrough=True`` -- and the
    candidates with ``D`` are kept only when :func:`~hdpbsid.selection.feedthrough.
    judge_direct_term` says so (better on the held-out one-step and simulation errors
    by more than :data:`~hdpbsid.selection.feedthrough.FEEDTHROUGH_Z` and
    :data:`~hdpbsid.selection.feedthrough.SIMULATION_Z` standard errors, paired, not
    worse over the whole held-out simulation, and in closed loop
    a larger simulation gain than ``bound``, the most a controller's instantaneous path
    could give).

    A method that estimates ``D`` whatever it is asked (Laguerre's ``D_d``) has no
    structure to choose: the structures are compared between the methods that take
    ``feedthrough=`` (a method with its own ``D`` would otherwise stand for "without
    ``D``"), and its candidates then compete in the pool of the structure chosen, as
    candidates with ``D`` when ``D`` is chosen (they then rank and tie with the
    others with ``D``)."""
    scored = [r for r in extra if r["criterion"] is not None and r["criterion"].finite]
    if not scored:
        return ok, why + ("; no candidate with D could be scored" if extra else "")
    own = [r for r in ok if not honours_feedthrough(r["model"])]
    plain = [r for r in ok if honours_feedthrough(r["model"])]
    scored.sort(key=structure_key)
    b = scored[choose_smallest_adequate([r["criterion"] for r in scored])[0]]
    a = plain[choose_smallest_adequate([r["criterion"] for r in plain])[0]] if plain else ok[k]
    choice = judge_direct_term(
        a["model"],
        b["model"],
        (a["criterion"], b["criterion"]),
        check_data(*val),
        windows,
        bound=bound,
    )
    text = (
        f"{why}; without D {a['method']} order {a['order']}, with D {b['method']} order "
        f"{b['order']}: {choice.text()}"
    )
    if not choice.value:
        return ok, text
    for r in own:
        r["settings"] = {**r.get("settings", {}), "feedthrough": True}
    return sorted(scored + own, key=structure_key), text


def _feedthrough_report(model: StateSpaceModel, ok: list[dict[str, Any]], why: str) -> str:
    """The text of ``options["feedthrough_rule"]``: whether the returned ``model`` has a
    direct term, and why (:func:`_feedthrough_candidates`, :func:`_choose_structure`)."""
    has_d = honours_feedthrough(model) and model.report.feedthrough.estimated
    return f"auto: {why}; returned: {'D estimated' if has_d else 'D = 0'}"


def _ranked(
    pool: list[dict[str, Any]], k: int, stats: list[float], val: tuple
) -> list[dict[str, Any]]:
    """The candidates of ``pool`` (sorted by order, then error) that the
    one-standard-error rule admits, in the order they are tried: the chosen order's
    (``pool[k]``'s) tied candidates by :func:`break_tie`, then the larger adequate
    orders.  Candidates more than one standard error worse than the best are not
    listed: the held-out data reject them against the best (:func:`_choose`)."""
    adequate = [r for r, z in zip(pool, stats, strict=True) if z <= SIGNIFICANCE_Z]
    queue = adequate[_index(adequate, pool[k]) :]
    # ties of one structure: one order, with or without D as pool[k] (the
    # whole-simulation tie-break does not trade the preference for no D)
    tied = break_tie([r for r in queue if structure_key(r)[:2] == structure_key(pool[k])[:2]], val)
    return tied + [r for r in queue if not _among(r, tied)]


def _admitted(pool: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The candidates of ``pool`` the one-standard-error rule admits: held-out error
    within :data:`~hdpbsid.models.criteria.SIGNIFICANCE_Z` standard errors of the best's
    (:func:`~hdpbsid.models.criteria.choose_smallest_adequate`); the rivals of
    :func:`instability_problem`."""
    _, stats = choose_smallest_adequate([r["criterion"] for r in pool])
    return [r for r, z in zip(pool, stats, strict=True) if z <= SIGNIFICANCE_Z]


def _stand_ins(
    pool: list[dict[str, Any]], queue: list[dict[str, Any]], row: dict[str, Any], val: tuple
) -> list[dict[str, Any]]:
    """The candidates of ``pool`` outside the ranking ``queue`` whose refit on the whole
    record may be returned instead of candidate ``row`` as fitted on the estimation part
    (:func:`_choose`, step 2): those not much worse than ``row`` (:func:`much_worse`) on
    the held-out part ``val``, by the windowed score that ranks the candidates and by the
    simulation over the whole held-out part (:func:`whole_held_out_error`, which sees
    the slow errors the windows hide: :func:`break_tie`), best held-out score first.

    Why these.  ``row`` heads the candidates that passed the floor but whose refit did
    not hold; returning it means returning a model that never saw the held-out part of
    the record, a decision the user is warned of.  A candidate the one-standard-error
    rule did not admit, but whose held-out error is within :data:`MUCH_WORSE_RATIO` of
    ``row``'s, is one the selection would return without a warning in ``row``'s place
    (:func:`_warn_if_much_worse` warns only beyond that ratio), and its refit, once it
    holds (:func:`refit_holds`: as good on the held-out part as the candidate was
    without seeing it) and passes the floor, uses the whole record.  A candidate much
    worse than ``row`` is no stand-in: the held-out part resolves the difference on any
    record (:func:`much_worse`), and the better model of part of the record is
    returned, with the warning (an order the data reject does not replace the order
    they choose because its refit happens to hold).  Both measures: a candidate close by
    the windowed score can simulate the held-out part many times worse (a wrong slow
    mode or static gain, which each window's fitted initial state absorbs), and the
    selection's tie-break already defers to the whole simulation where the windows
    cannot tell."""
    crit, whole = row["criterion"], whole_held_out_error(row["model"], val)
    near = [
        r
        for r in pool
        if not _among(r, queue) and r is not row and not much_worse(r["criterion"], crit)[0]
    ]
    near = [r for r in near if not much_worse(whole_held_out_error(r["model"], val), whole)[0]]
    return sorted(near, key=lambda r: r["criterion"].total)


def _choose(
    get_method: Any,
    ok: list[dict[str, Any]],
    queue: list[dict[str, Any]],
    est: tuple,
    whole: tuple,
    val: tuple,
    windows: int,
    opts: dict,
    where: str,
    refined: bool = False,
) -> tuple[StateSpaceModel, list[tuple[str, str, dict[str, Any]]], str]:
    """The model returned by :func:`select_model` from the scored candidates ``ok`` and
    the first ranking ``queue`` (:func:`_ranked`); also every failure and a note for the
    rule.  Never a model the checks rejected, quietly:

    1. the first candidate of ``queue`` that passes the floor (:func:`beats_the_mean`,
       :func:`instability_problem`) and whose refit on the whole record holds
       (:func:`_first_that_holds`);
    2. else, if a candidate of ``queue`` passed the floor, the first candidate outside
       ``queue`` that is not much worse than it on the held-out part (:func:`_stand_ins`),
       passes the floor and whose refit holds: a refit that fails its checks yields to
       the next candidate whose refit holds before any part-record model is returned;
       only when none holds, the first candidate's own model, fitted on the estimation
       part (:func:`_candidate_itself`; with ``refined`` the start of the refinement on
       the whole record, the front end warns only if that does not happen), with a
       :class:`SelectionWarning`: the held-out part judged exactly that model, while the
       refit is a different one (the method's data-driven settings, chosen again on the
       whole record, changed it), so the candidate is the model the evidence supports;
    3. else every candidate of ``queue`` failed the floor: they are no models of the
       held-out data, so they leave the ranking and the one-standard-error rule is applied
       again to the rest (a candidate the rule rejected against a better one is never
       returned while that better one stands);
    4. no candidate passes the floor (an unstable plant sampled non-uniformly has no stable
       predictor to run over the whole held-out part): the first ranking stands without
       the floor, with a :class:`SelectionWarning`;
    5. nothing holds: ``ValueError`` naming every failure and what would help.

    Whatever the step, when the model returned is much worse on the held-out part than
    the best candidate a check rejected (:func:`much_worse`), a :class:`SelectionWarning`
    says what was rejected, why, and how to ask for it (:func:`_warn_if_much_worse`).
    """
    failures: list[tuple[str, str, dict[str, Any]]] = []
    pool, first = list(ok), queue
    while queue:
        model, more, row = _first_that_holds(
            get_method, queue, est, whole, val, windows, opts, pool=_admitted(pool)
        )
        failures += more
        if model is not None:
            _warn_if_much_worse(row, model, failures)
            return model, failures, ""
        sound = [r for r in queue if r.get("passed_floor")]
        if sound:
            stand_ins = _stand_ins(pool, queue, sound[0], val)
            model, more, row = _first_that_holds(
                get_method, stand_ins, est, whole, val, windows, opts, pool=_admitted(pool)
            )
            failures += more
            if model is not None:
                _warn_if_much_worse(row, model, failures)
                return model, failures, ""
            model = _candidate_itself(sound[0], where, warn=not refined)
            _warn_if_much_worse(sound[0], model, failures)
            return (
                model,
                failures,
                (
                    f"; returned: {sound[0]['method']} order {sound[0]['order']} as fitted on the "
                    f"estimation part (no refit on the whole record held)"
                ),
            )
        pool = [r for r in pool if not _among(r, queue)]
        if not pool:
            break
        k, stats = choose_smallest_adequate([r["criterion"] for r in pool])
        queue = _ranked(pool, k, stats, val)
    # no candidate passes the floor: the floor cannot judge these models, the windowed
    # ranking stands
    model, more, row = _first_that_holds(
        get_method, first, est, whole, val, windows, opts, floor=False
    )
    failures += more
    if model is None:
        raise NoCandidate(
            "no scored candidate could be identified on the whole record: "
            + "; ".join(why[1] for why in failures)
            + "; a longer record, a smaller max_order, or giving order= and method= "
            "explicitly may help"
        )
    text = (
        f"no candidate model passes the checks on {where} (model.options['selection_rule'] "
        f"lists the failures); the best by the windowed held-out score is returned "
        f"({model.report.method or '?'} order {model.n}), check it on other data "
        f"before use"
    )
    model.report = model.report.warned(text)
    warnings.warn(text, SelectionWarning, stacklevel=user_stacklevel())
    return (
        model,
        failures,
        "; no candidate passes the floor: floor not applied",
    )


def much_worse(returned: WindowedError, rejected: WindowedError) -> tuple[bool, float]:
    """Whether the held-out score ``returned`` of the model returned is much worse than
    the score ``rejected`` of a candidate a check rejected, and the ratio of their
    held-out errors.

    Much worse: the returned model leaves more than :data:`MUCH_WORSE_RATIO` (2) times
    the held-out residual energy of the rejected one.  Why 2: beyond it the held-out
    data resolve the difference whatever the spread of their windows.  The standard
    error of the one-standard-error rule (:func:`~hdpbsid.models.criteria.choose_smallest_adequate`)
    is ``sqrt(W) std(r_w)`` of the better model's window errors ``r_w >= 0``, at most
    their sum ``T`` (equality when one window holds all of it), so a total above ``2 T``
    is more than one standard error worse on any record; a smaller ratio can be within
    the spread of the windows, a difference the record does not show.
    """
    if not rejected.finite or rejected.total <= 0.0:
        return False, np.inf
    ratio = returned.total / rejected.total if returned.finite else np.inf
    return bool(ratio > MUCH_WORSE_RATIO), ratio


def _warn_if_much_worse(
    row: dict[str, Any],
    model: StateSpaceModel,
    failures: list[tuple[str, str, dict[str, Any]]],
) -> None:
    """A :class:`SelectionWarning` when the candidate ``row`` returned (as ``model``) is
    much worse on the held-out part than the best candidate the checks rejected
    (:func:`much_worse`): what was rejected and why, the ratio, and what to pass to get
    it.  The text is kept in ``model.options["selection_warning"]``."""
    crit = row.get("criterion")
    rejected = [
        (r, text)
        for _, text, r in failures
        if r is not row and r.get("criterion") is not None and r["criterion"].finite
    ]
    if crit is None or not rejected:
        return
    best, why = min(rejected, key=lambda p: p[0]["criterion"].total)
    worse, ratio = much_worse(crit, best["criterion"])
    if not worse:
        return
    text = (
        f"{row['method']} order {row['order']} is returned, but its held-out error is "
        f"{ratio:.3g} times that of {why} (rejected for that reason). If that model is "
        f"what the record should give (e.g. an unstable plant inside a feedback loop), "
        f"pass method={best['method']!r}, order={best['order']}; "
        f"model.options['selection_rule'] lists every candidate that was rejected"
    )
    model.options["selection_warning"] = text
    model.report = model.report.warned(text)
    warnings.warn(text, SelectionWarning, stacklevel=user_stacklevel())


def _candidate_itself(row: dict[str, Any], where: str, warn: bool = True) -> StateSpaceModel:
    """The candidate ``row``'s own model (fitted on the estimation part), returned when
    no refit on the whole record holds (:func:`_choose`, step 2), with a
    :class:`SelectionWarning`
    (if ``warn``) saying so and what would help; the text is also kept in
    ``options["selection_fallback"]``."""
    model = row["model"]
    text = (
        f"{row['method']} order {row['order']}: the model fitted on the estimation part "
        f"(all but {where}) is returned, as judged on the held-out part; its refit on the "
        f"whole record did not hold (model.options['selection_rule'] says why): the "
        f"method's data-driven settings change with the record length. A longer record, "
        f"or giving those settings explicitly, lets the whole record be used"
    )
    model.options["selection_fallback"] = text
    model.report = model.report.but(selection_fallback=text)
    if warn:
        warnings.warn(text, SelectionWarning, stacklevel=user_stacklevel())
    return model


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
    """
    from hdpbsid.data.records import as_records
    from hdpbsid.methods.registry import get_method, is_available

    recs = as_records(t, u, y)
    if len(recs) == 1:
        t, u, y = recs[0].t, recs[0].u, recs[0].y
    mo = AUTO_MAX_ORDER if max_order is None else check_positive_int(max_order, "max_order")
    orders = [check_positive_int(order, "order")] if order is not None else list(range(1, mo + 1))
    if methods is None:
        uniform = all(is_uniform(r.t) for r in recs)
        methods = [m for m in AUTO_METHODS if (uniform or m != "dt") and is_available(m)]
    else:
        methods = list(methods)
        for m in methods:
            get_method(m)  # raises for unknown names
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
    )
    chosen = model.report.method
    model.options["selection"] = table
    model.options["order_selection"] = [r for r in table if r["method"] == chosen]
    model.options["selection_rule"] = rule
    model.report = model.report.but(
        candidates=tuple(Candidate.from_dict(r) for r in table), selection_rule=rule
    )
    return model


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
    """
    mo = AUTO_MAX_ORDER if max_order is None else check_positive_int(max_order, "max_order")
    from hdpbsid.methods.registry import get_method

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
        model = get_method(method)(t, u, y, order=None, max_order=mo, **options)
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


def decide_feedthrough(
    method: str,
    t: Any,
    u: Any,
    y: Any,
    order: int,
    options: dict[str, Any],
    *,
    holdout: float = HOLDOUT,
) -> tuple[bool, str]:
    """Whether ``method`` with the given ``order`` estimates a direct term on the record
    ``(t, u, y)`` (``feedthrough="auto"`` with the method and the order given), and why.

    The rule of :mod:`hdpbsid.selection.feedthrough` for two candidates: the method at
    ``order`` with ``D = 0`` and with ``D`` estimated, fitted on the first ``1 -
    holdout`` of the record and scored on the rest; ``D`` is offered by
    :func:`~hdpbsid.selection.feedthrough.feedthrough_offered` (with, in closed loop, the
    share of the simulation error a controller's instantaneous path could explain) and
    estimated when its candidate wins on the held-out one-step and simulation errors
    beyond that (:func:`~hdpbsid.selection.feedthrough.judge_direct_term`).  ``False`` when the
    record is too short to hold out the windows the rule needs, when the method does not
    take ``feedthrough=`` (:func:`~hdpbsid.selection.feedthrough.honours_feedthrough`),
    when the method is not a built-in one (:func:`~hdpbsid.selection.feedthrough.
    takes_feedthrough`), or when a candidate cannot be fitted or scored.

    Parameters
    ----------
    method : str
        A registered method name.
    t, u, y : array_like
        One record, as :func:`hdpbsid.identify` takes it (detrended).
    order : int
        The model order.
    options : dict
        The method's settings (without ``feedthrough``).
    holdout : float
        The held-out share at the end of the record.

    Returns
    -------
    tuple of (bool, str)
        The decision and its reason (for ``options["feedthrough_rule"]``).

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid.selection.auto import decide_feedthrough
    >>> t = np.arange(300) * 0.1
    >>> decide_feedthrough("dt", t, None, np.sin(t), 2, {})
    (False, 'auto: no input, no direct term; D = 0')
    """
    from hdpbsid.methods.registry import get_method

    t, u, y = check_data(t, u, y)
    if u.shape[1] == 0:
        return False, "auto: no input, no direct term; D = 0"
    if not takes_feedthrough(method):
        return False, f"auto: not judged ({method!r} is not a built-in method); D = 0"
    split = int(round(t.size * (1.0 - float(holdout))))
    est, val = (t[:split], u[:split], y[:split]), (t[split:], u[split:], y[split:])
    windows = default_windows(t.size - split, order)
    if windows < MIN_WINDOWS:
        return False, "auto: not judged (too short to hold out the scoring windows); D = 0"
    opts = {method: dict(options)}
    without = _fit_one(get_method, method, order, est, val, windows, opts)
    fitted = without["criterion"] is not None and without["criterion"].finite
    if fitted and not honours_feedthrough(without["model"]):
        return False, f"auto: {method} does not take feedthrough= (its own D is kept)"
    if fitted:
        # the test needs one candidate: tested first, a record where D is not offered
        # costs no fit with D
        offered, why, bound = feedthrough_offered(without["model"], est)
        if not offered:
            return False, f"auto: {why}; D = 0"
    with_row = _fit_one(
        get_method, method, order, est, val, windows, {method: {**options, "feedthrough": True}}
    )
    fitted_d = with_row["criterion"] is not None and with_row["criterion"].finite
    if fitted_d and not honours_feedthrough(with_row["model"]):
        return False, f"auto: {method} does not take feedthrough= (its own D is kept)"
    if not (fitted or fitted_d):
        return False, f"auto: not judged (no candidate: {without['status']}); D = 0"
    if not fitted:
        offered, why, bound = feedthrough_offered(with_row["model"], est)
        if not offered:
            return False, f"auto: {why}; D = 0"
    if not fitted_d:
        return False, f"auto: {why}; the candidate with D: {with_row['status']}; D = 0"
    if not fitted:
        return True, (
            f"auto: {why}; the candidate without D: {without['status']}; the one with D "
            f"scores: D estimated"
        )
    choice = judge_direct_term(
        without["model"],
        with_row["model"],
        (without["criterion"], with_row["criterion"]),
        val,
        windows,
        bound=bound,
    )
    return choice.value, (
        f"auto: {why}; at order {order} on the held-out part ({windows} windows): {choice.text()}"
    )
