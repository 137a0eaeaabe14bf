"""Frequency responses from data, their coherence and confidence.

Non-parametric estimates (the first look at any flight-test or structural record):

* :func:`frf_welch`: the H1 estimate ``H = S_yu S_uu^{-1}`` from Welch-averaged cross
  spectra (windowed, overlapping segments; Welch, "The use of fast Fourier transform for
  the estimation of power spectra", IEEE Trans. Audio Electroacoust. 15(2), 1967), the
  multiple coherence of each output and, when a reference ``r`` is given (closed loop),
  the indirect estimate ``H = S_yr S_ur^{-1}`` that is consistent under feedback where
  H1 is not (Wellstead, "Non-parametric methods of system identification", Automatica
  17(1), 1981; Pintelon & Schoukens, *System Identification: A Frequency Domain
  Approach*, 2nd ed., Wiley 2012, sec. 2.6 and 9.5).
* :func:`frf_periodic`: for periodic excitation over whole periods, the exact DFT lines
  ``H(k) = Y(k) / U(k)`` of the period-averaged spectra, with the noise variance of each
  line from the scatter between periods (Pintelon & Schoukens 2012, sec. 2.4-2.5): no
  leakage, so a noise-free record gives the frequency response to rounding.

Both return a :class:`FrequencyResponse` whose ``variance`` is the variance of each
estimate and ``dof`` the degrees of freedom of that variance estimate, so that the
``1 - alpha`` confidence region of each complex value is a circle of radius
``sqrt(variance F_{2, dof}(1 - alpha))`` (Bendat & Piersol, *Random Data*, 4th ed., Wiley
2010, sec. 9.2.4-9.2.5; for periodic data the same ratio of a circular Gaussian error to
its estimated variance).  Coherence bounds use Fisher's ``z = atanh|gamma|``
(:meth:`FrequencyResponse.coherence_bounds`; Bendat & Piersol sec. 9.2.3; Carter, Knapp &
Nuttall, IEEE Trans. Audio Electroacoust. 21(4), 1973).

Models fitted to these estimates are in :mod:`hdpbsid.frequency.fit`, which re-exports
every name of this module.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import as_columns, check_positive_int, check_step

__all__ = [
    "EstimateSettings",
    "ESTIMATE",
    "FrequencyResponse",
    "frf_welch",
    "frf_periodic",
    "effective_averages",
]

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]


@dataclass(frozen=True)
class EstimateSettings:
    """Thresholds of the non-parametric estimates.

    Attributes
    ----------
    excited_line_floor : float
        A line of a periodic record counts as excited by an input when its power is above
        this fraction of that input's strongest line.
    """

    #: -60 dB separates a designed line from the rounding (~1e-30) of a noise-free design
    #: and from the leakage floor of a windowed multisine; measured inputs with noise on
    #: every line should pass ``lines`` explicitly
    excited_line_floor: float = 1e-6


#: the thresholds :func:`frf_periodic` uses
ESTIMATE = EstimateSettings()


@dataclass
class FrequencyResponse:
    """A frequency-response estimate.

    Attributes
    ----------
    w : ndarray, shape (nf,)
        Angular frequencies (rad/s).
    H : ndarray of complex, shape (l, m, nf)
        Complex response (python-control layout, as
        :meth:`hdpbsid.models.model.StateSpaceModel.frequency_response`); ``nan`` where an input
        does not excite a line (orthogonal multi-input periodic designs).
    coherence : ndarray, shape (l, nf), or None, optional
        Multiple coherence of each output with the inputs (or, closed loop, with the reference),
        or ``None``.
    variance : ndarray, shape (l, m, nf), or None, optional
        Variance estimate of each complex value (``E|H_hat - H|^2`` scaled as the module
        docstring says), or ``None``.
    dof : float or None, optional
        Real degrees of freedom of ``variance`` (``2 n - 2`` for ``n`` averages or periods), or
        ``None``.
    method : {"welch", "welch-reference", "periodic", "given"}, optional
        How the estimate was made (``"given"``: built by hand).
    options : dict, optional
        Settings used (for display; nothing reads them back).
    dt : float or None, optional
        Sampling interval of the record the estimate was made from (the estimators set it),
        or ``None`` (built by hand from a model or continuous-time data).
    """

    w: Array
    H: CArray
    coherence: Array | None = None
    variance: Array | None = None
    dof: float | None = None
    method: str = "given"
    options: dict[str, Any] = field(default_factory=dict)
    dt: float | None = None

    @property
    def magnitude_db(self) -> Array:
        """``20 log10 |H|`` (dB)."""
        return 20.0 * np.log10(np.abs(self.H))

    def __repr__(self) -> str:
        l, m, nf = np.shape(self.H)
        band = f"{self.w.min():.3g}-{self.w.max():.3g} rad/s" if nf else "no lines"
        return f"FrequencyResponse({self.method!r}, l={l}, m={m}, {nf} lines, {band})"

    @property
    def phase_deg(self) -> Array:
        """Phase of ``H`` unwrapped along frequency (degrees)."""
        return np.degrees(np.unwrap(np.angle(self.H), axis=-1))

    def confidence_radius(self, alpha: float = 0.05) -> Array:
        """Radius of the ``1 - alpha`` confidence circle of each complex value:
        ``sqrt(variance F_{2, dof}(1 - alpha))`` (module docstring).

        Parameters
        ----------
        alpha : float, optional
            The circle's level is ``1 - alpha``.

        Returns
        -------
        ndarray, shape (l, m, nf)
            The radius around each complex value.

        Raises
        ------
        ValueError
            If the estimate carries no variance, or ``alpha`` is not in ``(0, 1)``.
        """
        from scipy.stats import f as f_dist

        if self.variance is None or self.dof is None:
            raise ValueError("this frequency response has no variance estimate")
        _check_alpha(alpha)
        return np.sqrt(self.variance * f_dist.ppf(1.0 - alpha, 2, self.dof))

    def coherence_bounds(self, alpha: float = 0.05) -> tuple[Array, Array]:
        """Lower and upper ``1 - alpha`` bounds of the coherence (Fisher's ``z``).

        ``z = atanh |gamma_hat|`` is close to normal with mean ``atanh |gamma| +
        1 / (2 (n - 1))`` and variance ``1 / (2 n - 2)`` for ``n`` independent averages
        (Bendat & Piersol 2010, eq. 9.81-9.82; Enochson & Goodman 1965), ``n = (dof + 2)
        / 2``.

        Parameters
        ----------
        alpha : float, optional
            The bounds' level is ``1 - alpha``.

        Returns
        -------
        lower, upper : ndarray, shape (l, nf)
            Bounds of the squared coherence.

        Raises
        ------
        ValueError
            If there is no coherence or degrees of freedom.
        """
        from scipy.stats import norm

        if self.coherence is None or self.dof is None:
            raise ValueError("this frequency response has no coherence estimate")
        _check_alpha(alpha)
        n = (self.dof + 2.0) / 2.0
        g = np.sqrt(np.clip(self.coherence, 0.0, 1.0 - 1e-15))
        z = np.arctanh(g) - 1.0 / (2.0 * (n - 1.0))
        half = norm.ppf(1.0 - alpha / 2.0) / np.sqrt(2.0 * n - 2.0)
        lo = np.tanh(np.maximum(z - half, 0.0)) ** 2
        hi = np.tanh(np.maximum(z + half, 0.0)) ** 2
        return lo, hi


# -- Welch / H1 ---------------------------------------------------------------------------
def effective_averages(window: Array, step: int, segments: int) -> float:
    """Number of independent averages equivalent to ``segments`` overlapping windowed
    segments ``step`` samples apart (Welch 1967, eq. 9; white-noise approximation):
    ``K / (1 + 2 sum_{j=1}^{K-1} (1 - j / K) rho_j^2)`` with ``rho_j`` the window's
    normalised overlap correlation ``sum w[n] w[n + j step] / sum w^2``.

    Parameters
    ----------
    window : ndarray, shape (L,)
        Window samples.
    step : int
        Samples between segment starts.
    segments : int
        Number of segments ``K``.

    Returns
    -------
    The equivalent number of averages (``K`` without overlap; about ``0.95 K`` for
    Hann windows at 50 % overlap).

    Examples
    --------
    >>> round(effective_averages(np.ones(100), 100, 8), 12)
    8.0
    """
    w = np.asarray(window, dtype=float)
    K = check_positive_int(segments, "segments")
    step = check_positive_int(step, "step")
    e = float(np.dot(w, w))
    acc = 0.0
    for j in range(1, K):
        lag = j * step
        if lag >= w.size:
            break
        rho = float(np.dot(w[:-lag], w[lag:])) / e
        acc += (1.0 - j / K) * rho**2
    return K / (1.0 + 2.0 * acc)


def frf_welch(
    u: Any,
    y: Any,
    dt: float,
    *,
    r: Any | None = None,
    nperseg: int | None = None,
    noverlap: int | None = None,
    window: str | tuple = "hann",
    detrend: str | bool = "constant",
) -> FrequencyResponse:
    """Frequency response and coherence from Welch-averaged spectra (H1, or from a
    reference in closed loop).

    Open loop: ``H(w) = S_yu(w) S_uu(w)^{-1}`` (H1; unbiased by output noise,
    Bendat & Piersol sec. 9.1) and the multiple coherence of output ``i``,
    ``gamma_i^2 = S_{y_i u} S_uu^{-1} S_{u y_i} / S_{y_i y_i}``.  With ``r`` (a measured
    reference, e.g. the excitation added to the controller output, as many inputs as
    ``u``): ``H = S_yr S_ur^{-1}``, consistent in closed loop because ``r`` is
    uncorrelated with the noise while ``u`` is not; the coherence is then that of ``y``
    with ``r``.  Variance of each entry (first order, noise on ``y`` only; Pintelon &
    Schoukens 2012, sec. 2.6; Bendat & Piersol eq. 9.90):
    ``S_{e_i e_i} [X^{-1}]_{jj} / (n - 1)`` with ``e = y - H u`` the residual (its power is
    ``(1 - gamma_i^2) S_{y_i y_i}`` in open loop; in closed loop it is the noise itself,
    not the part of ``y`` incoherent with ``r``, which the loop has filtered),
    ``X = S_uu`` (open loop) or ``S_ur S_rr^{-1} S_ru`` (reference) and ``n`` the
    effective number of averages (:func:`effective_averages`).

    Parameters
    ----------
    u : ndarray, shape (Ns,) or (Ns, m)
        Inputs.
    y : ndarray, shape (Ns,) or (Ns, l)
        Outputs.
    dt : float
        Sampling interval (s).
    r : ndarray, shape (Ns, m), optional
        Measured reference (closed loop): the response is then ``S_yr S_ur^{-1}``, unbiased
        by the feedback.
    nperseg : int or None, optional
        Samples per segment; default ``floor(2 Ns / 9)``, eight segments at 50 % overlap
        (MATLAB's ``tfestimate``).
    noverlap : int or None, optional
        Overlap in samples; default ``nperseg // 2``.
    window : str or tuple, optional
        Window name or tuple for :func:`scipy.signal.get_window`.
    detrend : str or bool, optional
        Passed to :func:`scipy.signal.csd`.

    Returns
    -------
    FrequencyResponse on the positive DFT frequencies of a segment (DC dropped).

    Raises
    ------
    ValueError
        On mismatched lengths, too short a record, or a reference with fewer channels than
        ``u``.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal(4096)
    >>> y = 0.5 * u
    >>> est = frf_welch(u, y, 0.01)
    >>> bool(np.allclose(est.H, 0.5))
    True
    """
    from scipy.signal import get_window

    dt = check_step(dt)
    U, Y, R = _welch_signals(u, y, r)
    ns = U.shape[0]
    nperseg, noverlap = _welch_segments(nperseg, noverlap, ns)
    kw = dict(fs=1.0 / dt, window=window, nperseg=nperseg, noverlap=noverlap, detrend=detrend)
    f, spectra = _welch_spectra(U, Y, R, kw)
    step = nperseg - noverlap
    K = (ns - noverlap) // step
    n_eff = effective_averages(get_window(window, nperseg), step, K)
    H, coh, var = _welch_lines(spectra, R is not None, n_eff)
    opts = dict(
        dt=dt,
        nperseg=nperseg,
        noverlap=noverlap,
        window=window,
        segments=K,
        effective_averages=n_eff,
        reference=R is not None,
    )
    method = "welch" if R is None else "welch-reference"
    return FrequencyResponse(2 * np.pi * f, H, coh, var, 2.0 * n_eff - 2.0, method, opts, dt)


def _welch_signals(u: Any, y: Any, r: Any | None) -> tuple[Array, Array, Array | None]:
    """``u``, ``y`` and the reference ``r`` (or ``None``) as columns of one length, the
    reference with at least as many channels as ``u``."""
    U = as_columns(u, "u")
    Y = as_columns(y, "y")
    ns = U.shape[0]
    if Y.shape[0] != ns:
        raise ValueError(f"y has {Y.shape[0]} samples but u has {ns}")
    if r is None:
        return U, Y, None
    R = as_columns(r, "r")
    if R.shape[0] != ns:
        raise ValueError(f"r has {R.shape[0]} samples but u has {ns}")
    if R.shape[1] < U.shape[1]:
        raise ValueError(
            f"r must have at least as many channels as u ({U.shape[1]}), got {R.shape[1]}"
        )
    return U, Y, R


def _welch_segments(nperseg: int | None, noverlap: int | None, ns: int) -> tuple[int, int]:
    """Segment length and overlap: by default eight segments at 50 % overlap
    (``floor(2 Ns / 9)``, at least 8 samples; MATLAB's ``tfestimate``)."""
    nperseg = max(2 * ns // 9, 8) if nperseg is None else check_positive_int(nperseg, "nperseg")
    if nperseg > ns:
        raise ValueError(f"nperseg ({nperseg}) exceeds the record ({ns} samples)")
    noverlap = nperseg // 2 if noverlap is None else int(noverlap)
    if not 0 <= noverlap < nperseg:
        raise ValueError(f"noverlap must be in [0, nperseg), got {noverlap}")
    return nperseg, noverlap


def _cross_spectra(a: Array, b: Array, kw: dict[str, Any]) -> tuple[CArray, Array]:
    """``E[a b^*]`` of every pair of channels, ``(a_ch, b_ch, nf)``, and the frequencies."""
    from scipy.signal import csd

    out = np.empty((a.shape[1], b.shape[1], kw["nperseg"] // 2 + 1), dtype=complex)
    for i in range(a.shape[1]):
        for j in range(b.shape[1]):
            f, out[i, j] = csd(a[:, i], b[:, j], **kw)  # csd(x, y) = E[X^* Y]
    return np.conj(out), f


def _welch_spectra(
    U: Array, Y: Array, R: Array | None, kw: dict[str, Any]
) -> tuple[Array, dict[str, CArray]]:
    """The positive frequencies (DC dropped) and the spectra there: ``yz``, ``uz``,
    ``zz`` with ``z`` the reference (or ``u``), and ``yu``, ``uu``, ``yy``."""
    Z = U if R is None else R
    pairs = {"yz": (Y, Z), "uz": (U, Z), "zz": (Z, Z), "yu": (Y, U), "uu": (U, U), "yy": (Y, Y)}
    spectra = {}
    for name, (a, b) in pairs.items():
        spectra[name], f = _cross_spectra(a, b, kw)
    keep = f > 0
    return f[keep], {name: S[..., keep] for name, S in spectra.items()}


def _welch_lines(
    S: dict[str, CArray], reference: bool, n_eff: float
) -> tuple[CArray, Array, Array]:
    """Response, multiple coherence and variance at every line from the spectra ``S``
    (:func:`_welch_spectra`; the formulas of :func:`frf_welch`)."""
    Syy = np.real(np.einsum("iik->ik", S["yy"]))
    l, m, nf = S["yu"].shape
    H = np.empty((l, m, nf), dtype=complex)
    coh = np.empty((l, nf))
    var = np.empty((l, m, nf))
    for k in range(nf):
        Szz_inv = np.linalg.pinv(S["zz"][:, :, k])
        if not reference:
            X = S["uz"][:, :, k]
            H[:, :, k] = S["yz"][:, :, k] @ np.linalg.pinv(X)
        else:
            # H S_ur = S_yr (least squares over the reference channels)
            Sur = S["uz"][:, :, k]
            H[:, :, k] = S["yz"][:, :, k] @ np.linalg.pinv(Sur)
            X = Sur @ Szz_inv @ Sur.conj().T
        Sy_z = S["yz"][:, :, k]
        explained = np.real(np.einsum("iz,zw,iw->i", Sy_z, Szz_inv, Sy_z.conj()))
        coh[:, k] = np.clip(explained / np.maximum(Syy[:, k], np.finfo(float).tiny), 0.0, 1.0)
        Xinv_diag = np.real(np.diag(np.linalg.pinv(X)))
        resid = _residual_power(H[:, :, k], S["yy"][:, :, k], S["yu"][:, :, k], S["uu"][:, :, k])
        var[:, :, k] = resid[:, None] * Xinv_diag[None, :] / max(n_eff - 1.0, 1e-12)
    return H, coh, var


# -- periodic excitation ----------------------------------------------------------------------
def frf_periodic(
    u: Any,
    y: Any,
    dt: float,
    period: int,
    *,
    skip: int = 0,
    lines: Any | None = None,
) -> FrequencyResponse:
    """Frequency response at the excited lines of a periodic input, over whole periods.

    The record (after ``skip`` periods, e.g. the transient) is cut into its ``P`` whole
    periods; each period's DFT gives ``U_p(k)``, ``Y_p(k)``.  With the averages
    ``U(k)``, ``Y(k)`` over periods, ``H(k) = Y(k) / U(k)`` on the lines input ``j``
    excites.  A steady-state periodic response has no leakage, so without noise ``H(k)``
    is the system's response at ``w_k = 2 pi k / (N dt)`` to rounding (for a band-limited
    input such as a multisine, the continuous-time ``G(j w_k)``; for a zero-order-held
    input, the sampled system's).  The variance of ``H(k)`` comes from the scatter of
    the periods: ``var(Y(k)) = sum_p |Y_p - Y|^2 / (P (P - 1))`` (and likewise for the
    input and their covariance; errors-in-variables, Pintelon & Schoukens 2012, sec.
    2.4-2.5) gives ``var(H) = |H|^2 (var Y / |Y|^2 + var U / |U|^2 - 2 Re(cov(Y, U) /
    (Y U^*)))``, with ``2 P - 2`` degrees of freedom.  The coherence of each line is the
    usual estimate over the ``P`` periods.

    Multiple inputs must be orthogonal in frequency (each line excited by one input, as
    :func:`hdpbsid.design.inputs.multisine` designs them): ``H[:, j, k]`` is ``nan`` on the lines
    input ``j`` does not excite.

    Parameters
    ----------
    u : ndarray, shape (Ns,) or (Ns, m)
        Inputs.
    y : ndarray, shape (Ns,) or (Ns, l)
        Outputs.
    dt : float
        Sampling interval (s).
    period : int
        Samples per period ``N``.
    skip : int, optional
        Whole periods dropped at the start.
    lines : sequence of ndarray of int, optional
        Excited lines, one array per input (e.g. ``design.lines``); by default the
        lines whose input power exceeds :attr:`EstimateSettings.excited_line_floor` of
        that input's strongest line.

    Returns
    -------
    FrequencyResponse on the union of the excited lines (``variance``/``dof``/``coherence``
    ``None`` for a single period).

    Raises
    ------
    ValueError
        If fewer than one whole period remains, or a line is excited by two inputs.

    Examples
    --------
    >>> n = 100
    >>> u = np.tile(np.cos(2 * np.pi * 3 * np.arange(n) / n), 4)
    >>> y = np.roll(u, 1)  # a one-sample delay
    >>> est = frf_periodic(u, y, 1.0, n)
    >>> bool(np.allclose(est.H[0, 0, 0], np.exp(-2j * np.pi * 3 / n)))
    True
    """
    dt = check_step(dt)
    U = as_columns(u, "u")
    Y = as_columns(y, "y")
    if Y.shape[0] != U.shape[0]:
        raise ValueError(f"y has {Y.shape[0]} samples but u has {U.shape[0]}")
    n = check_positive_int(period, "period", 2)
    skip = check_positive_int(skip, "skip", 0)
    P = U.shape[0] // n - skip
    if P < 1:
        raise ValueError(
            f"the record holds {U.shape[0] // n} whole periods of {n} samples; after skipping "
            f"{skip} none remains"
        )
    seg = slice(skip * n, (skip + P) * n)
    Uf = np.fft.rfft(U[seg].reshape(P, n, -1), axis=1)  # (P, nf, m)
    Yf = np.fft.rfft(Y[seg].reshape(P, n, -1), axis=1)  # (P, nf, l)
    per_input = _excited_lines(Uf.mean(axis=0), lines, n)
    all_lines = np.unique(np.concatenate(per_input))
    H, coh, var = _periodic_lines(Uf, Yf, all_lines, _line_owners(per_input, n))
    w = 2 * np.pi * all_lines / (n * dt)
    opts = dict(dt=dt, period=n, periods=P, skip=skip, lines=tuple(per_input))
    dof = 2.0 * P - 2.0 if P > 1 else None
    return FrequencyResponse(w, H, coh, var, dof, "periodic", opts, dt)


def _line_owners(per_input: list[NDArray[np.intp]], n: int) -> NDArray[np.intp]:
    """The input exciting each DFT line of a period of ``n`` samples (-1: none)."""
    owner = np.full(n // 2 + 1, -1)
    for j, lj in enumerate(per_input):
        if np.any(owner[lj] >= 0):
            raise ValueError(
                "a line is excited by two inputs: frf_periodic needs inputs orthogonal in "
                "frequency (e.g. hdpbsid.design.inputs.multisine with channels=m)"
            )
        owner[lj] = j
    return owner


def _periodic_lines(
    Uf: CArray, Yf: CArray, all_lines: NDArray[np.intp], owner: NDArray[np.intp]
) -> tuple[CArray, Array | None, Array | None]:
    """Response, coherence and variance at the excited lines from the spectra of the
    ``P`` periods ``Uf`` (P, nf, m), ``Yf`` (P, nf, l); the last two ``None`` for one
    period (no scatter to estimate them from)."""
    P, _, m = Uf.shape
    l = Yf.shape[2]
    Um, Ym = Uf.mean(axis=0), Yf.mean(axis=0)
    nf = all_lines.size
    H = np.full((l, m, nf), np.nan + 0j)
    var = np.full((l, m, nf), np.nan) if P > 1 else None
    coh = np.full((l, nf), np.nan) if P > 1 else None
    for idx, k in enumerate(all_lines):
        j = owner[k]
        H[:, j, idx] = Ym[k] / Um[k, j]
        if P > 1:
            var[:, j, idx], coh[:, idx] = _line_scatter(  # type: ignore[index]
                Uf[:, k, j], Yf[:, k, :], Um[k, j], Ym[k], H[:, j, idx]
            )
    if var is not None:
        var = np.maximum(var, 0.0)
    return H, coh, var


def _line_scatter(
    Up: CArray, Yp: CArray, Uk: complex, Yk: CArray, Hk: CArray
) -> tuple[Array, Array]:
    """Variance of ``H(k)`` and coherence of one line from its ``P`` periods ``Up`` (P,),
    ``Yp`` (P, l) around their means ``Uk``, ``Yk`` (errors in variables; the formulas of
    :func:`frf_periodic`)."""
    P = Up.shape[0]
    du = Up - Uk
    dy = Yp - Yk[None, :]
    vu = np.sum(np.abs(du) ** 2) / (P * (P - 1))
    vy = np.sum(np.abs(dy) ** 2, axis=0) / (P * (P - 1))
    cyu = np.sum(dy * np.conj(du)[:, None], axis=0) / (P * (P - 1))
    var = (vy - 2.0 * np.real(np.conj(Hk) * cyu) + np.abs(Hk) ** 2 * vu) / np.abs(Uk) ** 2
    suu = np.sum(np.abs(Up) ** 2)
    syy = np.sum(np.abs(Yp) ** 2, axis=0)
    syu = np.sum(Yp * np.conj(Up)[:, None], axis=0)
    return var, np.abs(syu) ** 2 / np.maximum(suu * syy, np.finfo(float).tiny)


def _residual_power(H: CArray, Syy: CArray, Syu: CArray, Suu: CArray) -> Array:
    """Power of each output's residual ``e = y - H u`` at one frequency:
    ``diag(S_yy - H S_uy - S_yu H^H + H S_uu H^H)`` (real, clipped at 0)."""
    See = Syy - H @ Syu.conj().T - Syu @ H.conj().T + H @ Suu @ H.conj().T
    return np.maximum(np.real(np.diag(See)), 0.0)


def _excited_lines(Um: CArray, lines: Any | None, n: int) -> list[NDArray[np.intp]]:
    m = Um.shape[1]
    if lines is not None:
        if len(lines) != m:
            raise ValueError(f"lines must hold one array per input ({m}), got {len(lines)}")
        out = []
        for j, lj in enumerate(lines):
            arr = np.asarray(lj, dtype=np.intp).reshape(-1)
            if arr.size and (arr.min() < 1 or arr.max() > n // 2):
                raise ValueError(f"lines[{j}] must be DFT lines between 1 and {n // 2}")
            out.append(arr)
        return out
    p = np.abs(Um) ** 2
    p[0] = 0.0  # DC is the operating point, not an excited line
    out = []
    for j in range(m):
        peak = p[:, j].max()
        if peak <= 0:
            raise ValueError(f"input {j} excites no line over the periods")
        out.append(np.nonzero(p[:, j] > ESTIMATE.excited_line_floor * peak)[0])
    return out


# -- helpers -------------------------------------------------------------------------------
def _check_alpha(alpha: float) -> None:
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")
