"""Prediction-error refinement (hdpbsid.refine.pem, identify(..., refine=...)).

Oracles: simulated systems with known truth (noise-free: exact recovery from a perturbed
start; noisy: the spread over seeds against the reported asymptotic standard deviation;
the closed-loop quadrotor of hdpbsid.systems.quadrotor against its open-loop eigenvalues).

Measured when written (closed-loop quadrotor, 30 s, SNR 20 dB, order 3, hermite then
refine="pem"; largest relative eigenvalue error): seeds 0..11 HD-PBSID alone 1.6 2.4 2.7
2.4 2.4 4.1 4.1 1.6 3.5 1.8 1.9 10.1 %, refined 4.48 1.30 3.53 1.34 1.37 5.90 1.89 2.90
0.24 1.69 1.26 1.67 %.  Seed 5 (5.9 %) is not an optimiser failure: the refined model's
prediction-error cost is *below* the true system's on that record, so the data
themselves place the real pole there (the linearised standard deviation of the real pole
at the truth is 2.1 %: 5 % is 2.4 sigma).
"""

from __future__ import annotations

import numpy as np
import pytest

from hdpbsid import identify
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.refine.pem import refine_pem
from hdpbsid.systems import add_noise, random_steps, second_order, simulate_zoh
from hdpbsid.systems.quadrotor import simulate_pitch_closed_loop

A2, B2, C2, D2 = second_order()
TRUE2 = np.linalg.eigvals(A2)


def _perturbed(rng: np.random.Generator, hold: str = "zoh") -> StateSpaceModel:
    """The true second-order model with every entry of A, B, C perturbed by ~5 %."""
    model = StateSpaceModel(
        A2 * (1 + 0.05 * rng.standard_normal(A2.shape)),
        B2 * (1 + 0.05 * rng.standard_normal(B2.shape)),
        C2 + 0.05 * rng.standard_normal(C2.shape),
        D2,
        np.zeros((2, 1)),
        options={"input_hold": hold},
    )
    return model


def test_noise_free_zoh_recovers_the_truth_from_a_perturbed_start() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 20.0, 0.01)
    u = random_steps(rng, t, hold=0.3)
    y = simulate_zoh(A2, B2, C2, D2, t, u)
    start = _perturbed(rng)
    m = refine_pem(start, t, u, y)
    # exact sampled model of exact data: limited by the LM tolerances (xtol 1e-10 on
    # O(1) scaled parameters); 1e-6 leaves room for the conditioning of eig
    assert eigenvalue_errors(m.eigenvalues, TRUE2).max() < 1e-6
    assert eigenvalue_errors(start.eigenvalues, TRUE2).max() > 1e-2  # it had to move
    assert m.options["refine"] == "pem" and m.options["refine_hold"] == "zoh"
    assert m.options["refine_cost"]["final"] < m.options["refine_cost"]["initial"]


def test_noise_free_foh_needs_the_foh_predictor() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 20.0, 0.01)
    u = np.sin(0.7 * t) + 0.5 * np.sin(2.3 * t + 1.0)
    y = StateSpaceModel(A2, B2, C2, D2, np.zeros((2, 1))).simulate(t, u[:, None], method="foh")
    start = _perturbed(rng, hold="foh")
    foh = refine_pem(start, t, u, y)
    zoh = refine_pem(start, t, u, y, hold="zoh")
    # FOH data through the exact FOH predictor: as exact as the ZOH case above
    assert eigenvalue_errors(foh.eigenvalues, TRUE2).max() < 1e-6
    # the ZOH predictor treats the ramp as steps (half-sample delay): a bias of order
    # h |lambda| / 2 ~ 1e-2; it must be clearly worse than the FOH fit
    assert eigenvalue_errors(zoh.eigenvalues, TRUE2).max() > 100 * (
        eigenvalue_errors(foh.eigenvalues, TRUE2).max() + 1e-12
    )


