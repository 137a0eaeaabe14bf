"""Benchmark systems and data generators."""

import numpy as np
import pytest
from scipy import signal

from hdpbsid.systems import (
    add_noise,
    pbsid_example,
    random_steps,
    second_order,
    simulate_pbsid_closed_loop,
    simulate_zoh,
)


def test_system_eigenvalues():
    A = second_order()[0]
    # quoted: -0.4 +- 1.9596i (to the 4 printed decimals)
    np.testing.assert_allclose(
        np.sort_complex(np.linalg.eigvals(A)), [-0.4 - 1.9596j, -0.4 + 1.9596j], atol=5e-5
    )
    Ad = pbsid_example()[0]
    np.testing.assert_allclose(np.abs(np.linalg.eigvals(Ad)), 0.67 * np.sqrt(2), rtol=1e-14)


def test_closed_loop_generator_against_open_loop_simulation():
    d = simulate_pbsid_closed_loop(np.random.default_rng(0), N=500, noise_std=0.7)
    A, B, C, D, K = pbsid_example()
    # the controller u = r - 0.25 y holds exactly
    np.testing.assert_allclose(d["u"], d["r"] - 0.25 * d["y"], atol=1e-12)
    # replaying (u, e) through the open-loop innovation model reproduces y (scipy dlsim)
    ol = (A, np.hstack([B, K]), C, np.hstack([D, np.eye(2)]), 1.0)
    _, y, _ = signal.dlsim(ol, np.hstack([d["u"], d["e"]]))
    # loop vs open-loop replay of a stable system: rounding accumulation only
    np.testing.assert_allclose(d["y"], y, atol=1e-9)
    # e has the requested standard deviation (500 x 2 samples: ~3 % sampling error)
    assert np.std(d["e"]) == pytest.approx(0.7, rel=0.1)
    assert d["t"].shape == (500,)


def test_add_noise_snr():
    rng = np.random.default_rng(1)
    y = np.column_stack([np.sin(np.linspace(0, 300, 200_000)), 5 + np.zeros(200_000)])
    yn, v = add_noise(y, 20.0, rng)
    np.testing.assert_array_equal(yn, y + v)
    snr = 10 * np.log10(np.mean(y**2, axis=0) / np.mean(v**2, axis=0))
    # 2e5 samples: noise power known to sqrt(2/N) = 0.3 % -> 0.014 dB; 0.05 dB tolerance
    np.testing.assert_allclose(snr, 20.0, atol=0.05)
    yn1, v1 = add_noise(y[:, 0], 10.0, rng)
    assert yn1.shape == (200_000,)
    with pytest.raises(ValueError, match="snr_db must be finite"):
        add_noise(y, np.inf, rng)


def test_random_steps_and_zoh_simulation():
    rng = np.random.default_rng(2)
    t = np.arange(100) * 0.05
    u = random_steps(rng, t, 0.25)
    # piecewise constant on blocks of 5 samples
    assert np.all(u.reshape(20, 5)[:, 1:] == u.reshape(20, 5)[:, :1])
    A, B, C, D = second_order()
    y = simulate_zoh(A, B, C, D, t, u)
    _, y_ref, _ = signal.lsim((A, B, C, D), u[:, 0], t, interp=False)
    # both exact ZOH discretisations: rounding level
    np.testing.assert_allclose(y[:, 0], y_ref, atol=1e-12)
    with pytest.raises(ValueError, match="hold must be > 0"):
        random_steps(rng, t, 0.0)
