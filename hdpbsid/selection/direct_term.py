"""``feedthrough="auto"`` inside the held-out selection (:mod:`hdpbsid.selection.auto`): the
candidates with a direct term ``D`` (:func:`_feedthrough_candidates`), the structure chosen
(:func:`_choose_structure`), and the decision for one method and order
(:func:`decide_feedthrough`).  The rule itself is :mod:`hdpbsid.selection.feedthrough`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from hdpbsid.data.checks import check_data
from hdpbsid.models.criteria import MIN_WINDOWS, choose_smallest_adequate, default_windows
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.selection.candidates import (
    CandidateRow,
    FitRecord,
    _fit_one,
    _predictor_name,
    _sweep,
)
from hdpbsid.selection.feedthrough import (
    FEEDTHROUGH_POLICY,
    Offer,
    feedthrough_offered,
    honours_feedthrough,
    judge_direct_term,
    structure_key,
    takes_feedthrough,
    without_own_d,
)
from hdpbsid.selection.policy import HOLDOUT
from hdpbsid.selection.scoring import score_model

__all__ = ["decide_feedthrough", "linear_hold_or_direct_term"]


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
    others with ``D``).  In closed loop, where a controller reacting within the sample
    could give a direct term part of the error (``offer.bound > 0``), their ``D`` is
    removed and they are scored again when the candidates with ``D`` were fitted and
    lost (:func:`_without_own_d`): kept, it would let them win by the term the
    judgement refused, which there predicts the measurement noise through the
    controller.  In open loop the input does not carry the noise, and their own ``D``
    stays: at an order below the plant's it stands for the static gain of the fast
    modes left out (removed also there, more records came out worse than better)."""
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
        return _without_own_d(ok, val, windows, offer), text
    for r in own:
        r.settings = {**r.settings, "feedthrough": True}
    return sorted(scored + own, key=structure_key), text


def _without_own_d(
    ok: list[CandidateRow], val: tuple, windows: int, offer: Offer
) -> list[CandidateRow]:
    """The pool of the structure without ``D`` after the judgement refused it: in closed
    loop (``offer.bound > 0``: a controller reacting within the sample could give a
    direct term part of the error), every candidate of ``ok`` whose method estimated a
    direct term of its own (:func:`~hdpbsid.selection.feedthrough.honours_feedthrough`
    False) has it set to zero (:func:`~hdpbsid.selection.feedthrough.without_own_d`)
    and is scored again on the held-out part, so that it competes in the structure
    chosen and not by a term refused; sorted again by
    :func:`~hdpbsid.selection.feedthrough.structure_key`.  In open loop ``ok`` as it
    is (:func:`_choose_structure`).  A candidate that cannot be scored without its
    ``D`` keeps it."""
    if offer.bound <= 0:
        return ok
    for r in ok:
        if r.model is None or honours_feedthrough(r.model) or not np.any(r.model.D):
            continue
        model = without_own_d(r.model)
        err, use_k = score_model(model, val, windows)
        if err.finite:
            r.model, r.criterion, r.predictor = model, err, _predictor_name(use_k)
            r.own_d_removed = True
    return sorted(ok, key=structure_key)


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


