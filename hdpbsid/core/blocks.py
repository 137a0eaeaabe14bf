"""The PBSID core over several column blocks with block-specific nuisance regressors.

Several experiments, or windows of one long record, are stacked along the column
(time / basis-index) axis: block ``b`` holds the ``N_b`` columns of record ``b``.  Lagging
never crosses a block edge (:class:`BlockLag`, the block-diagonal operator of per-block
lags).  In a basis domain each block also carries *pseudo-input* rows ``P_b`` (``q_b x
N_b``: boundary terms ``x(t0) phi(t0)^T - x(tN) phi(tN)^T``, the truncation of the cut
derivative operator): known rows whose vector factors are unknown **and different in
every block** (the state at each record's or window's edges).  Appended to the inputs
naively, they add ``sum_b q_b`` rows, and the VARX would grow by ``p sum_b q_b``
regressors per output, i.e. with the number of blocks.

Elimination (Frisch-Waugh-Lovell).  Every least-squares step of the core has the form

    T = Theta R + sum_b Gamma_b S_b + E,

with main regressors ``R`` (shared coefficients ``Theta``: the VARX's ``Xi_j``, ``C, D``,
``A, B, K``) and nuisance regressors ``S_b`` = block ``b``'s pseudo rows under the same
lags (``[P_b M_b^p; ...; P_b M_b]``, plus ``P_b`` with feedthrough, in the VARX; ``P_b``
in the ``C, D`` step with feedthrough; ``P_b M_b`` in the ``A, B, K`` step), zero outside
block ``b``.  Let ``Q_b`` (``N_b x r_b``) be an orthonormal basis of the row space of
``S_b`` (on the block's usable columns) and ``H_b`` (``N_b x (N_b - r_b)``) one of its
orthogonal complement.  Since the ``S_b`` have disjoint column supports, the projector
onto the complement of all nuisance rows is block diagonal, ``diag(H_b H_b^T)``, and the
Frisch-Waugh-Lovell theorem (Davidson & MacKinnon, *Econometric theory and methods*,
sec. 2.4) gives ``Theta`` exactly from the compressed problem

    [T_b H_b]_b = Theta [R_b H_b]_b + [E_b H_b]_b,

which has the size of the main problem (``sum_b (N_b - r_b)`` columns, the
residual degrees of freedom of the full problem): the global regression does not grow
with the number of blocks.  The nuisance coefficients follow block by block,
``Gamma_b = (T_b - Theta R_b) S_b^+``, and the residual is ``(T_b - Theta R_b)(I - Q_b
Q_b^T)``: both identical to the naive stacked solution.

Ridge (the VARX's GCV Tikhonov step).  Penalising the nuisance coefficients as well,
``+ lam^2 (||Theta||^2 + sum_b ||Gamma_b||^2)`` as when the pseudo-inputs were plain
input rows, and minimising over ``Gamma_b`` first leaves the weight ``I - S_b^T (S_b
S_b^T + lam^2 I)^{-1} S_b = H_b H_b^T + Q_b diag(lam^2 / (s^2 + lam^2)) Q_b^T`` (``s``
the singular values of ``S_b``): the compressed problem gains the ``r_b`` columns
``diag(lam / sqrt(s^2 + lam^2)) Q_b^T T_b`` per block and is again an ordinary ridge
problem in ``Theta``, and ``Gamma_b = (T_b - Theta R_b) S_b^T (S_b S_b^T + lam^2)^{-1}``.
``lam`` is chosen by GCV on the unpenalised-nuisance problem and then used for both.
The penalty matters: it makes the elimination the same estimator as the pseudo-inputs
appended to the inputs, and with the nuisance left free the noisy Laguerre projection
of a chirp broke down.  The nuisance coefficients are needed for the state
(``Gamma_f L_p Z_p`` includes the pseudo-inputs' columns of ``Gamma_f L_p``) and for the
Riccati residuals.  ``H_b`` is never formed: ``r_b`` Householder reflectors of ``Q_b``
map a block to ``[Q_b, H_b]^T`` coordinates, and the last ``N_b - r_b`` are kept.

Blocks that share the lag object, the column count and the pseudo-rows object (windows of
equal length of a uniformly sampled record) are handled together: their columns are
reshaped to one ``(rows * K, N)`` array, so each step is one BLAS call, not ``K``.
"""

from __future__ import annotations

import functools
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg.lapack import dgeqrf, dorgqr, dormqr

from hdpbsid.core.pbsid import (
    CoreResult,
    core_options,
    estimate_cd,
    resolve_order,
    stable_gain,
    thin_svd,
)
from hdpbsid.core.varx import (
    CachedPowers,
    LagOperator,
    VarxResult,
    parse_regularize,
    past_blocks,
    r_factor,
    ridge_gcv,
    two_stage_ls,
)
from hdpbsid.runtime import large_work

__all__ = [
    "BlockLag",
    "BlockPseudo",
    "VarxStage",
    "pbsid_core_blocks",
    "select_past_window_blocks",
    "varx_stage_blocks",
]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]

#: pseudo-input rows below this fraction of the block's largest row RMS carry no term
#: (the Laguerre boundary row at tN, ~e^{-aT}); normalising them would inject rounding
PSEUDO_ROW_FLOOR = 1e-8


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
        self.pseudo_stores: OrderedDict[tuple[int, ...], _PseudoStore] = OrderedDict()

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


