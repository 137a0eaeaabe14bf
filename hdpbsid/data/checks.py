"""Input checking shared by every identification routine.

Signal arrays follow the :func:`scipy.signal.lsim` convention (docs/user-guide.md, "Data
conventions"): ``t`` has shape ``(Ns,)``, ``u`` shape ``(Ns, m)`` and ``y`` shape ``(Ns, l)``; a 1-D
``u`` or ``y`` is accepted for a single channel.  Every problem raises a ``ValueError``
(or ``TypeError`` for non-numeric data) that names the argument and says what was
expected.  Nothing is silently clipped, reshaped beyond the 1-D -> one-column rule, or
dropped.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "CheckSettings",
    "CHECKS",
    "as_float_array",
    "check_time",
    "check_signal",
    "check_data",
    "check_varies",
    "ENERGY_HEADROOM",
    "check_uniform",
    "is_uniform",
    "uniform_tolerance",
    "UNIFORM_RTOL",
    "time_resolution",
    "check_positive_int",
    "check_matrix",
    "check_state_space",
    "MAX_LABEL",
    "check_label",
    "check_names",
    "SCALE_EXPONENT",
    "scale_exponents",
    "require_joblib",
]


def as_float_array(x: Any, name: str) -> NDArray[np.float64]:
    """Convert to a finite float64 array, rejecting complex, object and non-numeric data.

    Parameters
    ----------
    x : array_like
        Real numbers (booleans and integers are converted).
    name : str
        The argument's name in the messages.

    Returns
    -------
    ndarray of float64
        Same shape as ``x``.

    Raises
    ------
    TypeError
        If ``x`` is ``None``, complex, text or objects.
    ValueError
        If an entry is NaN or infinite (the message gives the count and the first index).

    Examples
    --------
    >>> as_float_array([1, 2], "u").dtype
    dtype('float64')
    >>> as_float_array([1.0, float("nan")], "u")
    Traceback (most recent call last):
    ...
    ValueError: u must be finite, but contains 1 NaN/inf value(s) (first NaN at index (1,))
    """
    if x is None:
        raise TypeError(f"{name} must be an array of real numbers, got None")
    try:
        arr = np.asarray(x)
    except Exception as exc:  # pragma: no cover - numpy rarely fails here
        raise TypeError(f"{name} must be an array of real numbers: {exc}") from exc
    if arr.dtype == object or arr.dtype.kind not in "biuf":
        if arr.dtype.kind == "c":
            raise TypeError(f"{name} must be real-valued, got complex dtype {arr.dtype}")
        raise TypeError(f"{name} must be an array of real numbers, got dtype {arr.dtype}")
    arr = arr.astype(np.float64, copy=False)
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = np.argwhere(bad)[0]
        kind = "NaN" if np.isnan(arr[tuple(idx)]) else "inf"
        raise ValueError(
            f"{name} must be finite, but contains {int(bad.sum())} NaN/inf value(s) "
            f"(first {kind} at index {tuple(int(i) for i in idx)})"
        )
    return arr


def as_columns(x: Any, name: str) -> NDArray[np.float64]:
    """``x`` as a finite real ``(samples, channels)`` array (a 1-D signal is one channel);
    ``TypeError``/``ValueError`` naming ``name`` otherwise."""
    arr = as_float_array(x, name)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] < 1:
        raise ValueError(f"{name} must be a 1-D or 2-D (samples, channels) array, got {arr.shape}")
    return arr


def check_step(dt: Any, name: str = "dt") -> float:
    """``dt`` as a positive finite float (a sampling interval); ``TypeError`` /
    ``ValueError`` naming ``name`` otherwise."""
    if isinstance(dt, bool) or not isinstance(dt, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a positive number, got {dt!r}")
    if not np.isfinite(dt) or dt <= 0:
        raise ValueError(f"{name} must be a positive finite number, got {dt!r}")
    return float(dt)


def check_time(t: Any, name: str = "t", min_samples: int = 2) -> NDArray[np.float64]:
    """Check a time vector.

    Parameters
    ----------
    t : array_like, shape (Ns,)
        Sample times.
    name : str, optional
        The argument's name in the messages.
    min_samples : int, optional
        The fewest samples accepted.

    Returns
    -------
    ndarray, shape (Ns,)
        ``t`` as float64.

    Raises
    ------
    ValueError
        If ``t`` is not 1-D (a list of time vectors: the message says how several
        records are passed), shorter than ``min_samples``, not finite, or not strictly
        increasing (the message names the first duplicate or decreasing pair).
    TypeError
        If ``t`` is not real numbers.

    Examples
    --------
    >>> check_time([0.0, 0.1, 0.1], "t")
    Traceback (most recent call last):
    ...
    ValueError: t must be strictly increasing, but has duplicate times at indices 1 and 2 (0.1, 0.1)
    """
    if isinstance(t, list | tuple) and t and np.ndim(t[0]) >= 1:  # O(1): no scan
        raise ValueError(
            f"{name} must be a 1-D array of shape (Ns,), got a list of {len(t)} arrays; "
            "several records are passed as one list of (t, u, y) tuples, "
            "e.g. identify([(t1, u1, y1), (t2, u2, y2)])"
        )
    arr = as_float_array(t, name)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array of shape (Ns,), got shape {arr.shape}")
    if arr.shape[0] < min_samples:
        raise ValueError(f"{name} must have at least {min_samples} samples, got {arr.shape[0]}")
    d = np.diff(arr)
    if np.any(d <= 0):
        k = int(np.argmax(d <= 0))
        what = "duplicate" if d[k] == 0 else "decreasing"
        raise ValueError(
            f"{name} must be strictly increasing, but has {what} times at indices "
            f"{k} and {k + 1} ({float(arr[k])!r}, {float(arr[k + 1])!r})"
        )
    return arr


@dataclass(frozen=True)
class CheckSettings:
    """The bounds the input checks hold records, orders and labels to.

    Attributes
    ----------
    energy_headroom : float
        Fraction of the float64 range a channel's sum of squares may reach.
    uniform_rtol : float
        Relative tolerance of the spacing of a uniform grid.
    default_max_order : int
        Default largest order of the order selection.
    max_label : int
        Longest time unit or channel name (characters).
    scale_exponent : int
        Power-of-two band outside which a channel is rescaled.
    """

    #: the share of the float64 range a signal channel's energy ``sum x_k^2`` may take.  A
    #: Gram entry of two channels is at most their energies (Cauchy-Schwarz), but the
    #: least-squares steps also take norms of stacks of up to ~10^4 regressors (a factor up to
    #: 10^4) and condition estimates square such norms again (10^8): the energy must stay
    #: 10^12 below overflow (values up to ~1e148 pass for 10^4 samples; no physical record
    #: comes near, and beyond it the squares themselves overflow deep inside a method)
    energy_headroom: float = 1e-12
    #: relative tolerance of the sample spacing of a uniform grid (:func:`check_uniform`):
    #: one sampled model then serves every step to ~1e-6 of its exponent, far below the
    #: statistical resolution of any record these methods identify from (a grid jittered by
    #: more is treated as non-uniform, with exact steps per interval)
    uniform_rtol: float = 1e-6
    #: Default largest order considered by the order selection of every method: a bound on
    #: the candidates that keeps the selection's work small (pass ``max_order`` for more).
    default_max_order: int = 10
    #: Longest time unit or channel name (characters): room for any name a person writes,
    #: short enough to stay readable in a message, a legend or a model file.
    max_label: int = 256
    #: Channels whose largest magnitude lies outside ``[2^-SCALE_EXPONENT, 2^SCALE_EXPONENT]``
    #: (about 1e-30 to 1e30) are scaled by a power of two before identification
    #: (:func:`scale_exponents`).  Inside the band the methods' float64 arithmetic -- sums of
    #: products of up to four samples over up to 10^10 samples, ``(2^100)^4 10^10 < 2^434``
    #: and ``(2^-100)^4 > 2^-400`` -- stays far from overflow and from the subnormal range,
    #: so records in any physical unit run unchanged; outside it, squares and their products
    #: overflow or underflow (at 1e-200 every square rounds to zero).
    scale_exponent: int = 100


#: The settings in force.
CHECKS = CheckSettings()
#: :attr:`CheckSettings.energy_headroom` of :data:`CHECKS`
ENERGY_HEADROOM = CHECKS.energy_headroom
#: :attr:`CheckSettings.uniform_rtol` of :data:`CHECKS`
UNIFORM_RTOL = CHECKS.uniform_rtol
#: :attr:`CheckSettings.default_max_order` of :data:`CHECKS`
DEFAULT_MAX_ORDER = CHECKS.default_max_order
#: :attr:`CheckSettings.max_label` of :data:`CHECKS`
MAX_LABEL = CHECKS.max_label
#: :attr:`CheckSettings.scale_exponent` of :data:`CHECKS`
SCALE_EXPONENT = CHECKS.scale_exponent


def check_signal(
    x: Any, name: str, ns: int | None = None, limit_energy: bool = True
) -> NDArray[np.float64]:
    r"""Check a signal array of shape ``(Ns, channels)``; 1-D means one channel.

    Parameters
    ----------
    x : array_like, shape (Ns, channels) or (Ns,)
        The signal.
    name : str
        The argument's name in the messages.
    ns : int or None, optional
        The number of rows required (the record's samples).
    limit_energy : bool, optional
        Refuse a channel whose energy :math:`\sum_k x_k^2` is not below
        :data:`ENERGY_HEADROOM` of the float64 range (the sums of the least-squares steps
        would overflow); off for a simulation, which forms no such sums.

    Returns
    -------
    ndarray, shape (Ns, channels)
        As float64.

    Raises
    ------
    ValueError
        If ``x`` has more than two dimensions, a channel is too large, or the number of
        rows is not ``ns`` (with a hint when the transpose would fit).
    TypeError
        If ``x`` is not real numbers.
    """
    arr = as_float_array(x, name)
    if arr.ndim == 1:
        arr = arr[:, None]
    elif arr.ndim != 2:
        raise ValueError(
            f"{name} must have shape (Ns,) or (Ns, channels) as in scipy.signal.lsim, "
            f"got shape {arr.shape}"
        )
    if arr.size and limit_energy:
        with np.errstate(over="ignore"):
            energy = np.einsum("ij,ij->j", arr, arr)
        limit = np.finfo(np.float64).max * ENERGY_HEADROOM
        big = ~(energy <= limit)
        if big.any():
            k = int(np.argmax(big))
            raise ValueError(
                f"{name}[:, {k}] is too large to identify from: its largest magnitude is "
                f"{np.abs(arr[:, k]).max():.3g} and its sum of squares is above {limit:.3g}, "
                f"where the sums of the least-squares steps would overflow; rescale it"
            )
    if ns is not None and arr.shape[0] != ns:
        hint = ""
        if arr.shape[1] == ns:
            hint = " (did you pass the transpose? signals are columns: shape (Ns, channels))"
        raise ValueError(
            f"{name} must have {ns} rows (one per time sample), got shape {arr.shape}{hint}"
        )
    return arr


def check_data(
    t: Any, u: Any, y: Any, min_samples: int = 2
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Check an identification record ``(t, u, y)``.

    Parameters
    ----------
    t : array_like, shape (Ns,)
        Strictly increasing sample times.
    u : array_like, shape (Ns, m) or (Ns,), or None
        Input; ``None`` (no measured input, a pure time series) becomes ``(Ns, 0)``.
    y : array_like, shape (Ns, l) or (Ns,)
        Output, at least one channel.
    min_samples : int, optional
        The fewest samples accepted.

    Returns
    -------
    t : ndarray, shape (Ns,)
    u : ndarray, shape (Ns, m)
    y : ndarray, shape (Ns, l)

    Raises
    ------
    ValueError
        If ``y`` has no channel, or :func:`check_time` / :func:`check_signal` refuse an
        argument.
    TypeError
        If an argument is not real numbers.
    """
    t = check_time(t, "t", min_samples=min_samples)
    ns = t.shape[0]
    y = check_signal(y, "y", ns)
    if y.shape[1] == 0:
        raise ValueError("y must have at least one output channel, got shape (Ns, 0)")
    u = np.zeros((ns, 0)) if u is None else check_signal(u, "u", ns)
    return t, u, y


def check_varies(y: NDArray[np.float64], name: str = "y") -> None:
    """Refuse a constant channel.

    A constant output holds no dynamics to identify (every method would divide by its zero
    variation somewhere), so the message names the channel to drop.

    Parameters
    ----------
    y : ndarray, shape (Ns, channels)
        The signal.
    name : str, optional
        The argument's name in the messages.

    Raises
    ------
    ValueError
        If a channel of ``y`` is constant.
    """
    flat = np.flatnonzero(np.ptp(y, axis=0) == 0) if y.shape[0] else np.zeros(0, dtype=int)
    if flat.size:
        k = int(flat[0])
        raise ValueError(
            f"{name}[:, {k}] is constant (every sample equals {float(y[0, k]):g}): it holds no "
            f"dynamics to identify; leave that channel out"
        )


def time_resolution(t: NDArray[np.float64]) -> float:
    """Absolute resolution of time stamps: twice the float64 spacing at ``max |t|``.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Time stamps.

    Returns
    -------
    float
        ``2 spacing(max |t|)``; 0 for an empty ``t``.

    Notes
    -----
    A stamp is stored to half its spacing, so a difference of two stamps is known only to
    one spacing; the factor 2 covers stamps computed as ``t0 + k h`` (one more rounding).
    Records stamped with Unix time (``t ~ 1.7e9 s``) have a resolution of ``4.8e-7 s``:
    ``5e-5`` of a 10 ms sample interval, far above any relative tolerance on the spacing.

    Examples
    --------
    >>> import numpy as np
    >>> time_resolution(np.array([1.7e9, 1.7e9 + 0.01]))
    4.76837158203125e-07
    """
    return 2.0 * float(np.spacing(np.max(np.abs(t)))) if t.size else 0.0


def uniform_tolerance(t: NDArray[np.float64], h: float, rtol: float = UNIFORM_RTOL) -> float:
    """The largest deviation ``|diff(t)_k - h|`` of a uniform grid with spacing ``h``.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Time stamps.
    h : float
        The grid's spacing (the median step).
    rtol : float, optional
        The uniformity asked of the grid itself (:data:`UNIFORM_RTOL`).

    Returns
    -------
    float
        ``rtol * h + 2 * time_resolution(t)``.

    Notes
    -----
    Every difference of two stamps is known to :func:`time_resolution`, and so is the
    reference ``h`` when it is itself a difference of stamps (the median spacing), hence
    twice the resolution; the stamps cannot say more.  The same grid shifted by a constant
    (``t = 0`` or Unix time ``t ~ 1.7e9``) is then uniform in both forms, whatever ``rtol``.
    """
    return rtol * h + 2.0 * time_resolution(t)


def check_uniform(t: NDArray[np.float64], rtol: float = UNIFORM_RTOL, name: str = "t") -> float:
    """The sampling interval of a uniformly sampled ``t``; the package's one uniformity test.

    Every path that treats a grid as uniform asks this one.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Strictly increasing time stamps.
    rtol : float, optional
        Relative tolerance of the spacing (:data:`UNIFORM_RTOL`).
    name : str, optional
        The argument's name in the messages.

    Returns
    -------
    float
        The mean spacing ``(t[-1] - t[0]) / (Ns - 1)`` (0 for a single sample).

    Raises
    ------
    ValueError
        If ``max |diff(t) - h| > uniform_tolerance(t, h, rtol)`` with ``h`` the median
        spacing; the message names the largest deviation and its index.

    Notes
    -----
    The spacing is computed on ``t - t[0]`` and the tolerance includes the rounding of the
    stamps themselves (:func:`uniform_tolerance`): without it a record stamped with Unix time
    (``t ~ 1.7e9``, ``h = 0.01``) would fail any ``rtol`` below ``5e-5`` although it is as
    uniform as its stamps can say.

    Examples
    --------
    >>> import numpy as np
    >>> round(check_uniform(1.7e9 + 0.01 * np.arange(1000)), 6)
    0.01
    """
    tr = t - t[0]
    d = np.diff(tr)
    if d.size == 0:
        return 0.0
    med = float(np.median(d))
    dev = float(np.max(np.abs(d - med)))
    tol = uniform_tolerance(t, med, rtol)
    if dev > tol:
        k = int(np.argmax(np.abs(d - med)))
        raise ValueError(
            f"{name} must be uniformly sampled for this method: the sample spacing deviates "
            f"from the median spacing {med:.6g} by up to {dev:.3g} (at index {k}, relative "
            f"{dev / med:.3g} > rtol={rtol:g} plus twice the stamps' resolution "
            f"{time_resolution(t):.3g}); use a basis-domain method for non-uniform data"
        )
    return float(tr[-1] / (t.shape[0] - 1))


def is_uniform(t: Any, rtol: float = UNIFORM_RTOL) -> bool:
    """Whether :func:`check_uniform` accepts ``t`` (same tolerance).

    Parameters
    ----------
    t : array_like, shape (Ns,)
        Time stamps.
    rtol : float, optional
        Relative tolerance of the spacing.

    Returns
    -------
    bool
        True for a uniform grid; a grid of fewer than three samples is uniform.

    Examples
    --------
    >>> import numpy as np
    >>> is_uniform(np.arange(10) * 0.1), is_uniform(np.array([0.0, 0.1, 0.3]))
    (True, False)
    """
    t = np.asarray(t, dtype=float)
    if t.size < 3:
        return True
    try:
        check_uniform(t, rtol)
    except ValueError:
        return False
    return True


def check_positive_int(value: Any, name: str, minimum: int = 1) -> int:
    """Check that a value is an integer ``>= minimum``.

    Parameters
    ----------
    value : int
        The value (``bool`` is rejected although it is an ``int``).
    name : str
        The argument's name in the messages.
    minimum : int, optional
        The smallest value accepted.

    Returns
    -------
    int
        ``value`` as a Python ``int``.

    Raises
    ------
    TypeError
        If ``value`` is not an integer (or is a bool).
    ValueError
        If ``value < minimum``.

    Examples
    --------
    >>> check_positive_int(0, "order")
    Traceback (most recent call last):
    ...
    ValueError: order must be an integer >= 1, got 0
    """
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__} {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value}")
    return int(value)


