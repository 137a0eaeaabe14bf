"""No silent wrong model: the held-out selection never returns a model its own checks
reject (hdpbsid.selection), a time series gets a stationary model, and a record stamped
with absolute (Unix) time gives the model of the same record from t = 0."""

import dataclasses
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import expm

import hdpbsid
from hdpbsid.models.conversion import c2d
from hdpbsid.models.criteria import SIGNIFICANCE_Z, WindowedError, choose_smallest_adequate
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.selection.auto import (
    MUCH_WORSE_RATIO,
    SelectionWarning,
    _warn_if_much_worse,
    instability_problem,
    much_worse,
    refinement_instability,
    score_model,
    stationarity_problem,
)
from hdpbsid.selection.candidates import CandidateRow
from hdpbsid.systems import random_steps, second_order, simulate_discrete, simulate_zoh

TRUE = np.linalg.eigvals(second_order()[0])  # -0.4 +- 1.96i


def _white_input_record(seed: int, dt: float = 0.01, ns: int = 1000):
    """The second-order system driven by a white (held) input, 1 % output noise."""
    rng = np.random.default_rng(seed)
    A, B, C, D = second_order()
    t = np.arange(ns) * dt
    u = rng.standard_normal((ns, 1))
    y = simulate_zoh(A, B, C, D, t, u)
    return t, u, y + 0.01 * np.std(y) * rng.standard_normal(y.shape)


def _time_series(seed: int, dt: float = 0.05, ns: int = 1000, noise: float = 0.1):
    """A stationary process: the second-order system driven by white noise (held over
    each step, exact sampling), observed with white noise of ``noise`` times its std."""
    rng = np.random.default_rng(seed)
    A, B, C, D = second_order()
    M = np.zeros((3, 3))
    M[:2, :2], M[:2, 2:] = A * dt, B * dt
    E = expm(M)
    y = simulate_discrete(E[:2, :2], E[:2, 2:], C, D, rng.standard_normal((ns, 1)))
    return np.arange(ns) * dt, y + noise * np.std(y) * rng.standard_normal(y.shape)


def _worst_relative_error(model: StateSpaceModel) -> float:
    lam = np.sort_complex(np.linalg.eigvals(model.A))
    return float(np.max(np.abs(lam - np.sort_complex(TRUE)) / np.abs(TRUE)))


SEEDS = range(6)


def _growing(model: StateSpaceModel) -> bool:
    return bool(np.any(model.eigenvalues.real > 0))


@pytest.mark.parametrize("seed", SEEDS)
@pytest.mark.parametrize("method", ["legendre", "chebyshev"])
def test_the_order_left_to_a_basis_method_is_never_an_unstable_first_order(method, seed):
    # 10 s of a white-input record: the basis methods' order-2 candidate wins the
    # held-out score by hundreds of standard errors over order 1, but on some seeds their
    # refit on the whole record chooses its settings again and fails; the selection used
    # to fall back to order 1, refined into an unstable pole +0.24 with a 2.6 % fit,
    # without a word
    t, u, y = _white_input_record(seed)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = hdpbsid.identify(t, u, y, method=method)
    said = any(issubclass(w.category, SelectionWarning) for w in caught)
    assert said or not _growing(model)  # never an unstable model without a warning
    assert model.n == 2 and not _growing(model)
    # refined by the prediction-error method on 1 % noise: the eigenvalues to a few
    # percent (measured worst 1.1 % over the seeds); the fallback model was order 1
    assert _worst_relative_error(model) < 0.05


def test_without_refinement_the_candidate_itself_is_returned_with_a_warning():
    t, u, y = _white_input_record(0)
    with pytest.warns(SelectionWarning, match="fitted on the estimation part"):
        model = hdpbsid.identify(t, u, y, method="legendre", refine=None)
    # the candidate the held-out part judged: order 2, fitted on the first two thirds
    assert model.n == 2 and model.options["n_samples"] == 667
    assert "as fitted on the estimation part" in model.options["order_selection_rule"]
    fit = model.fit(t, u, y)
    assert fit.vaf[0] > 50.0  # a model of the record (measured 95 %), not below its mean