class BlockPseudo:
    """Pseudo-input rows per block, whose coefficients are unknown and differ per block.

    In a basis domain each block carries known rows ``P_b`` (``q_b x N_b``: boundary terms
    of the projected derivative, whose factors are the state at the block's edges).
    Rows are normalised to unit RMS after dropping those below :data:`PSEUDO_ROW_FLOOR`
    of the block's largest (a row that small carries no term, and normalising it would
    inject rounding).  Blocks sharing the rows object (and lag object and size) are grouped
    as in :class:`BlockLag`.

    The work that depends only on the lag and the rows -- the normalised rows, their lag
    powers, the Householder factorisations of their row spaces and the finished
    eliminators -- is kept in a store on the :class:`BlockLag`, keyed by the identities of
    the row arrays and checked against their contents, so every ``BlockPseudo`` built on
    the same lag and rows shares it (e.g. core runs that differ only in the input hold).

    Parameters
    ----------
    lag : BlockLag
        The block lag the rows belong to.
    rows : sequence of array_like
        ``rows[b]`` of shape ``(q_b, sizes[b])``, one entry per block.

    Attributes
    ----------
    lag : BlockLag
        The block lag.
    groups : list of tuple
        ``(lag, size, blocks, columns, normalised rows)`` per group.

    Raises
    ------
    ValueError
        If ``rows`` does not have one entry per block or an entry has the wrong number of
        columns.
    """

    def __init__(self, lag: BlockLag, rows: Sequence[Array]) -> None:
        if len(rows) != len(lag.lags):
            raise ValueError(f"rows: one entry per block expected ({len(lag.lags)})")
        self.lag = lag
        store = _PseudoStore.lookup(lag, rows)
        if store is None:
            normed: dict[int, Array] = {}
            groups: dict[tuple[int, int, int], list[int]] = {}
            for b, P in enumerate(rows):
                P = np.asarray(P, dtype=float)
                if P.ndim != 2 or P.shape[1] != lag.sizes[b]:
                    raise ValueError(f"rows[{b}] must have {lag.sizes[b]} columns, got {P.shape}")
                if id(rows[b]) not in normed:
                    normed[id(rows[b])] = _normalise_rows(P)
                groups.setdefault((id(lag.lags[b]), lag.sizes[b], id(rows[b])), []).append(b)
            store = _PseudoStore.add(
                lag,
                rows,
                [
                    (lag.lags[bs[0]], lag.sizes[bs[0]], bs, lag.columns(bs), normed[key[2]])
                    for key, bs in groups.items()
                ],
            )
        self.groups = store.groups
        # lag powers of each group's rows, shared by every eliminator built on this object
        # (the AIC over p needs the powers 1..p for every p: p_max lags, not p_max^2 / 2)
        self._powers = store.powers
        self._store = store

    def lagged(self, g: int, js: Sequence[int]) -> Array:
        """The rows of group ``g`` lagged by each ``j`` in ``js``, stacked.

        Parameters
        ----------
        g : int
            Group index (into :attr:`groups`).
        js : sequence of int
            The lags (``0`` is the identity), in the order stacked.

        Returns
        -------
        ndarray, shape (q len(js), N)
            ``[lag^j P for j in js]``; the powers are computed once per object.
        """
        lag, *_, P = self.groups[g]
        if P.shape[0] == 0:
            return np.zeros((0, P.shape[1]))
        powers = self._powers[g]
        while len(powers) <= max(js, default=0):
            powers.append(lag.apply(powers[-1], 1))
        return np.vstack([powers[j] for j in js])

    def row_space(self, g: int, js: Sequence[int], mk: Mask, S: Array) -> tuple:
        """An orthonormal basis of the row space of ``S`` (group ``g``'s rows lagged by ``js``
        on the columns ``mk``), by a nested Householder QR.

        When ``js`` is a run of consecutive lags ``lo..hi`` (in any order), the rows are factored
        by increasing lag, one lag at a time, and the factorisation is kept per ``(g, mk,
        lo)``: lag ``j``'s rows are mapped by the reflectors of the lags before it and the part
        below the rows already eliminated is factored.  This is the blocked Householder QR of
        the whole stack (Golub & Van Loan, *Matrix Computations*, 4th ed., sec. 5.2.3), and its
        leading ``r`` reflectors and ``r x r`` block of ``R`` are those of the leading ``r``
        columns alone: the past windows ``p = 1..p_max`` share one factorisation, and a
        window's factors do not depend on what was asked for before.  Rank-deficient rows, or
        other sets of lags, are factored directly.

        Parameters
        ----------
        g : int
            Group index.
        js : sequence of int
            The lags of the rows of ``S``, in their order.
        mk : ndarray of bool, shape (N,)
            The columns used.
        S : ndarray, shape (q len(js), mk.sum())
            The lagged rows on those columns.

        Returns
        -------
        tuple
            ``(basis, s, Vt, refl, tau)``: ``basis()`` computes ``Q`` (``N_used x r``), ``s``
            the singular values of ``S``, ``Vt`` its right singular vectors in the order of
            ``js`` (``S^T = Q diag(s) Vt``), ``refl, tau`` the Householder reflectors.
        """
        P = self.groups[g][4]
        q, r, Nv = P.shape[0], S.shape[0], S.shape[1]
        lags = sorted(js)
        lo, hi = (lags[0], lags[-1]) if lags else (0, -1)
        if r == 0 or Nv < r or lags != list(range(lo, hi + 1)):
            return _eager(*_row_space(S))
        key = (g, mk.tobytes(), lo)
        got = self._store.qr.get(key)
        if got is None:
            got = (lo - 1, np.zeros((Nv, 0), order="F"), np.zeros(0))
        while got[0] < hi:
            j, refl_all, tau_all = got
            done = refl_all.shape[1]
            C = self.lagged(g, [j + 1])[:, mk].T  # (Nv, q), lag j + 1
            if done:
                C = _apply_qt(refl_all, tau_all, C)
            h, t = _householder(C[done:])
            ext = np.empty((Nv, done + q), order="F")
            ext[:, :done] = refl_all
            ext[:done, done:] = C[:done]
            ext[done:, done:] = h
            got = (j + 1, ext, np.concatenate([tau_all, t]))
            self._store.qr[key] = got
        refl, tau = got[1][:, :r], got[2][:r]
        Ur, s, Vt_asc = np.linalg.svd(np.triu(refl[:r]), full_matrices=False)
        tol = max(S.shape) * np.finfo(float).eps * s[0]
        if int(np.sum(s > tol)) < r:
            return _eager(*_row_space(S))
        perm = np.concatenate([np.arange((j - lo) * q, (j - lo + 1) * q) for j in js])

        def basis() -> Array:
            Q0, _, info = dorgqr(refl, tau, lwork=max(1, 64 * r))
            if info != 0:  # pragma: no cover - argument errors only
                raise ValueError(f"LAPACK orgqr failed (info = {info})")
            return Q0 @ Ur

        return basis, s, Vt_asc[:, perm], refl, tau

    def eliminator(self, js: Sequence[int], mask: Mask) -> Eliminator:
        """The eliminator of the rows lagged by ``js`` on the columns ``mask``, built once.

        Parameters
        ----------
        js : sequence of int
            The lags of the nuisance rows.
        mask : ndarray of bool, shape (ncols,)
            The global columns used.

        Returns
        -------
        Eliminator
            Shared by every call with the same lag, rows, ``js`` and ``mask`` (an eliminator
            is not modified after construction).
        """
        key = (tuple(int(j) for j in js), mask.tobytes())
        elim = self._store.eliminators.get(key)
        if elim is None:
            elim = Eliminator(self, js, mask)
            self._store.eliminators[key] = elim
        return elim

    @property
    def count(self) -> int:
        """Total number of (kept) pseudo rows over all blocks."""
        return sum(len(bs) * P.shape[0] for _, _, bs, _, P in self.groups)


