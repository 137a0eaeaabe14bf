"""Accuracy and run time of method "dt" (PBSID on samples + exact d2c) on the benchmarks.

Run: ``.venv/bin/python bench/identify_dt.py [--runs 20]``.  Prints, per scenario, the
median and maximum relative eigenvalue error over seeded Monte Carlo runs and the median
wall time.  Not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.signal import chirp

from hdpbsid import identify_discrete, identify_dt
from hdpbsid.metrics import eigenvalue_errors
from hdpbsid.systems import (
    add_noise,
    pbsid_example,
    random_steps,
    second_order,
    simulate_pbsid_closed_loop,
    simulate_zoh,
)


def closed_loop_mimo(rng: np.random.Generator, **kw: object) -> tuple[float, int, float]:
    d = simulate_pbsid_closed_loop(rng)
    t0 = time.perf_counter()
    m = identify_discrete(d["u"], d["y"], **kw)
    dt = time.perf_counter() - t0
    true = np.linalg.eigvals(pbsid_example()[0])
    err = eigenvalue_errors(m.eigenvalues, true).max() if m.n == 4 else np.nan
    return err, m.n, dt


def second_order_case(
    rng: np.random.Generator, dt: float, T: float, snr: float | None, inp: str, **kw: object
) -> tuple[float, int, float]:
    A, B, C, D = second_order()
    t = np.arange(int(round(T / dt))) * dt
    u = chirp(t, 0.05, T, 2.0)[:, None] if inp == "chirp" else random_steps(rng, t, 0.25)
    y = simulate_zoh(A, B, C, D, t, u)
    if snr is not None:
        y, _ = add_noise(y, snr, rng)
    t0 = time.perf_counter()
    m = identify_dt(t, u, y, **kw)
    el = time.perf_counter() - t0
    true = np.linalg.eigvals(A)
    err = eigenvalue_errors(m.eigenvalues, true).max() if m.n == 2 else np.nan
    return err, m.n, el


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=10)
    args = ap.parse_args()
    scenarios = {
        "MIMO closed loop, order 4, p=f=10": lambda r: closed_loop_mimo(r, order=4, p=10, f=10),
        "MIMO closed loop, all defaults": lambda r: closed_loop_mimo(r),
        "2nd order, dt=0.05, steps, noise-free": lambda r: second_order_case(
            r, 0.05, 40, None, "steps"
        ),
        "2nd order, dt=0.05, steps, 20 dB": lambda r: second_order_case(r, 0.05, 40, 20, "steps"),
        "2nd order, dt=0.01, chirp, 40 dB, order 2": lambda r: second_order_case(
            r, 0.01, 40, 40, "chirp", order=2
        ),
        "2nd order, dt=0.01, chirp, 20 dB, order 2": lambda r: second_order_case(
            r, 0.01, 40, 20, "chirp", order=2
        ),
        "2nd order, dt=0.01, chirp, 20 dB, no ridge": lambda r: second_order_case(
            r, 0.01, 40, 20, "chirp", order=2, regularize=False
        ),
    }
    print(f"{'scenario':46s} {'median err':>11s} {'max err':>10s} {'orders':>8s} {'time':>8s}")
    for name, fn in scenarios.items():
        res = [fn(np.random.default_rng(seed)) for seed in range(args.runs)]
        err = np.array([r[0] for r in res])
        orders = sorted({r[1] for r in res})
        tm = np.median([r[2] for r in res])
        print(
            f"{name:46s} {np.nanmedian(err):11.2e} {np.nanmax(err):10.2e} "
            f"{','.join(map(str, orders)):>8s} {tm:7.3f}s"
        )


if __name__ == "__main__":
    main()
