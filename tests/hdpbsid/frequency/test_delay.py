"""Dead times (hdpbsid.models.dead_time, hdpbsid.frequency.delay) and the model's
frequency-response band (hdpbsid.models.uncertainty), against analytic truths: shifted
records, exact delayed responses, Pade coefficients of python-control, a seeded Monte
Carlo of the band's coverage."""

from __future__ import annotations

import numpy as np
import pytest

from hdpbsid import StateSpaceModel, identify, load_model
from hdpbsid.frequency import fit as frequency
from hdpbsid.frequency.delay import delay_from_frf, estimate_delay
from hdpbsid.models.dead_time import PADE_PHASE_RANGE, check_delay, pade
from hdpbsid.models.uncertainty import ParameterCovariance, response_band

A2 = np.array([[0.0, 1.0], [-4.0, -0.8]])
B2 = np.array([[0.0], [1.0]])
C2 = np.array([[1.0, 0.0]])


def _model(delay=None, D=0.0) -> StateSpaceModel:
    return StateSpaceModel(A2, B2, C2, [[D]], np.zeros((2, 1)), delay=delay)


@pytest.mark.parametrize("method", ["zoh", "foh"])
@pytest.mark.parametrize("tau", [0.13, 0.033])
def test_delayed_simulation_is_the_shifted_response(method: str, tau: float) -> None:
    """On a grid 10 times finer every breakpoint of the delayed input is a sample, so the
    delay-free model driven by the input shifted by whole fine samples is the exact
    oracle; the delayed model on the coarse grid must agree to rounding."""
    rng = np.random.default_rng(1)
    h, n, r = 0.01, 400, 10
    t = np.arange(n) * h
    u = rng.standard_normal(n)
    u[0] = 0.0  # the record starts at the operating point (zero deviation before it)
    y = _model(tau, D=0.3).simulate(t, u, method=method)
    tf = np.arange(n * r) * h / r
    uf = np.repeat(u, r) if method == "zoh" else np.interp(tf, t, u)
    sh = round(tau / (h / r))
    ufs = np.concatenate([np.zeros(sh), uf[:-sh]])
    yf = _model(None, D=0.3).simulate(tf, ufs, method=method)[::r]
    # both are exact step recursions: rounding of ~1e3 steps of unit-size states
    np.testing.assert_allclose(y, yf, atol=1e-11)


def test_delayed_simulation_on_a_nonuniform_grid() -> None:
    """A non-uniform grid that contains the uniform one's samples gives the same values
    there (the delayed input is the same function of time)."""
    rng = np.random.default_rng(2)
    t = np.arange(300) * 0.02
    u = rng.standard_normal(300)
    m = _model(0.05)
    y = m.simulate(t, u)
    extra = np.sort(rng.uniform(0, t[-1], 200))
    tn = np.union1d(t, extra)
    un = u[np.searchsorted(t, tn, side="right") - 1]  # the same held input
    yn = m.simulate(tn, un)
    # exact recursions on both grids: rounding only
    np.testing.assert_allclose(yn[np.isin(tn, t)], y, atol=1e-10)


def test_frequency_response_and_pade() -> None:
    """``G e^{-jw tau}`` exactly; the Pade realisation equals python-control's ``pade``
    and ``to_control`` is within the stated phase of the exact response."""
    control = pytest.importorskip("control")
    w = np.logspace(-1, 1, 30)
    m = _model(0.2)
    G0 = _model().frequency_response(w)
    np.testing.assert_allclose(m.frequency_response(w), G0 * np.exp(-0.2j * w), rtol=1e-13)
    for N in (1, 3, 6):
        A, B, C, D = pade(0.2, N)
        num, den = control.pade(0.2, N)
        s = 1j * w
        ours = (C @ np.linalg.solve(s[:, None, None] * np.eye(N) - A, B))[:, 0, 0] + D[0, 0]
        ref = np.polyval(num, s) / np.polyval(den, s)
        np.testing.assert_allclose(ours, ref, rtol=1e-10)  # two realisations, rounding
    N = m.pade_order()
    sys = m.to_control()
    assert sys.nstates == 2 + N
    wmax = PADE_PHASE_RANGE[N] / 0.2
    ww = w[w <= wmax]
    Gc = np.array([complex(sys(1j * x)) for x in ww])
    Ge = m.frequency_response(ww)[0, 0]
    assert np.max(np.abs(np.degrees(np.angle(Gc / Ge)))) <= 1.0 + 1e-9  # the stated degree
    np.testing.assert_allclose(np.abs(Gc), np.abs(Ge), rtol=1e-9)  # all-pass
    with pytest.raises(ValueError, match="dead time"):
        m.to_discrete(0.01)


