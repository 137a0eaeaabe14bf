"""Saving and loading identified models: :func:`save_model` / :func:`load_model` (JSON).

``model.save("model.json")`` writes everything needed to rebuild a
:class:`~hdpbsid.models.model.StateSpaceModel`; ``hdpbsid.load_model("model.json")`` reads it
back.  The file is plain JSON (readable by any language):

========================  ==========================================================
key                       value
========================  ==========================================================
``format``                ``"hdpbsid.StateSpaceModel"``
``version``               ``4`` (files without it are version 1: no labels; version 2
                          has no ``delay``; version 3 no ``parameter_covariance``)
``time``                  ``"continuous"``
``n``, ``m``, ``l``       states, inputs, outputs (non-negative integers, ``l >= 1``)
``A B C D K``             matrices as lists of rows: ``n x n``, ``n x m``, ``l x n``,
                          ``l x m``, ``n x l`` (a matrix without rows is ``[]``)
``u0``, ``y0``            operating point (``m`` and ``l`` numbers)
``trend``                 ``null`` or ``{"t_ref", "u_slope" (m), "y_slope" (l)}``
``noise_covariance``      ``null`` or ``l x l``
``singular_values``       ``null`` or a list of non-negative numbers
``eigenvalues``           ``n`` objects ``{"real", "imag"}`` for readers of the file
                          (recomputed from ``A`` on loading)
``time_unit``             the unit of ``t`` (eigenvalues in rad per it), default ``"s"``
``input_names``           ``m`` distinct strings; ``output_names``: ``l``
``sampling_interval``     median step of the identification record, or ``null``
``delay``                 ``m`` dead times ``>= 0`` (one per input, in ``time_unit``);
                          absent in files before version 3 (no delay)
``parameter_covariance``  ``null`` or ``{"factor": p x k, "source": string}``, the
                          covariance factor of ``[vec A, vec B, vec C, vec D]``
                          (:class:`~hdpbsid.models.uncertainty.ParameterCovariance`, ``p = n^2 +
                          nm + ln + lm``); a version-3 file kept it as
                          ``options["parameter_covariance"]`` (a ``p x k`` matrix), which
                          is read, checked the same way, into the attribute
``options``               the settings the method used (any JSON object)
========================  ==========================================================

Reading is strict, because a model file is input like any other: every key is checked
(an unknown or repeated key is refused), every number must be a finite JSON number
(``"n": 2.7`` or ``"n": "two"`` is refused, never truncated), the matrices must have the
shapes ``n``, ``m``, ``l`` imply, a trend needs its ``t_ref``; the file may hold at most
:data:`MAX_BYTES` bytes of UTF-8 and nest at most :data:`MAX_DEPTH` levels (so no reader
recursion can run away).  Every problem raises ``ValueError`` naming the file and the
key.  Options that are not JSON values (callables, objects) are written as their
``repr`` and come back as strings; non-finite floats in options likewise.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hdpbsid.models.model import LinearTrend, StateSpaceModel
from hdpbsid.models.model_file import FORMAT, VERSION, describe, write_model
from hdpbsid.models.uncertainty import ParameterCovariance, parameter_count

__all__ = [
    "RecordColumns",
    "ModelFileLimits",
    "MODEL_FILE_LIMITS",
    "save_model",
    "load_model",
    "model_to_dict",
    "model_from_dict",
    "FORMAT",
    "VERSION",
    "MAX_BYTES",
    "MAX_DEPTH",
]


@dataclass(frozen=True)
class ModelFileLimits:
    """The limits a model file is read within.

    Attributes
    ----------
    max_bytes : int
        Largest model file read (bytes).
    max_depth : int
        Deepest nesting of JSON arrays and objects.
    """

    #: Largest model file read (bytes).  A model of 300 states with 10 inputs and outputs
    #: and its selection tables takes about 5 MB; 64 MiB leaves room for far larger ones
    #: while a runaway or hostile file is refused before it is read into memory.
    max_bytes: int = 64 * 2**20
    #: Deepest nesting of JSON arrays and objects.  The format itself nests 3 levels (the
    #: rows of a matrix in the file object); the options hold tables of dictionaries a few
    #: levels deep.  Python's JSON reader recurses once per level (a ``RecursionError``
    #: near 1000 levels, turned into a ``ValueError``), and so would code that walks the
    #: options; the bound keeps both far from it.
    max_depth: int = 32


#: The limits in force.
MODEL_FILE_LIMITS = ModelFileLimits()
#: :attr:`ModelFileLimits.max_bytes` of :data:`MODEL_FILE_LIMITS`
MAX_BYTES = MODEL_FILE_LIMITS.max_bytes
#: :attr:`ModelFileLimits.max_depth` of :data:`MODEL_FILE_LIMITS`
MAX_DEPTH = MODEL_FILE_LIMITS.max_depth


_REQUIRED = ("n", "m", "l", "A", "B", "C", "D", "K")
_OPTIONAL = (
    "format",
    "version",
    "time",
    "u0",
    "y0",
    "trend",
    "noise_covariance",
    "singular_values",
    "eigenvalues",
    "time_unit",
    "input_names",
    "output_names",
    "sampling_interval",
    "delay",
    "parameter_covariance",
    "options",
)
_KNOWN = _REQUIRED + _OPTIONAL


# -- writing (the description itself: hdpbsid.models.model_file) -------------------------
def model_to_dict(model: StateSpaceModel) -> dict[str, Any]:
    """The JSON-ready description of ``model`` (module docstring): everything
    :func:`model_from_dict` needs to rebuild it.

    Parameters
    ----------
    model : StateSpaceModel
        The model to describe.

    Returns
    -------
    dict
        Plain JSON values (lists, numbers, strings, ``None``).

    Raises
    ------
    TypeError
        When ``model`` is not a :class:`~hdpbsid.models.model.StateSpaceModel`.

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> d = model_to_dict(StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]]))
    >>> d["A"], d["time_unit"], d["input_names"]
    ([[-1.0]], 's', ['u1'])
    """
    if not isinstance(model, StateSpaceModel):
        raise TypeError(f"model must be a StateSpaceModel, got {type(model).__name__}")
    return describe(model)


def save_model(model: StateSpaceModel, path: str | Path) -> Path:
    """Write ``model`` to ``path`` as indented JSON (:func:`model_to_dict`).

    Parameters
    ----------
    model : StateSpaceModel
        The model to save.
    path : str or pathlib.Path
        The file to write; missing parent directories are created.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    ValueError
        When ``path`` is an existing directory.
    TypeError
        When ``model`` is not a :class:`~hdpbsid.models.model.StateSpaceModel`.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from hdpbsid import StateSpaceModel, load_model
    >>> m = StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]], input_names=["F"])
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     back = load_model(save_model(m, pathlib.Path(tmp) / "model.json"))
    >>> back.input_names
    ['F']
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path}: is a directory; give the model file's name")
    if not isinstance(model, StateSpaceModel):
        raise TypeError(f"model must be a StateSpaceModel, got {type(model).__name__}")
    return write_model(model, path)


