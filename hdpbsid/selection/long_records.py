"""Defaults that scale: ``identify(t, u, y)`` on long records (10^5 samples and more).

The default path of :func:`hdpbsid.identify` (``method="auto"``, ``refine="auto"``) fits
every candidate ``(method, order)`` on two thirds of the record, refits the chosen one on
all of it and refines it by the prediction-error method on all of it.  Its cost grows
with the record and its memory with some methods faster than the record (``dt``: the
VARX regressor of up to 200 lags).  On a *long* record -- more samples than
:attr:`LongRecordPolicy.long_samples` -- the same decisions are taken on bounded data:

1. **Spectrum** of the whole record, periodograms averaged over chunks
   (:func:`hdpbsid.methods.chunked.averaged_spectra`: Welch's method, one pass, memory of
   one chunk): the data bandwidth and the lowest significant output frequency
   ``f_low`` (below it lies :data:`~hdpbsid.bases.segments.LOW_FRACTION` of the output
   energy above the noise floor), the quantities HD-PBSID's own window rule uses.
2. **Which methods can run** (:meth:`LongRecordPolicy.plan`): the final model is fitted on
   the whole record, so a method is a candidate only if that fit is possible -- its memory
   estimate (:func:`~hdpbsid.selection.long_policy.whole_record_cost`) within the policy's
   budget, and, for a record read in chunks, a streamed core (HD-PBSID,
   :mod:`hdpbsid.methods.chunked`). Every other method is skipped before anything runs, with
   a typed reason (:class:`~hdpbsid.selection.long_policy.SkipReason`) in the selection
   table: none is left to run out of memory.
3. **Selection** (:func:`hdpbsid.selection.auto.identify_auto`) on one contiguous segment
   from the middle of the record (away from start-up transients) of
   :meth:`LongRecordPolicy.selection_samples` samples: ``selection_periods = 3 *
   WINDOW_PERIODS`` periods of ``f_low`` -- the estimation part (two thirds) then holds two
   of HD-PBSID's default windows (:data:`~hdpbsid.bases.segments.WINDOW_PERIODS` periods
   each, the length over which a window's forced response resolves the slowest significant
   component) and the held-out third one; at least
   :attr:`~LongRecordPolicy.min_selection_samples` (the held-out third then estimates the
   residual variance to ``sqrt(2 / 1365) = 4 %`` relative, below the few-percent differences
   between an adequate and an inadequate order); at most
   :attr:`~LongRecordPolicy.max_selection_samples` (the cost bound: the sweep of every
   candidate costs a few CPU seconds per 10^4 samples; when the periods rule asks for more,
   the selection sees fewer periods and the plan's rule says so).
4. **Whole record**: the chosen method and order are fitted on the whole record -- with
   the method itself when its memory estimate fits, else with HD-PBSID's streamed core
   (:func:`hdpbsid.methods.chunked.identify_chunked`: memory of one batch of samples).
   The cost of every such fit is linear in the samples.
5. **Refinement** (``refine="auto"`` or ``"pem"``; :func:`hdpbsid.refine.pem.refine_pem`) on
   a contiguous part of the record, started from the whole-record model (and the selection's
   refined candidate, when there is one).  The prediction-error estimate's covariance falls
   as ``1 / N`` (Ljung, *System Identification*, 2nd ed., sec. 9.3), so the part is the
   smallest one whose predicted relative eigenvalue standard deviation (the refinement's
   ``eigenvalue_std``) is within :attr:`~LongRecordPolicy.refine_std`: it is first refined
   on the selection segment, and when its reported standard deviation ``s`` exceeds the
   target, again on ``N s^2 / target^2`` samples (capped by
   :attr:`~LongRecordPolicy.max_refine_samples` and the record).  The whole-record model and
   the refined one are then scored on a segment of the record outside the refinement part
   (:func:`hdpbsid.selection.auto.score_model`); the whole-record model is returned unless
   the refined one predicts that segment better by more than one standard error
   (:func:`~hdpbsid.models.criteria.choose_smallest_adequate`, the whole-record model listed
   first).  Why this way round: in open loop the subspace fit on all ``Ns`` samples is
   consistent and its variance falls with ``Ns``, while the refinement saw a part; the
   refinement earns its place where the subspace estimate is biased (closed loop), which is
   what a better held-out prediction shows.  The whole-record model has seen that segment
   (an in-sample advantage of about ``parameters / Ns`` of the error, negligible on a long
   record).

``model.options["long_record"]`` holds the plan (:class:`LongRecordPlan` as a dict: the
inputs, the choices and the skipped methods with their reasons), the selection table
(``options["selection"]``) has one row per skipped method with ``status`` ``"skipped:
<reason>: <detail>"``.  ``progress=True`` shows a progress bar (tqdm) over the stages and
the passes over the record.
"""

