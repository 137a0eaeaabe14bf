"""Accuracy and run time of the basis-domain methods on the second-order benchmark.

Run: ``.venv/bin/python bench/identify_basis.py [--runs 50] [--snr 40 20 10]``.

Prints, per case (random smooth input / 0.05-2 Hz chirp, 40 s at ``dt = 0.01``), method
and SNR, over seeded Monte Carlo runs with the order given (2): the eigenvalue bias
``|mean(lambda_est) - lambda| / |lambda|`` and standard deviation
``sqrt(mean |lambda_est - mean|^2) / |lambda|`` (largest over the conjugate pair), the
median of the per-run largest relative error, the number of runs that raised, and the
median wall time; then the fit time for ``10^4`` samples with ``N = 400``.
Data are exact FOH responses (``StateSpaceModel.simulate(method="foh")``) plus white
noise at the given SNR (``hdpbsid.systems.add_noise``).  Not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import time
import warnings
from collections.abc import Callable

import numpy as np
from scipy.signal import butter, chirp, filtfilt

from hdpbsid.hermite import identify_hermite
from hdpbsid.laguerre import identify_laguerre
from hdpbsid.model import StateSpaceModel
from hdpbsid.sl_basis_method import identify_chebyshev, identify_legendre
from hdpbsid.systems import add_noise, second_order

A, B, C, D = second_order()
TRUE = np.linalg.eigvals(A)
TRUE = TRUE[np.argsort(TRUE.imag)]

METHODS: dict[str, Callable] = {
    "hermite": identify_hermite,
    "laguerre": identify_laguerre,
    "laguerre-filter": lambda t, u, y, order=None, **k: identify_laguerre(
        t, u, y, order, variant="filter", **k
    ),
    "legendre": identify_legendre,
    "chebyshev": identify_chebyshev,
}


def make_data(
    seed: int, kind: str, snr: float | None, T: float = 40.0, dt: float = 0.01
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, T + dt / 2, dt)
    if kind == "chirp":
        u = chirp(t, 0.05, T, 2.0)
    else:  # white noise low-passed at 1 Hz (4th-order Butterworth, zero phase)
        b, a = butter(4, 2 * dt)
        u = filtfilt(b, a, rng.standard_normal(t.size))
        u /= np.std(u)
    y = StateSpaceModel(A, B, C, D, np.zeros((2, 1))).simulate(t, u[:, None], method="foh")
    if snr is not None:
        y, _ = add_noise(y, snr, rng)
    return t, u, y


def monte_carlo(method: Callable, kind: str, snr: float | None, runs: int) -> dict:
    est, errs, times, failed = [], [], [], 0
    for s in range(runs):
        t, u, y = make_data(1000 + s, kind, snr)
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ev = method(t, u, y, order=2).eigenvalues
        except (ValueError, np.linalg.LinAlgError):
            failed += 1
            continue
        times.append(time.perf_counter() - t0)
        ev = ev[np.argsort(ev.imag)]
        est.append(ev)
        errs.append(float(np.max(np.abs(ev - TRUE) / np.abs(TRUE))))
    if not est:
        return {"bias": np.nan, "std": np.nan, "median": np.nan, "failed": failed, "time": np.nan}
    E = np.array(est)
    mean = E.mean(axis=0)
    bias = np.max(np.abs(mean - TRUE) / np.abs(TRUE))
    std = np.max(np.sqrt(np.mean(np.abs(E - mean) ** 2, axis=0)) / np.abs(TRUE))
    return {
        "bias": bias,
        "std": std,
        "median": float(np.median(errs)),
        "failed": failed,
        "time": float(np.median(times)),
    }


def fit_time(N: int = 400, ns: int = 10_000) -> None:
    dt = 0.01
    t, u, y = make_data(7, "smooth", 20.0, T=(ns - 1) * dt, dt=dt)
    print(f"\nfit time for Ns = {t.size} samples, N = {N} (SNR 20 dB, order 2, median of 3):")
    for name in ("hermite", "laguerre", "legendre", "chebyshev"):
        el = []
        for _ in range(3):
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                m = METHODS[name](t, u, y, order=2, N=N)
            el.append(time.perf_counter() - t0)
        ev = m.eigenvalues[np.argsort(m.eigenvalues.imag)]
        err = np.max(np.abs(ev - TRUE) / np.abs(TRUE))
        print(f"  {name:16s} {np.median(el) * 1e3:8.1f} ms   (error {100 * err:.3f} %)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--snr", type=float, nargs="+", default=[40.0, 20.0, 10.0])
    ap.add_argument("--methods", nargs="+", default=list(METHODS))
    args = ap.parse_args()
    print(f"second-order system, eigenvalues -0.4 +- 1.9596i, {args.runs} seeds per row")
    hdr = f"{'case':7s} {'method':16s} {'SNR':>5s} {'bias %':>8s} {'std %':>8s}"
    print(hdr + f" {'median %':>9s} {'failed':>6s} {'time ms':>8s}")
    for kind in ("smooth", "chirp"):
        for snr in args.snr:
            for name in args.methods:
                r = monte_carlo(METHODS[name], kind, snr, args.runs)
                print(
                    f"{kind:7s} {name:16s} {snr:5.0f} {100 * r['bias']:8.3f} "
                    f"{100 * r['std']:8.3f} {100 * r['median']:9.3f} {r['failed']:6d} "
                    f"{1e3 * r['time']:8.1f}",
                    flush=True,
                )
    fit_time()


if __name__ == "__main__":
    main()
