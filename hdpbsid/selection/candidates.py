"""The candidates of the held-out selection (:mod:`hdpbsid.selection.auto`): every
``(method, order)`` fitted on the estimation part and scored on the held-out part
(:func:`_sweep`), the settings a candidate is fitted with (:func:`sweep_settings`), judged
with (:func:`settle_candidate`) and refitted with (:func:`refit_keeps`), and the table of
the candidates (``options["selection"]``, :meth:`CandidateRow.as_row`).

A candidate is a :class:`CandidateRow`: what the sweep found (method, order, model,
held-out score) and what the later steps of the selection learn of it.
"""

from __future__ import annotations

import inspect
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np

from hdpbsid.bases.basis_core import WindowReason
from hdpbsid.bases.basis_domain import BasisTooSmall
from hdpbsid.data.records import Dataset
from hdpbsid.methods.registry import call_method
from hdpbsid.models.criteria import WindowedError
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import Choice
from hdpbsid.selection.feedthrough import honours_feedthrough, with_d, without_own_d
from hdpbsid.selection.scoring import looks_closed_loop, score_model, stationarity_problem

__all__ = [
    "FitRecord",
    "CandidateRow",
    "FirstPass",
    "accepts_held_out",
    "sweep_settings",
    "settle_candidate",
    "refit_keeps",
    "closed_loop_refit",
]


@dataclass(frozen=True)
class FitRecord:
    """A record the held-out selection fits candidates on (the estimation part, or the
    whole record for the refit of the chosen one), cut once by
    :func:`~hdpbsid.selection.auto.select_model`: its arrays as cut and the
    :class:`~hdpbsid.data.records.Dataset` the methods take (:meth:`fit`).

    The arrays are also what the judgements that run on the estimation part compute on
    (the refinement of :mod:`hdpbsid.selection.rejudge`, the feedback test of
    :func:`~hdpbsid.selection.feedthrough.feedthrough_offered`): one record's stamps as
    the caller gave them (a Dataset's records hold times relative to their first sample,
    rounded differently), or for several records their list in the ``t`` slot with
    ``u = y = None``, the form those judgements recognise and skip.  The Dataset is made
    on the first fit, so a record its checks refuse fails each fit as the method's own
    checks did (the candidate's ``status``), not the selection.

    Parameters
    ----------
    arrays : tuple
        ``(t, u, y)`` as cut (above).

    Examples
    --------
    >>> import numpy as np
    >>> t = 100.0 + np.arange(20) * 0.1
    >>> part = FitRecord((t, np.ones((20, 1)), np.sin(t)[:, None]))
    >>> len(part.data), float(part.arrays[0][0]), float(part.data.records[0].t[0])
    (1, 100.0, 0.0)
    """

    arrays: tuple[Any, Any, Any]

    @cached_property
    def data(self) -> Dataset:
        """The records, checked once (:meth:`~hdpbsid.data.records.Dataset.of`)."""
        return Dataset.of(*self.arrays)

    def fit(self, func: Any, order: int, **settings: Any) -> StateSpaceModel:
        """The registered method ``func`` fitted on the record.

        Parameters
        ----------
        func : callable
            The method (its front door, :func:`~hdpbsid.methods.registry.get_method`).
        order : int
            The model order.
        **settings
            The method's keywords.

        Returns
        -------
        StateSpaceModel
            Its model: the method's Dataset function on :attr:`data`; a method with a
            front door only gets the arrays (:func:`~hdpbsid.methods.registry.call_method`).
        """
        return call_method(func, self.arrays, lambda: self.data, order, **settings)


class FirstPass(NamedTuple):
    """The sweep's fit of a candidate whose held-out-judged settings were settled
    (:func:`settle_candidate`): kept for the table, replaced in the candidate by the
    settled fit.

    Attributes
    ----------
    model : StateSpaceModel
        The model fitted with the first-pass settings (:func:`sweep_settings`).
    criterion : WindowedError
        Its held-out score.
    """

    model: StateSpaceModel
    criterion: WindowedError


