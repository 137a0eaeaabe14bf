"""The policy of the bounded path for long records: which methods run, on which samples.

:class:`LongRecordPolicy` holds the numbers of the bounded path of
:func:`hdpbsid.selection.long_records.identify_long` (when a record is long, the selection
segment, the budgets of a whole-record fit, the refinement's target) and turns a record's
summary (samples, interval, channels, lowest significant output frequency) into a
:class:`LongRecordPlan`: the selection segment, the candidate methods and, for every method
left out, a :class:`Skip` with its typed :class:`SkipReason`.  The whole-record cost of a
method comes from :class:`CostModel` (:func:`whole_record_cost`).  Nothing here reads data:
the plan is decided before anything runs, so that no candidate is left to run out of memory
(the reasoning of each number is in the module docstring of
:mod:`hdpbsid.selection.long_records`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np

from hdpbsid.data.checks import check_positive_int

__all__ = [
    "CostModel",
    "LongRecordPlan",
    "LongRecordPolicy",
    "Skip",
    "SkipReason",
    "as_policy",
    "whole_record_cost",
]


class SkipReason(str, Enum):
    """Why a method is not a candidate on a long record."""

    MEMORY = "memory"  #: its whole-record fit would exceed the memory budget
    WORK = "work"  #: its whole-record fit's arithmetic would exceed the work budget
    NOT_STREAMED = "not streamed"  #: the record is read in chunks, the method has no streamed core
    NO_COST_MODEL = "no cost model"  #: its cost on long records is not known here


@dataclass(frozen=True)
class Skip:
    """A method left out of the selection: its name, the reason and the numbers.

    Attributes
    ----------
    method : str
        The method's name.
    reason : SkipReason
        Why it is left out.
    detail : str
        The numbers behind the reason, for the selection table.
    """

    method: str
    reason: SkipReason
    detail: str

    def status(self) -> str:
        """The ``status`` of its row in the selection table.

        Returns
        -------
        str
            ``"skipped: <reason>: <detail>"``.

        Examples
        --------
        >>> Skip("dt", SkipReason.MEMORY, "too large").status()
        'skipped: memory: too large'
        """
        return f"skipped: {self.reason.value}: {self.detail}"


@dataclass(frozen=True)
class CostModel:
    """What a whole-record fit of each method costs, as :func:`whole_record_cost` counts it.

    ``dt`` builds its VARX regressor ``ns x c`` (``c = p (m + l)``, ``p`` the largest past
    window of its default rule, :func:`hdpbsid.methods.dt.default_windows`) and holds one
    working copy for its QR (``2 ns c^2`` flops); the windowed basis-domain methods hold
    a fixed number of bytes per sample and channel and do arithmetic linear in the
    samples (fixed windows).

    Attributes
    ----------
    varx_bytes_per_entry : float
        Bytes per entry of ``dt``'s regressor with its working copy.
    linear_bytes_per_sample_channel : int
        Traced peak bytes per sample and channel (``m + l``) of the windowed methods.
    windowed : tuple of str
        The methods whose whole-record fit is windowed (linear cost).
    streamed : tuple of str
        The methods with a streamed core (memory of one batch:
        :mod:`hdpbsid.methods.chunked`).
    """

    #: two float64 copies (the regressor and its QR's work array); measured: 699 MB at
    #: 10^5 samples and 400 columns, 17 bytes per entry
    varx_bytes_per_entry: float = 16.0
    #: measured (tracemalloc, 3 10^5 samples, one input and one output): 320-390 bytes per
    #: sample, i.e. 160-195 per sample and channel, rounded up to a power of two
    linear_bytes_per_sample_channel: int = 256
    #: the windowed fits: fixed windows, so memory and work linear in the samples
    windowed: tuple[str, ...] = ("hermite", "laguerre", "legendre", "chebyshev", "sl")
    #: the streamed core covers HD-PBSID only
    streamed: tuple[str, ...] = ("hermite",)

    def cost(self, method: str, ns: int, m: int, l: int) -> tuple[float, float] | None:
        """Estimated peak memory (bytes) and arithmetic (flops) of ``method``'s fit.

        Parameters
        ----------
        method : str
            The method's name.
        ns : int
            Samples of the record, held in memory.
        m : int
            Number of inputs.
        l : int
            Number of outputs.

        Returns
        -------
        tuple of float or None
            ``(bytes, flops)``; the windowed methods' flops are counted as 0 against the
            work budget (it bounds superlinear work); None when there is no estimate.
        """
        if method == "dt":
            from hdpbsid.methods.dt import P_CAP, SAMPLES_PER_REGRESSOR

            c = min(P_CAP, ns // (SAMPLES_PER_REGRESSOR * (m + l))) * (m + l)
            return self.varx_bytes_per_entry * ns * c, 2.0 * ns * c**2
        if method in self.windowed:
            return float(self.linear_bytes_per_sample_channel * ns * (m + l)), 0.0
        return None


#: the cost model the policy uses
COSTS = CostModel()


def whole_record_cost(method: str, ns: int, m: int, l: int) -> tuple[float, float] | None:
    """Estimated peak memory (bytes) and arithmetic (flops) of ``method``'s fit on a record.

    The record of ``ns`` samples with ``m`` inputs and ``l`` outputs is held in memory;
    the counts are those of :class:`CostModel` (``dt``: its VARX regressor and QR; the
    windowed methods: bytes linear in the samples, arithmetic counted as 0).

    Parameters
    ----------
    method : str
        The method's name.
    ns : int
        Samples of the record.
    m : int
        Number of inputs.
    l : int
        Number of outputs.

    Returns
    -------
    tuple of float or None
        ``(bytes, flops)``, or None when there is no estimate.

    Examples
    --------
    >>> whole_record_cost("hermite", 10**6, 1, 1)
    (512000000.0, 0.0)
    >>> whole_record_cost("my-method", 10**6, 1, 1) is None
    True
    """
    return COSTS.cost(method, ns, m, l)


@dataclass(frozen=True)
class LongRecordPlan:
    """What :meth:`LongRecordPolicy.plan` chose for one record.

    Attributes
    ----------
    samples : int
        Samples of the record (input).
    dt : float
        Sampling interval (input).
    f_low : float
        Lowest significant output frequency, Hz (input).
    bandwidth : float
        Data bandwidth, Hz (input).
    chunked : bool
        Whether the record is read in chunks (input).
    selection : tuple of int
        First and end sample of the selection segment.
    methods : tuple of str
        The candidate methods.
    skipped : tuple of Skip
        The methods left out, each with its reason.
    streamed : tuple of str
        The methods whose whole-record fit uses the streamed core.
    rule : str
        The selection segment's bound and why.
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
        """Plain values, for ``model.options["long_record"]``.

        Returns
        -------
        dict
            The fields; ``skipped`` as a list of ``{"method", "reason", "detail"}``.
        """
        d = dataclasses.asdict(self)
        d["skipped"] = [
            {"method": s.method, "reason": s.reason.value, "detail": s.detail} for s in self.skipped
        ]
        return d


