"""The hand-written test kernels (numeric_kernels_fixture) against scipy.special closed forms."""

import numpy as np
import pytest
import scipy.special as sps
from numeric_kernels_fixture import ALL, CHEBYSHEV_T, HERMITE, LAGUERRE, LEGENDRE

from slbasis.numeric import check_kernel, evaluate, evaluate_derivative

NMAX = 20


def _reference(kernel, n, x):
    """phi_n(x) from scipy.special, independent of the recurrence."""
    if kernel is HERMITE:
        norm = np.sqrt(2.0**n * sps.factorial(n) * np.sqrt(np.pi))
        return sps.eval_hermite(n, x) * np.exp(-(x**2) / 2) / norm
    if kernel is LAGUERRE:
        return sps.eval_laguerre(n, x) * np.exp(-x / 2)
    if kernel is LEGENDRE:
        return sps.eval_legendre(n, x) * np.sqrt((2 * n + 1) / 2)
    d = np.sqrt(np.pi if n == 0 else np.pi / 2)
    return sps.eval_chebyt(n, x) * (1 - x * x) ** -0.25 / d


def _points(kernel):
    return {
        HERMITE: np.linspace(-6, 6, 41),
        LAGUERRE: np.linspace(0.0, 40, 41),
        LEGENDRE: np.linspace(-0.99, 0.99, 41),
        CHEBYSHEV_T: np.linspace(-0.99, 0.99, 41),
    }[kernel]


@pytest.mark.parametrize("name", sorted(ALL))
def test_kernel_interface(name):
    check_kernel(ALL[name], 16)


@pytest.mark.parametrize("name", sorted(ALL))
def test_values_match_scipy(name):
    kernel = ALL[name]
    x = _points(kernel)
    P = evaluate(kernel, NMAX, x)
    ref = np.array([_reference(kernel, n, x) for n in range(NMAX)])
    # both sides are O(1) and accurate to ~1e-15 relative; 1e-12 leaves room for the
    # scipy closed forms (factorials, powers) at n = 20
    assert np.max(np.abs(P - ref)) <= 1e-12 * max(1.0, np.max(np.abs(ref)))


@pytest.mark.parametrize("name", sorted(ALL))
def test_derivative_bands_match_finite_differences(name):
    """2 p0 phi_n' = sub phi_{n-1} + diag phi_n + sup phi_{n+1}, checked against a
    4th-order central difference of the scipy closed forms (independent of the bands)."""
    kernel = ALL[name]
    x = _points(kernel)[5:-5]
    _, dP = evaluate_derivative(kernel, NMAX, x)
    h = 1e-3
    for n in range(NMAX):
        f = lambda s, n=n: _reference(kernel, n, s)  # noqa: E731
        fd = (f(x - 2 * h) - 8 * f(x - h) + 8 * f(x + h) - f(x + 2 * h)) / (12 * h)
        # 4th-order difference: error ~ h^4 f^(5) / 30 ~ 1e-12 * n^{5/2}; 1e-6 is generous
        # but still catches any wrong band (they are O(1) .. O(n))
        assert np.max(np.abs(dP[n] - fd)) <= 1e-6 * max(1.0, np.max(np.abs(dP[n])))
