"""The order decided again between refined candidates (:func:`rejudge_refined`), when the
model returned by the held-out selection (:mod:`hdpbsid.selection.auto`) will be refined by
the prediction-error method (``refine="auto"``).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np

from hdpbsid.data.checks import is_uniform
from hdpbsid.models.criteria import (
    SIGNIFICANCE_Z,
    WindowedError,
    choose_smallest_adequate,
    windowed_simulation_error,
)
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.selection.candidates import CandidateRow, _index
from hdpbsid.selection.drift import drift_modes
from hdpbsid.selection.feedthrough import paired_z
from hdpbsid.selection.iterate import keep_iterate
from hdpbsid.selection.order_rule import OrderChoice, OrderReason
from hdpbsid.selection.policy import SELECTION_POLICY
from hdpbsid.selection.scoring import looks_closed_loop, score_model

__all__ = ["rejudge_refined", "rejudge_order"]


def _refine_and_score(
    model: StateSpaceModel, est: tuple, val: tuple, windows: int
) -> tuple[StateSpaceModel | None, WindowedError]:
    """``model`` refined on ``est`` (:func:`hdpbsid.refine.pem.refine_pem`; None when
    the refinement fails, or when its budget cut it off and ``est`` does not resolve the
    iterate as better than ``model``: :func:`~hdpbsid.selection.iterate.keep_iterate`,
    the rule of the final refinement) and the held-out score (:func:`score_model`) of
    the refined model, or of ``model`` itself without one.  A resolved iterate counts:
    scored unrefined, a candidate whose refinement ran out of budget would be compared
    with the other orders' refined models at its subspace bias."""
    from hdpbsid.refine.pem import refine_pem

    refined = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            fit = refine_pem(model, *est)
            if keep_iterate(model, fit, *est).value:
                refined = fit
        except (ValueError, np.linalg.LinAlgError):
            pass
        err, _ = score_model(model if refined is None else refined, val, windows)
    return refined, err


def _refined_error(r: CandidateRow, est: tuple, val: tuple, windows: int) -> WindowedError:
    """The held-out score of candidate ``r``'s model refined on ``est``
    (:func:`_refine_and_score`), kept in ``r.refined_criterion`` (and the refined
    model in ``r.refined_model``)."""
    if r.refined_criterion is None:
        _refine_rows([r], est, val, windows, None)
    return r.refined_criterion


def _refine_rows(
    rows: list[CandidateRow], est: tuple, val: tuple, windows: int, n_jobs: int | None
) -> None:
    """:func:`_refined_error` of every row of ``rows`` not refined yet, in parallel with
    joblib when ``n_jobs`` is given (one BLAS thread per worker, as in :func:`_sweep`: the
    same numbers as the serial run)."""
    todo = list({id(r): r for r in rows if r.refined_criterion is None}.values())
    if n_jobs is not None and n_jobs != 1 and len(todo) > 1:
        from joblib import Parallel, delayed

        out = Parallel(n_jobs=n_jobs, inner_max_num_threads=1)(
            delayed(_refine_and_score)(r.model, est, val, windows) for r in todo
        )
    else:
        out = [_refine_and_score(r.model, est, val, windows) for r in todo]
    for r, (refined, err) in zip(todo, out, strict=True):
        if refined is not None:
            r.refined_model = refined
        r.refined_criterion = err


