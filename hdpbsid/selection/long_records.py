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
2. **Which methods can run** (:meth:`LongRecordPolicy.plan`): the final model is fitted
   on the whole record, so a method is a candidate only if that fit is possible --
   its memory estimate (:func:`whole_record_bytes`) within the policy's budget, and, for
   a record read in chunks, a streamed core (HD-PBSID, :mod:`hdpbsid.methods.chunked`).
   Every other method is skipped before anything runs, with a typed reason
   (:class:`SkipReason`) in the selection table: none is left to run out of memory.
3. **Selection** (:func:`hdpbsid.selection.auto.identify_auto`) on one contiguous segment from
   the middle of the record (away from start-up transients) of
   :meth:`LongRecordPolicy.selection_samples` samples: ``SELECTION_PERIODS =
   3 * WINDOW_PERIODS`` periods of ``f_low`` -- the estimation part (two thirds) then
   holds two of HD-PBSID's default windows (:data:`~hdpbsid.bases.segments.WINDOW_PERIODS`
   periods each, the length over which a window's forced response resolves the slowest
   significant component) and the held-out third one; at least
   :data:`MIN_SELECTION_SAMPLES` (the held-out third then estimates the residual
   variance to ``sqrt(2 / 1365) = 4 %`` relative, below the few-percent differences
   between an adequate and an inadequate order); at most :data:`MAX_SELECTION_SAMPLES`
   (the cost bound: the sweep of every candidate costs a few CPU seconds per 10^4
   samples; when the periods rule asks for more, the selection sees fewer periods and
   the plan's rule says so).
4. **Whole record**: the chosen method and order are fitted on the whole record -- with
   the method itself when its memory estimate fits, else with HD-PBSID's streamed core
   (:func:`hdpbsid.methods.chunked.identify_chunked`: memory of one batch of samples).
   The cost of every such fit is linear in the samples.
5. **Refinement** (``refine="auto"`` or ``"pem"``; :func:`hdpbsid.refine.pem.refine_pem`)
   on a contiguous part of the record, started from the whole-record model (and the
   selection's refined candidate, when there is one).  The prediction-error estimate's
   covariance falls as ``1 / N`` (Ljung, *System Identification*, 2nd ed., sec. 9.3), so
   the part is the smallest one whose predicted relative eigenvalue standard deviation
   (the refinement's ``eigenvalue_std``) is within :data:`REFINE_RELATIVE_STD`: it is
   first refined on the selection segment, and when its reported standard deviation
   ``s`` exceeds the target, again on ``N s^2 / target^2`` samples (capped by
   :data:`MAX_REFINE_SAMPLES` and the record).  The whole-record model and the refined
   one are then scored on a segment of the record outside the refinement part
   (:func:`hdpbsid.selection.auto.score_model`); the whole-record model is returned unless the
   refined one predicts that segment better by more than one standard error
   (:func:`~hdpbsid.models.criteria.choose_smallest_adequate`, the whole-record model listed
   first).  Why this way round: in open loop the subspace fit on all ``Ns`` samples is
   consistent and its variance falls with ``Ns``, while the refinement saw a part; the
   refinement earns its place where the subspace estimate is biased (closed loop), which
   is what a better held-out prediction shows.  The whole-record model has seen that
   segment (an in-sample advantage of about ``parameters / Ns`` of the error,
   negligible on a long record).

``model.options["long_record"]`` holds the plan (:class:`LongRecordPlan` as a dict: the
inputs, the choices and the skipped methods with their reasons), the selection table
(``options["selection"]``) has one row per skipped method with ``status`` ``"skipped:
<reason>: <detail>"``.  ``progress=True`` shows a progress bar (tqdm) over the stages and
the passes over the record.
"""

from __future__ import annotations

import dataclasses
import time
import warnings
from dataclasses import dataclass, field
from enum import Enum
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_data, check_positive_int
from hdpbsid.models.report import Candidate, Choice

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

#: records longer than this take the bounded path: the whole-record default path costs
#: about a CPU millisecond per sample and more (its sweep fits 32 candidates on two
#: thirds of the record; ``dt``'s past-window criterion and the refinement on all of it)
LONG_SAMPLES = 50_000
#: periods of the lowest significant output frequency in the selection segment: two of
#: HD-PBSID's default windows (``WINDOW_PERIODS = 10`` of :mod:`hdpbsid.bases.segments`
#: each) to estimate, one to score (module docstring)
SELECTION_PERIODS = 30.0
#: fewest samples of the selection segment (module docstring: held-out variance to 4 %)
MIN_SELECTION_SAMPLES = 4096
#: most samples of the selection segment (cost bound, module docstring)
MAX_SELECTION_SAMPLES = 32_768
#: memory a whole-record fit may take (bytes); larger ones are skipped
MEMORY_BUDGET = 2**30
#: arithmetic a whole-record fit may take beyond linear (flops): seconds on one core
#: at a few Gflop/s; a larger one is skipped (the cost of a long record must be
#: linear in its samples)
WORK_BUDGET = 1e10
#: target relative standard deviation of the refined eigenvalues (module docstring):
#: a tenth of a percent, below what the model's structural errors (linearity, the input
#: hold between samples) leave on measured systems
REFINE_RELATIVE_STD = 1e-3
#: most samples the refinement runs on (its Jacobian holds ``samples x parameters``)
MAX_REFINE_SAMPLES = 200_000

#: traced peak bytes per sample and channel (``m + l``) of a whole-record fit of the
#: windowed basis-domain methods (their cost is linear in the samples: fixed windows);
#: measured (tracemalloc, 3 10^5 samples, one input and one output): 320-390 per sample,
#: rounded up
LINEAR_BYTES_PER_SAMPLE_CHANNEL = 256
#: methods whose whole-record fit is windowed (linear cost, :data:`LINEAR_BYTES_...`)
WINDOWED_METHODS = ("hermite", "laguerre", "legendre", "chebyshev", "sl")
#: methods with a streamed core (memory of one batch: :mod:`hdpbsid.methods.chunked`)
STREAMED_METHODS = ("hermite",)


class SkipReason(str, Enum):
    """Why a method is not a candidate on a long record."""

    MEMORY = "memory"  #: its whole-record fit would exceed the memory budget
    WORK = "work"  #: its whole-record fit's arithmetic would exceed the work budget
    NOT_STREAMED = "not streamed"  #: the record is read in chunks, the method has no streamed core
    NO_COST_MODEL = "no cost model"  #: its cost on long records is not known here


@dataclass(frozen=True)
class Skip:
    """A method left out of the selection: its name, the reason and the numbers."""

    method: str
    reason: SkipReason
    detail: str

    def status(self) -> str:
        """The ``status`` of its row in the selection table."""
        return f"skipped: {self.reason.value}: {self.detail}"


def whole_record_cost(method: str, ns: int, m: int, l: int) -> tuple[float, float] | None:
    """Estimated peak memory (bytes) and arithmetic (flops) of ``method``'s fit on ``ns``
    samples with ``m`` inputs and ``l`` outputs, held in memory; None when there is no
    estimate.

    ``dt``: its VARX regressor ``ns x c``, ``c = p (m + l)`` with ``p`` the largest past
    window of its default rule (``p (m + l) <= ns / 10``, ``p <= 200``;
    :func:`hdpbsid.methods.dt.default_windows`), held with one working copy (QR), 16
    bytes per entry (measured: 699 MB at 10^5 samples, 400 columns: 17 bytes per entry),
    and its QR, ``2 ns c^2`` flops.  The windowed methods:
    :data:`LINEAR_BYTES_PER_SAMPLE_CHANNEL` per sample and channel, and arithmetic linear
    in the samples (fixed windows; counted as 0 against the budget, which bounds
    superlinear work).
    """
    if method == "dt":
        from hdpbsid.methods.dt import P_CAP, SAMPLES_PER_REGRESSOR

        c = min(P_CAP, ns // (SAMPLES_PER_REGRESSOR * (m + l))) * (m + l)
        return 16.0 * ns * c, 2.0 * ns * c**2
    if method in WINDOWED_METHODS:
        return float(LINEAR_BYTES_PER_SAMPLE_CHANNEL * ns * (m + l)), 0.0
    return None


@dataclass(frozen=True)
class LongRecordPlan:
    """What :meth:`LongRecordPolicy.plan` chose for one record (module docstring).

    Inputs: ``samples``, ``dt``, ``f_low`` (Hz), ``bandwidth`` (Hz), ``chunked``.
    Choices: ``selection`` (first and end sample of the selection segment), ``methods``
    (the candidates), ``skipped`` (:class:`Skip` each), ``rule`` (the selection bound
    and why), ``streamed`` (methods whose whole-record fit uses the streamed core).
    """

    samples: int
    dt: float
    f_low: float
    bandwidth: float
    chunked: bool
    selection: tuple[int, int]
    methods: tuple[str, ...]
    skipped: tuple[Skip, ...]
    streamed: tuple[str, ...]
    rule: str

    def as_dict(self) -> dict[str, Any]:
        """Plain values, for ``model.options["long_record"]``."""
        d = dataclasses.asdict(self)
        d["skipped"] = [
            {"method": s.method, "reason": s.reason.value, "detail": s.detail} for s in self.skipped
        ]
        return d


@dataclass(frozen=True)
class LongRecordPolicy:
    """How ``identify`` bounds its work on long records (module docstring).

    ``long_samples``: records with more samples take the bounded path;
    ``selection_periods``, ``min_selection_samples``, ``max_selection_samples``: the
    selection segment; ``memory_budget``, ``work_budget``: bytes and flops beyond
    linear a whole-record fit may take;
    ``refine_std``, ``max_refine_samples``: the refinement part.  Pass one as
    ``identify(..., long_record=LongRecordPolicy(...))``; ``long_record=False`` turns
    the bounded path off.

    Examples
    --------
    >>> policy = LongRecordPolicy(long_samples=20_000)
    >>> policy.selection_samples(10**6, 1e-3, 3.0)
    10000
    """

    long_samples: int = LONG_SAMPLES
    selection_periods: float = SELECTION_PERIODS
    min_selection_samples: int = MIN_SELECTION_SAMPLES
    max_selection_samples: int = MAX_SELECTION_SAMPLES
    memory_budget: float = MEMORY_BUDGET
    work_budget: float = WORK_BUDGET
    refine_std: float = REFINE_RELATIVE_STD
    max_refine_samples: int = MAX_REFINE_SAMPLES
    _checked: bool = field(default=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        for name in (
            "long_samples",
            "min_selection_samples",
            "max_selection_samples",
            "max_refine_samples",
        ):
            check_positive_int(getattr(self, name), name, 16)
        for name in ("selection_periods", "memory_budget", "work_budget", "refine_std"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, int | float) or not v > 0:
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if self.min_selection_samples > self.max_selection_samples:
            raise ValueError(
                f"min_selection_samples ({self.min_selection_samples}) exceeds "
                f"max_selection_samples ({self.max_selection_samples})"
            )

    def selection_samples(self, ns: int, dt: float, f_low: float) -> int:
        """Samples of the selection segment: ``selection_periods / f_low`` seconds,
        within ``[min_selection_samples, max_selection_samples]`` and the record."""
        want = self.selection_periods / (f_low * dt) if f_low > 0 else np.inf
        n = min(max(want, self.min_selection_samples), self.max_selection_samples)
        return int(min(ns, np.ceil(n)))

    def _skip(self, name: str, ns: int, m: int, l: int, chunked: bool) -> Skip | None:
        """Why ``name`` cannot be fitted on the whole record, or None (module docstring)."""
        if name in STREAMED_METHODS:
            return None  # the streamed core: memory of one batch, linear work
        if chunked:
            text = "the record is read in chunks and the method has no streamed core"
            return Skip(name, SkipReason.NOT_STREAMED, text)
        cost = whole_record_cost(name, ns, m, l)
        if cost is None:
            text = (
                "its cost on a long record is not known here; ask for it with method= "
                "to run it on the whole record"
            )
            return Skip(name, SkipReason.NO_COST_MODEL, text)
        if cost[0] > self.memory_budget:
            text = (
                f"its fit on the whole record ({ns} samples) needs about "
                f"{cost[0] / 2**30:.3g} GiB, above the budget of "
                f"{self.memory_budget / 2**30:.3g} GiB"
            )
            return Skip(name, SkipReason.MEMORY, text)
        if cost[1] > self.work_budget:
            text = (
                f"its fit on the whole record ({ns} samples) takes about {cost[1]:.2g} "
                f"flops (a QR of its regressor), above the budget of {self.work_budget:.2g}"
            )
            return Skip(name, SkipReason.WORK, text)
        return None

    def plan(
        self,
        ns: int,
        dt: float,
        m: int,
        l: int,
        f_low: float,
        bandwidth: float,
        methods: list[str],
        chunked: bool,
    ) -> LongRecordPlan:
        """The plan for a record of ``ns`` samples at interval ``dt`` with ``m`` inputs,
        ``l`` outputs, lowest significant output frequency ``f_low`` and bandwidth (Hz);
        ``methods``: the candidates asked for; ``chunked``: read in chunks."""
        n_sel = self.selection_samples(ns, dt, f_low)
        a = (ns - n_sel) // 2
        kept: list[str] = []
        skipped: list[Skip] = []
        streamed: list[str] = []
        for name in methods:
            skip = self._skip(name, ns, m, l, chunked)
            if skip is not None:
                skipped.append(skip)
                continue
            kept.append(name)
            cost = whole_record_cost(name, ns, m, l)
            big = cost is not None and cost[0] > self.memory_budget
            if name in STREAMED_METHODS and (chunked or big):
                streamed.append(name)
        periods = n_sel * dt * f_low
        rule = (
            f"selection on samples {a}..{a + n_sel - 1} ({n_sel} of {ns}, the middle): "
            f"{self.selection_periods:g} periods of the lowest significant output frequency "
            f"{f_low:.4g} Hz, within [{self.min_selection_samples}, "
            f"{self.max_selection_samples}] samples"
        )
        if periods < self.selection_periods * (1 - 1e-9) and n_sel < ns:
            rule += f" (capped: the segment holds {periods:.3g} periods)"
        return LongRecordPlan(
            samples=ns,
            dt=dt,
            f_low=f_low,
            bandwidth=bandwidth,
            chunked=chunked,
            selection=(a, a + n_sel),
            methods=tuple(kept),
            skipped=tuple(skipped),
            streamed=tuple(streamed),
            rule=rule,
        )


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
    """Whether :func:`hdpbsid.identify` takes the bounded path: ``method="auto"`` on one
    record (or a :class:`~hdpbsid.data.chunked.ChunkedRecord`) longer than the
    policy's ``long_samples``; ``policy=False`` never."""
    if not isinstance(t, np.ndarray | list | tuple):  # cheap first: no import for arrays
        from hdpbsid.data.chunked import ChunkedRecord

        if isinstance(t, ChunkedRecord):
            return True
    if policy is False or method != "auto" or y is None:
        return False
    if isinstance(t, list | tuple) and (len(t) == 0 or isinstance(t[0], list | tuple)):
        return False
    policy = _policy(policy)
    return int(np.shape(y)[0]) > policy.long_samples


def _policy(policy: Any) -> LongRecordPolicy:
    if policy is None or policy is True:
        return LongRecordPolicy()
    if not isinstance(policy, LongRecordPolicy):
        raise TypeError(
            f"long_record must be a LongRecordPolicy, None or False, got {type(policy).__name__}"
        )
    return policy


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
    from hdpbsid.bases.segments import LOW_FRACTION
    from hdpbsid.data.chunked import ChunkedRecord
    from hdpbsid.methods.chunked import averaged_spectra
    from hdpbsid.models.model import LinearTrend, _set_levels
    from hdpbsid.refine.pem import REFINE_CHOICES, is_uniform
    from hdpbsid.selection.auto import AUTO_METHODS

    policy = _policy(long_record)
    if refine not in REFINE_CHOICES:
        raise ValueError(f"refine must be one of {REFINE_CHOICES}, got {refine!r}")
    bar = _Progress(progress, 6)
    t_start = time.perf_counter()
    trend = None
    try:
        bar.stage("levels")
        if isinstance(t, ChunkedRecord):
            if u is not None or y is not None:
                raise ValueError("with a ChunkedRecord in t, leave u and y out")
            if detrend == "linear":
                raise ValueError(
                    "detrend='linear' is not available for a record read in chunks; "
                    "use 'mean' or None"
                )
            raw = t
            chunked = True
            u0, y0 = _levels(raw, bar) if detrend == "mean" else (np.zeros(t.m), np.zeros(t.l))
            rec = dataclasses.replace(raw, read=_Centred(raw.read, u0, y0))
            op_info: Any = {"u0": u0.tolist(), "y0": y0.tolist(), "samples": raw.ns}
        else:
            from hdpbsid.data.detrend import detrend_record

            tt, ua, yy = check_data(t, u, y)
            if not is_uniform(tt):
                raise ValueError(
                    "t: the bounded path for long records needs uniform sampling; "
                    "pass long_record=False for the whole-record path"
                )
            ud, yd, lv = detrend_record(tt, ua, yy, detrend)
            chunked = False
            h = float((tt[-1] - tt[0]) / (tt.size - 1))
            rec = ChunkedRecord.from_arrays(ud if ua.shape[1] else None, yd, h, float(tt[0]))
            u0, y0 = lv.u0, lv.y0
            if lv.t_ref is not None:
                trend = LinearTrend(lv.t_ref, lv.u_slope, lv.y_slope)
            op_info = lv.as_dict()
        reading = dataclasses.replace(rec, read=_Ticking(rec.read, bar))
        # 1. spectrum
        bar.stage("spectrum")
        bar.reading(rec.ns, "spectrum")
        from hdpbsid.bases.basis_domain import spectra_data_bandwidth, spectrum_bandwidth

        w, Pu, Py = averaged_spectra(reading, min(rec.ns, 2**16))
        bar.end_reading()
        wb = spectra_data_bandwidth(w, Pu, w, Py)
        w_low = spectrum_bandwidth(w, Py, LOW_FRACTION)
        # 2. plan
        opts = dict(options)
        asked = opts.pop("methods", None)
        if asked is None:
            from hdpbsid.methods.registry import is_available

            asked = [m for m in AUTO_METHODS if is_available(m)]
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
        # 3. selection on the segment
        bar.stage(f"selection on {plan.selection[1] - plan.selection[0]} samples")
        from hdpbsid.selection.auto import identify_auto

        seg = _segment(rec, *plan.selection)
        t_sel = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            chosen = identify_auto(
                *seg, order=order, methods=list(plan.methods), refined=refine is not None, **opts
            )
        t_sel = time.perf_counter() - t_sel
        method, n = chosen.report.method, chosen.n
        # 4. the whole record
        bar.stage(f"{method} order {n} on {rec.ns} samples")
        model = _whole_record(method, n, rec, reading, chosen, opts, plan, bar)
        # 5. refinement
        info: dict[str, Any] = {}
        if refine is not None:
            bar.stage("refinement")
            model = _refine(model, chosen, rec, plan, policy, refine, info)
        bar.stage("done")
    finally:
        bar.close()
    table = [c.as_dict() for c in chosen.report.candidates]
    table += [_skip_row(s) for s in plan.skipped]
    rule = f"{plan.rule}; {chosen.report.selection_rule}"
    model.options["selection"] = table
    model.options["order_selection"] = [r for r in table if r["method"] == method]
    model.options["selection_rule"] = rule
    model.options["long_record"] = {
        **plan.as_dict(),
        "policy": {k: v for k, v in dataclasses.asdict(policy).items() if not k.startswith("_")},
        "selection_time": t_sel,
        "time": time.perf_counter() - t_start,
        **info,
    }
    _set_levels(model, u0, y0, trend)
    model.options.setdefault("refine", None)
    model.options["method"] = method
    model.report = model.report.but(
        method=method,
        candidates=tuple(Candidate.from_dict(r) for r in table),
        selection_rule=rule,
        warm_start=None,
    )
    model.options["detrend"] = detrend
    model.options["operating_points"] = op_info
    model.options["requested_method"] = "auto"
    model.options["requested_order"] = order
    model.options["requested_options"] = dict(options)
    return model


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
    from hdpbsid.methods.registry import get_method
    from hdpbsid.selection.auto import refit_keeps

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
    settings = {
        **given,
        **refit_keeps(func, chosen, given),
        **({} if refit is None else refit.value),
    }
    t, u, y = _segment(rec, 0, rec.ns)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = func(t, u, y, order=n, **settings)
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
) -> Any:
    """The refinement on a bounded part and the choice between it and ``model``
    (module docstring); what was done goes to ``info``."""
    from hdpbsid.models.criteria import choose_smallest_adequate, default_windows
    from hdpbsid.refine.pem import refine_pem, warm_start_option
    from hdpbsid.selection.auto import score_model
    from hdpbsid.selection.feedback import refine_decision

    t0 = time.perf_counter()
    a, b = plan.selection
    part = _segment(rec, a, b)
    if refine == "auto":
        do, rule, stats = refine_decision(model, *part, True)
        info["refine_statistics"] = stats
        if not do:
            model.options["refine_rule"] = rule
            model.report = model.report.but(refine_decision=Choice(False, rule))
            return model
    else:
        rule = "pem"
    # the selection's candidate refined on its estimation part: a second starting point
    start, warm = model, chosen.report.warm_start
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        refined = refine_pem(start, *part, warm_start=warm)
        rel = _relative_std(refined)
        parts = [b - a]
        converged = refined is not start and refined.report.converged
        want = int(np.ceil((b - a) * (rel / policy.refine_std) ** 2)) if converged else 0
        size = min(rec.ns, policy.max_refine_samples, want)
        if size > b - a:
            # the part whose predicted std meets the target: N s^2 / target^2 samples
            a = (rec.ns - size) // 2
            b = a + size
            again = refine_pem(start, *_segment(rec, a, b), warm_start=warm_start_option(refined))
            if again is not start and again.report.converged:
                refined, rel = again, _relative_std(again)
            parts.append(b - a)
    info["refine_samples"] = parts
    info["refine_part"] = (a, b)
    info["refine_relative_std"] = rel
    if not converged:
        text = (
            f"{rule}; the refinement on samples {a}..{b - 1} did not converge: the "
            f"whole-record subspace model is kept"
        )
        model.options["refine_rule"] = text
        model.options["refine_time"] = time.perf_counter() - t0
        model.report = model.report.but(refine_decision=Choice(False, text))
        return model
    # judge the two on a segment outside the refinement part
    n_val = plan.selection[1] - plan.selection[0]
    val_ab = (b, min(rec.ns, b + n_val)) if rec.ns - b >= a else (max(0, a - n_val), a)
    choice = "refined"
    if val_ab[1] - val_ab[0] >= 2 * n_val // 3:
        val = _segment(rec, *val_ab)
        windows = default_windows(val_ab[1] - val_ab[0], max(model.n, 1))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            e_ref, _ = score_model(refined, val, windows)
            e_sub, _ = score_model(model, val, windows)
        if e_ref.finite or e_sub.finite:
            # the whole-record model listed first: the refinement on a part replaces it
            # only when it predicts the held-out segment better by one standard error
            k, z = choose_smallest_adequate([e_sub, e_ref])
            choice = "whole-record subspace" if k == 0 else "refined"
            info["refine_judgement"] = {
                "samples": val_ab,
                "subspace_error": e_sub.total,
                "refined_error": e_ref.total,
                "z": z,
            }
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