def test_hold_chosen_by_the_refinement_unless_the_method_was_given_it() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 60.0, 0.02)
    u = random_steps(rng, t, hold=0.1)
    # the second-order system ten times faster (|lambda| h = 0.4): the half-sample shift
    # between the holds is then visible in the data (at |lambda| h = 0.04 the foh model
    # absorbs it and neither hold has evidence, test below); held input, so the zoh
    # predictor is the true one
    A, B = 10 * A2, 10 * B2
    y, _ = add_noise(simulate_zoh(A, B, C2, D2, t, u), 20.0, rng)
    start = _perturbed(rng, hold="foh")  # a method that picked the wrong hold itself
    start = StateSpaceModel(
        10 * start.A, 10 * start.B, start.C, start.D, start.K, options=start.options
    )
    m = refine_pem(start, t, u, y)
    zoh = refine_pem(start, t, u, y, hold="zoh")
    assert m.options["refine_hold"] == "zoh" and m.options["input_hold"] == "zoh"
    assert m.options["input_hold_before_refine"] == "foh"
    # same structure, same data: the same optimum up to the LM tolerances (and the
    # conditioning of eig)
    np.testing.assert_allclose(m.eigenvalues, zoh.eigenvalues, rtol=1e-5)
    start.options["input_hold_rule"] = "given"  # the user said foh: respected
    kept = refine_pem(start, t, u, y)
    assert kept.options["refine_hold"] == "foh" and kept.options["refine_holds_tried"] == ("foh",)


def test_the_first_hold_is_kept_when_the_data_cannot_tell_the_holds_apart() -> None:
    """The slow second-order system, steps held 0.3 s, |lambda| h = 0.04: the foh model
    absorbs the half-sample shift of held data, one Gauss-Newton step from the foh
    optimum predicts no evidence for zoh, and zoh is not fitted; the estimate is as good
    as the zoh fit's (the holds are equivalent on these data)."""
    rng = np.random.default_rng(2)
    t = np.arange(0.0, 60.0, 0.02)
    u = random_steps(rng, t, hold=0.3)
    y, _ = add_noise(simulate_zoh(A2, B2, C2, D2, t, u), 20.0, rng)
    start = _perturbed(rng, hold="foh")
    m = refine_pem(start, t, u, y)
    zoh = refine_pem(start, t, u, y, hold="zoh")
    assert m.options["refine_hold"] == "foh"
    assert str(m.options["refine_hold_costs"]["zoh"]).startswith("not fitted")
    err, err_zoh = (eigenvalue_errors(x.eigenvalues, TRUE2).max() for x in (m, zoh))
    # equivalent holds: within 10 % of each other (both ~7e-4, the 20 dB spread)
    assert abs(err - err_zoh) < 0.1 * err_zoh


def test_reported_std_matches_the_monte_carlo_spread() -> None:
    estimates, stds = [], []
    for seed in range(12):
        rng = np.random.default_rng(100 + seed)
        t = np.arange(0.0, 20.0, 0.02)
        u = random_steps(rng, t, hold=0.3)
        y, _ = add_noise(simulate_zoh(A2, B2, C2, D2, t, u), 10.0, rng)
        m = identify(t, u, y, 2, method="hermite", refine="pem")
        ev = m.eigenvalues
        estimates.append(ev[np.argmax(ev.imag)])
        stds.append(m.options["eigenvalue_std"][np.argmax(ev.imag)])
    estimates = np.array(estimates)
    spread = np.sqrt(np.mean(np.abs(estimates - estimates.mean()) ** 2))
    reported = float(np.median(stds))
    # 12 runs estimate a standard deviation to ~20 % (1/sqrt(2*11)); a factor 2 either
    # way separates a calibrated std from one that is off by an order of magnitude
    assert 0.5 < spread / reported < 2.0, (spread, reported)


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_quadrotor_20db_hermite_refined_within_5_percent(seed: int) -> None:
    d = simulate_pitch_closed_loop(np.random.default_rng(seed), snr_db=20.0)
    m = identify(d.t, d.u, d.y, 3, method="hermite", refine="pem")
    err = eigenvalue_errors(m.eigenvalues, d.true_eigenvalues)
    # target: all three open-loop eigenvalues (including +3.08) within 5 %; measured
    # 4.48, 1.30, 3.53, 1.34 % for seeds 0..3 (HD-PBSID alone: 1.6, 2.4, 2.7, 2.4 %)
    assert err.max() < 0.05, err
    assert np.all(np.isfinite(m.options["eigenvalue_std"]))


def test_auto_skips_non_uniform_records_and_pem_rejects_them() -> None:
    rng = np.random.default_rng(4)
    t = np.cumsum(np.r_[0.0, 0.01 * (1 + 0.4 * rng.uniform(-1, 1, 1999))])
    u = np.sin(0.9 * t)[:, None]
    y = StateSpaceModel(A2, B2, C2, D2, np.zeros((2, 1))).simulate(t, u, method="foh")
    m = identify(t, u, y, 2, method="hermite", refine="auto")
    assert m.options["refine"] is None
    assert "not uniformly sampled" in m.options["refine_rule"]
    with pytest.raises(ValueError, match="uniformly sampled"):
        identify(t, u, y, 2, method="hermite", refine="pem")


