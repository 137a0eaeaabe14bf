"""Compression onto the complement of every block's nuisance rows (Frisch-Waugh-Lovell).

The least-squares steps of the block core (:mod:`hdpbsid.core.blocks`, whose module
docstring derives it) regress on main regressors shared by all blocks and on nuisance
rows, the pseudo-inputs, different in every block.  :class:`Eliminator` maps a problem to
the coordinates of the orthogonal complement of the nuisance rows, block by block, by
their Householder reflectors (LAPACK ``ormqr``): the compressed problem has the size of
the main one and gives the same shared coefficients (Davidson & MacKinnon, *Econometric
Theory and Methods*, 2004, sec. 2.4).  The ridge of the VARX penalises the nuisance
coefficients like the main ones (:meth:`Eliminator.compress` with ``lam``).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.linalg.lapack import dormqr

from hdpbsid.core.varx import parse_regularize, r_factor, ridge_gcv

if TYPE_CHECKING:
    from hdpbsid.core.blocks import BlockPseudo

__all__ = ["Eliminator", "eliminator_for", "apply_qt", "lstsq_or_ridge", "fwl_lstsq"]

Array = NDArray[np.float64]
Mask = NDArray[np.bool_]


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


class Eliminator:
    """Compression onto the complement of every block's nuisance rows (module docstring).

    Parameters
    ----------
    pseudo : BlockPseudo or None
        The pseudo-input rows per block (None: nothing to eliminate).
    js : sequence of int
        The lags of the nuisance rows (``0`` the rows themselves).
    mask : ndarray of bool, shape (ncols,)
        The global columns used.

    Attributes
    ----------
    subs : list
        Per group of blocks with one nuisance row space: its columns, rows, orthonormal
        basis and Householder reflectors.
    plain : ndarray of int
        The used columns of blocks without nuisance rows.
    rank : int
        The number of nuisance directions eliminated.
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

        Parameters
        ----------
        W : ndarray, shape (rows, ncols)
            Rows on all columns.
        lam : float, optional
            The ridge of the nuisance coefficients (0: none).

        Returns
        -------
        ndarray, shape (rows, k)
            The compressed rows (``k = ncols`` plus ``rank`` with ``lam > 0``).
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
                C = apply_qt(s.refl, s.tau, C)
            parts.append(C[k:].T.reshape(rows, K * (nv - k)))
            if lam > 0:
                Wb = W[:, s.cols].reshape(rows * K, nv)
                soft = (Wb @ s.Q) * (lam / np.sqrt(s.sv**2 + lam**2))[None, :]
                parts.append(soft.reshape(rows, K * k))
        return np.hstack(parts)

    def residual(self, R: Array, lam: float = 0.0) -> tuple[Array, list[tuple[list[int], Array]]]:
        """Residual ``R`` with each block's nuisance fit removed, and the nuisance
        coefficients.

        Parameters
        ----------
        R : ndarray, shape (rows, ncols)
            A residual on all columns, zero off the mask.
        lam : float, optional
            The ridge of the nuisance coefficients (0: minimum-norm least squares).

        Returns
        -------
        residual : ndarray, shape (rows, ncols)
            ``R`` without the nuisance fit.
        coefficients : list of tuple
            ``(blocks, G)`` per group of blocks, ``G`` of shape ``(K, rows, r_raw)``:
            minimum-norm ``Gamma_b = R_b S_b^+``, or with ``lam > 0`` the ridge
            ``R_b S_b^T (S_b S_b^T + lam^2)^{-1}``.
        """
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


def eliminator_for(pseudo: BlockPseudo | None, js: Sequence[int], mask: Mask) -> Eliminator:
    """The (shared) :class:`Eliminator` of ``pseudo`` for the lags ``js`` on ``mask``.

    Parameters
    ----------
    pseudo : BlockPseudo or None
        The pseudo-input rows per block (None: nothing to eliminate).
    js : sequence of int
        The lags of the nuisance rows.
    mask : ndarray of bool, shape (ncols,)
        The global columns used.

    Returns
    -------
    Eliminator
        The eliminator, built once per ``(pseudo, js, mask)``.
    """
    return pseudo.eliminator(js, mask) if pseudo is not None else Eliminator(None, js, mask)


def apply_qt(refl: Array, tau: Array, C: Array) -> Array:
    """``Q^T C`` for the full orthogonal ``Q`` of a QR in LAPACK's raw layout, by ``ormqr``.

    Parameters
    ----------
    refl : ndarray, shape (N, k)
        The Householder vectors (``geqrf`` layout).
    tau : ndarray, shape (k,)
        Their factors.
    C : ndarray, shape (N, c)
        The matrix mapped.

    Returns
    -------
    ndarray, shape (N, c)
        ``Q^T C``, Fortran-ordered.

    Raises
    ------
    ValueError
        If LAPACK reports an argument error.
    """
    C = np.asfortranarray(C, dtype=float)
    if C.shape[1] == 0:
        return C
    lwork = max(1, C.shape[1]) * 64  # the blocked ormqr's work space (nb = 64 columns)
    out, _, info = dormqr("L", "T", refl, tau, C, lwork, overwrite_c=False)
    if info != 0:  # pragma: no cover - argument errors only
        raise ValueError(f"LAPACK ormqr failed (info = {info})")
    return out


def lstsq_or_ridge(
    Phi: Array, Y: Array, regularize: bool | str | float | None, floor: float
) -> tuple[Array, float, float | None, str]:
    """Least squares / ridge ``Y ~ Theta Phi`` as :func:`hdpbsid.core.varx.varx` does.

    Parameters
    ----------
    Phi : ndarray, shape (nreg, N)
        The regressors.
    Y : ndarray, shape (l, N)
        The targets.
    regularize : bool, str, float or None
        The regularisation (:func:`hdpbsid.core.varx.parse_regularize`).
    floor : float
        Lower bound of the GCV ridge.

    Returns
    -------
    theta : ndarray, shape (l, nreg)
        The coefficients.
    lam : float
        The ridge used (0 for least squares).
    gcv : float or None
        The GCV value of the ridge choice.
    kind : str
        The regularisation kind.
    """
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


def fwl_lstsq(reg: Array, target: Array, elim: Eliminator) -> tuple[Array, Array, list]:
    """Plain least squares of ``target`` on ``reg`` with the nuisance eliminated.

    Parameters
    ----------
    reg : ndarray, shape (d, ncols)
        The regressors on all columns.
    target : ndarray, shape (k, ncols)
        The targets.
    elim : Eliminator
        The nuisance eliminator.

    Returns
    -------
    theta : ndarray, shape (k, d)
        The coefficients.
    residual : ndarray, shape (k, ncols)
        The residual on all columns, nuisance fit removed.
    coefficients : list of tuple
        The nuisance coefficients (:meth:`Eliminator.residual`).
    """
    Rc = elim.compress(np.vstack([reg, target]))
    d = reg.shape[0]
    theta = np.linalg.lstsq(Rc[:d].T, Rc[d:].T, rcond=None)[0].T
    res, coefs = elim.residual(target - theta @ reg)
    return theta, res, coefs