@dataclass(eq=False, slots=True)
class CandidateRow:
    """One candidate of the held-out selection: a ``(method, order)`` fitted on the
    estimation part and scored on the held-out part (:func:`_fit_one`), and what the
    later steps of the selection learn of it, each step filling in its own fields.

    Mutable, and compared by identity (``eq=False``): the steps mark the candidate they
    judge in place, and two candidates of one method and order (with and without ``D``)
    are different candidates (:func:`_among`, :func:`_index`).  The table of the
    selection (``options["selection"]``) is :meth:`as_row` of every candidate.

    Attributes
    ----------
    method : str
        The registered method that fitted it.
    order : int
        Its order.
    model : StateSpaceModel or None
        The model fitted on the estimation part (None when the fit failed).
    criterion : WindowedError or None
        Its held-out score (:func:`~hdpbsid.selection.scoring.score_model`; None when
        the fit failed or is no candidate, e.g. a time series' model that is not
        stationary; not finite when it could not be scored).
    predictor : str or None
        The predictor that score is of: with its ``K`` or with ``K = 0`` (None when the
        fit failed).
    status : str
        ``"ok"``, or why it has no finite score.
    time : float
        The seconds its fit and score took in the sweep.
    settings : dict
        Its own settings beyond the user's: ``feedthrough=True`` for a candidate with
        ``D`` (:mod:`~hdpbsid.selection.direct_term`), the past window ``p`` that
        reaches an order the user gave (:func:`_fit_at_order`).
    p_rule : str or None
        The reason for that past window (None when the default one was used).
    z : float or None
        Its distance to the best held-out error in standard errors, set on the scored
        candidates (the one-standard-error rule).
    whole_simulation : float or None
        Its simulation error over the whole held-out part, set when it was tied with
        others of its order (:func:`~hdpbsid.selection.scoring.break_tie`).
    refined_model : StateSpaceModel or None
        Its model refined on the estimation part, set when the refinement converged
        (:mod:`~hdpbsid.selection.rejudge`).
    refined_criterion : WindowedError or None
        The held-out score of the refined model (of its own model when the refinement
        failed), set when it was refined.
    first_pass : FirstPass or None
        The sweep's fit, set when the settings its method judges on held-out data
        were settled (:func:`settle_candidate`).
    settled : bool
        Whether :func:`settle_candidate` judged it (it is idempotent by this mark).
    passed_floor : bool
        Whether it passed the floor of the refits
        (:func:`~hdpbsid.selection.refits._first_that_holds`).
    own_d_removed : bool
        Whether the direct term its method estimated of its own accord was set to zero
        because the judgement refused ``D`` on a closed-loop record
        (:func:`~hdpbsid.selection.feedthrough.without_own_d`); its settled fit and its
        refit are then made the same structure.

    Examples
    --------
    >>> row = CandidateRow("dt", 2, status="not scored")
    >>> row.as_row()["status"], row.as_row()["feedthrough"]
    ('not scored', False)
    """

    method: str
    order: int
    model: StateSpaceModel | None = None
    criterion: WindowedError | None = None
    predictor: str | None = None
    status: str = ""
    time: float = 0.0
    settings: dict[str, Any] = field(default_factory=dict)
    p_rule: str | None = None
    z: float | None = None
    whole_simulation: float | None = None
    refined_model: StateSpaceModel | None = None
    refined_criterion: WindowedError | None = None
    first_pass: FirstPass | None = None
    settled: bool = False
    passed_floor: bool = False
    own_d_removed: bool = False

    def as_row(self) -> dict[str, Any]:
        """The candidate's entry in the table of the selection (``options["selection"]``,
        read by :meth:`hdpbsid.models.report.Candidate.from_dict`).

        Returns
        -------
        dict
            ``method``, ``order``, ``feedthrough`` (fitted with ``D`` by the judgement),
            ``error`` and ``fit`` (held-out), ``z``, ``whole_simulation``,
            ``refined_error``, ``refined_fit``, ``predictor``, ``first_pass_error``,
            ``time``, ``status``; None where a step did not reach it.
        """
        c, refined, first = self.criterion, self.refined_criterion, self.first_pass
        return {
            "method": self.method,
            "order": self.order,
            "feedthrough": with_d(self),
            "error": None if c is None else c.total,
            "fit": None if c is None else c.fit,
            "z": self.z,
            "whole_simulation": self.whole_simulation,
            "refined_error": None if refined is None else refined.total,
            "refined_fit": None if refined is None else refined.fit,
            "predictor": self.predictor,
            "first_pass_error": None if first is None else first.criterion.total,
            "time": self.time,
            "status": self.status,
        }


def _predictor_name(use_k: bool) -> str:
    """The name of the predictor a score is of (:attr:`CandidateRow.predictor`)."""
    return "innovation (K)" if use_k else "output error (K = 0)"


