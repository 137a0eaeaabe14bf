"""Operator matrices: multiplication by x, 2 p0 d/dx, d/dx (with explicit truncation)."""

import warnings

import numpy as np
import pytest
import sympy as sym
from generated_kernels import ALL, CHEBYSHEV_T, HERMITE, LAGUERRE, LEGENDRE

import slbasis
from slbasis.numeric import (
    Basis,
    KernelSpec,
    derivative_matrix,
    derivative_operator,
    evaluate,
    evaluate_derivative,
    integration_matrix,
    is_legendre,
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


def _shifted_legendre(shift: float) -> KernelSpec:
    """Legendre functions on ``(shift - 1, shift + 1)`` (``b_n = shift``) with the signs
    ``(-1)^n`` of the catalogue's (``A_n -> -A_n``), built by hand."""

    def jacobi(N: int) -> tuple[np.ndarray, np.ndarray]:
        d, o = LEGENDRE.jacobi(N)
        return d + shift, -o

    def bands(N: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return LEGENDRE.derivative_bands(N)  # 2 p0 d/dx is shift invariant

    return KernelSpec(
        "shifted legendre",
        (shift - 1.0, shift + 1.0),
        (1.0 - shift * shift, 2.0 * shift, -1.0),
        jacobi,
        lambda x: LEGENDRE.log_phi0(np.asarray(x) - shift),
        bands,
    )


def _exact_integration(N: int, x0: sym.Rational, shift: int, signs: np.ndarray) -> np.ndarray:
    """``G[k, n] = int phi_k(x) int_{x0}^x phi_n`` for the orthonormal Legendre functions
    ``phi_n = signs[n] sqrt((2n+1)/2) P_n(x - shift)`` on ``(shift - 1, shift + 1)``: the
    integrals of the rational polynomials ``P_n`` in exact arithmetic (sympy), times the
    normalisation (one rounding)."""
    x = sym.symbols("x")
    P = [sym.Poly(sym.legendre(n, x - shift), x) for n in range(N + 1)]
    G = np.zeros((N + 1, N))
    for n in range(N):
        F = P[n].integrate()
        F = F - F.eval(x0)
        for k in range(N + 1):
            prod = (P[k] * F).integrate()
            exact = prod.eval(shift + 1) - prod.eval(shift - 1)
            norm = signs[k] * signs[n] * np.sqrt((2 * k + 1) * (2 * n + 1)) / 2
            G[k, n] = norm * float(exact)
    return G


def test_legendre_integration_matrix_against_exact_arithmetic():
    N = 7
    for shift, kernel in ((0, LEGENDRE), (1, _shifted_legendre(1.0))):
        signs = np.sign(evaluate(kernel, N + 1, np.array([shift + 1.0]))[:, 0])  # phi_n(b)
        for x0 in (sym.Integer(shift - 1), sym.Integer(shift + 1), sym.Rational(1, 3) + shift):
            exact = _exact_integration(N, x0, shift, signs)
            G = integration_matrix(kernel, N, float(x0))
            assert G.shape == (N + 1, N)
            # O(1) entries from a few roundings (measured <= 1.2e-16)
            assert np.max(np.abs(G.toarray() - exact)) <= 1e-14
            sq = integration_matrix(kernel, N, float(x0), "square")
            assert np.array_equal(sq.toarray(), G.toarray()[:N])
    # from an end of the interval the matrix is exactly tridiagonal
    G = integration_matrix(LEGENDRE, 50).toarray()
    assert not np.any(np.triu(G, 2)) and not np.any(np.tril(G, -2))


def test_legendre_integration_inverts_the_solved_derivative():
    # the general path: d/dx solved from p0(J) (no closed form), on N + 1 functions
    N = 400
    D = derivative_matrix(LEGENDRE, N + 1)
    for x0 in (-1.0, 0.3):
        G = integration_matrix(LEGENDRE, N, x0).toarray()
        err = np.abs(D @ G - np.eye(N + 1, N)).max()
        # d/dx int_{x0}^x phi_n = phi_n; the solved D is exact up to ~eps cond(1 - J^2)
        # ~ eps N^2 relative to its largest entries (module docstring); measured 1.2e-13
        assert err <= 1e-11
        # ... and the antiderivatives vanish at x0: sums of N terms of size ~1, rounding
        at_x0 = evaluate(LEGENDRE, N + 1, np.array([x0]))[:, 0] @ G
        assert np.abs(at_x0).max() <= 1e-12


def test_is_legendre():
    for kernel in (
        LEGENDRE,
        slbasis.kernel("jacobi", alpha=0.0, beta=0.0),
        slbasis.kernel(slbasis.SturmLiouville(p0="1 - x**2", p1="-2*x", q0=0)),
        _shifted_legendre(3.0),
    ):
        assert is_legendre(kernel, 300)
    for kernel in (
        CHEBYSHEV_T,
        HERMITE,
        LAGUERRE,
        slbasis.kernel("jacobi", alpha=1e-6, beta=0.0),  # differs from Legendre by ~1e-6
        slbasis.kernel("gegenbauer", lam=0.6),
    ):
        assert not is_legendre(kernel, 300)


def test_integration_matrix_errors():
    with pytest.raises(ValueError, match="Legendre"):
        integration_matrix(CHEBYSHEV_T, 10)
    with pytest.raises(ValueError, match="x0"):
        integration_matrix(LEGENDRE, 10, 1.5)
    with pytest.raises(ValueError, match="shape"):
        integration_matrix(LEGENDRE, 10, None, "tall")
