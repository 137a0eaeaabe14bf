"""The refinement started again from another candidate of its order when its result has
a mode the input does not drive (:mod:`hdpbsid.selection.restarts`).  Oracles: a simulated
second-order plant (modes ``-1``, ``-4``) against a refined model that spent a state on
a mode far beyond the input's band that the input does not reach; and the closed-loop
fast-mode plant with its oscillatory pair stable, whose record (seed 5) sends the
refinement from the ranked candidate into such a minimum."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from hdpbsid import identify
from hdpbsid.models.criteria import WindowedError
from hdpbsid.models.metrics import eigenvalue_errors
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import DirectTerm, Refinement, WarmStart
from hdpbsid.refine.pem import prediction_log_det, refine_pem
from hdpbsid.selection.candidates import CandidateRow
from hdpbsid.selection.restarts import restarted, same_order_starts

TRUE_MODES = np.array([-1.0, -4.0])


def _plant(modes, b2: float = 1.0) -> StateSpaceModel:
    """``diag(modes)``, ``B = [1, b2]^T``, ``C = [1, 1]``, no ``D``, ``K = 0``."""
    return StateSpaceModel(np.diag(modes), [[1.0], [b2]], [[1.0, 1.0]], [[0.0]], [[0.0], [0.0]])


def _record(seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The plant ``diag(-1, -4)``, ``B = C^T = [1, 1]``, under a random binary input held
    0.5 s, 2000 samples at 20 Hz, the exact sampled response plus 1 % white noise."""
    rng = np.random.default_rng(seed)
    t = 0.05 * np.arange(2000)
    u = np.repeat(rng.choice([-1.0, 1.0], 200), 10)[:, None]
    y = _plant(TRUE_MODES).simulate(t, u)
    return t, u, y + 0.01 * np.std(y) * rng.standard_normal(y.shape)


def _spurious() -> StateSpaceModel:
    """The model of a spurious minimum: it keeps ``-1`` and spends its second state on
    ``-200`` rad/s, which the input reaches through ``1e-6`` (where a biased start can
    lead the refinement), reported as a converged refinement."""
    model = _plant([-1.0, -200.0], 1e-6)
    model.report = model.report.but(refinement=Refinement(True, 10, "zoh", "model K", (1.0, 1.0)))
    return model


def _offering(model: StateSpaceModel, starts: tuple[WarmStart, ...]) -> StateSpaceModel:
    model.report = model.report.but(restarts=starts)
    return model


def test_a_refined_model_with_an_undriven_mode_is_refined_again_from_the_restarts() -> None:
    rec = _record()
    refined = _spurious()
    near = _plant([-1.3, -3.0])
    start = _offering(refined, (WarmStart.of(near, "zoh", "the other candidate"),))
    kept, note = restarted(start, refined, *rec, closed=True)
    assert "refined again from the other candidate" in note
    # the likelihood decides: the restart's is the larger (the smaller N log det S)
    costs = [prediction_log_det(m, *rec, m.report.hold) for m in (kept, refined)]
    assert costs[0] < costs[1]
    # the minimum the fit from the true system reaches (the record's own error, 1.1 %
    # on -4): the same minimum to the refinement's convergence tolerance
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        oracle = refine_pem(_plant(TRUE_MODES), *rec)
    assert np.max(eigenvalue_errors(kept.eigenvalues, oracle.eigenvalues)) < 1e-3


def test_no_restart_in_open_loop_or_without_starts() -> None:
    """In open loop the candidates are consistent and a mode the input does not drive is
    the noise model's: the refined model stands, as it does with no start offered."""
    rec = _record()
    refined = _spurious()
    start = _offering(refined, (WarmStart.of(_plant([-1.3, -3.0]), "zoh"),))
    assert restarted(start, refined, *rec, closed=False) == (refined, "")
    assert restarted(_offering(refined, ()), refined, *rec, closed=True) == (refined, "")


def _row(method: str, order: int, error: float, with_d: bool = False) -> CandidateRow:
    row = CandidateRow(method, order, settings={"feedthrough": True} if with_d else {})
    n = order
    row.model = StateSpaceModel(
        -np.eye(n), np.ones((n, 1)), np.ones((1, n)), [[0.0]], np.zeros((n, 1))
    )
    row.model.report = row.model.report.but(method=method, feedthrough=DirectTerm(with_d, False))
    row.criterion = WindowedError(np.array([error]), error, 1.0, True)
    return row


def test_the_starts_are_the_best_of_the_same_order_of_each_other_method_and_structure() -> None:
    chosen = _row("dt", 2, 0.1)
    ok = [
        chosen,
        _row("hermite", 2, 0.3),
        _row("hermite", 2, 0.2),  # the better of hermite's two
        _row("legendre", 2, 0.15),
        _row("laguerre", 3, 0.05),  # another order
        _row("chebyshev", 2, 0.01, with_d=True),  # another structure: a start as well
        _row("dt", 2, 0.05),  # the returned model's own method and structure
        _row("dt", 2, 0.12, with_d=True),  # its method, another structure
    ]
    starts = same_order_starts(ok, chosen.model)
    assert [s.name.split()[1] for s in starts] == ["chebyshev", "dt", "legendre", "hermite"]


def test_a_closed_loop_record_that_misleads_the_ranked_candidate_gets_the_modes() -> None:
    """The closed-loop fast-mode plant with its pair stable (``-28, -10, -1.2 +- 5.8i``),
    an observer-based state feedback, 20 dB, seed 5 (``bench/closed_loop_fast.py
    --plant stable-pair``): refined from the candidate ranked first, the model spends
    two states on a pair near the Nyquist frequency the input does not drive and loses
    the plant's pair; refined again from the next candidate of the order it reaches the
    minimum the refinement from the true system reaches (7.8 % off, the record's own
    error)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "bench"))
    import closed_loop_fast as clf

    old, clf.PLANT = clf.PLANT, "stable-pair"
    try:
        t, u, y = clf.record("observer", 5, 20.0)
        truth = np.linalg.eigvals(clf.plant_matrices()[0])
    finally:
        clf.PLANT = old
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = identify(t, u, y, order=4)
    assert "refined again from" in model.options["refine_rule"]
    # the ceiling the record sets is 7.8 % (the fit from the true system); 10 % the
    # bench's criterion
    assert np.max(eigenvalue_errors(model.eigenvalues, truth)) < 0.10


@pytest.mark.parametrize("closed", [True, False])
def test_a_model_whose_modes_are_all_driven_is_kept(closed: bool) -> None:
    rec = _record()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = refine_pem(
            _plant(TRUE_MODES),
            *rec,
        )
    start = _offering(fit, (WarmStart.of(_spurious(), "zoh"),))
    assert restarted(start, fit, *rec, closed=closed) == (fit, "")
