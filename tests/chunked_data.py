"""Shared data of the chunked-record tests: a 5 Hz resonance sampled at 1 kHz."""

from __future__ import annotations

import numpy as np
from scipy import signal

from hdpbsid.models.conversion import c2d
from hdpbsid.systems import add_noise

FS, F_RES, ZETA, F_BAND = 1000.0, 5.0, 0.05, 20.0


def _resonance() -> np.ndarray:
    wn = 2 * np.pi * F_RES
    return np.array([[0.0, 1.0], [-(wn**2), -2 * ZETA * wn]])


def _record(ns: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 5 Hz resonance sampled at 1 kHz, input low-passed to 20 Hz, 20 dB output noise."""
    rng = np.random.default_rng(seed)
    A = _resonance()
    wn2 = -A[1, 0]
    B, C, D = np.array([[0.0], [wn2]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))
    sos = signal.butter(8, F_BAND, fs=FS, output="sos")
    u = signal.sosfilt(sos, rng.standard_normal(ns + 2000))[2000:]
    Ad, Bd, Cd, Dd, _ = c2d(A, B, C, D, None, 1.0 / FS)
    num, den = signal.ss2tf(Ad, Bd, Cd, Dd)
    y, _ = add_noise(signal.lfilter(num[0], den, u), 20.0, rng)
    return np.arange(ns) / FS, u[:, None], y[:, None]
