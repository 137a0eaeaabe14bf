"""Monte Carlo engine of the studies: per-task seeds, backends (serial,
joblib, Dask LocalCluster) giving the same numbers, resume, failures as data, and the
argument checks of the public API."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import hdpbsid.studies as S
from hdpbsid.studies.runner import RESULTS_FILE, execute_task, run_tasks, task_rng

# a cheap study: second-order record of 1001 samples, two methods sharing each record
SMALL = {"snrs": (20.0,), "methods": ("hermite", "laguerre"), "samples": 1001}


def _numbers(records: list[dict]) -> list[dict]:
    """Records without the wall time (the only field allowed to differ between runs)."""
    return [{k: v for k, v in r.items() if k != "time"} for r in records]


def _leaves(x, path=""):
    if isinstance(x, dict):
        for k in sorted(x):
            yield from _leaves(x[k], f"{path}/{k}")
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from _leaves(v, f"{path}/{i}")
    else:
        yield path, x


def _assert_same_numbers(a: list[dict], b: list[dict]) -> None:
    """Same records: bit-identical when every process runs one BLAS thread (``make test``
    sets OPENBLAS_NUM_THREADS=1; measured identical on 1437 table1 tasks); a threaded BLAS
    in the serial process reorders sums, so floats may differ in the last bits: rtol 1e-9."""
    la, lb = list(_leaves(_numbers(a))), list(_leaves(_numbers(b)))
    assert [p for p, _ in la] == [p for p, _ in lb]
    for (p, x), (_, y) in zip(la, lb, strict=True):
        if isinstance(x, float) and isinstance(y, float):
            assert x == pytest.approx(y, rel=1e-9, abs=1e-12), p
        else:
            assert x == y, p


@pytest.fixture(scope="module")
def serial() -> S.StudyResult:
    return S.run_study("snr", runs=2, seed=7, progress=False, **SMALL)


def test_records_are_plain_json_and_ordered(serial: S.StudyResult) -> None:
    recs = serial.records
    assert [(r["case"]["method"], r["run"]) for r in recs] == [
        ("hermite", 0),
        ("hermite", 1),
        ("laguerre", 0),
        ("laguerre", 1),
    ]
    for r in recs:
        assert r["ok"], r
        json.dumps(r, allow_nan=False)  # plain data, standard JSON
        ev = r["result"]["eigenvalues"]
        assert len(ev) == 2 and all(len(z) == 2 for z in ev)  # [re, im] pairs
        assert r["result"]["options"]["method"] in ("hermite", "laguerre")
        assert r["time"] > 0


def test_methods_see_the_same_record_per_run(serial: S.StudyResult) -> None:
    # same seed, data settings and run -> same generator, whatever the method
    h, lag = serial.records[0], serial.records[2]
    assert h["case"]["data"] == lag["case"]["data"] and h["run"] == lag["run"] == 0
    r1 = task_rng(7, h["case"], 0).standard_normal(3)
    r2 = task_rng(7, lag["case"], 0).standard_normal(3)
    np.testing.assert_array_equal(r1, r2)
    assert not np.array_equal(r1, task_rng(7, h["case"], 1).standard_normal(3))


def test_numbers_do_not_depend_on_the_other_cases(serial: S.StudyResult) -> None:
    # a study with an extra SNR case and only one method reproduces the shared tasks
    other = S.run_study(
        "snr", runs=1, seed=7, progress=False, snrs=(40.0, 20.0), methods=("hermite",), samples=1001
    )
    mine = [r for r in other.records if r["case"]["data"]["snr_db"] == 20.0]
    _assert_same_numbers(mine, serial.records[:1])


def test_joblib_equals_serial(serial: S.StudyResult) -> None:
    par = S.run_study("snr", runs=2, seed=7, jobs=2, progress=False, **SMALL)
    _assert_same_numbers(par.records, serial.records)


def test_dask_local_cluster_equals_serial(serial: S.StudyResult) -> None:
    import dask.distributed as distributed  # the cluster extra, installed by make test

    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        # by address (the runner opens and closes its own client) ...
        by_addr = S.run_study(
            "snr", runs=2, seed=7, scheduler=cluster.scheduler_address, progress=False, **SMALL
        )
        # ... and with a client object the caller owns (left open)
        with distributed.Client(cluster) as client:
            by_client = S.run_study(
                "snr", runs=2, seed=7, scheduler=client, progress=False, **SMALL
            )
            assert client.status == "running"
    _assert_same_numbers(by_addr.records, serial.records)
    _assert_same_numbers(by_client.records, serial.records)


def test_resume_more_and_fewer_runs(serial: S.StudyResult, tmp_path: Path) -> None:
    out = tmp_path / "snr"
    first = S.run_study("snr", runs=1, seed=7, out=out, progress=False, **SMALL)
    lines = (out / RESULTS_FILE).read_text().splitlines()
    assert len(lines) == 2
    more = S.run_study("snr", runs=2, seed=7, out=out, progress=False, **SMALL)
    lines = (out / RESULTS_FILE).read_text().splitlines()
    assert len(lines) == 4  # only the two run-1 tasks were computed
    # the run-0 records are reused as they were (same wall time: not recomputed)
    assert more.records[0] == first.records[0] and more.records[2] == first.records[1]
    _assert_same_numbers(more.records, serial.records)
    fewer = S.run_study("snr", runs=1, seed=7, out=out, progress=False, **SMALL)
    assert len((out / RESULTS_FILE).read_text().splitlines()) == 4
    assert fewer.records == first.records
    # another seed is a different study: nothing reused
    S.run_study("snr", runs=1, seed=8, out=out, progress=False, **SMALL)
    assert len((out / RESULTS_FILE).read_text().splitlines()) == 6
    # resume=False starts afresh
    S.run_study("snr", runs=1, seed=7, out=out, progress=False, resume=False, **SMALL)
    assert len((out / RESULTS_FILE).read_text().splitlines()) == 2
    for name in ("summary.csv", "summary.json", "records.csv", "snr.png"):
        assert (out / name).is_file(), name
    meta = json.loads((out / "summary.json").read_text())
    assert meta["settings"]["runs"] == 1 and meta["study"] == "snr"


def test_interrupted_last_line_is_skipped(tmp_path: Path) -> None:
    out = tmp_path / "cut"
    S.run_study("snr", runs=1, seed=3, out=out, progress=False, **SMALL)
    path = out / RESULTS_FILE
    lines = path.read_text().splitlines()
    path.write_text(lines[0] + "\n" + lines[1][: len(lines[1]) // 2])  # a torn write
    with pytest.warns(RuntimeWarning, match="unreadable"):
        res = S.run_study("snr", runs=1, seed=3, out=out, progress=False, **SMALL)
    assert all(r["ok"] for r in res.records)


def _boom(case: dict, rng: np.random.Generator) -> dict:
    raise np.linalg.LinAlgError("singular matrix in the test")


def test_failures_are_recorded_not_raised() -> None:
    rec = execute_task(_boom, "test", 0, {"x": 1}, 0)
    assert rec["ok"] is False
    assert rec["error_type"] == "LinAlgError" and "singular" in rec["error"]
    recs = run_tasks(_boom, [{"x": 1}, {"x": 2}], 2, progress=False)
    assert len(recs) == 4 and not any(r["ok"] for r in recs)
    # a real one: N = 10 Hermite functions are refused for this record (band too small)
    res = S.basis_order(runs=1, basis_sizes=(10,), samples=1001, progress=False)
    (r,) = res.records
    assert not r["ok"] and r["error_type"] == "ValueError" and "N=10" in r["error"]
    assert res.summary[0]["failed"] == 1


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="name: unknown study 'nope'"):
        S.run_study("nope")
    with pytest.raises(TypeError, match="name must be a study name"):
        S.run_study(3)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="runs must be >= 1"):
        S.run_study("snr", runs=0)
    with pytest.raises(TypeError, match="runs must be an integer"):
        S.run_study("snr", runs=2.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="jobs must be >= 1"):
        S.run_study("snr", runs=1, jobs=0, **SMALL)
    with pytest.raises(ValueError, match="seed must be a non-negative integer"):
        S.run_study("snr", runs=1, seed=-1, **SMALL)
    with pytest.raises(TypeError, match=r"unknown setting\(s\) \['snr'\]"):
        S.run_study("snr", snr=3)
    with pytest.raises(ValueError, match="methods must be names from"):
        S.snr(runs=1, methods=("bogus",))
    with pytest.raises(ValueError, match="scheduler must be an address"):
        S.run_study("snr", runs=1, scheduler="localhost:8786", progress=False, **SMALL)
    with pytest.raises(TypeError, match="scheduler must be an address string"):
        S.run_study("snr", runs=1, scheduler=8786, progress=False, **SMALL)
    with pytest.raises(ValueError, match="outputs must be names"):
        S.table1(runs=1, outputs=("q", "pitch"))


def test_registry_and_functions() -> None:
    assert set(S.STUDIES) == {"snr", "samples", "basis_order", "operator", "table1", "quadrotor"}
    assert S.get_study("basis-order") is S.STUDIES["basis_order"]
    for key, study in S.STUDIES.items():
        fn = getattr(S, key)
        assert callable(fn) and study.title in (fn.__doc__ or "")
        assert study.defaults["runs"] >= 1


@pytest.mark.slow
def test_dask_worker_processes_equal_serial(serial: S.StudyResult) -> None:
    # separate worker processes: the task functions travel by reference (module-level)
    import dask.distributed as distributed  # the cluster extra, installed by make test

    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        res = S.run_study(
            "snr", runs=2, seed=7, scheduler=cluster.scheduler_address, progress=False, **SMALL
        )
    _assert_same_numbers(res.records, serial.records)