def test_delay_save_load_round_trip(tmp_path) -> None:
    m = StateSpaceModel(
        A2, np.hstack([B2, B2]), C2, [[0.0, 0.0]], np.zeros((2, 1)), delay=[0.13, 0.0]
    )
    back = load_model(m.save(tmp_path / "m.json"))
    assert back.delay.tolist() == [0.13, 0.0]
    text = (tmp_path / "m.json").read_text().replace("0.13,", "-0.13,")
    (tmp_path / "bad.json").write_text(text)
    with pytest.raises(ValueError, match="delay"):
        load_model(tmp_path / "bad.json")


def test_check_delay_rejects_bad_values() -> None:
    assert check_delay(0.5, 3).tolist() == [0.5, 0.5, 0.5]
    with pytest.raises(ValueError, match="delay"):
        check_delay(-1.0, 1)
    with pytest.raises(ValueError, match="delay"):
        check_delay([1.0, 2.0], 3)
    with pytest.raises(TypeError, match="delay"):
        check_delay("x", 1)


def test_delay_from_exact_frf() -> None:
    """Noise-free lines of a delayed second-order system: the profile's minimum is the
    delay (a whole number of steps, so the parabola lands on it)."""
    w = np.logspace(-1, 1.3, 120)
    H = _model(0.3).frequency_response(w)
    est = delay_from_frf(w, H, step=0.05, max_delay=1.0, order=2)
    assert est.samples.tolist() == [6]
    assert abs(est.delay[0] - 0.3) < 0.05 / 10  # a tenth of a step on exact data


@pytest.mark.parametrize("tau", [0.0, 0.13])
def test_estimate_delay_from_a_noisy_record(tau: float) -> None:
    """20 dB output noise, random binary input: within one sample (the resolution)."""
    from hdpbsid.design import inputs
    from hdpbsid.systems import add_noise

    rng = np.random.default_rng(3)
    d = inputs.random_binary(12000, 0.01, rng=rng)
    y, _ = add_noise(_model(tau).simulate(d.t, d.u), 20.0, rng)
    est = estimate_delay(d.t, d.u, y, max_delay=0.3, order=2)
    assert abs(est.delay[0] - tau) <= 0.01 * (1 + 1e-9)  # one sample, the resolution


def test_identify_with_given_and_auto_delay() -> None:
    """A record with 13 samples of dead time: with the delay given, the model is the
    one the method finds on the delay-free record that ends 13 samples earlier (the same
    numbers, the times shifted), and 'auto' finds the delay."""
    from hdpbsid.design import inputs

    rng = np.random.default_rng(4)
    d = inputs.random_binary(6000, 0.01, rng=rng)
    y = _model(0.13).simulate(d.t, d.u)
    m = identify(d.t, d.u, y, order=2, method="dt", refine=None, delay=0.13)
    assert m.delay.tolist() == [0.13]
    y_free = _model().simulate(d.t, d.u)
    free = identify(d.t[:-13], d.u[:-13], y_free[:-13], order=2, method="dt", refine=None)
    # the same regression on the same numbers; rounding of the two simulations only
    np.testing.assert_allclose(
        np.sort_complex(m.eigenvalues), np.sort_complex(free.eigenvalues), rtol=1e-8
    )
    auto = identify(d.t, d.u, y, order=2, method="dt", refine=None, delay="auto", max_delay=0.3)
    assert abs(auto.delay[0] - 0.13) <= 0.01 * (1 + 1e-9)  # one sample, the resolution
    with pytest.raises(ValueError, match="multiple of the sampling interval"):
        identify(d.t, d.u, y, order=2, delay=0.125)
    with pytest.raises(ValueError, match="delay_hold"):
        identify(d.t, d.u, y, order=2, delay="auto", delay_hold="linear")


