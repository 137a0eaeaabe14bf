"""VARX step: lag operators, least squares, ridge/GCV, past-window selection."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hdpbsid.core.block_lag import BlockLag
from hdpbsid.core.varx import (
    MatrixLag,
    SampleShift,
    is_strictly_causal,
    past_blocks,
    ridge_gcv,
    select_past_window,
    varx,
)
from hdpbsid.systems import pbsid_example, simulate_pbsid_closed_loop


def true_markov(p):
    """Predictor Markov parameters Xi_j = C (A - K C)^{j-1} [B - K D, K], j = 1..p."""
    A, B, C, D, K = pbsid_example()
    At, Bt = A - K @ C, np.hstack([B - K @ D, K])
    return np.stack([C @ np.linalg.matrix_power(At, j - 1) @ Bt for j in range(1, p + 1)])


def test_sample_shift_blocks_match_slicing():
    rng = np.random.default_rng(0)
    Z = rng.standard_normal((3, 20))
    Zp, valid = past_blocks(Z, 4, SampleShift())
    cols = np.flatnonzero(valid)
    assert cols.tolist() == list(range(4, 20))
    # toolbox dordvarx: Z((i-1)m+1:im, :) = z(:, i:N+i-p-1), oldest block first
    ref = np.vstack([Z[:, i : 20 + i - 4] for i in range(4)])
    np.testing.assert_array_equal(Zp[:, cols], ref)


def test_matrix_lag_with_shift_matrix_equals_zero_padded_sample_shift():
    """MatrixLag(M) with M the down-shift matrix is the sample shift with zero pre-history."""
    rng = np.random.default_rng(1)
    U, Y = rng.standard_normal((1, 300)), rng.standard_normal((2, 300))
    p = 5
    M = np.eye(300, k=1)  # (W M)[:, k] = W[:, k-1], zero for k = 0
    a = varx(U, Y, p, lag=MatrixLag(M))
    pad = np.zeros((1, p)), np.zeros((2, p))
    b = varx(np.hstack([pad[0], U]), np.hstack([pad[1], Y]), p, lag=SampleShift())
    assert a.columns.size == b.columns.size == 300
    # identical least-squares problems: agreement to rounding (1e-12 on O(1) coefficients)
    np.testing.assert_allclose(a.Xi, b.Xi, atol=1e-12)


def test_matrix_lag_validity_propagates_through_sparsity():
    M = np.eye(6, k=1)
    lag = MatrixLag(M)
    valid = np.array([True, False, True, True, True, True])
    # column c of W M^2 reads column c-2: invalid input column 1 spoils output column 3
    assert lag.valid_columns(valid, 2).tolist() == [True, True, True, False, True, True]
    with pytest.raises(ValueError, match="M must be a square matrix"):
        MatrixLag(np.ones((2, 3)))


def test_varx_recovers_predictor_markov_parameters():
    d = simulate_pbsid_closed_loop(np.random.default_rng(2), N=40_000)
    res = varx(d["u"].T, d["y"].T, p=10)
    Xi = true_markov(10)
    rel = np.linalg.norm(res.Xi - Xi) / np.linalg.norm(Xi)
    # variance-limited: measured 6-8 % at N=4e3, 1.9 % at 4e4, 0.6 % at 4e5 (N^-1/2);
    # truncation bias |eig(A-KC)|^10 ~ 1e-3.  5 % leaves > 2x margin at N = 4e4.
    assert rel < 0.05
    # the coef layout is the toolbox's [Xi_p, ..., Xi_1]
    np.testing.assert_array_equal(res.coef[:, -4:], res.Xi[0])


def test_varx_exact_on_noise_free_arx():
    """A finite ARX y_k = a y_{k-1} + b u_{k-1} is recovered to rounding."""
    rng = np.random.default_rng(3)
    u = rng.standard_normal(500)
    y = np.zeros(500)
    for k in range(1, 500):
        y[k] = 0.8 * y[k - 1] + 0.5 * u[k - 1]
    res = varx(u[None], y[None], p=1)
    # exact model, well-conditioned 2-column regression: rounding level
    np.testing.assert_allclose(res.Xi[0], [[0.5, 0.8]], atol=1e-12)
    with pytest.raises(ValueError, match="regressors .* but only .* usable columns"):
        varx(u[None, :40], y[None, :40], p=20)


def _gcv_brute(Phi, Y, lam):
    """GCV from the explicit hat matrix H = Phi^T (Phi Phi^T + lam^2 I)^{-1} Phi."""
    d, N = Phi.shape
    H = Phi.T @ np.linalg.solve(Phi @ Phi.T + lam**2 * np.eye(d), Phi)
    R = Y - (H @ Y.T).T
    return np.sum(R**2) / np.trace(np.eye(N) - H) ** 2


def test_ridge_gcv_against_explicit_hat_matrix():
    rng = np.random.default_rng(4)
    Phi = rng.standard_normal((8, 60)) * np.logspace(0, -3, 8)[:, None]
    Y = rng.standard_normal((2, 8)) @ Phi + 0.1 * rng.standard_normal((2, 60))
    theta, lam, g = ridge_gcv(Phi, Y)
    # the SVD formula and the explicit hat matrix are the same function: rounding agreement
    assert g == pytest.approx(_gcv_brute(Phi, Y, lam), rel=1e-9)
    grid = np.exp(np.linspace(np.log(lam) - 3, np.log(lam) + 3, 201))
    brute = np.array([_gcv_brute(Phi, Y, x) for x in grid])
    # the optimiser's minimum is not above the best grid point (up to its xatol=1e-4 in log)
    assert g <= brute.min() * (1 + 1e-6)
    # Tikhonov normal equations: theta (Phi Phi^T + lam^2 I) = Y Phi^T
    lhs = theta @ (Phi @ Phi.T + lam**2 * np.eye(8))
    np.testing.assert_allclose(lhs, Y @ Phi.T, rtol=1e-9, atol=1e-9)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), pmax=st.integers(2, 8))
def test_nested_qr_aic_equals_direct_least_squares(seed, pmax):
    """select_past_window's one-QR residuals equal separate fits for every p."""
    rng = np.random.default_rng(seed)
    N, m, l = 200, 1, 2
    U, Y = rng.standard_normal((m, N)), rng.standard_normal((l, N))
    Y[1] += 0.5 * np.r_[0.0, U[0, :-1]]
    p_best, crit = select_past_window(U, Y, pmax, rel_floor=0.0, growth=None)
    cols = np.arange(pmax, N)
    Ys = Y / np.sqrt(np.mean(Y[:, cols] ** 2, axis=1))[:, None]
    Z = np.vstack([U, Ys])
    for p in range(1, pmax + 1):
        Phi = np.vstack([Z[:, cols - j] for j in range(1, p + 1)])
        theta = np.linalg.lstsq(Phi.T, Ys[:, cols].T, rcond=None)[0]
        R = Ys[:, cols].T - Phi.T @ theta
        aic = cols.size * np.linalg.slogdet(R.T @ R / cols.size)[1] + 2 * l * p * (m + l)
        # same least-squares problem, QR vs lstsq: rounding on O(N) criterion values
        assert crit[p - 1] == pytest.approx(aic, rel=1e-9, abs=1e-7)
    assert p_best == int(np.argmin(crit)) + 1


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), widths=st.lists(st.integers(1, 7), min_size=1, max_size=4))
def test_growing_qr_residuals_equal_direct_least_squares(seed, widths):
    """The QR grown block by block gives the residual of every leading column set."""
    from hdpbsid.core.varx import _GrowingQR

    rng = np.random.default_rng(seed)
    N, l = 120, 2
    A, Y = rng.standard_normal((N, sum(widths))), rng.standard_normal((N, l))
    qr, c = _GrowingQR(Y), 0
    for w in widths:
        qr.add(A[:, c : c + w])
        c += w
    for k in range(c + 1):
        theta = np.linalg.lstsq(A[:, :k], Y, rcond=None)[0] if k else np.zeros((0, l))
        R = Y - A[:, :k] @ theta
        # the same least-squares problem by QR and by lstsq: rounding of O(N) entries
        np.testing.assert_allclose(qr.residual_gram(k), R.T @ R, rtol=1e-9, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    first=st.integers(1, 6),
    extra=st.integers(0, 5),
    d0=st.sampled_from([0, 1]),
    contiguous=st.booleans(),
)
def test_lag_block_is_the_lagged_samples_scaled(seed, first, extra, d0, contiguous):
    """The search's regressor block: column ``k``'s lag ``j`` is ``Z[:, k - j]``, the
    current input first with feedthrough, every column scaled to unit RMS -- built
    here from the samples directly, on consecutive and on scattered columns."""
    from hdpbsid.core.varx import _lag_block

    rng = np.random.default_rng(seed)
    m, l, N = 1, 2, 60
    Z = rng.standard_normal((m + l, N))
    last = first + extra
    cols = (
        np.arange(last, N)
        if contiguous
        else np.sort(rng.choice(np.arange(last, N), 25, replace=False))
    )
    block = _lag_block(Z[:m], Z, cols, SampleShift(), first, last, d0)
    lead = [Z[:m, cols]] if (d0 and first == 1) else []
    raw = np.vstack(lead + [Z[:, cols - j] for j in range(first, last + 1)]).T
    # copies of the same samples divided by their RMS, whose mean of squares numpy may
    # sum in another order for another array shape: a few units in the last place
    np.testing.assert_allclose(block, raw / np.sqrt(np.mean(raw**2, axis=0)), rtol=1e-14)