def rejudge_refined(
    ok: list[CandidateRow],
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
    within :attr:`~hdpbsid.selection.policy.SelectionPolicy.rejudge_z` (3) standard errors
    of the best takes part.

    *Down.*  Extra states can absorb part of the bias, so a larger order can score better
    than the true one although the true one, fitted efficiently, would not be beaten.
    The orders up to the chosen order ``n*`` are refined and the one with the smallest
    refined error is taken.  Not the one-standard-error rule again: its preference for
    the smaller order was applied once, to choose ``n*``; here a smaller order replaces
    ``n*`` only when, refined, it predicts at least as well as ``n*`` refined -- the bias
    correction, not a second discount for parsimony (applied twice, the rule drops a true
    mode that adds little output variance, such as an unstable pole held back by the loop,
    whenever the smaller order comes within one standard error).

    *Down over a drift.*  A state the chosen order spends on a drift of the record -- a
    mode slower than the record resolves that the input drives less than the noise
    (:func:`~hdpbsid.selection.drift.drift_modes`): an offset or a trend that each
    held-out window's fitted initial state turns into a better score -- is no mode of
    the plant.  At a high signal-to-noise ratio the held-out rule resolves that fit and
    prefers the larger order by many standard errors, while in closed loop the true
    order's subspace candidates can lie outside the window above through their own
    bias.  So on a record the feedback test declares closed loop, when the chosen model,
    refined, has such a mode, the best candidate of the next smaller order takes part
    whatever its unrefined distance, and replaces it when, refined, it has fewer drift
    modes and predicts the held-out part within one standard error
    (:func:`_smaller_over_drift`); and so on downwards.  The step up is then not taken
    (it would weigh the same state again).  In open loop the held-out ranking of
    consistent candidates stands.

    *Up.*  The bias can also make a too small order look adequate: in closed loop the
    subspace candidate of the larger order can be the biased one and tie with the
    smaller order, so the one-standard-error rule keeps the smaller, while refined, the
    larger order beats it by several standard errors.  The bias of the rival does not
    show in the chosen candidate (its refit can predict exactly as well as its subspace
    estimate), so the step does not wait for a symptom of it: when the feedback test
    declares the record closed loop (:func:`looks_closed_loop`, on the chosen
    candidate's errors over the estimation part; in open loop the subspace candidates
    are consistent and the ranking is not biased), the next larger order is refined too
    and replaces the decision when, refined, the data resolve it -- its held-out score
    better by more than one standard error (the smaller order listed first: the burden
    of proof on the larger order), or its likelihood on the estimation part higher by
    more than the Bayesian information criterion's price of a state
    (:func:`_larger_resolved`) -- when it adds no drift mode (:func:`_adds_drift`: a
    mode slower than the record resolves that the input drives less than the noise; an
    offset or trend the smaller order leaves), and when
    its windowed simulation error is better by more than one paired standard error (the
    plant's own: an order is the plant's, and a larger order that predicts better only
    through its noise model adds no mode of it, :func:`_plant_resolves`); and so on
    upwards.

    Each refined candidate's score is added to its row (``refined_error``,
    ``refined_fit``).  ``n_jobs``: the refinements known to be needed at the start (the
    orders down, and the chosen order in closed loop) run in parallel (joblib); the
    decision is that of the serial run.

    Parameters
    ----------
    ok : list of CandidateRow
        The scored candidates of one structure, sorted by order (with ``method``,
        ``order``, ``model`` and ``criterion``).
    stats : list of float
        Their distances to the best held-out error, in standard errors.
    k : int
        The index of the candidate the one-standard-error rule chose.
    est : tuple
        The estimation part ``(t, u, y)`` (a list of records: nothing to decide).
    val : tuple
        The held-out part ``(t, u, y)``.
    windows : int
        The number of scoring windows.
    n_jobs : int or None
        Parallel refinements (joblib), or None for a serial run.

    Returns
    -------
    tuple of (int, str)
        The index into ``ok`` of the candidate chosen, and the text the rule adds.
    """
    choice = rejudge_order(ok, OrderChoice(k, tuple(stats)), est, val, windows, n_jobs)
    return choice.index, choice.rule


def rejudge_order(
    ok: list[CandidateRow],
    order: OrderChoice,
    est: tuple,
    val: tuple,
    windows: int,
    n_jobs: int | None = None,
) -> OrderChoice:
    """:func:`rejudge_refined` as a choice: the order decision ``order`` on the
    candidates ``ok`` decided again between refined candidates.

    Parameters
    ----------
    ok : list of CandidateRow
        The scored candidates of one structure, sorted by order.
    order : OrderChoice
        The one-standard-error rule's decision on ``ok``.
    est : tuple
        The estimation part ``(t, u, y)`` (a list of records: nothing to decide).
    val : tuple
        The held-out part ``(t, u, y)``.
    windows : int
        The number of scoring windows.
    n_jobs : int or None
        Parallel refinements (joblib), or None for a serial run.

    Returns
    -------
    OrderChoice
        ``order`` itself when there is nothing to decide; else the candidate chosen,
        with the reason :attr:`~hdpbsid.selection.order_rule.OrderReason.REFINED_LARGER`
        when a larger order replaced it, :attr:`~hdpbsid.selection.order_rule.
        OrderReason.DRIFT` when a smaller one did over a drift mode,
        :attr:`~hdpbsid.selection.order_rule.OrderReason.REFINED` when the orders up to
        it were decided again, and the text the rule adds.
    """
    if isinstance(est[0], list | tuple) or not is_uniform(np.asarray(est[0], dtype=float)):
        return order
    k = order.index
    n_star = ok[k].order
    best_of = _best_of_orders(ok, order.stats)
    lower = [best_of[n] for n in sorted(best_of) if n <= n_star]
    lower = lower if len(lower) >= 2 else []
    upward = n_star + 1 in best_of and looks_closed_loop(ok[k].model, est)
    _refine_rows(
        lower + ([ok[k], best_of[n_star + 1]] if upward else []), est, val, windows, n_jobs
    )
    chosen, rule, reason = ok[k], "", order.reason
    if lower:
        chosen, rule = _smallest_refined(lower, chosen, est, val, windows)
        reason = OrderReason.REFINED if rule else reason
    before = chosen
    chosen, more = _smaller_over_drift(chosen, ok, est, val, windows, ok[k].model)
    if chosen is not before:
        return OrderChoice(_index(ok, chosen), order.stats, OrderReason.DRIFT, rule + more)
    if upward:
        before = chosen
        chosen, more = _larger_refined(chosen, best_of, n_star + 1, est, val, windows)
        rule += more
        reason = OrderReason.REFINED_LARGER if chosen is not before else reason
    return OrderChoice(_index(ok, chosen), order.stats, reason, rule)


def _best_of_orders(ok: list[CandidateRow], stats: Sequence[float]) -> dict[int, CandidateRow]:
    """The best candidate (smallest held-out error) of every order among the candidates
    ``ok`` within :attr:`~hdpbsid.selection.policy.SelectionPolicy.rejudge_z` standard
    errors (``stats``) of the best: those :func:`rejudge_refined` may refine."""
    best_of: dict[int, CandidateRow] = {}
    for r, z in zip(ok, stats, strict=True):
        n = r.order
        if z <= SELECTION_POLICY.rejudge_z and (
            n not in best_of or r.criterion.total < best_of[n].criterion.total
        ):
            best_of[n] = r
    return best_of


def _smallest_refined(
    lower: list[CandidateRow], chosen: CandidateRow, est: tuple, val: tuple, windows: int
) -> tuple[CandidateRow, str]:
    """*Down* (:func:`rejudge_refined`): of the candidates ``lower`` (the best of every
    order up to the chosen one), the one with the smallest refined held-out error, and
    the rule's text; ``chosen`` and ``""`` when none of them can be scored refined."""
    errors = [_refined_error(r, est, val, windows) for r in lower]
    finite = [i for i, e in enumerate(errors) if e.finite]
    if not finite:
        return chosen, ""
    chosen = lower[min(finite, key=lambda i: (errors[i].total, i))]
    names = ", ".join(f"{r.method} {r.order}" for r in lower)
    return chosen, (
        f"; order decided again between refined candidates ({names}; within "
        f"{SELECTION_POLICY.rejudge_z:g} SE of the best), the smallest refined error: "
        f"{chosen.method} order {chosen.order}"
    )