from __future__ import annotations

import dataclasses
import functools
import time
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_data
from hdpbsid.models.report import Candidate, Choice
from hdpbsid.selection.iterate import keep_iterate
from hdpbsid.selection.long_policy import (
    LongRecordPlan,
    LongRecordPolicy,
    Skip,
    SkipReason,
    as_policy,
    whole_record_cost,
)

if TYPE_CHECKING:
    from hdpbsid.data.chunked import ChunkedRecord

__all__ = [
    "LongRecordPolicy",
    "LongRecordPlan",
    "Skip",
    "SkipReason",
    "identify_long",
    "is_long",
    "whole_record_cost",
    "WORK_BUDGET",
    "LONG_SAMPLES",
    "SELECTION_PERIODS",
    "MIN_SELECTION_SAMPLES",
    "MAX_SELECTION_SAMPLES",
    "MEMORY_BUDGET",
    "REFINE_RELATIVE_STD",
    "MAX_REFINE_SAMPLES",
]

Array = NDArray[np.float64]

# the policy's defaults under their former names (the fields of LongRecordPolicy are the
# source; these stay importable for the front ends)
_DEFAULTS = LongRecordPolicy()
LONG_SAMPLES = _DEFAULTS.long_samples
SELECTION_PERIODS = _DEFAULTS.selection_periods
MIN_SELECTION_SAMPLES = _DEFAULTS.min_selection_samples
MAX_SELECTION_SAMPLES = _DEFAULTS.max_selection_samples
MEMORY_BUDGET = _DEFAULTS.memory_budget
WORK_BUDGET = _DEFAULTS.work_budget
REFINE_RELATIVE_STD = _DEFAULTS.refine_std
MAX_REFINE_SAMPLES = _DEFAULTS.max_refine_samples


# -- progress ------------------------------------------------------------------------------
class _Progress:
    """A tqdm bar over the stages, and one over the samples of each pass over the record;
    nothing when disabled."""

    def __init__(self, enabled: bool, stages: int) -> None:
        self.bar: Any = None
        self.samples: Any = None
        if not enabled:
            return
        from tqdm.auto import tqdm  # a dependency, imported only when a bar is shown

        self._tqdm = tqdm
        self.bar = tqdm(total=stages, desc="identify", unit="stage", leave=True)

    def stage(self, text: str) -> None:
        if self.bar is not None:
            if self.bar.n or self.bar.desc != "identify":
                self.bar.update(1)
            self.bar.set_description_str(f"identify: {text}")

    def reading(self, total: int, what: str) -> None:
        if self.bar is None:
            return
        self.end_reading()
        self.samples = self._tqdm(
            total=total, desc=f"  {what}", unit="sample", unit_scale=True, leave=False
        )

    def tick(self, n: int) -> None:
        if self.samples is not None:
            self.samples.update(n)

    def end_reading(self) -> None:
        if self.samples is not None:
            self.samples.close()
            self.samples = None

    def close(self) -> None:
        self.end_reading()
        if self.bar is not None:
            self.bar.update(self.bar.total - self.bar.n)
            self.bar.close()


