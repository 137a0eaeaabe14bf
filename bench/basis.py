"""Benchmark of slbasis.numeric: evaluation / projection throughput, memory, accuracy.

Hermite functions (and Laguerre functions for accuracy) for N in {100, 400, 1000, 2000,
5000}, side by side with scipy.special (eval_hermite * exp / norm) and numpy.polynomial
(hermvander * exp / norm) evaluation of the same functions. Accuracy is the max abs error
against mpmath at 50 digits at random points spanning 1.2x the support.

Engines (slbasis.numeric.engine): "numpy" (vectorised numpy recurrence) and "numba"
(compiled kernels, optional extra ``fast``), side by side: evaluation at 10^4 samples in
the first table, then a table of evaluation and projection times for 10^4..10^6 samples
x N = 400..4000 (``--engines``); numpy cells above ``--numpy-max-work`` function values
are not run (printed as '-'). Compilation (or loading the on-disk cache) happens once,
before any timing, and is reported on its own.

Run:  python bench/basis.py [--quick] [--engines] [--numpy-max-work 5e8]
(``env -u OPENBLAS_CORETYPE -u OPENBLAS_L2_SIZE`` avoids a slow BLAS set-up on some machines.)
Projection is timed in a fresh subprocess per N (default engine); peak memory is that
process's VmHWM (peak RSS; 'increase' = during the projection call, inputs of 16 MB
excluded). Times are wall-clock on whatever else the machine runs: the load average is
printed with each table. The kernels are the generated ones (slbasis/kernels/, via
slbasis.kernel).
"""

from __future__ import annotations

import argparse
import json
import os
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
from slbasis.numeric import Basis, engine, evaluate  # noqa: E402
from slbasis.numeric.projection import default_chunk  # noqa: E402

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
    B.project(t[:2000], y[:2000])  # compile or load the compiled kernels: not timed
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


def _stream_eval(N: int, x: np.ndarray, eng: str) -> None:
    """Evaluate all of ``x`` in chunks of ``default_chunk(N)`` into one reused buffer."""
    chunk = default_chunk(N)
    buf = np.empty((N, chunk))
    for s in range(0, x.size, chunk):
        xs = x[s : s + chunk]
        evaluate(HERMITE, N, xs, out=buf[:, : xs.size] if xs.size == chunk else None, engine=eng)


def _cell(v: float) -> str:
    return f"{v:8.3f}" if np.isfinite(v) else f"{'-':>8}"


def _ratio(a: float, b: float) -> str:
    return f"{a / b:5.1f}" if np.isfinite(a) else f"{'-':>5}"


