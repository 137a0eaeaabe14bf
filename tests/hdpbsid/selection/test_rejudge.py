"""Pieces of the order re-judgement (:mod:`hdpbsid.selection.rejudge`): the closed-loop
step up asks the larger order's plant to simulate better (the order is the plant's, so a
candidate that predicts better only through its noise model does not raise it), and a
candidate whose refinement runs out of budget is scored by its iterate when the
estimation part resolves it.  Oracles: the record's true plant, that plant with its
resonance moved, and a start 30 % too slow."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from focus_data import A, B, C, white_record

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.selection.candidates import CandidateRow
from hdpbsid.selection.rejudge import _plant_resolves

WINDOWS = 16


def _row(a: np.ndarray, k: np.ndarray, order: int = 2) -> CandidateRow:
    return CandidateRow("dt", order, model=StateSpaceModel(a, B, C, np.zeros((1, 1)), k))


def test_the_true_plant_resolves_against_a_moved_resonance() -> None:
    t, u, y = white_record(0)
    moved = A.copy()
    moved[1, 0] *= 1.1**2  # the pair's frequency 10 % up
    margin = _plant_resolves(_row(moved, np.zeros((2, 1))), _row(A, np.zeros((2, 1))),
                             (t, u, y), WINDOWS)  # fmt: skip
    # 20 dB white noise on 2000 samples: a 10 % frequency error of a lightly damped pair
    # is many standard errors of the windowed simulation error
    assert margin is not None and margin > 3.0


def test_a_different_noise_model_alone_does_not_resolve() -> None:
    """The same plant with a Kalman gain, one state more: its one-step prediction
    differs, its simulation does not, so it is no evidence for a larger plant order."""
    t, u, y = white_record(0)
    now = _row(A, np.zeros((2, 1)))
    up = _row(A, np.array([[0.5], [1.0]]), order=3)
    assert _plant_resolves(now, up, (t, u, y), WINDOWS) is None


def test_the_refined_model_stands_for_the_row() -> None:
    """A row refined on the estimation part is judged by its refined model: the moved
    resonance refined to the true plant resolves against the moved one."""
    t, u, y = white_record(0)
    moved = A.copy()
    moved[1, 0] *= 1.1**2
    up = _row(moved, np.zeros((2, 1)), order=3)
    assert _plant_resolves(_row(moved, np.zeros((2, 1))), up, (t, u, y), WINDOWS) is None
    up.refined_model = StateSpaceModel(A, B, C, np.zeros((1, 1)), np.zeros((2, 1)))
    margin = _plant_resolves(_row(moved, np.zeros((2, 1))), up, (t, u, y), WINDOWS)
    assert margin is not None and margin > 3.0


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_a_candidate_whose_refinement_runs_out_of_budget_is_scored_by_its_iterate(
    monkeypatch,
) -> None:
    """The re-judgement refines candidates on the estimation part with the final
    refinement's budget rule (:func:`~hdpbsid.selection.iterate.keep_iterate`): an iterate
    the estimation part resolves as better than its start is scored, not the start."""
    import hdpbsid.refine.pem as pem
    from hdpbsid import identify
    from hdpbsid.selection.rejudge import _refine_and_score
    from hdpbsid.selection.scoring import score_model

    t, u, y = white_record(0)
    cut = 1400
    est, val = (t[:cut], u[:cut], y[:cut]), (t[cut:], u[cut:], y[cut:])
    model = identify(*est, 2, method="dt", refine=None)
    start = dataclasses.replace(model, A=0.7 * model.A, options=dict(model.options))
    real = pem.refine_pem
    monkeypatch.setattr(pem, "refine_pem", lambda m, *r: real(m, *r, max_nfev=6))
    refined, score = _refine_and_score(start, est, val, WINDOWS)
    # six evaluations from a start 30 % too slow: not converged, yet far better
    assert refined is not None and not refined.report.converged
    assert score.total < score_model(start, val, WINDOWS)[0].total


def _scored(model: StateSpaceModel, val: tuple, order: int) -> CandidateRow:
    """A candidate judged as refined already (its refined model itself, scored on
    ``val``): the step down then needs no refinement."""
    from hdpbsid.selection.scoring import score_model

    row = CandidateRow("dt", order, model=model)
    row.criterion = row.refined_criterion = score_model(model, val, WINDOWS)[0]
    row.refined_model = model
    return row


def _with_slow_mode(b_slow: float) -> StateSpaceModel:
    """The record's pair and a third mode at -0.01 rad/s (``|lambda| T = 0.27`` over the
    27 s estimation part) seen at the output and driven through ``b_slow``."""
    A3 = np.zeros((3, 3))
    A3[:2, :2], A3[2, 2] = A, -0.01
    return StateSpaceModel(A3, np.vstack([B, [[b_slow]]]), np.hstack([C, [[1.0]]]),
                           np.zeros((1, 1)), np.zeros((3, 1)))  # fmt: skip


def _split(cut: int = 1334) -> tuple[tuple, tuple]:
    t, u, y = white_record(0)
    return (t[:cut], u[:cut], y[:cut]), (t[cut:], u[cut:], y[cut:])


@pytest.fixture
def closed(monkeypatch):
    """The feedback test declaring the (open-loop) record closed loop: the step down
    over a drift is a closed-loop step, its mechanics are tested on the white record."""
    import hdpbsid.selection.rejudge as rejudge

    monkeypatch.setattr(rejudge, "looks_closed_loop", lambda model, rec: True)


def test_a_drift_mode_steps_down_to_the_adequate_smaller_order(closed) -> None:
    """Order 3 is the true pair plus a mode the input does not reach: a drift; the true
    pair (order 2) predicts the held-out part as well, so it replaces it."""
    from hdpbsid.selection.rejudge import _smaller_over_drift

    est, val = _split()
    truth = StateSpaceModel(A, B, C, np.zeros((1, 1)), np.zeros((2, 1)))
    below, chosen = _scored(truth, val, 2), _scored(_with_slow_mode(0.0), val, 3)
    kept, rule = _smaller_over_drift(chosen, [below, chosen], est, val, WINDOWS, chosen.model)
    assert kept is below and "drift" in rule


def test_a_drift_mode_stays_when_the_smaller_order_is_resolved_worse(closed) -> None:
    """The smaller order with half the static gain is many standard errors worse on the
    held-out part (20 dB): the step down does not return it."""
    from hdpbsid.selection.rejudge import _smaller_over_drift

    est, val = _split()
    wrong = StateSpaceModel(A, 0.5 * B, C, np.zeros((1, 1)), np.zeros((2, 1)))
    below, chosen = _scored(wrong, val, 2), _scored(_with_slow_mode(0.0), val, 3)
    kept, rule = _smaller_over_drift(chosen, [below, chosen], est, val, WINDOWS, chosen.model)
    assert kept is chosen and rule == ""


def test_no_drift_mode_no_step_and_no_refinement(closed) -> None:
    """A model without a drift mode is not compared with the smaller order, whose
    candidate is then never refined (a record without one pays nothing for the step)."""
    from hdpbsid.selection.rejudge import _smaller_over_drift

    est, val = _split()
    truth = StateSpaceModel(A, B, C, np.zeros((1, 1)), np.zeros((2, 1)))
    chosen = _scored(truth, val, 2)
    below = CandidateRow("dt", 1, model=StateSpaceModel([[-1.0]], [[1.0]], [[1.0]],
                                                         [[0.0]], [[0.0]]))  # fmt: skip
    from hdpbsid.selection.scoring import score_model

    below.criterion = score_model(below.model, val, WINDOWS)[0]
    kept, rule = _smaller_over_drift(chosen, [below, chosen], est, val, WINDOWS, chosen.model)
    assert kept is chosen and rule == "" and below.refined_criterion is None


def test_in_open_loop_the_held_out_ranking_stands() -> None:
    """The same drift mode on the open-loop record (the feedback test finds no feedback):
    the candidates are consistent, their ranking stands, and there is no step down."""
    from hdpbsid.selection.rejudge import _smaller_over_drift

    est, val = _split()
    truth = StateSpaceModel(A, B, C, np.zeros((1, 1)), np.zeros((2, 1)))
    below, chosen = _scored(truth, val, 2), _scored(_with_slow_mode(0.0), val, 3)
    kept, rule = _smaller_over_drift(chosen, [below, chosen], est, val, WINDOWS, truth)
    assert kept is chosen and rule == ""
