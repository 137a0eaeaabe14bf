"""Several records and windows of one record in one PBSID problem (hdpbsid.data.records,
hdpbsid.core.blocks, hdpbsid.bases.segments), and Unix-time stamps."""

from __future__ import annotations

import numpy as np
import pytest
from basis_data import eig_error, make_data

from hdpbsid.bases.basis_domain import SolveLag
from hdpbsid.core.blocks import BlockLag, BlockPseudo, pbsid_core_blocks
from hdpbsid.core.pbsid import pbsid_core
from hdpbsid.core.varx import SampleShift
from hdpbsid.data.records import as_records
from hdpbsid.identify import identify
from hdpbsid.methods.dt import identify_dt
from hdpbsid.methods.hermite import hermite_lag, identify_hermite
from hdpbsid.methods.laguerre import identify_laguerre
from hdpbsid.methods.sturm_liouville import identify_legendre
from hdpbsid.systems import random_steps, second_order, simulate_zoh


@pytest.mark.parametrize(
    "method", [identify_hermite, identify_laguerre, identify_legendre, identify_dt]
)
def test_list_of_one_record_equals_the_record(method) -> None:
    t, u, y = make_data(3, T=20.0, snr=20)
    a = method(t, u, y, order=2)
    b = method([(t, u, y)], order=2)
    assert np.array_equal(a.A, b.A) and np.array_equal(a.C, b.C)


@pytest.mark.parametrize("kind", ["shift", "solve"])
@pytest.mark.parametrize("feedthrough", [False, True])
def test_elimination_equals_naive_stacked_pseudo_inputs(kind: str, feedthrough: bool) -> None:
    """Frisch-Waugh-Lovell: eliminating each block's pseudo rows equals appending them as
    block-diagonal input rows (plain least squares), on random data of two blocks."""
    rng = np.random.default_rng(1)
    sizes = [150, 120]
    n = sum(sizes)
    U, Y = rng.standard_normal((1, n)), rng.standard_normal((1, n))
    P = [rng.standard_normal((2, s)) for s in sizes]
    if kind == "shift":
        lags = [SampleShift(), SampleShift()]
    else:
        lags = []
        for s in sizes:
            Mi = 2 * np.eye(s) + 0.5 * np.eye(s, k=1) - 0.5 * np.eye(s, k=-1)
            lags.append(SolveLag(lambda W, Mi=Mi: np.linalg.solve(Mi.T, W.T).T))
    lag = BlockLag(lags, sizes)
    a = pbsid_core_blocks(U, Y, 3, lag, BlockPseudo(lag, P), order=2, feedthrough=feedthrough)
    Pz = np.zeros((4, n))  # the naive problem: 2 unit-RMS rows per block, zero elsewhere
    Pz[:2, :150] = P[0] / np.sqrt(np.mean(P[0] ** 2, axis=1))[:, None]
    Pz[2:, 150:] = P[1] / np.sqrt(np.mean(P[1] ** 2, axis=1))[:, None]
    b = pbsid_core(np.vstack([U, Pz]), Y, 3, order=2, lag=lag, feedthrough=feedthrough)
    # same least-squares problem solved two ways: equal to rounding (cond ~ 1e3)
    assert np.allclose(a.singular_values, b.singular_values, rtol=1e-9)
    assert np.allclose(np.sort_complex(np.linalg.eigvals(a.A)), np.sort_complex(b.eigenvalues))
    assert np.allclose(a.noise_covariance, b.noise_covariance, rtol=1e-9)


def test_hermite_lag_banded_equals_dense_solve() -> None:
    import slbasis

    b = slbasis.basis("hermite", 40, (0.0, 10.0))
    Dm = b.derivative_matrix("square")
    lag, _ = hermite_lag(Dm, 3.0, 1.0, 1.5)
    Dp = (-Dm.toarray() / 3.0 + np.eye(40)) / 1.5
    W = np.random.default_rng(0).standard_normal((3, 40))
    # oracle: W D'^{-1} by a dense solve; banded vs dense LU differ by rounding only
    assert np.allclose(lag.apply(W, 1), W @ np.linalg.inv(Dp), rtol=1e-10, atol=1e-12)


