"""The selection's decisions as named choices (order, method, refinement) and its
numbers as policy fields: the same decisions and texts as the rules they name."""

import numpy as np
import pytest

import hdpbsid.selection.auto as auto
from hdpbsid.models.criteria import WindowedError, choose_smallest_adequate
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.selection.candidates import CandidateRow
from hdpbsid.selection.feedback import (
    AR_ORDER,
    FEEDBACK_LAGS,
    FEEDBACK_LEVEL,
    FEEDBACK_TEST,
    GRAM_RCOND,
    RefineChoice,
    RefineReason,
    decide_refine,
    refine_decision,
)
from hdpbsid.selection.feedthrough import FEEDTHROUGH_POLICY, FEEDTHROUGH_Z, SIMULATION_Z
from hdpbsid.selection.order_rule import (
    MethodReason,
    OrderChoice,
    OrderReason,
    choose_order,
    rank_candidates,
)
from hdpbsid.selection.policy import SELECTION_POLICY
from hdpbsid.selection.rejudge import rejudge_order, rejudge_refined
from hdpbsid.systems import second_order, simulate_zoh


def _err(per_window) -> WindowedError:
    w = np.asarray(per_window, dtype=float)
    return WindowedError(w, float(w.sum()), 0.0, True)


def _row(method: str, order: int, per_window) -> CandidateRow:
    return CandidateRow(method, order, criterion=_err(per_window))


def test_the_policy_fields_are_the_module_constants():
    assert (auto.HOLDOUT, auto.AUTO_MAX_ORDER) == (1.0 / 3.0, 8)
    assert (auto.MUCH_WORSE_RATIO, auto.REJUDGE_Z) == (2.0, 3.0)
    assert SELECTION_POLICY.holdout == auto.HOLDOUT
    assert (
        (FEEDTHROUGH_Z, SIMULATION_Z)
        == (3.0, 2.0)
        == (
            FEEDTHROUGH_POLICY.z_prediction,
            FEEDTHROUGH_POLICY.z_simulation,
        )
    )
    assert (AR_ORDER, FEEDBACK_LAGS, FEEDBACK_LEVEL, GRAM_RCOND) == (40, 20, 1e-3, 1e-8)
    assert FEEDBACK_TEST.lags == FEEDBACK_LAGS


def test_every_name_of_auto_stays_importable():
    for name in auto.__all__:
        assert getattr(auto, name) is not None
    # names other modules import from auto, which now live in the stage modules
    for name in ("break_tie", "_warn_if_much_worse", "NoCandidate", "decide_feedthrough"):
        assert hasattr(auto, name)


def test_choose_order_is_the_one_standard_error_rule():
    # order 1 clearly worse, orders 2 and 3 within one standard error: order 2
    pool = [
        _row("a", 1, [4.0, 5.0, 4.5, 5.5]),
        _row("a", 2, [1.0, 1.1, 0.9, 1.05]),
        _row("a", 3, [1.0, 1.1, 0.9, 1.0]),
    ]
    choice = choose_order(pool)
    k, stats = choose_smallest_adequate([r.criterion for r in pool])
    assert (choice.index, choice.stats) == (k, tuple(stats))
    assert pool[choice.index].order == 2
    assert choice.reason is OrderReason.ONE_STANDARD_ERROR and choice.rule == ""


def test_rank_candidates_lists_the_admitted_from_the_chosen_order():
    pool = [
        _row("a", 1, [4.0, 5.0, 4.5, 5.5]),
        _row("a", 2, [1.0, 1.1, 0.9, 1.05]),
        _row("a", 3, [1.0, 1.1, 0.9, 1.0]),
    ]
    ranking = rank_candidates(pool, choose_order(pool), val=None)
    assert [r.order for r in ranking.queue] == [2, 3]
    assert ranking.tied == 1 and ranking.reason is MethodReason.ALONE
    assert ranking.method == "a"


def test_rejudge_on_several_records_keeps_the_choice():
    pool = [_row("a", 1, [1.0, 1.1]), _row("a", 2, [1.0, 1.0])]
    order = OrderChoice(0, (0.0, 0.0))
    est = ([np.arange(10.0)], None, None)
    assert rejudge_order(pool, order, est, None, 2) is order
    assert rejudge_refined(pool, [0.0, 0.0], 0, est, None, 2) == (0, "")


def _record():
    A, B, C, D = second_order()
    rng = np.random.default_rng(0)
    t = np.arange(600) * 0.05
    u = rng.standard_normal((600, 1))
    return t, u, simulate_zoh(A, B, C, D, t, u) + 0.01 * rng.standard_normal((600, 1))


def test_refine_choice_gives_the_rule_texts():
    A, B, C, D = second_order()
    model = StateSpaceModel(A, B, C, D, np.zeros((2, 1)))
    t, u, y = _record()
    not_uniform = decide_refine(model, t, u, y, uniform=False)
    assert not_uniform == RefineChoice(False, RefineReason.NOT_UNIFORM)
    assert refine_decision(model, t, u, y, False) == (
        False,
        "auto: t is not uniformly sampled, no refinement",
        None,
    )
    refined = decide_refine(model, t, u, y, uniform=True)
    assert refined.value and refined.reason is RefineReason.SINGLE_UNIFORM_RECORD
    do, text, stats = refine_decision(model, t, u, y, True)
    assert do and stats is not None and text == refined.text()
    assert text.startswith("auto: refine every single uniformly sampled record")
    assert text.endswith("open loop: refined")


@pytest.mark.parametrize("reason", list(RefineReason))
def test_every_refine_reason_has_a_text(reason):
    stats = {"feedback": False, "lags": 20, "statistic": 1.0, "threshold": 2.0}
    assert RefineChoice(reason is RefineReason.SINGLE_UNIFORM_RECORD, reason, stats).text()
