"""HD-PBSID on records read piece by piece (files larger than memory, Dask arrays).

A uniformly sampled record that does not fit in memory is described by a
:class:`ChunkedRecord`: its length, sampling interval and a reader ``read(a, b) ->
(u[a:b], y[a:b])`` (an HDF5 file, ``.npy`` memory maps: :func:`hdpbsid.data.io.open_chunked`;
any sliceable arrays, e.g. ``dask.array`` or ``zarr``: :meth:`ChunkedRecord.from_arrays`).
:func:`identify_chunked` runs method ``"hermite"`` (:mod:`hdpbsid.methods.hermite`) on it
in three passes over the data, never holding more than one batch of samples:

1. the data bandwidth and the lowest significant output frequency (the default rules of
   ``N`` and of the window) from periodograms averaged over chunks of
   ``spectrum_samples`` samples (Welch's method: Welch, *IEEE Trans. Audio
   Electroacoust.* 15 (1967) 70-73; each chunk detrended and Hann-windowed as in
   :func:`~hdpbsid.bases.basis_domain.bandwidth`).  A record of at most
   ``spectrum_samples`` samples is one chunk: the estimate is then the in-memory one;
2. the record is cut into the windows of :func:`hdpbsid.data.records.split_windows` (same
   edges); batches of windows (about ``chunk_samples`` samples each) are read, projected
   on their basis and reduced to the first-pass factors of the core
   (:func:`hdpbsid.core.streamed.varx_factors`: the AIC of every candidate ``p`` and the
   VARX);
3. the batches are read and projected again and reduced to the second-pass factors
   (:func:`hdpbsid.core.streamed.state_factors`: the state, ``C``, ``A, B, K``).

With ``use_dask=True`` every batch is a ``dask.delayed`` task (run on the active
``dask.distributed`` client, if any) and the factors are combined pairwise by tasks as
well, so only the final factors reach the caller.  The basis-domain problem of all
windows is the one :func:`~hdpbsid.methods.hermite.identify_hermite` solves (the same
family, :class:`~hdpbsid.methods.hermite.HermiteFamily`: bases, size rule, lags,
pseudo-inputs, map back; the same rules of ``p`` and of the input hold), built by the
steps of the in-memory pipeline (:func:`~hdpbsid.bases.pipeline.size_bases`,
:func:`~hdpbsid.bases.pipeline.block_kinds`, :func:`~hdpbsid.bases.pipeline.to_fit`) and
solved from triangular factors instead of the stacked coefficients
(:mod:`hdpbsid.core.streamed`), so on the same windows the model is the in-memory one to
rounding, up to the sign of each state coordinate.  Memory: one batch of samples and its
coefficients, the projection maps (one per window length) and factors of a few rows
squared -- nothing grows with the record.  ``feedthrough=True`` is not covered by the
streamed core: with it every window's coefficients are gathered and solved at once (memory
``N_w / Ns_w`` of the samples per signal and input hold, plus the core's work arrays).
"""

from __future__ import annotations

import copy
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.basis_domain import (
    COLS_PER_REGRESSOR,
    P_DEFAULT_RANGE,
    RIDGE_FLOOR,
    BasisTooSmall,
    CoreOut,
    _largest_determined_p,
    _power_spectra,
    project_record,
    resolve_holds,
    spectra_data_bandwidth,
    spectrum_bandwidth,
)
from hdpbsid.bases.family import Integrator, size_policy
from hdpbsid.bases.hermite_family import HermiteFamily
from hdpbsid.bases.pipeline import (
    BlockKind,
    block_kinds,
    core_on_rows,
    size_bases,
    size_report,
    stacked,
    to_fit,
)
from hdpbsid.bases.segments import LOW_FRACTION, MAP_BYTES, _maps, window_rule
from hdpbsid.bases.settings import BasisSettings, resolve_settings
from hdpbsid.core import streamed
from hdpbsid.core.blocks import BlockLag, BlockPseudo
from hdpbsid.core.varx import is_strictly_causal
from hdpbsid.data.checks import check_order, check_positive_int
from hdpbsid.data.chunked import CHUNK_SAMPLES, ChunkedRecord
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.runtime import library_call

