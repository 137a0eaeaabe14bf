"""Frequency-response estimates, coherence and confidence against simulated systems with a
known frequency response, and models identified from frequency data."""

from __future__ import annotations

import numpy as np
import pytest

import hdpbsid
from hdpbsid.design import inputs
from hdpbsid.frequency import fit as frequency
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.systems import add_noise, second_order, simulate_zoh

DT = 0.01


def second_order_sampled():
    A, B, C, D = second_order()
    return StateSpaceModel(A, B, C, D, np.zeros((2, 1))).to_discrete(DT)


# -- Welch / H1 -------------------------------------------------------------------------
def test_h1_within_1db_and_5deg_where_coherent() -> None:
    """Second-order system (2 rad/s, damping 0.2), random binary input, 20 dB output
    noise.  A random binary held on the samples makes the sampled (ZOH) model the exact
    truth.  Segments of 4096 samples resolve the resonance (half-power bandwidth 0.8 rad/s,
    0.15 rad/s per line; the Hann window's bias there is ~(1/3)(B_e / B_r)^2 ~ 3 %,
    Bendat & Piersol eq. 8.141) and 1200 s give ~54 effective averages: at coherence 0.9
    the phase's standard deviation is sqrt(0.1 / (2 54 0.9)) = 1.8 deg."""
    rng = np.random.default_rng(0)
    d = inputs.random_binary(120_000, DT, rng=rng)
    A, B, C, D = second_order()
    y, _ = add_noise(simulate_zoh(A, B, C, D, d.t, d.u), 20.0, rng)
    est = frequency.frf_welch(d.u, y, DT, nperseg=4096)
    truth = second_order_sampled().frequency_response(est.w)[0, 0]
    H = est.H[0, 0]
    good = est.coherence[0] > 0.9
    assert good.sum() > 40  # the band up to ~10 rad/s
    assert np.max(np.abs(20 * np.log10(np.abs(H / truth)))[good]) < 1.0
    assert np.max(np.abs(np.degrees(np.angle(H / truth)))[good]) < 5.0
    # the 95 % circles cover the truth: on ~2000 nearly independent lines the fraction
    # has standard deviation 0.5 %; 0.9 is far below any run's value, yet far above the
    # coverage of circles with a variance that is wrong by a factor 2 (~0.78)
    cover = np.abs(H - truth) < est.confidence_radius(0.05)[0, 0]
    assert 0.9 < cover.mean() < 0.99


def test_h1_of_a_static_mimo_map_is_exact() -> None:
    rng = np.random.default_rng(2)
    M = np.array([[1.0, -2.0], [0.5, 3.0]])
    d = inputs.random_binary(4096, DT, rng=rng, channels=2)
    est = frequency.frf_welch(d.u, d.u @ M.T, DT, nperseg=512)
    # linear in the data: rounding only
    np.testing.assert_allclose(est.H, np.broadcast_to(M[:, :, None], est.H.shape), atol=1e-10)
    np.testing.assert_allclose(est.coherence, 1.0, atol=1e-10)


