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
    r"""A lightly damped SISO second-order system.

    Returns
    -------
    A : ndarray, shape (2, 2)
        ``[[0, 1], [-4, -0.8]]``.
    B : ndarray, shape (2, 1)
        ``[0; 1]``.
    C : ndarray, shape (1, 2)
        ``[1, 0]``.
    D : ndarray, shape (1, 1)
        Zero.

    Notes
    -----
    Eigenvalues :math:`-0.4 \pm j\sqrt{3.84} = -0.4 \pm 1.9596j`: natural frequency
    2 rad/s, damping 0.2, so the resonance is clear in a Bode plot and the slow envelope
    (time constant 2.5 s) tests a method's low-frequency accuracy.

    Examples
    --------
    >>> import numpy as np
    >>> A, B, C, D = second_order()
    >>> np.round(np.linalg.eigvals(A), 4)
    array([-0.4+1.9596j, -0.4-1.9596j])
    """
    A = np.array([[0.0, 1.0], [-4.0, -0.8]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[1.0, 0.0]])
    D = np.zeros((1, 1))
    return A, B, C, D


def pbsid_example() -> tuple[Array, Array, Array, Array, Array]:
    r"""The PBSID toolbox's fourth-order 2x2 discrete example.

    Returns
    -------
    A : ndarray, shape (4, 4)
        Two rotation blocks with eigenvalues :math:`0.67 \pm 0.67j` and
        :math:`-0.67 \pm 0.67j` (modulus 0.9475).
    B : ndarray, shape (4, 2)
        Input matrix.
    C : ndarray, shape (2, 4)
        Output matrix.
    D : ndarray, shape (2, 2)
        Zero.
    K : ndarray, shape (4, 2)
        Innovation gain.

    Notes
    -----
    The closed-loop example shipped with the PBSID toolbox (van Wingerden), a standard
    test of closed-loop subspace identification: :func:`simulate_pbsid_closed_loop`.
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
    """Simulate ``x_{k+1} = A x_k + B u_k``, ``y_k = C x_k + D u_k``.

    Parameters
    ----------
    A : ndarray, shape (n, n)
        State matrix.
    B : ndarray, shape (n, m)
        Input matrix.
    C : ndarray, shape (l, n)
        Output matrix.
    D : ndarray, shape (l, m)
        Feedthrough.
    u : array_like, shape (Ns, m)
        Input sequence.
    x0 : array_like, shape (n,), optional
        Initial state (default 0).

    Returns
    -------
    ndarray, shape (Ns, l)
        The output.

    Examples
    --------
    >>> import numpy as np
    >>> y = simulate_discrete(np.array([[0.5]]), np.eye(1), np.eye(1), np.zeros((1, 1)),
    ...                       np.array([[1.0], [0.0], [0.0]]))
    >>> y.ravel().tolist()  # the impulse response 0, 1, 0.5
    [0.0, 1.0, 0.5]
    """
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
    """Closed-loop data of :func:`pbsid_example` under static output feedback.

    ``x_{k+1} = A x_k + B u_k + K e_k``, ``y_k = C x_k + e_k``, ``u = r - F y`` with
    ``F = feedback * I``; ``r`` and ``e`` white Gaussian, zero initial state.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of ``r`` and ``e``.
    N : int, optional
        Number of samples.
    noise_std : float, optional
        Standard deviation of ``e`` (``r`` has unit variance).
    feedback : float, optional
        The static gain of the controller.

    Returns
    -------
    dict of str to ndarray
        ``t`` (``0 .. N-1``, shape ``(N,)``), and ``u``, ``y``, ``r``, ``e``, each of shape
        ``(N, 2)``.

    Notes
    -----
    Because the controller is static, ``u_k`` depends on ``e_k``: identify with
    ``feedthrough=False`` (a direct term would explain the noise through the loop).

    Examples
    --------
    >>> import numpy as np
    >>> data = simulate_pbsid_closed_loop(np.random.default_rng(0), N=100)
    >>> data["u"].shape, bool(np.allclose(data["u"], data["r"] - 0.25 * data["y"]))
    ((100, 2), True)
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

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix.
    B : array_like, shape (n, m)
        Input matrix.
    C : array_like, shape (l, n)
        Output matrix.
    D : array_like, shape (l, m), or None
        Feedthrough (default zeros).
    t : array_like, shape (Ns,)
        Uniform sample times; use :meth:`hdpbsid.StateSpaceModel.simulate` for non-uniform
        ones.
    u : array_like, shape (Ns, m)
        Input, ``u[k]`` held on ``[t_k, t_{k+1})``.
    x0 : array_like, shape (n,), optional
        Initial state (default 0).

    Returns
    -------
    ndarray, shape (Ns, l)
        The output, exact at the samples (:func:`hdpbsid.models.conversion.c2d`).

    Raises
    ------
    ValueError
        If ``t`` is not uniform, or the shapes disagree.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(5) * 0.5
    >>> y = simulate_zoh([[-1.0]], [[1.0]], [[1.0]], None, t, np.ones(5))
    >>> bool(np.allclose(y[:, 0], 1 - np.exp(-t)))  # a held step is exact
    True
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

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of the levels.
    t : array_like, shape (Ns,)
        Sample times.
    hold : float
        Duration of each level; level ``i`` applies on ``[t_0 + i hold, t_0 + (i + 1)
        hold)``.
    channels : int, optional
        Number of independent channels.
    std : float, optional
        Standard deviation of the levels.

    Returns
    -------
    ndarray, shape (Ns, channels)
        The signal.

    Raises
    ------
    ValueError
        If ``hold`` is not positive.

    Examples
    --------
    >>> import numpy as np
    >>> u = random_steps(np.random.default_rng(0), np.arange(10) * 0.1, hold=0.5)
    >>> len(np.unique(u))  # two levels of 0.5 time units each
    2
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
    r"""Add white Gaussian measurement noise at a given signal-to-noise ratio.

    Parameters
    ----------
    y : array_like, shape (Ns, l) or (Ns,)
        Noise-free signal.
    snr_db : float
        Signal-to-noise ratio in dB, on signal *power* (mean square, not variance).
    rng : numpy.random.Generator
        Source of the noise.
    per_channel : bool, optional
        One standard deviation per channel (default), else one from the mean power over
        all channels.

    Returns
    -------
    y_noisy : ndarray
        ``y + noise``, with the shape of ``y``.
    noise : ndarray
        The noise added.

    Raises
    ------
    ValueError
        If ``snr_db`` is not finite.

    Notes
    -----
    Channel ``i`` gets noise of standard deviation
    :math:`\sigma_i = \sqrt{\overline{y_i^2}}\; 10^{-\mathrm{SNR_{dB}}/20}`, so that
    :math:`\mathrm{SNR_{dB}} = 10 \log_{10}(\overline{y_i^2} / \sigma_i^2)`.

    Examples
    --------
    >>> import numpy as np
    >>> y = np.ones((100_000, 1))
    >>> _, e = add_noise(y, 20.0, np.random.default_rng(0))
    >>> round(float(10 * np.log10(np.mean(y**2) / np.var(e))), 1)
    20.0
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
