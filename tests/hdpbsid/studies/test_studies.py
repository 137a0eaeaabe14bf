"""The studies of the thesis (§5-6) on small settings, each asserting its qualitative
finding as measured here.  ``SLOW=1`` runs the full-size versions.

Measured when written (seed 0, method defaults of commit 369b60c; second-order system =
``hdpbsid.systems.second_order``, 40 s, sweep 0.05-1 Hz projected on 100 Hermite functions; numbers
are the median worst relative eigenvalue error over the runs, full-size runs of
``hdpbsid study NAME`` unless stated):

* snr (20 runs): HD-PBSID 1.3e-4 (40 dB), 1.0e-3 (20), 4.3e-3 (10), 7.2e-3 (6),
  2.4e-2 (0 dB); CT-PBSID (Laguerre projection) alike down to 6 dB, 2 of 20 runs
  divergent at 0 dB;
* samples (20 runs, 20 dB): 100 samples fail (N <= Ns/2 = 50 functions cannot hold the
  record's band), 300: 7.2e-3, 1000: 3.1e-3, 3000: 1.9e-3, 10 000: 6.8e-4;
* basis order (20 runs, 20 dB): N <= 50 refused (band ``3.6 N / T`` below the data
  bandwidth 5.3 rad/s, i.e. N < 59), 60-100: 1.1e-3, 200: 1.9e-3, 500: 7.5e-3,
  1000: 2.4e-2 - past N ~ 150 the error grows (the thesis saw saturation above 50);
* operator (10 runs): alpha/s = 0.05: 0.85, 0.25: 5.1e-2, 0.5..64: <= 6e-3 (default 4:
  9.7e-4), 256: 5.9e-2; beta 0.1..10: <= 6.9e-3; gamma 0.1..10: 9.7e-4..1.1e-3 (gamma
  cancels in ``A' M = (A/alpha + beta)(D/alpha + beta)^-1``: no effect but the ridge);
* table1 (as in the test): 50 dB (3 runs) HD-PBSID 1.2e-3, Laguerre filters 1.1e-2,
  Laguerre projection 2.4e-3; 6 dB (8 runs) STD of the pair HD-PBSID 0.27 rad/s, filters
  2.5, projection 11.9 (100 runs: 0.31, 3.4, 11.0);
* quadrotor (q, theta outputs, 20 dB, N = 400): order 3 worst error 3.9 %; singular
  values 173, 102, 2.4, 0.65, ... (two dominant; the log-gap picks 2, not 3 or 4).
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
        runs=runs, snrs=(40.0, 0.0), methods=("hermite", "laguerre"), progress=False, out=tmp_path
    )
    for m in ("hermite", "laguerre"):
        # measured 3.1e-4 / 1.1e-4 at 40 dB (3 runs): accurate at low noise
        assert _row(res, snr_db=40.0, method=m)["median err"] < 1e-2
    h40 = _row(res, snr_db=40.0, method="hermite")["median err"]
    h0 = _row(res, snr_db=0.0, method="hermite")["median err"]
    # measured 2.0e-2 at 0 dB vs 3.1e-4 at 40 dB: 64x; 10x is the qualitative finding
    assert h0 > 10 * h40
    # ... but it degrades gracefully: no HD-PBSID run diverges even at 0 dB
    assert _row(res, snr_db=0.0, method="hermite")["divergent"] == 0
    assert (tmp_path / "snr.png").read_bytes()[:8] == PNG


def test_samples_error_decreases_with_samples() -> None:
    counts = (100, 300, 1000, 3000, 10000) if FULL else (100, 300, 10000)
    res = S.samples(runs=20 if FULL else 3, sample_counts=counts, progress=False)
    # 100 samples: N <= 50 Hermite functions cannot hold the record's band: every run fails
    assert _row(res, samples=100)["failed"] == _row(res, samples=100)["n"]
    e300 = _row(res, samples=300)["median err"]
    e10k = _row(res, samples=10000)["median err"]
    # measured 8.8e-3 (300) vs 2.6e-4 (10 000) with 3 runs: 34x; at least 5x
    assert e10k < e300 / 5


def test_basis_order_threshold_and_large_n() -> None:
    sizes = (10, 20, 30, 50, 60, 70, 80, 100, 150, 200, 300, 500, 1000) if FULL else (30, 100, 200)
    res = S.basis_order(runs=20 if FULL else 2, basis_sizes=sizes, progress=False)
    # N = 30 covers 2.7 rad/s < the 5.3 rad/s data bandwidth: refused, recorded as failure
    r30 = _row(res, N=30)
    assert r30["failed"] == r30["n"] and "ValueError" in r30["failures"][0]
    # N = 100 and 200: measured 5.9e-4 and 2.4e-3 median (2 runs); 1e-2 bounds both
    assert _row(res, N=100)["median err"] < 1e-2
    assert _row(res, N=200)["median err"] < 1e-2


@pytest.mark.slow
def test_basis_order_large_n_degrades() -> None:
    res = S.basis_order(runs=10 if FULL else 2, basis_sizes=(100, 1000), progress=False)
    # measured 5.9e-4 (N = 100) vs 1.3e-2 (N = 1000), 2 runs: the error grows with N
    # past ~150 (20 runs: 1.1e-3 vs 2.4e-2); 5x is well below the measured 23x
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
    # measured 5.4e-4 with the defaults (alpha = 4 s, beta = gamma = 1), 2 runs
    assert default < 5e-3
    # alpha = 0.05 s: A' = A/alpha + I is far outside the unit disc; measured 0.80
    assert _row(res, parameter="alpha/s", value=0.05)["median err"] > 0.2
    # beta 0.1..10 measured <= 7.9e-3: minimal impact (the thesis, §5); 3e-2 bounds it
    for b in (0.1, 10.0):
        assert _row(res, parameter="beta", value=b)["median err"] < 3e-2
    # gamma cancels from A'^j M^j; only the ridge sees it: measured 5.9e-4 / 7.3e-4 vs
    # 5.4e-4; 2x allows for the ridge's GCV choice on other records
    for g in (0.1, 10.0):
        assert _row(res, parameter="gamma", value=g)["median err"] < 2 * default + 1e-4


def test_table1_small(tmp_path: Path) -> None:
    methods = ("hermite", "laguerre", "laguerre-filter")
    # the thesis's comparison is of the subspace methods alone: refinement off (with the
    # default refinement all three reach the same prediction-error optimum)
    alone = {m: {"refine": None} for m in methods}
    res = S.table1(
        runs=20 if FULL else 3,
        snrs=(50.0,),
        methods=methods,
        options=alone,
        progress=False,
        out=tmp_path,
    )
    for m in methods:
        row = _row(res, snr_db=50.0, method=m)
        # measured 1.2e-3 (HD-PBSID), 2.4e-3 (projection), 1.1e-2 (filters) at 50 dB;
        # 3 % = "both accurate" (100 runs: 1.3e-3, 2.5e-3, 1.3e-2)
        assert row["failed"] == 0 and row["median err"] < 0.03, row
    # The effect (the thesis, Table 1): at 6 dB HD-PBSID's estimates of the oscillatory
    # pair scatter several times less than CT-PBSID's.  The Laguerre methods' estimates
    # there are bimodal: the pair is found (scatter ~0.5 rad/s projection, ~1 rad/s
    # filters) or lost to two real poles (errors 4-30 rad/s), and in about 1 run of 4
    # the mode is decided by rounding (OPENBLAS_CORETYPE=Prescott moved 2 of 8 runs per
    # method; HD-PBSID's estimates did not change).  So the STD over 3 runs depended on
    # the machine; over 8 runs (about half of them lost-pair runs, three of them the same
    # under both kernels) it stays far above 3x HD-PBSID's unless every run finds the
    # pair.  Measured over these 8 runs: STD of the pair 0.27 (HD-PBSID) vs 11.9
    # (projection) and 2.5-4.1 (filters), default and Prescott kernels.
    res6 = S.table1(
        runs=20 if FULL else 8,
        snrs=(6.0,),
        methods=methods,
        options=alone,
        progress=False,
        out=tmp_path,
    )
    h6 = _row(res6, snr_db=6.0, method="hermite")
    for m in ("laguerre", "laguerre-filter"):
        assert h6["std pair"] < _row(res6, snr_db=6.0, method=m)["std pair"] / 3, res6.summary
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
    # measured 3.9 % worst at 20 dB (runs 0-3: 1.0-5.7 %); 15 % catches a regression
    # while leaving room for the method work in progress
    assert m3["max_error"] < 0.15
    assert len(m4["eigenvalues"]) == 4 and len(m4["extra"]) == 1
    # the simulated-vs-measured check (Figure 2): measured VAF 99 % on both records
    assert min(m3["vaf_validation"]) > 90.0
    sv = np.array(r["singular_values"])
    # two dominant singular values (173, 102), then 2.4: the 3rd state is weak (a log-gap
    # rule picks 2), but the held-out simulation error of the models resolves it: order 3
    assert sv[1] / sv[2] > 10 and r["auto_order"] == 3
    # the one-standard-error rule's view of that choice (what the demo figure draws):
    # orders 1-2 more than one standard error worse than the best, an order-3 candidate
    # within it (the rows of the structure the direct term's judgement kept: the other
    # structure's candidates have no z)
    rows = [row for row in r["order_selection"] if row["z"] is not None]
    z = {o: min(row["z"] for row in rows if row["order"] == o) for o in (1, 2, 3)}
    assert z[1] > 1 and z[2] > 1 and z[3] <= 1, z
    for name in ("singular_values", "eigenvalues", "outputs", "bode"):
        assert (tmp_path / f"{name}.png").read_bytes()[:8] == PNG
    assert "fit valid" in res.table()
