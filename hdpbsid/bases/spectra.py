"""Power spectra of a record and the bandwidths the default rules of the basis methods use.

A basis must cover the band the data occupy: the basis size, the default window and the
operator scale's band of modes all start from the frequency below which a given share of
a signal's energy lies (:func:`bandwidth`, :func:`data_bandwidth`).  The spectra are
Hann-windowed periodograms of the detrended signals with their white-noise floor removed
(:func:`noise_floor`); the thresholds are the fields of :class:`SpectraSettings`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.memo import memoize

__all__ = [
    "SpectraSettings",
    "SPECTRA",
    "noise_floor",
    "bandwidth",
    "spectrum_bandwidth",
    "data_bandwidth",
    "spectra_data_bandwidth",
    "ENERGY_FRACTION",
    "BROADBAND_SHARE",
    "FLOOR_MARGIN",
    "SPECTRA_CACHE_SIZE",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SpectraSettings:
    """The thresholds of the bandwidth estimates, each with its reason.

    Parameters
    ----------
    energy_fraction : float, optional
        Default energy share below the bandwidth estimate (:func:`bandwidth`).
    broadband_share : float, optional
        Noise-floor share above which an input counts as broadband.
    floor_margin : float, optional
        Multiple of the noise floor removed before the energy is summed.
    input_fraction : float, optional
        Energy share of a band-limited input in :func:`data_bandwidth`.
    output_fraction : float, optional
        Energy share of an output in :func:`data_bandwidth`.
    cache_size : int, optional
        Periodograms kept by the memoised spectra.

    Examples
    --------
    >>> SpectraSettings().floor_margin
    3.0
    """

    #: fraction of the (detrended) signal energy below the bandwidth estimate
    energy_fraction: float = 0.99
    #: noise-floor share above which an input column counts as broadband (data_bandwidth)
    #: (a band-limited input's floor carries a few per cent of its power, a white one's
    #: all of it; a closed-loop command dominated by fed-back sensor noise lies in
    #: between, above this share)
    broadband_share: float = 0.25
    #: bandwidth() counts only power above this many times the noise floor: periodogram
    #: bins of white noise are exponentially distributed, so their excursions above the
    #: floor itself add up over thousands of bins (on a noisy record enough to move a
    #: 95 % band to Nyquist); above 3 floors the expected excess is e^-3 = 5 % of the noise
    floor_margin: float = 3.0
    #: a band-limited input's share in data_bandwidth: its floor is removed cleanly
    input_fraction: float = 0.99
    #: an output's share in data_bandwidth, lower than an input's: the output noise is
    #: never fully removed by a floor estimate
    output_fraction: float = 0.95
    #: periodograms kept by the memoised spectra: one identification asks for the
    #: spectra of a record's inputs and outputs several times (the data bandwidth, the
    #: default window, the band of the operator scale) and its held-out check those of
    #: the sub-record
    cache_size: int = 8


#: the settings the functions of this module use
SPECTRA = SpectraSettings()
#: the fields of :data:`SPECTRA` under their former names
ENERGY_FRACTION = SPECTRA.energy_fraction
BROADBAND_SHARE = SPECTRA.broadband_share
FLOOR_MARGIN = SPECTRA.floor_margin
SPECTRA_CACHE_SIZE = SPECTRA.cache_size


def _power_spectra(t: Array, x: Array) -> tuple[Array, Array]:
    """Angular frequencies and Hann-windowed periodograms of the detrended columns of
    ``x`` (resampled linearly onto a uniform grid with the mean step)."""
    ns = t.shape[0]
    tu = np.linspace(t[0], t[-1], ns)
    dt = (t[-1] - t[0]) / (ns - 1)
    P = np.empty((ns // 2 + 1, x.shape[1]))
    for k in range(x.shape[1]):
        xk = np.interp(tu, t, x[:, k])
        xk = xk - np.polyval(np.polyfit(tu - tu[0], xk, 1), tu - tu[0])
        P[:, k] = np.abs(np.fft.rfft(xk * np.hanning(ns))) ** 2
    return 2 * np.pi * np.fft.rfftfreq(ns, dt), P


@memoize(size=SPECTRA.cache_size)
def _record_spectra(t: Array, x: Array) -> tuple[Array, Array]:
    """:func:`_power_spectra`, memoised by the contents of ``t`` and ``x``
    (:mod:`hdpbsid.bases.memo`; the arrays returned are read-only)."""
    return _power_spectra(t, x)


def noise_floor(P: Array) -> tuple[float, float]:
    """White-noise floor of a periodogram and its share of the total power.

    The floor is estimated from the upper half of the spectrum (a band-limited signal
    sampled well above its band leaves only white measurement noise there) as its median
    divided by ``ln 2``: periodogram bins of white noise are exponentially distributed, with
    median ``ln 2`` times the mean, and the median ignores isolated peaks.

    Parameters
    ----------
    P : ndarray, shape (bins,)
        A periodogram.

    Returns
    -------
    floor : float
        The floor (mean power of a white bin).
    share : float
        ``floor * len(P) / sum(P)``; near 1 the column is white (or noise-dominated) over
        the whole band.

    References
    ----------
    .. [1] P. Stoica and R. Moses, *Spectral Analysis of Signals*, Prentice Hall, 2005,
       sec. 2.4 (the periodogram's distribution).

    Examples
    --------
    >>> P = np.random.default_rng(0).exponential(2.0, 1000)  # white, mean 2
    >>> np.round(noise_floor(P), 2)
    array([1.93, 0.95])
    """
    total = float(P.sum())
    if total == 0.0:
        return 0.0, 0.0
    floor = float(np.median(P[P.size // 2 :])) / np.log(2.0)
    return floor, floor * P.size / total


def bandwidth(
    t: Array, x: Array, fraction: float = ENERGY_FRACTION, subtract_floor: bool = True
) -> float:
    """Angular frequency (rad/s) below which ``fraction`` of the energy of ``x`` lies.

    Each column is detrended (mean and linear trend removed, so a record that does not
    start and end at rest does not look broadband), Hann-windowed (the jump between the
    ends would otherwise leak energy to high frequencies) and resampled linearly onto a
    uniform grid with the mean step (non-uniform ``t``).  With ``subtract_floor`` the
    power up to :data:`FLOOR_MARGIN` times the white-noise floor (:func:`noise_floor`) is
    removed first, so measurement noise does not stretch the band to Nyquist; a column with
    no power above it keeps its raw spectrum.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Sample times (s), increasing.
    x : ndarray, shape (Ns, k)
        The signals, one per column.
    fraction : float, optional
        Energy fraction, in ``(0, 1)``.
    subtract_floor : bool, optional
        Remove the noise floor first.

    Returns
    -------
    float
        The largest band over the columns (rad/s).

    Examples
    --------
    >>> t = np.linspace(0.0, 100.0, 10001)
    >>> round(bandwidth(t, np.sin(2.0 * t)[:, None]), 2)  # a sine at 2 rad/s
    2.07
    """
    return spectrum_bandwidth(*_record_spectra(t, x), fraction, subtract_floor)


def spectrum_bandwidth(
    w: Array, P: Array, fraction: float = ENERGY_FRACTION, subtract_floor: bool = True
) -> float:
    """:func:`bandwidth` from given power spectra.

    Parameters
    ----------
    w : ndarray, shape (bins,)
        Angular frequencies (rad/s).
    P : ndarray, shape (bins, k)
        Power spectra, one per column (e.g. periodograms averaged over the chunks of a
        record read from disk).
    fraction : float, optional
        Energy fraction.
    subtract_floor : bool, optional
        Remove the noise floor first.

    Returns
    -------
    float
        The largest band over the columns (rad/s); 0 when every column is zero.
    """
    best = 0.0
    for k in range(P.shape[1]):
        Pk = P[:, k]
        if Pk.sum() == 0:
            continue
        if subtract_floor:
            excess = np.clip(Pk - SPECTRA.floor_margin * noise_floor(Pk)[0], 0.0, None)
            Pk = excess if excess.sum() > 0 else Pk
        c = np.cumsum(Pk) / Pk.sum()
        i = int(np.searchsorted(c, fraction))
        best = max(best, float(w[min(i, w.size - 1)]))
    return best


@memoize
def data_bandwidth(t: Array, u: Array, y: Array) -> float:
    """Bandwidth of a record: 95 % of each output's energy above its noise floor, and 99 %
    of each band-limited input's.

    :func:`bandwidth` removes the white-noise floor.  An input whose floor carries more
    than :data:`BROADBAND_SHARE` of its power is not band-limited at this sampling rate (a
    white excitation, or a closed-loop command dominated by fed-back sensor noise, shaped by
    the controller so that no flat floor removes it) and does not set the band: the outputs,
    low-passed by the plant, do.  The outputs get the lower fraction because their noise is
    never fully removed by a floor estimate.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Sample times (s).
    u : ndarray, shape (Ns, m)
        Inputs.
    y : ndarray, shape (Ns, l)
        Outputs.

    Returns
    -------
    float
        The band (rad/s).

    Examples
    --------
    >>> t = np.linspace(0.0, 100.0, 10001)
    >>> s = np.sin(2.0 * t)[:, None]
    >>> round(data_bandwidth(t, s, s), 2)
    2.07
    """
    wu, Pu = _record_spectra(t, u)
    return spectra_data_bandwidth(wu, Pu, *_record_spectra(t, y))


def spectra_data_bandwidth(wu: Array, Pu: Array, wy: Array, Py: Array) -> float:
    """:func:`data_bandwidth` from the power spectra of the inputs and outputs.

    Parameters
    ----------
    wu : ndarray, shape (bins_u,)
        Angular frequencies of ``Pu`` (rad/s).
    Pu : ndarray, shape (bins_u, m)
        Input power spectra.
    wy : ndarray, shape (bins_y,)
        Angular frequencies of ``Py``.
    Py : ndarray, shape (bins_y, l)
        Output power spectra.

    Returns
    -------
    float
        The band (rad/s).
    """
    share = SPECTRA.broadband_share
    limited = [k for k in range(Pu.shape[1]) if noise_floor(Pu[:, k])[1] < share]
    band_u = spectrum_bandwidth(wu, Pu[:, limited], SPECTRA.input_fraction) if limited else 0.0
    return max(band_u, spectrum_bandwidth(wy, Py, SPECTRA.output_fraction))
