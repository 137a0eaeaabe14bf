"""What a user gets: the calls of a session timed in the default environment and with
one thread, side by side.

Run: ``python bench/user.py [--reps 5] [--rows NAME ...] [--list] [--md FILE]``

One table, printed and written as markdown to ``--md`` (default
``bench/results/user.md``, which the docs include) with the command that reproduces it
and the load average in its header.  Every row runs its work in fresh subprocesses: in
the **default environment** (what a user has: no thread variables set) and with **one
thread** (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS`` and
``NUMBA_NUM_THREADS`` set to 1), one process per repetition and column, the columns
alternating (default, one thread, one thread, default, ...: a load that drifts during
the row shifts both columns alike), and prints the median wall and CPU time of
``--reps`` repetitions and the ratio default / one thread of the medians.  CPU time is
the process's (all its threads), which a machine shared with other work disturbs less
than wall time.  The load average at the start and the end is in the table's header
and under it: on a loaded machine compare the ratios, not the absolute times.

Rows (``--list``):

* ``identify(t, u, y, order=3, method="hermite")`` and ``identify(t, u, y)`` on records of
  6000 samples (the closed-loop quadrotor of ``bench/cases.py`` at 20 dB, 24 s at 250 Hz;
  the second-order system with a smooth random input, 60 s at 100 Hz), with numba and
  with ``NUMBA_DISABLE_JIT=1`` (which the library treats as "no numba": numpy kernels);
  each repetition on a record of another seed, after one call on a further seed (imports,
  kernel cache, first-use setup) in the same process, so that no result is reused
  between repetitions;
* the first call with an empty kernel cache: ``import hdpbsid`` and one
  ``identify(..., order=3, method="hermite")`` in a fresh process whose
  ``NUMBA_CACHE_DIR`` is a new empty directory (the background compilation it starts is
  stopped when the time is taken);
* ``import hdpbsid`` and ``hdpbsid --help``: the whole process (interpreter start
  included), with ``import numpy`` (which ``--help`` needs) and ``import numpy,
  scipy.linalg`` (which the first ``identify`` needs) for comparison.

* ``sippy``: SIPPY N4SID (``f = p = 60``), ``identify(t, u, y, order=2)`` and HD-PBSID,
  ``identify(t, u, y, order=2, method="hermite")`` (the order is what N4SID is told;
  every other argument at its default) on ``--reps`` seeds (at least
  :data:`SIPPY_MIN_SEEDS`) of the 10^4-sample binary-input case of ``bench/scaling.py``
  (its functions), one worker process per method, seed and column (a threaded BLAS still
  spinning after one method's call must not be charged to the other), each seed's time
  the median of :data:`SIPPY_CALLS` calls; the worst eigenvalue error (median
  over the seeds) in the label and the ratio hdpbsid / N4SID of the default column on a
  line of its own.
  Without SIPPY (``pip install sippy-unipi``, extra ``bench``) the row says so;
* ``long-5``, ``long-6``: ``identify(t, u, y)`` with nothing else on 10^5 and 10^6
  samples of the lightly damped record of ``bench/long_records.py`` (its functions:
  one call per column and repetition in a fresh process, the columns alternating, timed
  without ``tracemalloc``, which would slow the call threefold; peak RSS, method,
  order, worst eigenvalue error of the default column in the label), and
  for 10^6 ``hdpbsid identify`` on the same record as a 10^6-line CSV, alternating
  likewise; ``long-7`` (only when named in ``--rows``: minutes)
  10^7 samples from a chunked HDF5 file (extra ``io``).  ``--timeout`` bounds each call.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
_DATA = {"dir": ""}  # the records of this table (set by main)
ROOT = HERE.parent
THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
#: every variable that sets a thread count; the default column removes them all
ALL_THREAD_VARIABLES = (*THREAD_VARIABLES, "NUMBA_NUM_THREADS", "HDPBSID_NUM_THREADS")
#: the kernel modules compiled before the table, so that rows other than the first-call
#: row time a filled cache (``make compiled`` does the same)
JIT_MODULES = (
    "slbasis.numeric.compiled",
    "hdpbsid.models.recursion_kernels",
    "hdpbsid.refine.pem_kernels",
)


# -- the work of each row, run inside a worker subprocess ---------------------------------
def _make_record(case: str, seed: int):
    sys.path.insert(0, str(HERE))
    from cases import quadrotor, second_order_smooth

    if case == "quadrotor":
        data = quadrotor(seed, 20.0, duration=24.0)
    elif case == "second-order":
        data = second_order_smooth(seed, 20.0, T=60.0)
    else:  # pragma: no cover - the rows name the cases
        raise ValueError(f"unknown case {case!r}")
    r = data.estimation
    return r.t, r.u, r.y


def _record(case: str, seed: int):
    """The record of ``case`` and ``seed``, made once per table (the quadrotor's closed-loop
    simulation takes longer than its identification) in ``BENCH_USER_DATA``.

    The process that makes it pauses 0.5 s after the simulation: in the default
    environment the simulation's threaded BLAS products leave OpenBLAS's workers spinning
    for ~0.1 s, which would be charged to the timed call that follows (and only in the
    column whose process happens to make the record)."""
    import numpy as np

    path = Path(os.environ["BENCH_USER_DATA"]) / f"{case}-{seed}.npz"
    if not path.exists():
        t, u, y = _make_record(case, seed)
        tmp = path.with_suffix(".tmp.npz")
        np.savez(tmp, t=t, u=u, y=y)
        tmp.replace(path)
        time.sleep(0.5)
    with np.load(path) as f:
        return f["t"], f["u"], f["y"]


def _time_calls(case: str, options: dict, reps: int, first: int = 0) -> dict:
    """Wall and CPU times of ``identify`` on the records of seeds ``first ... first + reps - 1``."""
    import hdpbsid

    t, u, y = _record(case, 1000)
    hdpbsid.identify(t, u, y, **options)  # first use: imports, kernel cache, bases
    walls, cpus = [], []
    for seed in range(first, first + reps):
        t, u, y = _record(case, seed)
        w0, c0 = time.perf_counter(), time.process_time()
        hdpbsid.identify(t, u, y, **options)
        walls.append(time.perf_counter() - w0)
        cpus.append(time.process_time() - c0)
    return {"wall": walls, "cpu": cpus, "samples": int(len(t))}


def _first_call(reps: int, first: int = 0) -> dict:
    """``import hdpbsid`` and a first ``identify`` in this fresh process (the caller set
    an empty ``NUMBA_CACHE_DIR``); one measurement (``reps`` is for the caller)."""
    t, u, y = _record("quadrotor", 0)
    w0, c0 = time.perf_counter(), time.process_time()
    import hdpbsid

    hdpbsid.identify(t, u, y, order=3, method="hermite")
    wall, cpu = time.perf_counter() - w0, time.process_time() - c0
    from slbasis.numeric import jit

    proc = jit._process["proc"]
    if proc:  # the background compilation this call started: stop it, it is not timed
        proc.terminate()
        proc.wait()
    return {"wall": [wall], "cpu": [cpu], "samples": int(len(t))}


#: the 10^4-sample binary-input case of ``bench/scaling.py``: ``identify`` given the order
#: (the one thing N4SID is told), every other argument at its default
SIPPY_SAMPLES = 10**4
#: calls per record and process, their median the record's time: a 0.2 s call varies by
#: ~10 % from call to call (the machine's other work, the allocator)
SIPPY_CALLS = 3
#: records (seeds, one process per side, column and seed) at least: the median time of a
#: process varies by ~15 % from process to process on one machine (where its arrays fall
#: in memory, which cores its threads get), so the median of 5 moved the ratio to N4SID by
#: up to a factor 2 between runs; the median of 15 is within ~5 %
SIPPY_MIN_SEEDS = 15
HDPBSID_SPEC = "auto+auto"  # scaling._fit: method "auto", refine "auto" (the defaults)
#: HD-PBSID itself: ``method="hermite"``, its refinement and every setting at the default
HERMITE_SPEC = "hermite+auto"


#: the sides of the SIPPY row: the key of the result and the spec of ``scaling._fit``
SIPPY_SPECS = {"n4sid": "n4sid", "hdpbsid": HDPBSID_SPEC, "hermite": HERMITE_SPEC}
#: the labels of the sides that are ours, in the order of the table
OUR_SIDES = {
    "hdpbsid": "identify(t, u, y, order=2), same records",
    "hermite": 'HD-PBSID: identify(t, u, y, order=2, method="hermite"), same records',
}
SHORT_NAMES = {"hdpbsid": "identify(order=2)", "hermite": "HD-PBSID"}


def _sippy_binary(key: str, reps: int, first: int = 0) -> dict:
    """SIPPY N4SID (``f = p = 60``, ``key="n4sid"``), ``identify(t, u, y, order=2)``
    (``key="hdpbsid"``) or HD-PBSID (``key="hermite"``) on the seeds ``first ... first +
    reps - 1`` of :func:`scaling.binary_record` in this process, after one untimed call on
    the record of another seed and the same length (imports, kernels, first-use setup, as
    the other rows): wall, CPU time and worst relative eigenvalue error of each call. Not a
    shorter record: it can take other paths (on this case the refinement screens its second
    input hold by one Gauss-Newton step only on the longer record), whose compiled kernels
    would then load from numba's cache inside the timed call, a one-off cost of the process
    that N4SID has no counterpart of.

    One side per process, and the records simulated before the untimed call: a threaded
    BLAS keeps its threads spinning for a while after a call returns (OpenBLAS: a fixed
    number of cycles before they sleep, ~0.1 s), so a call timed right after the other
    side's, or right after the simulation of its record, was charged that CPU time, and
    its wall time the core the spinning took (measured: +0.05-0.1 s of CPU on a 0.2 s
    call)."""
    if key == "n4sid":
        try:
            import sippy_unipi  # noqa: F401
        except ImportError as exc:
            return {"status": f"SIPPY not installed ({exc}): pip install sippy-unipi (extra bench)"}
    sys.path.insert(0, str(HERE))
    from scaling import _errors, _fit, binary_record

    from hdpbsid.bases.memo import clear_caches

    spec = SIPPY_SPECS[key]
    out: dict = {key: {"wall": [], "cpu": [], "err": []}}
    # every record simulated before the untimed call (see above: the simulation's own
    # BLAS threads would still spin inside the next call's time)
    records = [binary_record(SIPPY_SAMPLES, seed) for seed in range(first, first + reps)]
    _fit(spec, binary_record(SIPPY_SAMPLES, 99)[0])  # imports, kernels, first use
    for data, true in records:
        walls, cpus = [], []
        for _ in range(SIPPY_CALLS):
            clear_caches()  # the method projects the record itself
            w0, c0 = time.perf_counter(), time.process_time()
            eig, _ = _fit(spec, data)
            walls.append(time.perf_counter() - w0)
            cpus.append(time.process_time() - c0)
        out[key]["wall"].append(_median(walls))
        out[key]["cpu"].append(_median(cpus))
        out[key]["err"].append(_errors(eig, true))
    return out


def _cli_csv(csv: str, out: str, timeout: float) -> dict:
    """:func:`long_records.run_cli` from this (fresh) process, so that the peak RSS of its
    children is the command's alone; the order and worst eigenvalue error read from the
    model file the command wrote."""
    sys.path.insert(0, str(HERE))
    import numpy as np
    from long_records import run_cli
    from segments import resonance

    from hdpbsid.models.metrics import eigenvalue_errors

    got = run_cli(Path(csv), Path(out), timeout, env=dict(os.environ))
    if "status" in got:
        return got
    model = json.loads((Path(out) / "model.json").read_text())
    A = np.asarray(model["A"], dtype=float)
    got["order"] = int(model["n"])
    true = np.linalg.eigvals(resonance()[0])
    got["err"] = (
        float(eigenvalue_errors(np.linalg.eigvals(A), true).max()) if A.shape == (2, 2) else None
    )
    return got


WORKERS: dict[str, Callable[[int, int], dict]] = {
    "hermite-quadrotor": lambda r, f: _time_calls(
        "quadrotor", {"order": 3, "method": "hermite"}, r, f
    ),
    "auto-quadrotor": lambda r, f: _time_calls("quadrotor", {}, r, f),
    "auto-second-order": lambda r, f: _time_calls("second-order", {}, r, f),
    "first-call": _first_call,
    "sippy-n4sid": lambda r, f: _sippy_binary("n4sid", r, f),
    "sippy-hdpbsid": lambda r, f: _sippy_binary("hdpbsid", r, f),
    "sippy-hermite": lambda r, f: _sippy_binary("hermite", r, f),
}


# -- rows ------------------------------------------------------------------------------------
@dataclass
class Row:
    """One line of the table: what is timed, and how (a worker or a whole command)."""

    name: str
    label: str
    worker: str | None = None  # a key of WORKERS, run with --worker
    command: tuple[str, ...] | None = None  # a whole process, timed from outside
    env: dict[str, str] | None = None  # added to both columns
    fresh_cache: bool = False  # a new empty NUMBA_CACHE_DIR per repetition


ROWS = [
    Row("hermite", 'identify(order=3, method="hermite"), quadrotor', worker="hermite-quadrotor"),
    Row("auto", "identify(t, u, y), quadrotor", worker="auto-quadrotor"),
    Row("auto-2nd", "identify(t, u, y), second order", worker="auto-second-order"),
    Row(
        "hermite-nojit",
        'identify(order=3, method="hermite"), quadrotor, NUMBA_DISABLE_JIT=1',
        worker="hermite-quadrotor",
        env={"NUMBA_DISABLE_JIT": "1"},
    ),
    Row(
        "auto-nojit",
        "identify(t, u, y), quadrotor, NUMBA_DISABLE_JIT=1",
        worker="auto-quadrotor",
        env={"NUMBA_DISABLE_JIT": "1"},
    ),
    Row(
        "auto-2nd-nojit",
        "identify(t, u, y), second order, NUMBA_DISABLE_JIT=1",
        worker="auto-second-order",
        env={"NUMBA_DISABLE_JIT": "1"},
    ),
    Row(
        "first-call",
        "import + first identify(hermite), empty kernel cache",
        worker="first-call",
        fresh_cache=True,
    ),
    Row("import", "process: import hdpbsid", command=("-c", "import hdpbsid")),
    Row("help", "process: hdpbsid --help", command=("-m", "hdpbsid", "--help")),
    Row("numpy", "process: import numpy", command=("-c", "import numpy")),
    Row(
        "scipy", "process: import numpy, scipy.linalg", command=("-c", "import numpy, scipy.linalg")
    ),
]


#: a line of the table from a hook: label, default column, one-thread column
Line = tuple[str, dict | None, dict | None]


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.3g} %"


def sippy_row(reps: int, options: argparse.Namespace) -> list[Line]:
    """SIPPY N4SID (``f = p = 60``) against ``identify(t, u, y, order=2)`` and HD-PBSID
    (``method="hermite"``; every other argument at its default) on the 10^4-sample
    binary-input case of ``bench/scaling.py``, each in its own worker process per seed,
    side and column (:func:`_sippy_binary`), the columns alternating on ``reps`` seeds.
    Lines: each side's times (labels: median worst eigenvalue error in the default
    column), then the ratio of each of ours to N4SID of the default column's medians."""

    def both(one: bool, i: int) -> dict:
        env = _environment(one, None)
        return _merge([_spawn(f"sippy-{key}", 1, env, first=i) for key in SIPPY_SPECS])

    got = _alternate(max(reps, SIPPY_MIN_SEEDS), both)
    if "status" in got[False]:
        return [("SIPPY N4SID, 10^4 binary-input case", got[False], got[True])]
    lines: list[Line] = []
    labels = {"n4sid": "SIPPY N4SID f=p=60, 10^4 binary input", **OUR_SIDES}
    for key, label in labels.items():
        err = _median(got[False][key]["err"])
        lines.append((f"{label}; worst eig. error {_pct(err)}", got[False][key], got[True][key]))
    for key in OUR_SIDES:
        lines.append((_ratio_line(key, got[False]), None, None))
    return lines


