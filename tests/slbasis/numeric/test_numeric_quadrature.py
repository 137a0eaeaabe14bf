"""Gauss quadrature for orthonormal functions against mpmath and scipy."""

import mpmath
import numpy as np
import pytest
import scipy.special as sps
from generated_kernels import ALL, HERMITE, LAGUERRE, LEGENDRE

from slbasis.numeric import evaluate, gauss


def _hermite_node_and_weight_mp(N, x0):
    """Newton-polish a node of H_N at 50 digits, return (node, 1 / (N h_{N-1}(node)^2))."""
    with mpmath.workdps(50):

        def pair(x):
            hm, h = mpmath.mpf(0), mpmath.mpf(1)
            for k in range(N):
                hm, h = h, 2 * x * h - 2 * k * hm
            return h, hm  # H_N, H_{N-1}

        x = mpmath.mpf(float(x0))
        for _ in range(3):
            h, hm = pair(x)
            x -= h / (2 * N * hm)  # H_N' = 2N H_{N-1}
        _, hm = pair(x)
        norm = mpmath.mpf(2) ** (N - 1) * mpmath.factorial(N - 1) * mpmath.sqrt(mpmath.pi)
        w = 1 / (N * hm**2 * mpmath.exp(-x * x) / norm)
        return float(x), float(w)


def test_hermite_1000_against_mpmath():
    N = 1000
    x, W = gauss(HERMITE, N)
    assert np.all(W > 0) and np.all(np.isfinite(W)) and np.all(np.diff(x) > 0)
    idx = np.unique(np.concatenate((np.arange(0, N, 37), [0, 1, N // 2, N - 2, N - 1])))
    for i in idx:
        xr, wr = _hermite_node_and_weight_mp(N, x[i])
        # Newton-refined nodes: a few ulp of |x| <= 44 (measured 2e-15)
        assert abs(x[i] - xr) <= 2e-14
        # accuracy target 1e-10 relative; measured ~2e-13 (Christoffel sum of positive terms)
        assert abs(W[i] - wr) <= 1e-10 * wr


def test_hermite_1000_beats_numpy_and_scipy():
    N = 1000
    x, W = gauss(HERMITE, N)
    xs, ws = sps.roots_hermite(N)
    # same nodes (scipy's are accurate to ~1e-14 absolute)
    assert np.max(np.abs(xs - x)) <= 1e-12
    assert np.count_nonzero(ws == 0) > 0  # the known trap: underflowed weights
    assert np.count_nonzero(W == 0) == 0


@pytest.mark.parametrize("name", sorted(ALL))
def test_gram_matrix_is_identity(name):
    kernel = ALL[name]
    N = 200
    x, W = gauss(kernel, N)
    P = evaluate(kernel, N, x)
    G = (P * W) @ P.T
    # exact rule for products in the span: rounding only, ~N eps
    assert np.max(np.abs(G - np.eye(N))) <= 1e-12


def _polished(f, x0):
    with mpmath.workdps(50):
        return mpmath.findroot(f, mpmath.mpf(float(x0)), verify=False)  # secant, 50 digits


def test_legendre_against_mpmath():
    N = 100
    x, W = gauss(LEGENDRE, N)
    xs, _ = sps.roots_legendre(N)
    assert np.max(np.abs(x - xs)) <= 1e-14  # both at rounding level of |x| <= 1
    for i in (0, 1, 7, 50, 98, 99):
        with mpmath.workdps(50):
            r = _polished(lambda t: mpmath.legendre(N, t), x[i])
            dP = N * (r * mpmath.legendre(N, r) - mpmath.legendre(N - 1, r)) / (r * r - 1)
            wr = float(2 / ((1 - r * r) * dP**2))  # DLMF 3.5.19 (w = 1: function weights)
        assert abs(x[i] - float(r)) <= 1e-15  # nodes to an ulp
        # the weight at x ~ +-1 has relative sensitivity ~N^2 to the node (1 ulp -> ~1e-13);
        # measured 1.6e-13 (scipy.special.roots_legendre: 1e-11)
        assert abs(W[i] / wr - 1) <= 1e-12


def test_laguerre_against_mpmath():
    N = 100
    x, W = gauss(LAGUERRE, N)
    for i in (0, 1, 50, 98, 99):
        with mpmath.workdps(50):
            r = _polished(lambda t: mpmath.laguerre(N, 0, t), x[i])
            # DLMF 3.5.20 Christoffel numbers, times e^{x} for the functions e^{-x/2} L_n
            wr = float(r * mpmath.exp(r) / ((N + 1) ** 2 * mpmath.laguerre(N + 1, 0, r) ** 2))
        # x - b_n cancels for small x: absolute error ~ a few eps (measured 5e-16 at x = 0.014)
        assert abs(x[i] - float(r)) <= 1e-14 * max(1.0, x[i])
        # weights: node error (few ulp) times d log W/dx ~ O(1..N): 1e-11 relative
        assert abs(W[i] / wr - 1) <= 1e-11


def test_bad_inputs():
    with pytest.raises(ValueError, match="N"):
        gauss(HERMITE, 0)
    with pytest.raises(ValueError, match="newton_steps"):
        gauss(HERMITE, 5, newton_steps=-1)