class _Ticking:
    """``read(a, b)`` that advances a progress bar by the samples read (picklable when
    ``read`` is, the bar left behind)."""

    def __init__(self, read: Any, progress: _Progress) -> None:
        self.read, self.progress = read, progress

    def __call__(self, a: int, b: int) -> tuple[Array, Array]:
        out = self.read(a, b)
        self.progress.tick(b - a)
        return out

    def __getstate__(self) -> dict[str, Any]:
        return {"read": self.read, "progress": _Progress(False, 0)}


class _Centred:
    """``read(a, b)`` minus the levels ``u0``, ``y0`` (the operating point)."""

    def __init__(self, read: Any, u0: Array, y0: Array) -> None:
        self.read, self.u0, self.y0 = read, u0, y0

    def __call__(self, a: int, b: int) -> tuple[Array, Array]:
        u, y = self.read(a, b)
        return u - self.u0, y - self.y0


# -- the bounded path ----------------------------------------------------------------------
def is_long(t: Any, u: Any, y: Any, method: str, policy: Any) -> bool:
    """Whether :func:`hdpbsid.identify` takes the bounded path.

    It does for ``method="auto"`` on one record longer than the policy's
    ``long_samples``, and always for a :class:`~hdpbsid.data.chunked.ChunkedRecord`;
    ``policy=False`` turns it off for arrays.

    Parameters
    ----------
    t : array_like, list or ChunkedRecord
        The time argument of ``identify`` (a list of arrays: several records, never long).
    u : array_like or None
        The inputs (unused: the output's length decides).
    y : array_like or None
        The outputs.
    method : str
        The method asked for.
    policy : LongRecordPolicy, bool or None
        The ``long_record`` argument.

    Returns
    -------
    bool
        True for the bounded path.

    Examples
    --------
    >>> import numpy as np
    >>> is_long(np.arange(10), None, np.zeros(10), "auto", LongRecordPolicy(long_samples=16))
    False
    """
    if not isinstance(t, np.ndarray | list | tuple):  # cheap first: no import for arrays
        from hdpbsid.data.chunked import ChunkedRecord

        if isinstance(t, ChunkedRecord):
            return True
    if policy is False or method != "auto" or y is None:
        return False
    if isinstance(t, list | tuple) and (len(t) == 0 or isinstance(t[0], list | tuple)):
        return False
    policy = as_policy(policy)
    try:
        rows = int(np.shape(y)[0])
    except ValueError:  # ragged: not one record; the data checks say what is wrong
        return False
    return rows > policy.long_samples


def _levels(rec: ChunkedRecord, progress: _Progress) -> tuple[Array, Array]:
    """Channel means of a chunked record (one pass)."""
    from hdpbsid.data.chunked import CHUNK_SAMPLES

    su, sy = np.zeros(rec.m), np.zeros(rec.l)
    progress.reading(rec.ns, "means")
    for a in range(0, rec.ns, CHUNK_SAMPLES):
        u, y = rec.checked(a, min(rec.ns, a + CHUNK_SAMPLES))
        su += u.sum(axis=0)
        sy += y.sum(axis=0)
        progress.tick(u.shape[0])
    progress.end_reading()
    return su / rec.ns, sy / rec.ns


def _segment(rec: ChunkedRecord, a: int, b: int) -> tuple[Array, Array | None, Array]:
    u, y = rec.checked(a, b)
    t = rec.t0 + np.arange(a, b) * rec.dt
    return t, (u if rec.m else None), y


