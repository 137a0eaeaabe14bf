"""The Laguerre pole from the identified dynamics (hdpbsid.bases.laguerre_pole)."""

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hdpbsid
from hdpbsid.bases.laguerre_pole import (
    LaguerrePole,
    PoleRule,
    PoleSource,
    decide_pole,
    dynamics_band,
    map_back_amplification,
    minimax_pole,
)
from hdpbsid.methods.laguerre import cayley, inverse_cayley
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.systems import add_noise, random_steps, simulate_zoh


@settings(max_examples=30, deadline=None)
@given(
    st.floats(0.05, 50.0),
    st.floats(0.01, 100.0),
    st.floats(0.0, 100.0),
)
def test_amplification_is_the_derivative_of_the_map_back(a, sigma, omega):
    """g(a, lambda) against a central difference of the method's inverse Cayley map:
    the relative change of lambda per unit change of mu = (lambda + a)/(lambda - a)."""
    lam = complex(-sigma, omega)
    mu = (lam + a) / (lam - a)
    h = 1e-6 * abs(mu - 1.0)

    def back(m):  # the 1x1 (complex) inverse map: lambda = a (mu + 1)/(mu - 1)
        A = inverse_cayley(np.array([[m]]), np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)), a)
        return A[0][0, 0]

    numeric = abs(back(mu + h) - back(mu - h)) / (2 * h) / abs(lam)
    # central difference of a smooth map with h ~ 1e-6 |mu - 1|: truncation O(h^2)
    # relative, rounding ~1e-16/h ~ 1e-10 relative: 1e-6 is far above both
    assert numeric == pytest.approx(float(map_back_amplification(a, [lam])[0]), rel=1e-6)


def test_cayley_pair_round_trip_is_exact():
    """The maps the amplification is about invert each other (a sanity check of the
    oracle above on a real 2x2 pair)."""
    A = np.array([[-0.3, 1.5], [-1.5, -0.3]])
    B, C, D = np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))
    back = inverse_cayley(*cayley(A, B, C, D, 7.0), 7.0)
    np.testing.assert_allclose(back[0], A, atol=1e-12)  # two 2x2 inverses: rounding only


@settings(max_examples=30, deadline=None)
@given(st.floats(0.01, 10.0), st.floats(1.5, 1000.0))
def test_minimax_pole_of_two_real_modes_is_their_geometric_mean(slow, ratio):
    """Equal damping (real poles, zeta = 1): g(., lambda_i) are symmetric about
    log |lambda_i| in log a, so the largest is smallest half-way in log a."""
    a = minimax_pole([-slow, -slow * ratio])
    # the grid has GRID_PER_DECADE = 240 points per decade: a step of 1 %
    assert a == pytest.approx(slow * np.sqrt(ratio), rel=0.011)


def test_minimax_pole_of_one_mode_is_its_magnitude_and_none_without_modes():
    assert minimax_pole([-0.3 + 1.5j, -0.3 - 1.5j]) == pytest.approx(abs(-0.3 + 1.5j))
    assert minimax_pole([]) is None
    pole = LaguerrePole(2.0, PoleSource.GIVEN, "given")
    with pytest.raises(AttributeError):
        pole.a = 3.0  # frozen


#: the stiff plant of the measured-like benchmark: a real pole at -80 and a lightly
#: damped pair at -0.3 +- 1.5i, both visible in the output (parallel modal form)
A_STIFF = np.array([[-80.0, 0.0, 0.0], [0.0, -0.3, 1.5], [0.0, -1.5, -0.3]])
B_STIFF = np.array([[80.0], [0.0], [1.0]])
C_STIFF = np.array([[1.0, 1.0, 0.0]])


def _stiff_record(seed: int, snr: float = 40.0, dt: float = 0.01, ns: int = 6000):
    rng = np.random.default_rng(seed)
    t = dt * np.arange(ns)
    u = random_steps(rng, t, 0.05)
    y = simulate_zoh(A_STIFF, B_STIFF, C_STIFF, np.zeros((1, 1)), t, u)
    return t, u, add_noise(y, snr, rng)[0]


