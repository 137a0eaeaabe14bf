"""The statistics of the direct-term rule (hdpbsid.selection.feedthrough): the paired
standard error, the input's predictability, and the closed-loop bound on what a
controller reacting within the sample can imitate, against analytic oracles."""

from __future__ import annotations

import numpy as np
import pytest

from hdpbsid.models.criteria import WindowedError
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.selection.feedthrough import (
    FeedthroughReason,
    controller_share,
    input_innovation,
    judge_direct_term,
    lag0_link,
    paired_z,
)


def _err(per_window) -> WindowedError:
    w = np.asarray(per_window, dtype=float)
    return WindowedError(w, float(w.sum()), 0.0, True)


def test_paired_z_is_the_paired_t_statistic_of_the_log_ratios():
    a, b = _err([1.0, 1.2, 0.9, 1.1, 1.3]), _err([0.7, 1.0, 0.8, 0.8, 1.0])
    d = np.log(a.per_window / b.per_window)
    # the one-sample t statistic of the log ratios, written out
    assert paired_z(a, b) == pytest.approx(d.mean() / (d.std(ddof=1) / np.sqrt(5)), rel=1e-12)
    assert paired_z(b, a) == pytest.approx(-paired_z(a, b), rel=1e-12)
    # scale free: errors near overflow give the same statistic
    big = [_err(1e300 * e.per_window) for e in (a, b)]
    assert paired_z(*big) == pytest.approx(paired_z(a, b), rel=1e-9)
    # each window counts by its ratio, not its size: a window a million times larger in
    # both models changes nothing
    scale = np.r_[1e6, np.ones(4)]
    assert paired_z(_err(scale * a.per_window), _err(scale * b.per_window)) == pytest.approx(
        paired_z(a, b), rel=1e-9
    )
    assert paired_z(a, WindowedError(np.full(5, np.inf), np.inf, -np.inf, False)) == -np.inf
    assert paired_z(a, a) == 0.0


@pytest.mark.parametrize("a", [0.0, 1.0, 3.0])
def test_controller_share_of_a_one_lag_feedback(a):
    """u_k = a y_{k-1} + eta_k with y and eta white and independent (unit variances):
    past y predicts all of u but eta, u's own past nothing, so the share is
    var(eta) / var(u) = 1 / (1 + a^2)."""
    rng = np.random.default_rng(0)
    ns = 20000
    y = rng.standard_normal((ns, 1))
    u = a * np.r_[0.0, y[:-1, 0]] + rng.standard_normal(ns)
    share = controller_share(u[:, None], y, 10)
    # 20000 samples: a variance ratio's spread is about 1e-2 (plus 21 / 20000 of
    # overfit); 0.03 is three times that
    assert share == pytest.approx(1.0 / (1.0 + a**2), abs=0.03)


def _static_loop(rng, ns, f, d, delay, phi=0.95):
    """``y_k = b u_{k-1} + d u_k + v_k`` (``b = 0.5``) under ``u_k = r_k - f y_{k-delay}``:
    ``delay=0`` reacts within the sample (with ``d = 0``), ``delay=1`` has a sample of
    delay; ``|f b| < 1`` and ``|f d| < 1`` keep the loop stable.  ``r`` AR(1) with
    coefficient ``phi``, ``v`` white, both of unit innovation variance."""
    b = 0.5
    eta, v = rng.standard_normal(ns), rng.standard_normal(ns)
    r = np.zeros(ns)
    for k in range(1, ns):
        r[k] = phi * r[k - 1] + eta[k]
    u, y = np.zeros(ns), np.zeros(ns)
    for k in range(1, ns):
        if delay:
            u[k] = r[k] - f * y[k - 1]
        else:
            u[k] = r[k] - f * (b * u[k - 1] + v[k])
        y[k] = b * u[k - 1] + d * u[k] + v[k]
    return u, y


def _simulation_gain(u, y):
    """Relative drop of the output-error (least-squares simulation) residual when a
    direct term joins the one-lag model."""
    X1, X2 = u[:-1, None], np.column_stack([u[:-1], u[1:]])
    target = y[1:]
    r1 = target - X1 @ np.linalg.lstsq(X1, target, rcond=None)[0]
    r2 = target - X2 @ np.linalg.lstsq(X2, target, rcond=None)[0]
    return 1.0 - float(r2 @ r2) / float(r1 @ r1)


@pytest.mark.parametrize("f", [0.3, 1.0, 1.8])
def test_a_controller_path_lowers_the_simulation_by_less_than_the_bound(f):
    """The module's bound: with no direct term and a controller reacting within the
    sample, the direct term that best simulates y from u lowers the simulation error by
    at most the controller share; with a sample of delay in the loop a real direct
    term lowers it by more, and none by nothing beyond sampling."""
    rng = np.random.default_rng(1)
    ns = 20000
    u, y = _static_loop(rng, ns, f, 0.0, delay=0)
    bound = controller_share(u[:, None], y[:, None], 10)
    # the inequality F^2 s_v^2 <= var(w) has the slack var(eta) / var(u) (at f = 1.8 the
    # noise fed back is most of the innovation); sampling spreads of 20000 samples are
    # a few 1e-3 of either side
    assert _simulation_gain(u, y) < bound
    # a sample of delay, a direct term twice the plant's lag gain and as large as the
    # noise: gains 0.8-0.9 against shares 0.24-0.44 at these loop gains
    u, y = _static_loop(rng, ns, 0.9, 1.0, delay=1)
    assert _simulation_gain(u, y) > controller_share(u[:, None], y[:, None], 10) + 0.2
    u, y = _static_loop(rng, ns, 0.9, 0.0, delay=1)
    # no direct term, no lag-0 path: the gain is the overfit of one parameter, ~1 / ns
    assert _simulation_gain(u, y) < 1e-3


