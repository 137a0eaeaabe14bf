"""Quadrotor pitch benchmark (ANT-X drone at hover): model, closed loop, data."""

from __future__ import annotations

import numpy as np
import pytest

from hdpbsid import identify_dt
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.systems.quadrotor import (
    PitchData,
    pitch_excitation,
    pitch_model,
    pitch_output_matrices,
    simulate_pitch_closed_loop,
)


def _design_matrix() -> np.ndarray:
    # the model's published numbers, typed independently of hdpbsid.systems.quadrotor
    Xu, Xq, Mu, Mq, g = -0.1068, 0.1192, -5.9755, -2.6478, 9.81
    return np.array([[Xu, Xq, -g], [Mu, Mq, 0.0], [0.0, 1.0, 0.0]])


def test_open_loop_eigenvalues_match_design() -> None:
    A, B, C, D = pitch_model()
    np.testing.assert_array_equal(A, _design_matrix())
    np.testing.assert_array_equal(B, [[-10.1647], [450.7085], [0.0]])
    ev = np.linalg.eigvals(A)
    ref = np.linalg.eigvals(_design_matrix())
    # same matrix, so pairing must be exact up to eigvals rounding (~1e-15 relative)
    assert np.max(eigenvalue_errors(ev, ref)) < 1e-12
    # the eigenvalues as quoted to 3 significant digits: -2.92 +- 3.24i, +3.08
    quoted = np.array([-2.92 + 3.24j, -2.92 - 3.24j, 3.08])
    assert np.max(np.abs(np.sort_complex(ev) - np.sort_complex(quoted))) < 5e-3
    # the unstable real pole, to 1e-3 against the literal matrix
    assert abs(ev[np.argmax(ev.real)].real - 3.0844) < 1e-3


def test_output_matrices() -> None:
    C, D, names = pitch_output_matrices(("q", "theta", "a_x"))
    assert names == ("q", "theta", "a_x")
    np.testing.assert_array_equal(C, [[0, 1, 0], [0, 0, 1], [-0.1068, 0.1192, 0]])
    np.testing.assert_array_equal(D, [[0], [0], [-10.1647]])
    with pytest.raises(ValueError, match="outputs"):
        pitch_output_matrices(("q", "pitch"))
    with pytest.raises(ValueError, match="outputs"):
        pitch_output_matrices(())


def test_closed_loop_stable_no_saturation_and_noise_free() -> None:
    d = simulate_pitch_closed_loop(np.random.default_rng(0), duration=20.0, snr_db=None)
    assert isinstance(d, PitchData)
    ns = int(round(20.0 * 250)) + 1
    assert d.t.shape == (ns,) and d.u.shape == (ns, 1) and d.y.shape == (ns, 2)
    np.testing.assert_allclose(np.diff(d.t), 0.004, rtol=1e-9)  # 250 Hz controller
    # bounded: the open-loop +3.08 pole would grow by e^(3.08*20) ~ 1e26 if unstabilised
    assert np.max(np.abs(d.x_clean)) < 1.0
    # the nominal sweep stays far from the +-1 moment limit
    assert d.saturation_fraction == 0.0
    assert np.max(np.abs(d.u)) < 0.2
    np.testing.assert_array_equal(d.y, d.y_clean)  # snr_db=None: no noise at all
    np.testing.assert_allclose(d.y[:, 0], d.x_clean[:, 1])
    # the last few seconds after the sweep are not asked for; the state at the end is
    # still small (closed loop settles) -- regulation error stays below 0.1 rad
    assert np.max(np.abs(d.theta_clean)) < 0.1


def test_plant_is_exact_between_controller_samples() -> None:
    # with the total moment as a ZOH input the open-loop model reproduces the states
    # exactly (matrix exponential both ways; round-off ~1e-12 relative to the states)
    from hdpbsid.systems import simulate_zoh

    d = simulate_pitch_closed_loop(
        np.random.default_rng(1), duration=5.0, snr_db=None, excitation="3211"
    )
    A, B, C, D = pitch_model()
    x = simulate_zoh(A, B, C, D, d.t, d.u)
    # the open-loop simulation is unstable (+3.08), so round-off grows by e^(3.08*5)~5e6
    np.testing.assert_allclose(x, d.x_clean, atol=1e-6 * np.max(np.abs(d.x_clean)))


