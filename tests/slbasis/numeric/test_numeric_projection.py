"""Projection / reconstruction, streaming, white noise and Wiener covariance."""

import tracemalloc

import numpy as np
import pytest
from generated_kernels import HERMITE, LEGENDRE
from hypothesis import given, settings
from hypothesis import strategies as st

from slbasis.numeric import Basis, sample_weights


def _chirp(t, tc=20.0, width=4.0):
    return np.exp(-(((t - tc) / width) ** 2)) * np.sin(2.0 * t + 0.05 * (t - tc) ** 2)


def test_band_limited_round_trip():
    B = Basis(HERMITE, 400, (0.0, 40.0))
    rng = np.random.default_rng(3)
    c = np.zeros(400)
    c[:60] = rng.standard_normal(60)  # the first 60 functions live well inside the window
    t = np.linspace(0.0, 40.0, 8001)
    y = B.reconstruct(c, t)
    c2 = B.project(t, y)
    # integrand decays to ~1e-30 at the ends: trapezoid is spectrally accurate (E-M)
    assert np.max(np.abs(c2 - c)) <= 1e-12
    # round trip in signal space of a smooth windowed chirp, band-limited in effect
    y = _chirp(t)
    assert np.max(np.abs(B.reconstruct(B.project(t, y), t) - y)) <= 1e-10  # tail ~1e-13


def test_multichannel_and_chunking():
    B = Basis(HERMITE, 120, (0.0, 40.0))
    t = np.linspace(0.0, 40.0, 3001)
    Y = np.column_stack([_chirp(t), _chirp(t, 15.0, 3.0), np.zeros_like(t)])
    C = B.project(t, Y)
    assert C.shape == (120, 3)
    # same sums in a different order: rounding only
    np.testing.assert_allclose(B.project(t, Y, chunk=17), C, rtol=0, atol=1e-14)
    np.testing.assert_allclose(B.project(t, Y[:, 1]), C[:, 1], rtol=0, atol=1e-15)
    assert B.reconstruct(C, t).shape == (3001, 3)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), jitter=st.floats(0.0, 0.45))
def test_non_uniform_samples(seed, jitter):
    """Jittered sample times: trapezoid error O(h^2), lstsq exact for the span."""
    rng = np.random.default_rng(seed)
    B = Basis(LEGENDRE, 20, (0.0, 1.0))
    n = 2001
    h = 1.0 / (n - 1)
    t = np.linspace(0.0, 1.0, n) + rng.uniform(-jitter, jitter, n) * h
    t[0], t[-1] = 0.0, 1.0
    c = rng.standard_normal(20)
    y = B.reconstruct(c, t)
    # composite trapezoid error per coefficient <= sum_i h_i^3/12 max|f''| on cell i
    # ~<= h_max^2/12 int |f''| dt, f = y phi_n; f'' measured on a fine grid, x2 for the
    # max-vs-average on a cell
    tf = np.linspace(0.0, 1.0, 20001)
    F = B.eval(tf) * B.reconstruct(c, tf)
    F2 = np.gradient(np.gradient(F, tf, axis=1), tf, axis=1)
    bound = 2 * np.max(np.diff(t)) ** 2 / 12 * np.max(np.abs(F2).sum(axis=1) * (tf[1] - tf[0]))
    assert np.max(np.abs(B.project(t, y) - c)) <= bound
    # weighted least squares reproduces a signal in the span up to rounding (cond(G) ~ 1)
    assert np.max(np.abs(B.project(t, y, method="lstsq") - c)) <= 1e-10


def test_gregory_rule():
    t = np.linspace(0.0, 1.0, 101)
    # exact for cubics (order h^4 with exact end corrections for degree <= 3)
    assert abs(sample_weights(t, "gregory") @ t**3 - 0.25) <= 1e-14
    assert abs(sample_weights(t, "trapezoid") @ t**3 - 0.25) > 1e-6  # plain trapezoid is not


def test_streaming_memory():
    """2e5 samples x 500 functions: the full matrix would be 800 MB."""
    B = Basis(HERMITE, 500, (0.0, 100.0))
    t = np.linspace(0.0, 100.0, 200_000)
    y = np.sin(t)
    tracemalloc.start()
    try:
        B.project(t, y)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # default chunk keeps the block <= 64 MB; plus O(Ns) vectors (~10 MB)
    assert peak <= 120 * 2**20