def _ratio_line(key: str, default: dict) -> str:
    """The ratio ``key`` / N4SID of the default column's median wall and CPU times, and on
    how many seeds ``key``'s worst eigenvalue error is no larger than N4SID's."""
    ratio = {k: _median(default[key][k]) / _median(default["n4sid"][k]) for k in ("wall", "cpu")}
    pairs = list(zip(default[key]["err"], default["n4sid"]["err"], strict=True))
    smaller = sum(h <= n for h, n in pairs)
    return (
        f"{SHORT_NAMES[key]} / N4SID, default environment: wall"
        f" {ratio['wall']:.2f}x, CPU {ratio['cpu']:.2f}x; worst eig. error no larger than"
        f" N4SID's on {smaller} of {len(pairs)} seeds"
    )


def _long_details(r: dict) -> str:
    if "status" in r:
        return r["status"]
    mb = r["rss"] / 2**20
    out = f"peak RSS {mb:.0f} MB, {r.get('method')}"
    if "order" in r:
        out += f", order {r['order']}, worst eig. error {_pct(r.get('err'))}"
    if r.get("skipped"):
        out += f", skipped {r['skipped']}"
    if "progress bar" in r:
        out += f", progress bar {r['progress bar']}"
    return out


def _as_times(r: dict) -> dict:
    return r if "status" in r else {"wall": r["wall"], "cpu": r["cpu"]}