def _smaller_over_drift(
    chosen: CandidateRow,
    ok: list[CandidateRow],
    est: tuple,
    val: tuple,
    windows: int,
    tested: StateSpaceModel,
) -> tuple[CandidateRow, str]:
    """*Down over a drift* (:func:`rejudge_refined`): on a record the feedback test
    declares closed loop (:func:`looks_closed_loop` on the errors of ``tested``, the
    candidate the one-standard-error rule chose), while ``chosen``'s refined model has
    more drift modes (:func:`_adds_drift`) than the best candidate of the next smaller
    order refined, and that candidate, refined, predicts the held-out part within one
    standard error of ``chosen`` refined, the smaller order replaces it; the candidate
    kept and the rule's text.

    Closed loop only, as the step up: what puts the smaller order out of the window of
    the other steps is the closed-loop bias of its subspace candidates.  In open loop
    the candidates are consistent and the held-out ranking that chose the drift mode
    stands; there the mode models a disturbance the record carries on (a sensor drift
    of a measured-like record, which its validation part continued: removing the mode
    cost two points of validation fit).

    The state the larger order adds fits an offset or a trend of the record (the step
    up refuses such a state for the same reason), and at a high signal-to-noise ratio
    that fit is resolved: the held-out rule then prefers it by many standard errors of
    the unrefined candidates, while the smaller order's subspace candidates sit outside
    :attr:`~hdpbsid.selection.policy.SelectionPolicy.rejudge_z` through their own bias
    (closed loop), which the noise's standard error does not bound.  So the smaller
    order's best candidate takes part whatever its unrefined distance, and it must be
    adequate refined (the one-standard-error rule, the larger order listed second) --
    a smaller order the held-out part resolves as worse is not returned.  Checked only
    when a drift mode shows, so a record without one pays no refinement for it."""
    rule, drifts = "", drift_modes(_refined(chosen), est)
    if drifts == 0 or not looks_closed_loop(tested, est):
        return chosen, rule
    while drifts > 0:
        below = _best_of_order(ok, chosen.order - 1)
        if below is None:
            break
        e_now = _refined_error(chosen, est, val, windows)
        e_below = _refined_error(below, est, val, windows)
        if not (e_now.finite and e_below.finite):
            break
        below_drifts = drift_modes(_refined(below), est)
        if below_drifts >= drifts:  # as many drift modes below: the extra state is none
            break
        step, z = choose_smallest_adequate([e_below, e_now])
        if step != 0:
            break
        rule += (
            f"; refined, order {chosen.order}: {_DRIFT_TEXT.format(resolution=_resolution(est))}"
            f", and {below.method} order {below.order} refined is within {z[0]:.2g} SE of it:"
            f" order {below.order}"
        )
        chosen, drifts = below, below_drifts
    return chosen, rule


