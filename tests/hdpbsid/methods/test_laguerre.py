"""CT-PBSID (``identify_laguerre``): projection and filter variants, Cayley map.

Measured when written: noise-free 1e-9..5e-7 (both variants); SNR 20 dB random smooth
input 0.05-0.23 % (projection), 0.09-0.2 % (filter); chirp SNR 20 dB <= 0.45 %;
jittered times (+-40 %) 0.04-0.18 % vs 0.05-0.23 % uniform.
"""

from __future__ import annotations

import numpy as np
import pytest
from basis_data import A, B, C, D, eig_error, make_data

from hdpbsid.methods.laguerre import cayley, identify_laguerre, inverse_cayley


def test_cayley_round_trip_and_stability() -> None:
    Ad, Bd, Cd, Dd = cayley(A, B, C, D, 3.0)
    # a stable lambda maps inside the unit disc
    assert np.abs(np.linalg.eigvals(Ad)).max() < 1
    back = inverse_cayley(Ad, Bd, Cd, Dd, 3.0)
    for x, ref in zip(back, (A, B, C, D), strict=True):
        np.testing.assert_allclose(x, ref, atol=1e-12)  # rounding of 2x2 inverses
    # the transfer function is preserved: G(s) = Gd(z) at z = (s + a)/(s - a)
    s = 0.3 + 1.1j
    z = (s + 3.0) / (s - 3.0)
    G = C @ np.linalg.solve(s * np.eye(2) - A, B) + D
    Gd = Cd @ np.linalg.solve(z * np.eye(2) - Ad, Bd) + Dd
    np.testing.assert_allclose(Gd, G, atol=1e-12)


@pytest.mark.parametrize("variant", ["projection", "filter"])
def test_noise_free_eigenvalues(variant: str) -> None:
    for seed in range(2):
        m = identify_laguerre(*make_data(seed), order=2, variant=variant)
        # issue target 1e-3; measured <= 5e-7
        assert eig_error(m) < 1e-3
    assert m.options["variant"] == variant and "a_rule" in m.options


@pytest.mark.parametrize("variant", ["projection", "filter"])
def test_snr20(variant: str) -> None:
    errs = [
        eig_error(identify_laguerre(*make_data(10 + s, snr=20), order=2, variant=variant))
        for s in range(12)
    ]
    # at SNR 20 dB the thesis (§5, Table 1) reports the Laguerre method less robust than
    # Hermite; here measured <= 0.23 %: 2 % is the HD-PBSID target, kept for comparison
    assert max(errs) < 0.02
    errs = [
        eig_error(identify_laguerre(*make_data(20 + s, snr=20, kind="chirp"), order=2))
        for s in range(2)
    ]
    assert max(errs) < 0.02


def test_nonuniform_times() -> None:
    uni = [eig_error(identify_laguerre(*make_data(10 + s, snr=20), order=2)) for s in range(12)]
    jit = [
        eig_error(identify_laguerre(*make_data(10 + s, snr=20, jitter=0.4), order=2))
        for s in range(12)
    ]
    # issue target: within 1.5x of the uniform case.  Mean over the same 12 seeds: the
    # per-seed errors scatter by 2-3x, so fewer seeds make the ratio itself noisy
    # (16 seeds measured: ratio 1.00)
    assert np.mean(jit) <= 1.5 * np.mean(uni)


def test_options_and_bad_arguments() -> None:
    t, u, y = make_data(1)
    m = identify_laguerre(t, u, y, order=2, a=2.5, N=150)
    assert m.options["a"] == 2.5 and m.options["N"] == 150 and m.options["a_rule"] == "given"
    with pytest.raises(ValueError, match="variant"):
        identify_laguerre(t, u, y, variant="convolution")
    with pytest.raises(ValueError, match="a must be"):
        identify_laguerre(t, u, y, a=-1.0)
    with pytest.raises(ValueError, match="p=40 is too large"):
        identify_laguerre(t, u, y, order=2, N=100, p=40)


def test_initial_state_boundary_rows() -> None:
    # x0 != 0: the boundary rows make the index-domain equation exact, but near t0 the
    # high-index Laguerre functions oscillate faster than the sampling, and the default
    # GCV ridge then trades that inconsistency for bias (measured 0.15-7.7 % over 5
    # seeds).  Plain least squares keeps the exact structure: measured 2e-4..6e-4
    for s in range(3):
        data = make_data(30 + s, x0=[1.0, -1.0])
        m = identify_laguerre(*data, order=2, regularize=False)
        assert eig_error(m) < 1e-3  # issue's noise-free target