@dataclass(frozen=True)
class LongRecordPolicy:
    """How ``identify`` bounds its work on long records.

    Pass one as ``identify(..., long_record=LongRecordPolicy(...))``; ``long_record=False``
    turns the bounded path off.  The reasoning of every default is in the module
    docstring of :mod:`hdpbsid.selection.long_records`.

    Parameters
    ----------
    long_samples : int
        Records with more samples take the bounded path.
    selection_periods : float
        Periods of the lowest significant output frequency in the selection segment.
    min_selection_samples : int
        Fewest samples of the selection segment.
    max_selection_samples : int
        Most samples of the selection segment.
    memory_budget : float
        Bytes a whole-record fit may take; larger ones are skipped.
    work_budget : float
        Flops beyond linear a whole-record fit may take; larger ones are skipped.
    refine_std : float
        Target relative standard deviation of the refined eigenvalues.
    max_refine_samples : int
        Most samples the refinement runs on.

    Raises
    ------
    ValueError
        A count that is not an integer ``>= 16``, a budget or period that is not a positive
        number, or ``min_selection_samples > max_selection_samples``.

    Examples
    --------
    >>> policy = LongRecordPolicy(long_samples=20_000)
    >>> policy.selection_samples(10**6, 1e-3, 3.0)
    10000
    """

    #: above this the whole-record default path costs about a CPU millisecond per sample
    #: and more (its sweep fits 32 candidates on two thirds of the record; ``dt``'s
    #: past-window criterion and the refinement on all of it)
    long_samples: int = 50_000
    #: two of HD-PBSID's default windows (``WINDOW_PERIODS = 10`` periods each,
    #: :mod:`hdpbsid.bases.segments`) to estimate, one to score
    selection_periods: float = 30.0
    #: the held-out third then estimates the residual variance to ``sqrt(2 / 1365)``,
    #: 4 % relative, below the differences between an adequate and an inadequate order
    min_selection_samples: int = 4096
    #: the cost bound: the sweep of every candidate costs a few CPU seconds per 10^4 samples
    max_selection_samples: int = 32_768
    #: 1 GiB: a whole-record fit above it is skipped
    memory_budget: float = 2**30
    #: seconds on one core at a few Gflop/s: the cost of a long record must stay linear
    work_budget: float = 1e10
    #: a tenth of a percent, below what the model's structural errors (linearity, the input
    #: hold between samples) leave on measured systems
    refine_std: float = 1e-3
    #: the refinement's Jacobian holds ``samples x parameters``
    max_refine_samples: int = 200_000

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
        """Samples of the selection segment.

        ``selection_periods / f_low`` seconds, within ``[min_selection_samples,
        max_selection_samples]`` and the record.

        Parameters
        ----------
        ns : int
            Samples of the record.
        dt : float
            Sampling interval.
        f_low : float
            Lowest significant output frequency (Hz); ``<= 0``: unknown (the most samples).

        Returns
        -------
        int
            The segment's samples.
        """
        want = self.selection_periods / (f_low * dt) if f_low > 0 else np.inf
        n = min(max(want, self.min_selection_samples), self.max_selection_samples)
        return int(min(ns, np.ceil(n)))

    def _skip(self, name: str, ns: int, m: int, l: int, chunked: bool) -> Skip | None:
        """Why ``name`` cannot be fitted on the whole record, or None."""
        if name in COSTS.streamed:
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

    def _selection_rule(self, ns: int, dt: float, f_low: float, n_sel: int) -> str:
        """The report of the selection segment's bound."""
        a = (ns - n_sel) // 2
        periods = n_sel * dt * f_low
        rule = (
            f"selection on samples {a}..{a + n_sel - 1} ({n_sel} of {ns}, the middle): "
            f"{self.selection_periods:g} periods of the lowest significant output frequency "
            f"{f_low:.4g} Hz, within [{self.min_selection_samples}, "
            f"{self.max_selection_samples}] samples"
        )
        # 1e-9: rounding of the periods' product, far below one sample's share
        if periods < self.selection_periods * (1 - 1e-9) and n_sel < ns:
            rule += f" (capped: the segment holds {periods:.3g} periods)"
        return rule

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
        """The plan for one record: the selection segment and the candidate methods.

        A method is a candidate only if its fit on the whole record is possible: a streamed
        core, or (in memory) a cost estimate within the budgets; the others are skipped
        with their reason.

        Parameters
        ----------
        ns : int
            Samples of the record.
        dt : float
            Sampling interval.
        m : int
            Number of inputs.
        l : int
            Number of outputs.
        f_low : float
            Lowest significant output frequency (Hz).
        bandwidth : float
            Data bandwidth (Hz), reported.
        methods : list of str
            The candidates asked for.
        chunked : bool
            Whether the record is read in chunks.

        Returns
        -------
        LongRecordPlan
            The plan.
        """
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
            if name in COSTS.streamed and (chunked or big):
                streamed.append(name)
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
            rule=self._selection_rule(ns, dt, f_low, n_sel),
        )


def as_policy(policy: Any) -> LongRecordPolicy:
    """The policy a ``long_record`` argument names.

    Parameters
    ----------
    policy : LongRecordPolicy, True or None
        A policy, or True / None for the default one.

    Returns
    -------
    LongRecordPolicy
        The policy.

    Raises
    ------
    TypeError
        Anything else.

    Examples
    --------
    >>> as_policy(None) == LongRecordPolicy()
    True
    """
    if policy is None or policy is True:
        return LongRecordPolicy()
    if not isinstance(policy, LongRecordPolicy):
        raise TypeError(
            f"long_record must be a LongRecordPolicy, None or False, got {type(policy).__name__}"
        )
    return policy
