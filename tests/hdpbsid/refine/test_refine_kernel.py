"""The compiled evaluation of the prediction-error refinement (hdpbsid.refine.pem_kernels
through hdpbsid.refine.pem_residuals._residuals) against the numpy evaluation and against
finite differences.

Oracles: the numpy evaluation (modal coordinates, scipy.signal.lfilter: an independent
implementation of the same predictor and its sensitivities), central finite differences
of the prediction errors, the linearity of the Jacobian in the direction, and the
refined model of the numpy evaluation (eigenvalues within the statistical resolution at
which the fit stops).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.refine import pem_kernels  # noqa: F401  (numba is part of `make test`)
from hdpbsid.refine.pem import refine_pem
from hdpbsid.refine.pem_predictor import sampled_predictor
from hdpbsid.refine.pem_residuals import _kernels, _Layout, _Record, _residuals, _Workspace
from hdpbsid.refine.pem_settings import DEFAULT_SETTINGS
from hdpbsid.systems import add_noise, random_steps, second_order, simulate_zoh

EPS = np.finfo(float).eps


def _model(rng: np.random.Generator, n: int, m: int, l: int, feedthrough: bool, h: float):
    """A random stable model whose sampled predictor is stable (``K`` halved until it is),
    and the eigenvector condition number and spectral radius of that predictor."""
    R = rng.standard_normal((n, n))
    # eigenvalues with real parts in [-(1 + |z|) n - spread, -(1 + |z|)]: stable, not stiff
    A = R - (np.linalg.eigvals(R).real.max() + 1.0 + np.abs(rng.standard_normal())) * np.eye(n)
    B, C = rng.standard_normal((n, m)), rng.standard_normal((l, n))
    D = rng.standard_normal((l, m)) if feedthrough else np.zeros((l, m))
    K = rng.standard_normal((n, l))
    while True:
        F = sampled_predictor(A, B, C, D, K, h, "zoh", feedthrough).F
        foh = sampled_predictor(A, B, C, D, K, h, "foh", feedthrough).F
        rho = max(np.abs(np.linalg.eigvals(F)).max(), np.abs(np.linalg.eigvals(foh)).max())
        if rho < 0.999:
            break
        K = 0.5 * K
    cond = max(np.linalg.cond(np.linalg.eig(X)[1]) for X in (F, foh))
    return (A, B, C, D, K), float(cond), float(rho)


@settings(max_examples=12, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(1, 4),
    m=st.integers(0, 2),
    l=st.integers(1, 3),
    feedthrough=st.booleans(),
    hold=st.sampled_from(["zoh", "foh"]),
)
def test_compiled_and_numpy_evaluations_agree_to_rounding(
    seed: int, n: int, m: int, l: int, feedthrough: bool, hold: str
) -> None:
    rng = np.random.default_rng(seed)
    h, ns = 0.05, 300
    mats, cond, rho = _model(rng, n, m, l, feedthrough and m > 0, h)
    lay = _Layout(n, m, l, feedthrough and m > 0)
    theta = lay.pack(*mats)
    u, y = rng.standard_normal((ns, m)), rng.standard_normal((ns, l))
    W = np.tril(rng.standard_normal((l, l))) + 2 * np.eye(l)
    Q = rng.standard_normal((theta.size, max(1, theta.size // 2)))
    pr = sampled_predictor(*mats, h, hold, lay.feedthrough)
    cond_fr = _free_response_condition(W @ pr.C, pr.F, ns)
    # both evaluations eliminate the initial state through the normal equations of the
    # free response Fr, which resolve it to eps cond(Fr)^2 (Higham, Accuracy and
    # Stability of Numerical Algorithms, 2nd ed., sec. 20.4), and run recursions over
    # the samples, the numpy one in modal coordinates (rounding amplified by cond(V) and
    # carried over the filter memory 1 / (1 - rho) samples, ch. 7); measured on 150
    # random models: differences below 14 eps cond(Fr)^2 + 1.3 eps cond(V) cond(Fr) /
    # (1 - rho), relative to the largest entry
    tol = 1e2 * EPS * cond_fr**2 + 1e2 * EPS * cond * cond_fr / (1.0 - rho)
    # a Jacobian column is a sum of terms as large as |r| / |theta_i|, which cancel when
    # theta_i is small (the fitted initial state scales inversely with the output matrix:
    # C -> c C, x0 -> x0 / c; measured: dr/dC with C = -0.009, n = l = 1, differed by
    # 2300 eps of its largest entry, 1.1 x the bound relative to the largest entry of J):
    # its rounding is relative to the larger of that size and the largest entry of J
    r_np, J_np = _residuals(theta, lay, u, y, h, hold, W, True, None, engine="numpy")
    terms = np.maximum(np.abs(J_np).max(), np.abs(r_np).max() / np.abs(theta))
    for directions in (None, Q):
        r_np, J_np = _residuals(theta, lay, u, y, h, hold, W, True, directions, engine="numpy")
        r_nb, J_nb = _residuals(theta, lay, u, y, h, hold, W, True, directions, engine="numba")
        size = terms if directions is None else np.abs(directions).T @ terms
        assert np.abs(r_nb - r_np).max() <= tol * np.abs(r_np).max(), (cond, rho, cond_fr)
        assert (np.abs(J_nb - J_np).max(axis=0) <= tol * size).all(), (cond, rho, cond_fr)
    # the residuals alone (the predictor from a smaller matrix exponential)
    r_only = _residuals(theta, lay, u, y, h, hold, W, engine="numba")
    assert np.abs(r_only - r_np).max() <= tol * np.abs(r_np).max()


def _free_response_condition(WC: np.ndarray, F: np.ndarray, ns: int) -> float:
    """Condition number of the stacked free response ``W C F^k``, ``k < ns``."""
    rows, P = [], WC.copy()
    for _ in range(ns):
        rows.append(P)
        P = P @ F
    return float(np.linalg.cond(np.concatenate(rows, axis=0)))


@pytest.mark.parametrize(
    ("n", "m", "l", "feedthrough", "hold"),
    [
        (3, 1, 2, False, "zoh"),
        (3, 1, 2, False, "foh"),
        (2, 2, 2, True, "zoh"),
        (2, 0, 1, False, "zoh"),
    ],
)
def test_compiled_jacobian_matches_finite_differences(
    n: int, m: int, l: int, feedthrough: bool, hold: str
) -> None:
    # at (nearly) zero residual Kaufman's variable-projection Jacobian is the exact one
    rng = np.random.default_rng(7)
    h = 0.02
    (A, B, C, D, K), _, _ = _model(rng, n, m, l, feedthrough, h)
    lay = _Layout(n, m, l, feedthrough)
    theta = lay.pack(A, B, C, D, K)
    t = np.arange(600) * h
    u = np.zeros((t.size, m))
    for j in range(m):
        u[:, j] = np.sin((1 + j) * t) + 0.3 * np.sin(3.1 * (1 + j) * t)
    x0 = rng.standard_normal(n)
    y = StateSpaceModel(A, B, C, D, K).simulate(t, u, method=hold, x0=x0)
    y = y + 1e-8 * rng.standard_normal(y.shape)
    W = np.tril(rng.standard_normal((l, l))) + 2 * np.eye(l)
    r, J = _residuals(theta, lay, u, y, h, hold, W, jac=True, engine="numba")
    assert np.abs(r).max() < 1e-6  # the data are the model's: the residuals are the noise
    step = 1e-6
    for k in range(theta.size):
        e = np.zeros(theta.size)
        e[k] = step
        fd = (
            _residuals(theta + e, lay, u, y, h, hold, W, engine="numba")
            - _residuals(theta - e, lay, u, y, h, hold, W, engine="numba")
        ) / (2 * step)
        # residuals ~1e-8 make the neglected variable-projection term ~1e-8 relative;
        # central differences add ~step^2 = 1e-12 truncation and ~eps/step = 1e-10
        # rounding: 1e-6 of the column's size is a safe bound
        assert np.allclose(J[:, k], fd, atol=1e-6 * max(1.0, np.abs(fd).max())), k
    # along directions the Jacobian is J @ directions (linear in the direction)
    Q = rng.standard_normal((theta.size, 3))
    _, JQ = _residuals(theta, lay, u, y, h, hold, W, jac=True, directions=Q, engine="numba")
    # the same sums in another order: rounding of a q-term sum of O(|J|) products
    np.testing.assert_allclose(JQ, J @ Q, atol=1e-12 * np.abs(J).max() * theta.size)


def test_workspace_and_record_memory_return_the_same_numbers() -> None:
    rng = np.random.default_rng(3)
    (A, B, C, D, K), _, _ = _model(rng, 3, 1, 2, False, 0.05)
    lay = _Layout(3, 1, 2, False)
    theta = lay.pack(A, B, C, D, K)
    u, y = rng.standard_normal((400, 1)), rng.standard_normal((400, 2))
    W = np.eye(2)
    # the workspace is the compiled evaluation's: asked for by name, so that a run with
    # "auto" on the numpy evaluation (SLBASIS_NO_NUMBA, NUMBA_DISABLE_JIT) tests it too
    fresh = _residuals(theta, lay, u, y, 0.05, "zoh", W, jac=True, engine="numba")
    ws = _Workspace()
    kw = {"workspace": ws, "engine": "numba"}
    _residuals(theta + 0.01, lay, u, y, 0.05, "zoh", W, jac=True, **kw)  # dirty it
    again = _residuals(theta, lay, u, y, 0.05, "zoh", W, jac=True, **kw)
    assert all(np.array_equal(a, b) for a, b in zip(fresh, again, strict=True))
    # a Jacobian at the point of the last residual evaluation starts from that pass (the
    # predictor from the smaller matrix exponential): the same to rounding, amplified by
    # the normal equations of the free response: cond(Fr)^2 = 2e2 here, so 1e-11 is
    # ~200 eps cond(Fr)^2 (measured: no difference at all)
    r_first = _residuals(theta, lay, u, y, 0.05, "zoh", W, **kw)
    r_reused, J_reused = _residuals(theta, lay, u, y, 0.05, "zoh", W, jac=True, **kw)
    assert r_reused is r_first
    assert np.abs(J_reused - fresh[1]).max() <= 1e-11 * np.abs(fresh[1]).max()
    # the record remembers whatever its engine ("auto") computes
    fresh = _residuals(theta, lay, u, y, 0.05, "zoh", W, jac=True)
    record = _Record(lay, u, y, 0.05, "zoh")
    assert all(np.array_equal(a, b) for a, b in zip(fresh, record(theta, W, jac=True), strict=True))
    first = record(theta, W)
    assert np.array_equal(first, fresh[0])
    assert record(theta, W) is first  # remembered, not recomputed
    with pytest.raises(ValueError, match="read-only"):
        first[0] = 1.0  # a remembered result cannot be altered by a caller


def test_engine_choice(monkeypatch: pytest.MonkeyPatch) -> None:
    assert _kernels("numba") is not None and _kernels("numpy") is None
    monkeypatch.setenv("SLBASIS_NO_NUMBA", "1")
    assert _kernels("auto") is None  # switched off: the numpy evaluation
    with pytest.raises(ValueError, match="engine must be one of"):
        _kernels("fortran")


def test_refined_model_is_the_numpy_one_within_the_statistical_resolution(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # open-loop second-order system, 10 dB, refined from a perturbed start by both
    # evaluations; the fit stops when a run moves the estimate by less than STALL_SD
    # standard deviations, so two fits whose Jacobians differ by rounding end within
    # 2 STALL_SD of each other (each within STALL_SD of the optimum)
    A2, B2, C2, D2 = second_order()
    rng = np.random.default_rng(21)
    t = np.arange(0.0, 30.0, 0.02)
    u = random_steps(rng, t, hold=0.3)
    y, _ = add_noise(simulate_zoh(A2, B2, C2, D2, t, u), 10.0, rng)
    start = StateSpaceModel(
        A2 * (1 + 0.05 * rng.standard_normal(A2.shape)),
        B2 * (1 + 0.05 * rng.standard_normal(B2.shape)),
        C2 + 0.05 * rng.standard_normal(C2.shape),
        D2,
        np.zeros((2, 1)),
        options={"input_hold": "zoh"},
    )
    compiled = refine_pem(start, t, u, y)
    monkeypatch.setenv("SLBASIS_NO_NUMBA", "1")
    numpy = refine_pem(start, t, u, y)
    std = numpy.options["eigenvalue_std"]
    assert np.all(
        np.abs(compiled.eigenvalues - numpy.eigenvalues) <= 2 * DEFAULT_SETTINGS.stall_sd * std
    )
    assert compiled.options["refine_hold"] == numpy.options["refine_hold"]


@pytest.mark.parametrize("engine", ["numpy", "numba"])
def test_an_overflowing_predictor_is_penalised_like_an_unstable_one(engine: str) -> None:
    # a search step far outside the stable region: exp(A h) overflows; the evaluation
    # must return the penalty (which sends the search back), not raise from eig
    lay = _Layout(1, 1, 1, False)
    theta = lay.pack(
        np.array([[1e6]]), np.array([[1.0]]), np.array([[1.0]]), np.zeros((1, 1)), np.ones((1, 1))
    )
    rng = np.random.default_rng(0)
    u, y = rng.standard_normal((50, 1)), rng.standard_normal((50, 1))
    with np.errstate(over="ignore", invalid="ignore"):
        r, J = _residuals(theta, lay, u, y, 0.05, "zoh", np.eye(1), True, engine=engine)
    assert np.all(r == DEFAULT_SETTINGS.unstable_penalty) and not J.any()


def test_singular_free_response_gram_gives_the_least_squares_projection() -> None:
    from hdpbsid.refine.pem_residuals import _gram_solve

    rng = np.random.default_rng(1)
    Fr = rng.standard_normal((40, 3))
    Fr[:, 2] = Fr[:, 0] - Fr[:, 1]  # a mode with no independent trace in the outputs
    e = rng.standard_normal(40)
    FtF = Fr.T @ Fr
    FtF[:, 2] = FtF[:, 0] - FtF[:, 1]  # exactly singular, as rounding may leave it
    FtF[2] = FtF[0] - FtF[1]
    r = e - Fr @ _gram_solve(FtF, Fr.T @ e)
    oracle = e - Fr @ np.linalg.lstsq(Fr, e, rcond=None)[0]  # the projection itself
    # both are the residual of one projection; rounding of normal equations, cond ~ 10
    np.testing.assert_allclose(r, oracle, atol=1e-10)
    ok = rng.standard_normal((3, 3)) + 3 * np.eye(3)  # regular: the plain solve
    np.testing.assert_array_equal(_gram_solve(ok, e[:3]), np.linalg.solve(ok, e[:3]))
