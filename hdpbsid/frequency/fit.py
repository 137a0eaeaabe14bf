"""Frequency responses from data, their coherence and confidence, and models from them.

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

:func:`identify_frequency` fits a continuous-time :class:`~hdpbsid.models.model.StateSpaceModel`
to frequency-response data (see its docstring); :func:`estimate_delay` estimates an
input-output dead time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import as_columns, as_float_array, check_positive_int, check_step
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.uncertainty import ParameterCovariance, covariance_factor, response_band

__all__ = [
    "FrequencyResponse",
    "frf_welch",
    "frf_periodic",
    "effective_averages",
    "identify_frequency",
    "plot_frf",
]

Array = NDArray[np.float64]
CArray = NDArray[np.complex128]

#: A line of a periodic record counts as excited by an input when its power is above this
#: fraction of that input's strongest line: -60 dB separates a designed line from the
#: rounding (~1e-30) of a noise-free design and from the leakage floor of a windowed
#: multisine; measured inputs with noise on every line should pass ``lines`` explicitly.
EXCITED_LINE_FLOOR = 1e-6


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
        Settings used.
    """

    w: Array
    H: CArray
    coherence: Array | None = None
    variance: Array | None = None
    dof: float | None = None
    method: str = "given"
    options: dict[str, Any] = field(default_factory=dict)

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
    from scipy.signal import csd, get_window

    dt = check_step(dt)
    U = as_columns(u, "u")
    Y = as_columns(y, "y")
    ns = U.shape[0]
    if Y.shape[0] != ns:
        raise ValueError(f"y has {Y.shape[0]} samples but u has {ns}")
    R = None
    if r is not None:
        R = as_columns(r, "r")
        if R.shape[0] != ns:
            raise ValueError(f"r has {R.shape[0]} samples but u has {ns}")
        if R.shape[1] < U.shape[1]:
            raise ValueError(
                f"r must have at least as many channels as u ({U.shape[1]}), got {R.shape[1]}"
            )
    nperseg = max(2 * ns // 9, 8) if nperseg is None else check_positive_int(nperseg, "nperseg")
    if nperseg > ns:
        raise ValueError(f"nperseg ({nperseg}) exceeds the record ({ns} samples)")
    noverlap = nperseg // 2 if noverlap is None else int(noverlap)
    if not 0 <= noverlap < nperseg:
        raise ValueError(f"noverlap must be in [0, nperseg), got {noverlap}")
    kw = dict(fs=1.0 / dt, window=window, nperseg=nperseg, noverlap=noverlap, detrend=detrend)

    def spec(a: Array, b: Array) -> tuple[CArray, Array]:  # (a_ch, b_ch, nf): E[a b^*]
        out = np.empty((a.shape[1], b.shape[1], nperseg // 2 + 1), dtype=complex)
        for i in range(a.shape[1]):
            for j in range(b.shape[1]):
                f, out[i, j] = csd(a[:, i], b[:, j], **kw)  # csd(x, y) = E[X^* Y]
        return np.conj(out), f

    Z = U if R is None else R
    Syz, f = spec(Y, Z)
    Suz, _ = spec(U, Z)
    Szz, _ = spec(Z, Z)
    Syu, _ = spec(Y, U)
    Suu, _ = spec(U, U)
    Syy_full, _ = spec(Y, Y)
    keep = f > 0
    f = f[keep]
    Syz, Suz, Szz, Syu, Suu, Syy_full = (a[..., keep] for a in (Syz, Suz, Szz, Syu, Suu, Syy_full))
    Syy = np.real(np.einsum("iik->ik", Syy_full))
    nf = f.size
    l, m = Y.shape[1], U.shape[1]
    H = np.empty((l, m, nf), dtype=complex)
    coh = np.empty((l, nf))
    var = np.empty((l, m, nf))
    step = nperseg - noverlap
    K = (ns - noverlap) // step
    n_eff = effective_averages(get_window(window, nperseg), step, K)
    for k in range(nf):
        Szz_inv = np.linalg.pinv(Szz[:, :, k])
        if R is None:
            X = Suz[:, :, k]
            H[:, :, k] = Syz[:, :, k] @ np.linalg.pinv(X)
        else:
            # H S_ur = S_yr (least squares over the reference channels)
            Sur = Suz[:, :, k]
            H[:, :, k] = Syz[:, :, k] @ np.linalg.pinv(Sur)
            X = Sur @ Szz_inv @ Sur.conj().T
        Sy_z = Syz[:, :, k]
        explained = np.real(np.einsum("iz,zw,iw->i", Sy_z, Szz_inv, Sy_z.conj()))
        coh[:, k] = np.clip(explained / np.maximum(Syy[:, k], np.finfo(float).tiny), 0.0, 1.0)
        Xinv_diag = np.real(np.diag(np.linalg.pinv(X)))
        resid = _residual_power(H[:, :, k], Syy_full[:, :, k], Syu[:, :, k], Suu[:, :, k])
        var[:, :, k] = resid[:, None] * Xinv_diag[None, :] / max(n_eff - 1.0, 1e-12)
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
    return FrequencyResponse(2 * np.pi * f, H, coh, var, 2.0 * n_eff - 2.0, method, opts)


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
        lines whose input power exceeds :data:`EXCITED_LINE_FLOOR` of that input's strongest
        line.

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
    Um, Ym = Uf.mean(axis=0), Yf.mean(axis=0)
    m, l = U.shape[1], Y.shape[1]
    per_input = _excited_lines(Um, lines, n)
    all_lines = np.unique(np.concatenate(per_input))
    owner = np.full(n // 2 + 1, -1)
    for j, lj in enumerate(per_input):
        if np.any(owner[lj] >= 0):
            raise ValueError(
                "a line is excited by two inputs: frf_periodic needs inputs orthogonal in "
                "frequency (e.g. hdpbsid.design.inputs.multisine with channels=m)"
            )
        owner[lj] = j
    nf = all_lines.size
    H = np.full((l, m, nf), np.nan + 0j)
    var = np.full((l, m, nf), np.nan) if P > 1 else None
    coh = np.full((l, nf), np.nan) if P > 1 else None
    for idx, k in enumerate(all_lines):
        j = owner[k]
        Uk = Um[k, j]
        H[:, j, idx] = Ym[k] / Uk
        if P > 1:
            du = Uf[:, k, j] - Uk
            dy = Yf[:, k, :] - Ym[k][None, :]
            vu = np.sum(np.abs(du) ** 2) / (P * (P - 1))
            vy = np.sum(np.abs(dy) ** 2, axis=0) / (P * (P - 1))
            cyu = np.sum(dy * np.conj(du)[:, None], axis=0) / (P * (P - 1))
            Hk = H[:, j, idx]
            var[:, j, idx] = (  # type: ignore[index]
                vy - 2.0 * np.real(np.conj(Hk) * cyu) + np.abs(Hk) ** 2 * vu
            ) / np.abs(Uk) ** 2
            suu = np.sum(np.abs(Uf[:, k, j]) ** 2)
            syy = np.sum(np.abs(Yf[:, k, :]) ** 2, axis=0)
            syu = np.sum(Yf[:, k, :] * np.conj(Uf[:, k, j])[:, None], axis=0)
            coh[:, idx] = np.abs(syu) ** 2 / np.maximum(suu * syy, np.finfo(float).tiny)  # type: ignore[index]
    if var is not None:
        var = np.maximum(var, 0.0)
    w = 2 * np.pi * all_lines / (n * dt)
    opts = dict(dt=dt, period=n, periods=P, skip=skip, lines=tuple(per_input))
    dof = 2.0 * P - 2.0 if P > 1 else None
    return FrequencyResponse(w, H, coh, var, dof, "periodic", opts)


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
        out.append(np.nonzero(p[:, j] > EXCITED_LINE_FLOOR * peak)[0])
    return out


# -- helpers -------------------------------------------------------------------------------
def _check_alpha(alpha: float) -> None:
    if not 0.0 < alpha < 1.0:
        raise ValueError(f"alpha must be in (0, 1), got {alpha}")


# -- models from frequency data ------------------------------------------------------------
#: Interleaved folds of the held-out-lines order selection: line ``k`` is held out in fold
#: ``k mod FOLDS``, so every fold spans the whole band and every line is judged once.
FOLDS = 3

#: Residual evaluations allowed to one refinement.  From the subspace start a model of the
#: data's order converges in tens; the cap bounds the cost of the over-parametrised orders
#: the selection also fits (which then stop short of their optimum, i.e. are judged no
#: better than they are).
MAX_NFEV = 200


def identify_frequency(
    w: Any,
    H: Any | None = None,
    order: int | None = None,
    weight: Any = "auto",
    *,
    max_order: int | None = None,
    feedthrough: bool = False,
    refine: bool = True,
) -> StateSpaceModel:
    """Continuous-time state-space model from frequency-response data.

    1. **Subspace start** (McKelvey, Akcay & Ljung, "Subspace-based multivariable system
       identification from frequency response data", IEEE Trans. Autom. Control 41(7),
       1996, the algorithm for arbitrary frequencies): the frequencies are mapped to the
       unit circle by the bilinear map ``z = (w_c + s) / (w_c - s)`` with ``w_c`` the
       geometric mean of the band (so the band's logarithmic centre lands at ``z = j``
       and a band of decades is spread over the circle); the block-Hankel-like matrices
       ``[z_k^i H_k]`` and ``[z_k^i I]`` (``i < q``, ``q = 2 n + 2``), in real form and
       weighted per frequency, give the extended observability matrix as the dominant
       left singular vectors of the first orthogonalised against the second; ``A``,
       ``C`` by shift invariance, mapped back by ``A_c = w_c (A_d - I)(A_d + I)^{-1}``
       (exact: ``(zI - A_d) = (I + A_d)(sI - A_c) / (w_c - s)``), then ``B`` (and ``D``)
       by weighted linear least squares.
    2. **Refinement**: weighted nonlinear least squares
       (:func:`scipy.optimize.least_squares`) of ``sum |W (G(j w) - H)|^2`` over a real
       modal parametrisation (``A`` block-diagonal: each real eigenvalue, each pair's
       real and imaginary parts; ``B``, ``C`` and ``D`` free).  With ``W = 1 / sigma``
       this is the maximum-likelihood estimate for circular complex Gaussian errors of
       standard deviation ``sigma`` (Pintelon & Schoukens 2012, sec. 9.2-9.3).
    3. **Order** (``order=None``): each order from 1 to ``max_order`` is fitted on two
       thirds of the lines and scored on the held-out third, for three interleaved folds,
       so every line is scored once by a model that did not see it; the order is the
       smallest whose total held-out weighted error is within one standard error of the
       best (:func:`hdpbsid.models.criteria.choose_smallest_adequate`, the rule the time-domain
       selection uses).  Held-out lines judge what the data support without a noise level
       or a penalty to choose (an AIC needs the noise variance; singular-value gaps vanish
       in noise), and the interleaving keeps every fold over the whole band.

    Weights ``W`` (``weight``): ``"auto"`` uses the estimate's variance when ``w`` is a
    :class:`FrequencyResponse` that carries one (``1 / sqrt(variance)``), else its
    coherence (``"coherence"``), else ``"relative"``; ``"coherence"``: ``sqrt(gamma^2 /
    (1 - gamma^2)) / |H|``, proportional to ``1 / sigma`` of an H1 estimate (its variance
    is ``(1 - gamma^2) |H|^2 / (gamma^2 n)``, Bendat & Piersol eq. 9.90);
    ``"relative"``: ``1 / |H|``, each decade of a Bode plot alike (the error is then
    close to the log-magnitude and phase error); ``None``: uniform; or an array
    broadcastable to ``H``.

    Parameters
    ----------
    w : ndarray, shape (nf,), or FrequencyResponse
        Angular frequencies (rad/s), or a :class:`FrequencyResponse` (then ``H`` is taken from
        it).
    H : ndarray of complex, shape (nf,) or (l, m, nf), optional
        Frequency response (SISO or MIMO); not with a ``FrequencyResponse``.
    order : int or None, optional
        Model order, or ``None`` to choose it.
    weight : {"auto", "coherence", "relative"}, array_like or None, optional
        The weights ``W`` described above.
    max_order : int or None, optional
        Largest order tried (default :data:`hdpbsid.data.checks.DEFAULT_MAX_ORDER`, at most what
        the lines support).
    feedthrough : bool, optional
        Fit ``D`` (default: strictly proper, ``D = 0``).
    refine : bool, optional
        Run the nonlinear refinement (else the subspace start is returned).

    Returns
    -------
    StateSpaceModel
        ``K = 0``; ``options`` holds ``method="frequency"``, the order, ``w_c``, the
        weighted cost, the refinement's parameter covariance ``covariance`` (of the modal
        parameters, ``s^2 (J^T J)^+``) and, when the order was chosen, ``selection`` (one
        row per order: held-out error and its statistic).

    Raises
    ------
    ValueError
        On non-positive or repeated frequencies, non-finite ``H``, mismatched shapes or
        too few lines for the order.

    Examples
    --------
    >>> A = np.array([[0.0, 1.0], [-4.0, -0.8]]); B = np.array([[0.0], [1.0]])
    >>> C = np.array([[1.0, 0.0]])
    >>> w = np.logspace(-1, 1.5, 60)
    >>> H = (C @ np.linalg.solve(1j * w[:, None, None] * np.eye(2) - A, B))[:, 0, 0]
    >>> model = identify_frequency(w, H, order=2)
    >>> bool(np.allclose(np.sort_complex(model.eigenvalues), np.sort_complex(np.linalg.eigvals(A))))
    True
    """
    from hdpbsid.data.checks import DEFAULT_MAX_ORDER

    w_arr, Hc, W, source = _frequency_data(w, H, weight)
    l, m, nf = Hc.shape
    n_real = 2 * nf * m * l  # real equations
    if order is not None:
        order = check_positive_int(order, "order")
        _check_enough_lines(order, l, m, nf, feedthrough, "order")
    mo = DEFAULT_MAX_ORDER if max_order is None else check_positive_int(max_order, "max_order")
    wc = float(np.sqrt(w_arr.min() * w_arr.max()))
    selection = None
    if order is None:
        order, selection = _select_order(w_arr, Hc, W, wc, mo, feedthrough, refine)
    model_parts, info = _fit_order(w_arr, Hc, W, order, wc, feedthrough, refine)
    A, B, C, D = model_parts
    options: dict[str, Any] = dict(
        method="frequency",
        order=order,
        w_c=wc,
        weight=weight if isinstance(weight, str) or weight is None else "given",
        weight_source=source,
        feedthrough=feedthrough,
        refine=refine,
        lines=nf,
        equations=n_real,
        **info,
    )
    if selection is not None:
        options["selection"] = selection
    cov = None
    if "covariance" in info:
        cov = ParameterCovariance(_full_factor(info, l, m, feedthrough), "identify_frequency")
    return StateSpaceModel(
        A, B, C, D, np.zeros((A.shape[0], l)), options=options, parameter_covariance=cov
    )


def _full_factor(info: dict[str, Any], l: int, m: int, feedthrough: bool) -> Array:
    """The covariance factor of ``[vec A, vec B, vec C, vec D]``
    (:class:`hdpbsid.models.uncertainty.ParameterCovariance`) from the modal parameters'
    covariance of :func:`_refine`: ``A`` is linear in the modal parameters (a real
    eigenvalue sets its diagonal entry; a pair ``(sigma, omega)`` its block
    ``[[sigma, omega], [-omega, sigma]]``), ``B``, ``C``, ``D`` are parameters themselves
    (``D`` fixed at zero without feedthrough)."""
    lay = info["parameter_layout"]
    nr, npair, n = lay["real"], lay["pairs"], lay["states"]
    P = np.asarray(info["covariance"]).shape[0]
    M = np.zeros((n * n + n * m + l * n + l * m, P))
    for i in range(nr):
        M[i * n + i, i] = 1.0
    for k in range(npair):
        i, c = nr + 2 * k, nr + 2 * k
        M[i * n + i, c] = M[(i + 1) * n + i + 1, c] = 1.0  # sigma
        M[i * n + i + 1, c + 1], M[(i + 1) * n + i, c + 1] = 1.0, -1.0  # omega
    rows = n * n
    cols = nr + 2 * npair
    size = n * m + l * n
    M[rows : rows + size, cols : cols + size] = np.eye(size)
    if feedthrough:
        M[rows + size :, cols + size :] = np.eye(l * m)
    return M @ covariance_factor(info["covariance"])


def _frequency_data(w: Any, H: Any, weight: Any) -> tuple[Array, CArray, Array, str]:
    frf = w if isinstance(w, FrequencyResponse) else None
    if frf is not None:
        if H is not None:
            raise ValueError("H must not be given with a FrequencyResponse (it holds H)")
        w, H = frf.w, frf.H
    w_arr = as_float_array(w, "w").reshape(-1)
    if w_arr.size < 2 or np.any(w_arr <= 0) or np.any(np.diff(np.sort(w_arr)) <= 0):
        raise ValueError("w must hold at least 2 distinct positive frequencies (rad/s)")
    if H is None:
        raise ValueError("H must be given (or pass a FrequencyResponse as w)")
    Hc = np.asarray(H, dtype=complex)
    if Hc.ndim == 1:
        Hc = Hc[None, None, :]
    if Hc.ndim != 3 or Hc.shape[2] != w_arr.size:
        raise ValueError(
            f"H must have shape (nf,) or (l, m, nf) with nf = {w_arr.size} lines, got {Hc.shape}"
        )
    if not np.all(np.isfinite(Hc)):
        raise ValueError(
            "H must be finite: identify_frequency needs every entry at every line (for an "
            "orthogonal multi-input periodic design, identify each input's lines apart)"
        )
    W, source = _weights(weight, Hc, frf)
    return w_arr, Hc, W, source


def _weights(weight: Any, H: CArray, frf: FrequencyResponse | None) -> tuple[Array, str]:
    absH = np.maximum(np.abs(H), np.finfo(float).tiny)
    if isinstance(weight, str):
        if weight == "auto":
            if frf is not None and frf.variance is not None:
                weight = "variance"
            elif frf is not None and frf.coherence is not None:
                weight = "coherence"
            else:
                weight = "relative"
        if weight == "variance":
            if frf is None or frf.variance is None:
                raise ValueError("weight='variance' needs a FrequencyResponse with a variance")
            var = np.maximum(frf.variance, np.finfo(float).tiny)
            W = 1.0 / np.sqrt(var)
        elif weight == "coherence":
            if frf is None or frf.coherence is None:
                raise ValueError("weight='coherence' needs a FrequencyResponse with a coherence")
            g2 = np.clip(frf.coherence, 0.0, 1.0 - 1e-12)[:, None, :]
            W = np.sqrt(g2 / (1.0 - g2)) / absH
        elif weight == "relative":
            W = 1.0 / absH
        else:
            raise ValueError(
                "weight must be 'auto', 'variance', 'coherence', 'relative', None or an "
                f"array, got {weight!r}"
            )
        return np.broadcast_to(W, H.shape).astype(float), weight
    if weight is None:
        return np.ones(H.shape), "uniform"
    W = as_float_array(weight, "weight")
    try:
        W = np.broadcast_to(W, H.shape).astype(float)
    except ValueError as exc:
        raise ValueError(f"weight must broadcast to H's shape {H.shape}, got {W.shape}") from exc
    if np.any(W < 0):
        raise ValueError("weight must be non-negative")
    return W, "given"


def _transfer(A: Array, B: Array, C: Array, D: Array, s: CArray) -> CArray:
    """``C (sI - A)^{-1} B + D`` at every ``s``: (l, m, ns), as
    :meth:`hdpbsid.models.model.StateSpaceModel.frequency_response` lays it out."""
    n = A.shape[0]
    X = np.linalg.solve(
        s[:, None, None] * np.eye(n)[None] - A[None], np.broadcast_to(B, (s.size,) + B.shape)
    )
    return np.moveaxis(np.einsum("ij,kjl->kil", C, X) + D[None], 0, -1)


def _n_params(n: int, l: int, m: int, feedthrough: bool) -> int:
    return n + n * (m + l) + (l * m if feedthrough else 0)


def _check_enough_lines(n: int, l: int, m: int, nf: int, feedthrough: bool, name: str) -> None:
    need = _n_params(n, l, m, feedthrough)
    have = 2 * nf * l * m
    if have <= need or nf < n + 1:
        raise ValueError(
            f"{name} {n} needs more than {need} real equations and {n + 1} lines; the data "
            f"give {have} equations on {nf} lines"
        )


def _subspace_start(w: Array, H: CArray, W: Array, n: int, wc: float) -> tuple[Array, Array]:
    """``(A_c, C_c)`` of order ``n`` by the frequency-domain subspace method on the
    bilinear-mapped unit circle (:func:`identify_frequency`, step 1)."""
    l, m, nf = H.shape
    q = max(n + 1, min(2 * n + 2, nf // 2))
    z = (wc + 1j * w) / (wc - 1j * w)
    scale = np.mean(W, axis=(0, 1))  # one weight per frequency keeps the column relation
    zp = z[None, :] ** np.arange(q)[:, None]  # (q, nf)
    Gq = np.einsum("ik,abk,k->iakb", zp, H, scale).reshape(q * l, nf * m)
    Wq = np.einsum("ik,ab,k->iakb", zp, np.eye(m), scale).reshape(q * m, nf * m)
    Gr = np.hstack([Gq.real, Gq.imag])
    Wr = np.hstack([Wq.real, Wq.imag])
    R = np.linalg.qr(np.vstack([Wr, Gr]).T, mode="r").T
    R22 = R[q * m :, q * m :]
    U, _, _ = np.linalg.svd(R22, full_matrices=False)
    O = U[:, :n]
    Cd = O[:l]
    Ad = np.linalg.lstsq(O[:-l], O[l:], rcond=None)[0]
    Ip = Ad + np.eye(n)
    Ac = wc * np.linalg.solve(Ip.T, (Ad - np.eye(n)).T).T
    Cc = np.linalg.solve(Ip.T, Cd.T).T
    return Ac, Cc


def _fit_bd(
    w: Array, H: CArray, W: Array, A: Array, C: Array, feedthrough: bool
) -> tuple[Array, Array]:
    """``B``, ``D`` minimising ``sum |W (C (jwI - A)^{-1} B + D - H)|^2`` (linear)."""
    l, m, nf = H.shape
    n = A.shape[0]
    Phi = np.einsum(
        "ij,kjl->kil", C, np.linalg.inv(1j * w[:, None, None] * np.eye(n)[None] - A[None])
    )  # (nf, l, n)
    B = np.zeros((n, m))
    D = np.zeros((l, m))
    for j in range(m):
        Wj = W[:, j, :].T  # (nf, l)
        M = Phi * Wj[:, :, None]
        if feedthrough:
            M = np.concatenate([M, np.eye(l)[None] * Wj[:, :, None]], axis=2)
        M = M.reshape(nf * l, -1)
        rhs = (H[:, j, :].T * Wj).reshape(-1)
        x = np.linalg.lstsq(
            np.vstack([M.real, M.imag]), np.concatenate([rhs.real, rhs.imag]), rcond=None
        )[0]
        B[:, j] = x[:n]
        if feedthrough:
            D[:, j] = x[n:]
    return B, D


def _to_modal(A: Array, B: Array, C: Array) -> tuple[Array, Array, Array, Array, Array]:
    """Real modal form: ``(real eigenvalues, pairs (sigma, omega) (p, 2), A_m, B_m, C_m)``."""
    from scipy.linalg import cdf2rdf

    lam, V = np.linalg.eig(A)
    order = np.lexsort((np.abs(lam.imag), lam.real))
    lam, V = lam[order], V[:, order]
    # make conjugate pairs adjacent, positive imaginary part first (cdf2rdf's convention)
    real = [i for i in range(lam.size) if abs(lam[i].imag) <= 1e-12 * max(abs(lam[i]), 1.0)]
    upper = [i for i in range(lam.size) if lam[i].imag > 1e-12 * max(abs(lam[i]), 1.0)]
    idx: list[int] = list(real)
    for i in upper:
        j = int(np.argmin(np.abs(lam - np.conj(lam[i]))))
        idx += [i, j]
    lam, V = lam[idx], V[:, idx]
    lam[: len(real)] = lam[: len(real)].real
    V[:, : len(real)] = V[:, : len(real)].real
    for k in range(len(real), lam.size, 2):  # exact conjugates for cdf2rdf
        lam[k + 1] = np.conj(lam[k])
        V[:, k + 1] = np.conj(V[:, k])
    wr, vr = cdf2rdf(lam, V)
    T = np.real(vr)
    Am = np.real(wr)
    Bm = np.linalg.solve(T, B)
    Cm = C @ T
    reals = lam[: len(real)].real
    pairs = np.array([[lam[k].real, lam[k].imag] for k in range(len(real), lam.size, 2)])
    return reals, pairs.reshape(-1, 2), Am, Bm, Cm


def _modal_a(reals: Array, pairs: Array) -> Array:
    n = reals.size + 2 * pairs.shape[0]
    A = np.zeros((n, n))
    A[np.arange(reals.size), np.arange(reals.size)] = reals
    for k, (s, om) in enumerate(pairs):
        i = reals.size + 2 * k
        A[i : i + 2, i : i + 2] = [[s, om], [-om, s]]
    return A


def _modal_jacobian(
    A: Array, B: Array, C: Array, s: CArray, nr: int, npair: int, feedthrough: bool
) -> CArray:
    """Derivatives of ``G(s) = C (sI - A)^{-1} B + D`` with respect to the modal parameters,
    in the order of :func:`_refine`'s vector: ``(P, l, m, ns)``.

    With ``Phi = C (sI - A)^{-1}`` and ``Psi = (sI - A)^{-1} B``: ``dG / dA_pq = Phi[:, p]
    Psi[q, :]`` (from ``d(M^{-1}) = -M^{-1} dM M^{-1}``), ``dG_ij / dB_pj = Phi_ip``,
    ``dG_ij / dC_ip = Psi_pj``, ``dG_ij / dD_ij = 1``.  A real eigenvalue moves ``A_pp``; a
    pair ``(sigma, omega)`` moves its block by ``I`` and by ``[[0, 1], [-1, 0]]``.
    """
    n, m = B.shape
    l = C.shape[0]
    Rinv = np.linalg.inv(s[:, None, None] * np.eye(n)[None] - A[None])  # (ns, n, n)
    Phi = np.einsum("ip,kpq->kiq", C, Rinv)  # (ns, l, n)
    Psi = np.einsum("kpq,qj->kpj", Rinv, B)  # (ns, n, m)

    def outer(p: int, q: int) -> CArray:  # dG / dA_pq: (l, m, ns)
        return np.einsum("ki,kj->ijk", Phi[:, :, p], Psi[:, q, :])

    rows: list[CArray] = [outer(p, p) for p in range(nr)]
    for k in range(npair):
        i = nr + 2 * k
        rows.append(outer(i, i) + outer(i + 1, i + 1))
        rows.append(outer(i, i + 1) - outer(i + 1, i))
    ns = s.size
    dB = np.zeros((n, m, l, m, ns), dtype=complex)
    for j in range(m):
        dB[:, j, :, j, :] = np.moveaxis(Phi, 0, -1).transpose(1, 0, 2)
    dC = np.zeros((l, n, l, m, ns), dtype=complex)
    for i in range(l):
        dC[i, :, i, :, :] = np.moveaxis(Psi, 0, -1)
    parts = [np.stack(rows) if rows else np.zeros((0, l, m, ns), complex)]
    parts += [dB.reshape(n * m, l, m, ns), dC.reshape(l * n, l, m, ns)]
    if feedthrough:
        dD = np.zeros((l, m, l, m, ns), dtype=complex)
        for i in range(l):
            for j in range(m):
                dD[i, j, i, j, :] = 1.0
        parts.append(dD.reshape(l * m, l, m, ns))
    return np.concatenate(parts, axis=0)


def _refine(
    w: Array, H: CArray, W: Array, A: Array, B: Array, C: Array, D: Array, feedthrough: bool
) -> tuple[tuple[Array, Array, Array, Array], dict[str, Any]]:
    from scipy.optimize import least_squares

    l, m, _ = H.shape
    reals, pairs, _, Bm, Cm = _to_modal(A, B, C)
    nr, npair = reals.size, pairs.shape[0]
    n = nr + 2 * npair
    sizes = [nr, 2 * npair, n * m, l * n] + ([l * m] if feedthrough else [])
    theta0 = np.concatenate(
        [reals, pairs.reshape(-1), Bm.reshape(-1), Cm.reshape(-1)]
        + ([D.reshape(-1)] if feedthrough else [])
    )
    cuts = np.cumsum(sizes)[:-1]
    s = 1j * w

    def unpack(theta: Array) -> tuple[Array, Array, Array, Array]:
        parts = np.split(theta, cuts)
        Am = _modal_a(parts[0], parts[1].reshape(-1, 2))
        Dm = parts[4].reshape(l, m) if feedthrough else np.zeros((l, m))
        return Am, parts[2].reshape(n, m), parts[3].reshape(l, n), Dm

    def residual(theta: Array) -> Array:
        G = _transfer(*unpack(theta), s)
        e = (W * (G - H)).reshape(-1)
        return np.concatenate([e.real, e.imag])

    def jacobian(theta: Array) -> Array:
        Am, Bm, Cm, _ = unpack(theta)
        dG = _modal_jacobian(Am, Bm, Cm, s, nr, npair, feedthrough)  # (P, l, m, nf)
        J = (W[None] * dG).reshape(dG.shape[0], -1).T
        return np.vstack([J.real, J.imag])

    res = least_squares(
        residual, theta0, jac=jacobian, method="lm", x_scale="jac", max_nfev=MAX_NFEV
    )
    theta = res.x
    r0 = residual(theta0)
    dof = max(res.fun.size - theta.size, 1)
    s2 = float(res.fun @ res.fun) / dof
    J = res.jac
    cov = s2 * np.linalg.pinv(J.T @ J)
    cost0, cost = float(r0 @ r0), float(res.fun @ res.fun)
    if not np.isfinite(cost) or cost > cost0:  # keep the start if the refinement lost
        theta, cost = theta0, cost0
    info = dict(
        cost_start=cost0,
        cost=cost,
        nfev=int(res.nfev),
        covariance=cov,
        parameters=theta,
        parameter_layout=dict(real=nr, pairs=npair, states=n),
    )
    return unpack(theta), info


def _fit_order(
    w: Array, H: CArray, W: Array, n: int, wc: float, feedthrough: bool, refine: bool
) -> tuple[tuple[Array, Array, Array, Array], dict[str, Any]]:
    A, C = _subspace_start(w, H, W, n, wc)
    B, D = _fit_bd(w, H, W, A, C, feedthrough)
    if not refine:
        G = _transfer(A, B, C, D, 1j * w)
        return (A, B, C, D), dict(cost=float(np.sum(np.abs(W * (G - H)) ** 2)))
    return _refine(w, H, W, A, B, C, D, feedthrough)


def _select_order(
    w: Array, H: CArray, W: Array, wc: float, max_order: int, feedthrough: bool, refine: bool
) -> tuple[int, list[dict[str, Any]]]:
    from hdpbsid.models.criteria import WindowedError, choose_smallest_adequate

    l, m, nf = H.shape
    fold = np.arange(nf) % FOLDS
    errors: list[WindowedError] = []
    orders: list[int] = []
    for n in range(1, max_order + 1):
        try:
            _check_enough_lines(n, l, m, int(np.sum(fold != 0)), feedthrough, "order")
        except ValueError:
            break
        per_line = np.empty(nf)
        finite = True
        for f in range(FOLDS):
            est, held = fold != f, fold == f
            try:
                (A, B, C, D), _ = _fit_order(
                    w[est], H[..., est], W[..., est], n, wc, feedthrough, refine
                )
                G = _transfer(A, B, C, D, 1j * w[held])
                per_line[held] = np.sum(np.abs(W[..., held] * (G - H[..., held])) ** 2, axis=(0, 1))
            except (np.linalg.LinAlgError, ValueError):
                finite = False
        finite = finite and bool(np.all(np.isfinite(per_line)))
        total = float(np.sum(per_line)) if finite else np.inf
        errors.append(WindowedError(per_line, total, np.nan, finite))
        orders.append(n)
    if not errors:
        raise ValueError(f"too few lines ({nf}) to choose an order")
    chosen, stats = choose_smallest_adequate(errors)
    rows = [
        dict(order=o, held_out_error=e.total, z=z, chosen=(i == chosen))
        for i, (o, e, z) in enumerate(zip(orders, errors, stats, strict=True))
    ]
    return orders[chosen], rows


# -- figure -----------------------------------------------------------------------------------
def plot_frf(
    frf: FrequencyResponse,
    model: StateSpaceModel | None = None,
    alpha: float = 0.05,
    output: int = 0,
    input: int = 0,
) -> Any:
    """Bode magnitude and phase of an estimate with its ``1 - alpha`` confidence band
    (from :meth:`FrequencyResponse.confidence_radius`: ``|H| +- r`` and ``+- asin(r /
    |H|)`` in phase), a model's response over it with the model's own pointwise ``1 -
    alpha`` band when it carries a parameter covariance
    (:func:`hdpbsid.models.uncertainty.response_band`, the delta method), and the coherence
    with its bounds: the comparison of a parametric model with the non-parametric
    estimate a reviewer asks for.

    Parameters
    ----------
    frf : FrequencyResponse
        The estimate.
    model : StateSpaceModel or None, optional
        Optional model drawn over it.
    alpha : float, optional
        Level of the bands.
    output, input : int
        The channel drawn.

    Returns
    -------
    matplotlib.figure.Figure
        Three axes: magnitude, phase, coherence.

    Raises
    ------
    TypeError
        If ``frf`` is not a :class:`FrequencyResponse`.
    """
    import matplotlib.pyplot as plt

    if not isinstance(frf, FrequencyResponse):
        raise TypeError(f"frf must be a FrequencyResponse, got {type(frf).__name__}")
    fig, axes = plt.subplots(3, 1, figsize=(7, 7), sharex=True, layout="constrained")
    w, H = frf.w, frf.H[output, input]
    ok = np.isfinite(H)
    w, H = w[ok], H[ok]
    mag = np.abs(H)
    phase = np.degrees(np.unwrap(np.angle(H)))
    axes[0].semilogx(w, 20 * np.log10(mag), ".", ms=3, label=f"{frf.method} estimate")
    axes[1].semilogx(w, phase, ".", ms=3)
    if frf.variance is not None and frf.dof is not None:
        r = frf.confidence_radius(alpha)[output, input][ok]
        # a region reaching zero is drawn down to -40 dB below the estimate
        lo = 20 * np.log10(np.maximum(mag - r, 0.01 * mag))
        axes[0].fill_between(
            w,
            lo,
            20 * np.log10(mag + r),
            alpha=0.3,
            lw=0,
            label=f"{100 * (1 - alpha):.0f} % region",
        )
        dph = np.degrees(np.arcsin(np.clip(r / mag, 0.0, 1.0)))
        axes[1].fill_between(w, phase - dph, phase + dph, alpha=0.3, lw=0)
    if model is not None:
        wd = np.geomspace(w.min(), w.max(), 400)
        G = model.frequency_response(wd)[output, input]
        axes[0].semilogx(wd, 20 * np.log10(np.abs(G)), "-", lw=1.2, color="C1", label="model")
        gph = np.degrees(np.unwrap(np.angle(G)))
        shift = 360.0 * np.round((phase[0] - np.interp(w[0], wd, gph)) / 360.0)
        axes[1].semilogx(wd, gph + shift, "-", lw=1.2, color="C1")
        if model.parameter_covariance is not None:
            band = response_band(model, wd, alpha)
            lo, _, hi = (x[output, input] for x in band.magnitude_db())
            axes[0].fill_between(
                wd, lo, hi, color="C1", alpha=0.25, lw=0,
                label=f"model {100 * (1 - alpha):.0f} % band (parameter covariance)",
            )  # fmt: skip
            plo, pc, phi = (x[output, input] for x in band.phase_deg())
            off = gph + shift - pc
            axes[1].fill_between(wd, plo + off, phi + off, color="C1", alpha=0.25, lw=0)
    if frf.coherence is not None:
        c = frf.coherence[output][ok]
        axes[2].semilogx(w, c, ".", ms=3, label="coherence")
        if frf.dof is not None:
            clo, chi = frf.coherence_bounds(alpha)
            axes[2].fill_between(w, clo[output][ok], chi[output][ok], alpha=0.3, lw=0)
    axes[0].set_ylabel("|H| (dB)")
    axes[0].legend(fontsize=8)
    axes[1].set_ylabel("phase (deg)")
    axes[2].set_ylabel("coherence")
    axes[2].set_ylim(0, 1.05)
    axes[2].set_xlabel("w (rad/s)")
    return fig
