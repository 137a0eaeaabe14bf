"""Accuracy and run time of every hdpbsid method on the benchmark systems.

Run: ``.venv/bin/python bench/identify.py [--runs 20] [--snr 40 20 10]
[--cases second-order chirp quadrotor pbsid-mimo nonuniform] [--methods ...]``
(``--quick``: 5 runs, SNR 20 only; ``--order none``: ``order=None``, the method's own
choice).  Run in the default environment: the library sets its own thread counts
(:mod:`hdpbsid.runtime`).

``--defaults`` measures ``hdpbsid.identify(t, u, y)`` with every default instead
(``method="auto"``, held-out order choice, mean removal) on :data:`DEFAULTS_CASES`:
per seed the order and method chosen, the worst relative eigenvalue error, and the cost
of the call (CPU time of the process, which a loaded machine disturbs less than wall
time) against one HD-PBSID fit at the true order on the same record, like for like:

* both with their defaults (``refine="auto"``: each result refined by the
  prediction-error method where the rule says so; what a user gets from
  ``identify(t, u, y)`` against ``identify(t, u, y, n, method="hermite")``);
* both with ``refine=None``: the selection of the method and order against the subspace
  fit as the thesis describes it.

With ``--n-jobs N`` each ``auto`` call is also timed with ``n_jobs=N`` by wall time,
against the wall time of the same fit.  Last, each of ``auto``'s methods is fitted once
at the true order (``refine=None``): the sum of their CPU times is the floor of any
selection among them, whatever its rule.  Then an accuracy table and a cost table, one
row per case (``--runs`` seeds, default 10 here).  The caches of
:mod:`hdpbsid.bases.memo` are cleared before every timed call, so that no call is
timed on another's projection.

Prints, per case (the generators of ``bench/cases.py``),
SNR and method, over seeded Monte Carlo runs with the true order given:

* ``bias %``: ``max_i |mean(lambda_i) - lambda_i| / |lambda_i|`` (eigenvalues paired
  with the truth by :func:`hdpbsid.models.metrics.match_eigenvalues`);
* ``std %``: ``max_i sqrt(mean |lambda_i - mean|^2) / |lambda_i|``;
* ``median %``: median over runs of the largest relative error; ``<=5 %``: the share of
  runs whose every eigenvalue is within 5 %;
* ``failed``: runs that raised; ``time ms``: median wall time of the call.

Methods: the registry's (``dt``, ``hermite``, ``laguerre``, ``legendre``, ``chebyshev``),
``laguerre-filter`` (``variant="filter"``) and ``hermite+pem`` (``refine="pem"``).  The
PBSID toolbox MIMO case is discrete: only ``dt`` (``identify_discrete``), eigenvalues in
the z-plane.  Then the fit time for ``10^4`` samples with ``N = 400``.  Not a test:
nothing is asserted.
"""

from __future__ import annotations

import argparse
import inspect
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cases import DESCRIPTIONS, make_case  # noqa: E402

from hdpbsid import get_method, identify, identify_discrete  # noqa: E402
from hdpbsid.bases.memo import clear_caches  # noqa: E402
from hdpbsid.bases.settings import SETTING_NAMES  # noqa: E402
from hdpbsid.models.metrics import match_eigenvalues  # noqa: E402
from hdpbsid.selection.auto import AUTO_METHODS  # noqa: E402

#: method label -> (registry name, extra keyword arguments of identify)
METHODS: dict[str, tuple[str, dict[str, Any]]] = {
    "dt": ("dt", {}),
    "hermite": ("hermite", {}),
    "hermite+pem": ("hermite", {"refine": "pem"}),
    "laguerre": ("laguerre", {}),
    "laguerre-filter": ("laguerre", {"variant": "filter"}),
    "legendre": ("legendre", {}),
    "chebyshev": ("chebyshev", {}),
}
DEFAULT_CASES = ("second-order", "chirp", "quadrotor", "pbsid-mimo", "nonuniform")
#: acceptance threshold: every closed-loop eigenvalue within 5 % (relative error)
WITHIN = 0.05
#: ``--defaults``: (case, SNR) pairs, the SNR the case is usually quoted at
DEFAULTS_CASES: tuple[tuple[str, float | None], ...] = (
    ("second-order", 20.0),
    ("quadrotor", 20.0),
    ("stiff", 20.0),
    ("stiff", 40.0),
    ("rao-garnier", 10.0),
    ("pbsid-mimo", None),
    ("mimo-2x2", 20.0),
    ("table2-closed-loop-rate", 20.0),
    ("nonuniform", 20.0),
)


