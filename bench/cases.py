"""Data sets of the head-to-head benchmark (``bench/peers.py``), one generator per case.

Every generator takes a seed and an SNR and returns a :class:`CaseData` holding an
*estimation* record, an independent *validation* record (a second record drawn from
another seed; for some cases also another input, see the case descriptions), the true
eigenvalues, the order to identify and how the input behaves between samples (which is
how the validation simulation must treat it).  The systems themselves come from
``hdpbsid.systems`` and ``hdpbsid.systems.quadrotor``; only
the stiff third-order system is defined here.  Randomness only through
``numpy.random.default_rng(seed)``.

SNR (dB) is on signal power, as :func:`hdpbsid.systems.add_noise` defines it;
``snr=None`` means noise-free.  The PBSID toolbox example has its own innovation noise
(unit variance, as in the toolbox) and ignores ``snr``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import block_diag, expm, solve_discrete_are
from scipy.signal import butter, chirp, filtfilt

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.systems import (
    add_noise,
    pbsid_example,
    random_steps,
    second_order,
    simulate_pbsid_closed_loop,
    simulate_zoh,
)
from hdpbsid.systems.quadrotor import pitch_excitation, simulate_pitch_closed_loop

Array = NDArray[np.float64]

#: Offset between the seed of an estimation record and that of its validation record.
VALIDATION_SEED_OFFSET = 1_000_003

#: Eigenvalues of the stiff third-order system: a fast real pole two decades above a
#: lightly damped slow pair.
STIFF_EIGENVALUES = np.array([-50.0, -0.5 + 2.0j, -0.5 - 2.0j])


@dataclass
class Record:
    """One experiment: times ``t (Ns,)``, input ``u (Ns, m)``, measured output ``y (Ns, l)``."""

    t: Array
    u: Array
    y: Array


@dataclass
class CaseData:
    """What one benchmark run identifies from and is scored on.

    ``discrete``: the truth is a discrete-time model (sample index as time) and
    eigenvalues are compared in the z-plane; otherwise in the s-plane.
    ``hold``: ``"zoh"`` or ``"foh"``, the inter-sample behaviour of ``u`` under which the
    data were generated exactly (used to simulate models on the validation record).
    ``fit_window``: ``None`` to simulate the whole validation record, else the length
    (time units) of the windows it is cut into (each window with its own least-squares
    initial state) -- needed for an unstable plant, whose free simulation diverges.
    ``uniform``: whether the samples are uniform (discrete-time tools need it).
    ``closed_loop``: whether ``u`` is correlated with the noise through feedback.
    ``options``: keyword arguments a user would pass to the identification for this
    record (e.g. ``feedthrough=True`` when an output has a direct term); ``bench/identify.py``
    passes those a method accepts.
    """

    name: str
    estimation: Record
    validation: Record
    true_eigenvalues: NDArray[np.complex128]
    order: int
    discrete: bool = False
    hold: str = "zoh"
    fit_window: float | None = None
    uniform: bool = True
    closed_loop: bool = False
    options: dict[str, object] = field(default_factory=dict)


def stiff_third_order() -> tuple[Array, Array, Array, Array]:
    """SISO system with eigenvalues ``-50`` and ``-0.5 +- 2i`` (time scales 100x apart).

    Modal form ``A = diag(-50, [[-0.5, 2], [-2, -0.5]])``, ``B = [50, 0, 1]^T``,
    ``C = [1, 1, 0]``, ``D = 0``: the fast mode has DC gain 1, the slow pair
    ``2 / ((s + 0.5)^2 + 4)`` has DC gain 0.47, so both are visible in the output.
    """
    A = np.array([[-50.0, 0.0, 0.0], [0.0, -0.5, 2.0], [0.0, -2.0, -0.5]])
    B = np.array([[50.0], [0.0], [1.0]])
    C = np.array([[1.0, 1.0, 0.0]])
    D = np.zeros((1, 1))
    return A, B, C, D


def smooth_random_input(rng: np.random.Generator, t: Array, cutoff_hz: float = 1.0) -> Array:
    """White Gaussian noise low-passed at ``cutoff_hz`` (4th-order Butterworth, zero
    phase, ``filtfilt``) and scaled to unit standard deviation; ``t`` uniform.  This is
    the random smooth input of ``bench/identify_basis.py``.  Returns ``(Ns,)``."""
    dt = float(t[1] - t[0])
    b, a = butter(4, 2.0 * cutoff_hz * dt)
    u = filtfilt(b, a, rng.standard_normal(t.size))
    return u / np.std(u)


def _noisy(y: Array, snr: float | None, rng: np.random.Generator) -> Array:
    return y if snr is None else add_noise(y, snr, rng)[0]


def _foh_record(
    A: Array,
    B: Array,
    C: Array,
    D: Array,
    t: Array,
    u: Array,
    snr: float | None,
    rng: np.random.Generator,
) -> Record:
    u2 = u.reshape(t.size, -1)
    y = StateSpaceModel(A, B, C, D, np.zeros((A.shape[0], C.shape[0]))).simulate(
        t, u2, method="foh"
    )
    return Record(t, u2, _noisy(y, snr, rng))


def second_order_smooth(
    seed: int, snr: float | None, T: float = 40.0, dt: float = 0.01
) -> CaseData:
    """Second-order system, random smooth input (1 Hz low-passed noise), ``dt = 0.01``,
    40 s, exact FOH response plus white noise; validation: another seed."""
    A, B, C, D = second_order()
    t = np.arange(0.0, T + dt / 2, dt)
    recs = []
    for s in (seed, seed + VALIDATION_SEED_OFFSET):
        rng = np.random.default_rng(s)
        recs.append(_foh_record(A, B, C, D, t, smooth_random_input(rng, t), snr, rng))
    return CaseData("second-order", recs[0], recs[1], np.linalg.eigvals(A), 2, hold="foh")


def second_order_chirp(seed: int, snr: float | None, T: float = 40.0, dt: float = 0.01) -> CaseData:
    """Second-order system, 0.05-2 Hz linear chirp over 40 s at ``dt = 0.01`` (the case
    where discrete-time subspace tools miss the eigenvalues: docs/benchmarks.md); exact FOH
    response plus noise.
    Validation: the random smooth input of :func:`second_order_smooth` (another seed),
    because a second chirp record would differ only in its noise."""
    A, B, C, D = second_order()
    t = np.arange(0.0, T + dt / 2, dt)
    rng = np.random.default_rng(seed)
    est = _foh_record(A, B, C, D, t, chirp(t, 0.05, T, 2.0), snr, rng)
    rng_v = np.random.default_rng(seed + VALIDATION_SEED_OFFSET)
    val = _foh_record(A, B, C, D, t, smooth_random_input(rng_v, t), snr, rng_v)
    return CaseData("chirp", est, val, np.linalg.eigvals(A), 2, hold="foh")


def stiff(seed: int, snr: float | None, T: float = 40.0, dt: float = 0.01) -> CaseData:
    """Stiff third-order system (:func:`stiff_third_order`), random steps held 0.05 s
    (excites the -50 pole), ``dt = 0.01``, 40 s, exact ZOH response plus noise;
    validation: another seed."""
    A, B, C, D = stiff_third_order()
    t = np.arange(0.0, T + dt / 2, dt)
    recs = []
    for s in (seed, seed + VALIDATION_SEED_OFFSET):
        rng = np.random.default_rng(s)
        u = random_steps(rng, t, 0.05)
        recs.append(Record(t, u, _noisy(simulate_zoh(A, B, C, D, t, u), snr, rng)))
    return CaseData("stiff", recs[0], recs[1], STIFF_EIGENVALUES.copy(), 3, hold="zoh")


def nonuniform(seed: int, snr: float | None, T: float = 40.0, n_samples: int = 4001) -> CaseData:
    """Second-order system sampled at ``n_samples`` sorted uniform-random times on
    ``[0, T]`` (endpoints included; mean spacing 0.01); the input is the random smooth
    signal (built on a 0.001 grid, interpolated), linear between samples, and the output
    is the exact FOH response at those times plus noise.  Validation: another seed."""
    A, B, C, D = second_order()
    fine = np.arange(0.0, T + 0.0005, 0.001)
    recs = []
    for s in (seed, seed + VALIDATION_SEED_OFFSET):
        rng = np.random.default_rng(s)
        inner = np.sort(rng.uniform(0.0, T, n_samples - 2))
        t = np.concatenate([[0.0], inner, [T]])
        u = np.interp(t, fine, smooth_random_input(rng, fine))
        recs.append(_foh_record(A, B, C, D, t, u, snr, rng))
    return CaseData(
        "nonuniform", recs[0], recs[1], np.linalg.eigvals(A), 2, hold="foh", uniform=False
    )


def quadrotor(seed: int, snr: float | None, duration: float = 30.0) -> CaseData:
    """Closed-loop quadrotor pitch (``hdpbsid.systems.quadrotor``), 250 Hz, outputs ``q, theta``,
    order 3, 1-4 Hz sweep added to the moment command; validation: a 3211 multistep
    record (another seed), scored on 1 s windows because the open-loop plant is unstable
    (eigenvalue +3.08)."""
    est = simulate_pitch_closed_loop(np.random.default_rng(seed), duration, snr_db=snr)
    val = simulate_pitch_closed_loop(
        np.random.default_rng(seed + VALIDATION_SEED_OFFSET),
        duration,
        snr_db=snr,
        excitation="3211",
    )
    return CaseData(
        "quadrotor",
        Record(est.t, est.u, est.y),
        Record(val.t, val.u, val.y),
        est.true_eigenvalues,
        3,
        hold="zoh",
        fit_window=1.0,
        closed_loop=True,
    )


def pbsid_mimo(seed: int, snr: float | None = None, n_samples: int = 4000) -> CaseData:
    """The PBSID toolbox's closed-loop 2x2 example (discrete, 4th order, ``u = r - 0.25
    y``, white ``r`` and ``e``, 4000 samples); ``snr`` is ignored (the toolbox's unit
    innovation noise).  Times are sample indices (``dt = 1``); eigenvalues compared in the
    z-plane.  Validation: another seed."""
    A = pbsid_example()[0]
    recs = []
    for s in (seed, seed + VALIDATION_SEED_OFFSET):
        d = simulate_pbsid_closed_loop(np.random.default_rng(s), N=n_samples)
        recs.append(Record(d["t"], d["u"], d["y"]))
    return CaseData(
        "pbsid-mimo",
        recs[0],
        recs[1],
        np.linalg.eigvals(A),
        4,
        discrete=True,
        hold="zoh",
        closed_loop=True,
    )


# -- Rao-Garnier ----------------------------------------------------------------------
#: Numerator and denominator of the Rao-Garnier benchmark, highest power first.
RAO_GARNIER_NUM = np.array([-6400.0, 1600.0])
RAO_GARNIER_DEN = np.array([1.0, 5.0, 408.0, 416.0, 1600.0])


def rao_garnier_system() -> tuple[Array, Array, Array, Array]:
    """Real modal realisation of the Rao-Garnier benchmark
    ``G(s) = (-6400 s + 1600) / (s^4 + 5 s^3 + 408 s^2 + 416 s + 1600)``.

    CONTSID's standard continuous-time test system (Rao and Garnier, "Numerical
    illustrations of the relevance of direct continuous-time model identification",
    IFAC World Congress 2002).  The denominator factors exactly as
    ``(s^2 + s + 4)(s^2 + 4 s + 400)``: a pair ``-0.5 +- 1.936i`` (``omega = 2`` rad/s,
    ``zeta = 0.25``) and a pair ``-2 +- 19.90i`` (``omega = 20``, ``zeta = 0.1``), a
    decade apart; the zero ``s = 0.25`` is non-minimum phase; ``G(0) = 1``.  Partial
    fractions ``G = (c_1 s + d_1) / (s^2 + s + 4) + (c_2 s + d_2) / (s^2 + 4 s + 400)``
    (``c, d`` from matching the numerator's coefficients), each term in observable
    companion form ``A_i = [[0, 1], [-b_i, -a_i]]``, ``B_i = [0, 1]^T``,
    ``C_i = [d_i, c_i]``.  ``D = 0``.
    """
    (a1, b1), (a2, b2) = (1.0, 4.0), (4.0, 400.0)
    # (c1 s + d1)(s^2 + a2 s + b2) + (c2 s + d2)(s^2 + a1 s + b1) = -6400 s + 1600,
    # unknowns [c1, d1, c2, d2], rows: coefficients of s^3, s^2, s, 1
    M = np.array(
        [
            [1.0, 0.0, 1.0, 0.0],
            [a2, 1.0, a1, 1.0],
            [b2, a2, b1, a1],
            [0.0, b2, 0.0, b1],
        ]
    )
    c1, d1, c2, d2 = np.linalg.solve(M, [0.0, 0.0, RAO_GARNIER_NUM[0], RAO_GARNIER_NUM[1]])
    A = block_diag([[0.0, 1.0], [-b1, -a1]], [[0.0, 1.0], [-b2, -a2]])
    B = np.array([[0.0], [1.0], [0.0], [1.0]])
    C = np.array([[d1, c1, d2, c2]])
    return A, B, C, np.zeros((1, 1))


def rao_garnier(seed: int, snr: float | None, T: float = 40.0, dt: float = 0.01) -> CaseData:
    """Rao-Garnier benchmark (:func:`rao_garnier_system`), order 4: random binary input
    (levels ``+-1``, a new random sign every 0.05 s), ``dt = 0.01`` s, 40 s, exact ZOH
    response plus white output noise (the benchmark point is SNR 10 dB); validation:
    another seed."""
    A, B, C, D = rao_garnier_system()
    t = np.arange(0.0, T + dt / 2, dt)
    recs = []
    for s in (seed, seed + VALIDATION_SEED_OFFSET):
        rng = np.random.default_rng(s)
        u = np.sign(random_steps(rng, t, 0.05))
        recs.append(Record(t, u, _noisy(simulate_zoh(A, B, C, D, t, u), snr, rng)))
    return CaseData("rao-garnier", recs[0], recs[1], np.linalg.eigvals(A), 4, hold="zoh")


# -- 2x2 MIMO --------------------------------------------------------------------------
#: Eigenvalues of the 2x2 MIMO case: two pairs with damping ratio 0.1, a decade apart.
MIMO_EIGENVALUES = np.array([-0.2 + 2.0j, -0.2 - 2.0j, -2.0 + 20.0j, -2.0 - 20.0j])


def mimo_2x2_system() -> tuple[Array, Array, Array, Array]:
    """Open-loop 2x2 system of order 4 with modes a decade apart.

    Real modal form ``A = diag([[-0.2, 2], [-2, -0.2]], [[-2, 20], [-20, -2]])``
    (eigenvalues ``-0.2 +- 2i`` and ``-2 +- 20i``, both with damping ratio
    ``0.2 / sqrt(4.04) = 0.0995``), ``B = [[0, 1], [1, 0.5], [0, 20], [20, -10]]`` (the
    fast block's input gain is ten times larger so that both modes have comparable
    static gains, ``~|b| / |lambda|``), ``C = [[1, 0, 1, 0], [0, 1, -0.5, 1]]``, ``D = 0``.
    Every mode is controllable from each input alone and observable from each output
    alone (each block's part of every column of ``B`` and row of ``C`` is non-zero, and
    a rotation block has no real eigenvector), so all four channels see both modes.
    """
    A = block_diag([[-0.2, 2.0], [-2.0, -0.2]], [[-2.0, 20.0], [-20.0, -2.0]])
    B = np.array([[0.0, 1.0], [1.0, 0.5], [0.0, 20.0], [20.0, -10.0]])
    C = np.array([[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, -0.5, 1.0]])
    return A, B, C, np.zeros((2, 2))


def mimo_2x2(seed: int, snr: float | None, T: float = 40.0, dt: float = 0.01) -> CaseData:
    """2x2 open-loop system (:func:`mimo_2x2_system`), order 4: two independent random
    binary inputs (``+-1``, new random signs every 0.1 s: flat spectrum well past the
    20 rad/s mode), ``dt = 0.01`` s, 40 s, exact ZOH response plus white noise on each
    output at the given SNR; validation: another seed."""
    A, B, C, D = mimo_2x2_system()
    t = np.arange(0.0, T + dt / 2, dt)
    recs = []
    for s in (seed, seed + VALIDATION_SEED_OFFSET):
        rng = np.random.default_rng(s)
        u = np.sign(random_steps(rng, t, 0.1, channels=2))
        recs.append(Record(t, u, _noisy(simulate_zoh(A, B, C, D, t, u), snr, rng)))
    return CaseData("mimo-2x2", recs[0], recs[1], MIMO_EIGENVALUES.copy(), 4, hold="zoh")


# -- closed loop with the thesis's experimental eigenvalues ----------------------------
#: Plant eigenvalues near those of Table 2 (longitudinal dynamics, experiment 1) of
#: "Continuous-time system identification with functional basis expansions".
TABLE2_EIGENVALUES = np.array([-28.0, -10.0, 1.2 + 5.8j, 1.2 - 5.8j])
#: Controller sample time (s): 250 Hz, as the quadrotor case.
TABLE2_TS = 0.004


def table2_plant() -> tuple[Array, Array, Array, Array]:
    """4th-order plant from a moment to the pitch rate ``q`` and the angular
    acceleration ``dq/dt``.

    Real modal form ``A = diag(-28, -10, [[1.2, 5.8], [-5.8, 1.2]])`` (eigenvalues
    ``-28, -10, 1.2 +- 5.8i``: two fast real modes and an unstable oscillation, as the
    thesis measured on a quadrotor), ``B = [20, 8, 0, 6]^T``, rate row
    ``c_q = [1, 1, 1, 0]``, so ``q(s) / M(s) = 20 / (s + 28) + 8 / (s + 10) + 34.8 /
    ((s - 1.2)^2 + 5.8^2)``; relative degree one like a rigid body's moment-to-rate
    response.  The acceleration row is the exact derivative of the rate:
    ``dq/dt = c_q A x + c_q B M`` (feedthrough ``c_q B = 28``).  Returns ``(A, B, C, D)``
    with outputs ``[q, dq/dt]``.
    """
    A = block_diag(-28.0, -10.0, [[1.2, 5.8], [-5.8, 1.2]])
    B = np.array([[20.0], [8.0], [0.0], [6.0]])
    cq = np.array([[1.0, 1.0, 1.0, 0.0]])
    C = np.vstack([cq, cq @ A])
    D = np.vstack([np.zeros((1, 1)), cq @ B])
    return A, B, C, D


def table2_controller(ts: float = TABLE2_TS) -> dict[str, Array]:
    """Sampled LQG regulator of :func:`table2_plant` measuring only the rate ``q``.

    Plant sampled exactly (ZOH): ``[[Phi, Gamma], [0, I]] = expm([[A, B], [0, 0]] ts)``.
    State feedback ``M_k = -K xhat_k + r_k`` (``r``: the excitation), ``K`` the discrete
    LQR gain for ``Q = c_q^T c_q + 0.1 I``, ``R = 10^-3`` (``scipy.linalg.
    solve_discrete_are``; Franklin, Powell and Workman, "Digital control of dynamic
    systems", ch. 9); predictor observer ``xhat_{k+1} = Phi xhat_k + Gamma M_k +
    L (q_k - c_q xhat_k)`` with the steady-state Kalman gain for process noise
    ``Gamma Gamma^T + 10^-3 I`` and unit measurement noise.  By the separation principle
    the closed-loop eigenvalues are those of ``Phi - Gamma K`` and ``Phi - L c_q``;
    returns ``Phi, Gamma, K, L, c_q`` and the closed-loop matrix ``Acl`` of
    ``[x; xhat]`` (checked in the tests: spectral radius below 1).
    """
    A, B, C, _ = table2_plant()
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = A * ts, B * ts
    E = expm(M)
    Phi, Gam = E[:n, :n], E[:n, n:]
    cq = C[:1]
    P = solve_discrete_are(Phi, Gam, cq.T @ cq + 0.1 * np.eye(n), 1e-3 * np.eye(1))
    K = np.linalg.solve(1e-3 * np.eye(1) + Gam.T @ P @ Gam, Gam.T @ P @ Phi)
    S = solve_discrete_are(Phi.T, cq.T, Gam @ Gam.T + 1e-3 * np.eye(n), np.eye(1))
    L = Phi @ S @ cq.T @ np.linalg.inv(cq @ S @ cq.T + np.eye(1))
    Acl = np.block([[Phi, -Gam @ K], [L @ cq, Phi - Gam @ K - L @ cq]])
    return {"Phi": Phi, "Gamma": Gam, "K": K, "L": L, "cq": cq, "Acl": Acl}


def _table2_loop(ctrl: dict[str, Array], r: Array, noise_q: Array) -> tuple[Array, Array]:
    """States ``x_k (Ns, 4)`` and applied moments ``M_k (Ns,)`` of the sampled loop."""
    Phi, Gam, K, L, cq = (ctrl[k] for k in ("Phi", "Gamma", "K", "L", "cq"))
    ns, n = r.shape[0], Phi.shape[0]
    X, mom = np.empty((ns, n)), np.empty(ns)
    x, xh = np.zeros(n), np.zeros(n)
    for k in range(ns):
        X[k] = x
        m = float(r[k] - K[0] @ xh)
        mom[k] = m
        q_meas = float(cq[0] @ x) + noise_q[k]
        xh = Phi @ xh + Gam[:, 0] * m + L[:, 0] * (q_meas - float(cq[0] @ xh))
        x = Phi @ x + Gam[:, 0] * m
    return X, mom


TABLE2_OUTPUTS = ("rate", "rate+acc")


def simulate_table2_closed_loop(
    rng: np.random.Generator,
    duration: float = 30.0,
    snr: float | None = 20.0,
    excitation: str = "sweep",
    outputs: str = "rate+acc",
) -> Record:
    """One closed-loop record of :func:`table2_plant` under :func:`table2_controller`.

    ``excitation`` (``"sweep"``: 1-4 Hz linear chirp; ``"3211"``: 0.1 s pulses every
    2 s; :func:`hdpbsid.systems.quadrotor.pitch_excitation`, amplitude 1) is added to the
    moment command; the identified input is the applied moment, held on
    ``[t_k, t_k + ts)``.  Outputs: the rate (``"rate"``) or rate and acceleration
    (``"rate+acc"``), sampled at ``t_k``, each with white sensor noise; the controller
    uses the noisy rate.  SNR as in the quadrotor case: a noise-free run of the same loop
    gives each sensor's mean-square power ``P`` and the noise has standard deviation
    ``sqrt(P) 10^(-snr/20)``.
    """
    if outputs not in TABLE2_OUTPUTS:
        raise ValueError(f"outputs must be one of {TABLE2_OUTPUTS}, got {outputs!r}")
    ctrl = table2_controller()
    _, _, C, D = table2_plant()
    ns = int(round(duration / TABLE2_TS)) + 1
    t = np.arange(ns) * TABLE2_TS
    r = pitch_excitation(excitation, t, amplitude=1.0, f0=1.0, f1=4.0, pulse=0.1, period=2.0)
    zero = np.zeros(ns)
    noise = np.zeros((ns, 2))
    if snr is not None:
        X, mom = _table2_loop(ctrl, r, zero)
        clean = X @ C.T + mom[:, None] @ D.T
        sigma = np.sqrt(np.mean(clean**2, axis=0)) * 10.0 ** (-snr / 20.0)
        noise = rng.standard_normal((ns, 2)) * sigma
    X, mom = _table2_loop(ctrl, r, noise[:, 0])
    y = X @ C.T + mom[:, None] @ D.T + noise
    cols = 1 if outputs == "rate" else 2
    return Record(t, mom[:, None], y[:, :cols])


def _table2_case(name: str, outputs: str) -> Callable[..., CaseData]:
    def generate(seed: int, snr: float | None, duration: float = 30.0) -> CaseData:
        est = simulate_table2_closed_loop(
            np.random.default_rng(seed), duration, snr, "sweep", outputs
        )
        val = simulate_table2_closed_loop(
            np.random.default_rng(seed + VALIDATION_SEED_OFFSET), duration, snr, "3211", outputs
        )
        return CaseData(
            name,
            est,
            val,
            TABLE2_EIGENVALUES.copy(),
            4,
            hold="zoh",
            fit_window=1.0,
            closed_loop=True,
            options={"feedthrough": True} if outputs == "rate+acc" else {},
        )

    generate.__doc__ = (
        f"Closed-loop 4th-order plant with the thesis's Table 2 eigenvalues, outputs "
        f"{outputs!r} (:func:`simulate_table2_closed_loop`), 250 Hz, 30 s, 1-4 Hz sweep "
        f"added to the command; validation: a 3211 record (another seed), scored on 1 s "
        f"windows because the plant is unstable.  ``options``: ``feedthrough=True`` when "
        f"the acceleration is measured (it has a direct term from the moment)."
    )
    return generate


table2_closed_loop = _table2_case("table2-closed-loop", "rate+acc")
table2_closed_loop_rate = _table2_case("table2-closed-loop-rate", "rate")


#: Case name -> generator ``(seed, snr) -> CaseData``.
CASES: dict[str, Callable[..., CaseData]] = {
    "second-order": second_order_smooth,
    "chirp": second_order_chirp,
    "quadrotor": quadrotor,
    "pbsid-mimo": pbsid_mimo,
    "stiff": stiff,
    "nonuniform": nonuniform,
    "rao-garnier": rao_garnier,
    "mimo-2x2": mimo_2x2,
    "table2-closed-loop": table2_closed_loop,
    "table2-closed-loop-rate": table2_closed_loop_rate,
}

#: One line per case for tables.
DESCRIPTIONS: dict[str, str] = {
    "second-order": "second order, random smooth input, dt = 0.01, 40 s",
    "chirp": "second order, 0.05-2 Hz chirp, dt = 0.01, 40 s; validated on a random input",
    "quadrotor": "closed-loop quadrotor pitch, 250 Hz, 30 s, outputs q and theta, order 3; "
    "validated on a 3211 record in 1 s windows (unstable plant)",
    "pbsid-mimo": "PBSID toolbox closed-loop 2x2 example, discrete, 4000 samples, its own "
    "unit innovation noise; eigenvalues compared in the z-plane",
    "stiff": "stiff third order (eigenvalues -50, -0.5 +- 2i), random steps held 0.05 s, "
    "dt = 0.01, 40 s",
    "nonuniform": "second order, random smooth input at 4001 uniform-random times in 40 s",
    "rao-garnier": "Rao-Garnier (CONTSID) 4th order, modes at 2 and 20 rad/s, zero at +0.25, "
    "random binary input held 0.05 s, dt = 0.01, 40 s",
    "mimo-2x2": "open-loop 2x2, order 4, pairs -0.2 +- 2i and -2 +- 20i, random binary "
    "inputs held 0.1 s, dt = 0.01, 40 s",
    "table2-closed-loop": "closed-loop (LQG on the rate) plant with eigenvalues -28, -10, "
    "1.2 +- 5.8i, 250 Hz, 30 s, outputs rate and acceleration, 1-4 Hz sweep; validated on "
    "a 3211 record in 1 s windows (unstable plant)",
    "table2-closed-loop-rate": "as table2-closed-loop, output the rate only",
}

#: Cases whose data do not depend on the requested SNR.
SNR_INDEPENDENT = frozenset({"pbsid-mimo"})


def make_case(name: str, seed: int, snr: float | None) -> CaseData:
    """Generate case ``name`` (a key of :data:`CASES`) for ``seed`` at ``snr`` dB."""
    if name not in CASES:
        raise ValueError(f"unknown case {name!r}; known: {', '.join(CASES)}")
    return CASES[name](seed, snr)
