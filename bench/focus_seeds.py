"""The refinement's focus on the measured-like records, over seeds.

Run: ``python bench/focus_seeds.py [--seeds 0 1 2 3] [--records NAME ...]``; writes
``bench/results/focus_seeds.md``.

The measured-like records of ``bench/measured_like.py`` (a direct path with drift and
coloured noise, a nonlinear level loop, a long record of a resonance with a cubic spring,
a stiff plant behind a clipping actuator), each drawn with every seed, split and scored as
``bench/realdata.py`` scores them (estimation on the first two thirds, simulation fit on
the last third from a least-squares initial state).  Per record and seed it runs
``identify(t, u, y)`` with the default focus (``"auto"``, chosen from the record), with
``focus="prediction"`` and with ``focus="simulation"``, and prints the three validation
fits, the order and the default's :class:`~hdpbsid.selection.focus.FocusRule`.  Seed 0 is
the record of ``bench/realdata.py``; the others are records the rule was not written on.
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


def run(name: str, seed: int) -> dict[str, object]:
    """The validation fits of the three focuses on record ``name`` drawn with ``seed``,
    the default's order and focus rule, and the default's CPU seconds."""
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
    return row


def table(rows: list[dict[str, object]]) -> str:
    """The markdown table of :func:`run`'s rows."""
    head = "| record | seed | n | " + " | ".join(FOCUS) + " | default's rule | CPU s |"
    lines = [head, "|---|---:|---:|" + "---:|" * len(FOCUS) + "---|---:|"]
    for r in rows:
        fits = " | ".join(f"{r[k]:.1f}" for k in FOCUS)
        lines.append(
            f"| {r['record']} | {r['seed']} | {r['n']} | {fits} | {r['rule']} | {r['cpu']:.2f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    names = list(measured_like.GENERATORS)
    ap.add_argument("--records", nargs="+", default=names, choices=names)
    ap.add_argument("--md", type=Path, default=RESULTS, help="markdown file ('' for none)")
    args = ap.parse_args(argv)
    rows = []
    for name in args.records:
        for seed in args.seeds:
            rows.append(run(name, seed))
            print(table(rows[-1:]).splitlines()[-1], flush=True)
    command = "python bench/focus_seeds.py " + " ".join(sys.argv[1:] if argv is None else argv)
    text = (
        f"Produced by `{command.strip()}` ({peers.machine_line()}). Validation fit in "
        "percent on the last third of each record (`bench/realdata.py`'s scoring), "
        "identified on the first two thirds with the default focus, the prediction focus "
        "and the simulation focus; seed 0 is the record of the measured-records table.\n\n"
        + table(rows)
        + "\n"
    )
    print(text)
    if str(args.md):
        args.md.write_text(text)


if __name__ == "__main__":
    np.seterr(all="ignore")
    main()
