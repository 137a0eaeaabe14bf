"""How the cost of HD-PBSID (method ``hermite``) and of method ``dt`` grows with the data.

Run: ``.venv/bin/python bench/scaling.py [--quick]``.

Two sweeps on the second-order benchmark (random smooth input low-passed at 1 Hz,
``dt = 0.01``, exact ZOH response, SNR 20 dB, order 2):

* number of samples ``Ns`` = 10^3, 10^4, 10^5, 10^6 with every default (``hermite``
  chooses its basis size ``N`` from the record; ``dt`` its past window ``p`` by AIC);
* basis size ``N`` = 100 ... 3200 for ``hermite`` at ``Ns = 10^4`` (and ``10^5``).

Each point runs in a fresh subprocess (one BLAS thread, address space capped at
``--mem-limit-gb``): the data are generated, then one untimed warm-up call, then the
identification is timed (median of ``--repeats``).  Reported per point: median wall and
CPU time of ``hdpbsid.identify``; the peak resident set size of the process
(``ru_maxrss``); the peak *extra* memory of one identification call measured with
``tracemalloc`` (numpy reports its buffers to it), which excludes the data and the
interpreter; the chosen ``N`` / ``p``; and the eigenvalue error as a sanity check.  A
point that runs out of memory or time is reported as such.  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402  (after the BLAS thread settings)

HERE = Path(__file__).resolve()


def measure_point(method: str, n_samples: int, basis_size: int | None, repeats: int) -> dict:
    """Generate the data and time/measure ``repeats`` identifications (in this process)."""
    import resource
    import time
    import tracemalloc
    import warnings

    import hdpbsid
    from hdpbsid.metrics import eigenvalue_errors
    from hdpbsid.systems import add_noise, second_order, simulate_zoh

    sys.path.insert(0, str(HERE.parent))
    from cases import smooth_random_input

    rng = np.random.default_rng(n_samples)
    dt = 0.01
    t = np.arange(n_samples) * dt
    A, B, C, D = second_order()
    u = smooth_random_input(rng, t)[:, None]
    y, _ = add_noise(simulate_zoh(A, B, C, D, t, u), 20.0, rng)
    options = {} if basis_size is None else {"N": basis_size}

    def call() -> hdpbsid.StateSpaceModel:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return hdpbsid.identify(t, u, y, order=2, method=method, **options)

    model = call()  # warm-up (kernel caches, imports)
    rss_before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    times, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        model = call()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    tracemalloc.start()
    call()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return {
        "time": float(np.median(times)),
        "cpu": float(np.median(cpu)),
        "peak_call_mb": peak / 2**20,
        "max_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "rss_before_mb": rss_before / 1024,
        "N": model.options.get("N"),
        "p": model.options.get("p"),
        "error": float(eigenvalue_errors(model.eigenvalues, np.linalg.eigvals(A)).max()),
    }


def run_point(
    method: str,
    n_samples: int,
    basis_size: int | None,
    repeats: int,
    timeout: float,
    mem_limit_gb: float,
) -> dict:
    """:func:`measure_point` in a fresh subprocess; failures come back as ``status``."""
    cmd = [
        sys.executable,
        str(HERE),
        "--point",
        method,
        str(n_samples),
        str(basis_size or 0),
        str(repeats),
        str(mem_limit_gb),
    ]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"status": f"timeout > {timeout:.0f} s"}
    if out.returncode != 0:
        last = (out.stderr.strip().splitlines() or ["?"])[-1]
        status = "out of memory" if "MemoryError" in out.stderr else f"failed: {last[:80]}"
        return {"status": status}
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["status"] = "ok"
    return res


def _pow10(n: int) -> str:
    k = round(np.log10(n))
    return f"10^{k}" if 10**k == n else str(n)


def _row(method: str, ns: int, basis: int | None, r: dict) -> str:
    if r["status"] != "ok":
        return f"| {method} | {_pow10(ns)} | {basis or 'default'} | {r['status']} | | | | |"
    chosen = f"N={r['N']}" if r.get("N") else f"p={r['p']}"
    return (
        f"| {method} | {_pow10(ns)} | {basis or 'default'} ({chosen}) | {1e3 * r['time']:.1f} ms "
        f"| {1e3 * r['cpu']:.1f} ms "
        f"| {r['peak_call_mb']:.1f} MB | {r['max_rss_mb']:.0f} MB | {100 * r['error']:.2g} % |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="Ns up to 10^4, N up to 800")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--timeout", type=float, default=900.0, help="seconds per point")
    ap.add_argument("--mem-limit-gb", type=float, default=8.0)
    ap.add_argument("--point", nargs=5, help=argparse.SUPPRESS)
    args = ap.parse_args()

    if args.point:
        method, ns, basis, repeats, mem_gb = args.point
        import resource

        limit = int(float(mem_gb) * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        res = measure_point(method, int(ns), int(basis) or None, int(repeats))
        print(json.dumps(res))
        return

    head = subprocess.run(
        ["git", "-C", str(HERE.parent.parent), "describe", "--always", "--dirty"],
        capture_output=True,
        text=True,
    ).stdout.strip()
    print(f"# code {head or 'unknown'}; second-order benchmark, SNR 20 dB, one BLAS thread")
    sizes = [10**3, 10**4] if args.quick else [10**3, 10**4, 10**5, 10**6]
    bases = [100, 200, 400, 800] if args.quick else [100, 200, 400, 800, 1600, 3200]
    basis_ns = [10**4] if args.quick else [10**4, 10**5]
    print(
        "| method | samples | basis size | wall time (median) | CPU time | peak extra memory "
        "of the call | peak RSS of the process | eigenvalue error |"
    )
    print("|---|---|---|---|---|---|---|---|")
    kw = {"repeats": args.repeats, "timeout": args.timeout, "mem_limit_gb": args.mem_limit_gb}
    for ns in sizes:
        for method in ("hermite", "dt"):
            r = run_point(
                method,
                ns,
                None,
                repeats=1 if ns >= 10**6 else args.repeats,
                timeout=args.timeout,
                mem_limit_gb=args.mem_limit_gb,
            )
            print(_row(method, ns, None, r), flush=True)
    for ns in basis_ns:
        for basis in bases:
            r = run_point("hermite", ns, basis, **kw)
            print(_row("hermite", ns, basis, r), flush=True)


if __name__ == "__main__":
    main()
