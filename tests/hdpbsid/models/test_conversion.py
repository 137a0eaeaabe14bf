"""Exact ZOH c2d / d2c (augmented exponential and logarithm)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad_vec
from scipy.linalg import expm
from scipy.signal import cont2discrete

from hdpbsid import c2d, d2c
from hdpbsid.models.conversion import check_log_exists, sampled_steps
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


def _logm_oracle(Ad, G):
    """The first block row of scipy's generic logm of the augmented matrix."""
    from scipy.linalg import logm

    n, k = Ad.shape[0], G.shape[1]
    M = np.eye(n + k)
    M[:n, :n], M[:n, n:] = Ad, G
    return np.real(logm(M))[:n]


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 6),
    k=st.integers(1, 4),
    integrator=st.booleans(),
)
def test_logarithm_by_eigenvalues_is_the_generic_logm(seed, n, k, integrator):
    """d2c's eigenvalue route (log and phi(x) = log(x)/(x - 1) of Ad) against scipy's
    logm of the whole augmented matrix, an independent algorithm; an integrator (a unit
    eigenvalue of Ad, where phi is summed as its series) included."""
    rng = np.random.default_rng(seed)
    dt = 0.1
    A = random_system(rng, n, 1, 1, dt)[0]
    if integrator:
        A[:, 0] = 0.0  # a zero eigenvalue of A: Ad has the eigenvalue 1 exactly
    Ad = expm(A * dt)
    G = rng.standard_normal((n, k))
    from hdpbsid.models.conversion import MAX_LOG_CONDITION

    cond = np.linalg.cond(np.linalg.eig(Ad)[1])
    Ab, Gb = (d2c(Ad, G, np.ones((1, n)), None, None, dt)[i] * dt for i in (0, 1))
    ref = _logm_oracle(Ad, G)
    scale = max(1.0, np.abs(ref).max())
    # both are exact up to rounding: the eigenvalue route's ~cond(V) eps (at most
    # MAX_LOG_CONDITION eps = 2e-12 when taken), logm's ~1e-14; 1e-11 covers both
    tol = 1e-11 if cond <= MAX_LOG_CONDITION else 1e-12
    np.testing.assert_allclose(Ab, ref[:, :n], atol=tol * scale)
    np.testing.assert_allclose(Gb, ref[:, n:], atol=tol * scale)


def test_nearly_defective_ad_takes_the_generic_logarithm():
    # a Jordan block perturbed by 1e-14: eigenvectors nearly parallel, cond(V) ~ 1e7
    Ad = np.array([[0.9, 1.0], [1e-14, 0.9]])
    from hdpbsid.models.conversion import MAX_LOG_CONDITION

    assert np.linalg.cond(np.linalg.eig(Ad)[1]) > MAX_LOG_CONDITION  # the premise
    G = np.array([[0.0], [1.0]])
    A, B = d2c(Ad, G, np.ones((1, 2)), None, None, 1.0)[:2]
    ref = _logm_oracle(Ad, G)
    # the generic logm's own rounding on O(1) entries
    np.testing.assert_allclose(np.hstack([A, B]), ref, atol=1e-13)
    np.testing.assert_allclose(expm(A), Ad, atol=1e-12)  # and it inverts the exponential


def test_checked_eigenvalue_route_beyond_the_a_priori_bound(monkeypatch):
    """A nearly defective Ad whose eigenvalue route is still exact (cond(V) ~ 1e5): kept by
    the backward check without the generic logarithm, and equal to it; a Jordan-like Ad
    (cond(V) ~ 1e7) fails the check and still gets the generic one."""
    import hdpbsid.models.conversion as cv

    # two eigenvalues 0.9 and 0.9 + 2e-5: eigenvectors nearly parallel, cond(V) ~ 1e5
    Ad = np.array([[0.9, 1.0], [0.0, 0.90002]])
    cond = np.linalg.cond(np.linalg.eig(Ad)[1])
    assert cv.MAX_LOG_CONDITION < cond < cv.CHECKED_LOG_CONDITION  # the premise
    G = np.array([[0.3], [1.0]])
    ref = _logm_oracle(Ad, G)

    def no_logm(*_a, **_k):
        raise AssertionError("the generic logarithm was not needed")

    monkeypatch.setattr(cv, "logm", no_logm)
    A, B = d2c(Ad, G, np.ones((1, 2)), None, None, 1.0)[:2]
    # the eigenvalue route's rounding ~cond(V) eps = 2e-11 on O(1) entries; logm's ~1e-14
    np.testing.assert_allclose(np.hstack([A, B]), ref, atol=1e-9)
    np.testing.assert_allclose(expm(A), Ad, atol=1e-11)  # what the check itself asks
    # the perturbed Jordan block of the test above: the check fails, logm is asked for
    with pytest.raises(AssertionError, match="not needed"):
        d2c(np.array([[0.9, 1.0], [1e-14, 0.9]]), G, np.ones((1, 2)), None, None, 1.0)


def _steps_by_expm(A, B, K, h, hold):
    """The oracle: the augmented exponential of every step, one scipy ``expm`` each."""
    n, m, lk = A.shape[0], B.shape[1], K.shape[1]
    mu = 2 * m if hold == "foh" else m
    out = []
    for hk in h:
        M = np.zeros((n + mu + lk, n + mu + lk))
        M[:n, :n], M[:n, n : n + m], M[:n, n + mu :] = A * hk, B * hk, K * hk
        if hold == "foh":
            M[n : n + m, n + m : n + 2 * m] = np.eye(m)
        E = expm(M)
        out.append((E[:n, :n], E[:n, n : n + m], E[:n, n + m : n + 2 * m], E[:n, n + mu :]))
    return [np.array(x) for x in zip(*out, strict=True)]


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(1, 5),
    hold=st.sampled_from(["zoh", "foh"]),
    h_scale=st.sampled_from([1e-4, 1e-2, 1.0]),
)
def test_sampled_steps_match_the_augmented_exponential(seed, n, hold, h_scale):
    """Many distinct steps (non-uniform times) take the eigenvalue route with the
    ``phi`` functions; every block equals the augmented exponential of its step."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n)) * 3.0
    B, K = rng.standard_normal((n, 2)), rng.standard_normal((n, 1))
    h = h_scale * rng.uniform(0.2, 1.0, 30)
    got = sampled_steps(A, B, K, h, hold)
    want = _steps_by_expm(A, B, K, h, hold)
    for g, w in zip(got, want, strict=True):
        if hold == "zoh" and g is None:
            continue
        # the eigenvalue route's rounding ~ cond(V) eps (cond(V) <= 1e4 or the route is
        # not taken), relative to the blocks' size: 1e-9 leaves a factor 10 over 1e4 eps
        np.testing.assert_allclose(g, w, rtol=0, atol=1e-9 * max(1.0, np.abs(w).max()))


def test_sampled_steps_of_a_defective_matrix_fall_back_to_the_exponential():
    # a Jordan block has no eigenvector basis: the augmented exponential is taken, the
    # same arithmetic as the oracle
    A = np.array([[-1.0, 1.0], [0.0, -1.0]])
    B, K = np.array([[0.0], [1.0]]), np.array([[1.0], [0.0]])
    h = np.linspace(0.01, 0.3, 20)
    got = sampled_steps(A, B, K, h, "foh")
    want = _steps_by_expm(A, B, K, h, "foh")
    for g, w in zip(got, want, strict=True):
        # the batched and the per-step expm run the same algorithm: rounding only
        np.testing.assert_allclose(g, w, rtol=1e-13, atol=1e-15)
