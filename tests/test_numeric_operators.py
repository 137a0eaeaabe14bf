"""Operator matrices: multiplication by x, 2 p0 d/dx, d/dx (with explicit truncation)."""

import warnings

import numpy as np
import pytest
from generated_kernels import ALL, CHEBYSHEV_T, HERMITE, LAGUERRE, LEGENDRE

from slbasis.numeric import (
    Basis,
    derivative_matrix,
    derivative_operator,
    evaluate,
    evaluate_derivative,
    multiplication_matrix,
)


def _chirp(t, tc=20.0, width=3.0):
    return np.exp(-(((t - tc) / width) ** 2)) * np.sin(1.5 * t + 0.04 * (t - tc) ** 2)


def _chirp_dt(t, tc=20.0, width=3.0):
    g = np.exp(-(((t - tc) / width) ** 2))
    ph = 1.5 * t + 0.04 * (t - tc) ** 2
    return g * (-2 * (t - tc) / width**2 * np.sin(ph) + (1.5 + 0.08 * (t - tc)) * np.cos(ph))


def _coefficients(B, f, M=700):
    """First B.N + 1 coefficients by the Gauss rule of an M-term basis with the same map
    (exact for the span; f decays like a Gaussian, so aliasing is ~1e-15)."""
    big = Basis(B.kernel, M, B.t_span, scale=B.scale, centre=B.centre)
    tq, W = big.quadrature()
    keep = (tq > -50) & (tq < 90)  # the chirp is < 1e-100 outside: avoid pointless work
    P = Basis(B.kernel, B.N + 1, B.t_span, scale=B.scale, centre=B.centre).eval(tq[keep])
    return P @ (W[keep] * f(tq[keep]))


def test_hermite_derivative_of_chirp():
    N = 400
    B = Basis(HERMITE, N, (0.0, 40.0))
    c = _coefficients(B, _chirp)
    cd = _coefficients(B, _chirp_dt)
    D = B.derivative_matrix("rectangular")
    assert D.shape == (N + 1, N)
    # accuracy target 1e-8; coefficients are exact to ~1e-14 and D has norm ~ scale sqrt(2N)
    assert np.max(np.abs(D @ c[:N] - cd)) <= 1e-8
    # the square cut is wrong in its last row by exactly scale sqrt(N/2) c_N
    Dsq = B.derivative_matrix("square")
    miss = (Dsq @ c[:N])[-1] - cd[N - 1]
    assert abs(miss + B.scale * np.sqrt(N / 2) * c[N]) <= 1e-12  # rounding
    # integration in the basis: least squares with the rectangular operator recovers the
    # antiderivative's coefficients (D has full column rank; cond ~ sqrt(N))
    ci = np.linalg.lstsq(D.toarray(), cd, rcond=None)[0]
    assert np.max(np.abs(ci - c[:N])) <= 1e-8


def test_multiplication_matrix_matches_pointwise_product():
    x = np.linspace(-0.9, 0.9, 13)
    for kernel in ALL.values():
        xs = x if np.isfinite(kernel.interval[0]) and np.isfinite(kernel.interval[1]) else 5 * x
        xs = np.abs(xs) if kernel is LAGUERRE else xs
        P = evaluate(kernel, 31, xs)
        J = multiplication_matrix(kernel, 30, "rectangular")
        assert J.shape == (31, 30)
        # x phi_n = sum_m J[m, n] phi_m: rounding of O(10) sized terms
        assert np.max(np.abs(J.T @ P - xs * P[:30])) <= 1e-12


def test_two_p0_derivative_matches_evaluation():
    x = np.linspace(0.1, 0.8, 9)
    for kernel in ALL.values():
        P, dP = evaluate_derivative(kernel, 41, x)
        c0, c1, c2 = kernel.p0
        D2 = derivative_operator(kernel, 40)
        assert D2.shape == (41, 40)
        lhs = 2 * (c0 + c1 * x + c2 * x * x) * dP[:40]
        # evaluate_derivative uses the same bands: this checks the matrix assembly
        assert np.max(np.abs(D2.T @ P - lhs)) <= 1e-10


def test_laguerre_and_legendre_d_dx_exact_structure():
    N = 300
    D = derivative_matrix(LAGUERRE, N)
    assert D.shape == (N, N)  # the image of the first N functions stays in their span
    exact = -np.triu(np.ones((N, N)), 1) - 0.5 * np.eye(N)  # l_n' = -l_n/2 - sum_{k<n} l_k
    # solved with p0(J) of cond ~ (4N)^2: measured 2e-13
    assert np.max(np.abs(D - exact)) <= 1e-11
    D = derivative_matrix(LEGENDRE, N)
    k = np.arange(N)
    m, n = np.meshgrid(k, k, indexing="ij")
    exact = np.where((n > m) & ((n - m) % 2 == 1), np.sqrt((2.0 * n + 1) * (2 * m + 1)), 0.0)
    # cond(1 - J^2) ~ N^2: error ~ eps N^2 max|entry| ~ 1e-9 (rounding level of ||D|| ~ N^2)
    assert np.max(np.abs(D - exact)) <= 1e-8 * np.max(exact)


def test_laguerre_d_dx_against_pointwise_derivative():
    x = np.linspace(0.2, 30, 17)
    P, dP = evaluate_derivative(LAGUERRE, 25, x)
    D = derivative_matrix(LAGUERRE, 25)
    assert np.max(np.abs(D.T @ P - dP)) <= 1e-12  # O(1) values, exact matrix


def test_non_l2_derivative_warns():
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        derivative_matrix(CHEBYSHEV_T, 20)
    assert any("not well represented" in str(w.message) for w in rec)


def test_basis_operators_in_time_units():
    B = Basis(HERMITE, 30, (2.0, 12.0))
    T = B.multiplication_matrix("rectangular")
    t = np.linspace(4.0, 10.0, 7)
    P = Basis(HERMITE, 31, B.t_span, scale=B.scale, centre=B.centre).eval(t)
    assert np.max(np.abs(T.T @ P - t * P[:30])) <= 1e-12 * np.max(np.abs(t * P))  # rounding


def test_bad_shape():
    with pytest.raises(ValueError, match="shape"):
        derivative_matrix(HERMITE, 5, "tall")
    with pytest.raises(ValueError, match="N"):
        multiplication_matrix(HERMITE, 0)
