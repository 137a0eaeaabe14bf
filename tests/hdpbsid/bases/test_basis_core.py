"""The past window of the basis-domain core: a typed choice with the rule's text."""

from __future__ import annotations

import numpy as np
import pytest

from hdpbsid.bases import basis_core as bc
from hdpbsid.bases import basis_domain as bd
from hdpbsid.core.blocks import BlockLag
from hdpbsid.core.varx import SampleShift


def _rows(ncols: int = 400, seed: int = 0) -> tuple[np.ndarray, np.ndarray, BlockLag]:
    """``y_k = 0.8 y_{k-1} + u_{k-1}`` (one block, sample shift): a first-order VARX."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((1, ncols))
    y = np.zeros((1, ncols))
    for k in range(1, ncols):
        y[0, k] = 0.8 * y[0, k - 1] + u[0, k - 1]
    return u, y, BlockLag([SampleShift()], [ncols])


def test_old_names_are_the_rules_fields() -> None:
    assert bd.P_DEFAULT_RANGE == bc.CORE.p_default_range == (2, 4)
    assert bd.COLS_PER_REGRESSOR == bc.CORE.cols_per_regressor
    assert bd.RIDGE_FLOOR == bc.CORE.ridge_floor
    assert bd.run_core is bc.run_core and bd.BasisTooSmall is bc.BasisTooSmall


def test_given_window_is_reported_as_given() -> None:
    u, y, lag = _rows()
    out = bc.run_core(
        u, y, None, lag, order=1, p=3, f=None, max_order=5, regularize=False,
        feedthrough=False, stable_k=False, normalize=True,
    )  # fmt: skip
    assert out.options["p_rule"] == "given" and out.options["p_criterion_values"] is None
    np.testing.assert_allclose(out.A, [[0.8]], atol=1e-8)  # noise-free: exact to rounding


def test_default_window_is_the_smallest_aic_with_its_criterion() -> None:
    u, y, lag = _rows()
    sc = bc._scaled(u, y, None, lag, True)
    w = bc.default_past_window(sc, lag, None, f=None, order=1, feedthrough=False, p_range=None)
    assert w.reason is bc.WindowReason.AIC
    assert w.text.startswith("min AIC of the VARX fit over p in [2, 4]")
    assert w.criterion is not None and w.value == int(np.argmin(w.criterion)) + 1
    assert np.isinf(w.criterion[0])  # below the range


def test_order_beyond_the_range_takes_the_smallest_window_that_shows_it() -> None:
    u, y, lag = _rows(2000)
    sc = bc._scaled(u, y, None, lag, True)
    # order 6 with one output needs f = p >= 6, above the preferred range (2, 4)
    w = bc.default_past_window(sc, lag, None, f=None, order=6, feedthrough=False, p_range=None)
    assert (w.value, w.reason) == (6, bc.WindowReason.ORDER_NEEDS)


def test_too_small_a_basis_for_the_default_rule() -> None:
    u, y, lag = _rows(60)
    sc = bc._scaled(u, y, None, lag, True)
    with pytest.raises(bc.BasisTooSmall) as err:
        bc.default_past_window(sc, lag, None, f=None, order=6, feedthrough=False, p_range=None)
    assert err.value.p_needed == 6
