"""Defaults that scale (hdpbsid.selection.long_records): the bounded path of ``identify``
on long records.

Small synthetic stand-ins of long records: the policy's thresholds are lowered through a
:class:`LongRecordPolicy` passed as ``long_record=`` (no constant is patched).  Oracles:
the true eigenvalues of the simulated resonance, the whole-record path of ``identify``
(``long_record=False``) on the same record, and hand counts of the policy's arithmetic.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from chunked_data import _record, _resonance

from hdpbsid import identify
from hdpbsid.bases.segments import WINDOW_PERIODS
from hdpbsid.data.chunked import ChunkedRecord
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.selection.long_records import (
    SELECTION_PERIODS,
    LongRecordPolicy,
    SkipReason,
    is_long,
    whole_record_cost,
)

NS = 12_000
#: a stand-in "long" record: 12 000 samples are long for this policy, the selection
#: segment at most 3000 of them, and dt's whole-record fit (77 MB by its cost model)
#: over the 32 MB budget, the windowed methods' (6 MB) under it
POLICY = LongRecordPolicy(
    long_samples=6000,
    min_selection_samples=1000,
    max_selection_samples=3000,
    memory_budget=32 * 2**20,
)


@pytest.fixture(scope="module")
def record():
    return _record(NS, seed=1)


def _quiet(*args, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return identify(*args, **kw)


def test_selection_periods_are_three_hdpbsid_windows():
    # two default windows to estimate, one to score (module docstring)
    assert SELECTION_PERIODS == 3 * WINDOW_PERIODS


def test_selection_samples_follow_the_periods_rule_within_bounds():
    p = LongRecordPolicy(min_selection_samples=1000, max_selection_samples=5000)
    # 30 periods of 2 Hz at 1 kHz: 15 000 samples, capped at 5000
    assert p.selection_samples(10**6, 1e-3, 2.0) == 5000
    # 30 periods of 10 Hz: 3000 samples, within the bounds
    assert p.selection_samples(10**6, 1e-3, 10.0) == 3000
    # 30 periods of 100 Hz: 300 samples, raised to the floor
    assert p.selection_samples(10**6, 1e-3, 100.0) == 1000
    # never more than the record
    assert p.selection_samples(800, 1e-3, 2.0) == 800


def test_dt_cost_model_counts_its_regressor():
    # p = min(200, 10^5 // (10 * 2)) = 200 lags of m + l = 2 channels: 400 columns;
    # 16 bytes per entry (the regressor and one QR copy), 2 Ns c^2 flops
    mem, flops = whole_record_cost("dt", 10**5, 1, 1)
    assert mem == 16 * 10**5 * 400
    assert flops == 2 * 10**5 * 400**2
    # a short record: p = 2000 // 20 = 100 lags
    assert whole_record_cost("dt", 2000, 1, 1)[0] == 16 * 2000 * 200
    assert whole_record_cost("my-own-method", 10**5, 1, 1) is None


def test_plan_skips_with_typed_reasons():
    p = LongRecordPolicy(memory_budget=2**30)
    methods = ["hermite", "laguerre", "dt", "mine"]
    plan = p.plan(10**6, 1e-3, 1, 1, 3.0, 22.0, methods, chunked=False)
    reasons = {s.method: s.reason for s in plan.skipped}
    assert reasons == {"dt": SkipReason.MEMORY, "mine": SkipReason.NO_COST_MODEL}
    assert plan.methods == ("hermite", "laguerre")
    a, b = plan.selection
    assert b - a == 10_000 and a == (10**6 - 10_000) // 2  # 30 periods of 3 Hz, the middle
    # dt under the memory budget but over the work budget (3.2e10 flops at 10^5)
    plan = p.plan(10**5, 1e-3, 1, 1, 3.0, 22.0, ["dt"], chunked=False)
    assert [s.reason for s in plan.skipped] == [SkipReason.WORK]
    # read in chunks: only the streamed core
    plan = p.plan(10**7, 1e-3, 1, 1, 3.0, 22.0, ["hermite", "laguerre"], chunked=True)
    assert plan.methods == ("hermite",) and plan.streamed == ("hermite",)
    assert [s.reason for s in plan.skipped] == [SkipReason.NOT_STREAMED]
    # in memory but too large for the in-memory fit: HD-PBSID streams
    plan = p.plan(10**7, 1e-3, 1, 1, 3.0, 22.0, ["hermite", "laguerre"], chunked=False)
    assert plan.streamed == ("hermite",)
    assert [s.reason for s in plan.skipped] == [SkipReason.MEMORY]


@pytest.mark.parametrize(
    "kw, name",
    [
        ({"long_samples": 0}, "long_samples"),
        ({"memory_budget": -1.0}, "memory_budget"),
        ({"refine_std": 0.0}, "refine_std"),
        ({"min_selection_samples": 5000, "max_selection_samples": 4000}, "min_selection"),
    ],
)
def test_policy_rejects_bad_settings(kw, name):
    with pytest.raises(ValueError, match=name):
        LongRecordPolicy(**kw)


def test_long_record_must_be_a_policy(record):
    t, u, y = record
    with pytest.raises(TypeError, match="long_record"):
        identify(t, u, y, long_record={"long_samples": 10})


def test_is_long_only_for_auto_on_one_long_record(record):
    t, u, y = record
    assert is_long(t, u, y, "auto", POLICY)
    assert not is_long(t, u, y, "hermite", POLICY)  # a method asked for: whole record
    assert not is_long(t, u, y, "auto", False)
    assert not is_long(t, u, y, "auto", None)  # 12 000 samples: short by default
    assert not is_long([(t, u, y)], None, None, "auto", POLICY)


def test_long_default_call_reports_what_it_skipped(record):
    """The default call on the stand-in takes the bounded path: dt skipped for memory
    (row in the selection table with the reason), the selection on a segment, the right
    order, the eigenvalues of the truth."""
    t, u, y = record
    m = _quiet(t, u, y, long_record=POLICY, max_order=4)
    info = m.options["long_record"]
    assert [s["method"] for s in info["skipped"]] == ["dt"]
    assert info["skipped"][0]["reason"] == "memory"
    rows = [r for r in m.options["selection"] if r["method"] == "dt"]
    assert len(rows) == 1 and rows[0]["status"].startswith("skipped: memory: ")
    a, b = info["selection"]
    assert 1000 <= b - a <= 3000 < NS
    assert all(r["method"] != "dt" for r in m.options["selection"] if r["status"] == "ok")
    assert m.n == 2
    # 20 dB on 12 000 samples: the estimates' std is ~0.03 % (the refinement's reported
    # eigenvalue_std); 1 % is the accuracy the bounded path must keep, > 30 std
    assert eigenvalue_errors(m.eigenvalues, np.linalg.eigvals(_resonance())).max() < 0.01
    assert "refine_rule" in m.options and info["refine_samples"][0] == b - a


def test_bounded_path_refits_the_choice_on_the_whole_record(record):
    """With one method, the bounded path chooses the order on the segment and fits it on
    the whole record: the same order as the whole-record path, and the same call on the
    same samples, so the same eigenvalues to rounding."""
    t, u, y = record
    kw = {"refine": None, "max_order": 4, "methods": ["laguerre"]}
    bounded = _quiet(t, u, y, long_record=POLICY, **kw)
    whole = _quiet(t, u, y, long_record=False, **kw)
    assert "long_record" in bounded.options and "long_record" not in whole.options
    assert bounded.n == whole.n == 2
    # same fit of the same samples: rounding only (different BLAS paths, 1e-9 relative)
    ev_b, ev_w = np.sort_complex(bounded.eigenvalues), np.sort_complex(whole.eigenvalues)
    np.testing.assert_allclose(ev_b, ev_w, rtol=1e-9)


def test_bounded_and_whole_record_paths_agree(record):
    """Every method: the same order as the whole-record path, eigenvalues within the
    statistical resolution of the record."""
    t, u, y = record
    kw = {"max_order": 4, "methods": ["hermite", "laguerre", "legendre"]}
    bounded = _quiet(t, u, y, long_record=POLICY, **kw)
    whole = _quiet(t, u, y, long_record=False, **kw)
    assert bounded.n == whole.n == 2
    # two consistent estimates from the same record: each within a few standard
    # deviations of the truth, the whole-record refinement's reported std sigma; the
    # bounded one saw at least a quarter of the samples (std <= 2 sigma), so their
    # difference is within 4 sqrt(sigma^2 + (2 sigma)^2) < 9 sigma
    sigma = float(np.max(whole.options["eigenvalue_std"]))
    ev_b, ev_w = np.sort_complex(bounded.eigenvalues), np.sort_complex(whole.eigenvalues)
    assert np.max(np.abs(ev_b - ev_w)) < 9 * sigma


def test_chunked_record_uses_the_streamed_core(record, capsys):
    t, u, y = record
    rec = ChunkedRecord.from_arrays(u - u.mean(), y - y.mean(), float(t[1] - t[0]))
    m = _quiet(rec, max_order=4, long_record=POLICY, refine=None, progress=True)
    # the bar over the stages, and the passes over the record in samples
    err = capsys.readouterr().err
    assert "identify: done" in err and "sample" in err
    info = m.options["long_record"]
    assert info["chunked"] and info["methods"] == ("hermite",)
    assert {s["reason"] for s in info["skipped"]} == {"not streamed"}
    assert m.options["long_record_fit"].startswith("streamed core")
    assert m.n == 2
    # 20 dB, 12 000 samples, subspace fit: errors ~0.1 %; 2 % is > 10x that
    assert eigenvalue_errors(m.eigenvalues, np.linalg.eigvals(_resonance())).max() < 0.02


def test_chunked_record_rejects_linear_detrend(record):
    t, u, y = record
    rec = ChunkedRecord.from_arrays(u, y, float(t[1] - t[0]))
    with pytest.raises(ValueError, match="detrend='linear'"):
        identify(rec, detrend="linear")


def test_cli_progress_is_automatic_for_long_records():
    from hdpbsid.cli import _progress
    from hdpbsid.data.io import Record
    from hdpbsid.selection.long_records import LONG_SAMPLES

    def rec(ns):
        return Record(np.arange(ns) * 1e-3, None, np.zeros((ns, 1)), [], ["y"], "t", "x")

    # pytest captures stderr: not a terminal, so only the length decides "auto"
    assert _progress("auto", [rec(LONG_SAMPLES + 1)])
    assert not _progress("auto", [rec(100)])
    assert not _progress("off", [rec(LONG_SAMPLES + 1)])
    assert _progress("on", [rec(100)])