def _eager(Q: Array, s: Array, Vt: Array, refl: Array, tau: Array) -> tuple:
    return (lambda: Q), s, Vt, refl, tau


class _PseudoStore:
    """What :class:`BlockPseudo` shares between objects on one lag and one set of rows."""

    #: stores kept per lag (rows sets in use at once: the data's and a reference's)
    PER_LAG = 4

    def __init__(self, rows: Sequence[Array], groups: list) -> None:
        self.rows = list(rows)  # keeps the ids in the key valid
        self.copies = {id(r): np.array(r, dtype=float, copy=True) for r in rows}
        self.groups = groups
        self.powers: list[list[Array]] = [[P] for *_, P in groups]
        self.qr: dict[tuple, tuple[int, Array, Array]] = {}
        self.eliminators: dict[tuple, Eliminator] = {}

    @staticmethod
    def lookup(lag: BlockLag, rows: Sequence[Array]) -> _PseudoStore | None:
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
    def add(lag: BlockLag, rows: Sequence[Array], groups: list) -> _PseudoStore:
        store = _PseudoStore(rows, groups)
        stores = getattr(lag, "pseudo_stores", None)
        if stores is not None:
            stores[tuple(id(r) for r in rows)] = store
            while len(stores) > _PseudoStore.PER_LAG:
                stores.popitem(last=False)
        return store


def _normalise_rows(P: Array) -> Array:
    if P.shape[0] == 0:
        return P
    r = np.sqrt(np.mean(P**2, axis=1))
    if r.max() <= 0:
        return P[:0]
    keep = r > PSEUDO_ROW_FLOOR * r.max()
    return P[keep] / r[keep, None]


@dataclass
class _Sub:
    """Blocks with one nuisance row space: orthonormal basis and Householder reflectors."""

    blocks: list[int]
    cols: NDArray[np.intp]  # (K, Nv) global column indices used
    S: Array  # nuisance rows on the used columns (r_raw x Nv)
    basis: Callable[[], Array]  # computes Q, the orthonormal basis of their span (Nv x k)
    sv: Array  # singular values of S (k)
    Vt: Array  # right singular vectors (k x r_raw)
    refl: Array  # Householder vectors (Nv x k, LAPACK raw layout)
    tau: Array

    @property
    def k(self) -> int:
        """Rank of the nuisance rows."""
        return int(self.sv.size)

    @functools.cached_property
    def Q(self) -> Array:
        """Orthonormal basis of the span (``Nv x k``), formed on first use: the plain
        compression needs only the reflectors."""
        return self.basis()


def _householder(A: Array) -> tuple[Array, Array]:
    """Householder QR of ``A`` in LAPACK's raw layout (``geqrf``: ``R`` in the upper
    triangle, the reflectors below it, factors ``tau``), as ``scipy.linalg.qr(A,
    mode="raw")`` but without its workspace query and input checks (a fifth of the time
    for the tall, thin nuisance matrices here)."""
    A = np.asfortranarray(A, dtype=float)
    if A.shape[1] == 0:
        return A, np.zeros(0)
    with large_work(2.0 * A.shape[0] * A.shape[1] ** 2):  # Householder QR: 2 n k^2 flops
        h, tau, _, info = dgeqrf(A, lwork=max(1, 64 * A.shape[1]))
    if info != 0:  # pragma: no cover - argument errors only
        raise ValueError(f"LAPACK geqrf failed (info = {info})")
    return h, tau


def _row_space(S: Array) -> tuple[Array, Array, Array, Array, Array]:
    """Orthonormal basis ``Q`` (``Nv x k``) of the row space of ``S`` (``r x Nv``), its
    singular values ``s`` and right vectors ``Vt`` (``S^T = Q diag(s) Vt``, rank ``k``
    by the usual ``max(r, Nv) eps s_1`` cut), and Householder reflectors (LAPACK raw
    layout ``refl, tau``) whose first ``k`` columns span ``Q``.

    ``S^T = Q_0 R`` by Householder QR first, then the SVD of the small ``r x r`` factor
    ``R = U_r diag(s) Vt``: ``S^T = (Q_0 U_r) diag(s) Vt`` is the thin SVD of ``S^T``
    (Golub & Van Loan, *Matrix Computations*, 4th ed., sec. 8.6.3, R-SVD), at the cost of
    one QR of the tall ``Nv x r`` matrix and none of its SVD.  At full rank ``k = r`` the
    QR's own reflectors already span ``Q``; only a rank-deficient ``S`` needs the
    reflectors of ``Q`` itself (a second QR)."""
    Nv, r = S.shape[1], S.shape[0]
    if r == 0 or Nv < r:
        U, s, Vt = np.linalg.svd(S.T, full_matrices=False)
        tol = max(S.shape) * np.finfo(float).eps * (s[0] if s.size else 0.0)
        k = int(np.sum(s > tol))
        refl, tau = _householder(U[:, :k])
        return U[:, :k], s[:k], Vt[:k], refl, tau
    refl, tau = _householder(S.T)
    Ur, s, Vt = np.linalg.svd(np.triu(refl[:r]), full_matrices=False)
    tol = max(S.shape) * np.finfo(float).eps * s[0]
    k = int(np.sum(s > tol))
    Q0, _, info = dorgqr(refl[:, :r], tau[:r], lwork=max(1, 64 * r))
    if info != 0:  # pragma: no cover - argument errors only
        raise ValueError(f"LAPACK orgqr failed (info = {info})")
    Q = Q0 @ Ur[:, :k]
    if k < r:
        refl, tau = _householder(Q)
    else:
        refl, tau = refl[:, :r], tau[:r]
    return Q, s[:k], Vt[:k], refl, tau


