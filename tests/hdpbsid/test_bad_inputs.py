"""Bad and awkward inputs: every one gives a result or a clear error before the work.

Data files (encodings, decimal commas, NaN, one row, ...), the command line (output
paths, closed pipes, time units), extreme amplitudes and missing optional packages.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import hdpbsid
from hdpbsid.cli import main
from hdpbsid.data.io import read_record
from hdpbsid.systems import random_steps, second_order, simulate_zoh

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def record() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The second-order benchmark (poles -0.4 +- 1.96j) under random steps, 1 % noise."""
    rng = np.random.default_rng(11)
    t = np.arange(0.0, 20.0, 0.02)
    u = random_steps(rng, t, hold=0.5)
    y = simulate_zoh(*second_order(), t, u) + 0.01 * rng.standard_normal((t.size, 1))
    return t, u, y


@pytest.fixture(scope="module")
def csv_file(record, tmp_path_factory) -> Path:
    t, u, y = record
    path = tmp_path_factory.mktemp("data") / "so.csv"
    np.savetxt(path, np.c_[t, u, y], delimiter=",", header="time,force,pos", comments="")
    return path


# -- CSV files ------------------------------------------------------------------------------
# (file content, expected: None = reads as t = [0, 1, 2], u = [1, 2, 3]; else what the
# ValueError must say besides the file name)
CSV_CASES = {
    "utf-8 byte-order mark": ("\ufefft,u,y\n0,1,2\n1,2,3\n2,3,1\n".encode(), None),
    "utf-16 with its mark": ("t,u,y\n0,1,2\n1,2,3\n2,3,1\n".encode("utf-16"), None),
    "trailing delimiters": (b"t,u,y,,\n0,1,2,,\n1,2,3,,\n2,3,1,,\n", None),
    "spreadsheet sep line": (b"sep=;\nt;u;y\n0;1;2\n1;2;3\n2;3;1\n", None),
    "windows line ends": (b"t,u,y\r\n0,1,2\r\n1,2,3\r\n2,3,1\r\n", None),
    "decimal comma, semicolons": (b"t;u;y\n0;1,5;2\n1;2;3\n", ["line 2", "'u'", "decimal"]),
    "decimal comma, commas": (b"t,u,y\n0,1,5,2\n1,2,3\n", ["line 2", "decimal commas"]),
    "thousands and comma": (b"t;u;y\n0;1.000,5;2\n1;2;3\n", ["line 2", "decimal comma"]),
    "latin-1 header": ("t,u,y°\n0,1,2\n".encode("latin-1"), ["UTF-8", "line 1"]),
    "binary": (bytes(range(256)) * 4, ["UTF-8"]),
    "NaN value": (b"t,u,y\n0,1,2\n1,nan,3\n", ["line 3", "'u'", "NaN"]),
    "infinite value": (b"t,u,y\n0,1,2\n1,-inf,3\n", ["line 3", "'u'", "infinite"]),
    "beyond float range": (b"t,u,y\n0,1,2\n1,1e400,3\n", ["line 3", "'u'", "float64 range"]),
    "text value": (b"t,u,y\n0,1,2\n1,abc,3\n", ["line 3", "'u'", "not a number"]),
    "digit separators": (b"t,u,y\n0,1_000,2\n1,2,3\n", ["line 2", "'u'", "not a number"]),
    "missing value": (b"t,u,y\n0,,2\n1,2,3\n", ["line 2", "'u'", "missing"]),
    "ragged row": (b"t,u,y\n0,1,2\n1,2\n", ["line 3", "2 field(s)"]),
    "empty file": (b"", ["empty"]),
    "header only": (b"t,u,y\n", ["no data rows"]),
    "one row": (b"t,u,y\n0,1,2\n", ["1 sample(s)"]),
    "repeated column": (b"t,u,u,y\n0,1,2,3\n1,2,3,4\n", ["'u'", "more than once"]),
    "unsorted times": (b"t,u,y\n0,1,2\n2,2,3\n1,3,1\n", ["'t'", "increasing"]),
    "repeated times": (b"t,u,y\n0,1,2\n0,2,3\n", ["'t'", "repeated"]),
    "unknown column": (b"time,u,y\n0,1,2\n1,2,3\n", ["'t'", "dt"]),
}