def test_effective_averages_of_hann_at_half_overlap() -> None:
    """A periodic Hann window of even length L overlaps its half-shift with correlation
    sum sin^2 cos^2 / sum sin^4 = (L / 16) / (3 L / 8) = 1/6 (Harris 1978: 16.7 %), and only
    neighbours overlap: n = K / (1 + 2 (1 - 1/K) / 36)."""
    from scipy.signal import get_window

    L, K = 256, 10
    got = frequency.effective_averages(get_window("hann", L), L // 2, K)
    assert got == pytest.approx(K / (1 + 2 * (1 - 1 / K) / 36), rel=1e-12)
    assert frequency.effective_averages(np.ones(L), L, K) == K


def test_coherence_bounds_cover_a_known_coherence() -> None:
    """``y = u + e`` with white ``u`` and ``e`` of variance ``s2``: the coherence is
    ``1 / (1 + s2)`` on every line."""
    rng = np.random.default_rng(4)
    s2 = 0.5
    u = rng.standard_normal(2**17)
    y = u + np.sqrt(s2) * rng.standard_normal(u.size)
    est = frequency.frf_welch(u, y, 1.0, nperseg=1024, window="boxcar", noverlap=0)
    lo, hi = est.coherence_bounds(0.05)
    true = 1 / (1 + s2)
    inside = (lo[0] <= true) & (true <= hi[0])
    # 512 independent lines (no overlap, boxcar): coverage 0.95 +- 0.01
    assert 0.9 < inside.mean() < 0.99
    np.testing.assert_allclose(np.median(est.coherence[0]), true, rtol=0.02)


def test_reference_estimate_is_consistent_in_closed_loop() -> None:
    """P control ``u = r - 3 y_meas`` of the sampled second-order system with measurement
    noise fed back: H1 tends to the noise path (``-1/3``), ``S_yr / S_ur`` to the plant."""
    dm = second_order_sampled()
    n = 120_000
    rng = np.random.default_rng(0)
    r = rng.standard_normal(n)
    v = 0.2 * rng.standard_normal(n)
    x = np.zeros(2)
    u, y = np.zeros(n), np.zeros(n)
    for k in range(n):
        y[k] = dm.C[0] @ x + v[k]
        u[k] = r[k] - 3.0 * y[k]
        x = dm.A @ x + dm.B[:, 0] * u[k]
    h1 = frequency.frf_welch(u, y, DT, nperseg=4096)
    ref = frequency.frf_welch(u, y, DT, r=r, nperseg=4096)
    truth = dm.frequency_response(ref.w)[0, 0]
    band = ref.w < 10.0
    cover_ref = (np.abs(ref.H[0, 0] - truth) < ref.confidence_radius()[0, 0])[band]
    cover_h1 = (np.abs(h1.H[0, 0] - truth) < h1.confidence_radius()[0, 0])[band]
    assert ref.method == "welch-reference"
    assert cover_ref.mean() > 0.85  # ~65 lines: coverage 0.95 +- 0.027
    assert cover_h1.mean() < 0.5  # biased: its circles miss the plant


def test_welch_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match="samples"):
        frequency.frf_welch(np.ones(100), np.ones(99), DT)
    with pytest.raises(ValueError, match="nperseg"):
        frequency.frf_welch(np.ones(100), np.ones(100), DT, nperseg=200)
    with pytest.raises(ValueError, match="dt"):
        frequency.frf_welch(np.ones(100), np.ones(100), -1.0)
    with pytest.raises(ValueError, match="r must have"):
        frequency.frf_welch(np.ones((100, 2)), np.ones(100), DT, r=np.ones(100))


# -- periodic ---------------------------------------------------------------------------------
def _periodic_record(periods: int, snr: float | None, seed: int, channels: int = 1):
    A, B, C, D = second_order()
    n = 2048
    d = inputs.multisine(n, DT, (0.05, 5.0), periods=periods, channels=channels, iterations=50)
    if channels == 2:  # a 2-input plant: the same dynamics, second input scaled by -2
        B = np.hstack([B, -2.0 * B])
        D = np.zeros((1, 2))
    y = simulate_zoh(A, B, C, D, d.t, d.u)
    noise = np.zeros_like(y)
    if snr is not None:
        y, noise = add_noise(y, snr, np.random.default_rng(seed))
    return d, y, StateSpaceModel(A, B, C, D, np.zeros((2, 1))).to_discrete(DT), noise


def test_periodic_noise_free_is_exact() -> None:
    """Steady state after 6 skipped periods (the transient decays as exp(-0.4 t), 1e-21 of
    its start after 123 s): the lines are the sampled system's response to rounding."""
    d, y, dm, noise = _periodic_record(8, None, 0)
    est = frequency.frf_periodic(d.u, y, DT, d.period, skip=6)
    np.testing.assert_array_equal(est.options["lines"][0], d.lines[0])
    truth = dm.frequency_response(est.w)
    np.testing.assert_allclose(est.H, truth, rtol=1e-9)  # FFT rounding on O(1) lines
    # two noise-free periods agree: the variance is rounding
    assert np.max(est.variance / np.abs(truth) ** 2) < 1e-20


def test_periodic_two_inputs_on_interleaved_lines() -> None:
    d, y, dm, noise = _periodic_record(8, None, 0, channels=2)
    est = frequency.frf_periodic(d.u, y, DT, d.period, skip=6)
    truth = dm.frequency_response(est.w)
    for j in range(2):
        on = np.isin(est.w, 2 * np.pi * d.lines[j] / (d.period * DT))
        np.testing.assert_allclose(est.H[0, j, on], truth[0, j, on], rtol=1e-9)
        assert np.all(np.isnan(est.H[0, j, ~on]))


def test_periodic_noise_variance_from_periods() -> None:
    """20 dB output noise over 10 periods: the 95 % circles (F(2, 18)) cover the truth."""
    d, y, dm, noise = _periodic_record(16, 20.0, 7)
    est = frequency.frf_periodic(d.u, y, DT, d.period, skip=6)
    assert est.dof == 18
    truth = dm.frequency_response(est.w)[0, 0]
    cover = np.abs(est.H[0, 0] - truth) < est.confidence_radius(0.05)[0, 0]
    # ~100 independent lines: coverage 0.95 +- 0.022
    assert 0.85 < cover.mean() <= 1.0
    # white noise of variance s2 puts N s2 on each DFT line of a period, N s2 / P on the
    # average of P periods: var H = N s2 / (P |U_k|^2).  Each line's estimate scatters
    # as chi2(18) / 18 (23 % deviation at the median); the median of ~100 lines within 15 %
    s2 = float(np.var(noise))
    U = np.fft.rfft(d.u[: d.period, 0])[d.lines[0]]
    expected = d.period * s2 / (10 * np.abs(U) ** 2)
    np.testing.assert_allclose(np.median(est.variance[0, 0] / expected), 1.0, rtol=0.15)