# -- reading ------------------------------------------------------------------------------
def _check_depth(d: Any, limit: int) -> None:
    """Raise ``ValueError`` naming the key path where arrays/objects nest deeper than
    ``limit`` (iteratively: the check itself cannot recurse)."""
    stack = [(d, "", 0)]
    while stack:
        v, where, depth = stack.pop()
        if not isinstance(v, dict | list):
            continue
        if depth + 1 > limit:
            raise ValueError(
                f"key {where.lstrip('.')!r} nests arrays/objects deeper than {limit} levels; "
                f"a model file nests at most a few"
            )
        items = v.items() if isinstance(v, dict) else enumerate(v)
        for k, w in items:
            sub = f"{where}.{k}" if isinstance(v, dict) else f"{where}[{k}]"
            stack.append((w, sub, depth + 1))


_TOKEN = re.compile(r'"(?:[^"\\]|\\.)*"|[\[\]{}]')
_COLON = re.compile(r"\s*:")


def _deep_key(text: str, limit: int) -> str:
    """The top-level key under which ``text`` nests deeper than ``limit`` (a scan of
    strings and brackets, for the message when the recursive JSON reader gave up)."""
    depth, key = 0, "?"
    for tok in _TOKEN.finditer(text):
        c = tok.group()
        if c in "[{":
            depth += 1
            if depth > limit:
                return key
        elif c in "]}":
            depth -= 1
        elif depth == 1 and _COLON.match(text, tok.end()):
            key = c[1:-1]
    return key


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise ValueError(f"key {k!r} appears more than once in one object")
        out[k] = v
    return out


