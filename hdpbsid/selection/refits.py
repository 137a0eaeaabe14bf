"""The model the held-out selection returns (:mod:`hdpbsid.selection.auto`): the ranked
candidates (:func:`~hdpbsid.selection.order_rule.rank_candidates`), each past the floor
and refitted on the whole record until a refit holds (:func:`_first_that_holds`), and the
fallbacks when none does (:func:`_choose`), never a rejected model quietly
(:func:`_warn_if_much_worse`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from hdpbsid.bases.basis_core import WindowReason
from hdpbsid.models.criteria import choose_smallest_adequate
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import Choice
from hdpbsid.runtime import user_stacklevel
from hdpbsid.selection.candidates import (
    CandidateRow,
    FitRecord,
    _among,
    _fit_row,
    _given,
    _mark_window_rule,
    _refit_settings,
    closed_loop_refit,
    refit_keeps,
    settle_candidate,
)
from hdpbsid.selection.feedthrough import (
    honours_feedthrough,
    with_d,
    with_d_asked,
    without_own_d,
)
from hdpbsid.selection.order_rule import _admitted, _ranked
from hdpbsid.selection.policy import NoCandidate, SelectionWarning
from hdpbsid.selection.scoring import (
    _worst_eigenvalue,
    grows,
    instability_problem,
    much_worse,
    refit_holds,
    stationarity_problem,
    whole_held_out_error,
)

__all__: list[str] = []


def _first_that_holds(
    get_method: Any,
    candidates: list[CandidateRow],
    est: FitRecord,
    whole: FitRecord,
    val: tuple,
    windows: int,
    opts: dict,
    floor: bool = True,
    pool: Sequence[CandidateRow] = (),
) -> tuple[StateSpaceModel | None, list[tuple[str, str, CandidateRow]], CandidateRow | None]:
    """The first of ``candidates`` that, with its held-out-judged settings settled
    (:func:`settle_candidate`, fitted on ``est``), passes the floor (unless ``floor`` is
    False): :func:`instability_problem` against the scored candidates ``pool``; and
    whose refit on the ``whole`` record passes :func:`refit_holds` and grows no mode the
    candidate did not have (the held-out part judged a stable model; the growth of the
    refit was never judged); or None.  Returns ``(model, failures, row)``, ``row`` the
    candidate whose refit is returned.  Also
    every failure as ``(kind, text, row)``, kind ``"floor"`` or ``"refit"``; a candidate that
    passed the floor is marked ``passed_floor`` (its own model, fitted on ``est``, is then
    a sound answer when no refit holds: :func:`select_model`)."""
    failures: list[tuple[str, str, CandidateRow]] = []
    for chosen in candidates:
        settle_candidate(get_method, chosen, est, val, windows, opts)
        name = f"{chosen.method} order {chosen.order}"
        if floor:
            how = instability_problem(chosen, pool)
            if how:
                failures.append(("floor", f"{name}: {how}", chosen))
                continue
            chosen.passed_floor = True
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model, kept = _refit(get_method, chosen, whole, opts)
                how = _refit_problem(model, chosen, val, windows, floor)
                holds = not how
        except (ValueError, np.linalg.LinAlgError) as exc:
            holds, how = False, str(exc)
        if holds:
            _accept_refit(model, chosen, kept)
            return model, failures, chosen
        failures.append(("refit", f"{name}: {how}", chosen))
    return None, failures, None


def _refit(
    get_method: Any, chosen: CandidateRow, whole: FitRecord, opts: dict
) -> tuple[StateSpaceModel, dict[str, Any]]:
    """Candidate ``chosen`` identified again on the ``whole`` record, with the user's
    settings, those it keeps from the candidate (:func:`refit_keeps`) and those its
    method chose on held-out data, and those kept settings.  A candidate judged as a
    structure with ``D`` is marked as asked for it
    (:func:`~hdpbsid.selection.feedthrough.with_d_asked`)."""
    func = get_method(chosen.method)
    given = _given(chosen, opts)
    closed = closed_loop_refit(func, chosen.model, whole.arrays)
    kept = refit_keeps(func, chosen.model, given, closed)
    settings = {**given, **kept, **_refit_settings(chosen.model)}
    model = whole.fit(func, chosen.order, **settings)
    if chosen.own_d_removed and not honours_feedthrough(model):
        model = without_own_d(model)  # judged as a structure without D
    if with_d(chosen):
        # judged as a structure with D: D is a parameter of the refinement
        # (hdpbsid.refine.pem), whatever the method says of its own D
        with_d_asked(model)
    if chosen.p_rule is not None:
        _mark_window_rule(model, chosen.p_rule)
    return model, kept


def _refit_problem(
    model: StateSpaceModel, chosen: CandidateRow, val: tuple, windows: int, floor: bool
) -> str:
    """Why the refit ``model`` of candidate ``chosen`` is not returned, or ``""``: it does
    not hold on the held-out part ``val`` (:func:`refit_holds`); with the ``floor``, it
    grows a mode the candidate did not have; a time series' refit is not stationary."""
    holds, how = refit_holds(model, chosen.criterion, val, windows)
    if holds and floor:
        # the floor the candidate passed, for the model returned
        how = _new_growth(model, chosen.model)
        how = f"the refit on the whole record: {how}" if how else how
    if not how:
        why = stationarity_problem(model)
        how = f"the refit on the whole record: {why}" if why else ""
    return how


