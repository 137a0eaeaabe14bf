"""Identification of the closed-loop quadrotor pitch benchmark, and the input-hold
projection / alpha / ridge-floor defaults it needed.

Measured when written (order 3, 30 s, 250 Hz, moment in, q and theta out, 1-4 Hz sweep):

* noise-free, hermite defaults: 0.09 % (pair) / 0.07 % (real pole +3.08); before the
  changes 4 % / 21 % (trapezoid projection of the 250 Hz ZOH moment = half-sample shift);
  with the exact ZOH projection but no ridge floor 80-570 % (GCV chose 0 on exact data);
* SNR 20 dB, hermite defaults, seeds 0..11 (largest of the three): 1.6 2.4 2.7 2.4 2.4
  4.1 4.1 1.6 3.5 1.8 1.9 10.1 % with the noise-floor bandwidth (N = 335 instead of the
  cap 400) and AIC over p = 2..4; with AIC over 2..6 (p = 6) and N = 400: 4.1 2.1 3.2 8.5
  11.1 2.9 5.4 4.6 5.6 2.5 9.9 10.5 %.  Before the exact projection: the real pole 66-79 %
  off.
* Legendre, second-order system, noise-free: smooth FOH input 1e-5, ZOH random steps
  2e-5..5e-5 (before: 1.5e-3..3.4e-2 with default alpha = half the *input* bandwidth).
"""

from __future__ import annotations

import numpy as np
import pytest

import slbasis
from hdpbsid.bases.basis_domain import project_record
from hdpbsid.identify import identify
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.systems import random_steps, second_order, simulate_zoh
from hdpbsid.systems.quadrotor import simulate_pitch_closed_loop


@pytest.fixture(scope="module")
def clean() -> object:
    return simulate_pitch_closed_loop(np.random.default_rng(0), snr_db=None)


def test_project_record_is_exact_for_held_and_linear_inputs() -> None:
    rng = np.random.default_rng(3)
    t = np.sort(np.r_[0.0, rng.uniform(0.0, 5.0, 400), 5.0])
    u = rng.standard_normal((t.size, 1))
    basis = slbasis.basis("hermite", 30, (0.0, 5.0))
    (Uz, Uf), _ = project_record(basis, t, u, np.ones((t.size, 1)), ("zoh", "foh"))
    # reference: the interpolants on a fine grid, trapezoid (error ~ h_fine^2 = 1e-8 rel)
    tf = np.linspace(0.0, 5.0, 200001)
    idx = np.clip(np.searchsorted(t, tf, side="right") - 1, 0, t.size - 2)
    ref_z = basis.project(tf, u[idx]).reshape(-1)
    ref_f = basis.project(tf, np.interp(tf, t, u[:, 0])).reshape(-1)
    # the fine-grid trapezoid reference errs by ~h_fine/2 |jump| per ZOH jump (400 jumps,
    # measured 2.1e-4 absolute); the linear interpolant has no jumps (measured 1.9e-6,
    # the Gauss nodes on the longest random intervals)
    assert np.max(np.abs(Uz[0] - ref_z)) < 1e-3 * np.max(np.abs(ref_z))
    assert np.max(np.abs(Uf[0] - ref_f)) < 1e-5 * np.max(np.abs(ref_f))


def test_quadrotor_noise_free_hermite_defaults(clean) -> None:
    m = identify(clean.t, clean.u, clean.y, 3, method="hermite")
    err = eigenvalue_errors(m.eigenvalues, clean.true_eigenvalues)
    # measured 0.09 % / 0.07 %; the bound leaves room for BLAS/platform differences
    assert err.max() < 5e-3, err
    assert m.options["input_hold"] == "zoh"  # the controller's moment is held 4 ms
    assert m.options["ridge"] > 0  # the ridge floor is active on exact data


def test_quadrotor_noise_free_trapezoid_is_the_old_bias(clean) -> None:
    # the projection alone (refine=None): a refinement would move the model off it
    m = identify(
        clean.t, clean.u, clean.y, 3, method="hermite", input_hold="trapezoid", refine=None
    )
    err = eigenvalue_errors(m.eigenvalues, clean.true_eigenvalues)
    # the old projection: the real pole 21 % off (half-sample shift of the ZOH moment)
    assert err.max() > 0.1, err


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_quadrotor_20db_hermite_defaults(seed: int) -> None:
    d = simulate_pitch_closed_loop(np.random.default_rng(seed), snr_db=20.0)
    m = identify(d.t, d.u, d.y, 3, method="hermite")
    err = eigenvalue_errors(m.eigenvalues, d.true_eigenvalues)
    # target: all three within 5 %.  Measured (seeds 0..3) 1.6, 2.4, 2.7, 2.4 %; over 12
    # seeds 11 within 5 % (the 12th 10.1 %; refine="pem" brings it to 1.7 %, see
    # test_hdpbsid_refine.py).  Before the noise-floor bandwidth and p <= 4: 4.1, 2.1, 3.2,
    # 8.5 %; before the exact interpolant projection: the real pole 66-79 % off
    assert err.max() < 0.05, err
    assert m.options["p"] <= 4


@pytest.mark.parametrize("hold", [0.1, 0.5, 1.0])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_legendre_noise_free_zoh_steps(seed: int, hold: float) -> None:
    A, B, C, D = second_order()
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 40.0 + 0.005, 0.01)
    u = random_steps(rng, t, hold=hold)
    y = simulate_zoh(A, B, C, D, t, u)
    # simulated from rest around zero: detrend=None (mean removal adds an O(1/T) level
    # error the model cannot explain; measured 1.1e-3..8.7e-3 with it)
    m = identify(t, u, y, 2, method="legendre", detrend=None)
    err = eigenvalue_errors(m.eigenvalues, np.linalg.eigvals(A)).max()
    # issue: noise-free <= 1e-3; measured 2e-5..5e-5 for hold 0.5 (before: up to 3.4e-2)
    assert err < 1e-3, (err, m.options["alpha"])


def test_quadrotor_40db_a_drift_is_not_taken_for_a_mode() -> None:
    """At 40 dB the refined order 4 raises the likelihood beyond the information
    criterion's price of a state, through a fourth mode within 0.07 rad/s of zero: a
    drift over the 20 s estimation part (less than one period of the record's frequency
    resolution 2 pi / T), not a mode of the plant, whose three modes are all faster than
    2.9 rad/s.  The closed-loop step up does not take it."""
    d = simulate_pitch_closed_loop(np.random.default_rng(0), 30.0, snr_db=40.0)
    m = identify(d.t, d.u, d.y)
    rule = m.options["selection_rule"]
    # the premise: the likelihood alone would have resolved order 4
    assert "raises the likelihood on the estimation part" in rule, rule
    assert m.n == 3, rule
    assert "adds a mode slower than" in rule
    # 30 s at 40 dB: the order-3 fit within a per cent (measured 0.4 %)
    assert eigenvalue_errors(m.eigenvalues, d.true_eigenvalues).max() < 0.01
