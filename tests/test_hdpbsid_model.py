"""StateSpaceModel: simulation, fit, frequency response, scipy/python-control conversion."""

import warnings

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal
from scipy.integrate import solve_ivp

from hdpbsid import DiscreteModel, StateSpaceModel
from hdpbsid.systems import second_order


@pytest.fixture(scope="module")
def model():
    A, B, C, D = second_order()
    return StateSpaceModel(A, B, C, D, np.array([[0.2], [0.1]]), options={"method": "test"})


@pytest.fixture(scope="module")
def mimo():
    A = np.array([[-0.5, 2.0, 0.0], [-2.0, -0.5, 0.0], [0.0, 0.0, -3.0]])
    B = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, -1.0]])
    C = np.array([[1.0, 0.0, 1.0], [0.0, 1.0, 0.5]])
    D = np.array([[0.0, 0.1], [0.0, 0.0]])
    return StateSpaceModel(A, B, C, D, np.zeros((3, 2)))


def test_repr_and_properties(model):
    text = repr(model)
    assert "n=2, m=1, l=1" in text and "-0.4-1.95959j" in text and "method='test'" in text
    # eigenvalues of [[0, 1], [-4, -0.8]]: -0.4 +- i sqrt(3.84), rounding level
    np.testing.assert_allclose(
        model.eigenvalues, [-0.4 - np.sqrt(3.84) * 1j, -0.4 + np.sqrt(3.84) * 1j], atol=1e-14
    )


@pytest.mark.parametrize(("method", "interp"), [("zoh", False), ("foh", True)])
def test_simulate_matches_lsim(mimo, method, interp):
    rng = np.random.default_rng(5)
    t = np.linspace(0.0, 10.0, 1001)
    u = rng.standard_normal((1001, 2))
    x0 = np.array([0.5, -0.3, 1.0])
    y = mimo.simulate(t, u, x0, method=method)
    _, y_ref, _ = signal.lsim(mimo.to_scipy(), u, t, X0=x0, interp=interp)
    # both exact discretisations of the same hold (lsim: expm of the same augmented matrix)
    np.testing.assert_allclose(y, y_ref, atol=1e-12)


def test_simulate_non_uniform_against_ode_solver(model):
    rng = np.random.default_rng(6)
    t = np.r_[0.0, np.sort(rng.uniform(0.0, 8.0, 120))]
    u = rng.standard_normal(t.size)
    x0 = np.array([0.3, -0.2])
    y = model.simulate(t, u, x0)
    x, ys = x0, [model.C @ x0]
    for k in range(t.size - 1):  # ZOH: u[k] held on [t_k, t_k+1)
        sol = solve_ivp(
            lambda _, x, k=k: model.A @ x + model.B[:, 0] * u[k],
            (t[k], t[k + 1]),
            x,
            rtol=1e-12,
            atol=1e-13,
        )
        x = sol.y[:, -1]
        ys.append(model.C @ x)
    # the ODE solver's tolerance (1e-12 relative per step, ~120 steps) bounds the difference
    np.testing.assert_allclose(y, np.array(ys), atol=1e-9)


def test_fit_recovers_initial_state(model):
    rng = np.random.default_rng(7)
    t = np.arange(0.0, 20.0, 0.05)
    u = rng.standard_normal(t.size)
    x0 = np.array([1.0, -2.0])
    y = model.simulate(t, u, x0)
    res = model.fit(t, u, y)
    # exact model, linear least squares for x0: rounding level
    np.testing.assert_allclose(res.x0, x0, atol=1e-10)
    assert res.vaf[0] == pytest.approx(100.0, abs=1e-9)
    assert res.nrmse[0] < 1e-9
    wrong = model.fit(t, u, y, x0="zero")
    assert wrong.vaf[0] < res.vaf[0]
    # VAF definition on a known perturbation: data y + 0.1 v, model output y
    noise = rng.standard_normal(y.shape)
    y_data = y + 0.1 * noise
    vaf_ref = 100 * (1 - np.var(0.1 * noise) / np.var(y_data))
    res2 = model.fit(t, u, y_data, x0=x0)
    assert res2.vaf[0] == pytest.approx(vaf_ref, rel=1e-12)


def test_frequency_response_analytic(mimo):
    w = np.logspace(-2, 2, 40)
    G = mimo.frequency_response(w)
    assert G.shape == (2, 2, 40)
    for k, wk in enumerate(w):
        ref = mimo.C @ np.linalg.inv(1j * wk * np.eye(3) - mimo.A) @ mimo.B + mimo.D
        # same formula, explicit inverse vs batched solve: rounding level
        np.testing.assert_allclose(G[:, :, k], ref, rtol=1e-12, atol=1e-14)


