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
:attr:`~hdpbsid.refine.pem_settings.RefinementSettings.hold_evidence`; pass
``input_hold`` when you know it).

**Validity.**  The covariance is first-order asymptotic in the record's length (Ljung,
sec. 9.3): it neglects the curvature of the fit's cost, whose share of the estimates'
scatter falls only as the record grows against the slowest mode's time constant.  On a
record of a few tens of time constants of its slowest mode the band covers at its level;
on a shorter one the estimates scatter more widely than the band says, and the band is
too narrow.  The frequency-domain fit's band (exact lines with known noise) rests on the
same approximation.

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
    """The covariance of ``theta = [vec A, vec B, vec C, vec D]`` as a square-root factor.

    ``cov(theta) = factor @ factor.T`` (module docstring).

    Parameters
    ----------
    factor : array_like, shape (p, k)
        Finite; ``p = n^2 + n m + l n + l m`` rows in the order of ``theta`` (row-major
        ``vec``), in the units of the model's own matrices.
    source : str
        The fit that produced it (``"refine_pem"``, ``"identify_frequency"``).

    Raises
    ------
    ValueError
        On a factor that is not a finite 2-D array, or a ``source`` that is not a string.

    Examples
    --------
    >>> import numpy as np
    >>> F = np.zeros((4, 1)); F[1, 0] = 0.1
    >>> round(float(ParameterCovariance(F, "given").covariance()[1, 1]), 12)
    0.01
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
        """The covariance itself.

        Returns
        -------
        ndarray, shape (p, p)
            :math:`F F^T`.
        """
        return self.factor @ self.factor.T

    def check(self, n: int, m: int, l: int) -> None:
        """Check that the factor fits a model of dimensions ``(n, m, l)``.

        Parameters
        ----------
        n, m, l : int
            State, input and output dimensions.

        Raises
        ------
        ValueError
            Unless the factor has ``p = n^2 + n m + l n + l m`` rows.
        """
        p = parameter_count(n, m, l)
        if self.factor.shape[0] != p:
            raise ValueError(
                f"parameter_covariance.factor must have {p} rows (n^2 + nm + ln + lm for n={n}, "
                f"m={m}, l={l}), got {self.factor.shape[0]}"
            )

    def scaled(
        self, n: int, m: int, l: int, sB: Array, sC: Array, sD: Array
    ) -> ParameterCovariance:
        """The covariance after ``B``, ``C``, ``D`` are scaled entrywise (:func:`scale_factor`).

        Parameters
        ----------
        n, m, l : int
            State, input and output dimensions.
        sB : ndarray, shape (n, m)
            Factors of the entries of ``B``.
        sC : ndarray, shape (l, n)
            Factors of the entries of ``C``.
        sD : ndarray, shape (l, m)
            Factors of the entries of ``D``.

        Returns
        -------
        ParameterCovariance
            A new object with the same ``source``.
        """
        return ParameterCovariance(scale_factor(self.factor, n, m, l, sB, sC, sD), self.source)


def covariance_factor(cov: Any) -> Array:
    r"""A factor ``F`` with ``F F^T = cov`` for a symmetric positive semi-definite ``cov``.

    Parameters
    ----------
    cov : array_like, shape (p, p)
        The covariance (symmetrised first).

    Returns
    -------
    ndarray, shape (p, k)
        :math:`V \sqrt{\max(\Lambda, 0)}` of the eigendecomposition, the columns of zero
        eigenvalues dropped (rounding below :math:`p\,\epsilon \max\lambda` counts as
        zero), so a covariance of rank ``k`` keeps ``k`` columns.

    Examples
    --------
    >>> import numpy as np
    >>> F = covariance_factor([[4.0, 2.0], [2.0, 1.0]])  # rank 1
    >>> F.shape, bool(np.allclose(F @ F.T, [[4.0, 2.0], [2.0, 1.0]]))
    ((2, 1), True)
    """
    cov = np.asarray(cov, dtype=float)
    cov = 0.5 * (cov + cov.T)
    lam, V = np.linalg.eigh(cov)
    keep = lam > cov.shape[0] * np.finfo(float).eps * max(float(np.max(lam, initial=0.0)), 0.0)
    return V[:, keep] * np.sqrt(lam[keep])[None, :]


def scale_factor(F: Any, n: int, m: int, l: int, sB: Array, sC: Array, sD: Array) -> Array:
    """The factor of ``theta`` when ``B``, ``C``, ``D`` are multiplied entrywise.

    Parameters
    ----------
    F : array_like, shape (p, k)
        The factor.
    n, m, l : int
        State, input and output dimensions.
    sB : ndarray, shape (n, m)
        Factors of the entries of ``B``.
    sC : ndarray, shape (l, n)
        Factors of the entries of ``C``.
    sD : ndarray, shape (l, m)
        Factors of the entries of ``D`` (``A`` is unchanged).

    Returns
    -------
    ndarray, shape (p, k)
        Each row of ``F`` multiplied by its entry's factor (a linear change of parameters
        scales the covariance's factor by the same diagonal).

    Raises
    ------
    ValueError
        If ``F`` does not have ``p = n^2 + n m + l n + l m`` rows.
    """
    F = np.asarray(F, dtype=float)
    s = np.concatenate([np.ones(n * n), np.ravel(sB), np.ravel(sC), np.ravel(sD)])
    if F.shape[0] != s.size:
        raise ValueError(f"the covariance factor has {F.shape[0]} rows, expected {s.size}")
    return F * s[:, None]


def transfer_jacobian(A: Array, B: Array, C: Array, s: NDArray[np.complex128]) -> Any:
    r"""Derivatives of the transfer matrix with respect to ``theta`` (module docstring).

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix.
    B : ndarray, shape (n, m)
        Input matrix.
    C : ndarray, shape (l, n)
        Output matrix.
    s : ndarray of complex, shape (ns,)
        Laplace variables (``1j w``).

    Returns
    -------
    ndarray of complex, shape (l, m, ns, p)
        :math:`\partial G_{ij}(s) / \partial \theta`, in the order of ``theta``.

    Notes
    -----
    With :math:`\Phi = C (sI - A)^{-1}` and :math:`\Psi = (sI - A)^{-1} B`, from
    :math:`d(M^{-1}) = -M^{-1}\, dM\, M^{-1}`:

    .. math::

        \frac{\partial G}{\partial A_{pq}} = \Phi_{:,p} \Psi_{q,:}, \quad
        \frac{\partial G_{ij}}{\partial B_{pj}} = \Phi_{ip}, \quad
        \frac{\partial G_{ij}}{\partial C_{ip}} = \Psi_{pj}, \quad
        \frac{\partial G_{ij}}{\partial D_{ij}} = 1.
    """
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
    r"""A model's frequency response with its pointwise band (:func:`response_band`).

    Parameters
    ----------
    w : ndarray, shape (nf,)
        Angular frequencies.
    G : ndarray of complex, shape (l, m, nf)
        The response, dead times included.
    magnitude_sd : ndarray, shape (l, m, nf)
        Standard deviation of :math:`|G|`.
    phase_sd : ndarray, shape (l, m, nf)
        Standard deviation of :math:`\arg G` in rad.
    z : float
        The normal quantile of the band, :math:`z_{1 - \alpha/2}`.
    level : float
        The band's level, :math:`1 - \alpha`.
    """

    w: Array
    G: NDArray[np.complex128]
    magnitude_sd: Array
    phase_sd: Array
    z: float
    level: float

    def magnitude_db(self) -> tuple[Array, Array, Array]:
        r"""The magnitude band in dB.

        Returns
        -------
        lower, centre, upper : ndarray, shape (l, m, nf)
            :math:`20 \log_{10}(|G| \mp z\,\sigma)`; a lower edge at or below zero
            magnitude is drawn 40 dB below the centre.
        """
        mag = np.abs(self.G)
        lo = np.maximum(mag - self.z * self.magnitude_sd, 0.01 * mag)
        hi = mag + self.z * self.magnitude_sd
        return 20 * np.log10(lo), 20 * np.log10(mag), 20 * np.log10(hi)

    def phase_deg(self) -> tuple[Array, Array, Array]:
        r"""The phase band in degrees.

        Returns
        -------
        lower, centre, upper : ndarray, shape (l, m, nf)
            The phase unwrapped along frequency, :math:`\mp z\,\sigma_\phi`.
        """
        ph = np.unwrap(np.angle(self.G), axis=-1)
        half = self.z * self.phase_sd
        return np.degrees(ph - half), np.degrees(ph), np.degrees(ph + half)


def response_band(model: Any, w: Any, alpha: float = 0.05) -> ResponseBand:
    r"""Frequency response of a model with its pointwise ``1 - alpha`` band (module docstring).

    Parameters
    ----------
    model : StateSpaceModel
        A model with a :class:`ParameterCovariance` (refined by ``refine="pem"`` or fitted
        by :func:`hdpbsid.frequency.fit.identify_frequency`).
    w : array_like, shape (nf,)
        Angular frequencies (rad per the model's time unit).
    alpha : float, optional
        The band's level is ``1 - alpha``.

    Returns
    -------
    ResponseBand
        The response and the standard deviations of its magnitude and phase.

    Raises
    ------
    ValueError
        When the model carries no covariance, its factor does not fit the model's
        dimensions, or ``alpha`` is not in ``(0, 1)``.

    Notes
    -----
    Delta method: for each entry and frequency the row ``J`` of
    :func:`transfer_jacobian` gives :math:`R = \operatorname{Re}(J) F` and
    :math:`I = \operatorname{Im}(J) F`, the covariance of
    :math:`(\operatorname{Re} G, \operatorname{Im} G)` is
    :math:`\begin{bmatrix} R R^T & R I^T \\ I R^T & I I^T \end{bmatrix}` to first order,
    and the gradients :math:`(\operatorname{Re} G, \operatorname{Im} G) / |G|` and
    :math:`(-\operatorname{Im} G, \operatorname{Re} G) / |G|^2` give the standard
    deviations of magnitude and phase (Pintelon & Schoukens, *System Identification: A
    Frequency Domain Approach*, 2nd ed., 2012, sec. 9.3).

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
