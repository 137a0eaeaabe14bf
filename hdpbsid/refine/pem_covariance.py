"""The covariance of the prediction-error estimate (:mod:`hdpbsid.refine.pem`): the
asymptotic ``cov(beta) = s^2 (J^T J)^+`` of the local coordinates at the minimum
(Ljung, *System Identification*, 2nd ed., 1999, sec. 9.3), mapped to the eigenvalues
(:func:`_eigenvalue_std`) and to ``A, B, C, D`` in the record's units
(:func:`_abcd_factor`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from hdpbsid.models.uncertainty import covariance_factor, scale_factor
from hdpbsid.refine.pem_residuals import _Layout

__all__: list[str] = []

Array = NDArray[np.float64]


def _eigenvalue_std(lay: _Layout, theta: Array, Q: Array, J: Array, cost: float) -> Array:
    """Asymptotic standard deviation of each eigenvalue of ``A`` (sorted like
    :attr:`StateSpaceModel.eigenvalues`): ``cov(beta) = s^2 (J^T J)^+`` with the
    weighted residual variance ``s^2`` (Ljung sec. 9.3), mapped to the eigenvalues by
    their finite-difference gradient; ``sqrt(var Re + var Im)``."""
    P = cost * np.linalg.pinv(J.T @ J)

    def eig(beta: Array) -> NDArray[np.complex128]:
        A = lay.unpack(theta + Q @ beta)[0]
        ev = np.linalg.eigvals(A)
        return ev[np.lexsort((ev.imag, ev.real))]

    ev0 = eig(np.zeros(Q.shape[1]))
    G = np.empty((ev0.size, Q.shape[1]), dtype=complex)
    # forward difference at ~sqrt(eps) relative: truncation and rounding balanced
    step = 1e-6 * max(1.0, float(np.max(np.abs(ev0))))
    for k in range(Q.shape[1]):
        e = np.zeros(Q.shape[1])
        e[k] = step
        evp = eig(e)
        # pair the perturbed eigenvalues with the unperturbed ones (nearest)
        idx = np.argmin(np.abs(evp[None, :] - ev0[:, None]), axis=1)
        G[:, k] = (evp[idx] - ev0) / step
    var = np.einsum("ik,kl,il->i", G.real, P, G.real) + np.einsum("ik,kl,il->i", G.imag, P, G.imag)
    return np.sqrt(np.maximum(var, 0.0))


def _abcd_factor(lay: _Layout, Q: Array, J: Array, cost: float, ys: Array, us: Array) -> Array:
    """The covariance factor of ``[vec A, vec B, vec C, vec D]`` in the record's units
    (:class:`hdpbsid.models.uncertainty.ParameterCovariance`): ``cov(beta) = s^2
    (J^T J)^+`` of the local coordinates (as :func:`_eigenvalue_std`), mapped by
    ``theta = theta_0 + Q beta`` (rows of ``K`` dropped, zero rows for a ``D`` that is
    not a parameter) and by the unit scaling of
    :func:`~hdpbsid.refine.pem_residuals._unscale` (``B / us``, ``ys C``, ``ys D / us``)."""
    n, m, l = lay.n, lay.m, lay.l
    F = Q @ covariance_factor(cost * np.linalg.pinv(J.T @ J))
    s = lay.stops
    parts = [F[s[0] : s[1]], F[s[1] : s[2]], F[s[2] : s[3]]]
    parts.append(F[s[3] : s[4]] if lay.feedthrough else np.zeros((l * m, F.shape[1])))
    Fabcd = np.vstack(parts)
    inv_us = 1.0 / us if m else us
    return scale_factor(
        Fabcd,
        n,
        m,
        l,
        np.broadcast_to(inv_us[None, :], (n, m)),
        np.broadcast_to(ys[:, None], (l, n)),
        ys[:, None] * inv_us[None, :],
    )