@pytest.mark.parametrize("case", sorted(CSV_CASES))
def test_csv_reads_or_names_the_problem(case: str, tmp_path: Path) -> None:
    content, expected = CSV_CASES[case]
    path = tmp_path / "data.csv"
    path.write_bytes(content)
    if expected is None:
        rec = read_record(path, ["u"], ["y"], time="t")
        np.testing.assert_array_equal(rec.t, [0.0, 1.0, 2.0])
        np.testing.assert_array_equal(rec.u[:, 0], [1.0, 2.0, 3.0])
        return
    with pytest.raises(ValueError) as info:
        read_record(path, ["u"], ["y°" if "latin" in case else "y"], time="t")
    msg = str(info.value)
    assert str(path) in msg and all(s in msg for s in expected), msg


# -- command line ---------------------------------------------------------------------------
def _identify_args(csv_file: Path, out: Path) -> list[str]:
    return [
        "identify",
        str(csv_file),
        "--time",
        "time",
        "--inputs",
        "force",
        "--outputs",
        "pos",
        "--method",
        "dt",
        "--order",
        "2",
        "--no-plot",
        "--out",
        str(out),
    ]


def test_out_naming_a_file_fails_before_reading(csv_file: Path, tmp_path: Path, capsys) -> None:
    taken = tmp_path / "results"
    taken.write_text("not a directory")
    assert main(_identify_args(csv_file, taken)) == 2
    cap = capsys.readouterr()
    assert "--out" in cap.err and "not a directory" in cap.err
    assert cap.out == ""  # nothing read, nothing identified
    assert main(_identify_args(csv_file, taken / "below")) == 2
    assert "not a directory" in capsys.readouterr().err
    (tmp_path / "ok" / "model.json").mkdir(parents=True)
    assert main(_identify_args(csv_file, tmp_path / "ok")) == 2
    assert "model.json is a directory" in capsys.readouterr().err


def test_directories_and_interrupts(csv_file: Path, tmp_path: Path, capsys, monkeypatch) -> None:
    with pytest.raises(ValueError, match="is a directory"):
        read_record(tmp_path, ["u"], ["y"])
    with pytest.raises(ValueError, match="is a directory"):
        hdpbsid.load_model(tmp_path)
    import hdpbsid.cli as cli

    def interrupted(*args):
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_cmd_identify", interrupted)
    assert main(_identify_args(csv_file, tmp_path / "o")) == 130
    err = capsys.readouterr().err
    assert "interrupted" in err and "Traceback" not in err


def test_cli_reads_bom_csv_and_hints_decimal_commas(csv_file, tmp_path: Path, capsys) -> None:
    bom = tmp_path / "bom.csv"
    bom.write_bytes(b"\xef\xbb\xbf" + csv_file.read_bytes())
    assert main(_identify_args(bom, tmp_path / "o")) == 0
    assert json.loads((tmp_path / "o" / "model.json").read_text())["input_names"] == ["force"]
    comma = tmp_path / "comma.csv"
    comma.write_text("time;force;pos\n0;1,5;2\n0,01;2;3\n")
    capsys.readouterr()
    assert main(_identify_args(comma, tmp_path / "o2")) == 2
    err = capsys.readouterr().err
    assert str(comma) in err and "line 3, column 'time'" in err and "decimal comma" in err


class _ClosedPipe:
    """A stdout whose reader has gone (``| head``)."""

    def write(self, text: str) -> int:
        raise BrokenPipeError(32, "Broken pipe")

    def flush(self) -> None:
        raise BrokenPipeError(32, "Broken pipe")


