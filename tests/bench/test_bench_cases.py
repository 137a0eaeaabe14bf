"""The benchmark's data sets (``bench/cases.py``) and the scoring plumbing of
``bench/peers.py``, checked without the peers installed (they are an optional extra:
``bench/peers.py`` imports them only inside the functions that run them).

Oracles: the analytic eigenvalues of each benchmark system, exact ZOH sampling of a known
model, and method ``dt`` on noise-free data.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import cont2discrete, dlsim, tf2ss

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path.insert(0, str(BENCH))

import cases  # noqa: E402
import peers  # noqa: E402

from hdpbsid.models.conversion import c2d  # noqa: E402

SECOND_ORDER = np.array([-0.4 + np.sqrt(3.84) * 1j, -0.4 - np.sqrt(3.84) * 1j])
PBSID = 0.67 * np.array([1 + 1j, 1 - 1j, -1 + 1j, -1 - 1j])

# shorter records for the two slow generators (the properties checked do not depend on length)
SHORT = {
    "nonuniform": {"T": 4.0, "n_samples": 401},
    "quadrotor": {"duration": 4.0},
    "table2-closed-loop": {"duration": 4.0},
    "table2-closed-loop-rate": {"duration": 4.0},
}
# (s^2 + s + 4)(s^2 + 4 s + 400): the Rao-Garnier denominator factored by hand
RAO_GARNIER = np.array(
    [
        -0.5 + 1j * np.sqrt(15) / 2,
        -0.5 - 1j * np.sqrt(15) / 2,
        -2 + 1j * np.sqrt(396),
        -2 - 1j * np.sqrt(396),
    ]
)
MIMO = np.array([-0.2 + 2j, -0.2 - 2j, -2 + 20j, -2 - 20j])
TABLE2 = np.array([-28.0, -10.0, 1.2 + 5.8j, 1.2 - 5.8j])


def _sorted(ev: np.ndarray) -> np.ndarray:
    ev = np.asarray(ev, dtype=complex)
    return ev[np.lexsort((ev.imag, ev.real))]


def test_importing_the_bench_does_not_import_the_peers() -> None:
    # the peers are an optional extra: the bench modules must import without them
    code = (
        f"import sys; sys.path.insert(0, {str(BENCH)!r}); import peers, cases; "
        "print(sorted(m for m in ('sippy_unipi', 'nfoursid', 'pandas') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"


def test_stiff_system_has_the_stated_eigenvalues() -> None:
    A, B, C, D = cases.stiff_third_order()
    # eigenvalues of a real modal (block-diagonal) matrix: exact up to a few ulps of 50
    np.testing.assert_allclose(
        _sorted(np.linalg.eigvals(A)), _sorted([-50, -0.5 + 2j, -0.5 - 2j]), atol=1e-12
    )
    # both time scales must reach the output: (A, C) observable, (A, B) controllable
    n = A.shape[0]
    obs = np.vstack([C @ np.linalg.matrix_power(A, k) for k in range(n)])
    ctr = np.hstack([np.linalg.matrix_power(A, k) @ B for k in range(n)])
    assert np.linalg.matrix_rank(obs) == n and np.linalg.matrix_rank(ctr) == n


@pytest.mark.parametrize(
    ("name", "expected", "atol"),
    [
        # computed eigenvalues of 2x2 / modal / 4x4 rotation matrices: rounding only
        ("second-order", SECOND_ORDER, 1e-12),
        ("chirp", SECOND_ORDER, 1e-12),
        ("nonuniform", SECOND_ORDER, 1e-12),
        ("stiff", cases.STIFF_EIGENVALUES, 1e-12),
        ("pbsid-mimo", PBSID, 1e-12),
        # computed eigenvalues of 4x4 block-diagonal matrices with entries up to 400
        ("rao-garnier", RAO_GARNIER, 1e-10),
        ("mimo-2x2", MIMO, 1e-12),
        ("table2-closed-loop", TABLE2, 1e-12),
        ("table2-closed-loop-rate", TABLE2, 1e-12),
        # the quadrotor eigenvalues are quoted to two decimals: half a unit of 0.01
        ("quadrotor", np.array([-2.92 + 3.24j, -2.92 - 3.24j, 3.08]), 0.005 + 1e-9),
    ],
)
def test_case_true_eigenvalues(name: str, expected: np.ndarray, atol: float) -> None:
    data = cases.CASES[name](3, 20.0, **SHORT.get(name, {}))
    assert data.order == expected.size
    np.testing.assert_allclose(_sorted(data.true_eigenvalues), _sorted(expected), atol=atol)


@pytest.mark.parametrize("name", list(cases.CASES))
def test_case_records_are_consistent_and_seeded(name: str) -> None:
    gen = cases.CASES[name]
    kw = SHORT.get(name, {})
    a, b, c = gen(5, 20.0, **kw), gen(5, 20.0, **kw), gen(6, 20.0, **kw)
    for rec in (a.estimation, a.validation):
        ns = rec.t.size
        assert rec.u.shape[0] == ns and rec.y.shape[0] == ns
        assert np.all(np.diff(rec.t) > 0)
        assert np.all(np.isfinite(rec.u)) and np.all(np.isfinite(rec.y))
    np.testing.assert_array_equal(a.estimation.y, b.estimation.y)  # same seed, same data
    assert not np.array_equal(a.estimation.y, c.estimation.y)  # another seed, other data
    assert not np.array_equal(a.estimation.y, a.validation.y)  # validation is a new record
    assert a.uniform == bool(np.allclose(np.diff(a.estimation.t), a.estimation.t[1]))


def test_noise_free_stiff_data_are_the_exact_zoh_response() -> None:
    data = cases.make_case("stiff", seed=1, snr=None)
    A, B, C, D = cases.stiff_third_order()
    rec = data.estimation
    Ad, Bd, *_ = c2d(A, B, C, D, None, rec.t[1] - rec.t[0])
    x = np.zeros(3)
    y = np.empty(rec.t.size)
    for k in range(rec.t.size):
        y[k] = (C @ x)[0]
        x = Ad @ x + Bd @ rec.u[k]
    # same exact recursion computed twice: rounding only (signals are O(1))
    np.testing.assert_allclose(rec.y[:, 0], y, atol=1e-12)


def _true_case_model(data: cases.CaseData, discrete: bool) -> peers.Identified:
    A, B, C, D = cases.stiff_third_order()
    if not discrete:
        return peers.Identified(A, B, C, D)
    dt = float(data.estimation.t[1] - data.estimation.t[0])
    Ad, Bd, *_ = c2d(A, B, C, D, None, dt)
    return peers.Identified(Ad, Bd, C, D, dt)


@pytest.mark.parametrize("discrete", [False, True])
def test_scoring_of_the_true_model(discrete: bool) -> None:
    """The true model, continuous or exactly sampled (then mapped back by the bench's
    d2c), scores zero eigenvalue error and a perfect fit on noise-free data."""
    data = cases.make_case("stiff", seed=2, snr=None)
    model = _true_case_model(data, discrete)
    method = peers.Method("truth", lambda rec, order, h: model, "truth", peer=False)
    out = peers.run_one(method, data, None, score_fit=True)
    assert out.status == "ok"
    # expm/logm round trip of a matrix with norm 50 and dt = 0.01: ~1e-13 relative
    assert out.error < 1e-9
    # ZOH data simulated with the same ZOH model: only rounding separates them
    assert out.fit > 100 - 1e-6


def test_dt_method_recovers_noise_free_eigenvalues() -> None:
    """Method ``dt`` through the bench's plumbing on exact, noise-free ZOH data."""
    data = cases.make_case("stiff", seed=4, snr=None)
    out = peers.run_one(peers.METHODS["dt"], data, None, score_fit=True)
    assert out.status == "ok", out.message
    # PBSID is exact on noise-free data of the right order; what is left is the rounding of
    # the state estimate of a stiff system (poles 100x apart): 1e-13..4e-12 seen on seeds
    # 1-5, so 1e-8 leaves room for other BLAS builds and is far below any noisy-case error
    assert out.error < 1e-8
    assert out.fit > 100 - 1e-6  # same digits: the noise-free validation is reproduced