def _long_memory_record(lag_peak: int, dead_time: bool, N: int = 3000, seed: int = 0):
    """An ARX output with a strong output coefficient at ``lag_peak``, or with the input
    acting ``lag_peak`` samples late (a dead time): AIC wants p >= lag_peak."""
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(N)
    y = np.zeros(N)
    e = 0.1 * rng.standard_normal(N)
    for k in range(lag_peak, N):
        if dead_time:
            y[k] = 0.5 * y[k - 1] + u[k - lag_peak] + e[k]
        else:
            y[k] = 0.5 * y[k - 1] - 0.3 * y[k - lag_peak] + u[k - 1] + e[k]
    return u[None, :], y[None, :]


@pytest.mark.parametrize("lag_peak, dead_time", [(3, False), (30, False), (30, True)])
def test_growing_window_search_settles_where_the_full_search_does(lag_peak, dead_time):
    from hdpbsid.core.varx import WINDOW_SEARCH_GROWTH, search_is_complete

    U, Y = _long_memory_record(lag_peak, dead_time)
    p_max = 120
    p_full, full = select_past_window(U, Y, p_max, growth=None)
    p, crit = select_past_window(U, Y, p_max)
    # the first block (p_max / 3 = 40 lags) holds every peak; 3 x 30 = 90 needs a second
    assert p == p_full == lag_peak
    searched = np.isfinite(crit)
    assert searched.sum() >= WINDOW_SEARCH_GROWTH * p and search_is_complete(crit, p_max)
    assert searched.sum() < p_max  # the short-memory record did not need every lag
    # the values searched are the full search's: the same reflectors, rounding only
    np.testing.assert_allclose(crit[searched], full[searched], rtol=1e-10)
    assert not search_is_complete(np.r_[crit[:p], np.full(p_max - p, np.inf)], p_max)