def check_matrix(x: Any, name: str, shape: tuple[int | None, int | None]) -> NDArray[np.float64]:
    """Check a finite real 2-D matrix.

    Parameters
    ----------
    x : array_like
        The matrix.
    name : str
        The argument's name in the messages.
    shape : tuple of (int or None)
        The required shape; ``None`` entries are free.

    Returns
    -------
    ndarray, 2-D
        As float64.

    Raises
    ------
    ValueError
        If ``x`` is not 2-D, has the wrong shape, or is not finite.
    TypeError
        If ``x`` is not real numbers.
    """
    arr = as_float_array(x, name)
    if arr.ndim != 2:
        raise ValueError(f"{name} must be a 2-D matrix, got shape {arr.shape}")
    for axis, want in enumerate(shape):
        if want is not None and arr.shape[axis] != want:
            expected = "(" + ", ".join("*" if s is None else str(s) for s in shape) + ")"
            raise ValueError(f"{name} must have shape {expected}, got {arr.shape}")
    return arr


def check_state_space(
    A: Any, B: Any, C: Any, D: Any | None = None, K: Any | None = None
) -> tuple[NDArray[np.float64], ...]:
    """Check state-space matrices for consistent shapes.

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix.
    B : array_like, shape (n, m)
        Input matrix.
    C : array_like, shape (l, n)
        Output matrix.
    D : array_like, shape (l, m), or None, optional
        Feedthrough (default zeros).
    K : array_like, shape (n, l), or None, optional
        Innovation gain (default zeros).

    Returns
    -------
    A, B, C, D, K : ndarray
        As float64.

    Raises
    ------
    ValueError
        If ``A`` is not square, a shape disagrees with ``n``, ``m``, ``l``, or an entry is
        not finite.
    TypeError
        If a matrix is not real numbers.
    """
    A = check_matrix(A, "A", (None, None))
    n = A.shape[0]
    if A.shape[1] != n:
        raise ValueError(f"A must be square (n, n), got shape {A.shape}")
    B = check_matrix(B, "B", (n, None))
    C = check_matrix(C, "C", (None, n))
    m, l = B.shape[1], C.shape[0]
    D = np.zeros((l, m)) if D is None else check_matrix(D, "D", (l, m))
    K = np.zeros((n, l)) if K is None else check_matrix(K, "K", (n, l))
    return A, B, C, D, K