def test_saturation_is_reported() -> None:
    exc = pitch_excitation("3211", np.arange(1251) * 0.004, amplitude=2.0)
    d = simulate_pitch_closed_loop(
        np.random.default_rng(2), duration=5.0, snr_db=None, excitation=exc
    )
    assert d.saturation_fraction > 0.0
    assert np.max(np.abs(d.u)) <= 1.0  # applied moment clipped to +-1 (the saturation)


def test_noise_at_requested_snr_and_reproducible() -> None:
    rng = np.random.default_rng(3)
    d = simulate_pitch_closed_loop(rng, duration=30.0, snr_db=20.0)
    for clean, meas in ((d.q_clean, d.q), (d.theta_clean, d.theta)):
        noise = meas - clean
        snr = 10 * np.log10(np.mean(clean**2) / np.mean(noise**2))
        # Ns = 7501 white samples: the noise power estimate has relative std
        # sqrt(2/Ns) ~ 1.6 % (0.07 dB); feedback of the noise changes the clean power by
        # well under 1 %, so 0.5 dB is a > 5-sigma bound
        assert abs(snr - 20.0) < 0.5
    d2 = simulate_pitch_closed_loop(np.random.default_rng(3), duration=30.0, snr_db=20.0)
    np.testing.assert_array_equal(d.y, d2.y)
    np.testing.assert_array_equal(d.u, d2.u)
    d3 = simulate_pitch_closed_loop(np.random.default_rng(4), duration=30.0, snr_db=20.0)
    assert not np.array_equal(d.y, d3.y)


def test_velocity_loop_and_a_x_output() -> None:
    d = simulate_pitch_closed_loop(
        np.random.default_rng(5),
        duration=10.0,
        snr_db=None,
        velocity_loop=True,
        u_ref=0.5,
        outputs=("q", "a_x"),
    )
    assert d.outputs == ("q", "a_x")
    np.testing.assert_allclose(d.y[:, 1], d.x_clean @ d.C[1] + d.u[:, 0] * d.D[1, 0])
    # the velocity PI pulls u towards 0.5 m/s: it ends closer than it started
    assert abs(d.x_clean[-1, 0] - 0.5) < 0.5
    assert np.max(np.abs(d.x_clean)) < 5.0


def test_bad_arguments() -> None:
    rng = np.random.default_rng(6)
    with pytest.raises(TypeError, match="rng"):
        simulate_pitch_closed_loop(42)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="excitation"):
        simulate_pitch_closed_loop(rng, excitation="chirp")
    with pytest.raises(ValueError, match="excitation array"):
        simulate_pitch_closed_loop(rng, duration=1.0, excitation=np.zeros(10))
    with pytest.raises(ValueError, match="controller"):
        simulate_pitch_closed_loop(rng, controller={"kp": 1.0})
    with pytest.raises(ValueError, match="diverged"):
        simulate_pitch_closed_loop(
            rng,
            duration=20.0,
            snr_db=None,
            controller={"k_theta": 0.0, "kp_q": 0.0, "ki_q": 0.0, "kd_q": 0.0},
        )


@pytest.mark.parametrize("excitation", ["sweep", "3211"])
def test_identify_dt_recovers_open_loop_from_noise_free_closed_loop(excitation: str) -> None:
    d = simulate_pitch_closed_loop(
        np.random.default_rng(7), duration=20.0, snr_db=None, excitation=excitation
    )
    m = identify_dt(d.t, d.u, d.y, order=3)
    err = eigenvalue_errors(m.eigenvalues, d.true_eigenvalues)
    # measured ~1e-11 (noise-free ZOH data, exact d2c); 1e-6 leaves room for LAPACK
    # differences while being far below the 1e-3 accuracy target
    assert np.max(err) < 1e-6
    assert np.any(np.abs(m.eigenvalues - 3.0844) < 1e-3)  # the unstable pole is found
