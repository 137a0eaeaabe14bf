"""Windowed HD-PBSID on long records, and several records vs one (closed-loop quadrotor).

    python bench/segments.py resonance --samples 100000 1000000
    python bench/segments.py quadrotor --seeds 10
    python bench/segments.py resonance70 --seeds 5

``resonance``: a lightly damped resonance (5 Hz, damping 0.05) sampled at 1 kHz, driven
by Gaussian noise low-passed to 20 Hz (8th-order Butterworth), output noise at 20 dB,
order 2, ``method="hermite"`` with the default window; prints the wall time, the peak
memory traced by ``tracemalloc`` and the worst relative eigenvalue error.
``resonance70``: a lightly damped 70 Hz resonance sampled at 610 Hz (86 000 samples),
random-phase multisine to 200 Hz, exact steady-state response, 20 dB, order 2.
``quadrotor``: closed-loop pitch at 20 dB, order 3: three 30 s records in one problem
vs one 30 s record, over ``--seeds`` seeds; prints the eigenvalue spreads.
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np
from scipy import signal

from hdpbsid.methods.hermite import identify_hermite
from hdpbsid.models.conversion import c2d
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.systems import add_noise

F_RES, ZETA, FS, F_BAND = 5.0, 0.05, 1000.0, 20.0


def resonance() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    wn = 2 * np.pi * F_RES
    A = np.array([[0.0, 1.0], [-(wn**2), -2 * ZETA * wn]])
    return A, np.array([[0.0], [wn**2]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))


def resonance_record(ns: int, seed: int, snr_db: float = 20.0, band_hz: float = F_BAND):
    rng = np.random.default_rng(seed)
    A, B, C, D = resonance()
    h = 1.0 / FS
    t = np.arange(ns) * h
    sos = signal.butter(8, band_hz, fs=FS, output="sos")
    u = signal.sosfilt(sos, rng.standard_normal(ns + 2000))[2000:]
    Ad, Bd, Cd, Dd, _ = c2d(A, B, C, D, None, h)
    num, den = signal.ss2tf(Ad, Bd, Cd, Dd)
    y = signal.lfilter(num[0], den, u)
    y, _ = add_noise(y, snr_db, rng)
    return t, u[:, None], y[:, None]


#: the 70 Hz case: a lightly damped resonance (damping 0.02) sampled at 610 Hz, 86 000
#: samples, excited by a random-phase multisine with lines every 0.5 Hz up to 200 Hz
F70, ZETA70, FS70, NS70, F_MULTI, DF_MULTI = 70.0, 0.02, 610.0, 86_000, 200.0, 0.5


def resonance70() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    wn = 2 * np.pi * F70
    A = np.array([[0.0, 1.0], [-(wn**2), -2 * ZETA70 * wn]])
    return A, np.array([[0.0], [wn**2]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))


def resonance70_record(seed: int, snr_db: float = 20.0, ns: int = NS70):
    """The multisine and the system's exact steady-state (periodic) response to it,
    sampled at ``FS70``; output noise at ``snr_db``."""
    rng = np.random.default_rng(seed)
    A, B, C, D = resonance70()
    t = np.arange(ns) / FS70
    f = np.arange(DF_MULTI, F_MULTI + 1e-9, DF_MULTI)
    phase = rng.uniform(0.0, 2 * np.pi, f.size)
    s = 2j * np.pi * f
    G = np.array([(C @ np.linalg.solve(sk * np.eye(2) - A, B))[0, 0] for sk in s])
    u = np.zeros(ns)
    y = np.zeros(ns)
    for i in range(0, ns, 8192):  # blocks of samples: bounded temporaries
        e = np.exp(1j * (2 * np.pi * np.outer(t[i : i + 8192], f) + phase))
        u[i : i + 8192] = e.real.sum(axis=1)
        y[i : i + 8192] = (e * G).real.sum(axis=1)
    scale = 1.0 / u.std()
    y, _ = add_noise(y * scale, snr_db, rng)
    return t, u[:, None] * scale, y[:, None]


def run_resonance70(seeds: int) -> None:
    true = np.linalg.eigvals(resonance70()[0])
    for s in range(seeds):
        t, u, y = resonance70_record(s)
        t0 = time.perf_counter()
        m = identify_hermite(t, u, y, order=2)
        dt = time.perf_counter() - t0
        err = float(eigenvalue_errors(m.eigenvalues, true).max())
        o = m.options
        print(
            f"seed {s}: time {dt:5.2f} s  worst eig error {100 * err:.3f} %  window "
            f"{o['window']}  blocks {o['n_segments']}  N {o['N']}  hold {o['input_hold']}"
        )


def run_resonance(sizes: list[int], seed: int) -> None:
    true = np.linalg.eigvals(resonance()[0])
    for ns in sizes:
        t, u, y = resonance_record(ns, seed)
        tracemalloc.start()
        t0 = time.perf_counter()
        m = identify_hermite(t, u, y, order=2)
        dt = time.perf_counter() - t0
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        err = float(eigenvalue_errors(m.eigenvalues, true).max())
        o = m.options
        print(
            f"Ns={ns:>8d}  time {dt:6.2f} s  peak traced {peak / 2**20:7.1f} MiB  "
            f"worst eig error {100 * err:.3f} %  window {o['window']}  blocks "
            f"{o['n_segments']}  N {o['N']}  p {o['p']}  hold {o['input_hold']}"
        )


def run_quadrotor(seeds: int) -> None:
    from hdpbsid.systems.quadrotor import pitch_model, simulate_pitch_closed_loop

    true = np.linalg.eigvals(pitch_model()[0])
    one, three = [], []
    for s in range(seeds):
        recs = []
        for k in range(3):
            d = simulate_pitch_closed_loop(np.random.default_rng(1000 * s + k), snr_db=20.0)
            recs.append((d.t, d.u, d.y))
        m1 = identify_hermite(*recs[0], order=3)
        m3 = identify_hermite(recs, order=3)
        one.append(float(eigenvalue_errors(m1.eigenvalues, true).max()))
        three.append(float(eigenvalue_errors(m3.eigenvalues, true).max()))
        print(f"seed {s}: one record {100 * one[-1]:.2f} %  three records {100 * three[-1]:.2f} %")
    for name, e in (("one record", one), ("three records", three)):
        e = 100 * np.array(e)
        print(
            f"{name:>14s}: median {np.median(e):.2f} %  mean {e.mean():.2f} %  max {e.max():.2f} %"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("case", choices=("resonance", "resonance70", "quadrotor"))
    ap.add_argument("--samples", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--seeds", type=int, default=10)
    a = ap.parse_args()
    if a.case == "resonance":
        run_resonance(a.samples, a.seed)
    elif a.case == "resonance70":
        run_resonance70(a.seeds)
    else:
        run_quadrotor(a.seeds)


if __name__ == "__main__":
    main()
