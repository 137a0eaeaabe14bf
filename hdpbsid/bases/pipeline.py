"""The basis-domain pipeline: records and a family -> the core's problem -> a model.

Every basis method runs the same steps (docs/theory.md); only the family
(:class:`~hdpbsid.bases.family.BasisFamily`) and the choices differ:

1. :func:`make_blocks` -- the records, cut into windows by the window rule, each block with
   its basis of the chosen size (blocks with the same relative time axis share one);
2. :func:`project` -- the coefficient rows of every block side by side, one input
   projection per input hold (:func:`~hdpbsid.bases.segments.project_blocks`);
3. :func:`solve` -- the pseudo-input rows and lag of every block, the core on the stacked
   problem with the input hold of the smaller VARX AIC
   (:func:`~hdpbsid.bases.basis_domain.best_hold`), and the family's map back to a model.

The pipeline makes no choices: the window rule, the basis size of a block, the operator
scale, the input holds to compare and the past windows are passed in, chosen by the
method's policies, and every choice is reported in the model's options as its reason.

The steps that do not need every block's coefficients at once are functions of their own,
shared with HD-PBSID on records read in chunks (:mod:`hdpbsid.methods.chunked`), whose
windows are sample ranges of a record never held whole: :func:`size_bases` (one basis per
kind of block, of the size the policy chooses) and :func:`size_report`; :func:`block_kinds`
and :func:`stacked` (the lag and pseudo-input rows of every kind at one operator scale, and
of the blocks side by side); :func:`core_on_rows` (the core with the input hold of the
smaller VARX AIC on stacked coefficient rows) and :func:`to_fit` (the family's map back).
Projection and the core differ there: the chunked path projects batches of windows as
they are read and accumulates the core's triangular factors batch by batch
(:mod:`hdpbsid.core.streamed`) instead of stacking the rows.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.basis_domain import CoreOut, best_hold
from hdpbsid.bases.family import BasisFamily, Choice
from hdpbsid.bases.segments import make_segments, project_blocks, shared_keys
from hdpbsid.bases.settings import BasisSettings
from hdpbsid.core.blocks import BlockLag
from hdpbsid.data.records import Record
from hdpbsid.models.model import StateSpaceModel

__all__ = [
    "Blocks",
    "BlockKind",
    "Projection",
    "Fit",
    "make_blocks",
    "project",
    "lag",
    "solve",
    "one_or_all",
    "size_bases",
    "size_report",
    "block_kinds",
    "stacked",
    "core_on_rows",
    "to_fit",
]

Array = NDArray[np.float64]


def one_or_all(values: Sequence[Any]) -> Any:
    """The value shared by all blocks, or the list of them when they differ.

    Parameters
    ----------
    values : sequence
        One value per block (compared by ``repr``).

    Returns
    -------
    object or list
        ``values[0]`` when all are equal, else ``list(values)``.

    Examples
    --------
    >>> one_or_all([3, 3, 3]), one_or_all([3, 4])
    (3, [3, 4])
    """
    return values[0] if len(set(map(repr, values))) == 1 else list(values)


def size_report(Ns: Sequence[int], reasons: Sequence[str]) -> dict[str, Any]:
    """The report of the basis sizes: the largest, each block's when they differ, the rule.

    Parameters
    ----------
    Ns : sequence of int
        The basis size of every block.
    reasons : sequence of str
        The size rule's reason of every kind of block.

    Returns
    -------
    dict
        ``N``, ``N_per_block`` (None when there is one block) and ``N_rule``
        (:func:`one_or_all` of the reasons).

    Examples
    --------
    >>> size_report([40, 40], ["band rule"])
    {'N': 40, 'N_per_block': [40, 40], 'N_rule': 'band rule'}
    """
    return {
        "N": int(max(Ns)),
        "N_per_block": list(Ns) if len(Ns) > 1 else None,
        "N_rule": one_or_all(list(reasons)),
    }


def size_bases(
    family: BasisFamily,
    size: Callable[[float, int], Choice[int]],
    spans: dict[Hashable, tuple[float, int]],
) -> tuple[dict[Hashable, Any], dict[Hashable, Choice[int]]]:
    """One basis per kind of block, of the size the size policy chooses for its span.

    Parameters
    ----------
    family : BasisFamily
        The basis family.
    size : callable
        ``size(T, ns) -> Choice[int]`` (:func:`~hdpbsid.bases.family.size_policy`).
    spans : dict
        ``spans[key] = (T, ns)``: the duration (s) and samples of the blocks of that kind,
        in the order the bases are made.

    Returns
    -------
    bases : dict
        The basis per key.
    sizes : dict
        The size choice per key.
    """
    bases: dict[Hashable, Any] = {}
    sizes: dict[Hashable, Choice[int]] = {}
    for key, (T, ns) in spans.items():
        sizes[key] = size(T, ns)
        bases[key] = family.basis(int(sizes[key].value), float(T))
    return bases, sizes


@dataclass(frozen=True)
class Blocks:
    """Records cut into blocks, each with its basis.

    Attributes
    ----------
    family : BasisFamily
        The basis family.
    records : list of Record
        The records.
    segs : list of Record
        The blocks (records or windows).
    keys : list of int
        ``keys[i]``: the first block with the same relative time axis as block ``i`` (they
        share basis, lag and rows).
    bases : dict of int to Basis
        The basis per key.
    sizes : dict of int to Choice
        The basis-size choice per key.
    window : dict
        The window rule's report.
    """

    family: BasisFamily
    records: list[Record]
    segs: list[Record]
    keys: list[int]
    bases: dict[int, Any]
    sizes: dict[int, Choice[int]]
    window: dict[str, Any]

    @property
    def seg_bases(self) -> list[Any]:
        """The basis of every block."""
        return [self.bases[k] for k in self.keys]

    @property
    def Ns(self) -> list[int]:
        """The basis size of every block."""
        return [b.N for b in self.seg_bases]

    def options(self) -> dict[str, Any]:
        """The report of the blocks: sizes and their rule, samples, window rule.

        Returns
        -------
        dict
            ``N``, ``N_per_block``, ``N_rule``, ``n_samples``, ``t0`` and the window report.
        """
        return {
            **size_report(self.Ns, [c.reason for c in self.sizes.values()]),
            "n_samples": int(sum(r.ns for r in self.records)),
            "t0": self.records[0].t0,
            **self.window,
        }


def make_blocks(
    records: Sequence[Record],
    family: BasisFamily,
    window: Any,
    window_rule: Callable[[], tuple[float | None, dict[str, Any]]],
    size: Callable[[float, int], Choice[int]],
) -> Blocks:
    """Cut the records into blocks and give each its basis.

    Parameters
    ----------
    records : sequence of Record
        The records (:func:`hdpbsid.data.records.as_records`).
    family : BasisFamily
        The basis family.
    window : float, "auto" or None
        The window setting (:class:`~hdpbsid.bases.settings.BasisSettings`).
    window_rule : callable
        ``() -> (length or None, report)``, the default window (``window="auto"``).
    size : callable
        ``size(T, ns) -> Choice[int]``, the basis size of a block of ``T`` s, ``ns`` samples
        (:func:`~hdpbsid.bases.family.size_policy`).

    Returns
    -------
    Blocks
        The blocks, their bases and the size and window reports.
    """
    segs, w_info = make_segments(records, window, window_rule)
    keys = shared_keys(segs)
    spans: dict[Hashable, tuple[float, int]] = {}
    for key, seg in zip(keys, segs, strict=True):
        spans.setdefault(key, (seg.duration, seg.ns))
    bases, sizes = size_bases(family, size, spans)
    return Blocks(family, list(records), segs, keys, bases, sizes, w_info)


@dataclass(frozen=True)
class Projection:
    """The coefficient rows of all blocks side by side.

    Attributes
    ----------
    blocks : Blocks
        The blocks projected.
    holds : tuple of str
        The input holds projected.
    Us : list of ndarray, shape (m, sum N_b)
        ``Us[h]``: the input rows under ``holds[h]``.
    Y : ndarray, shape (l, sum N_b)
        The output rows.
    ones : list
        ``ones[i]``: the coefficients of the constant 1 on block ``i`` (when the family
        needs them, else None entries).
    """

    blocks: Blocks
    holds: tuple[str, ...]
    Us: list[Array]
    Y: Array
    ones: list[Any]

    def split_inputs(self, m: int) -> tuple[Projection, Array]:
        """The projection with the first ``m`` input rows, and the remaining rows of the first
        hold (extra columns projected alike, e.g. a reference signal).

        Parameters
        ----------
        m : int
            Number of real inputs.

        Returns
        -------
        projection : Projection
            The projection of the real inputs.
        extra : ndarray, shape (k, sum N_b)
            The remaining input rows of the first hold.
        """
        return replace(self, Us=[U[:m] for U in self.Us]), self.Us[0][m:]


def project(blocks: Blocks, holds: tuple[str, ...], n_jobs: int | None = None) -> Projection:
    """Project every block on its basis (:func:`~hdpbsid.bases.segments.project_blocks`).

    Parameters
    ----------
    blocks : Blocks
        The blocks and their bases (:func:`make_blocks`).
    holds : tuple of str
        The input holds to project (:func:`~hdpbsid.bases.basis_domain.resolve_holds`).
    n_jobs : int or None
        joblib workers for blocks projected one by one.

    Returns
    -------
    Projection
        The coefficient rows of all blocks.
    """
    ones = (lambda tau: np.ones(tau.size)) if blocks.family.needs_ones else None
    Us, Y, ex = project_blocks(blocks.seg_bases, blocks.segs, holds, y_extra=ones, n_jobs=n_jobs)
    return Projection(blocks, tuple(holds), Us, Y, ex)


@dataclass(frozen=True)
class Fit:
    """A fitted model and the input hold it used.

    Attributes
    ----------
    model : StateSpaceModel
        The continuous-time model.
    hold : str
        The input hold of the projection it was fitted on.
    criterion : dict of str to float
        The hold criterion of each hold compared (empty when one was given).
    """

    model: StateSpaceModel
    hold: str
    criterion: dict[str, float]


@dataclass(frozen=True)
class BlockKind:
    """What the blocks of one kind share at one operator scale: basis, lag, pseudo rows.

    Attributes
    ----------
    basis : Basis
        The basis.
    lag : object
        The family's lag operator (:meth:`~hdpbsid.bases.family.BasisFamily.lag`).
    rows : ndarray, shape (q, N)
        The pseudo-input rows (:meth:`~hdpbsid.bases.family.BasisFamily.pseudo_rows`).
    """

    basis: Any
    lag: Any
    rows: Array

    @property
    def N(self) -> int:
        """The basis size."""
        return int(self.basis.N)


def block_kinds(
    family: BasisFamily,
    bases: dict[Hashable, Any],
    operator: Any,
    boundary: bool,
    ones: dict[Hashable, Any] | None = None,
) -> dict[Hashable, BlockKind]:
    """The lag and pseudo-input rows of every kind of block at the operator scale.

    Parameters
    ----------
    family : BasisFamily
        The basis family.
    bases : dict
        The basis per key (:func:`size_bases`).
    operator : object
        The family's operator scale.
    boundary : bool
        Include the boundary rows.
    ones : dict, optional
        The coefficients of the constant 1 per key (families that need them).

    Returns
    -------
    dict of BlockKind
        Per key, in the order of ``bases``.
    """
    return {
        k: BlockKind(
            b,
            family.lag(b, operator),
            family.pseudo_rows(b, operator, boundary, None if ones is None else ones[k]),
        )
        for k, b in bases.items()
    }


def stacked(
    kinds: dict[Hashable, BlockKind], keys: Sequence[Hashable]
) -> tuple[BlockLag, list[Array]]:
    """The block-diagonal lag and the pseudo-input rows of blocks side by side.

    Parameters
    ----------
    kinds : dict of BlockKind
        The kinds (:func:`block_kinds`).
    keys : sequence
        The kind of every block, in column order.

    Returns
    -------
    lag : BlockLag
        The lag of the blocks (blocks of one kind share one lag object).
    rows : list of ndarray
        The pseudo-input rows of every block.
    """
    lag = BlockLag([kinds[k].lag for k in keys], [kinds[k].N for k in keys])
    return lag, [kinds[k].rows for k in keys]


def lag(blocks: Blocks, operator: Any) -> BlockLag:
    """The block-diagonal lag of all blocks at the operator scale ``operator``.

    Parameters
    ----------
    blocks : Blocks
        The blocks; blocks sharing a key share one lag object (grouped by
        :class:`~hdpbsid.core.blocks.BlockLag`).
    operator : object
        The family's operator scale.

    Returns
    -------
    BlockLag
        The lag.
    """
    lags = {k: blocks.family.lag(b, operator) for k, b in blocks.bases.items()}
    return BlockLag([lags[k] for k in blocks.keys], blocks.Ns)


def solve(
    proj: Projection,
    operator: Any,
    settings: BasisSettings,
    order: int | None,
    options: dict[str, Any],
    *,
    holds: tuple[str, ...] | None = None,
    instruments: Callable[[BlockLag], Array] | None = None,
    **hold_options: Any,
) -> Fit:
    """The core on the projected blocks at one operator scale, mapped back to a model.

    Parameters
    ----------
    proj : Projection
        The coefficient rows (:func:`project`).
    operator : object
        The family's operator scale (:class:`~hdpbsid.bases.family.Integrator`, or None
        for a family without one).
    settings : BasisSettings
        The shared settings (core options, boundary rows).
    order : int or None
        The model order (None: chosen from the singular values).
    options : dict
        The method's report, merged into the model's options.
    holds : tuple of str, optional
        The input holds to compare (a subset of ``proj.holds``; default all).
    instruments : callable, optional
        ``instruments(lag) -> rows``: the instrumental-variable core.
    **hold_options
        ``hold_range``, ``p_range``: passed to
        :func:`~hdpbsid.bases.basis_domain.best_hold`.

    Returns
    -------
    Fit
        The model and its input hold.
    """
    b = proj.blocks
    use = proj.holds if holds is None else holds
    ones: dict[Hashable, Any] = {}
    for i, key in enumerate(b.keys):
        if key not in ones:
            ones[key] = proj.ones[i]
    kinds = block_kinds(b.family, b.bases, operator, settings.boundary, ones)
    L, P = stacked(kinds, b.keys)
    Us = [proj.Us[proj.holds.index(h)] for h in use]
    out, hold, crit = core_on_rows(
        b.family, settings, order, use, Us, proj.Y, P, L, instruments=instruments, **hold_options
    )
    return to_fit(b.family, out, operator, options, settings, order, hold, crit)


def core_on_rows(
    family: BasisFamily,
    settings: BasisSettings,
    order: int | None,
    holds: Sequence[str],
    Us: list[Array],
    Y: Array,
    rows: list[Array],
    L: BlockLag,
    *,
    instruments: Callable[[BlockLag], Array] | None = None,
    **hold_options: Any,
) -> tuple[CoreOut, str, dict[str, float]]:
    """The core on stacked coefficient rows, with the input hold of the smaller VARX AIC.

    Parameters
    ----------
    family : BasisFamily
        The basis family (its ``core_overrides``).
    settings : BasisSettings
        The shared settings (core options).
    order : int or None
        The model order (None: chosen from the singular values).
    holds : sequence of str
        The input holds compared.
    Us : list of ndarray, shape (m, sum N_b)
        The input rows per hold.
    Y : ndarray, shape (l, sum N_b)
        The output rows.
    rows : list of ndarray
        The pseudo-input rows of every block (:func:`stacked`).
    L : BlockLag
        The lag of the blocks.
    instruments : callable, optional
        ``instruments(L) -> rows``: the instrumental-variable core.
    **hold_options
        ``hold_range``, ``p_range``: passed to
        :func:`~hdpbsid.bases.basis_domain.best_hold`.

    Returns
    -------
    out : CoreOut
        The basis-domain system in user units.
    hold : str
        The input hold used.
    criterion : dict of str to float
        The hold criterion of each hold compared.
    """
    core = {**settings.core_options(order), **family.core_overrides}
    psi = instruments(L) if instruments is not None else None
    if psi is not None:
        core["instruments"] = psi
    return best_hold(holds, Us, Y, rows, L, **hold_options, **core)


def to_fit(
    family: BasisFamily,
    out: CoreOut,
    operator: Any,
    options: dict[str, Any],
    settings: BasisSettings,
    order: int | None,
    hold: str,
    criterion: dict[str, float],
) -> Fit:
    """The family's map back of the core's system to a continuous-time model.

    Parameters
    ----------
    family : BasisFamily
        The basis family.
    out : CoreOut
        The core's system (:func:`core_on_rows`, or the streamed core's).
    operator : object
        The operator scale the core ran at.
    options : dict
        The method's report, merged into the model's options.
    settings : BasisSettings
        The shared settings.
    order : int or None
        The order asked for.
    hold : str
        The input hold used.
    criterion : dict of str to float
        The hold criterion of each hold compared.

    Returns
    -------
    Fit
        The model and its input hold; the core's past window and its typed reason are in
        ``model.report.past_window``.
    """
    model = family.model(
        out, operator, options, settings=settings, hold=hold, hold_criterion=criterion, order=order
    )
    if out.window is not None:
        window = Choice(out.window.value, out.window.text, out.window.reason)
        model.report = model.report.but(past_window=window)
    return Fit(model, hold, criterion)
