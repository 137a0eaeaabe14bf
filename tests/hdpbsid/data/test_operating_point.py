"""Operating points: identify(..., detrend=...), model u0/y0/trend, the list front end."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from hdpbsid.data.records import Dataset
from hdpbsid.identify import identify
from hdpbsid.methods.dt import identify_dt
from hdpbsid.methods.registry import METHODS
from hdpbsid.models.model import LinearTrend, StateSpaceModel
from hdpbsid.systems import add_noise, random_steps, second_order, simulate_zoh

REG = sys.modules["hdpbsid.methods.registry"]
DATA = Path(__file__).resolve().parents[3] / "bench" / "data"


@pytest.fixture(scope="module")
def ball_and_beam() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    d = np.loadtxt(DATA / "ball-and-beam.csv", delimiter=",", skiprows=1)
    return 0.1 * np.arange(d.shape[0]), d[:, 0], d[:, 1]  # dt = 0.1 s (DaISy)


@pytest.mark.parametrize("method", ["hermite", "dt"])
def test_shifted_record_gives_the_same_eigenvalues(ball_and_beam, method: str) -> None:
    t, u, y = ball_and_beam
    ref = identify(t, u, y, order=2, method=method).eigenvalues
    for shift in (5.0, 100.0):
        ev = identify(t, u + shift, y + shift, order=2, method=method).eigenvalues
        # the detrended data differ from the unshifted ones only by the rounding of
        # (x + s) - mean(x + s): ~ s * eps = 2e-14 against std(u) = 9e-3, a relative
        # perturbation ~1e-12 that the order-2 estimate amplifies by its conditioning
        # (measured 8e-14 .. 7e-13 absolute); 1e-8 is rounding-level, far below the 0.4-1 rad/s
        # changes the shift caused before detrending
        np.testing.assert_allclose(ev, ref, rtol=1e-8, atol=1e-10)
    # without detrending the shift changes the model (the defect this guards against)
    with pytest.warns(UserWarning, match="dominates its variation"):
        ev5 = identify(t, u + 5.0, y + 5.0, order=2, method=method, detrend=None).eigenvalues
    assert np.max(np.abs(ev5 - ref)) > 0.05


def test_levels_stored_and_used_by_simulate_fit_predict() -> None:
    A, B, C, D = second_order()
    rng = np.random.default_rng(5)
    t = np.arange(0.0, 30.0, 0.02)
    u = random_steps(rng, t, hold=0.4)
    y, _ = add_noise(simulate_zoh(A, B, C, D, t, u), 30.0, rng)
    ua, ya = u + 3.0, y - 7.0
    m = identify(t, ua, ya, order=2, method="dt")
    # the stored levels are the record's means (an independent computation)
    np.testing.assert_allclose(m.u0, ua.mean(axis=0), rtol=0, atol=1e-15 * 3)
    np.testing.assert_allclose(m.y0, ya.mean(axis=0), rtol=0, atol=1e-15 * 7)
    # the same matrices without levels: absolute simulation = deviation simulation + y0
    dev = StateSpaceModel(m.A, m.B, m.C, m.D, m.K)
    ys_abs = m.simulate(t, ua)
    ys_dev = dev.simulate(t, ua - m.u0)
    # same arithmetic up to the order of the subtraction: rounding of ~1e-13 on outputs ~1
    np.testing.assert_allclose(ys_abs, ys_dev + m.y0, rtol=0, atol=1e-10)
    f_abs = m.fit(t, ua, ya)
    f_dev = dev.fit(t, ua - m.u0, ya - m.y0)
    np.testing.assert_allclose(f_abs.y_sim, f_dev.y_sim + m.y0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(f_abs.vaf, f_dev.vaf, rtol=0, atol=1e-8)
    p_abs = m.predict(t, ua, ya, k=3)
    p_dev = dev.predict(t, ua - m.u0, ya - m.y0, k=3)
    np.testing.assert_allclose(p_abs, p_dev + m.y0, rtol=0, atol=1e-9)
    # the identified model explains the absolute record (30 dB: VAF ~99.9 %)
    assert f_abs.vaf[0] > 99.0
    # exports describe deviations: scipy's lsim of u - u0 plus y0 equals simulate (foh)
    from scipy.signal import lsim

    _, y_lsim, _ = lsim(m.to_scipy(), ua[:, 0] - m.u0[0], t)
    # lsim and the exact augmented exponential agree to integration rounding (~1e-12)
    np.testing.assert_allclose(y_lsim + m.y0[0], m.simulate(t, ua, method="foh")[:, 0], atol=1e-8)


def test_predict_one_step_equals_kalman_recursion_and_large_k_simulation() -> None:
    # an oracle written out by hand: discrete predictor from c2d of (A, B, K)
    from hdpbsid.models.conversion import c2d

    A, B, C, D = second_order()
    K = np.array([[0.3], [0.5]])
    m = StateSpaceModel(A, B, C, D, K, u0=[1.5], y0=[-2.0])
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 10.0, 0.05)
    u = 1.5 + random_steps(rng, t, hold=0.3)
    y = -2.0 + rng.standard_normal((t.size, 1))
    Ad, Bd, _, _, Kd = c2d(A, B, C, D, K, 0.05)
    x = np.zeros(2)
    ref = np.empty_like(y)
    for j in range(t.size):
        ud = u[j] - 1.5
        ref[j] = C @ x + D @ ud - 2.0
        x = Ad @ x + Bd @ ud + Kd @ (y[j] + 2.0 - C @ x - D @ ud)
    # same recursion, different summation order: rounding only
    np.testing.assert_allclose(m.predict(t, u, y, k=1, x0="zero"), ref, atol=1e-12)
    # with k beyond the record length the predictor never sees a measurement: simulation
    np.testing.assert_allclose(
        m.predict(t, u, y, k=t.size, x0="zero"), m.simulate(t, u), atol=1e-12
    )


def test_linear_trend_is_stored_and_put_back() -> None:
    A, B, C, D = second_order()
    rng = np.random.default_rng(8)
    t = np.arange(0.0, 30.0, 0.02)
    u = random_steps(rng, t, hold=0.4)
    y, _ = add_noise(simulate_zoh(A, B, C, D, t, u), 30.0, rng)
    drift_u, drift_y = 0.05, -0.2  # per time unit
    ua, ya = u + 1.0 + drift_u * t[:, None], y + 2.0 + drift_y * t[:, None]
    m = identify(t, ua, ya, order=2, method="dt", detrend="linear")
    assert isinstance(m.trend, LinearTrend)
    assert m.trend.t_ref == pytest.approx(t.mean())
    # the least-squares lines, computed independently by numpy.polyfit (same problem,
    # another algorithm: agreement to rounding, 1e-9 relative)
    assert m.trend.u_slope[0] == pytest.approx(np.polyfit(t, ua[:, 0], 1)[0], rel=1e-9)
    assert m.trend.y_slope[0] == pytest.approx(np.polyfit(t, ya[:, 0], 1)[0], rel=1e-9)
    U0, Y0 = m.operating_point(t)
    np.testing.assert_allclose(U0[:, 0], m.u0[0] + m.trend.u_slope[0] * (t - t.mean()))
    # simulating the absolute record restores the drift: VAF stays near the 30 dB level
    assert m.fit(t, ua, ya).vaf[0] > 99.0


def test_list_of_one_record_equals_the_record(ball_and_beam) -> None:
    t, u, y = ball_and_beam

    def stacked(t, u, y, order=None, **options):
        # stand-in for a method that accepts several records (identify gives them as a
        # Dataset, checked once): one record only here
        assert u is None and y is None and isinstance(t, Dataset)
        (tt, uu, yy), *rest = t
        assert not rest
        return identify_dt(tt, uu, yy, order=order, **options)

    METHODS["stacked-test"] = stacked
    try:
        m1 = identify([(t, u, y)], order=2, method="stacked-test")
    finally:
        del METHODS["stacked-test"]
    m = identify(t, u, y, order=2, method="dt", refine=None)  # a list is not refined
    np.testing.assert_array_equal(m1.A, m.A)
    np.testing.assert_array_equal(m1.u0, m.u0)
    np.testing.assert_array_equal(m1.y0, m.y0)


def test_several_records_detrended_each_and_weighted_levels(monkeypatch) -> None:
    monkeypatch.setattr(REG, "METHODS", dict(METHODS))
    seen = []

    def fake(t, u, y, order=None, **options):
        seen.extend(t)
        return StateSpaceModel(np.zeros((1, 1)), np.zeros((1, 1)), np.ones((1, 1)), None, None)

    REG.METHODS["fake-list"] = fake
    rng = np.random.default_rng(0)
    recs = []
    for n, (lu, ly) in ((100, (1.0, -3.0)), (300, (5.0, 2.0))):
        t = np.arange(n) * 0.1
        recs.append((t, lu + rng.standard_normal(n), ly + rng.standard_normal(n)))
    m = identify(recs, order=1, method="fake-list")
    for (_t, u, y), (_ts, us, ys) in zip(recs, seen, strict=True):
        # each record detrended by its OWN mean (to rounding of the subtraction)
        np.testing.assert_allclose(us[:, 0], u - u.mean(), atol=1e-14)
        np.testing.assert_allclose(ys[:, 0], y - y.mean(), atol=1e-14)
    wu = (100 * recs[0][1].mean() + 300 * recs[1][1].mean()) / 400
    wy = (100 * recs[0][2].mean() + 300 * recs[1][2].mean()) / 400
    # sample-weighted mean of the records' means; same sums in another order: rounding
    np.testing.assert_allclose(m.u0, [wu], rtol=1e-14)
    np.testing.assert_allclose(m.y0, [wy], rtol=1e-14)
    assert [op["samples"] for op in m.options["operating_points"]] == [100, 300]
    with pytest.raises(ValueError, match="same channels"):
        two_inputs = (recs[1][0], np.c_[recs[1][1], recs[1][1]], recs[1][2])
        identify([recs[0], two_inputs], order=1, method="fake-list")
    with pytest.raises(ValueError, match="record 1"):
        identify([recs[0], (recs[1][0][::-1], recs[1][1], recs[1][2])], method="fake-list")
    with pytest.raises(ValueError, match="leave u and y out"):
        identify(recs, recs[0][1], method="fake-list")
    with pytest.raises(ValueError, match="refine needs a single record"):
        identify(recs, method="fake-list", refine="pem")
    with pytest.raises(ValueError, match="empty"):
        identify([], method="fake-list")


def test_bad_detrend_and_no_warning_for_small_levels(ball_and_beam) -> None:
    t, u, y = ball_and_beam
    with pytest.raises(ValueError, match="detrend must be one of"):
        identify(t, u, y, 2, method="dt", detrend="quadratic")
    with pytest.raises(ValueError, match="y is required"):
        identify(t, u, method="dt")
    # the record as measured: |mean| < std on both channels, so no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        identify(t, u, y, 2, method="dt", detrend=None)
    with pytest.raises(ValueError, match="u0 must have 1 entries"):
        StateSpaceModel(np.eye(1), np.ones((1, 1)), np.ones((1, 1)), None, None, u0=[1.0, 2.0])
