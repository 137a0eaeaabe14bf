"""Identification data as a list of records: one experiment, several, or windows of one.

Every method accepts either one record ``t, u, y`` (the :func:`scipy.signal.lsim`
convention) or, in place of ``t``, a list of ``(t_i, u_i, y_i)`` tuples (then ``u`` and
``y`` must be ``None``): several experiments on the same system, each with its own time
axis and initial state.  :func:`as_records` turns both forms into a list of
:class:`Record`; :func:`split_windows` cuts a long record into windows that are then
treated exactly like several experiments.

Time is kept relative to each record's first sample (``Record.t = t - t[0]``,
``Record.t0 = t[0]``): records stamped with absolute (Unix) time, ``t ~ 1.7e9 s``, carry
an absolute rounding of ``ulp(1.7e9) = 2.4e-7 s`` in every stamp, and every later time
computation (sample spacing, basis time maps, quadrature nodes) must not add to it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_data, check_varies, is_uniform, time_resolution

__all__ = [
    "Record",
    "Labels",
    "Dataset",
    "as_records",
    "split_windows",
    "is_record_list",
    "relative_times",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Record:
    """One checked record with its time relative to its first sample.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Times relative to the first sample (``t[0] = 0``).
    u : ndarray, shape (Ns, m)
        Input.
    y : ndarray, shape (Ns, l)
        Output.
    t0 : float, optional
        Absolute time of the first sample.
    resolution : float, optional
        Resolution of the original stamps (:func:`hdpbsid.data.checks.time_resolution`).
    operating_point : tuple of ndarray, optional
        The levels ``(u0 (m,), y0 (l,))`` removed from ``u`` and ``y`` before they were
        stored (:mod:`hdpbsid.data.detrend`); None when nothing was removed.

    Attributes
    ----------
    ns : int
        Number of samples.
    duration : float
        ``t[-1] - t[0]``.
    uniform : bool
        Whether the record is uniformly sampled (:func:`hdpbsid.data.checks.is_uniform` of
        its relative times, ``k h`` exactly for a record made uniform by
        :func:`relative_times`): the one test the methods and the selection read.
    """

    t: Array
    u: Array
    y: Array
    t0: float = 0.0
    resolution: float = 0.0
    operating_point: tuple[Array, Array] | None = None

    @property
    def ns(self) -> int:
        """Number of samples."""
        return int(self.t.shape[0])

    @property
    def duration(self) -> float:
        """``t[-1] - t[0]``."""
        return float(self.t[-1])

    @property
    def uniform(self) -> bool:
        """Whether the record is uniformly sampled."""
        return is_uniform(self.t)


@dataclass(frozen=True)
class Labels:
    """The channel names and the time unit of a :class:`Dataset` (what a user gave
    :func:`hdpbsid.identify`; None where nothing was given).

    Parameters
    ----------
    inputs, outputs : tuple of str, optional
        One name per input and output channel.
    time_unit : str, optional
        The unit of the times.

    Examples
    --------
    >>> Labels(("elevator",), ("q", "theta"), "s").outputs
    ('q', 'theta')
    """

    inputs: tuple[str, ...] | None = None
    outputs: tuple[str, ...] | None = None
    time_unit: str | None = None


@dataclass(frozen=True)
class Dataset:
    """Several checked records of one system, made once and passed down whole.

    Made at the front door (:func:`hdpbsid.identify` turns a list of ``(t_i, u_i, y_i)``
    records into one after detrending them) and given to the methods in place of a list:
    :func:`as_records` returns its records without checking them again.  Iterating it, or
    indexing it with an integer, gives ``(t_i, u_i, y_i)`` tuples with the times relative
    to each record's first sample (the absolute start is ``records[i].t0``), so code
    written for the list form reads it unchanged; a slice is a :class:`Dataset`.

    Parameters
    ----------
    records : tuple of Record
        At least one record; every one with the channel counts of the first.
    labels : Labels, optional
        The channel names and time unit (:meth:`described`).

    Attributes
    ----------
    m, l : int
        Input and output channels.
    uniform : bool
        Whether every record is uniformly sampled (:func:`hdpbsid.data.checks.is_uniform`
        of its relative times, which are ``k h`` exactly for a uniform record).

    Raises
    ------
    TypeError
        If an entry is not a :class:`Record`.
    ValueError
        If there is no record, or the channel counts differ.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> t = 100.0 + np.arange(50) * 0.1
    >>> data = Dataset.of([(t, rng.standard_normal(50), rng.standard_normal(50))] * 3)
    >>> len(data), data.m, data.l, data.uniform, data.records[0].t0
    (3, 1, 1, True, 100.0)
    >>> tt, uu, yy = data[0]
    >>> float(tt[0]), uu.shape
    (0.0, (50, 1))
    """

    records: tuple[Record, ...]
    labels: Labels | None = None

    def __post_init__(self) -> None:
        records = tuple(self.records)
        if not records:
            raise ValueError("records: a Dataset needs at least one record")
        for i, r in enumerate(records):
            if not isinstance(r, Record):
                raise TypeError(f"records[{i}] must be a Record, got {type(r).__name__}")
            if (r.u.shape[1], r.y.shape[1]) != (records[0].u.shape[1], records[0].y.shape[1]):
                raise ValueError(
                    f"records[{i}]: has {r.u.shape[1]} input(s) and {r.y.shape[1]} output(s), "
                    f"records[0] has {records[0].u.shape[1]} and {records[0].y.shape[1]}"
                )
        object.__setattr__(self, "records", records)
        if self.labels is not None and not isinstance(self.labels, Labels):
            raise TypeError(f"labels must be a Labels, got {type(self.labels).__name__}")

    @classmethod
    def of(cls, t: Any, u: Any = None, y: Any = None, min_samples: int = 2) -> Dataset:
        """The records of ``(t, u, y)`` or of a list of ``(t_i, u_i, y_i)``, checked once.

        Parameters
        ----------
        t, u, y, min_samples
            As :func:`as_records` takes them.

        Returns
        -------
        Dataset

        Raises
        ------
        TypeError, ValueError
            As :func:`as_records` raises them.
        """
        return cls(tuple(as_records(t, u, y, min_samples)))

    def described(self, labels: Labels | None = None, operating_points: Any = None) -> Dataset:
        """This Dataset with its labels and each record's operating point (the levels
        detrending removed), as :func:`hdpbsid.identify` makes it at the front door.

        Parameters
        ----------
        labels : Labels, optional
            The channel names and time unit.
        operating_points : sequence of (u0, y0), optional
            One pair per record (None for a record whose levels were not removed).

        Returns
        -------
        Dataset
            The same records (arrays shared, not copied), described.

        Raises
        ------
        ValueError
            If ``operating_points`` does not give one entry per record.

        Examples
        --------
        >>> import numpy as np
        >>> t = np.arange(20) * 0.5
        >>> data = Dataset.of(t, None, np.sin(t)).described(
        ...     Labels(outputs=("q",), time_unit="s"), [(np.zeros(0), np.array([0.1]))]
        ... )
        >>> data.labels.time_unit, data.records[0].operating_point[1]
        ('s', array([0.1]))
        """
        records = self.records
        if operating_points is not None:
            ops = list(operating_points)
            if len(ops) != len(records):
                raise ValueError(
                    f"operating_points: expected {len(records)} entries (one per record), "
                    f"got {len(ops)}"
                )
            records = tuple(
                replace(r, operating_point=op) for r, op in zip(records, ops, strict=True)
            )
        return Dataset(records, labels)

    def __len__(self) -> int:
        return len(self.records)

    def __iter__(self) -> Any:
        return ((r.t, r.u, r.y) for r in self.records)

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, slice):
            return Dataset(self.records[key], self.labels)
        r = self.records[key]
        return (r.t, r.u, r.y)

    def __repr__(self) -> str:
        ns = ", ".join(str(r.ns) for r in self.records[:6])
        more = ", ..." if len(self.records) > 6 else ""
        return f"Dataset({len(self)} records of {ns}{more} samples, m={self.m}, l={self.l})"

    @property
    def m(self) -> int:
        """Input channels."""
        return int(self.records[0].u.shape[1])

    @property
    def l(self) -> int:  # noqa: E743 - l is the standard name for the number of outputs
        """Output channels."""
        return int(self.records[0].y.shape[1])

    @property
    def uniform(self) -> bool:
        """Whether every record is uniformly sampled."""
        return all(r.uniform for r in self.records)


def is_record_list(t: Any) -> bool:
    """Whether ``t`` is a list of ``(t_i, u_i, y_i)`` records rather than a time vector.

    Parameters
    ----------
    t : object
        The ``t`` argument of a method.

    Returns
    -------
    bool
        True when ``t`` is a :class:`Dataset`, or a non-empty list or tuple whose first entry
        is a 3-sequence with a 1-D first element.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(5.0)
    >>> is_record_list(t), is_record_list([(t, t, t)])
    (False, True)
    """
    if isinstance(t, Dataset):
        return True
    if not isinstance(t, list | tuple) or len(t) == 0:
        return False
    first = t[0]
    return isinstance(first, list | tuple) and len(first) == 3 and np.ndim(first[0]) == 1


def _one(t: Any, u: Any, y: Any, min_samples: int) -> Record:
    t, u, y = check_data(t, u, y, min_samples=min_samples)
    check_varies(y)
    return Record(relative_times(t), u, y, float(t[0]), time_resolution(t))


def relative_times(t: Array) -> Array:
    """Times relative to the first sample; exactly ``k h`` for a uniform grid.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Absolute, strictly increasing stamps.

    Returns
    -------
    ndarray, shape (Ns,)
        ``t - t[0]``, or ``k h`` with ``h`` the mean spacing when ``t`` is uniform
        (:func:`hdpbsid.data.checks.is_uniform`, judged on the stamps as given, so with
        their resolution).

    Notes
    -----
    The deviations a uniform grid is allowed are the rounding of its stamps and a relative
    ``1e-6`` of the spacing, which no path resolves (one sampled model serves every step).
    Kept in the relative axis they would be judged again without the stamps' resolution,
    which ``t - t[0]`` no longer shows (a record stamped with Unix time, ``t ~ 1.7e9``,
    carries ``2.4e-7 s`` per stamp), and the same record would be uniform from ``t = 0``
    but not from its absolute start.  As ``k h`` the relative axis is the same, to the
    rounding of ``h``, whatever the absolute start.

    Examples
    --------
    >>> import numpy as np
    >>> t = 1.7e9 + 0.01 * np.arange(1000)  # Unix time: each stamp rounded to 2.4e-7 s
    >>> bool(np.ptp(np.diff(t - t[0])) > 1e-8), bool(np.ptp(np.diff(relative_times(t))) < 1e-12)
    (True, True)
    """
    tr = t - t[0]
    if t.size > 2 and is_uniform(t):
        return np.arange(t.size) * (tr[-1] / (t.size - 1))
    return tr


def as_records(t: Any, u: Any = None, y: Any = None, min_samples: int = 2) -> list[Record]:
    """Normalise ``(t, u, y)`` or a list of ``(t_i, u_i, y_i)`` tuples to checked records.

    Parameters
    ----------
    t : array_like, shape (Ns,), list of (t_i, u_i, y_i), or Dataset
        One record's times, or several records (experiments on the same system, each with
        its own time axis and initial state); a :class:`Dataset`'s records are returned
        as they are (checked when it was made).
    u : array_like, shape (Ns, m), or None, optional
        The input of one record; ``None`` with a list.
    y : array_like, shape (Ns, l), or None, optional
        The output of one record; ``None`` with a list.
    min_samples : int, optional
        The fewest samples a record may have.

    Returns
    -------
    list of Record
        Each checked with :func:`hdpbsid.data.checks.check_data` and
        :func:`hdpbsid.data.checks.check_varies`.

    Raises
    ------
    TypeError
        If ``u`` or ``y`` is given with a list, or an entry of the list is not a
        ``(t, u, y)`` tuple with a 1-D ``t``.
    ValueError
        If a record fails its checks (the message names its index), or the records'
        channel counts differ.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(50) * 0.1
    >>> rng = np.random.default_rng(0)
    >>> recs = as_records([(t, rng.standard_normal(50), rng.standard_normal(50))] * 2)
    >>> len(recs), recs[0].u.shape
    (2, (50, 1))
    """
    if isinstance(t, Dataset):
        return _dataset_records(t, u, y, min_samples)
    if not is_record_list(t):
        if isinstance(t, list | tuple) and len(t) > 0 and isinstance(t[0], list | tuple):
            raise TypeError(
                "t: a list of records must hold (t_i, u_i, y_i) tuples with a 1-D t_i, "
                f"got an entry of length {len(t[0])}"
            )
        return [_one(t, u, y, min_samples)]
    if u is not None or y is not None:
        raise TypeError(
            "u and y must be None when t is a list of (t_i, u_i, y_i) records (each record "
            "carries its own u_i, y_i)"
        )
    records: list[Record] = []
    for i, item in enumerate(t):
        if not isinstance(item, list | tuple) or len(item) != 3:
            raise TypeError(f"record {i}: expected a (t, u, y) tuple, got {type(item).__name__}")
        try:
            rec = _one(*item, min_samples=min_samples)
        except (ValueError, TypeError) as exc:
            raise type(exc)(f"record {i}: {exc}") from exc
        if records:
            m0, l0 = records[0].u.shape[1], records[0].y.shape[1]
            if rec.u.shape[1] != m0 or rec.y.shape[1] != l0:
                raise ValueError(
                    f"record {i}: has {rec.u.shape[1]} input(s) and {rec.y.shape[1]} "
                    f"output(s), record 0 has {m0} and {l0}; all records must have the "
                    f"same channels"
                )
        records.append(rec)
    return records


def _dataset_records(data: Dataset, u: Any, y: Any, min_samples: int) -> list[Record]:
    """The records of ``data`` as they are (checked when it was made), unless one is
    shorter than ``min_samples`` (then the checks of the list form name it)."""
    if u is not None or y is not None:
        raise TypeError("u and y must be None when t is a Dataset (it carries its own)")
    if all(r.ns >= min_samples for r in data.records):
        return list(data.records)
    return as_records(list(data), None, None, min_samples)


def split_windows(record: Record, length: float, uniform: bool) -> list[Record]:
    """Cut a record into windows of (nearly) equal length.

    Parameters
    ----------
    record : Record
        The record.
    length : float
        The shortest window length; ``K = floor(T / length)`` windows are made, each at
        least ``length`` and shorter than ``2 length`` (and at least 3 samples).
    uniform : bool
        Give each window the relative time axis ``k h`` exactly (``h`` the record's mean
        spacing), so that windows of equal sample count share one time axis (and one
        projection); otherwise ``t[a:b+1] - t[a]``.

    Returns
    -------
    list of Record
        The windows, with their absolute starts.

    Notes
    -----
    Consecutive windows share their edge sample, so every sample interval belongs to exactly
    one window: nothing of the record is lost, and the state at each edge is unknown to both
    windows, which is what their boundary pseudo-inputs absorb.

    Examples
    --------
    >>> import numpy as np
    >>> rec = as_records(np.arange(101) * 0.1, np.zeros(101), np.sin(np.arange(101.0)))[0]
    >>> [(w.ns, round(w.t0, 6)) for w in split_windows(rec, 3.0, uniform=True)]
    [(34, 0.0), (35, 3.3), (34, 6.7)]
    """
    ns = record.ns
    K = max(1, int(np.floor(record.duration / length + 1e-9)))
    K = min(K, max(1, (ns - 1) // 2))  # at least 3 samples per window
    edges = np.round(np.linspace(0, ns - 1, K + 1)).astype(int)
    h = record.duration / (ns - 1)
    out = []
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        tau = np.arange(b - a + 1) * h if uniform else record.t[a : b + 1] - record.t[a]
        out.append(
            Record(
                tau,
                record.u[a : b + 1],
                record.y[a : b + 1],
                record.t0 + float(record.t[a]),
                record.resolution,
            )
        )
    return out


def stack_records(records: Sequence[Record]) -> tuple[Array, Array]:
    """``u``, ``y`` of the records stacked along time (for whole-data statistics)."""
    return np.vstack([r.u for r in records]), np.vstack([r.y for r in records])
