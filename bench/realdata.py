# ruff: noqa: E402  (bench/ goes on sys.path before its modules are imported)
"""Every hdpbsid method and the Python peers on measured and measured-like records.

Run: ``.venv/bin/python bench/realdata.py [--records NAME ...] [--out DIR] [--results]``
(peers from ``pip install -e ".[bench]"``; ``llsi``, ``pysib`` and ``PSID`` are used when
they import).

Data (``bench/data/``, from DaISy, the Database for the Identification of Systems, KU
Leuven, ESAT; see ``bench/data/README.md``): ``robot-arm.csv`` (flexible robot arm, 1024
samples, sampling time not given: one time unit) and ``ball-and-beam.csv`` (1000 samples,
0.1 s). Besides them, simulated records with the defects of measured ones
(``bench/measured_like.py``: a direct term with drift and coloured noise, a nonlinear
level loop with saturation and quantization, a long lightly damped resonance, a stiff
plant behind a clipping actuator), scored the same way; they judge methods and are never
used to tune a constant.

Scoring (the way a user judges a model on measured data):

1. split the record: the first ``floor(2 Ns / 3)`` samples estimate, the rest validate;
2. subtract the *estimation* part's input and output means from both parts (the same
   offsets: the validation part is not re-centred);
3. identify on the estimation part;
4. every model is compared in discrete time at the record's rate: continuous models are
   ZOH-sampled (:meth:`hdpbsid.models.model.StateSpaceModel.to_discrete`), discrete ones (SIPPY,
   nfoursid) are used as returned;
5. simulate it on the validation part from the initial state fitted by least squares
   (:func:`peers.discrete_ls_simulation`) and score
   ``fit = 100 (1 - ||y - yhat|| / ||y - mean y||)`` (:func:`peers.fit_percent`).

Methods: ours through ``hdpbsid.identify`` for every name of
``hdpbsid.available_methods()`` (plus ``method="auto"`` when ``identify`` accepts it), each
(a) with its defaults (``order=None``: the method picks the order) and (b) with the order
of ``1..8`` whose validation fit is best -- *tuned on validation*, i.e. on the answer.
Peers (the adapters of ``bench/peers.py``): SIPPY N4SID, MOESP, CVA and PARSIM-K and
nfoursid, each (a) at its default horizon (SIPPY ``f = p = 20``, nfoursid 2 block rows)
with the order tuned on validation over ``1..8``, and (b) with horizon and order both
tuned on validation (horizons of the ``bench/peers.py`` grids; a horizon needs more block
rows than the order).  Time: wall time of the identification call alone, in the default
environment (no thread variable set; hdpbsid sets its own thread counts,
:mod:`hdpbsid.runtime`); every method is called once before the timed runs (imports,
caches).  Not a
test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

sys.path.insert(0, str(Path(__file__).resolve().parent))

import measured_like
import more_peers
import peers
from cases import Record

import hdpbsid
from hdpbsid.models.model import StateSpaceModel

Array = NDArray[np.float64]

DATA = Path(__file__).resolve().parent / "data"

#: Orders tried when tuning on validation.
ORDERS = tuple(range(1, 9))

#: The peers of ``bench/peers.py`` run here (their ``METHODS`` keys, default horizon).
PEERS = ("sippy-n4sid", "sippy-moesp", "sippy-cva", "sippy-parsim-k", "nfoursid")


@dataclass(frozen=True)
class RecordInfo:
    """A measured record: CSV file in ``bench/data`` (columns ``u, y``), sampling time."""

    file: str
    dt: float
    description: str


RECORDS: dict[str, RecordInfo] = {
    "robot-arm": RecordInfo(
        "robot-arm.csv",
        1.0,
        "flexible robot arm, torque -> arm acceleration, 1024 samples, dt not given (1)",
    ),
    "ball-and-beam": RecordInfo(
        "ball-and-beam.csv",
        0.1,
        "ball and beam, beam angle -> ball position, 1000 samples, dt = 0.1 s",
    ),
}


@dataclass
class Split:
    """Estimation and validation parts of a record, both shifted by the estimation
    part's means ``u_offset (m,)``, ``y_offset (l,)``; times start at 0 and ``dt`` apart
    (the validation part continues the estimation part's clock)."""

    estimation: Record
    validation: Record
    dt: float
    u_offset: Array
    y_offset: Array


#: Simulated measured-like records (``bench/measured_like.py``), seed 0.
SIMULATED = tuple(measured_like.GENERATORS)

#: Above this many estimation samples the peers run at their default setting only (a
#: horizon grid on a long record costs minutes per tool and does not change the ranking).
LONG_RECORD = 20_000


#: Peers whose fit takes minutes on a long record (iterative PEM in pure Python): skipped
#: above :data:`LONG_RECORD` samples.
SLOW_PEERS = ("llsi-pem",)


def load_record(name: str, data_dir: Path = DATA) -> tuple[Array, Array, float]:
    """``(u (Ns, 1), y (Ns, 1), dt)`` of record ``name`` (a key of :data:`RECORDS` or a
    simulated record of :data:`SIMULATED`)."""
    if name in SIMULATED:
        s = measured_like.GENERATORS[name](0)
        return s.u, s.y, s.dt
    if name not in RECORDS:
        raise ValueError(f"record must be one of {list(RECORDS) + list(SIMULATED)}, got {name!r}")
    info = RECORDS[name]
    data = np.loadtxt(data_dir / info.file, delimiter=",", skiprows=1, ndmin=2)
    return data[:, :1], data[:, 1:2], info.dt


def split_record(u: Array, y: Array, dt: float) -> Split:
    """Split ``u (Ns, m)``, ``y (Ns, l)`` into the first ``floor(2 Ns / 3)`` samples and
    the rest, and subtract the first part's means from both parts."""
    u = np.asarray(u, dtype=float).reshape(u.shape[0], -1)
    y = np.asarray(y, dtype=float).reshape(y.shape[0], -1)
    if u.shape[0] != y.shape[0]:
        raise ValueError(f"u and y must have the same number of rows, got {u.shape}, {y.shape}")
    if not dt > 0:
        raise ValueError(f"dt must be positive, got {dt!r}")
    ns = u.shape[0]
    n_est = (2 * ns) // 3
    u_off, y_off = u[:n_est].mean(axis=0), y[:n_est].mean(axis=0)
    t = dt * np.arange(ns)
    est = Record(t[:n_est], u[:n_est] - u_off, y[:n_est] - y_off)
    val = Record(t[n_est:], u[n_est:] - u_off, y[n_est:] - y_off)
    return Split(est, val, float(dt), u_off, y_off)


def discrete_matrices(model: peers.Identified, dt: float) -> tuple[Array, Array, Array, Array]:
    """``(A, B, C, D)`` of ``model`` in discrete time at ``dt``: a continuous model
    (``model.dt is None``) is ZOH-sampled; a discrete one must already be at ``dt``."""
    if model.dt is None:
        K = np.zeros((model.A.shape[0], model.C.shape[0]))
        d = StateSpaceModel(model.A, model.B, model.C, model.D, K).to_discrete(dt)
        return d.A, d.B, d.C, d.D
    if not np.isclose(model.dt, dt, rtol=1e-9):
        raise ValueError(f"model.dt must equal the record's dt {dt}, got {model.dt}")
    return model.A, model.B, model.C, model.D


def validation_output(model: peers.Identified, split: Split) -> Array:
    """The model's simulated output on the validation part (least-squares initial state)."""
    A, B, C, D = discrete_matrices(model, split.dt)
    rec = split.validation
    with np.errstate(all="ignore"):
        return peers.discrete_ls_simulation(A, B, C, D, rec.u, rec.y)


def validation_fit(model: peers.Identified, split: Split) -> float:
    """Fit (percent) of ``model`` on the validation part; ``-inf`` if not finite."""
    try:
        yhat = validation_output(model, split)
    except (ValueError, np.linalg.LinAlgError):
        return -np.inf
    if not np.all(np.isfinite(yhat)):
        return -np.inf
    with np.errstate(all="ignore"):
        fit = peers.fit_percent(split.validation.y, yhat)
    return fit if np.isfinite(fit) else -np.inf


# -- runs ----------------------------------------------------------------------------------
@dataclass
class Run:
    """One identification: what was asked, what came out, its fit and time."""

    method: str
    horizon: int | None
    order_requested: int | None
    status: str  # "ok", "exception", "exit", "wrong-order", "nan"
    order: int | None = None
    fit: float = np.nan
    seconds: float = np.nan
    message: str = ""
    model: peers.Identified | None = None


def _attempt(
    label: str,
    func: Callable[[], peers.Identified],
    split: Split,
    horizon: int | None,
    order: int | None,
) -> Run:
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            model = func()
    except SystemExit as exc:  # SIPPY calls sys.exit() on bad arguments
        return Run(label, horizon, order, "exit", message=str(exc)[:200])
    except Exception as exc:  # noqa: BLE001 - a peer may raise anything; count it
        return Run(label, horizon, order, "exception", message=f"{type(exc).__name__}: {exc}"[:200])
    seconds = time.perf_counter() - t0
    mats = [np.asarray(M, dtype=float) for M in (model.A, model.B, model.C, model.D)]
    model = peers.Identified(*mats, dt=model.dt)
    n = model.A.shape[0]
    if order is not None and n != order:
        return Run(label, horizon, order, "wrong-order", n, seconds=seconds, message=f"order {n}")
    if not all(np.all(np.isfinite(M)) for M in mats):
        return Run(label, horizon, order, "nan", n, seconds=seconds)
    fit = validation_fit(model, split)
    return Run(label, horizon, order, "ok", n, fit, seconds, model=model)


#: suffixes of a method name that ask for a focus of the refinement
#: (``identify(..., focus=...)``), e.g. ``auto+simulation``; none: the default
FOCUS_SUFFIXES = ("+prediction", "+simulation")


def _ours(method: str, split: Split, order: int | None) -> Run:
    rec = split.estimation
    name, focus = method, {}
    for suffix in FOCUS_SUFFIXES:
        if method.endswith(suffix):
            name, focus = method.removesuffix(suffix), {"focus": suffix[1:]}

    def call() -> peers.Identified:
        m = hdpbsid.identify(rec.t, rec.u, rec.y, method=name, order=order, **focus)
        return peers.Identified(m.A, m.B, m.C, m.D, None)

    return _attempt(method, call, split, None, order)


def _peer(key: str, split: Split, horizon: int | None, order: int) -> Run:
    run = more_peers.PEERS[key].run if key in more_peers.PEERS else peers.METHODS[key].run
    return _attempt(key, lambda: run(split.estimation, order, horizon), split, horizon, order)


def peer_default(key: str) -> int | None:
    """The peer's default second setting (horizon, or input delay for polynomial models)."""
    if key in more_peers.PEERS:
        return more_peers.PEERS[key].default
    return peers.METHODS[key].default


def peer_label(key: str) -> str:
    if key in more_peers.PEERS:
        return more_peers.PEERS[key].label
    return peers.METHODS[key].label.split(" (")[0]


def auto_is_accepted() -> bool:
    """Whether ``hdpbsid.identify(..., method="auto")`` exists (it is not a registry name
    on every version): a call on a tiny record that fails only as an unknown method."""
    if "auto" in hdpbsid.available_methods():
        return True
    t = np.arange(200.0)
    rng = np.random.default_rng(0)
    u = rng.standard_normal((200, 1))
    y = np.convolve(u[:, 0], 0.5 ** np.arange(10))[:200, None]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            hdpbsid.identify(t, u, y, method="auto", order=1)
    except ValueError as exc:
        return "unknown method" not in str(exc) and "not available" not in str(exc)
    except Exception:  # noqa: BLE001 - "auto" exists but failed on this toy record
        return True
    return True


def our_methods(log: Callable[[str], None] = print) -> list[str]:
    """Registry names, plus ``"auto"`` when ``identify`` accepts it."""
    names = list(hdpbsid.available_methods())
    if "auto" not in names:
        if auto_is_accepted():
            names.append("auto")
        else:
            log('# note: hdpbsid.identify does not accept method="auto" here; skipped')
    return names


def peer_horizons(key: str, n_outputs: int, order: int) -> list[int]:
    """Default horizon first, then the rest of the ``bench/peers.py`` grid, keeping only
    horizons with more block rows (``h * n_outputs``) than the order."""
    if key in more_peers.PEERS:
        p = more_peers.PEERS[key]
        return [p.default, *[h for h in p.grid if h != p.default]]
    base = peers.METHODS[key]
    grid = peers.METHODS[key + "-tuned"].grid or ()
    hs = [base.default, *[h for h in grid if h != base.default]]
    return [h for h in hs if h * n_outputs > order]


def run_record(
    name: str,
    methods: Sequence[str],
    peer_keys: Sequence[str],
    log: Callable[[str], None] = print,
) -> tuple[Split, list[Run]]:
    """Every run on record ``name``: each of our methods at ``order=None`` and at every
    order of :data:`ORDERS`; each peer at every (valid horizon, order)."""
    u, y, dt = load_record(name)
    split = split_record(u, y, dt)
    runs: list[Run] = []
    l_out = split.estimation.y.shape[1]
    # warm-up, not timed or kept: imports, lazy registration, basis caches
    for m in methods:
        _ours(m, split, None)
    long = split.estimation.t.size > LONG_RECORD
    for key in peer_keys:
        if not (long and key in SLOW_PEERS):
            _peer(key, split, peer_default(key), 1)
    for m in methods:
        for order in (None, *ORDERS):
            r = _ours(m, split, order)
            runs.append(r)
        best = _best([r for r in runs if r.method == m and r.order_requested is not None])
        default = next(r for r in runs if r.method == m and r.order_requested is None)
        log(f"{name:13s} {m:16s} defaults: {_run_txt(default)};  tuned: {_run_txt(best)}")
    for key in peer_keys:
        if long and key in SLOW_PEERS:
            log(f"{name:13s} {key:16s} skipped: over {LONG_RECORD} samples (minutes a fit)")
            continue
        for order in ORDERS:
            hs = peer_horizons(key, l_out, order)
            if long:
                hs = hs[:1]
            for h in hs:
                runs.append(_peer(key, split, h, order))
        mine = [r for r in runs if r.method == key]
        default_h = peer_default(key)
        log(
            f"{name:13s} {key:16s} default horizon: "
            f"{_run_txt(_best([r for r in mine if r.horizon == default_h]))};  "
            f"tuned horizon: {_run_txt(_best(mine))}"
        )
    return split, runs


def _best(runs: Sequence[Run]) -> Run | None:
    ok = [r for r in runs if r.status == "ok"]
    return max(ok, key=lambda r: r.fit) if ok else None


def _run_txt(r: Run | None) -> str:
    if r is None:
        return "no model"
    if r.status != "ok":
        return f"{r.status} ({r.message[:60]})"
    h = "" if r.horizon is None else f" h={r.horizon}"
    return f"fit {r.fit:6.1f} %, order {r.order}{h}, {1e3 * r.seconds:.0f} ms"


# -- summary ---------------------------------------------------------------------------
@dataclass
class Entry:
    """One row of the table for one record: a method in one setting and its chosen run."""

    key: str
    label: str
    peer: bool
    run: Run | None
    failures: dict[str, int]


def summarize(runs: Sequence[Run], methods: Sequence[str], peer_keys: Sequence[str]) -> list[Entry]:
    """Rows: each of ours with defaults and tuned on validation; each peer at its default
    horizon (order tuned) and with horizon and order tuned."""
    out = []

    def fails(rr: Sequence[Run]) -> dict[str, int]:
        f: dict[str, int] = {}
        for r in rr:
            if r.status != "ok":
                f[r.status] = f.get(r.status, 0) + 1
        return f

    for m in methods:
        mine = [r for r in runs if r.method == m]
        default = [r for r in mine if r.order_requested is None]
        tuned = [r for r in mine if r.order_requested is not None]
        out.append(Entry(m, f"ours: {m}, defaults", False, default[0], fails(default)))
        out.append(
            Entry(m + "-tuned", f"ours: {m}, order tuned on validation", False, _best(tuned), {})
        )
    for key in peer_keys:
        mine = [r for r in runs if r.method == key]
        default = peer_default(key)
        dflt = [r for r in mine if r.horizon == default]
        name = peer_label(key)
        if key == "arx":
            fixed = [r for r in dflt if r.order_requested == 2]
            out.append(
                Entry(
                    "arx-2-2", "ARX(2, 2) least squares, nk = 1", True, _best(fixed), fails(fixed)
                )
            )
        setting = "" if default is None else f" (default setting {default})"
        out.append(
            Entry(
                key,
                f"{name}{setting}, order tuned on validation",
                True,
                _best(dflt),
                fails(dflt),
            )
        )
        out.append(
            Entry(
                key + "-tuned",
                f"{name}, setting and order tuned on validation",
                True,
                _best(mine),
                {},
            )
        )
    return out


def _cell(e: Entry) -> str:
    r = e.run
    if r is None:
        return "no model (" + ", ".join(f"{v} {k}" for k, v in sorted(e.failures.items())) + ")"
    if r.status != "ok":
        return f"fails ({r.status})"
    h = "" if r.horizon is None else f", h={r.horizon}"
    fit = f"{r.fit:.1f} %" if r.fit > -100 else "< -100 %"
    return f"{fit} · n={r.order}{h} · {_ms(r.seconds)}"


def _ms(x: float) -> str:
    return f"{1e3 * x:.0f} ms" if x >= 0.01 else f"{1e3 * x:.1f} ms"


def markdown_table(results: dict[str, list[Entry]]) -> str:
    """Rows = method and setting, a column per record: ``fit % · order (horizon) · time``."""
    names = list(results)
    labels = list(dict.fromkeys(e.label for ee in results.values() for e in ee))
    lines = [
        "| method | " + " | ".join(f"{n}: fit · order · time" for n in names) + " |",
        "|---|" + "---|" * len(names),
    ]
    for lab in labels:
        cells = []
        for n in names:
            e = next((e for e in results[n] if e.label == lab), None)
            cells.append("n/a" if e is None else _cell(e))
        lines.append(f"| {lab} | " + " | ".join(cells) + " |")
    best = []
    for n in names:
        for peer in (False, True):
            ok = [e for e in results[n] if e.peer == peer and e.run is not None]
            if ok:
                b = max(ok, key=lambda e: e.run.fit)
                who = "peer" if peer else "ours"
                best.append(f"{n}, best {who}: {b.label} {b.run.fit:.1f} %")
    return "\n".join(lines) + "\n\n" + "; ".join(best) + "."


def results_markdown(results: dict[str, list[Entry]], command: str) -> str:
    """The table as markdown, headed by the command, the machine and how it is scored
    (the commit measured is in ``summary.json`` of ``--out``)."""
    return "\n".join(
        [
            f"Produced by `{command}` on {peers.machine_line()}. "
            "Measured records from DaISy (KU Leuven, ESAT; `bench/data/README.md`); the "
            "others are simulated with the defects of measured ones "
            "(`bench/measured_like.py`). Identified on "
            "the first two thirds after removing that part's means, scored on the last "
            "third: simulation from a least-squares initial state, every model in discrete "
            "time at the record's rate (continuous models ZOH-sampled), fit = 100 (1 − "
            "‖y − ŷ‖ / ‖y − mean y‖). *Order tuned on validation*: the best of orders 1..8 "
            "on the validation third itself (the answer); *defaults*: the method picks the "
            "order. n = order, h = horizon (SIPPY f = p, nfoursid block rows). Times are "
            "noisy (shared cores). How it is measured: the docstring of "
            "`bench/realdata.py`.",
            "",
            markdown_table(results),
            "",
        ]
    )


def plot_record(name: str, split: Split, entries: Sequence[Entry], path: Path) -> None:
    """Measured validation output vs the best of ours and the best peer (by fit)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rec = split.validation
    fig, ax = plt.subplots(figsize=(9, 3.6))
    ax.plot(rec.t, rec.y[:, 0], color="k", lw=1.4, label="measured")
    for peer, style in ((False, "-"), (True, "--")):
        ok = [e for e in entries if e.peer == peer and e.run is not None and e.run.model]
        if not ok:
            continue
        b = max(ok, key=lambda e: e.run.fit)
        yhat = validation_output(b.run.model, split)
        ax.plot(rec.t, yhat[:, 0], style, lw=1.0, label=f"{b.label}: {b.run.fit:.1f} %")
    unit = "s" if split.dt != 1.0 else "samples"
    ax.set_xlabel(f"time ({unit})")
    ax.set_ylabel("y − estimation mean")
    ax.set_title(f"{name}: validation third")
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    names = list(RECORDS) + list(SIMULATED)
    ap.add_argument("--records", nargs="+", default=names, choices=names)
    all_peers = list(PEERS) + list(more_peers.PEERS)
    ap.add_argument(
        "--peers", nargs="+", choices=all_peers, help="default: every peer that imports here"
    )
    ap.add_argument(
        "--methods",
        nargs="+",
        help="our methods (default: every available); NAME+simulation, NAME+prediction: "
        "with that focus (e.g. auto+simulation)",
    )
    ap.add_argument("--out", type=Path, help="directory for CSV / JSON / markdown / figures")
    ap.add_argument(
        "--results", action="store_true", help="write the table to bench/results/realdata.md"
    )
    args = ap.parse_args(argv)

    command = "python bench/realdata.py " + " ".join(sys.argv[1:] if argv is None else argv)
    peers.import_all_methods()
    if args.peers is None:
        args.peers = list(PEERS) + more_peers.available()
    version = peers.code_version()
    print(f"# {peers.machine_line()}; {version}", flush=True)
    methods = args.methods or our_methods(log=lambda s: print(s, flush=True))
    results: dict[str, list[Entry]] = {}
    rows: list[dict[str, object]] = []
    if args.out:
        args.out.mkdir(parents=True, exist_ok=True)
    for name in args.records:
        t0 = time.perf_counter()
        split, runs = run_record(name, methods, args.peers, log=lambda s: print(s, flush=True))
        results[name] = summarize(runs, methods, args.peers)
        print(f"# {name}: {time.perf_counter() - t0:.0f} s", flush=True)
        rows += [
            {
                "record": name,
                "method": r.method,
                "horizon": r.horizon,
                "order_requested": r.order_requested,
                "order": r.order,
                "status": r.status,
                "fit": r.fit,
                "seconds": r.seconds,
                "message": r.message,
            }
            for r in runs
        ]
        if args.out:
            plot_record(name, split, results[name], args.out / f"{name}.png")
    table = markdown_table(results)
    print()
    print(table)
    section = results_markdown(results, command.strip())
    if args.out:
        with open(args.out / "runs.csv", "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        summary = {
            name: [
                {
                    "key": e.key,
                    "label": e.label,
                    "peer": e.peer,
                    "fit": None if e.run is None else e.run.fit,
                    "order": None if e.run is None else e.run.order,
                    "horizon": None if e.run is None else e.run.horizon,
                    "seconds": None if e.run is None else e.run.seconds,
                    "failures": e.failures,
                }
                for e in entries
            ]
            for name, entries in results.items()
        }
        (args.out / "summary.json").write_text(
            json.dumps({"results": summary, "command": command, "version": version}, indent=1)
        )
        (args.out / "table.md").write_text(section + "\n")
    if args.results:
        peers.write_results(section, "realdata")


if __name__ == "__main__":
    main()