def accepts_held_out(func: Any) -> bool:
    """Whether the method ``func`` takes ``held_out=(t, u, y)``: data kept out of its
    record on which it judges its own data-driven settings (HD-PBSID's operator scale),
    reporting what it chose in ``options["refit_settings"]``.  The candidates of
    :func:`select_model` get the held-out part, and the refit of the chosen one gets
    its ``refit_settings``: one judge for the order, the method and those settings, and
    no second split of the estimation part inside a method.

    Parameters
    ----------
    func : callable
        A method function of the registry.

    Returns
    -------
    bool
        Whether its signature has a ``held_out`` parameter (False when it has none to read).
    """
    try:
        return "held_out" in inspect.signature(func).parameters
    except (TypeError, ValueError):
        return False


def sweep_settings(func: Any, given: dict[str, Any]) -> dict[str, Any]:
    """The settings the candidates of method ``func`` are fitted with in a sweep: the
    ``given`` ones (the user's), and the first-pass values the method declares in its
    ``sweep_settings`` attribute for every such setting the user did not give.

    Why: a setting a method would ask the data for a second time fits the candidate
    again (HD-PBSID's operator scale: one to two more fits per order, each at a scale of
    its own, which no other order shares; the Laguerre pole from the modes), and only
    the chosen candidate's setting reaches the result.  A method that judges such a
    setting on held-out data (:func:`accepts_held_out`) has it judged for the chosen
    candidate by :func:`settle_candidate`: a setting judged for a candidate that is not
    chosen changes nothing of the result, so judging it only for the chosen one costs
    nothing in accuracy (``bench/regression.py`` compares both).  A method that cannot
    judge it on held-out data keeps the first pass, the predictor the held-out part
    judged, in its refit as well: a second pass there would be an in-sample screen the
    order and method choice never saw.

    Parameters
    ----------
    func : callable
        A method function of the registry.
    given : dict
        The settings the user gave the method.

    Returns
    -------
    dict
        The settings of its candidates in the sweep.
    """
    first = getattr(func, "sweep_settings", None)
    return {**(first or {}), **given}


def refit_keeps(
    func: Any, model: StateSpaceModel, given: dict[str, Any], closed_loop: bool = False
) -> dict[str, Any]:
    """The data-driven settings of candidate ``model`` that its refit on the whole
    record keeps: those the method ``func`` lists in its ``refit_keeps`` attribute
    (``dt``: the past and future windows), with the values the candidate used, except
    the ones the user gave (``given``, passed as they are); none on a ``closed_loop``
    record.

    Why: the held-out part judged the candidate's predictor as it was built, windows
    included; the refit re-estimates that structure on more data (as it keeps the
    order), instead of asking the data again for a setting the judgement did not test.
    A method lists a setting here when choosing it again would be costly (``dt``'s
    past-window criterion: a QR over up to 200 lags, most of a refit's time); the
    settings that can be kept are the core's windows ``"p"`` and ``"f"``, which the
    model reports (``model.report.windows``).

    In closed loop the windows are chosen again on the whole record.  PBSID on the
    samples is consistent under feedback only as its past window grows with the record
    (Chiuso, "The role of vector autoregressive modeling in predictor-based subspace
    identification", Automatica 43(6), 2007: ``p`` must grow with ``N``), because the
    predictor's memory left beyond the window is correlated with the input through the
    loop; the information criterion takes a longer window on a longer record (its
    penalty is fixed, the fit a lag adds grows with ``N``), so the window chosen on the
    estimation part is the shorter one, and its truncation can leave the start of the
    refinement in another basin of the prediction-error cost than the record's own
    window does.  In open loop the truncation adds no correlation with the input, and
    the refinement removes what it leaves.

    Parameters
    ----------
    func : callable
        The candidate's method function.
    model : StateSpaceModel
        The candidate, fitted on the estimation part.
    given : dict
        The settings the user gave the method.
    closed_loop : bool, optional
        Whether the record is closed loop (the feedback test on the candidate:
        :func:`~hdpbsid.selection.scoring.looks_closed_loop`).

    Returns
    -------
    dict
        The settings the refit keeps, with the candidate's values.
    """
    keys = () if closed_loop else getattr(func, "refit_keeps", ())
    used = model.report.windows
    return {k: used[k] for k in keys if k not in given and k in used}


def closed_loop_refit(func: Any, model: StateSpaceModel, record: tuple) -> bool:
    """Whether the refit of candidate ``model`` by the method ``func`` on ``record``
    (``(t, u, y)``) is a closed-loop refit for :func:`refit_keeps`: the feedback test
    declares the record closed loop on the candidate's one-step prediction errors
    (:func:`~hdpbsid.selection.scoring.looks_closed_loop`).  Asked only of a method whose
    refit would keep settings, and of one record with an input.

    Parameters
    ----------
    func : callable
        The candidate's method function.
    model : StateSpaceModel
        The candidate.
    record : tuple
        ``(t, u, y)`` of the refit (``u = None``: several records, or none).

    Returns
    -------
    bool
        Whether the refit is in closed loop.
    """
    if not getattr(func, "refit_keeps", ()) or record[1] is None or model.m == 0:
        return False
    return looks_closed_loop(model, record)


