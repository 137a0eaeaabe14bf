"""The past-window criterion from the lagged Gram matrix (hdpbsid.core.lag_gram).

Oracles: the lagged regressors stacked explicitly (the Gram matrix), one least-squares
fit per window (the criterion and its minimiser), the same fits in 50-digit arithmetic
with mpmath (the error bound), and the QR search (``gram=False``).
"""

import mpmath
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hdpbsid.core.lag_gram import (
    criterion_error_bounds,
    nested_residual_covariances,
    shift_gram,
)
from hdpbsid.core.varx import _window_search_by_gram, select_past_window


def _lagged(Z, first, lags):
    """Rows ``(i, a)``: ``Z[a, k - i]`` for ``k = first..N-1``, stacked explicitly."""
    return np.vstack([Z[:, first - i : Z.shape[1] - i] for i in range(lags + 1)])


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    d=st.integers(1, 4),
    lags=st.integers(0, 7),
    extra=st.integers(0, 5),
    n=st.integers(1, 40),
)
def test_shift_gram_is_the_gram_matrix_of_the_lagged_samples(seed, d, lags, extra, n):
    rng = np.random.default_rng(seed)
    first = lags + extra
    Z = rng.standard_normal((d, first + n))
    X = _lagged(Z, first, lags)
    # the same sums of at most n + 2 lags products, in another order: rounding only
    np.testing.assert_allclose(shift_gram(Z, first, lags), X @ X.T, rtol=1e-12, atol=1e-12 * n)


def test_shift_gram_rejects_a_window_before_the_record():
    with pytest.raises(ValueError, match="lags <= first"):
        shift_gram(np.ones((1, 10)), 2, 3)


def _varx_record(rng, N, m, l, smooth):
    """A random stable VARX(2) record; ``smooth`` > 0 low-passes the input (collinear lags)."""
    u = rng.standard_normal((m, N))
    for _ in range(smooth):
        u = 0.5 * (u + np.roll(u, 1, axis=1))
    a = rng.uniform(-0.4, 0.4, size=(2, l, l)) / l  # ||a_1|| + ||a_2|| <= 0.8: stable
    b = rng.standard_normal((2, l, m))
    y = np.zeros((l, N))
    e = rng.standard_normal((l, N))
    for k in range(2, N):
        y[:, k] = a[0] @ y[:, k - 1] + a[1] @ y[:, k - 2] + b[0] @ u[:, k - 1]
        y[:, k] += b[1] @ u[:, k - 2] + e[:, k]
    return u, y


def _oracle(U, Y, p_max, feedthrough=False, rel_floor=1e-12):
    """The AIC of every window by its own least-squares fit (outputs scaled to unit RMS
    on the columns valid for p_max, as select_past_window does)."""
    l = Y.shape[0]
    cols = np.arange(p_max, U.shape[1])
    Ys = Y / np.sqrt(np.mean(Y[:, cols] ** 2, axis=1))[:, None]
    Z = np.vstack([U, Ys])
    crit = np.empty(p_max)
    for p in range(1, p_max + 1):
        rows = ([U[:, cols]] if feedthrough else []) + [Z[:, cols - j] for j in range(1, p + 1)]
        Phi = np.vstack(rows)
        theta = np.linalg.lstsq(Phi.T, Ys[:, cols].T, rcond=None)[0]
        E = Ys[:, cols].T - Phi.T @ theta
        sigma = E.T @ E / cols.size + rel_floor * np.eye(l)
        crit[p - 1] = cols.size * np.linalg.slogdet(sigma)[1] + 2 * l * Phi.shape[0]
    return crit


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    m=st.integers(1, 2),
    l=st.integers(1, 2),
    p_max=st.integers(2, 12),
    feedthrough=st.booleans(),
    smooth=st.integers(0, 3),
)
def test_certified_window_is_the_per_window_refit_choice(seed, m, l, p_max, feedthrough, smooth):
    rng = np.random.default_rng(seed)
    U, Y = _varx_record(rng, 400, m, l, smooth)
    oracle = _oracle(U, Y, p_max, feedthrough)
    d0 = m if feedthrough else 0
    got = _window_search_by_gram(U, Y, p_max, 1, d0, "aic", 1e-12, None)
    if got is not None:  # certified: the exact criterion's minimiser
        assert got[0] == int(np.argmin(oracle)) + 1
        # the same criterion, rounding on O(N) values
        np.testing.assert_allclose(got[1], oracle, rtol=1e-9, atol=1e-7)
    # whichever factorisation decided, select_past_window keeps the QR search's choice
    p, _ = select_past_window(U, Y, p_max, feedthrough=feedthrough, growth=None)
    p_qr, _ = select_past_window(U, Y, p_max, feedthrough=feedthrough, growth=None, gram=False)
    assert p == p_qr


