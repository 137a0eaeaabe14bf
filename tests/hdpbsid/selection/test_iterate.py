"""A refinement its evaluation budget cut off is kept only when the record resolves it as
better than its start (:mod:`hdpbsid.selection.iterate`).

Oracle: a second record of the same system (fresh input and noise). An iterate the rule
keeps must predict that record better than its start; an iterate the rule does not keep
is the start moved by less than the record resolves, or a better noise model on the same
plant.
"""

from __future__ import annotations

import dataclasses

import pytest
from focus_data import coloured_record, white_record

from hdpbsid import identify
from hdpbsid.models.criteria import (
    choose_smallest_adequate,
    default_windows,
    windowed_prediction_error,
)
from hdpbsid.models.report import Choice, Refinement
from hdpbsid.refine.pem import prediction_log_det, refine_pem
from hdpbsid.selection.iterate import IterateRule, continued, keep_iterate


@pytest.fixture(scope="module")
def fitted():
    t, u, y = white_record(0)
    return (t, u, y), identify(t, u, y, 2, method="dt", refine=None)


def _detuned(model, factor, like=None):
    """``model`` (the matrices of ``like`` when given) with its dynamics scaled by
    ``factor``: the same modes on a wrong time scale, and no refinement reported."""
    m = like or model
    return dataclasses.replace(
        model, A=factor * m.A, B=m.B, C=m.C, D=m.D, K=m.K, options=dict(model.options)
    )


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_an_iterate_the_record_resolves_is_kept_and_predicts_a_new_record_better(fitted):
    rec, model = fitted
    start = _detuned(model, 0.7)  # 30 % too slow: far outside the eigenvalues' spread
    cut = refine_pem(start, *rec, max_nfev=6)
    assert not cut.report.converged  # six evaluations do not reach the minimum
    choice = keep_iterate(start, cut, *rec)
    assert choice.value and choice.rule is IterateRule.RESOLVED, choice
    fresh = white_record(1)
    before, after = (windowed_prediction_error(m, *fresh, 8).total for m in (start, cut))
    assert after < before, (before, after)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_an_iterate_within_the_records_resolution_leaves_the_start(fitted):
    rec, model = fitted
    refined = refine_pem(model, *rec)
    # 0.5 % off the minimum: its one-step prediction error is ~0.04 standard errors of
    # the window errors above the minimum's, where 1 decides (2 % off is 2.1)
    start = _detuned(model, 1.005, like=refined)
    cut = refine_pem(start, *rec, max_nfev=3)
    assert not cut.report.converged
    choice = keep_iterate(start, cut, *rec)
    assert not choice.value and choice.rule is IterateRule.NOT_RESOLVED, choice


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_a_cut_off_refinement_goes_on_to_the_minimum_from_where_it_stopped(fitted):
    rec, model = fitted
    minimum = refine_pem(model, *rec)  # oracle: the refinement from the subspace estimate
    cut = refine_pem(_detuned(model, 0.7), *rec, max_nfev=6)
    assert not cut.report.converged and minimum.report.converged
    kept, note = continued(cut, *rec)
    assert kept.report.converged and "went on from where it stopped" in note
    cost = {k: prediction_log_det(m, *rec, m.report.hold) for k, m in
            (("cut", cut), ("kept", kept), ("minimum", minimum))}  # fmt: skip
    # the same minimum: within one -2 log-likelihood unit (no evidence; the refinement's
    # own convergence test stops within a tenth of a standard deviation of it)
    assert abs(cost["kept"] - cost["minimum"]) < 1.0, cost
    assert cost["cut"] - cost["kept"] > 5.0, cost  # cut off short of it (measured: 9.7 units)


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_a_cut_off_refinement_at_an_order_the_data_chose_is_left_to_the_rule(fitted):
    rec, model = fitted
    cut = refine_pem(_detuned(model, 0.7), *rec, max_nfev=6)
    assert cut.report.order.given  # the fixture's order was given
    cut.report = cut.report.but(order=Choice(2, "held-out selection"))
    kept, note = continued(cut, *rec)
    assert kept is cut and note == ""


@pytest.mark.parametrize("order", [2, None])
def test_identify_tells_the_continuation_whether_the_order_was_given(order, monkeypatch):
    import importlib

    front = importlib.import_module("hdpbsid.identify")  # the module, not the function
    seen = []

    def spy(refined, *rec):
        seen.append(refined.report.order)
        return continued(refined, *rec)

    monkeypatch.setattr(front, "continued", spy)
    t, u, y = white_record(0)
    front.identify(t, u, y, order, method="dt")
    assert len(seen) == 1
    assert (seen[0] is not None and seen[0].given) == (order is not None), seen


def test_a_converged_refinement_is_kept_without_a_test(fitted):
    rec, model = fitted
    refined = refine_pem(model, *rec)
    assert refined.report.converged
    assert keep_iterate(model, refined, *rec).rule is IterateRule.CONVERGED


def test_a_better_noise_model_alone_does_not_keep_an_iterate():
    """An iterate whose plant is its start's and whose ``K`` predicts the record better
    (a search that spent its budget on the noise model) is not kept: the simulation
    error, the plant's alone, does not resolve it."""
    t, u, y = coloured_record(0)
    pem = identify(t, u, y, 2, method="dt", focus="prediction")
    start = dataclasses.replace(pem, K=0 * pem.K, options=dict(pem.options))
    cut = Refinement(False, 150, pem.report.hold, "model K", (1.0, 0.5))
    iterate = dataclasses.replace(pem, options=dict(pem.options))
    iterate.report = pem.report.but(refinement=cut)
    w = default_windows(t.size, 2)
    predicted = [windowed_prediction_error(m, t, u, y, w) for m in (start, iterate)]
    assert choose_smallest_adequate(predicted)[0] == 1  # K resolved: the noise is coloured
    choice = keep_iterate(start, iterate, t, u, y)
    assert not choice.value and "simulation" in choice.reason, choice