def _new_growth(model: StateSpaceModel, candidate: StateSpaceModel) -> str:
    """The growing mode of the refit ``model`` that the ``candidate`` judged on the
    held-out part did not have (its growth was never judged), or ``""``."""
    if grows(model) and not grows(candidate):
        return (
            f"it has a growing mode (eigenvalue {_worst_eigenvalue(model):.3g}) "
            f"that the candidate judged on the held-out part did not have"
        )
    return ""


def _accept_refit(model: StateSpaceModel, chosen: CandidateRow, kept: dict[str, Any]) -> None:
    """Record on the refit ``model`` returned what it takes from candidate ``chosen``: the
    candidate refined on the estimation part as a warm start of the refinement
    (:func:`hdpbsid.refine.pem.refine_pem`), the settings chosen on held-out data, and
    the settings ``kept`` (:func:`refit_keeps`)."""
    warm = chosen.refined_model
    if warm is not None:
        from hdpbsid.refine.pem import warm_start_option

        model.report = model.report.but(warm_start=warm_start_option(warm))
    _carry_refit_settings(model, chosen.model)
    if kept:
        rule = (
            "the candidate's own values, judged with it on the held-out part "
            "(hdpbsid.selection.auto.refit_keeps)"
        )
        model.options["refit_kept"] = kept
        model.options["refit_kept_rule"] = rule
        if "p" in kept:
            window = Choice(int(kept["p"]), rule, WindowReason.KEPT)
            model.report = model.report.but(past_window=window)


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


def _warn_if_much_worse(
    row: CandidateRow,
    model: StateSpaceModel,
    failures: list[tuple[str, str, CandidateRow]],
) -> None:
    """A :class:`SelectionWarning` when the candidate ``row`` returned (as ``model``) is
    much worse on the held-out part than the best candidate the checks rejected
    (:func:`much_worse`): what was rejected and why, the ratio, and what to pass to get
    it.  The text is kept in ``model.options["selection_warning"]``."""
    crit = row.criterion
    rejected = [
        (r, text)
        for _, text, r in failures
        if r is not row and r.criterion is not None and r.criterion.finite
    ]
    if crit is None or not rejected:
        return
    best, why = min(rejected, key=lambda p: p[0].criterion.total)
    worse, ratio = much_worse(crit, best.criterion)
    if not worse:
        return
    text = (
        f"{row.method} order {row.order} is returned, but its held-out error is "
        f"{ratio:.3g} times that of {why} (rejected for that reason). If that model is "
        f"what the record should give (e.g. an unstable plant inside a feedback loop), "
        f"pass method={best.method!r}, order={best.order}; "
        f"model.options['selection_rule'] lists every candidate that was rejected"
    )
    model.options["selection_warning"] = text
    model.report = model.report.warned(text)
    warnings.warn(text, SelectionWarning, stacklevel=user_stacklevel())