class Eliminator:
    """Compression onto the complement of every block's nuisance rows (module docstring).

    ``nuisance`` are the pseudo rows lagged by ``js``; ``mask`` the global columns used.
    """

    def __init__(self, pseudo: BlockPseudo | None, js: Sequence[int], mask: Mask) -> None:
        self.subs: list[_Sub] = []
        self.plain = np.flatnonzero(mask)  # columns of blocks without nuisance rows
        self.rank = 0
        if pseudo is None or not js:
            return
        has = np.zeros(mask.size, dtype=bool)
        for g, (_lag, _n, bs, idx, P) in enumerate(pseudo.groups):
            if P.shape[0] == 0:
                continue
            S_full = pseudo.lagged(g, js)
            masks = mask[idx]  # (K, N)
            # blocks of a group normally share the usable pattern; split where not
            patterns: dict[bytes, list[int]] = {}
            for i, row in enumerate(masks):
                patterns.setdefault(row.tobytes(), []).append(i)
            for rows_i in patterns.values():
                mk = masks[rows_i[0]]
                S = S_full[:, mk]
                basis, s, Vt, refl, tau = pseudo.row_space(g, js, mk, S)
                k = s.size
                cols = idx[rows_i][:, mk]
                has[idx[rows_i]] = True
                self.subs.append(_Sub([bs[i] for i in rows_i], cols, S, basis, s, Vt, refl, tau))
                self.rank += k * len(rows_i)
        self.plain = np.flatnonzero(mask & ~has)

    @property
    def ncols(self) -> int:
        """Columns of the compressed problem."""
        return int(self.plain.size + sum(s.cols.size - s.k * len(s.blocks) for s in self.subs))

    def compress(self, W: Array, lam: float = 0.0) -> Array:
        """``W`` (rows x all columns) -> its coordinates in the complement (rows x ncols).

        With ``lam > 0`` the nuisance coefficients are ridge-penalised like the main
        ones (``+ lam^2 ||Gamma_b||^2``): minimising over them leaves the weight
        ``I - S^T (S S^T + lam^2)^{-1} S = H H^T + Q diag(lam^2 / (s^2 + lam^2)) Q^T``,
        so the coordinates ``diag(lam / sqrt(s^2 + lam^2)) Q^T W`` are appended.
        """
        rows = W.shape[0]
        parts = [W[:, self.plain]]
        for s in self.subs:
            K, nv = s.cols.shape
            k = s.k
            if K == 1 and nv and s.cols[0, -1] - s.cols[0, 0] == nv - 1:
                # one block on consecutive columns (a sorted range): a slice, no gather
                C = np.asfortranarray(W[:, s.cols[0, 0] : s.cols[0, -1] + 1].T)
            else:
                C = np.asfortranarray(W[:, s.cols].reshape(rows * K, nv).T)  # (Nv, rows K)
            if k:
                # C <- [Q, H]^T C = H_k ... H_1 C, H_i = I - tau_i v_i v_i^T: the k
                # reflectors applied by LAPACK ormqr in one blocked call
                C = _apply_qt(s.refl, s.tau, C)
            parts.append(C[k:].T.reshape(rows, K * (nv - k)))
            if lam > 0:
                Wb = W[:, s.cols].reshape(rows * K, nv)
                soft = (Wb @ s.Q) * (lam / np.sqrt(s.sv**2 + lam**2))[None, :]
                parts.append(soft.reshape(rows, K * k))
        return np.hstack(parts)

    def residual(self, R: Array, lam: float = 0.0) -> tuple[Array, list[tuple[list[int], Array]]]:
        """Residual ``R`` (rows x all columns, zero off the mask) with each block's
        nuisance fit removed, and the nuisance coefficients per group of blocks
        (``(K, rows, r_raw)``: minimum-norm ``Gamma_b = R_b S_b^+``, or with ``lam > 0``
        the ridge ``R_b S_b^T (S_b S_b^T + lam^2)^{-1}``)."""
        out = np.zeros_like(R)
        out[:, self.plain] = R[:, self.plain]
        coefs = []
        rows = R.shape[0]
        for s in self.subs:
            K, nv = s.cols.shape
            Rb = R[:, s.cols].reshape(rows * K, nv)  # (rows K, Nv)
            RQ = Rb @ s.Q  # (rows K, k)
            filt = s.sv / (s.sv**2 + lam**2)
            G = (RQ * filt[None, :]) @ s.Vt  # (rows K, r_raw): R S^T (S S^T + lam^2)^-1
            fit = (RQ * (s.sv * filt)[None, :]) @ s.Q.T
            out[:, s.cols] = (Rb - fit).reshape(rows, K, nv)
            coefs.append((s.blocks, G.reshape(rows, K, -1).transpose(1, 0, 2)))
        return out, coefs


def _eliminator(pseudo: BlockPseudo | None, js: Sequence[int], mask: Mask) -> Eliminator:
    """The (shared) :class:`Eliminator` of ``pseudo`` for the lags ``js`` on ``mask``."""
    return pseudo.eliminator(js, mask) if pseudo is not None else Eliminator(None, js, mask)


def _apply_qt(refl: Array, tau: Array, C: Array) -> Array:
    """``Q^T C`` for the full orthogonal ``Q`` of a QR in raw layout (:func:`_householder`)
    (Householder vectors ``refl``, factors ``tau``), by LAPACK ``ormqr``."""
    C = np.asfortranarray(C, dtype=float)
    if C.shape[1] == 0:
        return C
    lwork = max(1, C.shape[1]) * 64  # the blocked ormqr's work space (nb = 64 columns)
    out, _, info = dormqr("L", "T", refl, tau, C, lwork, overwrite_c=False)
    if info != 0:  # pragma: no cover - argument errors only
        raise ValueError(f"LAPACK ormqr failed (info = {info})")
    return out


def _solve(Phi: Array, Y: Array, regularize: bool | str | float | None, floor: float):
    """Least squares / ridge ``Y ~ Theta Phi`` as :func:`hdpbsid.core.varx.varx` does."""
    kind, lam = parse_regularize(regularize)
    nreg = Phi.shape[0]
    if kind == "none":
        R = r_factor(Phi, Y)
        rcond = np.finfo(float).eps * max(Phi.shape)
        theta = np.linalg.lstsq(R[:nreg, :nreg], R[:nreg, nreg:], rcond=rcond)[0].T
        return theta, 0.0, None, kind
    theta, lam_used, g = ridge_gcv(
        Phi, Y, lam if kind == "fixed" else None, floor=floor if kind == "gcv" else 0.0
    )
    return theta, lam_used, g, kind