def test_auto_delay_without_order_warns() -> None:
    """Without the order the joint choice can trade a sample of delay for a mode: said."""
    from hdpbsid.design import inputs

    d = inputs.random_binary(3000, 0.01, rng=np.random.default_rng(8))
    y = _model(0.05).simulate(d.t, d.u)
    with pytest.warns(UserWarning, match="without an order"):
        identify(d.t, d.u, y, method="dt", refine=None, delay="auto", max_delay=0.1)


def test_band_covers_the_truth_at_its_level() -> None:
    """Seeded Monte Carlo: 400 fits to FRF points with known 2 % complex Gaussian noise;
    the 95 % band of magnitude and phase covers the true response at three frequencies.
    The coverage of 1200 independent-per-frequency trials has standard error 0.0063:
    the interval [0.92, 0.98] is about 5 standard errors wide either way, so it holds
    on any machine, and a band off by 25 % in width would leave it."""
    w = np.logspace(-1, 1.5, 60)
    true = _model()
    H0 = true.frequency_response(w)[0, 0]
    wt = np.array([0.5, 2.0, 5.0])
    Gt = true.frequency_response(wt)[0, 0]
    hits_m, hits_p = [], []
    for s in range(400):
        rng = np.random.default_rng(s)
        sig = 0.02 * np.abs(H0)
        H = H0 + sig * (rng.standard_normal(60) + 1j * rng.standard_normal(60)) / np.sqrt(2)
        model = frequency.identify_frequency(w, H, order=2, weight=1 / sig)
        b = response_band(model, wt)
        hits_m.append(np.abs(np.abs(b.G[0, 0]) - np.abs(Gt)) < b.z * b.magnitude_sd[0, 0])
        hits_p.append(np.abs(np.angle(b.G[0, 0] / Gt)) < b.z * b.phase_sd[0, 0])
    assert 0.92 <= np.mean(hits_m) <= 0.98
    assert 0.92 <= np.mean(hits_p) <= 0.98


def test_band_of_a_known_covariance() -> None:
    """One uncertain parameter: ``G = b / (s + 1)`` with ``sd(b) = 0.1``: ``sd |G| = 0.1
    |G| / b`` exactly (linear in ``b``) and the phase does not move."""
    F = np.zeros((4, 1))
    F[1, 0] = 0.1
    cov = ParameterCovariance(F, "given")
    m = StateSpaceModel([[-1.0]], [[2.0]], [[1.0]], [[0.0]], [[0.0]], parameter_covariance=cov)
    w = np.array([0.1, 1.0, 10.0])
    b = response_band(m, w)
    np.testing.assert_allclose(b.magnitude_sd[0, 0], 0.1 / np.abs(1j * w + 1), rtol=1e-12)
    np.testing.assert_allclose(b.phase_sd[0, 0], 0.0, atol=1e-15)
    with pytest.raises(ValueError, match="parameter_covariance"):
        response_band(_model(), w)
    with pytest.raises(ValueError, match="parameter_covariance.factor must have 4 rows"):
        StateSpaceModel([[-1.0]], [[2.0]], [[1.0]], [[0.0]], [[0.0]],
                        parameter_covariance=ParameterCovariance(F[:3], "given"))  # fmt: skip
    with pytest.raises(TypeError, match="parameter_covariance"):
        StateSpaceModel([[-1.0]], [[2.0]], [[1.0]], [[0.0]], [[0.0]], parameter_covariance=F)