def identify_long(
    t: Any,
    u: Any = None,
    y: Any = None,
    order: int | None = None,
    refine: str | None = "auto",
    detrend: str | None = "mean",
    *,
    long_record: LongRecordPolicy | None = None,
    progress: bool = False,
    focus: str = "auto",
    **options: Any,
) -> Any:
    """``identify(t, u, y)`` on a long record by the bounded path (module docstring).

    Parameters
    ----------
    t, u, y
        One uniformly sampled record as :func:`hdpbsid.identify` takes it, or a
        :class:`~hdpbsid.data.chunked.ChunkedRecord` in ``t`` (``u``, ``y`` None; e.g.
        :func:`hdpbsid.data.io.open_chunked`), read in pieces.
    order
        The model order, or None to choose it (on the selection segment).
    refine
        ``"auto"`` (default), ``"pem"`` or None, as in :func:`hdpbsid.identify`.
    detrend
        ``"mean"`` (default), ``"linear"`` (in-memory records only) or None.
    long_record
        The :class:`LongRecordPolicy` (default: its defaults).
    progress
        Show progress bars (tqdm).
    focus
        :func:`hdpbsid.identify`'s: ``"auto"`` (default: chosen on the refinement's part,
        :func:`hdpbsid.selection.focus.choose_focus`), ``"prediction"`` or
        ``"simulation"`` (:func:`hdpbsid.refine.pem.refine_pem`'s).
    **options
        As :func:`hdpbsid.selection.auto.identify_auto` takes them (``methods=``,
        ``max_order=``, ``method_options=``, settings shared by every method).

    Returns
    -------
    StateSpaceModel
        With ``options["long_record"]`` (the plan), ``options["selection"]`` (the
        candidates and the skipped methods) and the usual options of ``identify``.

    Raises
    ------
    ValueError
        Non-uniform ``t``, ``detrend="linear"`` on a chunked record, bad data, no
        candidate method left (every one skipped: the reasons are listed).
    TypeError
        A ``long_record`` that is not a :class:`LongRecordPolicy`.

    Examples
    --------
    >>> import numpy as np, hdpbsid
    >>> from hdpbsid.selection.long_records import LongRecordPolicy
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(20_000) * 0.01
    >>> u = rng.standard_normal(t.size)
    >>> y = np.convolve(u, 0.1 * 0.9 ** np.arange(60))[: t.size]
    >>> m = hdpbsid.identify(t, u, y, long_record=LongRecordPolicy(long_samples=10_000))
    >>> m.options["long_record"]["methods"]
    ('hermite', 'laguerre', 'legendre', 'dt')
    """
    from hdpbsid.refine.pem import REFINE_CHOICES

    policy = as_policy(long_record)
    if refine not in REFINE_CHOICES:
        raise ValueError(f"refine must be one of {REFINE_CHOICES}, got {refine!r}")
    bar = _Progress(progress, 6)
    t_start = time.perf_counter()
    info: dict[str, Any] = {}
    try:
        bar.stage("levels")
        lv = _centred(t, u, y, detrend, bar)
        rec = lv.rec
        reading = dataclasses.replace(rec, read=_Ticking(rec.read, bar))
        plan, opts = _plan(rec, reading, policy, options, lv.chunked, bar)
        bar.stage(f"selection on {plan.selection[1] - plan.selection[0]} samples")
        chosen, t_sel = _select(rec, plan, order, refine, opts)
        method, n = chosen.report.method, chosen.n
        bar.stage(f"{method} order {n} on {rec.ns} samples")
        model = _whole_record(method, n, rec, reading, chosen, opts, plan, bar)
        if refine is not None:
            bar.stage("refinement")
            model = _refine(model, chosen, rec, plan, policy, refine, info, focus)
        bar.stage("done")
    finally:
        bar.close()
    timing = {"selection_time": t_sel, "time": time.perf_counter() - t_start}
    extra = {**_policy_dict(policy), **timing, **info}
    _finish(model, chosen, plan, extra, lv, detrend, order, options)
    return model


@dataclass(frozen=True)
class _Levels:
    """The record as deviations from its operating point, read in pieces, and the levels
    removed (``info``: their report, ``model.options["operating_points"]``)."""

    rec: ChunkedRecord
    chunked: bool
    u0: Array
    y0: Array
    trend: Any
    info: dict[str, Any]


