"""One-step predictor of a sampled continuous-time innovation model, with its exact
parameter derivatives (for the prediction-error refinement, :mod:`hdpbsid.refine.pem`).

Sampling (uniform step ``h``, :mod:`hdpbsid.models.conversion`): with the block matrix

    Mb = [[A h, B h, K h, 0], [0, 0, 0, I (foh only)], [0 ...]],    E = expm(Mb),

``Phi = E_11``, ``Gu = E_12``, ``Kd = E_13`` and, for a first-order hold, ``G2 = E_14``
(Franklin, Powell & Workman, *Digital Control*, sec. 6.3): the state ``xi = x - G2 u``
gives ``Gu <- Gu - G2 + Phi G2`` and the feedthrough ``Du = D + C G2``.  The predictor is

    xi_{k+1} = F xi_k + G u_k + Kd y_k,   yhat_k = C xi_k + Du u_k,
    F = Phi - Kd C,   G = Gu - Kd Du.

Derivatives.  ``d expm(Mb)[dMb]`` (the Frechet derivative) is the upper-right block of
``expm([[Mb, dMb], [0, Mb]])`` (Van Loan 1978; Higham, *Functions of Matrices*, 2008,
eq. (3.16)); one batched ``expm`` gives it for every entry of ``A, B, K``.  The
sensitivity ``s = d xi / d theta_i`` obeys the predictor recursion driven by the
derivative matrices,

    s_{k+1} = F s_k + dF xi_k + dG u_k + dKd y_k,   s_0 = 0,
    d e_k = -(dC xi_k + C s_k + dDu u_k),

(Ljung, *System Identification*, 2nd ed., sec. 10.3, eq. (10.41)), so all ``P``
sensitivities run through the same ``n`` modal first-order recursions as the predictor
(:func:`scipy.signal.lfilter` on a ``P x Ns`` block per eigenvalue): the cost of the
exact Jacobian is that of ``P`` filtered signals, not ``P`` extra evaluations of the
cost as with finite differences.  The compiled evaluation
(:mod:`hdpbsid.refine.pem_kernels`) goes further: ``s`` is linear in the drive matrix
``[dF, dG, dKd]``, so the ``n (n + m + l)`` modal filters of ``[xi; u; y]`` carry the
sensitivities of every direction, which enter only through one matrix product.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from hdpbsid.models.recursion import modal_filter

__all__ = ["Predictor", "sampled_predictor", "conjugate_representatives", "modal_filter"]

Array = NDArray[np.float64]


class Predictor:
    """``F, G, Kd, C, Du`` and (optionally) their derivatives ``dF (P, n, n)``,
    ``dG (P, n, m)``, ``dKd (P, n, l)``, ``dC (P, l, n)``, ``dDu (P, l, m)`` with respect
    to the ``P`` parameters in the order ``vec A, vec B, vec C, [vec D], vec K`` (row
    major, as packed by the refinement)."""

    def __init__(self, F: Array, G: Array, Kd: Array, C: Array, Du: Array) -> None:
        self.F, self.G, self.Kd, self.C, self.Du = F, G, Kd, C, Du
        self.dF: Array | None = None
        self.dG: Array | None = None
        self.dKd: Array | None = None
        self.dC: Array | None = None
        self.dDu: Array | None = None


def _block(A: Array, B: Array, K: Array, h: float, hold: str) -> Array:
    n, m, l = A.shape[0], B.shape[1], K.shape[1]
    size = n + m + l + (m if hold == "foh" else 0)
    M = np.zeros((size, size))
    M[:n, :n] = A * h
    M[:n, n : n + m] = B * h
    M[:n, n + m : n + m + l] = K * h
    if hold == "foh":
        M[n : n + m, n + m + l :] = np.eye(m)
    return M


def sampled_predictor(
    A: Array,
    B: Array,
    C: Array,
    D: Array,
    K: Array,
    h: float,
    hold: str,
    feedthrough: bool,
    derivatives: bool = False,
) -> Predictor:
    """The sampled predictor (module docstring), with derivatives when asked."""
    n, m, l = A.shape[0], B.shape[1], C.shape[0]
    M = _block(A, B, K, h, hold)
    s = M.shape[0]
    foh = hold == "foh"
    if not derivatives:
        E = expm(M)
        dE = np.zeros((0, s, s))
    else:
        # one direction per entry of A, B, K: dM = h e_r e_c^T in the A/B/K blocks
        pos = [(r, c) for r in range(n) for c in range(n)]
        pos += [(r, n + c) for r in range(n) for c in range(m)]
        pos += [(r, n + m + c) for r in range(n) for c in range(l)]
        big = np.zeros((len(pos), 2 * s, 2 * s))
        big[:, :s, :s] = M
        big[:, s:, s:] = M
        for i, (r, c) in enumerate(pos):
            big[i, r, s + c] = h
        Ebig = expm(big)
        E = Ebig[0, :s, :s]
        dE = Ebig[:, :s, s:]
    Phi, Gu, Kd = E[:n, :n], E[:n, n : n + m], E[:n, n + m : n + m + l]
    G2 = E[:n, n + m + l :] if foh else np.zeros((n, m))
    Gf = Gu - G2 + Phi @ G2 if foh else Gu
    Du = D + C @ G2 if foh else D
    pred = Predictor(Phi - Kd @ C, Gf - Kd @ Du, Kd, C, Du)
    if not derivatives:
        return pred
    na, nb, nk = n * n, n * m, n * l
    nc, nd = l * n, (l * m if feedthrough else 0)
    # derivatives of E for the A, B, K entries; zero for C, D entries
    P = na + nb + nc + nd + nk
    dEf = np.zeros((P, s, s))
    dEf[: na + nb] = dE[: na + nb]
    dEf[na + nb + nc + nd :] = dE[na + nb :]
    dPhi, dGu, dKd = dEf[:, :n, :n], dEf[:, :n, n : n + m], dEf[:, :n, n + m : n + m + l]
    dG2 = dEf[:, :n, n + m + l :] if foh else np.zeros((P, n, m))
    dC = np.zeros((P, l, n))
    dC[na + nb : na + nb + nc] = np.eye(nc).reshape(nc, l, n)
    dD = np.zeros((P, l, m))
    if nd:
        dD[na + nb + nc : na + nb + nc + nd] = np.eye(nd).reshape(nd, l, m)
    if foh:
        dGf = dGu - dG2 + dPhi @ G2 + Phi @ dG2
        dDu = dD + dC @ G2 + C @ dG2
    else:
        dGf, dDu = dGu, dD
    pred.dF = dPhi - dKd @ C - Kd @ dC
    pred.dG = dGf - dKd @ Du - Kd @ dDu
    pred.dKd = dKd
    pred.dC = dC
    pred.dDu = dDu
    return pred


def conjugate_representatives(
    lam: NDArray[np.complex128],
) -> tuple[NDArray[np.intp], Array]:
    """Indices of one eigenvalue per conjugate pair (and every real one) and the weight
    that recovers a real signal from them: ``x = sum_a V[:, a] z_a =
    sum_{a kept} w_a Re(V[:, a] z_a)`` with ``w = 2`` for a pair, ``1`` for a real mode.

    ``lam`` from :func:`numpy.linalg.eig` of a real matrix (pairs are adjacent and exact
    conjugates; the signal ``z = V^{-1} x`` of a real ``x`` has conjugate entries on a
    pair).
    """
    keep, fac = [], []
    a = 0
    while a < lam.size:
        keep.append(a)
        if lam[a].imag != 0 and a + 1 < lam.size and lam[a + 1] == np.conj(lam[a]):
            fac.append(2.0)
            a += 2
        else:
            fac.append(1.0)
            a += 1
    return np.array(keep, dtype=np.intp), np.array(fac)
