"""The block PBSID core on blocks that arrive in batches: triangular factors accumulated.

:func:`hdpbsid.core.blocks.pbsid_core_blocks` holds every block's columns at once.  Its
least-squares steps only need, of the stacked columns, the triangular factor ``R`` of
``[regressors; targets]^T`` (``A = Q R``: ``A^T A = R^T R``, and ``R`` of a matrix whose
rows are split into batches is ``R`` of the batches' ``R`` factors stacked -- the
tall-skinny QR of Demmel, Grigori, Hoemmen & Langou, *SIAM J. Sci. Comput.* 34 (2012)
A206-A239).  The factors are orthogonal reductions of the data, so unlike the Gram
matrix ``A^T A`` they do not square its condition number.  The nuisance elimination of
:mod:`hdpbsid.core.blocks` is block-local (Frisch-Waugh-Lovell on each block's own
pseudo rows), so each batch is compressed on its own before its factor is taken.

Three facts make two passes over the batches enough (every step of the core, in the
order of :func:`~hdpbsid.core.blocks.pbsid_core_blocks`):

* a column scaling or permutation of ``A`` (normalisation, the row order of the VARX
  regressors) is ``A P D = Q (R P D)``, so its factor is that of ``R P D``; the factors
  of the first pass (raw coefficients, regressors ``lag^1 Z .. lag^p Z`` for every
  candidate ``p``) give the AIC of every ``p`` and the VARX of the chosen one;
* the ridge-penalised nuisance adds, per group of equal blocks and per nuisance
  direction ``i``, the columns ``lam / sqrt(s_i^2 + lam^2) Q_i^T W_b``: one factor per
  ``(group, i)`` accumulated unscaled, scaled once ``lam`` is known;
* the state is ``X = diag(s_n)^{-1/2} U_n^T S`` with ``S = Gamma_f L_p Z_p`` (+ each
  block's pseudo part) and ``S = U diag(s) V^T``: ``U, s`` come from the factor of
  ``S^T`` (``S = R_S^T Q^T``, SVD of the small ``R_S^T``), and every regression on
  ``X``, ``lag(X)`` and ``E = Y - C X`` is a linear map of the rows ``S, lag(S),
  lag(U), lag(Y), Y``: the second pass accumulates the factors of those rows
  (``[S; Y]`` for ``C`` and the innovation covariance, ``[lag S; lag U; lag Y; S]``
  compressed for ``A, B, K``) and the map is applied to the small factors afterwards.

The model is the in-memory one to rounding, except that the sign of each state
coordinate (a singular vector's sign) follows the rule of :func:`state_map`, so the
realisation may differ from the in-memory one by ``diag(+-1)``.  Only the defaults
``feedthrough=False``, least squares (no instruments) are covered; ``stable_k`` needs
the covariances of the state residual and of ``lag E`` only (:func:`solve_model`).
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.core.blocks import (
    BlockLag,
    BlockPseudo,
    Eliminator,
    _gamma_l_rows,
    best_window,
    window_aic,
)
from hdpbsid.core.pbsid import CoreResult, core_options, resolve_order, stable_gain
from hdpbsid.core.varx import VarxResult, parse_regularize, past_blocks, ridge_gcv_r
from hdpbsid.runtime import large_work

__all__ = [
    "VarxFactors",
    "VarxSolution",
    "StateFactors",
    "r_of",
    "varx_factors",
    "state_factors",
    "merge",
    "select_p",
    "solve_varx",
    "state_map",
    "solve_model",
]

Array = NDArray[np.float64]


def r_of(A: Array, width: int | None = None) -> Array:
    """Square triangular factor ``R`` of the tall matrix ``A = Q R``.

    ``A^T A = R^T R``, so ``R`` carries every least-squares statistic of ``A``'s columns
    without squaring its condition number; stacking the ``R`` of two row batches and
    factoring again gives the ``R`` of their union (tall-skinny QR).

    Parameters
    ----------
    A : ndarray, shape (rows, k)
        The matrix (one row per column of the data).
    width : int, optional
        Size of the result (default ``k``).

    Returns
    -------
    ndarray, shape (width, width)
        ``R``, zero-padded when ``A`` has fewer rows than columns.

    References
    ----------
    .. [1] J. Demmel, L. Grigori, M. Hoemmen and J. Langou, "Communication-optimal
       parallel and sequential QR and LU factorizations", *SIAM J. Sci. Comput.* 34(1),
       A206-A239, 2012.

    Examples
    --------
    >>> A = np.arange(12.0).reshape(6, 2)
    >>> R = r_of(A)
    >>> bool(np.allclose(R.T @ R, A.T @ A))
    True
    >>> R12 = r_of(np.vstack([r_of(A[:3]), r_of(A[3:])]))
    >>> bool(np.allclose(np.abs(R12), np.abs(R)))
    True
    """
    w = A.shape[1] if width is None else width
    with large_work(2.0 * A.shape[0] * A.shape[1] ** 2):  # Householder QR: 2 n k^2 flops
        R = np.linalg.qr(A, mode="r") if A.shape[0] else np.zeros((0, w))
    if R.shape[0] < w:
        R = np.vstack([R, np.zeros((w - R.shape[0], w))])
    return R


def _stack(a: Array, b: Array) -> Array:
    return r_of(np.vstack([a, b]), a.shape[1])


def _all_valid(lag: BlockLag, ncols: int, p: int) -> None:
    ones = np.ones(ncols, dtype=bool)
    for j in range(1, p + 2):
        if not lag.valid_columns(ones, j).all():
            raise ValueError(
                "the streamed core needs lags that keep every column valid (basis-domain "
                f"lags); {lag!r} invalidates columns at lag {j}"
            )


@dataclass
class VarxFactors:
    """First-pass statistics of one batch (or of several, :func:`merge`).

    Raw (unnormalised) coefficients ``Z = [U; Y]``.  For every candidate window ``p`` the
    factor of ``[lag^1 Z; ..; lag^p Z; Y]`` compressed onto the complement of the pseudo
    rows lagged ``1..p``, and the factors of the rows ``W_b Q_i`` that the ridge on the
    nuisance adds once its parameter is known.

    Attributes
    ----------
    ncols : int
        Number of columns.
    sumsq : ndarray, shape (m + l,)
        Sums of squares of the rows of ``Z``.
    lag_sumsq : ndarray, shape (p_max, m + l)
        ``lag_sumsq[j - 1]``: those of ``lag^j Z``.
    hard : dict of int to ndarray
        ``hard[p]``: the compressed factor of window ``p``.
    compressed : dict of int to int
        ``compressed[p]``: the columns of the compressed problem.
    rank : dict of int to int
        ``rank[p]``: the nuisance directions eliminated.
    soft : dict of int to dict
        ``soft[p][(kind, i)]``: the factor of the rows ``W_b Q_i`` of the blocks of one kind
        (``Q_i`` their ``i``-th nuisance direction).
    sv : dict of int to dict
        ``sv[p][kind]``: the singular values of those nuisance directions.
    batches : int
        Number of batches merged.
    """

    ncols: int
    sumsq: Array
    lag_sumsq: Array
    hard: dict[int, Array]
    compressed: dict[int, int]
    rank: dict[int, int]
    soft: dict[int, dict[tuple[Hashable, int], Array]]
    sv: dict[int, dict[Hashable, Array]]
    batches: int = 1


def varx_factors(
    U: Array,
    Y: Array,
    lag: BlockLag,
    pseudo: BlockPseudo | None,
    ps: Sequence[int],
    kinds: Sequence[Hashable] | None = None,
) -> VarxFactors:
    """:class:`VarxFactors` of one batch of blocks.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Raw input coefficients of the batch's blocks side by side.
    Y : ndarray, shape (l, N)
        Raw output coefficients.
    lag : BlockLag
        The lag of these blocks (every column must stay valid: basis-domain lags).
    pseudo : BlockPseudo or None
        Their pseudo-input rows.
    ps : sequence of int
        The candidate past windows.
    kinds : sequence of hashable, optional
        A label per block, the same for blocks with the same lag operator and pseudo rows
        in every batch (their nuisance directions are then the same, so their ridge columns
        are scaled alike); default: the block's column count.

    Returns
    -------
    VarxFactors
        The batch's statistics.

    Raises
    ------
    ValueError
        If the lag invalidates columns, or blocks of one kind have different pseudo rows.
    """
    Z = np.vstack([U, Y])
    ncols = Z.shape[1]
    p_hi = max(ps)
    _all_valid(lag, ncols, p_hi)
    lagged = [lag.apply(Z, j) for j in range(1, p_hi + 1)]
    valid = np.ones(ncols, dtype=bool)
    out = VarxFactors(
        ncols,
        np.sum(Z**2, axis=1),
        np.array([np.sum(L**2, axis=1) for L in lagged]),
        {},
        {},
        {},
        {},
        {},
    )
    for p in ps:
        W = np.vstack(lagged[:p] + [Y])
        rows = W.shape[0]
        elim = Eliminator(pseudo, list(range(1, p + 1)), valid)
        out.hard[p] = r_of(elim.compress(W).T, rows)
        out.compressed[p] = elim.ncols
        out.rank[p] = elim.rank
        out.soft[p], out.sv[p] = {}, {}
        for s in elim.subs:
            K, nv = s.cols.shape
            kind = nv if kinds is None else kinds[s.blocks[0]]
            if kind in out.sv[p] and not np.array_equal(out.sv[p][kind], s.sv):
                raise ValueError(f"kinds: blocks labelled {kind!r} have different pseudo rows")
            WQ = (W[:, s.cols].reshape(rows * K, nv) @ s.Q).reshape(rows, K, -1)
            for i in range(WQ.shape[2]):
                key = (kind, i)
                R = r_of(WQ[:, :, i].T, rows)
                prev = out.soft[p].get(key)
                out.soft[p][key] = R if prev is None else _stack(prev, R)
            out.sv[p][kind] = s.sv
    return out


@dataclass
class StateFactors:
    """Second-pass statistics (normalised coefficients).

    Attributes
    ----------
    ncols : int
        Number of columns.
    sy : ndarray
        Factor of ``[S; Y]`` on all columns, ``S = Gamma_f L_p Z_p`` with the pseudo part.
    abk : ndarray
        Factor of ``[lag S; lag U; lag Y; S]`` compressed onto the complement of the pseudo
        rows lagged once.
    compressed : int
        Columns of that compressed problem.
    lagged : ndarray
        Factor of ``[lag S; lag Y]`` on all columns (the innovations' lag, for
        ``stable_k``).
    batches : int
        Number of batches merged.
    """

    ncols: int
    sy: Array
    abk: Array
    compressed: int
    lagged: Array
    batches: int = 1


@dataclass
class VarxSolution:
    """The VARX of the chosen window (normalised units) and what the second pass needs.

    Attributes
    ----------
    p : int
        Past window.
    f : int
        Future window.
    theta : ndarray, shape (l, p (m + l))
        The VARX coefficients ``[Xi_p, ..., Xi_1]``.
    ridge : float
        The ridge parameter used.
    kind : str
        ``"none"``, ``"gcv"`` or ``"fixed"``.
    gcv : float or None
        The GCV function at ``ridge``.
    rank : int
        Nuisance directions eliminated.
    compressed : int
        Columns of the compressed VARX.
    su : ndarray, shape (m,)
        Input scales (row RMS, or ones).
    sy : ndarray, shape (l,)
        Output scales.
    extra : dict
        Record of the elimination.
    """

    p: int
    f: int
    theta: Array
    ridge: float
    kind: str
    gcv: float | None
    rank: int
    compressed: int
    su: Array
    sy: Array
    extra: dict = field(default_factory=dict)


def state_factors(
    U: Array, Y: Array, lag: BlockLag, pseudo: BlockPseudo | None, vs: VarxSolution
) -> StateFactors:
    """:class:`StateFactors` of one batch.

    ``S`` is as in :func:`~hdpbsid.core.blocks.varx_stage_blocks`: ``Gamma_f L_p Z_p``
    plus, per block, the pseudo rows' part with the block's ridge nuisance coefficients of
    the VARX residual.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Raw input coefficients of the batch.
    Y : ndarray, shape (l, N)
        Raw output coefficients.
    lag : BlockLag
        The batch's lag.
    pseudo : BlockPseudo or None
        Its pseudo-input rows.
    vs : VarxSolution
        The VARX (:func:`solve_varx`).

    Returns
    -------
    StateFactors
        The batch's statistics.
    """
    m, l = U.shape[0], Y.shape[0]
    p, f = vs.p, vs.f
    Uz = U / vs.su[:, None]
    Yz = Y / vs.sy[:, None]
    ncols = Yz.shape[1]
    _all_valid(lag, ncols, p)
    Zp, valid = past_blocks(np.vstack([Uz, Yz]), p, lag)
    js = list(range(p, 0, -1))
    elim = Eliminator(pseudo, js, valid)
    _, nuis = elim.residual(Yz - vs.theta @ Zp, vs.ridge)
    coef = vs.theta[:, : p * (m + l)]
    S = _gamma_l_rows(coef, p, f, m + l, l) @ Zp
    for sub, (blocks, G) in zip(elim.subs, nuis, strict=True):
        q = sub.S.shape[0] // len(js)
        Pp = sub.S[: p * q]
        LKb = np.stack([_gamma_l_rows(G[k][:, : p * q], p, f, q, l) for k in range(len(blocks))])
        S[:, sub.cols] += np.einsum("kfr,rn->fkn", LKb, Pp)
    e1 = Eliminator(pseudo, [1], valid)
    LS, LY = lag.apply(S, 1), lag.apply(Yz, 1)
    W = np.vstack([LS, lag.apply(Uz, 1), LY, S])
    return StateFactors(
        ncols,
        r_of(np.vstack([S, Yz]).T),
        r_of(e1.compress(W).T, W.shape[0]),
        e1.ncols,
        r_of(np.vstack([LS, LY]).T),
    )


def merge(a: Any, b: Any) -> Any:
    """Statistics of the union of two sets of batches.

    Factors are stacked and re-triangularised (the ``R`` of stacked ``R`` factors is the
    ``R`` of the stacked data), counts and sums added.

    Parameters
    ----------
    a, b : VarxFactors, StateFactors, list of them, or None
        The statistics; ``None`` is the empty set; lists (one entry per input hold) are
        merged entry by entry.

    Returns
    -------
    VarxFactors, StateFactors, list or None
        The merged statistics.

    Raises
    ------
    ValueError
        If blocks of one kind have different pseudo rows in ``a`` and ``b``.
    """
    if a is None:
        return b
    if b is None:
        return a
    if isinstance(a, list):
        return [merge(x, y) for x, y in zip(a, b, strict=True)]
    if isinstance(a, StateFactors):
        return _merge_state(a, b)
    return _merge_varx(a, b)


def _merge_state(a: StateFactors, b: StateFactors) -> StateFactors:
    """:func:`merge` of second-pass statistics: factors stacked, counts added."""
    return StateFactors(
        a.ncols + b.ncols,
        _stack(a.sy, b.sy),
        _stack(a.abk, b.abk),
        a.compressed + b.compressed,
        _stack(a.lagged, b.lagged),
        a.batches + b.batches,
    )


def _merge_varx(a: VarxFactors, b: VarxFactors) -> VarxFactors:
    """:func:`merge` of first-pass statistics: factors stacked per window (the ridge
    factors per ``(kind, direction)``), sums and counts added."""
    soft: dict[int, dict[tuple[Hashable, int], Array]] = {}
    sv = {p: {**a.sv[p], **b.sv[p]} for p in a.hard}
    for p in a.hard:
        _check_kinds(a.sv[p], b.sv[p])
    for p in a.hard:
        soft[p] = dict(a.soft[p])
        for key, R in b.soft[p].items():
            soft[p][key] = R if key not in soft[p] else _stack(soft[p][key], R)
    return VarxFactors(
        a.ncols + b.ncols,
        a.sumsq + b.sumsq,
        a.lag_sumsq + b.lag_sumsq,
        {p: _stack(a.hard[p], b.hard[p]) for p in a.hard},
        {p: a.compressed[p] + b.compressed[p] for p in a.hard},
        {p: a.rank[p] + b.rank[p] for p in a.hard},
        soft,
        sv,
        a.batches + b.batches,
    )


def _check_kinds(sa: dict[Hashable, Array], sb: dict[Hashable, Array]) -> None:
    """Blocks of one kind in two sets have the same nuisance singular values."""
    for kind in set(sa) & set(sb):
        # the same rows in another process may differ by rounding (1e-8: far above)
        if not np.allclose(sa[kind], sb[kind], rtol=1e-8, atol=0.0):
            raise ValueError(f"kinds: blocks labelled {kind!r} have different pseudo rows")


def _scales(vf: VarxFactors, m: int, normalize: bool) -> tuple[Array, Array]:
    """Row RMS of ``U`` and ``Y`` (``run_core``'s normalisation), ones without it."""
    rms = np.sqrt(vf.sumsq / vf.ncols)
    if normalize and np.any(rms == 0):
        k = int(np.flatnonzero(rms == 0)[0])
        name, i = ("u", k) if k < m else ("y", k - m)
        raise ValueError(f"{name}[:, {i}] is identically zero: nothing to identify from it")
    if not normalize:
        rms = np.ones_like(rms)
    return rms[:m], rms[m:]


def select_p(
    vf: VarxFactors,
    m: int,
    l: int,
    p_min: int,
    p_max: int,
    normalize: bool,
    rel_floor: float = 1e-12,
) -> tuple[int, Array]:
    """The past window from the first-pass factors.

    As :func:`~hdpbsid.core.blocks.select_past_window_blocks`: ``AIC = N log det Sigma_p +
    2 l (p (m + l) + rank_p)``, the column scalings applied to the factor (a column scaling
    of ``A`` is one of ``R``).

    Parameters
    ----------
    vf : VarxFactors
        Merged first-pass statistics.
    m : int
        Number of inputs.
    l : int
        Number of outputs.
    p_min : int
        Smallest window.
    p_max : int
        Largest window.
    normalize : bool
        Scale the signals to unit RMS first (as the in-memory core).
    rel_floor : float, optional
        Floor of the scaled residual covariance.

    Returns
    -------
    p : int
        The window chosen.
    crit : ndarray, shape (p_max,)
        The criterion, ``inf`` where not evaluated.
    """
    su, sy = _scales(vf, m, normalize)
    sz = np.concatenate([su, sy])
    N = vf.ncols
    ys = np.sqrt(vf.sumsq[m:] / sy**2 / N)
    ys[ys == 0] = 1.0
    crit = np.full(p_max, np.inf)
    for p in range(max(p_min, 1), p_max + 1):
        q = p * (m + l)
        if vf.compressed[p] <= q + l:
            break
        cs = np.sqrt(vf.lag_sumsq[:p] / sz[None, :] ** 2 / N)
        cs[cs == 0] = 1.0
        d = np.concatenate([(1.0 / (sz[None, :] * cs)).ravel(), 1.0 / (sy * ys)])
        res = (vf.hard[p] * d[None, :])[q:, q:]
        crit[p - 1] = window_aic(res, N, q + vf.rank[p], rel_floor)
    return best_window(crit, p_min, p_max, N), crit


def solve_varx(
    vf: VarxFactors,
    m: int,
    l: int,
    p: int,
    f: int,
    regularize: bool | str | float | None,
    ridge_floor: float,
    normalize: bool,
) -> VarxSolution:
    """Step 1 of :func:`~hdpbsid.core.blocks.varx_stage_blocks` from the factors.

    The VARX with the pseudo rows eliminated, the GCV ridge, and the same ridge on the
    nuisance: the factors of the rows ``W_b Q_i`` are scaled by ``lam / sqrt(s_i^2 +
    lam^2)`` once ``lam`` is known and stacked under the compressed factor.

    Parameters
    ----------
    vf : VarxFactors
        Merged first-pass statistics.
    m : int
        Number of inputs.
    l : int
        Number of outputs.
    p : int
        Past window.
    f : int
        Future window.
    regularize : bool, str, float or None
        VARX regularisation (:func:`hdpbsid.core.varx.varx`).
    ridge_floor : float
        Lower bound of the GCV ridge.
    normalize : bool
        Scale the signals to unit RMS.

    Returns
    -------
    VarxSolution
        The VARX in normalised units.

    Raises
    ------
    ValueError
        If the compressed problem has no more columns than regressors, or a signal is
        identically zero with ``normalize``.
    """
    su, sy = _scales(vf, m, normalize)
    sz = np.concatenate([su, sy])
    d = m + l
    nreg = p * d
    if vf.compressed[p] <= nreg:
        raise ValueError(
            f"the VARX regression has {nreg} regressors (p*(m+l) = {p}*({m}+{l})) but only "
            f"{vf.compressed[p]} usable columns after eliminating {vf.rank[p]} pseudo-input "
            f"directions: reduce p or supply more data"
        )
    # factor rows [lag^1 Z..lag^p Z; Y] (raw) -> the VARX's [lag^p Z..lag^1 Z; Y] normalised
    perm = np.concatenate([np.arange((j - 1) * d, j * d) for j in range(p, 0, -1)])
    perm = np.concatenate([perm, nreg + np.arange(l)])
    scale = np.concatenate([np.tile(1.0 / sz, p), 1.0 / sy])

    def factor(parts: list[Array]) -> Array:
        return r_of(np.vstack([(R * scale[None, :])[:, perm] for R in parts]), nreg + l)

    Rh = factor([vf.hard[p]])
    kind, lam = parse_regularize(regularize)
    N = vf.compressed[p]
    if kind == "none":
        rcond = np.finfo(float).eps * max(nreg, N)
        theta = np.linalg.lstsq(Rh[:nreg, :nreg], Rh[:nreg, nreg:], rcond=rcond)[0].T
        lam_used, gcv = 0.0, None
    else:
        theta, lam_used, gcv = ridge_gcv_r(
            Rh, nreg, N, lam if kind == "fixed" else None, ridge_floor if kind == "gcv" else 0.0
        )
    if lam_used > 0 and vf.rank[p]:
        parts = [vf.hard[p]]
        for (n, i), R in vf.soft[p].items():
            s = vf.sv[p][n][i]
            parts.append(R * (lam_used / np.sqrt(s**2 + lam_used**2)))
        theta = ridge_gcv_r(factor(parts), nreg, N, lam_used)[0]
    extra = {"eliminated_pseudo_directions": vf.rank[p], "compressed_columns": N}
    return VarxSolution(p, f, theta, lam_used, kind, gcv, vf.rank[p], N, su, sy, extra)


def state_map(sf: StateFactors, fl: int) -> tuple[Array, Array]:
    """``U, s`` of ``S = U diag(s) V^T`` from the factor of ``S^T``.

    ``S^T = Q R`` gives ``S = R^T Q^T``, so ``U`` and ``s`` are those of the small ``R^T``.
    Each column of ``U`` is signed so that its entry of largest magnitude is positive: a
    rule on ``S`` alone, so the state does not depend on how the columns were batched.

    Parameters
    ----------
    sf : StateFactors
        Merged second-pass statistics.
    fl : int
        Rows of ``S`` (``f l``).

    Returns
    -------
    U : ndarray, shape (fl, fl)
        Left singular vectors, signed as above.
    s : ndarray, shape (fl,)
        Singular values, descending.
    """
    Uu, s, _ = np.linalg.svd(sf.sy[:fl, :fl].T)
    idx = np.argmax(np.abs(Uu), axis=0)
    sign = np.sign(Uu[idx, np.arange(Uu.shape[1])])
    sign[sign == 0] = 1.0
    return Uu * sign[None, :], s


def solve_model(
    vs: VarxSolution,
    sf: StateFactors,
    m: int,
    l: int,
    order: int | None,
    max_order: int | None,
    ridge_floor: float = 0.0,
    stable_k: bool = False,
) -> CoreResult:
    """Steps 2-3 of :func:`~hdpbsid.core.blocks.pbsid_core_blocks` from the second-pass
    factors (normalised units).

    The order, ``C`` and the innovation covariance from the factor of ``[S; Y]`` mapped by
    ``X = T S``; ``A, B, K`` from the factor of ``[lag S; lag U; lag Y; S]`` mapped to
    ``[lag X; lag U; lag E; X]``.  The per-column arrays of the result (states,
    innovations, VARX regressors and residuals) are empty: they are never formed.

    Parameters
    ----------
    vs : VarxSolution
        The VARX (:func:`solve_varx`).
    sf : StateFactors
        Merged second-pass statistics.
    m : int
        Number of inputs.
    l : int
        Number of outputs.
    order : int or None
        Model order; ``None`` selects it.
    max_order : int or None
        Largest order the selection considers.
    ridge_floor : float, optional
        Reported in the options.
    stable_k : bool, optional
        Replace the least-squares gain by the Riccati gain.

    Returns
    -------
    CoreResult
        The model; the per-column arrays empty.

    Raises
    ------
    ValueError
        If the ``A, B, K`` regression has too few columns, or the order exceeds the rank.
    """
    p, f = vs.p, vs.f
    fl = f * l
    Uu, s = state_map(sf, fl)
    n, info = resolve_order(s, order, max_order)
    T = Uu[:, :n].T / np.sqrt(s[:n])[:, None]  # X = T S
    C, noise_cov = _output_step(sf, T, l)
    A, B, K, F_res = _abk_step(sf, T, C, m, l)
    k_method = "least squares"
    if stable_k:
        K, k_method = _stable_k(sf, T, A, C, K, F_res)
    vx = _varx_result(vs, m, l)
    options = core_options(
        p, f, n, order, False, vx, ridge_floor, stable_k, k_method, "", info, max_order
    )
    options["estimator"] = "ls"
    options["pseudo_inputs"] = "eliminated per block (Frisch-Waugh-Lovell)"
    options["eliminated_pseudo_directions"] = vs.rank
    options["streamed"] = {"batches": sf.batches, "state_signs": "largest entry of U positive"}
    return CoreResult(
        A=A,
        B=B,
        C=C,
        D=np.zeros((l, m)),
        K=K,
        order=n,
        singular_values=s,
        states=np.zeros((n, 0)),
        innovations=np.zeros((l, 0)),
        columns=np.zeros(0, dtype=np.intp),
        varx=vx,
        noise_covariance=noise_cov,
        options=options,
    )


def _output_step(sf: StateFactors, T: Array, l: int) -> tuple[Array, Array]:
    """``C`` and the innovation covariance: ``Y = C X + E`` on all columns, the factor of
    ``[X; Y]`` that of ``[S; Y]`` mapped by ``X = T S``."""
    n = T.shape[0]
    eps = np.finfo(float).eps
    R1 = r_of(sf.sy @ _blkdiag(T.T, np.eye(l)), n + l)
    C = np.linalg.lstsq(R1[:n, :n], R1[:n, n:], rcond=eps * max(sf.ncols, n))[0].T
    E2 = R1[n:, n:].T @ R1[n:, n:]
    return C, E2 / sf.ncols


def _abk_step(
    sf: StateFactors, T: Array, C: Array, m: int, l: int
) -> tuple[Array, Array, Array, Array]:
    """``A, B, K`` of ``X = A lag X + B lag U + K lag E`` (``lag E = lag Y - C lag X``) from
    the factor of ``[lag S; lag U; lag Y; S]`` mapped to ``[lag X; lag U; lag E; X]``;
    and the factor of the state residual (for ``stable_k``)."""
    n, fl = T.shape
    eps = np.finfo(float).eps
    dreg = n + m + l
    if sf.compressed <= dreg:
        raise ValueError(
            f"too few usable columns ({sf.compressed}) to estimate A, B, K with "
            f"{dreg} regressors per state; supply more data or reduce p/order"
        )
    Mt = np.zeros((dreg + n, 2 * fl + m + l))
    Mt[:n, :fl] = T
    Mt[n : n + m, fl : fl + m] = np.eye(m)
    Mt[n + m : dreg, :fl] = -C @ T
    Mt[n + m : dreg, fl + m : fl + m + l] = np.eye(l)
    Mt[dreg:, fl + m + l :] = T
    R2 = r_of(sf.abk @ Mt.T, dreg + n)
    th = np.linalg.lstsq(R2[:dreg, :dreg], R2[:dreg, dreg:], rcond=eps * max(sf.compressed, dreg))[
        0
    ].T
    return th[:, :n], th[:, n : n + m], th[:, n + m :], R2[dreg:, dreg:]


def _stable_k(
    sf: StateFactors, T: Array, A: Array, C: Array, K: Array, F_res: Array
) -> tuple[Array, str]:
    """The Riccati gain from the factors (:func:`~hdpbsid.core.pbsid.stable_gain`).

    ``W = X - A lag X - B lag U - (pseudo part) = residual + K lag E``, ``V = lag E``; the
    residual is orthogonal to the regressor ``lag E``, so with ``L = lag E lag E^T``:
    ``W W^T = Res + K L K^T``, ``W V^T = K L``, ``V V^T = L``.  Columns with these
    products: ``W' = [F_res^T, K F_L^T]``, ``V' = [0, F_L^T]`` (``F^T F = Res, L``),
    scaled to ``N`` columns.
    """
    n, l = T.shape[0], C.shape[0]
    Ml = np.hstack([-C @ T, np.eye(l)])  # lag E = Ml [lag S; lag Y]
    F_L = r_of(sf.lagged @ Ml.T, l)
    w = np.sqrt((n + l) / sf.ncols)
    Wv = w * np.hstack([F_res.T, K @ F_L.T])
    Vv = w * np.hstack([np.zeros((l, n)), F_L.T])
    return stable_gain(A, C, Wv, Vv, K)


def _varx_result(vs: VarxSolution, m: int, l: int) -> VarxResult:
    """The VARX of the solution as the in-memory core reports it (per-column arrays
    empty: never formed)."""
    p = vs.p
    coef = vs.theta[:, : p * (m + l)]
    Xi = np.stack([coef[:, (p - j) * (m + l) : (p - j + 1) * (m + l)] for j in range(1, p + 1)])
    return VarxResult(
        Xi=Xi,
        coef=coef,
        D=np.zeros((l, m)),
        Zp=np.zeros((p * (m + l), 0)),
        columns=np.zeros(0, dtype=np.intp),
        residuals=np.zeros((l, 0)),
        ridge=vs.ridge,
        regularize=vs.kind,
        gcv=vs.gcv,
        extra=dict(vs.extra),
    )


def _blkdiag(a: Array, b: Array) -> Array:
    out = np.zeros((a.shape[0] + b.shape[0], a.shape[1] + b.shape[1]))
    out[: a.shape[0], : a.shape[1]] = a
    out[a.shape[0] :, a.shape[1] :] = b
    return out