def identify_case(label: str, case: Any, free_order: bool = False) -> np.ndarray:
    """Eigenvalues identified by method ``label`` on the estimation record of ``case``,
    with the true order, or with ``order=None`` (the method's own choice) if
    ``free_order``."""
    rec = case.estimation
    order = None if free_order else case.order
    if case.discrete:
        return np.linalg.eigvals(identify_discrete(rec.u, rec.y, order, p=10).A)
    name, kw = METHODS[label]
    opts = case_options(name, case)
    # simulated from rest at a zero operating point: no mean removal (as the peers get them)
    return identify(rec.t, rec.u, rec.y, order, method=name, detrend=None, **kw, **opts).eigenvalues


def case_options(name: str, case: Any) -> dict[str, Any]:
    """The entries of ``case.options`` that method ``name``'s function accepts: its named
    keywords, and the shared basis settings when it takes them as ``**keywords``."""
    params = inspect.signature(get_method(name)).parameters
    names = set(params)
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        names |= set(SETTING_NAMES)
    return {k: v for k, v in case.options.items() if k in names}


def monte_carlo(
    label: str, case_name: str, snr: float | None, runs: int, free_order: bool = False
) -> dict[str, Any]:
    """Statistics of ``runs`` seeded identifications (module docstring); with
    ``free_order`` the errors are over the runs that chose the true order, and
    ``orders`` counts the chosen orders."""
    est, worst, times, failed = [], [], [], 0
    orders: dict[int, int] = {}
    true = None
    for seed in range(runs):
        case = make_case(case_name, seed, snr)
        true = np.asarray(case.true_eigenvalues)
        t0 = time.perf_counter()
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ev = identify_case(label, case, free_order)
        except (ValueError, np.linalg.LinAlgError):
            failed += 1
            continue
        times.append(time.perf_counter() - t0)
        orders[ev.size] = orders.get(ev.size, 0) + 1
        if ev.size != true.size:
            continue
        paired, tr = match_eigenvalues(ev, true)
        est.append(paired)
        worst.append(float(np.max(np.abs(paired - tr) / np.abs(tr))))
    if not est:
        stats = dict.fromkeys(("bias", "std", "median", "within"), float("nan"))
        t_med = float(np.median(times)) if times else float("nan")
        return {**stats, "time": t_med, "failed": failed, "orders": orders}
    tr = match_eigenvalues(true, true)[1]
    E = np.array(est)
    mean = E.mean(axis=0)
    return {
        "bias": float(np.max(np.abs(mean - tr) / np.abs(tr))),
        "std": float(np.max(np.sqrt(np.mean(np.abs(E - mean) ** 2, axis=0)) / np.abs(tr))),
        "median": float(np.median(worst)),
        "within": float(np.mean(np.array(worst) <= WITHIN)),
        "failed": failed,
        "time": float(np.median(times)),
        "orders": orders,
    }


def fit_time(N: int = 400, ns: int = 10_000) -> None:
    """Median of 3 fit times on ``ns`` samples of the second-order case with ``N`` terms."""
    case = make_case("second-order", 7, 20.0)
    rec = case.estimation
    t, u, y = rec.t, rec.u, rec.y
    while t.size < ns:  # extend by repeating the record (the fit time depends on Ns only)
        t = np.r_[t, t[-1] + (t[1] - t[0]) + rec.t - rec.t[0]]
        u, y = np.r_[u, rec.u], np.r_[y, rec.y]
    t, u, y = t[:ns], u[:ns], y[:ns]
    print(f"\nfit time for Ns = {t.size} samples, N = {N} (order 2, median of 3):")
    for label in ("hermite", "laguerre", "legendre", "chebyshev", "dt", "hermite+pem"):
        name, kw = METHODS[label]
        kw = dict(kw) if name == "dt" else {**kw, "N": N}
        el = []
        for _ in range(3):
            t0 = time.perf_counter()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                identify(t, u, y, 2, method=name, detrend=None, **kw)
            el.append(time.perf_counter() - t0)
        print(f"  {label:16s} {np.median(el) * 1e3:9.1f} ms")


