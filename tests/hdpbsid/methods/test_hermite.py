"""HD-PBSID (``identify_hermite``) on the second-order benchmark (the thesis, §3.2 and §5).

Measured when written (seeds as below): noise-free 1e-5..3e-5; SNR 20 dB random smooth
input 0.07-0.3 % (5 seeds); chirp 0.05-2 Hz, SNR 20 dB 0.17-0.43 %; jittered times
(+-40 %) 0.07-0.2 %; x0 != 0 noise-free 1e-5 with boundary rows, 4-6 % without.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
from basis_data import TRUE_EIGS, eig_error, make_data
from scipy.signal import butter, lfilter

from hdpbsid import StateSpaceModel
from hdpbsid.methods.hermite import identify_hermite
from hdpbsid.systems.linear import second_order


def test_noise_free_eigenvalues() -> None:
    for seed in range(2):
        m = identify_hermite(*make_data(seed), order=2)
        # issue target 1e-3; measured 3e-5 (trapezoid projection of FOH data, dt = 0.01)
        assert eig_error(m) < 1e-3
    m = identify_hermite(*make_data(5, kind="chirp"), order=2)
    assert eig_error(m) < 1e-3


def test_order_selected_and_options_reported() -> None:
    m = identify_hermite(*make_data(1))
    assert m.n == 2  # noise-free: the singular values drop by ~10 decades after 2
    o = m.options
    for key in ("N", "N_rule", "alpha", "alpha_rule", "beta", "gamma", "p", "p_rule", "scale"):
        assert key in o
    # first pass at 4 * scale, then the single mode's minimax alpha, |lambda| = 2
    # (operator_scale); 1 % = the noise-free eigenvalue error (1e-3) and margin
    assert o["alpha_passes"][0] == pytest.approx(4 * o["scale"])
    assert o["alpha"] == pytest.approx(2.0, rel=0.01)
    assert o["beta"] == 1.0 and o["gamma"] == 1.0 and o["boundary"] is True
    assert o["order_selected"] is True
    # overrides are honoured and reported
    m2 = identify_hermite(*make_data(1), order=2, N=250, p=4, alpha=3.0)
    assert (m2.options["N"], m2.options["p"], m2.options["alpha"]) == (250, 4, 3.0)


def test_snr20_random_input_five_seeds() -> None:
    errs = [eig_error(identify_hermite(*make_data(10 + s, snr=20), order=2)) for s in range(5)]
    # issue: std <= 2 % of |lambda| over 50 seeds; each of 5 seeds within 2 % (measured
    # max 0.3 %, so 2 % leaves room for seed-to-seed spread without hiding a bias)
    assert max(errs) < 0.02


def test_chirp_snr20() -> None:
    for s in range(3):
        m = identify_hermite(*make_data(20 + s, snr=20, kind="chirp"), order=2)
        # issue target: within 2 % (measured <= 0.43 %)
        assert eig_error(m) < 0.02


def test_initial_state_boundary_terms() -> None:
    for s in range(2):
        data = make_data(30 + s, x0=[1.0, -1.0])
        on = eig_error(identify_hermite(*data, order=2))
        off = eig_error(identify_hermite(*data, order=2, boundary=False))
        # with the boundary rows the equation is exact: noise-free target 1e-3 (measured
        # 1e-5); without them the missing x(t0) phi(t0) term biases by several percent
        assert on < 1e-3
        assert off > 10 * on


def test_nonuniform_times_within_1p5_of_uniform() -> None:
    uni = [eig_error(identify_hermite(*make_data(10 + s, snr=20), order=2)) for s in range(12)]
    jit = [
        eig_error(identify_hermite(*make_data(10 + s, snr=20, jitter=0.4), order=2))
        for s in range(12)
    ]
    # issue target: accuracy within 1.5x of the uniform case.  Mean over the same 12 seeds
    # (per-seed errors scatter 2-3x; 16 seeds measured: ratio 0.94)
    assert np.mean(jit) <= 1.5 * np.mean(uni)


@pytest.mark.slow
def test_monte_carlo_bias_and_std() -> None:
    """Bias and STD of the eigenvalues at SNR 20 dB (SLOW=1: the issue's 50 seeds)."""
    n = 50 if os.environ.get("SLOW") else 12
    est = []
    for s in range(n):
        ev = identify_hermite(*make_data(100 + s, snr=20), order=2).eigenvalues
        est.append(ev[np.argsort(ev.imag)])
    est = np.array(est)
    tru = TRUE_EIGS[np.argsort(TRUE_EIGS.imag)]
    bias = np.abs(est.mean(axis=0) - tru) / np.abs(tru)
    std = np.sqrt(np.mean(np.abs(est - est.mean(axis=0)) ** 2, axis=0)) / np.abs(tru)
    # issue targets: bias <= 1 %, std <= 2 % of |lambda| (measured ~0.1 % and ~0.1 %)
    assert bias.max() <= 0.01
    assert std.max() <= 0.02


@pytest.mark.parametrize("ns", [2001, 2000])  # odd / even node counts: with / without a centre
def test_mirrored_nodes_projected_once_same_coefficients(ns: int) -> None:
    import hdpbsid.bases.basis_domain as bd
    import slbasis

    rng = np.random.default_rng(ns)
    t = np.arange(ns) * 0.01
    u = np.repeat(np.sign(rng.standard_normal(ns // 5 + 1)), 5)[:ns, None]
    y = rng.standard_normal((ns, 1))
    basis = slbasis.basis("hermite", 300, (0.0, float(t[-1])))
    assert bd._has_parity(basis)
    assert not bd._has_parity(slbasis.basis("laguerre", 30, (0.0, float(t[-1]))))
    sizes: list[int] = []
    project = basis.project_alternating

    def spy(tt, *a, **k):
        sizes.append(len(tt))
        return project(tt, *a, **k)

    basis.project_alternating = spy  # type: ignore[method-assign]
    Us, Y = bd.project_record.__wrapped__(basis, t, u, y, ("zoh", "foh"))
    basis.project_alternating = project  # type: ignore[method-assign]
    assert sizes == [-(-3 * (ns - 1) // 2)]  # the mirrored nodes were paired: half of them
    # oracle: every node projected on its own (the unpaired quadrature, same nodes)
    x, w = np.polynomial.legendre.leggauss(bd.GAUSS_NODES)
    h = np.diff(t)
    tn = (t[:-1, None] + h[:, None] * (1.0 + x[None, :]) / 2.0).ravel()
    wn = (h[:, None] * w[None, :] / 2.0).ravel()
    lam = np.tile((1.0 + x) / 2.0, ns - 1)
    foh = (1.0 - lam) * np.repeat(u[:-1, 0], 3) + lam * np.repeat(u[1:, 0], 3)
    lin_y = (1.0 - lam) * np.repeat(y[:-1, 0], 3) + lam * np.repeat(y[1:, 0], 3)
    S = np.column_stack([np.repeat(u[:-1, 0], 3), foh, lin_y])
    ref = basis.project(tn, S, weights=wn).T
    got = np.vstack([Us[0], Us[1], Y])
    # pairing moves a node by <= PAIRING_ULPS ulps of t (~2e-14 s); with |phi_n'| <=
    # scale * sqrt(2 N) max|phi| that changes a coefficient by ~1e-12 of the largest, far
    # below 1e-9; summation order differs by rounding only
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9 * np.abs(ref).max())


@pytest.mark.parametrize("hold", ["zoh", "foh"])
def test_auto_input_hold_is_the_simulated_one_for_every_order(hold: str) -> None:
    """Second-order system (2 rad/s) sampled coarsely (0.25 s: the half-sample delay of
    the wrong hold is 0.25 rad of phase there), smooth input, 20 dB: with the input held
    between samples (``zoh``) or linear (``foh``), ``input_hold="auto"`` keeps the hold
    the record was simulated with, and the decision (made on the order-free VARX fit)
    is the same for every order."""
    A, B, C, D = second_order()
    t = np.arange(0.0, 100.0, 0.25)
    rng = np.random.default_rng(0)
    b, a = butter(2, 0.15)
    u = lfilter(b, a, rng.standard_normal(t.size))
    y = StateSpaceModel(A, B, C, D, None).simulate(t, u[:, None], method=hold)[:, 0]
    y = y + 0.1 * y.std() * rng.standard_normal(y.shape)
    models = [identify_hermite(t, u, y, n) for n in (1, 2, 3)]
    for m in models:
        assert m.options["input_hold"] == hold
        assert m.options["input_hold_criterion"] == models[0].options["input_hold_criterion"]
