"""Time and memory of the identification methods vs the number of samples and the band.

Run: ``.venv/bin/python bench/scaling.py [--quick] [--target-only] [--out FILE]`` (the
``bench`` extra for SIPPY, ``cluster`` for Dask, ``io`` for h5py).  One run, one table;
every point runs in a fresh subprocess (the default environment: no thread variable set;
address space capped at ``--mem-limit-gb``), so the timings of all methods are taken side
by side under the same machine load (the load average is printed with the table).

Rows (``sweep`` column):

* ``target``: the numbers the scaling work aims at --
  ``binary 10^4``: the second-order system of :mod:`hdpbsid.systems` (``dt = 0.01``),
  random binary input held 5 samples, 20 dB, order 2: HD-PBSID with every default
  (``identify(..., method="hermite", order=2)``) against SIPPY N4SID (``f = p = 60``),
  alternating on ``--seeds`` seeds in one process (median wall and CPU times, their
  ratios, median, RMS and worst eigenvalue errors).  Each runs as a user runs it: N4SID
  on the BLAS threads of the environment, HD-PBSID with the thread counts it sets itself
  (:mod:`hdpbsid.runtime`: one BLAS thread for its small-matrix work, its projection on
  the numba threads); the wall-time ratio is the target's, the CPU-time ratio tells what
  the cores add;
  ``resonance70``: a lightly damped 70 Hz resonance sampled at 610 Hz, 86 000 samples,
  multisine to 200 Hz, 20 dB (:func:`segments.resonance70_record`);
  ``projection``: 10^6 uniform samples onto 2000 Hermite functions
  (:meth:`slbasis.Basis.project`, default engine);
* ``samples``: the 5 Hz resonance sampled at 1 kHz, input low-passed to 20 Hz, 20 dB,
  order 2 (:func:`segments.resonance_record`), ``Ns = 10^3 ... 10^6`` for ``hermite``,
  ``laguerre``, ``dt``, ``hermite`` + ``refine="pem"`` and SIPPY N4SID (``f = p = 60``,
  up to 10^5), and ``10^6``, ``10^7`` through the chunked path
  (:func:`hdpbsid.methods.chunked.identify_chunked`) on a ``dask.distributed``
  ``LocalCluster`` (2 worker processes, one thread each), the record written chunk by
  chunk to an HDF5 file under ``--tmp`` first (not timed);
* ``band``: the same resonance at ``10^5`` samples with the input band 10 ... 200 Hz.

Reported per point: median wall and CPU time of the identification call (``--repeats``
for points below 10^6 samples, after one untimed warm-up; one call above); the peak
*extra* memory of one call traced by ``tracemalloc`` (numpy reports its buffers to it;
the data and the interpreter excluded); the peak resident set size of the process; the
worst relative eigenvalue error.  Chunked rows: the driver's traced peak and the peak
RSS of the largest worker (its RSS before the call in brackets).  Failures (time-out,
memory) are reported as such.  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve()
sys.path.insert(0, str(HERE.parent))

N4SID_HORIZON = 60
METHODS = ("hermite", "laguerre", "dt", "hermite+pem", "n4sid")


# -- data -------------------------------------------------------------------------------
def binary_record(ns: int, seed: int):
    """Second-order system, random binary input held 5 samples, ``dt = 0.01``, 20 dB."""
    from hdpbsid.systems import add_noise, second_order, simulate_zoh

    rng = np.random.default_rng(seed)
    A, B, C, D = second_order()
    t = np.arange(ns) * 0.01
    u = np.repeat(np.sign(rng.standard_normal(ns // 5 + 1)), 5)[:ns][:, None]
    y, _ = add_noise(simulate_zoh(A, B, C, D, t, u), 20.0, rng)
    return (t, u, y), np.linalg.eigvals(A)


def resonance_data(ns: int, band: float, seed: int = 0):
    from segments import resonance, resonance_record

    return resonance_record(ns, seed, band_hz=band), np.linalg.eigvals(resonance()[0])


def write_resonance_h5(path: Path, ns: int, band: float, chunk: int = 2**20, seed: int = 0):
    """The resonance record written chunk by chunk (filter states carried across chunks;
    the 20 dB noise level from the first chunk's output power)."""
    import h5py
    from scipy import signal
    from segments import FS, resonance

    from hdpbsid.models.conversion import c2d

    rng = np.random.default_rng(seed)
    A, B, C, D = resonance()
    sos = signal.butter(8, band, fs=FS, output="sos")
    Ad, Bd, Cd, Dd, _ = c2d(A, B, C, D, None, 1.0 / FS)
    num, den = signal.ss2tf(Ad, Bd, Cd, Dd)
    zs = np.zeros((sos.shape[0], 2))
    zl = np.zeros(max(len(den), len(num[0])) - 1)
    _, zs = signal.sosfilt(sos, rng.standard_normal(2000), zi=zs)  # settle the filter
    sigma = None
    with h5py.File(path, "w") as f:
        du = f.create_dataset("u", (ns,), dtype="f8", chunks=(min(ns, 2**16),))
        dy = f.create_dataset("y", (ns,), dtype="f8", chunks=(min(ns, 2**16),))
        for a in range(0, ns, chunk):
            b = min(ns, a + chunk)
            u, zs = signal.sosfilt(sos, rng.standard_normal(b - a), zi=zs)
            y, zl = signal.lfilter(num[0], den, u, zi=zl)
            if sigma is None:
                sigma = np.sqrt(np.mean(y**2)) * 10 ** (-20.0 / 20)
            du[a:b] = u
            dy[a:b] = y + sigma * rng.standard_normal(b - a)
    return np.linalg.eigvals(A)


# -- one point, in a fresh process ------------------------------------------------------
def _errors(est, true) -> float:
    from hdpbsid.models.metrics import eigenvalue_errors

    return float(eigenvalue_errors(est, true).max())


def _n4sid(t, u, y):
    import contextlib
    import io

    from sippy_unipi import system_identification

    h = float(t[1] - t[0])
    with contextlib.redirect_stdout(io.StringIO()):
        s = system_identification(
            y.T, u.T, "N4SID", SS_fixed_order=2, SS_f=N4SID_HORIZON, SS_p=N4SID_HORIZON, tsample=h
        )
    return np.log(np.linalg.eigvals(s.A).astype(complex)) / h


def _fit(method: str, data):
    import warnings

    import hdpbsid

    t, u, y = data
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if method == "n4sid":
            return _n4sid(t, u, y), {}
        name, _, refine = method.partition("+")
        m = hdpbsid.identify(t, u, y, order=2, method=name, refine=refine or None)
        o = m.options
        return m.eigenvalues, {k: o.get(k) for k in ("N", "p", "n_segments")}


def _timed(call, repeats: int):
    """Median wall and CPU time of ``repeats`` calls, each with empty result caches.

    The methods memoise their order-independent steps by the record's contents
    (:mod:`hdpbsid.bases.memo`); without clearing, a repeat would time a cache hit.
    """
    import time

    from hdpbsid.bases.memo import clear_caches

    out, times, cpu = None, [], []
    for _ in range(repeats):
        clear_caches()
        t0, c0 = time.perf_counter(), time.process_time()
        out = call()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return out, float(np.median(times)), float(np.median(cpu))


def _traced(call) -> float:
    import tracemalloc

    from hdpbsid.bases.memo import clear_caches

    clear_caches()  # trace the whole call, not a cache hit
    tracemalloc.start()
    call()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


def _rss_mb() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def measure_point(spec: dict) -> dict:
    kind, method, ns = spec["case"], spec["method"], int(spec["ns"])
    repeats = int(spec.get("repeats", 1)) if ns < 10**6 else 1
    if kind == "binary-target":
        return _binary_target(ns, int(spec["seeds"]))
    if kind == "projection":
        return _projection(ns, int(spec["N"]))
    if method == "chunked":
        return _chunked(ns, float(spec["band"]), Path(spec["tmp"]))
    if kind == "resonance70":
        from segments import resonance70, resonance70_record

        data, true = resonance70_record(0), np.linalg.eigvals(resonance70()[0])
    else:
        data, true = resonance_data(ns, float(spec["band"]))
    _fit(method, resonance_data(10**4, 20.0)[0])  # warm-up: imports, compiled kernels
    (eig, info), wall, cpu = _timed(lambda: _fit(method, data), repeats)
    peak = _traced(lambda: _fit(method, data))
    return {
        "time": wall,
        "cpu": cpu,
        "peak_mb": peak,
        "rss_mb": _rss_mb(),
        "error": _errors(eig, true),
        **info,
    }


#: the target's contestants: HD-PBSID's subspace fit alone (``refine=None``), HD-PBSID with
#: its default refinement (``refine="auto"``), SIPPY N4SID
TARGET_METHODS = ("hermite", "hermite+auto", "n4sid")


def _binary_target(ns: int, seeds: int) -> dict:
    from hdpbsid.bases.memo import clear_caches

    out: dict[str, list] = {k: [] for k in TARGET_METHODS}
    cpu: dict[str, list] = {k: [] for k in TARGET_METHODS}
    err: dict[str, list] = {k: [] for k in TARGET_METHODS}
    for method in TARGET_METHODS:
        _fit(method, binary_record(ns, 99)[0])  # compile and warm up
    for s in range(seeds):
        data, true = binary_record(ns, s)
        for method in TARGET_METHODS:
            clear_caches()  # each method projects the record itself
            (eig, _), wall, c = _timed(lambda m=method, d=data: _fit(m, d), 1)
            out[method].append(wall)
            cpu[method].append(c)
            err[method].append(_errors(eig, true))
    ref = err["n4sid"]
    return {
        "time": {k: float(np.median(v)) for k, v in out.items()},
        "cpu": {k: float(np.median(v)) for k, v in cpu.items()},
        "error_median": {k: float(np.median(v)) for k, v in err.items()},
        "error_rms": {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in err.items()},
        "error_max": {k: float(np.max(v)) for k, v in err.items()},
        "wins": {
            k: int(sum(a <= b for a, b in zip(err[k], ref, strict=True)))
            for k in TARGET_METHODS[:-1]
        },
        "seeds": seeds,
    }


def _projection(ns: int, N: int) -> dict:
    import slbasis

    t = np.linspace(0.0, 1.0, ns)
    x = np.sin(40 * t)[:, None]
    B = slbasis.basis("hermite", N, (0.0, 1.0))
    B.project(t[:5000], x[:5000])  # compile / load the kernels
    _, wall, cpu = _timed(lambda: B.project(t, x), 1)
    peak = _traced(lambda: B.project(t, x))
    return {"time": wall, "cpu": cpu, "peak_mb": peak, "rss_mb": _rss_mb(), "error": None}


def _chunked(ns: int, band: float, tmp: Path) -> dict:
    import resource
    import time
    import tracemalloc

    from dask.distributed import Client, LocalCluster

    from hdpbsid.data.io import open_chunked
    from hdpbsid.methods.chunked import identify_chunked

    tmp.mkdir(parents=True, exist_ok=True)
    path = tmp / f"resonance-{ns}.h5"
    true = write_resonance_h5(path, ns, band)
    rec = open_chunked(path, ["u"], ["y"], fs=1000.0)

    def worker_rss() -> float:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cl,
        Client(cl) as client,
    ):
        client.run(lambda: __import__("hdpbsid.methods.chunked"))
        before = max(client.run(worker_rss).values())
        tracemalloc.start()
        t0, c0 = time.perf_counter(), time.process_time()
        m = identify_chunked(rec, order=2, use_dask=True)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
        workers = max(client.run(worker_rss).values())
    path.unlink()
    return {
        "time": wall,
        "cpu": cpu,
        "peak_mb": peak,
        "rss_mb": _rss_mb(),
        "worker_rss_mb": workers,
        "worker_rss_before_mb": before,
        "error": _errors(m.eigenvalues, true),
        "N": m.options["N"],
        "p": m.options["p"],
        "n_segments": m.options["n_segments"],
        "batches": m.options["chunked"]["batches"],
    }


