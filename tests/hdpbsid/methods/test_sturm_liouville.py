"""PBSID in finite-interval Sturm-Liouville bases (``identify_sl``, ``identify_legendre``).

Measured when written: Legendre noise-free 7e-5..3e-4 (exact integration matrix);
Chebyshev-T noise-free 1e-4..4.5e-3 (integration matrix by quadrature: its truncation is
not confined to the last column, module docstring); Legendre SNR 20 dB 0.05-0.33 %;
chirp SNR 20 dB 0.1-0.14 %; x0 != 0 noise-free 0.4-1.7 % with the initial-state row
(the high-degree functions oscillate faster than the 0.01 s sampling near the window ends,
so a signal that is not zero there is projected less accurately), 4 % without.
"""

from __future__ import annotations

import numpy as np
import pytest
from basis_data import eig_error, make_data

import slbasis
from hdpbsid.bases import sl_family as sl
from hdpbsid.methods.sturm_liouville import (
    identify_chebyshev,
    identify_legendre,
    identify_sl,
    integration_matrix,
)


def test_legendre_integration_matrix_is_exact_and_tridiagonal() -> None:
    b = slbasis.basis("legendre", 12, (0.0, 4.0))
    G, how = integration_matrix(b, 0.0)
    assert how.startswith("exact")
    # int_{-1}^x P_n = (P_{n+1} - P_{n-1}) / (2n + 1): tridiagonal up to rounding
    assert np.abs(np.triu(G, 2)).max() < 1e-10 and np.abs(np.tril(G, -2)).max() < 1e-10
    # check against direct quadrature of phi_0 = 1/sqrt(T): int_0^t phi_0 = t / sqrt(T)
    # (Gauss rule of the basis: exact for products of functions in the span)
    tq, wq = b.quadrature()
    ref = b.eval(tq) @ (wq * tq / 2.0)  # 1/sqrt(4) = 1/2
    np.testing.assert_allclose(G[:, 0], ref, atol=1e-12)  # rounding only


def test_closed_form_integration_equals_the_general_path() -> None:
    # oracle: J from the solved derivative matrix on N + 1 functions (the general path)
    b = slbasis.basis("legendre", 300, (0.0, 7.5))
    for t0 in (0.0, 2.1):  # the window start (tridiagonal) and inside (dense row 0)
        G, how = integration_matrix(b, t0)
        assert how.startswith("exact (closed form")
        ref = sl._integration_exact(b, b.N, t0)[: b.N]
        # the solved derivative matrix is exact to ~eps N^2 relative (slbasis operators);
        # measured 7e-15 relative to the largest entry
        assert np.abs(G - ref).max() <= 1e-12 * np.abs(ref).max()


def test_banded_integrator_equals_the_dense_formula() -> None:
    rng = np.random.default_rng(3)
    b = slbasis.basis("legendre", 200, (0.0, 5.0))
    alpha, beta, gamma = 2.5, 1.0, 1.0
    W = rng.standard_normal((3, b.N))
    v = rng.standard_normal(b.N)
    for t0 in (0.0, 1.7):  # banded (tridiagonal G) and dense (row 0 filled) branches
        lag, solve_rows, _ = sl._integrator_lag(b, t0, alpha, beta, gamma)
        G = sl._integration_exact(b, b.N, t0)[: b.N]  # general path, dense
        J = G.T
        S = np.eye(b.N) + alpha * beta * J
        ref = alpha * gamma * np.linalg.solve(S.T, (W @ J).T).T  # W M, M = a g J S^-1
        # ||M|| <= 1 (a contraction), cond(S) <= 2e2 here: rounding (measured 2e-14)
        assert np.abs(lag.apply(W, 1) - ref).max() <= 1e-11 * np.abs(ref).max()
        w = solve_rows(v)
        # w J = v; cond(J) ~ 3e4 here, so the residual is ~eps cond(J) (measured 1.4e-12)
        assert np.abs(w @ J - v).max() <= 1e-10 * np.abs(v).max()