def check_order(order: int | None) -> int | None:
    """``order``: None (chosen by the method) or a positive int."""
    return None if order is None else check_positive_int(order, "order")


def check_method_args(
    order: int | None, p: int | None, f: int | None, max_order: int | None
) -> tuple[int | None, int | None, int | None, int]:
    """Common integer checks of the identification methods: ``order``, the windows ``p``,
    ``f`` (each ``None`` or a positive int) and ``max_order`` (default
    :data:`DEFAULT_MAX_ORDER`)."""
    order = check_order(order)
    if p is not None:
        p = check_positive_int(p, "p")
    if f is not None:
        f = check_positive_int(f, "f")
    mo = DEFAULT_MAX_ORDER if max_order is None else check_positive_int(max_order, "max_order")
    return order, p, f, mo


def check_label(value: Any, name: str) -> str:
    """Check a short printable string (a time unit or a channel name).

    Parameters
    ----------
    value : str
        The label.
    name : str
        The argument's name in the messages.

    Returns
    -------
    str
        ``value`` unchanged.

    Raises
    ------
    TypeError
        If ``value`` is not a string.
    ValueError
        If it is blank, longer than :data:`MAX_LABEL` characters or not printable.
    """
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string, got {type(value).__name__}")
    if not value.strip() or len(value) > MAX_LABEL or not value.isprintable():
        raise ValueError(
            f"{name} must be a non-empty printable string of at most {MAX_LABEL} "
            f"characters, got {value!r}"
        )
    return value


