"""``feedthrough="auto"`` inside the held-out selection (:mod:`hdpbsid.selection.auto`): the
candidates with a direct term ``D`` (:func:`_feedthrough_candidates`), the structure chosen
(:func:`_choose_structure`), and the decision for one method and order
(:func:`decide_feedthrough`).  The rule itself is :mod:`hdpbsid.selection.feedthrough`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from hdpbsid.data.checks import check_data
from hdpbsid.models.criteria import MIN_WINDOWS, choose_smallest_adequate, default_windows
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.selection.candidates import CandidateRow, FitRecord, _fit_one, _sweep
from hdpbsid.selection.feedthrough import (
    Offer,
    feedthrough_offered,
    honours_feedthrough,
    judge_direct_term,
    structure_key,
    takes_feedthrough,
)
from hdpbsid.selection.policy import HOLDOUT

__all__ = ["decide_feedthrough"]


def _feedthrough_candidates(
    get_method: Any,
    ok: list[CandidateRow],
    chosen: CandidateRow,
    swept: Sequence[str],
    orders: list[int],
    est: FitRecord,
    val: tuple,
    windows: int,
    opts: dict,
    n_jobs: int | None,
    order_given: bool = False,
) -> tuple[list[CandidateRow], Offer]:
    """The candidates with ``D`` for :func:`select_model` (``judge_feedthrough``), and
    whether they are offered, why, and the terms of their judgement
    (:func:`~hdpbsid.selection.feedthrough.feedthrough_offered`, tested with
    ``chosen``, the candidate without ``D`` the one-standard-error rule takes, on the
    estimation part): every built-in method of
    ``swept`` (:func:`~hdpbsid.selection.feedthrough.takes_feedthrough`) whose candidates
    do not estimate ``D`` of their own (:func:`~hdpbsid.selection.feedthrough.
    honours_feedthrough`) is fitted with ``feedthrough=True`` at every order of the
    sweep.  Every order: without ``D`` a direct term can cost states (a fast mode
    imitates it) or remove them (a plant whose output is dominated by ``D u`` looks
    static), so the order without ``D`` bounds nothing."""
    offer = feedthrough_offered(chosen.model, est.arrays)
    if not offer.offered:
        return [], offer
    why = offer.why
    # every built-in method of the sweep but those whose candidates showed they estimate
    # D whatever they are asked; a method with no candidate without D (dt with no
    # continuous-time model at an order) may have one with D
    own = {r.method for r in ok if not honours_feedthrough(r.model)}
    methods = [m for m in swept if takes_feedthrough(m) and m not in own]
    if not methods:
        why += "; no method here takes feedthrough=, so no candidate with D"
        return [], offer._replace(why=why)
    d_opts = {m: {**opts.get(m, {}), "feedthrough": True} for m in methods}
    extra = _sweep(get_method, methods, orders, est, val, windows, d_opts, n_jobs, order_given)
    for r in extra:
        r.settings = {**r.settings, "feedthrough": True}
    why += f"; candidates with D of {', '.join(methods)} at every order"
    return extra, offer._replace(why=why)


def _choose_structure(
    ok: list[CandidateRow],
    k: int,
    extra: list[CandidateRow],
    val: tuple,
    windows: int,
    offer: Offer,
) -> tuple[list[CandidateRow], str]:
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
    a larger simulation gain than ``offer.bound``, the most a controller's instantaneous
    path could give; with a deterministic input a larger gain than ``offer.min_gain``).

    A method that estimates ``D`` whatever it is asked (Laguerre's ``D_d``) has no
    structure to choose: the structures are compared between the methods that take
    ``feedthrough=`` (a method with its own ``D`` would otherwise stand for "without
    ``D``"), and its candidates then compete in the pool of the structure chosen, as
    candidates with ``D`` when ``D`` is chosen (they then rank and tie with the
    others with ``D``)."""
    why = offer.why
    scored = [r for r in extra if r.criterion is not None and r.criterion.finite]
    if not scored:
        return ok, why + ("; no candidate with D could be scored" if extra else "")
    own = [r for r in ok if not honours_feedthrough(r.model)]
    plain = [r for r in ok if honours_feedthrough(r.model)]
    scored.sort(key=structure_key)
    b = scored[choose_smallest_adequate([r.criterion for r in scored])[0]]
    a = plain[choose_smallest_adequate([r.criterion for r in plain])[0]] if plain else ok[k]
    choice = judge_direct_term(
        a.model,
        b.model,
        (a.criterion, b.criterion),
        check_data(*val),
        windows,
        bound=offer.bound,
        min_gain=offer.min_gain,
    )
    text = (
        f"{why}; without D {a.method} order {a.order}, with D {b.method} order "
        f"{b.order}: {choice.text()}"
    )
    if not choice.value:
        return ok, text
    for r in own:
        r.settings = {**r.settings, "feedthrough": True}
    return sorted(scored + own, key=structure_key), text