def _centred(t: Any, u: Any, y: Any, detrend: str | None, bar: _Progress) -> _Levels:
    """The record of ``identify_long``'s arguments, its levels removed (step 0)."""
    from hdpbsid.data.chunked import ChunkedRecord

    if isinstance(t, ChunkedRecord):
        return _centred_chunks(t, u, y, detrend, bar)
    return _centred_arrays(t, u, y, detrend)


def _centred_chunks(
    raw: ChunkedRecord, u: Any, y: Any, detrend: str | None, bar: _Progress
) -> _Levels:
    """A record read in chunks, its means (one pass) removed as it is read."""
    if u is not None or y is not None:
        raise ValueError("with a ChunkedRecord in t, leave u and y out")
    if detrend == "linear":
        raise ValueError(
            "detrend='linear' is not available for a record read in chunks; use 'mean' or None"
        )
    u0, y0 = _levels(raw, bar) if detrend == "mean" else (np.zeros(raw.m), np.zeros(raw.l))
    rec = dataclasses.replace(raw, read=_Centred(raw.read, u0, y0))
    info = {"u0": u0.tolist(), "y0": y0.tolist(), "samples": raw.ns}
    return _Levels(rec, True, u0, y0, None, info)


def _centred_arrays(t: Any, u: Any, y: Any, detrend: str | None) -> _Levels:
    """An in-memory record (uniformly sampled), detrended, read through a chunk reader."""
    from hdpbsid.data.chunked import ChunkedRecord
    from hdpbsid.data.detrend import detrend_record
    from hdpbsid.models.model import LinearTrend
    from hdpbsid.refine.pem import is_uniform

    tt, ua, yy = check_data(t, u, y)
    if not is_uniform(tt):
        raise ValueError(
            "t: the bounded path for long records needs uniform sampling; "
            "pass long_record=False for the whole-record path"
        )
    ud, yd, lv = detrend_record(tt, ua, yy, detrend)
    h = float((tt[-1] - tt[0]) / (tt.size - 1))
    rec = ChunkedRecord.from_arrays(ud if ua.shape[1] else None, yd, h, float(tt[0]))
    trend = None if lv.t_ref is None else LinearTrend(lv.t_ref, lv.u_slope, lv.y_slope)
    return _Levels(rec, False, lv.u0, lv.y0, trend, lv.as_dict())


def _plan(
    rec: ChunkedRecord,
    reading: ChunkedRecord,
    policy: LongRecordPolicy,
    options: dict[str, Any],
    chunked: bool,
    bar: _Progress,
) -> tuple[LongRecordPlan, dict[str, Any]]:
    """Steps 1-2: the averaged spectrum of the whole record and the policy's plan; the
    options without ``methods``."""
    from hdpbsid.bases.basis_domain import spectra_data_bandwidth, spectrum_bandwidth
    from hdpbsid.bases.segments import LOW_FRACTION
    from hdpbsid.methods.chunked import averaged_spectra

    bar.stage("spectrum")
    bar.reading(rec.ns, "spectrum")
    # 2^16 samples per periodogram: a resolution of fs / 2^16, finer than the lowest
    # frequency a selection segment can hold a few periods of
    w, Pu, Py = averaged_spectra(reading, min(rec.ns, 2**16))
    bar.end_reading()
    wb = spectra_data_bandwidth(w, Pu, w, Py)
    w_low = spectrum_bandwidth(w, Py, LOW_FRACTION)
    opts = dict(options)
    asked = opts.pop("methods", None)
    if asked is None:
        asked = _available()
    plan = policy.plan(
        rec.ns,
        rec.dt,
        rec.m,
        rec.l,
        w_low / (2 * np.pi),
        wb / (2 * np.pi),
        list(asked),
        chunked,
    )
    if not plan.methods:
        raise ValueError(
            "no method can be fitted on the whole record: "
            + "; ".join(f"{s.method}: {s.status()}" for s in plan.skipped)
        )
    return plan, opts


def _available() -> list[str]:
    """The default candidates that can run here (optional dependencies installed)."""
    from hdpbsid.methods.registry import is_available
    from hdpbsid.selection.auto import AUTO_METHODS

    return [m for m in AUTO_METHODS if is_available(m)]


