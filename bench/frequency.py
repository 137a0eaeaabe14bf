"""Input design, frequency responses and models from frequency data: the numbers of the
frequency-domain tools, side by side with scipy.signal, strid, freq-statespace and SIPPY.

Run: ``PYTHONPATH=. .venv/bin/python bench/frequency.py [--seeds 5]`` in an environment
with the ``bench`` extra; the table is printed and written as markdown to
``bench/results/frequency.md``.  Every tool, ours and the peers, sees the same seeds.

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

Peers (``pip install -e ".[bench]"``; a peer that does not import is reported "not
installed"), every one on the records and seeds our estimators get:

* row 3, ``strid.PolyReferenceLSCF`` (poly-reference least-squares complex frequency,
  a z-domain polynomial fit for modal analysis).  It takes the FRF on the uniform grid
  ``0 .. fs / 2`` only (its frequency axis is ``linspace(0, fs/2, len(H))``), so it gets
  200 *uniform* points on ``[0, 100]`` rad/s (``fs = 100 / pi`` Hz) with the same noise,
  and ``identify_frequency`` is run on those same points too.  Poles: the roots ``z`` of
  its denominator polynomial, ``s = fs log z``.  Two uses: order 4 (the true order), and
  the stabilisation diagram a modal analyst reads: orders 4..20, strid's own stability
  test (``StabilizationDiagram.find_stable_modes``: frequency within 1 %, damping within
  5 % of a mode of the previous order), the stable modes of order 20 below 0.9 times
  the Nyquist frequency picked (the band edge holds the fit's spurious modes);
* row 4, ``freq_statespace.lin.subspace_id`` (frequency-domain subspace, ``nq = nx +
  1`` default) and ``lin.optimize`` (Levenberg-Marquardt on the best linear
  approximation), with the true order 4, from the same ten steady periods
  ``frf_periodic`` uses (``create_data_object`` with the multisine's excited lines); its
  discrete model's eigenvalues mapped by ``log(z) / dt``.  JAX's default single
  precision is kept (the package does not enable ``jax_enable_x64``);
* row 4, SIPPY N4SID (the adapter of ``bench/peers.py``, order 4, its default horizon
  ``f = p = 20``) on the whole time record (it starts at rest, transient included),
  eigenvalues by the exact ZOH inverse, beside our time-domain ``identify(method="dt",
  order=4)`` on the same records.

No peer estimates a continuous-time dead time, so row 5 has no peer column.
Not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cases import Record, rao_garnier_system  # noqa: E402

from hdpbsid.design import inputs  # noqa: E402
from hdpbsid.frequency import fit as frequency  # noqa: E402
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


def _noisy(H0: np.ndarray, seed: int) -> np.ndarray:
    """``H0`` with 1 % circular complex Gaussian noise (seeded)."""
    rng = np.random.default_rng(seed)
    k = H0.size
    return H0 * (1 + 0.01 * (rng.standard_normal(k) + 1j * rng.standard_normal(k)) / 2**0.5)


def _errors_text(errs: list[float], runs: int, target: str = "") -> str:
    """``k/runs`` scored, median and worst largest relative eigenvalue error (%)."""
    if not errs:
        return f"no model of order 4 in {runs} runs"
    head = "" if len(errs) == runs else f"order 4 in {len(errs)}/{runs}; "
    tail = f" (target {target})" if target else ""
    return f"{head}eig err median {np.median(errs):.3f} %, worst {max(errs):.3f} %{tail}"


def _ours_frf_points(
    w: np.ndarray, H0: np.ndarray, seeds: int, true: StateSpaceModel, first: int = 0
):
    """``identify_frequency`` on ``w[first:]`` (the noise is drawn on all of ``H0``)."""
    orders, errs, times = [], [], []
    for s in range(seeds):
        H = _noisy(H0, s)[first:]
        t0 = time.process_time()
        m = frequency.identify_frequency(w[first:], H)
        times.append(time.process_time() - t0)
        orders.append(m.n)
        if m.n == 4:
            errs.append(100 * eigenvalue_errors(m.eigenvalues, true.eigenvalues).max())
    return orders, errs, times


def frf_points_rows(seeds: int) -> list[tuple[str, str, str]]:
    true = _rao_garnier()
    w = np.logspace(-1, 2, 200)
    orders, errs, times = _ours_frf_points(w, true.frequency_response(w)[0, 0], seeds, true)
    rows = [
        (
            "Rao-Garnier, 200 FRF pts, 1 %",
            "identify_frequency (order free)",
            f"order 4 in {orders.count(4)}/{seeds}; eig err median {np.median(errs):.3f} %, "
            f"worst {max(errs):.3f} % (target 1 %); CPU {np.median(times):.1f} s",
        )
    ]
    return rows + strid_rows(seeds, true)


def _strid_poles(N: np.ndarray, D: np.ndarray, fs: float) -> np.ndarray:
    """Continuous poles of strid's SISO matrix fraction: ``D[k]`` multiplies ``z^k``."""
    z = np.roots(D[::-1, 0, 0]).astype(complex)
    return fs * np.log(z)