def test_discrete_case_compares_in_the_z_plane() -> None:
    data = cases.make_case("pbsid-mimo", seed=1, snr=None)
    A = np.diag([0.5, 0.6, 0.7, 0.8])  # any discrete model: eigenvalues taken as they are
    model = peers.Identified(A, np.ones((4, 2)), np.ones((2, 4)), np.zeros((2, 2)), 1.0)
    np.testing.assert_allclose(np.sort(peers.model_eigenvalues(model, data)), np.diag(A))
    logA = np.diag(np.log(np.diag(A)))
    cont = peers.Identified(logA, np.ones((4, 2)), np.ones((2, 4)), np.zeros((2, 2)))
    # a continuous model is sampled with expm(A dt), dt = 1: exp(log(a)) = a to rounding
    np.testing.assert_allclose(np.sort(peers.model_eigenvalues(cont, data).real), np.diag(A))


def test_failures_are_counted_not_raised() -> None:
    data = cases.make_case("second-order", seed=1, snr=None)

    def exits(rec: cases.Record, order: int, h: int | None) -> peers.Identified:
        sys.exit("Error! like SIPPY")

    def raises(rec: cases.Record, order: int, h: int | None) -> peers.Identified:
        raise np.linalg.LinAlgError("SVD did not converge")

    def wrong_order(rec: cases.Record, order: int, h: int | None) -> peers.Identified:
        return peers.Identified(np.eye(3) * 0.5, np.ones((3, 1)), np.ones((1, 3)), np.zeros((1, 1)))

    def no_log(rec: cases.Record, order: int, h: int | None) -> peers.Identified:
        # a discrete eigenvalue on the negative real axis has no real logarithm
        Ad = np.diag([-0.9, 0.5])
        return peers.Identified(Ad, np.ones((2, 1)), np.ones((1, 2)), np.zeros((1, 1)), 0.01)

    def nan(rec: cases.Record, order: int, h: int | None) -> peers.Identified:
        return peers.Identified(
            np.full((2, 2), np.nan), np.ones((2, 1)), np.ones((1, 2)), np.zeros((1, 1))
        )

    expected = {exits: "exit", raises: "exception", wrong_order: "wrong-order"}
    expected.update({no_log: "no-d2c", nan: "nan"})
    for func, status in expected.items():
        out = peers.run_one(peers.Method(func.__name__, func, ""), data, None, score_fit=True)
        assert out.status == status
    summary = peers.summarize(
        [peers.Outcome("ok", error=0.1, fit=90.0, seconds=1.0), peers.Outcome("exit")]
    )
    assert summary["ok"] == 1 and summary["failures"] == {"exit": 1}
    assert summary["error_median_fail_inf"] == np.inf  # median of [0.1, inf]