def _best_of_order(ok: list[CandidateRow], n: int) -> CandidateRow | None:
    """The candidate of order ``n`` with the smallest held-out error, at any distance
    from the best; None when ``ok`` has none."""
    rows = [r for r in ok if r.order == n and r.criterion.finite]
    return min(rows, key=lambda r: r.criterion.total) if rows else None


def _larger_refined(
    chosen: CandidateRow,
    best_of: dict[int, CandidateRow],
    n_up: int,
    est: tuple,
    val: tuple,
    windows: int,
) -> tuple[CandidateRow, str]:
    """*Up* (:func:`rejudge_refined`): from order ``n_up`` (the one after the order the
    one-standard-error rule chose) upwards, each order's best candidate of ``best_of``
    replaces ``chosen`` while, refined, the data resolve it (:func:`_larger_resolved`),
    it adds no drift mode (:func:`_adds_drift`) and its plant simulates better
    (:func:`_plant_resolves`); the candidate kept and the rule's text."""
    rule = ""
    while n_up in best_of:
        up = best_of[n_up]
        evidence = _larger_resolved(chosen, up, est, val, windows)
        if evidence is None:
            break
        head = f"; closed loop (feedback test): refined, {up.method} order {n_up} {evidence}"
        if _adds_drift(up, chosen, est):
            rule += f"{head}, but {_DRIFT_TEXT.format(resolution=_resolution(est))}: not taken"
            break
        plant = _plant_resolves(chosen, up, val, windows)
        if plant is None:
            rule += f"{head}, but its plant does not simulate better by more than 1 SE: not taken"
            break
        chosen = up
        rule += f"{head} (its simulation better by {plant:.1f} paired SE)"
        n_up += 1
    return chosen, rule


def _larger_resolved(
    now: CandidateRow, up: CandidateRow, est: tuple, val: tuple, windows: int
) -> str | None:
    """How the data resolve the refined larger order ``up`` against the refined ``now``
    (the rule's text), or None when they do not.

    Two tests, either of which resolves it:

    * the held-out part: ``up``'s one-step prediction error is more than one standard
      error below ``now``'s (:func:`~hdpbsid.models.criteria.choose_smallest_adequate`,
      ``now`` listed first: the one-standard-error rule with the burden of proof on the
      larger order);
    * the estimation part, on which both were refined by the prediction-error method
      (maximum likelihood for Gaussian innovations): the likelihood ratio ``N (log det
      S_now - log det S_up)`` of their one-step errors' covariances ``S`` exceeds the
      Bayesian information criterion's price ``k ln N`` of the ``k = 2 l + m``
      parameters a state adds to an innovations model (``n (2 l + m) + l m`` free
      parameters in a pseudo-canonical form of order ``n``, ``l`` outputs and ``m``
      inputs; Schwarz 1978; Ljung, *System Identification*, 2nd ed., 1999, secs. 4.3
      and 16.4).  The held-out windows are few (the
      last third of the record cut into tens of windows), and the window-to-window
      spread of the errors, which the one-standard-error rule measures against, can
      hide a mode that the whole estimation part resolves by hundreds of likelihood
      units; the information criterion is consistent (the true order as ``N`` grows)
      and its price grows with ``ln N``, so it does not take a state that only fits the
      noise.

    Both models must have been refined (``refined_model``): a subspace estimate's
    likelihood is not the maximum of its order's.
    """
    e_now = _refined_error(now, est, val, windows)
    e_up = _refined_error(up, est, val, windows)
    if not (e_now.finite and e_up.finite):
        return None
    step, z = choose_smallest_adequate([e_now, e_up])
    if step == 1:
        return f"predicts the held-out part better by {z[0]:.1f} SE"
    if now.refined_model is None or up.refined_model is None:
        return None
    ratio, price = _likelihood_ratio(now.refined_model, up.refined_model, est)
    if ratio > price:
        return (
            f"raises the likelihood on the estimation part by {ratio:.0f} units "
            f"(-2 log ratio; its information criterion price {price:.0f})"
        )
    return None


