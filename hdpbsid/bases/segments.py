"""Records and windows as blocks of one basis-domain problem.

Several experiments, or windows of one long record, are each projected on their own
basis (own ``N`` by the band rule, own scale) with their own boundary and truncation
pseudo-inputs, and their coefficient columns are stacked side by side in one PBSID
problem (:func:`hdpbsid.bases.basis_domain.run_core`; the pseudo-inputs of each block
are eliminated there, so the regression does not grow with the number of blocks).

Windows (:func:`default_window`) make the cost linear in the number of samples: one
basis of ``N`` functions over the whole record costs ``O(N Ns)`` with ``N`` proportional
to the record length (``O(Ns^2)``), while ``K`` windows of bounded ``N_w`` cost
``O(N_w Ns)``.  Windows of equal sample count on a uniform grid share one time axis, so
their projection is one linear map applied to all of them at once
(:func:`project_blocks`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.basis_domain import PROJECTION, bandwidth, data_bandwidth, project_record
from hdpbsid.bases.memo import memoize
from hdpbsid.bases.settings import check_window
from hdpbsid.data.records import Record, split_windows

__all__ = [
    "SegmentSettings",
    "SEGMENTS",
    "default_window",
    "window_rule",
    "make_segments",
    "project_blocks",
    "records_bandwidth",
    "shared_keys",
    "NUISANCE_SHARE",
    "WINDOW_PERIODS",
    "LOW_FRACTION",
    "MAP_BYTES",
    "MAP_CACHE_BYTES",
    "MAP_CACHE_SIZE",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SegmentSettings:
    """The default window's rule and the projection maps' budgets, each with its reason.

    Parameters
    ----------
    nuisance_share : float, optional
        Largest share of a window's columns spent on its pseudo-input directions.
    window_periods : float, optional
        Periods of the lowest significant output frequency a default window holds.
    low_fraction : float, optional
        Share of the output energy below the lowest significant frequency.
    map_bytes : int, optional
        Largest dense projection map built for windows sharing a time axis.
    map_cache_bytes : int, optional
        Largest projection map memoised.
    map_cache_size : int, optional
        Projection maps kept.

    Examples
    --------
    >>> SegmentSettings().window_periods
    10.0
    """

    #: largest share of a window's columns spent on its own pseudo-input (nuisance)
    #: directions by the default window: ``(p_max + 1) q / N_w``.  The information lost
    #: by windowing is that share of the record's equations, whatever the system
    nuisance_share: float = 0.05
    #: the default window holds at least this many periods of the lowest significant
    #: frequency of the outputs (:func:`default_window`)
    window_periods: float = 10.0
    #: the lowest significant frequency: this fraction of the output energy lies below it
    low_fraction: float = 0.05
    #: largest dense projection map (bytes) built for windows sharing a time axis: beyond
    #: it the windows are projected one by one, in bounded memory
    map_bytes: int = 256 * 2**20
    #: projection maps at most this large (bytes, all holds) are memoised: an order or
    #: method selection projects the same windows once per candidate, and the map (a
    #: basis evaluation at every quadrature node) is most of that cost; the cache keeps
    #: ``map_cache_size`` of them, so it holds at most 4 x 64 MB
    map_cache_bytes: int = 64 * 2**20
    #: projection maps kept (estimation part and whole record, each with both holds' maps)
    map_cache_size: int = 4


#: the settings of this module
SEGMENTS = SegmentSettings()
#: the fields of :data:`SEGMENTS` under their former names
NUISANCE_SHARE = SEGMENTS.nuisance_share
WINDOW_PERIODS = SEGMENTS.window_periods
LOW_FRACTION = SEGMENTS.low_fraction
MAP_BYTES = SEGMENTS.map_bytes
MAP_CACHE_BYTES = SEGMENTS.map_cache_bytes
MAP_CACHE_SIZE = SEGMENTS.map_cache_size


def records_bandwidth(records: Sequence[Record]) -> float:
    """Largest :func:`~hdpbsid.bases.basis_domain.data_bandwidth` over the records.

    The basis of every block must cover the band of all records, since the model is shared.

    Parameters
    ----------
    records : sequence of Record
        The records.

    Returns
    -------
    float
        The band (rad/s).
    """
    return max(data_bandwidth(r.t, r.u, r.y) for r in records)


def default_window(
    records: Sequence[Record], n_per_band: float, q: int, p_max: int
) -> tuple[float | None, dict[str, Any]]:
    """Default window length (s), or None when no record needs to be split.

    Rule: ``T_w = max(T_N, T_dyn)`` with

    * ``T_N = N_w / n_per_band`` and ``N_w = (p_max + 1) q / NUISANCE_SHARE``: each window
      spends ``(p_max + 1) q`` of its ``N_w`` equations on its own pseudo-inputs (lags
      ``0..p_max`` of ``q`` rows), so at most :data:`NUISANCE_SHARE` of the record's
      equations are lost to windowing -- a statement about the regression, true for any
      system and record; and ``N_w`` is fixed by it, so the cost per sample is bounded;
    * ``T_dyn = WINDOW_PERIODS / f_low``, ``f_low`` the lowest significant frequency of the
      outputs (below it lies :data:`LOW_FRACTION` of their energy above the noise floor):
      the pseudo-inputs of a window absorb every free response on it, and a component
      slower than the window looks like one; over ``WINDOW_PERIODS`` periods of the slowest
      significant component the window's forced response resolves it.

    A record is split only when it is at least twice ``T_w`` long (windows are between
    ``T_w`` and ``2 T_w``, :func:`hdpbsid.data.records.split_windows`), so short records are
    identified on one basis.

    Parameters
    ----------
    records : sequence of Record
        The records.
    n_per_band : float
        Basis functions per second of window (the method's band rule at the data
        bandwidth: ``N = n_per_band T``).
    q : int
        Pseudo-input rows per window.
    p_max : int
        Largest default past window.

    Returns
    -------
    length : float or None
        The window (s), or None when no record is long enough to split.
    info : dict
        The rule's report (``window_rule``, ``window_target_N``,
        ``lowest_significant_frequency``).
    """
    w_low = min(bandwidth(r.t, r.y, SEGMENTS.low_fraction) for r in records)
    longest = max(r.duration for r in records)
    return window_rule(w_low, longest, n_per_band, q, p_max)


def window_rule(
    w_low: float, longest: float, n_per_band: float, q: int, p_max: int
) -> tuple[float | None, dict[str, Any]]:
    """:func:`default_window` from its ingredients (a record read in chunks has no in-memory
    records to pass).

    Parameters
    ----------
    w_low : float
        The lowest significant output frequency (rad/s); 0 means none.
    longest : float
        Length of the longest record (s).
    n_per_band : float
        Basis functions per second of window.
    q : int
        Pseudo-input rows per window.
    p_max : int
        Largest default past window.

    Returns
    -------
    length : float or None
        The window (s), or None when the longest record is shorter than twice it.
    info : dict
        The rule's report.

    Examples
    --------
    >>> length, info = window_rule(0.5, 1000.0, 10.0, 2, 4)
    >>> round(length, 2), info["window_target_N"]  # 10 periods of 0.5 rad/s
    (125.66, 200)
    >>> print(window_rule(0.5, 100.0, 10.0, 2, 4)[0])  # too short to split
    None
    """
    n_w = int(np.ceil((p_max + 1) * q / SEGMENTS.nuisance_share))
    t_n = n_w / n_per_band
    t_dyn = SEGMENTS.window_periods * 2.0 * np.pi / w_low if w_low > 0 else np.inf
    t_w = max(t_n, t_dyn)
    info = {
        "window_rule": (
            f"T_w = max(N_w / (N per second) = {t_n:.4g} s with N_w = (p_max+1) q / "
            f"{SEGMENTS.nuisance_share} = {n_w}, {SEGMENTS.window_periods:g} periods of the lowest "
            f"significant output frequency {w_low:.4g} rad/s = {t_dyn:.4g} s); records "
            f"shorter than 2 T_w are not split"
        ),
        "window_target_N": n_w,
        "lowest_significant_frequency": w_low,
    }
    return (t_w if longest >= 2 * t_w else None), info


def make_segments(
    records: Sequence[Record], window: Any, rule: Callable[[], tuple[float | None, dict]]
) -> tuple[list[Record], dict[str, Any]]:
    """Split the records into windows per the ``window`` option.

    Parameters
    ----------
    records : sequence of Record
        The records.
    window : float, "auto" or None
        None (no split), ``"auto"`` (``rule()`` gives the length) or a positive number of
        seconds (validated by :func:`~hdpbsid.bases.settings.check_window`).
    rule : callable
        ``rule() -> (length or None, info)``, the default window.

    Returns
    -------
    segments : list of Record
        The records, those at least twice the window long split into windows.
    info : dict
        The options to report (window, its rule, record and segment counts).

    Raises
    ------
    ValueError
        If ``window`` is not None, ``"auto"`` or a positive number (from
        :func:`~hdpbsid.bases.settings.check_window`).
    TypeError
        If ``window`` is of another type.

    Examples
    --------
    >>> from hdpbsid.data.records import Record
    >>> t = np.arange(0.0, 10.0, 0.1)
    >>> segs, info = make_segments([Record(t, np.zeros((100, 1)), np.zeros((100, 1)))], 2.0, None)
    >>> [s.ns for s in segs], info["n_segments"]
    ([26, 26, 25, 26], 4)
    """
    info: dict[str, Any] = {}
    window = check_window(window)
    if window is None:
        length = None
        info["window_rule"] = "none (window=None)"
    elif window == "auto":
        length, info = rule()
    else:
        length = float(window)
        info["window_rule"] = "given"
    segs: list[Record] = []
    for r in records:
        if length is None or r.duration < 2 * length:
            segs.append(r)
        else:
            segs.extend(split_windows(r, length, uniform=r.uniform))
    info["window"] = length
    info["n_records"] = len(records)
    info["n_segments"] = len(segs)
    return segs, info


def shared_keys(segs: Sequence[Record]) -> list[int]:
    """One key per segment, equal for segments with identical relative time axes.

    Such segments can share a basis, a lag, pseudo-input rows and a projection map.

    Parameters
    ----------
    segs : sequence of Record
        The segments.

    Returns
    -------
    list of int
        ``keys[i]``: the index of the first segment with the same time axis as segment
        ``i``.

    Examples
    --------
    >>> from hdpbsid.data.records import Record
    >>> t = np.arange(0.0, 10.0, 0.1)
    >>> segs, _ = make_segments([Record(t, np.zeros((100, 1)), np.zeros((100, 1)))], 2.0, None)
    >>> shared_keys(segs)  # the 25-sample window has its own axis
    [0, 0, 2, 0]
    """
    reps: list[int] = []
    keys = []
    for i, s in enumerate(segs):
        for r in reps:
            if segs[r].t.size == s.t.size and np.array_equal(segs[r].t, s.t):
                keys.append(r)
                break
        else:
            reps.append(i)
            keys.append(i)
    return keys


def _maps(basis: Any, t: Array, holds: tuple[str, ...]) -> tuple[list[Array], Array]:
    """The linear maps of :func:`~hdpbsid.bases.basis_domain.project_record`: samples
    ``(Ns,)`` -> coefficients ``(N,)`` per input hold, and for the outputs (``foh``)."""
    g = PROJECTION.gauss_nodes
    x, w = np.polynomial.legendre.leggauss(g)
    h = np.diff(t)
    tn = (t[:-1, None] + h[:, None] * (1.0 + x[None, :]) / 2.0).ravel()
    wn = (h[:, None] * w[None, :] / 2.0).ravel()
    lam = (1.0 + x) / 2.0
    PW = (basis.eval(tn) * wn[None, :]).reshape(basis.N, t.size - 1, g)
    a = PW @ (1.0 - lam)
    b = PW @ lam
    foh = np.zeros((basis.N, t.size))
    foh[:, :-1] += a
    foh[:, 1:] += b
    out = []
    for hold in holds:
        if hold == "zoh":
            z = np.zeros((basis.N, t.size))
            z[:, :-1] = PW.sum(axis=2)
            out.append(z)
        elif hold == "foh":
            out.append(foh)
        else:  # trapezoid: the product quadrature on the samples
            wt = np.zeros(t.size)
            wt[:-1] += h / 2
            wt[1:] += h / 2
            out.append(basis.eval(t) * wt[None, :])
    return out, foh


@memoize(size=SEGMENTS.map_cache_size)
def _maps_memoised(basis: Any, t: Array, holds: tuple[str, ...]) -> tuple[list[Array], Array]:
    """:func:`_maps`, memoised by the basis and the contents of ``t``
    (:mod:`hdpbsid.bases.memo`; the arrays returned are read-only)."""
    return _maps(basis, t, holds)


def project_blocks(
    bases: Sequence[Any],
    segs: Sequence[Record],
    holds: tuple[str, ...],
    y_extra: Array | None = None,
    n_jobs: int | None = None,
) -> tuple[list[Array], Array, list[Array]]:
    """Project every segment on its basis, the segments' columns side by side.

    Segments with the same basis object and time axis (windows of equal sample count on a
    uniform grid) share the projection map (identical to
    :func:`~hdpbsid.bases.basis_domain.project_record` up to summation order), applied to
    all of them by one matrix product; others are projected one by one, in parallel with
    ``joblib`` when ``n_jobs`` is given.

    Parameters
    ----------
    bases : sequence of Basis
        The basis of every segment.
    segs : sequence of Record
        The segments.
    holds : tuple of str
        The input holds to project.
    y_extra : callable, optional
        A function of the relative time (e.g. the constant 1) projected like an output,
        per segment.
    n_jobs : int, optional
        joblib workers for the segments projected one by one.

    Returns
    -------
    Us : list of ndarray, shape (m, sum N_b)
        The input rows per hold.
    Y : ndarray, shape (l, sum N_b)
        The output rows.
    extra : list of ndarray or None
        The projection of ``y_extra`` per segment (None entries without it).
    """
    m, l = segs[0].u.shape[1], segs[0].y.shape[1]
    groups: dict[int, list[int]] = {}
    for i, b in enumerate(bases):
        groups.setdefault(id(b), []).append(i)
    rows = _Rows([[None] * len(segs) for _ in holds], [None] * len(segs), [None] * len(segs))
    single: list[int] = []
    for idx in groups.values():
        same = _sharing(bases[idx[0]], segs, idx, len(holds))
        single.extend(i for i in idx if i not in same)
        if same:
            _project_shared(rows, bases[idx[0]], segs, same, holds, y_extra, (m, l))
    if single:
        _project_single(rows, bases, segs, single, holds, y_extra, n_jobs)
    U_out = [np.hstack(u) for u in rows.Us]
    return U_out, np.hstack(rows.Ys), rows.ex


@dataclass
class _Rows:
    """The coefficient rows of every segment, filled group by group: ``Us[h][i]`` the
    input rows of hold ``h``, ``Ys[i]`` the output rows, ``ex[i]`` the extra function's."""

    Us: list[list[Array | None]]
    Ys: list[Array | None]
    ex: list[Array | None]