def test_results_are_written_where_the_docs_include_them(tmp_path: Path) -> None:
    assert peers.RESULTS == Path(peers.__file__).resolve().parent / "results"
    path = peers.write_results("| a |\n|---|", "peers", directory=tmp_path / "results")
    assert path == tmp_path / "results" / "peers.md"
    assert path.read_text(encoding="utf-8") == "| a |\n|---|\n"


def _transfer(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, s: complex) -> np.ndarray:
    return C @ np.linalg.solve(s * np.eye(A.shape[0]) - A, B) + D


FREQS = 1j * np.array([0.1, 1.0, 2.0, 5.0, 19.9, 20.0, 100.0])


def test_rao_garnier_realisation_has_the_stated_transfer_function() -> None:
    A, B, C, D = cases.rao_garnier_system()
    num = np.array([-6400.0, 1600.0])
    den = np.array([1.0, 5.0, 408.0, 416.0, 1600.0])
    At, Bt, Ct, Dt = tf2ss(num, den)  # scipy's controllable canonical form
    for s in [*FREQS, 0.0, 3.0 - 1.0j]:
        g = _transfer(A, B, C, D, s)[0, 0]
        # the polynomial ratio itself and scipy's realisation: a 4x4 solve with entries
        # up to 400 loses ~1e-13 relative
        assert g == pytest.approx(np.polyval(num, s) / np.polyval(den, s), rel=1e-10, abs=1e-12)
        assert g == pytest.approx(_transfer(At, Bt, Ct, Dt, s)[0, 0], rel=1e-10, abs=1e-12)
    # DC gain 1 and the non-minimum-phase zero at s = 1/4 (exact values, rounding only)
    assert _transfer(A, B, C, D, 0.0)[0, 0] == pytest.approx(1.0, rel=1e-12)
    assert abs(_transfer(A, B, C, D, 0.25)[0, 0]) < 1e-12
    # poles: the hand factorisation, and the roots of the denominator polynomial
    np.testing.assert_allclose(_sorted(np.linalg.eigvals(A)), _sorted(RAO_GARNIER), atol=1e-10)
    np.testing.assert_allclose(_sorted(np.roots(den)), _sorted(RAO_GARNIER), atol=1e-10)


