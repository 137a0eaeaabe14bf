"""Records read in chunks (hdpbsid.methods.chunked, hdpbsid.data.io.open_chunked).

Oracles: the in-memory HD-PBSID (identify_hermite, a separate code path: whole-record
spectra, split_windows, project_blocks) on the same samples, and the true eigenvalues of
the simulated system.
"""

from __future__ import annotations

import dataclasses

import h5py
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from chunked_data import FS, _record, _resonance

from hdpbsid.bases.basis_domain import BasisTooSmall, data_bandwidth
from hdpbsid.bases.segments import window_rule
from hdpbsid.core import streamed
from hdpbsid.data.chunked import ChunkedRecord
from hdpbsid.data.io import open_chunked
from hdpbsid.methods.chunked import averaged_spectra, identify_chunked
from hdpbsid.methods.hermite import identify_hermite
from hdpbsid.models.metrics import eigenvalue_errors


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.abs(a - b).max() / np.abs(b).max())


def _signed(model, ref) -> dict[str, np.ndarray]:
    """``model``'s A, B, C, K in ``ref``'s state signs: ``T = diag(+-1)`` with each
    state's sign read off the largest entry of ``C``'s column.  The chunked core signs
    the singular vectors of ``Gamma L Z_p`` by its own rule, LAPACK's in-memory SVD by
    another; only a sign flip per state is aligned, any other difference stays."""
    j = np.argmax(np.abs(ref.C), axis=0)
    cols = np.arange(ref.C.shape[1])
    T = np.diag(np.sign(model.C[j, cols] * ref.C[j, cols]))
    return {"A": T @ model.A @ T, "B": T @ model.B, "C": model.C @ T, "K": T @ model.K}


def _diff(model, ref, names=("A", "B", "C", "K")) -> dict[str, float]:
    mm = _signed(model, ref)
    return {k: _rel(mm[k], getattr(ref, k)) for k in names}


@pytest.fixture(scope="module")
def data() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return _record(40_000)


@pytest.fixture(scope="module")
def in_memory(data):
    return identify_hermite(*data, order=2)


# the two paths do the same arithmetic up to summation order in the projection (one map
# per batch vs per-window products): rounding, amplified by the conditioning of the
# least-squares steps, stays far below 1e-8
SAME = 1e-8


def test_default_windows_match_in_memory(data, in_memory) -> None:
    t, u, y = data
    m = identify_chunked(ChunkedRecord.from_arrays(u, y, 1.0 / FS), order=2, chunk_samples=7000)
    assert in_memory.options["n_segments"] > 1  # the record is windowed by the default
    assert m.options["n_segments"] == in_memory.options["n_segments"]
    assert m.options["chunked"]["batches"] > 1  # several reads
    assert max(_diff(m, in_memory).values()) < SAME, _diff(m, in_memory)
    # the input hold by the same criterion (the VARX AIC, from the streamed factors)
    assert m.options["input_hold"] == in_memory.options["input_hold"]
    crit, ref = m.options["input_hold_criterion"], in_memory.options["input_hold_criterion"]
    assert set(crit) == set(ref) == {"zoh", "foh"}
    for h in ref:
        assert abs(crit[h] - ref[h]) < SAME * abs(ref[h]), (crit, ref)
    # and both are the true system: 40 s of a 5 Hz resonance at 20 dB
    err = eigenvalue_errors(m.eigenvalues, np.linalg.eigvals(_resonance())).max()
    assert err < 0.01  # 1 %: measured 0.05-0.2 % on such records; 5x margin


def test_files_match_in_memory(tmp_path, data, in_memory) -> None:
    t, u, y = data
    h5 = tmp_path / "r.h5"
    with h5py.File(h5, "w") as f:
        f["sig/u"] = u[:, 0]
        f["sig/y"] = y[:, 0]
    npy = tmp_path / "r.npy"
    np.save(npy, np.hstack([y, u]))
    par = tmp_path / "r.parquet"
    pq.write_table(pa.table({"u": u[:, 0], "y": y[:, 0]}), par, row_group_size=3001)
    recs = [
        open_chunked(h5, ["sig/u"], ["sig/y"], dt=1.0 / FS),
        open_chunked(npy, [1], [0], fs=FS),
        open_chunked(par, ["u"], ["y"], dt=1.0 / FS),
    ]
    for rec in recs:
        assert (rec.ns, rec.m, rec.l) == (t.size, 1, 1)
        m = identify_chunked(rec, order=2, chunk_samples=5000)
        assert _diff(m, in_memory)["A"] < SAME
    # reads that straddle Parquet row groups and HDF5 chunks return the exact samples
    for a, b in ((0, 1), (2999, 3003), (5999, 12_002), (39_000, 40_000)):
        for rec in recs:
            ru, ry = rec.read(a, b)
            np.testing.assert_array_equal(ru, u[a:b])
            np.testing.assert_array_equal(ry, y[a:b])