@pytest.mark.parametrize("seed", SEEDS)
def test_a_time_series_gets_a_stationary_model_of_its_order(seed: int):
    # scored by their simulation (no input: a fit of the free response to each window),
    # the candidates of 4-8 states won on every seed, some with unstable pairs.  Scored
    # by the one-step prediction, order 2 is within 0.2 standard errors of the best on
    # every seed and order 1 at least 5 behind: no rounding moves the choice
    t, y = _time_series(seed)
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)  # no fallback or instability warning
        model = hdpbsid.identify(t, None, y)
    assert model.n == 2
    assert np.all(model.eigenvalues.real < 0)
    # 50 s (16 periods) at 10 % noise: the damping to tens of percent, the pair's
    # modulus closely (measured worst 12 % relative); the order-4 models were 60 % off
    assert _worst_relative_error(model) < 0.2
    assert "time series" in model.options["selection_rule"]


def test_a_drifting_time_series_is_refused_with_what_would_help():
    # a random walk has no stationary model: every candidate is refused (or the whole
    # selection is), and the message says what to do
    rng = np.random.default_rng(3)
    t = np.arange(600) * 0.05
    y = np.cumsum(rng.standard_normal((600, 1)), axis=0)
    try:
        model = hdpbsid.identify(t, None, y)
    except ValueError as exc:
        assert "stationary" in str(exc) or "difference" in str(exc)
    else:
        assert np.all(model.eigenvalues.real < 0)  # or a stationary model


def test_stationarity_problem_names_the_unstable_eigenvalue():
    K = np.array([[1.0], [0.0]])
    C = np.array([[1.0, 0.0]])
    stable = StateSpaceModel(second_order()[0], np.zeros((2, 0)), C, np.zeros((1, 0)), K)
    assert stationarity_problem(stable) == ""
    A = np.array([[0.0, 1.0], [-4.0, 0.8]])  # the mirrored pair +0.4 +- 1.96i
    grows = StateSpaceModel(A, np.zeros((2, 0)), C, np.zeros((1, 0)), K)
    why = stationarity_problem(grows)
    assert "not stationary" in why and "0.4" in why
    # an integrator is not stationary either (a random walk)
    walk = StateSpaceModel(np.zeros((1, 1)), np.zeros((1, 0)), [[1.0]], np.zeros((1, 0)), [[1.0]])
    assert stationarity_problem(walk)
    # with an input the question is instability_problem's
    A_, B_, C_, D_ = second_order()
    assert stationarity_problem(StateSpaceModel(A, B_, C_, D_, np.zeros((2, 1)))) == ""


def _row(model: StateSpaceModel, rec: tuple, windows: int = 8) -> CandidateRow:
    err, _ = score_model(model, rec, windows)
    return CandidateRow("given", model.n, model=model, criterion=err)


def _grown_truth(gain: float) -> StateSpaceModel:
    """The second-order truth plus a mode growing at +2 /s driven with ``gain``."""
    A, B, C, D = second_order()
    Ag = np.block([[A, np.zeros((2, 1))], [np.zeros((1, 2)), np.array([[2.0]])]])
    return StateSpaceModel(
        Ag, np.vstack([B, [[gain]]]), np.hstack([C, [[1.0]]]), D, np.zeros((3, 1))
    )


def test_an_unstable_candidate_a_stable_one_explains_is_rejected():
    # open loop, stable plant: the truth plus a weakly driven mode growing at +2 /s
    # (e^20 over the 10 s record): on the held-out third it predicts no better than the
    # truth, so the record does not need the growth
    t, u, y = _white_input_record(1)
    val = (t[667:], u[667:], y[667:])
    A, B, C, D = second_order()
    truth = _row(StateSpaceModel(A, B, C, D, np.zeros((2, 1))), val)
    grown = _row(_grown_truth(1e-3), val)
    why = instability_problem(grown, [truth, grown])
    assert "does not need the growth" in why and "given order 2" in why
    assert instability_problem(truth, [truth, grown]) == ""  # stable: nothing to judge
    # alone (no stable rival of its size) the growth is not rejected: the rule compares
    assert instability_problem(grown, [grown]) == ""
    # a larger stable model is no rival: stability is not bought with states
    big = dataclasses.replace(truth, order=4)
    assert instability_problem(grown, [big, grown]) == ""