def _likelihood_ratio(now: StateSpaceModel, up: StateSpaceModel, est: tuple) -> tuple[float, float]:
    """``(N (log det S_now - log det S_up), (2 l + m) ln N)``: the ``-2 log`` likelihood
    ratio of two models' one-step errors on ``est``
    (:func:`~hdpbsid.refine.pem.prediction_log_det`, ``S`` their covariance) and the
    Bayesian information criterion's price of one more state (:func:`_larger_resolved`);
    ``-inf`` when a predictor is unstable."""
    from hdpbsid.refine.pem import prediction_log_det

    values = [prediction_log_det(model, *est) for model in (now, up)]
    if values[0] is None or values[1] is None:
        return -np.inf, 0.0
    l, m = up.C.shape[0], up.B.shape[1]
    return values[0] - values[1], (2 * l + m) * float(np.log(np.size(est[0])))


def _resolution(rec: tuple) -> float:
    """``2 pi / T``, the frequency resolution of a record spanning ``T``."""
    return 2 * np.pi / float(np.ptp(np.asarray(rec[0], dtype=float)))


#: the rule's text when an order adds a drift mode (:func:`_adds_drift`)
_DRIFT_TEXT = (
    "it adds a mode slower than 2 pi / T = {resolution:.3g} rad/s that the input drives less "
    "than the noise (a drift over the record, not a mode of the plant)"
)


def _refined(row: CandidateRow) -> StateSpaceModel:
    return row.model if row.refined_model is None else row.refined_model


def _adds_drift(larger: CandidateRow, smaller: CandidateRow, est: tuple) -> bool:
    """Whether ``larger``'s (refined) model has more drift modes on ``est`` than
    ``smaller``'s (:func:`~hdpbsid.selection.drift.drift_modes`: slower than the record
    resolves, ``|lambda| T < 2 pi``, and driven by the input less than the noise): the
    state it adds fits an offset or a trend of the record, not a mode of the plant.  A
    plant mode as slow (an integrator) carries the input's effect and is not one."""
    return drift_modes(_refined(larger), est) > drift_modes(_refined(smaller), est)


def _plant_resolves(now: CandidateRow, up: CandidateRow, val: tuple, windows: int) -> float | None:
    """The larger order's margin in standard errors when its refined plant simulates the
    held-out part better than the refined ``now`` by more than one standard error of
    their paired difference (:func:`~hdpbsid.selection.feedthrough.paired_z` on the
    same windows, :data:`~hdpbsid.models.criteria.SIGNIFICANCE_Z`); None when it does
    not.  A larger order that predicts better only through its noise model (``K``) adds
    no mode of the plant: the order is the plant's, so its extra state must show in the
    plant's own error, the simulation error (as
    :func:`~hdpbsid.selection.iterate.keep_iterate` asks of an iterate).  Paired,
    because the two models simulate the same windows and share their noise: the
    window-to-window spread that the one-standard-error rule measures against is not
    the uncertainty of their difference."""
    models = [_refined(r) for r in (now, up)]
    try:
        errors = [windowed_simulation_error(m, *val, windows) for m in models]
    except ValueError:
        return None
    if not all(e.finite for e in errors):
        return None
    z = paired_z(*errors)
    return z if z > SIGNIFICANCE_Z else None
