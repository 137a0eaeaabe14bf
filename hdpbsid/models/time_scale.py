"""Whether a record's time scale matches a model's: units and sampling intervals.

A model's eigenvalues are in rad per its ``time_unit``; a record whose times are in
another unit simulates without error and fits meaninglessly.  Two checks flag it, each
only when both sides are known: the record's declared unit differs from the model's, or
its median step differs from the identification record's by more than
:attr:`TimeScaleSettings.sampling_ratio_limit` either way (:func:`check_time_scale`).
Neither is an error: the exact sampled model simulates any step size, so the checks warn
(:class:`TimeScaleWarning`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from hdpbsid.data.checks import check_label, check_time
from hdpbsid.runtime import user_stacklevel

__all__ = [
    "TimeScaleWarning",
    "TimeScaleSettings",
    "TIME_SCALE",
    "TIME_UNITS",
    "SAMPLING_RATIO_LIMIT",
    "check_time_scale",
]


class TimeScaleWarning(UserWarning):
    """A record's time scale does not match the model's: its time unit differs, or its
    sampling interval is more than :data:`SAMPLING_RATIO_LIMIT` times larger or smaller
    than the identification record's (:meth:`StateSpaceModel.check_record`)."""


#: Seconds per unit of the time units the messages can convert between.  Any other
#: non-empty name is accepted as a label; it is only compared for equality.
TIME_UNITS: dict[str, float] = {
    "ns": 1e-9,
    "us": 1e-6,
    "\u00b5s": 1e-6,
    "ms": 1e-3,
    "s": 1.0,
    "min": 60.0,
    "h": 3600.0,
    "d": 86400.0,
}


@dataclass(frozen=True)
class TimeScaleSettings:
    """When a record's sampling interval is taken for another time unit.

    Attributes
    ----------
    sampling_ratio_limit : float
        A record whose median sampling interval differs from the model's by more than
        this factor (either way) draws a :class:`TimeScaleWarning`.
    """

    #: Resampling a record of the same system by a factor up to 10 is routine (a 1 kHz
    #: log validated at 100 Hz), and the exact sampled model simulates any step size, so
    #: such records are not flagged; a time stamp in the wrong unit changes the interval
    #: by at least 24 (hours and days), usually 60 (seconds and minutes) or 1000
    #: (milliseconds and seconds).  20 lies between the two, so every wrong common unit
    #: is flagged and no routine resampling is.
    sampling_ratio_limit: float = 20.0


#: The settings in force.
TIME_SCALE = TimeScaleSettings()
#: :attr:`TimeScaleSettings.sampling_ratio_limit` of :data:`TIME_SCALE`.
SAMPLING_RATIO_LIMIT = TIME_SCALE.sampling_ratio_limit


def check_time_scale(
    t: Any,
    time_unit: str | None,
    model_unit: str,
    sampling_interval: float | None,
    name: str = "t",
) -> None:
    """Warn when a record's time scale does not match a model's (module docstring).

    Parameters
    ----------
    t : array_like, shape (Ns,)
        The record's sample times.
    time_unit : str or None
        The unit of ``t``, if known.
    model_unit : str
        The model's time unit.
    sampling_interval : float or None
        The identification record's median step in ``model_unit``, if known.
    name : str, optional
        The argument's name in the messages.

    Warns
    -----
    TimeScaleWarning
        When the units differ (the message gives the conversion factor for the units of
        :data:`TIME_UNITS`), else when the median steps are more than
        :data:`SAMPLING_RATIO_LIMIT` apart.

    Raises
    ------
    ValueError
        If ``t`` is not a strictly increasing finite vector, or ``time_unit`` is empty.
    """
    if time_unit is not None:
        unit = check_label(time_unit, "time_unit")
        if unit != model_unit:
            warnings.warn(
                _unit_message(unit, model_unit),
                TimeScaleWarning,
                stacklevel=user_stacklevel(),
            )
            return  # the step comparison would repeat the same finding
    if sampling_interval is None:
        return
    tt = check_time(t, name)
    h = float(np.median(np.diff(tt)))
    ratio = h / sampling_interval
    limit = TIME_SCALE.sampling_ratio_limit
    if not 1.0 / limit <= ratio <= limit:
        warnings.warn(
            f"{name}: the record's median sampling interval {h:.6g} is {ratio:.3g} times "
            f"the identification record's {sampling_interval:.6g} {model_unit} "
            f"(more than a factor {limit:g} apart): are its times in "
            f"{model_unit}?  A record in another time unit fits meaninglessly; "
            f"convert its times, or ignore this if it was only resampled",
            TimeScaleWarning,
            stacklevel=user_stacklevel(),
        )


def check_interval(value: Any, name: str) -> float | None:
    """A sampling interval: ``None``, or a positive finite number as a float.

    Parameters
    ----------
    value : float or None
        The interval.
    name : str
        Its name in the messages.

    Returns
    -------
    float or None
        ``value`` as a float, or None.

    Raises
    ------
    TypeError
        If ``value`` is not a number (a bool is not).
    ValueError
        If it is not positive and finite.
    """
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a positive number or None, got {value!r}")
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number or None, got {value!r}")
    return float(value)


def _unit_message(record: str, model: str) -> str:
    """The warning for a record whose time unit differs from the model's."""
    hint = ""
    if record in TIME_UNITS and model in TIME_UNITS:
        f = TIME_UNITS[record] / TIME_UNITS[model]
        hint = f" (1 {record} = {f:g} {model}: multiply the record's times by {f:g})"
    return (
        f"the record's time unit {record!r} differs from the model's {model!r}{hint}; "
        f"the eigenvalues are in rad/{model} and a record in another unit fits meaninglessly"
    )