def check_names(names: Any, name: str, size: int, prefix: str) -> list[str]:
    """Check ``size`` distinct channel names, or make the default ones.

    Parameters
    ----------
    names : list or tuple of str, or None
        The names; ``None`` gives ``prefix1, prefix2, ...``.
    name : str
        The argument's name in the messages.
    size : int
        The number of channels.
    prefix : str
        Prefix of the default names.

    Returns
    -------
    list of str
        ``size`` names, each checked by :func:`check_label`.

    Raises
    ------
    TypeError
        If ``names`` is not a list or tuple (a single string is refused), or an entry is
        not a string.
    ValueError
        If the count is not ``size`` or a name repeats.

    Examples
    --------
    >>> check_names(None, "input_names", 2, "u")
    ['u1', 'u2']
    """
    if names is None:
        return [f"{prefix}{i + 1}" for i in range(size)]
    if isinstance(names, str) or not isinstance(names, list | tuple):
        raise TypeError(f"{name} must be a list of {size} strings, got {type(names).__name__}")
    out = [check_label(v, f"{name}[{i}]") for i, v in enumerate(names)]
    if len(out) != size:
        raise ValueError(f"{name} must have {size} entries (one per channel), got {len(out)}")
    dup = sorted({v for v in out if out.count(v) > 1})
    if dup:
        raise ValueError(f"{name} must be distinct, but {dup} occur more than once")
    return out