@pytest.mark.parametrize("seed", [0, 1])
@pytest.mark.parametrize("a", [None, "dynamics"])
def test_laguerre_on_a_stiff_record_takes_its_pole_from_the_dynamics(seed, a):
    """Steps held 0.05 s put the data bandwidth near 190 rad/s, and the first pass's pole
    (95) is 60 times the pair's |lambda|: its model is far off (a spurious mode, or the
    pair lost), and its modes are ill-conditioned there, so the default asks the
    dynamics as ``a="dynamics"`` does.  The pole from the dynamics lies between the
    modes, and both are recovered within 5 % (the target at 40 dB), before any
    refinement."""
    t, u, y = _stiff_record(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = hdpbsid.identify(t, u, y, order=3, method="laguerre", refine=None, a=a)
    assert model.options["a_source"] == "dynamics"
    lam = np.linalg.eigvals(A_STIFF)
    assert 1.5 < model.options["a"] < 80.0
    assert np.max(eigenvalue_errors(np.linalg.eigvals(model.A), lam)) < 0.05


def _random_stiff_17():
    """Random stiff system 17 of ``bench/stiff_laguerre.py --random`` (seed 1017): a real
    pole at -249, a pair at -0.97 +- 1.74i that reaches the output weakly, 20 000 samples
    with |lambda| h = 0.72 for the fast pole, steps held a few samples, 40 dB."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "bench"))
    from stiff_laguerre import random_stiff

    t, u, y, A, _, _ = random_stiff(17, 40.0)
    return t, u, y, A


def test_the_band_is_what_the_samples_resolve_whatever_the_output_spectrum():
    """The lower edge is one period of the record and the upper the Nyquist frequency, for
    a record whose output energy lies far above the former (a fast sine): where the
    energy lies says how much each mode reaches the output, not where the modes are."""
    from types import SimpleNamespace

    t = 0.01 * np.arange(5001)  # T = 50 s
    rec = SimpleNamespace(t=t, u=np.zeros((t.size, 1)), y=np.sin(30.0 * t)[:, None])
    w_lo, w_hi = dynamics_band([rec])
    assert w_lo == pytest.approx(2 * np.pi / 50.0, rel=1e-12)  # arithmetic only
    assert w_hi == pytest.approx(np.pi / 0.01, rel=1e-12)


def test_laguerre_default_on_a_stiff_record_whose_pair_barely_reaches_the_output():
    """Nearly all the output energy is the fast mode's: 1 % of it lies below about 3
    rad/s, above the pair's |lambda| = 2.  The first pass at the bandwidth pole (360)
    loses the pair (a spurious mode beyond Nyquist), so the band's edges stand in
    for the modes; with the lower edge at one period of the record the passes reach a
    pole that resolves the pair, and the default call is within 5 % (the target at
    40 dB; the fit started at the true system is within 0.4 %)."""
    t, u, y, A = _random_stiff_17()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = hdpbsid.identify(t, u, y, order=3, method="laguerre")
    assert model.options["a_source"] == "dynamics"
    assert np.max(eigenvalue_errors(model.eigenvalues, np.linalg.eigvals(A))) < 0.05


def test_laguerre_pole_names_the_argument():
    t, u, y = _stiff_record(0)
    with pytest.raises(ValueError, match="'dynamics'"):
        hdpbsid.identify(t, u, y, order=3, method="laguerre", a="modes")


def test_laguerre_given_pole_is_kept():
    t, u, y = _stiff_record(0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = hdpbsid.identify(t, u, y, order=3, method="laguerre", refine=None, a=20.0)
    assert model.options["a"] == 20.0 and model.options["a_rule"] == "given"


class _PoleModel:
    """A stand-in with the state matrix the passes read."""

    def __init__(self, eigenvalues):
        self.A = np.diag(np.asarray(eigenvalues, dtype=float))


class _Rec:
    def __init__(self, m: int = 1, ns: int = 50):
        self.t = 0.01 * np.arange(ns)
        self.u = np.ones((ns, m))
        self.y = np.ones((ns, 1))


def test_decide_pole_given_and_bandwidth_take_one_fit():
    fits = []

    def fit(a):
        fits.append(a)
        return _PoleModel([-1.0])

    pole, _ = decide_pole(2.0, 5.0, fit, [_Rec()])
    assert (pole.rule, pole.a, pole.source) == (PoleRule.GIVEN, 2.0, PoleSource.GIVEN)
    assert pole.options() == {"a_rule": "given"}
    pole, _ = decide_pole("bandwidth", 5.0, fit, [_Rec()])
    assert (pole.rule, pole.a) == (PoleRule.BANDWIDTH, 5.0)
    assert pole.options() == {"a_rule": "half the data bandwidth"}  # no a_source
    assert fits == [2.0, 5.0]


def test_default_pole_asks_the_dynamics_only_when_ill_conditioned(monkeypatch):
    """``a=None``: the mode -1 at the pole 5 has ``g = 6^2 / 10 = 3.6`` (one fit, the
    bandwidth pole kept); the mode -0.05 has ``g = 5.05^2 / 0.5 = 51`` > 10, so the pole
    is asked of the dynamics, which put it at the mode's magnitude."""
    from hdpbsid.bases import laguerre_pole

    monkeypatch.setattr(laguerre_pole, "dynamics_band", lambda records: (0.01, 1000.0))
    fits = []

    def fit_at(mode):
        def fit(a):
            fits.append(a)
            return _PoleModel([mode])

        return fit

    pole, _ = decide_pole(None, 5.0, fit_at(-1.0), [_Rec()])
    assert (pole.rule, pole.a, fits) == (PoleRule.CONDITIONED, 5.0, [5.0])
    assert "3.6" in pole.reason
    fits.clear()
    policy = type(laguerre_pole.OPERATOR_SCALE)
    monkeypatch.setattr(policy, "in_sample_screen", lambda self, *args: _Take())
    pole, _ = decide_pole(None, 5.0, fit_at(-0.05), [_Rec()])
    assert pole.rule is PoleRule.SCREEN_WON and pole.source is PoleSource.DYNAMICS
    assert pole.a == pytest.approx(0.05, rel=0.011)  # the grid's 1 % step
    assert fits[0] == 5.0 and len(fits) == 2  # the first pass is fitted once


class _Take:
    """A screen that takes the change."""

    take_new = True
    how = "stand-in"


def test_decide_pole_from_the_dynamics_typed_ways(monkeypatch):
    from hdpbsid.bases import laguerre_pole

    monkeypatch.setattr(laguerre_pole, "dynamics_band", lambda records: (0.01, 1000.0))
    # several records or a time series: a change cannot be screened, one fit
    for records in ([_Rec(), _Rec()], [_Rec(m=0)]):
        pole, _ = decide_pole("dynamics", 5.0, lambda a: _PoleModel([-1.0]), records)
        assert pole.rule is PoleRule.NOT_SCREENABLE and pole.a == 5.0
        assert pole.options()["a_source"] == "bandwidth"
    # the first pass's modes ask for its own pole
    pole, _ = decide_pole("dynamics", 1.0, lambda a: _PoleModel([-1.0]), [_Rec()])
    assert pole.rule is PoleRule.FIRST_PASS_ASKED and pole.passes == (1.0,)

    # the fit at the modes' pole fails: the first pass is kept
    def failing(a):
        if a != 5.0:
            raise ValueError("no model")
        return _PoleModel([-1.0])

    pole, _ = decide_pole("dynamics", 5.0, failing, [_Rec()])
    assert pole.rule is PoleRule.REFIT_FAILED and pole.a == 5.0 and pole.passes[0] == 5.0
    assert pole.reason.endswith("its modes ask for it")  # the text the rule had before


def test_diverging_predictor_prints_nothing_from_lapack(capfd):
    """A first-pass model whose one-step predictor diverges (the bandwidth pole on the
    stiff record) is not refined, and no non-finite free response reaches LAPACK, whose
    scaling routine would print "On entry to DLASCL ..." on the process's standard output."""
    t, u, y = _stiff_record(1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = hdpbsid.identify(t, u, y, order=3, method="laguerre", a="bandwidth")
    assert "diverges" in model.options["refine_rule"]
    out = capfd.readouterr()
    assert "DLASCL" not in out.out + out.err