def test_cli_frf_draws_a_saved_model(tmp_path) -> None:
    from hdpbsid.cli import main
    from hdpbsid.design import inputs

    rng = np.random.default_rng(5)
    d = inputs.random_binary(4000, 0.01, rng=rng)
    y = _model().simulate(d.t, d.u) + 0.01 * rng.standard_normal((4000, 1))
    np.savetxt(tmp_path / "r.csv", np.c_[d.t, d.u, y], delimiter=",", header="t,u,y", comments="")
    m = frequency.identify_frequency(frequency.frf_welch(d.u, y, 0.01), order=2)
    m.save(tmp_path / "m.json")
    argv = ["frf", str(tmp_path / "r.csv"), "--inputs", "u", "--outputs", "y"]
    assert main([*argv, "--model", str(tmp_path / "m.json"), "--out", str(tmp_path / "o")]) == 0
    assert (tmp_path / "o" / "frf.png").stat().st_size > 0


def _sampled_response(tau: float, h: float, w: np.ndarray) -> np.ndarray:
    """The exact response ``u_k -> y_k`` of the delayed second-order system with its input
    held between samples (zero order), from the matrix exponential alone (Franklin,
    Powell & Workman, *Digital Control*, sec. 4.3.3): with ``tau = (d + f) h``,
    ``x_{k+1} = Phi x_k + G1 u_{k-d-1} + G2 u_{k-d}``, ``G2 = int_0^{(1-f) h} e^{As} ds B``,
    ``G1 = e^{A (1-f) h} int_0^{f h} e^{As} ds B``."""
    from scipy.linalg import expm

    d = int(np.floor(tau / h + 1e-9))
    f = tau / h - d

    def integral(T: float) -> tuple[np.ndarray, np.ndarray]:
        M = np.zeros((3, 3))
        M[:2, :2], M[:2, 2:] = A2 * T, B2 * T
        E = expm(M)
        return E[:2, :2], E[:2, 2:]

    Phi, _ = integral(h)
    Ea, G2 = integral((1 - f) * h)
    _, Gf = integral(f * h)
    G1 = Ea @ Gf
    z = np.exp(1j * w * h)
    X = np.linalg.solve(z[:, None, None] * np.eye(2) - Phi, (G2 + G1 / z[:, None, None]))
    return (C2 @ X)[:, 0, 0] * z ** (-d)