def _kind(x: Any) -> str:
    if x is None:
        return "null"
    if isinstance(x, bool):
        return "a boolean"
    if isinstance(x, str):
        return f"the string {x[:40]!r}"
    if isinstance(x, list):
        return f"a list of {len(x)}"
    if isinstance(x, dict):
        return "an object"
    return f"the number {x!r}"


def _number(x: Any, key: str) -> float:
    if isinstance(x, bool) or not isinstance(x, int | float):
        raise ValueError(f"key {key!r}: expected a number, got {_kind(x)}")
    if isinstance(x, int) and abs(x) > 2**1023:
        raise ValueError(f"key {key!r}: the number {x} is beyond the float range")
    if not math.isfinite(x):
        raise ValueError(f"key {key!r}: expected a finite number, got {x!r}")
    return float(x)


def _integer(x: Any, key: str, minimum: int) -> int:
    if isinstance(x, bool) or not isinstance(x, int):
        raise ValueError(f"key {key!r}: expected a whole number >= {minimum}, got {_kind(x)}")
    if x < minimum:
        raise ValueError(f"key {key!r}: expected a whole number >= {minimum}, got {x}")
    return x


def _vector(x: Any, key: str, size: int | None) -> np.ndarray:
    if not isinstance(x, list):
        want = "a list" if size is None else f"a list of {size} numbers"
        raise ValueError(f"key {key!r}: expected {want}, got {_kind(x)}")
    if size is not None and len(x) != size:
        raise ValueError(f"key {key!r}: expected {size} numbers, got {len(x)}")
    return np.array([_number(v, f"{key}[{i}]") for i, v in enumerate(x)], dtype=float)


def _matrix(x: Any, key: str, rows: int, cols: int, dims: str) -> np.ndarray:
    want = f"a {rows} x {cols} matrix ({dims}) as a list of {rows} rows of {cols} numbers"
    if not isinstance(x, list):
        raise ValueError(f"key {key!r}: expected {want}, got {_kind(x)}")
    if len(x) != rows:
        raise ValueError(f"key {key!r}: expected {want}, got {len(x)} rows")
    out = np.empty((rows, cols))
    for i, row in enumerate(x):
        if not isinstance(row, list) or len(row) != cols:
            got = f"{len(row)} numbers" if isinstance(row, list) else _kind(row)
            raise ValueError(f"key {key!r}: row {i}: expected {cols} numbers ({dims}), got {got}")
        for j, v in enumerate(row):
            out[i, j] = _number(v, f"{key}[{i}][{j}]")
    return out


def _strings(x: Any, key: str, size: int) -> list[str]:
    if not isinstance(x, list) or len(x) != size:
        got = f"{len(x)} entries" if isinstance(x, list) else _kind(x)
        raise ValueError(f"key {key!r}: expected a list of {size} names, got {got}")
    for i, v in enumerate(x):
        if not isinstance(v, str):
            raise ValueError(f"key {key!r}[{i}]: expected a string, got {_kind(v)}")
    return list(x)


def _check_options(x: Any, key: str) -> None:
    """JSON values only, finite numbers; the depth is bounded by :func:`_check_depth`."""
    stack = [(x, key)]
    while stack:
        v, where = stack.pop()
        if isinstance(v, dict):
            stack.extend((w, f"{where}.{k}") for k, w in v.items())
        elif isinstance(v, list):
            stack.extend((w, f"{where}[{i}]") for i, w in enumerate(v))
        elif isinstance(v, float) and not math.isfinite(v):
            raise ValueError(f"key {where!r}: expected a finite number, got {v!r}")


