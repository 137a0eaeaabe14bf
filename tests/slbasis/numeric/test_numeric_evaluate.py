"""Stable evaluation: the mantissa/exponent recurrence against mpmath at 50 digits."""

import importlib

import mpmath
import numpy as np
import pytest
from generated_kernels import CHEBYSHEV_T, HERMITE, LAGUERRE, LEGENDRE
from hypothesis import given, settings
from hypothesis import strategies as st

from slbasis.numeric import evaluate
from slbasis.numeric.quadrature import gauss

mpmath.mp.dps = 50


def hermite_function_mp(n, x):
    """h_n(x) at 50 digits (DLMF 18.5.13 series via mpmath.hermite, exact normalisation)."""
    with mpmath.workdps(50):
        x = mpmath.mpf(float(x))
        norm = mpmath.sqrt(mpmath.mpf(2) ** n * mpmath.factorial(n) * mpmath.sqrt(mpmath.pi))
        return float(mpmath.hermite(n, x) * mpmath.exp(-x * x / 2) / norm)


def laguerre_function_mp(n, x):
    """l_n(x) = e^{-x/2} L_n(x) at 50 digits."""
    with mpmath.workdps(50):
        x = mpmath.mpf(float(x))
        return float(mpmath.laguerre(n, 0, x) * mpmath.exp(-x / 2))


def _max_error(kernel, oracle, N, x, rows):
    P = evaluate(kernel, N, x)
    assert np.all(np.isfinite(P))
    return max(np.max(np.abs(P[n] - [oracle(n, xi) for xi in x])) for n in rows)


def test_hermite_5000_against_mpmath():
    N = 5000
    rng = np.random.default_rng(20240501)
    half = 1.2 * np.sqrt(2 * N)  # 1.2x the effective support +-sqrt(2N)
    x = np.concatenate((rng.uniform(-half, half, 150), [-half, half, 0.0, 38.5, 99.9]))
    err = _max_error(HERMITE, hermite_function_mp, N, x, [0, 1, 2, 1000, 2500, 4999])
    # accuracy target 1e-12; measured ~6e-14 (the phi_0 split carries |x^2/2| * eps relative error)
    assert err <= 1e-12


@pytest.mark.slow
def test_hermite_5000_against_mpmath_full():
    N = 5000
    rng = np.random.default_rng(7)
    half = 1.2 * np.sqrt(2 * N)
    x = rng.uniform(-half, half, 500)  # bench/basis.py does the full 2000 points
    rows = [3, 700, 3000, 4998]
    # accuracy target (1e-12) at more points and other rows
    assert _max_error(HERMITE, hermite_function_mp, N, x, rows) <= 1e-12


def test_laguerre_2000_against_mpmath():
    N = 2000
    rng = np.random.default_rng(11)
    top = 1.2 * gauss(LAGUERRE, N, newton_steps=0)[0][-1]  # 1.2x the largest node (~4N)
    x = np.concatenate((rng.uniform(0, top, 120), [0.0, 1480.5, top]))
    err = _max_error(LAGUERRE, laguerre_function_mp, N, x, [0, 1, 2, 500, 1000, 1999])
    # accuracy target 1e-12; |l_n| <= 1 and the recurrence is forward stable (measured ~1e-13)
    assert err <= 1e-12


def test_plain_recurrence_trap_is_avoided():
    """At |x| = 40 phi_0 = exp(-800) underflows; h_999(40) is still O(0.1)."""
    x = np.array([40.0, -40.0])
    P = evaluate(HERMITE, 1000, x)
    ref = hermite_function_mp(999, 40.0)
    assert abs(ref) > 1e-3  # the value the plain recurrence would return as 0
    # O(1) values, forward-stable recurrence: rounding level times a few hundred
    assert np.max(np.abs(P[999] - [ref, -ref])) <= 1e-13


@pytest.mark.parametrize("kernel", [LEGENDRE, CHEBYSHEV_T])
def test_finite_interval_no_nan(kernel):
    x = np.array([-1.0, -0.5, 0.0, 0.999999, 1.0, 1.5])
    P = evaluate(kernel, 300, x)
    inside = np.abs(x) < 1
    assert np.all(np.isfinite(P[:, inside]))
    assert np.all(P[:, np.abs(x) > 1] == 0)  # outside the interval phi_0 = 0


@settings(max_examples=25, deadline=None)
@given(
    N=st.integers(1, 300),
    chunk=st.integers(1, 50),
    seed=st.integers(0, 2**32 - 1),
)
def test_chunking_does_not_change_values(N, chunk, seed):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-40, 40, 97)
    # the per-sample arithmetic is identical, only the renormalisation points may move
    # (they depend on the chunk's x range): exact powers of two, so bitwise equal values
    np.testing.assert_array_equal(evaluate(HERMITE, N, x), evaluate(HERMITE, N, x, chunk=chunk))


def test_bad_inputs():
    with pytest.raises(ValueError, match="N"):
        evaluate(HERMITE, 0, np.zeros(3))
    with pytest.raises(ValueError, match="x"):
        evaluate(HERMITE, 3, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="x"):
        evaluate(HERMITE, 3, np.array([0.0, np.nan]))


@pytest.mark.parametrize(
    ("kernel", "N", "xr"),
    [(HERMITE, 4000, (-80.0, 80.0)), (HERMITE, 66, (0.0, 5.0)), (LAGUERRE, 3000, (0.0, 1e4))],
)
def test_schedule_is_the_sequential_growth_rule(kernel, N, xr):
    """The renormalisation points found block by block equal the rule stated row by row:
    close a block before step ``n`` when its summed growth exceeds the budget or it has
    ``_MAX_STEPS`` steps (a point at ``n = 0`` is a no-op and is not used)."""
    ev = importlib.import_module("slbasis.numeric.evaluate")  # the module, not the function
    rec = ev.Recurrence(kernel, N)
    b = rec.b[: N - 1]
    dist = np.maximum(np.abs(xr[1] - b), np.abs(xr[0] - b))
    g = np.log2(np.maximum(1.0, (dist + rec.abs_A_prev[: N - 1]) * rec.abs_inv_A[: N - 1]))
    want, acc, last = [], 0.0, 0
    for n in range(N - 1):
        acc += g[n]
        if acc > ev._GROWTH_BUDGET or n + 1 - last >= ev._MAX_STEPS:
            want.append(n)
            acc, last = g[n], n
    got = rec.schedule(xr[0], xr[1], N - 1)
    assert [n for n in got if n > 0] == [n for n in want if n > 0]
