"""The Jacobi family (``identify_jacobi``) on the second-order benchmark of known truth."""

from __future__ import annotations

import numpy as np
import pytest
from basis_data import eig_error, make_data

from hdpbsid.methods.jacobi import identify_jacobi
from hdpbsid.methods.registry import get_method
from hdpbsid.methods.sturm_liouville import identify_legendre


@pytest.mark.parametrize(("a", "b"), [(1.0, 1.0), (2.0, 0.0), (-0.5, -0.5)])
def test_noise_free_eigenvalues(a: float, b: float) -> None:
    # data exact for the FOH input: the error is the method's own (VARX truncation, J by
    # quadrature), measured 7e-5 for a, b >= 0 and 1.7e-3 with the padded window of
    # end-singular functions; 1e-2 is six times the worst, a wrong model is off by O(1)
    t, u, y = make_data(0)[:3]
    model = identify_jacobi(t, u, y, 2, a=a, b=b)
    assert model.options["method"] == "jacobi"
    assert eig_error(model) < 1e-2


@pytest.mark.parametrize("seed", range(3))
def test_noisy_record_order_and_eigenvalues(seed: int) -> None:
    # 30 dB: the order is selected (largest log-gap); errors measured 1e-4..8e-4 over
    # 4 seeds, 1e-2 leaves more than ten times that for the noise of another draw
    t, u, y = make_data(seed, snr=30)[:3]
    model = identify_jacobi(t, u, y)
    assert model.n == 2
    assert eig_error(model) < 1e-2


def test_zero_exponents_are_legendre() -> None:
    # P_n^(0,0) = P_n (DLMF 18.7.9): same basis, closed-form J, same model to the bit
    t, u, y = make_data(1, snr=40)[:3]
    jac, leg = identify_jacobi(t, u, y, 2, a=0, b=0), identify_legendre(t, u, y, 2)
    assert np.array_equal(jac.A, leg.A)
    assert jac.options["integration"].startswith("exact (closed form")


def test_registered_and_bad_input() -> None:
    assert get_method("jacobi") is identify_jacobi
    t, u, y = make_data(0)[:3]
    with pytest.raises(ValueError, match="a must be > -1"):
        identify_jacobi(t, u, y, 2, a=-1.0)
    with pytest.raises(TypeError, match="b must be a real number"):
        identify_jacobi(t, u, y, 2, b="1")
    with pytest.raises(TypeError, match="family is Jacobi's"):
        identify_jacobi(t, u, y, 2, family="legendre")
