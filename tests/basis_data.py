"""Shared data of the basis-domain method tests.

The second-order benchmark system (``A = [[0, 1], [-4, -0.8]]``, eigenvalues
``-0.4 +- 1.9596i``), simulated exactly for an input linear between samples (FOH, which is
what trapezoid projection assumes), so noise-free errors measure the method, not the data
generator.
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import butter, chirp, filtfilt

from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.systems import add_noise, second_order

A, B, C, D = second_order()
TRUE_EIGS = np.linalg.eigvals(A)


def smooth_knots(rng: np.random.Generator, T: float, dt: float, fc: float = 1.0) -> tuple:
    """Knots ``(tk, xk)`` of a smooth input: white noise low-passed by a 4th-order
    Butterworth at ``fc`` Hz (zero phase), unit std; the input is linear between knots."""
    tk = np.arange(0.0, T + dt / 2, dt)
    b, a = butter(4, fc * 2 * dt)
    x = filtfilt(b, a, rng.standard_normal(tk.size))
    return tk, x / np.std(x)


def make_data(
    seed: int,
    *,
    T: float = 40.0,
    dt: float = 0.01,
    snr: float | None = None,
    x0: list[float] | None = None,
    jitter: float = 0.0,
    kind: str = "smooth",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, u, y)`` of the second-order system; ``jitter`` is the +- fraction of ``dt``."""
    rng = np.random.default_rng(seed)
    tk, xk = smooth_knots(rng, T, dt)
    t = np.arange(0.0, T + dt / 2, dt)
    if jitter:
        t = t + rng.uniform(-jitter, jitter, t.size) * dt
        t[0], t[-1] = 0.0, T
        t = np.sort(t)
    model = StateSpaceModel(A, B, C, D, np.zeros((2, 1)))
    if kind == "chirp":
        u = chirp(t, 0.05, T, 2.0)
        y = model.simulate(t, u[:, None], x0=x0, method="foh")
    elif jitter:
        # exact FOH response on the uniform knot grid refined 4 times (u is linear between
        # knots), then a cubic spline at the jittered times (error ~ (dt/4)^4 |y^(4)|)
        u = np.interp(t, tk, xk)
        tf = np.arange(0.0, T + dt / 8, dt / 4)
        yf = model.simulate(tf, np.interp(tf, tk, xk)[:, None], x0=x0, method="foh")
        y = CubicSpline(tf, yf[:, 0])(t)[:, None]
    else:
        u = np.interp(t, tk, xk)
        y = model.simulate(t, u[:, None], x0=x0, method="foh")
    if snr is not None:
        y, _ = add_noise(y, snr, rng)
    return t, u, y


def eig_error(model: StateSpaceModel) -> float:
    """Largest relative eigenvalue error against the true ``-0.4 +- 1.9596i``."""
    return float(eigenvalue_errors(model.eigenvalues, TRUE_EIGS).max())
