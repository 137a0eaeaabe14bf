"""Parameter covariance of an identified model and the confidence band of its frequency
response (delta method).

**Convention.**  A refinement that knows its parameter covariance (the prediction-error
fit :func:`hdpbsid.refine.pem.refine_pem`, the frequency-domain fit
:func:`hdpbsid.frequency.fit.identify_frequency`) gives the model a
:class:`ParameterCovariance` (``model.parameter_covariance``): a square-root factor ``F
(p, k)`` of the covariance of the vector ``theta = [vec A, vec B, vec C, vec D]``
(row-major, ``p = n^2 + n m + l n + l m``, in the units of the model's own matrices):
``cov(theta) = F F^T``.  A factor keeps the semi-definite covariance of a
parametrisation with fewer free directions than ``p`` (modal coordinates, the
data-driven local coordinates) exactly, and is smaller to store.  Each refinement forms
it as ``s^2 (J^T J)^+`` of its own free parameters (Ljung, *System Identification*, 2nd
ed., sec. 9.3; Pintelon & Schoukens, *System Identification: A Frequency Domain
Approach*, 2nd ed., 2012, sec. 9.3), mapped to ``theta`` by the linear map of its
parametrisation.  It is the covariance *given the model structure*: the order, the dead
times and, for a model fitted to sampled data, the input's behaviour between samples
(``options["input_hold"]``).  The continuous-time response of two holds differs by about
half a sample of phase, ``w h / 2``, which a record whose modes are slow against the
sampling cannot resolve; the band is then honest only for the hold the input really had
(the refinement keeps its first hold, zero order, unless the data reject it,
:data:`hdpbsid.refine.pem.HOLD_EVIDENCE`; pass ``input_hold`` when you know it).

**Validity.**  The covariance is first-order asymptotic in the record's length.  Measured
(tests and a seeded study: the second-order system at 2 rad/s, damping 0.2, 20 % white
output noise, ``identify(method="dt", refine="pem")``, the 95 % band at the resonance):
coverage 0.94-0.95 on 100-s records (dt 0.05 s and 0.2 s), but about 0.7 on 30-s records
(twelve time constants of the mode), whose estimates scatter about twice the band's
standard deviation.  A record shorter than a few tens of time constants of its slowest
mode gets a band that is too narrow; the frequency-domain fit's band (exact lines with
known noise) covered at its level in the tests.

**Delta method** (:func:`response_band`).  ``G(s) = C (sI - A)^{-1} B + D`` is smooth in
``theta``; with ``Phi = C (sI - A)^{-1}`` and ``Psi = (sI - A)^{-1} B``,

    dG / dA_pq = Phi[:, p] Psi[q, :],   dG_ij / dB_pj = Phi_ip,
    dG_ij / dC_ip = Psi_pj,             dG_ij / dD_ij = 1,

(from ``d(M^{-1}) = -M^{-1} dM M^{-1}``).  For each entry and frequency the row ``J``
of these derivatives gives ``R = Re(J) F`` and ``I = Im(J) F``, so that ``(Re G, Im
G)`` has covariance ``[[R.R, R.I], [R.I, I.I]]`` to first order.  The magnitude and
phase are functions of ``(Re G, Im G)`` with gradients ``(Re G, Im G) / |G|`` and
``(-Im G, Re G) / |G|^2``; their standard deviations follow, and the pointwise
``1 - alpha`` band is ``+- z_{1 - alpha/2}`` of them (normal approximation, valid where
the standard deviation is small against ``|G|``: the band of a response that is not
known to within its own size is not a band).  A dead time multiplies ``G`` by
``e^{-j w tau}``: it turns the phase and leaves both standard deviations unchanged (the
delay is treated as known).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "ParameterCovariance",
    "covariance_factor",
    "scale_factor",
    "ResponseBand",
    "response_band",
    "transfer_jacobian",
]

Array = NDArray[np.float64]


def parameter_count(n: int, m: int, l: int) -> int:
    """``p = n^2 + n m + l n + l m``, the length of ``theta`` (module docstring)."""
    return n * n + n * m + l * n + l * m


@dataclass(frozen=True)
class ParameterCovariance:
    """The covariance of ``theta = [vec A, vec B, vec C, vec D]`` (module docstring) as a
    factor: ``cov(theta) = factor @ factor.T``.

    Attributes
    ----------
    factor : (p, k) finite array, ``p = n^2 + n m + l n + l m``.
    source : the fit that produced it (``"refine_pem"``, ``"identify_frequency"``).

    Raises
    ------
    ValueError
        On a factor that is not a finite 2-D array, or a ``source`` that is not a string.

    Examples
    --------
    >>> F = np.zeros((4, 1)); F[1, 0] = 0.1
    >>> ParameterCovariance(F, "given").covariance()[1, 1]
    np.float64(0.010000000000000002)
    """

    factor: Array
    source: str

    def __post_init__(self) -> None:
        F = np.asarray(self.factor, dtype=float)
        if F.ndim != 2 or not np.all(np.isfinite(F)):
            raise ValueError(
                f"parameter_covariance.factor must be a finite 2-D array, got shape {F.shape}"
            )
        if not isinstance(self.source, str):
            raise ValueError(
                f"parameter_covariance.source must be a string, got {type(self.source).__name__}"
            )
        object.__setattr__(self, "factor", F)

    def covariance(self) -> Array:
        """``F F^T``, ``(p, p)``."""
        return self.factor @ self.factor.T

    def check(self, n: int, m: int, l: int) -> None:
        """Raise ``ValueError`` unless the factor has ``p`` rows for ``(n, m, l)``."""
        p = parameter_count(n, m, l)
        if self.factor.shape[0] != p:
            raise ValueError(
                f"parameter_covariance.factor must have {p} rows (n^2 + nm + ln + lm for n={n}, "
                f"m={m}, l={l}), got {self.factor.shape[0]}"
            )

    def scaled(
        self, n: int, m: int, l: int, sB: Array, sC: Array, sD: Array
    ) -> ParameterCovariance:
        """The covariance after ``B``, ``C``, ``D`` are scaled entrywise
        (:func:`scale_factor`)."""
        return ParameterCovariance(scale_factor(self.factor, n, m, l, sB, sC, sD), self.source)


def covariance_factor(cov: Any) -> Array:
    """A factor ``F`` with ``F F^T = cov`` for a symmetric positive semi-definite
    ``cov``: ``V sqrt(max(lambda, 0))`` of its eigen-decomposition, the columns of zero
    eigenvalues dropped (rounding below ``p eps max(lambda)`` counts as zero)."""
    cov = np.asarray(cov, dtype=float)
    cov = 0.5 * (cov + cov.T)
    lam, V = np.linalg.eigh(cov)
    keep = lam > cov.shape[0] * np.finfo(float).eps * max(float(np.max(lam, initial=0.0)), 0.0)
    return V[:, keep] * np.sqrt(lam[keep])[None, :]


def scale_factor(F: Any, n: int, m: int, l: int, sB: Array, sC: Array, sD: Array) -> Array:
    """The factor of ``theta`` when ``B``, ``C``, ``D`` are multiplied entrywise by
    ``sB (n, m)``, ``sC (l, n)``, ``sD (l, m)`` (``A`` unchanged): each row of ``F``
    by its entry's factor."""
    F = np.asarray(F, dtype=float)
    s = np.concatenate([np.ones(n * n), np.ravel(sB), np.ravel(sC), np.ravel(sD)])
    if F.shape[0] != s.size:
        raise ValueError(f"the covariance factor has {F.shape[0]} rows, expected {s.size}")
    return F * s[:, None]


