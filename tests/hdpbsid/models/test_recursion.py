"""Modal first-order filters against the plain loop of the state recursion."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hdpbsid.models.recursion import (
    MAX_MODAL_CONDITION,
    forced_responses,
    linear_recursion,
    matrix_powers,
)

try:
    import hdpbsid.models.recursion_kernels  # noqa: F401

    ENGINES = ["numpy", "numba"]
except ImportError:  # the extra "fast" is not installed: the numpy engine only
    ENGINES = ["numpy"]


def loop(F: np.ndarray, W: np.ndarray, x0: np.ndarray) -> np.ndarray:
    X = np.empty((W.shape[0] + 1, F.shape[0]))
    X[0] = x0
    for k in range(W.shape[0]):
        X[k + 1] = F @ X[k] + W[k]
    return X


@pytest.mark.parametrize("engine", ENGINES)
@settings(max_examples=40, deadline=None)
@given(n=st.integers(1, 6), seed=st.integers(0, 2**31 - 1), ns=st.integers(1, 400))
def test_recursion_matches_the_loop(engine: str, n: int, seed: int, ns: int) -> None:
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((n, n))
    F *= 0.98 / max(1e-12, np.max(np.abs(np.linalg.eigvals(F))))  # stable, as predictors are
    W = rng.standard_normal((ns - 1, n))
    x0 = rng.standard_normal(n)
    V = np.linalg.eig(F)[1]
    cond = np.linalg.cond(V)
    X = linear_recursion(F, W, x0, engine=engine)
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
    np.testing.assert_array_equal(linear_recursion(F, W, x0, engine="numpy"), loop(F, W, x0))


@settings(max_examples=30, deadline=None)
@given(
    n=st.integers(1, 5),
    seed=st.integers(0, 2**31 - 1),
    batch=st.integers(1, 6),
    steps=st.integers(1, 200),
    radius=st.sampled_from([0.5, 0.98, 1.02]),
)
@pytest.mark.parametrize("engine", ENGINES)
def test_batched_forced_responses_and_powers_match_the_loop(
    engine: str, n: int, seed: int, batch: int, steps: int, radius: float
) -> None:
    rng = np.random.default_rng(seed)
    F = rng.standard_normal((n, n))
    F *= radius / max(1e-12, np.max(np.abs(np.linalg.eigvals(F))))  # unstable ones too
    W = rng.standard_normal((batch, steps, n))
    X = forced_responses(F, W, engine=engine)
    ref = np.stack([loop(F, W[b], np.zeros(n)) for b in range(batch)])
    cond = min(np.linalg.cond(np.linalg.eig(F)[1]), MAX_MODAL_CONDITION)
    # rounding of the change of coordinates, ~cond(V) eps per step, accumulated over at
    # most 200 steps whose terms grow by at most 1.02^200 ~ 52 (relative to the largest)
    tol = 1e-13 * cond * steps
    assert np.max(np.abs(X - ref)) <= tol * (np.max(np.abs(ref)) + 1.0)
    P = matrix_powers(F, steps, engine=engine)
    Pref = np.stack([np.linalg.matrix_power(F, k) for k in range(steps)])
    assert np.max(np.abs(P - Pref)) <= tol * (np.max(np.abs(Pref)) + 1.0)


def test_batched_recursion_of_a_defective_matrix_is_the_loop() -> None:
    F = np.array([[0.5, 1.0], [0.0, 0.5]])  # a Jordan block: no eigenvector basis
    W = np.ones((3, 40, 2))
    ref = np.stack([loop(F, W[b], np.zeros(2)) for b in range(3)])
    # the fallback loop is the same arithmetic in the same order as the reference
    np.testing.assert_allclose(forced_responses(F, W, engine="numpy"), ref, rtol=1e-15, atol=0)
    P = matrix_powers(F, 5, engine="numpy")
    np.testing.assert_array_equal(P[4], np.linalg.matrix_power(F, 4))


@pytest.mark.skipif("numba" not in ENGINES, reason="numba (extra 'fast') not installed")
@settings(max_examples=30, deadline=None)
@given(
    n=st.integers(1, 6),
    seed=st.integers(0, 2**31 - 1),
    steps=st.integers(1, 300),
    defective=st.booleans(),
)
def test_compiled_recursion_is_the_loop_without_the_modal_rounding(
    n: int, seed: int, steps: int, defective: bool
) -> None:
    """The compiled engine runs the loop itself: it agrees with the numpy loop to the
    rounding of one step's dot products, whatever the eigenvector condition (a nearly
    defective ``F`` included, where the modal filters lose ``cond(V)``)."""
    rng = np.random.default_rng(seed)
    if defective:  # a Jordan block perturbed by 1e-9: cond(V) ~ 1e9
        F = 0.9 * np.eye(n) + np.diag(np.ones(n - 1), 1)
        F[-1, 0] = 1e-9
    else:
        F = rng.standard_normal((n, n))
    F *= 0.99 / max(1e-12, np.max(np.abs(np.linalg.eigvals(F))))
    W = rng.standard_normal((steps, n))
    x0 = rng.standard_normal(n)
    ref = loop(F, W, x0)
    X = linear_recursion(F, W, x0, engine="numba")
    # each step rounds a dot product of n terms (~n eps relative) and the errors are
    # carried by a contraction amplified at most by the transient growth of F^k (the
    # Jordan case: up to ~n^n); 1e-12 relative covers both with a margin of 100
    assert np.max(np.abs(X - ref)) <= 1e-12 * (np.max(np.abs(ref)) + 1.0)
    P = matrix_powers(F, steps, engine="numba")
    Pref = np.stack([np.linalg.matrix_power(F, k) for k in range(steps)])
    assert np.max(np.abs(P - Pref)) <= 1e-12 * (np.max(np.abs(Pref)) + 1.0)


def test_unknown_engine_is_refused() -> None:
    with pytest.raises(ValueError, match="engine must be one of"):
        forced_responses(np.eye(2), np.zeros((1, 3, 2)), engine="fortran")
