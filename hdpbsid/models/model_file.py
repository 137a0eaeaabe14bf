"""Writing a model file: the JSON description of a model (:mod:`hdpbsid.models.model_io`
documents the format and reads it back).

Kept apart from the reader because it needs nothing but the model's attributes:
:meth:`hdpbsid.models.model.StateSpaceModel.save` calls :func:`write_model` without the
model module and the file module importing each other.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["FileFormat", "FILE_FORMAT", "FORMAT", "VERSION", "describe", "write_model"]

FORMAT = "hdpbsid.StateSpaceModel"


@dataclass(frozen=True)
class FileFormat:
    """The model file's format version.

    Attributes
    ----------
    version : int
        The version written; readers refuse newer ones.
    """

    #: the format's version: raised whenever a key is added or changes meaning, so that a
    #: reader refuses a file newer than it can read instead of misreading it
    version: int = 4


#: The format written.
FILE_FORMAT = FileFormat()
#: :attr:`FileFormat.version` of :data:`FILE_FORMAT`
VERSION = FILE_FORMAT.version


def _jsonable(x: Any) -> Any:
    """Convert numpy arrays/scalars, complex numbers and containers to JSON values.

    Complex numbers become ``{"real": ..., "imag": ...}``; anything else unknown becomes
    its ``repr`` (options may hold callables or objects; they are recorded, not lost), and
    so do non-finite floats (JSON has no NaN).
    """
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, np.generic):
        return _jsonable(x.item())
    if isinstance(x, complex):
        return {"real": _jsonable(x.real), "imag": _jsonable(x.imag)}
    if isinstance(x, float):
        return x if math.isfinite(x) else repr(x)
    if x is None or isinstance(x, bool | int | str):
        return x
    return repr(x)


def describe(model: Any) -> dict[str, Any]:
    """The JSON-ready description of a continuous model.

    Parameters
    ----------
    model : StateSpaceModel
        The model (its type is checked by the caller, :func:`write_model`'s).

    Returns
    -------
    dict
        Format name and version, dimensions, the matrices, operating point, trend, noise
        and parameter covariances, eigenvalues (for readers without a linear-algebra
        library), singular values, labels, sampling interval, dead times and the options
        (numpy values converted, non-finite floats as their ``repr``).
    """
    sv = model.singular_values
    tr = model.trend
    nc = model.noise_covariance
    return {
        "format": FORMAT,
        "version": VERSION,
        "time": "continuous",
        "n": model.n,
        "m": model.m,
        "l": model.l,
        "A": model.A.tolist(),
        "B": model.B.tolist(),
        "C": model.C.tolist(),
        "D": model.D.tolist(),
        "K": model.K.tolist(),
        "u0": model.u0.tolist(),
        "y0": model.y0.tolist(),
        "trend": None
        if tr is None
        else {"t_ref": tr.t_ref, "u_slope": tr.u_slope.tolist(), "y_slope": tr.y_slope.tolist()},
        "noise_covariance": None if nc is None else np.asarray(nc, dtype=float).tolist(),
        "eigenvalues": [{"real": float(e.real), "imag": float(e.imag)} for e in model.eigenvalues],
        "singular_values": None if sv is None else np.asarray(sv, dtype=float).ravel().tolist(),
        "time_unit": model.time_unit,
        "input_names": list(model.input_names or []),
        "output_names": list(model.output_names or []),
        "sampling_interval": model.sampling_interval,
        "delay": model.delay.tolist(),
        "parameter_covariance": None
        if model.parameter_covariance is None
        else {
            "factor": model.parameter_covariance.factor.tolist(),
            "source": model.parameter_covariance.source,
        },
        "options": _jsonable(model.options),
    }


def write_model(model: Any, path: str | Path) -> Path:
    """Write :func:`describe` of a model to a file as indented JSON.

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    path : str or path-like
        The file; missing parent directories are created.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    ValueError
        If ``path`` is an existing directory.
    """
    path = Path(path)
    if path.is_dir():
        raise ValueError(f"{path}: is a directory; give the model file's name")
    text = json.dumps(describe(model), indent=2, allow_nan=False) + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path