def _fwl_lstsq(reg: Array, target: Array, elim: Eliminator):
    """Plain least squares of ``target`` on ``reg`` with the nuisance eliminated.

    Returns ``(Theta, residual on all columns, nuisance coefficients)``."""
    Rc = elim.compress(np.vstack([reg, target]))
    d = reg.shape[0]
    theta = np.linalg.lstsq(Rc[:d].T, Rc[d:].T, rcond=None)[0].T
    res, coefs = elim.residual(target - theta @ reg)
    return theta, res, coefs


def select_past_window_blocks(
    U: Array,
    Y: Array,
    p_max: int,
    p_min: int,
    lag: LagOperator,
    pseudo: BlockPseudo | None,
    feedthrough: bool = False,
    rel_floor: float = 1e-12,
) -> tuple[int, Array]:
    """AIC of the VARX fit for ``p = p_min..p_max`` with the pseudo-inputs eliminated.

    As :func:`hdpbsid.core.varx.select_past_window` (``AIC = N log det Sigma_p + 2 l d_p``
    on unit-RMS outputs, ``Sigma_p`` floored at ``rel_floor``, every ``p`` on the columns
    valid for ``p_max``), with ``d_p`` counting the nuisance coefficients too: their number,
    the rank eliminated, grows with ``p``, and they are fitted like the others.  Each ``p``
    is one compressed fit, or, for one block whose nuisance rows have full rank, all ``p``
    come from one QR.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Inputs of all blocks side by side.
    Y : ndarray, shape (l, N)
        Outputs.
    p_max : int
        Largest window.
    p_min : int
        Smallest window.
    lag : LagOperator
        The (block) lag.
    pseudo : BlockPseudo or None
        Pseudo-input rows per block.
    feedthrough : bool, optional
        Include ``D u_k``.
    rel_floor : float, optional
        Floor of the scaled residual covariance (noise-free records choose the smallest
        exact window).

    Returns
    -------
    p : int
        The window of the smallest criterion.
    crit : ndarray, shape (p_max,)
        The criterion, ``inf`` where not evaluated.

    Raises
    ------
    ValueError
        If no window in ``[p_min, p_max]`` leaves enough columns for the VARX.

    References
    ----------
    .. [1] H. Akaike, "A new look at the statistical model identification", *IEEE Trans.
       Automatic Control* 19(6), 716-723, 1974.
    .. [2] R. Davidson and J. G. MacKinnon, *Econometric Theory and Methods*, Oxford
       University Press, 2004, sec. 2.4 (the Frisch-Waugh-Lovell theorem).
    """
    m, l = U.shape[0], Y.shape[0]
    Z = np.vstack([U, Y])
    all_valid = np.ones(Z.shape[1], dtype=bool)
    valid = all_valid.copy()
    for j in range(1, p_max + 1):
        valid &= lag.valid_columns(all_valid, j)
    N = int(valid.sum())
    scale = np.sqrt(np.mean(Y[:, valid] ** 2, axis=1))
    scale[scale == 0] = 1.0
    Ys = Y / scale[:, None]
    d0 = m if (feedthrough and m > 0) else 0
    lagged = [U] if d0 else []
    lagged += [lag.apply(Z, j) for j in range(1, p_max + 1)]
    crit = np.full(p_max, np.inf)

    def lags_of(p: int) -> list[int]:
        # the nuisance lags of window p, in the order of varx_stage_blocks (which then
        # reuses the chosen window's eliminator)
        return list(range(p, 0, -1)) + ([0] if d0 else [])

    nested = _nested_window_residuals(pseudo, lags_of, lagged, d0, Ys, valid, p_max)
    for p in range(max(p_min, 1), p_max + 1):
        q = d0 + p * (m + l)
        if nested is not None:
            rank, res = nested(p)
            if N - rank <= q + l:
                break
            crit[p - 1] = window_aic(res, N, q + rank, rel_floor)
            continue
        reg = np.vstack(lagged[: (1 if d0 else 0) + p])
        cs = np.sqrt(np.mean(reg[:, valid] ** 2, axis=1))
        cs[cs == 0] = 1.0
        elim = _eliminator(pseudo, lags_of(p), valid)
        if elim.ncols <= q + l:
            break
        Rc = elim.compress(np.vstack([reg / cs[:, None], Ys]))
        R = r_factor(Rc[:q], Rc[q:])
        crit[p - 1] = window_aic(R[q:, q:], N, q + elim.rank, rel_floor)
    return best_window(crit, p_min, p_max, N), crit


def window_aic(res: Array, N: int, coefficients: int, rel_floor: float) -> float:
    """Akaike's criterion of a VARX from the residual block of an R factor.

    Parameters
    ----------
    res : ndarray, shape (k, l)
        The residual rows of the R factor (unit-RMS outputs).
    N : int
        Number of columns of the regression.
    coefficients : int
        Coefficients per output, nuisance ones included.
    rel_floor : float
        Added to the diagonal of ``Sigma``.

    Returns
    -------
    float
        ``N log det Sigma + 2 l d`` with ``Sigma = res^T res / N + rel_floor I``.
    """
    l = res.shape[1]
    sigma = res.T @ res / N + rel_floor * np.eye(l)
    return float(N * np.linalg.slogdet(sigma)[1] + 2.0 * l * coefficients)


def best_window(crit: Array, p_min: int, p_max: int, N: int) -> int:
    """The past window ``p`` of the smallest criterion ``crit[p - 1]``.

    Parameters
    ----------
    crit : ndarray, shape (p_max,)
        Criterion values, ``inf`` where not fitted.
    p_min : int
        Smallest window (for the message).
    p_max : int
        Largest window (for the message).
    N : int
        Number of columns (for the message).

    Returns
    -------
    int
        The window.

    Raises
    ------
    ValueError
        If no window could be fitted (too few columns).
    """
    if not np.isfinite(crit).any():
        raise ValueError(
            f"p in [{p_min}, {p_max}]: too few columns ({N}) for the VARX with the "
            f"pseudo-inputs eliminated"
        )
    return int(np.argmin(crit)) + 1


