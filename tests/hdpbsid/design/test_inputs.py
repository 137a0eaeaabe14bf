"""Input designs against analytic truths: PRBS period and two-valued autocorrelation,
multisine lines, Parseval, crest factors, chirp zero crossings, random-binary spectrum,
orthogonality of multi-input designs."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hdpbsid.design import inputs


def circular_autocorrelation(x: np.ndarray) -> np.ndarray:
    """sum_k x_k x_{k+tau} for every lag, by brute force (independent of any FFT)."""
    return np.array([np.dot(x, np.roll(x, -tau)) for tau in range(x.size)])


# -- PRBS ------------------------------------------------------------------------------
@pytest.mark.parametrize("order", range(2, 11))
def test_prbs_period_and_two_valued_autocorrelation(order: int) -> None:
    d = inputs.prbs(order, 0.01, periods=2)
    n = 2**order - 1
    assert d.period == n
    s = d.u[:n, 0]
    np.testing.assert_array_equal(d.u[n:, 0], s)  # periodic with period N
    r = circular_autocorrelation(s)
    # maximum length <=> R(0) = N and R(tau) = -1 otherwise (Golomb); R(tau) = N at a lag
    # 0 < tau < N would mean a shorter period, so this also proves the period is minimal
    assert r[0] == n
    np.testing.assert_array_equal(r[1:], -1.0)
    assert s.sum() == 1.0  # one more +1 than -1


def test_prbs_long_register_has_two_valued_autocorrelation() -> None:
    order = 16
    d = inputs.prbs(order, 1.0)
    n = 2**order - 1
    s = d.u[:, 0]
    r = np.fft.irfft(np.abs(np.fft.rfft(s)) ** 2, n)  # circular autocorrelation
    assert abs(r[0] - n) < 1e-6 * n  # FFT rounding on a sum of N unit terms
    np.testing.assert_allclose(r[1:], -1.0, atol=1e-6 * n)


def test_prbs_clock_and_amplitude() -> None:
    d = inputs.prbs(4, 0.1, clock=3, amplitude=0.2)
    assert d.period == 45
    np.testing.assert_array_equal(np.abs(d.u), 0.2)
    bits = d.u[::3, 0]
    np.testing.assert_array_equal(np.repeat(bits, 3), d.u[:, 0])
    np.testing.assert_allclose(d.crest_factor, 1.0)


def test_shifted_prbs_channels_are_nearly_uncorrelated() -> None:
    order, m = 7, 3
    d = inputs.prbs(order, 0.01, channels=m)
    n = 2**order - 1
    for i in range(m):
        for j in range(i + 1, m):
            r = np.array([np.dot(d.u[:, i], np.roll(d.u[:, j], -tau)) for tau in range(n)])
            # a cyclic shift of an m-sequence: cross-correlation N at one lag, -1 at all others
            assert np.sum(r == n) == 1
            np.testing.assert_array_equal(r[r != n], -1.0)


# -- multisines ------------------------------------------------------------------------
def test_multisine_power_exactly_on_chosen_lines() -> None:
    n, dt, band = 2000, 0.005, (0.5, 20.0)
    d = inputs.multisine(n, dt, band, periods=3, amplitude=2.0)
    df = 1.0 / (n * dt)  # 0.1 Hz
    expected = np.arange(5, 201)  # 0.5 Hz ... 20 Hz on the 0.1 Hz grid
    np.testing.assert_array_equal(d.lines[0], expected)
    p = d.power[:, 0]
    on = np.zeros(p.size, bool)
    on[expected] = True
    # rounding of an inverse and a forward FFT of O(1) values: ~1e-30 relative power
    assert p[~on].max() < 1e-24 * p[on].max()
    np.testing.assert_allclose(p[on], p[on].mean(), rtol=1e-10)  # flat amplitude spectrum
    np.testing.assert_allclose(d.freqs[expected], expected * df)
    np.testing.assert_allclose(p.sum(), np.mean(d.u[:n, 0] ** 2), rtol=1e-12)  # Parseval
    np.testing.assert_allclose(d.u[:n], d.u[n : 2 * n], atol=0)  # whole periods
    assert abs(np.max(np.abs(d.u)) - 2.0) < 1e-12


def test_multisine_grid_keeps_every_grid_th_harmonic() -> None:
    d = inputs.multisine(1000, 0.01, (0.3, 3.0), grid=3, phases="schroeder")
    np.testing.assert_array_equal(d.lines[0], np.arange(3, 31, 3))


def test_crest_factor_of_flat_100_line_multisine() -> None:
    n = 4096
    kw = dict(period=n, dt=1.0 / n, band=(1.0, 100.0))
    schroeder = inputs.multisine(**kw, phases="schroeder")
    reduced = inputs.multisine(**kw)
    assert schroeder.lines[0].size == 100
    # Schroeder phases give about 1.6-1.8 for flat spectra of this size (Schroeder 1970;
    # Pintelon & Schoukens sec. 5.4); the clipping algorithm must bring it to <= 1.5
    assert 1.6 <= schroeder.crest_factor[0] <= 1.8
    assert reduced.crest_factor[0] <= 1.5
    # the reduction changes phases only: the amplitude spectrum is unchanged
    np.testing.assert_allclose(
        reduced.power[reduced.lines[0], 0] / reduced.power[reduced.lines[0], 0].sum(),
        np.full(100, 0.01),
        rtol=1e-10,
    )


def test_crest_factor_of_a_sine_and_a_square() -> None:
    t = np.arange(1000) / 1000
    np.testing.assert_allclose(inputs.crest_factor(np.sin(2 * np.pi * 5 * t)), np.sqrt(2))
    np.testing.assert_allclose(inputs.crest_factor(np.sign(np.sin(2 * np.pi * 5 * t + 0.1))), 1)


@settings(max_examples=25, deadline=None)
@given(
    n=st.integers(64, 600),
    lo=st.integers(1, 20),
    width=st.integers(0, 40),
    m=st.integers(1, 3),
)
def test_multi_input_multisine_is_orthogonal(n: int, lo: int, width: int, m: int) -> None:
    dt = 1.0 / n  # resolution 1 Hz: line k is k Hz
    hi = min(lo + width, (n - 1) // 2)
    if hi - lo + 1 < m:
        with pytest.raises(ValueError, match="band"):
            inputs.multisine(n, dt, (lo, hi), channels=m, iterations=5)
        return
    d = inputs.multisine(n, dt, (lo, hi), channels=m, iterations=5)
    union = np.sort(np.concatenate(d.lines))
    np.testing.assert_array_equal(union, np.arange(lo, hi + 1))  # every line, once
    gram = d.u[:n].T @ d.u[:n] / n
    # disjoint line sets are orthogonal over a period; FFT rounding only
    off = gram - np.diag(np.diag(gram))
    assert np.max(np.abs(off)) < 1e-12 * np.max(np.diag(gram))
    for j in range(m):
        p = d.power[:, j]
        on = np.zeros(p.size, bool)
        on[d.lines[j]] = True
        assert p[~on].max(initial=0.0) < 1e-24 * p[on].max()


def test_random_phase_multisine_needs_a_generator() -> None:
    with pytest.raises(TypeError, match="rng"):
        inputs.multisine(100, 0.01, (1, 10), phases="random")
    a = inputs.multisine(100, 0.01, (1, 10), phases="random", rng=np.random.default_rng(1))
    b = inputs.multisine(100, 0.01, (1, 10), phases="random", rng=np.random.default_rng(1))
    np.testing.assert_array_equal(a.u, b.u)


# -- chirps ----------------------------------------------------------------------------
def _zero_crossings(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    i = np.nonzero(np.sign(x[:-1]) * np.sign(x[1:]) < 0)[0]
    return t[i] - x[i] * (t[i + 1] - t[i]) / (x[i + 1] - x[i])


@pytest.mark.parametrize("method", ["linear", "logarithmic"])
def test_chirp_instantaneous_frequency(method: str) -> None:
    """Zero crossings of ``sin(phi(t))`` are where ``phi(t) = k pi``; solving the analytic
    phase of each sweep for those times is an oracle independent of scipy."""
    dt, n, f0, f1 = 1e-3, 20001, 0.2, 4.0
    d = inputs.chirp(n, dt, f0, f1, method=method, taper=0.2, amplitude=0.5)
    T = (n - 1) * dt
    tz = _zero_crossings(d.t, d.u[:, 0])[1:-1]  # interior crossings (taper ends are ~0)
    phase = np.pi * np.arange(1, 2000)
    if method == "linear":  # phi = 2 pi (f0 t + (f1 - f0) t^2 / (2 T))
        a = np.pi * (f1 - f0) / T
        t_true = (-2 * np.pi * f0 + np.sqrt((2 * np.pi * f0) ** 2 + 4 * a * phase)) / (2 * a)
    else:  # phi = 2 pi f0 T / ln k (k^(t/T) - 1), k = f1 / f0
        lk = np.log(f1 / f0)
        t_true = T * np.log1p(phase * lk / (2 * np.pi * f0 * T)) / lk
    t_true = t_true[t_true < T]
    # match each measured crossing to the nearest analytic one
    j = np.searchsorted(t_true, tz)
    j = np.clip(j, 1, t_true.size - 1)
    nearest = np.where(
        np.abs(t_true[j] - tz) < np.abs(t_true[j - 1] - tz), t_true[j], t_true[j - 1]
    )
    # linear interpolation of a sine's zero: error O(dt^3 f^2), far below 1e-6 s here
    np.testing.assert_allclose(tz, nearest, atol=1e-6)
    assert tz.size > 0.9 * t_true.size  # the taper hides only the ends' crossings
    assert abs(d.u[0, 0]) < 1e-12 and abs(d.u[-1, 0]) < 1e-12
    assert np.max(np.abs(d.u)) <= 0.5 + 1e-12


def test_chirp_rejects_bad_settings() -> None:
    with pytest.raises(ValueError, match="f1"):
        inputs.chirp(100, 0.1, 1.0, 6.0)
    with pytest.raises(ValueError, match="logarithmic"):
        inputs.chirp(100, 0.1, 0.0, 1.0, method="logarithmic")
    with pytest.raises(ValueError, match="taper"):
        inputs.chirp(100, 0.1, 0.1, 1.0, taper=1.5)


# -- random binary ---------------------------------------------------------------------
def test_random_binary_levels_switch_on_the_clock() -> None:
    d = inputs.random_binary(1000, 0.01, rng=np.random.default_rng(3), clock=0.05, channels=2)
    np.testing.assert_array_equal(np.abs(d.u), 1.0)
    switches = np.nonzero(np.any(np.diff(d.u, axis=0) != 0, axis=1))[0] + 1
    assert np.all(switches % 5 == 0)


def test_random_binary_spectrum_is_the_held_white_sequence() -> None:
    """``u = repeat(b, h)`` with i.i.d. signs ``b``: ``E|U_k|^2 = n_bits |D_h(w_k)|^2`` with
    ``D_h(w) = sum_{i<h} exp(-j w i)``, exactly, for ``N`` a multiple of ``h``."""
    h, n_bits, reps = 4, 256, 400
    n = h * n_bits
    rng = np.random.default_rng(11)
    acc = np.zeros(n // 2 + 1)
    for _ in range(reps):
        d = inputs.random_binary(n, 1.0, rng=rng, clock=float(h))
        acc += np.abs(np.fft.rfft(d.u[:, 0])) ** 2
    acc /= reps
    w = 2 * np.pi * np.arange(n // 2 + 1) / n
    expected = n_bits * np.abs(np.exp(-1j * np.outer(w, np.arange(h))).sum(axis=1)) ** 2
    # compare in bands of 32 lines away from the nulls of D_h: each line's average has
    # relative standard deviation 1/sqrt(reps) = 5 %, a band of 32 lines 0.9 %; 5 % is
    # more than 5 standard errors
    for start in range(1, n // (2 * h) - 32, 32):
        band = slice(start, start + 32)
        assert abs(acc[band].sum() / expected[band].sum() - 1) < 0.05


def test_band_limited_random_binary_keeps_its_power_in_band() -> None:
    rng = np.random.default_rng(5)
    d = inputs.random_binary(8192, 0.01, rng=rng, band=(0.0, 5.0))
    f, p = d.freqs, d.power[:, 0]
    in_band = p[f <= 5.0].sum() / p.sum()
    # Van Vleck's arcsine law: the sign's autocorrelation is (2/pi) arcsin(rho) =
    # (2/pi) (rho + rho^3 / 6 + ...); the first term is the band-limited process's own
    # and carries 2/pi of the power, the higher ones partly in band too: in expectation
    # more than 2/pi ~ 0.64 lies in the band (one record of 8192 samples scatters ~1 %)
    assert in_band > 2 / np.pi
    assert sorted(set(d.u[:, 0].tolist())) == [-1.0, 1.0]


def test_random_binary_needs_a_generator() -> None:
    with pytest.raises(TypeError, match="rng"):
        inputs.random_binary(10, 0.1, rng=None)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="clock"):
        inputs.random_binary(10, 0.1, rng=np.random.default_rng(0), clock=0.15)


# -- Hermite-projected sweep -----------------------------------------------------------
def test_hermite_sweep_lies_in_the_span_of_its_basis() -> None:
    import slbasis

    n, dt, n_max_u = 2001, 0.01, 80
    d = inputs.hermite_sweep(n, dt, 0.05, 1.0, n_max_u=n_max_u, amplitude=0.3)
    assert abs(np.max(np.abs(d.u)) - 0.3) < 1e-12
    t = d.t
    basis = slbasis.basis("hermite", n_max_u, (float(t[0]), float(t[-1])))
    again = basis.reconstruct(basis.project(t, d.u[:, 0]), t).reshape(-1)
    u = d.u[:, 0]

    def rel(x: np.ndarray) -> float:
        return float(np.linalg.norm(x - u) / np.linalg.norm(u))

    # a projection is idempotent, up to the part of the functions outside the sampled
    # record (the record fills 90 % of their support; about 1 % of the norm here)
    assert rel(again) < 0.03
    fewer = slbasis.basis("hermite", n_max_u // 2, (float(t[0]), float(t[-1])))
    cut = fewer.reconstruct(fewer.project(t, u), t).reshape(-1)
    assert rel(cut) > 0.3  # half the functions lose the sweep's fast end


# -- plotting --------------------------------------------------------------------------
def test_plot_input_draws_trace_and_spectrum() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d = inputs.multisine(500, 0.01, (0.5, 10.0), channels=2, iterations=5)
    fig = inputs.plot_input(d)
    ax_t, ax_f = fig.axes
    assert len(ax_t.lines) == 2 and len(ax_f.lines) == 2
    np.testing.assert_allclose(ax_t.lines[0].get_ydata(), d.u[:500, 0])
    plt.close(fig)
    with pytest.raises(TypeError, match="design"):
        inputs.plot_input(d.u)
