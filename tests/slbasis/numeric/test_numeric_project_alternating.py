"""project_alternating: the projection of mirrored sample pairs on a basis with parity.

Oracle: the parity identity ``phi_n(-x) = (-1)^n phi_n(x)`` (Hermite functions, Legendre
polynomials) -- projecting a record sampled symmetrically about the centre with
:func:`slbasis.numeric.project` over *all* samples gives the coefficients that
``project_alternating`` computes from the half ``x >= 0`` with ``y(x) +- y(-x)``.
"""

import numpy as np
import pytest
from generated_kernels import HERMITE, LEGENDRE

import slbasis
from slbasis.numeric import TimeMap, engine, evaluate, project
from slbasis.numeric.projection import project_alternating

# as in test_numeric_engine: the compiled engine is installed by `make test`; only an
# explicit SLBASIS_NO_NUMBA=1 (testing the numpy fallback alone) turns these off
pytestmark = pytest.mark.skipif(
    engine._disabled(), reason="SLBASIS_NO_NUMBA set: the compiled engine is switched off"
)
EPS = np.finfo(float).eps


def _mirrored(kernel, half_width: float, n_half: int, k: int, seed: int):
    """Samples ``-x_j, ..., x_j`` (``x_j > 0``, random), signals and weights on both halves."""
    rng = np.random.default_rng(seed)
    xp = np.sort(rng.uniform(0.0, half_width, n_half))
    x = np.concatenate([-xp[::-1], xp])
    Y = rng.standard_normal((x.size, k))
    w = rng.uniform(0.5, 1.5, n_half)
    W = np.concatenate([w[::-1], w])  # mirrored pairs share a weight
    return xp, x, Y, w, W


def _bound(kernel, N: int, x: np.ndarray, vy: np.ndarray) -> np.ndarray:
    """Any-order summation bound ``(Ns + 1) eps sum_i |phi_n(x_i) vy_i|`` (Higham 2002,
    eq. 4.4), doubled: the two sides sum the same products in different orders."""
    return 2 * (x.size + 1) * EPS * (np.abs(evaluate(kernel, N, x, engine="numpy")) @ np.abs(vy))


@pytest.mark.parametrize(
    ("kernel", "N", "half_width"), [(HERMITE, 700, 40.0), (LEGENDRE, 300, 0.999)]
)
@pytest.mark.parametrize("eng", ["numpy", "numba"])
@pytest.mark.parametrize("k", [1, 3, 8])
def test_equals_the_projection_of_all_samples(kernel, N, half_width, eng, k) -> None:
    xp, x, Y, w, W = _mirrored(kernel, half_width, 600, k, seed=k)
    n = xp.size
    hi, lo = Y[n:], Y[:n][::-1]  # y(x_j), y(-x_j)
    tmap = TimeMap(0.0, 1.0)
    got = project_alternating(kernel, N, tmap, xp, hi + lo, hi - lo, weights=w, engine=eng)
    ref = project(kernel, N, tmap, x, Y, weights=W, engine="numpy")
    assert got.shape == (N, k)
    # the parity identity is exact in floating point for these kernels (b_n = 0, phi_0
    # even); what differs is the order of the sums (pairs first), within the bound
    tol = _bound(kernel, N, x, W[:, None] * Y) + 1e-40  # + subnormal products
    assert np.all(np.abs(got - ref) <= tol)


def test_compiled_engine_sums_only_the_needed_signals() -> None:
    """The compiled path agrees with the numpy path (project both, select) to the
    summation bound, on more rows than one renormalisation block and a partial block."""
    rng = np.random.default_rng(7)
    x = np.sort(rng.uniform(0.0, 60.0, 1000))  # 3 blocks of 256 samples and a partial one
    ye, yo = rng.standard_normal((2, x.size, 5))
    tmap = TimeMap(0.0, 1.0)
    fast = project_alternating(HERMITE, 2000, tmap, x, ye, yo, weights="trapezoid", engine="numba")
    ref = project_alternating(HERMITE, 2000, tmap, x, ye, yo, weights="trapezoid", engine="numpy")
    v = slbasis.numeric.sample_weights(x)[:, None]
    # as above: one summation order against another
    tol = _bound(HERMITE, 2000, x, v * np.hstack([ye, yo])) + 1e-40
    assert np.all(np.abs(fast - ref) <= np.maximum(tol[:, :5], tol[:, 5:]))


def test_basis_method_in_time_units() -> None:
    """Basis.project_alternating on a time axis: the even rows of a record symmetric in
    time are its projection (odd part of the signal zero), the odd rows vanish."""
    B = slbasis.basis("hermite", 200, (0.0, 10.0))
    t = np.linspace(0.0, 10.0, 2001)
    y = np.exp(-((t - 5.0) ** 2))  # even about the centre t = 5
    c_full = B.project(t, y)
    half = t[1000:]
    w = slbasis.numeric.sample_weights(t)[1000:].copy()
    w[0] /= 2.0  # the centre sample is its own mirror: counted once
    c = B.project_alternating(half, 2.0 * y[1000:], np.zeros(half.size), weights=w)
    # same quadrature, pairs summed first: rounding only (1e-13 of the largest coefficient)
    np.testing.assert_allclose(c, c_full, rtol=0, atol=1e-13 * np.abs(c_full).max())
    assert np.all(c[1::2] == 0.0)  # odd rows sum exact zeros


def test_mismatched_signals_rejected() -> None:
    t = np.linspace(0.0, 1.0, 50)
    tmap = TimeMap(0.0, 1.0)
    with pytest.raises(ValueError, match="y_odd"):
        project_alternating(HERMITE, 10, tmap, t, np.ones((50, 2)), np.ones((50, 3)))
    with pytest.raises(ValueError, match="y_even"):
        project_alternating(HERMITE, 10, tmap, t, np.ones(49), np.ones(49))


def test_engine_columns_checked() -> None:
    from slbasis.numeric.evaluate import Recurrence

    x = np.linspace(0.0, 1.0, 10)
    z = np.zeros(10)
    with pytest.raises(ValueError, match="columns"):
        engine.project_compiled(
            Recurrence(HERMITE, 5),
            5,
            x,
            z,
            z.astype(np.int64),
            np.ones((3, 10)),
            np.zeros(5, bool),
            2,
        )
