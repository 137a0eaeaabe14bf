"""The regression table's record generator, one run and its comparison (``bench/regression.py``).

Oracles: ``scipy.signal.lsim`` (input linear between samples) and ``dlsim`` on
``cont2discrete`` (held input) for the exact simulation; the closed-loop matrix
``Phi - Gamma K C`` of static output feedback for the loop; hand-made CSV tables whose
verdicts follow from the margin rule by arithmetic.  No timing is asserted.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.signal import cont2discrete, dlsim, lsim
from threadpoolctl import threadpool_limits

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path.insert(0, str(BENCH))

import regression as R  # noqa: E402

# a lightly damped pair and a real pole a decade faster, two inputs, one output
A = np.array([[-0.3, 2.0, 0.0], [-2.0, -0.3, 0.0], [0.0, 0.0, -20.0]])
B = np.array([[0.0, 1.0], [1.0, 0.5], [20.0, -10.0]])
C = np.array([[1.0, 0.5, 1.0]])
DT = 0.01
# agreement of two exact simulations of one linear system: rounding of a few thousand
# steps of a contraction, far below any modelling difference
SIM_TOL = 1e-9


@pytest.fixture(autouse=True)
def _one_blas_thread() -> Iterator[None]:
    """As the bench runs its records (small matrices: threads only add contention)."""
    with threadpool_limits(limits=1):
        yield


def _inputs(ns: int) -> np.ndarray:
    t = DT * np.arange(ns)
    return np.stack([np.sin(1.3 * t) + 0.2 * np.cos(7 * t), np.cos(0.7 * t)], 1)


def test_specs_cover_the_set_once() -> None:
    specs = R.record_specs()
    ids = [s.id for s in specs]
    assert len(ids) == len(set(ids))
    n_cases = sum(s.source == "case" for s in specs)
    per_case = len(R.SEEDS) * len(R.CASE_SNRS)
    own = len(R.SNR_INDEPENDENT)
    assert n_cases == (len(R.CASES) - own) * per_case + own * len(R.SEEDS)
    fams = [s.family for s in specs if s.source == "random"]
    assert len(fams) == R.N_RANDOM >= 100
    # the strata are filled equally: every family, and every order within a family
    assert {f: fams.count(f) for f in R.RANDOM_FAMILIES} == dict.fromkeys(
        R.RANDOM_FAMILIES, R.N_RANDOM // 4
    )
    orders = [R._stratum(i)[0] for i in range(R.N_RANDOM)]
    assert sorted(set(orders)) == [1, 2, 3, 4, 5, 6]
    assert {s.name for s in specs if s.source == "daisy"} == set(R.realdata.RECORDS)
    assert [s.id for s in R.select(specs, ["daisy"])] == [f"daisy/{n}" for n in R.realdata.RECORDS]
    assert R.select(specs, ["stiff/40dB/*"]) == [s for s in specs if s.id.startswith("stiff/40dB/")]


@pytest.mark.parametrize("index", [0, 2, 3, 14])
def test_random_record_is_reproducible_and_as_specified(index: int) -> None:
    """Seeded: the same arrays on every call; the truth is stable and minimal enough, the
    sampling resolves the fastest mode, the length is in range, the loop is stable."""
    r1, r2 = R.random_record(index), R.random_record(index)
    for name in ("t", "u", "y", "A", "B", "C", "u_val", "y_val"):
        np.testing.assert_array_equal(getattr(r1, name), getattr(r2, name))
    order, loop, io = R._stratum(index)
    ev = np.linalg.eigvals(r1.A)
    assert ev.size == order and np.all(ev.real < 0)
    w = np.abs(ev)
    assert w.max() / w.min() <= 100.0 * (1 + 1e-9)  # at most two decades
    assert w.max() * r1.dt == pytest.approx(R.FAST_MODE_STEP)
    assert R.SAMPLES_RANGE[0] <= r1.t.size <= R.SAMPLES_RANGE[1]
    assert np.all(np.diff(r1.t) > 0)
    m, l = r1.u.shape[1], r1.y.shape[1]
    assert (m, l) == (1, 1) if io == "siso" else (m * l > 1 and m <= 2 and l <= 3)
    assert r1.loop.startswith(loop)
    assert R.hankel_ratio(r1.A, r1.B, r1.C) >= R.MIN_HSV_RATIO
    assert 10 <= r1.snr <= 40
    assert np.all(np.isfinite(r1.y)) and np.all(np.isfinite(r1.y_val))


def test_random_records_differ() -> None:
    a, b = R.random_record(0), R.random_record(24)  # the same stratum, another draw
    assert R._stratum(0) == R._stratum(24)
    assert not np.array_equal(np.linalg.eigvals(a.A), np.linalg.eigvals(b.A))


def test_held_input_simulation_matches_scipy() -> None:
    ns = 800
    t, u = DT * np.arange(ns), _inputs(ns)
    Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, np.zeros((1, 2))), DT, method="zoh")
    ref = dlsim((Ad, Bd, Cd, Dd, DT), u)[1]
    for uniform in (True, False):  # one step's matrices, and every step's own
        y = R.simulate_open(A, B, C, t, u, "zoh", uniform)
        np.testing.assert_allclose(y, ref, rtol=0, atol=SIM_TOL * np.abs(ref).max())


def test_linear_input_simulation_matches_lsim() -> None:
    ns = 800
    t, u = DT * np.arange(ns), _inputs(ns)
    ref = lsim((A, B, C, np.zeros((1, 2))), u, t, interp=True)[1].reshape(-1, 1)
    for uniform in (True, False):
        y = R.simulate_open(A, B, C, t, u, "foh", uniform)
        np.testing.assert_allclose(y, ref, rtol=0, atol=1e-7 * np.abs(ref).max())


def test_static_feedback_loop_is_the_closed_loop_system() -> None:
    """Noise-free static feedback ``u = r - K y``: ``x+ = (Phi - Gamma K C) x + Gamma r``."""
    ns = 600
    t, r = DT * np.arange(ns), _inputs(ns)
    K = np.array([[0.5], [-0.3]])
    u, y = R.simulate_loop(A, B, C, t, r, np.zeros((ns, 1)), K, None, True)
    Ad, Bd, *_ = cont2discrete((A, B, C, np.zeros((1, 2))), DT, method="zoh")
    Acl = Ad - Bd @ K @ C
    ref = dlsim((Acl, Bd, C, np.zeros((1, 2)), DT), r)[1]
    np.testing.assert_allclose(y, ref, rtol=0, atol=SIM_TOL * np.abs(ref).max())
    np.testing.assert_allclose(u, r - y @ K.T, rtol=0, atol=1e-12)
    steps = np.array([DT, DT, DT])
    assert R.loop_is_stable(A, B, C, K, None, steps)
    # a gain that pushes a sampled eigenvalue out of the unit circle: -20 with a large
    # negative feedback through the fast pole's input (positive loop gain of 1e3)
    assert not R.loop_is_stable(A, B, C, np.array([[0.0], [-1e3]]), None, steps)


def test_an_exception_is_a_row() -> None:
    row = R.run_record(R.RecordSpec("x/1", "x", "case", "no-such-case", 0, 20.0))
    assert "no-such-case" in row["error"] and row["method"] == ""


def _row(id_: str, **kw: object) -> dict[str, object]:
    row = dict.fromkeys(R.CSV_FIELDS, "")
    row.update(
        id=id_,
        family="f",
        true_order=2,
        method="hermite",
        order=2,
        order_found=True,
        err_pct=1.0,
        fit_pct=90.0,
        stable=True,
        true_stable=True,
        cpu_s=0.5,
    )
    row.update(kw)
    return row


def _write(rows: list[dict[str, object]], path: Path) -> list[dict[str, str]]:
    R.write_csv(rows, path)
    return R.read_csv(path)


def test_compare_flags_the_worse_rows_only(tmp_path: Path) -> None:
    old = _write([_row(f"r{i}") for i in range(6)], tmp_path / "old.csv")
    e = 1.0 * (1 + R.MARGIN_REL) + R.MARGIN_ERR_PP  # the margin's edge above err 1 %
    new = _write(
        [
            _row("r0"),  # equal
            _row("r1", err_pct=e * 0.999),  # within the margin
            _row("r2", err_pct=e * 1.01),  # worse
            _row("r3", order=3, order_found=False, err_pct=""),  # true order lost
            _row(
                "r4", error="ValueError: boom", method="", order="", order_found=""
            ),  # newly failing
            _row("r5", err_pct=0.5),  # better
        ],
        tmp_path / "new.csv",
    )
    changes, tot, worse = R.compare_tables(old, new)
    verdicts = {i: v for i, v, _ in changes}
    assert verdicts == {"r2": "worse", "r3": "worse", "r4": "worse", "r5": "better"}
    assert worse
    assert tot["found"][:2] == (6, 4) and tot["failed"][:2] == (0, 1)
    # a table against itself: nothing changes, no total worse
    changes, _, worse = R.compare_tables(old, old)
    assert changes == [] and not worse


def test_totals_guard_ignores_newly_found_records(tmp_path: Path) -> None:
    """A record whose order is newly found (with a large error) is better, and does not
    raise the error totals, which are over the records scored in both tables."""
    old = _write([_row("a"), _row("b", order=1, order_found=False, err_pct="")], tmp_path / "o.csv")
    new = _write([_row("a"), _row("b", err_pct=50.0)], tmp_path / "n.csv")
    changes, tot, worse = R.compare_tables(old, new)
    assert [(i, v) for i, v, _ in changes] == [("b", "better")]
    assert tot["err_median"][:2] == (1.0, 1.0) and not worse


@given(
    st.floats(0, 1e3, allow_nan=False),
    st.floats(0, 1e3, allow_nan=False),
    st.floats(0, 10, allow_nan=False),
)
def test_margin_is_antisymmetric(a: float, b: float, floor: float) -> None:
    assert R.beyond_margin(a, b, floor) == -R.beyond_margin(b, a, floor)
    assert R.beyond_margin(a, a, floor) == 0


def test_main_runs_a_record(tmp_path: Path) -> None:
    """One quick record through the command line: the CSV and its metadata are written,
    and the table compared with itself has no change."""
    out = tmp_path / "t.csv"
    assert R.main(["--subset", "random/000", "--out", str(out)]) == 0
    rows = R.read_csv(out)
    assert [r["id"] for r in rows] == ["random/000"] and rows[0]["error"] == ""
    assert rows[0]["order"].isdigit() and rows[0]["order_found"] in ("True", "False")
    assert rows[0]["true_order"] == "1" and rows[0]["family"] == "random-open-siso"
    meta = json.loads(out.with_suffix(".json").read_text())
    assert len(meta["commit"]) == 40 and meta["records"] == 1
    assert R.compare_tables(rows, rows)[0] == []


def test_main_exit_status_is_the_guard(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--compare``: status 1 when a guarded total is worse, 0 when not (the table run
    is replaced by fixed rows: only the guard is under test)."""
    base = tmp_path / "base.csv"
    R.write_csv([_row("a"), _row("b")], base)
    for new, status in (([_row("a"), _row("b")], 0), ([_row("a"), _row("b", err_pct=9.0)], 1)):
        monkeypatch.setattr(R, "run_table", lambda specs, n_jobs, rows=new: rows)
        args = ["--subset", "daisy", "--out", str(tmp_path / "new.csv"), "--compare", str(base)]
        assert R.main(args) == status
