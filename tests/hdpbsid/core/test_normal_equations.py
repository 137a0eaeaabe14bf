"""Least-squares residuals from the normal equations (hdpbsid.core.normal_equations).

Oracles: the residuals of an orthogonal factorisation (numpy's QR) on well-conditioned
problems, and exact arithmetic (mpmath at 50 digits) on a nearly collinear one, where the
normal equations alone would lose the digits and the fallback must keep them.
"""

from __future__ import annotations

import mpmath
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hdpbsid.core.normal_equations import lstsq_residuals


def _qr_residuals(X: np.ndarray, y: np.ndarray) -> np.ndarray:
    Q = np.linalg.qr(X)[0]
    return y - Q @ (Q.T @ y)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    rows=st.integers(20, 400),
    cols=st.integers(1, 12),
    spread=st.floats(0.0, 3.0),
)
def test_matches_an_orthogonal_factorisation(seed, rows, cols, spread):
    rng = np.random.default_rng(seed)
    # columns scaled over up to three decades: cond(X^T X) up to ~1e6 plus the sampling's
    X = rng.standard_normal((rows, cols)) * 10.0 ** rng.uniform(0, spread, cols)
    y = rng.standard_normal((rows, 2))
    r = lstsq_residuals(X, y)
    ref = _qr_residuals(X, y)
    # the normal equations' residual error is about eps cond(X^T X) |y|; cond <= ~1e7 here
    # (three decades of column scale squared, times the sampling's): 1e-8 |y| bounds it
    np.testing.assert_allclose(r, ref, atol=1e-8 * np.linalg.norm(y))
    # the defining property: residuals orthogonal to every column (relative to its norm)
    # orthogonality to the same relative accuracy
    assert np.all(np.abs(X.T @ r) <= 1e-8 * np.linalg.norm(X, axis=0)[:, None] * np.linalg.norm(y))


def test_a_predictable_signal_keeps_its_tiny_residual():
    """Lags of a sum of two sinusoids predict it exactly: the residual share is ~0 only
    if the nearly singular problem is solved by the factorisation of ``X``, which the
    normal equations (squared condition number) cannot resolve."""
    k = np.arange(2000)
    x = np.sin(0.1 * k) + 0.5 * np.sin(0.37 * k + 1.0)
    lags = 8
    X = np.stack([x[lags - i : x.size - i] for i in range(1, lags + 1)], axis=1)
    target = x[lags:]
    r = lstsq_residuals(X, target)
    share = float(np.sum(r**2) / np.sum(target**2))
    # exact arithmetic: the signal obeys a 4-term recurrence, so its residual is 0; the
    # oracle's residual at 50 digits confirms it for these samples
    mpmath.mp.dps = 50
    w1, w2 = mpmath.mpf("0.1"), mpmath.mpf("0.37")

    def exact(j):
        return mpmath.sin(w1 * j) + mpmath.mpf("0.5") * mpmath.sin(w2 * j + 1)

    a1, a2 = 2 * mpmath.cos(w1), 2 * mpmath.cos(w2)
    # x_k = (a1 + a2) x_{k-1} - (2 + a1 a2) x_{k-2} + (a1 + a2) x_{k-3} - x_{k-4}
    c = [a1 + a2, -(2 + a1 * a2), a1 + a2, -1]

    def gap(j):
        return abs(exact(j) - sum(ci * exact(j - i - 1) for i, ci in enumerate(c)))

    worst = max(gap(j) for j in (10, 500, 1999))
    assert worst < mpmath.mpf(10) ** -40
    # the sqrt(eps) floor of the direct-term screen is 1.5e-8: the computed share must be
    # far below it (the Gram matrix is singular to rounding here: its Cholesky
    # factorisation breaks down, and the factorisation of X resolves the share to ~eps^2)
    assert share < 1e-20
