# ruff: noqa: E402  (bench/ goes on sys.path before its modules are imported)
"""Head-to-head benchmark of hdpbsid against the Python tools users would pick instead.

Run: ``.venv/bin/python bench/peers.py [--runs 10] [--cases ...] [--snr 40 20 10]
[--methods ...] [--n-jobs 2] [--no-timing] [--peers-from SUMMARY.json]
[--timing-from SUMMARY.json] [--out DIR] [--results]`` (peers from
``pip install -e ".[bench]"``).  The whole grid takes hours on two cores, nearly all of
it the peers' tuning grids: run the accuracy part with ``--n-jobs 2 --no-timing --out
DIR`` (load does not change an error); after a change of ours, ``--peers-from
DIR/summary.json --no-timing --out DIR2`` reruns only our methods and keeps the peers'
cells, which depend on nothing but their data (checked: a digest of every cell's
records); then ``--timing-from DIR2/summary.json --results`` on an idle machine.

What is measured, per case (``bench/cases.py``), SNR and method, over seeded runs on
*identical* data (every method sees the same estimation record):

* **eigenvalue error**: the largest relative error ``|lambda_est - lambda| / |lambda|``
  over the true eigenvalues after optimal matching
  (:func:`hdpbsid.models.metrics.eigenvalue_errors`); median and interquartile range over the
  runs that produced a model of the right order.  Discrete-time models (SIPPY, nfoursid,
  ERA) are converted exactly to continuous time with the ZOH matrix logarithm
  (:func:`hdpbsid.models.conversion.d2c`); on the discrete PBSID toolbox example the comparison
  is in the z-plane instead (continuous models are sampled with ``expm(A dt)``).
* **fit** on a second, independent validation record: ``100 (1 - NRMSE)`` (MATLAB's
  ``fit``), the model simulated from the measured input with a least-squares initial
  state, averaged over outputs; for the unstable quadrotor plant on 1 s windows.
* **failures**: an exception (``SystemExit`` from SIPPY's ``sys.exit`` included), a model
  of another order than requested, non-finite matrices, or a discrete model with no
  continuous counterpart (``d2c`` impossible: eigenvalue on the negative real axis).
  Nothing stops the bench; failures are counted per cell.
* **time**: median wall time of the identification call alone (no conversion, no fit),
  and its CPU time (``time.process_time``; less sensitive to other jobs on the machine).

Every method gets the true order.  Peers run twice: with their default horizons
(SIPPY ``f = p = 20``, nfoursid ``num_block_rows = 2``, ERA with python-control's
default Hankel size ``2 r`` on ``4 r + 1`` Markov parameters) and *tuned*: every horizon
of a grid is run on every seed and the one with the smallest median eigenvalue error
over those same seeds is reported -- tuned with knowledge of the true eigenvalues, the
best a user could possibly get, which makes the comparison conservative for us.  Our
methods run with their defaults.  ERA (impulse response by ``control.markov`` least
squares, then ``control.eigensys_realization``) applies only to open-loop, uniformly
sampled cases; the discrete-time tools only to uniform sampling.  Every method runs in
the default environment, as a user runs it: no thread variable is set (hdpbsid sets its
own thread counts, :mod:`hdpbsid.runtime`; the peers use the BLAS threads they find).

A separate table times the identification call on ``10^4`` samples (second-order and
quadrotor cases at SNR 20 dB): HD-PBSID and ``dt`` vs SIPPY N4SID.

``--results`` writes the tables as markdown to ``bench/results/peers.md`` (the
documentation's page includes it); ``--out DIR`` writes the per-run CSV, the summary JSON
(with the commit measured) and the same markdown; ``--from-json DIR/summary.json``
re-renders the tables of an earlier run without rerunning it.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import hashlib
import io
import json
import os
import platform
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cases import CASES, DESCRIPTIONS, SNR_INDEPENDENT, CaseData, Record, make_case

import hdpbsid
from hdpbsid.models.conversion import d2c
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.models.model import StateSpaceModel

Array = NDArray[np.float64]

REPO = Path(__file__).resolve().parent.parent
RESULTS = REPO / "bench" / "results"

#: First seed of the evaluation runs.
EVAL_SEED0 = 1

SIPPY_DEFAULT_HORIZON = 20
SIPPY_GRID = (5, 10, 20, 40, 80)
NFOURSID_DEFAULT_ROWS = 2
NFOURSID_GRID = (2, 5, 10, 20)
ERA_GRID = (21, 51, 201, 801)  # number of Markov parameters (FIR length)


class WrongOrder(Exception):
    """The method returned a model of another order than requested."""


@dataclass
class Identified:
    """A model as a method returned it: continuous (``dt is None``) or discrete."""

    A: Array
    B: Array
    C: Array
    D: Array
    dt: float | None = None


@dataclass
class Method:
    """A method of the bench: ``run(record, order, horizon) -> Identified``.

    ``grid``: horizons tried when tuning (``None``: not tunable); ``default``: the
    horizon of the untuned run.  ``open_loop_only``/``uniform_only`` say where it
    applies; ``continuous_time``: whether it works on time stamps (our methods).
    """

    name: str
    run: Callable[[Record, int, int | None], Identified]
    label: str
    default: int | None = None
    grid: tuple[int, ...] | None = None
    tuned: bool = False
    open_loop_only: bool = False
    uniform_only: bool = True
    peer: bool = True
    notes: str = ""
    extra: dict[str, object] = field(default_factory=dict)


def _dt_of(t: Array) -> float:
    return float(np.median(np.diff(t)))


# -- peers -------------------------------------------------------------------------------
def _sippy(method: str) -> Callable[[Record, int, int | None], Identified]:
    def run(rec: Record, order: int, horizon: int | None) -> Identified:
        from sippy_unipi import system_identification

        h = int(horizon)
        # SIPPY prints warnings to stdout; its orientation rule is "the longer axis is time"
        with contextlib.redirect_stdout(io.StringIO()):
            model = system_identification(
                rec.y.T,
                rec.u.T,
                method,
                SS_fixed_order=int(order),
                SS_f=h,
                SS_p=h,
                tsample=_dt_of(rec.t),
            )
        return Identified(model.A, model.B, model.C, model.D, _dt_of(rec.t))

    return run


def _nfoursid(rec: Record, order: int, horizon: int | None) -> Identified:
    import pandas as pd
    from nfoursid.nfoursid import NFourSID

    rows = int(horizon)
    ucols = [f"u{i}" for i in range(rec.u.shape[1])]
    ycols = [f"y{i}" for i in range(rec.y.shape[1])]
    frame = pd.DataFrame(np.hstack([rec.u, rec.y]), columns=ucols + ycols)
    n4 = NFourSID(frame, output_columns=ycols, input_columns=ucols, num_block_rows=rows)
    n4.subspace_identification()
    ss, _ = n4.system_identification(rank=order)
    return Identified(ss.a, ss.b, ss.c, ss.d, _dt_of(rec.t))


def _era(rec: Record, order: int, horizon: int | None) -> Identified:
    import control

    n_markov = 4 * order + 1 if horizon is None else int(horizon)
    hankel = None if horizon is None else (n_markov - 1) // 2  # None: control's 2 r
    markov = control.markov(rec.y.T, rec.u.T, n_markov)
    if markov.ndim == 1:
        markov = markov[None, None, :]
    sysd, _ = control.eigensys_realization(markov, order, m=hankel, n=hankel)
    return Identified(sysd.A, sysd.B, sysd.C, sysd.D, _dt_of(rec.t))


def _ours(name: str) -> Callable[[Record, int, int | None], Identified]:
    def run(rec: Record, order: int, horizon: int | None) -> Identified:
        # the simulated cases are deviations from a zero operating point, starting at rest,
        # and every tool gets them as they are: no mean removal (identify's default)
        m = hdpbsid.identify(rec.t, rec.u, rec.y, order=order, method=name, detrend=None)
        return Identified(m.A, m.B, m.C, m.D, None)

    return run


def build_methods() -> dict[str, Method]:
    """Every method of the bench, peers (default and tuned) and ours, by name."""
    methods: dict[str, Method] = {}
    for sm in ("N4SID", "MOESP", "CVA", "PARSIM-K"):
        key = "sippy-" + sm.lower()
        run = _sippy(sm)
        methods[key] = Method(key, run, f"SIPPY {sm} (f=p=20)", default=SIPPY_DEFAULT_HORIZON)
        methods[key + "-tuned"] = Method(
            key + "-tuned", run, f"SIPPY {sm}, tuned f=p", grid=SIPPY_GRID, tuned=True
        )
    methods["nfoursid"] = Method(
        "nfoursid", _nfoursid, "nfoursid (2 block rows)", default=NFOURSID_DEFAULT_ROWS
    )
    methods["nfoursid-tuned"] = Method(
        "nfoursid-tuned", _nfoursid, "nfoursid, tuned rows", grid=NFOURSID_GRID, tuned=True
    )
    methods["era"] = Method(
        "era", _era, "python-control markov+ERA (4r+1, 2r)", open_loop_only=True
    )
    methods["era-tuned"] = Method(
        "era-tuned",
        _era,
        "python-control markov+ERA, tuned",
        grid=ERA_GRID,
        tuned=True,
        open_loop_only=True,
    )
    for name, label in (
        ("dt", "ours: dt (PBSID + exact d2c)"),
        ("hermite", "ours: hermite (HD-PBSID)"),
        ("laguerre", "ours: laguerre"),
        ("legendre", "ours: legendre"),
        ("chebyshev", "ours: chebyshev"),
    ):
        methods[name] = Method(name, _ours(name), label, peer=False, uniform_only=(name == "dt"))
    return methods


METHODS = build_methods()
DEFAULT_METHODS = [m for m in METHODS if m != "chebyshev"]


def applies(method: Method, case: CaseData) -> bool:
    """Whether ``method`` can run on ``case`` at all (not a failure when it cannot)."""
    if method.uniform_only and not case.uniform:
        return False
    if method.open_loop_only and case.closed_loop:
        return False
    return True


# -- scoring -----------------------------------------------------------------------------
def model_eigenvalues(model: Identified, case: CaseData) -> NDArray[np.complex128]:
    """Eigenvalues in the plane of the truth: s-plane, or z-plane for discrete cases."""
    if case.discrete:
        if model.dt is not None:
            return np.linalg.eigvals(model.A)
        return np.linalg.eigvals(expm(model.A * _dt_of(case.estimation.t)))
    return np.linalg.eigvals(continuous_A(model))


def continuous_A(model: Identified) -> Array:
    """``A`` of the continuous model (exact ZOH inverse for a discrete one)."""
    if model.dt is None:
        return model.A
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return d2c(model.A, model.B, model.C, model.D, None, model.dt)[0]


def discrete_ls_simulation(A: Array, B: Array, C: Array, D: Array, u: Array, y: Array) -> Array:
    """Simulated output ``(Ns, l)`` of ``x_{k+1} = A x_k + B u_k``, ``y_k = C x_k + D u_k``
    driven by ``u (Ns, m)``, from the initial state that fits ``y (Ns, l)`` best in least
    squares (the output is affine in ``x_0``: ``y_k = C A^k x_0 + (zero-state response)``)."""
    n, ns = A.shape[0], u.shape[0]
    X = np.empty((ns, n))
    x = np.zeros(n)
    Bu = u @ B.T
    for k in range(ns):
        X[k] = x
        x = A @ x + Bu[k]
    y0 = X @ C.T + u @ D.T
    O = np.empty((ns, C.shape[0], n))
    P = np.eye(n)
    for k in range(ns):
        O[k] = C @ P
        P = A @ P
    O2 = O.reshape(-1, n)
    if not (np.all(np.isfinite(O2)) and np.all(np.isfinite(y0))):
        # an unstable model overflowed: no fit, and LAPACK's scaling routine would print
        # "On entry to DLASCL ..." on a non-finite matrix
        return np.full(y.shape, np.nan)
    x0 = np.linalg.lstsq(O2, (y - y0).ravel(), rcond=None)[0]
    return y0 + (O2 @ x0).reshape(y.shape)


def _discrete_fit(A: Array, B: Array, C: Array, D: Array, rec: Record) -> float:
    """Fit (percent, mean over outputs) of a discrete model on ``rec``, LS initial state."""
    return fit_percent(rec.y, discrete_ls_simulation(A, B, C, D, rec.u, rec.y))


def fit_percent(y: Array, ysim: Array) -> float:
    """``100 (1 - ||y - ysim|| / ||y - mean y||)`` per output column, averaged (MATLAB's
    ``fit``; 100 is perfect, 0 is no better than the mean, negative is worse)."""
    err = np.linalg.norm(y - ysim, axis=0)
    ref = np.linalg.norm(y - y.mean(axis=0), axis=0)
    return float(np.mean(100.0 * (1.0 - err / ref)))


def _ct_model(A: Array, B: Array, C: Array, D: Array) -> StateSpaceModel:
    return StateSpaceModel(A, B, C, D, np.zeros((A.shape[0], C.shape[0])))


def validation_fit(model: Identified, case: CaseData) -> float:
    """Fit (percent) of ``model`` on the validation record (module docstring)."""
    rec = case.validation
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if case.discrete:
            if model.dt is not None:
                A, B = model.A, model.B
            else:
                sys_d = _ct_model(model.A, model.B, model.C, model.D).to_discrete(_dt_of(rec.t))
                A, B = sys_d.A, sys_d.B
            fit = _discrete_fit(A, B, model.C, model.D, rec)
        else:
            A = continuous_A(model)
            if model.dt is None:
                B = model.B
            else:
                B = d2c(model.A, model.B, model.C, model.D, None, model.dt)[1]
            ct = _ct_model(A, B, model.C, model.D)
            if case.fit_window is None:
                windows = [slice(0, rec.t.size)]
            else:
                edges = np.arange(rec.t[0], rec.t[-1], case.fit_window)
                idx = np.searchsorted(rec.t, edges)
                ends = np.r_[idx[1:], rec.t.size]
                windows = [slice(a, b) for a, b in zip(idx, ends, strict=True)]
            fits = []
            for w in windows:
                r = ct.fit(rec.t[w], rec.u[w], rec.y[w], method=case.hold)
                fits.append(float(np.mean(100.0 * (1.0 - r.nrmse))))
            fit = float(np.mean(fits))
    return fit if np.isfinite(fit) else -np.inf


@dataclass
class Outcome:
    """One run of one method on one data set (``model`` kept until the fit is scored)."""

    status: str  # "ok", "exception", "exit", "wrong-order", "nan", "no-d2c"
    error: float = np.nan
    fit: float = np.nan
    seconds: float = np.nan
    cpu_seconds: float = np.nan
    message: str = ""
    model: Identified | None = field(default=None, repr=False)


def run_one(method: Method, case: CaseData, horizon: int | None, score_fit: bool) -> Outcome:
    """Identify with ``method`` on ``case.estimation`` and score it; never raises.

    With ``score_fit=False`` the fit is left for :func:`score_fit` (the model is kept).
    """
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            model = method.run(case.estimation, case.order, horizon)
    except SystemExit as exc:  # SIPPY calls sys.exit() on bad arguments
        return Outcome(
            "exit",
            seconds=time.perf_counter() - t0,
            cpu_seconds=time.process_time() - c0,
            message=str(exc)[:200],
        )
    except Exception as exc:  # noqa: BLE001 - a peer may raise anything; count it
        return Outcome(
            "exception",
            seconds=time.perf_counter() - t0,
            cpu_seconds=time.process_time() - c0,
            message=f"{type(exc).__name__}: {exc}"[:200],
        )
    seconds, cpu_seconds = time.perf_counter() - t0, time.process_time() - c0
    mats = [np.asarray(M, dtype=float) for M in (model.A, model.B, model.C, model.D)]
    model = Identified(*mats, dt=model.dt)
    if model.A.shape != (case.order, case.order):
        return Outcome(
            "wrong-order",
            seconds=seconds,
            cpu_seconds=cpu_seconds,
            message=f"order {model.A.shape[0]}",
        )
    if not all(np.all(np.isfinite(M)) for M in mats):
        return Outcome(
            "nan", seconds=seconds, cpu_seconds=cpu_seconds, message="non-finite matrices"
        )
    try:
        ev = model_eigenvalues(model, case)
    except (ValueError, np.linalg.LinAlgError) as exc:
        return Outcome("no-d2c", seconds=seconds, cpu_seconds=cpu_seconds, message=str(exc)[:200])
    if not np.all(np.isfinite(ev)):
        return Outcome(
            "nan", seconds=seconds, cpu_seconds=cpu_seconds, message="non-finite eigenvalues"
        )
    err = float(eigenvalue_errors(ev, case.true_eigenvalues).max())
    out = Outcome("ok", error=err, seconds=seconds, cpu_seconds=cpu_seconds, model=model)
    if score_fit:
        score_fit_of(out, case)
    return out


def score_fit_of(outcome: Outcome, case: CaseData) -> None:
    """Fill ``outcome.fit`` from its model on ``case.validation`` (then drop the model)."""
    if outcome.status != "ok" or outcome.model is None:
        return
    try:
        outcome.fit = validation_fit(outcome.model, case)
    except (ValueError, np.linalg.LinAlgError):
        outcome.fit = -np.inf
    outcome.model = None


# -- driver ------------------------------------------------------------------------------
def _median_error(outcomes: Sequence[Outcome]) -> float:
    errs = [o.error if o.status == "ok" else np.inf for o in outcomes]
    return float(np.median(errs))


def _tuning_key(outcomes: Sequence[Outcome]) -> tuple[float, int, float]:
    """Rank of a horizon: median error (failures infinite), failures, mean ok error."""
    ok = [o.error for o in outcomes if o.status == "ok"]
    return (_median_error(outcomes), len(outcomes) - len(ok), float(np.mean(ok)) if ok else np.inf)


def valid_horizons(method: Method, order: int, n_outputs: int) -> list[int | None]:
    """The grid (tuned) or the default (untuned); tuned subspace horizons must give more
    block rows than the order (SIPPY would silently lower the order otherwise)."""
    if not method.tuned:
        return [method.default]
    if method.name.startswith(("sippy", "nfoursid")):
        return [h for h in method.grid if h * n_outputs > order]
    return list(method.grid)


def summarize(outcomes: Sequence[Outcome]) -> dict[str, object]:
    """Median / quartiles of the error, median fit and time, failure counts."""
    ok = [o for o in outcomes if o.status == "ok"]
    errs = np.array([o.error for o in ok])
    fits = np.array([o.fit for o in ok])
    times = np.array([o.seconds for o in outcomes if np.isfinite(o.seconds)])
    cpu = np.array([o.cpu_seconds for o in outcomes if np.isfinite(o.cpu_seconds)])
    fails: dict[str, int] = {}
    for o in outcomes:
        if o.status != "ok":
            fails[o.status] = fails.get(o.status, 0) + 1
    return {
        "runs": len(outcomes),
        "ok": len(ok),
        "failures": fails,
        "error_median": float(np.median(errs)) if ok else None,
        "error_q25": float(np.quantile(errs, 0.25)) if ok else None,
        "error_q75": float(np.quantile(errs, 0.75)) if ok else None,
        "error_median_fail_inf": _median_error(outcomes),
        "fit_median": float(np.median(fits)) if ok else None,
        "time_median": float(np.median(times)) if times.size else None,
        "cpu_median": float(np.median(cpu)) if cpu.size else None,
        "messages": sorted({o.message for o in outcomes if o.message})[:3],
    }


def snr_label(snr: float | None, case_name: str = "") -> str:
    if case_name in SNR_INDEPENDENT:
        return "own noise"
    return "noise-free" if snr is None else f"{snr:g} dB"


def data_digest(cases: Sequence[CaseData]) -> str:
    """SHA-256 of the estimation and validation records of a cell's seeds: a peer's cell
    can be reused (``--peers-from``) exactly when its data are these."""
    h = hashlib.sha256()
    for case in cases:
        for rec in (case.estimation, case.validation):
            for x in (rec.t, rec.u, rec.y):
                h.update(np.ascontiguousarray(x, dtype=float).tobytes())
    return h.hexdigest()[:16]


def reuse_peer_cells(
    summary: Path, case_names: Sequence[str], snrs: Sequence[float | None], runs: int
) -> tuple[list[dict[str, object]], list[dict[str, object]]]:
    """The peers' cells (and their per-run rows, from ``runs.csv`` beside ``summary``) of
    an earlier run, for the (case, SNR) cells asked for.  A peer's result depends only on
    its data, so a cell is reused only when the records it was computed on are the ones
    :func:`~cases.make_case` gives now (:func:`data_digest`); a run whose cells have no
    digest is refused."""
    saved = json.loads(summary.read_text())
    now = {}
    for case_name in case_names:
        for snr in [None] if case_name in SNR_INDEPENDENT else list(snrs):
            cases = [make_case(case_name, EVAL_SEED0 + r, snr) for r in range(runs)]
            now[(case_name, snr_label(snr, case_name))] = data_digest(cases)
    cells = [c for c in saved["cells"] if c["peer"] and (c["case"], c["snr"]) in now]
    for c in cells:
        if c.get("data") != now[(c["case"], c["snr"])] or c["runs"] != runs:
            raise SystemExit(
                f"--peers-from {summary}: the {c['case']} {c['snr']} cell of "
                f"{c['method']} was computed on other data or another number of runs; "
                f"rerun the peers"
            )
    keys = {(c["case"], c["snr"], c["method"]) for c in cells}
    rows: list[dict[str, object]] = []
    runs_csv = summary.parent / "runs.csv"
    if runs_csv.is_file():
        with open(runs_csv, newline="") as fh:
            rows = [r for r in csv.DictReader(fh) if (r["case"], r["snr"], r["method"]) in keys]
    return rows, cells


def run_bench(
    case_names: Sequence[str],
    snrs: Sequence[float | None],
    method_names: Sequence[str],
    runs: int,
    log: Callable[[str], None] = print,
    n_jobs: int = 1,
) -> tuple[list[dict[str, object]], list[dict[str, object]]]:
    """Run every (case, SNR, method); returns (per-run rows, per-cell summaries).

    Tuned methods run at every horizon of their grid on every seed; the horizon with the
    best median error over these same seeds is kept (an oracle choice, favourable to the
    peers), and only its models are scored on the validation records.  With ``n_jobs > 1``
    the (case, SNR) cells run in parallel processes (joblib): the errors are the same, the
    per-run times of the detail table then share the cores.
    """
    todo = [
        (case_name, snr)
        for case_name in case_names
        for snr in ([None] if case_name in SNR_INDEPENDENT else list(snrs))
    ]
    if n_jobs == 1:
        done = [_run_cell(c, s, method_names, runs, log) for c, s in todo]
    else:
        from joblib import Parallel, delayed

        done = Parallel(n_jobs=n_jobs)(
            delayed(_run_cell)(c, s, method_names, runs, None) for c, s in todo
        )
    rows: list[dict[str, object]] = []
    cells: list[dict[str, object]] = []
    for (case_name, snr), (cell_rows, cell_cells, seconds) in zip(todo, done, strict=True):
        if n_jobs != 1:
            for c in cell_cells:
                log(_cell_line(c))
            log(f"# {case_name} {snr_label(snr, case_name)}: {seconds:.0f} s")
        rows += cell_rows
        cells += cell_cells
    return rows, cells


def _run_cell(
    case_name: str,
    snr: float | None,
    method_names: Sequence[str],
    runs: int,
    log: Callable[[str], None] | None,
) -> tuple[list[dict[str, object]], list[dict[str, object]], float]:
    """One (case, SNR) cell of :func:`run_bench`: its rows, summaries and wall time."""
    import_all_methods()
    rows: list[dict[str, object]] = []
    cells: list[dict[str, object]] = []
    t_cell = time.perf_counter()
    probe = make_case(case_name, EVAL_SEED0, snr)
    active = [METHODS[m] for m in method_names if applies(METHODS[m], probe)]
    n_out = probe.estimation.y.shape[1]
    grids = {m.name: valid_horizons(m, probe.order, n_out) for m in active}
    for m in active:  # warm up: imports, kernel caches (not timed, not scored)
        run_one(m, probe, grids[m.name][0], score_fit=False)
    cases = [make_case(case_name, EVAL_SEED0 + r, snr) for r in range(runs)]
    data = data_digest(cases)
    # every (run function, horizon) once per seed: tuned grids include defaults
    per_key: dict[tuple[int, int | None], list[Outcome]] = {}
    for case in cases:
        done: set[tuple[int, int | None]] = set()
        for m in active:
            for h in grids[m.name]:
                key = (id(m.run), h)
                if key not in done:
                    done.add(key)
                    per_key.setdefault(key, []).append(run_one(m, case, h, score_fit=False))
    for m in active:
        by_h = {h: per_key[(id(m.run), h)] for h in grids[m.name]}
        best_h = min(by_h, key=lambda h: _tuning_key(by_h[h]))
        outcomes = by_h[best_h]
        for case, o in zip(cases, outcomes, strict=True):
            score_fit_of(o, case)
        s = summarize(outcomes)
        s.update(
            {
                "case": case_name,
                "snr": snr_label(snr, case_name),
                "method": m.name,
                "label": m.label,
                "peer": m.peer,
                "horizon": best_h,
                "data": data,
                "grid_median_errors": {str(h): _median_error(v) for h, v in by_h.items()}
                if m.tuned
                else None,
            }
        )
        cells.append(s)
        if log is not None:
            log(_cell_line(s))
        for seed, o in enumerate(outcomes, start=EVAL_SEED0):
            rows.append(
                {
                    "case": case_name,
                    "snr": snr_label(snr, case_name),
                    "method": m.name,
                    "seed": seed,
                    "horizon": best_h,
                    "status": o.status,
                    "error": o.error,
                    "fit": o.fit,
                    "seconds": o.seconds,
                    "cpu_seconds": o.cpu_seconds,
                    "message": o.message,
                }
            )
    seconds = time.perf_counter() - t_cell
    if log is not None:
        log(f"# {case_name} {snr_label(snr, case_name)}: {seconds:.0f} s")
    return rows, cells, seconds


def _cell_line(s: dict[str, object]) -> str:
    return (
        f"{s['case']:23s} {s['snr']:>10s} {s['method']:20s} h={s['horizon']!s:>4s} "
        f"err {_pct(s['error_median'])} [{_pct(s['error_q25'])}, {_pct(s['error_q75'])}] "
        f"fit {_num(s['fit_median'])} ok {s['ok']}/{s['runs']} "
        f"{_fails(s['failures'])} t {_ms(s['time_median'])} cpu {_ms(s['cpu_median'])}"
    )


# -- timing on 10^4 samples ---------------------------------------------------------------
def timing_table(
    tuned_horizons: dict[str, int], repeats: int = 5, log: Callable[[str], None] = print
) -> list[dict[str, object]]:
    """Identification time on ``10^4`` samples (SNR 20 dB): hermite, dt, SIPPY N4SID at
    its default horizon and at ``tuned_horizons[case]`` (the horizon the bench chose)."""
    from cases import quadrotor, second_order_smooth

    datasets = {
        "second-order": second_order_smooth(EVAL_SEED0, 20.0, T=100.0),
        "quadrotor": quadrotor(EVAL_SEED0, 20.0, duration=40.0),
    }
    out = []
    for name, case in datasets.items():
        tuned_h = tuned_horizons.get(name, 40)
        for label, m, h in (
            ("hermite (HD-PBSID)", METHODS["hermite"], None),
            ("dt", METHODS["dt"], None),
            ("SIPPY N4SID f=20", METHODS["sippy-n4sid"], SIPPY_DEFAULT_HORIZON),
            (f"SIPPY N4SID f={tuned_h} (tuned)", METHODS["sippy-n4sid-tuned"], tuned_h),
        ):
            run_one(m, case, h, score_fit=False)  # warm-up
            res = [run_one(m, case, h, score_fit=False) for _ in range(repeats)]
            row = {
                "case": name,
                "samples": int(case.estimation.t.size),
                "method": label,
                "time_median": float(np.median([o.seconds for o in res])),
                "cpu_median": float(np.median([o.cpu_seconds for o in res])),
                "error": res[0].error if res[0].status == "ok" else None,
                "status": res[0].status,
            }
            out.append(row)
            log(
                f"{name:13s} Ns={row['samples']} {label:28s} {_ms(row['time_median'])} "
                f"cpu {_ms(row['cpu_median'])} "
                f"err {_pct(row['error'])} {row['status']}"
            )
    return out


# -- formatting ---------------------------------------------------------------------------
def _pct(x: object) -> str:
    if x is None or not np.isfinite(x):
        return "–"
    x = 100.0 * float(x)
    return f"{x:.2g} %" if x < 10 else f"{x:.0f} %"


def _num(x: object) -> str:
    if x is None or not np.isfinite(x):
        return "–"
    return f"{x:.1f}" if x > -100 else "<-100"


def _ms(x: object) -> str:
    if x is None or not np.isfinite(x):
        return "–"
    return f"{1e3 * x:.0f} ms" if x >= 0.01 else f"{1e3 * x:.1f} ms"


def _fails(f: object) -> str:
    f = dict(f)  # type: ignore[arg-type]
    return ", ".join(f"{v} {k}" for k, v in sorted(f.items())) if f else ""


def _cell(s: dict[str, object]) -> str:
    if s["ok"] == 0:
        return f"fails {s['runs']}/{s['runs']} ({_fails(s['failures'])})"
    txt = f"{_pct(s['error_median'])} ({_pct(s['error_q25'])}–{_pct(s['error_q75'])})"
    nfail = s["runs"] - s["ok"]
    if nfail:
        txt += f", **{nfail}/{s['runs']} fail**"
    return txt


def full_tables(cells: Sequence[dict[str, object]]) -> str:
    """Markdown: one table per case, rows = methods, a column per SNR."""
    out = []
    for case_name in dict.fromkeys(c["case"] for c in cells):
        cc = [c for c in cells if c["case"] == case_name]
        snrs = list(dict.fromkeys(c["snr"] for c in cc))
        out.append(f"\n**{case_name}**: {DESCRIPTIONS[case_name]}\n")
        head = "| method | " + " | ".join(f"{s}: error (IQR) · fit" for s in snrs)
        out.append(head + " | wall time | CPU time |")
        out.append("|" + "---|" * (len(snrs) + 3))
        for m in dict.fromkeys(c["method"] for c in cc):
            row = [c for c in cc if c["method"] == m]
            by_snr = {c["snr"]: c for c in row}
            label = row[0]["label"]
            if row[0]["horizon"] is not None and METHODS[m].tuned:
                hs = sorted({str(c["horizon"]) for c in row})
                label += f" ({'/'.join(hs)})"
            cellsx = []
            for s in snrs:
                c = by_snr.get(s)
                cellsx.append("n/a" if c is None else f"{_cell(c)} · {_num(c['fit_median'])}")
            wall = np.median([c["time_median"] for c in row if c["time_median"] is not None])
            cpu = [c["cpu_median"] for c in row if c["cpu_median"] is not None]
            cpu_txt = _ms(float(np.median(cpu))) if cpu else "–"
            out.append(
                f"| {label} | " + " | ".join(cellsx) + f" | {_ms(float(wall))} | {cpu_txt} |"
            )
    return "\n".join(out)


def summary_table(cells: Sequence[dict[str, object]]) -> str:
    """Markdown: per case and SNR, our methods vs the best default and best tuned peer."""
    ours = [m for m in ("hermite", "dt", "laguerre", "legendre") if m in METHODS]
    present = [m for m in ours if any(c["method"] == m for c in cells)]
    head = (
        "| case | SNR | "
        + " | ".join(present)
        + " | best peer, defaults | best peer, tuned on the truth | most accurate |"
    )
    lines = [head, "|" + "---|" * (len(present) + 5)]
    keys = list(dict.fromkeys((c["case"], c["snr"]) for c in cells))
    for case_name, snr in keys:
        cc = {c["method"]: c for c in cells if c["case"] == case_name and c["snr"] == snr}
        row = [case_name, snr]
        for m in present:
            row.append(_short(cc[m]) if m in cc else "n/a")
        for tuned in (False, True):
            peers = [c for c in cc.values() if c["peer"] and METHODS[c["method"]].tuned == tuned]
            if not peers:
                row.append("n/a")
                continue
            best = min(peers, key=lambda c: c["error_median_fail_inf"])
            row.append(f"{_short(best)} {_peer_name(best)}")
        winner = min(cc.values(), key=lambda c: c["error_median_fail_inf"])
        row.append(_peer_name(winner)[1:-1] if winner["peer"] else f"**{winner['method']}**")
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines)


def _short(c: dict[str, object]) -> str:
    if c["ok"] == 0:
        return f"fails {c['runs']}/{c['runs']}"
    txt = _pct(c["error_median"])
    nfail = c["runs"] - c["ok"]
    return txt + (f" ({nfail}/{c['runs']} fail)" if nfail else "")


def _peer_name(c: dict[str, object]) -> str:
    name = str(c["method"]).replace("-tuned", "").replace("sippy-", "SIPPY ")
    name = name.replace("n4sid", "N4SID").replace("moesp", "MOESP").replace("cva", "CVA")
    name = name.replace("parsim-k", "PARSIM-K").replace("era", "ERA")
    method = METHODS[str(c["method"])]
    if method.tuned:
        name += f" h={c['horizon']}"
        if method.grid and c["horizon"] == max(method.grid):
            name += ", grid max"
    return f"({name})"


def timing_markdown(rows: Sequence[dict[str, object]]) -> str:
    lines = [
        "| case | samples | method | wall time | CPU time | eigenvalue error |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['samples']} | {r['method']} | {_ms(r['time_median'])} | "
            f"{_ms(r['cpu_median'])} | "
            f"{_pct(r['error']) if r['status'] == 'ok' else r['status']} |"
        )
    return "\n".join(lines)


def code_version() -> str:
    """Commit of the working tree and whether hdpbsid/ or slbasis/ had uncommitted edits
    (other people edit them; every hdpbsid module is imported at start, see main)."""
    import subprocess

    try:
        head = subprocess.run(
            ["git", "-C", str(REPO), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "-C", str(REPO), "status", "--porcelain", "hdpbsid", "slbasis"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown commit"
    return f"commit {head}" + (" with uncommitted edits in hdpbsid/slbasis" if dirty else "")


def import_all_methods() -> None:
    """Import every hdpbsid module now, so that a long run uses one version of the code
    even if the files change while it runs (imports are otherwise lazy)."""
    import importlib
    import pkgutil

    for info in pkgutil.walk_packages(hdpbsid.__path__, "hdpbsid."):
        if ".studies" not in info.name and not info.name.endswith(("__main__", ".cli")):
            importlib.import_module(info.name)


def machine_line() -> str:
    import scipy

    cpus = os.cpu_count()
    return (
        f"{platform.machine()}, {cpus} cores (shared), Python {platform.python_version()}, "
        f"numpy {np.__version__}, scipy {scipy.__version__}, {_peer_versions()}"
    )


def _peer_versions() -> str:
    from importlib.metadata import PackageNotFoundError, version

    parts = []
    for pkg in ("sippy_unipi", "nfoursid", "control"):
        try:
            parts.append(f"{pkg} {version(pkg)}")
        except PackageNotFoundError:
            parts.append(f"{pkg} not installed")
    return ", ".join(parts)


def findings(cells: Sequence[dict[str, object]], timing: Sequence[dict[str, object]]) -> str:
    """Generated sentences: where a peer is most accurate, and the 10^4-sample time ratios."""
    lost = []
    for case_name, snr in dict.fromkeys((c["case"], c["snr"]) for c in cells):
        cc = [c for c in cells if c["case"] == case_name and c["snr"] == snr]
        winner = min(cc, key=lambda c: c["error_median_fail_inf"])
        if winner["peer"]:
            lost.append(f"{case_name} {snr}")
    parts = ["A peer is the most accurate in: " + (", ".join(lost) if lost else "no case") + "."]
    for case_name in dict.fromkeys(r["case"] for r in timing):
        rr = {r["method"]: r for r in timing if r["case"] == case_name}
        ours, sippy = rr.get("hermite (HD-PBSID)"), rr.get("SIPPY N4SID f=20")
        if ours and sippy:
            parts.append(
                f"On 10⁴ samples of the {case_name} case HD-PBSID took "
                f"{sippy['time_median'] / ours['time_median']:.1f}x less wall time "
                f"({sippy['cpu_median'] / ours['cpu_median']:.1f}x less CPU time) than "
                f"SIPPY N4SID at its default horizon."
            )
    return " ".join(parts)


def results_markdown(
    cells: Sequence[dict[str, object]],
    timing: Sequence[dict[str, object]],
    command: str,
    load: float | None = None,
) -> str:
    """The tables as markdown, headed by the command and the machine (the commit measured
    is in ``summary.json`` of ``--out``); ``load``: the load average when the timing began."""
    runs = max(int(c["runs"]) for c in cells)
    busy = (
        "the load average was not recorded"
        if load is None
        else f"the 1-minute load average was {load:.2f} on {os.cpu_count()} cores when it began"
    )
    return "\n".join(
        [
            f"Produced by `{command}` on {machine_line()}. "
            f"Median over {runs} seeds of the largest relative eigenvalue error over the "
            f"runs that produced a model (in brackets: failed runs, i.e. exception, "
            f"`sys.exit`, wrong order, NaN or no continuous counterpart; n/a: the method "
            f"does not apply); all methods get the true order and identical data. "
            f"Ours run with defaults; peers with their defaults and *tuned*: the horizon "
            f"of a grid with the best median error over the same seeds, i.e. chosen with "
            f"the true eigenvalues (the best a user could get). Timing: {busy}. "
            f"How it is measured: the docstring of "
            f"`bench/peers.py`.",
            "",
            summary_table(cells),
            "",
            findings(cells, timing),
            "",
            "Identification time on 10⁴ samples (median of 5, SNR 20 dB):",
            "",
            timing_markdown(timing),
            "",
            "<details><summary>Every method, with interquartile range, validation fit "
            "(100 (1 − NRMSE), %) and time</summary>",
            "",
            full_tables(cells),
            "",
            "</details>",
            "",
        ]
    )


def write_results(text: str, name: str, directory: Path = RESULTS) -> Path:
    """Write ``text`` to ``<directory>/<name>.md``, by default ``bench/results/<name>.md``
    (the benchmark pages include it), ending in one newline."""
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / f"{name}.md"
    path.write_text(text if text.endswith("\n") else text + "\n", encoding="utf-8")
    print(f"wrote {path}")
    return path


def _parse_snr(x: str) -> float | None:
    return None if x.lower() in ("none", "inf", "clean") else float(x)


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=10, help="seeds per cell")
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument(
        "--snr", nargs="+", type=_parse_snr, default=[40.0, 20.0, 10.0], help="dB, or none"
    )
    ap.add_argument("--methods", nargs="+", default=DEFAULT_METHODS, choices=list(METHODS))
    ap.add_argument("--out", type=Path, help="directory for CSV / JSON / markdown")
    ap.add_argument(
        "--results", action="store_true", help="write the tables to bench/results/peers.md"
    )
    ap.add_argument("--no-timing", action="store_true", help="skip the 10^4-sample timing")
    ap.add_argument("--n-jobs", type=int, default=1, help="(case, SNR) cells in parallel")
    ap.add_argument(
        "--from-json",
        type=Path,
        help="re-render the tables (and --results) from a summary.json of an earlier run",
    )
    ap.add_argument(
        "--peers-from",
        type=Path,
        help="reuse the peers' cells of an earlier run's summary.json (same data, checked) "
        "and run only our methods",
    )
    ap.add_argument(
        "--timing-from",
        type=Path,
        help="take the accuracy cells from a summary.json of an earlier run (e.g. one with "
        "--no-timing on a shared machine) and run only the timing, on an idle one",
    )
    args = ap.parse_args(argv)

    if args.from_json:
        saved = json.loads(args.from_json.read_text())
        cells, timing, command = saved["cells"], saved["timing"], saved["command"]
        print(summary_table(cells))
        if args.results:
            md = results_markdown(cells, timing, command.strip(), saved.get("load"))
            write_results(md, "peers")
        return

    command = "python bench/peers.py " + " ".join(sys.argv[1:] if argv is None else list(argv))
    import_all_methods()
    version = code_version()
    print(f"# {machine_line()}; {version}", flush=True)
    if args.timing_from:
        saved = json.loads(args.timing_from.read_text())
        rows, cells = [], saved["cells"]
        command = f"{saved['command'].strip()}; then {command}"
    else:
        methods, kept_rows, kept = args.methods, [], []
        if args.peers_from:
            kept_rows, kept = reuse_peer_cells(args.peers_from, args.cases, args.snr, args.runs)
            saved = json.loads(args.peers_from.read_text())
            command = f"{saved['command'].strip()}; then {command}"
            methods = [m for m in methods if not METHODS[m].peer]
        rows, cells = run_bench(
            args.cases,
            args.snr,
            methods,
            args.runs,
            log=lambda s: print(s, flush=True),
            n_jobs=args.n_jobs,
        )
        rows, cells = rows + kept_rows, cells + kept
    tuned_h = {
        str(c["case"]): int(c["horizon"])
        for c in cells
        if c["method"] == "sippy-n4sid-tuned" and c["snr"] == "20 dB"
    }
    load = None if args.no_timing else os.getloadavg()[0]
    timing = [] if args.no_timing else timing_table(tuned_h, log=lambda s: print(s, flush=True))
    print()
    print(summary_table(cells))
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
        if rows:
            with open(args.out / "runs.csv", "w", newline="") as fh:
                w = csv.DictWriter(fh, fieldnames=list(rows[0]))
                w.writeheader()
                w.writerows(rows)
        (args.out / "summary.json").write_text(
            json.dumps(
                {
                    "cells": cells,
                    "timing": timing,
                    "command": command,
                    "version": version,
                    "load": load,
                },
                indent=1,
            )
        )
        (args.out / "tables.md").write_text(results_markdown(cells, timing, command.strip(), load))
    if args.results:
        write_results(results_markdown(cells, timing, command.strip(), load), "peers")


if __name__ == "__main__":
    main()