# -- driver -----------------------------------------------------------------------------
def run_point(spec: dict, timeout: float, mem_limit_gb: float) -> dict:
    """:func:`measure_point` in a fresh subprocess; failures come back as ``status``."""
    cmd = [
        sys.executable,
        str(HERE),
        "--point",
        json.dumps(spec),
        "--mem-limit-gb",
        str(mem_limit_gb),
    ]
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return {"status": f"timeout > {timeout:.0f} s"}
    if out.returncode != 0:
        last = (out.stderr.strip().splitlines() or ["?"])[-1]
        status = "out of memory" if "MemoryError" in out.stderr else f"failed: {last[:70]}"
        return {"status": status}
    res = json.loads(out.stdout.strip().splitlines()[-1])
    res["status"] = "ok"
    return res


def _pow10(n: int) -> str:
    k = round(np.log10(n))
    return f"10^{k}" if 10**k == n else f"{n:,}"


def _ms(x: float) -> str:
    return f"{x:.2f} s" if x >= 1 else f"{1e3 * x:.0f} ms"


def _row(sweep: str, case: str, method: str, spec: dict, r: dict) -> str:
    head = f"| {sweep} | {case} | {method} | {_pow10(int(spec['ns']))} | {spec.get('band', '')} |"
    if r["status"] != "ok":
        return f"{head} {r['status']} | | | | | |"
    notes = ", ".join(f"{k}={r[k]}" for k in ("N", "p", "n_segments", "batches") if r.get(k))
    mem = f"{r['peak_mb']:.0f} MB"
    rss = f"{r['rss_mb']:.0f} MB"
    if "worker_rss_mb" in r:
        rss += f"; workers {r['worker_rss_mb']:.0f} MB (before {r['worker_rss_before_mb']:.0f})"
    err = "" if r["error"] is None else f"{100 * r['error']:.3g} %"
    return f"{head} {_ms(r['time'])} | {_ms(r['cpu'])} | {mem} | {rss} | {err} | {notes} |"


