"""The benchmark's data sets (``bench/cases.py``) and the scoring plumbing of
``bench/peers.py``, checked without the peers installed (they are an optional extra:
``bench/peers.py`` imports them only inside the functions that run them).

Oracles: the analytic eigenvalues of each benchmark system (DESIGN.md, "Benchmark
systems"), exact ZOH sampling of a known model, and method ``dt`` on noise-free data.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parent.parent / "bench"
sys.path.insert(0, str(BENCH))

import cases  # noqa: E402
import peers  # noqa: E402

from hdpbsid.conversion import c2d  # noqa: E402

SECOND_ORDER = np.array([-0.4 + np.sqrt(3.84) * 1j, -0.4 - np.sqrt(3.84) * 1j])
PBSID = 0.67 * np.array([1 + 1j, 1 - 1j, -1 + 1j, -1 - 1j])

# shorter records for the two slow generators (the properties checked do not depend on length)
SHORT = {"nonuniform": {"T": 4.0, "n_samples": 401}, "quadrotor": {"duration": 4.0}}


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
        # DESIGN.md states the quadrotor eigenvalues to two decimals: half a unit of 0.01
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


def test_readme_section_replaces_only_between_markers(tmp_path: Path) -> None:
    readme = tmp_path / "README.md"
    readme.write_text(f"before\n{peers.README_BEGIN}\nold\n{peers.README_END}\nafter\n")
    peers.write_readme(f"{peers.README_BEGIN}\nnew\n{peers.README_END}", readme)
    assert readme.read_text() == f"before\n{peers.README_BEGIN}\nnew\n{peers.README_END}\nafter\n"
