"""hdpbsid.methods.registry: the two call shapes of a method -- the public front door
``identify_<name>(t, u, y, ...)`` and the package's ``fit_<name>(data: Dataset, ...)`` --
give the same model, and a user's front-door-only method keeps getting the arrays."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import hdpbsid
from hdpbsid.data.records import Dataset
from hdpbsid.methods.registry import (
    LAZY_METHODS,
    METHODS,
    FrontDoor,
    call_method,
    dataset_call,
    get_fit,
    get_method,
    register_method,
)
from hdpbsid.systems.linear import simulate_zoh

A2 = np.array([[0.0, 1.0], [-9.0, -1.0]])
B2 = np.array([[0.0], [9.0]])
C2 = np.array([[1.0, 0.0]])
D2 = np.zeros((1, 1))


def _record(seed: int = 0, ns: int = 1200, start: float = 1000.0):
    """A noisy second-order record with an absolute start (its stamps are not ``k h``)."""
    rng = np.random.default_rng(seed)
    t = start + np.arange(ns) * 0.02
    u = np.repeat(rng.choice([-1.0, 1.0], size=ns // 25 + 1), 25)[:ns, None]
    y = simulate_zoh(A2, B2, C2, D2, t - start, u)
    return t, u, y + 0.02 * np.std(y) * rng.standard_normal(y.shape)


def _same(a, b) -> None:
    for k in "ABCDK":
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))


def test_every_built_in_method_has_its_dataset_function() -> None:
    for name in LAZY_METHODS:
        fit = get_fit(name)
        assert fit is get_method(name).fit and fit.__name__ == f"fit_{name}"


@pytest.mark.parametrize("name", ["dt", "hermite", "laguerre", "legendre", "jacobi"])
def test_the_front_door_is_the_dataset_function_on_the_record(name: str) -> None:
    """Bit for bit: the front door only makes the Dataset of its arguments."""
    t, u, y = _record()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        front = get_method(name)(t, u, y, order=2)
        inside = get_fit(name)(Dataset.of(t, u, y), order=2)
    _same(front, inside)
    assert front.options.keys() == inside.options.keys()


def test_a_front_door_only_method_gets_the_arrays_it_always_got() -> None:
    """A user's method registered with ``func(t, u, y, ...)``: ``identify`` hands it the
    record's arrays (not rebuilt from the Dataset: the absolute stamps bit for bit), the
    selection its estimation part's, and ``get_fit`` wraps it in a :class:`FrontDoor`."""
    t, u, y = _record(1)
    seen = []

    def mine(t, u=None, y=None, order=None, **options):
        seen.append(np.array(t, copy=True))
        return get_method("dt")(t, u, y, order=order)

    register_method("mine-front-door", mine)
    try:
        assert isinstance(get_fit("mine-front-door"), FrontDoor)
        assert isinstance(dataset_call(mine), FrontDoor)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            hdpbsid.identify(t, u, y, order=2, method="mine-front-door", refine=None, detrend=None)
            np.testing.assert_array_equal(seen[-1], t)
            hdpbsid.identify(
                t, u, y, order=2, method="auto", methods=["mine-front-door"], refine=None
            )
    finally:
        METHODS.pop("mine-front-door", None)
    # method="auto" selects on the record's relative times (as it always did): the sweep's
    # candidate on the estimation part, then its refit on the whole record
    split = int(round(t.size * (1.0 - 1.0 / 3.0)))
    assert seen[1][0] == 0.0 and seen[1].size == split and seen[-1].size == t.size


def test_call_method_makes_the_dataset_only_for_a_dataset_function() -> None:
    t, u, y = _record(2)
    made = []

    def data():
        made.append(1)
        return Dataset.of(t, u, y)

    out = call_method(lambda t, u, y, order=None: (t, order), (t, u, y), data, order=3)
    assert out[0] is t and out[1] == 3 and not made
    model = call_method(get_method("dt"), (t, u, y), data, order=2)
    assert made == [1] and model.n == 2
