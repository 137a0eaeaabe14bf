"""The block-diagonal lag of stacked records, and the pseudo-row work kept on it.

Several records (or windows of one record) stacked side by side along the column axis are
lagged block by block (:class:`BlockLag`), never across a block edge.  What the
pseudo-input rows of :class:`~hdpbsid.core.blocks.BlockPseudo` share between objects on
one lag (their normalised rows, lag powers, Householder factorisations and eliminators)
is kept on the lag in a :class:`PseudoStore`.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.core.varx import CachedPowers, LagOperator, is_strictly_causal

__all__ = ["BlockLag", "PseudoStore"]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]


class BlockLag(CachedPowers):
    """Block-diagonal lag: each block of columns is lagged by its own operator.

    Several records (or windows of one record) stacked side by side must not be lagged
    across their edges: the sample before a record's first one is not the last sample of
    the previous record.  ``apply(W, j)`` therefore lags the columns of block ``b`` with
    ``lags[b]`` only.  Blocks with the same lag object and size form a group that is
    lagged in one call (columns reshaped to rows).  Powers of the last argument are cached
    (:class:`~hdpbsid.core.varx.CachedPowers`).

    Parameters
    ----------
    lags : sequence of LagOperator
        One lag operator per block.
    sizes : sequence of int
        The number of consecutive columns of each block.

    Attributes
    ----------
    lags : list of LagOperator
        The block lags.
    sizes : list of int
        The block sizes.
    offsets : ndarray of int
        The first column of each block, and the total at the end.
    ncols : int
        The total number of columns.
    groups : list of tuple
        ``(lag, size, blocks, columns)`` of the blocks lagged together.

    Raises
    ------
    ValueError
        If ``lags`` and ``sizes`` are empty or of different lengths.

    Examples
    --------
    >>> from hdpbsid.core.varx import SampleShift
    >>> shift = SampleShift()
    >>> lag = BlockLag([shift, shift], [3, 3])
    >>> lag.apply(np.arange(6.0)[None], 1)
    array([[0., 0., 1., 0., 3., 4.]])
    >>> lag.valid_columns(np.ones(6, dtype=bool), 1)
    array([False,  True,  True, False,  True,  True])
    """

    def __init__(self, lags: Sequence[LagOperator], sizes: Sequence[int]) -> None:
        super().__init__()
        if len(lags) != len(sizes) or not lags:
            raise ValueError("lags and sizes must be non-empty and of equal length")
        self.lags = list(lags)
        self.sizes = [int(s) for s in sizes]
        self.offsets = np.concatenate([[0], np.cumsum(self.sizes)]).astype(int)
        self.ncols = int(self.offsets[-1])
        groups: dict[tuple[int, int], list[int]] = {}
        for b, (lag, n) in enumerate(zip(self.lags, self.sizes, strict=True)):
            groups.setdefault((id(lag), n), []).append(b)
        self.groups = [
            (self.lags[bs[0]], self.sizes[bs[0]], bs, self.columns(bs)) for bs in groups.values()
        ]
        # pseudo-row work shared by the BlockPseudo objects built on this lag (BlockPseudo)
        self.pseudo_stores: OrderedDict[tuple[int, ...], PseudoStore] = OrderedDict()

    @property
    def strictly_causal(self) -> bool:
        """Whether every block's lag is strictly causal
        (:func:`~hdpbsid.core.varx.is_strictly_causal`)."""
        return all(is_strictly_causal(lag) for lag in self.lags)

    def columns(self, blocks: Sequence[int]) -> NDArray[np.intp]:
        """Column indices of blocks of equal size.

        Parameters
        ----------
        blocks : sequence of int
            Block indices, all of one size ``N``.

        Returns
        -------
        ndarray of int, shape (len(blocks), N)
            Row ``i`` holds the columns of block ``blocks[i]``.
        """
        return np.array(
            [np.arange(self.offsets[b], self.offsets[b + 1]) for b in blocks], dtype=np.intp
        )

    def _once(self, W: Array) -> Array:
        if len(self.groups) == 1 and len(self.groups[0][2]) == 1:
            return self.groups[0][0].apply(W, 1)  # one block: no gather / scatter of columns
        out = np.empty_like(W)
        rows = W.shape[0]
        for lag, n, bs, idx in self.groups:
            Wg = W[:, idx].reshape(rows * len(bs), n)
            out[:, idx] = lag.apply(Wg, 1).reshape(rows, len(bs), n)
        return out

    def cache_key(self) -> tuple | None:
        """Exact key of the operator for memoisation.

        Returns
        -------
        tuple or None
            The block sizes and every block lag's ``cache_key()``; ``None`` when a block lag
            has none (the operator then cannot be memoised).
        """
        keys = []
        for lag in self.lags:
            k = getattr(lag, "cache_key", None)
            k = k() if callable(k) else None
            if k is None:
                return None
            keys.append((type(lag).__qualname__, k))
        return (tuple(self.sizes), tuple(keys))

    def valid_columns(self, valid: Mask, j: int) -> Mask:
        """Which columns of ``apply(., j)`` the known columns determine, block by block.

        Parameters
        ----------
        valid : ndarray of bool, shape (ncols,)
            The known input columns.
        j : int
            Number of lags.

        Returns
        -------
        ndarray of bool, shape (ncols,)
            Each block's ``valid_columns`` of its own part of ``valid``.
        """
        out = np.empty_like(valid)
        for b, lag in enumerate(self.lags):
            sl = slice(self.offsets[b], self.offsets[b + 1])
            out[sl] = lag.valid_columns(valid[sl], j)
        return out

    def __repr__(self) -> str:
        kinds = sorted({repr(g[0]) for g in self.groups})
        return f"BlockLag({len(self.lags)} blocks: {', '.join(kinds)})"


class PseudoStore:
    """What :class:`~hdpbsid.core.blocks.BlockPseudo` shares between objects on one lag and
    one set of rows.

    Parameters
    ----------
    rows : sequence of ndarray
        The pseudo-input rows per block (kept, so that their ids stay valid).
    groups : list of tuple
        ``(lag, size, blocks, columns, normalised rows)`` per group.
    """

    #: stores kept per lag (rows sets in use at once: the data's and a reference's)
    PER_LAG = 4

    def __init__(self, rows: Sequence[Array], groups: list) -> None:
        self.rows = list(rows)  # keeps the ids in the key valid
        self.copies = {id(r): np.array(r, dtype=float, copy=True) for r in rows}
        self.groups = groups
        self.powers: list[list[Array]] = [[P] for *_, P in groups]
        self.qr: dict[tuple, tuple[int, Array, Array]] = {}
        self.eliminators: dict[tuple, Any] = {}  # Eliminator

    @staticmethod
    def lookup(lag: BlockLag, rows: Sequence[Array]) -> PseudoStore | None:
        """The store of ``rows`` on ``lag``, if the same arrays with unchanged contents.

        Parameters
        ----------
        lag : BlockLag
            The lag the store hangs on.
        rows : sequence of ndarray
            The pseudo-input rows per block.

        Returns
        -------
        PseudoStore or None
            The store, or None (none kept, or the contents changed).
        """
        stores = getattr(lag, "pseudo_stores", None)
        if stores is None:
            return None
        store = stores.get(tuple(id(r) for r in rows))
        if store is None:
            return None
        for r in rows:  # same objects; unchanged contents
            c = store.copies[id(r)]
            a = np.asarray(r)
            if a.shape != c.shape or not np.array_equal(a, c):
                del stores[tuple(id(r) for r in rows)]
                return None
        return store

    @staticmethod
    def add(lag: BlockLag, rows: Sequence[Array], groups: list) -> PseudoStore:
        """A new store of ``rows``, kept on ``lag`` (the oldest beyond ``PER_LAG`` dropped).

        Parameters
        ----------
        lag : BlockLag
            The lag the store hangs on.
        rows : sequence of ndarray
            The pseudo-input rows per block.
        groups : list of tuple
            Their groups.

        Returns
        -------
        PseudoStore
            The store.
        """
        store = PseudoStore(rows, groups)
        stores = getattr(lag, "pseudo_stores", None)
        if stores is not None:
            stores[tuple(id(r) for r in rows)] = store
            while len(stores) > PseudoStore.PER_LAG:
                stores.popitem(last=False)
        return store
