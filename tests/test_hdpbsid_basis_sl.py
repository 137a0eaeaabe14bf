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
from test_hdpbsid_basis_common import eig_error, make_data

import slbasis
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