@dataclass(frozen=True)
class RecordColumns:
    """Where a model's data came from: the columns of the file it was identified from.

    ``hdpbsid identify`` writes them into the model's ``options`` (keys ``columns``,
    ``sampling_interval``, ``source``; :meth:`to_options`), so that ``hdpbsid validate``
    reads another record of the same layout without being told the columns again
    (:meth:`from_options`).  This class is the one definition of those keys.

    Attributes
    ----------
    time : str or None
        The time column, or ``None`` when the record was given a sampling interval
        (``--dt``/``--fs``).
    inputs : list of str
        The input columns.
    outputs : list of str
        The output columns.
    sampling_interval : float or None, optional
        The sampling interval of the (first) identification record, or ``None``.
    source : str, list of str or None, optional
        The file(s) identified from.

    Examples
    --------
    >>> rc = RecordColumns(None, ["u"], ["y"], 0.1, "bb.csv")
    >>> RecordColumns.from_options(rc.to_options()) == rc
    True
    """

    time: str | None
    inputs: list[str]
    outputs: list[str]
    sampling_interval: float | None = None
    source: str | list[str] | None = None

    def to_options(self) -> dict[str, Any]:
        """The entries of a model's ``options`` that hold these columns.

        Returns
        -------
        dict
            ``columns`` (``time``, ``inputs``, ``outputs``), ``sampling_interval``,
            ``source``.
        """
        columns = {"time": self.time, "inputs": self.inputs, "outputs": self.outputs}
        return {
            "columns": columns,
            "sampling_interval": self.sampling_interval,
            "source": self.source,
        }

    @classmethod
    def from_options(cls, options: Mapping[str, Any]) -> RecordColumns | None:
        """The columns stored in a model's ``options``, ``None`` when it has none (a model
        identified from Python).

        Parameters
        ----------
        options : mapping
            A model's ``options``.

        Returns
        -------
        RecordColumns or None
            The columns; ``sampling_interval`` only when it is a positive number.

        Raises
        ------
        ValueError
            When ``options["columns"]`` is not an object with ``time`` (a name or null),
            ``inputs`` and ``outputs`` (lists of names).
        """
        cols = options.get("columns")
        if cols is None:
            return None
        ok = isinstance(cols, dict) and isinstance(cols.get("time"), str | None)
        for key in ("inputs", "outputs"):
            names = cols.get(key) if isinstance(cols, dict) else None
            ok = ok and isinstance(names, list) and all(isinstance(c, str) for c in names)
        if not ok:
            raise ValueError(
                "key 'options.columns' must be an object with 'time' (a name or null), "
                f"'inputs' and 'outputs' (lists of names), got {cols!r:.200}"
            )
        dt = options.get("sampling_interval")
        dt = float(dt) if isinstance(dt, int | float) and dt > 0 else None
        src = options.get("source")
        return cls(cols["time"], list(cols["inputs"]), list(cols["outputs"]), dt, src)


def _legacy_names(options: dict[str, Any], which: str, size: int) -> list[str] | None:
    """Channel names of a version-1 file: the CLI stored the column names in
    ``options["columns"]``; ``None`` when they are absent or do not fit."""
    cols = options.get("columns")
    names = cols.get(which) if isinstance(cols, dict) else None
    if isinstance(names, list) and len(names) == size and all(isinstance(s, str) for s in names):
        if len(set(names)) == size and all(s.strip() and s.isprintable() for s in names):
            return names
    return None


