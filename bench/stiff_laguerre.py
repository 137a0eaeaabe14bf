"""The Laguerre method on a stiff open-loop record, with the order given.

Run: ``python bench/stiff_laguerre.py [--seeds 10] [--snr 40 20]``;
writes ``bench/results/stiff_laguerre.md``.

Two stiff plants, each excited by random steps held 0.05 s (so the data bandwidth sits
near the fast pole) and sampled every 0.01 s, with white output noise at each SNR and
seed (seeds 1, 2, ..., as ``bench/peers.py``): the ``stiff`` case of ``bench/cases.py``
(eigenvalues ``-50, -0.5 +- 2i``, 40 s), and ``stiff-80`` (a real pole at ``-80`` and
a lightly damped pair ``-0.3 +- 1.5i``, both visible in the output, 60 s).  Per record
it runs ``identify(t, u, y, order=3, method="laguerre")`` with the default pole
(``a=None``), with the bandwidth pole alone (``a="bandwidth"``, the former default) and
with ``a="dynamics"``, and prints the worst relative eigenvalue error per seed, how many
are within 5 %, the CPU seconds per fit and where the pole came from
(``model.options["a_source"]``; ``bandwidth`` when the first pass was kept).  Not a
test: nothing is asserted.
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
from hdpbsid.systems import add_noise, random_steps, simulate_zoh  # noqa: E402

RESULTS = HERE / "results" / "stiff_laguerre.md"
#: the first seed: that of ``bench/peers.py``, whose table has the peers on these records
EVAL_SEED0 = 1
#: the calls compared: label -> the pole argument
POLES = {"a=None (default)": None, 'a="bandwidth"': "bandwidth", 'a="dynamics"': "dynamics"}


#: ``stiff-80``: a real pole at -80 and the pair -0.3 +- 1.5i in parallel modal form
A80 = np.array([[-80.0, 0.0, 0.0], [0.0, -0.3, 1.5], [0.0, -1.5, -0.3]])
B80, C80 = np.array([[80.0], [0.0], [1.0]]), np.array([[1.0, 1.0, 0.0]])


def stiff80(seed: int, snr: float) -> tuple[np.ndarray, ...]:
    """``(t, u, y, true eigenvalues)`` of the ``stiff-80`` record of ``seed``."""
    rng = np.random.default_rng(seed)
    t = 0.01 * np.arange(6000)
    u = random_steps(rng, t, 0.05)
    y = simulate_zoh(A80, B80, C80, np.zeros((1, 1)), t, u)
    return t, u, add_noise(y, snr, rng)[0], np.linalg.eigvals(A80)


def record(name: str, seed: int, snr: float) -> tuple[np.ndarray, ...]:
    """``(t, u, y, true eigenvalues)`` of record ``name`` (``stiff`` or ``stiff-80``)."""
    if name == "stiff-80":
        return stiff80(seed, snr)
    case = make_case(name, seed, snr)
    rec = case.estimation
    return rec.t, rec.u, rec.y, np.asarray(case.true_eigenvalues)


def run(
    name: str, seeds: int, snr: float, a: str | None
) -> tuple[list[float], list[float], list[str]]:
    """Worst relative eigenvalue error (percent), CPU seconds and pole source per seed."""
    errs, cpu, source = [], [], []
    for seed in range(EVAL_SEED0, EVAL_SEED0 + seeds):
        t, u, y, truth = record(name, seed, snr)
        c0 = time.process_time()
        model = hdpbsid.identify(t, u, y, order=truth.size, method="laguerre", a=a)
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
        "| record | SNR | call | worst eig. err % per seed | <= 5 % | median % | CPU s median "
        "| pole |",
        "|---|---:|---|---|---:|---:|---:|---|",
    ]
    for name, snr in ((n, s) for n in ("stiff", "stiff-80") for s in args.snr):
        for label, a in POLES.items():
            errs, cpu, source = run(name, args.seeds, snr, a)
            kinds = ", ".join(f"{k} {source.count(k)}" for k in sorted(set(source)))
            lines.append(
                f"| {name} | {snr:g} dB | {label} | {' '.join(f'{e:.3g}' for e in errs)} | "
                f"{sum(e <= 5.0 for e in errs)}/{len(errs)} | {np.median(errs):.3g} | "
                f"{np.median(cpu):.2f} | {kinds} |"
            )
            print(lines[-1], flush=True)
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