def _select(
    rec: ChunkedRecord,
    plan: LongRecordPlan,
    order: int | None,
    refine: str | None,
    opts: dict[str, Any],
) -> tuple[Any, float]:
    """Step 3: the selection on the plan's segment, and its time (s)."""
    from hdpbsid.selection.auto import identify_auto

    seg = _segment(rec, *plan.selection)
    t_sel = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        chosen = identify_auto(
            *seg, order=order, methods=list(plan.methods), refined=refine is not None, **opts
        )
    return chosen, time.perf_counter() - t_sel


def _policy_dict(policy: LongRecordPolicy) -> dict[str, Any]:
    """The policy as ``options["long_record"]["policy"]``."""
    fields = dataclasses.asdict(policy).items()
    return {"policy": {k: v for k, v in fields if not k.startswith("_")}}


def _finish(
    model: Any,
    chosen: Any,
    plan: LongRecordPlan,
    extra: dict[str, Any],
    lv: _Levels,
    detrend: str | None,
    order: int | None,
    options: dict[str, Any],
) -> None:
    """The selection table (candidates and skipped methods), its rule, the plan with
    ``extra``, the levels and the request into the model's options and report."""
    from hdpbsid.models.model import _set_levels

    method = chosen.report.method
    table = [c.as_dict() for c in chosen.report.candidates]
    table += [_skip_row(s) for s in plan.skipped]
    rule = f"{plan.rule}; {chosen.report.selection_rule}"
    model.options["selection"] = table
    model.options["order_selection"] = [r for r in table if r["method"] == method]
    model.options["selection_rule"] = rule
    model.options["long_record"] = {**plan.as_dict(), **extra}
    _set_levels(model, lv.u0, lv.y0, lv.trend)
    model.options.setdefault("refine", None)
    model.options["method"] = method
    model.report = model.report.but(
        method=method,
        candidates=tuple(Candidate.from_dict(r) for r in table),
        selection_rule=rule,
        warm_start=None,
    )
    model.options["detrend"] = detrend
    model.options["operating_points"] = lv.info
    model.options["requested_method"] = "auto"
    model.options["requested_order"] = order
    model.options["requested_options"] = dict(options)


def _skip_row(s: Skip) -> dict[str, Any]:
    return {
        "method": s.method,
        "order": None,
        "error": None,
        "fit": None,
        "z": None,
        "whole_simulation": None,
        "refined_error": None,
        "refined_fit": None,
        "predictor": None,
        "first_pass_error": None,
        "time": 0.0,
        "status": s.status(),
    }


