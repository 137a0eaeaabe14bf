"""``identify(t, u, y)`` with nothing else on long records: time, memory, choice, error.

Run: ``python bench/long_records.py [--sizes 1e5 1e6 1e7] [--cli] [--tmp DIR]`` (extra
``io`` for h5py).  The default environment: no thread variables are set.  Every row runs
in a fresh subprocess; reported: wall and CPU time of the call (the process's user +
system time, all threads), the peak resident set size of the subprocess
(``resource.getrusage`` maxrss: data and interpreter included), the peak traced by
``tracemalloc`` during the call (numpy's buffers; the data excluded), the method and
order chosen, the worst relative eigenvalue error.  The times here are taken with
``tracemalloc`` running (the traced peak needs it), which slows the call; the user
table (``bench/user.py``) times the same call untraced (:func:`run_api`).

Case: a lightly damped resonance (5 Hz, damping 0.05) sampled at 1 kHz, driven by Gaussian
noise low-passed to 20 Hz, 20 dB output noise (:func:`segments.resonance_record`).
``10^5`` and ``10^6`` in memory (``identify(t, u, y)``); ``10^7`` written chunk by chunk to
an HDF5 file in a temporary directory (not timed) and identified from it
(``identify(open_chunked(path, ["u"], ["y"], dt=1e-3))``).  ``--cli``: the same 10^6 data
as a CSV file through ``hdpbsid identify FILE --inputs u --outputs y --no-plot`` (wall
time of the command, progress bar forced on).  Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve()
ROOT = HERE.parent.parent

CHILD = r"""
import json, resource, sys, time, tracemalloc, warnings
sys.path.insert(0, {bench!r})
import numpy as np
from segments import resonance
from hdpbsid import identify
from hdpbsid.models.metrics import eigenvalue_errors
ns, path, trace = {ns}, {path!r}, {trace!r}
if path:
    from hdpbsid.data.io import open_chunked
    data = (open_chunked(path, ["u"], ["y"], dt=1e-3),)
else:
    from segments import resonance_record
    data = resonance_record(ns, 0)
lam = np.linalg.eigvals(resonance()[0])
# the simulation's threaded BLAS products leave OpenBLAS's workers spinning for ~0.1 s
# (2^28 cycles, its default thread time-out): without a pause that CPU time, and the
# core it takes, are charged to the timed call, which a record read from a file never is
time.sleep(0.5)
if trace:
    tracemalloc.start()
