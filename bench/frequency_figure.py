"""Draw ``docs/_static/frequency_delay_band.png``, the figure of the frequency-domain page.

Run: ``PYTHONPATH=. .venv/bin/python bench/frequency_figure.py [--out PATH]``.

A second-order system (2 rad/s, damping 0.2) behind a dead time of 0.15 s (3 samples),
sampled at dt = 0.05 s for 100 s (forty time constants of the mode: long enough for the
band's asymptotic covariance, module docstring of :mod:`hdpbsid.models.uncertainty`) with a
random binary input and output noise 10 dB below the output, so that the model's 95 %
band is wide enough to see.  The model is ``identify(..., order=2,
method="dt", refine="pem", delay="auto")``; the figure is ``plot_frf`` of the Welch
estimate with the model and its band.  The seed is fixed: the figure is reproducible.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402

import hdpbsid  # noqa: E402
from hdpbsid.design import inputs  # noqa: E402
from hdpbsid.frequency import fit as frequency
from hdpbsid.systems import second_order  # noqa: E402

OUT = Path(__file__).resolve().parent.parent / "docs" / "_static" / "frequency_delay_band.png"
TAU, DT, SAMPLES, NOISE = 0.15, 0.05, 2_000, 10 ** (-10 / 20)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args()
    A, B, C, D = second_order()
    rng = np.random.default_rng(0)
    d = inputs.random_binary(SAMPLES, DT, rng=rng)
    truth = hdpbsid.StateSpaceModel(A, B, C, D, np.zeros((2, 1)), delay=TAU)
    y0 = truth.simulate(d.t, d.u)
    y = y0 + NOISE * np.std(y0) * rng.standard_normal(y0.shape)
    model = hdpbsid.identify(
        d.t, d.u, y, order=2, method="dt", refine="pem", delay="auto", max_delay=0.5
    )
    est = frequency.frf_welch(d.u, y, DT, nperseg=256)
    fig = frequency.plot_frf(est, model)
    fig.suptitle(
        f"dead time {TAU} s, found {model.delay[0]:.2f} s; 100 s at dt = {DT} s, 10 dB", fontsize=9
    )
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=110, bbox_inches="tight")
    print(
        f"delay {model.delay[0]:.3f} s, eigenvalues {np.round(model.eigenvalues, 3)} -> {args.out}"
    )


if __name__ == "__main__":
    main()