def _map_bytes(b: Any, t0: Array, n_holds: int) -> int:
    """Bytes of the projection maps of one basis on one time axis, all holds and ``y``."""
    return b.N * t0.size * 8 * (n_holds + 1)


def _sharing(b: Any, segs: Sequence[Record], idx: list[int], n_holds: int) -> list[int]:
    """The segments of ``idx`` (all on basis ``b``) whose time axis is the first one's,
    when at least two share it and their map is within ``map_bytes``; else none."""
    t0 = segs[idx[0]].t
    same = [i for i in idx if segs[i].t is t0 or np.array_equal(segs[i].t, t0)]
    if len(same) < 2 or _map_bytes(b, t0, n_holds) > SEGMENTS.map_bytes:
        return []
    return same


def _project_shared(
    rows: _Rows,
    b: Any,
    segs: Sequence[Record],
    same: list[int],
    holds: tuple[str, ...],
    y_extra: Callable | None,
    sizes: tuple[int, int],
) -> None:
    """Project the segments ``same`` (one basis, one time axis) by one map product."""
    m, l = sizes
    t0 = segs[same[0]].t
    small = _map_bytes(b, t0, len(holds)) <= SEGMENTS.map_cache_bytes
    Gu, Gy = (_maps_memoised if small else _maps)(b, t0, tuple(holds))
    if m:
        u_all = np.hstack([segs[i].u for i in same])  # (Ns, K m)
        for h, G in enumerate(Gu):
            C = G @ u_all
            for k, i in enumerate(same):
                rows.Us[h][i] = C[:, k * m : (k + 1) * m].T
    C = Gy @ np.hstack([segs[i].y for i in same])
    e = Gy @ y_extra(t0) if y_extra is not None else None
    for k, i in enumerate(same):
        rows.Ys[i] = C[:, k * l : (k + 1) * l].T
        if m == 0:
            for h in range(len(holds)):
                rows.Us[h][i] = np.zeros((0, b.N))
        rows.ex[i] = e


def _project_single(
    rows: _Rows,
    bases: Sequence[Any],
    segs: Sequence[Record],
    single: list[int],
    holds: tuple[str, ...],
    y_extra: Callable | None,
    n_jobs: int | None,
) -> None:
    """Project the segments ``single`` one by one (in parallel with ``n_jobs``)."""
    l = segs[0].y.shape[1]

    def one(i: int) -> tuple[list[Array], Array]:
        s = segs[i]
        yy = s.y if y_extra is None else np.hstack([s.y, y_extra(s.t)[:, None]])
        return project_record(bases[i], s.t, s.u, yy, holds)

    if n_jobs is not None and len(single) > 1:
        from joblib import Parallel, delayed

        res = Parallel(n_jobs=n_jobs)(delayed(one)(i) for i in single)
    else:
        res = [one(i) for i in single]
    for i, (u_i, y_i) in zip(single, res, strict=True):
        for h in range(len(holds)):
            rows.Us[h][i] = u_i[h]
        rows.Ys[i] = y_i[:l]
        rows.ex[i] = y_i[l] if y_extra is not None else None
