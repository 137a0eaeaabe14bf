"""hdpbsid.load_model / StateSpaceModel.save: round trips and a sweep of tampered files."""

from __future__ import annotations

import copy
import json
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import hdpbsid
from hdpbsid import StateSpaceModel, load_model
from hdpbsid.models.model import LinearTrend
from hdpbsid.models.model_io import MAX_DEPTH, model_to_dict

# written by the version-1 writer (hdpbsid.cli.write_model_json before the labels were
# stored), verbatim: such files must keep loading
V1_FILE = (
    '{"time": "continuous", "n": 2, "m": 1, "l": 1, "A": [[0.0, 1.0], [-4.0, -0.8]], '
    '"B": [[0.0], [1.0]], "C": [[1.0, 0.0]], "D": [[0.0]], "K": [[0.2], [0.1]], '
    '"u0": [1.5], "y0": [-2.0], "trend": {"t_ref": 3.0, "u_slope": [0.1], "y_slope": [-0.2]}, '
    '"noise_covariance": [[0.01]], "eigenvalues": [{"real": -0.4000000000000001, '
    '"imag": -1.9595917942265426}, {"real": -0.4000000000000001, "imag": 1.9595917942265426}], '
    '"singular_values": [3.0, 2.0, 0.1], "options": {"method": "dt", "columns": {"time": '
    '"time", "inputs": ["force"], "outputs": ["pos"]}, "sampling_interval": null, "p": 12}}'
)


def _assert_same(a: StateSpaceModel, b: StateSpaceModel) -> None:
    """Every stored field equal (JSON writes floats with repr, which round-trips exactly)."""
    for k in ("A", "B", "C", "D", "K", "u0", "y0"):
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k), err_msg=k)
    for k in ("singular_values", "noise_covariance"):
        x, y = getattr(a, k), getattr(b, k)
        assert (x is None) == (y is None), k
        if x is not None:
            np.testing.assert_array_equal(np.asarray(x, dtype=float), y, err_msg=k)
    assert (a.trend is None) == (b.trend is None)
    if a.trend is not None:
        assert a.trend.t_ref == b.trend.t_ref
        np.testing.assert_array_equal(a.trend.u_slope, b.trend.u_slope)
        np.testing.assert_array_equal(a.trend.y_slope, b.trend.y_slope)
    assert a.options == b.options
    assert (a.time_unit, a.input_names, a.output_names, a.sampling_interval) == (
        b.time_unit,
        b.input_names,
        b.output_names,
        b.sampling_interval,
    )
    np.testing.assert_array_equal(a.eigenvalues, b.eigenvalues)


_json_leaf = st.none() | st.booleans() | st.integers(-(2**53), 2**53) | st.text(max_size=8)
_json_leaf = _json_leaf | st.floats(allow_nan=False, allow_infinity=False)
_options = st.dictionaries(
    st.text(max_size=6),
    st.recursive(
        _json_leaf,
        lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=4), c, max_size=3),
        max_leaves=10,
    ),
    max_size=4,
)
# printable names (letters, digits, punctuation, symbols, the plain space), as the labels
# accept them
_name = st.text(
    st.characters(codec="utf-8", categories=("L", "N", "P", "S"), include_characters=" "),
    min_size=1,
    max_size=12,
).filter(lambda s: s.strip() != "")


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(0, 5),
    m=st.integers(0, 3),
    l=st.integers(1, 3),
    seed=st.integers(0, 2**32 - 1),
    with_extras=st.booleans(),
    options=_options,
    unit=_name,
    names=st.lists(_name, min_size=6, max_size=6, unique=True),
)
def test_save_load_round_trip(n, m, l, seed, with_extras, options, unit, names) -> None:
    rng = np.random.default_rng(seed)

    def mat(r: int, c: int) -> np.ndarray:
        # magnitudes over many decades, so the exactness of the float text is exercised
        return rng.standard_normal((r, c)) * 10.0 ** rng.integers(-200, 200, (r, c))

    extras: dict[str, Any] = {}
    if with_extras:
        extras = dict(
            singular_values=np.abs(rng.standard_normal(n + 2)),
            noise_covariance=mat(l, l),
            u0=mat(1, m)[0],
            y0=mat(1, l)[0],
            trend=LinearTrend(float(rng.uniform(-1e9, 1e9)), mat(1, m)[0], mat(1, l)[0]),
            sampling_interval=float(rng.uniform(1e-6, 1e3)),
        )
    model = StateSpaceModel(
        mat(n, n),
        mat(n, m),
        mat(l, n),
        mat(l, m),
        mat(n, l),
        options=options,
        time_unit=unit,
        input_names=names[:m],
        output_names=names[3 : 3 + l],
        **extras,
    )
    with tempfile.TemporaryDirectory() as tmp:
        path = model.save(Path(tmp) / "sub" / "model.json")
        loaded = load_model(path)
    _assert_same(model, loaded)


