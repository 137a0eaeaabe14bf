"""Linear benchmark systems and their data generators.

Each system is a function returning its state-space matrices; data generators take a
``numpy.random.Generator`` (never global random state).  The quadrotor pitch closed
loop lives in :mod:`hdpbsid.systems.quadrotor`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_signal, check_state_space, check_time, is_uniform
from hdpbsid.models.conversion import c2d

__all__ = [
    "second_order",
    "pbsid_example",
    "simulate_pbsid_closed_loop",
    "simulate_discrete",
    "simulate_zoh",
    "random_steps",
    "add_noise",
]

Array = NDArray[np.float64]


def second_order() -> tuple[Array, Array, Array, Array]:
    """SISO ``A = [[0, 1], [-4, -0.8]]``, ``B = [0; 1]``, ``C = [1, 0]``, ``D = 0``.

    Eigenvalues ``-0.4 +- i sqrt(3.84) = -0.4 +- 1.9596i`` (natural frequency 2 rad/s,
    damping 0.2).
    """
    A = np.array([[0.0, 1.0], [-4.0, -0.8]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[1.0, 0.0]])
    D = np.zeros((1, 1))
    return A, B, C, D


def pbsid_example() -> tuple[Array, Array, Array, Array, Array]:
    """The PBSID toolbox's 4th-order 2x2 discrete example ``(A, B, C, D, K)``.

    Eigenvalues ``0.67 +- 0.67i`` and ``-0.67 +- 0.67i`` (modulus 0.9475).
    """
    A = np.array(
        [
            [0.67, 0.67, 0.0, 0.0],
            [-0.67, 0.67, 0.0, 0.0],
            [0.0, 0.0, -0.67, -0.67],
            [0.0, 0.0, 0.67, -0.67],
        ]
    )
    B = np.array([[0.6598, -0.5256], [1.9698, 0.4845], [4.3171, -0.4879], [-2.6436, -0.3416]])
    C = np.array([[-0.3749, 0.0751, -0.5225, 0.5830], [-0.8977, 0.7543, 0.1159, 0.0982]])
    K = np.array([[-0.6968, -0.1474], [0.1722, 0.5646], [0.6484, -0.4660], [-0.9400, 0.1032]])
    D = np.zeros((2, 2))
    return A, B, C, D, K


def simulate_discrete(
    A: Array, B: Array, C: Array, D: Array, u: Array, x0: Array | None = None
) -> Array:
    """Simulate ``x_{k+1} = A x_k + B u_k``, ``y_k = C x_k + D u_k``; ``u`` is (Ns, m)."""
    u = np.asarray(u, dtype=float)
    n = A.shape[0]
    x = np.zeros(n) if x0 is None else np.asarray(x0, dtype=float).copy()
    X = np.empty((u.shape[0], n))
    Bu = u @ B.T
    for k in range(u.shape[0]):
        X[k] = x
        x = A @ x + Bu[k]
    return X @ C.T + u @ D.T


def simulate_pbsid_closed_loop(
    rng: np.random.Generator,
    N: int = 4000,
    noise_std: float = 1.0,
    feedback: float = 0.25,
) -> dict[str, Array]:
    """Closed-loop data of the toolbox example: ``u = r - F y`` with ``F = feedback * I``.

    ``x_{k+1} = A x_k + B u_k + K e_k``, ``y_k = C x_k + e_k``, ``r`` and ``e`` white
    Gaussian (``r`` unit variance, ``e`` standard deviation ``noise_std``), zero initial
    state, ``N`` samples.  Because the controller is static, ``u_k`` depends on ``e_k``:
    identify with ``feedthrough=False``.  Returns a dict with ``t`` (0..N-1), ``u``,
    ``y``, ``r``, ``e`` (arrays of shape (N, 2)).
    """
    A, B, C, D, K = pbsid_example()
    r = rng.standard_normal((N, 2))
    e = noise_std * rng.standard_normal((N, 2))
    F = feedback * np.eye(2)
    # closed loop: u = r - F (C x + e)
    Acl = A - B @ F @ C
    Bcl = np.hstack([B, K - B @ F])
    Ccl = np.vstack([C, -F @ C])
    Dcl = np.block([[np.zeros((2, 2)), np.eye(2)], [np.eye(2), -F]])
    out = simulate_discrete(Acl, Bcl, Ccl, Dcl, np.hstack([r, e]))
    y, u = out[:, :2], out[:, 2:]
    return {"t": np.arange(N, dtype=float), "u": u, "y": y, "r": r, "e": e}


def simulate_zoh(
    A: Array,
    B: Array,
    C: Array,
    D: Array | None,
    t: Array,
    u: Array,
    x0: Array | None = None,
) -> Array:
    """Exact response of a continuous model to a piecewise-constant (ZOH) input.

    ``u[k]`` is held on ``[t_k, t_{k+1})``; ``t`` must be uniform (use
    :meth:`hdpbsid.StateSpaceModel.simulate` for non-uniform times).  Returns ``y``
    (Ns, l).
    """
    A, B, C, D, _ = check_state_space(A, B, C, D, None)
    t = check_time(t)
    u = check_signal(u, "u", t.shape[0])
    dt = float(t[1] - t[0])
    if not is_uniform(t):  # the package's one uniformity test (hdpbsid.data.checks)
        raise ValueError("t must be uniformly sampled for simulate_zoh")
    Ad, Bd, _, _, _ = c2d(A, B, C, D, None, dt)
    return simulate_discrete(Ad, Bd, C, D, u, x0)


def random_steps(
    rng: np.random.Generator, t: Array, hold: float, channels: int = 1, std: float = 1.0
) -> Array:
    """Random piecewise-constant signal: Gaussian levels held for ``hold`` time units.

    Level ``i`` applies on ``[t_0 + i hold, t_0 + (i + 1) hold)``.  Returns (Ns, channels).
    """
    t = np.asarray(t, dtype=float)
    if hold <= 0:
        raise ValueError(f"hold must be > 0, got {hold}")
    idx = np.floor((t - t[0]) / hold + 1e-9).astype(int)
    levels = std * rng.standard_normal((int(idx[-1]) + 1, channels))
    return levels[idx]


def add_noise(
    y: Array, snr_db: float, rng: np.random.Generator, per_channel: bool = True
) -> tuple[Array, Array]:
    """Add white Gaussian measurement noise at a given signal-to-noise ratio.

    SNR is defined on signal *power* (mean square, not variance):
    ``SNR_dB = 10 log10(mean(y_i^2) / sigma_i^2)``, so each channel ``i`` gets noise of
    standard deviation ``sigma_i = sqrt(mean(y_i^2)) 10^(-SNR_dB / 20)`` (with
    ``per_channel=False`` one sigma from the mean power over all channels).  Returns
    ``(y_noisy, noise)`` with the shape of ``y``.
    """
    y = np.asarray(y, dtype=float)
    if not np.isfinite(snr_db):
        raise ValueError(f"snr_db must be finite, got {snr_db}")
    y2 = y if y.ndim == 2 else y[:, None]
    power = np.mean(y2**2, axis=0)
    if not per_channel:
        power = np.full_like(power, np.mean(power))
    sigma = np.sqrt(power) * 10.0 ** (-snr_db / 20.0)
    noise = rng.standard_normal(y2.shape) * sigma
    noise = noise.reshape(y.shape)
    return y + noise, noise
