"""Basis: default time maps, orthonormality under random affine maps, validation."""

import numpy as np
import pytest
from generated_kernels import ALL, HERMITE, LAGUERRE, LEGENDRE
from hypothesis import given, settings
from hypothesis import strategies as st

from slbasis.numeric import Basis, gauss


def test_default_maps():
    B = Basis(HERMITE, 400, (10.0, 50.0))
    xN = gauss(HERMITE, 400, newton_steps=0)[0][-1]
    assert B.centre == pytest.approx(30.0, abs=1e-12)
    assert B.scale * 20.0 == pytest.approx(0.9 * xN, rel=1e-12)  # 90 % of the node span
    B = Basis(LAGUERRE, 100, (5.0, 25.0))
    assert B.tmap.to_x(5.0) == 0.0  # window start -> 0
    B = Basis(LEGENDRE, 10, (5.0, 25.0))
    assert B.tmap.to_x(np.array([5.0, 25.0])) == pytest.approx([-1.0, 1.0], abs=1e-15)
    assert Basis(LAGUERRE, 10, (0.0, 1.0), scale=2.0).scale == 2.0  # pole a = 1


@settings(max_examples=20, deadline=None)
@given(
    name=st.sampled_from(sorted(ALL)),
    N=st.integers(1, 120),
    t0=st.floats(-1e3, 1e3),
    length=st.floats(1e-2, 1e3),
    stretch=st.floats(0.3, 3.0),
)
def test_orthonormal_in_time_under_random_maps(name, N, t0, length, stretch):
    B0 = Basis(ALL[name], N, (t0, t0 + length))
    B = Basis(ALL[name], N, (t0, t0 + length), scale=B0.scale * stretch)
    t, W = B.quadrature()
    P = B.eval(t)
    # Gauss rule exact on the span: rounding ~N eps, plus the float64 time map itself:
    # t = centre + x/scale and back loses dx ~ eps |t| scale, times |phi_n'| <~ N^2
    dx = np.finfo(float).eps * (np.max(np.abs(t)) + abs(B.centre)) * B.scale
    assert np.max(np.abs((P * W) @ P.T - np.eye(N))) <= 1e-11 + 2 * N**2 * dx


def test_eval_includes_sqrt_scale():
    B = Basis(HERMITE, 3, (0.0, 4.0), scale=4.0, centre=2.0)
    t = np.array([2.0])
    assert B.eval(t)[0, 0] == pytest.approx(2.0 * np.pi**-0.25, rel=1e-15)


def test_bad_inputs():
    with pytest.raises(ValueError, match="N"):
        Basis(HERMITE, 0, (0.0, 1.0))
    with pytest.raises(TypeError, match="N"):
        Basis(HERMITE, 2.5, (0.0, 1.0))
    with pytest.raises(ValueError, match="t_span"):
        Basis(HERMITE, 5, (1.0, 0.0))
    with pytest.raises(ValueError, match="t_span"):
        Basis(HERMITE, 5, (0.0, np.inf))
    with pytest.raises(ValueError, match="t_span"):
        Basis(HERMITE, 5, (0.0, 1.0, 2.0))
    with pytest.raises(ValueError, match="scale"):
        Basis(HERMITE, 5, (0.0, 1.0), scale=-1.0)
    with pytest.raises(ValueError, match="centre"):
        Basis(HERMITE, 5, (0.0, 1.0), centre=np.nan)
    with pytest.raises(TypeError, match="kernel"):
        Basis(object(), 5, (0.0, 1.0))
    B = Basis(LEGENDRE, 5, (0.0, 1.0))
    with pytest.raises(ValueError, match="t"):
        B.eval(np.array([0.5, 1.5]))  # outside the interval (-1, 1) of x
    with pytest.raises(ValueError, match="t"):
        B.eval(np.array([[0.5]]))
    with pytest.raises(ValueError, match="shape"):
        B.derivative_matrix("round")


def test_record_end_mapped_past_the_interval_by_rounding() -> None:
    # t = 3999 of arange(4000.) maps to x = 1 + 2.2e-16 on [-1, 1]: moved onto the end,
    # not refused (it made every Legendre identification of 4000 samples fail)
    t = np.arange(4000.0)
    B = Basis(LEGENDRE, 50, (t[0], t[-1]))
    P = B.eval(t)
    assert np.all(np.isfinite(P))
    # the last column is phi_n(1) = sqrt(scale) sqrt(n + 1/2) exactly (Legendre at x = 1)
    expected = np.sqrt(B.scale) * np.sqrt(np.arange(50) + 0.5)
    np.testing.assert_allclose(P[:, -1], expected, rtol=1e-12)  # rounding of the recurrence
    with pytest.raises(ValueError, match="outside the basis interval"):
        B.eval(np.array([4000.0]))