def test_identified_model_round_trip(tmp_path: Path) -> None:
    from hdpbsid.systems import random_steps, second_order, simulate_zoh

    rng = np.random.default_rng(3)
    t = np.arange(0.0, 20.0, 0.02)
    u = random_steps(rng, t, hold=0.5)
    y = simulate_zoh(*second_order(), t, u) + 0.01 * rng.standard_normal((t.size, 1))
    model = hdpbsid.identify(
        t, u, y, order=2, method="dt", input_names=["F"], output_names=["x"], time_unit="s"
    )
    loaded = load_model(model.save(tmp_path / "model.json"))
    # options go through JSON: tuples become lists, objects their repr; the matrices,
    # labels and levels are exact
    for k in ("A", "B", "C", "D", "K", "u0", "y0"):
        np.testing.assert_array_equal(getattr(loaded, k), getattr(model, k))
    assert loaded.input_names == ["F"] and loaded.output_names == ["x"]
    assert loaded.sampling_interval == model.sampling_interval
    np.testing.assert_array_equal(loaded.simulate(t, u), model.simulate(t, u))


def test_version1_file_still_loads(tmp_path: Path) -> None:
    path = tmp_path / "old.json"
    path.write_text(V1_FILE)
    m = load_model(path)
    np.testing.assert_array_equal(m.A, [[0.0, 1.0], [-4.0, -0.8]])
    np.testing.assert_array_equal(m.noise_covariance, [[0.01]])
    assert m.trend.t_ref == 3.0 and m.u0.tolist() == [1.5]
    # the labels come from the CLI's record of the columns; the unit is the default
    assert m.input_names == ["force"] and m.output_names == ["pos"]
    assert m.time_unit == "s" and m.sampling_interval is None
    assert m.options["p"] == 12
    # the CLI's old helpers still work and give the same model
    from hdpbsid.cli import read_model_json

    _assert_same(read_model_json(path), m)


def _base() -> dict[str, Any]:
    m = StateSpaceModel(
        [[0.0, 1.0], [-4.0, -0.8]],
        [[0.0], [1.0]],
        [[1.0, 0.0]],
        [[0.0]],
        [[0.2], [0.1]],
        singular_values=np.array([3.0, 2.0, 0.1]),
        options={"method": "dt", "nested": {"a": [1, 2, {"b": 3}]}},
        noise_covariance=[[0.01]],
        u0=[1.5],
        y0=[-2.0],
        trend=LinearTrend(3.0, [0.1], [-0.2]),
        input_names=["force"],
        output_names=["pos"],
        sampling_interval=0.01,
    )
    return json.loads(json.dumps(model_to_dict(m)))


def _nest(depth: int) -> Any:
    x: Any = 0
    for _ in range(depth):
        x = [x]
    return x


def _set(path: str, value: Any, drop: bool = False):
    """A corruption: ``d[path] = value`` (dots and integers walk into the description)."""

    def corrupt(d: dict[str, Any]) -> dict[str, Any]:
        d = copy.deepcopy(d)
        keys = [int(k) if k.isdigit() else k for k in path.split(".")]
        target = d
        for k in keys[:-1]:
            target = target[k]
        if drop:
            del target[keys[-1]]
        else:
            target[keys[-1]] = value
        return d

    return corrupt


