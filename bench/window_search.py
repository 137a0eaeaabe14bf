"""The past-window search of ``method="dt"``: QR of the regressors against the lagged Gram
matrix (``hdpbsid.core.lag_gram``), side by side on the records the default sweep sees.

Run: ``python bench/window_search.py [--reps 3] [--md bench/results/window_search.md]``

For each record (the estimation part, 80 %, that ``identify(t, u, y)`` sweeps; inputs
and outputs scaled to unit RMS as ``identify_discrete`` does; the window range of its
default rule): the window chosen by the QR search (``select_past_window(...,
gram=False)``), whether the Gram search certified its choice and which window it chose
(``_window_search_by_gram``; "-" when it left the choice to the QR), and the CPU time of
each (median of ``--reps``, one BLAS thread as inside the library's calls).  Nothing is
asserted: the tests compare the two (``tests/hdpbsid/core/test_lag_gram.py``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _records() -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(name, u, y) of the records: the 10^4 binary-input case of ``bench/scaling.py``
    (seeds 0-4) and cases of ``bench/cases.py`` at 20 dB (seeds 0-1)."""
    sys.path.insert(0, str(HERE))
    from cases import make_case
    from scaling import binary_record

    out = []
    for seed in range(5):
        (t, u, y), _ = binary_record(10**4, seed)
        out.append((f"binary 10^4 / {seed}", u, y))
    for name in ("second-order-smooth", "stiff", "rao-garnier", "quadrotor", "mimo-2x2"):
        for seed in range(2):
            try:
                r = make_case(name, seed, 20.0).estimation
            except (KeyError, ValueError):
                continue
            out.append((f"{name} / {seed}", r.u, r.y))
    return out


def _cpu(call, reps: int) -> tuple[object, float]:
    times, got = [], None
    for _ in range(reps):
        c0 = time.process_time()
        got = call()
        times.append(time.process_time() - c0)
    return got, statistics.median(times)


def main(argv: list[str] | None = None) -> int:
    """Print the table and write it as markdown."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--md", default=str(HERE / "results" / "window_search.md"))
    args = ap.parse_args(argv)
    from threadpoolctl import threadpool_limits

    from hdpbsid.core.varx import _window_search_by_gram, select_past_window
    from hdpbsid.methods.dt import default_windows

    lines = [
        f"`python bench/window_search.py --reps {args.reps}`: load average"
        f" {', '.join(f'{x:.1f}' for x in os.getloadavg())} at the start; CPU seconds,"
        f" median of {args.reps}, one BLAS thread",
        "",
        "| record | samples | p range | p (QR) | p (Gram) | QR s | Gram s | ratio |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    print("\n".join(lines), flush=True)
    with threadpool_limits(1):
        for name, u, y in _records():
            n = int(round(0.8 * len(u)))
            u, y = u[:n], y[:n]
            U = (u / np.sqrt(np.mean(u**2, axis=0))).T
            Y = (y / np.sqrt(np.mean(y**2, axis=0))).T
            p_min, p_max = default_windows(n, U.shape[0], Y.shape[0], None, 10, None, None)
            qr = lambda U=U, Y=Y, a=p_min, b=p_max: select_past_window(  # noqa: E731
                U, Y, b, p_min=a, gram=False
            )
            gram = lambda U=U, Y=Y, a=p_min, b=p_max: _window_search_by_gram(  # noqa: E731
                U, Y, b, a, 0, "aic", 1e-12, 3.0
            )
            (p_qr, _), t_qr = _cpu(qr, args.reps)
            got, t_gram = _cpu(gram, args.reps)
            p_gram = "-" if got is None else str(got[0])
            lines.append(
                f"| {name} | {n} | {p_min}-{p_max} | {p_qr} | {p_gram} | {t_qr:.4f} |"
                f" {t_gram:.4f} | {t_gram / t_qr:.2f} |"
            )
            print(lines[-1], flush=True)
    lines += ["", f"load average {', '.join(f'{x:.1f}' for x in os.getloadavg())} at the end"]
    if args.md:
        Path(args.md).write_text("\n".join(lines) + "\n")
        print(f"wrote {args.md}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