def transfer_jacobian(A: Array, B: Array, C: Array, s: NDArray[np.complex128]) -> Any:
    """``dG / dtheta``, complex ``(l, m, ns, p)`` in the order of ``theta`` (module
    docstring)."""
    n, m = B.shape
    l = C.shape[0]
    R = np.linalg.inv(s[:, None, None] * np.eye(n)[None] - A[None])  # (ns, n, n)
    Phi = np.einsum("ip,kpq->kiq", C, R)  # (ns, l, n)
    Psi = np.einsum("kpq,qj->kpj", R, B)  # (ns, n, m)
    ns = s.size
    dA = np.einsum("kip,kqj->ijkpq", Phi, Psi).reshape(l, m, ns, n * n)
    dB = np.zeros((l, m, ns, n, m), dtype=complex)
    dC = np.zeros((l, m, ns, l, n), dtype=complex)
    dD = np.zeros((l, m, ns, l, m), dtype=complex)
    for j in range(m):
        dB[:, j, :, :, j] = np.moveaxis(Phi, 0, 1)
        for i in range(l):
            dD[i, j, :, i, j] = 1.0
    for i in range(l):
        dC[i, :, :, i, :] = np.moveaxis(Psi, 0, 2).transpose(1, 2, 0)
    return np.concatenate(
        [dA, dB.reshape(l, m, ns, -1), dC.reshape(l, m, ns, -1), dD.reshape(l, m, ns, -1)],
        axis=3,
    )