def test_windowed_agrees_with_one_window_on_a_short_record() -> None:
    data = make_data(7, T=40.0)
    one = identify_hermite(*data, order=2, window=None)
    two = identify_hermite(*data, order=2, window=20.0)
    assert two.options["n_segments"] == 2 and one.options["n_segments"] == 1
    # noise-free: both are exact to the projection precision (each ~1e-5 here); the
    # windows' equations are exact too (their edge states are the pseudo-inputs)
    assert eig_error(one) < 1e-3 and eig_error(two) < 1e-3
    assert np.allclose(one.eigenvalues, two.eigenvalues, rtol=1e-3)


def test_windowed_estimate_improves_as_the_record_grows() -> None:
    means = []
    for T in (100.0, 400.0, 1600.0):
        errs = [
            eig_error(identify_hermite(*make_data(40 + s, T=T, dt=0.05, snr=20), order=2))
            for s in range(3)
        ]
        means.append(np.mean(errs))
    # measured 0.23 %, 0.12 %, 0.089 % (1600 s: 7 default windows); the statistical error
    # falls like 1/sqrt(T), so each 4x longer record must at least not be worse
    assert means[0] > means[1] > means[2]


def test_several_records_stack_and_errors_name_the_record() -> None:
    recs = [make_data(50 + k, T=20.0, snr=20) for k in range(3)]
    m = identify_hermite(recs, order=2)
    assert m.options["n_records"] == 3 and m.options["n_segments"] == 3
    # three 20 s records at 20 dB: within the single-record 2 % target
    assert eig_error(m) < 0.02
    t, u, y = recs[1]
    with pytest.raises(ValueError, match="record 1"):
        as_records([recs[0], (t, np.hstack([u[:, None], u[:, None]]), y)])
    with pytest.raises(ValueError, match="record 2"):
        as_records([recs[0], recs[1], (t[::-1], u, y)])
    with pytest.raises(TypeError, match="u and y must be None"):
        as_records(recs, u, None)


def test_dt_records_do_not_lag_across_edges() -> None:
    """Two ZOH experiments (different inputs, the second from x0 != 0): sampled exactly,
    so each obeys the discrete model exactly; concatenated with a lag across the edge
    the join would violate it."""
    A, B, C, D = second_order()
    t = np.arange(0.0, 20.0, 0.05)
    recs = []
    for k, x0 in enumerate((None, [1.0, -0.5])):
        u = random_steps(np.random.default_rng(70 + k), t, 0.5)
        recs.append((t, u, simulate_zoh(A, B, C, D, t, u, x0)))
    m = identify_dt(recs, order=2, regularize=False)
    assert m.options["n_records"] == 2
    # noise-free ZOH data: the discrete model is exact, error at rounding level (1e-8
    # leaves room for the conditioning of the VARX and the matrix logarithm)
    assert eig_error(m) < 1e-8


def test_unix_time_stamps() -> None:
    t, u, y = make_data(8, T=20.0, snr=20)
    tu = 1.7e9 + t  # stamps rounded to 2.4e-7 s: the spacing scatters by 2.4e-5 relative
    for method in ("dt", "hermite"):
        a = identify(t, u, y, order=2, method=method)
        b = identify(tu, u, y, order=2, method=method)
        # same record up to the stamps' rounding (2.4e-5 of a sample): eigenvalues agree
        # far inside the statistical error (~0.3 %)
        assert np.allclose(a.eigenvalues, b.eigenvalues, rtol=1e-3)
        assert b.options["t0"] == pytest.approx(1.7e9)
    r = identify(tu, u, y, order=2, method="hermite", refine="pem")
    assert r.options["refine"] == "pem"
    assert eig_error(r) < 0.02  # the refined model keeps the 2 % target at 20 dB
