"""``focus="simulation"``: the plant by its simulation error (output error), then ``K``.

Oracles: the output-error plant is consistent in open loop whatever the disturbance's
spectrum (Ljung 1999, sec. 8.5), so on a plant disturbed by noise of another
resonance it finds the plant's eigenvalues; on a plant with a cubic spring it is the
best linear approximation, which simulates an independent record better than the
prediction-error plant; in closed loop it is biased and says so.
"""

from __future__ import annotations

import numpy as np
import pytest
from focus_data import A, coloured_record
from scipy.signal import lfilter

from hdpbsid import identify
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.refine.pem import refine_pem
from hdpbsid.systems.quadrotor import simulate_pitch_closed_loop


@pytest.mark.parametrize("seed", [0, 1])
def test_the_output_error_plant_is_consistent_under_a_coloured_disturbance(seed):
    t, u, y = coloured_record(seed)
    m = identify(t, u, y, 2, method="dt", focus="simulation")
    err = eigenvalue_errors(m.eigenvalues, np.linalg.eigvals(A))
    # 2000 samples at 15 dB: the output-error std of these eigenvalues is ~0.3 %
    # (the refinement's reported std); 3 % is ten of them
    assert err.max() < 0.03, err
    assert m.options["refine_focus"] == "simulation"
    assert np.any(m.K != 0.0)  # the noise model is fitted after the plant


def _cubic_spring(seed: int, n: int = 12_000):
    """``x'' + 2 zeta w x' + w^2 (x + 0.1 x^3) = w^2 u`` (w = 2 pi 5 rad/s, zeta 0.03)
    driven by white noise low-passed at 15 Hz, 100 Hz sampling, RK4 with four steps per
    sample, output noise 40 dB below: at the record's amplitude the cubic term moves
    the resonance by tens of percent, so no linear model simulates it well."""
    rng = np.random.default_rng(seed)
    dt, w, zeta, sub = 0.01, 2 * np.pi * 5.0, 0.03, 4
    u = lfilter(*_butter(15.0 * dt * 2), rng.standard_normal(n))
    u /= np.std(u)
    h = dt / sub
    x, v, y = 0.0, 0.0, np.empty(n)

    def acc(x, v, uk):
        return w * w * (uk - x - 0.1 * x**3) - 2 * zeta * w * v

    for k in range(n):
        y[k] = x
        for _ in range(sub):
            a1, b1 = v, acc(x, v, u[k])
            a2, b2 = v + h / 2 * b1, acc(x + h / 2 * a1, v + h / 2 * b1, u[k])
            a3, b3 = v + h / 2 * b2, acc(x + h / 2 * a2, v + h / 2 * b2, u[k])
            a4, b4 = v + h * b3, acc(x + h * a3, v + h * b3, u[k])
            x += h / 6 * (a1 + 2 * a2 + 2 * a3 + a4)
            v += h / 6 * (b1 + 2 * b2 + 2 * b3 + b4)
    y = y + 0.01 * np.std(y) * rng.standard_normal(n)
    return dt * np.arange(n), u[:, None], y[:, None]


def _butter(wn: float):
    from scipy.signal import butter

    return butter(2, wn)


def _simulation_fit(model, t, u, y) -> float:
    """Percent fit of the model's simulation from a least-squares initial state."""
    return float(model.compare(t, u, y, method=model.report.hold or "zoh").fit[0])


def test_the_output_error_plant_simulates_a_nonlinear_record_better():
    t, u, y = _cubic_spring(0)
    tv, uv, yv = _cubic_spring(1)
    pem = identify(t, u, y, 2, method="dt", focus="prediction")
    oe = identify(t, u, y, 2, method="dt", focus="simulation")
    f_pem, f_oe = _simulation_fit(pem, tv, uv, yv), _simulation_fit(oe, tv, uv, yv)
    # the best linear approximation against the one-step predictor's plant, on a record
    # neither saw; measured 0 and 1: see the margin in the assertion's message
    assert f_oe > f_pem + 3.0, (f_oe, f_pem)
    # the default's focus rule sees it on the estimation record alone
    auto = identify(t, u, y, 2, method="dt")
    assert auto.report.focus.value == "simulation", auto.report.focus


def test_closed_loop_warns_and_bad_values_raise():
    d = simulate_pitch_closed_loop(np.random.default_rng(0), snr_db=20.0)
    with pytest.warns(UserWarning, match="closed loop"):
        identify(d.t, d.u, d.y, 3, method="hermite", focus="simulation")
    with pytest.raises(ValueError, match="focus"):
        identify(d.t, d.u, d.y, 3, method="hermite", focus="output")
    with pytest.raises(ValueError, match="focus"):
        identify(d.t, d.u, d.y, 3, method="hermite", refine=None, focus="simulation")
    jittered = d.t + 1e-4 * np.sin(np.arange(d.t.size))  # not uniform: refused at once
    with pytest.raises(ValueError, match="uniformly sampled"):
        identify(jittered, d.u, d.y, 3, method="hermite", focus="simulation")
    with pytest.raises(ValueError, match="single"):
        identify([(d.t, d.u, d.y)] * 2, order=3, method="hermite", focus="simulation")
    m = identify(d.t, d.u, d.y, 3, method="hermite", refine=None)
    with pytest.raises(ValueError, match="focus"):
        refine_pem(m, d.t, d.u, d.y, focus="sim")


@pytest.mark.parametrize("n, m, l", [(2, 1, 1), (3, 2, 1), (4, 1, 2)])
def test_the_plant_chart_leaves_k_alone_and_keeps_every_plant_direction(n, m, l):
    # at K = 0 the similarity directions (TA - AT, TB, -CT, 0, TK) have no K part, so the
    # output-error chart is the plant's n (m + l) directions beyond them (l m more with
    # D): orthonormal, zero on K, and orthogonal to every similarity direction
    from hdpbsid.refine.pem_residuals import _ddlc_basis, _Layout

    rng = np.random.default_rng(n + 10 * m + 100 * l)
    for feedthrough in (False, True):
        lay = _Layout(n, m, l, feedthrough, free="plant")
        A, B, C = (
            rng.standard_normal((n, n)),
            rng.standard_normal((n, m)),
            rng.standard_normal((l, n)),
        )
        theta = lay.pack(A, B, C, rng.standard_normal((l, m)), np.zeros((n, l)))
        Q = _ddlc_basis(lay, theta)
        s = lay.stops
        assert Q.shape[1] == n * (m + l) + (l * m if feedthrough else 0)
        np.testing.assert_allclose(Q.T @ Q, np.eye(Q.shape[1]), atol=1e-12)  # rounding
        assert not np.any(Q[s[4] : s[5]])
        for i in range(n):
            for j in range(n):
                T = np.zeros((n, n))
                T[i, j] = 1.0
                d = lay.pack(T @ A - A @ T, T @ B, -C @ T, np.zeros((l, m)), np.zeros((n, l)))
                # orthogonal up to the rounding of the SVD of a unit-scale matrix
                assert np.abs(Q.T @ d).max() < 1e-10
        noise = _ddlc_basis(_Layout(n, m, l, feedthrough, free="noise"), theta)
        assert noise.shape[1] == n * l and not np.any(noise[: s[4]])
