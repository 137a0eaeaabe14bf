"""Reading measured records (hdpbsid.data.io) and the CLI on them: formats, bad files, --dt."""

from __future__ import annotations

import importlib
import json
import re
from pathlib import Path

import h5py
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.io import savemat

from hdpbsid.cli import main
from hdpbsid.data import csv_reader
from hdpbsid.data.io import read_columns, read_record
from hdpbsid.models.model import StateSpaceModel

REG = importlib.import_module("hdpbsid.methods.registry")
DATA = Path(__file__).resolve().parents[3] / "bench" / "data"

RNG = np.random.default_rng(7)
T = np.arange(50) * 0.02
U = RNG.standard_normal(50)
Y = RNG.standard_normal(50)


def _write(path: Path, cols: dict[str, np.ndarray]) -> Path:
    suffix = path.suffix
    if suffix == ".csv":
        names = list(cols)
        rows = np.column_stack([cols[n] for n in names])
        np.savetxt(path, rows, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    elif suffix == ".mat":
        savemat(path, cols)
    elif suffix == ".npz":
        np.savez(path, **cols)
    elif suffix == ".parquet":
        pq.write_table(pa.table(cols), path)
    elif suffix == ".h5":
        with h5py.File(path, "w") as f:
            for k, v in cols.items():
                f[k] = v
    return path


@pytest.mark.parametrize("suffix", [".csv", ".mat", ".npz", ".parquet", ".h5"])
def test_round_trip(tmp_path: Path, suffix: str) -> None:
    path = _write(tmp_path / f"rec{suffix}", {"time": T, "force": U, "pos": Y})
    rec = read_record(path, ["force"], ["pos"], time="time")
    # 17 significant digits in CSV and binary formats elsewhere: exact round trips
    np.testing.assert_array_equal(rec.t, T)
    np.testing.assert_array_equal(rec.u[:, 0], U)
    np.testing.assert_array_equal(rec.y[:, 0], Y)
    assert (rec.inputs, rec.outputs, rec.time) == (["force"], ["pos"], "time")


def test_dt_and_fs_build_the_time_vector(tmp_path: Path) -> None:
    path = _write(tmp_path / "r.npz", {"u": U, "y": Y})
    np.testing.assert_allclose(read_record(path, ["u"], ["y"], time=None, dt=0.5).t,
                               0.5 * np.arange(50))  # fmt: skip
    # fs = 4 Hz is dt = 0.25 s; 1/4 is exact in binary
    np.testing.assert_array_equal(
        read_record(path, ["u"], ["y"], time=None, fs=4.0).t, 0.25 * np.arange(50)
    )
    with pytest.raises(ValueError, match="not both"):
        read_record(path, ["u"], ["y"], time="t", dt=0.5)
    with pytest.raises(ValueError, match="dt must be a positive"):
        read_record(path, ["u"], ["y"], time=None, dt=-1.0)
    with pytest.raises(ValueError, match=r"unknown column\(s\) \['t'\].*--dt"):
        read_record(path, ["u"], ["y"])


BAD_CSV = {
    "missing column": ("t,u,z\n0,1,2\n1,2,3\n", "unknown column"),
    "text in a column": ("t,u,y\n0,1,2\n1,abc,3\n", "line 3, column 'u': not a number: 'abc'"),
    "empty cell": ("t,u,y\n0,1,2\n1,,3\n", "line 3, column 'u': missing value"),
    "NaN": ("t,u,y\n0,1,2\n1,nan,3\n", "line 3, column 'u': 'nan' is NaN"),
    "unsorted times": ("t,u,y\n0,1,2\n2,2,3\n1,3,4\n", "strictly increasing.*decreasing"),
    "repeated times": ("t,u,y\n0,1,2\n1,2,3\n1,3,4\n", "strictly increasing.*repeated"),
    "empty file": ("", "empty file"),
    "header only": ("t,u,y\n", "no data rows"),
    "short row": ("t,u,y\n0,1,2\n1,2\n", "line 3 has 2 field"),
    "one sample": ("t,u,y\n0,1,2\n", "a record needs at least 2"),
}


@pytest.mark.parametrize("case", sorted(BAD_CSV))
def test_bad_csv_files_raise_and_exit_2(tmp_path: Path, case: str, capsys) -> None:
    text, message = BAD_CSV[case]
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message) as exc:
        read_record(path, ["u"], ["y"], time="t")
    assert str(path) in str(exc.value)
    out = tmp_path / "out"
    argv = ["identify", str(path), "--inputs", "u", "--outputs", "y", "--out", str(out)]
    assert main([*argv, "--method", "dt", "--order", "1"]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "error:" in err
    assert not (out / "model.json").exists()  # no model from a bad file


@pytest.mark.parametrize("suffix", [".mat", ".npz", ".parquet", ".h5"])
def test_bad_binary_files(tmp_path: Path, suffix: str) -> None:
    nan_u = U.copy()
    nan_u[7] = np.nan
    path = _write(tmp_path / f"nan{suffix}", {"t": T, "u": nan_u, "y": Y})
    with pytest.raises(ValueError, match=r"column 'u' has 1 missing/NaN/inf.*sample 7"):
        read_record(path, ["u"], ["y"])
    path = _write(tmp_path / f"unsorted{suffix}", {"t": T[::-1].copy(), "u": U, "y": Y})
    with pytest.raises(ValueError, match="decreasing"):
        read_record(path, ["u"], ["y"])
    path = _write(tmp_path / f"miss{suffix}", {"t": T, "u": U, "y": Y})
    with pytest.raises(ValueError, match=r"unknown column\(s\) \['v'\]") as exc:
        read_record(path, ["v"], ["y"])
    assert "--dt" not in str(exc.value)  # the time column exists: no sampling-interval hint
    if suffix != ".parquet":  # a Parquet table cannot hold columns of unequal length
        path = _write(tmp_path / f"len{suffix}", {"t": T, "u": U[:-1], "y": Y})
        with pytest.raises(ValueError, match="different lengths"):
            read_record(path, ["u"], ["y"])


def test_text_and_matrix_variables_are_refused(tmp_path: Path) -> None:
    path = tmp_path / "text.npz"
    np.savez(path, t=T, u=np.array(["a"] * 50), y=Y)
    with pytest.raises(ValueError, match="column 'u' holds <U1 values, expected real numbers"):
        read_record(path, ["u"], ["y"])
    path = _write(tmp_path / "mat.mat", {"t": T, "u": np.c_[U, U], "y": Y})
    with pytest.raises(ValueError, match=r"shape \(50, 2\), expected a vector"):
        read_record(path, ["u"], ["y"])
    path = tmp_path / "text.parquet"
    pq.write_table(pa.table({"t": T, "u": ["x"] * 50, "y": Y}), path)
    with pytest.raises(ValueError, match="column 'u' holds"):
        read_columns(path, ["u"])
    with pytest.raises(ValueError, match="unknown file type '.xlsx'"):
        (tmp_path / "a.xlsx").write_text("x")
        read_columns(tmp_path / "a.xlsx", ["u"])
    with pytest.raises(ValueError, match="data file not found"):
        read_columns(tmp_path / "none.csv", ["u"])


def test_robot_arm_identifies_with_dt(tmp_path: Path, capsys) -> None:
    path = DATA / "robot-arm.csv"
    base = ["identify", str(path), "--inputs", "u", "--outputs", "y", "--out", str(tmp_path)]
    assert main([*base, "--no-plot"]) == 2  # no time column and no --dt
    assert "give the sampling interval" in capsys.readouterr().err
    assert main([*base, "--dt", "1", "--method", "dt", "--order", "4", "--no-plot"]) == 0
    d = json.loads((tmp_path / "model.json").read_text())
    assert d["options"]["sampling_interval"] == 1.0 and d["options"]["columns"]["time"] is None
    # the stored levels are the record's means, computed independently here
    raw = np.loadtxt(path, delimiter=",", skiprows=1)
    np.testing.assert_allclose(d["u0"], [raw[:, 0].mean()], rtol=1e-12)
    np.testing.assert_allclose(d["y0"], [raw[:, 1].mean()], rtol=1e-12)
    # DT PBSID order 4 on the whole sweep: simulation fit measured 29.8 % (VAF 50.7 %);
    # a fit above 16 % (a VAF above 30 %: 100 (1 - sqrt(0.7))) says a model came out of
    # the file, not noise (the order is not tuned here)
    text = capsys.readouterr().out
    fit = float(re.search(r"^  y: (-?[\d.]+) %$", text, re.MULTILINE).group(1))
    assert fit > 16.0, text


def test_several_data_files_use_the_list_form(tmp_path: Path, monkeypatch, capsys) -> None:
    monkeypatch.setattr(REG, "METHODS", dict(REG.METHODS))
    got = {}

    def listwise(t, u, y, order=None, **options):
        got["records"] = t
        return StateSpaceModel(-np.eye(1), np.ones((1, 1)), np.ones((1, 1)), None, None)

    REG.METHODS["listwise"] = listwise
    a = _write(tmp_path / "a.csv", {"u": U, "y": Y})
    b = _write(tmp_path / "b.npz", {"u": U[:40] + 3.0, "y": Y[:40] - 1.0})
    argv = ["identify", "--data", str(a), "--data", str(b), "--inputs", "u", "--outputs", "y"]
    argv += ["--dt", "0.02", "--method", "listwise", "--order", "1", "--out", str(tmp_path)]
    assert main([*argv, "--no-plot"]) == 0
    assert [r[0].size for r in got["records"]] == [50, 40]
    d = json.loads((tmp_path / "model.json").read_text())
    w = (50 * U.mean() + 40 * (U[:40].mean() + 3.0)) / 90
    np.testing.assert_allclose(d["u0"], [w], rtol=1e-12)  # sample-weighted mean level
    assert d["options"]["source"] == [str(a), str(b)]


# -- the two CSV readers: numpy's C reader on plain text, the checked reader otherwise ----
# within 1e300: rounded to 4 digits ('{:.3e}') the largest doubles would overflow to inf,
# which the fast reader rightly leaves to the checked one
_PLAIN_FLOATS = st.floats(min_value=-1e300, max_value=1e300, width=64)


@settings(max_examples=60, deadline=None)
@given(
    values=st.lists(st.tuples(_PLAIN_FLOATS, _PLAIN_FLOATS), min_size=1, max_size=30),
    delimiter=st.sampled_from([",", ";", "\t", " "]),
    line_end=st.sampled_from(["\n", "\r\n"]),
    fmt=st.sampled_from(["{!r}", "{:.9g}", "{:.3e}", "{:f}"]),
    text_column=st.booleans(),
    blank_every=st.integers(0, 4),
)
def test_fast_csv_reader_agrees_with_the_checked_one(
    values, delimiter, line_end, fmt, text_column, blank_every
) -> None:
    """On plain text numpy's reader takes the file and returns what the field-by-field
    reader (Python's ``float`` on every cell, an independent parser) returns, bit for
    bit: both round the decimal text correctly.  A text column that is not selected and
    blank lines keep the fast path."""
    names = ["u", "label", "y"] if text_column else ["u", "y"]
    lines = [delimiter.join(names)]
    for k, (u, y) in enumerate(values):
        cells = (
            [fmt.format(u), "ok", fmt.format(y)] if text_column else [fmt.format(u), fmt.format(y)]
        )
        lines.append(delimiter.join(cells))
        if blank_every and k % blank_every == 0:
            lines.append("")
    text = line_end.join(lines) + line_end
    path = Path("plain.csv")
    fast = csv_reader._read_csv_fast(path, text, ["u", "y"], None)
    assert fast is not None  # the fast path is taken: otherwise this test compares nothing
    checked = csv_reader._read_csv_checked(path, text, ["u", "y"], None)
    for c in ("u", "y"):
        np.testing.assert_array_equal(fast[c], checked[c])
    np.testing.assert_array_equal(fast["u"], [float(fmt.format(u)) for u, _ in values])


@pytest.mark.parametrize(
    "body",
    [
        "0,1,2\n# a note\n1,2,3\n",  # a comment line after the header
        '0,"1",2\n1,2,3\n',  # a quoted field
        "0,1,2\n1,2\n",  # a short row
        "0,1,2,9\n1,2,3\n",  # a long row (numpy would ignore the extra field)
        "0,1,2\n   \n1,2,3\n",  # a line of spaces
        "0,1,2\r1,2,3\r",  # old Mac line ends
        "0,nan,2\n1,2,3\n",  # a non-finite value: the checked reader names it
        "0,1_0,2\n1,2,3\n",  # digit separators
    ],
)
def test_fast_csv_reader_leaves_other_text_to_the_checked_one(body: str) -> None:
    assert csv_reader._read_csv_fast(Path("x.csv"), "t,u,y\n" + body, ["u", "y"], None) is None


def test_long_csv_with_notes_before_the_header(tmp_path: Path) -> None:
    """A header after more than the scanned head of comment lines still reads (checked
    reader), and a long plain file after a few comment lines reads through numpy."""
    n = 5000
    t = np.arange(n) * 0.01
    rows = "".join(f"{a!r},{b!r}\n" for a, b in zip(t.tolist(), np.sin(t).tolist(), strict=True))
    long_notes = "# note\n" * (csv_reader.CSV_TEXT.head_chars // 7 + 10)
    for notes, fast in (("# exported\n\n", True), (long_notes, False)):
        text = f"{notes}t,y\n{rows}"
        got = csv_reader._read_csv_fast(tmp_path / "a.csv", text, ["t", "y"], None)
        assert (got is not None) == fast
        path = tmp_path / "a.csv"
        path.write_text(text)
        rec = read_record(path, [], ["y"], time="t")
        np.testing.assert_array_equal(rec.t, t)  # repr round-trips exactly
        np.testing.assert_array_equal(rec.y[:, 0], np.sin(t))


def test_unknown_column_of_a_long_csv_is_named_before_the_rows_are_read(
    tmp_path: Path, monkeypatch
) -> None:
    path = tmp_path / "big.csv"
    path.write_text("t,u,y\n" + "0,1,2\n" * 1000)

    def not_called(*args, **kwargs):
        raise AssertionError("rows read before the header was checked")

    monkeypatch.setattr(csv_reader, "_read_csv_checked", not_called)
    monkeypatch.setattr(csv_reader.np, "loadtxt", not_called)
    with pytest.raises(ValueError, match=r"unknown column\(s\) \['v'\]"):
        read_columns(path, ["v"])