def test_rao_garnier_input_is_binary_held_five_samples() -> None:
    data = cases.make_case("rao-garnier", seed=2, snr=10.0)
    u = data.estimation.u[:, 0]
    assert set(np.unique(u)) == {-1.0, 1.0}
    # levels change only at multiples of 0.05 s = 5 samples of 0.01 s
    changes = np.flatnonzero(np.diff(u)) + 1
    assert changes.size > 100 and np.all(changes % 5 == 0)


def _pbh_rank_ok(A: np.ndarray, M: np.ndarray, columns: bool) -> bool:
    n = A.shape[0]
    for lam in np.linalg.eigvals(A):
        test = (
            np.hstack([lam * np.eye(n) - A, M]) if columns else np.vstack([lam * np.eye(n) - A, M])
        )
        if np.linalg.matrix_rank(test) < n:
            return False
    return True


def test_mimo_modes_reach_every_channel() -> None:
    A, B, C, D = cases.mimo_2x2_system()
    assert B.shape == (4, 2) and C.shape == (2, 4)
    # PBH test: every mode controllable from each input alone, observable from each output
    for j in range(2):
        assert _pbh_rank_ok(A, B[:, j : j + 1], columns=True)
        assert _pbh_rank_ok(A, C[j : j + 1, :], columns=False)
    # modes a decade apart, both lightly damped (zeta = 0.0995)
    ev = _sorted(np.linalg.eigvals(A))
    zeta = -ev.real / np.abs(ev)
    np.testing.assert_allclose(zeta, 0.2 / np.sqrt(4.04), rtol=1e-12)
    assert np.abs(ev).max() / np.abs(ev).min() == pytest.approx(10.0, rel=1e-12)


def test_table2_acceleration_is_the_derivative_of_the_rate() -> None:
    A, B, C, D = cases.table2_plant()
    for s in [*FREQS, 0.0, 2.0 - 3.0j]:
        g = _transfer(A, B, C, D, s)[:, 0]
        # d/dt <-> multiplication by s; rounding of a 4x4 solve with entries up to 28
        assert g[1] == pytest.approx(s * g[0], rel=1e-10, abs=1e-12)


def test_table2_controller_stabilises_the_plant() -> None:
    ctrl = cases.table2_controller()
    A, _, _, _ = cases.table2_plant()
    Phi = ctrl["Phi"]
    assert np.max(np.abs(np.linalg.eigvals(Phi))) > 1  # the plant alone is unstable
    eig_cl = np.linalg.eigvals(ctrl["Acl"])
    assert np.max(np.abs(eig_cl)) < 1  # the loop is stable
    # separation principle: the loop's eigenvalues are those of the regulator and observer
    sep = np.r_[
        np.linalg.eigvals(Phi - ctrl["Gamma"] @ ctrl["K"]),
        np.linalg.eigvals(Phi - ctrl["L"] @ ctrl["cq"]),
    ]
    # eigenvalues of an 8x8 non-normal matrix vs two 4x4 ones: ~1e-10 of rounding
    np.testing.assert_allclose(_sorted(eig_cl), _sorted(sep), atol=1e-8)
    # Phi is the exact ZOH transition: its eigenvalues are exp(lambda ts)
    ts = cases.TABLE2_TS
    np.testing.assert_allclose(
        _sorted(np.linalg.eigvals(Phi)), _sorted(np.exp(TABLE2 * ts)), atol=1e-12
    )