def _nested_window_residuals(
    pseudo: BlockPseudo | None,
    lags_of: Callable[[int], list[int]],
    lagged: list[Array],
    d0: int,
    Ys: Array,
    valid: Mask,
    p_max: int,
) -> Callable[[int], tuple[int, Array]] | None:
    """All past windows' VARX residuals from one QR, when that is exact: one block (one
    lag, one set of pseudo rows) whose nuisance rows for ``p_max`` have full rank.

    Window ``p`` regresses ``Ys`` on the data lags ``1..p`` (and ``U`` with feedthrough)
    and the nuisance rows of the same lags; these regressors are the leading columns of
    ``[S_0, U, S_1, Z_1, ..., S_pmax, Z_pmax]`` (``S_j``, ``Z_j``: the pseudo rows and
    the data lagged ``j`` times, transposed; ``S_0, U`` only with feedthrough).  With
    the Householder QR of ``[that, Ys^T] = Q R``, the least-squares residual of ``Ys``
    on the leading ``k`` columns has the Gram matrix ``R[k:, -l:]^T R[k:, -l:]``
    (Golub & Van Loan, *Matrix Computations*, 4th ed., sec. 5.3.3): the residual
    covariance of every window from one factorisation instead of one eliminator,
    compression and QR per window -- the same least-squares problems, so the same
    criterion up to rounding.  Full rank of the ``p_max`` nuisance rows (by the
    eliminator's own cut) implies it for every leading subset (the smallest singular
    value of a column subset is at least that of the whole, the largest at most), so
    the nuisance rank of window ``p`` is its row count.  Returns ``p -> (rank,
    residual factor)``, or None when the per-window compressed fits are needed (several
    blocks, rank-deficient rows, too few columns).
    """
    if pseudo is None or len(pseudo.lag.lags) != 1 or len(pseudo.groups) != 1:
        return None
    P = pseudo.groups[0][4]
    q, Nv = P.shape[0], int(valid.sum())
    if q == 0:
        return None
    js = lags_of(p_max)
    S = pseudo.lagged(0, js)[:, valid]
    _, sv, *_ = pseudo.row_space(0, js, valid, S)
    if sv.size < S.shape[0]:
        return None
    cols = [pseudo.lagged(0, [0]), lagged[0]] if d0 else []
    for j in range(1, p_max + 1):
        cols += [pseudo.lagged(0, [j]), lagged[(1 if d0 else 0) + j - 1]]
    l = Ys.shape[0]
    width = [c.shape[0] for c in cols]
    total = sum(width) + l
    if Nv < total:
        return None
    use = slice(None) if Nv == valid.size else valid
    # the regressors (rows scaled to unit RMS as in the per-window fits; scaling a column
    # does not change the residual) and Ys, transposed into one Fortran-ordered array
    MT = np.empty((Nv, total), order="F")
    a = 0
    for c in [*cols, Ys]:
        b = a + c.shape[0]
        MT[:, a:b] = c[:, use].T
        a = b
    cs = np.sqrt(np.mean(MT[:, : total - l] ** 2, axis=0))
    cs[cs == 0] = 1.0
    MT[:, : total - l] /= cs[None, :]
    R = np.triu(_householder(MT)[0][:total])

    def at(p: int) -> tuple[int, Array]:
        k = sum(width[: (2 if d0 else 0) + 2 * p])
        return q * len(lags_of(p)), R[k:, -l:]

    return at


def _gamma_l_rows(coef: Array, p: int, f: int, d: int, l: int) -> Array:
    """``Gamma_f L_p`` row blocks from coefficients ``[Xi_p, ..., Xi_1]`` of ``d`` rows each
    (:func:`hdpbsid.core.pbsid.gamma_l` for any block width ``d``)."""
    LK = np.zeros((f * l, p * d))
    for i in range(f):
        LK[i * l : (i + 1) * l, i * d :] = coef[:, : (p - i) * d]
    return LK


@dataclass
class VarxStage:
    """The order-independent part of :func:`pbsid_core_blocks`.

    The VARX fit, the SVD ``Gamma_f L_p Z_p = Uu diag(s) Vt`` and the eliminator and
    lagged inputs of the ``A, B, K`` step.  Every order of one ``(data, lag, p, f)``
    truncates the same decomposition (the state is ``diag(s_1..n)^{1/2} Vt_{1..n}``), so a
    sweep over orders computes it once (:func:`varx_stage_blocks`).

    Attributes
    ----------
    cols : ndarray of int
        The columns on which the VARX is defined.
    valid : ndarray of bool
        The same as a mask over all columns.
    varx : VarxResult
        The VARX fit.
    elim : Eliminator
        The VARX's nuisance eliminator.
    Uu : ndarray
        Left singular vectors of ``Gamma_f L_p Z_p``.
    s : ndarray
        Its singular values, descending.
    Vt : ndarray
        Its right singular vectors.
    LU : ndarray, shape (m, N)
        The inputs lagged once.
    use : ndarray of bool
        The columns of the ``A, B, K`` regression.
    e1 : Eliminator
        The eliminator of the pseudo rows lagged once, on ``use``.
    extra_iv : dict
        The IV estimator's record (empty for least squares).
    """

    cols: NDArray[np.intp]
    valid: Mask
    varx: VarxResult
    elim: Eliminator
    Uu: Array
    s: Array
    Vt: Array
    LU: Array
    use: Mask
    e1: Eliminator
    extra_iv: dict


