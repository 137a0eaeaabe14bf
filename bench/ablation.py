"""Ablation of the pipeline's decision rules: what each one is worth on the regression table.

Run: ``python bench/ablation.py [--rules NAME ...] [--n-jobs N] [--subset PATTERN ...]
[--full] [--base bench/results/regression.csv] [--out bench/results/ablation.md]
[--csv-dir bench/results/ablation] [--report-only] [--list]``.

How it is measured.  Every rule of :data:`RULES` is a secondary decision of the default
pipeline of ``hdpbsid.identify(t, u, y)`` -- a re-judgement, a check, a fallback, a
tie-break or a starting point beside the principled criterion (the held-out prediction
error with its standard error, the one-standard-error rule, the prediction-error
criterion of the refinement).  For one rule at a time, the rule is *switched off*: the
function that takes it (or the policy method, or the setting) is replaced, for the
duration of the run and inside this process only, by the principled baseline -- the
check passes, the fallback is empty, the re-judgement keeps the one-standard-error
rule's order, the tie is broken by the held-out windowed error, the extra starting point
is not offered (:func:`switched_off`; the library is not edited).  Then every record of
the table is identified as ``bench/regression.py`` identifies it (its
:func:`regression.run_record`: the same records, the same scores, caches emptied before
each call) and the rows are compared with the baseline table of the unchanged library
(``--base``) by :func:`regression.compare_tables`: a row is *worse* or *better* when the
true order is lost or found, the eigenvalue error or the validation misfit moves beyond
the margin of :func:`regression.beyond_margin`, a failure or the stability of a stable
truth changes; *changed* when only the method or the order changed.  The totals (true
orders found, median and 90th percentile of the eigenvalue error, median misfit) are
those of :func:`regression.compare_tables`, over the rows scored in both tables.

The verdict per rule (:func:`verdict`): *earns its place* when switching it off makes a
row worse (also when other rows get better: the rule is then a trade, kept); *hurts* when
switching it off only makes rows better; *neutral* when rows change (method or order)
but none beyond the margins; *no effect* when no row changes at all.  A rule that is
neutral or has no effect on the subset may still act on records outside it: ``--full``
runs all rows of the table.

The default records are the guard subset of ``bench/regression.py`` (``--subset
'*/*/0' 'random/0[0-2]?' 'daisy/*'``, 60 records, a few minutes per rule on one core);
each rule's rows are written to ``--csv-dir`` (``RULE.csv``, the columns of
``bench/regression.py``) and the report (``--out``, markdown) is rebuilt from every
rule's CSV found there after each rule, so that runs of separate rules can be combined
(``--report-only`` only rebuilds it).  Not a test: nothing is asserted here.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH))

import regression  # noqa: E402

#: the guard subset of ``bench/regression.py`` (HELPERS: the behaviour guard)
DEFAULT_SUBSET = ("*/*/0", "random/0[0-2]?", "daisy/*")

#: ``(owner, attribute, replacement)``: one monkeypatch of a switch
Patch = tuple[Any, str, Any]


@dataclass(frozen=True)
class Rule:
    """A decision rule of the default pipeline and how it is switched off.

    ``patches()`` imports the library and returns the monkeypatches that switch the rule
    off (applied by :func:`switched_off`, undone after the run).  ``removed``: the rule
    has since been removed from the library on the ablation's evidence; its switch is
    then a no-op and its measured rows stay in the report."""

    name: str
    area: str
    does: str
    off: str
    patches: Callable[[], list[Patch]]
    removed: bool = False


# -- the switches ----------------------------------------------------------------------
def _front() -> Any:
    """The module ``hdpbsid.identify`` (the package's ``identify`` is the function)."""
    return importlib.import_module("hdpbsid.identify")


def _tie_break() -> list[Patch]:
    from hdpbsid.selection import order_rule

    def by_windowed_error(tied: list[Any], val: tuple) -> list[Any]:
        return sorted(tied, key=lambda r: r.criterion.total)

    return [(order_rule, "break_tie", by_windowed_error)]


def _rejudge_down() -> list[Patch]:
    from hdpbsid.selection import auto

    original = auto.rejudge_order

    def without_smaller_orders(ok, order, est, val, windows, n_jobs=None):  # noqa: ANN001, ANN202
        # only the chosen order and the larger ones: the *down* step has nothing to refine
        n_star = ok[order.index].order
        keep = [i for i, r in enumerate(ok) if r.order >= n_star]
        sub = [ok[i] for i in keep]
        within = type(order)(keep.index(order.index), tuple(order.stats[i] for i in keep))
        again = original(sub, within, est, val, windows, n_jobs)
        k = keep[again.index]
        return type(order)(
            k, order.stats, again.reason if k != order.index else order.reason, again.rule
        )

    return [(auto, "rejudge_order", without_smaller_orders)]


def _rejudge_up() -> list[Patch]:
    from hdpbsid.selection import rejudge

    return [(rejudge, "looks_closed_loop", lambda model, rec: False)]


def _floor_mean() -> list[Patch]:
    from hdpbsid.selection import refits

    return [(refits, "beats_the_mean", lambda model, val: (True, ""))]


def _floor_instability() -> list[Patch]:
    from hdpbsid.selection import refits

    original = refits.instability_problem

    def inputs_unchecked(row: Any, pool: Any) -> str:
        # a time series keeps its stationarity check (not a rule of this ablation)
        return original(row, pool) if row.model.m == 0 else ""

    return [(refits, "instability_problem", inputs_unchecked)]


def _refit_growth() -> list[Patch]:
    from hdpbsid.selection import refits

    return [(refits, "_new_growth", lambda model, candidate: "")]


def _refit_holds() -> list[Patch]:
    from hdpbsid.selection import refits

    original = refits.refit_holds

    def finite_holds(model: Any, held_out: Any, val: tuple, windows: int) -> tuple[bool, str]:
        holds, how = original(model, held_out, val, windows)
        return (holds, how) if "cannot be simulated" in how else (True, "")

    return [(refits, "refit_holds", finite_holds)]


def _stand_ins() -> list[Patch]:
    from hdpbsid.selection import refits

    return [(refits, "_stand_ins", lambda pool, queue, row, val: [])]


def _settle() -> list[Patch]:
    from hdpbsid.selection import refits

    def unsettled(get_method, row, est, val, windows, options):  # noqa: ANN001, ANN202
        return row

    return [(refits, "settle_candidate", unsettled)]


def _refit_keeps() -> list[Patch]:
    from hdpbsid.selection import refits

    return [(refits, "refit_keeps", lambda func, model, given: {})]


def _warm_start() -> list[Patch]:
    from hdpbsid.selection import refits

    original = refits._accept_refit

    def without_warm_start(model: Any, chosen: Any, kept: Any) -> None:
        warm, chosen.refined_model = chosen.refined_model, None
        try:
            original(model, chosen, kept)
        finally:
            chosen.refined_model = warm

    return [(refits, "_accept_refit", without_warm_start)]


def _closed_loop_start() -> list[Patch]:
    from hdpbsid.selection import feedback

    return [(feedback, "closed_loop_start", lambda model, t, u, y, statistics: model)]


def _diverging_start() -> list[Patch]:
    from hdpbsid.selection import feedback

    front = _front()

    def without_dt_rescue(model, t, u, y, uniform, errors=None):  # noqa: ANN001, ANN202
        do, rule, stats = feedback.refine_decision(model, t, u, y, uniform, errors=errors)
        start = feedback.closed_loop_start(model, t, u, y, stats) if do else model
        return do, rule, stats, start

    return [(front, "refine_plan", without_dt_rescue)]


def _refinement_instability() -> list[Patch]:
    front = _front()

    return [(front, "_refinement_problem", lambda start, refined, t, u, y: "")]


def _unconverged() -> list[Patch]:
    front = _front()

    original = front.refine_pem

    def converged_anyway(*args: Any, **kwargs: Any) -> Any:
        model = original(*args, **kwargs)
        ref = model.report.refinement
        if ref is not None and not ref.converged:
            model.report = model.report.but(refinement=replace(ref, converged=True))
        return model

    return [(front, "refine_pem", converged_anyway)]


def _other_hold() -> list[Patch]:
    from hdpbsid.refine import pem

    original = pem._candidate_holds
    return [(pem, "_candidate_holds", lambda model, hold: original(model, hold)[:1])]


def _oe_start() -> list[Patch]:
    from hdpbsid.refine import pem

    def no_gain(*args: Any) -> Any:
        raise pem.np.linalg.LinAlgError("switched off by bench/ablation.py")

    return [(pem, "_kalman_gain", no_gain)]


def _start_screen() -> list[Patch]:
    from hdpbsid.refine import pem

    original = pem._fit_starts

    def every_start(starts, lay, residuals, kw, budget, n_r, settings=pem.DEFAULT_SETTINGS):  # noqa: ANN001, ANN202
        # an evidence of -inf: every start's prediction passes the screen
        loose = replace(settings, evidence=-float("inf"))
        return original(starts, lay, residuals, kw, budget, n_r, loose)

    return [(pem, "_fit_starts", every_start)]


def _alpha_modes() -> list[Patch]:
    from hdpbsid.bases import operator_scale as osc

    def basis_rule(self, unchecked, alpha0, fit, ev):  # noqa: ANN001, ANN202
        refit = None if ev.held_out is None else {"alpha": "basis"}
        text = "4 * scale (median over blocks); the modes' rule switched off (ablation)"
        decision = osc.AlphaDecision(alpha0, osc.AlphaRule.BASIS, text, None, (), refit)
        return decision, fit(alpha0)

    return [(osc.OperatorScalePolicy, "_from_modes", basis_rule)]


def _alpha_proof() -> list[Patch]:
    from hdpbsid.bases import operator_scale as osc

    def unproved(self, old, new, modes, evidence):  # noqa: ANN001, ANN202
        check = osc.AlphaCheck(True, osc.CheckReason.SKIPPED, "not checked (ablation)")
        return (check,), "held-out part"

    return [(osc.OperatorScalePolicy, "prove", unproved)]


def _alpha_screen() -> list[Patch]:
    from hdpbsid.bases import operator_scale as osc

    def no_screen(self, old, new, record, alphas):  # noqa: ANN001, ANN202
        return osc.AlphaCheck(True, osc.CheckReason.SKIPPED, "screen skipped (ablation)")

    return [(osc.OperatorScalePolicy, "in_sample_screen", no_screen)]


_SEL, _REF, _OSC = "selection", "refinement", "operator scale"

#: the rules measured, in report order
RULES: dict[str, Rule] = {
    r.name: r
    for r in (
        Rule(
            "tie_break", _SEL,
            "among tied candidates of the chosen order, the best whole-held-out simulation first",
            "tied candidates ranked by their held-out windowed error", _tie_break,
        ),
        Rule(
            "rejudge_down", _SEL,
            "refined: a smaller order replaces the chosen one when, refined, it predicts better",
            "no smaller order is refined; the one-SE rule's order stands", _rejudge_down,
        ),
        Rule(
            "rejudge_up", _SEL,
            "closed loop, refit worse than its subspace estimate: larger orders refined",
            "the feedback test of the step says open loop: no larger order", _rejudge_up,
        ),
        Rule(
            "floor_mean", _SEL,
            "a candidate or refit must predict the whole held-out part better than its mean",
            "beats_the_mean always passes", _floor_mean, removed=True,
        ),
        Rule(
            "floor_instability", _SEL,
            "an unstable candidate is rejected when a stable one no larger predicts as well",
            "instability_problem passes every model with inputs", _floor_instability,
        ),
        Rule(
            "refit_growth", _SEL,
            "a refit with a growing mode its candidate did not have is rejected",
            "_new_growth finds none", _refit_growth,
        ),
        Rule(
            "refit_holds", _SEL,
            "a refit on the whole record must score within one SE of its candidate",
            "every refit that can be simulated holds", _refit_holds,
        ),
        Rule(
            "stand_ins", _SEL,
            "no refit holds: refits of not-much-worse candidates outside the ranking tried",
            "no stand-in: the candidate's own model is returned", _stand_ins,
        ),
        Rule(
            "settle", _SEL,
            "the chosen candidate's held-out-judged settings (alpha) settled on held-out data",
            "the candidate keeps its first-pass fit and settings", _settle,
        ),
        Rule(
            "refit_keeps", _SEL,
            "the refit keeps the candidate's data-driven settings (dt: its windows)",
            "the refit chooses them again on the whole record", _refit_keeps,
        ),
        Rule(
            "warm_start", _REF,
            "the candidate refined on the estimation part is the refinement's warm start",
            "no warm start from the selection", _warm_start,
        ),
        Rule(
            "closed_loop_start", _REF,
            "feedback found: the dt model is offered as a further starting point",
            "closed_loop_start returns the model", _closed_loop_start,
        ),
        Rule(
            "diverging_start", _REF,
            "first-pass predictor diverges: the dt model, if it shows feedback, is refined",
            "no refinement when the predictor diverges", _diverging_start,
        ),
        Rule(
            "refinement_instability", _REF,
            "a refinement that grows a mode the record does not need is not kept",
            "every converged refinement is kept", _refinement_instability,
        ),
        Rule(
            "unconverged_kept", _REF,
            "a refinement cut off by its budget is not kept: the unrefined model is",
            "the last iterate is kept", _unconverged,
        ),
        Rule(
            "other_hold", _REF,
            "the refinement screens and fits the other input hold, switching on evidence",
            "only the first pass's hold is fitted", _other_hold,
        ),
        Rule(
            "oe_start", _REF,
            "a second start: the Kalman gain of a measurement-noise model",
            "only the model's own K (and a warm start)", _oe_start,
        ),
        Rule(
            "start_screen", _REF,
            "a later start is fitted only if one Gauss-Newton step predicts a lower cost",
            "every start is fitted", _start_screen,
        ),
        Rule(
            "alpha_modes", _OSC,
            "Hermite alpha from the identified modes (minimax contraction), checked",
            "alpha = 4 * scale, the basis rule (HD-PBSID as published)", _alpha_modes,
        ),
        Rule(
            "alpha_proof", _OSC,
            "a change of alpha from the basis rule must win on held-out data",
            "the modes' alpha is taken unchecked (alpha='dynamics')", _alpha_proof,
        ),
        Rule(
            "alpha_screen", _OSC,
            "before the held-out check, an in-sample screen of the change",
            "the screen passes; the held-out check alone decides", _alpha_screen,
        ),
    )
}  # fmt: skip


#: calls of the switched functions in this process since the last :func:`run_one`
_CALLS = [0]


def _counted(new: Any) -> Any:
    """``new`` counting its calls in :data:`_CALLS` (a plain function, so that a method
    replaced on a class still binds ``self``)."""
    if not callable(new):
        return new

    def counted(*args: Any, **kwargs: Any) -> Any:
        _CALLS[0] += 1
        return new(*args, **kwargs)

    return counted


@contextlib.contextmanager
def switched_off(rule: Rule | None) -> Iterator[None]:
    """Apply the patches of ``rule`` (none for ``None``: the unchanged library) for the
    duration of the block, each replacement counting its calls (:data:`_CALLS`), and
    undo them, in reverse order, after it."""
    saved: list[Patch] = []
    try:
        for owner, attr, new in [] if rule is None or rule.removed else rule.patches():
            old = owner.__dict__[attr] if isinstance(owner, type) else getattr(owner, attr)
            saved.append((owner, attr, old))
            setattr(owner, attr, _counted(new))
        yield
    finally:
        for owner, attr, old in reversed(saved):
            setattr(owner, attr, old)


def run_one(rule_name: str | None, spec: regression.RecordSpec) -> tuple[dict[str, Any], int]:
    """One row of the table (:func:`regression.run_record`) with rule ``rule_name``
    switched off (``None``: the unchanged library), and how often the switch was reached
    (calls of the replacements; the untimed warm-up call of a fresh process is made
    before the switch, with the library unchanged)."""
    regression._warm_up()
    _CALLS[0] = 0
    with switched_off(None if rule_name is None else RULES[rule_name]):
        row = regression.run_record(spec)
    return row, _CALLS[0]


def run_rule(
    rule_name: str | None, specs: Sequence[regression.RecordSpec], n_jobs: int = 1
) -> tuple[list[dict[str, Any]], dict[str, int]]:
    """Every row of ``specs`` with the rule switched off, in the order of ``specs``, and
    the calls of the switch per record; ``n_jobs > 1`` runs records in parallel (joblib,
    each worker patching itself)."""
    if n_jobs > 1:
        from joblib import Parallel, delayed

        # the workers import this script's modules by name
        paths = [str(BENCH), os.environ.get("PYTHONPATH", "")]
        os.environ["PYTHONPATH"] = os.pathsep.join(p for p in paths if p)
        out = Parallel(n_jobs=n_jobs)(delayed(run_one)(rule_name, s) for s in specs)
    else:
        out = [run_one(rule_name, s) for s in specs]
    rows = [{k: ("" if v is None else str(v)) for k, v in r.items()} for r, _ in out]
    return rows, {r["id"]: n for r, n in zip(rows, (n for _, n in out), strict=True)}


# -- comparison and report ---------------------------------------------------------------
@dataclass(frozen=True)
class Outcome:
    """The comparison of one rule's table with the baseline."""

    rule: str
    changes: list[tuple[str, str, list[str]]]
    totals: dict[str, tuple[float, float, str]]
    rows: int
    #: records on which the switch was reached (None: not recorded)
    reached: int | None = None
    #: CPU seconds of the identification calls, summed over the rows
    cpu: float = 0.0

    def count(self, verdict: str) -> int:
        """Rows with that verdict of :func:`regression.compare_rows`."""
        return sum(c[1] == verdict for c in self.changes)


def compare(
    rule: str,
    base: Sequence[dict[str, Any]],
    rows: Sequence[dict[str, Any]],
    calls: dict[str, int] | None = None,
) -> Outcome:
    """``rows`` (one rule switched off) against the ``base`` table, on their common ids;
    ``calls``: the switch's calls per record (:func:`run_rule`)."""
    ids = {r["id"] for r in rows}
    base = [r for r in base if r["id"] in ids]
    changes, tot, _ = regression.compare_tables(base, rows)
    reached = None if calls is None else sum(n > 0 for i, n in calls.items() if i in ids)
    cpu = sum(x for x in (regression._num(r["cpu_s"]) for r in rows) if x == x)
    return Outcome(rule, changes, tot, len(base), reached, cpu)


def verdict(outcome: Outcome) -> str:
    """The rule's verdict (module docstring) from the rows its switch-off changed, marked
    when the rule has since been removed."""
    mark = " (removed)" if outcome.rule in RULES and RULES[outcome.rule].removed else ""
    if outcome.count("worse") or outcome.count("mixed"):
        return "earns its place" + mark
    if outcome.count("better"):
        return "hurts" + mark
    if outcome.count("changed"):
        return "neutral" + mark
    return "no effect" + mark


def _delta(tot: dict[str, tuple[float, float, str]], key: str, fmt: str) -> str:
    a, b, mark = tot[key]
    return f"{regression._f(a, fmt)} -> {regression._f(b, fmt)}" + (
        " (worse)" if mark == "WORSE" else ""
    )


def report(outcomes: Sequence[Outcome], header: str, notes: str = "") -> str:
    """The markdown report: one row per rule, the ``notes`` (markdown, written by hand),
    then each rule's changed rows."""
    lines = [
        header,
        "",
        "| rule | area | what it does | switched off | reached | worse | mixed | better "
        "| changed | true order | err % median | err % p90 | misfit % median | CPU s "
        "| verdict |",
        "|---|---|---|---|---:|---:|---:|---:|---:|---|---|---|---|---:|---|",
    ]
    for o in outcomes:
        r = RULES.get(o.rule, _UNCHANGED)
        t = o.totals
        found = f"{t['found'][0]:.0f} -> {t['found'][1]:.0f}"
        lines.append(
            f"| `{r.name}` | {r.area} | {r.does} | {r.off} | "
            f"{'?' if o.reached is None else o.reached}/{o.rows} | {o.count('worse')} | "
            f"{o.count('mixed')} | {o.count('better')} | {o.count('changed')} | {found} | "
            f"{_delta(t, 'err_median', '.3g')} | {_delta(t, 'err_p90', '.3g')} | "
            f"{_delta(t, 'misfit_median', '.3g')} | {o.cpu:.0f} | {verdict(o)} |"
        )
    lines += ["", "## The rows each switch-off changed", ""]
    if notes:
        lines[-3:-3] = ["", notes.strip()]
    order = {"worse": 0, "mixed": 1, "better": 2, "changed": 3}
    for o in outcomes:
        lines.append(f"### `{o.rule}` ({o.rows} rows; {verdict(o)})")
        lines.append("")
        if not o.changes:
            lines.append("no row changed")
        for i, v, reasons in sorted(o.changes, key=lambda c: (order[c[1]], c[0])):
            lines.append(f"* {v} `{i}`: {'; '.join(reasons)}")
        lines.append("")
    return "\n".join(lines)


def collect(csv_dir: Path, base: Sequence[dict[str, Any]]) -> list[Outcome]:
    """The outcome of every rule of :data:`RULES` whose CSV is in ``csv_dir``."""
    out = []
    for name in ["none", *RULES]:
        path = csv_dir / f"{name}.csv"
        if path.is_file():
            calls = path.with_suffix(".json")
            reached = json.loads(calls.read_text())["calls"] if calls.is_file() else None
            out.append(compare(name, base, regression.read_csv(path), reached))
    return out


#: the row of the unchanged library (``--check-baseline``): the comparison's noise floor
_UNCHANGED = Rule("none", "-", "the unchanged library against the baseline table", "-", list)


def _header(csv_dir: Path, base: Path) -> str:
    runs = sorted(
        {
            f"`{m['command']}`"
            for m in (json.loads(p.read_text()) for p in sorted(csv_dir.glob("*.json")))
            if "command" in m
        }
    )
    date = datetime.now(timezone.utc).isoformat(timespec="minutes")
    return (
        "# Ablation of the decision rules\n\n"
        f"Rows of {', '.join(runs) or csv_dir}; report of {date}; baseline "
        f"`{base.name}`.  How it is measured: "
        "the docstring of `bench/ablation.py` (each rule switched off alone; rows worse / "
        "better by the margins of `bench/regression.py`; totals over the rows scored in "
        "both tables).  Verdicts: *earns its place* (switching it off makes a row worse), "
        "*hurts* (switching it off only improves rows), *neutral* (rows change within the "
        "margins), *no effect* (no row changes).  *reached*: records on which the switched "
        "replacement was called at least once (a wrapper replacing the function that takes the "
        "rule counts every call of it).  *CPU s*: the identification calls' CPU seconds "
        "summed over the rows (shared cores: compare with the row `none`, the unchanged "
        "library run in the same session, and read differences below about 10 % as noise)."
    )


def _report(csv_dir: Path, base_path: Path, base: Sequence[dict[str, Any]]) -> str:
    """The report of every rule measured in ``csv_dir``, with its ``notes.md`` if any."""
    notes = csv_dir / "notes.md"
    text = notes.read_text() if notes.is_file() else ""
    return report(collect(csv_dir, base), _header(csv_dir, base_path), text) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rules", nargs="+", choices=sorted(RULES), help="default: every rule")
    ap.add_argument("--n-jobs", type=int, default=1, help="records in parallel (joblib)")
    ap.add_argument("--subset", nargs="+", default=list(DEFAULT_SUBSET))
    ap.add_argument("--full", action="store_true", help="every record of the table")
    ap.add_argument("--base", type=Path, default=BENCH / "results" / "regression.csv")
    ap.add_argument("--out", type=Path, default=BENCH / "results" / "ablation.md")
    ap.add_argument("--csv-dir", type=Path, default=BENCH / "results" / "ablation")
    ap.add_argument("--report-only", action="store_true", help="rebuild --out from --csv-dir")
    ap.add_argument("--list", action="store_true", help="list the rules and exit")
    ap.add_argument(
        "--check-baseline",
        action="store_true",
        help="first run the unchanged library (rule 'none'): the comparison's noise floor",
    )
    args = ap.parse_args(argv)
    if args.list:
        for r in RULES.values():
            print(f"{r.name:24s} {r.area:15s} {r.does}")
        return 0
    if args.n_jobs < 1:
        raise SystemExit(f"--n-jobs must be >= 1, got {args.n_jobs}")
    base = regression.read_csv(args.base)
    command = "python bench/ablation.py " + " ".join(sys.argv[1:] if argv is None else argv)
    specs = regression.select(regression.record_specs(), None if args.full else args.subset)
    names: list[str | None] = [] if args.report_only else list(args.rules or RULES)
    if args.check_baseline and not args.report_only:
        names.insert(0, None)
    args.csv_dir.mkdir(parents=True, exist_ok=True)
    for rule in names:
        name = rule or "none"
        w0 = time.perf_counter()
        rows, calls = run_rule(rule, specs, args.n_jobs)
        regression.write_csv(rows, args.csv_dir / f"{name}.csv")
        meta = {"command": command, "commit": regression._git("rev-parse", "--short", "HEAD")}
        (args.csv_dir / f"{name}.json").write_text(json.dumps({**meta, "calls": calls}) + "\n")
        o = compare(name, base, rows, calls)
        print(
            f"{name}: {len(rows)} rows in {time.perf_counter() - w0:.0f} s, reached on "
            f"{o.reached}; worse "
            f"{o.count('worse')}, mixed {o.count('mixed')}, better {o.count('better')}, "
            f"changed {o.count('changed')}: {verdict(o)}",
            flush=True,
        )
        args.out.write_text(_report(args.csv_dir, args.base, base))
    if args.report_only:
        args.out.write_text(_report(args.csv_dir, args.base, base))
    return 0


if __name__ == "__main__":
    sys.exit(main())
