"""The least-squares steps of the block core, each with the pseudo-inputs eliminated.

:func:`hdpbsid.core.blocks.pbsid_core_blocks` runs the PBSID steps on stacked blocks:
the VARX (:func:`fit_varx`), ``Gamma_f L_p Z_p`` with each block's pseudo-input part
(:func:`state_rows`), the output equation ``C, D`` (:func:`output_equation`) and the
state equation ``A, B, K`` (:func:`state_equation`).  Every step eliminates the
block-specific nuisance rows by the Frisch-Waugh-Lovell theorem
(:mod:`hdpbsid.core.eliminator`; the derivation is in :mod:`hdpbsid.core.blocks`).  The
order-independent part is kept as a :class:`VarxStage`, shared by the orders of a sweep.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from hdpbsid.core.eliminator import Eliminator, eliminator_for, fwl_lstsq, lstsq_or_ridge
from hdpbsid.core.pbsid import estimate_cd, stable_gain
from hdpbsid.core.varx import LagOperator, VarxResult, parse_regularize, ridge_gcv, two_stage_ls

if TYPE_CHECKING:
    from hdpbsid.core.blocks import BlockPseudo

__all__ = [
    "VarxStage",
    "VarxFit",
    "fit_varx",
    "varx_result",
    "state_rows",
    "checked_instruments",
    "checked_future",
    "output_equation",
    "state_equation",
]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]


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


@dataclass
class VarxFit:
    """The VARX coefficients and how they were fitted.

    Parameters
    ----------
    theta : ndarray, shape (l, nreg)
        The coefficients of the regressors.
    lam : float
        The ridge applied to the nuisance coefficients too (0 with instruments).
    ridge : float
        The ridge reported (the two-stage one with instruments).
    gcv : float or None
        The GCV value of the ridge choice.
    kind : str
        The regularisation (:func:`hdpbsid.core.varx.parse_regularize`).
    extra_iv : dict
        The IV estimator's record (empty for least squares).
    """

    theta: Array
    lam: float
    ridge: float
    gcv: float | None
    kind: str
    extra_iv: dict


def fit_varx(
    Phi: Array,
    Y: Array,
    valid: Mask,
    elim: Eliminator,
    regularize: bool | str | float | None,
    ridge_floor: float,
    instruments: Array | None,
) -> VarxFit:
    """Step 1 of :func:`~hdpbsid.core.blocks.varx_stage_blocks`: ``Y ~ Theta Phi`` with
    the nuisance rows eliminated, by (ridge) least squares or, with instruments, two-stage
    least squares.

    Parameters
    ----------
    Phi : ndarray, shape (nreg, ncols)
        The regressors (past data, and ``U`` with feedthrough).
    Y : ndarray, shape (l, ncols)
        The outputs.
    valid : ndarray of bool, shape (ncols,)
        The columns of the regression.
    elim : Eliminator
        The nuisance eliminator of the regression.
    regularize : bool, str, float or None
        VARX regularisation (:func:`hdpbsid.core.varx.varx`).
    ridge_floor : float
        Lower bound of the GCV ridge.
    instruments : ndarray or None
        Instrument rows (IV VARX).

    Returns
    -------
    VarxFit
        The coefficients and how they were fitted.
    """
    nreg, l = Phi.shape[0], Y.shape[0]
    if instruments is None:
        Cz = elim.compress(np.vstack([Phi, Y]))
        theta, lam_used, gcv_val, kind = lstsq_or_ridge(
            Cz[:nreg], Cz[nreg:], regularize, ridge_floor
        )
        fit = VarxFit(theta, lam_used, lam_used, gcv_val, kind, {})
    else:
        Cz = elim.compress(np.vstack([Phi, Y, np.where(valid, instruments, 0.0)]))
        kind, lam = parse_regularize(regularize)
        theta, ridge_iv, gcv_val, extra_iv = two_stage_ls(
            Cz[:nreg],
            Cz[nreg : nreg + l],
            Cz[nreg + l :],
            lam if kind == "fixed" else (None if kind == "gcv" else 0.0),
            floor=ridge_floor if kind == "gcv" else 0.0,
        )
        # the nuisance coefficients are fitted unpenalised to the IV residual below
        fit = VarxFit(theta, 0.0, ridge_iv, gcv_val, kind, extra_iv)
    if fit.lam > 0 and elim.rank:
        # the ridge penalises the pseudo-inputs' coefficients as well (as if they were
        # inputs): same lam, nuisance minimised out exactly (Eliminator.compress)
        Cs = elim.compress(np.vstack([Phi, Y]), fit.lam)
        fit.theta = ridge_gcv(Cs[:nreg], Cs[nreg:], fit.lam)[0]
    return fit


def varx_result(
    fit: VarxFit,
    coef: Array,
    Zp: Array,
    cols: NDArray[np.intp],
    residuals: Array,
    elim: Eliminator,
    sizes: tuple[int, int, int],
    ft: bool,
) -> VarxResult:
    """The :class:`~hdpbsid.core.varx.VarxResult` of the fit.

    Parameters
    ----------
    fit : VarxFit
        The fit (:func:`fit_varx`).
    coef : ndarray, shape (l, p (m + l))
        Its coefficients of the past data.
    Zp : ndarray
        The past data on the VARX columns.
    cols : ndarray of int
        The VARX columns.
    residuals : ndarray
        The residuals on those columns.
    elim : Eliminator
        The nuisance eliminator of the fit.
    sizes : tuple of int
        ``(p, m, l)``.
    ft : bool
        Whether ``D`` was estimated.

    Returns
    -------
    VarxResult
        The VARX result.
    """
    p, m, l = sizes
    Xi = np.stack([coef[:, (p - j) * (m + l) : (p - j + 1) * (m + l)] for j in range(1, p + 1)])
    return VarxResult(
        Xi=Xi,
        coef=coef,
        D=fit.theta[:, p * (m + l) :] if ft else np.zeros((l, m)),
        Zp=Zp,
        columns=cols,
        residuals=residuals,
        ridge=fit.ridge,
        regularize=fit.kind,
        gcv=fit.gcv,
        extra={
            "eliminated_pseudo_directions": elim.rank,
            "compressed_columns": elim.ncols,
            **fit.extra_iv,
        },
    )


def state_rows(
    coef: Array,
    Zp_all: Array,
    cols: NDArray[np.intp],
    elim: Eliminator,
    nuis: list,
    n_lags: int,
    sizes: tuple[int, int, int, int],
) -> Array:
    """``Gamma_f L_p Z_p`` on all columns with each block's pseudo-input part (step 2).

    Parameters
    ----------
    coef : ndarray, shape (l, p d)
        The VARX coefficients ``[Xi_p, ..., Xi_1]`` of the past data.
    Zp_all : ndarray, shape (p d, ncols)
        The past data on all columns.
    cols : ndarray of int
        The VARX columns.
    elim : Eliminator
        The VARX's nuisance eliminator.
    nuis : list of tuple
        Its nuisance coefficients (:meth:`Eliminator.residual`).
    n_lags : int
        Nuisance lags per row set.
    sizes : tuple of int
        ``(p, f, d, l)``, ``d = m + l``.

    Returns
    -------
    ndarray, shape (f l, ncols)
        The rows whose SVD gives the state.
    """
    p, f, d, l = sizes
    LK = _gamma_l_rows(coef, p, f, d, l)
    S = np.zeros((f * l, Zp_all.shape[1]))
    S[:, cols] = LK @ Zp_all[:, cols]
    for sub, (blocks, G) in zip(elim.subs, nuis, strict=True):
        # G: (K, l, r_raw) coefficients of [P M^p; ...; P M^1 (; P)]; q rows per lag
        q = sub.S.shape[0] // n_lags
        Pp = sub.S[: p * q]  # lags p..1 on the used columns
        K = len(blocks)
        LKb = np.stack([_gamma_l_rows(G[k][:, : p * q], p, f, q, l) for k in range(K)])
        S[:, sub.cols] += np.einsum("kfr,rn->fkn", LKb, Pp)
    return S


def checked_instruments(instruments: Array | None, ncols: int, feedthrough: bool) -> Array | None:
    """The instrument rows as a float array, checked.

    Parameters
    ----------
    instruments : array_like or None
        Instrument rows, or None (least squares).
    ncols : int
        The number of data columns.
    feedthrough : bool
        Whether ``D`` is asked for (not with IV).

    Returns
    -------
    ndarray or None
        The instruments.

    Raises
    ------
    ValueError
        If the instruments are not 2-D with ``ncols`` columns, or come with feedthrough.
    """
    if instruments is None:
        return None
    instruments = np.asarray(instruments, dtype=float)
    if instruments.ndim != 2 or instruments.shape[1] != ncols:
        raise ValueError(
            f"instruments must be a 2-D array with {ncols} columns (one per data "
            f"column), got shape {instruments.shape}"
        )
    if feedthrough:
        raise ValueError("instruments: feedthrough=True is not supported with IV")
    return instruments


def checked_future(p: int, f: int | None, order: int | None, l: int) -> int:
    """The future window (default ``p``), checked against ``p`` and the order.

    Parameters
    ----------
    p : int
        The past window.
    f : int or None
        The future window asked for.
    order : int or None
        The order asked for.
    l : int
        The number of outputs.

    Returns
    -------
    int
        The future window.

    Raises
    ------
    ValueError
        If ``f > p`` or the order exceeds ``f l``.
    """
    f = p if f is None else f
    if f > p:
        raise ValueError(f"the future window f must satisfy f <= p, got f={f} > p={p}")
    if order is not None and order > f * l:
        raise ValueError(
            f"order={order} exceeds f*l = {f}*{l} = {f * l}, the number of rows of Gamma L; "
            f"increase f (and p) or reduce the order"
        )
    return f


def output_equation(
    X: Array,
    U: Array,
    Y: Array,
    stage: VarxStage,
    pseudo: BlockPseudo | None,
    feedthrough: bool,
    iv: bool,
) -> tuple[Array, Array, Array]:
    """Step 3a of :func:`~hdpbsid.core.blocks.pbsid_core_blocks`: ``C, D`` and the
    innovations ``E`` on the VARX columns (the pseudo-inputs enter the output equation
    only with feedthrough).

    Parameters
    ----------
    X : ndarray, shape (n, len(cols))
        The state on the VARX columns.
    U : ndarray, shape (m, ncols)
        The inputs.
    Y : ndarray, shape (l, ncols)
        The outputs.
    stage : VarxStage
        The order-independent stage.
    pseudo : BlockPseudo or None
        Pseudo-input rows per block.
    feedthrough : bool
        Estimate ``D``.
    iv : bool
        The instrumental-variable core (``C`` from ``Gamma``).

    Returns
    -------
    C, D, E : ndarray
        The output matrices and the innovations.
    """
    m, l, n = U.shape[0], Y.shape[0], X.shape[0]
    cols, valid = stage.cols, stage.valid
    if iv:
        C = stage.Uu[:l, :n] * np.sqrt(stage.s[:n])[None, :]
        return C, np.zeros((l, m)), Y[:, cols] - C @ X
    if feedthrough and pseudo is not None:
        ft = m > 0
        e0 = eliminator_for(pseudo, [0], valid)
        Xf = np.zeros((n, Y.shape[1]))
        Xf[:, cols] = X
        reg = np.vstack([Xf, U]) if ft else Xf
        th, Ef, _ = fwl_lstsq(reg, np.where(valid, Y, 0.0), e0)
        D = th[:, n:] if ft else np.zeros((l, m))
        return th[:, :n], D, Ef[:, cols]
    return estimate_cd(X, U[:, cols], Y[:, cols], feedthrough)


def state_equation(
    X: Array, E: Array, C: Array, lag: LagOperator, stage: VarxStage, stable_k: bool, m: int
) -> tuple[Array, Array, Array, str]:
    """Step 3b of :func:`~hdpbsid.core.blocks.pbsid_core_blocks`: ``A, B, K`` by least
    squares on the lagged state, inputs and innovations with the pseudo rows lagged once
    eliminated.

    Parameters
    ----------
    X : ndarray, shape (n, len(cols))
        The state on the VARX columns.
    E : ndarray, shape (l, len(cols))
        The innovations.
    C : ndarray, shape (l, n)
        The output matrix (for the Riccati gain).
    lag : LagOperator
        The (block) lag.
    stage : VarxStage
        The order-independent stage.
    stable_k : bool
        Replace the least-squares gain by the Riccati gain.
    m : int
        The number of inputs.

    Returns
    -------
    A, B, K : ndarray
        The state equation.
    k_method : str
        How ``K`` was obtained.

    Raises
    ------
    ValueError
        If too few columns are left for the regression.
    """
    n, l = X.shape[0], E.shape[0]
    ncols = stage.valid.size
    Xf = np.zeros((n, ncols))
    Xf[:, stage.cols] = X
    Ef = np.zeros((l, ncols))
    Ef[:, stage.cols] = E
    LX = lag.apply(Xf, 1)
    LE = lag.apply(Ef, 1)
    LU, use, e1 = stage.LU, stage.use, stage.e1
    if e1.ncols <= n + m + l:
        raise ValueError(
            f"too few usable columns ({e1.ncols}) to estimate A, B, K with "
            f"{n + m + l} regressors per state; supply more data or reduce p/order"
        )
    reg_u = np.where(use, np.vstack([LX, LU, LE]), 0.0)
    th, resid_abk, _ = fwl_lstsq(reg_u, np.where(use, Xf, 0.0), e1)
    A, B, Kg = th[:, :n], th[:, n : n + m], th[:, n + m :]
    k_method = "least squares"
    if stable_k:
        ui = np.flatnonzero(use)
        # W = x - A lag(x) - B lag(u) - (pseudo part) = K lag(e) + residual
        W = (resid_abk + Kg @ reg_u[n + m :])[:, ui]
        Kg, k_method = stable_gain(A, C, W, LE[:, ui], Kg)
    return A, B, Kg, k_method
