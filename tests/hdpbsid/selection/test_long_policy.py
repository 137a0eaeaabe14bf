"""The policy of the bounded path (hdpbsid.selection.long_policy): one source of its numbers."""

from __future__ import annotations

import dataclasses

import pytest

from hdpbsid.selection import long_records
from hdpbsid.selection.long_policy import (
    CostModel,
    LongRecordPolicy,
    SkipReason,
    as_policy,
    whole_record_cost,
)


def test_former_constants_are_the_policy_defaults():
    policy = LongRecordPolicy()
    names = {
        "LONG_SAMPLES": "long_samples",
        "SELECTION_PERIODS": "selection_periods",
        "MIN_SELECTION_SAMPLES": "min_selection_samples",
        "MAX_SELECTION_SAMPLES": "max_selection_samples",
        "MEMORY_BUDGET": "memory_budget",
        "WORK_BUDGET": "work_budget",
        "REFINE_RELATIVE_STD": "refine_std",
        "MAX_REFINE_SAMPLES": "max_refine_samples",
    }
    for const, fld in names.items():
        assert getattr(long_records, const) == getattr(policy, fld)
        assert const in long_records.__all__
    # the re-exported classes are the policy module's
    assert long_records.LongRecordPolicy is LongRecordPolicy
    assert long_records.whole_record_cost is whole_record_cost


def test_cost_model_counts():
    costs = CostModel()
    assert whole_record_cost("hermite", 1000, 1, 2) == costs.cost("hermite", 1000, 1, 2)
    assert whole_record_cost("laguerre", 1000, 1, 1) == (256.0 * 1000 * 2, 0.0)
    mem, work = whole_record_cost("dt", 10**5, 1, 1)
    c = mem / (16.0 * 10**5)
    assert work == 2.0 * 10**5 * c**2
    assert whole_record_cost("unknown", 10**5, 1, 1) is None
    with pytest.raises(dataclasses.FrozenInstanceError):
        costs.linear_bytes_per_sample_channel = 1  # type: ignore[misc]


def test_plan_reasons():
    policy = LongRecordPolicy(memory_budget=2**20)
    plan = policy.plan(10**5, 1e-3, 1, 1, 2.0, 20.0, ["hermite", "dt", "foo"], False)
    assert plan.methods == ("hermite",)
    assert plan.streamed == ("hermite",)  # its in-memory fit would exceed the budget
    reasons = {s.method: s.reason for s in plan.skipped}
    assert reasons == {"dt": SkipReason.MEMORY, "foo": SkipReason.NO_COST_MODEL}
    chunked = policy.plan(10**5, 1e-3, 1, 1, 2.0, 20.0, ["hermite", "dt"], True)
    assert [s.reason for s in chunked.skipped] == [SkipReason.NOT_STREAMED]
    assert plan.as_dict()["skipped"][0]["reason"] == "memory"


def test_as_policy():
    assert as_policy(True) == LongRecordPolicy()
    with pytest.raises(TypeError):
        as_policy(3)