def _header(d: dict[str, Any]) -> int:
    """Check the keys and the format tags; returns the format version."""
    unknown = sorted(set(d) - set(_KNOWN))
    if unknown:
        raise ValueError(f"unknown key(s) {unknown}; a model file has {list(_KNOWN)}")
    for k in _REQUIRED:
        if k not in d:
            raise ValueError(f"model description lacks the entry {k!r}")
    if "format" in d and d["format"] != FORMAT:
        raise ValueError(f"key 'format': expected {FORMAT!r}, got {_kind(d['format'])}")
    version = _integer(d.get("version", 1), "version", 1)
    if version > VERSION:
        raise ValueError(
            f"key 'version': {version} is newer than this hdpbsid reads ({VERSION}); update hdpbsid"
        )
    if d.get("time", "continuous") != "continuous":
        raise ValueError(f"key 'time': expected 'continuous', got {_kind(d.get('time'))}")
    return version


def _trend(x: Any, m: int, l: int) -> LinearTrend | None:
    if x is None:
        return None
    if not isinstance(x, dict):
        raise ValueError(f"key 'trend': expected null or an object, got {_kind(x)}")
    keys = ("t_ref", "u_slope", "y_slope")
    extra = sorted(set(x) - set(keys))
    if extra:
        raise ValueError(f"key 'trend': unknown key(s) {extra}; a trend has {list(keys)}")
    for k in keys:
        if k not in x:
            raise ValueError(f"key 'trend.{k}': missing (a trend needs t_ref, u_slope, y_slope)")
    return LinearTrend(
        _number(x["t_ref"], "trend.t_ref"),
        _vector(x["u_slope"], "trend.u_slope", m),
        _vector(x["y_slope"], "trend.y_slope", l),
    )


def _eigenvalues(x: Any, n: int) -> None:
    """Shape and finiteness only: the model recomputes its eigenvalues from ``A``."""
    if not isinstance(x, list) or len(x) != n:
        got = f"{len(x)} entries" if isinstance(x, list) else _kind(x)
        raise ValueError(f"key 'eigenvalues': expected a list of {n} (n) objects, got {got}")
    for i, e in enumerate(x):
        if not isinstance(e, dict) or set(e) != {"real", "imag"}:
            raise ValueError(f"key 'eigenvalues[{i}]': expected {{'real': .., 'imag': ..}}")
        _number(e["real"], f"eigenvalues[{i}].real")
        _number(e["imag"], f"eigenvalues[{i}].imag")


def model_from_dict(d: Any) -> StateSpaceModel:
    """Rebuild a model from :func:`model_to_dict`'s description, checking every key.

    Version-1 descriptions (written before the labels were stored) load with the time
    unit ``"s"``, the channel names of ``options["columns"]`` when they fit, and the
    sampling interval of ``options["sampling_interval"]`` when it is a positive number.

    Parameters
    ----------
    d : dict
        The parsed JSON object.

    Returns
    -------
    StateSpaceModel
        The model (``discrete`` is not stored: ``None``).

    Raises
    ------
    ValueError
        Naming the key, for an unknown, repeated or missing key, a value of the wrong
        type (a string for a number, ``2.7`` for an integer), a non-finite number, a
        matrix whose shape does not follow from ``n``, ``m``, ``l``, or a trend without
        ``t_ref``.

    Examples
    --------
    >>> from hdpbsid import StateSpaceModel
    >>> m0 = StateSpaceModel([[-2.0]], [[1.0]], [[3.0]], [[0.0]], [[0.0]])
    >>> m = model_from_dict(model_to_dict(m0))
    >>> m.eigenvalues.real.tolist()
    [-2.0]
    """
    if not isinstance(d, dict):
        raise ValueError(f"a model description must be a JSON object, got {_kind(d)}")
    _check_depth(d, MAX_DEPTH)
    version = _header(d)
    n = _integer(d["n"], "n", 0)
    m = _integer(d["m"], "m", 0)
    l = _integer(d["l"], "l", 1)
    shapes = {
        "A": (n, n, "n x n"),
        "B": (n, m, "n x m"),
        "C": (l, n, "l x n"),
        "D": (l, m, "l x m"),
        "K": (n, l, "n x l"),
    }
    mats = [_matrix(d[k], k, *shapes[k]) for k in "ABCDK"]
    options = _options(d)
    nc = d.get("noise_covariance")
    sv = _singular_values(d, n)
    u0 = d.get("u0")
    y0 = d.get("y0")
    unit, inames, onames, dt = _labels(d, options, version, m, l)
    delay = _delay(d, version, m)
    cov = _parameter_covariance(d, options, version, n, m, l)
    fields: list[tuple[str, Any]] = [
        ("time_unit", unit),
        ("input_names", inames),
        ("output_names", onames),
        ("sampling_interval", dt),
        ("delay", delay),
    ]
    try:
        model = StateSpaceModel(
            *mats,
            singular_values=sv,
            options=dict(options),
            noise_covariance=None if nc is None else _matrix(nc, "noise_covariance", l, l, "l x l"),
            u0=None if u0 is None else _vector(u0, "u0", m),
            y0=None if y0 is None else _vector(y0, "y0", l),
            trend=_trend(d.get("trend"), m, l),
            parameter_covariance=cov,
            **dict(fields),
        )
    except (ValueError, TypeError) as exc:  # the labels' own checks name the argument
        raise ValueError(f"key {_culprit(str(exc), fields)!r}: {exc}") from exc
    return model