def test_dask_delayed_matches_serial(data, in_memory) -> None:
    t, u, y = data
    rec = ChunkedRecord.from_arrays(u, y, 1.0 / FS)
    m = identify_chunked(rec, order=2, chunk_samples=9000, use_dask=True)
    assert _diff(m, in_memory)["A"] < SAME


def test_given_window_and_N_match_in_memory(data) -> None:
    t, u, y = data
    ref = identify_hermite(t, u, y, order=2, window=3.0, N=240)
    m = identify_chunked(
        ChunkedRecord.from_arrays(u, y, 1.0 / FS), order=2, window=3.0, N=240, chunk_samples=4000
    )
    assert ref.options["n_segments"] == m.options["n_segments"] == 13
    assert _diff(m, ref)["A"] < SAME


def test_averaged_spectrum_bandwidth_close_to_whole_record() -> None:
    t, u, y = _record(2**17, seed=3)
    rec = ChunkedRecord.from_arrays(u, y, 1.0 / FS)
    w, Pu, Py = averaged_spectra(rec, spectrum_samples=2**14)
    from hdpbsid.bases.basis_domain import spectra_data_bandwidth

    whole = data_bandwidth(t, u, y)
    chunked = spectra_data_bandwidth(w, Pu, w, Py)
    # eight averaged periodograms of 16 s vs one of 131 s: both locate the 99 % energy
    # point of the 20 Hz Butterworth input within their resolution and variance (a few %)
    assert abs(chunked - whole) / whole < 0.05
    assert 2 * np.pi * 15 < chunked < 2 * np.pi * 25  # the input's cutoff is 20 Hz


def test_window_rule_is_the_in_memory_rule(data) -> None:
    t, u, y = data
    from hdpbsid.bases.segments import default_window
    from hdpbsid.data.records import as_records

    recs = as_records(t, u, y)
    expected = default_window(recs, 300.0, 3, 4)
    assert window_rule(7.0, t[-1], 300.0, 3, 4)[0] != expected[0]  # depends on w_low
    w_low = expected[1]["lowest_significant_frequency"]
    assert window_rule(w_low, t[-1], 300.0, 3, 4) == expected


def test_bad_input() -> None:
    u, y = np.zeros((100, 1)), np.ones((100, 1))
    with pytest.raises(TypeError, match="ChunkedRecord"):
        identify_chunked((np.arange(100.0), u, y), order=2)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="dt"):
        ChunkedRecord.from_arrays(u, y, -1.0)
    with pytest.raises(ValueError, match="u must be"):
        ChunkedRecord.from_arrays(np.zeros(99), y, 0.1)
    bad = y.copy()
    bad[57] = np.nan
    with pytest.raises(ValueError, match="sample 57"):
        identify_chunked(ChunkedRecord.from_arrays(u, bad, 0.1), order=2)
    with pytest.raises(ValueError, match="window"):
        identify_chunked(ChunkedRecord.from_arrays(u, y, 0.1), order=2, window="long")


def test_open_chunked_errors(tmp_path) -> None:
    csv = tmp_path / "r.csv"
    csv.write_text("u,y\n1,2\n")
    with pytest.raises(ValueError, match="chunked reading supports"):
        open_chunked(csv, ["u"], ["y"], dt=0.1)
    npy = tmp_path / "r.npy"
    np.save(npy, np.zeros((10, 2)))
    with pytest.raises(ValueError, match="column index 5"):
        open_chunked(npy, [0], [5], dt=0.1)
    with pytest.raises(ValueError, match="exactly one"):
        open_chunked(npy, [0], [1])
    with pytest.raises(ValueError, match="not both"):
        open_chunked(npy, [0], [1], dt=0.1, fs=10.0)
    with pytest.raises(ValueError, match="dt must be a positive"):
        open_chunked(npy, [0], [1], dt=-0.1)
    with pytest.raises(TypeError, match="fs must be a positive number"):
        open_chunked(npy, [0], [1], fs="100")
    h5 = tmp_path / "r.h5"
    with h5py.File(h5, "w") as f:
        f["u"] = np.zeros(10)
        f["y"] = np.zeros(11)
    with pytest.raises(ValueError, match="different lengths"):
        open_chunked(h5, ["u"], ["y"], dt=0.1)
    with pytest.raises(ValueError, match="no dataset 'v'"):
        open_chunked(h5, ["v"], ["y"], dt=0.1)