# (corruption, the key the message must name)
TAMPERED = {
    "matrix is a string": (_set("A", "[[0, 1], [-4, -0.8]]"), "'A'"),
    "matrix row too short": (_set("A.1", [-4.0]), "'A'"),
    "matrix has a string entry": (_set("C.0.1", "0"), "'C[0][1]'"),
    "matrix entry is a boolean": (_set("B.1.0", True), "'B[1][0]'"),
    "matrix entry is null": (_set("K.0.0", None), "'K[0][0]'"),
    "matrix has too many rows": (_set("B", [[0.0], [1.0], [2.0]]), "'B'"),
    "D of the wrong width": (_set("D", [[0.0, 1.0]]), "'D'"),
    "missing matrix": (_set("K", None, drop=True), "'K'"),
    "n is a word": (_set("n", "two"), "'n'"),
    "n is fractional": (_set("n", 2.7), "'n'"),
    "n is a whole float": (_set("n", 2.0), "'n'"),
    "n is a boolean": (_set("n", True), "'n'"),
    "n is negative": (_set("n", -1), "'n'"),
    "n disagrees with A": (_set("n", 3), "'A'"),
    "n is enormous": (_set("n", 10**30), "'A'"),
    "m is null": (_set("m", None), "'m'"),
    "no outputs": (_set("l", 0), "'l'"),
    "trend without t_ref": (_set("trend.t_ref", None, drop=True), "t_ref"),
    "trend t_ref is a string": (_set("trend.t_ref", "3"), "'trend.t_ref'"),
    "trend slope too long": (_set("trend.u_slope", [0.1, 0.2]), "'trend.u_slope'"),
    "trend with an unknown key": (_set("trend.slope", 1.0), "'trend'"),
    "trend is a list": (_set("trend", [3.0]), "'trend'"),
    "u0 too long": (_set("u0", [1.0, 2.0]), "'u0'"),
    "y0 is a string": (_set("y0", "-2"), "'y0'"),
    "noise covariance misshapen": (_set("noise_covariance", [[0.01, 0.0]]), "'noise_covariance'"),
    "negative singular value": (_set("singular_values.1", -2.0), "'singular_values'"),
    "singular values a number": (_set("singular_values", 3.0), "'singular_values'"),
    "eigenvalues miscounted": (_set("eigenvalues", [{"real": 0.0, "imag": 0.0}]), "eigenvalues"),
    "options is a list": (_set("options", [1, 2]), "'options'"),
    "options nested too deep": (_set("options.deep", _nest(MAX_DEPTH + 5)), "'options.deep"),
    "unknown key": (_set("colour", "red"), "'colour'"),
    "wrong format tag": (_set("format", "something else"), "'format'"),
    "newer version": (_set("version", 99), "'version'"),
    "version is a string": (_set("version", "2"), "'version'"),
    "discrete time": (_set("time", "discrete"), "'time'"),
    "time unit a number": (_set("time_unit", 5), "'time_unit'"),
    "time unit empty": (_set("time_unit", ""), "'time_unit'"),
    "input names miscounted": (_set("input_names", ["a", "b"]), "'input_names'"),
    "input name a number": (_set("input_names", [1]), "'input_names'"),
    "output names repeated": (_set("output_names", ["p", "p"]), "'output_names'"),
    "sampling interval negative": (_set("sampling_interval", -0.01), "'sampling_interval'"),
    "sampling interval a string": (_set("sampling_interval", "0.01"), "'sampling_interval'"),
}


@pytest.mark.parametrize("case", sorted(TAMPERED))
def test_tampered_file_names_the_key(case: str, tmp_path: Path) -> None:
    corrupt, key = TAMPERED[case]
    path = tmp_path / "model.json"
    path.write_text(json.dumps(corrupt(_base())))
    with pytest.raises(ValueError) as info:
        load_model(path)
    assert str(path) in str(info.value) and key in str(info.value), str(info.value)


# corruptions of the text itself: (text transformation, what the message must name)
RAW = {
    "not UTF-8": (lambda b: b.replace(b'"dt"', b'"\xff\xfe"'), "UTF-8"),
    "not JSON": (lambda b: b[:-10], "not a JSON"),
    "repeated key": (lambda b: b.replace(b'"n": 2,', b'"n": 2, "n": 3,'), "'n'"),
    "NaN literal": (lambda b: b.replace(b'"D": [\n    [\n      0.0', b'"D": [[NaN'), "'D[0][0]'"),
    "number beyond float": (lambda b: b.replace(b"-4.0", b"-4e400"), "'A[1][0]'"),
    "array instead of object": (lambda b: b"[" + b + b"]", "JSON object"),
    "deeper than the reader recurses": (
        lambda b: b.replace(b'"method": "dt"', b'"method": ' + b"[" * 100000 + b"]" * 100000),
        "'options'",
    ),
}


@pytest.mark.parametrize("case", sorted(RAW))
def test_tampered_bytes_give_value_error(case: str, tmp_path: Path) -> None:
    transform, what = RAW[case]
    path = tmp_path / "model.json"
    good = json.dumps(_base(), indent=2).encode()
    bad = transform(good)
    assert bad != good  # the transformation applied
    path.write_bytes(bad)
    with pytest.raises(ValueError) as info:
        load_model(path)
    assert str(path) in str(info.value) and what in str(info.value), str(info.value)


