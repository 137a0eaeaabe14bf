"""Modal first-order filters against the plain loop of the state recursion."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hdpbsid.recursion import MAX_MODAL_CONDITION, linear_recursion


def loop(F: np.ndarray, W: np.ndarray, x0: np.ndarray) -> np.ndarray:
    X = np.empty((W.shape[0] + 1, F.shape[0]))
    X[0] = x0
    for k in range(W.shape[0]):
        X[k + 1] = F @ X[k] + W[k]
    return X


@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 6), seed=st.integers(0, 2**31 - 1), ns=st.integers(1, 400))
def test_modal_recursion_matches_the_loop(n: int, seed: int, ns: int) -> None:
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((n, n))
    F *= 0.98 / max(1e-12, np.max(np.abs(np.linalg.eigvals(F))))  # stable, as predictors are
    W = rng.standard_normal((ns - 1, n))
    x0 = rng.standard_normal(n)
    V = np.linalg.eig(F)[1]
    cond = np.linalg.cond(V)
    X = linear_recursion(F, W, x0)
    ref = loop(F, W, x0)
    scale = np.max(np.abs(ref)) + 1.0
    # rounding of the change of coordinates: ~cond(V) eps per step, summed over <= 400
    # steps of a contraction (|lam| <= 0.98: at most 1/(1 - 0.98) = 50 terms matter)
    tol = 1e-12 * min(cond, MAX_MODAL_CONDITION) * 50
    assert np.max(np.abs(X - ref)) <= tol * scale


def test_defective_matrix_falls_back_to_the_loop() -> None:
    F = np.array([[0.5, 1.0], [0.0, 0.5]])  # a Jordan block: no eigenvector basis
    W = np.ones((50, 2))
    x0 = np.array([1.0, -1.0])
    # the loop itself is the result: identical to the last bit
    np.testing.assert_array_equal(linear_recursion(F, W, x0), loop(F, W, x0))
