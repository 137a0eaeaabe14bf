"""hdpbsid CLI: identify from CSV, demo, JSON, figures, errors."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from hdpbsid.cli import best_method, main, model_from_dict, model_to_dict, read_model_json
from hdpbsid.methods.registry import is_available
from hdpbsid.systems import random_steps, second_order, simulate_zoh
from hdpbsid.systems.quadrotor import pitch_model

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
TRUE_EIGS = np.array([-0.4 - np.sqrt(3.84) * 1j, -0.4 + np.sqrt(3.84) * 1j])


def _eigs(d: dict) -> np.ndarray:
    return np.sort_complex(np.array([e["real"] + 1j * e["imag"] for e in d["eigenvalues"]]))


def _assert_png(path: Path) -> None:
    assert path.is_file()
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC and len(data) > 1000


@pytest.fixture(scope="module")
def csv_file(tmp_path_factory) -> Path:
    rng = np.random.default_rng(21)
    t = np.arange(0.0, 20.0, 0.01)
    u = random_steps(rng, t, hold=0.5)
    A, B, C, D = second_order()
    y = simulate_zoh(A, B, C, D, t, u)
    path = tmp_path_factory.mktemp("data") / "second_order.csv"
    rows = np.column_stack([t, u[:, 0], y[:, 0]])
    np.savetxt(path, rows, delimiter=",", header="time,force,pos", comments="", fmt="%.17g")
    return path


def test_identify_round_trip(csv_file: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "out"
    argv = [
        "identify",
        str(csv_file),
        "--time",
        "time",
        "--inputs",
        "force",
        "--outputs",
        "pos",
        "--order",
        "2",
        "--method",
        "dt",
        "--detrend",
        "none",  # simulated from rest around zero: no operating point to remove
        "--out",
        str(out),
    ]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "eigenvalues" in text and "100 (1 - NRMSE)" in text and "  pos: " in text
    d = json.loads((out / "model.json").read_text())
    assert d["time"] == "continuous" and (d["n"], d["m"], d["l"]) == (2, 1, 1)
    for key, shape in (("A", (2, 2)), ("B", (2, 1)), ("C", (1, 2)), ("D", (1, 1)), ("K", (2, 1))):
        assert np.array(d[key]).shape == shape
    # noise-free ZOH data, 17-digit CSV and exact d2c: measured ~1e-10; 1e-6 is generous
    np.testing.assert_allclose(_eigs(d), TRUE_EIGS, rtol=1e-6)
    assert d["options"]["method"] == "dt"
    assert d["options"]["columns"] == {"time": "time", "inputs": ["force"], "outputs": ["pos"]}
    assert len(d["singular_values"]) >= 2
    _assert_png(out / "identification.png")
    m = read_model_json(out / "model.json")
    np.testing.assert_allclose(np.sort_complex(m.eigenvalues), _eigs(d), rtol=1e-12)


def test_identify_leaves_numpy_print_options_alone(csv_file: Path, tmp_path: Path) -> None:
    """The printed model uses its own print options for its own lines only: the caller's
    numpy options (a process that runs the CLI in-line, a notebook) are unchanged after."""
    argv = ["identify", str(csv_file), "--time", "time", "--inputs", "force", "--outputs"]
    argv += ["pos", "--order", "2", "--method", "dt", "--refine", "none", "--no-plot"]
    with np.printoptions(precision=3, linewidth=60, suppress=True):
        before = np.get_printoptions()
        assert main([*argv, "--out", str(tmp_path / "o")]) == 0
        assert np.get_printoptions() == before


def test_identify_refine_flag(csv_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    argv = ["identify", str(csv_file), "--time", "time", "--inputs", "force"]
    argv += ["--outputs", "pos", "--order", "2", "--method", "hermite", "--refine", "pem"]
    argv += ["--detrend", "none"]  # simulated from rest around zero: no operating point
    assert main([*argv, "--out", str(out), "--no-plot"]) == 0
    d = json.loads((out / "model.json").read_text())
    assert d["options"]["refine"] == "pem"
    # noise-free ZOH data through the exact sampled predictor (refine_pem): measured
    # ~1e-9 from the HD-PBSID start (1e-5); 1e-6 leaves room for the LM tolerances
    np.testing.assert_allclose(_eigs(d), TRUE_EIGS, rtol=1e-6)


def test_identify_focus_flag(csv_file: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    argv = ["identify", str(csv_file), "--time", "time", "--inputs", "force"]
    argv += ["--outputs", "pos", "--order", "2", "--method", "hermite", "--detrend", "none"]
    assert main([*argv, "--focus", "simulation", "--out", str(out), "--no-plot"]) == 0
    d = json.loads((out / "model.json").read_text())
    assert d["options"]["refine_focus"] == "simulation"
    # noise-free ZOH data: the output-error plant is the truth up to the LM tolerances
    np.testing.assert_allclose(_eigs(d), TRUE_EIGS, rtol=1e-6)


def test_options_passed_through_and_semicolon_csv(csv_file: Path, tmp_path: Path) -> None:
    semi = tmp_path / "semi.csv"
    semi.write_text(csv_file.read_text().replace(",", ";"))
    out = tmp_path / "o"
    argv = [
        "identify",
        str(semi),
        "--time",
        "time",
        "--inputs",
        "force",
        "--outputs",
        "pos",
        "--order",
        "2",
        "--method",
        "dt",
        "--option",
        "p=12",
        "--out",
        str(out),
        "--no-plot",
    ]
    assert main(argv) == 0
    d = json.loads((out / "model.json").read_text())
    assert d["options"]["requested_options"] == {"p": 12} and d["options"]["p"] == 12
    assert not (out / "identification.png").exists()


def test_model_dict_round_trip(csv_file: Path) -> None:
    from hdpbsid import identify

    data = np.loadtxt(csv_file, delimiter=",", skiprows=1)
    m = identify(data[:, 0], data[:, 1], data[:, 2], order=2, method="dt")
    d = json.loads(json.dumps(model_to_dict(m)))  # must be pure JSON
    m2 = model_from_dict(d)
    for k in "ABCDK":
        np.testing.assert_array_equal(getattr(m2, k), getattr(m, k))


def test_usage_errors_exit_2(csv_file: Path, tmp_path: Path, capsys) -> None:
    base = ["--time", "time", "--inputs", "force", "--out", str(tmp_path)]
    assert main(["identify", str(tmp_path / "missing.csv"), "--outputs", "pos", *base]) == 2
    assert "not found" in capsys.readouterr().err
    assert main(["identify", str(csv_file), "--outputs", "height", *base]) == 2
    err = capsys.readouterr().err
    assert "unknown column" in err and "height" in err and "pos" in err
    assert main(["identify", str(csv_file), "--outputs", "pos", "--method", "n4sid", *base]) == 2
    err = capsys.readouterr().err
    assert "n4sid" in err and "dt" in err
    assert main(["identify", str(csv_file), *base]) == 2  # --outputs is required
    assert "--outputs" in capsys.readouterr().err
    assert main(["identify", str(csv_file), "--outputs", "pos", "--option", "p", *base]) == 2
    assert main(["frobnicate"]) == 2
    assert main([]) == 2
    assert main(["--help"]) == 0
    bad = tmp_path / "bad.csv"
    bad.write_text("time,force,pos\n0,1,2\n0.01,x,3\n")
    assert main(["identify", str(bad), "--outputs", "pos", *base]) == 2
    assert "not a number" in capsys.readouterr().err


def test_identification_failure_exit_1(csv_file: Path, tmp_path: Path, capsys) -> None:
    argv = [
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
        "--option",
        "p=5000",
        "--out",
        str(tmp_path),
    ]
    assert main(argv) == 1
    assert "identification failed" in capsys.readouterr().err


def test_best_method() -> None:
    assert best_method() == ("hermite" if is_available("hermite") else "dt")


def test_demo_end_to_end(tmp_path: Path, capsys) -> None:
    out = tmp_path / "demo"
    argv = ["demo", "--method", "dt", "--snr", "none", "--duration", "10", "--out", str(out)]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "identified" in text and "true" in text and "new record q " in text
    d = json.loads((out / "model.json").read_text())
    true = np.sort_complex(np.linalg.eigvals(pitch_model()[0]))
    # noise-free closed loop, total moment as input: dt is exact to ~1e-11 (see
    # test_hdpbsid_quadrotor); 1e-6 relative is generous
    np.testing.assert_allclose(_eigs(d), true, rtol=1e-6)
    _assert_png(out / "identification.png")
    _assert_png(out / "eigenvalues.png")
    assert main(["demo", "--outputs", "q,pitch", "--out", str(out)]) == 2


def test_study_command(tmp_path: Path, capsys) -> None:
    out = tmp_path / "study"
    argv = ["study", "snr", "--runs", "1", "--set", "snrs=(20,)", "--set", "methods=('hermite',)"]
    assert main([*argv, "--set", "samples=1001", "--out", str(out), "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert "snr_db" in text and "hermite" in text and "1 tasks" in text
    for name in ("results.jsonl", "summary.csv", "summary.json", "records.csv"):
        assert (out / name).is_file(), name
    _assert_png(out / "snr.png")
    # resumed: nothing recomputed, same table
    assert main([*argv, "--set", "samples=1001", "--out", str(out), "--no-progress"]) == 0
    assert len((out / "results.jsonl").read_text().splitlines()) == 1
    capsys.readouterr()
    assert main(["study", "nope"]) == 2
    assert main(["study", "snr", "--runs", "0", "--out", str(out)]) == 2
    assert main(["study", "snr", "--set", "bogus=1", "--out", str(out)]) == 2
    assert "unknown setting" in capsys.readouterr().err
    assert main(["study", "snr", "--scheduler", "localhost:1", "--out", str(out)]) == 2
    assert "scheduler must be an address" in capsys.readouterr().err


@pytest.mark.parametrize(
    "setting, numpy_first, expected",
    [(None, False, "module"), ("28", False, "28"), (None, True, "None")],
)
def test_the_command_shortens_openblas_spin_unless_the_user_set_it(setting, numpy_first, expected):
    """OPENBLAS_THREAD_TIMEOUT in the command's process: the module's value when unset
    before numpy loads, the user's own value kept, untouched once numpy is loaded (the
    variable is read when OpenBLAS loads, so setting it then would only reach children)."""
    import subprocess
    import sys

    from hdpbsid.cli import BLAS_SPIN_LOG2_CYCLES

    expected = str(BLAS_SPIN_LOG2_CYCLES) if expected == "module" else expected
    env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_THREAD_TIMEOUT"}
    if setting is not None:
        env["OPENBLAS_THREAD_TIMEOUT"] = setting
    code = ("import numpy; " if numpy_first else "") + (
        "import os, hdpbsid.cli; print(os.environ.get('OPENBLAS_THREAD_TIMEOUT'))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.strip() == expected
