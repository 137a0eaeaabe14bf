"""StateSpaceModel: simulation, fit, frequency response, scipy/python-control conversion."""

import warnings

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal
from scipy.integrate import solve_ivp

from hdpbsid import DiscreteModel, StateSpaceModel, TimeScaleWarning
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


def _rate_and_acceleration(scale: float = 1.0) -> StateSpaceModel:
    """Fast real modes and a slow pair, observed as a rate (``scale`` its unit) and as
    its derivative, which has a direct term: the rate row ``[1, 1, 1, 0]`` and ``C A``."""
    A = np.array([[-28.0, 0, 0, 0], [0, -10.0, 0, 0], [0, 0, -1.2, 5.8], [0, 0, -5.8, -1.2]])
    B = np.ones((4, 1))
    cq = np.array([[1.0, 1.0, 1.0, 0.0]])
    C, D = np.vstack([scale * cq, cq @ A]), np.vstack([[0.0], cq @ B])
    return StateSpaceModel(A, B, C, D, np.zeros((4, 2)))


def _noisy_record(model, seed, sigma, duration=30.0):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 0.004)
    u = np.repeat(rng.choice([-1.0, 1.0], t.size // 5 + 1), 5)[: t.size]  # held 0.02 s
    v = rng.standard_normal((t.size, 2)) * np.asarray(sigma)
    return t, u, model.simulate(t, u) + v, v


def _errors_three_ways(model, t, u, y):
    """The errors of the simulation (``fit``), of the one-step prediction (``predict``)
    and of :func:`~hdpbsid.refine.pem.one_step_errors`, each from its fitted ``x0``."""
    from hdpbsid.refine.pem import one_step_errors

    return (
        y - model.fit(t, u, y).y_sim,
        y - model.predict(t, u, y, k=1),
        one_step_errors(model, t, u, y),
    )


@pytest.mark.parametrize("seed", range(4))
def test_the_fitted_initial_state_does_not_trade_a_quiet_output_for_a_loud_one(seed):
    """The exact model (``K = 0``, white output noise ``v``) on a record whose rate is
    measured to 0.014 and its derivative to 1.87: every error is ``v`` but for what
    the fitted initial state (4 values from 7500 samples) takes out.  Unweighted, the
    initial state is fitted to the loud output's noise, and the rate's error grew
    3-14 % above its noise on these seeds."""
    model = _rate_and_acceleration()
    t, u, y, v = _noisy_record(model, seed, [0.014, 1.87])
    for e in _errors_three_ways(model, t, u, y):
        ratio = np.sqrt(np.mean(e**2, axis=0) / np.mean(v**2, axis=0))
        # 4 initial-state values fitted to 7500 samples change an output's error by
        # about 4 / 7500; 1 % is twenty times that
        np.testing.assert_allclose(ratio, 1.0, atol=0.01)


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), scale=st.floats(1e-3, 1e3))
def test_the_fitted_initial_state_does_not_depend_on_the_outputs_units(seed, scale):
    """The rate in other units (its row of ``C`` and its record times ``scale``): the
    acceleration's errors are unchanged and the rate's scale with it, for the
    simulation, the prediction and :func:`~hdpbsid.refine.pem.one_step_errors`."""
    t, u, y, _ = _noisy_record(_rate_and_acceleration(), seed, [0.014, 1.87], 4.0)
    base = _errors_three_ways(_rate_and_acceleration(), t, u, y)
    y2 = y * np.array([scale, 1.0])
    other = _errors_three_ways(_rate_and_acceleration(scale), t, u, y2)
    for e, e2 in zip(base, other, strict=True):
        # the same weighted least squares in both units: equal to rounding (the
        # recursions over 1000 samples and a 4-state least squares)
        np.testing.assert_allclose(e2, e * np.array([scale, 1.0]), rtol=1e-6, atol=1e-9 * scale)


# -- labels: time unit, channel names, sampling interval --------------------------------------
def _labelled(sampling_interval=0.02, time_unit="s"):
    A, B, C, D = second_order()
    return StateSpaceModel(
        A,
        B,
        C,
        D,
        np.array([[0.2], [0.1]]),
        input_names=["force"],
        output_names=["pos"],
        time_unit=time_unit,
        sampling_interval=sampling_interval,
    )