def test_bad_arguments() -> None:
    t = np.arange(0.0, 5.0, 0.01)
    u = np.sin(t)
    y = np.cos(t)
    with pytest.raises(ValueError, match="refine must be one of"):
        identify(t, u, y, 2, refine="newton")
    with pytest.raises(TypeError, match="StateSpaceModel"):
        refine_pem("model", t, u, y)  # type: ignore[arg-type]
    model = StateSpaceModel(A2, B2, C2, D2, np.zeros((2, 1)))
    with pytest.raises(ValueError, match="columns"):
        refine_pem(model, t, np.c_[u, u], y)
    with pytest.raises(ValueError, match="hold must be"):
        refine_pem(model, t, u, y, hold="cubic")


def test_fit_converges_at_the_statistical_resolution_on_a_two_time_scale_mimo_system() -> None:
    """Open-loop 2x2 system of order 4, modes -2 +- 20i and -0.2 +- 2i, random steps,
    20 dB.  Levenberg-Marquardt alone never declared convergence here (its tolerances
    kept it stepping at the optimum until the budget ran out, and the unrefined model
    was returned); with the statistical-resolution stop the fit converges, and a larger
    budget does not move it by more than the resolution."""
    A = np.array([[-2.0, 20.0, 0, 0], [-20.0, -2.0, 0, 0], [0, 0, -0.2, 2.0], [0, 0, -2.0, -0.2]])
    B = np.array([[1.0, 0.0], [0.0, 5.0], [0.5, 0.0], [0.0, 0.5]])
    C = np.array([[1.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 1.0]])
    truth = np.linalg.eigvals(A)
    rng = np.random.default_rng(12)
    t = np.arange(4001) * 0.01
    u = random_steps(rng, t, 0.05, channels=2)
    y = add_noise(simulate_zoh(A, B, C, None, t, u), 20.0, rng)[0]
    start = identify(t, u, y, 4, method="dt", refine=None)
    fit = refine_pem(start, t, u, y)
    longer = refine_pem(start, t, u, y, max_nfev=600)
    assert fit.options["refine_converged"], fit.options["refine_status"]
    # better than the subspace start (measured 0.1-0.5 % against 2-4 % on such records)
    assert (
        eigenvalue_errors(fit.eigenvalues, truth).max()
        < eigenvalue_errors(start.eigenvalues, truth).max()
    )
    # each stop is within STALL_SD = 0.1 standard deviation of the optimum: the two end
    # points agree within 0.2 of the reported standard deviation
    std = np.max(fit.options["eigenvalue_std"])
    gap = eigenvalue_errors(longer.eigenvalues, fit.eigenvalues) * np.abs(fit.eigenvalues)
    assert np.max(gap) <= 0.2 * std, (gap, std)


@pytest.mark.parametrize("case", ["open loop", "closed loop"])
def test_start_screen_reaches_the_best_minimum_of_all_starts(case: str) -> None:
    """The refinement fits the start its Gauss-Newton step ranks first and skips a start
    whose prediction cannot beat that minimum; the oracle fits every start to
    convergence and keeps the lowest cost.  The screened fit must not end above it
    beyond the statistical resolution (its cost is the mean of n_r whitened squares:
    a difference below 1/n_r relative is no evidence of a better minimum)."""
    from hdpbsid.refine import pem as R

    rng = np.random.default_rng(11)
    if case == "open loop":
        t = np.arange(0.0, 40.0, 0.01)
        u = random_steps(rng, t, hold=0.05)
        y, _ = add_noise(simulate_zoh(A2, B2, C2, D2, t, u), 20.0, rng)
        model = identify(t, u, y, 2, method="hermite", refine=None, detrend=None)
    else:
        d = simulate_pitch_closed_loop(rng, snr_db=10.0)
        t, u, y = d.t, d.u, d.y
        model = identify(t, u, y, 3, method="hermite", refine=None, detrend=None)
    m = refine_pem(model, t, u, y)
    costs = m.options["refine_start_costs"]
    predicted = m.options["refine_start_predicted"]
    assert set(costs) <= set(predicted) and len(predicted) == 2
    # the oracle: every start to convergence, with the weighting and hold the fit used
    full = {}
    original = R._fit_starts

    def every_start(starts, lay, residuals, kw, budget, n_r, settings):
        fits, c0, pred, extra = original(starts, lay, residuals, kw, budget, n_r, settings)
        for name, th in starts.items():
            full[name] = R._lm_fit(th, lay, residuals, kw, budget, settings).cost
        return fits, c0, pred, extra

    R._fit_starts = every_start
    try:
        refine_pem(model, t, u, y, hold=m.options["refine_holds_tried"][0])
    finally:
        R._fit_starts = original
    n_r = y.size
    screened = min(costs.values())
    assert screened <= min(full.values()) * (1.0 + 1.0 / n_r)