def _feedthrough_report(model: StateSpaceModel, ok: list[CandidateRow], why: str) -> str:
    """The text of ``options["feedthrough_rule"]``: whether the returned ``model`` has a
    direct term, and why (:func:`_feedthrough_candidates`, :func:`_choose_structure`)."""
    has_d = honours_feedthrough(model) and model.report.feedthrough.estimated
    return f"auto: {why}; returned: {'D estimated' if has_d else 'D = 0'}"


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
    val = (t[split:], u[split:], y[split:])
    windows = default_windows(t.size - split, order)
    if windows < MIN_WINDOWS:
        return False, "auto: not judged (too short to hold out the scoring windows); D = 0"
    est = FitRecord((t[:split], u[:split], y[:split]))
    return _judge_two(get_method, method, order, options, est, val, windows)


def _judge_two(
    get_method: Any,
    method: str,
    order: int,
    options: dict[str, Any],
    est: FitRecord,
    val: tuple,
    windows: int,
) -> tuple[bool, str]:
    """:func:`decide_feedthrough` on the split record: ``D`` offered (the screen is
    model-free and runs first: a record where ``D`` is not offered costs no fit at all,
    and the method is then fitted once, on the whole record), the candidates without
    and with ``D`` fitted on ``est`` and scored on ``val`` over ``windows`` windows, and
    judged."""
    offer = feedthrough_offered(None, est.arrays)
    if not offer.offered:
        return False, f"auto: {offer.why}; D = 0"
    fit = _fit_one(get_method, method, order, est, val, windows, {method: dict(options)})
    with_opts = {method: {**options, "feedthrough": True}}
    own = f"auto: {method} does not take feedthrough= (its own D is kept)"
    if _scores(fit) and not honours_feedthrough(fit.model):
        return False, own
    fit_d = _fit_one(get_method, method, order, est, val, windows, with_opts)
    if _scores(fit_d) and not honours_feedthrough(fit_d.model):
        return False, own
    if not _scores(fit):
        return _judge_without_rival(fit, fit_d, offer)
    if not _scores(fit_d):
        return False, f"auto: {offer.why}; the candidate with D: {fit_d.status}; D = 0"
    choice = judge_direct_term(
        fit.model, fit_d.model, (fit.criterion, fit_d.criterion), val, windows,
        bound=offer.bound, min_gain=offer.min_gain,
    )  # fmt: skip
    return choice.value, (
        f"auto: {offer.why}; at order {order} on the held-out part ({windows} windows): "
        f"{choice.text()}"
    )


def _scores(row: CandidateRow) -> bool:
    """Whether the candidate ``row`` was fitted and has a finite held-out score."""
    return row.criterion is not None and row.criterion.finite


def _judge_without_rival(fit: CandidateRow, fit_d: CandidateRow, offer: Offer) -> tuple[bool, str]:
    """:func:`decide_feedthrough` when the candidate without ``D`` (``fit``) has no score
    and ``D`` is offered (``offer``): ``D`` is estimated when its candidate ``fit_d``
    scores."""
    if not _scores(fit_d):
        return False, f"auto: not judged (no candidate: {fit.status}); D = 0"
    return True, (
        f"auto: {offer.why}; the candidate without D: {fit.status}; the one with D scores: "
        "D estimated"
    )