def test_a_noisy_record_is_certified_and_a_noise_free_one_is_left_to_the_qr():
    rng = np.random.default_rng(3)
    U, Y = _varx_record(rng, 2000, 1, 1, 1)
    got = _window_search_by_gram(U, Y, 30, 1, 0, "aic", 1e-12, 3.0)
    assert got is not None  # unit noise on a VARX(2): AIC's margins are O(1), the bounds 1e-6
    p, crit = select_past_window(U, Y, 30, gram=False)
    assert got[0] == p and np.array_equal(np.isfinite(got[1]), np.isfinite(crit))
    # noise-free: every window >= 2 fits to rounding, Sigma sits at its floor
    u = rng.standard_normal((1, 600))
    y = np.zeros((1, 600))
    for k in range(2, 600):
        y[0, k] = 0.5 * y[0, k - 1] - 0.2 * y[0, k - 2] + u[0, k - 1]
    assert _window_search_by_gram(u, y, 10, 1, 0, "aic", 1e-12, None) is None
    assert select_past_window(u, y, 10, growth=None)[0] == 2  # the smallest exact window


def _exact_sigmas(G, l):
    """Every nested Schur complement of the mpmath matrix ``G`` (outputs last)."""
    with mpmath.workdps(50):
        K = G.rows
        k = K - l
        out = []
        for q in range(k + 1):
            Gyy = G[k:, k:]
            if q:
                Gxx, Gxy = G[:q, :q], G[:q, k:]
                S = Gyy - Gxy.T * mpmath.lu_solve(Gxx, Gxy)
            else:
                S = Gyy
            out.append(S)
        return out


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), smooth=st.integers(0, 4), lags=st.integers(1, 4))
def test_error_bound_holds_against_50_digit_arithmetic(seed, smooth, lags):
    rng = np.random.default_rng(seed)
    U, Y = _varx_record(rng, 80, 1, 1, smooth)
    Z = np.vstack([U, Y])
    first = lags
    M = shift_gram(Z, first, lags)
    idx = list(range(2, 2 * (lags + 1))) + [1]
    # the exact Gram matrix of the same floating-point samples, scaled exactly as the code
    X = _lagged(Z, first, lags)[idx]
    with mpmath.workdps(50):
        Gx = mpmath.matrix(X.tolist())
        Gexact = Gx * Gx.T
    s = np.sqrt(np.diag(M)[idx])
    G = M[np.ix_(idx, idx)] / s[:, None] / s[None, :]
    R = np.linalg.cholesky(G).T
    floor = 1e-12
    sigma = nested_residual_covariances(R, 1) + floor
    rho = np.sqrt(np.tile(np.sum(Z * Z, axis=1), lags + 1)[idx] / np.diag(M)[idx])
    bound = criterion_error_bounds(R, 1, X.shape[1] + 2 * lags, rho, sigma[:, 0, 0])
    assert bound is not None
    with mpmath.workdps(50):
        Ghat = mpmath.matrix(G.shape[0], G.shape[1])
        for i in range(G.shape[0]):
            for j in range(G.shape[1]):
                Ghat[i, j] = Gexact[i, j] / (mpmath.mpf(s[i]) * mpmath.mpf(s[j]))
        exact = _exact_sigmas(Ghat, 1)
        for q, S in enumerate(exact):
            got = float(np.log(sigma[q, 0, 0]))
            want = float(mpmath.log(S[0, 0] + floor))
            assert abs(got - want) <= bound[q]