def test_ridge_gcv_keeps_exact_data_exact():
    rng = np.random.default_rng(5)
    Phi = rng.standard_normal((4, 50))
    theta_true = rng.standard_normal((2, 4))
    theta, lam, _ = ridge_gcv(Phi, theta_true @ Phi)
    # GCV -> 0 as lam -> 0 on consistent data, so lam = 0 (plain LS) must win
    assert lam == 0.0
    np.testing.assert_allclose(theta, theta_true, atol=1e-12)  # well-conditioned 4x4 LS


def test_past_window_policy_is_the_function_and_says_why():
    """select_past_window is the default PastWindowPolicy's choice, which carries its
    range and the reason it reports."""
    from hdpbsid.core.varx import PastWindowChoice, PastWindowPolicy, choose_past_window

    U, Y = _long_memory_record(3, False)
    p, crit = select_past_window(U, Y, 60, p_min=2, criterion="bic")
    choice = choose_past_window(U, Y, 60, p_min=2, policy=PastWindowPolicy(criterion="bic"))
    assert isinstance(choice, PastWindowChoice)
    assert choice.p == p and np.array_equal(choice.criterion_values, crit)
    assert (choice.p_min, choice.p_max) == (2, 60)
    assert choice.reason("bounds").startswith("min BIC of the VARX fit over p in [2, 60] (bounds)")
    assert f"searched up to p = {choice.searched}" in choice.reason()


def test_past_window_policy_schedule_and_checks():
    from hdpbsid.core.varx import PastWindowPolicy

    policy = PastWindowPolicy()
    assert policy.first_target(1, 120) == 40 and policy.first_target(50, 120) == 50
    assert policy.next_target(40, 30, 120) == 90  # three times the best window
    assert policy.next_target(90, 30, 120) is None  # settled
    assert PastWindowPolicy(growth=None).first_target(1, 120) == 120
    with pytest.raises(ValueError, match="criterion"):
        PastWindowPolicy(criterion="hqc")
    with pytest.raises(ValueError, match="growth"):
        PastWindowPolicy(growth=1.0)


def _depends_on_own_or_later_column(lag, n: int, rng: np.random.Generator) -> bool:
    """Oracle of strict causality: perturbing columns ``k..n-1`` of ``W`` changes
    column ``k`` of the lagged ``W`` for some ``k``."""
    W = rng.standard_normal((2, n))
    base = lag.apply(W, 1)
    for k in range(n):
        V = W.copy()
        V[:, k:] += rng.standard_normal((2, n - k))
        if not np.allclose(lag.apply(V, 1)[:, k], base[:, k], rtol=0, atol=1e-12):
            return True
    return False


@settings(max_examples=30, deadline=None)
@given(
    n=st.integers(2, 7),
    seed=st.integers(0, 2**31 - 1),
    causal=st.booleans(),
)
def test_strict_causality_is_what_the_lag_does(n, seed, causal):
    """``is_strictly_causal`` says True exactly when no lagged column depends on its own
    or a later column (the perturbation oracle), for matrices with a random pattern and
    for blocks of them; the sample shift is strictly causal."""
    rng = np.random.default_rng(seed)
    M = rng.standard_normal((n, n)) * (rng.uniform(size=(n, n)) < 0.6)
    if causal:
        M = np.triu(M, 1)
    lag = MatrixLag(M)
    # atol 1e-12: the lagged columns are sums of a few O(1) products, exact to ~1e-15
    assert is_strictly_causal(lag) == (not _depends_on_own_or_later_column(lag, n, rng))
    blocks = BlockLag([lag, SampleShift()], [n, 3])
    assert is_strictly_causal(blocks) == is_strictly_causal(lag)
    assert is_strictly_causal(SampleShift())
    assert not _depends_on_own_or_later_column(SampleShift(), n, rng)
