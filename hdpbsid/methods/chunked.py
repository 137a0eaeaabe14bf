"""HD-PBSID on records read piece by piece (files larger than memory, Dask arrays).

A uniformly sampled record that does not fit in memory is described by a
:class:`ChunkedRecord`: its length, sampling interval and a reader ``read(a, b) ->
(u[a:b], y[a:b])`` (an HDF5 file, ``.npy`` memory maps: :func:`hdpbsid.io.open_chunked`;
any sliceable arrays, e.g. ``dask.array`` or ``zarr``: :meth:`ChunkedRecord.from_arrays`).
:func:`identify_chunked` runs method ``"hermite"`` (:mod:`hdpbsid.methods.hermite`) on it
in two passes over the data, never holding more than one chunk of samples:

1. the data bandwidth and the lowest significant output frequency (the default rules of
   ``N`` and of the window) from periodograms averaged over chunks of
   ``spectrum_samples`` samples (Welch's method: Welch, *IEEE Trans. Audio
   Electroacoust.* 15 (1967) 70-73; each chunk detrended and Hann-windowed as in
   :func:`~hdpbsid.methods.basis_domain.bandwidth`).  A record of at most
   ``spectrum_samples`` samples is one chunk: the estimate is then the in-memory one;
2. the record is cut into the windows of :func:`hdpbsid.records.split_windows` (same
   edges), and batches of windows (about ``chunk_samples`` samples each) are read and
   projected on their basis; only the basis coefficients are kept.  With
   ``use_dask=True`` every batch is a ``dask.delayed`` task (run on the active
   ``dask.distributed`` client, if any), so batches are read and projected on the
   workers.

The basis-domain problem of all windows is then solved as by
:func:`~hdpbsid.methods.hermite.identify_hermite` (same bases, lags, pseudo-inputs and
core), so on the same windows the model is the in-memory one to rounding.  Memory: one
batch of samples plus the coefficients, ``N_w / Ns_w`` of the samples (``N_w`` functions
on windows of ``Ns_w`` samples) per signal and input hold, plus the core's work arrays on
those coefficients -- these grow with the record, at that fraction of its size.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

import slbasis

from ..checks import check_order, check_positive_int
from ..core.blocks import BlockLag
from ..model import StateSpaceModel
from .basis_domain import (
    P_DEFAULT_RANGE,
    _power_spectra,
    best_hold,
    integrator_model,
    project_record,
    resolve_holds,
    spectra_data_bandwidth,
    spectrum_bandwidth,
)
from .hermite import BAND_MARGIN, HERMITE_BAND, default_hermite_N, hermite_lag
from .segments import LOW_FRACTION, MAP_BYTES, _maps, window_rule
from .settings import BasisSettings, resolve_settings

__all__ = ["ChunkedRecord", "identify_chunked", "SPECTRUM_SAMPLES", "CHUNK_SAMPLES"]

Array = NDArray[np.float64]

#: samples per periodogram of the averaged spectrum (frequency resolution ``fs / 2^20``)
SPECTRUM_SAMPLES = 2**20
#: samples read and projected per batch of windows
CHUNK_SAMPLES = 2**20


class _ArrayReader:
    """``read(a, b)`` of sliceable ``u`` (or None), ``y`` (``np.memmap``, ``h5py``
    datasets, ``zarr`` or ``dask`` arrays: anything ``np.asarray(x[a:b])`` accepts)."""

    def __init__(self, u: Any, y: Any) -> None:
        self.u, self.y = u, y

    def __call__(self, a: int, b: int) -> tuple[Array, Array]:
        y = _two_d(np.asarray(self.y[a:b], dtype=float))
        u = np.zeros((b - a, 0)) if self.u is None else _two_d(np.asarray(self.u[a:b], float))
        return u, y


def _two_d(x: Array) -> Array:
    return x[:, None] if x.ndim == 1 else x


@dataclass(frozen=True)
class ChunkedRecord:
    """A uniformly sampled record read in pieces.

    ``read(a, b)`` returns ``(u, y)`` of samples ``a..b-1`` as ``(b-a, m)`` and ``(b-a,
    l)`` float arrays; ``ns`` samples, ``m`` inputs, ``l`` outputs, sampling interval
    ``dt`` and absolute start ``t0``.  ``read`` must be picklable for ``use_dask`` on a
    distributed cluster (the readers of :func:`hdpbsid.io.open_chunked` are).
    """

    read: Callable[[int, int], tuple[Array, Array]]
    ns: int
    m: int
    l: int
    dt: float
    t0: float = 0.0

    def __post_init__(self) -> None:
        check_positive_int(self.ns, "ns", 3)
        if isinstance(self.dt, bool) or not isinstance(self.dt, int | float | np.number):
            raise TypeError(f"dt must be a positive number, got {type(self.dt).__name__}")
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise ValueError(f"dt must be a positive finite sampling interval, got {self.dt}")
        if self.l < 1 or self.m < 0:
            raise ValueError(f"need m >= 0 inputs and l >= 1 outputs, got m={self.m}, l={self.l}")

    @classmethod
    def from_arrays(cls, u: Any, y: Any, dt: float, t0: float = 0.0) -> ChunkedRecord:
        """A record over sliceable arrays ``u`` (``(Ns,)``, ``(Ns, m)`` or None) and ``y``
        (``(Ns,)`` or ``(Ns, l)``): ``np.memmap``, ``h5py`` datasets, ``zarr`` or
        ``dask.array`` arrays; nothing is read until identification."""
        ys = tuple(np.shape(y))
        if len(ys) not in (1, 2):
            raise ValueError(f"y must be (Ns,) or (Ns, l), got shape {ys}")
        m = 0
        if u is not None:
            us = tuple(np.shape(u))
            if len(us) not in (1, 2) or us[0] != ys[0]:
                raise ValueError(f"u must be (Ns,) or (Ns, m) with Ns = {ys[0]}, got {us}")
            m = 1 if len(us) == 1 else us[1]
        return cls(_ArrayReader(u, y), int(ys[0]), m, 1 if len(ys) == 1 else ys[1], dt, t0)

    @property
    def duration(self) -> float:
        """``(Ns - 1) dt``."""
        return float((self.ns - 1) * self.dt)

    def checked(self, a: int, b: int) -> tuple[Array, Array]:
        """``read(a, b)`` with the shapes and finiteness checked."""
        u, y = self.read(a, b)
        if u.shape != (b - a, self.m) or y.shape != (b - a, self.l):
            raise ValueError(
                f"the reader returned u {u.shape}, y {y.shape} for samples {a}..{b - 1}; "
                f"expected ({b - a}, {self.m}) and ({b - a}, {self.l})"
            )
        for name, x in (("u", u), ("y", y)):
            if not np.all(np.isfinite(x)):
                k = a + int(np.flatnonzero(~np.isfinite(x).all(axis=1))[0])
                raise ValueError(f"{name} has a NaN or infinite value at sample {k}")
        return u, y


def _spectra(rec: ChunkedRecord, a: int, b: int) -> tuple[Array, Array, Array]:
    u, y = rec.checked(a, b)
    t = np.arange(b - a) * rec.dt
    w, Pu = _power_spectra(t, u)
    return w, Pu, _power_spectra(t, y)[1]


def _compute(tasks: list[Any], use_dask: bool) -> list[Any]:
    if not use_dask:
        return [f(*args) for f, *args in tasks]
    import dask

    return list(dask.compute(*[dask.delayed(f)(*args) for f, *args in tasks]))


def averaged_spectra(
    rec: ChunkedRecord, spectrum_samples: int = SPECTRUM_SAMPLES, use_dask: bool = False
) -> tuple[Array, Array, Array]:
    """Angular frequencies and the periodograms of ``u`` and ``y`` averaged over
    ``floor(Ns / L)`` consecutive chunks of ``L = min(Ns, spectrum_samples)`` samples
    (module docstring); the tail shorter than ``L`` is not used."""
    L = min(rec.ns, check_positive_int(spectrum_samples, "spectrum_samples", 16))
    k = rec.ns // L
    parts = _compute([[_spectra, rec, i * L, (i + 1) * L] for i in range(k)], use_dask)
    w = parts[0][0]
    return w, sum(p[1] for p in parts) / k, sum(p[2] for p in parts) / k


def _window_edges(rec: ChunkedRecord, length: float | None) -> Array:
    """Edges of :func:`hdpbsid.records.split_windows` (one window: the whole record)."""
    if length is None or rec.duration < 2 * length:
        return np.array([0, rec.ns - 1])
    K = max(1, int(np.floor(rec.duration / length + 1e-9)))
    K = min(K, max(1, (rec.ns - 1) // 2))
    return np.round(np.linspace(0, rec.ns - 1, K + 1)).astype(int)


def _apply_map(G: Array, x: Array, idx: NDArray[np.intp]) -> list[Array]:
    """``G`` (``N x n``) applied to the windows ``x[idx[k]]`` (``idx``: ``K x n`` sample
    indices) of the columns of ``x``: ``K`` arrays ``(columns, N)``."""
    K, n = idx.shape
    c = x.shape[1]
    if c == 0:
        return [np.zeros((0, G.shape[0]))] * K
    X = x[idx].transpose(1, 0, 2).reshape(n, K * c)  # (n, K c)
    C = (G @ X).reshape(G.shape[0], K, c)
    return [C[:, k, :].T for k in range(K)]


def _project_batch(
    rec: ChunkedRecord, a: int, b: int, sizes: list[int], maps: dict[int, list[Array]]
) -> tuple[list[Array], Array]:
    """Coefficients of consecutive windows starting at sample ``a`` with ``sizes[i]``
    samples each (consecutive windows share their edge sample), read at once; windows
    of ``n`` samples are projected together by their maps ``maps[n] = [G_hold ...,
    G_y]`` (``N x n`` each).  Returns ``([U per hold], Y)``, windows side by side."""
    u, y = rec.checked(a, b)
    sizes_a = np.array(sizes, dtype=int)
    starts = np.concatenate([[0], np.cumsum(sizes_a[:-1] - 1)]).astype(int)
    nh = len(next(iter(maps.values()))) - 1
    parts_u: list[list[Any]] = [[None] * len(sizes) for _ in range(nh)]
    parts_y: list[Any] = [None] * len(sizes)
    for n in sorted(set(sizes)):
        sel = np.flatnonzero(sizes_a == n)
        idx = starts[sel, None] + np.arange(n)[None, :]  # (K, n)
        for hh in range(nh):
            for k, c in zip(sel, _apply_map(maps[n][hh], u, idx), strict=True):
                parts_u[hh][k] = c
        for k, c in zip(sel, _apply_map(maps[n][-1], y, idx), strict=True):
            parts_y[k] = c
    return [np.hstack(p) for p in parts_u], np.hstack(parts_y)


def _project_single(
    rec: ChunkedRecord, a: int, b: int, basis: Any, holds: tuple[str, ...]
) -> tuple[list[Array], Array]:
    u, y = rec.checked(a, b)
    return project_record(basis, np.arange(b - a) * rec.dt, u, y, holds)


def identify_chunked(
    record: ChunkedRecord,
    order: int | None = None,
    *,
    N: int | None = None,
    chunk_samples: int = CHUNK_SAMPLES,
    spectrum_samples: int = SPECTRUM_SAMPLES,
    use_dask: bool = False,
    settings: BasisSettings | None = None,
    **shared: Any,
) -> StateSpaceModel:
    """HD-PBSID (method ``"hermite"``) of a record read in chunks (module docstring).

    ``record``: a :class:`ChunkedRecord` (:func:`hdpbsid.io.open_chunked` for HDF5,
    Parquet and ``.npy`` files).  ``order``, ``N`` and the shared settings (keywords or
    ``settings=`` :class:`~hdpbsid.methods.settings.BasisSettings`; ``n_jobs`` is not
    used: batches run serially or on Dask) as in
    :func:`~hdpbsid.methods.hermite.identify_hermite`, with ``alpha = 4 scale``,
    ``beta = gamma = 1``.  No mean is removed: pass deviations from the operating
    point.  ``chunk_samples``: samples read per batch of windows (at least one window);
    ``spectrum_samples``: samples per periodogram of the bandwidth estimate;
    ``use_dask``: batches as ``dask.delayed`` tasks (on the active ``dask.distributed``
    client, if one exists).
    """
    if not isinstance(record, ChunkedRecord):
        raise TypeError(f"record must be a ChunkedRecord, got {type(record).__name__}")
    chunk_samples = check_positive_int(chunk_samples, "chunk_samples", 2)
    st = resolve_settings(settings, shared, "identify_chunked")
    order = check_order(order)
    if N is not None:
        N = check_positive_int(N, "N", 2)
    m, h = record.m, record.dt
    w, Pu, Py = averaged_spectra(record, spectrum_samples, use_dask)
    wb = spectra_data_bandwidth(w, Pu, w, Py)
    q = 3 if st.boundary else 1  # truncation row and the two boundary rows
    info: dict[str, Any] = {}
    window = st.window
    if window is None:
        length, info["window_rule"] = None, "none (window=None)"
    elif window == "auto":
        w_low = spectrum_bandwidth(w, Py, LOW_FRACTION)
        n_per_band = BAND_MARGIN * wb / HERMITE_BAND
        length, info = window_rule(w_low, record.duration, n_per_band, q, P_DEFAULT_RANGE[1])
    else:
        length = float(window)
        info["window_rule"] = "given"
    edges = _window_edges(record, length)
    sizes = np.diff(edges) + 1  # samples per window (edge samples shared)
    # one basis per distinct window length, in order of first appearance
    bases: dict[int, Any] = {}
    n_rules: list[str] = []
    for n in sizes:
        n = int(n)
        if n in bases:
            continue
        T = (n - 1) * h
        if N is None:
            Nb, rule = default_hermite_N(T, wb, n)
        else:
            Nb, rule = N, "given"
            if HERMITE_BAND * N / T < wb:
                raise ValueError(
                    f"N={N} Hermite functions over a window of {T:g} s cover only "
                    f"{HERMITE_BAND * N / T:.3g} rad/s, below the data bandwidth {wb:.3g} rad/s"
                )
            if N > n:
                raise ValueError(f"N={N} exceeds the number of samples per window {n}; reduce N")
        n_rules.append(rule)
        bases[n] = slbasis.basis("hermite", Nb, (0.0, T))
    s_ref = float(np.median([b.scale for b in bases.values()]))
    alpha, beta, gamma = 4.0 * s_ref, 1.0, 1.0
    lags, rows = {}, {}
    for n, b in bases.items():
        lags[n] = hermite_lag(b.derivative_matrix("square"), alpha, beta, gamma)[0]
        r = [np.eye(1, b.N, b.N - 1)[0]]
        if st.boundary:
            r += list(b.eval(np.array([0.0, (n - 1) * h])).T)
        rows[n] = np.array(r)
    holds = resolve_holds(st.input_hold, m)
    # batches: consecutive windows, about chunk_samples samples each, read at once
    tasks: list[Any] = []
    maps: dict[int, list[Array]] = {}
    batch: list[int] = []

    def flush() -> None:
        if batch:
            a, b = int(edges[batch[0]]), int(edges[batch[-1] + 1]) + 1
            tasks.append([_project_batch, record, a, b, [int(sizes[i]) for i in batch], maps])
            batch.clear()

    for k, n in enumerate(int(n) for n in sizes):
        b = bases[n]
        if b.N * n * 8 * (len(holds) + 1) > MAP_BYTES:  # too large a map: one by one
            flush()
            tasks.append([_project_single, record, int(edges[k]), int(edges[k + 1]) + 1, b, holds])
            continue
        if n not in maps:
            Gu, Gy = _maps(b, np.arange(n) * h, holds)
            maps[n] = Gu + [Gy]
        if batch and int(edges[k + 1]) - int(edges[batch[0]]) + 1 > chunk_samples:
            flush()
        batch.append(k)
    flush()
    if use_dask and maps:
        import dask

        shared = dask.delayed(maps, pure=True)  # one copy of the maps in the graph
        for task in tasks:
            if task[0] is _project_batch:
                task[5] = shared
    results = _compute(tasks, use_dask)
    Us = [np.hstack([r[0][i] for r in results]) for i in range(len(holds))]
    Yc = np.hstack([r[1] for r in results])
    keys = [int(n) for n in sizes]
    seg_bases = [bases[n] for n in keys]
    lag = BlockLag([lags[n] for n in keys], [b.N for b in seg_bases])
    out, hold, hold_crit = best_hold(
        holds,
        Us,
        Yc,
        [rows[n] for n in keys],
        lag,
        **st.core_options(order),
    )
    Ns_ = [b.N for b in seg_bases]
    options = {
        "method": "hermite",
        "N": int(max(Ns_)),
        "N_per_block": Ns_ if len(Ns_) > 1 else None,
        "N_rule": n_rules[0] if len(set(n_rules)) == 1 else n_rules,
        "bandwidth": wb,
        "bandwidth_rule": (
            f"periodograms averaged over chunks of {min(record.ns, spectrum_samples)} samples"
        ),
        "scale": s_ref,
        "centre": record.t0 + seg_bases[0].centre,
        "alpha_rule": "4 * scale (median over blocks)",
        "boundary": st.boundary,
        "truncation": "last column of the cut D absorbed as a pseudo-input",
        "n_samples": record.ns,
        "t0": record.t0,
        "chunked": {"batches": len(tasks), "chunk_samples": chunk_samples, "dask": use_dask},
        **info,
        "window": length,
        "n_records": 1,
        "n_segments": len(keys),
    }
    return integrator_model(
        out,
        alpha,
        beta,
        gamma,
        options,
        settings=st,
        hold=hold,
        hold_criterion=hold_crit,
        order=order,
    )