def _mode_poles(modes) -> np.ndarray:
    """The pole pairs ``-xi w +- j w sqrt(1 - xi^2)`` of strid ``Mode`` objects."""
    p = np.array([-m.xi * m.w + 1j * m.w * np.sqrt(1 - m.xi**2) for m in modes])
    return np.concatenate([p, p.conj()])


def strid_rows(seeds: int, true: StateSpaceModel) -> list[tuple[str, str, str]]:
    """``strid.PolyReferenceLSCF`` at order 4 and by stabilisation, beside ours, on 200
    uniform FRF points (the only grid strid accepts)."""
    case = "  same, 200 uniform pts on [0, 100] rad/s"
    wmax, top = 100.0, 20
    w = np.linspace(0.0, wmax, 200)
    fs = wmax / np.pi  # strid's grid is linspace(0, fs / 2) Hz
    H0 = true.frequency_response(w)[0, 0]
    orders, errs, times = _ours_frf_points(w, H0, seeds, true, first=1)  # w > 0
    rows = [
        (
            case,
            "identify_frequency (order free, w > 0)",
            f"order 4 in {orders.count(4)}/{seeds}; eig err median {np.median(errs):.3f} %, "
            f"worst {max(errs):.3f} %; CPU {np.median(times):.1f} s",
        )
    ]
    try:
        import matplotlib

        matplotlib.use("Agg")  # strid's StabilizationDiagram makes a figure
        import strid
    except ImportError:
        return rows + [("", "strid PolyReferenceLSCF", "not installed")]
    e4, unstable, stab, counts, times = [], 0, [], [], []
    for s in range(seeds):
        t0 = time.process_time()
        est = strid.PolyReferenceLSCF(_noisy(H0, s)[None, None, :], fs)
        modes = {}
        for order in range(4, top + 1):
            N, D = est.perform(order, max_order=top)
            if order == 4:
                p4 = _strid_poles(N, D, fs)
            with np.errstate(all="ignore"):  # its z = 0 poles give log(0) in Mode
                modes[order] = strid.Mode.find_modes_from_rmfd(N, D, fs)
        times.append(time.process_time() - t0)
        e4.append(100 * eigenvalue_errors(p4, true.eigenvalues).max())
        unstable += int(np.any(p4.real >= 0))
        diagram = strid.StabilizationDiagram()
        with np.errstate(all="ignore"):
            stable = diagram.find_stable_modes(diagram.filter_modes(modes))[top]
        picked = [m for m in stable if m.w < 0.9 * np.pi * fs]
        counts.append(len(picked))
        if len(picked) == 2:
            stab.append(100 * eigenvalue_errors(_mode_poles(picked), true.eigenvalues).max())
        import matplotlib.pyplot as plt

        plt.close("all")
    return rows + [
        (
            "",
            "strid PolyReferenceLSCF, order 4",
            _errors_text(e4, seeds) + f"; unstable poles in {unstable}/{seeds}",
        ),
        (
            "",
            f"strid LSCF, stabilisation 4..{top}",
            f"2 stable modes in {counts.count(2)}/{seeds}; "
            + (_errors_text(stab, len(stab)) if stab else "none scored")
            + f"; CPU (orders 4..{top}) {np.median(times):.2f} s",
        ),
    ]


