"""Data sets of the head-to-head benchmark (``bench/peers.py``), one generator per case.

Every generator takes a seed and an SNR and returns a :class:`CaseData` holding an
*estimation* record, an independent *validation* record (a second record drawn from
another seed; for some cases also another input, see the case descriptions), the true
eigenvalues, the order to identify and how the input behaves between samples (which is
how the validation simulation must treat it).  The systems themselves come from
``hdpbsid.systems`` and ``hdpbsid.systems.quadrotor`` (DESIGN.md, "Benchmark systems"); only
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
from scipy.signal import butter, chirp, filtfilt

from hdpbsid.model import StateSpaceModel
from hdpbsid.systems import (
    add_noise,
    pbsid_example,
    random_steps,
    second_order,
    simulate_pbsid_closed_loop,
    simulate_zoh,
)
from hdpbsid.systems.quadrotor import simulate_pitch_closed_loop

Array = NDArray[np.float64]

#: Offset between the seed of an estimation record and that of its validation record.
VALIDATION_SEED_OFFSET = 1_000_003

#: Eigenvalues of the stiff third-order system (DESIGN issue 6).
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
    where DESIGN.md says the discrete-time tools fail); exact FOH response plus noise.
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


#: Case name -> generator ``(seed, snr) -> CaseData``.
CASES: dict[str, Callable[..., CaseData]] = {
    "second-order": second_order_smooth,
    "chirp": second_order_chirp,
    "quadrotor": quadrotor,
    "pbsid-mimo": pbsid_mimo,
    "stiff": stiff,
    "nonuniform": nonuniform,
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
}

#: Cases whose data do not depend on the requested SNR.
SNR_INDEPENDENT = frozenset({"pbsid-mimo"})


def make_case(name: str, seed: int, snr: float | None) -> CaseData:
    """Generate case ``name`` (a key of :data:`CASES`) for ``seed`` at ``snr`` dB."""
    if name not in CASES:
        raise ValueError(f"unknown case {name!r}; known: {', '.join(CASES)}")
    return CASES[name](seed, snr)
