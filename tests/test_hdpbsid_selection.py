"""``method="auto"`` and the windowed simulation criterion (hdpbsid.selection, .criteria)."""

import numpy as np
import pytest

import hdpbsid
from hdpbsid.criteria import (
    WindowedError,
    choose_smallest_adequate,
    windowed_simulation_error,
)
from hdpbsid.model import StateSpaceModel
from hdpbsid.systems import add_noise, random_steps, second_order, simulate_zoh


def _record(seed: int, snr: float | None = 30.0, T: float = 30.0, dt: float = 0.02):
    A, B, C, D = second_order()
    t = np.arange(0.0, T + dt / 2, dt)
    rng = np.random.default_rng(seed)
    u = random_steps(rng, t, 0.2)
    y = simulate_zoh(A, B, C, D, t, u)
    if snr is not None:
        y = add_noise(y, snr, rng)[0]
    return t, u, y, StateSpaceModel(A, B, C, D, np.zeros((2, 1)))


def test_true_model_scores_zero_on_noise_free_data():
    t, u, y, true = _record(0, snr=None)
    err = windowed_simulation_error(true, t, u[:, None], y, windows=8, hold="zoh")
    # exact ZOH data and the exact sampled model: only rounding remains (relative 1e-20
    # in energy is ~1e-10 in amplitude, far above double rounding of a 1500-step recursion)
    assert err.finite and err.total < 1e-20


def test_wrong_initial_state_is_absorbed_per_window():
    """A window starting anywhere on the trajectory scores like the whole record: the
    initial state of every window is fitted."""
    t, u, y, true = _record(1, snr=None)
    err = windowed_simulation_error(true, t[300:], u[300:, None], y[300:], windows=6, hold="zoh")
    assert err.total < 1e-20  # same reason as above


def test_smallest_adequate_rule_prefers_the_smaller_equivalent_model():
    rng = np.random.default_rng(0)
    base = rng.uniform(1.0, 2.0, 16)
    errs = [
        WindowedError(base * 3.0, 3.0, 0.0, True),  # clearly worse everywhere
        WindowedError(base * 1.001, 1.001, 0.0, True),  # immaterially worse
        WindowedError(base, 1.0, 0.0, True),  # the best
    ]
    k, z = choose_smallest_adequate(errs)
    assert k == 1 and z[2] == 0.0 and z[0] > 2.0


def test_auto_is_deterministic_and_reports_every_candidate():
    t, u, y, true = _record(2)
    kw = {"method": "auto", "methods": ("hermite", "dt"), "max_order": 3}
    m1 = hdpbsid.identify(t, u, y, **kw)
    m2 = hdpbsid.identify(t, u, y, **kw)
    np.testing.assert_array_equal(m1.A, m2.A)
    table = m1.options["selection"]
    assert {(r["method"], r["order"]) for r in table} == {
        (m, n) for m in ("hermite", "dt") for n in (1, 2, 3)
    }
    assert all({"error", "fit", "z", "time", "status"} <= set(r) for r in table)
    assert m1.options["method"] in ("hermite", "dt")
    # 30 dB, 1500 samples: the second-order truth is found and accurate to a few percent
    assert m1.n == 2
    err = hdpbsid.eigenvalue_errors(m1.eigenvalues, np.linalg.eigvals(true.A))
    assert np.max(err) < 0.05  # 30 dB: measured < 1 %; 5 % flags a wrong model


def test_auto_refuses_a_record_too_short_to_score():
    t, u, y, _ = _record(3, T=0.5)
    with pytest.raises(ValueError, match="longer record"):
        hdpbsid.identify(t, u, y, method="auto")


def test_constant_input_warns_not_persistently_exciting():
    t, u, y, _ = _record(4)
    # the warning says why; after the mean is removed nothing of u is left, so no model
    # comes back either (the method refuses an identically zero input)
    with pytest.warns(UserWarning, match="not persistently exciting"):
        with pytest.raises(ValueError, match="identically zero"):
            hdpbsid.identify(t, np.full(t.size, 2.5), y, order=2, method="dt")


def test_auto_with_several_records_holds_out_the_last():
    recs = [_record(s)[:3] for s in (5, 6, 7)]
    m = hdpbsid.identify(recs, None, None, method="auto", methods=("dt",), max_order=3)
    assert "the last record" in m.options["selection_rule"]
    # three 30 dB records of the second-order system: the true order is kept
    assert m.n == 2
