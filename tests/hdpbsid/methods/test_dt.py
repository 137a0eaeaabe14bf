"""Method "dt": PBSID on samples + exact d2c, on the second-order benchmark system."""

import numpy as np
import pytest

import hdpbsid
from hdpbsid import StateSpaceModel, identify_dt
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.systems import add_noise, random_steps, second_order, simulate_zoh

TRUE = np.array([-0.4 + np.sqrt(3.84) * 1j, -0.4 - np.sqrt(3.84) * 1j])  # -0.4 +- 1.9596i


def record(seed, dt=0.05, T=40.0, hold=0.25):
    """ZOH-sampled response to a random piecewise-constant input (levels held `hold` s)."""
    rng = np.random.default_rng(seed)
    A, B, C, D = second_order()
    t = np.arange(int(round(T / dt))) * dt
    u = random_steps(rng, t, hold)
    return t, u, simulate_zoh(A, B, C, D, t, u), rng


@pytest.mark.parametrize("order", [2, None])
def test_noise_free_second_order(order):
    t, u, y, _ = record(0)
    m = identify_dt(t, u, y, order=order)
    assert isinstance(m, StateSpaceModel) and m.n == 2
    err = eigenvalue_errors(m.eigenvalues, TRUE)
    # spec: <= 1e-3.  Noise-free ZOH data make every step exact, so only round-off
    # remains (measured ~1e-14); 1e-8 still leaves a wide margin for BLAS differences
    assert err.max() < 1e-8
    # the u -> y behaviour matches as well: frequency response vs the true system
    A, B, C, D = second_order()
    w = np.logspace(-1, 1, 20)
    G = np.array([(C @ np.linalg.solve(1j * wk * np.eye(2) - A, B) + D)[0, 0] for wk in w])
    np.testing.assert_allclose(m.frequency_response(w)[0, 0], G, rtol=1e-8)  # same reason
    fit = m.fit(t, u, y)
    assert fit.vaf[0] > 100 - 1e-8


def test_options_report_every_default():
    t, u, y, _ = record(1)
    m = identify_dt(t, u, y)
    o = m.options
    for key in (
        "method",
        "p",
        "f",
        "order",
        "order_selected",
        "order_criterion",
        "max_order",
        "feedthrough",
        "regularize",
        "ridge",
        "stable_k",
        "k_method",
        "normalize",
        "input_scale",
        "output_scale",
        "p_rule",
        "f_rule",
        "dt",
        "n_samples",
        "d2c",
    ):
        assert key in o, key
    assert o["method"] == "dt" and o["dt"] == pytest.approx(0.05)
    assert o["order_selected"] and o["order"] == 2 and o["f"] == o["p"]
    assert o["p"] * 2 <= 800 / 10  # the documented default rule p (m + l) <= Ns / 10
    # the sampled model is kept and maps to the continuous one by exp(lambda dt)
    np.testing.assert_allclose(
        np.sort_complex(np.exp(m.eigenvalues * 0.05)),
        np.sort_complex(m.discrete.eigenvalues),
        atol=1e-12,  # expm/logm round trip, rounding level
    )
    assert "StateSpaceModel(continuous, n=2" in repr(m)


def test_noisy_second_order():
    t, u, y, rng = record(2)
    y_noisy, _ = add_noise(y, 20.0, rng)
    m = identify_dt(t, u, y_noisy)
    assert m.n == 2
    err = eigenvalue_errors(m.eigenvalues, TRUE)
    # SNR 20 dB, 800 samples: measured 0.63 % here, median 0.2 % over 10 seeds (bench);
    # 2 % allows for the estimator's spread (~N^-1/2) without hiding a bias
    assert err.max() < 0.02


def test_scaling_of_signals_does_not_change_eigenvalues():
    t, u, y, rng = record(3)
    y_noisy, _ = add_noise(y, 30.0, rng)
    a = identify_dt(t, u, y_noisy, order=2, p=15)
    b = identify_dt(t, 1e3 * u, 1e-2 * y_noisy, order=2, p=15)
    # normalisation makes the problem invariant to channel units: rounding-level agreement
    np.testing.assert_allclose(
        np.sort_complex(a.eigenvalues), np.sort_complex(b.eigenvalues), rtol=1e-9
    )
    # ... and the gains scale back: frequency responses differ by the unit factor 1e-5
    w = np.array([0.5, 2.0])
    np.testing.assert_allclose(b.frequency_response(w), 1e-5 * a.frequency_response(w), rtol=1e-8)


