"""Input design, frequency responses and models from frequency data: the numbers of the
frequency-domain tools, side by side with scipy.signal where scipy has the same estimator.

Run: ``PYTHONPATH=. .venv/bin/python bench/frequency.py [--seeds 5]``; the table is
printed and written as markdown to ``bench/results/frequency.md``.

Rows (median and worst over seeds where a seed matters):

1. crest factor of a flat 100-line multisine: Schroeder phases, Schroeder + clipping
   (``hdpbsid.design.inputs.multisine``), random phases (the median a user gets without design);
2. FRF of the second-order system (2 rad/s, damping 0.2) from a 20 dB random-binary
   record (1200 s, dt = 0.01, 4096-sample Hann segments), largest magnitude (dB) and phase
   (deg) error where the coherence exceeds 0.9, and the coverage of the 95 % circles:
   ``hdpbsid.frequency.fit.frf_welch`` and the same H1 from ``scipy.signal.csd`` /
   ``scipy.signal.welch`` / ``scipy.signal.coherence`` (no confidence region in scipy);
3. Rao-Garnier from 200 log-spaced FRF points with 1 % complex noise: order chosen and
   largest relative eigenvalue error (``identify_frequency``, order free); scipy has no
   fit of a model to frequency-response data;
4. Rao-Garnier from 20 dB time data (12 periods of a 0.04-8 Hz multisine, 2 skipped)
   through ``frf_periodic`` and ``identify_frequency``;
5. the second-order system with a dead time of 0.13 s at dt = 0.01 (random binary input,
   120 s, 20 dB): ``identify(..., order=2, method="dt", delay="auto")``, the delay error
   in samples and the largest relative eigenvalue error, beside ``identify`` on the same
   record without the dead time (same input and noise); and ``estimate_delay`` on the
   delayed records without the order (order and delay chosen together).

SIPPY, ``freq-statespace`` and ``strid`` are not run (not installed in this environment);
no peer estimates a continuous-time dead time, so row 5 has no peer column.
Not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cases import rao_garnier_system  # noqa: E402

from hdpbsid.design import inputs  # noqa: E402
from hdpbsid.frequency import fit as frequency
from hdpbsid.models.metrics import eigenvalue_errors  # noqa: E402
from hdpbsid.models.model import StateSpaceModel  # noqa: E402
from hdpbsid.systems import add_noise, second_order, simulate_zoh  # noqa: E402


def crest_rows(seeds: int) -> list[tuple[str, str, str]]:
    kw = dict(period=4096, dt=1 / 4096, band=(1.0, 100.0))
    sch = inputs.multisine(**kw, phases="schroeder").crest_factor[0]
    red = inputs.multisine(**kw).crest_factor[0]
    rnd = [
        inputs.multisine(**kw, phases="random", rng=np.random.default_rng(s)).crest_factor[0]
        for s in range(max(seeds, 20))
    ]
    return [
        ("crest factor, 100 flat lines", "Schroeder", f"{sch:.3f}"),
        ("", "Schroeder + clipping (hdpbsid)", f"{red:.3f}  (target <= 1.5)"),
        ("", f"random phases (median of {len(rnd)})", f"{np.median(rnd):.3f}"),
    ]


def _scipy_h1(u: np.ndarray, y: np.ndarray, dt: float, nperseg: int):
    from scipy.signal import coherence, csd, welch

    f, Puy = csd(u, y, fs=1 / dt, nperseg=nperseg)  # E[U^* Y]
    _, Puu = welch(u, fs=1 / dt, nperseg=nperseg)
    _, coh = coherence(u, y, fs=1 / dt, nperseg=nperseg)
    keep = f > 0
    return 2 * np.pi * f[keep], (Puy / Puu)[keep], coh[keep]


def frf_rows(seeds: int) -> list[tuple[str, str, str]]:
    A, B, C, D = second_order()
    dt = 0.01
    dm = StateSpaceModel(A, B, C, D, np.zeros((2, 1))).to_discrete(dt)
    ours, sp, cover = [], [], []
    for s in range(seeds):
        rng = np.random.default_rng(s)
        d = inputs.random_binary(120_000, dt, rng=rng)
        y, _ = add_noise(simulate_zoh(A, B, C, D, d.t, d.u), 20.0, rng)
        est = frequency.frf_welch(d.u, y, dt, nperseg=4096)
        T = dm.frequency_response(est.w)[0, 0]
        good = est.coherence[0] > 0.9
        ratio = est.H[0, 0] / T
        ours.append(
            (
                np.max(np.abs(20 * np.log10(np.abs(ratio)))[good]),
                np.max(np.abs(np.degrees(np.angle(ratio)))[good]),
            )
        )
        cover.append(np.mean(np.abs(est.H[0, 0] - T) < est.confidence_radius()[0, 0]))
        w, H, coh = _scipy_h1(d.u[:, 0], y[:, 0], dt, 4096)
        r2 = H / dm.frequency_response(w)[0, 0]
        g2 = coh > 0.9
        sp.append(
            (
                np.max(np.abs(20 * np.log10(np.abs(r2)))[g2]),
                np.max(np.abs(np.degrees(np.angle(r2)))[g2]),
            )
        )
    o, p = np.array(ours), np.array(sp)

    def fmt(a: np.ndarray) -> str:
        return (
            f"{np.median(a[:, 0]):.2f} / {a[:, 0].max():.2f} dB, "
            f"{np.median(a[:, 1]):.2f} / {a[:, 1].max():.2f} deg"
        )

    return [
        ("FRF, 2nd order, 20 dB, RBS", "frf_welch (median / worst)", fmt(o)),
        ("", "scipy.signal csd/welch H1", fmt(p)),
        ("", "95 % circles cover truth", f"{np.median(cover):.3f} (median)"),
    ]


def _rao_garnier() -> StateSpaceModel:
    A, B, C, D = rao_garnier_system()
    return StateSpaceModel(A, B, C, D, np.zeros((4, 1)))


def frf_points_rows(seeds: int) -> list[tuple[str, str, str]]:
    true = _rao_garnier()
    w = np.logspace(-1, 2, 200)
    H0 = true.frequency_response(w)[0, 0]
    orders, errs, times = [], [], []
    for s in range(seeds):
        rng = np.random.default_rng(s)
        H = H0 * (1 + 0.01 * (rng.standard_normal(200) + 1j * rng.standard_normal(200)) / 2**0.5)
        t0 = time.process_time()
        m = frequency.identify_frequency(w, H)
        times.append(time.process_time() - t0)
        orders.append(m.n)
        if m.n == 4:
            errs.append(100 * eigenvalue_errors(m.eigenvalues, true.eigenvalues).max())
    return [
        (
            "Rao-Garnier, 200 FRF pts, 1 %",
            "identify_frequency (order free)",
            f"order 4 in {orders.count(4)}/{seeds}; eig err median {np.median(errs):.3f} %, "
            f"worst {max(errs):.3f} % (target 1 %); CPU {np.median(times):.1f} s",
        )
    ]


def time_data_rows(seeds: int) -> list[tuple[str, str, str]]:
    true = _rao_garnier()
    dt, n, up = 0.01, 2048, 10
    d = inputs.multisine(n * up, dt / up, (0.04, 8.0), periods=12, iterations=50)
    y0 = true.simulate(d.t, d.u, method="foh")[::up]
    orders, errs = [], []
    for s in range(seeds):
        y, _ = add_noise(y0, 20.0, np.random.default_rng(s))
        frf = frequency.frf_periodic(d.u[::up], y, dt, n, skip=2)
        m = frequency.identify_frequency(frf)
        orders.append(m.n)
        if m.n == 4:
            errs.append(100 * eigenvalue_errors(m.eigenvalues, true.eigenvalues).max())
    return [
        (
            "Rao-Garnier, 20 dB multisine",
            "frf_periodic + identify_frequency",
            f"order 4 in {orders.count(4)}/{seeds}; eig err median {np.median(errs):.3f} %, "
            f"worst {max(errs):.3f} % (target 2 %)",
        )
    ]


def delay_rows(seeds: int) -> list[tuple[str, str, str]]:
    from hdpbsid import identify
    from hdpbsid.frequency.delay import estimate_delay

    A, B, C, D = second_order()
    ev = np.linalg.eigvals(A)
    dt, tau = 0.01, 0.13
    derr, e_del, e_free = [], [], []
    for s in range(seeds):
        rng = np.random.default_rng(s)
        d = inputs.random_binary(12_000, dt, rng=rng)
        noise = rng.standard_normal((12_000, 1))
        for delay, out in ((tau, e_del), (0.0, e_free)):
            m = StateSpaceModel(A, B, C, D, np.zeros((2, 1)), delay=delay)
            y0 = m.simulate(d.t, d.u)
            y = y0 + noise * np.std(y0) / 10.0  # 20 dB
            kw = dict(delay="auto", max_delay=0.5) if delay else {}
            model = identify(d.t, d.u, y, order=2, method="dt", **kw)
            out.append(100 * eigenvalue_errors(model.eigenvalues, ev).max())
            if delay:
                derr.append(abs(model.delay[0] - tau) / dt)
    joint = []
    for s in range(seeds):  # the same records, the order not given
        rng = np.random.default_rng(s)
        d = inputs.random_binary(12_000, dt, rng=rng)
        noise = rng.standard_normal((12_000, 1))
        y0 = StateSpaceModel(A, B, C, D, np.zeros((2, 1)), delay=tau).simulate(d.t, d.u)
        est = estimate_delay(d.t, d.u, y0 + noise * np.std(y0) / 10.0, 0.3)
        joint.append((int(est.order[0]), abs(int(est.samples[0]) - round(tau / dt))))
    jo = np.array(joint)
    return [
        (
            "2nd order, dead time 0.13 s, 20 dB",
            "identify(delay='auto'), delay error",
            f"median {np.median(derr):.2f}, worst {max(derr):.2f} samples (target <= 1)",
        ),
        (
            "",
            "eigenvalue error with / without delay",
            f"median {np.median(e_del):.3f} / {np.median(e_free):.3f} %, "
            f"worst {max(e_del):.3f} / {max(e_free):.3f} %",
        ),
        (
            "",
            "estimate_delay without the order",
            f"order 2 in {int(np.sum(jo[:, 0] == 2))}/{seeds}; delay error median "
            f"{np.median(jo[:, 1]):.2f}, worst {jo[:, 1].max()} samples",
        ),
    ]


def markdown(rows: list[tuple[str, str, str]]) -> str:
    """The table as markdown (for the docs pages that include ``bench/results``)."""
    lines = ["| case | estimator | result |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    args = ap.parse_args()
    rows = []
    for fn in (crest_rows, frf_rows, frf_points_rows, time_data_rows, delay_rows):
        rows += fn(args.seeds)
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len(r[1]) for r in rows)
    print(f"{'case':<{w0}}  {'estimator':<{w1}}  result")
    print("-" * (w0 + w1 + 60))
    for a, b, c in rows:
        print(f"{a:<{w0}}  {b:<{w1}}  {c}")
    out = Path(__file__).resolve().parent / "results" / "frequency.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(markdown(rows), encoding="utf-8")
    print(f"-> {out}")


if __name__ == "__main__":
    main()
