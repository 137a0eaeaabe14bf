"""The studies of the source (§5-6) on small settings, each asserting its qualitative
finding as measured here (issue 5).  ``SLOW=1`` runs the full-size versions.

Measured when written (seed 0; second-order system = DESIGN.md benchmark, 40 s, sweep
0.05-1 Hz projected on 100 Hermite functions; numbers are the median worst relative
eigenvalue error over the runs):

* snr (4 runs): HD-PBSID 3.4e-4 at 40 dB, 7.4e-4 at 20 dB, 0.11 at 10 dB, 0.44 at 0 dB;
  CT-PBSID (Laguerre projection) 1.1e-4 / 7.5e-4, then runaway (4 of 4 runs > 100 %)
  at 10 dB and below;
* samples (4 runs, 20 dB): 100 samples fail (N <= Ns/2 = 50 functions cannot carry the
  past window), 300: 1.1e-2, 1000: 4.1e-3, 3000: 2.7e-3, 10 000: 5.2e-4;
* basis order (4 runs, 20 dB): N <= 50 refused (band ``3.6 N / T`` below the data
  bandwidth 5.3 rad/s, i.e. N < 59), 100: 8.0e-4, 200: 1.9e-3, 500: 1.5e-2,
  1000: 0.11 - the error *grows* past N ~ 200 (the source saw saturation above 50);
* operator (3 runs): alpha/s = 0.05: 0.73, 0.25: 0.12, 0.5..64: <= 1e-2 (default 4:
  6.5e-4), 256: 6.3e-2; beta 0.1..10: <= 7e-3; gamma 0.1..10: 5.6e-4..7.1e-4 (gamma
  cancels in ``A' M = (A/alpha + beta)(D/alpha + beta)^-1``: no effect but the ridge);
* table1 (3 runs): 50 dB HD-PBSID 1.5e-3, Laguerre filters 4.7e-3, Laguerre projection
  0.70 / 33 / 73 (runaway on 2 of 3 records); 6 dB STD of the pair HD-PBSID 0.45 rad/s,
  Laguerre filters 30, Laguerre projection 2.8e3;
* quadrotor (q, theta outputs, 20 dB): order 3 worst error 6.3 %; singular values
  1.24e3, 654, 11.1, 3.6, ... (the log-gap picks 2, not 3 or 4).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import hdpbsid.studies as S

FULL = bool(os.environ.get("SLOW"))
PNG = b"\x89PNG\r\n\x1a\n"


def _row(result: S.StudyResult, **match) -> dict:
    rows = [r for r in result.summary if all(r.get(k) == v for k, v in match.items())]
    assert len(rows) == 1, (match, result.summary)
    return rows[0]


def test_snr_error_grows_as_noise_grows(tmp_path: Path) -> None:
    runs = 20 if FULL else 3
    res = S.snr(
        runs=runs, snrs=(40.0, 10.0), methods=("hermite", "laguerre"), progress=False, out=tmp_path
    )
    h40 = _row(res, snr_db=40.0, method="hermite")["median err"]
    h10 = _row(res, snr_db=10.0, method="hermite")["median err"]
    # measured 3.4e-4 at 40 dB: well under 1e-2 (the bound leaves room for other seeds)
    assert h40 < 1e-2
    # measured 0.11 at 10 dB vs 3.4e-4: 300x; 10x is the qualitative finding
    assert h10 > 10 * h40
    lag10 = _row(res, snr_db=10.0, method="laguerre")
    # measured: CT-PBSID runs away on every record at 10 dB (worst error 3-4x |lambda|)
    assert lag10["median err"] > 1.0
    assert (tmp_path / "snr.png").read_bytes()[:8] == PNG


def test_samples_error_decreases_with_samples() -> None:
    counts = (100, 300, 1000, 3000, 10000) if FULL else (100, 300, 10000)
    res = S.samples(runs=20 if FULL else 3, sample_counts=counts, progress=False)
    # 100 samples: N <= 50 Hermite functions cannot hold the record's band: every run fails
    assert _row(res, samples=100)["failed"] == _row(res, samples=100)["n"]
    e300 = _row(res, samples=300)["median err"]
    e10k = _row(res, samples=10000)["median err"]
    # measured 1.1e-2 (300) vs 5.2e-4 (10 000): 20x; at least 5x with 3 runs
    assert e10k < e300 / 5


def test_basis_order_threshold_and_large_n() -> None:
    sizes = (10, 20, 30, 50, 60, 70, 80, 100, 150, 200, 300, 500, 1000) if FULL else (30, 100, 200)
    res = S.basis_order(runs=20 if FULL else 2, basis_sizes=sizes, progress=False)
    # N = 30 covers 2.7 rad/s < the 5.3 rad/s data bandwidth: refused, recorded as failure
    r30 = _row(res, N=30)
    assert r30["failed"] == r30["n"] and "ValueError" in r30["failures"][0]
    # N = 100 and 200: measured 8e-4 and 1.9e-3 median; 1e-2 bounds both with 2 runs
    assert _row(res, N=100)["median err"] < 1e-2
    assert _row(res, N=200)["median err"] < 1e-2


@pytest.mark.slow
def test_basis_order_large_n_degrades() -> None:
    res = S.basis_order(runs=10 if FULL else 2, basis_sizes=(100, 1000), progress=False)
    # measured 8e-4 (N = 100) vs 0.11 (N = 1000): the error grows with N past ~200;
    # 5x is far below the measured 140x
    assert _row(res, N=1000)["median err"] > 5 * _row(res, N=100)["median err"]


def test_operator_ranges() -> None:
    res = S.operator(
        runs=10 if FULL else 2,
        alpha_factors=(0.05, 4.0),
        betas=(0.1, 10.0),
        gammas=(0.1, 10.0),
        progress=False,
    )
    default = _row(res, parameter="alpha/s", value=4.0)["median err"]
    # measured 6.5e-4 with the defaults (alpha = 4 s, beta = gamma = 1)
    assert default < 5e-3
    # alpha = 0.05 s: A' = A/alpha + I is far outside the unit disc; measured 0.73
    assert _row(res, parameter="alpha/s", value=0.05)["median err"] > 0.2
    # beta 0.1..10 measured <= 7e-3: minimal impact (source §5); 3e-2 bounds it
    for b in (0.1, 10.0):
        assert _row(res, parameter="beta", value=b)["median err"] < 3e-2
    # gamma cancels from A'^j M^j; only the ridge sees it: measured within 10 % of the
    # default, 2x allows for the ridge's GCV choice on other records
    for g in (0.1, 10.0):
        assert _row(res, parameter="gamma", value=g)["median err"] < 2 * default + 1e-4


def test_table1_small(tmp_path: Path) -> None:
    runs = 20 if FULL else 3
    res = S.table1(
        runs=runs,
        snrs=(50.0, 6.0),
        methods=("hermite", "laguerre-filter"),
        progress=False,
        out=tmp_path,
    )
    for m in ("hermite", "laguerre-filter"):
        row = _row(res, snr_db=50.0, method=m)
        # measured 1.5e-3 (HD-PBSID) and 4.7e-3 (Laguerre filters) at 50 dB; 2 % = accurate
        assert row["failed"] == 0 and row["median err"] < 0.02, row
    h6 = _row(res, snr_db=6.0, method="hermite")
    f6 = _row(res, snr_db=6.0, method="laguerre-filter")
    # measured STD of the pair 0.45 (HD-PBSID) vs 30 rad/s (filters): "several times"
    assert h6["std pair"] < f6["std pair"] / 3
    assert h6["divergent"] == 0  # measured: no HD-PBSID estimate runs away at 6 dB
    text = res.table()
    assert "std pair" in text and "laguerre-filter" in text
    for name in ("table1_eig_50dB.png", "table1_eig_6dB.png", "table1_std.png"):
        assert (tmp_path / name).read_bytes()[:8] == PNG


def test_quadrotor_example(tmp_path: Path) -> None:
    res = S.quadrotor(outputs=("q", "theta"), progress=False, out=tmp_path)
    (rec,) = res.records
    assert rec["ok"], rec
    r = rec["result"]
    m3, m4 = r["models"]["3"], r["models"]["4"]
    # measured 6.3 % worst (the real pole +3.08) at 20 dB; 15 % catches a regression
    # while leaving room for the method work in progress (2-11 % over seeds, issue 4)
    assert m3["max_error"] < 0.15
    assert len(m4["eigenvalues"]) == 4 and len(m4["extra"]) == 1
    # the simulated-vs-measured check (Figure 2): measured VAF 99 % on both records
    assert min(m3["vaf_validation"]) > 90.0
    sv = np.array(r["singular_values"])
    # two dominant singular values (1.24e3, 654), then 11: the 3rd state is weak; the
    # log-gap picks 2 - nothing in them "motivates" order 4 for this 3-state plant
    assert sv[1] / sv[2] > 10 and r["auto_order"] in (1, 2)
    for name in ("singular_values", "eigenvalues", "outputs", "bode"):
        assert (tmp_path / f"{name}.png").read_bytes()[:8] == PNG
    assert "VAF valid" in res.table()