def test_to_control_works_with_python_control(mimo, model):
    sys = mimo.to_control()
    assert isinstance(sys, control.StateSpace) and sys.dt == 0
    w = np.logspace(-1, 1, 25)
    fr = control.frequency_response(sys, w)
    # python-control evaluates the same transfer function: rounding level
    np.testing.assert_allclose(fr.complex, mimo.frequency_response(w), rtol=1e-10, atol=1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)  # bode(plot=False) return is deprecated
        mag, phase, om = control.bode(model.to_control(), w, plot=False)
    np.testing.assert_allclose(mag, np.abs(model.frequency_response(w)[0, 0]), rtol=1e-10)
    closed = control.feedback(model.to_control(), 1.0)
    # unity feedback of 1/(s^2 + 0.8 s + 4): characteristic polynomial s^2 + 0.8 s + 5
    np.testing.assert_allclose(
        np.sort_complex(closed.poles()), np.sort_complex(np.roots([1, 0.8, 5])), atol=1e-12
    )
    t = np.linspace(0, 10, 501)
    u = np.sin(t)
    resp = control.forced_response(model.to_control(), T=t, U=u)
    # forced_response interpolates the input linearly (FOH): same exact discretisation
    np.testing.assert_allclose(resp.outputs, model.simulate(t, u, method="foh")[:, 0], atol=1e-12)
    assert model.to_control(noise_inputs=True).ninputs == 2


def test_discrete_model_round_trip(model):
    dm = model.to_discrete(0.1)
    assert isinstance(dm, DiscreteModel) and dm.dt == 0.1
    # ZOH maps eigenvalues by exp(lambda dt): rounding level
    np.testing.assert_allclose(
        np.sort_complex(dm.eigenvalues),
        np.sort_complex(np.exp(model.eigenvalues * 0.1)),
        atol=1e-14,
    )
    back = dm.to_continuous()
    np.testing.assert_allclose(back.A, model.A, atol=1e-12)  # logm/expm round trip
    np.testing.assert_allclose(back.K, model.K, atol=1e-12)
    t = np.arange(50) * 0.1
    u = np.cos(t)
    # the sampled model reproduces the ZOH simulation at the sample times
    np.testing.assert_allclose(dm.simulate(u), model.simulate(t, u), atol=1e-12)
    # discrete frequency response at z = e^{jw dt} equals python-control's evaluation
    w = np.linspace(0.1, 20, 30)
    fr = control.frequency_response(dm.to_control(), w)
    np.testing.assert_allclose(dm.frequency_response(w), fr.complex.reshape(1, 1, -1), rtol=1e-10)
    assert dm.to_control().dt == 0.1


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(1, 4))
def test_random_stable_systems_simulate_like_lsim(seed, n):
    rng = np.random.default_rng(seed)
    # random stable A: shift a random matrix left of its spectral abscissa
    A = rng.standard_normal((n, n))
    A -= (np.max(np.linalg.eigvals(A).real) + rng.uniform(0.1, 2.0)) * np.eye(n)
    B, C = rng.standard_normal((n, 1)), rng.standard_normal((1, n))
    m = StateSpaceModel(A, B, C, np.zeros((1, 1)), np.zeros((n, 1)))
    t = np.linspace(0, 5, 201)
    u = rng.standard_normal(201)
    _, y_ref, _ = signal.lsim((A, B, C, np.zeros((1, 1))), u, t)
    scale = max(1.0, np.abs(y_ref).max())
    # same exact FOH discretisation; rounding grows with the 200 steps
    np.testing.assert_allclose(m.simulate(t, u, method="foh")[:, 0], y_ref, atol=1e-10 * scale)


@pytest.mark.parametrize("method", ["zoh", "foh"])
def test_fit_recovers_the_initial_state_on_non_uniform_times(method):
    """``fit`` with ``x0="estimate"`` on jittered times (the one-pass forced and free
    responses): on the model's own noise-free response from a known state it returns
    that state and the response itself."""
    rng = np.random.default_rng(7)
    A = np.array([[-0.5, 2.0, 0.0], [-2.0, -0.5, 0.0], [0.0, 0.0, -3.0]])
    B, C = rng.standard_normal((3, 2)), rng.standard_normal((2, 3))
    model = StateSpaceModel(A, B, C, np.zeros((2, 2)), np.zeros((3, 2)))
    t = np.sort(rng.uniform(0.0, 10.0, 400))
    u = rng.standard_normal((t.size, 2))
    x_true = np.array([1.0, -2.0, 0.5])
    y = model.simulate(t, u, x0=x_true, method=method)
    res = model.fit(t, u, y, method=method)
    # a least-squares fit of a noise-free response: rounding of the recursion (a few
    # hundred steps) amplified by the conditioning of the observability matrix
    np.testing.assert_allclose(res.x0, x_true, rtol=0, atol=1e-9)
    np.testing.assert_allclose(res.y_sim, y, rtol=0, atol=1e-9 * np.abs(y).max())
