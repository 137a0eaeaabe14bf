"""The Laguerre method on a stiff open-loop record, with the order given.

Run: ``python bench/stiff_laguerre.py [--seeds 10] [--snr 40 20]``;
writes ``bench/results/stiff_laguerre.md``.

The record is the ``stiff`` case of ``bench/cases.py`` (a real pole at ``-80`` and a
lightly damped pair, excited by steps held 0.05 s, so the data bandwidth sits near the
fast pole), at each SNR and seed.  Per record it runs ``identify(t, u, y, order=3,
method="laguerre")`` with the default pole (``a=None``), with the bandwidth pole alone
(``a="bandwidth"``, the former default) and with ``a="dynamics"``, and prints the worst
relative eigenvalue error per seed, how many are within 5 %, the CPU seconds per fit and
where the pole came from (``model.options["a_source"]``; ``bandwidth`` when the first
pass was kept).  Not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from cases import make_case  # noqa: E402

import hdpbsid  # noqa: E402
from hdpbsid.models.metrics import eigenvalue_errors  # noqa: E402

RESULTS = HERE / "results" / "stiff_laguerre.md"
#: the calls compared: label -> the pole argument
POLES = {"a=None (default)": None, 'a="bandwidth"': "bandwidth", 'a="dynamics"': "dynamics"}


def run(seeds: int, snr: float, a: str | None) -> tuple[list[float], list[float], list[str]]:
    """Worst relative eigenvalue error (percent), CPU seconds and pole source per seed."""
    errs, cpu, source = [], [], []
    for seed in range(seeds):
        case = make_case("stiff", seed, snr)
        rec, truth = case.estimation, np.asarray(case.true_eigenvalues)
        c0 = time.process_time()
        model = hdpbsid.identify(rec.t, rec.u, rec.y, order=truth.size, method="laguerre", a=a)
        cpu.append(time.process_time() - c0)
        errs.append(100.0 * float(np.max(eigenvalue_errors(model.eigenvalues, truth))))
        source.append(str(model.options.get("a_source", "bandwidth")))
    return errs, cpu, source


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--snr", type=float, nargs="+", default=[40.0, 20.0])
    ap.add_argument("--out", type=Path, default=RESULTS)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    lines = [
        f"# Laguerre on a stiff record, order given ({args.seeds} seeds)",
        "",
        "`python bench/stiff_laguerre.py` (module docstring: the record and the calls).",
        f"CPU seconds per call (process time), load average {os.getloadavg()[0]:.1f} at the "
        "start on a shared 2-core machine.",
        "",
        "| SNR | call | worst eig. err % per seed | <= 5 % | median % | CPU s median | pole |",
        "|---:|---|---|---:|---:|---:|---|",
    ]
    for snr in args.snr:
        for label, a in POLES.items():
            errs, cpu, source = run(args.seeds, snr, a)
            kinds = ", ".join(f"{k} {source.count(k)}" for k in sorted(set(source)))
            lines.append(
                f"| {snr:g} dB | {label} | {' '.join(f'{e:.3g}' for e in errs)} | "
                f"{sum(e <= 5.0 for e in errs)}/{len(errs)} | {np.median(errs):.3g} | "
                f"{np.median(cpu):.2f} | {kinds} |"
            )
            print(lines[-1], flush=True)
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