def _reference_driven_loop(seed: int, dt: float = 0.05, ns: int = 1200):
    """An unstable plant (poles +0.5 and -2) held by a static output feedback
    ``u = r - 3 y`` (closed-loop poles -0.75 +- 1.2i), driven by random steps ``r``;
    the measured output carries 1 % white noise."""
    A = np.array([[0.0, 1.0], [1.0, -1.5]])
    B, C, D = np.array([[0.0], [1.0]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))
    Ad, Bd, *_ = c2d(A, B, C, D, None, dt)
    rng = np.random.default_rng(seed)
    t = np.arange(ns) * dt
    r = random_steps(rng, t, 0.5)
    v = 0.01 * rng.standard_normal(ns)
    x, u, y = np.zeros(2), np.zeros((ns, 1)), np.zeros((ns, 1))
    for i in range(ns):
        y[i] = C @ x + v[i]
        u[i] = r[i] - 3.0 * y[i]
        x = Ad @ x + Bd @ u[i]
    return t, u, y


@pytest.mark.parametrize("seed", [0, 3])
def test_an_unstable_plant_in_a_quiet_loop_keeps_its_growing_mode(seed: int):
    # the loop is driven by its reference, with little noise for the controller to
    # react to: on these seeds the feedback test does not see it, and a free run from the
    # state fitted on the record's start diverges for the true plant (e^0.5t over 60 s).
    # No stable candidate of order <= 2 predicts the held-out part as well, so the
    # growth is what the record asks for
    from hdpbsid.selection.auto import looks_closed_loop

    t, u, y = _reference_driven_loop(seed)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = hdpbsid.identify(t, u, y)
    assert not any(issubclass(w.category, SelectionWarning) for w in caught)
    assert model.n == 2
    lam = np.sort(model.eigenvalues.real)
    # 1 % noise on 60 s: both poles to a few percent (measured worst 1.2 %)
    np.testing.assert_allclose(lam, [-2.0, 0.5], rtol=0.05)
    assert not looks_closed_loop(model, (t, u, y))  # the case the rule is for


def test_instability_is_kept_in_the_closed_loop_quadrotor():
    # closed loop around the unstable airframe (eigenvalue +3.08): no stable model of
    # its order or less predicts the held-out part as well
    from hdpbsid.systems.quadrotor import simulate_pitch_closed_loop

    d = simulate_pitch_closed_loop(np.random.default_rng(0), snr_db=20.0)
    model = hdpbsid.identify(d.t, d.u, d.y, method="hermite", refine=None, detrend=None)
    assert np.max(model.eigenvalues.real) > 2.0  # the airframe's +3.08, estimated
    assert "does not need the growth" not in model.options["order_selection_rule"]


def test_a_refinement_that_grows_an_unneeded_mode_is_not_kept():
    t, u, y = _white_input_record(2)
    A, B, C, D = second_order()
    start = StateSpaceModel(A, B, C, D, np.zeros((2, 1)))
    assert refinement_instability(start, start, (t, u, y)) == ""
    # the same response plus a weakly driven mode growing at +0.3 /s: it simulates the
    # record no better than the stable start, so the growth is not kept
    grown = StateSpaceModel(
        np.block([[A, np.zeros((2, 1))], [np.zeros((1, 2)), np.array([[0.3]])]]),
        np.vstack([B, [[1e-4]]]),
        np.hstack([C, [[1.0]]]),
        D,
        np.zeros((3, 1)),
    )
    why = refinement_instability(start, grown, (t, u, y))
    assert "where the start was stable" in why and "0.3" in why
    # a start that grows already: nothing new grew, the refinement is judged elsewhere
    assert refinement_instability(grown, grown, (t, u, y)) == ""


def _err(per_window) -> WindowedError:
    per = np.asarray(per_window, dtype=float)
    return WindowedError(per, float(per.sum()), 0.0, True)


def test_much_worse_is_the_ratio_of_the_held_out_errors():
    rejected = _err(np.full(8, 1.0) + 0.01 * np.arange(8))
    # about twelve times the residual energy: much worse (96 against 8 + 0.01 * 28)
    assert much_worse(_err(np.full(8, 12.0)), rejected) == (True, pytest.approx(96.0 / 8.28))
    # below the ratio: not much worse, although the windows resolve it
    below = 0.9 * MUCH_WORSE_RATIO
    assert much_worse(_err(np.full(8, below) + 0.01 * np.arange(8)), rejected)[0] is False
    # a model that cannot be simulated is much worse than any rejected one
    assert much_worse(WindowedError(np.full(8, np.inf), np.inf, -np.inf, False), rejected)[0]


