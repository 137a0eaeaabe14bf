"""Shared nuisance factorisations of the block core (hdpbsid.core.blocks): the past-window
AIC from one QR, eliminators shared between BlockPseudo objects on one lag.

Oracles: the AIC from plain least squares with the pseudo rows appended as regressors
(numpy lstsq, one fit per window), and the same core run on a fresh lag object (no
shared state).
"""

from __future__ import annotations

import numpy as np
import pytest

from hdpbsid.bases.basis_domain import SolveLag
from hdpbsid.core.blocks import BlockLag, BlockPseudo, pbsid_core_blocks, select_past_window_blocks

NCOLS = 300
FLOOR = 1e-12  # select_past_window_blocks' default rel_floor


def _lag(n: int = NCOLS) -> BlockLag:
    """One block, lag = a solve with a well-conditioned tridiagonal matrix (every column
    valid, as the Hermite integrator)."""
    Mi = 2 * np.eye(n) + 0.5 * np.eye(n, k=1) - 0.5 * np.eye(n, k=-1)
    return BlockLag([SolveLag(lambda W: np.linalg.solve(Mi.T, W.T).T)], [n])


def _data(seed: int = 0):
    rng = np.random.default_rng(seed)
    U, Y = rng.standard_normal((1, NCOLS)), rng.standard_normal((1, NCOLS))
    Y += 0.5 * np.roll(U, 1)  # some dependence so the fits are not trivial
    return U, Y


def _aic_oracle(U, Y, P, lag, p_max, feedthrough):
    """AIC per window by plain least squares on [data lags; pseudo lags] (rows scaled
    to unit RMS, the nuisance count = the numerical rank of the stacked pseudo rows)."""
    Ys = Y / np.sqrt(np.mean(Y**2, axis=1))[:, None]
    Pn = P / np.sqrt(np.mean(P**2, axis=1))[:, None]
    Z = np.vstack([U, Y])
    crit = np.full(p_max, np.inf)
    for p in range(1, p_max + 1):
        data = [U] if feedthrough else []
        data += [lag.apply(Z, j) for j in range(1, p + 1)]
        S = [lag.apply(Pn, j) for j in ([0] if feedthrough else []) + list(range(1, p + 1))]
        X = np.vstack(data + S)
        theta = np.linalg.lstsq(X.T, Ys.T, rcond=None)[0]
        E = Ys - theta.T @ X
        sigma = E @ E.T / NCOLS + FLOOR * np.eye(Y.shape[0])
        rank = np.linalg.matrix_rank(np.vstack(S))
        d = (U.shape[0] if feedthrough else 0) + p * Z.shape[0]
        crit[p - 1] = NCOLS * np.linalg.slogdet(sigma)[1] + 2.0 * Y.shape[0] * (d + rank)
    return crit


@pytest.mark.parametrize("feedthrough", [False, True])
@pytest.mark.parametrize("deficient", [False, True])
def test_window_aic_equals_plain_least_squares(feedthrough: bool, deficient: bool) -> None:
    """One QR for every window (full-rank pseudo rows) or the per-window compressed fits
    (rank-deficient rows: a repeated row) give the criterion of the naive regression."""
    U, Y = _data(1)
    rng = np.random.default_rng(2)
    P = rng.standard_normal((3, NCOLS))
    if deficient:
        P[2] = P[0]
    lag = _lag()
    _, crit = select_past_window_blocks(
        U, Y, 4, 1, lag, BlockPseudo(lag, [P]), feedthrough=feedthrough
    )
    ref = _aic_oracle(U, Y, P, lag, 4, feedthrough)
    # the same least-squares problems solved two ways (cond ~ 1e2): AIC ~ 1e2..1e3,
    # rounding differences far below 1e-9 relative
    np.testing.assert_allclose(crit, ref, rtol=1e-9)


def test_shared_state_does_not_change_results() -> None:
    """A core run on a lag whose pseudo store was filled by other requests (another
    window first, another BlockPseudo object) equals the run on a fresh lag bit for bit,
    and changing the rows in place is seen (the store is checked against contents)."""
    U, Y = _data(3)
    P = np.random.default_rng(4).standard_normal((3, NCOLS))
    used = _lag()
    BlockPseudo(used, [P]).eliminator([1], np.ones(NCOLS, dtype=bool))  # lag 1 first
    select_past_window_blocks(U, Y, 4, 2, used, BlockPseudo(used, [P]))
    a = pbsid_core_blocks(U, Y, 3, used, BlockPseudo(used, [P]), order=2, regularize="gcv")
    fresh = _lag()
    b = pbsid_core_blocks(U, Y, 3, fresh, BlockPseudo(fresh, [P]), order=2, regularize="gcv")
    assert np.array_equal(a.A, b.A) and np.array_equal(a.K, b.K)
    assert np.array_equal(a.noise_covariance, b.noise_covariance)
    P[1] = np.random.default_rng(5).standard_normal(NCOLS)  # same object, new contents
    c = pbsid_core_blocks(U, Y, 3, used, BlockPseudo(used, [P]), order=2, regularize="gcv")
    fresh = _lag()
    d = pbsid_core_blocks(U, Y, 3, fresh, BlockPseudo(fresh, [P]), order=2, regularize="gcv")
    assert np.array_equal(c.A, d.A) and not np.array_equal(c.A, a.A)