def _candidate_itself(row: CandidateRow, where: str, warn: bool = True) -> StateSpaceModel:
    """The model of candidate ``row`` the held-out part judged, fitted on the estimation
    part, returned when no refit on the whole record holds (:func:`_choose`, step 2),
    with a :class:`SelectionWarning` (if ``warn``) saying so and what would help; the
    text is also kept in ``options["selection_fallback"]``.

    That model is the candidate refined on the estimation part when the order was
    decided between refined candidates (``row.refined_model``,
    :func:`~hdpbsid.selection.rejudge.rejudge_refined`): the decision scored the refined
    model, not the subspace estimate it started from, so the refined model is the one
    the evidence supports -- unless it grows a mode the candidate did not have (the
    floor the candidate passed, :func:`_new_growth`).  Else the candidate's own model."""
    model = row.model
    if row.refined_model is not None and not _new_growth(row.refined_model, model):
        model = row.refined_model
    text = (
        f"{row.method} order {row.order}: the model fitted on the estimation part "
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


def _stand_ins(
    pool: list[CandidateRow], queue: list[CandidateRow], row: CandidateRow, val: tuple
) -> list[CandidateRow]:
    """The candidates of ``pool`` outside the ranking ``queue`` whose refit on the whole
    record may be returned instead of candidate ``row`` as fitted on the estimation part
    (:func:`_choose`, step 2): those not much worse than ``row`` (:func:`much_worse`) on
    the held-out part ``val``, by the windowed score that ranks the candidates and by the
    simulation over the whole held-out part (:func:`whole_held_out_error`, which sees
    the slow errors the windows hide: :func:`break_tie`), best held-out score first.

    Why these.  ``row`` heads the candidates that passed the floor but whose refit did
    not hold; returning it means returning a model that never saw the held-out part of
    the record, a decision the user is warned of.  A candidate the one-standard-error
    rule did not admit, but whose held-out error is within
    :data:`~hdpbsid.selection.policy.MUCH_WORSE_RATIO` of ``row``'s, is one the selection
    would return without a warning in ``row``'s place
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
    crit, whole = row.criterion, whole_held_out_error(row.model, val)
    near = [
        r
        for r in pool
        if not _among(r, queue) and r is not row and not much_worse(r.criterion, crit)[0]
    ]
    near = [r for r in near if not much_worse(whole_held_out_error(r.model, val), whole)[0]]
    return sorted(near, key=lambda r: r.criterion.total)


def _choose(
    get_method: Any,
    ok: list[CandidateRow],
    queue: list[CandidateRow],
    est: FitRecord,
    whole: FitRecord,
    val: tuple,
    windows: int,
    opts: dict,
    where: str,
    refined: bool = False,
) -> tuple[StateSpaceModel, list[tuple[str, str, CandidateRow]], str]:
    """The model returned by :func:`~hdpbsid.selection.auto.select_model` from the scored
    candidates ``ok`` and the first ranking ``queue``
    (:func:`~hdpbsid.selection.order_rule.rank_candidates`); also every failure and a note
    for the rule.  Never a model the checks rejected, quietly:

    1. the first candidate of ``queue`` that passes the floor
       (:func:`instability_problem`) and whose refit on the whole record holds
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
    4. no candidate passes the floor: the first ranking stands without the floor, with
       a :class:`SelectionWarning`;
    5. nothing holds: ``ValueError`` naming every failure and what would help.

    Whatever the step, when the model returned is much worse on the held-out part than
    the best candidate a check rejected (:func:`much_worse`), a :class:`SelectionWarning`
    says what was rejected, why, and how to ask for it (:func:`_warn_if_much_worse`).
    """
    failures: list[tuple[str, str, CandidateRow]] = []
    pool, first = list(ok), queue
    while queue:
        model, more, row = _first_that_holds(
            get_method, queue, est, whole, val, windows, opts, pool=_admitted(pool)
        )
        failures += more
        if model is not None:
            _warn_if_much_worse(row, model, failures)
            return model, failures, ""
        sound = [r for r in queue if r.passed_floor]
        if sound:
            split = (est, whole, val, windows)
            model, note = _sound_fallback(
                get_method, pool, queue, sound[0], split, opts, where, refined, failures
            )
            return model, failures, note
        pool = [r for r in pool if not _among(r, queue)]
        if not pool:
            break
        k, stats = choose_smallest_adequate([r.criterion for r in pool])
        queue = _ranked(pool, k, stats, val)
    # no candidate passes the floor: the floor cannot judge these models, the windowed
    # ranking stands
    model = _without_floor(get_method, first, est, whole, val, windows, opts, where, failures)
    return model, failures, "; no candidate passes the floor: floor not applied"


def _sound_fallback(
    get_method: Any,
    pool: list[CandidateRow],
    queue: list[CandidateRow],
    row: CandidateRow,
    split: tuple,
    opts: dict,
    where: str,
    refined: bool,
    failures: list[tuple[str, str, CandidateRow]],
) -> tuple[StateSpaceModel, str]:
    """Step 2 of :func:`_choose`: ``row``, the first candidate of ``queue`` that passed the
    floor, had no refit that held; the refit of the first stand-in that holds
    (:func:`_stand_ins`), else ``row``'s own model (:func:`_candidate_itself`), and the
    note for the rule.  ``split``: ``(est, whole, val, windows)``; the failures are added
    to ``failures``."""
    est, whole, val, windows = split
    stand_ins = _stand_ins(pool, queue, row, val)
    model, more, held = _first_that_holds(
        get_method, stand_ins, est, whole, val, windows, opts, pool=_admitted(pool)
    )
    failures.extend(more)
    if model is not None:
        _warn_if_much_worse(held, model, failures)
        return model, ""
    model = _candidate_itself(row, where, warn=not refined)
    _warn_if_much_worse(row, model, failures)
    return model, (
        f"; returned: {row.method} order {row.order} as fitted on the "
        f"estimation part (no refit on the whole record held)"
    )


def _without_floor(
    get_method: Any,
    first: list[CandidateRow],
    est: FitRecord,
    whole: FitRecord,
    val: tuple,
    windows: int,
    opts: dict,
    where: str,
    failures: list[tuple[str, str, CandidateRow]],
) -> StateSpaceModel:
    """Step 4 of :func:`_choose`: no candidate passes the floor, so the first ranking
    ``first`` stands without it, with a :class:`SelectionWarning`; the failures are added
    to ``failures``.  Raises :class:`NoCandidate` (step 5) when no refit holds either."""
    model, more, _ = _first_that_holds(
        get_method, first, est, whole, val, windows, opts, floor=False
    )
    failures.extend(more)
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
    return model


def _unscored(
    get_method: Any,
    methods: Sequence[str],
    order: int,
    whole: FitRecord,
    opts: dict,
    reason: str,
) -> tuple[StateSpaceModel, list[dict[str, Any]], str]:
    """The model at the order the user gave when the held-out part is too short to
    compare the methods there (``reason`` says why): the first of ``methods`` that
    answers at ``order`` on the ``whole`` record with its own settings, a basis method
    at the smallest past window that reaches the order if its default cannot
    (:func:`~hdpbsid.selection.candidates._fit_row`, as the sweep fits a candidate).
    ``methods`` is the order of preference (:data:`~hdpbsid.selection.policy.AUTO_METHODS`).
    Returns ``(model, table, rule)`` as :func:`~hdpbsid.selection.auto.select_model`; the
    table lists the methods tried, none scored.  A :class:`SelectionWarning` says that
    the method was not chosen by the data and how to compare them (a longer record, or
    ``holdout``).

    Why not refuse: the order is the user's, and every method estimates a model of it
    from these samples (as other tools do at any order); what the record cannot carry is
    the *comparison*, since a held-out score needs windows whose initial state is
    determined by several samples per state.  Raises :class:`NoCandidate` when no
    method answers.
    """
    rows = []
    for name in methods:
        row = CandidateRow(name, order)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                model = _fit_row(row, get_method(name), whole, dict(opts.get(name, {})), True)
        except (ValueError, np.linalg.LinAlgError) as exc:
            row.status = f"{type(exc).__name__}: {exc}"
            rows.append(row)
            continue
        row.status = "not scored: " + reason
        rows.append(row)
        rule = (
            f"not compared: {reason}; the first of the methods {', '.join(methods)} that "
            f"answers at the order given, {name}, fitted on the whole record"
        )
        warnings.warn(
            f"the methods were not compared at order {order}: {reason}; returned "
            f"{name!r}, the first method that answers (pass method= to choose another, or "
            f"a longer record to compare them)",
            SelectionWarning,
            stacklevel=user_stacklevel(),
        )
        return model, [r.as_row() for r in rows], rule
    detail = "; ".join(f"{r.method}: {r.status}" for r in rows)
    raise NoCandidate(f"no method answers at order {order} on this record ({detail})")
