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
(``model.options["a_source"]``; ``bandwidth`` when the first pass was kept).

``--random N`` adds stiff systems the method was not developed on (:func:`random_stiff`,
one per seed ``1000 + i``, ``i`` from ``--random-from K``, 0 by default): a real pole
between -30 and -300 rad/s, a pair with natural frequency 0.3-3 rad/s and damping
0.05-0.5, in 40 % of them a further real pole at -0.3 to -10, random input and output
rows; sampled so the fast pole moves 0.1-0.8 of its time constant a sample, 20 periods of
the pair (2000-20 000 samples), random steps held 2-7 samples.  Per system the default
``method="laguerre"`` call, ``identify`` with every default (its own choice of method),
and the ceiling: the prediction-error fit started at the true system (not a method a user
can call), whose error is what the record's information leaves.  Not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from scipy.linalg import block_diag

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from cases import make_case  # noqa: E402

import hdpbsid  # noqa: E402
from hdpbsid.models.metrics import eigenvalue_errors  # noqa: E402
from hdpbsid.models.model import StateSpaceModel  # noqa: E402
from hdpbsid.refine.pem import refine_pem  # noqa: E402
from hdpbsid.systems import add_noise, random_steps, simulate_zoh  # noqa: E402

RESULTS = HERE / "results" / "stiff_laguerre.md"
#: the first seed: that of ``bench/peers.py``, whose table has the peers on these records
EVAL_SEED0 = 1
#: the calls compared: label -> the pole argument
POLES = {"a=None (default)": None, 'a="bandwidth"': "bandwidth", 'a="dynamics"': "dynamics"}
#: the first seed of ``--random``'s systems
RANDOM_SEED0 = 1000


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


def random_stiff(i: int, snr: float) -> tuple[np.ndarray, ...]:
    """``(t, u, y, A, B, C)`` of the random stiff system ``i`` (module docstring)."""
    rng = np.random.default_rng(RANDOM_SEED0 + i)
    fast = -(10 ** rng.uniform(np.log10(30.0), np.log10(300.0)))
    wn, zeta = 10 ** rng.uniform(np.log10(0.3), np.log10(3.0)), rng.uniform(0.05, 0.5)
    wd = wn * np.sqrt(1.0 - zeta**2)
    blocks = [np.array([[fast]]), np.array([[-zeta * wn, wd], [-wd, -zeta * wn]])]
    if rng.random() < 0.4:
        blocks.append(np.array([[-(10 ** rng.uniform(-0.5, 1.0))]]))
    A = block_diag(*blocks)
    n = A.shape[0]
    B = rng.standard_normal((n, 1))
    B[0, 0] = abs(fast) * np.sign(B[0, 0]) * rng.uniform(0.5, 1.5)  # the fast mode visible
    C = rng.standard_normal((1, n))
    h = rng.uniform(0.1, 0.8) / abs(fast)
    ns = max(int(min(20 * 2 * np.pi / wn / h, 20_000)), 2000)
    t = h * np.arange(ns)
    u = random_steps(rng, t, h * rng.integers(2, 8))
    y = simulate_zoh(A, B, C, np.zeros((1, 1)), t, u)
    return t, u, add_noise(y, snr, rng)[0], A, B, C


def random_rows(count: int, snr: float, first: int = 0) -> list[str]:
    """The table rows of ``--random``: per system (``first`` .. ``first + count - 1``) the
    worst eigenvalue error (%) of the default Laguerre call, of ``identify`` with every
    default, and of the ceiling."""
    errs: dict[str, list[float]] = {k: [] for k in RANDOM_CALLS}
    cpu: dict[str, list[float]] = {k: [] for k in RANDOM_CALLS}
    which = f"{count}" if first == 0 else f"{first}..{first + count - 1}"
    for i in range(first, first + count):
        t, u, y, A, B, C = random_stiff(i, snr)
        truth = np.linalg.eigvals(A)
        for label in RANDOM_CALLS:
            c0 = time.process_time()
            try:
                model = RANDOM_CALLS[label](t, u, y, A, B, C)
                err = 100.0 * float(np.max(eigenvalue_errors(model.eigenvalues, truth)))
            except ValueError:
                err = float("inf")
            cpu[label].append(time.process_time() - c0)
            errs[label].append(err)
    return [
        f"| random stiff ({which}) | {snr:g} dB | {label} | "
        f"{' '.join(f'{e:.3g}' for e in errs[label])} | "
        f"{sum(e <= 5.0 for e in errs[label])}/{count} | {np.median(errs[label]):.3g} | "
        f"{np.median(cpu[label]):.2f} | |"
        for label in RANDOM_CALLS
    ]


def _ceiling(t, u, y, A, B, C) -> Any:
    """The prediction-error fit started at the true system in its true hold."""
    truth = StateSpaceModel(A, B, C, np.zeros((1, 1)), np.zeros((A.shape[0], 1)))
    return refine_pem(truth, t, u - u.mean(axis=0), y - y.mean(axis=0), hold="zoh")


#: the calls of ``--random``: label -> call on ``(t, u, y, A, B, C)``
RANDOM_CALLS = {
    "ceiling: prediction-error fit from the true system": _ceiling,
    "laguerre, a=None (default)": lambda t, u, y, A, B, C: hdpbsid.identify(
        t, u, y, order=A.shape[0], method="laguerre"
    ),
    "identify, every default": lambda t, u, y, A, B, C: hdpbsid.identify(t, u, y, order=A.shape[0]),
}


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
    ap.add_argument("--random", type=int, default=0, help="random stiff systems (40 dB)")
    ap.add_argument("--random-from", type=int, default=0, help="the first random system")
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
    if args.random:
        lines += random_rows(args.random, 40.0, args.random_from)
        print("\n".join(lines[-len(RANDOM_CALLS) :]), flush=True)
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