def _target_row(spec: dict, r: dict) -> str:
    what = f"HD-PBSID (refine=None / default refinement) vs N4SID f=p={N4SID_HORIZON}"
    head = f"| target | binary, 2nd order | {what} | {_pow10(int(spec['ns']))} | |"
    if r["status"] != "ok":
        return f"{head} {r['status']} | | | | | |"

    def trio(values: dict, fmt) -> str:
        return " / ".join(fmt(values[k]) for k in TARGET_METHODS)

    def ratios(values: dict) -> str:
        return " / ".join(f"{values[k] / values['n4sid']:.2f}" for k in TARGET_METHODS[:-1])

    def pct(x: float) -> str:
        return f"{100 * x:.3g} %"

    wins = " / ".join(str(r["wins"][k]) for k in TARGET_METHODS[:-1])
    return (
        f"{head} {trio(r['time'], _ms)} (ratio {ratios(r['time'])}) | "
        f"{trio(r['cpu'], _ms)} (ratio {ratios(r['cpu'])}) | | | "
        f"median {trio(r['error_median'], pct)}; RMS {trio(r['error_rms'], pct)}; worst "
        f"{trio(r['error_max'], pct)} | error <= N4SID's on {wins} of {r['seeds']} seeds |"
    )


def _finish(lines: list[str], emit, out: str | None) -> None:
    emit(f"# load average at the end {os.getloadavg()[0]:.2f}")
    if out:
        Path(out).write_text(_markdown(lines))