def test_size_bound_and_missing_file(tmp_path: Path) -> None:
    path = tmp_path / "model.json"
    path.write_text(json.dumps(_base()))
    with pytest.raises(ValueError, match="more than a model file may have"):
        load_model(path, max_bytes=100)
    assert load_model(path, max_bytes=path.stat().st_size).n == 2
    with pytest.raises(ValueError, match="not found"):
        load_model(tmp_path / "none.json")
    with pytest.raises(TypeError, match="path"):
        load_model(3)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="is a directory"):
        StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]]).save(tmp_path)


def test_utf8_bom_is_read(tmp_path: Path) -> None:
    path = tmp_path / "model.json"
    path.write_bytes(b"\xef\xbb\xbf" + json.dumps(_base()).encode())
    assert load_model(path).input_names == ["force"]


def _with_covariance() -> StateSpaceModel:
    from hdpbsid.models.uncertainty import ParameterCovariance

    rng = np.random.default_rng(7)
    F = rng.standard_normal((4 + 2 + 2 + 1, 3))  # n = 2, m = l = 1: p = 9
    A = np.array([[0.0, 1.0], [-4.0, -0.8]])
    return StateSpaceModel(
        A, [[0.0], [1.0]], [[1.0, 0.0]], [[0.0]], np.zeros((2, 1)),
        parameter_covariance=ParameterCovariance(F, "refine_pem"),
    )  # fmt: skip


def test_parameter_covariance_round_trip(tmp_path: Path) -> None:
    """The factor and its source come back bit for bit (JSON keeps float64 exactly)."""
    m = _with_covariance()
    back = load_model(m.save(tmp_path / "m.json"))
    assert back.parameter_covariance is not None
    np.testing.assert_array_equal(back.parameter_covariance.factor, m.parameter_covariance.factor)
    assert back.parameter_covariance.source == "refine_pem"
    assert "parameter_covariance" not in back.options


@pytest.mark.parametrize(
    "edit, key",
    [
        (lambda d: d["parameter_covariance"]["factor"].pop(), "parameter_covariance.factor"),
        (lambda d: d["parameter_covariance"].update(extra=1), "parameter_covariance"),
        (lambda d: d["parameter_covariance"].update(source=3), "parameter_covariance.source"),
        (lambda d: d["parameter_covariance"]["factor"][0].__setitem__(0, "x"), "factor"),
        (lambda d: d.update(version=3), "parameter_covariance"),
    ],
)
def test_parameter_covariance_is_read_strictly(edit: Any, key: str, tmp_path: Path) -> None:
    d = json.loads(_with_covariance().save(tmp_path / "m.json").read_text())
    edit(d)
    (tmp_path / "bad.json").write_text(json.dumps(d))
    with pytest.raises(ValueError, match=key):
        load_model(tmp_path / "bad.json")


def test_version3_covariance_in_options_is_migrated(tmp_path: Path) -> None:
    """A version-3 file kept the factor in its options: read into the attribute, checked
    like the version-4 key (a wrong row count names the option)."""
    m = _with_covariance()
    d = json.loads(m.save(tmp_path / "m.json").read_text())
    F = d.pop("parameter_covariance")["factor"]
    d["version"] = 3
    d["options"]["parameter_covariance"] = F
    (tmp_path / "v3.json").write_text(json.dumps(d))
    back = load_model(tmp_path / "v3.json")
    np.testing.assert_array_equal(back.parameter_covariance.factor, m.parameter_covariance.factor)
    assert "parameter_covariance" not in back.options
    d["options"]["parameter_covariance"] = F[:-1]
    (tmp_path / "v3bad.json").write_text(json.dumps(d))
    with pytest.raises(ValueError, match="options.parameter_covariance"):
        load_model(tmp_path / "v3bad.json")


def test_record_columns_round_trip_and_refusals() -> None:
    from hdpbsid.models.model_io import RecordColumns

    rc = RecordColumns("t", ["u1", "u2"], ["y"], 0.01, ["a.csv", "b.csv"])
    opts = rc.to_options()
    # the keys hdpbsid identify writes, in its order, as JSON values
    assert list(opts) == ["columns", "sampling_interval", "source"]
    assert json.loads(json.dumps(opts)) == opts
    assert RecordColumns.from_options(opts) == rc
    assert RecordColumns.from_options({"method": "dt"}) is None  # identified from Python
    # a non-positive or non-numeric interval is not a sampling interval
    for dt in (0.0, -1.0, "0.1", None):
        assert (
            RecordColumns.from_options({**opts, "sampling_interval": dt}).sampling_interval is None
        )
    for bad in ({"time": 3, "inputs": [], "outputs": []}, {"time": None, "inputs": "u"}, [1]):
        with pytest.raises(ValueError, match="'options.columns' must be an object"):
            RecordColumns.from_options({"columns": bad})