def test_closed_pipe_is_quiet_and_files_are_written(csv_file, tmp_path: Path, capsys) -> None:
    out = tmp_path / "o"
    assert main(_identify_args(csv_file, out), stdout=_ClosedPipe()) == 0  # type: ignore[arg-type]
    assert capsys.readouterr().err == ""
    assert (out / "model.json").is_file()


def test_closed_pipe_subprocess(csv_file: Path, tmp_path: Path) -> None:
    """``hdpbsid identify ... | head -n 1``: no traceback on stderr, the model written."""
    out = tmp_path / "o"
    cmd = [sys.executable, "-m", "hdpbsid", *_identify_args(csv_file, out)]
    env = {"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    first = proc.stdout.readline()
    proc.stdout.close()  # the reader goes away after one line, as head does
    err = proc.stderr.read().decode()
    proc.stderr.close()
    assert proc.wait(timeout=300) == 0, err
    assert first.startswith(b"data:") and "Traceback" not in err and "BrokenPipe" not in err
    assert (out / "model.json").is_file()


def test_cli_time_unit_and_validate_warnings(csv_file, record, tmp_path: Path, capsys) -> None:
    out = tmp_path / "o"
    assert main([*_identify_args(csv_file, out), "--time-unit", "ms"]) == 0
    assert "eigenvalues (rad/ms)" in capsys.readouterr().out
    d = json.loads((out / "model.json").read_text())
    assert d["time_unit"] == "ms" and d["output_names"] == ["pos"]
    assert d["sampling_interval"] == pytest.approx(0.02, rel=1e-9)  # the record's step
    model = str(out / "model.json")
    base = ["validate", model, "--no-plot", "--out", str(tmp_path / "v")]
    # the same record: no warning
    assert main([*base, str(csv_file)]) == 0
    assert "warning" not in capsys.readouterr().err
    # the record with its times in seconds of a model in ms: the unit and the step
    t, u, y = record
    secs = tmp_path / "seconds.csv"
    np.savetxt(secs, np.c_[t / 1000, u, y], delimiter=",", header="time,force,pos", comments="")
    assert main([*base, str(secs)]) == 0
    err = capsys.readouterr().err
    assert err.count("warning") == 1 and "sampling interval" in err and "0.001" in err
    assert main([*base, str(secs), "--time-unit", "s"]) == 0
    err = capsys.readouterr().err
    assert err.count("warning") == 1 and "'s' differs from the model's 'ms'" in err
    assert "1 s = 1000 ms" in err
    assert main([*base, str(secs), "--time-unit", ""]) == 2
    assert "--time-unit" in capsys.readouterr().err


# -- extreme amplitudes ---------------------------------------------------------------------
@pytest.mark.parametrize("method", ["dt", "hermite", "legendre"])
@pytest.mark.parametrize(
    ("su", "sy"), [(1e-200, 1e-200), (1e200, 1e200), (1e-150, 1e150), (1.0, 1e-200), (1e200, 1.0)]
)
def test_extreme_amplitudes_give_the_unscaled_model(record, method, su, sy) -> None:
    t, u, y = record
    ref = hdpbsid.identify(t, u, y, order=2, method=method, refine=None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        m = hdpbsid.identify(t, u * su, y * sy, order=2, method=method, refine=None)
    arithmetic = ("overflow", "underflow", "invalid value", "divide")
    assert not [w for w in caught if any(a in str(w.message) for a in arithmetic)]
    # the scaled record differs from the unscaled one by one rounding per sample
    # (1e-16 relative) and the identification is well conditioned here: 1e-8 is generous
    np.testing.assert_allclose(m.eigenvalues, ref.eigenvalues, rtol=1e-8)
    w = np.array([0.3, 2.0, 10.0])
    np.testing.assert_allclose(
        m.frequency_response(w), ref.frequency_response(w) * (sy / su), rtol=1e-8
    )
    np.testing.assert_allclose(m.y0, ref.y0 * sy, rtol=1e-8)
    assert m.m == 1 and m.options["signal_scaling"]["u_exponents"] == [
        0 if su == 1.0 else -int(np.frexp(np.abs(u * su).max())[1])
    ]
    # the model of the scaled record fits it as the reference fits the unscaled one
    vaf = m.fit(t, u * su, y * sy).vaf
    np.testing.assert_allclose(vaf, ref.fit(t, u, y).vaf, atol=1e-6)  # percent


def test_moderate_amplitudes_are_not_touched(record) -> None:
    """Inside the band the record goes to the method unchanged (bit for bit)."""
    t, u, y = record
    m = hdpbsid.identify(t, u * 1e-20, y * 1e20, order=2, method="dt", refine=None)
    assert "signal_scaling" not in m.options


def test_extreme_amplitudes_default_call(record) -> None:
    t, u, y = record
    ref = hdpbsid.identify(t, u, y)
    m = hdpbsid.identify(t, u * 1e-200, y * 1e-200)
    assert m.n == ref.n
    # refinement and selection on the scaled record reach the same model (the
    # prediction-error optimum is unit-invariant); its tolerance is the statistical one
    np.testing.assert_allclose(m.eigenvalues, ref.eigenvalues, rtol=1e-6)


# -- optional packages ----------------------------------------------------------------------
def test_n_jobs_without_joblib_names_the_extra(record, monkeypatch) -> None:
    t, u, y = record
    monkeypatch.setitem(sys.modules, "joblib", None)  # as if it were not installed
    with pytest.raises(ImportError, match=r'pip install "slbasis-hdpbsid\[studies\]"'):
        hdpbsid.identify(t, u, y, n_jobs=2)
    with pytest.raises(ImportError, match="n_jobs"):
        hdpbsid.identify(t, u, y, method="hermite", order=2, n_jobs=-1)
    # serial runs do not need it
    assert hdpbsid.identify(t, u, y, method="hermite", order=2, refine=None, n_jobs=1).n == 2
    # the extra the message names is the one that installs joblib
    studies = re.search(r"^studies = \[(.*)\]$", (ROOT / "pyproject.toml").read_text(), re.M)
    assert studies is not None and '"joblib' in studies.group(1)


# -- labels ---------------------------------------------------------------------------------
def test_identify_labels_are_checked_first(record) -> None:
    t, u, y = record
    with pytest.raises(ValueError, match="input_names must have 1 entries"):
        hdpbsid.identify(t, u, y, input_names=["a", "b"])
    with pytest.raises(TypeError, match="output_names"):
        hdpbsid.identify(t, u, y, output_names="pos")
    with pytest.raises(ValueError, match="time_unit"):
        hdpbsid.identify(t, u, y, time_unit="")
    with pytest.raises(ValueError, match="distinct"):
        hdpbsid.identify([(t, np.c_[u, -u], y)], input_names=["a", "a"])


@pytest.mark.parametrize("scale", [1.0, 1e200])
@pytest.mark.parametrize(
    "bad_u",
    [np.ones(100) * (1 + 1j), [["a"]] * 100, [[1.0, 2.0]] * 50 + [[1.0]] * 50],
    ids=["complex", "text", "ragged"],
)
def test_malformed_input_is_named_not_cast(bad_u, scale) -> None:
    """Complex, text and ragged inputs reach the data checks untouched (no imaginary
    part silently dropped by the scaling or the excitation check)."""
    t = np.arange(100.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a ComplexWarning would mean a silent cast
        with pytest.raises(TypeError, match="^u must"):
            hdpbsid.identify(t, bad_u, scale * np.sin(t), order=1, method="dt")


def test_cli_column_names_must_make_channel_names(tmp_path: Path, capsys) -> None:
    long = "y" * 300
    data = tmp_path / "d.csv"
    data.write_text(f"t,u,{long}\n0,1,2\n1,2,3\n2,3,1\n")
    argv = ["identify", str(data), "--inputs", "u", "--outputs", long, "--out", str(tmp_path)]
    assert main(argv) == 2
    assert "--outputs[0]" in capsys.readouterr().err
    assert main([*argv[:5], "u", "--outputs", "u", "--out", str(tmp_path)]) == 2