@settings(max_examples=200, deadline=None)
@given(
    per=st.lists(st.floats(0.0, 1e3), min_size=2, max_size=16).filter(lambda p: sum(p) > 1e-6),
    ratio=st.floats(MUCH_WORSE_RATIO * (1.0 + 1e-9), 50.0),  # 1e-9: rounding of the sums
    spread=st.floats(0.0, 1.0),
)
def test_much_worse_is_always_resolved_by_the_held_out_windows(per, ratio, spread):
    # the reason for the ratio 2: whatever the windows' spread, a model with more than
    # twice the held-out error of another is more than one standard error worse
    rejected = _err(per)
    w = np.linspace(1.0 - spread, 1.0 + spread, len(per))
    returned = _err(w / w.sum() * ratio * rejected.total)
    assert much_worse(returned, rejected)[0]
    _, z = choose_smallest_adequate([returned, rejected])
    assert z[0] >= SIGNIFICANCE_Z * (1.0 - 1e-9)  # 1e-9: rounding of the window sums


def test_a_much_worse_fallback_names_what_was_rejected_and_what_to_pass():
    A, B, C, D = second_order()
    model = StateSpaceModel(A[:1, :1], B[:1], C[:, :1], D, np.zeros((1, 1)))
    returned = CandidateRow("dt", 1, criterion=_err(np.full(8, 12.0)))
    best = CandidateRow("legendre", 4, criterion=_err(np.full(8, 1.0) + 0.01 * np.arange(8)))
    failures = [("floor", "legendre order 4: unstable (eigenvalue 0.3)", best)]
    with pytest.warns(SelectionWarning, match=r"method='legendre', order=4") as rec:
        _warn_if_much_worse(returned, model, failures)
    text = str(rec[0].message)
    assert "unstable (eigenvalue 0.3)" in text and "times that of" in text
    assert model.options["selection_warning"] == text
    # not much worse: silent
    close = CandidateRow("dt", 2, criterion=_err(np.full(8, 1.2)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _warn_if_much_worse(close, model, failures)


def test_the_fallback_is_the_refined_candidate_the_order_was_decided_on():
    """When no refit on the whole record holds, the model returned is the one the
    held-out part judged: with the order decided between refined candidates, the
    candidate refined on the estimation part, not the subspace estimate it started from
    -- unless the refinement grew a mode the candidate did not have."""
    from hdpbsid.refine.pem import refine_pem
    from hdpbsid.selection.refits import _candidate_itself

    t, u, y = _white_input_record(4)
    est, val = (t[:667], u[:667], y[:667]), (t[667:], u[667:], y[667:])
    A, B, C, D = second_order()
    # a biased start (the gain 30 % off, the damping doubled), refined on the estimation
    # part back to the truth: the oracle is the true system
    biased = StateSpaceModel(A + np.diag([0.0, -0.8]), 1.3 * B, C, D, np.zeros((2, 1)))
    row = _row(biased, val)
    row.refined_model = refine_pem(biased, *est)
    # 1 % noise on 667 samples: refined to the truth (measured 0.04 % on seeds 0-5; the
    # start is 21 % off), so 2 % separates the two whatever the rounding
    assert _worst_relative_error(row.refined_model) < 0.02
    with pytest.warns(SelectionWarning, match="fitted on the estimation part"):
        model = _candidate_itself(row, "the last third")
    assert model is row.refined_model and "selection_fallback" in model.options
    # a refinement that grew a mode the stable candidate did not have is not returned
    row = _row(biased, val)
    row.refined_model = _grown_truth(1e-3)
    with pytest.warns(SelectionWarning):
        assert _candidate_itself(row, "the last third") is biased


def test_the_part_record_fallback_is_said_unless_the_whole_record_refined_it():
    """``identify`` warns that the model was fitted on the estimation part when the
    refinement on the whole record did not replace the selection's fallback: the
    refinement the fallback already carried (from the estimation part) does not count."""
    from hdpbsid.identify import _warn_if_fallback
    from hdpbsid.refine.pem import refine_pem

    t, u, y = _white_input_record(4)
    A, B, C, D = second_order()
    start = StateSpaceModel(A, 1.3 * B, C, D, np.zeros((2, 1)))
    part = refine_pem(start, t[:667], u[:667], y[:667])
    part.report = part.report.but(selection_fallback="fitted on the estimation part")
    with pytest.warns(SelectionWarning, match="fitted on the estimation part"):
        _warn_if_fallback(part, part)  # the whole-record refinement was not kept
    whole = refine_pem(part, t, u, y)
    whole.report = whole.report.but(selection_fallback="fitted on the estimation part")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _warn_if_fallback(whole, part)  # refined on the whole record: said in the rule
    assert "started the refinement on the whole record" in whole.report.selection_fallback
