"""Shared records of the focus tests: a lightly damped pair under a disturbance of the
innovation form (white measurement noise) and of another form (noise through a
resonance of its own)."""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from hdpbsid.systems import simulate_zoh

#: a lightly damped pair at 2 rad/s (zeta 0.1), unit static gain
A = np.array([[0.0, 1.0], [-4.0, -0.4]])
B = np.array([[0.0], [4.0]])
C = np.array([[1.0, 0.0]])


def _clean(rng: np.random.Generator):
    """The pair driven by a random binary input held 0.2 s, 40 s at 0.02 s."""
    t = np.arange(2000) * 0.02
    u = np.repeat(rng.choice((-1.0, 1.0), 200), 10)[:, None]
    return t, u, simulate_zoh(A, B, C, np.zeros((1, 1)), t, u)


def coloured_record(seed: int):
    """The pair plus a disturbance that is not of the innovation form of the plant:
    white noise through a sharp resonance at 9 rad/s (AR(2) with poles of modulus
    0.98), 15 dB below the output."""
    rng = np.random.default_rng(seed)
    t, u, y = _clean(rng)
    r, w = 0.98, 9.0 * (t[1] - t[0])
    v = lfilter([1.0], [1.0, -2 * r * np.cos(w), r * r], rng.standard_normal(t.size))
    v *= np.std(y) / np.std(v) * 10 ** (-15 / 20)
    return t, u, y + v[:, None]


def white_record(seed: int):
    """The pair plus white measurement noise 20 dB below the output (the innovation form
    with ``K = 0``)."""
    rng = np.random.default_rng(seed)
    t, u, y = _clean(rng)
    return t, u, y + 0.1 * np.std(y) * rng.standard_normal(y.shape)
