"""Benchmark of slbasis.numeric: evaluation / projection throughput, memory, accuracy.

Hermite functions (and Laguerre functions for accuracy) for N in {100, 400, 1000, 2000,
5000}, side by side with scipy.special (eval_hermite * exp / norm) and numpy.polynomial
(hermvander * exp / norm) evaluation of the same functions. Accuracy is the max abs error
against mpmath at 50 digits at random points spanning 1.2x the support.

Run:  python bench/basis.py [--quick]
(``env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE`` avoids a slow BLAS set-up on some machines.)
Projection is timed in a fresh subprocess per N; peak memory is that process's VmHWM
(peak RSS; 'increase' = during the projection call, inputs of 16 MB excluded).
The kernels are the generated ones (slbasis/kernels/, via slbasis.kernel).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
import warnings
from pathlib import Path

import mpmath
import numpy as np
import scipy.special as sps

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import slbasis  # noqa: E402
from slbasis.numeric import Basis, evaluate  # noqa: E402

HERMITE = slbasis.kernel("hermite_functions")
LAGUERRE = slbasis.kernel("laguerre", alpha=0)


def hermite_mp(n: int, x: float) -> float:
    with mpmath.workdps(50):
        x = mpmath.mpf(float(x))
        norm = mpmath.sqrt(mpmath.mpf(2) ** n * mpmath.factorial(n) * mpmath.sqrt(mpmath.pi))
        return float(mpmath.hermite(n, x) * mpmath.exp(-x * x / 2) / norm)


def laguerre_mp(n: int, x: float) -> float:
    with mpmath.workdps(50):
        x = mpmath.mpf(float(x))
        return float(mpmath.laguerre(n, 0, x) * mpmath.exp(-x / 2))


def scipy_hermite(N: int, x: np.ndarray) -> np.ndarray:
    n = np.arange(N)[:, None]
    lognorm = 0.5 * (n * np.log(2.0) + sps.gammaln(n + 1) + 0.5 * np.log(np.pi))
    with np.errstate(all="ignore"):
        return sps.eval_hermite(n, x) * np.exp(-(x**2) / 2 - lognorm)


def numpy_hermite(N: int, x: np.ndarray) -> np.ndarray:
    n = np.arange(N)[:, None]
    lognorm = 0.5 * (n * np.log(2.0) + sps.gammaln(n + 1) + 0.5 * np.log(np.pi))
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        V = np.polynomial.hermite.hermvander(x, N - 1).T
        return V * np.exp(-(x**2) / 2 - lognorm)


def best_time(f, repeat: int = 3) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t0)
    return best


def accuracy(P: np.ndarray, oracle, rows, x) -> str:
    """Max abs error over the finite entries, and how many entries are NaN/inf."""
    bad = int(np.count_nonzero(~np.isfinite(P[rows])))
    errs = [np.abs(P[n] - [oracle(n, xi) for xi in x]) for n in rows]
    fin = np.concatenate([e[np.isfinite(e)] for e in errs])
    err = f"{fin.max():8.1e}" if fin.size else "     n/a"
    return err + (f" +{bad} nan/inf" if bad else "")


def project_child(N: int, Ns: int) -> None:
    """Run in a subprocess: time one projection and report the peak RSS increase."""
    B = Basis(HERMITE, N, (0.0, 1000.0))
    t = np.linspace(0.0, 1000.0, Ns)
    y = np.sin(0.3 * t) * np.exp(-(((t - 500) / 200) ** 2))
    base = _vm_hwm_kb()
    t0 = time.perf_counter()
    B.project(t, y)
    dt = time.perf_counter() - t0
    peak = _vm_hwm_kb()
    print(json.dumps({"time": dt, "peak_mb": peak / 1024, "delta_mb": (peak - base) / 1024}))


def _vm_hwm_kb() -> float:
    """Peak resident set of this process (VmHWM; unlike ru_maxrss it is reset by exec)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return float(line.split()[1])
    except OSError:
        pass
    return float(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer mpmath points, Ns = 1e5")
    ap.add_argument("--project-child", nargs=2, type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.project_child:
        project_child(*args.project_child)
        return
    rng = np.random.default_rng(0)
    Ns_eval = 10_000
    npts = 200 if args.quick else 2000
    print("Hermite functions: evaluation at samples in 1.2x the support (values/s); max abs")
    print("error vs mpmath (50 digits) at 200 random points (2000 for slbasis at N = 5000),")
    print("rows 0, N/2, N-1; '+k nan/inf' = entries that are NaN/inf (error is over the rest)")
    print(
        f"{'N':>5} | {'slbasis/s':>9} {'err':>8} | {'scipy/s':>8} {'err':>24} |"
        f" {'numpy/s':>8} {'err':>24}"
    )
    for N in (100, 400, 1000, 2000, 5000):
        half = 1.2 * np.sqrt(2 * N)
        x = rng.uniform(-half, half, Ns_eval)
        xs = x[: max(200, min(Ns_eval, 2 * 10**7 // N**2))]  # scipy: O(N^2) per sample
        xa = x[: (npts if N == 5000 else 200)]
        rows = sorted({0, N // 2, N - 1})
        t_sl = best_time(lambda N=N, x=x: evaluate(HERMITE, N, x))
        t_sp = best_time(lambda N=N, x=xs: scipy_hermite(N, x), 1)
        t_np = best_time(lambda N=N, x=x: numpy_hermite(N, x), 1)
        a_sl = accuracy(evaluate(HERMITE, N, xa), hermite_mp, rows, xa)
        a_sp = accuracy(scipy_hermite(N, xa[:200]), hermite_mp, rows, xa[:200])
        a_np = accuracy(numpy_hermite(N, xa[:200]), hermite_mp, rows, xa[:200])
        print(
            f"{N:5d} | {N * x.size / t_sl:9.2e} {a_sl:>8} | {N * xs.size / t_sp:8.2e} {a_sp:>24} |"
            f" {N * x.size / t_np:8.2e} {a_np:>24}",
            flush=True,
        )
        if N == 1000:
            print(f"      (N = 1000 at 10^4 samples: slbasis {t_sl:.3f} s; target <= 0.15 s)")
    N = 2000
    top = 1.2 * 4 * N
    x = rng.uniform(0, top, 200)
    print(
        f"Laguerre functions N = {N}, x in [0, {top:.0f}] (200 points, rows 0, N/2, N-1): "
        f"max err {accuracy(evaluate(LAGUERRE, N, x), laguerre_mp, [0, N // 2, N - 1], x)}"
    )
    Ns = 100_000 if args.quick else 1_000_000
    print(f"\nProjection of {Ns} uniform samples onto N Hermite functions (fresh process each)")
    print(f"{'N':>5} | {'time s':>8} {'values/s':>9} {'peak RSS MB':>11} {'increase MB':>11}")
    for N in (100, 400, 1000, 2000, 5000):
        out = subprocess.run(
            [sys.executable, __file__, "--project-child", str(N), str(Ns)],
            capture_output=True,
            text=True,
            check=True,
        )
        r = json.loads(out.stdout.strip().splitlines()[-1])
        print(
            f"{N:5d} | {r['time']:8.2f} {N * Ns / r['time']:9.2e} {r['peak_mb']:11.0f}"
            f" {r['delta_mb']:11.0f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