r0 = resource.getrusage(resource.RUSAGE_SELF)
t0 = time.perf_counter()
with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    m = identify(*data)
wall = time.perf_counter() - t0
r1 = resource.getrusage(resource.RUSAGE_SELF)
cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
err = float(eigenvalue_errors(m.eigenvalues, lam).max()) if m.n == 2 else None
lr = m.options.get("long_record") or {{}}
print(json.dumps(dict(
    wall=wall, cpu=cpu, **(dict(traced=tracemalloc.get_traced_memory()[1]) if trace else {{}}),
    rss=r1.ru_maxrss * 1024, method=m.options.get("method"), order=m.n, err=err,
    refine=m.options.get("refine"), skipped=[s["method"] for s in lr.get("skipped", [])],
    selection=lr.get("selection"),
)))
"""


def _env(base: dict[str, str] | None = None) -> dict[str, str]:
    env = dict(os.environ if base is None else base)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    return env


def run_api(
    ns: int, path: str = "", timeout: float = 900, env: dict | None = None, trace: bool = True
) -> dict:
    """``identify`` on ``ns`` samples (or the file ``path``) in a fresh subprocess whose
    environment is ``env`` (default: this process's); the measurements as a dict, or
    ``{"status": ...}`` on a time-out or failure.  ``trace``: ``tracemalloc`` runs during
    the call for its traced peak (``"traced"``); it records every allocation, which
    slows the call (the first call in a process, whose imports allocate much, about
    threefold), so a timing meant as a user's time passes ``trace=False``."""
    code = CHILD.format(bench=str(HERE.parent), ns=ns, path=path, trace=trace)
    try:
        out = subprocess.run(
            [sys.executable, "-c", code],
            capture_output=True,
            text=True,
            timeout=timeout,
            env=_env(env),
            check=False,
        )
    except subprocess.TimeoutExpired:
        return {"status": f"time-out ({timeout:g} s)"}
    if out.returncode != 0:
        return {"status": f"failed: {out.stderr.strip().splitlines()[-1:]}"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def write_h5(path: Path, ns: int) -> None:
    sys.path.insert(0, str(HERE.parent))
    from scaling import write_resonance_h5

    write_resonance_h5(path, ns, 20.0)


def write_csv(path: Path, ns: int) -> None:
    sys.path.insert(0, str(HERE.parent))
    import numpy as np
    from segments import resonance_record

    t, u, y = resonance_record(ns, 0)
    np.savetxt(path, np.column_stack([t, u[:, 0], y[:, 0]]), delimiter=",", header="t,u,y",
               comments="", fmt="%.9g")  # fmt: skip


def run_cli(path: Path, out: Path, timeout: float = 900, env: dict | None = None) -> dict:
    """``hdpbsid identify`` on the CSV ``path`` (results in ``out``) in a subprocess whose
    environment is ``env`` (default: this process's): wall, CPU, peak RSS, method, whether
    a progress bar was drawn; ``{"status": ...}`` on a time-out or failure."""
    import resource

    cmd = [sys.executable, "-m", "hdpbsid", "identify", str(path), "--inputs", "u",
           "--outputs", "y", "--no-plot", "--progress", "on", "--out", str(out)]  # fmt: skip
    t0 = time.perf_counter()
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    try:
        res = subprocess.run(
            cmd, capture_output=True, text=True, timeout=timeout, env=_env(env), check=False
        )
    except subprocess.TimeoutExpired:
        return {"status": f"time-out ({timeout:g} s)"}
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        return {"status": f"failed: {res.stderr.strip().splitlines()[-1:]}"}
    bar = "stage" in res.stderr and "sample" in res.stderr
    model = json.loads((out / "model.json").read_text())
    return {
        "wall": wall,
        "cpu": (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime),
        "rss": r1.ru_maxrss * 1024,
        "method": model.get("options", {}).get("method"),
        "progress bar": bar,
    }


def _fmt(row: dict) -> str:
    if "status" in row:
        return row["status"]
    mb = lambda b: f"{b / 2**20:.0f} MB"  # noqa: E731
    err = row.get("err")
    return (
        f"{row['wall']:.1f} s | {row['cpu']:.1f} s | {mb(row['rss'])} | "
        + (f"{mb(row['traced'])} | " if "traced" in row else "| ")
        + f"{row.get('method')} | {row.get('order', '')} | "
        + (f"{100 * err:.4f} %" if err is not None else "")
        + (f" | skipped {row['skipped']}" if row.get("skipped") else "")
        + (f" | progress bar: {row['progress bar']}" if "progress bar" in row else "")
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", type=float, default=[1e5, 1e6, 1e7])
    ap.add_argument("--cli", action="store_true", help="also the CLI on the 10^6 CSV")
    ap.add_argument("--tmp", default=None, help="directory for the data files")
    ap.add_argument("--timeout", type=float, default=900)
    args = ap.parse_args()
    tmp = Path(args.tmp or tempfile.mkdtemp(prefix="hdpbsid-long-"))
    print(f"load average before: {os.getloadavg()[0]:.1f}; {os.cpu_count()} cores")
    print("| samples | source | wall | CPU | peak RSS | traced peak | method | order | "
          "worst eigenvalue error |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for s in args.sizes:
        ns = int(s)
        if ns > 2 * 10**6:
            path = tmp / f"resonance-{ns}.h5"
            if not path.exists():
                write_h5(path, ns)
            row, src = run_api(ns, str(path), args.timeout), "HDF5 file, chunked"
        else:
            row, src = run_api(ns, "", args.timeout), "in memory"
        print(f"| {ns:.0e} | {src} | {_fmt(row)} |", flush=True)
    if args.cli:
        csv = tmp / "resonance-1e6.csv"
        if not csv.exists():
            write_csv(csv, 10**6)
        row = run_cli(csv, tmp / "cli-out", args.timeout)
        print(f"| 1e+06 | CLI, CSV | {_fmt(row)} |", flush=True)
    print(f"load average after: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