def _one_run(r: dict) -> dict:
    """One long-record run as a part for :func:`_merge`: its times as lists (the
    repetitions concatenate), the rest as the last run's."""
    if "status" in r:
        return r
    out = dict(r, wall=[r["wall"]], cpu=[r["cpu"]])
    if "skipped" in out:
        out["skipped"] = str(out["skipped"])
    return out


def long_record_row(n_samples: int, reps: int, options: argparse.Namespace) -> list[Line]:
    """``identify(t, u, y)`` with nothing else on ``n_samples`` of the lightly damped
    second-order record of ``bench/long_records.py`` (in memory up to 2 10^6 samples, from
    a chunked HDF5 file above), one call per column and repetition in a fresh process,
    the columns alternating (``reps`` repetitions in memory; one above, where a call
    takes minutes), and for 10^6 also ``hdpbsid identify`` on the same record as a CSV
    file, alternating likewise.  Labels: peak RSS, method, order, worst eigenvalue error
    of the default column."""
    sys.path.insert(0, str(HERE))
    from long_records import run_api, write_csv, write_h5

    tmp = Path(_DATA["dir"])
    path = ""
    if n_samples > 2 * 10**6:
        path = str(tmp / f"resonance-{n_samples}.h5")
        if not Path(path).exists():
            write_h5(Path(path), n_samples)
    runs = 1 if path else reps
    got = _alternate(
        runs,
        lambda one, i: _one_run(
            run_api(n_samples, path, options.timeout, env=_environment(one, None), trace=False)
        ),
    )
    src = "chunked HDF5" if path else "in memory"
    lines: list[Line] = [
        (
            f"identify(t, u, y), 10^{len(str(n_samples)) - 1} samples, {src};"
            f" {_long_details(got[False])}",
            _as_times(got[False]),
            _as_times(got[True]),
        )
    ]
    if n_samples == 10**6:
        csv = tmp / "resonance-1e6.csv"
        if not csv.exists():
            write_csv(csv, n_samples)

        def cli_once(one: bool, i: int) -> dict:
            with tempfile.TemporaryDirectory() as out:
                return _one_run(
                    _spawn(
                        "cli-csv",
                        1,
                        _environment(one, None),
                        ["--csv", str(csv), "--out", out, "--timeout", str(options.timeout)],
                    )
                )

        cli = _alternate(reps, cli_once)
        lines.append(
            (
                f"CLI hdpbsid identify, 10^6-line CSV; {_long_details(cli[False])}",
                _as_times(cli[False]),
                _as_times(cli[True]),
            )
        )
    return lines


