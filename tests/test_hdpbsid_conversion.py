"""Exact ZOH c2d / d2c (augmented exponential and logarithm)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad_vec
from scipy.linalg import expm
from scipy.signal import cont2discrete

from hdpbsid import c2d, d2c
from hdpbsid.conversion import check_log_exists
from hdpbsid.systems import second_order


def random_system(rng, n, m, l, dt):
    """Random (A, B, C, D, K) with spectral radius of A*dt <= 1 (no aliasing: |Im| dt < pi)."""
    A = rng.standard_normal((n, n))
    A *= rng.uniform(0.05, 1.0) / (max(np.abs(np.linalg.eigvals(A)).max(), 1e-3) * dt)
    return (
        A,
        rng.standard_normal((n, m)),
        rng.standard_normal((l, n)),
        rng.standard_normal((l, m)),
        rng.standard_normal((n, l)),
    )


def test_c2d_matches_scipy_and_quadrature():
    A, B, C, D = second_order()
    K = np.array([[0.3], [-0.1]])
    dt = 0.05
    Ad, Bd, C2, D2, Kd = c2d(A, B, C, D, K, dt)
    ref = cont2discrete((A, np.hstack([B, K]), C, np.hstack([D, np.eye(1)])), dt, "zoh")
    # both are the same augmented exponential up to rounding
    np.testing.assert_allclose(Ad, ref[0], atol=1e-14)
    np.testing.assert_allclose(np.hstack([Bd, Kd]), ref[1], atol=1e-14)
    # independent oracle: int_0^dt e^{As} ds B by adaptive quadrature (tolerance 1e-13)
    integral = quad_vec(lambda s: expm(A * s), 0, dt, epsabs=1e-14, epsrel=1e-13)[0]
    np.testing.assert_allclose(Bd, integral @ B, atol=1e-13)
    np.testing.assert_array_equal(C2, C)
    np.testing.assert_array_equal(D2, D)


def test_round_trip_second_order():
    A, B, C, D = second_order()
    K = np.array([[0.3], [-0.1]])
    for dt in (1e-3, 0.05, 1.0):
        back = d2c(*c2d(A, B, C, D, K, dt), dt)
        for got, want in zip(back, (A, B, C, D, K), strict=True):
            # logm of a well-conditioned 4x4 matrix: ~1e-13 absolute on O(1) entries
            np.testing.assert_allclose(got, want, atol=1e-10)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 5),
    m=st.integers(0, 3),
    l=st.integers(1, 3),
    dt=st.floats(1e-3, 10.0),
)
def test_round_trip_random(seed, n, m, l, dt):
    rng = np.random.default_rng(seed)
    A, B, C, D, K = random_system(rng, n, m, l, dt)
    Ab, Bb, Cb, Db, Kb = d2c(*c2d(A, B, C, D, K, dt), dt)
    scale = max(1.0, np.abs(np.hstack([A, B, K])).max())
    # principal logm inverts expm when |Im(eig)| dt < pi (guaranteed by rho(A dt) <= 1);
    # error ~ eps * cond * ||[A, B, K]||: worst measured 2e-14 over 3000 random cases;
    # 1e-10 is the spec's round-trip tolerance
    np.testing.assert_allclose(Ab, A, atol=1e-10 * scale)
    np.testing.assert_allclose(Bb, B, atol=1e-10 * scale)
    np.testing.assert_allclose(Kb, K, atol=1e-10 * scale)
    np.testing.assert_array_equal(Cb, C)
    np.testing.assert_array_equal(Db, D)


def test_negative_real_eigenvalue_has_no_continuous_model():
    Ad = np.diag([-0.5, 0.3])
    B, C = np.ones((2, 1)), np.ones((1, 2))
    with pytest.raises(ValueError, match=r"negative real axis \(-0\.5\).*no real matrix logarithm"):
        d2c(Ad, B, C, None, None, 0.1)
    with pytest.raises(ValueError, match=r"eigenvalue at zero"):
        check_log_exists(np.diag([0.0, 0.5]))
    # a complex pair near (not on) the negative axis is fine
    r, th = 0.9, 3.0
    rot = r * np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    A = d2c(rot, B, C, None, None, 1.0)[0]
    # log of a rotation-scaling: eigenvalues log(r) +- i th exactly (rounding level)
    np.testing.assert_allclose(
        np.sort_complex(np.linalg.eigvals(A)), [np.log(r) - 3j, np.log(r) + 3j], atol=1e-12
    )