def _explicit_varx(Z, p, m, feedthrough):
    """The sample-shift VARX of window ``p`` built explicitly: regressors ``z_{k-p} ...
    z_{k-1}`` (oldest first) and ``u_k`` with feedthrough, targets ``y_k``, on ``k = p..N-1``;
    numpy's least squares and each coefficient's standard error ``sqrt(Sigma_jj
    [G_xx^{-1}]_ii)``."""
    N = Z.shape[1]
    rows = [Z[:, p - j : N - j] for j in range(p, 0, -1)]
    if feedthrough:
        rows.append(Z[:m, p:])
    Phi, Y = np.vstack(rows), Z[m:, p:]
    theta = np.linalg.lstsq(Phi.T, Y.T, rcond=None)[0]
    E = Y.T - Phi.T @ theta
    se = np.sqrt(np.outer(np.diag(np.linalg.inv(Phi @ Phi.T)), np.diag(E.T @ E) / E.shape[0]))
    return Phi, Y, theta, se


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    m=st.integers(1, 2),
    l=st.integers(1, 2),
    p=st.integers(1, 10),
    feedthrough=st.booleans(),
    smooth=st.integers(0, 3),
)
def test_regression_factor_gives_the_least_squares_fit_within_its_resolution(
    seed, m, l, p, feedthrough, smooth
):
    from hdpbsid.core.lag_gram import COEFFICIENT_RESOLUTION, regression_factor

    rng = np.random.default_rng(seed)
    U, Y = _varx_record(rng, 400, m, l, smooth)
    Z = np.vstack([U, Y])
    R = regression_factor(Z, p, m, feedthrough)
    Phi, Yt, theta, se = _explicit_varx(Z, p, m, feedthrough)
    if R is None:
        return  # left to the QR factorisation: nothing to check here
    G = np.vstack([Phi, Yt]) @ np.vstack([Phi, Yt]).T
    # R^T R is the Gram matrix of [Phi; Y] (rounding of 400-term sums)
    np.testing.assert_allclose(R.T @ R, G, rtol=1e-10, atol=1e-10 * np.abs(G).max())
    k = Phi.shape[0]
    got = np.linalg.solve(R[:k, :k], R[:k, k:])
    # the certificate: every coefficient within its resolution of the least-squares one
    # (twice, for the rounding of the oracle's own QR)
    assert np.all(np.abs(got - theta) <= 2 * COEFFICIENT_RESOLUTION * se)


def test_regression_factor_certifies_a_noisy_record_and_not_a_noise_free_one():
    from hdpbsid.core.lag_gram import regression_factor

    rng = np.random.default_rng(3)
    U, Y = _varx_record(rng, 2000, 1, 1, 1)
    # unit noise on a VARX(2): standard errors O(1/sqrt(N)), the rounding far below
    assert regression_factor(np.vstack([U, Y]), 8, 1, False) is not None
    u = rng.standard_normal((1, 600))
    y = np.zeros((1, 600))
    for k in range(2, 600):
        y[0, k] = 0.5 * y[0, k - 1] - 0.2 * y[0, k - 2] + u[0, k - 1]
    # noise-free: the residual is rounding, no standard error to hide the Gram's in
    assert regression_factor(np.vstack([u, y]), 4, 1, False) is None


def test_varx_takes_the_certified_factor_and_keeps_its_fit():
    """The sample-shift VARX with the Gram route: the same coefficients (within the
    resolution) and residuals as the explicit least squares, and the factor it keeps for
    the state sequence is ``Zp^T``'s."""
    from hdpbsid.core.varx import varx

    rng = np.random.default_rng(11)
    U, Y = _varx_record(rng, 3000, 1, 2, 2)
    vx = varx(U, Y, 6, regularize=False)
    Phi, Yt, theta, se = _explicit_varx(np.vstack([U, Y]), 6, 1, False)
    assert np.all(np.abs(vx.coef - theta.T) <= 2e-3 * se.T)  # COEFFICIENT_RESOLUTION, twice
    G = vx.Zp @ vx.Zp.T
    np.testing.assert_allclose(vx.zp_factor.T @ vx.zp_factor, G, rtol=1e-10, atol=1e-10 * G.max())
