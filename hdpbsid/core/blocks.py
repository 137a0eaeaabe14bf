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

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg.lapack import dgeqrf, dorgqr

from hdpbsid.core.block_lag import BlockLag, PseudoStore
from hdpbsid.core.block_steps import (
    VarxStage,
    checked_future,
    checked_instruments,
    fit_varx,
    output_equation,
    state_equation,
    state_rows,
    varx_result,
)
from hdpbsid.core.block_steps import _gamma_l_rows as _gamma_l_rows
from hdpbsid.core.eliminator import (
    Eliminator,
    apply_qt,
    eliminator_for,
)
from hdpbsid.core.pbsid import CoreResult, core_options, resolve_order, thin_svd
from hdpbsid.core.varx import (
    LagOperator,
    past_blocks,
    r_factor,
)
from hdpbsid.runtime import large_work

__all__ = [
    "BlockSettings",
    "BLOCKS",
    "BlockLag",
    "BlockPseudo",
    "Eliminator",
    "VarxStage",
    "pbsid_core_blocks",
    "select_past_window_blocks",
    "varx_stage_blocks",
    "window_aic",
    "best_window",
    "PSEUDO_ROW_FLOOR",
]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]


@dataclass(frozen=True)
class BlockSettings:
    """The tolerance of the pseudo-input rows of the block core.

    Parameters
    ----------
    pseudo_row_floor : float, optional
        Relative RMS below which a pseudo-input row is dropped.

    Examples
    --------
    >>> BlockSettings().pseudo_row_floor
    1e-08
    """

    #: pseudo-input rows below this fraction of the block's largest row RMS carry no term
    #: (the Laguerre boundary row at tN, ~e^{-aT}); normalising them would inject rounding
    pseudo_row_floor: float = 1e-8


#: the settings of the block core
BLOCKS = BlockSettings()
#: the field of :data:`BLOCKS` under its former name
PSEUDO_ROW_FLOOR = BLOCKS.pseudo_row_floor


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
        store = PseudoStore.lookup(lag, rows)
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
            store = PseudoStore.add(
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
                C = apply_qt(refl_all, tau_all, C)
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


def _normalise_rows(P: Array) -> Array:
    if P.shape[0] == 0:
        return P
    r = np.sqrt(np.mean(P**2, axis=1))
    if r.max() <= 0:
        return P[:0]
    keep = r > BLOCKS.pseudo_row_floor * r.max()
    return P[keep] / r[keep, None]


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
        elim = eliminator_for(pseudo, lags_of(p), valid)
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
    elim = eliminator_for(pseudo, js, valid)
    nreg = Phi.shape[0]
    if elim.ncols <= nreg:
        raise ValueError(
            f"the VARX regression has {nreg} regressors (p*(m+l) = {p}*({m}+{l})"
            f"{' + m' if ft else ''}) but only {elim.ncols} usable columns after "
            f"eliminating {elim.rank} pseudo-input directions: reduce p or supply more data"
        )
    fit = fit_varx(Phi, Y, valid, elim, regularize, ridge_floor, instruments)
    res_full = np.zeros((l, ncols))
    res_full[:, cols] = Y[:, cols] - fit.theta @ Phi[:, cols]
    resid, nuis = elim.residual(res_full, fit.lam)
    coef = fit.theta[:, : p * (m + l)]
    vx = varx_result(fit, coef, Zp_all[:, cols], cols, resid[:, cols], elim, (p, m, l), ft)
    # -- 2. Gamma L Z_p (+ each block's pseudo-input part), SVD, state ------------------
    S = state_rows(coef, Zp_all, cols, elim, nuis, len(js), (p, f, m + l, l))
    Uu, s, Vt = thin_svd(S[:, cols])
    LU, vu = lag.apply(U, 1), lag.valid_columns(np.ones(ncols, dtype=bool), 1)
    use = valid & lag.valid_columns(valid, 1) & vu
    e1 = eliminator_for(pseudo, [1], use)
    return VarxStage(cols, valid, vx, elim, Uu, s, Vt, LU, use, e1, fit.extra_iv)


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
    instruments = checked_instruments(instruments, Y.shape[1], feedthrough)
    f = checked_future(p, f, order, l)
    if stage is None:
        stage = varx_stage_blocks(
            U, Y, p, lag, pseudo, f, feedthrough, regularize, ridge_floor, instruments
        )
    cols, vx, s = stage.cols, stage.varx, stage.s
    n, info = resolve_order(s, order, max_order)
    X = np.sqrt(s[:n])[:, None] * stage.Vt[:n]
    C, D, E = output_equation(X, U, Y, stage, pseudo, feedthrough, instruments is not None)
    A, B, Kg, k_method = state_equation(X, E, C, lag, stage, stable_k, m)
    noise_cov = E @ E.T / E.shape[1]
    options = core_options(
        p, f, n, order, feedthrough, vx, ridge_floor, stable_k, k_method, lag, info, max_order
    )
    options["pseudo_inputs"] = "eliminated per block (Frisch-Waugh-Lovell)"
    options["eliminated_pseudo_directions"] = stage.elim.rank
    options["estimator"] = "ls" if instruments is None else "iv"
    if instruments is not None:
        options["instruments"] = stage.extra_iv.get("instruments")
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
