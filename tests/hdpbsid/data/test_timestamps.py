"""Absolute timestamps: one uniformity test whose tolerance is the rounding of the stamps
(hdpbsid.data.checks.is_uniform, and its copy in slbasis), and the same model from the same
record stamped from t = 0 or with Unix time."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hdpbsid
from hdpbsid.data.checks import check_uniform, is_uniform, time_resolution, uniform_tolerance
from hdpbsid.systems import random_steps, second_order, simulate_zoh
from slbasis.numeric.projection import _is_uniform as slbasis_is_uniform

UNIX = 1.7e9  # a Unix time stamp of 2023: ulp 2.4e-7 s


@settings(max_examples=60, deadline=None)
@given(
    dt=st.floats(1e-3, 10.0),
    ns=st.integers(3, 5000),
    t0=st.one_of(st.just(0.0), st.floats(-2e9, 2e9)),
)
def test_a_shifted_uniform_grid_is_uniform_for_both_packages(dt: float, ns: int, t0: float):
    # the stamps t0 + k dt as a logger writes them: each rounded once to the ulp of t
    t = t0 + np.arange(ns) * dt
    if not np.all(np.diff(t) > 0):
        return  # dt below the stamps' resolution: not a time axis
    assert is_uniform(t)
    assert slbasis_is_uniform(t)
    # the sampling interval, relative to t[0], to the stamps' resolution
    assert abs(check_uniform(t) - dt) <= time_resolution(t) / (ns - 1) + 1e-12 * dt


@settings(max_examples=40, deadline=None)
@given(t0=st.one_of(st.just(0.0), st.just(UNIX)), k=st.integers(1, 98))
def test_a_grid_jittered_beyond_the_tolerance_is_not_uniform(t0: float, k: int):
    # one sample moved by 1e-3 of the step (30 ulps at 1.7e9 with dt = 0.01, far beyond
    # the stamps' rounding; 1000 times the relative tolerance)
    t = t0 + np.arange(100) * 0.01
    t[k] += 1e-5
    assert not is_uniform(t)
    assert not slbasis_is_uniform(t)
    with pytest.raises(ValueError, match="uniformly sampled"):
        check_uniform(t)


def test_the_tolerance_is_the_relative_one_plus_the_stamps_rounding():
    t = UNIX + np.arange(10) * 0.01
    assert uniform_tolerance(t, 0.01) == pytest.approx(1e-6 * 0.01 + 2 * time_resolution(t))
    assert time_resolution(t) == pytest.approx(2 * np.spacing(UNIX))
    # from t = 0 the rounding term is negligible: the relative tolerance decides
    assert uniform_tolerance(t - UNIX, 0.01) == pytest.approx(1e-8, rel=1e-6)


def _record(seed: int = 2, T: float = 30.0, dt: float = 0.02):
    A, B, C, D = second_order()
    t = np.arange(int(round(T / dt)) + 1) * dt
    rng = np.random.default_rng(seed)
    u = random_steps(rng, t, 0.2)
    y = simulate_zoh(A, B, C, D, t, u)
    return t, u, y + 0.03 * np.std(y) * rng.standard_normal(y.shape)


def _identify(t, u, y, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return hdpbsid.identify(t, u, y, **kw)


#: eigenvalues of the record stamped from Unix time against the same record from 0: the
#: stamps at 1.7e9 are rounded to 2.4e-7 s, 1.2e-5 of the 0.02 s step; the uniform paths
#: see only the mean step (1e-9 relative), the basis projections of non-uniform form would
#: see each stamp's rounding, first order in it
EIG_RTOL = 1e-4


@pytest.mark.parametrize("method", ["dt", "hermite", "laguerre", "legendre", "chebyshev"])
def test_unix_stamps_give_the_model_of_the_record_from_zero(method: str):
    t, u, y = _record()
    kw = {"order": 2, "method": method, "refine": None}
    ref = _identify(t, u, y, **kw)
    unix = _identify(t + UNIX, u, y, **kw)
    assert unix.options["method"] == ref.options["method"]
    np.testing.assert_allclose(
        np.sort_complex(unix.eigenvalues), np.sort_complex(ref.eigenvalues), rtol=EIG_RTOL
    )


def test_unix_stamps_give_the_auto_choice_of_the_record_from_zero():
    t, u, y = _record()
    ref = _identify(t, u, y)
    unix = _identify(t + UNIX, u, y)
    assert (unix.options["method"], unix.n) == (ref.options["method"], ref.n)
    # refined by the prediction-error method on both: the same optimum to its tolerance
    # (a tenth of a standard deviation of the estimate, hdpbsid.refine.pem.STALL_SD)
    np.testing.assert_allclose(
        np.sort_complex(unix.eigenvalues), np.sort_complex(ref.eigenvalues), rtol=1e-3
    )
