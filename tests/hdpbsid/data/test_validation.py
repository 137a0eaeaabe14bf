"""Bad inputs get clear errors naming the argument (docs/user-guide.md, "Data conventions")."""

import numpy as np
import pytest

from hdpbsid import StateSpaceModel, c2d, identify_discrete, identify_dt
from hdpbsid.data.checks import check_data, check_state_space, check_uniform
from hdpbsid.systems import random_steps, second_order, simulate_zoh


@pytest.fixture(scope="module")
def record():
    rng = np.random.default_rng(11)
    A, B, C, D = second_order()
    t = np.arange(400) * 0.05
    u = random_steps(rng, t, 0.1)
    y = simulate_zoh(A, B, C, D, t, u)
    return t, u, y


def test_valid_shapes_are_normalised(record):
    t, u, y = record
    t2, u2, y2 = check_data(list(t), u[:, 0], y[:, 0])
    assert t2.shape == (400,) and u2.shape == (400, 1) and y2.shape == (400, 1)
    t3, u3, _ = check_data(t, None, y)
    assert u3.shape == (400, 0)


@pytest.mark.parametrize(
    ("t_bad", "match"),
    [
        (np.zeros((400, 1)), r"t must be a 1-D array of shape \(Ns,\)"),
        (np.r_[0.0, np.nan, np.arange(2, 400) * 0.05], r"t must be finite.*NaN"),
        (np.r_[np.arange(200) * 0.05, np.arange(200) * 0.05], r"t must be strictly increasing"),
        (np.r_[0.0, 0.0, np.arange(2, 400) * 0.05], r"duplicate times at indices 0 and 1"),
    ],
)
def test_bad_time(record, t_bad, match):
    _, u, y = record
    with pytest.raises(ValueError, match=match):
        identify_dt(t_bad, u, y)


@pytest.mark.parametrize("second", [400, 333])
def test_records_given_as_lists_of_arrays_say_how_to_pass_several(record, second):
    """``identify([t1, t2], [u1, u2], [y1, y2])`` (equal or ragged lengths, default
    method included) names ``t`` and says how several records are passed, before any
    fit."""
    from hdpbsid import identify

    t, u, y = record
    with pytest.raises(ValueError, match=r"t must be .* list of \(t, u, y\) tuples"):
        identify([t, t[:second]], [u, u[:second]], [y, y[:second]], order=2)


def test_bad_signals(record):
    t, u, y = record
    with pytest.raises(ValueError, match=r"u must have 400 rows .* got shape \(399, 1\)"):
        identify_dt(t, u[:-1], y)
    with pytest.raises(ValueError, match=r"did you pass the transpose"):
        identify_dt(t, u.T, y)
    y_inf = y.copy()
    y_inf[5, 0] = np.inf
    with pytest.raises(ValueError, match=r"y must be finite.*inf at index \(5, 0\)"):
        identify_dt(t, u, y_inf)
    with pytest.raises(ValueError, match=r"y must have shape \(Ns,\) or \(Ns, channels\)"):
        identify_dt(t, u, y[:, :, None])
    with pytest.raises(TypeError, match=r"u must be real-valued"):
        identify_dt(t, u + 1j, y)
    with pytest.raises(TypeError, match=r"y must be an array of real numbers"):
        identify_dt(t, u, np.array(["a"] * 400))
    with pytest.raises(ValueError, match=r"u\[:, 0\] is identically zero"):
        identify_dt(t, np.zeros_like(u), y)


def test_non_uniform_time_names_max_deviation(record):
    t, u, y = record
    t_bad = t.copy()
    t_bad[100:] += 0.01  # one step of 0.06 instead of 0.05
    with pytest.raises(ValueError, match=r"uniformly sampled.*deviates .* by up to 0\.01"):
        identify_dt(t_bad, u, y)
    # float round-off of np.arange is not "non-uniform"
    assert check_uniform(np.arange(10_000) * 0.01) == pytest.approx(0.01)


def test_order_and_window_too_large(record):
    t, u, y = record
    with pytest.raises(ValueError, match=r"p=300 is too large for the data"):
        identify_dt(t, u, y, order=2, p=300)
    with pytest.raises(ValueError, match=r"f <= p, got f=8 > p=4"):
        identify_dt(t, u, y, order=2, p=4, f=8)
    with pytest.raises(ValueError, match=r"order=6 needs f\*l >= 6, but f\*l = 3\*1 = 3"):
        identify_dt(t, u, y, order=6, p=5, f=3)
    with pytest.raises(ValueError, match=r"record is too short for order=30"):
        identify_dt(t, u, y, order=30)
    with pytest.raises(TypeError, match=r"order must be an integer, got float"):
        identify_dt(t, u, y, order=2.0)
    with pytest.raises(ValueError, match=r"order must be an integer >= 1, got 0"):
        identify_dt(t, u, y, order=0)
    with pytest.raises(ValueError, match=r"regularize must be False/'none', True/'gcv'"):
        identify_dt(t, u, y, order=2, regularize="lcurve")
    with pytest.raises(ValueError, match=r"ridge parameter\) must be >= 0"):
        identify_dt(t, u, y, order=2, regularize=-1.0)


def test_discrete_entry_point_checks():
    with pytest.raises(ValueError, match=r"y must have at least one output channel"):
        identify_discrete(np.ones((50, 1)), np.ones((50, 0)))


def test_state_space_shapes():
    A, B, C, D = second_order()
    with pytest.raises(ValueError, match=r"A must be square"):
        check_state_space(np.ones((2, 3)), B, C)
    with pytest.raises(ValueError, match=r"B must have shape \(2, \*\), got \(3, 1\)"):
        StateSpaceModel(A, np.ones((3, 1)), C, D, np.zeros((2, 1)))
    with pytest.raises(ValueError, match=r"K must have shape \(2, 1\)"):
        StateSpaceModel(A, B, C, D, np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"dt must be a positive finite sampling interval"):
        c2d(A, B, C, D, None, 0.0)
    model = StateSpaceModel(A, B, C, D, np.zeros((2, 1)))
    with pytest.raises(ValueError, match=r"u must have 1 column\(s\)"):
        model.simulate(np.arange(5.0), np.ones((5, 2)))
    with pytest.raises(ValueError, match=r"x0 must have 2 entries"):
        model.simulate(np.arange(5.0), np.ones(5), x0=[1.0])
    with pytest.raises(ValueError, match=r"method must be 'zoh' or 'foh'"):
        model.simulate(np.arange(5.0), np.ones(5), method="cubic")


def test_discrete_option_checks():
    rng = np.random.default_rng(12)
    u, y = rng.standard_normal((300, 1)), rng.standard_normal((300, 1))
    with pytest.raises(ValueError, match=r"p_criterion must be 'aic' or 'bic', got 'hqc'"):
        identify_discrete(u, y, order=1, p_criterion="hqc")
    with pytest.raises(ValueError, match=r"dt must be a positive finite sampling interval"):
        identify_discrete(u, y, order=1, dt=-1.0)
    with pytest.raises(ValueError, match=r"order selection needs f\*l >= 2 singular values"):
        identify_discrete(u, y, p=1)