def test_judge_direct_term_needs_more_than_the_bound():
    """Two identical models: no gain, so D = 0 for the one-step reason; the bound alone
    rejects a candidate with D that wins every statistical comparison."""
    t = 0.1 * np.arange(600)
    rng = np.random.default_rng(2)
    u = rng.standard_normal((600, 1))
    A, B, C = np.array([[-1.0]]), np.array([[1.0]]), np.array([[1.0]])
    plain = StateSpaceModel(A, B, C, np.zeros((1, 1)), np.zeros((1, 1)))
    direct = StateSpaceModel(A, B, C, np.array([[0.5]]), np.zeros((1, 1)))
    y = direct.simulate(t, u) + 0.01 * rng.standard_normal((600, 1))
    val = (t, u, y)
    from hdpbsid.models.criteria import windowed_prediction_error

    scores = tuple(windowed_prediction_error(m, t, u, y, 8) for m in (plain, plain))
    same = judge_direct_term(plain, plain, scores, val, 8)
    assert not same.value and same.reason is FeedthroughReason.LOST_PREDICTION
    scores = tuple(windowed_prediction_error(m, t, u, y, 8) for m in (plain, direct))
    won = judge_direct_term(plain, direct, scores, val, 8)
    assert won.value and won.reason is FeedthroughReason.WON and won.gain > 0.9
    capped = judge_direct_term(plain, direct, scores, val, 8, bound=won.gain + 0.01)
    assert not capped.value
    assert capped.reason is FeedthroughReason.WITHIN_CONTROLLER_BOUND
    assert "D = 0" in capped.text() and "closed loop" in capped.text()
    # a deterministic input asks for a larger gain whatever the loop
    weak = judge_direct_term(plain, direct, scores, val, 8, min_gain=won.gain + 0.01)
    assert not weak.value and weak.reason is FeedthroughReason.NOT_IDENTIFIED
    assert "deterministic input" in weak.text()


def test_input_innovation_tells_a_deterministic_input():
    """A sum of sinusoids is predicted exactly by its own past (an AR recursion of twice
    the number of tones), so nothing of it is left for D; white noise is all
    innovation; filtered noise keeps a share far above the floor."""
    from scipy.signal import lfilter

    from hdpbsid.selection.feedthrough import FEEDTHROUGH_POLICY, arx_residuals

    ns, lags = 4000, 20
    k = np.arange(ns)
    rng = np.random.default_rng(3)
    y = rng.standard_normal((ns, 1))
    sines = sum(np.sin(0.05 * j * k + j) for j in range(1, 6))[:, None]
    white = rng.standard_normal((ns, 1))
    smooth = lfilter([1.0], [1.0, -1.8, 0.81], white[:, 0])[:, None]

    def share(u):
        return input_innovation(arx_residuals(y, u, lags)[lags:], u[lags:])

    # rounding leaves ~1e-20 of a deterministic input; the floor is sqrt(eps) ~ 1.5e-8
    assert share(sines) < FEEDTHROUGH_POLICY.innovation_floor
    # white noise: only the 40 regressors' overfit (~1 %) is predicted
    assert share(white) == pytest.approx(1.0, abs=0.03)
    # AR(2) noise: the innovation is var(white) / var(smooth), about 1e-2 here
    assert share(smooth) > 1e3 * FEEDTHROUGH_POLICY.innovation_floor


def test_lag0_link_is_bartletts_test():
    """Independent white innovations exceed the threshold about as often as its level
    says; a direct term's link (e = d w + v) is found."""

    rng = np.random.default_rng(4)
    hits = 0
    for _ in range(400):
        e, w = rng.standard_normal((500, 2)), rng.standard_normal((500, 1))
        stat, thr = lag0_link(e, w)
        hits += stat > thr
    # level 1 %: 4 of 400 expected; the binomial spread is 2, so 12 is four of them
    assert hits <= 12
    w = rng.standard_normal((2000, 1))
    e = 0.2 * w + rng.standard_normal((2000, 1))
    # d = 0.2: the correlation 0.2 gives N r^2 = 80 against a threshold of 6.6
    stat, thr = lag0_link(e, w)
    assert stat > 5 * thr


def test_arx_innovations_are_the_two_arx_predictors_residuals():
    """One factorisation for both predictors: the residuals equal those of the two
    separate least-squares fits (same regressors, columns permuted), to rounding."""
    from hdpbsid.selection.feedthrough import arx_innovations, arx_residuals

    rng = np.random.default_rng(3)
    u = rng.standard_normal((600, 2))
    y = np.cumsum(rng.standard_normal((600, 1)), axis=0) * 0.1 + u[:, :1]
    e, w = arx_innovations(u, y, 5)
    # the regressors are well conditioned here: 1e-9 of the signals' scale is rounding
    np.testing.assert_allclose(e, arx_residuals(u, y, 5), atol=1e-9)
    np.testing.assert_allclose(w, arx_residuals(y, u, 5), atol=1e-9)
    assert np.all(e[:5] == 0) and np.all(w[:5] == 0)