def _whole_record(
    method: str,
    n: int,
    rec: ChunkedRecord,
    reading: ChunkedRecord,
    chosen: Any,
    opts: dict[str, Any],
    plan: LongRecordPlan,
    bar: _Progress,
) -> Any:
    """``method`` at order ``n`` on the whole record: the method itself (in memory), or
    HD-PBSID's streamed core when the plan says so."""
    from hdpbsid.data.records import Dataset
    from hdpbsid.methods.registry import call_method, get_method
    from hdpbsid.selection.candidates import closed_loop_refit, refit_keeps

    given = {**{k: v for k, v in opts.items() if k not in _AUTO_ONLY}}
    given.update((opts.get("method_options") or {}).get(method, {}))
    if method in plan.streamed:
        from hdpbsid.methods.chunked import identify_chunked

        bar.reading(3 * rec.ns, "whole record (3 passes)")
        given.pop("window", None) if given.get("window") == "auto" else None
        model = identify_chunked(reading, order=n, **given)
        bar.end_reading()
        model.options["long_record_fit"] = "streamed core (hdpbsid.methods.chunked)"
        return model
    func = get_method(method)
    refit = chosen.report.refit_settings
    t, u, y = _segment(rec, 0, rec.ns)
    settings = {
        **given,
        **refit_keeps(func, chosen, given, closed_loop_refit(func, chosen, (t, u, y))),
        **({} if refit is None else refit.value),
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = functools.partial(Dataset.of, t, u, y)  # made only for a Dataset function
        model = call_method(func, (t, u, y), data, order=n, **settings)
    model.options["long_record_fit"] = "the method on the whole record, in memory"
    return model


#: options of identify_auto that are not method settings
_AUTO_ONLY = ("max_order", "holdout", "n_jobs", "method_options", "methods")


def _refine(
    model: Any,
    chosen: Any,
    rec: ChunkedRecord,
    plan: LongRecordPlan,
    policy: LongRecordPolicy,
    refine: str,
    info: dict[str, Any],
    focus: str = "auto",
) -> Any:
    """The refinement on a bounded part and the choice between it and ``model``
    (module docstring, step 5); what was done goes to ``info``; ``focus``: the
    refinement's."""
    t0 = time.perf_counter()
    part = _segment(rec, *plan.selection)
    do, rule = _refine_decision(model, part, refine, info)
    if not do:
        return model
    if focus == "simulation":
        rule += f"; focus={focus!r}"
        from hdpbsid.refine.pem_focus import warn_if_closed_loop

        warn_if_closed_loop(focus, info.get("refine_statistics"))
    fitted = "simulation" if focus == "simulation" else "prediction"
    refined, converged, (a, b), rel = _refine_parts(
        model, chosen, rec, part, plan, policy, info, fitted
    )
    why = _not_kept(model, refined, converged, _segment(rec, a, b), fitted)
    if why:
        text = (
            f"{rule}; the refinement on samples {a}..{b - 1} {why}: the whole-record "
            f"subspace model is kept"
        )
        model.options["refine_rule"] = text
        model.options["refine_time"] = time.perf_counter() - t0
        model.report = model.report.but(refine_decision=Choice(False, text))
        return model
    choice, val_ab = _judge(model, refined, rec, plan, (a, b), info)
    if choice == "refined" and focus == "auto":  # on the refinement's part, its feedback test
        from hdpbsid.selection.focus import choose_focus

        feedback = bool((info.get("refine_statistics") or {}).get("feedback"))
        refined = choose_focus(refined, *_segment(rec, a, b), feedback, model)[0]
    out = refined if choice == "refined" else model
    text = (
        f"{rule}; refined on samples {a}..{b - 1} ({b - a} of {rec.ns}: predicted relative "
        f"eigenvalue std {rel:.3g}, target {policy.refine_std:g}); kept: {choice} model "
        f"(held-out one-step prediction on samples {val_ab[0]}..{val_ab[1] - 1})"
    )
    out.options["refine_rule"] = text
    out.options["refine_time"] = time.perf_counter() - t0
    if choice != "refined":
        out.options["refine"] = None
    kept = out.report.refinement if choice == "refined" else None
    out.report = out.report.but(refinement=kept, refine_decision=Choice(choice == "refined", text))
    return out


def _refine_decision(
    model: Any, part: tuple[Array, Array | None, Array], refine: str, info: dict[str, Any]
) -> tuple[bool, str]:
    """Whether to refine and the rule: ``refine="pem"`` always; ``"auto"`` by
    :func:`~hdpbsid.selection.feedback.refine_decision` on the selection segment ``part``
    (a refusal is written to the model)."""
    if refine != "auto":
        return True, "pem"
    from hdpbsid.selection.feedback import refine_decision

    do, rule, stats = refine_decision(model, *part, True)
    info["refine_statistics"] = stats
    if not do:
        model.options["refine_rule"] = rule
        model.report = model.report.but(refine_decision=Choice(False, rule))
    return do, rule


def _not_kept(model: Any, refined: Any, converged: bool, seg: tuple, focus: str) -> str:
    """Why the refinement ``refined`` of ``model`` on ``seg`` is not kept, ``""`` when it
    is: it did not lower the cost, or its budget cut it off and the record does not
    resolve it from ``model`` (:func:`hdpbsid.selection.iterate.keep_iterate`)."""
    if converged:
        return ""
    if refined is model:
        return "did not converge"
    iterate = keep_iterate(model, refined, *seg, focus=focus)
    return "" if iterate.value else iterate.reason


def _refine_parts(
    model: Any,
    chosen: Any,
    rec: ChunkedRecord,
    part: tuple[Array, Array | None, Array],
    plan: LongRecordPlan,
    policy: LongRecordPolicy,
    info: dict[str, Any],
    focus: str = "prediction",
) -> tuple[Any, bool, tuple[int, int], float]:
    """The refined model: on the selection segment ``part``, and when its predicted
    relative eigenvalue std ``s`` exceeds the target, again on ``N s^2 / target^2``
    samples of the middle (the covariance falls as ``1 / N``).  Returns the refined
    model, whether the first refinement converged, its part and its std."""
    from hdpbsid.refine.pem import refine_pem, warm_start_option

    a, b = plan.selection
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # the selection's candidate refined on its estimation part: a second starting point
        refined = refine_pem(model, *part, warm_start=chosen.report.warm_start, focus=focus)
        rel = _relative_std(refined)
        parts = [b - a]
        converged = refined is not model and refined.report.converged
        want = int(np.ceil((b - a) * (rel / policy.refine_std) ** 2)) if converged else 0
        size = min(rec.ns, policy.max_refine_samples, want)
        if size > b - a:
            a = (rec.ns - size) // 2
            b = a + size
            again = refine_pem(
                model, *_segment(rec, a, b), warm_start=warm_start_option(refined), focus=focus
            )
            if again is not model and again.report.converged:
                refined, rel = again, _relative_std(again)
            parts.append(b - a)
    info["refine_samples"] = parts
    info["refine_part"] = (a, b)
    info["refine_relative_std"] = rel
    return refined, converged, (a, b), rel


def _judge(
    model: Any,
    refined: Any,
    rec: ChunkedRecord,
    plan: LongRecordPlan,
    ab: tuple[int, int],
    info: dict[str, Any],
) -> tuple[str, tuple[int, int]]:
    """Which model to keep, judged on a segment outside the refinement part ``ab``: the
    whole-record model listed first, the refined one replaces it only when it predicts
    that segment better by one standard error.  Returns the choice and the segment."""
    from hdpbsid.models.criteria import choose_smallest_adequate, default_windows
    from hdpbsid.selection.auto import score_model

    a, b = ab
    n_val = plan.selection[1] - plan.selection[0]
    val_ab = (b, min(rec.ns, b + n_val)) if rec.ns - b >= a else (max(0, a - n_val), a)
    if val_ab[1] - val_ab[0] < 2 * n_val // 3:
        return "refined", val_ab
    val = _segment(rec, *val_ab)
    windows = default_windows(val_ab[1] - val_ab[0], max(model.n, 1))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        e_ref, _ = score_model(refined, val, windows)
        e_sub, _ = score_model(model, val, windows)
    if not (e_ref.finite or e_sub.finite):
        return "refined", val_ab
    k, z = choose_smallest_adequate([e_sub, e_ref])
    info["refine_judgement"] = {
        "samples": val_ab,
        "subspace_error": e_sub.total,
        "refined_error": e_ref.total,
        "z": z,
    }
    return ("whole-record subspace" if k == 0 else "refined"), val_ab


def _relative_std(model: Any) -> float:
    """Largest ``eigenvalue_std / |eigenvalue|`` of a refined model (inf without one)."""
    refinement = model.report.refinement
    std = None if refinement is None else refinement.eigenvalue_std
    if std is None:
        return float("inf")
    lam = np.abs(np.asarray(model.eigenvalues))
    std = np.abs(np.asarray(std, dtype=float).reshape(-1))
    if std.size != lam.size:
        return float("inf")
    return float(np.max(std / np.maximum(lam, np.finfo(float).tiny)))
