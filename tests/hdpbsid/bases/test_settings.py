"""The shared settings of the basis methods: one object, validated once, same models."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hdpbsid import BasisSettings
from hdpbsid.bases.settings import SETTING_NAMES, resolve_settings
from hdpbsid.methods.hermite import identify_hermite
from hdpbsid.methods.laguerre import identify_laguerre
from hdpbsid.methods.sturm_liouville import identify_legendre
from hdpbsid.systems import add_noise, second_order, simulate_zoh

METHODS = [identify_hermite, identify_laguerre, identify_legendre]


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(3)
    t = np.arange(1500) * 0.01
    # a multisine inside the system's band (|lambda| = 2 rad/s): a few basis functions suffice
    u = sum(np.sin(w * t + rng.uniform(0, 2 * np.pi)) for w in (0.5, 1.3, 2.1, 3.4))[:, None]
    A, B, C, D = second_order()
    y, _ = add_noise(simulate_zoh(A, B, C, D, t, u), 30.0, rng)
    return t, u, y


@pytest.mark.parametrize(
    ("kwargs", "error", "text"),
    [
        ({"p": 0}, ValueError, "p must be"),
        ({"f": 2.5}, TypeError, "f must be"),
        ({"max_order": -1}, ValueError, "max_order"),
        ({"boundary": "yes"}, TypeError, "boundary must be True or False"),
        ({"regularize": "lasso"}, ValueError, "regularize"),
        ({"regularize": -1.0}, ValueError, "ridge parameter"),
        ({"input_hold": "cubic"}, ValueError, "input_hold must be one of"),
        ({"window": -3.0}, ValueError, "window must be a positive length"),
        ({"window": "long"}, ValueError, "window must be None, 'auto'"),
        ({"n_jobs": 0}, ValueError, "n_jobs"),
        ({"n_jobs": 1.5}, TypeError, "n_jobs"),
    ],
)
def test_bad_settings_raise_naming_the_argument(kwargs, error, text) -> None:
    with pytest.raises(error, match=text):
        BasisSettings(**kwargs)


def test_settings_are_frozen_and_defaults_resolved() -> None:
    s = BasisSettings()
    assert s.max_order >= 1 and s.p is None and s.window == "auto"
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.p = 3  # type: ignore[misc]


@pytest.mark.parametrize("method", METHODS, ids=lambda f: f.__name__)
def test_unknown_keyword_names_the_shared_settings(method, record) -> None:
    t, u, y = record
    with pytest.raises(TypeError, match="unexpected keyword argument.*bounday.*boundary"):
        method(t, u, y, 2, bounday=False)


@pytest.mark.parametrize("method", METHODS, ids=lambda f: f.__name__)
def test_object_and_keywords_give_the_same_model(method, record) -> None:
    t, u, y = record
    by_keywords = method(t, u, y, 2, p=3, input_hold="zoh")
    by_object = method(t, u, y, 2, settings=BasisSettings(p=3, input_hold="zoh"))
    # keywords override the object's fields: p=3 replaces p=2
    overridden = method(t, u, y, 2, settings=BasisSettings(p=2, input_hold="zoh"), p=3)
    for other in (by_object, overridden):
        # the same computation in the same order: identical to the last bit
        np.testing.assert_array_equal(other.A, by_keywords.A)
        np.testing.assert_array_equal(other.K, by_keywords.K)
    assert by_keywords.options["p"] == 3


def test_resolve_settings_rejects_other_objects() -> None:
    with pytest.raises(TypeError, match="settings must be a BasisSettings"):
        resolve_settings({"p": 3}, {}, "identify_hermite")  # type: ignore[arg-type]
    assert set(SETTING_NAMES) == {f.name for f in dataclasses.fields(BasisSettings)}
