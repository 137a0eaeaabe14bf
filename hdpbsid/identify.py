"""``hdpbsid.identify``: one entry point for every identification method.

``m = hdpbsid.identify(t, u, y, order=4, method="hermite")`` with ``method`` one of
``"hermite"``, ``"laguerre"``, ``"legendre"``, ``"dt"``, ... (docs/user-guide.md): the
record is checked, scaled and detrended here (the mechanics of the inputs in
:mod:`hdpbsid.identify_inputs`), the method is taken from the registry
(:mod:`hdpbsid.methods.registry`, which imports each method on first use), and the
model refined and given its operating point.  :func:`identify` is the pipeline
``check inputs -> run the method (one record, or several as one Dataset) -> refine ->
report``, each step a function of its own below it.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from hdpbsid.data.checks import (
    check_data,
    check_time,
    check_varies,
    is_uniform,
    require_joblib,
)
from hdpbsid.data.detrend import DETREND_CHOICES, detrend_record, warn_if_levels_dominate
from hdpbsid.data.records import Dataset, Labels
from hdpbsid.identify_inputs import (
    _check_records,
    _Labels,
    _listed,
    _Scaling,
    _warn_not_exciting,
    _weighted_levels,
)
from hdpbsid.methods.registry import (
    IdentifyFunc,
    call_method,
    get_method,
)
from hdpbsid.models.model import LinearTrend, StateSpaceModel, _set_levels
from hdpbsid.models.report import Choice
from hdpbsid.refine.pem import (
    FOCUSES,
    REFINE_CHOICES,
    one_step_errors,
    refine_pem,
)
from hdpbsid.refine.pem_focus import warn_if_closed_loop
from hdpbsid.runtime import library_call, user_stacklevel
from hdpbsid.selection import long_records as scaling
from hdpbsid.selection.feedback import refine_decision, refine_plan, retried
from hdpbsid.selection.feedthrough import check_feedthrough, with_d_asked
from hdpbsid.selection.focus import choose_focus, given
from hdpbsid.selection.iterate import IterateRule, continued, keep_iterate

__all__ = ["identify"]


@dataclass(frozen=True)
class _Request:
    """What the user asked of :func:`identify`, checked before any computation: the
    method and order, the refinement and the operating point, and the keywords
    :func:`identify` takes out of ``options`` itself (the direct term when judged here,
    the long-record policy and the progress bars)."""

    method: str
    order: Any
    refine: str | None
    detrend: str | None
    feedthrough: Any  # True, False or "auto" (the default)
    long_record: Any
    progress: bool
    focus: str = "auto"


def _request(
    method: str, order: Any, refine: Any, detrend: Any, options: dict[str, Any]
) -> _Request:
    """Check ``refine`` and ``detrend`` and take :func:`identify`'s own keywords out of
    ``options`` (a ``feedthrough`` other than ``"auto"`` goes back to the method)."""
    if refine not in REFINE_CHOICES:
        raise ValueError(f"refine must be one of {REFINE_CHOICES}, got {refine!r}")
    if detrend not in DETREND_CHOICES:
        raise ValueError(f"detrend must be one of {DETREND_CHOICES}, got {detrend!r}")
    feedthrough = check_feedthrough(options.pop("feedthrough", "auto"))
    if feedthrough != "auto":
        options["feedthrough"] = feedthrough
    long_record, progress = options.pop("long_record", None), options.pop("progress", False)
    focus = options.pop("focus", "auto")
    if focus not in ("auto", *FOCUSES):
        raise ValueError(f"focus must be 'auto' or one of {FOCUSES}, got {focus!r}")
    if focus not in ("auto", "prediction") and refine is None:
        raise ValueError(f"focus={focus!r} is the refinement's: it needs refine='auto' or 'pem'")
    return _Request(method, order, refine, detrend, feedthrough, long_record, progress, focus)


@dataclass
class _FirstPass:
    """The method's model before the refinement, the record the refinement runs on
    (``(None, None, None)`` for several records) and the operating point removed."""

    model: Any
    record: tuple[Any, Any, Any]
    u0: Any
    y0: Any
    trend: LinearTrend | None
    op_info: Any


def _is_several(t: Any) -> bool:
    """Whether ``t`` is the list form ``[(t1, u1, y1), ...]`` (an empty list included)."""
    return isinstance(t, list | tuple) and (len(t) == 0 or isinstance(t[0], list | tuple))


def _identify_long(
    t: Any, u: Any, y: Any, req: _Request, labels: _Labels | None, options: dict[str, Any]
) -> StateSpaceModel:
    """The bounded path of a long record (:mod:`hdpbsid.selection.long_records`), labelled
    and reported as :func:`identify` reports the in-memory path."""
    model = scaling.identify_long(
        t, u, y, req.order, req.refine, req.detrend, long_record=req.long_record,
        progress=req.progress, focus=req.focus, **options,
    )  # fmt: skip
    if labels is not None:
        labels.apply(model, [(t, u, y)])
    model.report = _decided(model, req.order, req.method, model.report.refine_decision, {})
    return model


def _first_pass_records(
    func: IdentifyFunc,
    t: Any,
    u: Any,
    y: Any,
    req: _Request,
    options: dict[str, Any],
    labels: Labels | None = None,
) -> _FirstPass:
    """The method on several records, each detrended on its own and given to the method
    as one :class:`~hdpbsid.data.records.Dataset`; the model holds the sample-weighted
    mean level."""
    if u is not None or y is not None:
        raise ValueError(
            "with a list of (t, u, y) records in t, leave u and y out (u=None, y=None)"
        )
    if req.refine == "pem":
        raise ValueError("refine needs a single record; pass refine=None with a list")
    records, levels = [], []
    for i, (tt, uu, yy) in enumerate(_check_records(t)):
        ua = np.zeros((tt.size, 0)) if uu is None else uu
        ud, yd, lv = detrend_record(tt, ua, yy, req.detrend)
        if req.detrend is None:
            warn_if_levels_dominate(ua, yy, f"record {i}: ")
        records.append((tt, None if uu is None else ud, yd))
        levels.append(lv)
    options.pop("order_rule", None)
    # made once here: the method takes the records as they are (as_records)
    data = Dataset.of(records).described(labels, [(lv.u0, lv.y0) for lv in levels])
    model = call_method(func, (data, None, None), data, order=req.order, **options)
    if req.feedthrough == "auto":
        model.options.setdefault("feedthrough_rule", "auto: several records, not judged; D = 0")
    if req.order is None:
        model.options["order_selection"] = "singular values of the method (several records)"
    u0, y0 = _weighted_levels(levels)
    # no single record to refine on
    return _FirstPass(model, (None, None, None), u0, y0, None, [lv.as_dict() for lv in levels])


def _first_pass_record(
    func: IdentifyFunc,
    t: Any,
    u: Any,
    y: Any,
    req: _Request,
    options: dict[str, Any],
    labels: Labels | None = None,
) -> _FirstPass:
    """The method on one record, detrended as ``req.detrend`` says (the record passed
    unchanged with ``detrend=None``: exactly what the method got before)."""
    if y is None:
        raise ValueError("y is required: identify(t, u, y, ...) or a list of (t, u, y)")
    tt, ua, yy = check_data(t, u, y)
    check_varies(yy)
    ud, yd, lv = detrend_record(tt, ua, yy, req.detrend)
    if req.detrend is None:
        warn_if_levels_dominate(ua, yy)
        record = (t, u, y)
    else:
        record = (tt, None if u is None else ud, yd)
    ops = [None if req.detrend is None else (lv.u0, lv.y0)]
    model = _run(
        req.method, func, record, req.order, options, refined=req.refine is not None,
        judge_feedthrough=req.feedthrough == "auto",
        describe=lambda data: data.described(labels, ops),
    )  # fmt: skip
    trend = None if lv.t_ref is None else LinearTrend(lv.t_ref, lv.u_slope, lv.y_slope)
    return _FirstPass(model, record, lv.u0, lv.y0, trend, lv.as_dict())


def _refine_step(first: _FirstPass, req: _Request, several: bool, t_method: float) -> Any:
    """The refinement of the first pass (:func:`_refined`), its decision and the seconds of
    the stages written to ``model.report`` (:func:`_decided`)."""
    model = first.model
    if not isinstance(model, StateSpaceModel):
        raise TypeError(
            f"method {req.method!r} returned {type(model).__name__}, expected StateSpaceModel"
        )
    t_refine = time.perf_counter()
    timings = {"method": t_refine - t_method}
    judged = req.feedthrough == "auto"
    if isinstance(req.order, int):  # an order given: its refinement goes on (continued)
        model.report = model.report.but(order=Choice(model.n, "given"))
    model, rule = _refined(
        model, req.refine, several, *first.record, judged=judged, focus=req.focus
    )
    # a starting point offered to the refinement (method="auto"), not part of the result
    model.report = model.report.but(warm_start=None, restarts=())
    if not several:
        _warn_if_fallback(model, first.model)
    _warn_if_biased_time_series(model)
    if req.refine is not None:
        timings["refine"] = time.perf_counter() - t_refine
        model.options["refine_time"] = timings["refine"]
    decision = None if req.refine is None else Choice(model.report.refinement is not None, rule)
    model.report = _decided(model, req.order, req.method, decision, timings)
    return model


def _warn_if_biased_time_series(model: StateSpaceModel) -> None:
    """A ``UserWarning`` when a time series (no input) is returned as the subspace
    estimate of a method whose lag operator is not strictly causal
    (:func:`hdpbsid.core.varx.is_strictly_causal`; ``model.report.strictly_causal_lag``).

    Such a lag mixes the current coefficient into its own regressor, so a regressor
    built from noise-driven output is correlated with the equation error
    (:mod:`hdpbsid.methods.hermite_iv`).  With an input that share is the noise's, small
    at a good signal-to-noise ratio; a time series is driven by its noise alone, so the
    whole regression is, and the poles come out far too slow (a first-order process at
    -0.5 rad/s: -0.002 to -0.02 from the Hermite and Legendre methods).  The
    prediction-error refinement removes the bias (the default on uniform samples); the
    sample shift and the Laguerre shift are strictly causal and need no warning."""
    if model.m or model.report.refinement is not None:
        return
    if model.report.strictly_causal_lag is not False:
        return
    warnings.warn(
        f"{model.report.method}: a time series (no input) identified in a basis domain "
        "and not refined is biased: the method's lag is not strictly causal, so each "
        "regressor holds part of the noise it should predict, and a time series is all "
        "noise-driven (poles come out far too slow); the prediction-error refinement "
        "removes the bias (refine='auto' or 'pem' on uniform samples; why it did not "
        "run or was not kept: options['refine_rule']), or use method='laguerre' or "
        "'dt', whose lags are strictly causal",
        UserWarning,
        stacklevel=user_stacklevel(),
    )


def _finished(
    model: StateSpaceModel,
    first: _FirstPass,
    signal_scale: _Scaling,
    labels: _Labels,
    records: Any,
    req: _Request,
    options: dict[str, Any],
) -> StateSpaceModel:
    """The model given its operating point, its signals' scale, its labels and the
    settings asked for (``model.options``)."""
    _set_levels(model, first.u0, first.y0, first.trend)
    model, op_info = signal_scale.undo(model, first.op_info)
    labels.apply(model, records)
    model.options.setdefault("refine", None)
    model.options.setdefault("method", req.method)
    model.options["detrend"] = req.detrend
    model.options["operating_points"] = op_info
    model.options["requested_method"] = req.method
    model.options["requested_order"] = req.order
    model.options["requested_options"] = dict(options)
    return model


@library_call
def identify(
    t: Any,
    u: Any = None,
    y: Any = None,
    order: int | None = None,
    method: str = "auto",
    refine: str | None = "auto",
    detrend: str | None = "mean",
    *,
    input_names: Any = None,
    output_names: Any = None,
    time_unit: str = "s",
    delay: Any = None,
    **options: Any,
) -> StateSpaceModel:
    """Identify a continuous-time model ``dx/dt = A x + B u + K e``, ``y = C x + D u + e``.

    The front door of the package: the record is checked, its channels scaled when they
    lie far outside the float64 comfort band, its operating point removed
    (``detrend``), the method taken from the registry (:data:`METHODS`,
    :func:`available_methods`) and run, its model refined by a prediction-error fit
    (``refine``) and given back its operating point, labels and report.  Every decision
    and its reason is in ``model.report``; every setting used in ``model.options``.

    Parameters
    ----------
    t : array_like, shape (Ns,), list of (t, u, y), Dataset or ChunkedRecord
        Sample times (any spacing for the basis-domain methods; uniform for ``"dt"`` and
        for the refinement).  Several experiments of the same system: a list
        ``[(t1, u1, y1), (t2, u2, y2), ...]`` or a
        :class:`~hdpbsid.data.records.Dataset` (``u``, ``y`` left out); every record is
        detrended on its own and the method gets them as one ``Dataset``.  A
        :class:`~hdpbsid.data.chunked.ChunkedRecord` takes the long-record path.
    u : array_like, shape (Ns, m) or (Ns,), optional
        Inputs as for :func:`scipy.signal.lsim`; None for a time series (no input).
    y : array_like, shape (Ns, l) or (Ns,)
        Outputs (required with a single record).
    order : int, optional
        Model order.  None chooses it from identified models scored on held-out data
        (Notes; :func:`hdpbsid.selection.auto.select_order`).
    method : str, optional
        An entry of :data:`METHODS`: ``"auto"`` (default: ``hermite``, ``laguerre``,
        ``legendre`` and ``dt`` tried, the best by held-out prediction error kept,
        :func:`hdpbsid.selection.auto.identify_auto`), ``"hermite"`` (HD-PBSID),
        ``"laguerre"``, ``"legendre"``, ``"dt"``, ... (:func:`available_methods`).
    refine : {"auto", "pem", None}, optional
        ``"auto"`` (default) refines every single uniformly sampled record whose
        first-pass one-step predictor does not diverge, or whose plant's simulation
        errors show no feedback when it does
        (:func:`hdpbsid.selection.feedback.refine_plan`); ``"pem"`` always refines
        (:func:`hdpbsid.refine.pem.refine_pem`; one uniformly sampled record);
        None returns the method's subspace model.
    detrend : {"mean", "linear", None}, optional
        The operating point removed before the method runs (:mod:`hdpbsid.data.detrend`):
        each channel's mean (default), its least-squares line in ``t``, or nothing (with
        a ``UserWarning`` when a channel's level outweighs its variation,
        ``|mean| > std``).  The levels removed are stored in the model (Notes).
    input_names : sequence of str, optional
        ``m`` distinct input names (default ``u1``, ``u2``, ...).
    output_names : sequence of str, optional
        ``l`` distinct output names (default ``y1``, ``y2``, ...).
    time_unit : str, optional
        The unit of ``t`` (default ``"s"``; the eigenvalues are in rad per it).
    delay : float, sequence of float or "auto", optional
        Known dead time of the inputs (one, or one per input; a multiple of the sampling
        interval), ``"auto"`` to estimate it, or None (default) for none (Notes; one
        uniformly sampled record).
    **options
        Passed to the method unchanged (e.g. ``p=``, ``f=``, ``regularize=`` for
        ``"dt"``); with ``"auto"`` to every method tried, besides ``methods=``,
        ``max_order=``, ``n_jobs=`` and ``method_options=`` of
        :func:`~hdpbsid.selection.auto.identify_auto`.  Read here: ``feedthrough=``
        (``"auto"``, the default, ``True`` or ``False``; Notes), ``order_rule=`` (``"held-out"``
        or ``"svd"``), ``long_record=`` (a
        :class:`~hdpbsid.selection.long_records.LongRecordPolicy`, or False: off),
        ``progress=`` (progress bars on the long-record path), ``focus=``
        (``"auto"``, the default, ``"prediction"`` or ``"simulation"``: the plant by its
        simulation error, open loop; Notes), ``max_delay=`` and
        ``delay_hold=`` (``"zoh"``, ``"foh"`` or ``"bandlimited"``, with
        ``delay="auto"``).

    Returns
    -------
    StateSpaceModel
        The continuous-time model with its operating point (``u0``, ``y0``, ``trend``),
        labels, ``sampling_interval`` (the median step of the record(s)) and ``delay``;
        ``model.report`` (:class:`~hdpbsid.models.report.IdentificationReport`) says,
        typed, what was decided and why (the method, the order, the input hold, the direct
        term, the selection's candidates, the refinement and whether it was kept, the
        seconds of the stages); ``model.options`` holds every setting the method used
        plus ``"method"``, ``"refine"``, ``"detrend"``, ``"operating_points"`` and
        ``"requested_options"`` (the keyword arguments as passed here).

    Raises
    ------
    ValueError
        For an unknown method (listing the known ones), ``refine``, ``detrend``,
        ``order_rule`` or ``delay``; bad data (empty, non-finite, constant output,
        mismatched lengths or channels); a list of records with ``u``/``y`` given or with
        ``refine="pem"``; a single record without ``y``; a delay that is not whole
        samples or leaves too little of the record; and whatever the method raises.
    TypeError
        For a record that is not a ``(t, u, y)`` triple, data of the wrong type, or a
        method that does not return a :class:`~hdpbsid.StateSpaceModel`.

    Notes
    -----
    *Order.*  ``order=None``: orders ``1..max_order`` (default 8) are identified on the
    first two thirds of the record and scored by their windowed one-step prediction
    error on the last third (the better of the predictors with the model's ``K`` and
    with ``K = 0``, i.e. the simulation error; the prediction error is consistent in
    closed loop); the smallest order within one standard error of the best is
    identified on the whole record, the scores in ``options["order_selection"]``.  With
    one method given, a record too short to score, a list of records and
    ``order_rule="svd"`` use the method's singular-value rule instead; with the method
    not given, a short record compares the orders its last third can score (four
    windows of three samples per state), and an order given that it cannot score is
    answered by the first method that reaches it, not compared (a
    ``SelectionWarning``).  A constant input column raises a
    ``UserWarning`` (not persistently exciting).

    *Operating point.*  The levels removed are stored in the model (``model.u0``,
    ``model.y0``; ``model.trend`` for ``"linear"``), so
    :meth:`~hdpbsid.StateSpaceModel.simulate`, ``fit``, ``predict`` and ``compare`` map
    absolute signals to absolute signals; the matrices (and ``to_scipy``,
    ``to_control``) describe deviations.  With several records the model holds the
    sample-weighted mean level ``sum N_i x0_i / sum N_i`` (and no trend); each record's
    own levels are in ``model.options["operating_points"]``.  Removing the means makes
    the estimate invariant to constant shifts of the data; the price is an O(1/T) level
    error on records that start at rest.

    *Refinement.*  The subspace model is the start, the prediction-error model the
    answer: efficient in open loop, consistent in closed loop where the basis-domain
    least squares is biased, and it matters most at low SNR, where the subspace estimate
    is biased by the noise and the prediction-error minimum is not (Ljung 1999,
    ch. 8-9).  A chi-square feedback test of the first-pass residuals against the
    prewhitened input is reported with the rule in ``options["refine_rule"]`` and
    ``options["refine_statistics"]``, the seconds in ``options["refine_time"]``.  A
    refinement that grows a mode the record does not ask for is dropped (the rule says
    so).  One its evaluation budget cuts off before it converges is kept only when the
    record resolves it as better than its start, its windowed one-step prediction and
    simulation errors both lower by more than one standard error
    (:mod:`hdpbsid.selection.iterate`; the report then says it did not converge): the
    estimate is consistent at a minimum of the cost, an iterate on its way is not, yet a
    descent that has already left the subspace estimate far behind is the better model
    of the record.  ``D`` is a parameter only with
    ``feedthrough=True`` (a free ``D`` lets closed-loop data predict the noise through
    the controller).

    *Focus.*  The refinement fits the innovation model by its one-step prediction error
    (``focus="prediction"``: maximum likelihood when the disturbance has the innovation
    form, consistent in closed loop).  ``focus="simulation"`` fits the plant by its
    simulation error instead (``K = 0``), then ``K`` with the plant held
    (:func:`hdpbsid.refine.pem.refine_pem`): in open loop that plant is consistent
    whatever the disturbance, and on a process with a nonlinear distortion it is the
    best linear approximation, the linear model that simulates the record best, where
    the prediction-error plant is pulled towards what predicts one step ahead (a
    resonance too sharp, for one).  Biased in closed loop (a ``UserWarning`` when the
    feedback test finds feedback).  ``focus="auto"`` (the default) refines with the
    prediction focus and, on an open-loop record whose noise model predicts more than
    the simulation does, fits the output-error plant from it (or from the refinement's
    start, whichever simulates the record better); that plant replaces it only when it
    simulates the record better, after Akaike's correction for the fit's own optimism,
    by more than one standard error of the windowed simulation errors, a difference the
    innovation form cannot explain
    (:mod:`hdpbsid.selection.focus`; the choice in ``model.report.focus``).  The order
    and method are chosen as with the prediction focus.

    *Direct term.*  ``feedthrough="auto"`` (the default) decides ``D`` from the data
    (:mod:`hdpbsid.selection.feedthrough`), judged like the order on the last third of
    the record: candidates with ``D`` are fitted only when the innovations of ``u`` and
    ``y`` are linked at lag 0, and ``D`` is estimated only when the best candidate with
    it is better by more than three standard errors of the paired difference on the
    one-step prediction error and two on the simulation error, no worse over the whole
    held-out simulation, in closed loop better than a controller reacting within the
    sample could make it (such a controller makes ``D`` unidentifiable; the bound is
    derived in :mod:`hdpbsid.selection.feedthrough`), and with a deterministic input
    (which cannot tell ``D`` from dynamics) when it halves the simulation error.  An
    input linear between samples links ``u_k`` to ``y_k`` as ``D`` does with a held
    input; when the refinement keeps the held input with a ``D`` decided so, the linear
    hold without ``D`` (the smaller of two nested structures) is fitted too and returned
    unless a likelihood-ratio test rejects it
    (:func:`hdpbsid.selection.direct_term.linear_hold_or_direct_term`;
    ``options["linear_hold_rule"]``).  Several
    records, non-uniform samples, ``order_rule="svd"`` and the long-record path keep
    ``D = 0``.
    What was decided and why: ``options["feedthrough_rule"]``.  ``True``/``False``
    estimate ``D`` or keep it at zero, as given.

    *Long records* (``method="auto"`` on more than 50 000 samples, or a
    ``ChunkedRecord``) take a bounded path (:mod:`hdpbsid.selection.long_records`):
    methods and orders chosen on a segment, the chosen one fitted on the whole record,
    refined on a bounded part.

    *Dead time.*  ``delay="auto"`` estimates it
    (:func:`hdpbsid.frequency.delay.estimate_delay`: the Welch frequency response
    searched on the grid of whole samples with discrete-time models of the sampled
    record, the input held between samples unless ``delay_hold="foh"`` (or the method's
    ``input_hold``) says it is linear between them, or ``"bandlimited"`` that it has no
    power near the Nyquist frequency); ``order`` when given is the order of the dynamics
    it is estimated against, otherwise order and delay are chosen together by Schwarz's
    criterion.  Each input is shifted by its delay in whole samples and the first
    ``max(delay)`` samples of ``y`` are dropped (no input is invented before the
    record); the model gets ``model.delay``, ``options["delay"]`` says how it was found.
    None stays the default because a search on a record without a dead time can still
    return one sample (the estimate's resolution).

    References
    ----------
    .. [1] L. Ljung, *System Identification: Theory for the User*, 2nd ed.,
       Prentice Hall, 1999.
    .. [2] A. Chiuso, "The role of vector autoregressive modeling in predictor-based
       subspace identification", *Automatica* 43(6), 1034-1048, 2007.

    Examples
    --------
    A lightly damped second-order system (eigenvalues ``-0.4 +- 1.9596j``) under a
    random-step input held between samples:

    >>> import numpy as np
    >>> from hdpbsid.systems.linear import random_steps, second_order, simulate_zoh
    >>> A, B, C, D = second_order()
    >>> t = np.arange(0.0, 60.0, 0.05)
    >>> u = random_steps(np.random.default_rng(0), t, hold=0.5)
    >>> y = simulate_zoh(A, B, C, D, t, u)

    >>> model = identify(t, u, y, order=2, method="dt", refine=None)
    >>> np.sort_complex(model.eigenvalues).round(2)
    array([-0.4-1.96j, -0.4+1.96j])
    >>> model.report.order
    Choice(value=2, reason='given')
    """
    t = _listed(t, u, y)
    if delay is not None:
        return _identify_delayed(
            t, u, y, order, method, refine, detrend, delay,
            input_names=input_names, output_names=output_names, time_unit=time_unit,
            **options,
        )  # fmt: skip
    # 1. check the inputs: identify's own settings, the labels, the path
    req = _request(method, order, refine, detrend, options)
    in_memory = isinstance(t, np.ndarray | list | tuple)
    labels = _Labels(input_names, output_names, time_unit, t, u, y) if in_memory else None
    if scaling.is_long(t, u, y, method, req.long_record):
        return _identify_long(t, u, y, req, labels, options)  # bounded work
    func = get_method(method)
    require_joblib(options.get("n_jobs"))
    assert labels is not None  # only the bounded path takes a chunked record
    _warn_not_exciting(u if not isinstance(t, list | tuple) else None)
    # 2. the record(s) scaled and detrended, the method run (several: as one Dataset)
    several = _is_several(t)
    if req.focus == "simulation" and (several or not is_uniform(check_time(t, "t"))):
        raise ValueError(f"focus={req.focus!r} needs a single uniformly sampled record")
    signal_scale = _Scaling(t, u, y, several)
    t, u, y = signal_scale.apply(t, u, y)
    t_method = time.perf_counter()
    first_pass = _first_pass_records if several else _first_pass_record
    first = first_pass(func, t, u, y, req, options, labels.as_labels())
    # 3. refine; 4. report: the operating point, the units, the labels, the settings
    model = _refine_step(first, req, several, t_method)
    records = t if several else [(t, u, y)]
    return _finished(model, first, signal_scale, labels, records, req, options)


def _identify_delayed(
    t: Any,
    u: Any,
    y: Any,
    order: Any,
    method: str,
    refine: Any,
    detrend: Any,
    delay: Any,
    **options: Any,
) -> StateSpaceModel:
    """:func:`identify` with ``delay`` given or ``"auto"`` (its docstring): the inputs
    shifted by whole samples, the model told its dead times."""
    from hdpbsid.data.checks import check_uniform

    if isinstance(t, list | tuple) and len(t) and isinstance(t[0], list | tuple):
        raise ValueError("delay needs a single record, not a list of records")
    if u is None:
        raise ValueError("delay needs an input u (a dead time delays the inputs)")
    tt, ua, yy = check_data(t, u, y)
    dt = check_uniform(tt)
    max_delay = options.pop("max_delay", None)
    if isinstance(delay, str):
        steps, info = _estimated_delay(delay, tt, ua, yy, order, max_delay, options)
    else:
        steps, info = _given_delay(delay, ua.shape[1], dt)
    if np.any(steps >= tt.size // 2):
        raise ValueError(f"delay of {steps.tolist()} samples leaves too little of the record")
    # y from sample dmax on against each input dmax - d_j samples earlier: no input is
    # invented before the record, the method estimates the state at t[dmax]
    dmax, ns = int(np.max(steps)), tt.size
    shifted = np.column_stack([ua[dmax - d : ns - d, j] for j, d in enumerate(steps)])
    model = identify(tt[dmax:], shifted, yy[dmax:], order, method, refine, detrend, **options)
    model.delay = steps * dt
    info["samples"] = steps.tolist()
    model.options["delay"] = info
    return model


def _given_delay(delay: Any, m: int, dt: float) -> tuple[Any, dict[str, Any]]:
    """A known dead time (one, or one per input) in whole samples of ``dt``."""
    from hdpbsid.models.dead_time import check_delay

    tau = check_delay(delay, m)
    steps = np.round(tau / dt).astype(np.intp)
    # the rounding of a delay computed in floating point (k * dt), far below a sample
    if np.any(np.abs(tau / dt - steps) > 1e-6):
        raise ValueError(
            f"delay must be a multiple of the sampling interval {dt:g} (whole samples), "
            f"got {tau.tolist()}; a fractional part is left to the model's dynamics"
        )
    return steps, {"rule": "given"}


def _delay_hold(delay: str, options: dict[str, Any]) -> str:
    """The input hold the delay search assumes: ``delay_hold=`` (taken out of ``options``),
    else the method's ``input_hold``, else ``"zoh"``."""
    if delay != "auto":
        raise ValueError(f"delay must be None, 'auto', a number or one per input, got {delay!r}")
    hold = options.pop("delay_hold", None) or options.get("input_hold")
    if hold not in ("zoh", "foh", "bandlimited"):
        if hold not in (None, "auto"):
            raise ValueError(f"delay_hold must be 'zoh', 'foh' or 'bandlimited', got {hold!r}")
        hold = "zoh"
    return hold


def _estimated_delay(
    delay: str, tt: Any, ua: Any, yy: Any, order: Any, max_delay: Any, options: dict[str, Any]
) -> tuple[Any, dict[str, Any]]:
    """``delay="auto"``: the dead time in whole samples estimated from the record
    (:func:`hdpbsid.frequency.delay.estimate_delay`) and how it was found."""
    from hdpbsid.frequency.delay import estimate_delay

    hold = _delay_hold(delay, options)
    if not isinstance(order, int):
        warnings.warn(
            "delay='auto' without an order: the delay and the order of the dynamics are "
            "chosen together (Schwarz's criterion), and on short or noisy records an "
            "extra mode can take the place of a sample of delay; pass order= when known",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
    est = estimate_delay(
        tt, ua, yy, max_delay, order=order if isinstance(order, int) else None,
        hold=None if hold == "bandlimited" else hold,
    )  # fmt: skip
    info: dict[str, Any] = {
        "rule": "auto: Welch FRF, discrete-time fits profiled over whole samples "
        "(hdpbsid.frequency.delay.estimate_delay)",
        "hold": hold,
        "estimate": est.delay.tolist(),
        "order": est.order.tolist(),
    }
    return est.samples, info


def _refined(
    model: StateSpaceModel,
    refine: Any,
    several: bool,
    t: Any,
    u: Any,
    y: Any,
    judged: bool = False,
    focus: str = "auto",
) -> tuple[StateSpaceModel, str]:
    """The refinement ``refine`` of :func:`identify` (its docstring) of ``model`` on the
    record ``(t, u, y)``: the model returned and the rule that decided it; ``judged``:
    ``feedthrough="auto"`` decided the direct term (:func:`_hold_or_direct_term`);
    ``focus``: :func:`identify`'s (:func:`_focused`)."""
    rule = "pem: asked for"
    if focus == "simulation":
        return _simulation_refined(model, t, u, y, refine)
    if refine == "pem":
        refined = refine_pem(model, t, u, y, warm_start=model.report.warm_start)
        kept = _hold_or_direct_term(model, refined, t, u, y, judged)
        return _focused(kept, focus, (t, u, y), None, model), rule
    if refine != "auto":
        return model, rule
    if several:
        do, rule, stats, start = False, "auto: several records, no refinement", None, model
    else:
        uniform = is_uniform(check_time(t, "t", min_samples=2))
        errors = _one_step_errors(model, t, u, y) if uniform else None
        do, rule, stats, start = refine_plan(model, t, u, y, uniform, errors=errors)
    if do:
        model = start  # in closed loop, offering the refinement a consistent start
        refined = refine_pem(model, t, u, y, warm_start=model.report.warm_start)
        refined, note = retried(model, refined, t, u, y, stats)
        rule += note
        refined, note = continued(refined, t, u, y)
        rule += note
        from hdpbsid.selection.restarts import restarted

        refined, note = restarted(model, refined, t, u, y, bool((stats or {}).get("feedback")))
        rule += note
        unsound = _refinement_problem(model, refined, t, u, y)
        if unsound:
            rule += f"; the refined model is not kept: {unsound}"
        elif (iterate := keep_iterate(model, refined, t, u, y)).value:
            if iterate.rule is not IterateRule.CONVERGED:
                rule += f"; the refinement {iterate.reason}"
            kept = _hold_or_direct_term(model, refined, t, u, y, judged)
            model = _focused(kept, focus, (t, u, y), stats, model)
        else:
            # an iterate cut off by the evaluation budget that the record does not
            # resolve from its start (hdpbsid.selection.iterate): keep the start
            rule += f"; the refinement {iterate.reason}: the unrefined model is kept"

    model.options["refine_rule"] = rule
    model.options["refine_statistics"] = stats
    return model, rule


def _focused(
    model: StateSpaceModel, focus: str, rec: tuple, stats: dict | None, start: StateSpaceModel
) -> StateSpaceModel:
    """The prediction-error refinement ``model`` on ``rec``, or with ``focus="auto"`` the
    output-error plant fitted from it or from its ``start`` when the record shows the
    innovation form does not hold (:func:`hdpbsid.selection.focus.choose_focus`;
    ``stats``: the feedback test's, run here when None); the choice in
    ``model.report.focus``."""
    if focus != "auto":
        model.report = model.report.but(focus=given(focus))
        return model
    if stats is None:
        _, _, stats = refine_decision(model, *rec, True)
    return choose_focus(model, *rec, bool((stats or {}).get("feedback")), start)[0]


def _simulation_refined(
    model: StateSpaceModel, t: Any, u: Any, y: Any, refine: Any
) -> tuple[StateSpaceModel, str]:
    """``focus="simulation"``: the output-error plant and then ``K``
    (:func:`~hdpbsid.refine.pem.refine_pem`), on a single uniformly sampled record
    (checked by :func:`identify` before the method runs);
    a ``UserWarning`` when the feedback test finds the record closed loop (there the
    output-error plant is biased)."""
    errors = _one_step_errors(model, t, u, y)
    # the feedback test only: the closed-loop start of refine_plan is not used here
    _, _, stats = refine_decision(model, t, u, y, True, errors=errors)
    rule = f"{'pem' if refine == 'pem' else 'auto'}: focus='simulation', the output-error plant"
    if warn_if_closed_loop("simulation", stats):
        rule += " (closed loop: biased)"
    refined = refine_pem(model, t, u, y, focus="simulation")
    if refined is not model and not refined.report.converged:
        # as with the default focus (hdpbsid.selection.iterate), by the simulation error
        iterate = keep_iterate(model, refined, t, u, y, focus="simulation")
        rule += f"; the refinement {iterate.reason}"
        if not iterate.value:
            rule += ": the unrefined model is kept"
            refined = model
    refined.options["refine_rule"] = rule
    refined.options["refine_statistics"] = stats
    refined.report = refined.report.but(focus=given("simulation"))
    return refined, rule


def _hold_or_direct_term(
    start: StateSpaceModel, refined: StateSpaceModel, t: Any, u: Any, y: Any, judged: bool
) -> StateSpaceModel:
    """``refined``, or the same dynamics with the input linear between samples and no
    direct term when that explains the record as well
    (:func:`hdpbsid.selection.direct_term.linear_hold_or_direct_term`: a ``D`` that
    ``feedthrough="auto"`` decided, ``judged``, before the hold was chosen); the test's
    outcome in ``options["linear_hold_rule"]``."""
    from hdpbsid.selection.direct_term import linear_hold_or_direct_term

    model, text = linear_hold_or_direct_term(start, refined, t, u, y, judged)
    if text:
        model.options["linear_hold_rule"] = text
    return model


def _decided(
    model: StateSpaceModel,
    order: Any,
    method: str,
    decision: Choice[bool] | None,
    timings: dict[str, float],
) -> Any:
    """``model.report`` completed with what :func:`identify` decided itself: the method
    asked for when the model's does not say, how the order was chosen, whether the model
    returned is the refinement and why (``decision``), and the seconds of the stages
    (``timings``)."""
    report = model.report
    if isinstance(order, int):
        how = "given"
    elif report.candidates:
        how = "held-out selection (report.selection_rule)"
    else:
        how = "the method's rule (singular values)"
    return report.but(
        method=report.method if report.method is not None else method,
        order=Choice(model.n, how),
        refine_decision=decision,
        timings={**report.timings, **timings},
    )


def _refinement_problem(
    start: StateSpaceModel, refined: StateSpaceModel, t: Any, u: Any, y: Any
) -> str:
    """Why the prediction-error refinement ``refined`` of ``start`` on ``(t, u, y)`` is
    not kept, or ``""``: it grew a mode the record does not ask for
    (:func:`hdpbsid.selection.auto.refinement_instability`: a time series' model not
    stationary, or an unstable model that simulates the record no better than its stable
    start).  The prediction-error criterion judges the predictor ``A - K C``, stable
    either way, so by itself it does not keep ``A`` stable."""
    from hdpbsid.selection.auto import refinement_instability

    return refinement_instability(start, refined, (t, u, y))


def _warn_if_fallback(model: StateSpaceModel, selected: StateSpaceModel) -> None:
    """A :class:`~hdpbsid.selection.auto.SelectionWarning` when the held-out selection
    returned the candidate fitted on part of the record (``selected``) and no refinement
    on the whole record replaced it (``model`` carries the same refinement as
    ``selected``, or none): a decision for the user (a longer record, or the method's
    settings given)."""
    from hdpbsid.selection.auto import SelectionWarning

    fallback = model.report.selection_fallback
    done = model.report.refinement
    if fallback and done is not None and done is not selected.report.refinement:
        text = (
            "the held-out selection's candidate, fitted on the estimation part (its refit "
            "on the whole record did not hold), started the refinement on the whole record"
        )
        model.options["selection_fallback"] = text
        model.report = model.report.but(selection_fallback=text)
    elif fallback:
        model.report = model.report.warned(fallback)
        warnings.warn(fallback, SelectionWarning, stacklevel=user_stacklevel())


def _one_step_errors(model: StateSpaceModel, t: Any, u: Any, y: Any) -> Any:
    """The model's one-step prediction errors on a uniformly sampled record for the
    feedback test, by the refinement's compiled predictor
    (:func:`~hdpbsid.refine.pem.one_step_errors`: the numbers of ``model.predict``,
    10^4 samples 0.6 instead of 4.4 ms), with the model's input hold; None when its
    sampled predictor is unstable (the test then takes ``predict``'s, whose overflow
    it reports)."""
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            return one_step_errors(model, t, u, y)
    except (np.linalg.LinAlgError, ValueError):
        return None  # the test falls back to predict, whose failure it reports


def _run(
    method: str,
    func: IdentifyFunc,
    record: tuple[Any, Any, Any],
    order: Any,
    options: dict,
    refined: bool = False,
    judge_feedthrough: bool = False,
    describe: Callable[[Dataset], Dataset] | None = None,
) -> StateSpaceModel:
    """Run ``method`` on one record ``record = (t, u, y)``: the held-out selections split
    its arrays (their candidates score on the stamps as given), the method itself runs on
    the :class:`~hdpbsid.data.records.Dataset` made of it here
    (:func:`~hdpbsid.methods.registry.call_method`).  ``order=None`` goes through the
    held-out order choice
    (:func:`hdpbsid.selection.auto.select_order`) unless ``order_rule="svd"``.  ``refined``:
    the result will be refined, so the held-out choice is told (it then decides close
    orders between refined candidates, :func:`hdpbsid.selection.auto.rejudge_refined`).
    ``judge_feedthrough`` (``feedthrough="auto"``): the held-out choice judges the direct
    term with the order (:mod:`hdpbsid.selection.feedthrough`); with the method and the
    order given, :func:`hdpbsid.selection.auto.decide_feedthrough` judges it alone.
    ``describe`` gives the Dataset made of ``record`` the front door's labels and the
    operating point detrending removed (:meth:`~hdpbsid.data.records.Dataset.described`)."""
    rule = options.pop("order_rule", "held-out")
    if rule not in ("held-out", "svd"):
        raise ValueError(f"order_rule must be 'held-out' or 'svd', got {rule!r}")
    given = options.pop("feedthrough", None)
    ft: dict[str, Any] = {"feedthrough": given} if given is not None else {}
    # the held-out selections judge the direct term themselves when asked to
    judged = {"feedthrough": "auto"} if judge_feedthrough else ft

    # the method runs on the Dataset of the record, made here (when it has a Dataset
    # function: call_method); the held-out selections cut the arrays themselves
    def data() -> Dataset:
        made = Dataset.of(*record)
        return made if describe is None else describe(made)

    if order is None and method != "auto" and rule == "held-out":
        from hdpbsid.selection.auto import select_order

        model = select_order(method, *record, refined=refined, **judged, **options)
        return _d_asked(model, judged)
    if method == "auto":
        model = call_method(func, record, data, order=order, refined=refined, **judged, **options)
        return _d_asked(model, judged)
    why = ""
    if judge_feedthrough and order is None:
        why = "auto: not judged (order_rule='svd' chooses the order on the whole record); D = 0"
    elif judge_feedthrough:
        from hdpbsid.selection.auto import decide_feedthrough

        has_d, why = decide_feedthrough(method, *record, order, options)
        ft = {"feedthrough": True} if has_d else {}
    model = call_method(func, record, data, order=order, **ft, **options)
    if why and isinstance(model, StateSpaceModel):
        model.options["feedthrough_rule"] = why
    return _d_asked(model, ft)


def _d_asked(model: Any, settings: dict[str, Any]) -> Any:
    """``model``, marked as fitted with ``D`` asked for when ``settings`` ask for it: a
    parameter of the refinement, whatever its method's own ``D`` (:func:`with_d_asked`)."""
    return with_d_asked(model) if settings.get("feedthrough") is True else model