def time_data_rows(seeds: int) -> list[tuple[str, str, str]]:
    true = _rao_garnier()
    dt, n, up, skip = 0.01, 2048, 10, 2
    d = inputs.multisine(n * up, dt / up, (0.04, 8.0), periods=12, iterations=50)
    y0 = true.simulate(d.t, d.u, method="foh")[::up]
    u = d.u[::up]
    records = [add_noise(y0, 20.0, np.random.default_rng(s))[0] for s in range(seeds)]
    orders, errs = [], []
    for y in records:
        frf = frequency.frf_periodic(u, y, dt, n, skip=skip)
        m = frequency.identify_frequency(frf)
        orders.append(m.n)
        if m.n == 4:
            errs.append(100 * eigenvalue_errors(m.eigenvalues, true.eigenvalues).max())
    rows = [
        (
            "Rao-Garnier, 20 dB multisine",
            "frf_periodic + identify_frequency",
            f"order 4 in {orders.count(4)}/{seeds}; eig err median {np.median(errs):.3f} %, "
            f"worst {max(errs):.3f} % (target 2 %)",
        )
    ]
    lines = np.asarray(d.lines[0])
    rows += freq_statespace_rows(u, records, dt, n, skip, lines, true)
    recs = [Record(d.t[::up], u, y) for y in records]
    return rows + time_domain_rows(recs, true)


def freq_statespace_rows(u, records, dt, n, skip, lines, true) -> list[tuple[str, str, str]]:
    """``freq_statespace.lin.subspace_id`` and ``lin.optimize`` (true order 4) on the
    steady periods, eigenvalues ``log(z) / dt``."""
    try:
        import freq_statespace as fss
    except ImportError:
        return [("", "freq_statespace subspace_id / optimize", "not installed")]

    def periods(x: np.ndarray) -> np.ndarray:  # (N, channels, 1 realisation, P periods)
        p = x.shape[0] // n - skip
        return x[skip * n : (skip + p) * n].reshape(p, n, -1).transpose(1, 2, 0)[:, :, None]

    def ct(model) -> np.ndarray:
        z = np.linalg.eigvals(np.asarray(model.A, dtype=float)).astype(complex)
        return np.log(z) / float(model.ts)

    sub, opt, times = [], [], []
    for y in records:
        data = fss.create_data_object(periods(u), periods(y), lines, 1 / dt)
        t0 = time.process_time()
        m0 = fss.lin.subspace_id(data, 4, logging_enabled=False)
        m1 = fss.lin.optimize(m0, data, print_every=-1)
        times.append(time.process_time() - t0)
        sub.append(100 * eigenvalue_errors(ct(m0), true.eigenvalues).max())
        opt.append(100 * eigenvalue_errors(ct(m1), true.eigenvalues).max())
    return [
        ("", "freq_statespace subspace_id (nx=4)", _errors_text(sub, len(records))),
        (
            "",
            "freq_statespace + lin.optimize",
            _errors_text(opt, len(records)) + f"; CPU {np.median(times):.1f} s",
        ),
    ]


def time_domain_rows(records: list[Record], true: StateSpaceModel) -> list[tuple[str, str, str]]:
    """Order 4 from the whole time records: our ``dt`` method (PBSID, exact d2c) and SIPPY
    N4SID with its default horizon (the adapter of ``bench/peers.py``)."""
    from hdpbsid import identify

    ours = [
        100
        * eigenvalue_errors(
            identify(r.t, r.u, r.y, order=4, method="dt", detrend=None).eigenvalues,
            true.eigenvalues,
        ).max()
        for r in records
    ]
    rows = [("", "identify(method='dt', order=4), time data", _errors_text(ours, len(records)))]
    label = "SIPPY N4SID (time data, f=p=20)"
    try:
        import sippy_unipi  # noqa: F401
    except ImportError:
        return rows + [("", label, "not installed")]
    from peers import SIPPY_DEFAULT_HORIZON, _sippy, continuous_A

    run = _sippy("N4SID")
    errs, fails = [], 0
    for rec in records:
        try:
            model = run(rec, 4, SIPPY_DEFAULT_HORIZON)
            errs.append(
                100
                * eigenvalue_errors(np.linalg.eigvals(continuous_A(model)), true.eigenvalues).max()
            )
        except (SystemExit, ValueError, np.linalg.LinAlgError):
            fails += 1
    text = _errors_text(errs, len(records))
    return rows + [("", label, text + (f"; failed {fails}" if fails else ""))]


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