def test_periodic_rejects_bad_records() -> None:
    with pytest.raises(ValueError, match="whole periods"):
        frequency.frf_periodic(np.ones(100), np.ones(100), DT, 60, skip=1)
    u = np.tile(np.cos(2 * np.pi * 3 * np.arange(50) / 50), 3)
    with pytest.raises(ValueError, match="two inputs"):
        frequency.frf_periodic(np.stack([u, u], 1), u, DT, 50)


# -- identification from frequency data ------------------------------------------------------
def _rao_garnier():
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "bench"))
    from cases import rao_garnier_system

    A, B, C, D = rao_garnier_system()
    return StateSpaceModel(A, B, C, D, np.zeros((4, 1)))


def test_subspace_start_is_exact_without_noise() -> None:
    true = _rao_garnier()
    w = np.logspace(-1, 2, 50)
    H = true.frequency_response(w)
    model = frequency.identify_frequency(w, H, order=4, refine=False)
    # noise-free data lie in the model class: the subspace step is exact to rounding
    # (conditioning of the two decades between the modes costs a few digits)
    np.testing.assert_allclose(model.frequency_response(w), H, rtol=1e-7)
    err = hdpbsid.eigenvalue_errors(model.eigenvalues, true.eigenvalues)
    assert err.max() < 1e-7


def test_mimo_frequency_data_noise_free() -> None:
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "bench"))
    from cases import mimo_2x2_system

    A, B, C, D = mimo_2x2_system()
    true = StateSpaceModel(A, B, C, D, np.zeros((4, 2)))
    w = np.logspace(-1, 2, 80)
    model = frequency.identify_frequency(w, true.frequency_response(w), order=4)
    err = hdpbsid.eigenvalue_errors(model.eigenvalues, true.eigenvalues)
    assert err.max() < 1e-6  # exact data: rounding and the refinement's tolerance


def test_rao_garnier_from_noisy_frf_points() -> None:
    """200 log-spaced points with 1 % complex (relative) noise: the held-out lines choose
    order 4 and the eigenvalues are within 1 %.  The estimate's scatter is ~0.05 % (the
    relative noise over 200 lines and four modes), so 1 % is a margin of twenty."""
    true = _rao_garnier()
    w = np.logspace(-1, 2, 200)
    rng = np.random.default_rng(0)
    noise = 0.01 * (rng.standard_normal(200) + 1j * rng.standard_normal(200)) / np.sqrt(2)
    H = true.frequency_response(w)[0, 0] * (1 + noise)
    model = frequency.identify_frequency(w, H)
    assert model.n == 4
    assert [r["order"] for r in model.options["selection"] if r["chosen"]] == [4]
    err = hdpbsid.eigenvalue_errors(model.eigenvalues, true.eigenvalues)
    assert err.max() < 0.01
    assert model.options["method"] == "frequency"
    assert np.all(model.K == 0)


def test_rao_garnier_from_multisine_time_data() -> None:
    """Time data through the FRF path: a band-limited multisine (0.04-8 Hz, 12 periods of
    20.48 s at dt = 0.01) drives the continuous system (simulated on a 10x finer grid with
    a first-order hold: the hold's error at 8 Hz is (w h)^2 / 12 ~ 1e-4), 20 dB output
    noise, 2 periods skipped; the periodic FRF weighted by its variance from the periods."""
    true = _rao_garnier()
    dt, n, up = 0.01, 2048, 10
    d = inputs.multisine(n * up, dt / up, (0.04, 8.0), periods=12, iterations=50)
    y = true.simulate(d.t, d.u, method="foh")[::up]
    y, _ = add_noise(y, 20.0, np.random.default_rng(1))
    frf = frequency.frf_periodic(d.u[::up], y, dt, n, skip=2)
    model = frequency.identify_frequency(frf)
    assert model.options["weight_source"] == "variance"
    assert model.n == 4
    err = hdpbsid.eigenvalue_errors(model.eigenvalues, true.eigenvalues)
    assert err.max() < 0.02  # measured ~0.05 %: the periods average the 20 dB noise down