def test_white_noise_covariance():
    """Discrete white noise (variance s2, step dt) -> coefficients with covariance
    s2 * Phi V^2 Phi^T ~= s2 dt I (V = trapezoid weights, Gram ~ I)."""
    N, R = 12, 4000
    T, dt, s2 = 10.0, 0.01, 4.0
    t = np.arange(0.0, T + dt / 2, dt)
    B = Basis(LEGENDRE, N, (0.0, T))
    rng = np.random.default_rng(123)
    E = np.sqrt(s2) * rng.standard_normal((t.size, R))
    C = B.project(t, E)  # (N, R), all realisations in one streaming pass
    S = C @ C.T / R / (s2 * dt)  # normalised sample covariance (known zero mean)
    # sampling error: sd(S_ii) = sqrt(2/R) = 0.022, sd(S_ij) = sqrt(1/R) = 0.016; the
    # max over 78 entries of |z| stays below 4.5 sd with probability > 0.999. The
    # deterministic bias (end weights dt/2, Gram - I) is < 1e-2 / R-independent: add 0.01
    diag_tol = 4.5 * np.sqrt(2 / R) + 0.01
    off_tol = 4.5 * np.sqrt(1 / R) + 0.01
    assert np.max(np.abs(np.diag(S) - 1)) <= diag_tol
    assert np.max(np.abs(S - np.diag(np.diag(S)))) <= off_tol


def test_wiener_covariance():
    """W(t) (W(t0) = 0): E[c c^T] = int int min(s, t) phi_m(s) phi_n(t) ds dt."""
    N, R = 8, 4000
    T, dt = 5.0, 0.01
    t = np.arange(0.0, T + dt / 2, dt)
    B = Basis(LEGENDRE, N, (0.0, T))
    rng = np.random.default_rng(99)
    steps = np.sqrt(dt) * rng.standard_normal((t.size - 1, R))
    W = np.vstack([np.zeros((1, R)), np.cumsum(steps, axis=0)])
    C = B.project(t, W)
    S = C @ C.T / R
    # exact expectation for the sampled process, E[W_j W_k] = min(t_j, t_k), then the
    # same sample weights: K = Phi V M V Phi^T
    P = B.eval(t) * sample_weights(t)
    K = P @ np.minimum.outer(t, t) @ P.T
    # continuum double integral vs this discrete version differ by O(dt) relative
    Kc = _wiener_kernel_continuum(B)
    assert np.max(np.abs(K - Kc)) <= 5e-3 * np.max(np.abs(Kc))
    # sampling error of a product moment of Gaussians: var = (K_mm K_nn + K_mn^2) / R;
    # 4.5 sd over 36 entries
    sd = np.sqrt((np.outer(np.diag(K), np.diag(K)) + K**2) / R)
    assert np.all(np.abs(S - K) <= 4.5 * sd)


def _wiener_kernel_continuum(B):
    """int int min(s,t) phi_m(s) phi_n(t) ds dt for a Legendre basis, exactly (Gauss rules)."""
    x, w = np.polynomial.legendre.leggauss(40)
    T = B.t_span[1]
    s = (x + 1) * T / 2
    ws = w * T / 2
    # min(s,t) = int_0^T 1[u<s] 1[u<t] du, so K = int_0^T g(u) g(u)^T du with
    # g_m(u) = int_u^T phi_m(s) ds (a polynomial): exact with Gauss rules
    G = np.empty((B.N, s.size))
    for j, u in enumerate(s):
        su = u + (x + 1) * (T - u) / 2
        G[:, j] = B.eval(su) @ (w * (T - u) / 2)
    return (G * ws) @ G.T


def test_bad_inputs():
    B = Basis(HERMITE, 10, (0.0, 1.0))
    t = np.linspace(0, 1, 11)
    with pytest.raises(ValueError, match="t"):
        B.project(t[::-1], np.zeros(11))
    with pytest.raises(ValueError, match="t"):
        B.project(np.where(t == 0.5, np.nan, t), np.zeros(11))
    with pytest.raises(ValueError, match="t"):
        B.project(np.linspace(0, 2, 11), np.zeros(11))  # outside the window
    with pytest.raises(ValueError, match="y"):
        B.project(t, np.zeros(10))
    with pytest.raises(ValueError, match="y"):
        B.project(t, np.full(11, np.inf))
    with pytest.raises(ValueError, match="method"):
        B.project(t, np.zeros(11), method="magic")
    with pytest.raises(ValueError, match="c"):
        B.reconstruct(np.zeros(9), t)
    with pytest.raises(ValueError, match="rule"):
        sample_weights(t, "simpson")