def test_regularised_and_stable_k_variants():
    t, u, y, rng = record(4)
    y_noisy, _ = add_noise(y, 20.0, rng)
    m = identify_dt(t, u, y_noisy, order=2, regularize="gcv", stable_k=True)
    assert m.options["regularize"] == "gcv" and m.options["ridge"] > 0
    assert m.options["k_method"] == "riccati"
    # Riccati K gives a stable continuous predictor A - K C (Hurwitz)
    assert np.max(np.linalg.eigvals(m.A - m.K @ m.C).real) < 0
    # same accuracy band as the unregularised estimate at SNR 20 dB (see test above)
    assert eigenvalue_errors(m.eigenvalues, TRUE).max() < 0.02


def test_feedthrough_estimated_when_present():
    rng = np.random.default_rng(8)
    A, B, C, _ = second_order()
    D = np.array([[0.7]])
    t = np.arange(600) * 0.05
    u = random_steps(rng, t, 0.05)
    y = simulate_zoh(A, B, C, D, t, u)
    m = identify_dt(t, u, y, order=2, feedthrough=True)
    # noise-free and exact model structure: round-off only
    np.testing.assert_allclose(m.D, D, atol=1e-8)
    assert eigenvalue_errors(m.eigenvalues, TRUE).max() < 1e-8


def test_time_series_without_input():
    """u=None: a noise-driven AR process; the model has m = 0 inputs."""
    rng = np.random.default_rng(9)
    e = rng.standard_normal(3000)
    y = np.zeros(3000)
    for k in range(2, 3000):
        y[k] = 1.5 * y[k - 1] - 0.7 * y[k - 2] + e[k]
    m = hdpbsid.identify_discrete(None, y, order=2)
    assert m.m == 0
    # AR(2) poles 0.75 +- 0.37i; 3000 samples, relative spread ~ 1/sqrt(N) ~ 2 %
    true = np.roots([1, -1.5, 0.7])
    assert eigenvalue_errors(m.eigenvalues, true).max() < 0.05


def test_no_continuous_model_gives_clear_error():
    """A sign-alternating sampled mode (eigenvalue near -0.8) has no real logarithm."""
    rng = np.random.default_rng(10)
    u = rng.standard_normal(2000)
    y = np.zeros(2000)
    for k in range(1, 2000):
        y[k] = -0.8 * y[k - 1] + u[k - 1]
    t = np.arange(2000) * 0.1
    with pytest.raises(ValueError, match=r"cannot be converted to continuous time.*negative real"):
        identify_dt(t, u, y, order=1)


def test_fast_sampled_chirp_benchmark():
    """Chirp benchmark: dt = 0.01, 40 s, 0.05-2 Hz chirp (where N4SID/MOESP fail)."""
    from scipy.signal import chirp

    A, B, C, D = second_order()
    t = np.arange(4000) * 0.01
    u = chirp(t, 0.05, 40.0, 2.0)
    y = simulate_zoh(A, B, C, D, t, u)
    m = identify_dt(t, u, y)
    assert m.n == 2
    # noise-free, spec 1e-3: measured 2e-8; fast sampling makes the past regressors
    # nearly collinear (singular values 210 ... 2e-11), and the GCV ridge (2e-12) filters
    # at that rounding level, so errors of ~1e-8 (not 1e-14) are expected
    assert eigenvalue_errors(m.eigenvalues, TRUE).max() < 1e-6
    y40, _ = add_noise(y, 40.0, np.random.default_rng(1))
    m40 = identify_dt(t, u, y40, order=2)
    assert m40.options["regularize"] == "gcv" and m40.options["ridge"] > 0
    # SNR 40 dB: measured 0.02 % with the GCV ridge default (plain LS: > 1000 %);
    # 1 % separates "works" from the unregularised failure mode by orders of magnitude
    assert eigenvalue_errors(m40.eigenvalues, TRUE).max() < 0.01


def test_window_bounds_are_the_default_rule():
    """default_windows applies WindowBounds, and p_rule names them."""
    from hdpbsid.methods.dt import P_CAP, SAMPLES_PER_REGRESSOR, WindowBounds, default_windows

    bounds = WindowBounds()
    assert (bounds.samples_per_regressor, bounds.p_cap) == (SAMPLES_PER_REGRESSOR, P_CAP)
    assert default_windows(100_000, 1, 1, 2, 10, None, None) == (2, bounds.p_cap)
    assert default_windows(1200, 1, 1, 2, 10, None, None)[1] == 1200 // (10 * 2)