def _refit_settings(model: StateSpaceModel) -> dict[str, Any]:
    """The settings ``model``'s method chose on held-out data for a refit of it
    (``model.report.refit_settings``; empty when none)."""
    chosen = model.report.refit_settings
    return {} if chosen is None else dict(chosen.value)


def settle_candidate(
    get_method: Any, row: CandidateRow, est: FitRecord, val: tuple, windows: int, options: dict
) -> CandidateRow:
    """The candidate ``row`` with the settings its method judges on held-out data
    (:func:`sweep_settings`) judged: fitted again on ``est`` with the user's settings
    and ``held_out=val``, scored (:func:`score_model`), and that fit replaces the row's
    model and score (``row.settled``; the sweep's first-pass fit is kept in
    ``row.first_pass``).  A candidate whose method declares no such settings, whose
    settings the user gave, or whose second fit fails or cannot be scored is returned as
    it is, its refit then given the first-pass settings it was fitted with.  Idempotent.

    Parameters
    ----------
    get_method : callable
        The registry's ``get_method``.
    row : CandidateRow
        The candidate (scored: ``model`` and ``criterion``), updated in place.
    est : FitRecord
        The estimation part.
    val : tuple
        The held-out part ``(t, u, y)``.
    windows : int
        The number of scoring windows.
    options : dict
        The user's settings per method.

    Returns
    -------
    CandidateRow
        ``row``.
    """
    func = get_method(row.method)
    given = _given(row, options)
    first = sweep_settings(func, given)
    if row.settled or first == given:
        return row
    row.settled = True
    if not accepts_held_out(func):
        return _keep_first_pass(row, first, given, "the method judges none on held-out data")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = est.fit(func, row.order, **given, held_out=val)
            if row.own_d_removed and not honours_feedthrough(model):
                model = without_own_d(model)  # the structure it was judged in
            # a time series' model that is not stationary is no candidate
            bad = bool(stationarity_problem(model))
            err, use_k = (None, False) if bad else score_model(model, val, windows)
    except (ValueError, np.linalg.LinAlgError):
        err = None
    if err is None or not err.finite:
        return _keep_first_pass(row, first, given, "its fit judged on held-out data failed")
    row.first_pass = FirstPass(row.model, row.criterion)
    if row.p_rule is not None:
        _mark_window_rule(model, row.p_rule)
    row.model, row.criterion, row.predictor = model, err, _predictor_name(use_k)
    return row


def _keep_first_pass(
    row: CandidateRow, first: dict[str, Any], given: dict[str, Any], why: str
) -> CandidateRow:
    """The candidate ``row`` as the sweep fitted it: its refit on the whole record gets
    the sweep's settings (``first``) but the user's (``given``), for the reason ``why``."""
    carried = {k: v for k, v in first.items() if k not in given}
    row.model.options["refit_settings"] = carried
    row.model.report = row.model.report.but(
        refit_settings=Choice(carried, f"the first pass's ({why})")
    )
    return row


def _among(row: CandidateRow, rows: Sequence[CandidateRow]) -> bool:
    """Whether the candidate ``row`` is one of ``rows`` (by identity: two candidates of
    one method and order, with and without ``D``, are different rows)."""
    return any(r is row for r in rows)


def _index(rows: Sequence[CandidateRow], row: CandidateRow) -> int:
    """The position of the candidate ``row`` in ``rows``, by identity (:func:`_among`)."""
    return next(i for i, r in enumerate(rows) if r is row)


def _given(row: CandidateRow, options: dict) -> dict[str, Any]:
    """The settings candidate ``row`` of a sweep is fitted with: its method's in
    ``options`` (the user's), and the row's own (``row.settings``: ``feedthrough``
    for a candidate with ``D`` of :mod:`hdpbsid.selection.feedthrough`)."""
    return {**options.get(row.method, {}), **row.settings}