__all__ = ["identify_chunked", "averaged_spectra", "ChunkedDefaults", "SPECTRUM_SAMPLES"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class ChunkedDefaults:
    """The numbers of the chunked path that are not settings of the basis methods.

    Attributes
    ----------
    spectrum_samples : int
        Samples per periodogram of the averaged spectrum (:func:`averaged_spectra`).
    selection_rows : int
        Rows ``f l`` of ``Gamma L`` a past window must give when the order is selected
        (:func:`~hdpbsid.bases.basis_domain.run_core`'s rule).
    """

    #: a frequency resolution of ``fs / 2^20``, and one periodogram (the in-memory
    #: estimate) for records up to 2^20 samples
    spectrum_samples: int = 2**20
    #: order selection compares orders up to ``f l - 1``: at least 1 and 2
    selection_rows: int = 3


#: the defaults in use
DEFAULTS = ChunkedDefaults()
#: samples per periodogram of the averaged spectrum (:attr:`ChunkedDefaults.spectrum_samples`)
SPECTRUM_SAMPLES = DEFAULTS.spectrum_samples


def _spectra(rec: ChunkedRecord, a: int, b: int) -> tuple[Array, Array, Array]:
    u, y = rec.checked(a, b)
    t = np.arange(b - a) * rec.dt
    w, Pu = _power_spectra(t, u)
    return w, Pu, _power_spectra(t, y)[1]


def _compute(tasks: list[Any], use_dask: bool, shared: Any = None) -> list[Any]:
    if not use_dask:
        return [f(*args) for f, *args in tasks]
    import dask

    one = dask.delayed(shared, pure=True) if shared is not None else None
    return list(
        dask.compute(
            *[
                dask.delayed(f)(*[one if (one is not None and a is shared) else a for a in args])
                for f, *args in tasks
            ]
        )
    )


def averaged_spectra(
    rec: ChunkedRecord, spectrum_samples: int = SPECTRUM_SAMPLES, use_dask: bool = False
) -> tuple[Array, Array, Array]:
    """Angular frequencies and the periodograms of ``u`` and ``y`` averaged over chunks.

    Welch's method: ``floor(Ns / L)`` consecutive chunks of ``L = min(Ns, spectrum_samples)``
    samples, each detrended and Hann-windowed as in
    :func:`~hdpbsid.bases.basis_domain.bandwidth`; averaging lowers the variance of the
    periodogram by the number of chunks.  The tail shorter than ``L`` is not used.

    Parameters
    ----------
    rec : ChunkedRecord
        The record.
    spectrum_samples : int, optional
        Samples per chunk, ``>= 16``.
    use_dask : bool, optional
        Chunks as ``dask.delayed`` tasks.

    Returns
    -------
    w : ndarray, shape (L // 2 + 1,)
        Angular frequencies (rad per time unit).
    Pu : ndarray, shape (L // 2 + 1, m)
        Averaged input periodograms.
    Py : ndarray, shape (L // 2 + 1, l)
        Averaged output periodograms.

    Raises
    ------
    ValueError
        If ``spectrum_samples`` is not an integer ``>= 16``.

    References
    ----------
    .. [1] P. D. Welch, "The use of fast Fourier transform for the estimation of power
       spectra", *IEEE Trans. Audio Electroacoust.* 15(2), 70-73, 1967.
    """
    L = min(rec.ns, check_positive_int(spectrum_samples, "spectrum_samples", 16))
    k = rec.ns // L
    w, Pu, Py = _reduce(
        [[_spectra, rec, i * L, (i + 1) * L] for i in range(k)], _add_spectra, use_dask
    )
    return w, Pu / k, Py / k


def _add_spectra(a: tuple[Array, Array, Array], b: tuple[Array, Array, Array]):
    return a[0], a[1] + b[1], a[2] + b[2]


def _window_edges(rec: ChunkedRecord, length: float | None) -> Array:
    """Edges of :func:`hdpbsid.data.records.split_windows` (one window: the whole record)."""
    if length is None or rec.duration < 2 * length:
        return np.array([0, rec.ns - 1])
    # 1e-9: a whole number of windows up to rounding counts as whole (as split_windows)
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


class _Shared:
    """The record and the per-length data every batch task needs (one copy in a Dask
    graph).

    The projection maps (``N x n`` per input hold and window length, hundreds of MiB for
    long windows) are not shipped: every process builds them from the bases (small) on
    first use, so a ``dask.distributed`` graph carries the record's address, the bases and
    the lag operators only.  The lock keeps the threads of one worker from building them
    twice; neither the lock nor the maps are pickled.
    """

    def __init__(
        self,
        record: ChunkedRecord,
        mapped: dict[int, Any],
        kinds: dict[int, BlockKind],
        holds: tuple[str, ...],
    ) -> None:
        self.record, self.kinds, self.holds = record, kinds, holds
        self._mapped = mapped
        self._maps: dict[int, list[Array]] | None = None
        self._lock = threading.Lock()

    @property
    def maps(self) -> dict[int, list[Array]]:
        """``{n: [G_hold ..., G_y]}`` for the window lengths projected by maps."""
        with self._lock:
            if self._maps is None:
                dt = self.record.dt
                self._maps = {
                    n: _window_maps(b, n, dt, self.holds) for n, b in self._mapped.items()
                }
            return self._maps

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_maps"] = None
        del state["_lock"]
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()


def _coefficients(shared: _Shared, a: int, b: int, sizes: list[int], single: bool):
    """Coefficients of a batch of windows: ``([U per hold], Y)``."""
    if single:
        return _project_single(shared.record, a, b, shared.kinds[sizes[0]].basis, shared.holds)
    return _project_batch(shared.record, a, b, sizes, shared.maps)


def _batch_task(
    shared: _Shared, a: int, b: int, sizes: list[int], single: bool, step: Any, params: Any
) -> list[Any]:
    """Read and project one batch, then ``step(U, Y, lag, pseudo, params[hold], sizes)``
    per input hold on its windows."""
    Us, Y = _coefficients(shared, a, b, sizes, single)
    # private copies: the lag operators cache their powers, which threads must not share
    lags = {n: copy.deepcopy(shared.kinds[n].lag) for n in set(sizes)}
    lag = BlockLag([lags[n] for n in sizes], [shared.kinds[n].N for n in sizes])
    pseudo = BlockPseudo(lag, [shared.kinds[n].rows for n in sizes])
    return [step(U, Y, lag, pseudo, prm, sizes) for U, prm in zip(Us, params, strict=True)]


class _Batches:
    """The batches of a record: ``(first sample, end, window sizes, single)`` each, run
    serially or as ``dask.delayed`` tasks and reduced."""

    def __init__(
        self, jobs: list[tuple[int, int, list[int], bool]], shared: _Shared, use_dask: bool
    ) -> None:
        self.jobs, self.shared, self.use_dask = jobs, shared, use_dask

    def reduce(self, step: Any, params: Any, combine: Callable[[Any, Any], Any]) -> Any:
        """``combine`` of ``step``'s statistics over all batches (:func:`_reduce`)."""
        return _reduce(
            [
                [_batch_task, self.shared, a, b, sz, one, step, params]
                for a, b, sz, one in self.jobs
            ],
            combine,
            self.use_dask,
            shared=self.shared,
        )

    def gather(self) -> list[Any]:
        """Every batch's coefficients (the memory of all of them at once)."""
        tasks = [[_coefficients, self.shared, a, b, sz, one] for a, b, sz, one in self.jobs]
        return _compute(tasks, self.use_dask, shared=self.shared)


def _varx_step(U: Array, Y: Array, lag: BlockLag, pseudo: BlockPseudo, ps: list[int], sizes):
    # windows of one sample count share lag and pseudo rows: the count labels their kind
    return streamed.varx_factors(U, Y, lag, pseudo, ps, sizes)


def _state_step(U: Array, Y: Array, lag: BlockLag, pseudo: BlockPseudo, vs: Any, sizes):
    # None: a hold that was not chosen, nothing to gather (streamed.merge: the empty set)
    return None if vs is None else streamed.state_factors(U, Y, lag, pseudo, vs)


def _tightest(
    kinds: dict[int, BlockKind], sizes: Array, m: int, l: int
) -> tuple[int, int, int, int, int]:
    """The tightest window kind (fewest coefficients per ``m + q + l`` regressor rows; the
    first such length in dict order), its ``N`` and ``d = m + q + l``, the default rule's
    largest past window ``p_cap`` (``p d <= N / 6`` there and over all ``ncols``
    columns), and ``ncols``: ``(worst, nb, d, p_cap, ncols)``."""
    counts = {n: int(np.sum(sizes == n)) for n in kinds}
    ncols = sum(kinds[n].N * counts[n] for n in kinds)
    d = {n: m + _kept_rows(k) + l for n, k in kinds.items()}
    worst = min(kinds, key=lambda n: kinds[n].N / d[n])
    nb = kinds[worst].N
    p_cap = min(nb // (COLS_PER_REGRESSOR * d[worst]), ncols // (COLS_PER_REGRESSOR * (m + l)))
    return worst, nb, d[worst], p_cap, ncols


def _p_plan(
    kinds: dict[int, BlockKind], sizes: Array, m: int, l: int, st: BasisSettings, order: int | None
) -> tuple[list[int], int | None, int, int, str]:
    """The past windows to try, as :func:`~hdpbsid.bases.basis_domain.run_core` rules
    them: ``(candidates, p or None for AIC, lo, hi, rule)``."""
    need = order if order is not None else DEFAULTS.selection_rows
    f_min = -(-need // l)
    worst, nb, d, p_cap, ncols = _tightest(kinds, sizes, m, l)
    if st.p is not None:
        p = st.p
        if p * d >= nb - p:
            raise ValueError(
                f"p={p} is too large for the basis: the VARX has p*(m+q+l) = {p}*{d} = "
                f"{p * d} regressors per output (q = {d - m - l} boundary/truncation rows) "
                f"but only {nb} basis coefficients per window; reduce p or increase N"
            )
        if st.f is None and p * l < need:
            raise ValueError(f"order needs f*l >= {need}, but f = p = {p}; increase p")
        return [p], p, p, p, "given"
    lo = max(P_DEFAULT_RANGE[0], f_min, st.f or 1)
    hi = min(P_DEFAULT_RANGE[1], p_cap)
    if hi < lo:
        if lo > p_cap:
            p_max = _largest_determined_p(nb, d, ncols, m + l)
            raise BasisTooSmall(
                f"the basis is too small for the requested order by the default rule: it "
                f"needs a past window p >= {lo}, but N = {nb} coefficients and m+q+l = {d} "
                f"rows give p <= {p_cap} by p*(m+q+l) <= N/{COLS_PER_REGRESSOR}; the VARX is "
                f"determined up to p = {p_max}: pass p explicitly (less precise), increase "
                f"N, or ask for a smaller order",
                lo,
                p_max,
            )
        rule = (
            f"p = {lo}, the smallest window with f*l >= the order (above the preferred "
            f"range {P_DEFAULT_RANGE}; p*(m+q+l) <= N/{COLS_PER_REGRESSOR})"
        )
        return [lo], lo, lo, lo, rule
    rule = (
        f"min AIC of the VARX fit over p in [{lo}, {hi}] "
        f"(p*(m+q+l) <= N/{COLS_PER_REGRESSOR}, f*l >= required rows)"
    )
    return list(range(lo, hi + 1)), (lo if hi == lo else None), lo, hi, rule


def _kept_rows(kind: BlockKind) -> int:
    """Pseudo rows of a window kept by :class:`~hdpbsid.core.blocks.BlockPseudo`."""
    one = BlockPseudo(BlockLag([kind.lag], [kind.N]), [kind.rows])
    return int(one.groups[0][4].shape[0])


def _hold_windows(
    kinds: dict[int, BlockKind], sizes: Array, m: int, l: int, st: BasisSettings
) -> list[int]:
    """The past windows the input-hold criterion compares the holds over, as
    :func:`~hdpbsid.bases.basis_domain.hold_criterion` rules them: the given ``p``, or
    the preferred range capped at ``p (m + q + l) <= N / 6`` (empty when nothing fits)."""
    if st.p is not None:
        return [st.p]
    p_cap = _tightest(kinds, sizes, m, l)[3]
    lo, hi = P_DEFAULT_RANGE
    return list(range(max(lo, 1), min(hi, p_cap) + 1))


def _streamed_hold_criterion(vf: Any, m: int, l: int, windows: list[int], normalize: bool) -> float:
    """:func:`~hdpbsid.bases.basis_domain.hold_criterion` from first-pass factors: the
    smallest VARX AIC over ``windows`` (``inf`` when none fits)."""
    if not windows:
        return float("inf")
    try:
        _, crit = streamed.select_p(vf, m, l, windows[0], windows[-1], normalize)
    except ValueError:
        return float("inf")
    return float(np.min(crit[windows[0] - 1 : windows[-1]]))


def _best_hold_streamed(
    ctx: _Batches, sizes: Array, m: int, l: int, st: BasisSettings, order: int | None
) -> tuple[CoreOut, str, dict[str, float]]:
    """:func:`~hdpbsid.bases.basis_domain.best_hold` with
    :func:`~hdpbsid.bases.basis_domain.run_core` replaced by the streamed core
    (:mod:`hdpbsid.core.streamed`): two passes over the batches, factors reduced; the
    hold chosen from the first pass's factors by the same VARX criterion, and the second
    pass made for that hold only."""
    kinds, holds = ctx.shared.kinds, ctx.shared.holds
    ps, p_fixed, lo, hi, p_rule = _p_plan(kinds, sizes, m, l, st, order)
    first, hold, hold_crit = _first_pass(ctx, sizes, m, l, st, ps)
    k = holds.index(hold)
    vf = first[k]
    crit = None
    p = p_fixed
    if p is None:
        p, crit = streamed.select_p(vf, m, l, lo, hi, st.normalize)
    f = _future_window(st, p, l, order)
    vs = streamed.solve_varx(vf, m, l, p, f, st.regularize, RIDGE_FLOOR, st.normalize)
    # the second pass for the chosen hold only (None: nothing to gather for the others)
    second = ctx.reduce(
        _state_step, [vs if i == k else None for i in range(len(holds))], streamed.merge
    )
    mo = _max_order(st, vs.f, l, order)
    core = streamed.solve_model(vs, second[k], m, l, order, mo, RIDGE_FLOOR, st.stable_k)
    report = {
        "normalize": st.normalize,
        "input_scale": vs.su,
        "output_scale": vs.sy,
        "p_rule": p_rule,
        "p_criterion_values": crit,
        "f_rule": "given" if st.f is not None else "f = p",
        **_block_counts(kinds, sizes),
    }
    return _core_out(core, vs, m, l, kinds, sizes, report), hold, hold_crit


def _first_pass(
    ctx: _Batches, sizes: Array, m: int, l: int, st: BasisSettings, ps: list[int]
) -> tuple[list[Any], str, dict[str, float]]:
    """The first-pass factors of every input hold (the windows ``ps`` and those of the
    hold criterion), the hold of the smallest criterion (the first on ties) and the
    criterion of each hold (empty for one hold)."""
    kinds, holds = ctx.shared.kinds, ctx.shared.holds
    hold_ps = _hold_windows(kinds, sizes, m, l, st) if len(holds) > 1 else []
    first = ctx.reduce(_varx_step, [sorted(set(ps) | set(hold_ps))] * len(holds), streamed.merge)
    hold_crit = {
        h: _streamed_hold_criterion(vf, m, l, hold_ps, st.normalize)
        for h, vf in zip(holds, first, strict=True)
        if len(holds) > 1
    }
    hold = min(holds, key=lambda h: (hold_crit.get(h, 0.0), holds.index(h)))
    return first, hold, hold_crit


def _future_window(st: BasisSettings, p: int, l: int, order: int | None) -> int:
    """The future window: ``st.f`` checked against ``p`` and the order, else ``p``
    (:func:`~hdpbsid.bases.basis_domain.run_core`'s rule)."""
    need = order if order is not None else DEFAULTS.selection_rows
    if st.f is not None and st.f > p:
        raise ValueError(f"the future window f must satisfy f <= p, got f={st.f} > p={p}")
    if st.f is not None and st.f * l < need:
        raise ValueError(f"order needs f*l >= {need}, but f*l = {st.f * l}; increase f")
    return p if st.f is None else st.f


def _max_order(st: BasisSettings, f: int, l: int, order: int | None) -> int | None:
    """The largest order of the selection (None with a given order), checked against the
    ``f l`` rows of ``Gamma L``."""
    mo = min(st.max_order, f * l - 1) if order is None else None
    if mo is not None and mo < 1:
        raise ValueError("order selection needs f*l >= 2; increase p/f or pass an order")
    if order is not None and order > f * l:
        raise ValueError(
            f"order={order} exceeds f*l = {f}*{l} = {f * l}, the number of rows "
            f"of Gamma L; increase f (and p) or reduce the order"
        )
    return mo


def _block_counts(kinds: dict[int, BlockKind], sizes: Array) -> dict[str, int]:
    """The pseudo-inputs kept and the blocks, as the in-memory core reports them."""
    n_pseudo = sum(
        _kept_rows(kinds[int(n)]) * int(c)
        for n, c in zip(*np.unique(sizes, return_counts=True), strict=True)
    )
    return {"n_pseudo_inputs": n_pseudo, "n_blocks": int(sizes.size)}


def _core_out(
    core: Any,
    vs: Any,
    m: int,
    l: int,
    kinds: dict[int, BlockKind],
    sizes: Array,
    report: dict[str, Any],
) -> CoreOut:
    """The streamed core's model in user units (the normalisation undone), as
    :func:`~hdpbsid.bases.basis_domain.run_core` returns it."""
    lags = ", ".join(sorted({repr(k.lag) for k in kinds.values()}))
    core.options["lag"] = f"BlockLag({int(sizes.size)} blocks: {lags})"
    core.options["lag_strictly_causal"] = all(is_strictly_causal(k.lag) for k in kinds.values())
    su, sy = vs.su, vs.sy
    ncov = sy[:, None] * core.noise_covariance * sy[None, :]
    opts: dict[str, Any] = dict(core.options)
    opts.update(report)
    return CoreOut(
        core.A,
        core.B / su[None, :] if m else core.B[:, :0],
        core.C * sy[:, None],
        np.zeros((l, m)),
        core.K / sy[None, :],
        np.zeros((core.A.shape[0], 0)),
        ncov,
        core,
        opts,
    )


def _best_hold_in_memory(
    ctx: _Batches, sizes: Array, family: HermiteFamily, st: BasisSettings, order: int | None
) -> tuple[CoreOut, str, dict[str, float]]:
    """:func:`~hdpbsid.bases.pipeline.core_on_rows` on every window's coefficients at
    once (the settings the streamed core does not cover)."""
    kinds, holds = ctx.shared.kinds, ctx.shared.holds
    results = ctx.gather()
    Us = [np.hstack([r[0][i] for r in results]) for i in range(len(holds))]
    Yc = np.hstack([r[1] for r in results])
    lag, rows = stacked(kinds, [int(n) for n in sizes])
    return core_on_rows(family, st, order, holds, Us, Yc, rows, lag)


def _reduce(
    tasks: list[Any], combine: Callable[[Any, Any], Any], use_dask: bool, shared: Any = None
) -> Any:
    """``combine`` over the results of ``tasks`` (``[f, *args]``) without holding them
    all: serially a running fold; with Dask a pairwise tree of ``combine`` tasks, so the
    workers reduce and only the final result reaches the caller.  ``shared`` (an
    argument of many tasks) is put in the graph once."""
    if not use_dask:
        acc = None
        for f, *args in tasks:
            r = f(*args)
            acc = r if acc is None else combine(acc, r)
        return acc
    import dask

    one = dask.delayed(shared, pure=True) if shared is not None else None
    parts = [
        dask.delayed(f)(*[one if (one is not None and a is shared) else a for a in args])
        for f, *args in tasks
    ]
    while len(parts) > 1:
        nxt = [dask.delayed(combine)(x, y) for x, y in zip(parts[::2], parts[1::2], strict=False)]
        parts = nxt + ([parts[-1]] if len(parts) % 2 else [])
    return dask.compute(parts[0])[0]


@library_call
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

    Three passes over the data, never holding more than one batch of samples: the
    bandwidth from averaged periodograms, then the first-pass and the second-pass
    triangular factors of the streamed core (:mod:`hdpbsid.core.streamed`).  On the same
    windows the model is the in-memory one to rounding, up to the sign of each state
    coordinate.

    Parameters
    ----------
    record : ChunkedRecord
        The record (:func:`hdpbsid.data.io.open_chunked` for HDF5, Parquet and ``.npy``
        files; :meth:`~hdpbsid.data.chunked.ChunkedRecord.from_arrays` for sliceable arrays).
        No mean is removed: pass deviations from the operating point.
    order : int, optional
        Model order; None selects it.
    N : int, optional
        Basis size of every window (as in :func:`~hdpbsid.methods.hermite.identify_hermite`).
    chunk_samples : int, optional
        Samples read per batch of windows (at least one window is read).
    spectrum_samples : int, optional
        Samples per periodogram of the bandwidth estimate (:func:`averaged_spectra`).
    use_dask : bool, optional
        Batches as ``dask.delayed`` tasks (on the active ``dask.distributed`` client, if
        one exists), the factors combined pairwise by tasks as well.
    settings : BasisSettings, optional
        The shared settings; ``n_jobs`` is not used (batches run serially or on Dask).
    **shared
        The shared settings as keywords.  The operator scale is ``alpha = 4 scale``,
        ``beta = gamma = 1`` (the modes are not known before the last pass).

    Returns
    -------
    StateSpaceModel
        The continuous-time model; ``options["chunked"]`` reports the batches and which core
        ran (``"streamed"``, or ``"in memory"`` with ``feedthrough=True``, which the
        streamed core does not cover).

    Raises
    ------
    TypeError
        If ``record`` is not a :class:`~hdpbsid.data.chunked.ChunkedRecord`, or a keyword is
        not a shared setting.
    ValueError
        If an argument is out of range, or the record is too short for the order.

    References
    ----------
    .. [1] J. Demmel, L. Grigori, M. Hoemmen and J. Langou, "Communication-optimal
       parallel and sequential QR and LU factorizations", *SIAM J. Sci. Comput.* 34(1),
       A206-A239, 2012.
    .. [2] P. D. Welch, "The use of fast Fourier transform for the estimation of power
       spectra", *IEEE Trans. Audio Electroacoust.* 15(2), 70-73, 1967.

    Examples
    --------
    >>> from hdpbsid.data.chunked import ChunkedRecord
    >>> from hdpbsid.systems.linear import second_order, simulate_zoh
    >>> A, B, C, D = second_order()  # eigenvalues -0.4 +- 1.9596j
    >>> t = np.arange(0.0, 40.0, 0.05)
    >>> u = (np.sin(0.7 * t) + np.sin(1.9 * t) + np.sin(3.1 * t))[:, None]
    >>> record = ChunkedRecord.from_arrays(u, simulate_zoh(A, B, C, D, t, u), dt=0.05)
    >>> model = identify_chunked(record, order=2, chunk_samples=200)
    >>> np.sort_complex(model.eigenvalues).round(2), model.options["chunked"]["core"]
    (array([-0.4-1.96j, -0.4+1.96j]), 'streamed')
    """
    if not isinstance(record, ChunkedRecord):
        raise TypeError(f"record must be a ChunkedRecord, got {type(record).__name__}")
    chunk_samples = check_positive_int(chunk_samples, "chunk_samples", 2)
    st = resolve_settings(settings, shared, "identify_chunked")
    order = check_order(order)
    N = None if N is None else check_positive_int(N, "N", 2)
    family = HermiteFamily()
    w, Pu, Py = averaged_spectra(record, spectrum_samples, use_dask)
    wb = spectra_data_bandwidth(w, Pu, w, Py)
    length, info = _window(record, st, family, wb, lambda: spectrum_bandwidth(w, Py, LOW_FRACTION))
    edges = _window_edges(record, length)
    sizes = np.diff(edges) + 1  # samples per window (edge samples shared)
    # one basis per window length (samples), in order of first appearance
    spans = {n: ((n - 1) * record.dt, n) for n in dict.fromkeys(int(n) for n in sizes)}
    bases, size_choices = size_bases(family, size_policy(family, N, wb), spans)
    s_ref = float(np.median([b.scale for b in bases.values()]))
    op = Integrator(4.0 * s_ref, 1.0, 1.0)
    holds = resolve_holds(st.input_hold, record.m)
    kinds = block_kinds(family, bases, op, st.boundary)
    jobs, single = _plan_batches(edges, sizes, bases, len(holds), chunk_samples)
    mapped = {n: b for n, b in bases.items() if n not in single}
    ctx = _Batches(jobs, _Shared(record, mapped, kinds, holds), use_dask)
    if st.feedthrough:
        # not covered by the streamed core: every window's coefficients held at once
        out, hold, hold_crit = _best_hold_in_memory(ctx, sizes, family, st, order)
    else:
        out, hold, hold_crit = _best_hold_streamed(ctx, sizes, record.m, record.l, st, order)
    reasons = [c.reason for c in size_choices.values()]
    options = {
        **_report(record, bases, sizes, reasons, s_ref, st.boundary),
        "bandwidth": wb,
        "bandwidth_rule": (
            f"periodograms averaged over chunks of {min(record.ns, spectrum_samples)} samples"
        ),
        "chunked": {
            "batches": len(jobs),
            "chunk_samples": chunk_samples,
            "dask": use_dask,
            "core": "in memory" if st.feedthrough else "streamed",
        },
        **info,
        "window": length,
    }
    return to_fit(family, out, op, options, st, order, hold, hold_crit).model


def _window(
    record: ChunkedRecord,
    st: BasisSettings,
    family: HermiteFamily,
    wb: float,
    w_low: Callable[[], float],
) -> tuple[float | None, dict[str, Any]]:
    """The window length (s) of the ``window`` setting, or None, and its report: the rule
    of :func:`~hdpbsid.bases.segments.window_rule` for ``"auto"``, with the lowest
    significant output frequency ``w_low()`` from the averaged spectra."""
    if st.window is None:
        return None, {"window_rule": "none (window=None)"}
    if st.window == "auto":
        q = family.q[st.boundary]  # truncation row and the two boundary rows
        return window_rule(w_low(), record.duration, family.size_rate(wb), q, P_DEFAULT_RANGE[1])
    return float(st.window), {"window_rule": "given"}


def _plan_batches(
    edges: Array, sizes: Array, bases: dict[int, Any], n_holds: int, chunk_samples: int
) -> tuple[list[tuple[int, int, list[int], bool]], set[int]]:
    """Batches of consecutive windows, about ``chunk_samples`` samples each, read at once:
    ``(first sample, end, window sizes, single)``; a window whose projection map would be
    too large (:data:`~hdpbsid.bases.segments.MAP_BYTES`) is a batch of its own.  Returns
    the batches and the window lengths projected one by one."""
    jobs: list[tuple[int, int, list[int], bool]] = []
    batch: list[int] = []
    single: set[int] = set()

    def flush() -> None:
        if batch:
            a, b = int(edges[batch[0]]), int(edges[batch[-1] + 1]) + 1
            jobs.append((a, b, [int(sizes[i]) for i in batch], False))
            batch.clear()

    for k, n in enumerate(int(n) for n in sizes):
        # the maps of every hold and the output's, 8 bytes per float64 entry
        if bases[n].N * n * 8 * (n_holds + 1) > MAP_BYTES:  # too large a map: one by one
            flush()
            single.add(n)
            jobs.append((int(edges[k]), int(edges[k + 1]) + 1, [n], True))
            continue
        if batch and int(edges[k + 1]) - int(edges[batch[0]]) + 1 > chunk_samples:
            flush()
        batch.append(k)
    flush()
    return jobs, single


def _report(
    record: ChunkedRecord,
    bases: dict[int, Any],
    sizes: Array,
    reasons: list[str],
    s_ref: float,
    boundary: bool,
) -> dict[str, Any]:
    """The options of the blocks as :func:`~hdpbsid.methods.hermite.identify_hermite`
    reports them."""
    return {
        "method": "hermite",
        **size_report([bases[int(n)].N for n in sizes], reasons),
        "scale": s_ref,
        "centre": record.t0 + bases[int(sizes[0])].centre,
        "alpha_rule": "4 * scale (median over blocks)",
        "boundary": boundary,
        "truncation": "last column of the cut D absorbed as a pseudo-input",
        "n_samples": record.ns,
        "t0": record.t0,
        "n_records": 1,
        "n_segments": int(sizes.size),
    }


def _window_maps(basis: Any, n: int, dt: float, holds: tuple[str, ...]) -> list[Array]:
    """The projection maps of a window of ``n`` samples, ``[G_hold ..., G_y]``
    (:func:`~hdpbsid.bases.segments._maps`)."""
    Gu, Gy = _maps(basis, np.arange(n) * dt, holds)
    return Gu + [Gy]