def _timed(f: Any, *args: Any, **kwargs: Any) -> tuple[Any, float, float]:
    """``f(*args, **kwargs)`` from empty caches (none reuses another call's projection):
    ``(result, CPU seconds of the process, wall seconds)``."""
    clear_caches()
    t0, w0 = time.process_time(), time.perf_counter()
    out = f(*args, **kwargs)
    return out, time.process_time() - t0, time.perf_counter() - w0


def defaults_run(
    case_name: str, seed: int, snr: float | None, n_jobs: int | None = None
) -> dict[str, Any]:
    """One seed of ``--defaults``: ``identify(t, u, y)`` and one HD-PBSID fit at the true
    order on the same record (module docstring), each with its default refinement and
    with ``refine=None`` (the selection's own cost against the subspace fit's).  A
    discrete case's model is compared through ``exp(lambda dt)`` (its times are sample
    indices, ``dt = 1``).  With ``n_jobs``, both ``identify(t, u, y, n_jobs=n_jobs)``
    calls are timed as well, by wall time (the workers' CPU time is not the process's),
    against the wall time of the one fit."""
    case = make_case(case_name, seed, snr)
    rec = case.estimation
    data = (rec.t, rec.u, rec.y)
    true = np.asarray(case.true_eigenvalues)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, t_one, w_one = _timed(identify, *data, case.order, method="hermite", refine=None)
        _, t_one_ref, w_one_ref = _timed(identify, *data, case.order, method="hermite")
        # the floor of any selection among auto's methods: each fitted once, true order
        t_each = 0.0
        for name in AUTO_METHODS:
            try:
                t_each += _timed(identify, *data, case.order, method=name, refine=None)[1]
            except ValueError:
                pass
        model, t_auto, _ = _timed(identify, *data)
        _, t_auto_sub, _ = _timed(identify, *data, refine=None)
        w_par = w_par_sub = None
        if n_jobs is not None:
            w_par = _timed(identify, *data, n_jobs=n_jobs)[2]
            w_par_sub = _timed(identify, *data, refine=None, n_jobs=n_jobs)[2]
    ev = model.eigenvalues
    if case.discrete:
        ev = np.exp(ev * float(rec.t[1] - rec.t[0]))
    worst = float("nan")
    if ev.size == true.size:
        paired, tr = match_eigenvalues(ev, true)
        worst = float(np.max(np.abs(paired - tr) / np.abs(tr)))
    return {
        "order": model.n,
        "true_order": case.order,
        "method": model.options.get("method"),
        "worst": worst,
        "t_auto": t_auto,
        "t_auto_sub": t_auto_sub,
        "t_each": t_each,
        "t_one": t_one,
        "t_one_refined": t_one_ref,
        "w_one": w_one,
        "w_one_refined": w_one_ref,
        "w_par": w_par,
        "w_par_sub": w_par_sub,
    }


#: ``--defaults`` cost ratios: (name, numerator, denominator); per seed, then median / max
COST_RATIOS = (
    ("cpu", "t_auto", "t_one_refined"),
    ("wall", "w_par", "w_one_refined"),
    ("cpu_sub", "t_auto_sub", "t_one"),
    ("wall_sub", "w_par_sub", "w_one"),
    ("each", "t_each", "t_one"),
)


def _median_max(values: list[float]) -> str:
    return f"{np.median(values):.1f} / {np.max(values):.1f}" if values else "n/a"