def scale_exponents(x: Any, name: str) -> NDArray[np.int64]:
    """Per channel, the power of two that brings an extreme channel to unit size.

    Parameters
    ----------
    x : array_like, shape (Ns,) or (Ns, k)
        The signal.  Data that is not a numeric array (the checks report it) and ``None``
        give zeros.
    name : str
        The argument's name (kept for symmetry with the checks; nothing is raised).

    Returns
    -------
    ndarray of int64, shape (k,)
        The exponent ``p`` with the channel's largest finite magnitude times ``2^p`` in
        ``[0.5, 1)`` when that magnitude lies outside ``[2^-SCALE_EXPONENT,
        2^SCALE_EXPONENT]``; 0 inside the band and for an all-zero channel.

    Notes
    -----
    Multiplying by a power of two changes only the floating-point exponent, so it is exact
    (no rounding) unless a value underflows, and the scaled record is the same record in
    another unit.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.array([[1e-200, 3.0], [2e-200, 1.0]])
    >>> p = scale_exponents(x, "y")
    >>> int(p[1]), 0.5 <= float(np.ldexp(2e-200, int(p[0]))) < 1.0  # 3.0 needs no scaling
    (0, True)
    """
    if x is None:
        return np.zeros(0, dtype=np.int64)
    arr = _real_array(x)
    if arr is None:
        return np.zeros(0, dtype=np.int64)
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2 or arr.shape[0] == 0:
        return np.zeros(arr.shape[-1] if arr.ndim == 2 else 0, dtype=np.int64)
    with np.errstate(invalid="ignore"):
        big = np.max(np.where(np.isfinite(arr), np.abs(arr), 0.0), axis=0)
    e = np.frexp(big)[1].astype(np.int64)  # big = mantissa * 2^e, mantissa in [0.5, 1)
    inside = (big == 0) | ((big >= 2.0**-SCALE_EXPONENT) & (big <= 2.0**SCALE_EXPONENT))
    return np.where(inside, 0, -e)


def _real_array(x: Any) -> NDArray[np.float64] | None:
    """``x`` as a float array when it is an array of real numbers, else ``None`` (complex,
    text, objects and ragged lists are left to the checks, which name them)."""
    try:
        arr = np.asarray(x)
    except (TypeError, ValueError):
        return None
    if arr.dtype.kind not in "biuf":
        return None
    return arr.astype(np.float64, copy=False)


def require_joblib(n_jobs: Any, name: str = "n_jobs") -> None:
    """Refuse parallel workers early when joblib is missing.

    Parameters
    ----------
    n_jobs : int or None
        The requested workers; anything but ``None`` and 1 needs joblib.
    name : str, optional
        The argument's name in the message.

    Raises
    ------
    ImportError
        Naming the extra to install, before the work starts rather than when the first
        parallel section is reached.
    """
    if n_jobs is None or (isinstance(n_jobs, int | np.integer) and n_jobs == 1):
        return
    import importlib.util

    if importlib.util.find_spec("joblib") is None:
        raise ImportError(
            f"{name}={n_jobs!r} runs workers in parallel with joblib, which is not "
            f'installed: pip install "slbasis-hdpbsid[studies]" (or pip install joblib), '
            f"or leave {name} out"
        )
