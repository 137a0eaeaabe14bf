"""``feedthrough="auto"`` (hdpbsid.selection.feedthrough) and a model at every order asked
for (hdpbsid.selection.auto.select_model with ``order_given``)."""

import warnings

import numpy as np
import pytest

import hdpbsid
from hdpbsid.selection.auto import decide_feedthrough
from hdpbsid.selection.candidates import CandidateRow
from hdpbsid.selection.feedthrough import check_feedthrough, structure_key
from hdpbsid.systems import (
    add_noise,
    random_steps,
    second_order,
    simulate_zoh,
)

#: the direct term of the plant with one: as large as the static gain of its dynamics
#: (C A^-1 B = -1 for second_order()), so its effect on the output is not marginal
D_TRUE = 0.5


def _open_loop(seed: int, d: float, ns: int = 1501, dt: float = 0.02):
    """Second-order plant with direct term ``d``, random steps held 0.2 s, 30 dB."""
    A, B, C, D = second_order()
    t = dt * np.arange(ns)
    rng = np.random.default_rng(seed)
    u = random_steps(rng, t, 0.2)
    y = add_noise(simulate_zoh(A, B, C, np.full_like(D, d), t, u), 30.0, rng)[0]
    return t, u, y


def _quiet(func, *args, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return func(*args, **kwargs)


def test_check_feedthrough_names_the_argument():
    assert check_feedthrough(np.bool_(True)) is True
    assert check_feedthrough("auto") == "auto"
    with pytest.raises(ValueError, match="feedthrough"):
        check_feedthrough("yes")
    with pytest.raises(ValueError, match="feedthrough"):
        hdpbsid.identify(*_open_loop(0, 0.0), order=2, method="dt", feedthrough=1)


def test_structure_key_ranks_no_d_first_within_an_order():
    from hdpbsid.models.criteria import WindowedError

    def row(order, d, total):
        err = WindowedError(np.array([total]), total, 0.0, True)
        return CandidateRow("x", order, criterion=err, settings={"feedthrough": d})

    rows = [row(2, True, 0.1), row(3, False, 0.05), row(2, False, 0.2), row(1, True, 0.9)]
    assert [(r.order, r.settings["feedthrough"]) for r in sorted(rows, key=structure_key)] == [
        (1, True),
        (2, False),
        (2, True),
        (3, False),
    ]


@pytest.mark.parametrize("seed", [0, 1])
def test_auto_estimates_a_direct_term_that_is_there(seed):
    """Open loop, a direct term of the size of the static gain: the candidates with D
    predict the held-out part far better (the no-D models must imitate D u_k by a fast
    mode), so D is estimated, near its true value."""
    t, u, y = _open_loop(seed, D_TRUE)
    model = _quiet(hdpbsid.identify, t, u, y, feedthrough="auto")
    assert model.options["feedthrough"] is True
    assert "D estimated" in model.options["feedthrough_rule"]
    # 30 dB output noise on 1501 samples: the D estimate's spread is a few 1e-3; 0.05
    # (10 % of D) leaves a margin of an order of magnitude
    assert abs(model.D[0, 0] - D_TRUE) < 0.05
    assert model.n == 2
    assert any(r["feedthrough"] for r in model.options["selection"])


@pytest.mark.parametrize("seed", [0, 1])
def test_auto_keeps_d_zero_when_there_is_none(seed):
    """Open loop, no direct term, a zero-order-held input: y_k depends on u up to
    u_{k-1} only, so the innovations of u and y are not linked at lag 0 and no candidate
    with D is fitted (the screen); D stays exactly zero."""
    t, u, y = _open_loop(seed, 0.0)
    model = _quiet(hdpbsid.identify, t, u, y, feedthrough="auto")
    assert "not offered: open loop" in model.options["feedthrough_rule"]
    assert "no lag-0 link" in model.options["feedthrough_rule"]
    assert not any(r["feedthrough"] for r in model.options["selection"])
    assert "returned: D = 0" in model.options["feedthrough_rule"]
    assert np.all(model.D == 0.0)


def test_order_and_method_given_decide_by_two_candidates():
    t, u, y = _open_loop(0, D_TRUE)
    has_d, why = decide_feedthrough("dt", t, u, y, 2, {})
    assert has_d and "D estimated" in why
    has_d, why = decide_feedthrough("dt", *_open_loop(0, 0.0), 2, {})
    assert not has_d and "D = 0" in why
    model = _quiet(hdpbsid.identify, t, u, y, order=2, method="dt", feedthrough="auto")
    assert model.options["feedthrough"] is True
    assert abs(model.D[0, 0] - D_TRUE) < 0.05  # as in the test above


def test_default_judges_the_direct_term():
    """Without ``feedthrough`` the direct term is judged (the default is "auto"); on a
    record without one, D stays exactly zero and the rule says why."""
    t, u, y = _open_loop(0, 0.0)
    model = _quiet(hdpbsid.identify, t, u, y, order=2, method="dt")
    assert np.all(model.D == 0.0)
    assert "D = 0" in model.options["feedthrough_rule"]
    model = _quiet(hdpbsid.identify, t, u, y, order=2, method="dt", feedthrough=False)
    assert "feedthrough_rule" not in model.options


def _closed_loop(
    seed: int,
    ns: int = 3000,
    dt: float = 0.02,
    kp: float = 1.0,
    ki: float = 2.0,
    d: float = 0.0,
    delay: int = 0,
    snr_db: float = 15.0,
    hold: float = 0.2,
):
    """The second-order plant (direct term ``d``) sampled exactly (ZOH) under the PI
    controller ``u_k = r_k - kp y_{k-delay} - ki dt sum_{j <= k-delay} y_j``: with
    ``delay=0`` it reacts to the measured ``y_k`` within the sample, so ``u_k`` depends on
    the measurement noise ``e_k`` (and every later ``u`` through the integral); with
    ``delay=1`` it has one sample of delay (a digital controller computing ``u_k`` from
    ``y_{k-1}``), so ``u_k`` does not depend on ``e_k`` and ``D`` is identifiable.  ``r``
    random steps held 0.2 s, ``e`` white at ``snr_db`` of the noise-free output: at
    15 dB on 3000 samples the noise fed back shows in the feedback test (its statistic
    1.3-2.6 times the threshold on the seeds used; at 20 dB this weak loop leaves it
    near the threshold).
    The default gains keep the sampled loop stable with either delay and with
    ``d = 0.5`` (spectral radius below 0.997)."""
    from scipy.linalg import expm

    A, B, C, _ = second_order()
    n = A.shape[0]
    E = expm(np.block([[A, B], [np.zeros((1, n + 1))]]) * dt)
    Ad, Bd = E[:n, :n], E[:n, n:]
    rng = np.random.default_rng(seed)
    t = dt * np.arange(ns)
    r = random_steps(rng, t, hold)[:, 0]
    e = rng.standard_normal(ns)

    def run(noise):
        x, u, y = np.zeros(n), np.zeros(ns), np.zeros(ns)
        s = 0.0
        for k in range(ns):
            x_out = (C @ x)[0]
            if delay:
                y_seen = y[k - 1] if k else 0.0
                s += dt * y_seen
                u[k] = r[k] - kp * y_seen - ki * s
                y[k] = x_out + d * u[k] + noise[k]
            else:
                y[k] = x_out + noise[k]  # no direct term: the loop is well posed
                s += dt * y[k]
                u[k] = r[k] - kp * y[k] - ki * s
            x = Ad @ x + Bd[:, 0] * u[k]
        return u, y

    clean = run(np.zeros(ns))[1]
    return (t, *run(e * np.sqrt(np.mean(clean**2)) * 10 ** (-snr_db / 20)))


def test_closed_loop_with_an_instantaneous_controller_keeps_d_zero():
    """u_k = r_k - F y_k reacts within the sample: u_k depends on e_k, so a free D could
    predict e_k through the controller.  D is offered (no test tells the controller's
    path from a direct term) and loses on the held-out part; the true D is 0, and it
    stays exactly 0, with the order given or chosen."""
    t, u, y = _closed_loop(0)
    for kwargs in (
        {"order": 2, "method": "legendre"},
        {"max_order": 3, "methods": ["dt", "legendre"]},
    ):
        model = _quiet(hdpbsid.identify, t, u, y, **kwargs)
        rule = model.options["feedthrough_rule"]
        assert "closed loop" in rule and "D estimated" not in rule, rule
        assert np.all(model.D == 0.0)


def test_without_own_d_is_the_structure_without_d():
    """A Laguerre model (its ``D`` estimated whatever it is asked) made a structure
    without ``D``: ``D`` exactly zero and reported so, its dynamics and noise model
    unchanged."""
    from hdpbsid.selection.feedthrough import honours_feedthrough, without_own_d

    t, u, y = _open_loop(0, 0.0)
    own = _quiet(hdpbsid.identify, t, u, y, 2, method="laguerre", refine=None)
    assert not honours_feedthrough(own) and np.any(own.D != 0.0)
    plain = without_own_d(own)
    assert np.all(plain.D == 0.0) and honours_feedthrough(plain)
    assert not plain.report.feedthrough.estimated and plain.options["feedthrough"] is False
    for name in ("A", "B", "C", "K"):
        np.testing.assert_array_equal(getattr(plain, name), getattr(own, name))


def _servo(seed: int, snr_db: float = 20.0, ns: int = 3000, h: float = 0.01):
    """A position servo: ``3 / (s (s + 3))`` (an integrator and a pole at -3 rad/s)
    sampled exactly (ZOH) under the proportional controller ``u_k = 2 (r_k - y_k)`` on
    the measured position, which reacts within the sample (``u_k`` depends on the
    measurement noise ``e_k``); ``r`` random signs held 0.5 s, ``e`` white at ``snr_db``
    of the noise-free output.  The loop's poles are -1.5 +- 1.9i rad/s."""
    from scipy.linalg import expm

    A = np.array([[0.0, 1.0], [0.0, -3.0]])
    B = np.array([[0.0], [3.0]])
    E = expm(np.block([[A, B], [np.zeros((1, 3))]]) * h)
    Ad, Bd = E[:2, :2], E[:2, 2]
    rng = np.random.default_rng(seed)
    r = np.repeat(rng.choice([-1.0, 1.0], ns // 50 + 1), 50)[:ns]

    def run(noise):
        x, u, y = np.zeros(2), np.empty(ns), np.empty(ns)
        for k in range(ns):
            y[k] = x[0] + noise[k]
            u[k] = 2.0 * (r[k] - y[k])
            x = Ad @ x + Bd * u[k]
        return u, y

    clean = run(np.zeros(ns))[1]
    u, y = run(rng.standard_normal(ns) * np.sqrt(np.mean(clean**2)) * 10 ** (-snr_db / 20))
    return h * np.arange(ns), u[:, None], y[:, None]


def test_a_method_with_its_own_direct_term_competes_without_it():
    """Under a controller reacting within the sample, a direct term predicts the noise
    through the controller.  The rule refuses ``D``; a method that estimates ``D`` of its
    own (Laguerre's ``D_d`` mapped back) then competes without it: with its own ``D`` it
    won the selection at order 7 on this record by that prediction, with poles the
    servo does not have.  With every default: ``D = 0`` exactly, order 2, the pole at
    -3 rad/s and the integrator."""
    t, u, y = _servo(0)
    model = _quiet(hdpbsid.identify, t, u, y)
    rule = model.options["feedthrough_rule"]
    # the premise: D offered in closed loop and refused, Laguerre candidates in the pool
    assert "closed loop" in rule and rule.endswith("returned: D = 0"), rule
    assert any(row["method"] == "laguerre" for row in model.options["selection"])
    assert np.all(model.D == 0.0) and model.n == 2, model.options["selection_rule"]
    ev = np.sort(model.eigenvalues.real)
    # 30 s at 20 dB: the pole within 5 % (measured 0.7 %), the integrator within
    # 0.05 rad/s of zero (measured 0.001; the record resolves 2 pi / 30 s = 0.2 rad/s)
    assert abs(ev[0] / -3.0 - 1.0) < 0.05 and abs(ev[1]) < 0.05


@pytest.mark.parametrize("seed", [0, 1])
def test_closed_loop_with_a_sample_of_delay_estimates_the_direct_term(seed):
    """A loop with one sample of delay (u_k from y_{k-1}) and a direct term of twice the
    plant's static gain: D is identifiable and estimated near its true value, with the
    defaults.  The loop is strong against its excitation (white ``r`` at 10 dB, gain
    1.8; spectral radius 0.997), so the noise fed back is much of the input's
    innovation and the controller bound leaves room (about 0.7 of the simulation error
    against the 0.9 that D explains).  In a weak loop (the steps of the tests above)
    the bound is near 1: no data tell D from a controller's path there."""
    t, u, y = _closed_loop(seed, d=D_TRUE, delay=1, kp=1.8, ki=0.5, snr_db=10.0, hold=0.02)
    model = _quiet(hdpbsid.identify, t, u, y)
    rule = model.options["feedthrough_rule"]
    assert "offered: closed loop" in rule and "D estimated" in rule
    assert model.options["feedthrough"] is True
    # 10 dB on 3000 samples: the estimate's spread is about 1e-2 (the prediction-error
    # fit's standard deviation); 0.1 (20 % of D) is beyond any BLAS rounding
    assert abs(model.D[0, 0] - D_TRUE) < 0.1


def test_closed_loop_with_a_sample_of_delay_and_no_direct_term_keeps_d_zero():
    t, u, y = _closed_loop(0, delay=1)
    model = _quiet(hdpbsid.identify, t, u, y)
    assert "closed loop" in model.options["feedthrough_rule"]
    assert np.all(model.D == 0.0)


def test_explicit_feedthrough_is_not_judged():
    t, u, y = _open_loop(0, 0.0)
    model = _quiet(hdpbsid.identify, t, u, y, order=2, method="dt", feedthrough=True)
    assert model.options["feedthrough"] is True
    assert "feedthrough_rule" not in model.options


@pytest.mark.parametrize("order", [7, 8])
def test_a_model_at_every_order_asked_for_on_a_short_record(order):
    """450 samples: the basis methods' default past window cannot reach orders 7-8
    (p (m + q + l) <= N / 6 with N = 100) and ``dt`` has no continuous-time model at
    some of them; the selection still answers at the order asked for, and the failing
    candidates are in the table with their reason."""
    t, u, y = _open_loop(1, 0.0, ns=450, dt=0.05)
    model = _quiet(hdpbsid.identify, t, u, y, order=order)
    assert model.n == order
    assert np.all(np.isfinite(model.A))
    table = model.options["selection"]
    assert all(r["order"] == order for r in table)
    assert any(r["status"] != "ok" for r in table)
    if model.options["method"] != "dt":
        assert "order asked for" in model.options["p_rule"]


def _linear_between_samples(seed: int):
    """A third-order plant without a direct term, a binary input changing every sample
    and simulated linear between samples (``lsim``'s default), 20 dB: a fast real mode
    (|lambda| h = 0.15) and a lightly damped pair."""
    from scipy import signal

    lam = np.array([-0.45 + 1.89j, -0.45 - 1.89j, -15.4])
    A, B, C, D = signal.tf2ss([0.3, -1.2, 2.0], np.real(np.poly(lam)))
    rng = np.random.default_rng(seed)
    t = np.arange(4000) * 0.01
    u = np.sign(rng.standard_normal(t.size))
    _, y, _ = signal.lsim((A, B, C, D), u, t)
    return t, u, add_noise(y, 20.0, rng)[0], lam


@pytest.mark.parametrize("seed", [9, 10])
def test_an_input_linear_between_samples_is_not_taken_for_a_direct_term(seed):
    """The linear hold links u_k to y_k within the sample as a direct term does with a
    held input, and the direct term is judged before the refinement chooses the hold; the
    linear hold without D is then tested against the held input with D (the smaller
    of two nested structures), fits as well, and is returned with D = 0."""
    from hdpbsid.models.metrics import eigenvalue_errors

    t, u, y, lam = _linear_between_samples(seed)
    model = _quiet(hdpbsid.identify, t, u, y, 3, method="dt")
    # the judgement before the hold took the link for D
    assert "D estimated" in model.options["feedthrough_rule"]
    assert "the linear hold explains the lag-0 link, D = 0" in model.options["linear_hold_rule"]
    assert model.options["input_hold"] == "foh"
    assert np.all(model.D == 0.0)
    # the 20 dB spread of these eigenvalues is ~0.5 %; 2 % leaves room for the seed
    assert eigenvalue_errors(model.eigenvalues, lam).max() < 0.02


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_direct_term_with_a_held_input_is_not_taken_for_the_linear_hold(seed):
    """The converse: a plant with a direct term and a held input.  The linear hold
    without D cannot give the sampled direct term independently of the dynamics
    (``C G2 B``), so it is rejected, by the likelihood ratio or because its fit from
    the held-input model does not converge within one run; D is kept."""
    t, u, y = _open_loop(seed, D_TRUE)
    model = _quiet(hdpbsid.identify, t, u, y, order=2, method="dt")
    rule = model.options["linear_hold_rule"]
    assert rule.startswith("the input linear between samples without D") and rule.endswith("D kept")
    assert model.options["input_hold"] == "zoh"
    assert abs(model.D[0, 0] - D_TRUE) < 0.05  # as in test_auto_estimates_a_direct_term...


@pytest.mark.parametrize("method", ["laguerre", "auto"])
def test_a_direct_term_asked_for_is_estimated_by_a_method_with_its_own(method):
    """``feedthrough=True`` asks for ``D`` as a parameter of the model; the Laguerre
    method estimates a direct term of its own whatever it is asked, and the refinement
    fixed ``D`` at zero for such a model (the structure every method assumes by
    default), so the direct term asked for was lost.  Oracle: the second-order plant
    with ``D = 0.5`` at 30 dB, 1501 samples."""
    t, u, y = _open_loop(0, D_TRUE)
    kw = {"methods": ["laguerre"]} if method == "auto" else {}
    model = _quiet(hdpbsid.identify, t, u, y, order=2, method=method, feedthrough=True, **kw)
    assert model.report.method == "laguerre"
    assert model.report.feedthrough.asked
    # 30 dB on 1501 samples: the least-squares D is within a few percent (measured 0.3 %)
    assert abs(model.D[0, 0] / D_TRUE - 1.0) < 0.05