def varx_stage_blocks(
    U: Array,
    Y: Array,
    p: int,
    lag: LagOperator,
    pseudo: BlockPseudo | None = None,
    f: int | None = None,
    feedthrough: bool = False,
    regularize: bool | str | float | None = False,
    ridge_floor: float = 0.0,
    instruments: Array | None = None,
) -> VarxStage:
    """Steps 1-2 of :func:`pbsid_core_blocks` and the order-independent regressors of step 3.

    The VARX with each block's pseudo-inputs eliminated (ridge-penalised like the main
    coefficients when ``regularize`` chooses a ridge, so that the penalty treats them as
    the inputs they stand for), ``Gamma_f L_p Z_p`` with each block's pseudo-input part,
    and its SVD.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Inputs of all blocks side by side.
    Y : ndarray, shape (l, N)
        Outputs.
    p : int
        Past window.
    lag : LagOperator
        The (block) lag.
    pseudo : BlockPseudo, optional
        Pseudo-input rows per block.
    f : int, optional
        Future window (default ``p``).
    feedthrough : bool, optional
        Include ``D u_k``.
    regularize : bool, str, float or None, optional
        VARX regularisation (:func:`hdpbsid.core.varx.varx`).
    ridge_floor : float, optional
        Lower bound of the GCV ridge.
    instruments : ndarray, shape (k, N), optional
        Instrument rows (IV VARX).

    Returns
    -------
    VarxStage
        The stage shared by the orders.

    Raises
    ------
    ValueError
        If the compressed problem has no more columns than regressors (reduce ``p``).
    """
    m, l = U.shape[0], Y.shape[0]
    f = p if f is None else f
    ncols = Y.shape[1]
    ft = feedthrough and m > 0
    # -- 1. VARX ---------------------------------------------------------------------
    Z = np.vstack([U, Y])
    Zp_all, valid = past_blocks(Z, p, lag)
    cols = np.flatnonzero(valid)
    Phi = np.vstack([Zp_all, U]) if ft else Zp_all
    js = list(range(p, 0, -1)) + ([0] if (feedthrough and pseudo is not None) else [])
    elim = _eliminator(pseudo, js, valid)
    nreg = Phi.shape[0]
    if elim.ncols <= nreg:
        raise ValueError(
            f"the VARX regression has {nreg} regressors (p*(m+l) = {p}*({m}+{l})"
            f"{' + m' if ft else ''}) but only {elim.ncols} usable columns after "
            f"eliminating {elim.rank} pseudo-input directions: reduce p or supply more data"
        )
    extra_iv: dict = {}
    if instruments is None:
        Cz = elim.compress(np.vstack([Phi, Y]))
        theta, lam_used, gcv_val, kind = _solve(Cz[:nreg], Cz[nreg:], regularize, ridge_floor)
    else:
        Cz = elim.compress(np.vstack([Phi, Y, np.where(valid, instruments, 0.0)]))
        kind, lam = parse_regularize(regularize)
        theta, lam_used, gcv_val, extra_iv = two_stage_ls(
            Cz[:nreg],
            Cz[nreg : nreg + l],
            Cz[nreg + l :],
            lam if kind == "fixed" else (None if kind == "gcv" else 0.0),
            floor=ridge_floor if kind == "gcv" else 0.0,
        )
        # the nuisance coefficients are fitted unpenalised to the IV residual below
        ridge_iv, lam_used = lam_used, 0.0
    if lam_used > 0 and elim.rank:
        # the ridge penalises the pseudo-inputs' coefficients as well (as if they were
        # inputs): same lam, nuisance minimised out exactly (Eliminator.compress)
        Cs = elim.compress(np.vstack([Phi, Y]), lam_used)
        theta = ridge_gcv(Cs[:nreg], Cs[nreg:], lam_used)[0]
    res_full = np.zeros((l, ncols))
    res_full[:, cols] = Y[:, cols] - theta @ Phi[:, cols]
    resid, nuis = elim.residual(res_full, lam_used)
    coef = theta[:, : p * (m + l)]
    Xi = np.stack([coef[:, (p - j) * (m + l) : (p - j + 1) * (m + l)] for j in range(1, p + 1)])
    vx = VarxResult(
        Xi=Xi,
        coef=coef,
        D=theta[:, p * (m + l) :] if ft else np.zeros((l, m)),
        Zp=Zp_all[:, cols],
        columns=cols,
        residuals=resid[:, cols],
        ridge=lam_used if instruments is None else ridge_iv,
        regularize=kind,
        gcv=gcv_val,
        extra={
            "eliminated_pseudo_directions": elim.rank,
            "compressed_columns": elim.ncols,
            **extra_iv,
        },
    )
    # -- 2. Gamma L Z_p (+ each block's pseudo-input part), SVD, state ------------------
    LK = _gamma_l_rows(coef, p, f, m + l, l)
    S = np.zeros((f * l, ncols))
    S[:, cols] = LK @ Zp_all[:, cols]
    for sub, (blocks, G) in zip(elim.subs, nuis, strict=True):
        # G: (K, l, r_raw) coefficients of [P M^p; ...; P M^1 (; P)]; q rows per lag
        q = sub.S.shape[0] // len(js)
        Pp = sub.S[: p * q]  # lags p..1 on the used columns
        K = len(blocks)
        LKb = np.stack([_gamma_l_rows(G[k][:, : p * q], p, f, q, l) for k in range(K)])
        S[:, sub.cols] += np.einsum("kfr,rn->fkn", LKb, Pp)
    Uu, s, Vt = thin_svd(S[:, cols])
    LU, vu = lag.apply(U, 1), lag.valid_columns(np.ones(ncols, dtype=bool), 1)
    use = valid & lag.valid_columns(valid, 1) & vu
    e1 = _eliminator(pseudo, [1], use)
    return VarxStage(cols, valid, vx, elim, Uu, s, Vt, LU, use, e1, extra_iv)