def test_identification_with_the_closed_form_equals_the_general_path(monkeypatch) -> None:
    data = make_data(10, snr=20)
    fast = identify_legendre(*data, order=2)
    assert fast.options["integration"].startswith("exact (closed form")
    monkeypatch.setattr(sl, "_legendre_integration", lambda *a: None)
    sl._integration.cache_clear()
    sl._integrator_lag.cache_clear()
    try:
        slow = identify_legendre(*data, order=2)
    finally:  # later tests must not get the general path's J from the caches
        sl._integration.cache_clear()
        sl._integrator_lag.cache_clear()
    assert slow.options["integration"].startswith("exact (from the derivative")
    ef, es = (np.sort_complex(np.linalg.eigvals(m.A)) for m in (fast, slow))
    # the two J differ by rounding (~1e-15 relative); the PBSID steps amplify it by their
    # conditioning (measured 3e-15 here, 1.5e-11 on a 4000-sample 4th-order record)
    assert np.abs(ef - es).max() <= 1e-8 * np.abs(es).max()


def test_noise_free_eigenvalues() -> None:
    for seed in range(2):
        # issue target 1e-3; measured <= 3e-4
        assert eig_error(identify_legendre(*make_data(seed), order=2)) < 1e-3
    assert eig_error(identify_legendre(*make_data(5, kind="chirp"), order=2)) < 1e-3


def test_chebyshev_and_custom_problem() -> None:
    data = make_data(1)
    # Chebyshev-T: integration matrix by quadrature (approximate truncation); measured
    # <= 4.5e-3 over 3 seeds, so 1e-2 rather than the 1e-3 of the exact Legendre case
    m = identify_chebyshev(*data, order=2)
    assert eig_error(m) < 1e-2
    assert m.options["integration"].startswith("quadrature") and m.options["window_padding"] > 0
    # a custom problem: Legendre's p0, p1 given to SturmLiouville gives the exact path
    prob = slbasis.SturmLiouville(p0="1 - x**2", p1="-2*x", q0=0)
    m = identify_sl(*data, order=2, family=prob)
    assert eig_error(m) < 1e-3 and m.options["integration"].startswith("exact")


def test_snr20_and_chirp() -> None:
    errs = [eig_error(identify_legendre(*make_data(10 + s, snr=20), order=2)) for s in range(5)]
    # the HD-PBSID target (2 %) applied to this basis; measured <= 0.33 %
    assert max(errs) < 0.02
    for s in range(2):
        m = identify_legendre(*make_data(20 + s, snr=20, kind="chirp"), order=2)
        assert eig_error(m) < 0.02


def test_initial_state_row() -> None:
    for s in range(2):
        data = make_data(30 + s, x0=[1.0, -1.0])
        on = eig_error(identify_legendre(*data, order=2))
        off = eig_error(identify_legendre(*data, order=2, boundary=False))
        # measured 0.4-1.7 % with the row (window-end resolution, module docstring) and
        # ~4 % without: the row must help, and keep the error below 3 %
        assert on < 0.03
        assert on < off


def test_nonuniform_times() -> None:
    uni = [eig_error(identify_legendre(*make_data(10 + s, snr=20), order=2)) for s in range(12)]
    jit = [
        eig_error(identify_legendre(*make_data(10 + s, snr=20, jitter=0.4), order=2))
        for s in range(12)
    ]
    # issue target 1.5x (mean over the same 12 seeds; 16 seeds measured: ratio 1.11)
    assert np.mean(jit) <= 1.5 * np.mean(uni)


def test_defaults_reported_and_errors() -> None:
    t, u, y = make_data(1)
    m = identify_legendre(t, u, y)
    assert m.n == 2
    for key in ("N", "N_rule", "alpha", "alpha_rule", "p", "integration", "bandwidth"):
        assert key in m.options
    with pytest.raises(ValueError, match="below the data bandwidth"):
        identify_legendre(t, u, y, order=2, N=40)
    with pytest.raises(ValueError, match="infinite interval"):
        identify_sl(t, u, y, order=2, family="hermite")
    with pytest.raises(TypeError, match="family is fixed"):
        identify_legendre(t, u, y, family="jacobi")
    with pytest.raises(TypeError, match="family/family_params"):
        identify_sl(t, u, y, family="jacobi", family_params={"a": 1})
