"""Tests of the machinery the basis-domain methods share (data: ``tests/basis_data.py``:
the second-order benchmark system (``A = [[0, 1], [-4, -0.8]]``,
eigenvalues ``-0.4 +- 1.9596i``), simulated exactly for an input linear between samples
(FOH, which is what trapezoid projection assumes), so noise-free errors measure the
method, not the data generator.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.signal import butter, filtfilt

from hdpbsid.bases.basis_domain import (
    BlockShift,
    SolveLag,
    _power_spectra,
    bandwidth,
    clip_basis_size,
    data_bandwidth,
    noise_floor,
)
from hdpbsid.methods.hermite import identify_hermite
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.systems import random_steps, second_order
from hdpbsid.systems.quadrotor import simulate_pitch_closed_loop


def test_solve_lag_matches_dense_powers() -> None:
    rng = np.random.default_rng(0)
    Mi = np.eye(6) + 0.3 * rng.standard_normal((6, 6))
    lag = SolveLag(lambda W: np.linalg.solve(Mi.T, W.T).T)
    W = rng.standard_normal((2, 6))
    M = np.linalg.inv(Mi)
    # rounding only: 3 solves with a well-conditioned 6x6 matrix
    np.testing.assert_allclose(lag.apply(W, 3), W @ M @ M @ M, atol=1e-12)
    np.testing.assert_allclose(lag.apply(W, 0), W, atol=0)
    valid = np.ones(6, dtype=bool)
    assert lag.valid_columns(valid, 2).all()
    valid[2] = False
    assert not lag.valid_columns(valid, 1).any()


def test_block_shift() -> None:
    W = np.arange(8.0)[None, :]
    out = BlockShift(4).apply(W, 1)
    np.testing.assert_array_equal(out, [[0, 0, 1, 2, 0, 4, 5, 6]])
    v = BlockShift(4).valid_columns(np.ones(8, dtype=bool), 2)
    np.testing.assert_array_equal(v, [0, 0, 1, 1, 0, 0, 1, 1])


def test_bandwidth_of_a_sine() -> None:
    t = np.linspace(0, 100, 10001)
    x = np.sin(3.0 * t)[:, None]
    # Hann-windowed FFT bin spacing is 2 pi / 100 = 0.063 rad/s; the main lobe is 2 bins
    assert abs(bandwidth(t, x) - 3.0) < 0.2
    y = x + 0.1 * np.random.default_rng(1).standard_normal(x.shape)  # SNR 17 dB
    # the output fraction (95 %) ignores the 2 % white noise power spread to Nyquist
    assert abs(data_bandwidth(t, x, y) - 3.0) < 0.2


@pytest.mark.parametrize("snr", [20.0, 10.0, 6.0])
def test_bandwidth_ignores_the_noise_floor_in_closed_loop(snr: float) -> None:
    clean = simulate_pitch_closed_loop(np.random.default_rng(0), snr_db=None)
    noisy = simulate_pitch_closed_loop(np.random.default_rng(0), snr_db=snr)
    reference = data_bandwidth(clean.t, clean.u, clean.y)  # noise-free: 22 rad/s
    # without the floor the outputs alone gave 509 rad/s at 10 dB (Nyquist is 785); with
    # it 20-21 rad/s; 15 % allows the few-bin spread of the 95 % band edge between records
    assert abs(data_bandwidth(noisy.t, noisy.u, noisy.y) / reference - 1) < 0.15
    if snr <= 10:
        assert bandwidth(noisy.t, noisy.y, 0.95, subtract_floor=False) > 2 * reference


def test_noise_floor_share_tells_white_from_band_limited() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 40.0, 0.01)
    white = rng.standard_normal((t.size, 1))
    smooth = random_steps(rng, t, hold=0.5)
    share = [noise_floor(_power_spectra(t, x)[1][:, 0])[1] for x in (white, smooth)]
    # white noise: the floor is the whole spectrum (share ~1, estimator spread ~5 %);
    # steps held 0.5 s: sinc^2 tails far below the band (measured 0.008)
    assert 0.8 < share[0] < 1.2 and share[1] < 0.05, share


def test_explicit_N_accepted_on_noisy_closed_loop_data() -> None:
    d = simulate_pitch_closed_loop(np.random.default_rng(1), snr_db=20.0)
    # N = 250 covers 3.6 * 250 / 30 = 30 rad/s > the 21 rad/s band; before the noise
    # floor was removed the band read 770 rad/s and any N < 6400 was refused
    m = identify_hermite(d.t, d.u, d.y, 3, N=250)
    assert m.options["N"] == 250


def test_clip_basis_size_warns_when_the_cap_binds() -> None:
    with pytest.warns(RuntimeWarning, match="asks for N = 5000"):
        N, rule = clip_basis_size(5000.0, 100, 4000, 100_000, "hermite", "rule")
    assert N == 4000 and "capped by the default cap" in rule
    with pytest.warns(RuntimeWarning, match="Ns/2"):
        N, _ = clip_basis_size(900.0, 100, 4000, 1000, "hermite", "rule")
    assert N == 500
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert clip_basis_size(42.0, 100, 4000, 1000, "hermite", "rule")[0] == 100


def test_hermite_default_N_follows_a_long_record() -> None:
    # 400 s of the second-order system: the rule asks for N ~ 2 * 7 * 400 / 3.6 ~ 1500,
    # beyond the former silent cap of 400 (which cost 9.4 % error at 10^5 samples)
    rng = np.random.default_rng(5)
    A, B, C, D = second_order()
    t = np.arange(0.0, 400.0, 0.05)
    u = filtfilt(*butter(4, 2 * 0.05), rng.standard_normal(t.size))[:, None]
    y = StateSpaceModel(A, B, C, D, np.zeros((2, 1))).simulate(t, u, method="foh")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no cap binds
        m = identify_hermite(t, u, y, 2, window=None)
    assert m.options["N"] > 1000
    # noise-free FOH data: exact to the projection precision (measured ~1e-5)
    assert eigenvalue_errors(m.eigenvalues, np.linalg.eigvals(A)).max() < 1e-3
    # the default cuts the record into windows of bounded N instead, as exact
    w = identify_hermite(t, u, y, 2)
    assert w.options["n_segments"] > 1 and w.options["N"] < m.options["N"]
    assert eigenvalue_errors(w.eigenvalues, np.linalg.eigvals(A)).max() < 1e-3
