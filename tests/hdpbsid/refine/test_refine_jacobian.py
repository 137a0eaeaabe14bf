"""Two-stage least squares of the core (hdpbsid.core.varx.two_stage_ls) and the exact
Jacobian of the prediction-error refinement (hdpbsid.refine.pem_predictor).

Oracles: known regression coefficients (errors-in-variables regression), the simulated
closed-loop quadrotor with known open-loop eigenvalues, central finite differences of
the prediction errors and of the matrix exponential.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from hdpbsid import identify
from hdpbsid.core.varx import two_stage_ls
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.refine.pem import _Layout, _residuals
from hdpbsid.refine.pem_predictor import sampled_predictor
from hdpbsid.studies.data import quadrotor_record
from hdpbsid.systems.quadrotor import pitch_model

TRUE_PITCH = np.linalg.eigvals(pitch_model()[0])


def test_two_stage_ls_is_consistent_where_least_squares_is_not() -> None:
    # y = 2 x + e with a regressor x = z + e (correlated with the error), instrument z
    rng = np.random.default_rng(0)
    N = 20000
    z = rng.standard_normal(N)
    e = rng.standard_normal(N)
    x = z + e
    y = 2.0 * x + e
    theta_iv = two_stage_ls(x[None], y[None], z[None], lam=0.0)[0]
    theta_ls = np.linalg.lstsq(x[:, None], y, rcond=None)[0]
    # IV: standard error sqrt(var e / (N var z)) ~ 0.007, so 0.05 is 7 SE; LS converges to
    # 2 + cov(x, e) / var x = 2.5
    assert abs(theta_iv[0, 0] - 2.0) < 0.05
    assert abs(theta_ls[0] - 2.5) < 0.05


def test_two_stage_ls_needs_enough_instruments() -> None:
    rng = np.random.default_rng(1)
    Phi = rng.standard_normal((3, 50))
    with pytest.raises(ValueError, match="instruments"):
        two_stage_ls(Phi, Phi[:1], Phi[:2], lam=0.0)


@pytest.mark.parametrize("hold", ["zoh", "foh"])
def test_predictor_derivatives_match_finite_differences(hold: str) -> None:
    rng = np.random.default_rng(5)
    n, m, l = 3, 2, 2
    mats = [
        rng.standard_normal((n, n)) - 2 * np.eye(n),
        rng.standard_normal((n, m)),
        rng.standard_normal((l, n)),
        rng.standard_normal((l, m)),
        rng.standard_normal((n, l)),
    ]
    lay = _Layout(n, m, l, True)
    theta = lay.pack(*mats)
    pr = sampled_predictor(*mats, 0.05, hold, True, derivatives=True)
    step = 1e-6
    for k in range(theta.size):
        e = np.zeros(theta.size)
        e[k] = step
        hi = sampled_predictor(*lay.unpack(theta + e), 0.05, hold, True)
        lo = sampled_predictor(*lay.unpack(theta - e), 0.05, hold, True)
        for name in ("F", "G", "Kd", "C", "Du"):
            fd = (getattr(hi, name) - getattr(lo, name)) / (2 * step)
            # central differences: truncation ~ step^2 |third derivative|, rounding
            # ~ 1e-16 / step = 1e-10 on O(1) entries; 1e-7 leaves a margin
            assert np.allclose(getattr(pr, "d" + name)[k], fd, atol=1e-7), (name, k)
    # the sampled Phi is expm(A h): an independent check of the un-differentiated part
    Phi = expm(mats[0] * 0.05)
    Kd = pr.Kd
    assert np.allclose(pr.F + Kd @ mats[2], Phi, atol=1e-12)


@pytest.mark.parametrize("hold", ["zoh", "foh"])
def test_prediction_error_jacobian_matches_finite_differences(hold: str) -> None:
    # at (nearly) zero residual Kaufman's variable-projection Jacobian equals the exact one
    rng = np.random.default_rng(6)
    n, m, l = 3, 1, 2
    A = np.array([[-1.0, 2.0, 0.0], [-2.0, -1.0, 0.5], [0.0, 0.0, -0.5]])
    B, C = rng.standard_normal((n, m)), rng.standard_normal((l, n))
    D, K = np.zeros((l, m)), 0.2 * rng.standard_normal((n, l))
    lay = _Layout(n, m, l, False)
    theta = lay.pack(A, B, C, D, K)
    t = np.arange(600) * 0.02
    u = (np.sin(t) + 0.3 * np.sin(3.1 * t))[:, None]
    y = StateSpaceModel(A, B, C, D, K).simulate(t, u, method=hold)
    y = y + 1e-8 * rng.standard_normal(y.shape)
    W = np.array([[1.0, 0.0], [0.3, 2.0]])
    r, J = _residuals(theta, lay, u, y, 0.02, hold, W, jac=True)
    step = 1e-6
    for k in range(theta.size):
        e = np.zeros(theta.size)
        e[k] = step
        fd = (
            _residuals(theta + e, lay, u, y, 0.02, hold, W)
            - _residuals(theta - e, lay, u, y, 0.02, hold, W)
        ) / (2 * step)
        # residuals ~1e-8 make the neglected variable-projection term ~1e-8 relative;
        # finite differences add ~1e-10: 1e-6 of the column's size is a safe bound
        assert np.allclose(J[:, k], fd, atol=1e-6 * max(1.0, np.abs(fd).max())), k


@pytest.mark.slow
def test_refined_std_matches_the_closed_loop_spread() -> None:
    est, std = [], []
    for i in range(10):
        d = quadrotor_record(
            np.random.default_rng([11, i]), snr_db=10.0, excitation="hermite-sweep", n_max_u=300
        )
        m = identify(d.t, d.u, d.y, 3, method="hermite", refine="pem")
        ev = m.eigenvalues
        k = int(np.argmin(np.abs(ev - TRUE_PITCH[np.argmin(np.abs(TRUE_PITCH.imag))])))
        est.append(ev[k].real)
        std.append(m.options["eigenvalue_std"][k])
    spread = float(np.std(est, ddof=1))
    # 10 runs estimate a standard deviation to ~24 % (1/sqrt(2*9)); a factor 2 either way
    # separates a calibrated std from one that is off by an order of magnitude
    assert 0.5 < spread / float(np.median(std)) < 2.0, (spread, np.median(std))
