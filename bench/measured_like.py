"""Simulated records with the defects of measured ones, for ``bench/realdata.py``.

A measured record differs from a benchmark simulation in ways no single model class
captures: the actuator saturates, the sensor has an offset, drifts and quantizes, the
noise is coloured, a direct input-output path exists, the dynamics are slow next to the
record or lightly damped over a long record, and the process runs in a loop. Each
generator below builds one such record from a stated physical model, seeded, so a tool
can be judged the way a user judges it on real data (validation fit on the last third)
while the true system stays known for the notes.

These records judge methods; they must never be used to tune a constant of the library.

Every generator returns a :class:`Synthetic`: ``u (Ns, 1)``, ``y (Ns, 1)``, ``dt`` and a
description naming each defect.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm
from scipy.signal import lfilter

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Synthetic:
    """A simulated measured-like record: ``u (Ns, 1)``, ``y (Ns, 1)``, sampling time."""

    u: Array
    y: Array
    dt: float
    description: str


def _zoh(A: Array, B: Array, dt: float) -> tuple[Array, Array]:
    """Exact zero-order-hold discretisation by the block exponential (Van Loan)."""
    n, m = B.shape
    M = np.zeros((n + m, n + m))
    M[:n, :n], M[:n, n:] = A, B
    E = expm(M * dt)
    return E[:n, :n], E[:n, n:]


def _lsim(A: Array, B: Array, C: Array, D: Array, u: Array, dt: float) -> Array:
    """Output of the continuous system under a zero-order hold of ``u (Ns,)`` from rest."""
    Ad, Bd = _zoh(A, B, dt)
    x = np.zeros(A.shape[0])
    y = np.empty(u.size)
    for k, uk in enumerate(u):
        y[k] = C @ x + D * uk
        x = Ad @ x + Bd[:, 0] * uk
    return y


def _coloured(rng: np.random.Generator, n: int, pole: float) -> Array:
    """Unit-variance AR(1) noise ``e_k = pole e_{k-1} + w_k`` (pole in [0, 1))."""
    e = lfilter([1.0], [1.0, -pole], rng.standard_normal(n))
    return e / np.std(e)


def _noise_at(y: Array, snr_db: float, noise: Array) -> Array:
    """``noise`` scaled so that ``std(y - mean y) / std(noise)`` is ``snr_db`` (20 log10)."""
    return noise * np.std(y - y.mean()) / 10.0 ** (snr_db / 20.0)


def _random_binary(rng: np.random.Generator, n: int, clock: int) -> Array:
    """+-1 levels held for ``clock`` samples each (a band-limited random binary input)."""
    levels = rng.choice((-1.0, 1.0), size=n // clock + 1)
    return np.repeat(levels, clock)[:n]


def thermal_direct(seed: int = 0) -> Synthetic:
    """A heated plate: two thermal time constants, a direct path, drift and offset.

    Heater power ``u`` (random binary, 30 s clock, recorded command) drives the plate
    temperature through ``K / ((40 s) s + 1)((8 s) s + 1)`` with ``K = 2``; the sensor
    also picks up the heater current directly (gain ``0.5``: a direct term ``D``). The
    sensor reads an offset of 20 units, drifts by 0.3 units over the record and adds
    AR(1) noise (pole 0.8) at 25 dB. ``dt = 1 s``, 2400 samples.
    """
    rng = np.random.default_rng(seed)
    dt, n = 1.0, 2400
    A = np.array([[-1 / 40.0, 1 / 40.0], [0.0, -1 / 8.0]])
    B = np.array([[0.0], [2.0 / 8.0]])
    C, D = np.array([1.0, 0.0]), 0.5
    u = _random_binary(rng, n, 30)
    y = _lsim(A, B, C, D, u, dt)
    drift = 0.3 * np.linspace(0.0, 1.0, n)
    y = 20.0 + y + drift + _noise_at(y, 25.0, _coloured(rng, n, 0.8))
    return Synthetic(
        u[:, None],
        y[:, None],
        dt,
        "heated plate: time constants 40 s and 8 s, direct path 0.5, sensor offset, "
        "drift, AR(1) noise at 25 dB; 2400 samples at 1 s",
    )


def _tanks_rhs(h: Array, q: float) -> Array:
    """Two cascaded tanks with Torricelli outflow: ``dh1 = q - 0.05 sqrt(h1)``,
    ``dh2 = 0.05 sqrt(h1) - 0.04 sqrt(h2)`` (levels in metres, flow in m/s)."""
    o1 = 0.05 * np.sqrt(max(h[0], 0.0))
    o2 = 0.04 * np.sqrt(max(h[1], 0.0))
    return np.array([q - o1, o1 - o2])


def level_control(seed: int = 0) -> Synthetic:
    """A slow level-control loop: cascaded tanks, PI controller, pump saturation.

    The lower tank's level ``y`` is held by a PI controller (``Kp = 0.1``, ``Ti = 60 s``)
    acting on the pump flow ``u``, which saturates at ``[0, 0.06]``; the set point steps
    every 300 s between 0.4 and 0.8 m. The tanks are nonlinear (Torricelli outflow); the
    sensor quantizes to 1 mm and adds white noise of 2 mm. The recorded input is the
    delivered (saturated) flow. ``dt = 2 s``, 1500 samples; four RK4 steps per sample.
    """
    rng = np.random.default_rng(seed)
    dt, n, sub = 2.0, 1500, 4
    setpoints = rng.uniform(0.4, 0.8, size=n * int(dt) // 300 + 1)
    h = np.array([1.0, 0.6])
    integ, u, y = 0.0, np.empty(n), np.empty(n)
    kp, ti = 0.1, 60.0
    for k in range(n):
        meas = np.round(h[1] + 0.002 * rng.standard_normal(), 3)
        r = setpoints[int(k * dt) // 300]
        e = r - meas
        q = float(np.clip(0.03 + kp * (e + integ / ti), 0.0, 0.06))
        if 0.0 < q < 0.06:  # anti-windup: integrate only when the pump is not saturated
            integ += e * dt
        u[k], y[k] = q, meas
        hs = dt / sub
        for _ in range(sub):
            k1 = _tanks_rhs(h, q)
            k2 = _tanks_rhs(h + hs / 2 * k1, q)
            k3 = _tanks_rhs(h + hs / 2 * k2, q)
            k4 = _tanks_rhs(h + hs * k3, q)
            h = h + hs / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return Synthetic(
        u[:, None],
        y[:, None],
        dt,
        "cascaded tanks under PI level control: Torricelli outflow, pump saturation, "
        "set-point steps, 1 mm quantization; 1500 samples at 2 s",
    )


def resonance_long(seed: int = 0, n: int = 86_000) -> Synthetic:
    """A lightly damped resonance over a long, wide-band record (a shaker-like rig).

    Mass-spring-damper ``x'' + 2 zeta w x' + w^2 (x + 0.05 x^3) = w^2 u`` with a 60 Hz
    resonance, ``zeta = 0.03`` and a cubic spring, driven by white noise low-passed at
    200 Hz; ``dt = 1/610 s``; output noise white at 35 dB. The cubic term is not small on
    this record: ``x`` has a standard deviation near 2.2, where it adds about a quarter
    of the linear stiffness (twice it at the peaks), so the resonance moves with the
    amplitude and no linear model of any order simulates the validation part well (fits
    near 20 % for every tool). The nonlinearity and the long record are what linear
    tools meet on such rigs.
    """
    rng = np.random.default_rng(seed)
    dt = 1.0 / 610.0
    w, zeta, sub = 2 * np.pi * 60.0, 0.03, 4
    b, a = _butter2(200.0 * dt * 2)
    u = lfilter(b, a, rng.standard_normal(n))
    u /= np.std(u)
    x, v = 0.0, 0.0
    y = np.empty(n)
    hs = dt / sub

    def acc(x: float, v: float, uk: float) -> float:
        return w * w * (uk - x - 0.05 * x**3) - 2 * zeta * w * v

    for k in range(n):
        y[k] = x
        uk = u[k]
        for _ in range(sub):
            a1, b1 = v, acc(x, v, uk)
            a2, b2 = v + hs / 2 * b1, acc(x + hs / 2 * a1, v + hs / 2 * b1, uk)
            a3, b3 = v + hs / 2 * b2, acc(x + hs / 2 * a2, v + hs / 2 * b2, uk)
            a4, b4 = v + hs * b3, acc(x + hs * a3, v + hs * b3, uk)
            x += hs / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
            v += hs / 6 * (b1 + 2 * b2 + 2 * b3 + b4)
    y = y + _noise_at(y, 35.0, rng.standard_normal(n))
    return Synthetic(
        u[:, None],
        y[:, None],
        dt,
        f"lightly damped 60 Hz resonance (zeta 0.03, cubic spring), band-limited "
        f"noise input, 35 dB; {n} samples at 610 Hz",
    )


def _butter2(wn: float) -> tuple[Array, Array]:
    from scipy.signal import butter

    b, a = butter(2, wn)
    return np.asarray(b), np.asarray(a)


def saturated_stiff(seed: int = 0) -> Synthetic:
    """A stiff plant behind a saturating actuator, recorded command, coloured noise.

    ``G(s) = 80 / (s + 80) * 2.34 / ((s + 0.3)^2 + 1.5^2)`` (a fast real pole two decades
    above a lightly damped pair); the recorded input is the commanded value, a multisine
    of 0.01-5 Hz with random phases, which the actuator clips at 80 % of its peak (the
    linear tools see the command, not the delivered input). AR(1) output noise (pole 0.9)
    at 30 dB. ``dt = 0.01 s``, 6000 samples.
    """
    rng = np.random.default_rng(seed)
    dt, n = 0.01, 6000
    t = dt * np.arange(n)
    f = np.arange(1, 501) / (n * dt)
    f = f[(f >= 0.01) & (f <= 5.0)]
    phases = rng.uniform(0, 2 * np.pi, f.size)
    u = np.sin(2 * np.pi * f[None, :] * t[:, None] + phases).sum(axis=1)
    u /= np.std(u)
    delivered = np.clip(u, -0.8 * np.max(np.abs(u)), 0.8 * np.max(np.abs(u)))
    A = np.array([[-80.0, 0.0, 0.0], [0.0, -0.3, 1.5], [0.0, -1.5, -0.3]])
    B = np.array([[80.0], [0.0], [0.0]])
    A[2, 0] = 2.34 / 1.5  # the fast state drives the pair
    C = np.array([0.0, 1.0, 0.0])
    y = _lsim(A, B, C, 0.0, delivered, dt)
    y = y + _noise_at(y, 30.0, _coloured(rng, n, 0.9))
    return Synthetic(
        u[:, None],
        y[:, None],
        dt,
        "stiff plant (pole -80, pair -0.3 +- 1.5i) behind an actuator clipping the "
        "commanded multisine at 80 % of its peak, AR(1) noise at 30 dB; 6000 samples at "
        "0.01 s",
    )


#: The measured-like records by name.
GENERATORS: dict[str, Callable[[int], Synthetic]] = {
    "thermal-direct": thermal_direct,
    "level-control": level_control,
    "resonance-long": resonance_long,
    "saturated-stiff": saturated_stiff,
}
