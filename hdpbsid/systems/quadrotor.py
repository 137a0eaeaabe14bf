"""Quadrotor pitch benchmark (ANT-X drone at hover) in its closed loop.

The pitch axis of the ANT-X quadrotor (the drone of the thesis's §6 experiment): states
``[u, q, theta]`` (forward velocity, pitch rate, pitch angle), input the (normalised)
pitching moment ``delta``::

    A = [[Xu, Xq, -g], [Mu, Mq, 0], [0, 1, 0]],   B = [[Xd], [Md], [0]]

with ``Xu = -0.1068, Xq = 0.1192, Mu = -5.9755, Mq = -2.6478, Xd = -10.1647,
Md = 450.7085, g = 9.81``.  Open loop the airframe is unstable (eigenvalues
``-2.92 +- 3.24i`` and ``+3.08``), so data come from a closed loop:

* attitude P: ``q_ref = K_theta (theta_ref - theta_meas)``, ``K_theta = 12``;
* pitch-rate PID on ``e_q = q_ref - q_meas``: ``Kp = 0.09, Ki = 0.21, Kd = 0.0016`` with
  the derivative filtered as ``Kd N s / (s + N)``, ``N = 100``;
* optional velocity PI on top: ``theta_ref = -(Kp_v e_u + Ki_v int e_u)``,
  ``e_u = u_ref - u``, ``(Kp_v, Ki_v) = (0.5, 0.04)`` (the minus sign because a nose-down
  attitude accelerates forward: ``du/dt = ... - g theta``);
* the excitation is added to the moment command, the sum saturated to ``+-1``;
* the controller runs at 250 Hz (``Ts = 0.004`` s): it samples the noisy sensors at
  ``t_k``, and its moment is held (ZOH) on ``[t_k, t_k + Ts)``.

Discretisation of the controller (the usual PX4-style implementation): integrators by
forward Euler, ``I_{k+1} = I_k + Ts e_k``; the filtered derivative by backward Euler,
``d_k = (d_{k-1} + Kd N (e_k - e_{k-1})) / (1 + N Ts)`` (stable for any ``N Ts``; at
``N Ts = 0.4`` the bilinear form would also do, backward Euler avoids its ringing).

The plant is propagated *exactly* between controller samples: ``x_{k+1} = Phi x_k +
Gamma delta_k`` with ``[[Phi, Gamma], [0, I]] = expm([[A, B], [0, 0]] Ts)``.  Sensor
noise is white Gaussian on ``q`` and ``theta`` (and on ``u`` / ``a_x`` when they are
chosen as outputs) at a requested SNR; see :func:`simulate_pitch_closed_loop` for the
definition.  The identified input is the total (applied) moment; outputs ``q`` and
``theta`` (or ``a_x = Xu u + Xq q + Xd delta``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

__all__ = [
    "PITCH_PARAMETERS",
    "CONTROLLER_DEFAULTS",
    "OUTPUT_NAMES",
    "PitchData",
    "pitch_model",
    "pitch_output_matrices",
    "pitch_excitation",
    "simulate_pitch_closed_loop",
    "hermite_sweep_excitation",
]

Array = NDArray[np.float64]

#: Stability and control derivatives of the ANT-X pitch model (module docstring).
PITCH_PARAMETERS: dict[str, float] = {
    "Xu": -0.1068,
    "Xq": 0.1192,
    "Mu": -5.9755,
    "Mq": -2.6478,
    "Xd": -10.1647,
    "Md": 450.7085,
    "g": 9.81,
}

#: Controller of the module docstring: attitude P over rate PID, velocity PI, saturation, 250 Hz.
CONTROLLER_DEFAULTS: dict[str, float] = {
    "k_theta": 12.0,
    "kp_q": 0.09,
    "ki_q": 0.21,
    "kd_q": 0.0016,
    "n_filter": 100.0,
    "kp_u": 0.5,
    "ki_u": 0.04,
    "saturation": 1.0,
    "rate_hz": 250.0,
}

#: Output names accepted by :func:`pitch_output_matrices` (``u`` is the forward velocity,
#: ``q_dot`` the angular acceleration ``Mu u + Mq q + Md delta``, the thesis, §6).
OUTPUT_NAMES: tuple[str, ...] = ("u", "q", "theta", "a_x", "q_dot")


def pitch_model() -> tuple[Array, Array, Array, Array]:
    r"""Open-loop pitch model with all three states as outputs.

    Returns
    -------
    A : ndarray, shape (3, 3)
        ``[[Xu, Xq, -g], [Mu, Mq, 0], [0, 1, 0]]`` for the states ``[u, q, theta]``
        (:data:`PITCH_PARAMETERS`).
    B : ndarray, shape (3, 1)
        ``[[Xd], [Md], [0]]``, the normalised pitching moment's entry.
    C : ndarray, shape (3, 3)
        The identity.
    D : ndarray, shape (3, 1)
        Zero.

    Notes
    -----
    The airframe is unstable: eigenvalues :math:`-2.92 \pm 3.24j` and :math:`+3.08` (to three
    significant digits; checked in ``tests/hdpbsid/systems/test_quadrotor.py``), which is
    why its data come from the closed loop of :func:`simulate_pitch_closed_loop`.

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import pitch_model
    >>> A, B, C, D = pitch_model()
    >>> bool(np.max(np.linalg.eigvals(A).real) > 0)  # unstable in open loop
    True
    """
    p = PITCH_PARAMETERS
    A = np.array(
        [
            [p["Xu"], p["Xq"], -p["g"]],
            [p["Mu"], p["Mq"], 0.0],
            [0.0, 1.0, 0.0],
        ]
    )
    B = np.array([[p["Xd"]], [p["Md"]], [0.0]])
    return A, B, np.eye(3), np.zeros((3, 1))


def pitch_output_matrices(outputs: Any = ("q", "theta")) -> tuple[Array, Array, tuple[str, ...]]:
    """Output rows ``(C, D)`` of the chosen measured signals.

    Parameters
    ----------
    outputs : str or sequence of str, optional
        Names from :data:`OUTPUT_NAMES`: ``u`` (forward velocity), ``q`` (pitch rate),
        ``theta`` (pitch angle), ``a_x = Xu u + Xq q + Xd delta`` (the accelerometer:
        specific force, so no gravity term), ``q_dot = Mu u + Mq q + Md delta`` (the
        angular acceleration).

    Returns
    -------
    C : ndarray, shape (l, 3)
        Output matrix.
    D : ndarray, shape (l, 1)
        Feedthrough (non-zero for the accelerations).
    names : tuple of str
        The outputs, in order.

    Raises
    ------
    TypeError
        If ``outputs`` is not a string or a sequence.
    ValueError
        If it is empty, names an unknown signal or repeats one.

    Examples
    --------
    >>> C, D, names = pitch_output_matrices(("q", "a_x"))
    >>> C.shape, D.ravel().tolist(), names
    ((2, 3), [0.0, -10.1647], ('q', 'a_x'))
    """
    if isinstance(outputs, str):
        outputs = (outputs,)
    try:
        names = tuple(outputs)
    except TypeError as exc:
        raise TypeError(
            f"outputs must be a sequence of names from {OUTPUT_NAMES}, got {outputs!r}"
        ) from exc
    if not names:
        raise ValueError(f"outputs must name at least one of {OUTPUT_NAMES}, got ()")
    bad = [o for o in names if o not in OUTPUT_NAMES]
    if bad:
        raise ValueError(f"outputs must be names from {OUTPUT_NAMES}, got unknown {bad}")
    if len(set(names)) != len(names):
        raise ValueError(f"outputs must not repeat a name, got {names}")
    p = PITCH_PARAMETERS
    rows = {
        "u": ([1.0, 0.0, 0.0], 0.0),
        "q": ([0.0, 1.0, 0.0], 0.0),
        "theta": ([0.0, 0.0, 1.0], 0.0),
        "a_x": ([p["Xu"], p["Xq"], 0.0], p["Xd"]),
        "q_dot": ([p["Mu"], p["Mq"], 0.0], p["Md"]),
    }
    C = np.array([rows[o][0] for o in names])
    D = np.array([[rows[o][1]] for o in names])
    return C, D, names


def pitch_excitation(
    kind: str,
    t: Array,
    amplitude: float = 0.05,
    f0: float = 1.0,
    f1: float = 4.0,
    pulse: float = 0.1,
    period: float = 2.0,
) -> Array:
    r"""Excitation added to the moment command: a sine sweep or a 3211 multistep.

    Parameters
    ----------
    kind : {"sweep", "3211"}
        ``"sweep"``: the linear chirp
        :math:`a \sin\bigl(2\pi (f_0 t + (f_1 - f_0) t^2 / (2T))\bigr)` over the record
        ``[0, T]``; ``"3211"``: the multistep of widths ``3, 2, 1, 1`` x ``pulse`` with
        signs ``+, -, +, -``, repeated every ``period`` seconds, starting at ``period / 2``.
    t : array_like, shape (Ns,)
        The controller sample times.
    amplitude : float, optional
        Peak of the excitation (normalised moment).
    f0, f1 : float, optional
        Start and end frequencies of the sweep (Hz).
    pulse : float, optional
        Unit width of the 3211 (s).
    period : float, optional
        Repetition period of the 3211 (s), at least ``7 pulse``.

    Returns
    -------
    ndarray, shape (Ns,)
        The excitation.

    Raises
    ------
    ValueError
        On an unknown ``kind``, or a 3211 with ``pulse <= 0`` or ``period < 7 pulse``.

    Examples
    --------
    >>> import numpy as np
    >>> e = pitch_excitation("3211", np.arange(20) * 0.1, amplitude=1.0, pulse=0.1)
    >>> e[8:19].tolist()  # from t = period / 2 = 1 s: widths 3, 2, 1, 1 pulses
    [0.0, 0.0, 1.0, 1.0, 1.0, -1.0, -1.0, 1.0, -1.0, 0.0, 0.0]
    """
    t = np.asarray(t, dtype=float)
    tt = t - t[0]
    if kind == "sweep":
        T = max(float(tt[-1]), np.finfo(float).tiny)
        phase = 2.0 * np.pi * (f0 * tt + 0.5 * (f1 - f0) * tt**2 / T)
        return amplitude * np.sin(phase)
    if kind == "3211":
        if pulse <= 0 or period < 7 * pulse:
            raise ValueError(
                f"a 3211 needs pulse > 0 and period >= 7 pulse, got pulse={pulse}, period={period}"
            )
        local = np.mod(tt - period / 2.0, period)
        started = tt >= period / 2.0
        edges = np.array([0.0, 3.0, 5.0, 6.0, 7.0]) * pulse
        signs = np.array([1.0, -1.0, 1.0, -1.0])
        out = np.zeros_like(tt)
        for i in range(4):
            on = started & (local >= edges[i] - 1e-12) & (local < edges[i + 1] - 1e-12)
            out[on] = amplitude * signs[i]
        return out
    raise ValueError(f"excitation must be 'sweep', '3211' or an array, got {kind!r}")


@dataclass
class PitchData:
    """One closed-loop flight record, sampled at the controller rate.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Sample times (s) from 0.
    u : ndarray, shape (Ns, 1)
        The total applied moment after saturation: the input to identify from.
    y : ndarray, shape (Ns, l)
        The measured (noisy) chosen outputs.
    y_clean : ndarray, shape (Ns, l)
        Their noise-free values in the same (noisy) run.
    q, theta, a_x : ndarray, shape (Ns,)
        Measured pitch rate, pitch angle and longitudinal acceleration.
    q_clean, theta_clean, a_x_clean : ndarray, shape (Ns,)
        Their noise-free values.
    x_clean : ndarray, shape (Ns, 3)
        Noise-free states ``[u, q, theta]``.
    excitation : ndarray, shape (Ns,)
        The excitation added to the moment command.
    command : ndarray, shape (Ns,)
        The moment command before saturation.
    saturated : ndarray of bool, shape (Ns,)
        Whether the command hit the saturation.
    A, B, C, D : ndarray
        The true open-loop model for the chosen ``outputs``.
    outputs : tuple of str
        The chosen outputs.
    noise_std : dict of str to float, optional
        Sensor noise standard deviation per measured signal.
    options : dict, optional
        Every setting used.

    Attributes
    ----------
    saturation_fraction : float
        Fraction of samples whose command hit the saturation.
    true_eigenvalues : ndarray of complex
        Open-loop eigenvalues of ``A``, what identification should recover.
    """

    t: Array
    u: Array
    y: Array
    y_clean: Array
    q: Array
    theta: Array
    a_x: Array
    q_clean: Array
    theta_clean: Array
    a_x_clean: Array
    x_clean: Array
    excitation: Array
    command: Array
    saturated: NDArray[np.bool_]
    A: Array
    B: Array
    C: Array
    D: Array
    outputs: tuple[str, ...]
    noise_std: dict[str, float] = field(default_factory=dict)
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def saturation_fraction(self) -> float:
        """Fraction of controller samples whose moment command hit the saturation."""
        return float(np.mean(self.saturated))

    @property
    def true_eigenvalues(self) -> NDArray[np.complex128]:
        """Open-loop eigenvalues of ``A`` (what identification should recover)."""
        return np.linalg.eigvals(self.A)


def _loop_gains(ctrl: dict[str, float]) -> tuple[float, ...]:
    """``(ts, k_theta, kp_q, ki_q, kp_u, ki_u, saturation, d_gain, d_pole)`` of the
    controller: the sample time and the gains, the filtered derivative discretised by the
    backward Euler rule (``d_k = d_pole d_{k-1} + d_gain (e_k - e_{k-1})``)."""
    ts = 1.0 / ctrl["rate_hz"]
    k_th, kp, ki, kd, nf = (ctrl[k] for k in ("k_theta", "kp_q", "ki_q", "kd_q", "n_filter"))
    d_gain = kd * nf / (1.0 + nf * ts)
    d_pole = 1.0 / (1.0 + nf * ts)
    return ts, k_th, kp, ki, ctrl["kp_u"], ctrl["ki_u"], ctrl["saturation"], d_gain, d_pole


def _run_loop(
    Phi: Array,
    Gam: Array,
    exc: Array,
    noise_q: Array,
    noise_th: Array,
    ctrl: dict[str, float],
    velocity_loop: bool,
    u_ref: float,
    x0: Array,
) -> tuple[Array, Array, Array]:
    """The sampled closed loop; returns states ``x_k``, commands and applied moments."""
    ns = exc.shape[0]
    ts, k_th, kp, ki, kp_u, ki_u, sat, d_gain, d_pole = _loop_gains(ctrl)
    X = np.empty((ns, 3))
    cmd = np.empty(ns)
    mom = np.empty(ns)
    # plain Python floats in the loop (the same IEEE operations in the same order as
    # with numpy scalars, so the same numbers, at a fraction of the per-step overhead)
    x0_, x1_, x2_ = (float(v) for v in x0)
    i_q = 0.0
    i_u = 0.0
    d = 0.0
    e_prev = None
    (p00, p01, p02), (p10, p11, p12), (p20, p21, p22) = Phi.tolist()
    g0, g1, g2 = (float(v) for v in Gam)
    exc_l, nq_l, nth_l = (np.asarray(v, dtype=float).tolist() for v in (exc, noise_q, noise_th))
    for k in range(ns):
        X[k] = (x0_, x1_, x2_)
        q_m = x1_ + nq_l[k]
        th_m = x2_ + nth_l[k]
        if velocity_loop:
            e_u = u_ref - x0_
            th_ref = -(kp_u * e_u + ki_u * i_u)
            i_u += ts * e_u
        else:
            th_ref = 0.0
        q_ref = k_th * (th_ref - th_m)
        e_q = q_ref - q_m
        if e_prev is not None:
            d = d_pole * d + d_gain * (e_q - e_prev)
        e_prev = e_q
        c = kp * e_q + ki * i_q + d + exc_l[k]
        i_q += ts * e_q
        cmd[k] = c
        m = min(max(c, -sat), sat)
        mom[k] = m
        x0_, x1_, x2_ = (
            p00 * x0_ + p01 * x1_ + p02 * x2_ + g0 * m,
            p10 * x0_ + p11 * x1_ + p12 * x2_ + g1 * m,
            p20 * x0_ + p21 * x1_ + p22 * x2_ + g2 * m,
        )
        # "not (|x| <= 1e6)" is also true for NaN
        if not (abs(x0_) <= 1e6 and abs(x1_) <= 1e6 and abs(x2_) <= 1e6):
            raise ValueError(
                f"the closed loop diverged at t = {k * ts:.3f} s (|x| > 1e6): check the "
                f"controller gains and the excitation amplitude"
            )
    return X, cmd, mom


def simulate_pitch_closed_loop(
    rng: np.random.Generator,
    duration: float = 30.0,
    snr_db: float | None = 20.0,
    excitation: str | Any = "sweep",
    outputs: Any = ("q", "theta"),
    amplitude: float = 0.05,
    velocity_loop: bool = False,
    u_ref: float = 0.0,
    x0: Any | None = None,
    controller: dict[str, float] | None = None,
    f0: float = 1.0,
    f1: float = 4.0,
    pulse: float = 0.1,
    period: float = 2.0,
) -> PitchData:
    r"""Simulate the ANT-X pitch dynamics in its cascade loop (module docstring).

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws the sensor noise.
    duration : float, optional
        Seconds at the controller rate: ``Ns = round(duration * 250) + 1`` samples from 0.
    snr_db : float or None, optional
        Sensor signal-to-noise ratio in dB (``None``: no noise; Notes).
    excitation : {"sweep", "3211"} or array_like, shape (Ns,), optional
        Added to the moment command (:func:`pitch_excitation`).
    outputs : sequence of str, optional
        Names from :data:`OUTPUT_NAMES` (:func:`pitch_output_matrices`).
    amplitude : float, optional
        Peak of the built-in excitation.
    velocity_loop : bool, optional
        Close the outer velocity PI loop too.
    u_ref : float, optional
        Its forward-velocity reference.
    x0 : array_like, shape (3,), optional
        Initial state ``[u, q, theta]`` (default 0, hover).
    controller : dict of str to float, optional
        Overrides entries of :data:`CONTROLLER_DEFAULTS`.
    f0, f1 : float, optional
        Band of the sweep (Hz).
    pulse, period : float, optional
        Shape of the 3211 (s).

    Returns
    -------
    PitchData
        ``data.u`` and ``data.y`` are what to identify from.

    Raises
    ------
    TypeError
        If ``rng`` is not a :class:`numpy.random.Generator`.
    ValueError
        On an unknown controller key, a non-positive ``duration``, a non-finite
        ``snr_db``, an excitation array of the wrong length or not finite, an ``x0`` of the
        wrong size, unknown outputs, or a loop that diverges.

    Notes
    -----
    The SNR is on signal power (mean square, as :func:`hdpbsid.systems.add_noise`): a
    noise-free run of the same loop gives each measured signal's power :math:`P`, and the
    sensor noise has standard deviation :math:`\sqrt P\,10^{-\mathrm{SNR}/20}`.  The noise
    then circulates through the controller, so the noisy run's own clean signals differ
    slightly from the noise-free run's; ``y_clean`` are the clean signals *of the noisy
    run*.

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import simulate_pitch_closed_loop
    >>> data = simulate_pitch_closed_loop(np.random.default_rng(0), duration=2.0)
    >>> data.u.shape, data.y.shape, data.outputs
    ((501, 1), (501, 2), ('q', 'theta'))
    """
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    ctrl = _controller(controller)
    if not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a positive number of seconds, got {duration}")
    if snr_db is not None and not np.isfinite(snr_db):
        raise ValueError(f"snr_db must be finite or None, got {snr_db}")
    C, D, names = pitch_output_matrices(outputs)
    ts = 1.0 / ctrl["rate_hz"]
    ns = int(round(duration / ts)) + 1
    t = np.arange(ns) * ts
    shape = {"f0": f0, "f1": f1, "pulse": pulse, "period": period}
    if isinstance(excitation, str):
        exc = pitch_excitation(excitation, t, amplitude, **shape)
        exc_name = excitation
    else:
        exc = _excitation_array(excitation, ns, duration, ctrl["rate_hz"])
        exc_name = "array"
    xinit = _initial_state(x0)
    A, B, Phi, Gam = _sampled_plant(ts)
    loop = (ctrl, velocity_loop, u_ref, xinit)
    noise_std, draws = _sensor_noise(rng, snr_db, names, Phi, Gam, exc, loop)
    nq = noise_std["q"] * draws["q"]
    nth = noise_std["theta"] * draws["theta"]
    X, cmd, mom = _run_loop(Phi, Gam, exc, nq, nth, *loop)
    meas, clean = _measurements(X, mom, noise_std, draws, nq, nth)
    options = {
        "duration": float(duration),
        "snr_db": snr_db,
        "snr_definition": "mean-square power of the noise-free run / noise variance",
        "excitation": exc_name,
        "amplitude": amplitude if exc_name != "array" else None,
        **shape,
        "velocity_loop": velocity_loop,
        "u_ref": u_ref,
        "controller": ctrl,
        "sample_time": ts,
        "x0": xinit,
        "plant_discretisation": "exact ZOH (matrix exponential) between controller samples",
    }
    plant = (A, B, C, D)
    return _pitch_data(t, exc, (X, cmd, mom), meas, clean, plant, names, noise_std, options)


def _controller(controller: dict[str, float] | None) -> dict[str, float]:
    """:data:`CONTROLLER_DEFAULTS` with the entries of ``controller`` (floats) in place."""
    ctrl = dict(CONTROLLER_DEFAULTS)
    if controller is not None:
        unknown = set(controller) - set(ctrl)
        if unknown:
            raise ValueError(
                f"controller has unknown key(s) {sorted(unknown)}; known: {sorted(ctrl)}"
            )
        ctrl.update({k: float(v) for k, v in controller.items()})
    return ctrl


def _excitation_array(excitation: Any, ns: int, duration: float, rate_hz: float) -> Array:
    """An excitation given as samples: ``ns`` finite numbers."""
    exc = np.asarray(excitation, dtype=float).reshape(-1)
    if exc.shape[0] != ns:
        raise ValueError(
            f"excitation array must have Ns = {ns} samples (duration {duration} s at "
            f"{rate_hz:g} Hz), got {exc.shape[0]}"
        )
    if not np.all(np.isfinite(exc)):
        raise ValueError("excitation must be finite (no NaN/inf)")
    return exc


def _initial_state(x0: Any | None) -> Array:
    """The initial state ``[u, q, theta]``: zeros (hover) when ``None``."""
    xinit = np.zeros(3) if x0 is None else np.asarray(x0, dtype=float).reshape(-1)
    if xinit.shape != (3,):
        raise ValueError(f"x0 must have 3 entries [u, q, theta], got shape {xinit.shape}")
    return xinit


def _sampled_plant(ts: float) -> tuple[Array, Array, Array, Array]:
    """``(A, B, Phi, Gam)``: the pitch model and its exact zero-order-hold sampling over
    one controller step ``ts`` (the exponential of the augmented matrix)."""
    A, B, _, _ = pitch_model()
    n, m = 3, 1
    M = np.zeros((n + m, n + m))
    M[:n, :n] = A * ts
    M[:n, n:] = B * ts
    E = expm(M)
    return A, B, E[:n, :n], E[:n, n]


def _sensor_noise(
    rng: np.random.Generator,
    snr_db: float | None,
    names: tuple[str, ...],
    Phi: Array,
    Gam: Array,
    exc: Array,
    loop: tuple[dict[str, float], bool, float, Array],
) -> tuple[dict[str, float], dict[str, Array]]:
    """Each sensor's noise standard deviation (from the noise-free run at ``snr_db``) and
    its unit draws; zeros without noise."""
    ns = exc.shape[0]
    zero = np.zeros(ns)
    sensors = ("u", "q", "theta", "a_x", "q_dot")
    noise_std = {k: 0.0 for k in sensors}
    if snr_db is None:
        return noise_std, {k: zero for k in sensors}
    p = PITCH_PARAMETERS
    Xc, _, mc = _run_loop(Phi, Gam, exc, zero, zero, *loop)
    axc = p["Xu"] * Xc[:, 0] + p["Xq"] * Xc[:, 1] + p["Xd"] * mc
    qdc = p["Mu"] * Xc[:, 0] + p["Mq"] * Xc[:, 1] + p["Md"] * mc
    scale = 10.0 ** (-snr_db / 20.0)
    for name, sig in (
        ("u", Xc[:, 0]),
        ("q", Xc[:, 1]),
        ("theta", Xc[:, 2]),
        ("a_x", axc),
        ("q_dot", qdc),
    ):
        noise_std[name] = float(np.sqrt(np.mean(sig**2)) * scale)
    # one draw per sensor, in a fixed order, so the same seed gives the same record
    # (q_dot, added later, is drawn last and only when asked for: the other sensors'
    # noise is unchanged by it)
    draws = {k: rng.standard_normal(ns) for k in ("q", "theta", "u", "a_x")}
    draws["q_dot"] = rng.standard_normal(ns) if "q_dot" in names else zero
    return noise_std, draws


def _measurements(
    X: Array,
    mom: Array,
    noise_std: dict[str, float],
    draws: dict[str, Array],
    nq: Array,
    nth: Array,
) -> tuple[dict[str, Array], dict[str, Array]]:
    """The measured and the noise-free sensor signals of the closed-loop run."""
    p = PITCH_PARAMETERS
    ax_clean = p["Xu"] * X[:, 0] + p["Xq"] * X[:, 1] + p["Xd"] * mom
    qd_clean = p["Mu"] * X[:, 0] + p["Mq"] * X[:, 1] + p["Md"] * mom
    meas = {
        "u": X[:, 0] + noise_std["u"] * draws["u"],
        "q": X[:, 1] + nq,
        "theta": X[:, 2] + nth,
        "a_x": ax_clean + noise_std["a_x"] * draws["a_x"],
        "q_dot": qd_clean + noise_std["q_dot"] * draws["q_dot"],
    }
    clean = {"u": X[:, 0], "q": X[:, 1], "theta": X[:, 2], "a_x": ax_clean, "q_dot": qd_clean}
    return meas, clean


def _pitch_data(
    t: Array,
    exc: Array,
    run: tuple[Array, Array, Array],
    meas: dict[str, Array],
    clean: dict[str, Array],
    plant: tuple[Array, Array, Array, Array],
    names: tuple[str, ...],
    noise_std: dict[str, float],
    options: dict[str, Any],
) -> PitchData:
    """The :class:`PitchData` of a run: its states, commands and moments ``run``, the
    sensors measured and noise-free, the plant ``(A, B, C, D)`` and the settings."""
    X, cmd, mom = run
    A, B, C, D = plant
    return PitchData(
        t=t,
        u=mom[:, None],
        y=np.column_stack([meas[o] for o in names]),
        y_clean=np.column_stack([clean[o] for o in names]),
        q=meas["q"],
        theta=meas["theta"],
        a_x=meas["a_x"],
        q_clean=clean["q"],
        theta_clean=clean["theta"],
        a_x_clean=clean["a_x"],
        x_clean=X,
        excitation=exc,
        command=cmd,
        saturated=np.abs(cmd) > options["controller"]["saturation"],
        A=A,
        B=B,
        C=C,
        D=D,
        outputs=names,
        noise_std={k: noise_std[k] for k in dict.fromkeys(("q", "theta", *names))},
        options=options,
    )


def hermite_sweep_excitation(
    t: Any,
    n_terms: int = 300,
    amplitude: float = 0.05,
    f0: float = 1.0,
    f1: float = 4.0,
) -> Array:
    r"""A linear sine sweep projected onto the first ``n_terms`` Hermite functions of the record.

    This is the excitation of the thesis (sec. 5-6): it lies exactly in the span of
    ``n_terms`` Hermite functions (``n_max,u``) and fades to about 0 at the record's ends.

    Parameters
    ----------
    t : array_like, shape (Ns,)
        Increasing sample times.
    n_terms : int, optional
        Number of Hermite functions.
    amplitude : float, optional
        Peak of the sweep before projection.
    f0, f1 : float, optional
        Band of the sweep (Hz).

    Returns
    -------
    ndarray, shape (Ns,)
        The projected sweep reconstructed at ``t``.

    Raises
    ------
    ValueError
        If ``t`` has fewer than 2 samples or is not increasing, or ``n_terms`` is not a
        positive integer.

    Notes
    -----
    The sweep of :func:`pitch_excitation` is projected (:meth:`slbasis.Basis.project`, the
    record filling 90 % of the functions' effective support, as the HD-PBSID basis does).
    The functions reach about :math:`3.6\,n/T` rad/s: over 30 s, 300 terms cover 36 rad/s
    (5.7 Hz) and keep the whole 1-4 Hz sweep; fewer than :math:`2\pi f_1 T / 3.6` terms
    (209 for 4 Hz over 30 s) cut its fast end.
    """
    import slbasis

    t = np.asarray(t, dtype=float).reshape(-1)
    if t.size < 2 or not np.all(np.diff(t) > 0):
        raise ValueError("t must be increasing with at least 2 samples")
    if isinstance(n_terms, bool) or not isinstance(n_terms, int | np.integer) or n_terms < 1:
        raise ValueError(f"n_terms must be a positive integer, got {n_terms!r}")
    sweep = pitch_excitation("sweep", t, amplitude, f0=f0, f1=f1)
    basis = slbasis.basis("hermite", int(n_terms), (float(t[0]), float(t[-1])))
    c = basis.project(t, sweep)
    return np.asarray(basis.reconstruct(c, t), dtype=float).reshape(-1)