def _options(d: dict[str, Any]) -> dict[str, Any]:
    """The model description's ``options`` (an empty dict when absent), checked."""
    options = d.get("options")
    if options is None:
        options = {}
    if not isinstance(options, dict):
        raise ValueError(f"key 'options': expected an object, got {_kind(options)}")
    _check_options(options, "options")
    return options


def _singular_values(d: dict[str, Any], n: int) -> Any:
    """The description's singular values (None when absent), after its eigenvalues are
    checked against ``n``."""
    sv = d.get("singular_values")
    if "eigenvalues" in d:
        _eigenvalues(d["eigenvalues"], n)
    if sv is not None:
        sv = _vector(sv, "singular_values", None)
        if np.any(sv < 0):
            raise ValueError("key 'singular_values': expected non-negative numbers")
    return sv


def _labels(
    d: dict[str, Any], options: dict[str, Any], version: int, m: int, l: int
) -> tuple[str, Any, Any, float | None]:
    """``(time_unit, input_names, output_names, sampling_interval)`` of a description:
    keys of their own from version 2 on, entries of ``options`` before."""
    unit = d.get("time_unit", "s")
    if not isinstance(unit, str):
        raise ValueError(f"key 'time_unit': expected a string, got {_kind(unit)}")
    if version >= 2:
        inames = _strings(d["input_names"], "input_names", m) if "input_names" in d else None
        onames = _strings(d["output_names"], "output_names", l) if "output_names" in d else None
        dt = d.get("sampling_interval")
    else:
        inames = _legacy_names(options, "inputs", m)
        onames = _legacy_names(options, "outputs", l)
        dt = options.get("sampling_interval")
        dt = dt if isinstance(dt, int | float) and not isinstance(dt, bool) and dt > 0 else None
    if dt is not None:
        dt = _number(dt, "sampling_interval")
    return unit, inames, onames, dt


def _delay(d: dict[str, Any], version: int, m: int) -> Any:
    """The description's dead times (None when absent; version 3 on)."""
    if "delay" not in d:
        return None
    if version < 3:
        raise ValueError(f"key 'delay': not part of a version-{version} file (version 3 on)")
    delay = _vector(d["delay"], "delay", m)
    if np.any(delay < 0):
        raise ValueError(f"key 'delay': expected dead times >= 0, got {delay.tolist()}")
    return delay