def test_table2_closed_loop_data_are_the_plant_response_to_the_applied_input() -> None:
    """Noise-free: the loop only shapes the input, so the outputs are the open-loop plant's
    exact ZOH response to the recorded moment (short record: the plant is unstable)."""
    rec = cases.simulate_table2_closed_loop(
        np.random.default_rng(0), duration=2.0, snr=None, outputs="rate+acc"
    )
    A, B, C, D = cases.table2_plant()
    Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, D), cases.TABLE2_TS, method="zoh")
    _, y, _ = dlsim((Ad, Bd, Cd, Dd, cases.TABLE2_TS), rec.u)
    # same ZOH recursion from two implementations over 500 steps, growth e^(1.2 * 2) ~ 11
    np.testing.assert_allclose(rec.y, y, atol=1e-10 * np.abs(y).max())
    rate = cases.simulate_table2_closed_loop(
        np.random.default_rng(0), duration=2.0, snr=None, outputs="rate"
    )
    np.testing.assert_array_equal(rate.y[:, 0], rec.y[:, 0])
    np.testing.assert_array_equal(rate.u, rec.u)


def test_table2_record_stays_bounded() -> None:
    clean = cases.simulate_table2_closed_loop(np.random.default_rng(4), 30.0, None, "sweep")
    # a stable loop under a bounded sweep: the last third no larger than ~the first
    n = clean.y.shape[0] // 3
    assert np.all(np.isfinite(clean.y))
    assert np.abs(clean.y[-n:]).max() < 3 * np.abs(clean.y[:n]).max()


def test_table2_sensor_noise_has_the_snr() -> None:
    """Sensor noise = measured output - the plant's exact response to the recorded input
    (the loop only shapes the input); its power relative to the noise-free run's."""
    clean = cases.simulate_table2_closed_loop(np.random.default_rng(4), 2.0, None, "sweep")
    noisy = cases.simulate_table2_closed_loop(np.random.default_rng(4), 2.0, 20.0, "sweep")
    A, B, C, D = cases.table2_plant()
    Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, D), cases.TABLE2_TS, method="zoh")
    _, y_plant, _ = dlsim((Ad, Bd, Cd, Dd, cases.TABLE2_TS), noisy.u)
    ratio = np.mean((noisy.y - y_plant) ** 2, axis=0) / np.mean(clean.y**2, axis=0)
    # 501 samples: the variance estimate has a relative standard error sqrt(2/501) = 6.3 %;
    # 25 % is four of them
    np.testing.assert_allclose(ratio, 10 ** (-20 / 10), rtol=0.25)


def test_table2_rejects_unknown_outputs() -> None:
    with pytest.raises(ValueError, match="outputs"):
        cases.simulate_table2_closed_loop(np.random.default_rng(0), 1.0, None, "sweep", "angle")


@pytest.mark.parametrize("name", ["table2-closed-loop", "table2-closed-loop-rate"])
def test_table2_noise_free_data_identify_the_plant(name: str) -> None:
    """Method ``dt`` with the case's options (feedthrough for the acceleration output) on
    noise-free closed-loop data recovers the plant's eigenvalues: the excitation makes the
    closed-loop record informative enough."""
    import hdpbsid

    data = cases.CASES[name](1, None, duration=4.0)
    assert data.options == ({"feedthrough": True} if name == "table2-closed-loop" else {})
    rec = data.estimation
    # noise-free from rest: no mean removal, which would leave an O(1/T) level error
    model = hdpbsid.identify(rec.t, rec.u, rec.y, 4, method="dt", detrend=None, **data.options)
    # PBSID is exact on noise-free ZOH data of the right order; 1e-6 relative leaves room
    # for the conditioning of a plant whose modes span 5.9 to 28 rad/s over 4 s (7e-10 and
    # 4e-9 seen for the two output choices)
    errs = hdpbsid.eigenvalue_errors(model.eigenvalues, TABLE2)
    assert errs.max() < 1e-6