@pytest.mark.parametrize("hold", ["zoh", "foh"])
def test_one_step_errors_are_the_model_predictions(hold: str) -> None:
    """The compiled one-step errors against ``StateSpaceModel.predict`` (the numpy
    predictor, initial state fitted), with a direct term, a gain and an operating point;
    an unstable predictor gives None."""
    from hdpbsid.refine.pem import one_step_errors

    rng = np.random.default_rng(9)
    t = np.arange(0.0, 20.0, 0.01)
    u = random_steps(rng, t, hold=0.2)
    y, _ = add_noise(simulate_zoh(A2, B2, C2, D2, t, u), 20.0, rng)
    model = StateSpaceModel(A2, B2, C2, np.array([[0.3]]), np.array([[0.5], [-0.2]]))
    model.u0, model.y0 = np.array([0.1]), np.array([-0.4])
    e = one_step_errors(model, t, u + 0.1, y - 0.4, hold)
    ref = (y - 0.4) - model.predict(t, u + 0.1, y - 0.4, k=1, method=hold)
    # the same predictor, two implementations: rounding of 2000 steps of a 2-state filter
    np.testing.assert_allclose(e, ref, rtol=0, atol=1e-10 * np.abs(ref).max())
    unstable = StateSpaceModel(-A2, B2, C2, D2, np.zeros((2, 1)))
    assert one_step_errors(unstable, t, u, y, hold) is None


def test_the_other_hold_is_fitted_from_the_starts_when_the_data_want_it() -> None:
    """Input linear between samples (``lsim``'s default) changing every sample, a fast
    real mode (|lambda| h = 0.15): the subspace model comes with the held input, the data
    give strong evidence for the linear one, and the linear-hold fit from the subspace
    start reaches the system where the fit from the held optimum alone stopped at a
    local minimum (9.6 % off on the pair)."""
    from scipy import signal

    lam = np.array([-0.45 + 1.89j, -0.45 - 1.89j, -15.4])
    A, B, C, D = signal.tf2ss([0.3, -1.2, 2.0], np.real(np.poly(lam)))
    rng = np.random.default_rng(9)
    t = np.arange(4000) * 0.01
    u = np.sign(rng.standard_normal(t.size))
    _, y, _ = signal.lsim((A, B, C, D), u, t)  # linear interpolation of u
    y = y + 0.1 * np.std(y) * rng.standard_normal(t.size)  # 20 dB
    # D = 0 stated: this test is about the hold reached from the starts; how the default
    # tells the linear hold from a direct term (both link u_k to y_k within the sample)
    # is tested in tests/hdpbsid/selection/test_feedthrough.py
    m = identify(t, u, y, 3, method="dt", feedthrough=False)
    assert m.options["refine"] == "pem" and m.options["input_hold"] == "foh"
    # the 20 dB spread of this record's eigenvalues is ~0.5 %; 2 % leaves room for the
    # seed and is far below the 9.6 % of the local minimum
    assert eigenvalue_errors(m.eigenvalues, lam).max() < 0.02


