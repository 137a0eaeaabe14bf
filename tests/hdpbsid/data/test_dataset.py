"""hdpbsid.data.records.Dataset: several records checked once at the front door and
passed down whole."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hdpbsid
from hdpbsid.data.records import Dataset, as_records, is_record_list
from hdpbsid.methods.registry import METHODS, register_method
from hdpbsid.systems.linear import simulate_zoh

A2 = np.array([[0.0, 1.0], [-9.0, -1.0]])
B2 = np.array([[0.0], [9.0]])
C2 = np.array([[1.0, 0.0]])
D2 = np.zeros((1, 1))


def _records(seed: int, k: int = 3, ns: int = 900) -> list[tuple]:
    """``k`` experiments on the same second-order system, each with its own absolute start
    and level; noise 2 % of the output's spread."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(k):
        t = 50.0 * i + np.arange(ns) * 0.02
        u = np.repeat(rng.choice([-1.0, 1.0], size=ns // 25 + 1), 25)[:ns, None]
        y = simulate_zoh(A2, B2, C2, D2, t, u)
        out.append((t, u, y + 0.02 * np.std(y) * rng.standard_normal(y.shape) + 1.0))
    return out


@settings(max_examples=25, deadline=None)
@given(
    starts=st.lists(st.floats(-1e6, 1e9, allow_nan=False), min_size=1, max_size=4),
    ns=st.integers(3, 40),
    seed=st.integers(0, 2**16),
)
def test_a_dataset_holds_the_records_the_list_form_gives(starts, ns, seed) -> None:
    rng = np.random.default_rng(seed)
    recs = [(t0 + 0.1 * np.arange(ns), rng.standard_normal(ns), rng.standard_normal((ns, 2)))
            for t0 in starts]  # fmt: skip
    data = Dataset.of(recs)
    expected = as_records(recs)
    assert len(data) == len(recs) and (data.m, data.l) == (1, 2)
    for got, want in zip(data.records, expected, strict=True):
        np.testing.assert_array_equal(got.t, want.t)
        np.testing.assert_array_equal(got.y, want.y)
        assert got.t0 == want.t0
    # passed down: the methods' as_records takes the records as they are, unchecked
    assert all(a is b for a, b in zip(as_records(data), data.records, strict=True))
    assert is_record_list(data) and isinstance(data[:1], Dataset)
    t0, u0, y0 = data[0]
    assert t0[0] == 0.0 and u0.shape == (ns, 1) and y0.shape == (ns, 2)


def test_bad_datasets_are_refused_naming_what_is_wrong() -> None:
    t = np.arange(10) * 0.1
    one = as_records(t, np.ones(10) * np.arange(10), np.sin(t))[0]
    two = as_records(t, np.ones((10, 2)), np.sin(t))[0]
    with pytest.raises(ValueError, match="at least one record"):
        Dataset(())
    with pytest.raises(ValueError, match=r"records\[1\]: has 2 input"):
        Dataset((one, two))
    with pytest.raises(TypeError, match=r"records\[0\] must be a Record"):
        Dataset(((t, t, t),))  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="u and y must be None"):
        as_records(Dataset((one,)), np.ones(10))
    with pytest.raises(ValueError, match="leave u and y out"):
        hdpbsid.identify(Dataset((one,)), np.ones(10), np.sin(t))
    # a method asking for more samples than a record has: the usual checks name it
    with pytest.raises(ValueError, match="record 0"):
        as_records(Dataset((one,)), min_samples=20)
    assert "1 records of 10 samples" in repr(Dataset((one,)))


def test_the_method_gets_the_records_checked_once_and_identify_takes_a_dataset() -> None:
    """``identify`` makes the Dataset of the detrended records and the method receives it
    (a user's method sees a Dataset, each record with its absolute start); and
    ``identify(dataset)`` is ``identify(list)`` of its records."""
    recs = _records(0)
    seen = []

    def spy(t, u=None, y=None, order=None, **options):
        seen.append(t)
        return hdpbsid.identify(list(t), order=order, method="dt", refine=None, detrend=None)

    register_method("spy-dataset", spy)
    try:
        hdpbsid.identify(recs, order=2, method="spy-dataset", refine=None)
    finally:
        METHODS.pop("spy-dataset", None)
    (data,) = seen
    assert isinstance(data, Dataset) and len(data) == 3
    assert [r.t0 for r in data.records] == [0.0, 50.0, 100.0]
    # detrended before the method (detrend="mean"): each record's output has mean zero,
    # to the rounding of a mean of 900 samples of size about 1
    assert all(abs(float(np.mean(r.y))) < 1e-12 for r in data.records)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from_list = hdpbsid.identify(recs, order=2, method="dt", refine=None)
        from_data = hdpbsid.identify(Dataset.of(recs), order=2, method="dt", refine=None)
    # the same records up to the relative time axis, rebuilt from relative times: its
    # spacing differs by rounding (1e-16 relative), far below the estimate's noise
    np.testing.assert_allclose(from_data.eigenvalues, from_list.eigenvalues, rtol=1e-9)
    assert from_data.n == 2 and isinstance(from_data.report.method, str)


@pytest.mark.parametrize("several", [False, True])
def test_the_dataset_a_method_gets_carries_labels_and_operating_points(several) -> None:
    """The Dataset made at the front door carries what the user named (channels, time
    unit) and, per record, the levels detrending removed: the record's own input and
    output means (detrend="mean"), computed here independently."""
    recs = _records(0)
    seen = []

    def fit(data, order=None, **options):
        seen.append(data)
        return hdpbsid.methods.registry.get_fit("dt")(data, order=order, **options)

    def door(t, u=None, y=None, order=None, **options):  # pragma: no cover - not called
        raise AssertionError("the package calls the Dataset function")

    door.fit = fit
    register_method("spy-labels", door)
    try:
        args = (recs,) if several else recs[0]
        hdpbsid.identify(
            *args, order=2, method="spy-labels", refine=None,
            input_names=["force"], output_names=["position"], time_unit="ms",
        )  # fmt: skip
    finally:
        METHODS.pop("spy-labels", None)
    (data,) = seen
    assert data.labels.inputs == ("force",) and data.labels.outputs == ("position",)
    assert data.labels.time_unit == "ms"
    for r, (_, u, y) in zip(data.records, recs if several else recs[:1], strict=True):
        u0, y0 = r.operating_point
        # a mean of 900 samples of size about 1: rounding far below 1e-12
        np.testing.assert_allclose(u0, np.mean(u, axis=0).ravel(), atol=1e-12)
        np.testing.assert_allclose(y0, np.mean(y, axis=0).ravel(), atol=1e-12)