def test_identify_frequency_rejects_bad_data() -> None:
    w = np.logspace(0, 1, 10)
    H = 1 / (1j * w + 1)
    with pytest.raises(ValueError, match="w must"):
        frequency.identify_frequency(-w, H)
    with pytest.raises(ValueError, match="H must have shape"):
        frequency.identify_frequency(w, H[:-1])
    bad = H.copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="H must be finite"):
        frequency.identify_frequency(w, bad)
    with pytest.raises(ValueError, match="order 8"):
        frequency.identify_frequency(w[:4], H[:4], order=8)
    with pytest.raises(ValueError, match="weight"):
        frequency.identify_frequency(w, H, weight="coherence")


def test_cli_input_and_frf_round_trip(tmp_path) -> None:
    """``hdpbsid input`` writes a multisine, ``hdpbsid frf --period --fit`` reads its
    noise-free response back: the lines are exact and the model is the system."""
    from hdpbsid.cli import main

    assert (
        main(
            [
                "input",
                "multisine",
                "--dt",
                "0.01",
                "--samples",
                "1024",
                "--band",
                "0.1",
                "5",
                "--periods",
                "8",
                "--out",
                str(tmp_path / "des"),
                "--no-plot",
            ]
        )
        == 0
    )
    d = np.loadtxt(tmp_path / "des" / "input.csv", delimiter=",", skiprows=1)
    A, B, C, D = second_order()
    y = simulate_zoh(A, B, C, D, d[:, 0], d[:, 1:2])
    np.savetxt(tmp_path / "rec.csv", np.c_[d, y], delimiter=",", header="t,u,y", comments="")
    argv = [
        "frf",
        str(tmp_path / "rec.csv"),
        "--inputs",
        "u",
        "--outputs",
        "y",
        "--period",
        "1024",
        "--skip",
        "6",
        "--fit",
        "--order",
        "2",
        "--out",
        str(tmp_path / "frf"),
    ]
    assert main(argv) == 0
    tab = np.loadtxt(tmp_path / "frf" / "frf.csv", delimiter=",", skiprows=1)
    truth = second_order_sampled().frequency_response(tab[:, 0])[0, 0]
    # steady state after 6 periods of 10 s (transient ~exp(-24)): exact lines
    np.testing.assert_allclose(tab[:, 1], 20 * np.log10(np.abs(truth)), atol=1e-6)
    assert (tmp_path / "frf" / "frf.png").exists()
    assert main(["input", "chirp", "--dt", "0.01", "--out", str(tmp_path / "c")]) == 2


def test_cli_frf_refuses_fit_and_model_before_reading(tmp_path, capsys) -> None:
    """``--fit`` and ``--model`` together are a usage error found before any reading or
    estimation: the file named does not even exist."""
    from hdpbsid.cli import main

    argv = ["frf", str(tmp_path / "absent.csv"), "--inputs", "u", "--outputs", "y"]
    assert main([*argv, "--fit", "--model", str(tmp_path / "m.json")]) == 2
    assert "not both" in capsys.readouterr().err


def test_cli_frf_with_reference_uses_the_instrument(tmp_path, capsys) -> None:
    """``--reference r`` reads the reference column and estimates with it as the
    instrument (the estimate's method says so)."""
    from hdpbsid.cli import main

    rng = np.random.default_rng(0)
    t = 0.01 * np.arange(4096)
    r = rng.standard_normal(t.size)
    A, B, C, D = second_order()
    y = simulate_zoh(A, B, C, D, t, r[:, None])
    np.savetxt(tmp_path / "rec.csv", np.c_[t, r, y, r], delimiter=",", header="t,u,y,r",
               comments="")  # fmt: skip
    argv = ["frf", str(tmp_path / "rec.csv"), "--inputs", "u", "--outputs", "y"]
    assert main([*argv, "--reference", "r", "--no-plot", "--out", str(tmp_path / "o")]) == 0
    assert capsys.readouterr().out.startswith("welch-reference")


def test_estimates_carry_the_sampling_interval_and_fit_cost_is_the_fits() -> None:
    d, y, dm, noise = _periodic_record(8, None, 0)
    est = frequency.frf_periodic(d.u, y, DT, d.period, skip=6)
    assert est.dt == DT and frequency.FrequencyResponse(est.w, est.H).dt is None
    rng = np.random.default_rng(3)
    u = rng.standard_normal(4000)
    assert frequency.frf_welch(u, u, DT).dt == DT
    # the cost of the fit that identify_frequency returns, computed by the same steps
    w = np.logspace(-1, 1.5, 50)
    H = dm.frequency_response(w)[0, 0] * (1 + 0.01 * rng.standard_normal(w.size))
    model = frequency.identify_frequency(w, H, order=2)
    # same operations; 1e-12 leaves room for a threaded BLAS's summation order only
    assert frequency.fit_cost(w, H, 2) == pytest.approx(model.options["cost"], rel=1e-12)