def _lines(h: float, n: int = 2048) -> np.ndarray:
    return 2 * np.pi * np.arange(1, n // 2) / (n * h)


@pytest.mark.parametrize("d", [0, 5, 13])
def test_delay_of_a_sampled_response_is_exact_in_whole_samples(d: int) -> None:
    """The exact sampled response (no noise) of a record delayed by ``d`` whole samples:
    the discrete-time fit finds ``d`` itself, not ``d + 1`` (the hold's half sample)."""
    h = 0.01
    w = _lines(h)
    H = _sampled_response(d * h, h, w)
    est = delay_from_frf(w, H, step=h, max_delay=20 * h, order=2, weight="relative", hold="zoh")
    assert est.samples.tolist() == [d]
    # the parabola through an exact minimum and its neighbours: within a tenth of a sample
    assert abs(est.delay[0] / h - d) < 0.1


@pytest.mark.parametrize("frac", [0.25, 0.5, 0.75])
def test_fractional_delay_within_half_a_sample(frac: float) -> None:
    """``tau = (13 + f) h``: the sampled response is no whole-sample shift (the modified
    z-transform adds a numerator term), so the best whole sample is either neighbour;
    the parabola through the profile places the delay within half a sample."""
    h = 0.01
    w = _lines(h)
    tau = (13 + frac) * h
    est = delay_from_frf(
        w, _sampled_response(tau, h, w), step=h, max_delay=20 * h, order=2,
        weight="relative", hold="zoh",
    )  # fmt: skip
    assert est.samples[0] in (13, 14)
    assert abs(est.delay[0] - tau) <= 0.5 * h


def test_delay_of_a_first_order_hold_record() -> None:
    """A periodic input linear between samples, simulated exactly (the first-order hold)
    and delayed by 7 samples: the exact DFT lines, fitted with ``hold="foh"``."""
    rng = np.random.default_rng(6)
    n, h = 1024, 0.01
    u = np.tile(rng.standard_normal(n), 3)
    t = np.arange(u.size) * h
    y = _model(7 * h).simulate(t, u, method="foh")
    frf = frequency.frf_periodic(u, y, h, n, skip=1)
    est = delay_from_frf(frf, max_delay=20 * h, order=2, weight="relative", hold="foh")
    assert est.samples.tolist() == [7]


def test_order_and_delay_chosen_together() -> None:
    """Without the order: 1 % complex noise on the exact sampled lines of the
    second-order system delayed by 13 samples.  Order 3 at 12 samples contains the truth
    (a state at the origin is one sample), so Akaike's ``2 p`` could take it on noise;
    Schwarz's ``p log N`` refuses it and returns order 2 at 13 on every seed."""
    h = 0.01
    w = _lines(h)
    H0 = _sampled_response(0.13, h, w)
    for seed in range(3):
        rng = np.random.default_rng(seed)
        sig = 0.01 * np.abs(H0)
        H = H0 + sig * (rng.standard_normal(w.size) + 1j * rng.standard_normal(w.size)) / 2**0.5
        est = delay_from_frf(w, H, step=h, max_delay=16 * h, weight=1 / sig, hold="zoh")
        assert est.order.tolist() == [2] and est.samples.tolist() == [13]


def test_hold_needs_a_sampling_interval() -> None:
    w = _lines(0.01)
    with pytest.raises(ValueError, match="hold"):
        delay_from_frf(w, np.ones(w.size), hold="zoh")
    with pytest.raises(ValueError, match="hold"):
        delay_from_frf(w, np.ones(w.size), step=0.01, hold="linear")


def test_time_domain_band_covers_the_truth_at_its_level() -> None:
    """Seeded Monte Carlo of ``identify(method="dt", refine="pem")``: 300 records of 100 s
    (random binary input held over dt = 0.2 s, 20 % white output noise) of the
    second-order system; the 95 % band of magnitude and phase at its resonance (2 rad/s)
    must cover the true response.  Each record is one independent Bernoulli trial, so the
    count is Binomial(300, p): for an honest band (p = 0.95) the interval [270, 297]
    (0.90-0.99) holds with probability 1 - 1.3e-4 - 2.9e-5 (exact binomial tails), and a
    band that misses one time in five or more (p <= 0.82, a hold chosen on noise moving
    the phase by half a sample) passes it with probability below 1e-4."""
    import warnings

    from hdpbsid.design import inputs

    true = _model()
    wt = np.array([2.0])
    Gt = true.frequency_response(wt)[0, 0, 0]
    hits_m = hits_p = 0
    for s in range(300):
        rng = np.random.default_rng(s)
        d = inputs.random_binary(500, 0.2, rng=rng)
        y0 = true.simulate(d.t, d.u)
        y = y0 + 0.2 * np.std(y0) * rng.standard_normal(y0.shape)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a refinement that keeps its start warns
            m = identify(d.t, d.u, y, order=2, method="dt", refine="pem")
        b = response_band(m, wt)
        G = b.G[0, 0, 0]
        hits_m += bool(abs(abs(G) - abs(Gt)) < b.z * b.magnitude_sd[0, 0, 0])
        hits_p += bool(abs(np.angle(G / Gt)) < b.z * b.phase_sd[0, 0, 0])
    assert 270 <= hits_m <= 297
    assert 270 <= hits_p <= 297
