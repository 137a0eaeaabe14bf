"""``hdpbsid.identify``: one entry point for every identification method.

``m = hdpbsid.identify(t, u, y, order=4, method="hermite")`` with ``method`` one of
``"hermite"``, ``"laguerre"``, ``"legendre"``, ``"dt"``, ... (docs/user-guide.md): the
record is checked, scaled and detrended here, the method is taken from the registry
(:mod:`hdpbsid.methods.registry`, which imports each method on first use), and the
model refined and given its operating point.
"""

from __future__ import annotations

import time
import warnings
from typing import Any

import numpy as np

from hdpbsid.data.checks import (
    check_data,
    check_label,
    check_names,
    check_time,
    check_varies,
    is_uniform,
    require_joblib,
    scale_exponents,
)
from hdpbsid.data.detrend import DETREND_CHOICES, Levels, detrend_record, warn_if_levels_dominate
from hdpbsid.data.records import Dataset
from hdpbsid.methods.registry import (
    IdentifyFunc,
    get_method,
)
from hdpbsid.models.model import LinearTrend, StateSpaceModel, _set_levels, scale_signals
from hdpbsid.models.report import Choice
from hdpbsid.refine.pem import (
    REFINE_CHOICES,
    one_step_errors,
    refine_pem,
)
from hdpbsid.runtime import library_call, user_stacklevel
from hdpbsid.selection import long_records as scaling
from hdpbsid.selection.feedback import refine_plan
from hdpbsid.selection.feedthrough import check_feedthrough

__all__ = ["identify"]


def _check_records(records: Any) -> list[tuple[Any, Any, Any]]:
    """The list form ``[(t1, u1, y1), ...]``: every record checked, channel counts equal."""
    if len(records) == 0:
        raise ValueError("t: the list of records is empty; pass at least one (t, u, y)")
    out = []
    for i, rec in enumerate(records):
        if not isinstance(rec, tuple | list) or len(rec) != 3:
            raise TypeError(f"t[{i}] must be a (t, u, y) tuple, got {type(rec).__name__}")
        try:
            tt, uu, yy = check_data(*rec)
            check_varies(yy)
        except (ValueError, TypeError) as exc:
            raise type(exc)(f"record {i}: {exc}") from exc
        out.append((tt, None if rec[1] is None else uu, yy))
        m0, l0 = check_data(*out[0])[1].shape[1], out[0][2].shape[1]
        if uu.shape[1] != m0 or yy.shape[1] != l0:
            raise ValueError(
                f"record {i} has {uu.shape[1]} input(s) and {yy.shape[1]} output(s); "
                f"record 0 has {m0} and {l0}: every record needs the same channels"
            )
    return out


def _listed(t: Any, u: Any, y: Any) -> Any:
    """``t``, or the list form of a :class:`~hdpbsid.data.records.Dataset` given as ``t``
    (its records, checked again with the list form's messages)."""
    if not isinstance(t, Dataset):
        return t
    if u is not None or y is not None:
        raise ValueError("with a Dataset in t, leave u and y out (u=None, y=None)")
    return list(t)