def _markdown(lines: list[str]) -> str:
    """The printed lines as a Markdown page: the ``# ...`` remarks become paragraphs
    (as headings they would title the page that includes the table)."""
    out: list[str] = []
    for line in lines:
        if line.startswith("# "):
            out += ["", line[2:] + ".", ""]
        else:
            out.append(line)
    return "\n".join(out).strip() + "\n"


def _chunked_rows(args, quick: bool, kw: dict, emit) -> None:
    for ns in [10**5] if quick else [10**6, 10**7]:
        spec = {"case": "resonance", "method": "chunked", "ns": ns, "band": 20, "tmp": args.tmp}
        emit(
            _row(
                "samples",
                "5 Hz resonance, HDF5 file",
                "hermite chunked, Dask",
                spec,
                run_point(spec, **kw),
            )
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="small sizes only (a smoke run)")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--seeds", type=int, default=5, help="seeds of the binary 10^4 target")
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per point")
    ap.add_argument("--mem-limit-gb", type=float, default=8.0)
    ap.add_argument("--tmp", default="/tmp/hdpbsid-scaling", help="directory of the chunked files")
    ap.add_argument(
        "--out", help="also write the table to this file (the docs page: bench/results/scaling.md)"
    )
    ap.add_argument(
        "--target-only",
        action="store_true",
        help="only the binary 10^4 target row (HD-PBSID vs N4SID)",
    )
    ap.add_argument(
        "--chunked-only",
        action="store_true",
        help="only the chunked rows (10^6 and 10^7 samples from an HDF5 file on Dask)",
    )
    ap.add_argument("--point", help=argparse.SUPPRESS)
    args = ap.parse_args()

    if args.point:
        import resource

        limit = int(args.mem_limit_gb * 2**30)
        resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        print(json.dumps(measure_point(json.loads(args.point))))
        return

    head = subprocess.run(
        ["git", "-C", str(HERE.parent.parent), "describe", "--always", "--dirty"],
        capture_output=True,
        text=True,
    ).stdout.strip()
    print(f"# code {head or 'unknown'}", flush=True)  # the log's, not the table's
    from importlib.metadata import PackageNotFoundError, version

    day = time.strftime("%Y-%m-%d", time.gmtime())
    try:
        package = f"slbasis-hdpbsid {version('slbasis-hdpbsid')}"
    except PackageNotFoundError:  # run from a source tree that was not installed
        package = "slbasis-hdpbsid (not installed)"
    lines = [
        f"# {package}, {day}; default environment; load average at start "
        f"{os.getloadavg()[0]:.2f} ({os.cpu_count()} CPUs)",
        "| sweep | case | method | samples | input band (Hz) | wall time | CPU time "
        "| peak extra memory of the call | peak RSS | worst eigenvalue error | notes |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for line in lines:
        print(line, flush=True)
    kw = {"timeout": args.timeout, "mem_limit_gb": args.mem_limit_gb}

    def emit(line: str) -> None:
        lines.append(line)
        print(line, flush=True)

    quick = args.quick
    if args.chunked_only:
        _chunked_rows(args, quick, kw, emit)
        _finish(lines, emit, args.out)
        return
    spec = {"case": "binary-target", "method": "", "ns": 10**4, "seeds": 2 if quick else args.seeds}
    emit(_target_row(spec, run_point(spec, **kw)))
    if args.target_only:
        _finish(lines, emit, args.out)
        return
    spec = {"case": "resonance70", "method": "hermite", "ns": 86_000, "band": 200, "repeats": 1}
    emit(_row("target", "70 Hz resonance at 610 Hz", "hermite", spec, run_point(spec, **kw)))
    spec = {"case": "projection", "method": "", "ns": 10**5 if quick else 10**6, "N": 2000}
    emit(_row("target", "projection, N = 2000", "slbasis project", spec, run_point(spec, **kw)))

    sizes = [10**3, 10**4] if quick else [10**3, 10**4, 10**5, 10**6]
    for ns in sizes:
        for method in METHODS:
            if method == "n4sid" and ns > 10**5:
                continue
            spec = {
                "case": "resonance",
                "method": method,
                "ns": ns,
                "band": 20,
                "repeats": args.repeats,
            }
            emit(_row("samples", "5 Hz resonance", method, spec, run_point(spec, **kw)))
    _chunked_rows(args, quick, kw, emit)
    bands = [10, 50] if quick else [10, 20, 50, 100, 200]
    ns = 10**4 if quick else 10**5
    for band in bands:
        for method in METHODS:
            spec = {
                "case": "resonance",
                "method": method,
                "ns": ns,
                "band": band,
                "repeats": args.repeats,
            }
            emit(_row("band", "5 Hz resonance", method, spec, run_point(spec, **kw)))
    _finish(lines, emit, args.out)


if __name__ == "__main__":
    main()