def linear_hold_or_direct_term(
    start: StateSpaceModel, refined: StateSpaceModel, t: Any, u: Any, y: Any, judged: bool
) -> tuple[StateSpaceModel, str]:
    """The refined model with the direct term the data chose, or the same dynamics with
    the input linear between samples and ``D = 0`` when that explains the record as well.

    Why.  Sampled with a first-order hold (the input linear between samples, as
    :func:`scipy.signal.lsim` assumes), a model without ``D`` has the sampled direct term
    ``C G2``: the input at ``t_k`` reaches ``y_k`` within the sample (Franklin, Powell &
    Workman, *Digital Control of Dynamic Systems*, 3rd ed., sec. 6.3.2).  The
    direct-term screen and the held-out judgement of ``D`` compare candidates before the
    refinement chooses the hold, so on such a record they take that link for ``D``, and
    with ``D`` free the held input explains it as well, so the refinement then has no
    evidence for the other hold.  The two structures are nested as sampled predictors:
    a held input with ``D`` reproduces any linear-hold model without ``D`` exactly (same
    ``Phi``, ``C``, ``K``; ``D = C G2``; ``B`` from the held input's ``Gamma``, which is
    invertible when the modes are resolved by the sampling), with ``l m`` parameters
    more.  So the smaller structure is tested against it by the likelihood ratio of the
    one-step errors, ``N (log det S_0 - log det S_1)``, asymptotically chi-square with
    ``l m`` degrees of freedom under the smaller one (Ljung, *System Identification*,
    2nd ed., 1999, sec. 16.4), and kept unless rejected at
    :attr:`~hdpbsid.selection.feedthrough.FeedthroughPolicy.linear_hold_level`.

    The linear-hold fit starts from the held-input model mapped to the smaller
    structure (:func:`_linear_hold_input_matrix`) with the budget of one
    Levenberg-Marquardt run and its confirmation
    (:class:`~hdpbsid.refine.pem_settings.RefinementSettings`: ``run_nfev +
    converged_nfev``): when the smaller structure holds, the refined held-input model is
    within its estimation error of a linear-hold model, so the mapped start lies in the
    quadratic region of the smaller structure's minimum, where one run converges; a fit
    that needs more is far from the held-input model, which then is not the linear hold in
    another form, and ``D`` is kept without the long fit.

    Only for a ``D`` that ``feedthrough="auto"`` decided (``judged``; ``feedthrough=True``
    is the user's structure), a refinement that chose the held input while free to choose
    (the method was not told its hold), and a refined linear-hold fit that converged and
    is sound (:func:`~hdpbsid.selection.scoring.refinement_instability`).

    Parameters
    ----------
    start : StateSpaceModel
        The model the refinement started from.
    refined : StateSpaceModel
        Its refinement on ``(t, u, y)``.
    t, u, y : array_like
        The record.
    judged : bool
        Whether ``feedthrough="auto"`` decided the direct term.

    Returns
    -------
    model : StateSpaceModel
        ``refined`` or the linear-hold model without ``D``.
    text : str
        What was tested and found, for ``options["linear_hold_rule"]`` (empty when
        nothing was tested).
    """
    import dataclasses

    from scipy.stats import chi2

    from hdpbsid.models.report import DirectTerm
    from hdpbsid.refine.pem import prediction_log_det, refine_pem
    from hdpbsid.refine.pem_settings import DEFAULT_SETTINGS
    from hdpbsid.selection.scoring import refinement_instability

    fd, fitted = refined.report.feedthrough, refined.report.refinement
    held = start.report.input_hold
    free = held is None or not held.given
    if not (judged and fd is not None and fd.asked and free and fitted is not None):
        return refined, ""
    if fitted.hold != "zoh":
        return refined, ""
    h = float(np.median(np.diff(np.asarray(t, dtype=float))))
    alt_start = dataclasses.replace(
        refined,
        B=_linear_hold_input_matrix(refined.A, refined.B, refined.C, refined.D, h),
        D=np.zeros_like(refined.D),
        options={**start.options, "feedthrough": False},
        report=start.report.but(feedthrough=DirectTerm(False, False)),
    )
    one_run = DEFAULT_SETTINGS.run_nfev + DEFAULT_SETTINGS.converged_nfev
    alt = refine_pem(alt_start, t, u, y, hold="foh", max_nfev=one_run)
    what = "the input linear between samples without D"
    if not alt.report.converged:
        return refined, (
            f"{what}: its fit from the held-input model did not converge within one run, "
            f"so it is not that model in another form; D kept"
        )
    unsound = refinement_instability(alt_start, alt, (t, u, y))
    if unsound:
        return refined, f"{what} not tested: {unsound}; D kept"
    v1 = prediction_log_det(refined, t, u, y, hold="zoh")
    v0 = prediction_log_det(alt, t, u, y, hold="foh")
    if v0 is None or v1 is None:
        return refined, f"{what} not tested: an unstable predictor; D kept"
    stat = v0 - v1
    dof, level = refined.l * refined.m, FEEDTHROUGH_POLICY.linear_hold_level
    bound = float(chi2.ppf(1.0 - level, dof))
    test = (
        f"{what} against the held input with D: likelihood ratio {stat:.3g} vs {bound:.3g} "
        f"(chi2, {dof} dof, {level:g})"
    )
    if not stat <= bound:
        return refined, f"{test}: D kept"
    return alt, f"{test}: the linear hold explains the lag-0 link, D = 0"


def _linear_hold_input_matrix(A: Any, B: Any, C: Any, D: Any, h: float) -> Any:
    """The ``B`` of the linear-hold model without ``D`` nearest, as a sampled model, to
    the held-input model ``(A, B, C, D)`` with step ``h``: the start of
    :func:`linear_hold_or_direct_term`'s fit.

    Held input: ``x+ = Phi x + G1 B u_k``, ``y_k = C x_k + D u_k``.  Linear between
    samples without ``D``: ``x+ = Phi x + (G1 - G2 + Phi G2) B' u_k``, ``y_k = C x_k +
    C G2 B' u_k`` (the state shifted by ``G2 B' u_k``), with ``G1 = int_0^h e^{A s} ds``
    and ``G2 = int_0^h e^{A s} (h - s) / h ds`` (Franklin, Powell & Workman, sec.
    6.3.2), both linear in ``B'``; ``B'`` is the least-squares match of the two input
    maps, exact when the held-input model is the sampled linear-hold one."""
    from scipy.linalg import expm

    A, B, C, D = (np.asarray(a, dtype=float) for a in (A, B, C, D))
    n = A.shape[0]
    M = np.zeros((3 * n, 3 * n))
    M[:n, :n], M[:n, n : 2 * n], M[n : 2 * n, 2 * n :] = A * h, np.eye(n) * h, np.eye(n)
    E = expm(M)
    Phi, G1, G2 = E[:n, :n], E[:n, n : 2 * n], E[:n, 2 * n :]
    lhs = np.vstack([G1 - G2 + Phi @ G2, C @ G2])
    rhs = np.vstack([G1 @ B, D])
    return np.linalg.lstsq(lhs, rhs, rcond=None)[0]