def _fit_at_order(
    func: Any, rec: FitRecord, order: int, settings: dict[str, Any], order_given: bool
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
        return rec.fit(func, order, **settings), {}, ""
    except BasisTooSmall as exc:
        if not order_given or "p" in settings or exc.p_needed > exc.p_max:
            raise
        extra = {"p": exc.p_needed}
        model = rec.fit(func, order, **settings, **extra)
        rule = (
            f"p = {exc.p_needed}, the smallest window that reaches the order asked for, "
            f"above the precision rule (the VARX is determined up to p = {exc.p_max}; "
            f"less precise than a basis that holds the default window)"
        )
        _mark_window_rule(model, rule)
        return model, extra, rule


def _mark_window_rule(model: StateSpaceModel, rule: str) -> None:
    """Say on ``model`` why its past window is the one :func:`_fit_at_order` passed
    (``options["p_rule"]`` and ``report.past_window``, typed
    :attr:`~hdpbsid.bases.basis_core.WindowReason.ORDER_NEEDS`: the smallest window that
    reaches the order asked for).

    Parameters
    ----------
    model : StateSpaceModel
        A basis method's model fitted with that window.
    rule : str
        The rule's text.
    """
    model.options["p_rule"] = rule
    before = model.report.past_window
    p = before.value if before is not None else model.report.windows.get("p")
    model.report = model.report.but(past_window=Choice(p, rule, WindowReason.ORDER_NEEDS))


def _fit_row(
    row: CandidateRow, func: Any, rec: FitRecord, settings: dict[str, Any], order_given: bool
) -> StateSpaceModel:
    """The model of candidate ``row`` (its method ``func`` at ``row.order``) fitted on
    ``rec`` with ``settings`` (:func:`_fit_at_order`; a past window it passed beyond
    them is written to ``row.settings`` and ``row.p_rule``).  Raises ``TypeError`` when
    the method returns no :class:`StateSpaceModel`, ``ValueError`` when it returns a
    time-series model that describes no stationary process
    (:func:`~hdpbsid.selection.scoring.stationarity_problem`), besides what the method
    raises."""
    model, extra, p_rule = _fit_at_order(func, rec, row.order, settings, order_given)
    if extra:
        row.settings, row.p_rule = extra, p_rule
    if not isinstance(model, StateSpaceModel):
        raise TypeError(
            f"method {row.method!r} returned {type(model).__name__}, expected StateSpaceModel"
        )
    why = stationarity_problem(model)
    if why:
        raise ValueError(why)
    return model


def _fit_one(
    get_method: Any,
    method: str,
    order: int,
    est: FitRecord,
    val: tuple,
    windows: int,
    options: dict,
    order_given: bool = False,
) -> CandidateRow:
    """The candidate ``(method, order)``: fitted on ``est`` with its sweep settings
    (:func:`sweep_settings`, :func:`_fit_at_order`) and scored on ``val`` over
    ``windows`` windows (:func:`score_model`); a fit that fails, or a time series' model
    that is not stationary, is a candidate with no score and the reason in ``status``."""
    t0 = time.perf_counter()
    row = CandidateRow(method, order)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            func = get_method(method)
            settings = sweep_settings(func, options.get(method, {}))
            model = _fit_row(row, func, est, settings, order_given)
            err, use_k = score_model(model, val, windows)
        row.status = (
            "ok"
            if err.finite
            else "not scored: its one-step predictor is unstable or its simulation overflows"
        )
        row.criterion, row.predictor, row.model = err, _predictor_name(use_k), model
    except (ValueError, np.linalg.LinAlgError) as exc:
        row.status, row.criterion, row.predictor = f"{type(exc).__name__}: {exc}", None, None
    row.time = time.perf_counter() - t0
    return row


def _sweep_method(
    get_method: Any,
    method: str,
    orders: list[int],
    est: FitRecord,
    val: tuple,
    windows: int,
    options: dict,
    order_given: bool = False,
) -> list[CandidateRow]:
    """Every order of one method, upwards (the orders share the method's memoised
    order-independent steps, :mod:`hdpbsid.bases.memo`)."""
    return [
        _fit_one(get_method, method, n, est, val, windows, options, order_given) for n in orders
    ]


def _sweep(
    get_method: Any,
    methods: Sequence[str],
    orders: list[int],
    est: FitRecord,
    val: tuple,
    windows: int,
    options: dict,
    n_jobs: int | None,
    order_given: bool = False,
) -> list[CandidateRow]:
    """Every ``(method, order)`` candidate, listed orders upwards and, within an order, in
    the order of ``methods`` (``order_given``: the user asked for the one order, see
    :func:`_fit_at_order`).  With ``n_jobs`` the methods are swept in parallel
    (joblib), each method's orders in one worker, where they share its memoised
    projection and operators; the candidates, and so the result, are those of the
    serial run (bit for bit when that runs with one BLAS thread, as the workers do).

    Every order is fitted: a larger order that does not beat the best by a standard
    error cannot be chosen, but it can become the best and so move the reference of the
    one-standard-error rule (the choice between two small orders can depend on a much
    larger one), so stopping the sweep early would change the choice.
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
