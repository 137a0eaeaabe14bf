"""``feedthrough="auto"`` (hdpbsid.selection.feedthrough) and a model at every order asked
for (hdpbsid.selection.auto.select_model with ``order_given``)."""

import warnings

import numpy as np
import pytest

import hdpbsid
from hdpbsid.selection.auto import decide_feedthrough
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
        return {"order": order, "criterion": err, "settings": {"feedthrough": d}}

    rows = [row(2, True, 0.1), row(3, False, 0.05), row(2, False, 0.2), row(1, True, 0.9)]
    assert [
        (r["order"], r["settings"]["feedthrough"]) for r in sorted(rows, key=structure_key)
    ] == [
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
    """Open loop, no direct term: the candidates with D are offered and lose (no better
    by one standard error), so D stays exactly zero."""
    t, u, y = _open_loop(seed, 0.0)
    model = _quiet(hdpbsid.identify, t, u, y, feedthrough="auto")
    assert "offered: open loop" in model.options["feedthrough_rule"]
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


def test_default_is_not_judged():
    """Without ``feedthrough``, D = 0 and nothing is judged: the held-out judgement is
    opt-in (its one-standard-error margin on the one-step score admits a D that then
    simulates worse on records without one)."""
    t, u, y = _open_loop(0, 0.0)
    model = _quiet(hdpbsid.identify, t, u, y, order=2, method="dt")
    assert np.all(model.D == 0.0)
    assert "feedthrough_rule" not in model.options


def _closed_loop(seed: int, ns: int = 2000, dt: float = 0.02, kp: float = 2.0, ki: float = 10.0):
    """The second-order plant sampled exactly (ZOH) under the PI controller
    ``u_k = r_k - kp y_k - ki dt sum_{j <= k} y_j``, which reacts to the measured ``y_k``
    within the sample: ``u_k`` then depends on the measurement noise ``e_k``, and every
    later ``u`` through the integral.  ``r`` random steps held 0.2 s, ``e`` white at
    20 dB of the noise-free output."""
    from scipy.linalg import expm

    A, B, C, _ = second_order()
    n = A.shape[0]
    E = expm(np.block([[A, B], [np.zeros((1, n + 1))]]) * dt)
    Ad, Bd = E[:n, :n], E[:n, n:]
    rng = np.random.default_rng(seed)
    t = dt * np.arange(ns)
    r = random_steps(rng, t, 0.2)[:, 0]
    e = rng.standard_normal(ns)

    def run(noise):
        x, s, u, y = np.zeros(n), 0.0, np.empty(ns), np.empty(ns)
        for k in range(ns):
            y[k] = (C @ x)[0] + noise[k]
            s += dt * y[k]
            u[k] = r[k] - kp * y[k] - ki * s
            x = Ad @ x + Bd[:, 0] * u[k]
        return u, y

    clean = run(np.zeros(ns))[1]
    return (t, *run(e * np.sqrt(np.mean(clean**2)) * 10 ** (-20 / 20)))


def test_closed_loop_with_an_instantaneous_controller_keeps_d_zero():
    """u_k = r_k - F y_k reacts within the sample: u_k depends on e_k, so a free D could
    predict e_k through the controller.  The feedback test sees the loop and no
    candidate with D is offered, with the order given or chosen; the true D is 0."""
    t, u, y = _closed_loop(0)
    for kwargs in (
        {"order": 2, "method": "legendre", "feedthrough": "auto"},
        {"max_order": 3, "methods": ["dt", "legendre"], "feedthrough": "auto"},
    ):
        model = _quiet(hdpbsid.identify, t, u, y, **kwargs)
        rule = model.options["feedthrough_rule"]
        assert "closed loop" in rule and "not offered" in rule
        assert np.all(model.D == 0.0)
        assert not any(r.get("feedthrough") for r in model.options.get("selection", []))


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