HOOKS: dict[str, tuple[str, Callable[[int, argparse.Namespace], list[Line]]]] = {
    "sippy": ("SIPPY N4SID vs identify, 10^4 binary-input case", sippy_row),
    **{
        f"long-{k}": (
            f"identify(t, u, y), 10^{k} samples" + (" and the CLI on a CSV" if k == 6 else ""),
            lambda r, o, k=k: long_record_row(10**k, r, o),
        )
        for k in (5, 6, 7)
    },
}
#: rows run only when named in ``--rows`` (minutes each)
ON_REQUEST = ("long-7",)


# -- the parent: subprocesses, table ----------------------------------------------------------
def _environment(one_thread: bool, extra: dict[str, str] | None) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ALL_THREAD_VARIABLES}
    env["BENCH_USER_DATA"] = _DATA["dir"]
    env.pop("NUMBA_DISABLE_JIT", None)
    env.pop("SLBASIS_NO_NUMBA", None)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    if one_thread:
        env.update({k: "1" for k in (*THREAD_VARIABLES, "NUMBA_NUM_THREADS")})
    env.update(extra or {})
    return env


def _cpu_of_children() -> float:
    """CPU time of the waited-for children, from ``getrusage`` (microseconds; ``os.times``
    counts clock ticks, 10 ms, a tenth of the ``--help`` row)."""
    import resource

    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _spawn(
    worker: str,
    reps: int,
    env: dict[str, str],
    extra: list[str] | None = None,
    first: int = 0,
) -> dict:
    """Run ``worker`` on the seeds ``first ... first + reps - 1`` in a fresh subprocess
    with ``env``; its JSON result (``{"status": ...}`` when it failed)."""
    me = str(Path(__file__).resolve())
    out = subprocess.run(
        [sys.executable, me, "--worker", worker, "--reps", str(reps), "--first", str(first)]
        + (extra or []),
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    if out.returncode != 0:
        return {"status": f"failed: {out.stderr.strip().splitlines()[-1:]}"}
    return json.loads(out.stdout.strip().splitlines()[-1])


def _merge(parts: list[dict]) -> dict:
    """The results of several processes as one: lists concatenated, a failure kept."""
    failed = [p for p in parts if "status" in p]
    if failed:
        return failed[0]
    out: dict = {}
    for part in parts:
        for key, value in part.items():
            if isinstance(value, dict):
                out[key] = _merge([out.get(key, {}), value]) if key in out else value
            elif isinstance(value, list):
                out[key] = out.get(key, []) + value
            else:
                out[key] = value
    return out


def _alternate(reps: int, run: Callable[[bool, int], dict]) -> dict[bool, dict]:
    """``run(one_thread, i)`` for ``i < reps`` in both columns, the columns alternating
    in the order default, one thread, one thread, default, ... (a load that drifts during
    the table shifts both columns alike); the merged results per column."""
    parts: dict[bool, list[dict]] = {False: [], True: []}
    for i in range(reps):
        for one in (False, True) if i % 2 == 0 else (True, False):
            parts[one].append(run(one, i))
    return {one: _merge(p) for one, p in parts.items()}


def _worker_once(row: Row, one_thread: bool, i: int) -> dict:
    """One process of ``row``'s worker on seed ``i`` (a new empty kernel cache when the row
    asks for it)."""
    env = _environment(one_thread, row.env)
    with tempfile.TemporaryDirectory() as cache:
        if row.fresh_cache:
            env["NUMBA_CACHE_DIR"] = cache
        got = _spawn(row.worker, 1, env, first=i)
    return {k: got[k] for k in ("wall", "cpu")} if "status" not in got else got


def _command_once(row: Row, one_thread: bool, i: int) -> dict:
    """The whole process of ``row``'s command: wall time and the children's CPU time."""
    c0 = _cpu_of_children()
    w0 = time.perf_counter()
    env = _environment(one_thread, row.env)
    subprocess.run([sys.executable, *row.command], env=env, capture_output=True, check=True)
    return {"wall": [time.perf_counter() - w0], "cpu": [_cpu_of_children() - c0]}


def _median(x: list[float]) -> float:
    return statistics.median(x) if x else float("nan")


def _cells(default: dict | None, one: dict | None) -> str:
    if default is None or one is None:
        return "| | | | | | |"
    if "status" in default or "status" in one:
        return f"| {default.get('status', '')} | {one.get('status', '')} | | | | |"
    dw, ow = _median(default["wall"]), _median(one["wall"])
    dc, oc = _median(default["cpu"]), _median(one["cpu"])
    return f"| {dw:.3f} | {ow:.3f} | {dw / ow:.2f} | {dc:.3f} | {oc:.3f} | {dc / oc:.2f} |"


def _prepare_kernels() -> None:
    """Fill numba's cache (the rows other than "first-call" time a filled cache)."""
    subprocess.run(
        [sys.executable, "-m", "slbasis.numeric.jit", *JIT_MODULES],
        env=_environment(False, None),
        capture_output=True,
        check=False,
    )


def main(argv: list[str] | None = None) -> int:
    """Print the table (or, with ``--worker``, run one row's work and print its times)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--reps", type=int, default=5, help="repetitions per cell (median)")
    ap.add_argument("--rows", nargs="*", help="row names (default: all; --list)")
    ap.add_argument("--list", action="store_true", help="list the rows and exit")
    ap.add_argument(
        "--timeout", type=float, default=900, help="seconds per long-record call (long-*)"
    )
    ap.add_argument(
        "--md",
        default=str(HERE / "results" / "user.md"),
        help="markdown file of the table (default bench/results/user.md; '' for none)",
    )
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--first", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--csv", help=argparse.SUPPRESS)
    ap.add_argument("--out", help=argparse.SUPPRESS)
    ap.add_argument("--make-records", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.make_records:
        for case in ("quadrotor", "second-order"):
            for seed in (*range(args.reps), 1000):
                _record(case, seed)
        return 0
    if args.worker == "cli-csv":
        print(json.dumps(_cli_csv(args.csv, args.out, args.timeout)))
        return 0
    if args.worker:
        print(json.dumps(WORKERS[args.worker](args.reps, args.first)))
        return 0
    names = [r.name for r in ROWS] + list(HOOKS)
    if args.list:
        for r in ROWS:
            print(f"{r.name:16s} {r.label}")
        for k, (label, _) in HOOKS.items():
            print(f"{k:16s} {label}" + (" (only when named)" if k in ON_REQUEST else ""))
        return 0
    chosen = args.rows or [n for n in names if n not in ON_REQUEST]
    unknown = sorted(set(chosen) - set(names))
    if unknown:
        ap.error(f"unknown rows {unknown}; known: {names}")
    data = tempfile.TemporaryDirectory(prefix="bench-user-")
    _DATA["dir"] = data.name
    if any(r.worker for r in ROWS if r.name in chosen) or set(chosen) & set(HOOKS):
        _prepare_kernels()
        subprocess.run(
            [sys.executable, str(HERE / "user.py"), "--make-records", "--reps", str(args.reps)],
            env=_environment(False, None),
            check=True,
        )
    load0 = os.getloadavg()
    command = " ".join(["python bench/user.py", *(argv if argv is not None else sys.argv[1:])])
    lines = [
        f"`{command}` ({_provenance()}): {os.cpu_count()} cores, load average (1, 5, 15 min)"
        f" {_loads(load0)} at the start; median of {args.reps} (the SIPPY rows: of"
        f" {max(args.reps, SIPPY_MIN_SEEDS)} seeds, each the median of {SIPPY_CALLS} calls),"
        " the columns alternating process by process",
        "",
        "| row | default wall s | 1 thread wall s | ratio | default CPU s | 1 thread CPU s"
        " | ratio |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    print("\n".join(lines), flush=True)

    def add(label: str, default: dict | None, one: dict | None) -> None:
        lines.append(f"| {label} {_cells(default, one)}")
        print(lines[-1], flush=True)

    for row in ROWS:
        if row.name in chosen:
            run = _worker_once if row.worker else _command_once
            got = _alternate(args.reps, lambda one, i, row=row, run=run: run(row, one, i))
            add(row.label, got[False], got[True])
    for key, (_, hook) in HOOKS.items():
        if key in chosen:
            for label, default, one in hook(args.reps, args):
                add(label, default, one)
    data.cleanup()
    lines += ["", f"load average (1, 5, 15 min) {_loads(os.getloadavg())} at the end"]
    print(lines[-1])
    if args.md:
        Path(args.md).parent.mkdir(parents=True, exist_ok=True)
        Path(args.md).write_text("\n".join(lines) + "\n")
        print(f"wrote {args.md}")
    return 0


def _provenance() -> str:
    """The package version and the date of the run (the page is documentation: the commit
    measured is a development detail, kept out of it)."""
    from importlib.metadata import PackageNotFoundError, version

    day = time.strftime("%Y-%m-%d", time.gmtime())
    try:
        return f"slbasis-hdpbsid {version('slbasis-hdpbsid')}, {day}"
    except PackageNotFoundError:  # run from a source tree that was not installed
        return f"slbasis-hdpbsid (not installed), {day}"


def _loads(load: tuple[float, float, float]) -> str:
    return ", ".join(f"{x:.1f}" for x in load)


if __name__ == "__main__":
    raise SystemExit(main())
