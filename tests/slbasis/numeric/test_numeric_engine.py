"""The compiled (numba) engine against the numpy engine, and projections against oracles."""

import mpmath
import numpy as np
import pytest
from generated_kernels import CHEBYSHEV_T, HERMITE, LAGUERRE, LEGENDRE
from hypothesis import given, settings
from hypothesis import strategies as st
from numeric_kernels_fixture import LAGUERRE as LAGUERRE_SPEC

import slbasis
from slbasis.numeric import Basis, TimeMap, engine, evaluate, project
from slbasis.numeric.projection import sample_weights

# the compiled engine is part of what `make test` installs (extra "fast"): a missing numba
# must fail here, not skip; only an explicit SLBASIS_NO_NUMBA=1 (testing the numpy
# fallback alone) turns these comparisons off
pytestmark = pytest.mark.skipif(
    engine._disabled(), reason="SLBASIS_NO_NUMBA set: the compiled engine is switched off"
)
if not engine._disabled():
    import numba  # noqa: F401

EPS = np.finfo(float).eps
JACOBI = slbasis.kernel("jacobi", alpha=0.5, beta=-0.3)
GEGENBAUER = slbasis.kernel("gegenbauer", lam=0.7)

# (kernel, N, x): far tails included (Hermite |x| > 38 where phi_0 underflows, Laguerre
# x > 1480), uniform grids and random points; LAGUERRE_SPEC is a hand-built KernelSpec
# with negative A_n (a "custom" kernel)
_rng = np.random.default_rng(2024)
CASES = [
    (HERMITE, 5000, _rng.uniform(-120.0, 120.0, 700)),
    (HERMITE, 1000, np.linspace(-60.0, 60.0, 1001)),
    (LAGUERRE, 2000, np.concatenate(([0.0, 1480.5], _rng.uniform(0.0, 9600.0, 500)))),
    (LAGUERRE_SPEC, 700, np.linspace(0.0, 3000.0, 400)),
    (LEGENDRE, 3000, np.concatenate(([-1.0, 1.0, 1.5], _rng.uniform(-1.0, 1.0, 400)))),
    (CHEBYSHEV_T, 500, np.linspace(-0.999, 0.999, 301)),
    (JACOBI, 800, _rng.uniform(-1.0, 1.0, 300)),
    (GEGENBAUER, 600, np.linspace(-1.0, 1.0, 257)),
]
IDS = [f"{k.name}-{N}" for k, N, _ in CASES]


def _both(fn):
    return fn("numpy"), fn("numba")


@pytest.mark.parametrize(("kernel", "N", "x"), CASES, ids=IDS)
def test_evaluate_bitwise(kernel, N, x):
    ref, fast = _both(lambda e: evaluate(kernel, N, x, engine=e))
    # same IEEE operations in the same order (no FMA, division not reciprocal), exact
    # power-of-two renormalisation, correctly rounded 2^e scaling: equal bit for bit
    np.testing.assert_array_equal(fast, ref)


@settings(max_examples=30, deadline=None)
@given(
    N=st.integers(1, 400),
    half=st.floats(0.5, 60.0),
    size=st.integers(1, 700),
    seed=st.integers(0, 2**32 - 1),
)
def test_evaluate_bitwise_random(N, half, size, seed):
    x = np.random.default_rng(seed).uniform(-half, half, size)
    ref, fast = _both(lambda e: evaluate(HERMITE, N, x, engine=e))
    np.testing.assert_array_equal(fast, ref)  # bit for bit, as in test_evaluate_bitwise


def test_evaluate_threads(monkeypatch):
    """Several threads (forced on a small problem) write disjoint columns: same values."""
    x = np.linspace(-50.0, 50.0, 3001)
    ref = evaluate(HERMITE, 700, x, engine="numpy")
    monkeypatch.setattr(engine, "_THREAD_MIN_WORK", 1)
    monkeypatch.setattr(engine, "_threads", lambda: 3)
    assert len(engine._ranges(x.size, 700)) == 3
    np.testing.assert_array_equal(evaluate(HERMITE, 700, x, engine="numba"), ref)  # bitwise


def _summation_bound(kernel, N, x, vy):
    """Any-order bound on ``|Phi @ vy - exact|`` for each engine, doubled for their gap:
    ``(Ns + 1) eps sum_i |phi_n(x_i) vy_i|`` (Higham 2002, eq. 4.4: products and sums)."""
    S = np.abs(evaluate(kernel, N, x, engine="numpy")) @ np.abs(vy)
    return 2 * (x.size + 1) * EPS * S


def _project(kernel, N, t, Y, weights, eng, method="quadrature"):
    return project(kernel, N, TimeMap(0.0, 1.0), t, Y, weights=weights, engine=eng, method=method)