def test_to_control_names_the_signals():
    m = _labelled()
    sys = m.to_control(name="plant")
    assert sys.input_labels == ["force"] and sys.output_labels == ["pos"] and sys.name == "plant"
    noisy = m.to_control(noise_inputs=True)
    assert noisy.input_labels == ["force", "e_pos"]
    # the names survive an interconnection by name (python-control connects by label)
    ctrl = control.ss([], [], [], [[2.0]], inputs=["pos_err"], outputs=["force"], name="k")
    loop = control.interconnect(
        [sys, ctrl, control.summing_junction(["ref", "-pos"], "pos_err")],
        inplist=["ref"],
        outlist=["pos"],
    )
    # proportional feedback 2 on 1/(s^2 + 0.8 s + 4): poles of s^2 + 0.8 s + 6
    np.testing.assert_allclose(
        np.sort_complex(loop.poles()), np.sort_complex(np.roots([1, 0.8, 6])), atol=1e-12
    )
    dm = m.to_discrete(0.1)
    assert dm.input_names == ["force"] and dm.to_control().output_labels == ["pos"]
    assert dm.to_continuous().sampling_interval == 0.1


def test_labels_are_checked():
    A, B, C, D = second_order()
    with pytest.raises(ValueError, match="input_names must have 1 entries"):
        StateSpaceModel(A, B, C, D, None, input_names=["a", "b"])
    with pytest.raises(TypeError, match="output_names"):
        StateSpaceModel(A, B, C, D, None, output_names="pos")
    with pytest.raises(ValueError, match="time_unit"):
        StateSpaceModel(A, B, C, D, None, time_unit="\n")
    with pytest.raises(ValueError, match="sampling_interval"):
        StateSpaceModel(A, B, C, D, None, sampling_interval=0.0)
    m = StateSpaceModel(A, B, C, D, None)
    assert (m.input_names, m.output_names, m.time_unit) == (["u1"], ["y1"], "s")
    m.set_labels(input_names=["F"], time_unit="ms")
    assert m.input_names == ["F"] and "rad/ms" in repr(m)


@pytest.mark.parametrize(
    ("factor", "warns"),
    [(1.0, False), (2.0, False), (0.1, False), (19.0, False), (25.0, True), (1000.0, True)],
)
def test_compare_warns_on_a_foreign_sampling_interval(factor, warns):
    """The limit lies between routine resampling (up to 10) and the smallest factor
    between common time units (24); see SAMPLING_RATIO_LIMIT."""
    m = _labelled()
    t = np.arange(300) * 0.02 * factor
    u = np.sin(0.05 * np.arange(300))
    y = m.simulate(t, u)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m.compare(t, u, y)
        m.residuals(t, u, y)
        m.predict(t, u, y, k=2)
        m.fit(t, u, y)
    got = [w for w in caught if issubclass(w.category, TimeScaleWarning)]
    assert len(got) == (4 if warns else 0)  # one per call, none repeated inside
    if warns:
        assert "sampling interval" in str(got[0].message)


def test_compare_warns_on_another_time_unit():
    m = _labelled(time_unit="s")
    t = np.arange(300) * 0.02
    u = np.sin(0.05 * np.arange(300))
    y = m.simulate(t, u)
    with pytest.warns(TimeScaleWarning, match=r"1 ms = 0\.001 s"):
        m.compare(t, u, y, time_unit="ms")
    with pytest.warns(TimeScaleWarning, match="'cycles' differs"):
        m.compare(t, u, y, time_unit="cycles")
    with warnings.catch_warnings():
        warnings.simplefilter("error", TimeScaleWarning)
        m.compare(t, u, y, time_unit="s")  # the same unit and step: silent
        _labelled(sampling_interval=None).compare(t * 1000, u, y)  # no step recorded


def test_plots_carry_names_and_units():
    from hdpbsid.plots import plot_identification, plot_validation

    m = _labelled(time_unit="ms")
    rng = np.random.default_rng(4)
    t = np.arange(400) * 0.02
    u = rng.standard_normal(400)
    y = m.simulate(t, u) + 0.01 * rng.standard_normal((400, 1))
    for fig in (plot_identification(m, t, u, y), plot_validation(m, t, u, y, max_lag=10)):
        labels = [a.get_xlabel() for a in fig.axes] + [a.get_ylabel() for a in fig.axes]
        titles = " ".join(a.get_title() for a in fig.axes)
        legends = " ".join(
            t.get_text() for a in fig.axes if a.get_legend() for t in a.get_legend().get_texts()
        )
        assert any("[ms]" in s for s in labels) and "pos" in labels
        assert "rad/s" not in " ".join(labels)
        assert "force" in titles + legends
