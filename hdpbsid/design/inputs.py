"""Input design for identification experiments: binary signals, PRBS, multisines, chirps
and the thesis's Hermite-projected sweep.

Every generator returns an :class:`InputDesign` holding the sample times ``t``, the input
``u`` (shape ``(Ns, m)``), the power of each DFT line (over one period for a periodic
signal, so that the excited lines are exact) and the crest factor ``max|u| / rms(u)`` of
each channel.  The ``amplitude`` of every generator is the *peak* value of the signal
(the actuator limit a flight-test engineer designs against); the power then follows from
the crest factor.

* :func:`random_binary`: levels ``+-amplitude`` with a random sign every ``clock``
  seconds (power spectrum ``A^2 T_c sinc^2(f T_c)``, first null at ``1 / T_c``), or, with
  ``band``, the sign of band-limited Gaussian noise (MATLAB's ``idinput('rbs')``).
* :func:`prbs`: maximum-length binary sequences (period ``2^k - 1`` bits) from a linear
  feedback shift register on a primitive polynomial (:func:`scipy.signal.max_len_seq`);
  over one period the autocorrelation is two-valued, ``N`` at lag 0 and ``-1`` elsewhere
  (Golomb, *Shift Register Sequences*, 1967; Ljung, *System Identification*, 2nd ed.,
  sec. 13.3).
* :func:`multisine`: a sum of harmonics of ``1 / (N dt)`` on a chosen band and grid, with
  Schroeder phases (Schroeder, "Synthesis of low-peak-factor signals and binary
  sequences with low autocorrelation", IEEE Trans. Inf. Theory 16(1), 1970) then the
  time-frequency swapping (clipping) algorithm of Van der Ouderaa, Schoukens and
  Renneboog ("Peak factor minimization using a time-frequency domain swapping
  algorithm", IEEE Trans. Instrum. Meas. 37(1), 1988) to lower the crest factor.
* :func:`chirp`: linear or logarithmic sweeps with cosine-tapered ends.
* :func:`hermite_sweep`: the thesis's excitation, a linear sweep projected on the first
  ``n_max,u`` Hermite functions of the record
  (:func:`hdpbsid.systems.quadrotor.hermite_sweep_excitation`).

Multi-input designs: independent random streams (uncorrelated), cyclically shifted PRBS
(cross-correlation ``-1`` per period at every lag but the shift), and multisines whose
channels excite interleaved subsets of the line grid (orthogonal in frequency: no line
is shared, so each channel's frequency response is read on its own lines from a single
experiment; Pintelon & Schoukens, *System Identification: A Frequency Domain Approach*,
2nd ed., 2012, sec. 3.7).  :func:`plot_input` draws a design.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import as_columns, check_positive_int, check_step

__all__ = [
    "CrestSettings",
    "CREST",
    "InputDesign",
    "crest_factor",
    "line_power",
    "random_binary",
    "prbs",
    "multisine",
    "schroeder_phases",
    "reduce_crest_factor",
    "chirp",
    "hermite_sweep",
    "plot_input",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class CrestSettings:
    """The clipping algorithm of :func:`reduce_crest_factor`.

    Attributes
    ----------
    iterations : int
        Iterations by default.
    clip_schedule : tuple of float
        Clipping level as a fraction of the current peak: it rises linearly from the first
        to the second value over the iterations.
    """

    #: the crest factor decreases quickly over the first tens of iterations and then
    #: slowly; the best iterate is kept, so more iterations never make the result worse
    iterations: int = 300
    #: deep clipping first moves the phases far from the Schroeder start; shallow clipping
    #: at the end settles them (a fixed level either stalls, if shallow, or oscillates, if
    #: deep)
    clip_schedule: tuple[float, float] = (0.8, 0.98)


#: the settings of :func:`reduce_crest_factor` and :func:`multisine`
CREST = CrestSettings()
#: :attr:`CrestSettings.iterations`, under its earlier name
CREST_ITERATIONS = CREST.iterations
#: :attr:`CrestSettings.clip_schedule`, under its earlier name
CLIP_SCHEDULE = CREST.clip_schedule


@dataclass(frozen=True)
class InputDesign:
    """A designed input signal.

    Attributes
    ----------
    t : ndarray, shape (Ns,)
        Sample times (s), starting at 0.
    u : ndarray, shape (Ns, m)
        Input samples.
    kind : str
        Name of the generator.
    freqs : ndarray, shape (nf,)
        Frequencies (Hz) of the DFT lines of :attr:`power`.
    power : ndarray, shape (nf, m)
        One-sided power of each line (:func:`line_power`): over one period for a periodic
        design, over the record otherwise; each column sums to the channel's mean square
        (Parseval).
    crest_factor : ndarray, shape (m,)
        ``max|u| / rms(u)`` per channel (over one period if periodic).
    period : int or None, optional
        Samples per period for a periodic design, else ``None``.
    lines
        Per channel, the indices of the excited DFT lines of one period (multisines only, else
        ``None``).
    options : dict, optional
        Every setting used, defaults included.
    """

    t: Array
    u: Array
    kind: str
    freqs: Array
    power: Array
    crest_factor: Array
    period: int | None = None
    lines: tuple[NDArray[np.intp], ...] | None = None
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def dt(self) -> float:
        """Sampling interval (s)."""
        return float(self.t[1] - self.t[0])

    @property
    def m(self) -> int:
        """Number of input channels."""
        return int(self.u.shape[1])

    def __repr__(self) -> str:
        crest = np.array2string(np.asarray(self.crest_factor), precision=2, separator=", ")
        period = "" if self.period is None else f", period={self.period} samples"
        return (
            f"InputDesign({self.kind!r}, Ns={self.t.size}, m={self.m}, dt={self.dt:g}"
            f"{period}, crest factor={crest})"
        )


def crest_factor(u: Any) -> Array:
    """Crest factor ``max|u| / sqrt(mean(u^2))`` of each column of ``u``.

    Parameters
    ----------
    u : array_like, shape (Ns,) or (Ns, m)
        The signal, one column per channel.

    Returns
    -------
    (m,) array; ``inf`` for an all-zero column.

    Examples
    --------
    >>> float(crest_factor(np.sin(2 * np.pi * np.arange(100) / 100))[0])  # doctest: +ELLIPSIS
    1.414...
    """
    u = as_columns(u, "u")
    rms = np.sqrt(np.mean(u**2, axis=0))
    peak = np.max(np.abs(u), axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(rms > 0, peak / np.where(rms > 0, rms, 1.0), np.inf)


def line_power(u: Any, dt: float, period: int | None = None) -> tuple[Array, Array]:
    """One-sided power of each DFT line: ``(freqs (Hz), power (nf, m))``.

    With ``period`` the first whole period of ``u`` is transformed, so a periodic signal's
    power sits exactly on its lines; otherwise the whole record is.  With ``U_k`` the DFT
    of ``N`` samples, ``P_k = c_k |U_k|^2 / N^2`` with ``c_k = 2`` except at DC and
    Nyquist (``c_k = 1``), so that ``sum_k P_k = mean(u^2)`` (Parseval).

    Parameters
    ----------
    u : ndarray, shape (Ns,) or (Ns, m)
        Samples.
    dt : float
        Sampling interval (s).
    period : int or None, optional
        Samples per period, or ``None``.

    Returns
    -------
    freqs : (N // 2 + 1,) Hz.
    power : (N // 2 + 1, m).

    Raises
    ------
    ValueError
        If ``period`` exceeds the record.
    """
    u = as_columns(u, "u")
    dt = check_step(dt)
    n = u.shape[0] if period is None else check_positive_int(period, "period")
    if n > u.shape[0]:
        raise ValueError(f"period ({n} samples) exceeds the record ({u.shape[0]} samples)")
    U = np.fft.rfft(u[:n], axis=0)
    c = np.full(U.shape[0], 2.0)
    c[0] = 1.0
    if n % 2 == 0:
        c[-1] = 1.0
    return np.fft.rfftfreq(n, dt), c[:, None] * np.abs(U) ** 2 / n**2


# -- random binary and PRBS ----------------------------------------------------------------
def random_binary(
    n_samples: int,
    dt: float,
    *,
    rng: np.random.Generator,
    clock: float | None = None,
    band: tuple[float, float] | None = None,
    amplitude: float = 1.0,
    channels: int = 1,
) -> InputDesign:
    """Random binary signal ``+-amplitude``.

    A new random sign is drawn every ``clock`` seconds (default ``dt``) and held; its
    power spectrum is ``A^2 T_c sinc^2(f T_c)`` (``T_c = clock``), flat to -3 dB up to
    ``0.443 / T_c`` with a first null at ``1 / T_c`` (Ljung, sec. 13.3), so the clock
    sets the band.  With ``band = (f_lo, f_hi)`` (Hz) the signs are those of Gaussian
    white noise band-passed to ``band`` by an ideal filter over the record (MATLAB's
    ``idinput('rbs')``): the sign keeps most of the power in the band.  Channels are
    independent draws from ``rng`` (uncorrelated).

    Parameters
    ----------
    n_samples : int
        Number of samples.
    dt : float
        Sampling interval (s).
    rng : numpy.random.Generator
        The random generator.
    clock : float or None, optional
        Seconds between possible switches, a multiple of ``dt`` (rounded to one).
    band : tuple of two float or None, optional
        Optional pass band (Hz) of the underlying Gaussian noise.
    amplitude : float, optional
        Level (peak) of the signal.
    channels : int, optional
        Number of inputs.

    Returns
    -------
    InputDesign

    Raises
    ------
    TypeError
        If ``rng`` is not a :class:`numpy.random.Generator`.
    ValueError
        On a non-positive size, step, clock or amplitude, or a band outside
        ``(0, Nyquist]``.

    Examples
    --------
    >>> d = random_binary(1000, 0.01, rng=np.random.default_rng(0), clock=0.05)
    >>> sorted(set(d.u[:, 0].tolist()))
    [-1.0, 1.0]
    """
    n_samples = check_positive_int(n_samples, "n_samples", 2)
    dt = check_step(dt)
    rng = _check_rng(rng)
    channels = check_positive_int(channels, "channels")
    amplitude = _check_amplitude(amplitude)
    hold = 1 if clock is None else _clock_samples(clock, dt)
    n_bits = -(-n_samples // hold)
    if band is None:
        bits = np.sign(rng.standard_normal((n_bits, channels)))
    else:
        lo, hi = _check_band(band, 1.0 / (2.0 * hold * dt))
        e = rng.standard_normal((n_bits, channels))
        f = np.fft.rfftfreq(n_bits, hold * dt)
        E = np.fft.rfft(e, axis=0)
        E[(f < lo) | (f > hi)] = 0.0
        bits = np.sign(np.fft.irfft(E, n_bits, axis=0))
    bits[bits == 0] = 1.0
    u = amplitude * np.repeat(bits, hold, axis=0)[:n_samples]
    opts = dict(clock=hold * dt, band=band, amplitude=amplitude, channels=channels)
    return _design("random_binary", u, dt, None, None, opts)


def prbs(
    order: int,
    dt: float,
    *,
    clock: int = 1,
    periods: int = 1,
    amplitude: float = 1.0,
    channels: int = 1,
) -> InputDesign:
    """Maximum-length pseudo-random binary sequence ``+-amplitude``.

    The ``order``-bit linear feedback shift register on a primitive polynomial
    (:func:`scipy.signal.max_len_seq`, orders 2-32) has period ``2^order - 1`` bits;
    each bit is held ``clock`` samples.  Over one period the sequence has one more
    ``+1`` than ``-1`` and the two-valued autocorrelation ``sum_k s_k s_{k+tau} = N``
    (``tau = 0``), ``-1`` otherwise (Golomb 1967): its power is flat over the harmonics
    of the period (``clock = 1``).  Channel ``j`` is the sequence cyclically shifted by
    ``j floor(N / m)`` bits, so two channels' cross-correlation is ``-1`` except at one
    lag (Ljung, sec. 13.3, "shifted PRBS").

    Parameters
    ----------
    order : int
        Register length ``k`` (2-32).
    dt : float
        Sampling interval (s).
    clock : int, optional
        Samples per bit.
    periods : int, optional
        Number of periods generated.
    amplitude : float, optional
        Level (peak).
    channels : int, optional
        Number of inputs (at most the number of bits of a period).

    Returns
    -------
    InputDesign with ``period = (2^order - 1) clock``.

    Raises
    ------
    ValueError
        On an order outside 2-32, non-positive counts or more channels than bits.

    Examples
    --------
    >>> d = prbs(5, 0.1)
    >>> d.period, int(d.u.sum())
    (31, 1)
    """
    from scipy.signal import max_len_seq

    order = check_positive_int(order, "order", 2)
    if order > 32:
        raise ValueError(f"order must be between 2 and 32, got {order}")
    dt = check_step(dt)
    clock = check_positive_int(clock, "clock")
    periods = check_positive_int(periods, "periods")
    channels = check_positive_int(channels, "channels")
    amplitude = _check_amplitude(amplitude)
    seq = 2.0 * max_len_seq(order)[0].astype(float) - 1.0
    n = seq.size
    if channels > n:
        raise ValueError(f"channels must be at most the {n} bits of a period, got {channels}")
    shift = n // channels
    cols = np.stack([np.roll(seq, -j * shift) for j in range(channels)], axis=1)
    one = np.repeat(cols, clock, axis=0)
    u = amplitude * np.tile(one, (periods, 1))
    opts = dict(order=order, clock=clock, periods=periods, amplitude=amplitude, shift=shift)
    return _design("prbs", u, dt, n * clock, None, opts)


# -- multisines ------------------------------------------------------------------------
def schroeder_phases(power: Any) -> Array:
    """Schroeder's low-crest-factor phases for relative line powers ``p_1..p_K``:
    ``phi_k = -2 pi sum_{i < k} (k - i) p_i / sum(p)`` (Schroeder 1970, eq. 11); for a
    flat spectrum ``phi_k = -pi k (k - 1) / K`` (lines counted from 1).

    Parameters
    ----------
    power : ndarray, shape (K,)
        Non-negative relative powers of the excited lines, in frequency order.

    Returns
    -------
    ndarray, shape (K,)
        Phases (rad).

    Raises
    ------
    ValueError
        If the powers are empty, negative, not finite or sum to zero.

    Examples
    --------
    >>> np.allclose(schroeder_phases(np.ones(4)), -np.pi * np.arange(4) * np.arange(1, 5) / 4)
    True
    """
    p = np.asarray(power, dtype=float).reshape(-1)
    if p.size == 0 or np.any(p < 0) or not np.all(np.isfinite(p)) or p.sum() <= 0:
        raise ValueError("power must be non-negative finite values with a positive sum")
    p = p / p.sum()
    k = np.arange(p.size)
    # sum_{i<k} (k - i) p_i for every k: a convolution of p with the ramp 0, 1, 2, ...
    acc = np.convolve(p, k.astype(float))[: p.size]
    return -2.0 * np.pi * acc


def _periodic_from_lines(n: int, lines: NDArray[np.intp], amp: Array, phase: Array) -> Array:
    X = np.zeros(n // 2 + 1, dtype=complex)
    X[lines] = amp * np.exp(1j * phase)
    return np.fft.irfft(X, n) * n


def reduce_crest_factor(
    n: int,
    lines: Any,
    amplitudes: Any,
    phases: Any,
    iterations: int = CREST.iterations,
) -> tuple[Array, float]:
    """Lower the crest factor of a multisine by time-frequency swapping (clipping).

    Each iteration clips the period at a fraction of its peak (:attr:`CrestSettings.clip_schedule`),
    takes the DFT of the clipped signal, keeps its phases on the excited lines and puts
    back the prescribed amplitudes (and zeros elsewhere): the projection of the clipped
    signal on the multisines with the prescribed spectrum (Van der Ouderaa, Schoukens &
    Renneboog 1988).  The amplitude spectrum is therefore exact at every iterate; only
    the phases change.  The iterate with the lowest crest factor is returned.

    Parameters
    ----------
    n : int
        Samples per period.
    lines : ndarray, shape (K,)
        Excited DFT lines (``1 <= line < n / 2``).
    amplitudes : ndarray, shape (K,)
        Amplitude of each line.
    phases : ndarray, shape (K,)
        Starting phases (e.g. :func:`schroeder_phases`).
    iterations : int, optional
        Number of iterations.

    Returns
    -------
    phases : ndarray, shape (K,)
        The phases of the best iterate.
    crest_factor : float
        Its crest factor ``max|u| / rms(u)``.

    Raises
    ------
    ValueError
        If ``lines``, ``amplitudes`` and ``phases`` differ in length or are empty, or
        ``n < 4``.

    Examples
    --------
    >>> k = np.arange(1, 101)
    >>> ph, cf = reduce_crest_factor(4096, k, np.ones(100), schroeder_phases(np.ones(100)))
    >>> bool(cf < 1.5)
    True
    """
    n = check_positive_int(n, "n", 4)
    lines = np.asarray(lines, dtype=np.intp).reshape(-1)
    amp = np.asarray(amplitudes, dtype=float).reshape(-1)
    phase = np.asarray(phases, dtype=float).reshape(-1)
    if not (lines.size == amp.size == phase.size) or lines.size == 0:
        raise ValueError("lines, amplitudes and phases must have the same non-zero length")
    iterations = check_positive_int(iterations, "iterations", 0)
    x = _periodic_from_lines(n, lines, amp, phase)
    best_phase, best_cf = phase, float(crest_factor(x)[0])
    lo, hi = CREST.clip_schedule
    for it in range(iterations):
        level = (lo + (hi - lo) * it / max(iterations - 1, 1)) * np.max(np.abs(x))
        phase = np.angle(np.fft.rfft(np.clip(x, -level, level))[lines])
        x = _periodic_from_lines(n, lines, amp, phase)
        cf = float(crest_factor(x)[0])
        if cf < best_cf:
            best_phase, best_cf = phase, cf
    return best_phase, best_cf


def multisine(
    period: int,
    dt: float,
    band: tuple[float, float],
    *,
    grid: int = 1,
    periods: int = 1,
    amplitude: float = 1.0,
    channels: int = 1,
    phases: str = "crest",
    rng: np.random.Generator | None = None,
    iterations: int = CREST.iterations,
) -> InputDesign:
    """Periodic multisine with a flat amplitude spectrum on a band of harmonics.

    The excited lines are the harmonics ``k / (period dt)`` inside ``band`` (Hz) whose
    index ``k >= 1`` is a multiple of ``grid`` (``grid = 2``: odd-multiple-free designs
    are built from it by the user's choice of band and grid).  With ``channels = m`` the
    lines are dealt out in turn, channel ``j`` getting lines ``j, j + m, ...`` of the
    list: no line is shared, so the channels are orthogonal over a period and each
    channel's response is read on its own lines.

    Phases: ``"schroeder"`` (:func:`schroeder_phases`), ``"crest"`` (Schroeder then
    :func:`reduce_crest_factor`, the default: about 1.4-1.5 for 100 lines against
    Schroeder's 1.6-1.8), or ``"random"`` (uniform, from ``rng``).  Each channel is
    scaled to the peak ``amplitude``.

    Parameters
    ----------
    period : int
        Samples per period ``N`` (frequency resolution ``1 / (N dt)``).
    dt : float
        Sampling interval (s).
    band : tuple of two float
        ``(f_lo, f_hi)`` Hz, ``0 <= f_lo <= f_hi <= 1 / (2 dt)``.
    grid : int, optional
        Keep every ``grid``-th harmonic.
    periods : int, optional
        Number of periods generated.
    amplitude : float, optional
        Peak of each channel.
    channels : int, optional
        Number of inputs.
    phases : {"crest", "schroeder", "random"}, optional
        The phases of the lines (above).
    rng : numpy.random.Generator or None, optional
        Generator, needed for ``phases="random"``.
    iterations : int, optional
        Clipping iterations for ``"crest"``.

    Returns
    -------
    InputDesign with ``period`` and ``lines`` set.

    Raises
    ------
    ValueError
        On a band with fewer lines than channels, or a bad setting.

    Examples
    --------
    >>> d = multisine(1000, 0.01, (1.0, 5.0), iterations=20)
    >>> d.lines[0][[0, -1]]  # 1 Hz and 5 Hz at 0.1 Hz resolution
    array([10, 50])
    """
    n = check_positive_int(period, "period", 4)
    dt = check_step(dt)
    lo, hi = _check_band(band, 1.0 / (2.0 * dt))
    grid = check_positive_int(grid, "grid")
    periods = check_positive_int(periods, "periods")
    channels = check_positive_int(channels, "channels")
    amplitude = _check_amplitude(amplitude)
    if phases not in ("crest", "schroeder", "random"):
        raise ValueError(f"phases must be 'crest', 'schroeder' or 'random', got {phases!r}")
    if phases == "random":
        rng = _check_rng(rng)
    df = 1.0 / (n * dt)
    k = np.arange(1, (n - 1) // 2 + 1)  # below Nyquist: a line at Nyquist has no phase
    f = k * df
    lines = k[(f >= lo - 1e-9 * df) & (f <= hi + 1e-9 * df) & (k % grid == 0)]
    if lines.size < channels:
        raise ValueError(
            f"band {band} Hz holds {lines.size} lines of the {df:g} Hz grid (grid={grid}); "
            f"at least {channels} (one per channel) are needed"
        )
    per_channel = tuple(lines[j::channels] for j in range(channels))
    cols = []
    for lj in per_channel:
        amp = np.ones(lj.size)
        if phases == "random":
            ph = rng.uniform(0.0, 2.0 * np.pi, lj.size)  # type: ignore[union-attr]
        else:
            ph = schroeder_phases(amp**2)
            if phases == "crest":
                ph, _ = reduce_crest_factor(n, lj, amp, ph, iterations)
        x = _periodic_from_lines(n, lj, amp, ph)
        cols.append(amplitude * x / np.max(np.abs(x)))
    one = np.stack(cols, axis=1)
    u = np.tile(one, (periods, 1))
    opts = dict(
        band=(lo, hi),
        grid=grid,
        periods=periods,
        amplitude=amplitude,
        channels=channels,
        phases=phases,
        iterations=iterations,
        resolution_hz=df,
    )
    return _design("multisine", u, dt, n, per_channel, opts)


# -- sweeps ----------------------------------------------------------------------------
def chirp(
    n_samples: int,
    dt: float,
    f0: float,
    f1: float,
    *,
    method: str = "linear",
    taper: float = 0.1,
    amplitude: float = 1.0,
) -> InputDesign:
    """Sine sweep from ``f0`` to ``f1`` Hz over the record, with cosine-tapered ends.

    Instantaneous frequency (:func:`scipy.signal.chirp`): ``f0 + (f1 - f0) t / T``
    (``"linear"``) or ``f0 (f1 / f0)^(t / T)`` (``"logarithmic"``, constant time per
    octave), ``T`` the record length.  The ends are multiplied by a Tukey window whose
    tapered part is ``taper`` of the record (half at each end,
    :func:`scipy.signal.windows.tukey`), so the sweep starts and ends at zero without the
    broadband step of an abrupt start.

    Parameters
    ----------
    n_samples : int
        Number of samples.
    dt : float
        Sampling interval (s).
    f0, f1 : float
        Start and end frequencies (Hz), below Nyquist; both positive for a logarithmic sweep.
    method : {"linear", "logarithmic"}, optional
        How the instantaneous frequency moves from ``f0`` to ``f1``.
    taper : float, optional
        Fraction of the record in the tapered ends (0: none, 1: a Hann window).
    amplitude : float, optional
        Peak.

    Returns
    -------
    InputDesign

    Raises
    ------
    ValueError
        On frequencies outside ``[0, Nyquist]``, an unknown method or a taper outside
        ``[0, 1]``.

    Examples
    --------
    >>> d = chirp(2001, 0.01, 0.1, 5.0)
    >>> bool(abs(d.u[0, 0]) < 1e-12 and abs(d.u[-1, 0]) < 1e-12)
    True
    """
    from scipy.signal import chirp as sp_chirp
    from scipy.signal.windows import tukey

    n_samples = check_positive_int(n_samples, "n_samples", 2)
    dt = check_step(dt)
    nyq = 1.0 / (2.0 * dt)
    for name, v in (("f0", f0), ("f1", f1)):
        if not np.isfinite(v) or not 0.0 <= v <= nyq:
            raise ValueError(f"{name} must be in [0, {nyq:g}] Hz (Nyquist), got {v}")
    if method not in ("linear", "logarithmic"):
        raise ValueError(f"method must be 'linear' or 'logarithmic', got {method!r}")
    if method == "logarithmic" and (f0 <= 0 or f1 <= 0):
        raise ValueError(f"a logarithmic sweep needs f0, f1 > 0, got {f0}, {f1}")
    if not 0.0 <= taper <= 1.0:
        raise ValueError(f"taper must be in [0, 1], got {taper}")
    amplitude = _check_amplitude(amplitude)
    t = np.arange(n_samples) * dt
    T = t[-1]
    x = sp_chirp(t, f0, T, f1, method=method, phi=-90.0)  # a sine: starts at 0
    u = amplitude * x * tukey(n_samples, taper)
    opts = dict(f0=f0, f1=f1, method=method, taper=taper, amplitude=amplitude)
    return _design("chirp", u[:, None], dt, None, None, opts)


def hermite_sweep(
    n_samples: int,
    dt: float,
    f0: float,
    f1: float,
    *,
    n_max_u: int = 300,
    amplitude: float = 1.0,
) -> InputDesign:
    """The thesis's excitation: a linear ``f0 -> f1`` Hz sine sweep projected on the
    first ``n_max_u`` Hermite functions of the record (``n_max,u``).

    Delegates to :func:`hdpbsid.systems.quadrotor.hermite_sweep_excitation` (the studies'
    generator), then scales the result to the peak ``amplitude``.  The signal lies in the
    span of ``n_max_u`` Hermite functions, which reach about ``3.6 n_max_u / T`` rad/s
    over a record of ``T`` s: fewer terms than ``2 pi f1 T / 3.6`` cut the sweep's fast
    end; the projection also fades the ends towards zero.

    Parameters
    ----------
    n_samples : int
        Number of samples.
    dt : float
        Sampling interval (s).
    f0, f1 : float
        Start and end of the sweep (Hz).
    n_max_u : int, optional
        Number of Hermite functions.
    amplitude : float, optional
        Peak.

    Returns
    -------
    InputDesign

    Raises
    ------
    ValueError
        On bad sizes or frequencies.

    Examples
    --------
    >>> d = hermite_sweep(1001, 0.01, 0.1, 1.0, n_max_u=60)
    >>> round(float(np.max(np.abs(d.u))), 12)
    1.0
    """
    from hdpbsid.systems.quadrotor import hermite_sweep_excitation

    n_samples = check_positive_int(n_samples, "n_samples", 2)
    dt = check_step(dt)
    n_max_u = check_positive_int(n_max_u, "n_max_u")
    nyq = 1.0 / (2.0 * dt)
    for name, v in (("f0", f0), ("f1", f1)):
        if not np.isfinite(v) or not 0.0 <= v <= nyq:
            raise ValueError(f"{name} must be in [0, {nyq:g}] Hz (Nyquist), got {v}")
    amplitude = _check_amplitude(amplitude)
    t = np.arange(n_samples) * dt
    x = hermite_sweep_excitation(t, n_max_u, amplitude=1.0, f0=f0, f1=f1)
    peak = float(np.max(np.abs(x)))
    if peak == 0.0:
        raise ValueError("the projected sweep is zero: n_max_u is too small for the band")
    u = amplitude * x / peak
    opts = dict(f0=f0, f1=f1, n_max_u=n_max_u, amplitude=amplitude)
    return _design("hermite_sweep", u[:, None], dt, None, None, opts)


# -- figure ----------------------------------------------------------------------------
def plot_input(design: InputDesign, axes: Any | None = None) -> Any:
    """Time trace (first period of a periodic design, else the record) and line power
    (dB) of every channel, with the crest factors in the legend.

    Parameters
    ----------
    design : InputDesign
        An :class:`InputDesign`.
    axes : sequence of two matplotlib.axes.Axes, optional
        Where to draw; ``None`` for a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        The figure drawn on.

    Raises
    ------
    TypeError
        If ``design`` is not an :class:`InputDesign`.
    """
    import matplotlib.pyplot as plt

    if not isinstance(design, InputDesign):
        raise TypeError(f"design must be an InputDesign, got {type(design).__name__}")
    if axes is None:
        fig, axes = plt.subplots(2, 1, figsize=(7, 5), layout="constrained")
    else:
        fig = axes[0].figure
    n = design.period or design.u.shape[0]
    for j in range(design.m):
        label = f"u{j + 1} (crest factor {design.crest_factor[j]:.2f})"
        axes[0].plot(design.t[:n], design.u[:n, j], lw=0.8, label=label)
        p = design.power[:, j]
        keep = p > 1e-12 * max(float(p.max()), np.finfo(float).tiny)
        axes[1].plot(design.freqs[keep], 10 * np.log10(p[keep]), ".", ms=3, label=f"u{j + 1}")
    axes[0].set_xlabel("t (s)")
    axes[0].set_ylabel("u")
    axes[0].set_title(f"{design.kind}" + (" (one period)" if design.period else ""))
    axes[0].legend(fontsize=8, loc="upper right")
    axes[1].set_xscale("log")
    axes[1].set_xlabel("f (Hz)")
    axes[1].set_ylabel("power per line (dB)")
    return fig


# -- helpers ---------------------------------------------------------------------------
def _design(
    kind: str,
    u: Array,
    dt: float,
    period: int | None,
    lines: tuple[NDArray[np.intp], ...] | None,
    options: dict[str, Any],
) -> InputDesign:
    t = np.arange(u.shape[0]) * dt
    freqs, power = line_power(u, dt, period)
    cf = crest_factor(u[: period or u.shape[0]])
    return InputDesign(t, u, kind, freqs, power, cf, period, lines, {"dt": dt, **options})


def _check_amplitude(a: Any) -> float:
    if isinstance(a, bool) or not isinstance(a, int | float | np.integer | np.floating):
        raise TypeError(f"amplitude must be a number, got {type(a).__name__}")
    if not np.isfinite(a) or a <= 0:
        raise ValueError(f"amplitude must be positive and finite, got {a}")
    return float(a)


def _check_rng(rng: Any) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            f"rng must be a numpy.random.Generator (numpy.random.default_rng(seed)), "
            f"got {type(rng).__name__}"
        )
    return rng


def _clock_samples(clock: Any, dt: float) -> int:
    if not np.isfinite(clock) or clock < dt * (1 - 1e-9):
        raise ValueError(f"clock must be at least dt = {dt:g} s, got {clock}")
    hold = int(round(clock / dt))
    if abs(hold * dt - clock) > 1e-6 * clock:
        raise ValueError(f"clock must be a multiple of dt = {dt:g} s, got {clock}")
    return hold


def _check_band(band: Any, nyquist: float) -> tuple[float, float]:
    try:
        lo, hi = (float(b) for b in band)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"band must be a pair (f_lo, f_hi) in Hz, got {band!r}") from exc
    finite = np.isfinite(lo) and np.isfinite(hi)
    if not (finite and 0 <= lo <= hi <= nyquist * (1 + 1e-12)):
        raise ValueError(
            f"band must satisfy 0 <= f_lo <= f_hi <= {nyquist:g} Hz (Nyquist of the clock), "
            f"got {band!r}"
        )
    if hi <= 0:
        raise ValueError(f"band must have f_hi > 0, got {band!r}")
    return lo, hi
