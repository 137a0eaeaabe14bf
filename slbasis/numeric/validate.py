"""Input checks shared by the numeric layer (clear errors naming the argument)."""

from __future__ import annotations

import numpy as np

__all__ = ["as_times", "as_signal", "as_int_at_least"]


def as_int_at_least(value, name: str, low: int = 1) -> int:
    """``value`` as an ``int >= low``, or an error naming ``name``.

    Parameters
    ----------
    value : int or float
        An integer (a float with an integer value is accepted; a bool is not).
    name : str
        The argument's name in messages.
    low : int, optional
        The smallest value allowed.

    Returns
    -------
    int
        The value.

    Raises
    ------
    TypeError
        If ``value`` is not an integer.
    ValueError
        If ``value < low``.

    Examples
    --------
    >>> as_int_at_least(4.0, "N")
    4
    """
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        if isinstance(value, (float, np.floating)) and float(value).is_integer():
            value = int(value)
        else:
            raise TypeError(f"{name}: expected an integer, got {type(value).__name__}")
    if value < low:
        raise ValueError(f"{name}: expected an integer >= {low}, got {value}")
    return int(value)


def as_times(t, name: str = "t", *, increasing: bool = True, min_len: int = 1) -> np.ndarray:
    """A finite 1-D float array of times (strictly increasing if ``increasing``).

    Parameters
    ----------
    t : array_like
        The times.
    name : str, optional
        The argument's name in messages.
    increasing : bool, optional
        Require strictly increasing times.
    min_len : int, optional
        The fewest samples allowed.

    Returns
    -------
    ndarray, shape (Ns,)
        The times.

    Raises
    ------
    TypeError
        If ``t`` is not numeric.
    ValueError
        If ``t`` is not 1-D, too short, not finite, or not increasing.
    """
    try:
        ta = np.asarray(t, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected a 1-D array of numbers") from exc
    if ta.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array, got shape {ta.shape}")
    if ta.size < min_len:
        raise ValueError(f"{name}: expected at least {min_len} samples, got {ta.size}")
    if not np.all(np.isfinite(ta)):
        raise ValueError(f"{name}: contains NaN or inf")
    if increasing and ta.size > 1 and not np.all(np.diff(ta) > 0):
        raise ValueError(f"{name}: sample times must be strictly increasing")
    return ta


def as_signal(y, ns: int, name: str = "y") -> np.ndarray:
    """A finite ``(ns,)`` or ``(ns, k)`` float array.

    Parameters
    ----------
    y : array_like
        The signal.
    ns : int
        The number of samples required.
    name : str, optional
        The argument's name in messages.

    Returns
    -------
    ndarray, shape (ns,) or (ns, k)
        The signal.

    Raises
    ------
    TypeError
        If ``y`` is not numeric.
    ValueError
        If ``y`` has the wrong shape or is not finite.
    """
    try:
        ya = np.asarray(y, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name}: expected an array of numbers") from exc
    if ya.ndim not in (1, 2) or ya.shape[0] != ns:
        raise ValueError(f"{name}: expected shape ({ns},) or ({ns}, k), got {ya.shape}")
    if not np.all(np.isfinite(ya)):
        raise ValueError(f"{name}: contains NaN or inf")
    return ya