def _parameter_covariance(
    d: dict[str, Any], options: dict[str, Any], version: int, n: int, m: int, l: int
) -> ParameterCovariance | None:
    """The ``parameter_covariance`` entry (version 4), or a version-3 file's
    ``options["parameter_covariance"]`` factor (removed from the options), checked:
    ``p = n^2 + nm + ln + lm`` rows of finite numbers."""
    p = parameter_count(n, m, l)
    if "parameter_covariance" in d:
        if version < 4:
            raise ValueError(
                f"key 'parameter_covariance': not part of a version-{version} file (version 4 on)"
            )
        x = d["parameter_covariance"]
        if x is None:
            return None
        if not isinstance(x, dict) or set(x) != {"factor", "source"}:
            raise ValueError(
                "key 'parameter_covariance': expected null or an object with exactly "
                f"'factor' and 'source', got {_kind(x) if not isinstance(x, dict) else sorted(x)}"
            )
        if not isinstance(x["source"], str):
            raise ValueError(
                f"key 'parameter_covariance.source': expected a string, got {_kind(x['source'])}"
            )
        return ParameterCovariance(
            _factor(x["factor"], "parameter_covariance.factor", p), x["source"]
        )
    if version == 3 and "parameter_covariance" in options:
        F = _factor(options.pop("parameter_covariance"), "options.parameter_covariance", p)
        return ParameterCovariance(F, "options (version-3 file)")
    return None


def _factor(x: Any, key: str, p: int) -> np.ndarray:
    """A ``p x k`` matrix of finite numbers (``k >= 1``)."""
    cols = len(x[0]) if isinstance(x, list) and x and isinstance(x[0], list) else 0
    if cols == 0:
        raise ValueError(f"key {key!r}: expected a {p} x k matrix (k >= 1), got {_kind(x)}")
    return _matrix(x, key, p, cols, f"{p} x k (n^2 + nm + ln + lm rows)")


def _culprit(message: str, fields: list[tuple[str, Any]]) -> str:
    for k, _ in fields:
        if message.startswith(k):
            return k
    return "model"


def load_model(path: str | Path, max_bytes: int = MAX_BYTES) -> StateSpaceModel:
    """Read a model written by :meth:`StateSpaceModel.save` / :func:`save_model` (or by
    ``hdpbsid identify``), checking every key (module docstring).

    Parameters
    ----------
    path : str or pathlib.Path
        The JSON model file.
    max_bytes : int
        Largest file accepted (default :data:`MAX_BYTES`).

    Returns
    -------
    StateSpaceModel
        The model, with its operating point, labels and options.

    Raises
    ------
    ValueError
        Naming the file (and the key), when the file is missing, larger than
        ``max_bytes``, not UTF-8, not JSON, nested deeper than :data:`MAX_DEPTH`, or not
        a valid model description (:func:`model_from_dict`).
    TypeError
        When ``path`` is not a path.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from hdpbsid import StateSpaceModel
    >>> m = StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]], time_unit="ms")
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     back = load_model(m.save(pathlib.Path(tmp) / "m.json"))
    >>> back.time_unit
    'ms'
    """
    if not isinstance(path, str | Path):
        raise TypeError(f"path must be a str or pathlib.Path, got {type(path).__name__}")
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path}: is a directory; give the model file inside it")
    if not path.is_file():
        raise ValueError(f"model file not found: {path}")
    try:
        size = path.stat().st_size
        if size > max_bytes:
            raise ValueError(
                f"{path}: {size} bytes, more than a model file may have ({max_bytes}; "
                f"pass max_bytes= to read a larger one)"
            )
        with path.open("rb") as f:
            raw = f.read(max_bytes + 1)
    except OSError as exc:  # permissions, a file that vanished
        raise ValueError(f"{path}: cannot read the file: {exc.strerror or exc}") from exc
    if len(raw) > max_bytes:  # grew since stat
        raise ValueError(f"{path}: more than a model file may have ({max_bytes} bytes)")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise ValueError(
            f"{path}: not UTF-8 text (invalid byte at offset {exc.start}); a model file is "
            f"the JSON that model.save writes"
        ) from exc
    try:
        d = json.loads(text, object_pairs_hook=_no_duplicates)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{path}: not a JSON model file: {exc}") from exc
    except RecursionError as exc:  # deeper than the reader's own recursion allows
        raise ValueError(
            f"{path}: key {_deep_key(text, MAX_DEPTH)!r} nests arrays/objects deeper than "
            f"the JSON reader can follow; a model file nests at most {MAX_DEPTH} levels"
        ) from exc
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc
    try:
        return model_from_dict(d)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from exc