def defaults_table(
    runs: int, cases: Any = DEFAULTS_CASES, n_jobs: int | None = None
) -> list[dict[str, Any]]:
    """``--defaults``: print one line per seed, then an accuracy table and a cost table
    (one row per case), and return the summary rows."""
    # one small fit first, so that no case pays for the first call's compilation, and with
    # n_jobs one parallel call, so that none pays for starting the workers (reported)
    warm = make_case("second-order", 0, 20.0).estimation
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        identify(warm.t[:800], warm.u[:800], warm.y[:800], 2, method="hermite")
        if n_jobs is not None:
            w0 = time.perf_counter()
            identify(warm.t[:800], warm.u[:800], warm.y[:800], n_jobs=n_jobs)
            print(
                f"  first parallel call of the process (starts {n_jobs} workers): "
                f"{time.perf_counter() - w0:.2f} s wall, not counted below",
                flush=True,
            )
    summary = []
    for case_name, snr in cases:
        snr_txt = "own" if snr is None else f"{snr:g} dB"
        rows = []
        for seed in range(runs):
            r = defaults_run(case_name, seed, snr, n_jobs)
            rows.append(r)
            par = (
                f"; n_jobs={n_jobs}: {r['w_par']:.2f} s wall = "
                f"{r['w_par'] / r['w_one_refined']:.1f} x, refine=None "
                f"{r['w_par_sub'] / r['w_one']:.1f} x (wall)"
                if n_jobs is not None
                else ""
            )
            print(
                f"  {case_name:23s} {snr_txt:>6s} seed {seed:2d}: order {r['order']} "
                f"(true {r['true_order']}) {r['method']:9s} worst {100 * r['worst']:7.3f} % "
                f"auto {r['t_auto']:5.2f} s CPU = {r['t_auto'] / r['t_one_refined']:4.1f} x "
                f"one HD-PBSID fit ({r['t_one_refined']:.3f} s); refine=None "
                f"{r['t_auto_sub']:5.2f} s = {r['t_auto_sub'] / r['t_one']:4.1f} x "
                f"({r['t_one']:.3f} s){par}",
                flush=True,
            )
        hit = [r for r in rows if r["order"] == r["true_order"]]
        worst = [r["worst"] for r in hit]
        methods: dict[str, int] = {}
        for r in rows:
            methods[r["method"]] = methods.get(r["method"], 0) + 1
        ratios = {
            name: [r[a] / r[b] for r in rows if r[a] is not None] for name, a, b in COST_RATIOS
        }
        summary.append(
            {
                "case": case_name,
                "snr": snr_txt,
                "true_order": rows[0]["true_order"],
                "picked": f"{len(hit)}/{runs}",
                "orders": sorted(r["order"] for r in rows),
                "worst_median": float(np.median(worst)) if worst else float("nan"),
                "worst_max": float(np.max(worst)) if worst else float("nan"),
                "t_auto_median": float(np.median([r["t_auto"] for r in rows])),
                "t_auto_sub_median": float(np.median([r["t_auto_sub"] for r in rows])),
                "ratios": ratios,
                "methods": methods,
            }
        )
    print(
        "\n| case | SNR | true order | picked | worst eig. error (median / max) "
        "| methods chosen |\n|---|---:|---:|---:|---:|---|"
    )
    for s_ in summary:
        meth = ", ".join(f"{k} {v}" for k, v in sorted(s_["methods"].items()))
        print(
            f"| {s_['case']} | {s_['snr']} | {s_['true_order']} | {s_['picked']} | "
            f"{100 * s_['worst_median']:.2f} / {100 * s_['worst_max']:.2f} % | {meth} |"
        )
    nj = f"n_jobs={n_jobs}" if n_jobs is not None else "n_jobs"
    print(
        "\nCost, median / max over the seeds: the call against one HD-PBSID fit at the true "
        "order, both with the default refinement, then both with refine=None; last, each "
        f"of auto's methods ({', '.join(AUTO_METHODS)}) fitted once at the true order with "
        "refine=None, CPU against the one HD-PBSID fit\n"
        f"\n| case | SNR | auto CPU | CPU x | {nj}: wall x | auto, refine=None: CPU | "
        f"CPU x | {nj}: wall x | each method once: CPU x |"
        "\n|---|---:|---:|---:|---:|---:|---:|---:|---:|"
    )
    for s_ in summary:
        q = s_["ratios"]
        print(
            f"| {s_['case']} | {s_['snr']} | {s_['t_auto_median']:.2f} s | "
            f"{_median_max(q['cpu'])} | {_median_max(q['wall'])} | "
            f"{s_['t_auto_sub_median']:.2f} s | {_median_max(q['cpu_sub'])} | "
            f"{_median_max(q['wall_sub'])} | {_median_max(q['each'])} |"
        )
    return summary


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--snr", type=float, nargs="+", default=[40.0, 20.0, 10.0])
    ap.add_argument("--cases", nargs="+", default=list(DEFAULT_CASES))
    ap.add_argument("--methods", nargs="+", default=list(METHODS), choices=list(METHODS))
    ap.add_argument("--quick", action="store_true", help="5 runs at SNR 20 dB")
    ap.add_argument("--no-fit-time", action="store_true")
    ap.add_argument(
        "--order",
        choices=("true", "none"),
        default="true",
        help="give the true order, or order=None (the method chooses; errors over the "
        "runs that chose the true order, the chosen orders listed)",
    )
    ap.add_argument(
        "--defaults",
        action="store_true",
        help="identify(t, u, y) with every default: order picked per seed, worst "
        "eigenvalue error and cost relative to one HD-PBSID fit (--runs seeds, default 10)",
    )
    ap.add_argument(
        "--n-jobs",
        type=int,
        default=None,
        help="with --defaults: also time identify(t, u, y, n_jobs=N) by wall time "
        "(with its default refinement and with refine=None)",
    )
    ap.add_argument(
        "--defaults-cases",
        nargs="+",
        default=None,
        help="with --defaults: only these cases (names of DEFAULTS_CASES)",
    )
    args = ap.parse_args()
    if args.defaults:
        runs = args.runs if "--runs" in sys.argv else 10
        cases = DEFAULTS_CASES
        if args.defaults_cases:
            cases = tuple(c for c in DEFAULTS_CASES if c[0] in args.defaults_cases)
        print(f"identify(t, u, y) with every default, {runs} seeds per case")
        defaults_table(runs, cases, args.n_jobs)
        return
    free = args.order == "none"
    if args.quick:
        args.runs, args.snr = 5, [20.0]
    hdr = (
        f"{'case':23s} {'method':16s} {'SNR':>5s} {'bias %':>8s} {'std %':>8s} "
        f"{'median %':>9s} {'<=5 %':>6s} {'failed':>6s} {'time ms':>9s}"
        + ("  chosen orders" if free else "")
    )
    print(f"{args.runs} seeds per row; eigenvalue errors relative to |lambda|")
    if free:
        print("order=None: errors over the runs that chose the true order")
    for case_name in args.cases:
        print(f"\n{case_name}: {DESCRIPTIONS[case_name]}")
        opts = make_case(case_name, 0, 20.0).options
        if opts:
            print(f"case options (passed to the methods that accept them): {opts}")
        print(hdr)
        discrete = make_case(case_name, 0, 20.0).discrete
        methods = ["dt"] if discrete else args.methods
        snrs = [None] if case_name == "pbsid-mimo" else args.snr
        for snr in snrs:
            for label in methods:
                r = monte_carlo(label, case_name, snr, args.runs, free)
                snr_txt = "own" if snr is None else f"{snr:5.0f}"
                chosen = ", ".join(f"{n}: {c}x" for n, c in sorted(r["orders"].items()))
                print(
                    f"{case_name:23s} {label:16s} {snr_txt:>5s} {100 * r['bias']:8.3f} "
                    f"{100 * r['std']:8.3f} {100 * r['median']:9.3f} "
                    f"{100 * r['within']:5.0f}% {r['failed']:6d} {1e3 * r['time']:9.1f}"
                    + (f"  {chosen}" if free else ""),
                    flush=True,
                )
    if not args.no_fit_time:
        fit_time()


if __name__ == "__main__":
    main()
