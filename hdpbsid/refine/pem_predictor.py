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
    """The sampled predictor ``F, G, Kd, C, Du`` (module docstring) and, optionally, its
    derivatives with respect to the ``P`` parameters in the order ``vec A, vec B, vec C,
    [vec D], vec K`` (row major, as packed by the refinement).

    Parameters
    ----------
    F : ndarray
        ``Phi - Kd C``, ``(n, n)``.
    G : ndarray
        ``Gu - Kd Du``, ``(n, m)``.
    Kd : ndarray
        The sampled gain, ``(n, l)``.
    C : ndarray
        The output matrix, ``(l, n)``.
    Du : ndarray
        The sampled feedthrough, ``(l, m)``.

    Attributes
    ----------
    dF, dG, dKd, dC, dDu : ndarray or None
        The derivatives, ``(P, n, n)``, ``(P, n, m)``, ``(P, n, l)``, ``(P, l, n)``,
        ``(P, l, m)``; None unless :func:`sampled_predictor` was asked for them.
    """

    def __init__(self, F: Array, G: Array, Kd: Array, C: Array, Du: Array) -> None:
        self.F, self.G, self.Kd, self.C, self.Du = F, G, Kd, C, Du
        self.dF: Array | None = None
        self.dG: Array | None = None
        self.dKd: Array | None = None
        self.dC: Array | None = None
        self.dDu: Array | None = None


def _block(A: Array, B: Array, K: Array, h: float, hold: str) -> Array:
    """The block matrix ``Mb`` whose exponential samples the model (module docstring)."""
    n, m, l = A.shape[0], B.shape[1], K.shape[1]
    size = n + m + l + (m if hold == "foh" else 0)
    M = np.zeros((size, size))
    M[:n, :n] = A * h
    M[:n, n : n + m] = B * h
    M[:n, n + m : n + m + l] = K * h
    if hold == "foh":
        M[n : n + m, n + m + l :] = np.eye(m)
    return M


def _exponential(
    M: Array, n: int, m: int, l: int, h: float, derivatives: bool
) -> tuple[Array, Array]:
    """``expm(M)`` and, with ``derivatives``, its Frechet derivatives along ``h e_r
    e_c^T`` for every entry of the ``A, B, K`` blocks (``(n (n + m + l), s, s)``; empty
    otherwise), all from one batched exponential of ``[[M, dM], [0, M]]``."""
    s = M.shape[0]
    if not derivatives:
        return expm(M), np.zeros((0, s, s))
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
    return Ebig[0, :s, :s], Ebig[:, :s, s:]


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
    """The sampled one-step predictor of the innovation model ``(A, B, C, D, K)``.

    ``F = Phi - Kd C``, ``G = Gu - Kd Du`` with ``Phi, Gu, Kd`` (and ``G2`` for a
    first-order hold) blocks of ``expm(Mb)`` (module docstring; Franklin, Powell &
    Workman, *Digital Control of Dynamic Systems*, 3rd ed., sec. 6.3), and with
    ``derivatives`` their exact derivatives (Van Loan's block exponential).

    Parameters
    ----------
    A, B, C, D, K : ndarray
        The continuous-time innovation model, ``(n, n)``, ``(n, m)``, ``(l, n)``,
        ``(l, m)``, ``(n, l)``.
    h : float
        The sampling interval.
    hold : {"zoh", "foh"}
        How the input behaves between samples.
    feedthrough : bool
        Whether ``D`` is a parameter (its derivatives then included).
    derivatives : bool, optional
        Whether to compute the derivatives (default False).

    Returns
    -------
    Predictor

    Examples
    --------
    >>> import numpy as np
    >>> pr = sampled_predictor(
    ...     np.array([[-1.0]]), np.array([[1.0]]), np.array([[1.0]]), np.zeros((1, 1)),
    ...     np.array([[0.5]]), 0.1, "zoh", False)
    >>> round(float(pr.F[0, 0]), 6)
    0.857256
    """
    n, m, l = A.shape[0], B.shape[1], C.shape[0]
    M = _block(A, B, K, h, hold)
    foh = hold == "foh"
    E, dE = _exponential(M, n, m, l, h, derivatives)
    Phi, Gu, Kd = E[:n, :n], E[:n, n : n + m], E[:n, n + m : n + m + l]
    G2 = E[:n, n + m + l :] if foh else np.zeros((n, m))
    Gf = Gu - G2 + Phi @ G2 if foh else Gu
    Du = D + C @ G2 if foh else D
    pred = Predictor(Phi - Kd @ C, Gf - Kd @ Du, Kd, C, Du)
    if derivatives:
        _set_derivatives(pred, dE, Phi, G2, feedthrough, foh)
    return pred


def _set_derivatives(
    pred: Predictor, dE: Array, Phi: Array, G2: Array, feedthrough: bool, foh: bool
) -> None:
    """The derivatives of ``pred`` from those of the block exponential ``dE`` (entries of
    ``A, B, K``); the ``C`` and ``D`` entries enter directly."""
    C, Kd, Du = pred.C, pred.Kd, pred.Du
    n, m, l = Phi.shape[0], G2.shape[1], C.shape[0]
    s = dE.shape[1]
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


def conjugate_representatives(
    lam: NDArray[np.complex128],
) -> tuple[NDArray[np.intp], Array]:
    """One eigenvalue per conjugate pair (and every real one), with its weight.

    The weight recovers a real signal from the kept modes: ``x = sum_a V[:, a] z_a =
    sum_{a kept} w_a Re(V[:, a] z_a)`` with ``w = 2`` for a pair, ``1`` for a real mode
    (the signal ``z = V^{-1} x`` of a real ``x`` has conjugate entries on a pair), so one
    filter per pair suffices.

    Parameters
    ----------
    lam : ndarray of complex
        Eigenvalues from :func:`numpy.linalg.eig` of a real matrix (pairs adjacent and
        exact conjugates).

    Returns
    -------
    keep : ndarray of int
        Indices of the kept eigenvalues.
    fac : ndarray of float
        Their weights, 2 for a pair and 1 for a real mode.

    Examples
    --------
    >>> import numpy as np
    >>> keep, fac = conjugate_representatives(np.array([-1 + 2j, -1 - 2j, -3 + 0j]))
    >>> keep.tolist(), fac.tolist()
    ([0, 2], [2.0, 1.0])
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
