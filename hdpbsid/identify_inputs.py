"""What :func:`hdpbsid.identify.identify` does to its inputs before a method sees them.

The list form of several records checked record by record, a
:class:`~hdpbsid.data.records.Dataset` turned into that list, the channel names and time
unit checked against the channel counts, channels far outside the float64 comfort band
scaled by powers of two (and the model scaled back), a constant input warned about, and
the records' operating points averaged.  Mechanism only: :mod:`hdpbsid.identify` decides
when each step runs.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from hdpbsid.data.checks import (
    check_data,
    check_label,
    check_names,
    check_time,
    check_varies,
    scale_exponents,
)
from hdpbsid.data.detrend import Levels
from hdpbsid.data.records import Dataset, Labels
from hdpbsid.models.model import StateSpaceModel, scale_signals
from hdpbsid.runtime import user_stacklevel

__all__: list[str] = []


def _check_records(records: Any) -> list[tuple[Any, Any, Any]]:
    """The list form ``[(t1, u1, y1), ...]``: every record checked, channel counts equal."""
    if len(records) == 0:
        raise ValueError("t: the list of records is empty; pass at least one (t, u, y)")
    out = []
    for i, rec in enumerate(records):
        if not isinstance(rec, tuple | list) or len(rec) != 3:
            raise TypeError(f"t[{i}] must be a (t, u, y) tuple, got {type(rec).__name__}")
        try:
            tt, uu, yy = check_data(*rec)
            check_varies(yy)
        except (ValueError, TypeError) as exc:
            raise type(exc)(f"record {i}: {exc}") from exc
        out.append((tt, None if rec[1] is None else uu, yy))
        m0, l0 = check_data(*out[0])[1].shape[1], out[0][2].shape[1]
        if uu.shape[1] != m0 or yy.shape[1] != l0:
            raise ValueError(
                f"record {i} has {uu.shape[1]} input(s) and {yy.shape[1]} output(s); "
                f"record 0 has {m0} and {l0}: every record needs the same channels"
            )
    return out


def _listed(t: Any, u: Any, y: Any) -> Any:
    """``t``, or the list form of a :class:`~hdpbsid.data.records.Dataset` given as ``t``
    (its records, checked again with the list form's messages)."""
    if not isinstance(t, Dataset):
        return t
    if u is not None or y is not None:
        raise ValueError("with a Dataset in t, leave u and y out (u=None, y=None)")
    return list(t)


def _weighted_levels(levels: list[Levels]) -> tuple[Any, Any]:
    """Sample-weighted mean operating point ``sum N_i x0_i / sum N_i``."""
    w = np.array([lv.samples for lv in levels], dtype=float)
    u0 = np.sum([wi * lv.u0 for wi, lv in zip(w, levels, strict=True)], axis=0) / w.sum()
    y0 = np.sum([wi * lv.y0 for wi, lv in zip(w, levels, strict=True)], axis=0) / w.sum()
    return u0, y0


class _Labels:
    """The channel names and time unit given to :func:`~hdpbsid.identify.identify`,
    checked before any computation against the channel counts of the first record."""

    def __init__(self, inputs: Any, outputs: Any, time_unit: Any, t: Any, u: Any, y: Any) -> None:
        if isinstance(t, list | tuple) and len(t) and isinstance(t[0], list | tuple):
            u, y = (t[0][1], t[0][2]) if len(t[0]) == 3 else (None, None)
        m = 0 if u is None else _channels(u)
        l = None if y is None else _channels(y)
        self.time_unit = check_label(time_unit, "time_unit")
        # the counts are checked here when the signals have a shape (else the data checks
        # report them, and apply() checks the names against the model)
        self.inputs, self.outputs = inputs, outputs
        if inputs is not None and m is not None:
            self.inputs = check_names(inputs, "input_names", m, "u")
        if outputs is not None and l is not None:
            self.outputs = check_names(outputs, "output_names", l, "y")

    def as_labels(self) -> Labels:
        """The names and unit as the :class:`~hdpbsid.data.records.Labels` of a Dataset."""
        names = [
            None if n is None else tuple(str(x) for x in n) for n in (self.inputs, self.outputs)
        ]
        return Labels(names[0], names[1], self.time_unit)

    def apply(self, model: StateSpaceModel, records: Any) -> None:
        """Label ``model`` (and its sampled model) and record the median step of the
        records' times as ``model.sampling_interval``."""
        steps = [np.diff(check_time(r[0], "t")) for r in records]
        for mod in (model, model.discrete):
            if mod is not None:
                mod.set_labels(self.inputs, self.outputs, self.time_unit)
        model.sampling_interval = float(np.median(np.concatenate(steps)))


class _Scaling:
    """Channels far outside the float64 comfort band, scaled by powers of two for the
    identification and the model scaled back (:func:`~hdpbsid.data.checks.scale_exponents`):
    the result is the model of the unscaled record, since a power-of-two scaling is
    exact and the methods are invariant to the signals' units.  The state takes the
    inputs' scale, so ``B`` keeps moderate entries and ``C``, ``D`` carry the gain."""

    def __init__(self, t: Any, u: Any, y: Any, several: bool) -> None:
        recs = [r for r in t if isinstance(r, list | tuple) and len(r) == 3] if several else []
        pairs = [(r[1], r[2]) for r in recs] if several else [(u, y)]
        pu = [scale_exponents(uu, "u") for uu, _ in pairs if uu is not None]
        py = [scale_exponents(yy, "y") for _, yy in pairs if yy is not None]
        # one exponent per channel for all records (the same units): the smallest, so
        # that no record's largest value grows beyond the band
        self.pu = _common(pu)
        self.py = _common(py)
        self.active = bool(np.any(self.pu) or np.any(self.py))

    def apply(self, t: Any, u: Any, y: Any) -> tuple[Any, Any, Any]:
        if not self.active:
            return t, u, y
        if isinstance(t, list | tuple) and u is None and y is None:
            return [(r[0], self._u(r[1]), self._y(r[2])) for r in t], None, None
        return t, self._u(u), self._y(y)

    def _u(self, x: Any) -> Any:
        return x if x is None or not np.any(self.pu) else _ldexp(x, self.pu)

    def _y(self, x: Any) -> Any:
        return x if x is None or not np.any(self.py) else _ldexp(x, self.py)

    def undo(self, model: StateSpaceModel, info: Any) -> tuple[StateSpaceModel, Any]:
        if not self.active:
            return model, info
        pu = self.pu if self.pu.size else np.zeros(model.m, dtype=np.int64)
        py = self.py if self.py.size else np.zeros(model.l, dtype=np.int64)
        # the state in the inputs' scale (the outputs' without inputs): B (and K of a time
        # series) keep the entries they had, C and D carry the gain -- the sampled
        # model's augmented exponential takes A, B and K, and must not see huge entries
        px = -int(round(float(np.mean(pu if pu.size else py))))
        model = scale_signals(model, -pu, -py, px)
        model.options["signal_scaling"] = {
            "u_exponents": pu.tolist(),
            "y_exponents": py.tolist(),
            "note": "channels scaled by 2**exponent for the identification; option "
            "values in signal units refer to the scaled signals",
        }
        return model, _unscale_levels(info, pu, py)


def _common(exps: list[Any]) -> Any:
    exps = [e for e in exps if e.size]
    if not exps or len({e.size for e in exps}) > 1:
        return np.zeros(0 if not exps else exps[0].size, dtype=np.int64)  # checks report
    return np.min(np.stack(exps), axis=0)


def _ldexp(x: Any, p: Any) -> Any:
    """``x * 2^p`` per column (a 1-D ``x`` is one channel); ``x`` left to the data
    checks when it is not a numeric array of the right width."""
    arr = np.asarray(x) if isinstance(x, np.ndarray | list | tuple) else None
    if arr is None or arr.dtype.kind not in "biuf":
        return x  # the data checks name what is wrong with it
    if arr.ndim == 1 and p.size == 1:
        return np.ldexp(arr, int(p[0]))
    if arr.ndim == 2 and arr.shape[1] == p.size:
        return np.ldexp(arr, p[None, :])
    return x


def _unscale_levels(info: Any, pu: Any, py: Any) -> Any:
    """The operating points of ``options["operating_points"]`` in the record's units."""
    if isinstance(info, list):
        return [_unscale_levels(d, pu, py) for d in info]
    out = dict(info)
    for key, p in (("u0", pu), ("u_slope", pu), ("y0", py), ("y_slope", py)):
        if key in out:
            out[key] = np.ldexp(np.asarray(out[key], dtype=float), -p).tolist()
    return out


def _channels(x: Any) -> int | None:
    """Columns of a signal given as ``(Ns,)`` or ``(Ns, k)``; ``None`` for a ragged one
    (the data checks report it)."""
    try:
        shape = np.shape(x)
    except ValueError:
        return None
    return 1 if len(shape) < 2 else int(shape[1])


def _warn_not_exciting(u: Any) -> None:
    """Warn when an input column is constant: a constant input excites no dynamics
    (it is not persistently exciting of any order), so ``B`` is not identifiable from
    the record -- the model would describe the noise and initial conditions only."""
    if u is None:
        return
    try:
        ua = np.asarray(u)
    except (TypeError, ValueError):  # ragged: the data checks name it
        return
    if ua.dtype.kind not in "biuf":
        return  # complex, text, objects: the data checks name them
    ua = ua.astype(float)
    ua = ua[:, None] if ua.ndim == 1 else ua
    if ua.ndim != 2 or ua.shape[0] < 2:
        return  # the method's checks report malformed input
    spread = np.ptp(ua, axis=0)
    level = np.max(np.abs(ua), axis=0)
    for k in np.flatnonzero(spread <= 1e-12 * np.maximum(level, np.finfo(float).tiny)):
        warnings.warn(
            f"u[:, {k}] is constant: the input is not persistently exciting, so its effect "
            f"(B) cannot be identified from this record; excite the system (steps, a "
            f"multisine, a random binary signal) or leave the input out",
            UserWarning,
            stacklevel=user_stacklevel(),
        )