def test_a_warm_start_is_screened_with_the_others_and_reaches_the_same_minimum() -> None:
    """A prediction-error fit on part of the record offered as a further start
    (``warm_start=``, as method="auto" offers its chosen candidate refined on the
    estimation part): the screen ranks it with the method's own starts, the fit reaches
    the same minimum as without it, and the start is not carried to the result; a start
    of other dimensions is ignored."""
    from hdpbsid.models.report import WarmStart
    from hdpbsid.refine.pem import warm_start_option
    from hdpbsid.refine.pem_starts import WARM_START_NAME

    rng = np.random.default_rng(3)
    t = np.arange(0.0, 40.0, 0.01)
    u = random_steps(rng, t, hold=0.05)
    y, _ = add_noise(simulate_zoh(A2, B2, C2, D2, t, u), 20.0, rng)
    model = identify(t, u, y, 2, method="hermite", refine=None, detrend=None)
    cold = refine_pem(model, t, u, y)
    part = refine_pem(model, t[:2667], u[:2667], y[:2667])  # the first two thirds
    warm = refine_pem(model, t, u, y, warm_start=warm_start_option(part))
    assert WARM_START_NAME in warm.options["refine_start_predicted"]
    assert warm.report.warm_start is None
    # the same minimum: the costs of the two fits (each whitened by its own first
    # start's residuals, so compared through the models' eigenvalues) agree within a
    # tenth of the reported standard deviation (the fits stop at STALL_SD = 0.1 of it)
    std = np.max(cold.options["eigenvalue_std"])
    gap = eigenvalue_errors(warm.eigenvalues, cold.eigenvalues) * np.abs(cold.eigenvalues)
    assert np.max(gap) <= 0.2 * std, (gap, std)
    # a start of another order is not a start of this model: ignored
    bad = WarmStart(np.eye(3), np.ones((3, 1)), np.ones((1, 3)), np.zeros((1, 1)), np.zeros((3, 1)))
    out = refine_pem(model, t, u, y, warm_start=bad)
    assert WARM_START_NAME not in out.options["refine_start_predicted"]


def test_settings_carry_the_budget_and_the_stopping_rule() -> None:
    """``settings.max_nfev`` is the budget ``max_nfev`` overrides, and the default
    settings are the behaviour without ``settings``; a budget too small to converge is
    reported unconverged in the options and in the report's ``Refinement``."""
    from dataclasses import replace

    from hdpbsid.refine.pem import DEFAULT_SETTINGS, RefinementSettings

    rng = np.random.default_rng(4)
    t = np.arange(0.0, 20.0, 0.01)
    u = random_steps(rng, t, hold=0.3)
    y, _ = add_noise(simulate_zoh(A2, B2, C2, D2, t, u), 30.0, rng)
    start = _perturbed(rng)
    plain = refine_pem(start, t, u, y, hold="zoh")
    same = refine_pem(start, t, u, y, hold="zoh", settings=RefinementSettings())
    np.testing.assert_array_equal(plain.A, same.A)
    short = refine_pem(start, t, u, y, hold="zoh", settings=replace(DEFAULT_SETTINGS, max_nfev=2))
    capped = refine_pem(start, t, u, y, hold="zoh", max_nfev=2)
    np.testing.assert_array_equal(short.A, capped.A)
    assert not short.options["refine_converged"] and not short.report.refinement.converged
    assert plain.options["refine_converged"] and plain.report.refinement.converged
    with pytest.raises(AttributeError):
        DEFAULT_SETTINGS.max_nfev = 3  # type: ignore[misc]  # frozen


def test_a_first_hold_out_of_budget_gives_way_to_the_other_hold() -> None:
    """The first hold (the method's, here the wrong one) spends its budget without
    converging: with no minimum to screen the other hold at, the other hold is fitted
    from the starting points and, converged at a lower cost, is the refinement's result
    -- the optimum of the fit told the right hold, not an unconverged wrong-hold fit
    (as when the other hold was tried only from a converged first one)."""
    from scipy.linalg import block_diag

    rng = np.random.default_rng(3)
    # stiff: a real pole at -200 with |lambda| h = 0.5 and a slow pair, held steps
    A = block_diag([[-200.0]], [[-0.25, 0.45], [-0.45, -0.25]])
    B, C, D = np.array([[200.0], [1.0], [-0.5]]), np.array([[1.0, 1.0, 0.5]]), np.zeros((1, 1))
    t = 0.0025 * np.arange(4000)
    u = random_steps(rng, t, 0.0075)
    y, _ = add_noise(simulate_zoh(A, B, C, D, t, u), 40.0, rng)
    start = StateSpaceModel(A, B, C, D, np.zeros((3, 1)), options={"input_hold": "foh"})
    # 90 evaluations: the foh fit from the truth needs about 110 (it absorbs the
    # half-sample shift by moving the fast pole), the zoh fit about 75
    m = refine_pem(start, t, u, y, max_nfev=90)
    assert m.options["refine_converged"] and m.options["refine_hold"] == "zoh"
    costs = m.options["refine_hold_costs"]
    assert costs["zoh"] < costs["foh"]
    zoh = refine_pem(start, t, u, y, hold="zoh")
    # the same optimum: each fit stops within a tenth of a standard deviation of it
    # (the stopping rule), so the two within two tenths of the smallest one
    gap = np.abs(np.sort_complex(m.eigenvalues) - np.sort_complex(zoh.eigenvalues))
    assert gap.max() <= 0.2 * np.min(m.options["eigenvalue_std"])
