"""Windowed HD-PBSID on long records, and several records vs one (closed-loop quadrotor).

    python bench/segments.py resonance --samples 100000 1000000
    python bench/segments.py quadrotor --seeds 10

``resonance``: a lightly damped resonance (5 Hz, damping 0.05) sampled at 1 kHz, driven
by Gaussian noise low-passed to 20 Hz (8th-order Butterworth), output noise at 20 dB,
order 2, ``method="hermite"`` with the default window; prints the wall time, the peak
memory traced by ``tracemalloc`` and the worst relative eigenvalue error.
``quadrotor``: closed-loop pitch at 20 dB, order 3: three 30 s records in one problem
vs one 30 s record, over ``--seeds`` seeds; prints the eigenvalue spreads.
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np
from scipy import signal

from hdpbsid.conversion import c2d
from hdpbsid.methods.hermite import identify_hermite
from hdpbsid.metrics import eigenvalue_errors
from hdpbsid.systems import add_noise

F_RES, ZETA, FS, F_BAND = 5.0, 0.05, 1000.0, 20.0


def resonance() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    wn = 2 * np.pi * F_RES
    A = np.array([[0.0, 1.0], [-(wn**2), -2 * ZETA * wn]])
    return A, np.array([[0.0], [wn**2]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))


def resonance_record(ns: int, seed: int, snr_db: float = 20.0):
    rng = np.random.default_rng(seed)
    A, B, C, D = resonance()
    h = 1.0 / FS
    t = np.arange(ns) * h
    sos = signal.butter(8, F_BAND, fs=FS, output="sos")
    u = signal.sosfilt(sos, rng.standard_normal(ns + 2000))[2000:]
    Ad, Bd, Cd, Dd, _ = c2d(A, B, C, D, None, h)
    num, den = signal.ss2tf(Ad, Bd, Cd, Dd)
    y = signal.lfilter(num[0], den, u)
    y, _ = add_noise(y, snr_db, rng)
    return t, u[:, None], y[:, None]


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
    ap.add_argument("case", choices=("resonance", "quadrotor"))
    ap.add_argument("--samples", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--seeds", type=int, default=10)
    a = ap.parse_args()
    if a.case == "resonance":
        run_resonance(a.samples, a.seed)
    else:
        run_quadrotor(a.seeds)


if __name__ == "__main__":
    main()
