"""The refinement's focus on the measured-like records, over seeds.

Run: ``python bench/focus_seeds.py [--seeds 0 1 2 3] [--records NAME ...] [--peers KEY
...] [--tune-on validation estimation]``; writes ``bench/results/focus_seeds.md``.

The measured-like records of ``bench/measured_like.py`` (a direct path with drift and
coloured noise, a nonlinear level loop, a long record of a resonance with a cubic spring,
a stiff plant behind a clipping actuator), each drawn with every seed, split and scored as
``bench/realdata.py`` scores them (estimation on the first two thirds, simulation fit on
the last third from a least-squares initial state).  Per record and seed it runs
``identify(t, u, y)`` with the default focus (``"auto"``, chosen from the record), with
``focus="prediction"`` and with ``focus="simulation"``, and prints the three validation
fits, the order and the default's :class:`~hdpbsid.selection.focus.FocusRule`.  Seed 0 is
the record of ``bench/realdata.py``; the others are records the rule was not written on.
With ``--peers`` (keys of ``bench/peers.py`` / ``bench/more_peers.py``) a column gives the
best of those tools on the same split with their order and setting tuned on the
validation third, as ``bench/realdata.py`` tunes them (on records over its
``LONG_RECORD`` samples, the default setting only and its slow peers skipped).  With
``--tune-on estimation`` a column gives the same tools tuned as a user without the
validation data can tune them: on the last third of the estimation part, estimated on
the rest, then refitted on the whole estimation part and scored on validation.
Not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import measured_like  # noqa: E402
import peers  # noqa: E402
import realdata  # noqa: E402

import hdpbsid  # noqa: E402

RESULTS = HERE / "results" / "focus_seeds.md"
#: the calls compared: label -> identify's focus
FOCUS = {"default (auto)": "auto", "prediction": "prediction", "simulation": "simulation"}
#: where :func:`best_peer` may tune the peers' order and setting
TUNE_ON = ("validation", "estimation")


def best_peer(split: realdata.Split, keys: list[str], tune_on: str = "validation") -> str:
    """The validation fit of the best of the tools ``keys`` on ``split``, each over the
    orders and settings of ``bench/realdata.py``, with the tool, order and setting.

    ``tune_on="validation"`` picks the setting by its validation fit (the answer, as
    ``bench/realdata.py`` tunes the peers); ``"estimation"`` picks it as a user without
    the validation data can: by its fit on the last third of the estimation part when
    estimated on the rest (the same split applied to the estimation part), then refits
    that setting on the whole estimation part and scores it on validation."""
    if tune_on not in TUNE_ON:
        raise ValueError(f"tune_on must be one of {TUNE_ON}, got {tune_on!r}")
    est = split.estimation
    judge = split if tune_on == "validation" else realdata.split_record(est.u, est.y, split.dt)
    long = est.t.size > realdata.LONG_RECORD
    best = None
    for key in keys:
        if long and key in realdata.SLOW_PEERS:
            continue
        for order in realdata.ORDERS:
            hs = realdata.peer_horizons(key, est.y.shape[1], order)
            for h in hs[:1] if long else hs:
                r = realdata._peer(key, judge, h, order)
                if r.status == "ok" and (best is None or r.fit > best.fit):
                    best = r
    if best is None:
        return "-"
    if tune_on == "estimation":
        best = realdata._peer(best.method, split, best.horizon, best.order_requested)
        if best.status != "ok":
            return f"- ({best.method}: {best.status})"
    return f"{best.fit:.1f} ({best.method}, n={best.order_requested}, h={best.horizon})"


def run(
    name: str,
    seed: int,
    peer_keys: list[str] | None = None,
    tune_on: tuple[str, ...] = ("validation",),
) -> dict[str, object]:
    """The validation fits of the three focuses on record ``name`` drawn with ``seed``,
    the default's order and focus rule, and the default's CPU seconds; with
    ``peer_keys`` the best of those tools tuned on each part of ``tune_on``
    (:func:`best_peer`)."""
    s = measured_like.GENERATORS[name](seed)
    split = realdata.split_record(s.u, s.y, s.dt)
    est = split.estimation
    row: dict[str, object] = {"record": name, "seed": seed}
    for label, focus in FOCUS.items():
        t0 = time.process_time()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = hdpbsid.identify(est.t, est.u, est.y, focus=focus)
        row[label] = realdata.validation_fit(peers.Identified(m.A, m.B, m.C, m.D, None), split)
        if focus == "auto":
            row["cpu"] = time.process_time() - t0
            row["n"] = m.n
            choice = m.report.focus
            row["rule"] = "no refined model" if choice is None else choice.rule.value
    for where in tune_on if peer_keys else ():
        row[f"peer:{where}"] = best_peer(split, peer_keys, where)
    return row


def table(rows: list[dict[str, object]]) -> str:
    """The markdown table of :func:`run`'s rows."""
    tuned = [k for k in rows[0] if k.startswith("peer:")]
    head = "| record | seed | n | " + " | ".join(FOCUS) + " | default's rule | CPU s |"
    head += "".join(f" best peer tuned on {k.removeprefix('peer:')} |" for k in tuned)
    rule = "|---|---:|---:|" + "---:|" * len(FOCUS) + "---|---:|" + "---|" * len(tuned)
    lines = [head, rule]
    for r in rows:
        fits = " | ".join(f"{r[k]:.1f}" for k in FOCUS)
        line = f"| {r['record']} | {r['seed']} | {r['n']} | {fits} | {r['rule']} | {r['cpu']:.2f} |"
        lines.append(line + "".join(f" {r[k]} |" for k in tuned))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    names = list(measured_like.GENERATORS)
    ap.add_argument("--records", nargs="+", default=names, choices=names)
    ap.add_argument("--md", type=Path, default=RESULTS, help="markdown file ('' for none)")
    ap.add_argument("--peers", nargs="*", default=[], help="peer keys for the tuned column")
    ap.add_argument(
        "--tune-on",
        nargs="+",
        default=["validation"],
        choices=TUNE_ON,
        help="where the peers' order and setting are tuned (one column each)",
    )
    args = ap.parse_args(argv)
    rows = []
    for name in args.records:
        for seed in args.seeds:
            rows.append(run(name, seed, args.peers, tuple(args.tune_on)))
            print(table(rows[-1:]).splitlines()[-1], flush=True)
    command = "python bench/focus_seeds.py " + " ".join(sys.argv[1:] if argv is None else argv)
    text = (
        f"Produced by `{command.strip()}` ({peers.machine_line()}). Validation fit in "
        "percent on the last third of each record (`bench/realdata.py`'s scoring), "
        "identified on the first two thirds with the default focus, the prediction focus "
        "and the simulation focus; seed 0 is the record of the measured-records table"
        + (
            "; the best tuned peer: the best of the tools listed, order and setting "
            "tuned on the validation third (the answer) or, as a user without it can, on "
            "the last third of the estimation part, then refitted on the whole estimation "
            "part"
            if args.peers
            else ""
        )
        + ".\n\n"
        + table(rows)
        + "\n"
    )
    print(text)
    if str(args.md):
        args.md.write_text(text)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