def _weighted_levels(levels: list[Levels]) -> tuple[Any, Any]:
    """Sample-weighted mean operating point ``sum N_i x0_i / sum N_i``."""
    w = np.array([lv.samples for lv in levels], dtype=float)
    u0 = np.sum([wi * lv.u0 for wi, lv in zip(w, levels, strict=True)], axis=0) / w.sum()
    y0 = np.sum([wi * lv.y0 for wi, lv in zip(w, levels, strict=True)], axis=0) / w.sum()
    return u0, y0


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

    ``t (Ns,)``, ``u (Ns, m)`` (or ``None`` for no input), ``y (Ns, l)`` follow
    :func:`scipy.signal.lsim` (1-D for one channel).  Several experiments of the same
    system: ``identify([(t1, u1, y1), (t2, u2, y2), ...], order=...)`` (``u``, ``y``
    left out), or ``identify(dataset)`` with a :class:`~hdpbsid.data.records.Dataset`;
    every record is detrended on its own, and the method is given them as one
    :class:`~hdpbsid.data.records.Dataset`, checked once here.  ``method`` names an entry
    of :data:`METHODS`: ``"auto"`` (the default) tries
    ``hermite``, ``laguerre``, ``legendre`` and ``dt`` and keeps the best by held-out
    prediction error (:func:`hdpbsid.selection.auto.identify_auto`; with several records the
    last one is held out); ``"hermite"`` is HD-PBSID as the thesis describes it;
    ``"laguerre"``, ``"legendre"``, ``"dt"``, ... (see :func:`available_methods`).
    ``options`` go to the method unchanged (e.g. ``p=``, ``f=``, ``regularize=`` for
    ``"dt"``); with ``"auto"`` they go to every method tried (e.g. ``feedthrough=True``),
    besides ``methods=``, ``max_order=``, ``n_jobs=`` (the methods swept in parallel) and
    ``method_options=`` (per method) of :func:`~hdpbsid.selection.auto.identify_auto`.

    ``order=None`` chooses the order from the identified *models*
    (:func:`hdpbsid.selection.auto.select_order`): orders ``1..max_order`` (default 8) are
    identified on the first two thirds of the record and scored by their windowed
    one-step prediction error on the last third (the better of the predictors with the
    model's ``K`` and with ``K = 0``, i.e. the simulation error; the prediction error is
    consistent in closed loop); the smallest order within one standard error of the
    best is identified on the whole record, and the scores are in
    ``options["order_selection"]``.  A record too short to score, a list of records and
    ``order_rule="svd"`` use the method's singular-value rule instead (said in
    ``options["order_selection"]``).  A constant input column raises a ``UserWarning``
    (not persistently exciting).

    ``detrend`` sets the operating point (:mod:`hdpbsid.data.detrend`): ``"mean"`` (default)
    removes each channel's mean before the method runs, ``"linear"`` its least-squares
    line in ``t``, ``None`` nothing (with a ``UserWarning`` when a channel's level
    outweighs its variation, ``|mean| > std``).  The removed levels are stored in the
    model (``model.u0``, ``model.y0``; ``model.trend`` for ``"linear"``), so
    :meth:`~hdpbsid.StateSpaceModel.simulate`, ``fit``, ``predict`` and ``compare`` map
    absolute signals to absolute signals; the matrices (and ``to_scipy``,
    ``to_control``) describe deviations.  With several records the model holds the
    sample-weighted mean level ``sum N_i x0_i / sum N_i`` (and no trend); each record's
    own levels are in ``model.options["operating_points"]``.  Removing the means makes
    the estimate invariant to constant shifts of the data; the price is an O(1/T) level
    error on records that start at rest (see :mod:`hdpbsid.data.detrend`).

    ``refine="pem"`` follows the method with a prediction-error fit started from its
    model (:func:`hdpbsid.refine.pem.refine_pem`: efficient, consistent in closed loop,
    reports ``options["eigenvalue_std"]``; needs uniformly sampled ``t``, about 0.1 s
    on 7500 samples; one record only); ``None`` returns the subspace model as the method
    produced it; ``"auto"`` (default) refines every single uniformly sampled record
    whose first-pass one-step predictor does not diverge
    (:func:`hdpbsid.selection.feedback.refine_plan`): the subspace model is the start, the
    prediction-error model the answer (efficient in open loop, consistent in closed loop
    where the basis-domain least squares is biased).  A chi-square feedback test of the
    first-pass residuals against the prewhitened input is reported with the rule in
    ``options["refine_rule"]`` and ``options["refine_statistics"]``, the seconds the
    decision and the refinement took in ``options["refine_time"]``.  A refinement
    that does not converge within its evaluation budget is dropped (the unrefined model
    is returned, the rule says so): the prediction-error estimate is consistent at a
    minimum of the cost, and an iterate cut off on its way is neither that nor the
    subspace estimate.  Convergence is judged at the statistical resolution (a run that
    moves the estimate by less than a tenth of its standard deviation ends the fit), and
    ``D`` is a parameter only with ``feedthrough=True`` (a free ``D`` lets closed-loop
    data predict the noise through the controller): started from the HD-PBSID, Legendre
    and CT-PBSID models of a closed loop, the fit reaches the same optimum.  The
    refinement matters most at low SNR, where the subspace estimate is biased by the
    noise and the prediction-error minimum is not (Ljung,
    *System Identification*, 2nd ed., ch. 8-9); the measured effect is in the
    benchmark pages (``hdpbsid study table1``).

    ``feedthrough`` (a keyword among ``options``): not given (the default), ``D = 0``
    for every method that has the setting (not yet ``"auto"``: on closed-loop records
    at high SNR the rule below still admits a small ``D`` that compensates model
    error); ``"auto"`` decides the direct term ``D`` from the data
    (:mod:`hdpbsid.selection.feedthrough`), judged like the order on the last third
    of the record: the best candidates with and without
    ``D`` (each by the one-standard-error rule among its own orders and methods; with
    the method and the order given, the two candidates of that order,
    :func:`hdpbsid.selection.auto.decide_feedthrough`) are compared, and ``D`` is
    estimated only when it is better by more than three standard errors of the paired
    difference on the one-step prediction error and two on the simulation error, no
    worse over the whole held-out simulation, and in closed loop when it lowers the
    simulation error by more than a controller reacting within the sample could (such
    a controller makes ``D`` unidentifiable, and no test on ``u`` and ``y`` tells its
    path from a direct term; the bound is derived in
    :mod:`hdpbsid.selection.feedthrough`, :func:`hdpbsid.selection.feedthrough.
    judge_direct_term`).  Where that bound leaves no room (weak feedback, a white
    input) ``D = 0``, and ``feedthrough=True`` says the loop has at least one sample
    of delay.  Several records, non-uniform samples, ``order_rule="svd"`` and the
    long-record path keep ``D = 0``.  What was decided and why: ``options["feedthrough_rule"]``.
    ``True``/``False`` estimate ``D`` or keep it at zero, as given.

    Long records (``method="auto"`` on more than 50 000 samples, or a
    :class:`~hdpbsid.data.chunked.ChunkedRecord` in ``t``) take a bounded path
    (:mod:`hdpbsid.selection.long_records`): methods and orders chosen on a segment, the chosen one
    fitted on the whole record, refined on a bounded part; ``long_record=`` a
    :class:`~hdpbsid.selection.long_records.LongRecordPolicy` (or False: off),
    ``progress=True`` shows progress bars.

    ``input_names``, ``output_names`` (``m`` and ``l`` distinct strings; default ``u1``,
    ... and ``y1``, ...) and ``time_unit`` (the unit of ``t``, default ``"s"``; the
    eigenvalues are in rad per it) label the model (:meth:`~hdpbsid.StateSpaceModel.
    set_labels`): plots, ``to_control`` and the saved file carry them, and
    ``model.sampling_interval`` records the median step of the record(s) so that
    ``compare`` can warn about a record on another time scale.

    ``delay`` (one uniformly sampled record): ``None`` (default) identifies without a
    dead time, as before; a number (or one per input), a multiple of the sampling
    interval, is a known dead time; ``"auto"`` estimates it
    (:func:`hdpbsid.frequency.delay.estimate_delay`, the Welch frequency response searched on the
    grid of whole samples with discrete-time models of the sampled record, the input
    held between samples unless ``delay_hold="foh"`` (or the method's ``input_hold``)
    says it is linear between them, or ``delay_hold="bandlimited"`` that the input has no
    power near the Nyquist frequency (a multisine: the response is then ``G(jw)``, fitted
    by continuous-time models); ``order`` when given is
    the order of the dynamics it is estimated against, otherwise order and delay are
    chosen together by Schwarz's criterion; ``max_delay=`` bounds the search).  Each
    input is shifted by its delay in whole samples and the first ``max(delay)`` samples
    of ``y`` are dropped (no input is invented before the record), the method runs on
    the shifted record, and the model gets ``model.delay``; ``options["delay"]`` says how
    it was found.  ``None`` stays the default because a search on a record without a
    dead time can still return one sample (the estimate's resolution), which would
    change models that are right as they are.

    The returned model's ``options`` hold every setting the method used plus
    ``"method"``, ``"refine"``, ``"detrend"`` and ``"requested_options"`` (the keyword
    arguments as passed here).  ``model.report``
    (:class:`~hdpbsid.models.report.IdentificationReport`) says, typed, what was decided
    and why: the method, the order, the input hold and the direct term with their
    reasons, the selection's candidates, the refinement and whether it was kept, the
    seconds of the stages.
    Raises ``ValueError`` for an unknown method (listing the known ones), an unknown
    ``detrend`` and bad data, and whatever the method raises.
    """
    t = _listed(t, u, y)
    if delay is not None:
        return _identify_delayed(
            t, u, y, order, method, refine, detrend, delay,
            input_names=input_names, output_names=output_names, time_unit=time_unit,
            **options,
        )  # fmt: skip
    if refine not in REFINE_CHOICES:
        raise ValueError(f"refine must be one of {REFINE_CHOICES}, got {refine!r}")
    if detrend not in DETREND_CHOICES:
        raise ValueError(f"detrend must be one of {DETREND_CHOICES}, got {detrend!r}")
    given_ft = options.pop("feedthrough", None)
    feedthrough = None if given_ft is None else check_feedthrough(given_ft)
    if feedthrough is not None and feedthrough != "auto":
        options["feedthrough"] = feedthrough
    long_record, progress = options.pop("long_record", None), options.pop("progress", False)
    in_memory = isinstance(t, np.ndarray | list | tuple)
    labels = _Labels(input_names, output_names, time_unit, t, u, y) if in_memory else None
    if scaling.is_long(
        t, u, y, method, long_record
    ):  # bounded work: hdpbsid.selection.long_records
        model = scaling.identify_long(t, u, y, order, refine, detrend, long_record=long_record,
                                      progress=progress, **options)  # fmt: skip
        if labels is not None:
            labels.apply(model, [(t, u, y)])
        model.report = _decided(model, order, method, model.report.refine_decision, {})
        return model
    func = get_method(method)
    require_joblib(options.get("n_jobs"))
    assert labels is not None  # only the bounded path takes a chunked record
    _warn_not_exciting(u if not isinstance(t, list | tuple) else None)
    several = isinstance(t, list | tuple) and (len(t) == 0 or isinstance(t[0], list | tuple))
    signal_scale = _Scaling(t, u, y, several)
    t, u, y = signal_scale.apply(t, u, y)
    t_method = time.perf_counter()
    if several:
        if u is not None or y is not None:
            raise ValueError(
                "with a list of (t, u, y) records in t, leave u and y out (u=None, y=None)"
            )
        if refine == "pem":
            raise ValueError("refine needs a single record; pass refine=None with a list")
        records, levels = [], []
        for i, (tt, uu, yy) in enumerate(_check_records(t)):
            ua = np.zeros((tt.size, 0)) if uu is None else uu
            ud, yd, lv = detrend_record(tt, ua, yy, detrend)
            if detrend is None:
                warn_if_levels_dominate(ua, yy, f"record {i}: ")
            records.append((tt, None if uu is None else ud, yd))
            levels.append(lv)
        options.pop("order_rule", None)
        tm = um = ym = None  # no single record to refine on
        # made once here: the method takes the records as they are (as_records)
        model = func(Dataset.of(records), None, None, order=order, **options)
        if feedthrough == "auto":
            model.options.setdefault("feedthrough_rule", "auto: several records, not judged; D = 0")
        if order is None:
            model.options["order_selection"] = "singular values of the method (several records)"
        u0, y0 = _weighted_levels(levels)
        trend = None
        op_info: Any = [lv.as_dict() for lv in levels]
    else:
        if y is None:
            raise ValueError("y is required: identify(t, u, y, ...) or a list of (t, u, y)")
        tt, ua, yy = check_data(t, u, y)
        check_varies(yy)
        ud, yd, lv = detrend_record(tt, ua, yy, detrend)
        if detrend is None:
            warn_if_levels_dominate(ua, yy)
            tm, um, ym = t, u, y  # unchanged: exactly what the method got before
        else:
            tm, um, ym = tt, None if u is None else ud, yd
        model = _run(
            method, func, tm, um, ym, order, options, refined=refine is not None,
            judge_feedthrough=feedthrough == "auto",
        )  # fmt: skip
        u0, y0 = lv.u0, lv.y0
        trend = None if lv.t_ref is None else LinearTrend(lv.t_ref, lv.u_slope, lv.y_slope)
        op_info = lv.as_dict()
    if not isinstance(model, StateSpaceModel):
        raise TypeError(
            f"method {method!r} returned {type(model).__name__}, expected StateSpaceModel"
        )
    t_refine = time.perf_counter()
    timings = {"method": t_refine - t_method}
    model, rule = _refined(model, refine, several, tm, um, ym)
    # a starting point offered to the refinement (method="auto"), not part of the result
    model.report = model.report.but(warm_start=None)
    if not several:
        _warn_if_fallback(model)
    if refine is not None:
        timings["refine"] = time.perf_counter() - t_refine
        model.options["refine_time"] = timings["refine"]
    decision = None if refine is None else Choice(model.report.refinement is not None, rule)
    model.report = _decided(model, order, method, decision, timings)
    _set_levels(model, u0, y0, trend)
    model, op_info = signal_scale.undo(model, op_info)
    labels.apply(model, t if several else [(t, u, y)])
    model.options.setdefault("refine", None)
    model.options.setdefault("method", method)
    model.options["detrend"] = detrend
    model.options["operating_points"] = op_info
    model.options["requested_method"] = method
    model.options["requested_order"] = order
    model.options["requested_options"] = dict(options)
    return model


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
    from hdpbsid.frequency.delay import estimate_delay
    from hdpbsid.models.dead_time import check_delay

    if isinstance(t, list | tuple) and len(t) and isinstance(t[0], list | tuple):
        raise ValueError("delay needs a single record, not a list of records")
    if u is None:
        raise ValueError("delay needs an input u (a dead time delays the inputs)")
    tt, ua, yy = check_data(t, u, y)
    dt = check_uniform(tt)
    max_delay = options.pop("max_delay", None)
    if isinstance(delay, str):
        if delay != "auto":
            raise ValueError(
                f"delay must be None, 'auto', a number or one per input, got {delay!r}"
            )
        hold = options.pop("delay_hold", None) or options.get("input_hold")
        if hold not in ("zoh", "foh", "bandlimited"):
            if hold not in (None, "auto"):
                raise ValueError(f"delay_hold must be 'zoh', 'foh' or 'bandlimited', got {hold!r}")
            hold = "zoh"
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
        steps = est.samples
        info: dict[str, Any] = {
            "rule": "auto: Welch FRF, discrete-time fits profiled over whole samples "
            "(hdpbsid.frequency.delay.estimate_delay)",
            "hold": hold,
            "estimate": est.delay.tolist(),
            "order": est.order.tolist(),
        }
    else:
        tau = check_delay(delay, ua.shape[1])
        steps = np.round(tau / dt).astype(np.intp)
        if np.any(np.abs(tau / dt - steps) > 1e-6):
            raise ValueError(
                f"delay must be a multiple of the sampling interval {dt:g} (whole samples), "
                f"got {tau.tolist()}; a fractional part is left to the model's dynamics"
            )
        info = {"rule": "given"}
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


def _refined(
    model: StateSpaceModel, refine: Any, several: bool, t: Any, u: Any, y: Any
) -> tuple[StateSpaceModel, str]:
    """The refinement ``refine`` of :func:`identify` (its docstring) of ``model`` on the
    record ``(t, u, y)``: the model returned and the rule that decided it."""
    rule = "pem: asked for"
    if refine == "pem":
        return refine_pem(model, t, u, y, warm_start=model.report.warm_start), rule
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
        unsound = _refinement_problem(model, refined, t, u, y)
        if unsound:
            rule += f"; the refined model is not kept: {unsound}"
        elif refined.report.converged:
            model = refined
        else:
            # an iterate cut off by the evaluation budget is neither the subspace
            # estimate nor a prediction-error one (docstring): keep the former
            assert refined.report.refinement is not None
            rule += (
                f"; the refinement did not converge in {refined.report.refinement.nfev} "
                f"evaluations: the unrefined model is kept"
            )
    model.options["refine_rule"] = rule
    model.options["refine_statistics"] = stats
    return model, rule


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


def _warn_if_fallback(model: StateSpaceModel) -> None:
    """A :class:`~hdpbsid.selection.auto.SelectionWarning` when the held-out selection returned
    the candidate fitted on part of the record and no refinement on the whole record
    replaced it: a decision for the user (a longer record, or the method's settings
    given)."""
    from hdpbsid.selection.auto import SelectionWarning

    fallback = model.report.selection_fallback
    if fallback and model.report.refinement is not None:
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


class _Labels:
    """The channel names and time unit given to :func:`identify`, checked before any
    computation against the channel counts of the first record."""

    def __init__(self, inputs: Any, outputs: Any, time_unit: Any, t: Any, u: Any, y: Any) -> None:
        if isinstance(t, list | tuple) and len(t) and isinstance(t[0], list | tuple):
            u, y = (t[0][1], t[0][2]) if len(t[0]) == 3 else (None, None)
        m = 0 if u is None else _channels(u)
        l = None if y is None else _channels(y)
        self.time_unit = check_label(time_unit, "time_unit")
        # the counts are checked here when the signals have a shape (else the data checks
        # report them, and apply() checks the names against the model)
        self.inputs, self.outputs = inputs, outputs
        if inputs is not None and m is not None:
            self.inputs = check_names(inputs, "input_names", m, "u")
        if outputs is not None and l is not None:
            self.outputs = check_names(outputs, "output_names", l, "y")

    def apply(self, model: StateSpaceModel, records: Any) -> None:
        """Label ``model`` (and its sampled model) and record the median step of the
        records' times as ``model.sampling_interval``."""
        steps = [np.diff(check_time(r[0], "t")) for r in records]
        for mod in (model, model.discrete):
            if mod is not None:
                mod.set_labels(self.inputs, self.outputs, self.time_unit)
        model.sampling_interval = float(np.median(np.concatenate(steps)))


class _Scaling:
    """Channels far outside the float64 comfort band, scaled by powers of two for the
    identification and the model scaled back (:func:`~hdpbsid.data.checks.scale_exponents`):
    the result is the model of the unscaled record, since a power-of-two scaling is
    exact and the methods are invariant to the signals' units.  The state takes the
    inputs' scale, so ``B`` keeps moderate entries and ``C``, ``D`` carry the gain."""

    def __init__(self, t: Any, u: Any, y: Any, several: bool) -> None:
        recs = [r for r in t if isinstance(r, list | tuple) and len(r) == 3] if several else []
        pairs = [(r[1], r[2]) for r in recs] if several else [(u, y)]
        pu = [scale_exponents(uu, "u") for uu, _ in pairs if uu is not None]
        py = [scale_exponents(yy, "y") for _, yy in pairs if yy is not None]
        # one exponent per channel for all records (the same units): the smallest, so
        # that no record's largest value grows beyond the band
        self.pu = _common(pu)
        self.py = _common(py)
        self.active = bool(np.any(self.pu) or np.any(self.py))

    def apply(self, t: Any, u: Any, y: Any) -> tuple[Any, Any, Any]:
        if not self.active:
            return t, u, y
        if isinstance(t, list | tuple) and u is None and y is None:
            return [(r[0], self._u(r[1]), self._y(r[2])) for r in t], None, None
        return t, self._u(u), self._y(y)

    def _u(self, x: Any) -> Any:
        return x if x is None or not np.any(self.pu) else _ldexp(x, self.pu)

    def _y(self, x: Any) -> Any:
        return x if x is None or not np.any(self.py) else _ldexp(x, self.py)

    def undo(self, model: StateSpaceModel, info: Any) -> tuple[StateSpaceModel, Any]:
        if not self.active:
            return model, info
        pu = self.pu if self.pu.size else np.zeros(model.m, dtype=np.int64)
        py = self.py if self.py.size else np.zeros(model.l, dtype=np.int64)
        # the state in the inputs' scale (the outputs' without inputs): B (and K of a time
        # series) keep the entries they had, C and D carry the gain -- the sampled
        # model's augmented exponential takes A, B and K, and must not see huge entries
        px = -int(round(float(np.mean(pu if pu.size else py))))
        model = scale_signals(model, -pu, -py, px)
        model.options["signal_scaling"] = {
            "u_exponents": pu.tolist(),
            "y_exponents": py.tolist(),
            "note": "channels scaled by 2**exponent for the identification; option "
            "values in signal units refer to the scaled signals",
        }
        return model, _unscale_levels(info, pu, py)


def _common(exps: list[Any]) -> Any:
    exps = [e for e in exps if e.size]
    if not exps or len({e.size for e in exps}) > 1:
        return np.zeros(0 if not exps else exps[0].size, dtype=np.int64)  # checks report
    return np.min(np.stack(exps), axis=0)


def _ldexp(x: Any, p: Any) -> Any:
    """``x * 2^p`` per column (a 1-D ``x`` is one channel); ``x`` left to the data
    checks when it is not a numeric array of the right width."""
    arr = np.asarray(x) if isinstance(x, np.ndarray | list | tuple) else None
    if arr is None or arr.dtype.kind not in "biuf":
        return x  # the data checks name what is wrong with it
    if arr.ndim == 1 and p.size == 1:
        return np.ldexp(arr, int(p[0]))
    if arr.ndim == 2 and arr.shape[1] == p.size:
        return np.ldexp(arr, p[None, :])
    return x


def _unscale_levels(info: Any, pu: Any, py: Any) -> Any:
    """The operating points of ``options["operating_points"]`` in the record's units."""
    if isinstance(info, list):
        return [_unscale_levels(d, pu, py) for d in info]
    out = dict(info)
    for key, p in (("u0", pu), ("u_slope", pu), ("y0", py), ("y_slope", py)):
        if key in out:
            out[key] = np.ldexp(np.asarray(out[key], dtype=float), -p).tolist()
    return out


def _channels(x: Any) -> int | None:
    """Columns of a signal given as ``(Ns,)`` or ``(Ns, k)``; ``None`` for a ragged one
    (the data checks report it)."""
    try:
        shape = np.shape(x)
    except ValueError:
        return None
    return 1 if len(shape) < 2 else int(shape[1])


def _warn_not_exciting(u: Any) -> None:
    """Warn when an input column is constant: a constant input excites no dynamics
    (it is not persistently exciting of any order), so ``B`` is not identifiable from
    the record -- the model would describe the noise and initial conditions only."""
    if u is None:
        return
    try:
        ua = np.asarray(u)
    except (TypeError, ValueError):  # ragged: the data checks name it
        return
    if ua.dtype.kind not in "biuf":
        return  # complex, text, objects: the data checks name them
    ua = ua.astype(float)
    ua = ua[:, None] if ua.ndim == 1 else ua
    if ua.ndim != 2 or ua.shape[0] < 2:
        return  # the method's checks report malformed input
    spread = np.ptp(ua, axis=0)
    level = np.max(np.abs(ua), axis=0)
    for k in np.flatnonzero(spread <= 1e-12 * np.maximum(level, np.finfo(float).tiny)):
        warnings.warn(
            f"u[:, {k}] is constant: the input is not persistently exciting, so its effect "
            f"(B) cannot be identified from this record; excite the system (steps, a "
            f"multisine, a random binary signal) or leave the input out",
            UserWarning,
            stacklevel=user_stacklevel(),
        )


def _run(
    method: str,
    func: IdentifyFunc,
    t: Any,
    u: Any,
    y: Any,
    order: Any,
    options: dict,
    refined: bool = False,
    judge_feedthrough: bool = False,
) -> StateSpaceModel:
    """Run ``method`` on one record; ``order=None`` goes through the held-out order choice
    (:func:`hdpbsid.selection.auto.select_order`) unless ``order_rule="svd"``.  ``refined``:
    the result will be refined, so the held-out choice is told (it then decides close
    orders between refined candidates, :func:`hdpbsid.selection.auto.rejudge_refined`).
    ``judge_feedthrough`` (``feedthrough="auto"``): the held-out choice judges the direct
    term with the order (:mod:`hdpbsid.selection.feedthrough`); with the method and the
    order given, :func:`hdpbsid.selection.auto.decide_feedthrough` judges it alone."""
    rule = options.pop("order_rule", "held-out")
    if rule not in ("held-out", "svd"):
        raise ValueError(f"order_rule must be 'held-out' or 'svd', got {rule!r}")
    given = options.pop("feedthrough", None)
    ft: dict[str, Any] = {"feedthrough": given} if given is not None else {}
    # the held-out selections judge the direct term themselves when asked to
    judged = {"feedthrough": "auto"} if judge_feedthrough else ft
    if order is None and method != "auto" and rule == "held-out":
        from hdpbsid.selection.auto import select_order

        return select_order(method, t, u, y, refined=refined, **judged, **options)
    if method == "auto":
        return func(t, u, y, order=order, refined=refined, **judged, **options)
    why = ""
    if judge_feedthrough and order is None:
        why = "auto: not judged (order_rule='svd' chooses the order on the whole record); D = 0"
    elif judge_feedthrough:
        from hdpbsid.selection.auto import decide_feedthrough

        has_d, why = decide_feedthrough(method, t, u, y, order, options)
        ft = {"feedthrough": True} if has_d else {}
    model = func(t, u, y, order=order, **ft, **options)
    if why and isinstance(model, StateSpaceModel):
        model.options["feedthrough_rule"] = why
    return model