def _transfer(A: Array, B: Array, C: Array, D: Array, s: NDArray[np.complex128]) -> Any:
    """``C (sI - A)^{-1} B + D``, (l, m, ns)."""
    X = np.linalg.solve(
        s[:, None, None] * np.eye(A.shape[0])[None] - A[None],
        np.broadcast_to(B, (s.size, *B.shape)),
    )
    return np.moveaxis(np.einsum("ij,kjl->kil", C, X) + D[None], 0, -1)


@dataclass
class ResponseBand:
    """A model's frequency response with its pointwise ``level`` band (:func:`response_band`).

    ``w`` (nf,), ``G`` (l, m, nf) complex (dead times included), ``magnitude_sd`` and
    ``phase_sd`` (rad) the standard deviations of ``|G|`` and ``arg G``, ``z`` the
    normal quantile of the band.
    """

    w: Array
    G: NDArray[np.complex128]
    magnitude_sd: Array
    phase_sd: Array
    z: float
    level: float

    def magnitude_db(self) -> tuple[Array, Array, Array]:
        """``(lower, centre, upper)`` of the magnitude in dB; a lower edge at or below
        zero magnitude is drawn 40 dB below the centre."""
        mag = np.abs(self.G)
        lo = np.maximum(mag - self.z * self.magnitude_sd, 0.01 * mag)
        hi = mag + self.z * self.magnitude_sd
        return 20 * np.log10(lo), 20 * np.log10(mag), 20 * np.log10(hi)

    def phase_deg(self) -> tuple[Array, Array, Array]:
        """``(lower, centre, upper)`` of the phase (unwrapped along frequency), degrees."""
        ph = np.unwrap(np.angle(self.G), axis=-1)
        half = self.z * self.phase_sd
        return np.degrees(ph - half), np.degrees(ph), np.degrees(ph + half)


def response_band(model: Any, w: Any, alpha: float = 0.05) -> ResponseBand:
    """Frequency response of ``model`` at ``w`` with its pointwise ``1 - alpha`` band
    from the parameter covariance (module docstring).

    Parameters
    ----------
    model : StateSpaceModel
        A model with a :class:`ParameterCovariance` (refined by ``refine="pem"`` or fitted
        by :func:`hdpbsid.frequency.fit.identify_frequency`).
    w : (nf,) angular frequencies (rad per the model's time unit).
    alpha : the band's level is ``1 - alpha``.

    Returns
    -------
    ResponseBand

    Raises
    ------
    ValueError
        When the model carries no covariance, its factor does not fit the model's
        dimensions, or ``alpha`` is not in ``(0, 1)``.

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> F = np.zeros((4, 1)); F[1, 0] = 0.1  # B = 1 +- 0.1
    >>> m = StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]],
    ...                     parameter_covariance=ParameterCovariance(F, "given"))
    >>> band = response_band(m, [0.0])
    >>> round(float(band.magnitude_sd[0, 0, 0]), 12)
    0.1
    """
    from scipy.stats import norm

    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
    cov = getattr(model, "parameter_covariance", None)
    if cov is None:
        raise ValueError(
            "the model has no parameter_covariance: refine it (identify(..., refine='pem')) "
            "or fit it with identify_frequency"
        )
    n, m, l = model.n, model.m, model.l
    cov.check(n, m, l)
    F = cov.factor
    w = np.asarray(w, dtype=float).reshape(-1)
    s = 1j * w
    J = transfer_jacobian(model.A, model.B, model.C, s)  # (l, m, nf, p)
    Rr = np.einsum("ijkp,pq->ijkq", J.real, F)
    Ri = np.einsum("ijkp,pq->ijkq", J.imag, F)
    vrr = np.sum(Rr * Rr, axis=-1)
    vii = np.sum(Ri * Ri, axis=-1)
    vri = np.sum(Rr * Ri, axis=-1)
    G = _transfer(model.A, model.B, model.C, model.D, s)
    mag = np.maximum(np.abs(G), np.finfo(float).tiny)
    gr, gi = G.real / mag, G.imag / mag
    var_mag = gr * gr * vrr + 2 * gr * gi * vri + gi * gi * vii
    var_ph = (gi * gi * vrr - 2 * gr * gi * vri + gr * gr * vii) / mag**2
    delay = np.asarray(getattr(model, "delay", np.zeros(m)), dtype=float)
    if np.any(delay):
        G = G * np.exp(-1j * delay[None, :, None] * w[None, None, :])
    z = float(norm.ppf(1.0 - alpha / 2.0))
    return ResponseBand(
        w, G, np.sqrt(np.maximum(var_mag, 0)), np.sqrt(np.maximum(var_ph, 0)), z, 1.0 - alpha
    )