def engines_table(sizes, orders, numpy_max_work: float, k: int = 4) -> None:
    """Eval and project (``k`` signals, trapezoid weights) times, numpy vs numba."""
    t0 = time.perf_counter()
    evaluate(HERMITE, 8, np.linspace(-1, 1, 300), engine="numba")
    Basis(HERMITE, 8, (0.0, 1.0)).project(np.linspace(0, 1, 300), np.ones((300, k)), engine="numba")
    print(
        f"\nEngines side by side: Hermite functions, samples uniform on 90 % of the support;"
        f"\neval = all samples streamed through a reused (N x {default_chunk(2000)}-ish) block;"
        f" project = Basis.project of {k} signals.\nWall seconds ('nb cpu': CPU seconds of"
        f" one numba projection, all threads); '-' = numpy not run"
        f" (> {numpy_max_work:.0e} values). numba threads: {engine._threads()};"
        f" compile/cache load before timing: {time.perf_counter() - t0:.2f} s;"
        f" load average {os.getloadavg()[0]:.1f}."
    )
    print(
        f"{'Ns':>8} {'N':>5} | {'eval np':>8} {'eval nb':>8} {'x':>5} |"
        f" {'proj np':>8} {'proj nb':>8} {'x':>5} {'nb cpu':>8}"
    )
    rng = np.random.default_rng(1)
    for Ns in sizes:
        for N in orders:
            B = Basis(HERMITE, N, (0.0, 1000.0))
            t = np.linspace(0.0, 1000.0, Ns)
            x = B.tmap.to_x(t)
            Y = rng.standard_normal((Ns, k))
            reps = 3 if N * Ns <= 10**8 else 1
            row, cpu = {}, {}
            for eng in ("numpy", "numba"):
                if eng == "numpy" and N * Ns > numpy_max_work:
                    row[eng] = (np.nan, np.nan)
                    continue
                te = best_time(lambda e=eng, N=N, x=x: _stream_eval(N, x, e), reps)
                c0 = time.process_time()
                tp = best_time(lambda e=eng, B=B, t=t, Y=Y: B.project(t, Y, engine=e), reps)
                cpu[eng] = (time.process_time() - c0) / reps
                row[eng] = (te, tp)
            (e_np, p_np), (e_nb, p_nb) = row["numpy"], row["numba"]

            print(
                f"{Ns:8d} {N:5d} | {_cell(e_np)} {_cell(e_nb)} {_ratio(e_np, e_nb)} |"
                f" {_cell(p_np)} {_cell(p_nb)} {_ratio(p_np, p_nb)} {cpu['numba']:8.3f}",
                flush=True,
            )
    print(f"(load average at the end {os.getloadavg()[0]:.1f})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer mpmath points, Ns = 1e5")
    ap.add_argument(
        "--engines", action="store_true", help="only the numpy-vs-numba eval/project table"
    )
    ap.add_argument(
        "--numpy-max-work",
        type=float,
        default=5e8,
        help="largest N * Ns run with the numpy engine in the engines table",
    )
    ap.add_argument("--project-child", nargs=2, type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.project_child:
        project_child(*args.project_child)
        return
    sizes = (10**4, 10**5) if args.quick else (10**4, 10**5, 10**6)
    orders = (400, 1000, 2000, 4000)
    if args.engines:
        engines_table(sizes, orders, args.numpy_max_work)
        return
    rng = np.random.default_rng(0)
    Ns_eval = 10_000
    npts = 200 if args.quick else 2000
    print("Hermite functions: evaluation at samples in 1.2x the support (values/s); max abs")
    print("error vs mpmath (50 digits) at 200 random points (2000 for slbasis at N = 5000),")
    print("rows 0, N/2, N-1; '+k nan/inf' = entries that are NaN/inf (error is over the rest);")
    print("slbasis engines numpy and numba give the same values bit for bit (one error column)")
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print(
        f"{'N':>5} | {'numpy/s':>8} {'numba/s':>8} {'err':>8} | {'scipy/s':>8} {'err':>24} |"
        f" {'np.poly/s':>9} {'err':>24}"
    )
    compiled = engine.numba_available()
    for N in (100, 400, 1000, 2000, 5000):
        half = 1.2 * np.sqrt(2 * N)
        x = rng.uniform(-half, half, Ns_eval)
        xs = x[: max(200, min(Ns_eval, 2 * 10**7 // N**2))]  # scipy: O(N^2) per sample
        xa = x[: (npts if N == 5000 else 200)]
        rows = sorted({0, N // 2, N - 1})
        t_np = best_time(lambda N=N, x=x: evaluate(HERMITE, N, x, engine="numpy"))
        t_nb = (
            best_time(lambda N=N, x=x: evaluate(HERMITE, N, x, engine="numba"))
            if compiled
            else np.nan
        )
        t_sp = best_time(lambda N=N, x=xs: scipy_hermite(N, x), 1)
        t_poly = best_time(lambda N=N, x=x: numpy_hermite(N, x), 1)
        a_sl = accuracy(evaluate(HERMITE, N, xa), hermite_mp, rows, xa)
        a_sp = accuracy(scipy_hermite(N, xa[:200]), hermite_mp, rows, xa[:200])
        a_poly = accuracy(numpy_hermite(N, xa[:200]), hermite_mp, rows, xa[:200])
        print(
            f"{N:5d} | {N * x.size / t_np:8.2e} {N * x.size / t_nb:8.2e} {a_sl:>8} |"
            f" {N * xs.size / t_sp:8.2e} {a_sp:>24} | {N * x.size / t_poly:9.2e} {a_poly:>24}",
            flush=True,
        )
        if N == 1000:
            print(
                f"      (N = 1000 at 10^4 samples: numpy {t_np:.3f} s, numba {t_nb:.3f} s;"
                " target <= 0.15 s)"
            )
    N = 2000
    top = 1.2 * 4 * N
    x = rng.uniform(0, top, 200)
    print(
        f"Laguerre functions N = {N}, x in [0, {top:.0f}] (200 points, rows 0, N/2, N-1): "
        f"max err {accuracy(evaluate(LAGUERRE, N, x), laguerre_mp, [0, N // 2, N - 1], x)}"
    )
    if engine.numba_available():
        engines_table(sizes, orders, args.numpy_max_work)
    Ns = 100_000 if args.quick else 1_000_000
    print(
        f"\nProjection of {Ns} uniform samples onto N Hermite functions (fresh process each,"
        " default engine)"
    )
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