def test_time_series_without_input_matches_in_memory(data) -> None:
    t, _, y = data
    ref = identify_hermite(t, None, y, order=2, window=4.0)
    m = identify_chunked(
        ChunkedRecord.from_arrays(None, y, 1.0 / FS), order=2, window=4.0, chunk_samples=6000
    )
    assert m.B.shape == (2, 0)
    assert max(_diff(m, ref, ("A", "C", "K")).values()) < SAME


def _arrays(x):
    """Every numpy array inside ``x`` (dataclasses, dicts, lists, tuples)."""
    if isinstance(x, np.ndarray):
        yield x
    elif dataclasses.is_dataclass(x):
        for f in dataclasses.fields(x):
            yield from _arrays(getattr(x, f.name))
    elif isinstance(x, dict):
        for v in x.values():
            yield from _arrays(v)
    elif isinstance(x, list | tuple):
        for v in x:
            yield from _arrays(v)


def test_driver_statistics_do_not_grow_with_the_record(monkeypatch, data) -> None:
    """Everything the batches hand back and the driver combines is a fixed-size factor:
    the largest array is the same for a record twice as long (twice the batches)."""
    t, u, y = data
    real = streamed.merge
    seen: list[int] = []

    def spy(a, b):
        out = real(a, b)
        seen.extend(arr.size for arr in _arrays([a, b, out]))
        return out

    monkeypatch.setattr(streamed, "merge", spy)
    largest, batches = {}, {}
    for ns in (20_000, 40_000):
        seen.clear()
        rec = ChunkedRecord.from_arrays(u[:ns], y[:ns], 1.0 / FS)
        m = identify_chunked(rec, order=2, window=2.0, chunk_samples=4000)
        largest[ns], batches[ns] = max(seen), m.options["chunked"]["batches"]
    assert batches[40_000] >= 2 * batches[20_000] - 1  # the longer record: more batches
    assert largest[40_000] == largest[20_000]
    # and that size is a (rows x rows) factor of the core's regressions, not columns:
    # p (m + l) + l = 9 rows of the VARX, 2 f l + m + l = 10 of the A, B, K step
    assert largest[40_000] <= 10 * 10


@pytest.mark.parametrize(
    ("setting", "core"), [("stable_k", "streamed"), ("feedthrough", "in memory")]
)
def test_other_core_settings_match_in_memory(data, setting, core) -> None:
    t, u, y = data
    ref = identify_hermite(t, u, y, order=2, window=4.0, **{setting: True})
    rec = ChunkedRecord.from_arrays(u, y, 1.0 / FS)
    m = identify_chunked(rec, order=2, window=4.0, chunk_samples=6000, **{setting: True})
    assert m.options["chunked"]["core"] == core
    assert max(_diff(m, ref).values()) < SAME, _diff(m, ref)
    if setting == "feedthrough":
        assert _rel(m.D, ref.D) < SAME


def test_tasks_pickle_for_a_process_scheduler(data, in_memory) -> None:
    """``dask.distributed`` and Dask's process scheduler ship every task -- record address,
    bases, lag operators -- to other processes by (cloud)pickle; the result must equal the
    in-process one (same arithmetic, other process)."""
    import dask

    t, u, y = data
    rec = ChunkedRecord.from_arrays(u, y, 1.0 / FS)
    with dask.config.set(scheduler="processes", num_workers=2):
        m = identify_chunked(rec, order=2, chunk_samples=9000, use_dask=True)
    assert _diff(m, in_memory)["A"] < SAME


def test_order_beyond_the_default_window_is_a_typed_error(data) -> None:
    """Order 40 from one output needs ``f = p >= 40`` (``f l >= n``), beyond what the
    default precision rule allows this basis: the same typed error as the in-memory path,
    with the window the order needs, so a caller can retry with ``p`` given."""
    t, u, y = data
    with pytest.raises(BasisTooSmall, match="too small") as info:
        identify_chunked(ChunkedRecord.from_arrays(u, y, 1.0 / FS), order=40)
    assert info.value.p_needed == 40
    assert isinstance(info.value, ValueError)