def pbsid_core_blocks(
    U: Array,
    Y: Array,
    p: int,
    lag: LagOperator,
    pseudo: BlockPseudo | None = None,
    f: int | None = None,
    order: int | None = None,
    feedthrough: bool = False,
    regularize: bool | str | float | None = False,
    ridge_floor: float = 0.0,
    stable_k: bool = False,
    max_order: int | None = None,
    instruments: Array | None = None,
    stage: VarxStage | None = None,
) -> CoreResult:
    r""":func:`hdpbsid.core.pbsid.pbsid_core` over several blocks with block-specific
    pseudo-inputs eliminated.

    Every least-squares step (VARX, ``C, D``, ``A, B, K``) eliminates the nuisance
    regressors by the Frisch-Waugh-Lovell theorem (module docstring): the compressed problem
    has the size of the main one, so the regression does not grow with the number of
    blocks, and the shared coefficients equal those of the naive stacked regression.  The
    state ``Gamma_f L_p Z_p`` adds each block's pseudo-input part.  ``B`` of the result
    has the real inputs only.  With ``pseudo=None`` the steps reduce to those of
    ``pbsid_core``.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        The real inputs of all blocks side by side.
    Y : ndarray, shape (l, N)
        Outputs.
    p : int
        Past window.
    lag : LagOperator
        The lag, normally a :class:`BlockLag`.
    pseudo : BlockPseudo, optional
        Pseudo-input rows per block (None: none).
    f : int, optional
        Future window, ``f <= p`` (default ``p``).
    order : int, optional
        Model order; ``None`` selects it from the singular values.
    feedthrough : bool, optional
        Estimate ``D`` (not with ``instruments``).
    regularize : bool, str, float or None, optional
        VARX regularisation (:func:`hdpbsid.core.varx.varx`).
    ridge_floor : float, optional
        Lower bound of the GCV ridge.
    stable_k : bool, optional
        Replace the least-squares gain by the Riccati gain.
    max_order : int, optional
        Largest order the selection considers.
    instruments : ndarray, shape (k, N), optional
        Rows uncorrelated with the innovations (e.g. lags of a projected reference): IV as
        in :func:`~hdpbsid.core.pbsid.pbsid_core` (see Notes).
    stage : VarxStage, optional
        Steps 1-2 computed before by :func:`varx_stage_blocks` with the same arguments.

    Returns
    -------
    CoreResult
        The model and what the core computed.

    Raises
    ------
    ValueError
        If ``instruments`` has the wrong shape or comes with ``feedthrough``, if ``f > p``,
        if ``order > f l``, or if a step has too few columns.

    Notes
    -----
    With instruments the VARX is solved by two-stage least squares, ``C`` is the first
    block row of :math:`\Gamma = U_n S_n^{1/2}` and ``A, B, K`` by least squares (the state
    recursion has no noise term).  The pseudo-input rows are deterministic, so they are
    their own instruments; partialling exogenous regressors out of the regressors, the
    targets and the instruments alike leaves the IV estimate unchanged (Davidson &
    MacKinnon, sec. 8.5), so the instruments are compressed with the same eliminator.

    References
    ----------
    .. [1] A. Chiuso, "The role of vector autoregressive modeling in predictor-based
       subspace identification", *Automatica* 43(6), 1034-1048, 2007.
    .. [2] R. Davidson and J. G. MacKinnon, *Econometric Theory and Methods*, Oxford
       University Press, 2004, sec. 2.4 and 8.5.

    Examples
    --------
    Two records of ``y_k = 0.8 y_{k-1} + u_{k-1}``, side by side, never lagged across the
    edge:

    >>> from hdpbsid.core.varx import SampleShift
    >>> rng = np.random.default_rng(1)
    >>> def record(n):
    ...     u, y = rng.standard_normal((1, n)), np.zeros((1, n))
    ...     for k in range(1, n):
    ...         y[0, k] = 0.8 * y[0, k - 1] + u[0, k - 1]
    ...     return u, y
    >>> (u1, y1), (u2, y2) = record(150), record(200)
    >>> lag = BlockLag([SampleShift(), SampleShift()], [150, 200])
    >>> res = pbsid_core_blocks(np.hstack([u1, u2]), np.hstack([y1, y2]), p=3, lag=lag, order=1)
    >>> res.A.round(6)
    array([[0.8]])
    """
    m, l = U.shape[0], Y.shape[0]
    if instruments is not None:
        instruments = np.asarray(instruments, dtype=float)
        if instruments.ndim != 2 or instruments.shape[1] != Y.shape[1]:
            raise ValueError(
                f"instruments must be a 2-D array with {Y.shape[1]} columns (one per data "
                f"column), got shape {instruments.shape}"
            )
        if feedthrough:
            raise ValueError("instruments: feedthrough=True is not supported with IV")
    f = p if f is None else f
    if f > p:
        raise ValueError(f"the future window f must satisfy f <= p, got f={f} > p={p}")
    if order is not None and order > f * l:
        raise ValueError(
            f"order={order} exceeds f*l = {f}*{l} = {f * l}, the number of rows of Gamma L; "
            f"increase f (and p) or reduce the order"
        )
    if stage is None:
        stage = varx_stage_blocks(
            U, Y, p, lag, pseudo, f, feedthrough, regularize, ridge_floor, instruments
        )
    ncols, cols, valid, vx = Y.shape[1], stage.cols, stage.valid, stage.varx
    ft = feedthrough and m > 0
    Uu, s, Vt = stage.Uu, stage.s, stage.Vt
    extra_iv = stage.extra_iv
    n, info = resolve_order(s, order, max_order)
    X = np.sqrt(s[:n])[:, None] * Vt[:n]
    # -- 3a. C, D (pseudo-inputs enter the output equation only with feedthrough) -------
    if instruments is not None:
        C = Uu[:l, :n] * np.sqrt(s[:n])[None, :]
        D = np.zeros((l, m))
        E = Y[:, cols] - C @ X
    elif feedthrough and pseudo is not None:
        e0 = _eliminator(pseudo, [0], valid)
        Xf = np.zeros((n, ncols))
        Xf[:, cols] = X
        reg = np.vstack([Xf, U]) if ft else Xf
        th, Ef, _ = _fwl_lstsq(reg, np.where(valid, Y, 0.0), e0)
        C = th[:, :n]
        D = th[:, n:] if ft else np.zeros((l, m))
        E = Ef[:, cols]
    else:
        C, D, E = estimate_cd(X, U[:, cols], Y[:, cols], feedthrough)
    # -- 3b. A, B, K -------------------------------------------------------------------
    Xf = np.zeros((n, ncols))
    Xf[:, cols] = X
    Ef = np.zeros((l, ncols))
    Ef[:, cols] = E
    LX = lag.apply(Xf, 1)
    LE = lag.apply(Ef, 1)
    LU, use, e1 = stage.LU, stage.use, stage.e1
    if e1.ncols <= n + m + l:
        raise ValueError(
            f"too few usable columns ({e1.ncols}) to estimate A, B, K with "
            f"{n + m + l} regressors per state; supply more data or reduce p/order"
        )
    reg = np.vstack([LX, LU, LE])
    reg_u = np.where(use, reg, 0.0)
    th, resid_abk, coefs1 = _fwl_lstsq(reg_u, np.where(use, Xf, 0.0), e1)
    A, B, Kg = th[:, :n], th[:, n : n + m], th[:, n + m :]
    k_method = "least squares"
    if stable_k:
        ui = np.flatnonzero(use)
        # W = x - A lag(x) - B lag(u) - (pseudo part) = K lag(e) + residual
        W = (resid_abk + Kg @ reg_u[n + m :])[:, ui]
        Kg, k_method = stable_gain(A, C, W, LE[:, ui], Kg)
    noise_cov = E @ E.T / E.shape[1]
    options = core_options(
        p, f, n, order, feedthrough, vx, ridge_floor, stable_k, k_method, lag, info, max_order
    )
    options["pseudo_inputs"] = "eliminated per block (Frisch-Waugh-Lovell)"
    options["eliminated_pseudo_directions"] = stage.elim.rank
    options["estimator"] = "ls" if instruments is None else "iv"
    if instruments is not None:
        options["instruments"] = extra_iv.get("instruments")
        options["c_method"] = "first block row of Gamma"
    return CoreResult(
        A=A,
        B=B,
        C=C,
        D=D,
        K=Kg,
        order=n,
        singular_values=s,
        states=X,
        innovations=E,
        columns=cols,
        varx=vx,
        noise_covariance=noise_cov,
        options=options,
    )