@pytest.mark.parametrize(("kernel", "N", "x"), CASES, ids=IDS)
@pytest.mark.parametrize("k", [1, 3, 5, 6, 8, 10])
def test_project_agrees(kernel, N, x, k):
    """Fused kernel (k <= 8: every column grouping) and compiled blocks + BLAS (k = 10)
    vs numpy, uniform and random sample points."""
    a, b = kernel.interval
    t = np.unique(np.clip(x, a, b))
    if kernel is CHEBYSHEV_T:
        t = t[np.abs(t) < 1]  # phi_0 is infinite at the ends
    rng = np.random.default_rng(k)
    Y = rng.standard_normal((t.size, k))
    w = rng.uniform(0.0, 2.0, t.size)  # explicit non-negative weights
    ref, fast = _both(lambda e: _project(kernel, N, t, Y, w, e))
    # summation order differs (SIMD partial sums vs BLAS); each is within the any-order
    # bound; + 1e-40 for products rounded in the subnormal range (< 2^-174 each)
    tol = _summation_bound(kernel, N, t, w[:, None] * Y) + 1e-40
    assert np.all(np.abs(fast - ref) <= tol)


@settings(max_examples=20, deadline=None)
@given(
    N=st.integers(1, 300),
    k=st.integers(1, 9),
    size=st.integers(2, 900),
    jitter=st.floats(0.0, 0.45),
    seed=st.integers(0, 2**32 - 1),
)
def test_project_agrees_random(N, k, size, jitter, seed):
    """Non-uniform samples, trapezoid weights, 1..9 signal columns (every column group)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(-45.0, 45.0, size)
    if size > 2:
        t[1:-1] += rng.uniform(-jitter, jitter, size - 2) * (t[1] - t[0])
    Y = rng.standard_normal((size, k))
    ref, fast = _both(lambda e: _project(HERMITE, N, t, Y, "trapezoid", e))
    tol = _summation_bound(HERMITE, N, t, sample_weights(t)[:, None] * Y) + 1e-40  # as above
    assert np.all(np.abs(fast - ref) <= tol)


def test_project_threads(monkeypatch):
    """Per-thread partial sums, reduced at the end: same bound as one thread."""
    t = np.linspace(-50.0, 50.0, 5001)
    Y = np.column_stack([np.cos(t), np.exp(-(t**2) / 50), np.sin(3 * t)])
    ref = _project(HERMITE, 600, t, Y, "trapezoid", "numpy")
    monkeypatch.setattr(engine, "_THREAD_MIN_WORK", 1)
    monkeypatch.setattr(engine, "_threads", lambda: 3)
    fast = _project(HERMITE, 600, t, Y, "trapezoid", "numba")
    tol = _summation_bound(HERMITE, 600, t, sample_weights(t)[:, None] * Y)  # as above
    assert np.all(np.abs(fast - ref) <= tol)


def test_project_same_bits_on_any_number_of_threads(monkeypatch):
    """The lanes depend on the call's size only: one, two or three threads (the override,
    which is obeyed without a measurement) give the same sums bit for bit."""
    from slbasis.runtime import num_threads

    t = np.linspace(-50.0, 50.0, 5001)
    Y = np.column_stack([np.cos(t), np.exp(-(t**2) / 50), np.sin(3 * t)])
    monkeypatch.setattr(engine, "_THREAD_MIN_WORK", 1)
    assert len(engine._lanes(t.size, 600)[1]) > 3  # more lanes than threads
    got = []
    for n in (1, 2, 3):
        with num_threads(n):
            got.append(_project(HERMITE, 600, t, Y, "trapezoid", "numba"))
    np.testing.assert_array_equal(got[1], got[0])
    np.testing.assert_array_equal(got[2], got[0])


@given(st.integers(1, 3000), st.integers(2, 4))
def test_interleaved_split_is_a_round_robin_permutation(n, parts):
    """Group g of the permuted samples holds every parts-th block from block g."""
    order = engine._interleaved(n, parts)
    block = engine._compiled().BLOCK
    expected = [i for g in range(parts) for i in range(n) if (i // block) % parts == g]
    assert np.array_equal(order, expected)


@given(st.integers(1, 40_000), st.integers(1, 5000))
def test_lanes_are_round_robin_groups_of_a_power_of_two(n, N):
    """The lanes of a projection: a power of two of them, at most MAX_LANES, lane g the
    samples of the blocks g, g + L, ... (in order), together every sample once."""
    order, ranges = engine._lanes(n, N)
    L = len(ranges)
    assert L & (L - 1) == 0 and L <= engine.MAX_LANES
    block = engine._compiled().BLOCK
    perm = np.arange(n) if order is None else order
    assert np.array_equal(np.sort(perm), np.arange(n))
    group = (np.arange(n) // block) % L
    for g, (lo, hi) in enumerate(ranges):
        assert np.array_equal(perm[lo:hi], np.flatnonzero(group == g))


def _gaussian_coefficients(N, a):
    """``c_n`` of ``exp(-(x - a)^2 / 2)`` in Hermite functions, from the generating
    function ``exp(2xs - s^2) = sum_n H_n(x) s^n / n!`` at ``s = a / 2`` (DLMF 18.12.15):
    ``c_n = pi^(1/4) exp(-a^2/4) (a / sqrt 2)^n / sqrt(n!)`` (mpmath, 30 digits)."""
    with mpmath.workdps(30):
        a = mpmath.mpf(a)
        front = mpmath.pi**0.25 * mpmath.exp(-a * a / 4)
        r = a / mpmath.sqrt(2)
        return np.array([float(front * r**n / mpmath.sqrt(mpmath.factorial(n))) for n in range(N)])


@pytest.mark.parametrize("eng", ["numpy", "numba"])
def test_project_shifted_gaussian_analytic(eng):
    """Projection of exp(-(x - a)^2 / 2) onto 2000 Hermite functions vs the closed form."""
    N, a = 2000, 9.0
    x = np.linspace(-60.0, 60.0, 60001)  # dx = 2e-3, far below the Nyquist step pi/63
    Y = np.column_stack([np.exp(-((x - a) ** 2) / 2), -np.exp(-((x + a) ** 2) / 2)])
    c = _project(HERMITE, N, x, Y, "trapezoid", eng)
    exact = _gaussian_coefficients(N, a)
    # band-limited integrand, ~0 at the ends: the trapezoid rule is exact to rounding
    # (6e4 terms of size <= 2e-3, |c_n| <= 0.34); measured 1.3e-15 (both engines)
    assert np.max(np.abs(c[:, 0] - exact)) <= 1e-14
    assert np.max(np.abs(c[:, 1] + _gaussian_coefficients(N, -a))) <= 1e-14  # same


def test_basis_project_mpmath_coefficient():
    """Basis.project (auto engine, time units) against mpmath quadrature for one row."""
    B = Basis(HERMITE, 400, (0.0, 40.0))
    t = np.linspace(0.0, 40.0, 40001)
    y = np.exp(-(((t - 22.0) / 3.0) ** 2)) * np.sin(1.5 * t)
    c = B.project(t, y, engine="numba")
    n = 37
    s, c0 = B.scale, B.centre

    def integrand(tt):
        xx = (tt - c0) * s
        norm = mpmath.sqrt(mpmath.mpf(2) ** n * mpmath.factorial(n) * mpmath.sqrt(mpmath.pi))
        h = mpmath.hermite(n, xx) * mpmath.exp(-xx * xx / 2) / norm
        return mpmath.sqrt(s) * h * mpmath.exp(-(((tt - 22) / 3) ** 2)) * mpmath.sin(1.5 * tt)

    with mpmath.workdps(30):
        ref = float(mpmath.quad(integrand, [0, 16, 22, 28, 40]))
    # integrand < 1e-16 at the window ends and band-limited: the trapezoid error is
    # rounding (4e4 terms of size <= 1e-3, |c_n| <= 0.71); measured 1.1e-16
    assert abs(c[n] - ref) <= 1e-14


def test_reconstruct_agrees():
    B = Basis(LEGENDRE, 300, (0.0, 2.0))
    c = np.random.default_rng(5).standard_normal((300, 2))
    t = np.linspace(0.0, 2.0, 4001)
    ref, fast = _both(lambda e: B.reconstruct(c, t, engine=e))
    # same (bitwise) function values; both multiply by c with the same BLAS call
    np.testing.assert_array_equal(fast, ref)


def test_lstsq_agrees():
    B = Basis(LEGENDRE, 40, (0.0, 1.0))
    t = np.sort(np.random.default_rng(8).uniform(0.0, 1.0, 3000))
    y = np.cos(7 * t)
    ref, fast = _both(lambda e: B.project(t, y, method="lstsq", engine=e))
    # identical function values and BLAS calls (the compiled engine only evaluates here)
    np.testing.assert_array_equal(fast, ref)


@pytest.mark.parametrize("eng", ["numpy", "numba"])
def test_singular_end_rejected(eng):
    t = np.linspace(-1.0, 1.0, 2001)  # Chebyshev-T functions are infinite at x = +-1
    with pytest.raises(ValueError, match="infinite"):
        project(CHEBYSHEV_T, 50, TimeMap(0.0, 1.0), t, np.ones_like(t), engine=eng)


def test_engine_choice(monkeypatch):
    assert engine.resolve("auto", 10) == "numpy"  # too small to be worth a compilation
    assert engine.resolve("auto", 1 << 20) == "numba"
    with pytest.raises(ValueError, match="engine"):
        engine.resolve("fortran", 10)
    monkeypatch.setenv("SLBASIS_NO_NUMBA", "1")
    assert not engine.numba_available()
    assert engine.resolve("auto", 1 << 30) == "numpy"
    with pytest.raises(RuntimeError, match="SLBASIS_NO_NUMBA"):
        evaluate(HERMITE, 3, np.zeros(2), engine="numba")
    monkeypatch.setenv("SLBASIS_NO_NUMBA", "0")
    assert engine.numba_available()


def test_auto_counts_the_numpy_row_overhead():
    # many functions at a few points: the numpy engine still pays its per-row cost
    # (NUMPY_ROW_OVERHEAD values per row), so "auto" compiles; few rows stay with numpy
    assert engine.work(4000, 2) == 4000 * (2 + engine.NUMPY_ROW_OVERHEAD)
    if engine.numba_available():
        assert engine.resolve("auto", engine.work(4000, 2)) == "numba"
    assert engine.resolve("auto", engine.work(10, 2)) == "numpy"
