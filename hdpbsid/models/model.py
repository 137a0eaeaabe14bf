"""Identified models: continuous-time :class:`StateSpaceModel` and sampled :class:`DiscreteModel`.

Both hold the innovation form ``x' = A x + B u + K e``, ``y = C x + D u + e`` (``x'`` is
``dx/dt`` or ``x_{k+1}``), the singular values the order was chosen from and the
``options`` actually used.  Simulation, prediction, fit statistics, frequency responses
and conversions to scipy / python-control live here; identification lives elsewhere.

**Operating point.**  The matrices describe *deviations* from an operating point
``(u0, y0)``: with absolute signals ``u``, ``y`` the model is

    x' = A x + B (u - u0) + K e,    y = y0 + C x + D (u - u0) + e,

(Ljung, *System Identification*, 2nd ed., sec. 14.1: identify on signals with their
levels removed, put the levels back when the model is used).  ``u0`` and ``y0`` default
to zero (a model built by hand is exactly the matrices); :func:`hdpbsid.identify` stores
the levels it removed.  With a linear trend (``detrend="linear"``) the operating point
is ``u0 + u_slope (t - t_ref)`` and ``y0 + y_slope (t - t_ref)`` (:class:`LinearTrend`).
:meth:`StateSpaceModel.simulate`, :meth:`~StateSpaceModel.fit`,
:meth:`~StateSpaceModel.predict` and :meth:`~StateSpaceModel.compare` take and return
absolute signals; states ``x`` (and ``x0``) are always deviation states.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import (
    as_float_array,
    check_label,
    check_names,
    check_positive_int,
    check_signal,
    check_state_space,
    check_time,
    check_uniform,
    is_uniform,
    scale_exponents,
)
from hdpbsid.models.assessment import Comparison, ResidualReport, fit_percent, residual_tests
from hdpbsid.models.conversion import c2d, d2c, sampled_steps
from hdpbsid.models.dead_time import check_delay, delayed_input_terms, pade, pade_order
from hdpbsid.models.recursion import linear_recursion
from hdpbsid.models.report import IdentificationReport
from hdpbsid.models.uncertainty import ParameterCovariance
from hdpbsid.runtime import library_call, user_stacklevel

__all__ = [
    "StateSpaceModel",
    "DiscreteModel",
    "FitResult",
    "LinearTrend",
    "fit_statistics",
    "TimeScaleWarning",
    "TIME_UNITS",
    "SAMPLING_RATIO_LIMIT",
    "scale_signals",
]

Array = NDArray[np.float64]


@dataclass
class FitResult:
    r"""Simulation fit of a model on a record (:meth:`StateSpaceModel.fit`).

    Parameters
    ----------
    vaf : ndarray, shape (l,)
        Variance accounted for, percent per output,
        ``100 (1 - var(y - y_sim) / var(y))``; kept for those who quote it.
    nrmse : ndarray, shape (l,)
        Normalised root-mean-square error per output, ``||y - y_sim|| / ||y - mean(y)||``.
    y_sim : ndarray, shape (Ns, l)
        The simulated output (absolute: the operating point added).
    x0 : ndarray, shape (n,)
        The initial deviation state used (estimated or given).

    Attributes
    ----------
    fit : ndarray, shape (l,)
        ``100 (1 - nrmse)`` percent per output, the fit of MATLAB's ``compare`` and the
        measure every printed summary uses.

    Notes
    -----
    For a zero-mean error the two measures are tied,

    .. math:: \mathrm{VAF} = 100\,\bigl(1 - (1 - \mathrm{fit}/100)^2\bigr),

    so a VAF of 99 % is a fit of 90 %: VAF flatters a model, which is why the summaries
    quote the fit.
    """

    vaf: Array
    nrmse: Array
    y_sim: Array
    x0: Array

    @property
    def fit(self) -> Array:
        """``100 (1 - nrmse)`` percent per output (MATLAB's ``compare`` fit)."""
        return 100.0 * (1.0 - self.nrmse)

    def __repr__(self) -> str:
        return f"FitResult(fit={np.array2string(self.fit, precision=2)} %)"


def fit_statistics(y: Array, y_sim: Array) -> tuple[Array, Array]:
    """VAF (percent) and NRMSE per output column of a measured and a simulated output.

    Parameters
    ----------
    y : ndarray, shape (Ns, l)
        Measured output.
    y_sim : ndarray, shape (Ns, l)
        Simulated (or predicted) output.

    Returns
    -------
    vaf : ndarray, shape (l,)
        ``100 (1 - var(y - y_sim) / var(y))``; NaN for a constant output column.
    nrmse : ndarray, shape (l,)
        ``||y - y_sim|| / ||y - mean(y)||``; NaN for a constant output column.

    Notes
    -----
    Both are ratios, computed on the columns scaled by the power of two of
    :func:`~hdpbsid.data.checks.scale_exponents` (an exact change of exponent), so that the
    squares of a record in extreme units (1e-200) neither underflow nor overflow.

    Examples
    --------
    >>> import numpy as np
    >>> y = np.array([[0.0], [1.0], [2.0], [3.0]])
    >>> vaf, nrmse = fit_statistics(y, y + 0.1)
    >>> print(np.round(vaf, 6), np.round(nrmse, 4))
    [100.] [0.0894]

    A constant offset leaves the VAF (a variance) untouched but not the NRMSE.
    """
    p = scale_exponents(y, "y")
    y, y_sim = np.ldexp(y, p), np.ldexp(y_sim, p)
    err = y - y_sim
    var_y = np.var(y, axis=0)
    safe = np.where(var_y > 0, var_y, np.nan)
    vaf = 100.0 * (1.0 - np.var(err, axis=0) / safe)
    nrmse = np.linalg.norm(err, axis=0) / np.sqrt(safe * y.shape[0])
    return vaf, nrmse


@dataclass
class LinearTrend:
    """Linear drift of the operating point of a model.

    At time ``t`` the input level is ``u0 + u_slope (t - t_ref)`` and the output level
    ``y0 + y_slope (t - t_ref)``.

    Parameters
    ----------
    t_ref : float
        Reference time (in the model's ``time_unit``), finite.
    u_slope : array_like, shape (m,)
        Drift of each input level per time unit.
    y_slope : array_like, shape (l,)
        Drift of each output level per time unit.

    Raises
    ------
    ValueError
        If ``t_ref`` is not finite or a slope is not finite.

    Notes
    -----
    Stored by ``identify(..., detrend="linear")`` from the least-squares line through each
    channel of the identification record (``t_ref`` its mean time, so ``u0``, ``y0`` are
    the record's means).  The line is a function of absolute time: on a record outside the
    identification interval it extrapolates the drift, which is right for a drifting
    sensor and wrong for a drift that belonged to that one experiment (then identify with
    ``detrend="mean"``, or set ``model.trend = None``).
    """

    t_ref: float
    u_slope: Array
    y_slope: Array

    def __post_init__(self) -> None:
        self.t_ref = float(self.t_ref)
        if not np.isfinite(self.t_ref):
            raise ValueError(f"t_ref must be finite, got {self.t_ref}")
        self.u_slope = as_float_array(self.u_slope, "u_slope").reshape(-1)
        self.y_slope = as_float_array(self.y_slope, "y_slope").reshape(-1)


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

#: A record whose median sampling interval differs from the model's by more than this
#: factor (either way) draws a :class:`TimeScaleWarning`.  Resampling a record of the
#: same system by a factor up to 10 is routine (a 1 kHz log validated at 100 Hz), and the
#: exact sampled model simulates any step size, so such records are not flagged; a time
#: stamp in the wrong unit changes the interval by at least 24 (hours and days), usually
#: 60 (seconds and minutes) or 1000 (milliseconds and seconds).  20 lies between the two,
#: so every wrong common unit is flagged and no routine resampling is.
SAMPLING_RATIO_LIMIT = 20.0


def _check_interval(value: Any, name: str) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a positive number or None, got {value!r}")
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number or None, got {value!r}")
    return float(value)


def _fmt_eigs(ev: NDArray[np.complex128], limit: int = 8) -> str:
    parts = []
    for lam in ev[:limit]:
        if abs(lam.imag) <= 1e-12 * max(1.0, abs(lam)):
            parts.append(f"{lam.real:.6g}")
        else:
            parts.append(f"{lam.real:.6g}{lam.imag:+.6g}j")
    more = f", ... ({ev.size} total)" if ev.size > limit else ""
    return "[" + ", ".join(parts) + more + "]"


def _sort_eigs(ev: NDArray[np.complex128]) -> NDArray[np.complex128]:
    return ev[np.lexsort((ev.imag, ev.real))]


@dataclass(repr=False)
class _ModelBase:
    A: Array
    B: Array
    C: Array
    D: Array
    K: Array
    singular_values: Array | None = None
    options: dict[str, Any] = field(default_factory=dict)
    noise_covariance: Array | None = None
    u0: Array | None = None
    y0: Array | None = None
    trend: LinearTrend | None = None
    time_unit: str = "s"
    input_names: list[str] | None = None
    output_names: list[str] | None = None
    report: IdentificationReport | None = field(default=None, kw_only=True, compare=False)

    def __post_init__(self) -> None:
        self.A, self.B, self.C, self.D, self.K = check_state_space(
            self.A, self.B, self.C, self.D, self.K
        )
        m, l = self.B.shape[1], self.C.shape[0]
        self.time_unit = check_label(self.time_unit, "time_unit")
        self.input_names = check_names(self.input_names, "input_names", m, "u")
        self.output_names = check_names(self.output_names, "output_names", l, "y")
        self.u0 = _level(self.u0, "u0", m)
        self.y0 = _level(self.y0, "y0", l)
        if self.trend is not None:
            if not isinstance(self.trend, LinearTrend):
                raise TypeError(f"trend must be a LinearTrend or None, got {self.trend!r}")
            if self.trend.u_slope.size != m or self.trend.y_slope.size != l:
                raise ValueError(
                    f"trend slopes must have {m} (inputs) and {l} (outputs) entries, got "
                    f"{self.trend.u_slope.size} and {self.trend.y_slope.size}"
                )

    def operating_point(self, t: Any) -> tuple[Array, Array]:
        """Input and output levels at the times ``t``: ``(U0 (Ns, m), Y0 (Ns, l))``.

        Constant ``u0``, ``y0`` without a trend; ``u0 + u_slope (t - t_ref)`` (and likewise
        for ``y``) with one (module docstring).
        """
        t = np.asarray(t, dtype=float).reshape(-1)
        U0 = np.broadcast_to(self.u0, (t.size, self.m)).copy()
        Y0 = np.broadcast_to(self.y0, (t.size, self.l)).copy()
        if self.trend is not None:
            dt = (t - self.trend.t_ref)[:, None]
            U0 += dt * self.trend.u_slope[None, :]
            Y0 += dt * self.trend.y_slope[None, :]
        return U0, Y0

    def _offsets_kwargs(self) -> dict[str, Any]:
        """The operating point and the labels, for a converted copy of the model."""
        return {
            "u0": self.u0.copy(),
            "y0": self.y0.copy(),
            "trend": self.trend,
            "time_unit": self.time_unit,
            "input_names": list(self.input_names or []),
            "output_names": list(self.output_names or []),
        }

    def set_labels(
        self,
        input_names: Any | None = None,
        output_names: Any | None = None,
        time_unit: str | None = None,
    ) -> None:
        """Set the channel names and the time unit (each left as it is when ``None``).

        ``input_names`` (``m`` distinct strings), ``output_names`` (``l``) and
        ``time_unit`` (a non-empty string, e.g. ``"s"`` or ``"ms"``: the unit of ``t``,
        so the eigenvalues are in rad per that unit) travel with the model: plots,
        :meth:`StateSpaceModel.to_control` and the saved file use them.  Raises
        ``TypeError`` / ``ValueError`` naming the argument.
        """
        if input_names is not None:
            self.input_names = check_names(input_names, "input_names", self.m, "u")
        if output_names is not None:
            self.output_names = check_names(output_names, "output_names", self.l, "y")
        if time_unit is not None:
            self.time_unit = check_label(time_unit, "time_unit")

    @property
    def n(self) -> int:
        """State dimension."""
        return self.A.shape[0]

    @property
    def m(self) -> int:
        """Number of inputs."""
        return self.B.shape[1]

    @property
    def l(self) -> int:  # noqa: E743 - l is the standard name for the number of outputs
        """Number of outputs."""
        return self.C.shape[0]

    @property
    def eigenvalues(self) -> NDArray[np.complex128]:
        """Eigenvalues of ``A`` sorted by real then imaginary part."""
        return _sort_eigs(np.linalg.eigvals(self.A))

    def _repr_body(self) -> str:
        body = f"n={self.n}, m={self.m}, l={self.l}, eigenvalues={_fmt_eigs(self.eigenvalues)}"
        if self.time_unit != "s":
            body += f" rad/{self.time_unit}"
        if np.any(self.u0) or np.any(self.y0) or self.trend is not None:
            body += ", with operating point" + (" and trend" if self.trend is not None else "")
        return body


def _level(x: Any, name: str, size: int) -> Array:
    """An operating-point vector: zeros when ``None``, else ``size`` finite numbers."""
    if x is None:
        return np.zeros(size)
    arr = as_float_array(x, name).reshape(-1)
    if arr.size != size:
        raise ValueError(f"{name} must have {size} entries (one per channel), got {arr.size}")
    return arr


def _initial_state(O: Array, r: Array) -> Array:
    """Least-squares ``x0`` of ``O x0 ~ r``, with ``O`` and ``r`` scaled by powers of two
    (exact) to unit size first: the solver forms norms (sums of squares), which for a
    record in extreme units (1e-200, 1e200) underflow or overflow."""
    po = int(scale_exponents(O.ravel(), "O")[0]) if O.size else 0
    pr = int(scale_exponents(r, "r")[0]) if r.size else 0
    x = np.linalg.lstsq(np.ldexp(O, po), np.ldexp(r, pr), rcond=None)[0]
    return np.ldexp(x, po - pr)


def _step_groups(t: Array) -> tuple[Array, Array, Array]:
    """``(h, h_groups, inv)``: the steps ``h = diff(t)``, one representative per group of
    steps equal to 1e-12 relative, and each step's group index (``h ~ h_groups[inv]``).

    A uniformly sampled ``t`` (:func:`~hdpbsid.data.checks.check_uniform`: spacing equal to
    1e-6 relative plus the stamps' own rounding) is one group with the mean spacing:
    ``arange(Ns) * dt`` has steps that differ in their last bits, which would otherwise
    split it into several groups and the recursions into a loop over the samples.
    """
    h = np.diff(t)
    if h.size > 1 and is_uniform(t):
        return h, np.array([check_uniform(t)]), np.zeros(h.size, dtype=np.intp)
    key = np.round(h / np.max(h), 12)
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    return h, h[first], inv.reshape(-1)


def _get_report(self: _ModelBase) -> IdentificationReport:
    """What the identification decided and why (:mod:`hdpbsid.models.report`): the report
    the model was given, else the report of its ``options``."""
    own = self.__dict__.get("_report")
    return own if own is not None else IdentificationReport.from_options(self.options)


def _set_report(self: _ModelBase, report: IdentificationReport | None) -> None:
    if report is not None and not isinstance(report, IdentificationReport):
        raise TypeError(
            "report must be a hdpbsid.models.report.IdentificationReport or None, got "
            f"{type(report).__name__}"
        )
    self.__dict__["_report"] = report


# a property over the dataclass field: a model given no report (built by hand, by a
# user's method that records its choices in options, or read from a model file written
# before the report existed) reports its options, also after they change
_ModelBase.report = property(_get_report, _set_report)  # type: ignore[assignment]


@dataclass(repr=False)
class StateSpaceModel(_ModelBase):
    """Continuous-time innovation model ``dx/dt = A x + B u + K e``, ``y = C x + D u + e``.

    The matrices describe deviations from the operating point ``(u0, y0)`` (module
    docstring); :meth:`simulate`, :meth:`fit`, :meth:`predict` and :meth:`compare` take and
    return absolute signals.

    Parameters
    ----------
    A : array_like, shape (n, n)
        State matrix (rad per ``time_unit``: its eigenvalues are the poles).
    B : array_like, shape (n, m)
        Input matrix.
    C : array_like, shape (l, n)
        Output matrix.
    D : array_like, shape (l, m)
        Direct feedthrough.
    K : array_like, shape (n, l)
        Innovation gain, in the hold convention of :mod:`hdpbsid.models.conversion`.
    singular_values : ndarray or None, optional
        The singular values of the SVD step the order was chosen from.
    options : dict, optional
        Every setting the identification used, defaults included: a record for printing
        and the model file (the stages of the identification read ``report``).
    noise_covariance : ndarray, shape (l, l), or None, optional
        Innovation covariance estimate; ``None`` when unknown.
    u0, y0 : array_like, shape (m,) and (l,), optional
        Operating point (default zeros: a model built by hand is exactly its matrices).
    trend : LinearTrend or None, optional
        Linear drift of the operating point (``detrend="linear"``).
    time_unit : str, optional
        Unit of the times ``t`` (default ``"s"``); the eigenvalues are in rad per that unit.
    input_names, output_names : list of str, optional
        Channel names (default ``u1, ...`` and ``y1, ...``).
    report : IdentificationReport or None, optional (keyword only)
        What the identification decided and why (:mod:`hdpbsid.models.report`); without
        one, ``model.report`` is the report of ``options``
        (:meth:`IdentificationReport.from_options`).
    discrete : DiscreteModel or None, optional
        The sampled model this one was converted from, if any.
    sampling_interval : float or None, optional
        Median step of the identification record in ``time_unit``; :meth:`check_record`
        compares a record with it.
    delay : float or array_like, shape (m,), optional
        Dead time of each input, ``>= 0`` in ``time_unit`` (a scalar is used for every
        input): ``dx/dt = A x + B u(t - delay) + K e``, ``y = C x + D u(t - delay) + e``
        (:mod:`hdpbsid.models.dead_time`).  The matrices are the delay-free part.
    parameter_covariance : ParameterCovariance or None, optional
        Covariance of ``[vec A, vec B, vec C, vec D]`` from the fit (set by
        ``refine="pem"`` and :func:`hdpbsid.frequency.fit.identify_frequency`), which
        :func:`hdpbsid.models.uncertainty.response_band` turns into a band of the frequency
        response.

    Attributes
    ----------
    n, m, l : int
        State, input and output dimensions.
    eigenvalues : ndarray of complex
        Eigenvalues of ``A`` sorted by real, then imaginary part.
    has_delay : bool
        Whether any input has a dead time.

    Raises
    ------
    ValueError
        If the matrices' shapes disagree, an entry is not finite, a name list has the wrong
        length or repeats a name, ``sampling_interval`` is not positive or a delay is
        negative.
    TypeError
        If a label is not a string or ``parameter_covariance`` has the wrong type.

    Notes
    -----
    Dead times are honoured exactly by :meth:`simulate`, :meth:`fit`, :meth:`predict` and
    :meth:`frequency_response`; :meth:`to_control` and :meth:`to_scipy` replace them by a
    Pade approximant (:meth:`pade_order`); :meth:`to_discrete` refuses a delayed model
    (its exact sampled model needs extra states).

    Examples
    --------
    A first-order low-pass ``G(s) = 1 / (s + 1)``:

    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.5]])
    >>> model
    StateSpaceModel(continuous, n=1, m=1, l=1, eigenvalues=[-1])
    >>> t = np.arange(0.0, 20.0, 0.01)
    >>> y = model.simulate(t, np.ones((t.size, 1)))
    >>> round(float(y[-1, 0]), 4)  # the step response settles at the DC gain G(0) = 1
    1.0
    >>> np.round(model.frequency_response([0.0, 1.0])[0, 0], 3)  # G(0), G(j) = 1 / (1 + j)
    array([1. +0.j , 0.5-0.5j])
    """

    discrete: DiscreteModel | None = None
    sampling_interval: float | None = None
    delay: Array | None = None
    parameter_covariance: ParameterCovariance | None = None

    def __post_init__(self) -> None:
        super().__post_init__()
        self.sampling_interval = _check_interval(self.sampling_interval, "sampling_interval")
        self.delay = check_delay(self.delay, self.m)
        cov = self.parameter_covariance
        if cov is not None:
            if not isinstance(cov, ParameterCovariance):
                raise TypeError(
                    "parameter_covariance must be a hdpbsid.models.uncertainty.ParameterCovariance "
                    f"or None, got {type(cov).__name__}"
                )
            cov.check(self.n, self.m, self.l)

    @property
    def has_delay(self) -> bool:
        """Whether any input has a dead time."""
        return bool(np.any(self.delay))

    def save(self, path: Any) -> Any:
        """Write the model to a JSON file.

        Parameters
        ----------
        path : str or path-like
            File to write (:func:`hdpbsid.models.model_io.save_model`); :func:`hdpbsid.load_model`
            reads it back with every label, the operating point and the dead times.

        Returns
        -------
        pathlib.Path
            The path written.

        Raises
        ------
        ValueError
            If the path's suffix is not ``.json`` (:func:`~hdpbsid.models.model_file.write_model`).

        Examples
        --------
        >>> import tempfile, pathlib
        >>> from hdpbsid import StateSpaceModel, load_model
        >>> model = StateSpaceModel(A=[[-2.0]], B=[[1.0]], C=[[3.0]], D=[[0.0]], K=[[0.0]])
        >>> with tempfile.TemporaryDirectory() as tmp:
        ...     path = model.save(pathlib.Path(tmp) / "model.json")
        ...     back = load_model(path)
        >>> back.eigenvalues.real.tolist(), back.C.tolist()
        ([-2.0], [[3.0]])
        """
        from hdpbsid.models.model_file import write_model

        return write_model(self, path)

    def check_record(self, t: Any, time_unit: str | None = None, name: str = "t") -> None:
        """Warn when a record's time scale does not match the model's.

        Two checks, each only when both sides are known: ``time_unit`` (the record's)
        differs from ``model.time_unit`` (the message gives the conversion factor for the
        units of :data:`TIME_UNITS`); the record's median step differs from
        ``model.sampling_interval`` by more than :data:`SAMPLING_RATIO_LIMIT` either way, the
        signature of times in another unit (its comment says why that factor).

        Parameters
        ----------
        t : array_like, shape (Ns,)
            The record's sample times.
        time_unit : str or None, optional
            The unit of ``t``, if known.
        name : str, optional
            The argument's name in the messages.

        Warns
        -----
        TimeScaleWarning
            When either check fails.

        Raises
        ------
        ValueError
            If ``t`` is not a strictly increasing finite vector, or ``time_unit`` is empty.

        Notes
        -----
        The exact sampled model simulates any step size, so neither finding is an error: the
        fit of a record in the wrong unit is merely meaningless.
        """
        if time_unit is not None:
            unit = check_label(time_unit, "time_unit")
            if unit != self.time_unit:
                warnings.warn(
                    _unit_message(unit, self.time_unit),
                    TimeScaleWarning,
                    stacklevel=user_stacklevel(),
                )
                return  # the step comparison would repeat the same finding
        if self.sampling_interval is None:
            return
        tt = check_time(t, name)
        h = float(np.median(np.diff(tt)))
        ratio = h / self.sampling_interval
        if not 1.0 / SAMPLING_RATIO_LIMIT <= ratio <= SAMPLING_RATIO_LIMIT:
            warnings.warn(
                f"{name}: the record's median sampling interval {h:.6g} is {ratio:.3g} times "
                f"the identification record's {self.sampling_interval:.6g} {self.time_unit} "
                f"(more than a factor {SAMPLING_RATIO_LIMIT:g} apart): are its times in "
                f"{self.time_unit}?  A record in another time unit fits meaninglessly; "
                f"convert its times, or ignore this if it was only resampled",
                TimeScaleWarning,
                stacklevel=user_stacklevel(),
            )

    def __repr__(self) -> str:
        method = self.report.method if self.report is not None else None
        extra = f", method={method!r}" if method else ""
        if self.has_delay:
            extra += f", delay={np.array2string(self.delay, precision=6)} {self.time_unit}"
        return f"StateSpaceModel(continuous, {self._repr_body()}{extra})"

    # -- simulation ------------------------------------------------------------------
    def _step_matrices(
        self, h: Array, method: str, with_k: bool = False
    ) -> tuple[Array, Array, Array | None, Array | None]:
        """Exact one-step matrices for steps ``h``: ``(Phi, G1, G2, Gk)`` from the augmented
        exponentials (Franklin, Powell & Workman, *Digital Control*, sec. 6.3):
        ``expm([[A h, B h, 0, K h], [0, 0, I, 0], [0, 0, 0, 0], [0, 0, 0, 0]])``.  ``G1``
        multiplies ``u_k``; ``G2`` (FOH only, else ``None``) multiplies ``u_{k+1} - u_k``;
        ``Gk`` (``with_k`` only) multiplies the innovation held over the step, the hold
        convention of :mod:`hdpbsid.models.conversion`
        (:func:`~hdpbsid.models.conversion.sampled_steps`).
        """
        return sampled_steps(self.A, self.B, self.K if with_k else None, h, method)

    @library_call
    def simulate(
        self,
        t: Any,
        u: Any,
        x0: Any | None = None,
        method: str = "zoh",
        return_states: bool = False,
    ) -> Array | tuple[Array, Array]:
        r"""Deterministic response (``e = 0``) at the times ``t``, which need not be uniform.

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Strictly increasing sample times in ``time_unit``.
        u : array_like, shape (Ns, m) or (Ns,)
            Absolute input: the model runs on ``u - u0`` and adds ``y0`` to its output.
            ``None`` is accepted for a model without inputs.
        x0 : array_like, shape (n,), optional
            Initial *deviation* state (default 0: the system at its operating point).
        method : {"zoh", "foh"}, optional
            ``"zoh"``: ``u[k]`` held on ``[t_k, t_{k+1})`` (the assumption under which
            :func:`~hdpbsid.identify_dt` data are sampled); ``"foh"``: ``u`` linear between
            samples, as :func:`scipy.signal.lsim` does by default.
        return_states : bool, optional
            Also return the deviation states.

        Returns
        -------
        y : ndarray, shape (Ns, l)
            The absolute output.
        x : ndarray, shape (Ns, n)
            The deviation states (only with ``return_states``).

        Raises
        ------
        ValueError
            If ``method`` is unknown, ``t`` is not strictly increasing, ``u`` has the wrong
            shape or ``x0`` the wrong length.

        Notes
        -----
        Each step uses the exact exponential of the augmented matrix for its own
        ``h = t_{k+1} - t_k`` (Franklin, Powell & Workman, *Digital Control of Dynamic
        Systems*, sec. 6.3),

        .. math::

            \exp\begin{bmatrix} A h & B h & 0 \\ 0 & 0 & I \\ 0 & 0 & 0 \end{bmatrix}
            = \begin{bmatrix} \Phi & \Gamma_1 & \Gamma_2 \\ 0 & I & I \\ 0 & 0 & I
            \end{bmatrix},
            \qquad x_{k+1} = \Phi x_k + \Gamma_1 u_k + \Gamma_2 (u_{k+1} - u_k),

        with the last term only for the first-order hold; steps equal to 1e-12 relative share
        one exponential, so a uniform record needs one.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]])
        >>> t = np.array([0.0, 0.5, 1.0, 3.0])  # non-uniform steps are exact too
        >>> y = model.simulate(t, np.ones(4))
        >>> np.allclose(y[:, 0], 1.0 - np.exp(-t))  # the step response 1 - e^{-t}
        True
        """
        t, u = self._check_input(t, u, method)
        U0, Y0 = self.operating_point(t)
        y, X = self._simulate_deviation(t, u - U0, self._check_x0(x0), method)
        y = y + Y0
        return (y, X) if return_states else y

    def _check_input(self, t: Any, u: Any, method: str) -> tuple[Array, Array]:
        if method not in ("zoh", "foh"):
            raise ValueError(f"method must be 'zoh' or 'foh', got {method!r}")
        t = check_time(t, "t", min_samples=1)
        if self.m == 0 and u is None:
            u = np.zeros((t.shape[0], 0))
        u = check_signal(u, "u", t.shape[0], limit_energy=False)
        if u.shape[1] != self.m:
            raise ValueError(f"u must have {self.m} column(s) (inputs), got shape {u.shape}")
        return t, u

    def _check_x0(self, x0: Any | None) -> Array:
        x = np.zeros(self.n) if x0 is None else as_float_array(x0, "x0").reshape(-1)
        if x.shape[0] != self.n:
            raise ValueError(
                f"x0 must have {self.n} entries (the state dimension), got {x.shape[0]}"
            )
        return x

    def _input_steps(self, t: Array, u: Array, method: str) -> tuple[Array, Array, Array, Array]:
        """The sampled system over the steps of ``t`` (``Ns >= 2``): the distinct one-step
        matrices ``Phi (g, n, n)``, the index ``inv (Ns - 1,)`` of each step's group, and
        the input's contribution to each step, ``Bu[k] = G1 u_k (+ G2 (u_{k+1} - u_k))``
        (``G2`` only with a first-order hold), so that ``x_{k+1} = Phi[inv[k]] x_k + Bu[k]``;
        and the input the direct term sees, ``ud`` (``u`` itself, or ``u`` at ``t - delay``
        with a dead time: :func:`hdpbsid.models.dead_time.delayed_input_terms`)."""
        _, hg, inv = _step_groups(t)
        Phi, G1, G2, _ = self._step_matrices(hg, method)
        Bu, ud = self._input_terms(t, u, method, Phi, G1, G2, inv)
        return Phi, inv, Bu, ud

    def _input_terms(
        self, t: Array, u: Array, method: str, Phi: Array, G1: Array, G2: Any, inv: Array
    ) -> tuple[Array, Array]:
        """``(Bu, ud)`` of :meth:`_input_steps` for the step matrices given."""
        if self.has_delay:
            return delayed_input_terms(self.A, self.B, t, u, self.delay, method, Phi, inv)
        Bu = np.einsum("kij,kj->ki", G1[inv], u[:-1])
        if G2 is not None:
            Bu += np.einsum("kij,kj->ki", G2[inv], np.diff(u, axis=0))
        return Bu, u

    def _simulate_deviation(self, t: Array, u: Array, x: Array, method: str) -> tuple[Array, Array]:
        """Response ``(y, X)`` of the matrices alone to the deviation input ``u``."""
        ns, n = t.shape[0], self.n
        X = np.empty((ns, n))
        X[0] = x
        ud = u
        if ns > 1:
            Phi, inv, Bu, ud = self._input_steps(t, u, method)
            if Phi.shape[0] == 1:  # uniform sampling: modal filters
                X = linear_recursion(Phi[0], Bu, x)
            else:
                for k in range(ns - 1):
                    x = Phi[inv[k]] @ x + Bu[k]
                    X[k + 1] = x
        elif self.has_delay:
            ud = np.where(self.delay[None, :] > 0, 0.0, u)
        return X @ self.C.T + ud @ self.D.T, X

    def _forced_and_free(self, t: Array, u: Array, method: str) -> tuple[Array, Array]:
        """The response to the deviation input ``u`` from the zero state and the free
        responses from each unit initial state, in one pass over the steps (the step
        matrices of a non-uniform ``t`` are computed once for all of them):
        ``(y (Ns, l), O (Ns l, n))``, ``y + (O x0).reshape(Ns, l)`` the response from
        ``x0``."""
        ns, n = t.shape[0], self.n
        S = np.zeros((ns, n, n + 1))  # column 0: forced; columns 1..n: free from e_j
        S[0, :, 1:] = np.eye(n)
        ud = u
        if ns > 1:
            Phi, inv, Bu, ud = self._input_steps(t, u, method)
            z = S[0]
            for k in range(ns - 1):
                z = Phi[inv[k]] @ z
                z[:, 0] += Bu[k]
                S[k + 1] = z
        Y = np.einsum("li,kij->klj", self.C, S)
        return Y[:, :, 0] + ud @ self.D.T, Y[:, :, 1:].reshape(ns * self.l, n)

    def _check_output(self, t: Array, y: Any) -> Array:
        y = check_signal(y, "y", t.shape[0], limit_energy=False)
        if y.shape[1] != self.l:
            raise ValueError(f"y must have {self.l} column(s) (outputs), got shape {y.shape}")
        return y

    @library_call
    def fit(
        self,
        t: Any,
        u: Any,
        y: Any,
        x0: Any = "estimate",
        method: str = "zoh",
        time_unit: str | None = None,
    ) -> FitResult:
        """Simulate on ``(t, u)`` and compare with ``y``: VAF and NRMSE per output.

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Strictly increasing sample times in ``time_unit``.
        u : array_like, shape (Ns, m)
            Absolute input.
        y : array_like, shape (Ns, l)
            Absolute measured output.
        x0 : {"estimate", "zero"} or array_like, shape (n,), optional
            ``"estimate"`` (default) fits the initial deviation state by least squares (the
            output is affine in ``x0``); ``"zero"`` or an array use that state.
        method : {"zoh", "foh"}, optional
            Input between samples, as in :meth:`simulate`.
        time_unit : str or None, optional
            The unit of ``t``, if known; a record whose time scale does not match the model's
            draws a :class:`TimeScaleWarning` (:meth:`check_record`).

        Returns
        -------
        FitResult
            ``vaf``, ``nrmse``, ``fit`` per output, the simulated output and the initial state.

        Raises
        ------
        ValueError
            If ``x0`` is an unknown string or has the wrong length, or the signals' shapes
            disagree with the model's.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]])
        >>> rng = np.random.default_rng(0)
        >>> t = np.arange(0.0, 20.0, 0.01)
        >>> u = np.repeat(rng.standard_normal(20), 100)[:, None]  # steps held for 1 s
        >>> y = model.simulate(t, u, x0=[2.0])  # started away from rest
        >>> result = model.fit(t, u, y)
        >>> print(np.round(result.fit, 6), np.round(result.x0, 6))  # x0 recovered by least squares
        [100.] [2.]
        """
        self.check_record(t, time_unit)
        return self._fit(t, u, y, x0, method)

    def _fit(self, t: Any, u: Any, y: Any, x0: Any, method: str) -> FitResult:
        t = check_time(t, "t")
        y = self._check_output(t, y)
        t, u = self._check_input(t, u, method)
        U0, Y0 = self.operating_point(t)
        ud = u - U0
        if isinstance(x0, str):
            if x0 not in ("estimate", "zero"):
                raise ValueError(f"x0 must be 'estimate', 'zero' or an array, got {x0!r}")
            x0v = np.zeros(self.n)
            if x0 == "estimate" and self.n > 0 and not is_uniform(t):
                # non-uniform steps: one pass for the forced and all free responses
                y_sim, O = self._forced_and_free(t, ud, method)
                x0v = _initial_state(O, (y - Y0 - y_sim).ravel())
                y_sim = y_sim + Y0 + (O @ x0v).reshape(y.shape)
                vaf, nrmse = fit_statistics(y, y_sim)
                return FitResult(vaf=vaf, nrmse=nrmse, y_sim=y_sim, x0=x0v)
            y_sim = self._simulate_deviation(t, ud, x0v, method)[0] + Y0
            if x0 == "estimate" and self.n > 0:
                ufree = np.zeros((t.shape[0], self.m))
                O = np.stack(
                    [
                        self._simulate_deviation(t, ufree, e, method)[0].ravel()
                        for e in np.eye(self.n)
                    ],
                    axis=1,
                )
                x0v = _initial_state(O, (y - y_sim).ravel())
                y_sim = y_sim + (O @ x0v).reshape(y.shape)
        else:
            x0v = self._check_x0(x0)
            y_sim = self._simulate_deviation(t, ud, x0v, method)[0] + Y0
        vaf, nrmse = fit_statistics(y, y_sim)
        return FitResult(vaf=vaf, nrmse=nrmse, y_sim=y_sim, x0=x0v)

    # -- prediction and validation -----------------------------------------------------
    def _predict_deviation(
        self, t: Array, u: Array, y: Array, x: Array, k: int, method: str
    ) -> Array:
        """k-step-ahead predictions of the deviation output (module docstring of
        :meth:`predict`), for deviation signals ``u``, ``y`` and initial state ``x``."""
        ns, n = t.shape[0], self.n
        Z = np.empty((ns, n))
        Z[0] = x
        if ns > 1:
            _, hg, inv = _step_groups(t)
            Phi, G1, G2, Gk = self._step_matrices(hg, method, with_k=True)
            Bu, u = self._input_terms(t, u, method, Phi, G1, G2, inv)  # u: the delayed input
            Ku = np.einsum("kij,kj->ki", Gk[inv], y[:-1] - u[:-1] @ self.D.T)
            # predictor: x_{j+1} = (Phi - Gk C) x_j + Bu_j + Gk (y_j - D u_j)
            F = Phi - np.einsum("kij,jl->kil", Gk, self.C)
            if F.shape[0] == 1:  # uniform sampling: one predictor matrix, modal filters
                Z = linear_recursion(F[0], Bu + Ku, x)
            else:
                for j in range(ns - 1):
                    x = F[inv[j]] @ x + Bu[j] + Ku[j]
                    Z[j + 1] = x
            # Z[j] = x_{j|j-1}; k - 1 open-loop steps give x_{j|j-k} (x_{j|.} = x0 for the
            # first samples, where no measurement precedes)
            for _ in range(k - 1):
                Znew = np.empty_like(Z)
                Znew[0] = Z[0]
                Znew[1:] = np.einsum("kij,kj->ki", Phi[inv], Z[:-1]) + Bu
                Z = Znew
        return Z @ self.C.T + u @ self.D.T

    def _predict(
        self, t: Any, u: Any, y: Any, k: int, x0: Any, method: str
    ) -> tuple[Array, Array, Array]:
        k = check_positive_int(k, "k")
        t = check_time(t, "t")
        y = self._check_output(t, y)
        t, u = self._check_input(t, u, method)
        U0, Y0 = self.operating_point(t)
        ud, yd = u - U0, y - Y0
        if isinstance(x0, str):
            if x0 not in ("estimate", "zero"):
                raise ValueError(f"x0 must be 'estimate', 'zero' or an array, got {x0!r}")
            x0v = np.zeros(self.n)
            yp = self._predict_deviation(t, ud, yd, x0v, k, method)
            if x0 == "estimate" and self.n > 0:
                zu, zy = np.zeros_like(ud), np.zeros_like(yd)
                O = np.stack(
                    [
                        self._predict_deviation(t, zu, zy, e, k, method).ravel()
                        for e in np.eye(self.n)
                    ],
                    axis=1,
                )
                x0v = _initial_state(O, (yd - yp).ravel())
                yp = yp + (O @ x0v).reshape(yd.shape)
        else:
            x0v = self._check_x0(x0)
            yp = self._predict_deviation(t, ud, yd, x0v, k, method)
        return yp + Y0, x0v, y

    @library_call
    def predict(
        self,
        t: Any,
        u: Any,
        y: Any,
        k: int = 1,
        x0: Any = "estimate",
        method: str = "zoh",
        time_unit: str | None = None,
    ) -> Array:
        r"""``k``-step-ahead predictions ``y_hat(t_j | t_{j-k})`` of the measured ``y``.

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Strictly increasing sample times (need not be uniform).
        u : array_like, shape (Ns, m)
            Absolute input.
        y : array_like, shape (Ns, l)
            Absolute measured output.
        k : int, optional
            Prediction horizon in samples, ``>= 1``.  ``k = 1`` is the one-step predictor whose
            errors are the model's innovations; a large ``k`` approaches :meth:`simulate`.
        x0 : {"estimate", "zero"} or array_like, shape (n,), optional
            ``"estimate"`` (least squares on the prediction errors, in which the predictions
            are affine), ``"zero"`` or the initial deviation state.
        method : {"zoh", "foh"}, optional
            Input between samples.
        time_unit : str or None, optional
            As in :meth:`fit`.

        Returns
        -------
        ndarray, shape (Ns, l)
            The predicted absolute output.

        Raises
        ------
        ValueError
            If ``k`` is not a positive integer, ``x0`` an unknown string, or the signals' shapes
            disagree with the model's.
        TypeError
            If ``k`` is not an integer.

        Notes
        -----
        The sampled innovation model (hold convention of :mod:`hdpbsid.models.conversion`:
        ``u`` and ``e`` held over each step, exact exponentials per step) gives the one-step
        predictor (Ljung, *System Identification*, 2nd ed., 1999, eq. 4.87)

        .. math::

            \hat x_{j+1|j} = \Phi_j \hat x_{j|j-1} + \Gamma_j u_j
            + G_j \bigl(y_j - C \hat x_{j|j-1} - D u_j\bigr),

        and :math:`\hat x_{j|j-k}` follows from :math:`\hat x_{j-k+1|j-k}` by ``k - 1`` steps
        of the model without the correction term; :math:`\hat y = C \hat x_{j|j-k} + D u_j`.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[2.0]])
        >>> rng = np.random.default_rng(1)
        >>> t = np.arange(0.0, 10.0, 0.05)
        >>> u = np.repeat(rng.standard_normal(10), 20)[:, None]
        >>> y = model.simulate(t, u) + 0.1 * rng.standard_normal((t.size, 1))
        >>> y1 = model.predict(t, u, y, k=1)
        >>> y1.shape
        (200, 1)
        """
        self.check_record(t, time_unit)
        return self._predict(t, u, y, k, x0, method)[0]

    @library_call
    def compare(
        self,
        t: Any,
        u: Any,
        y: Any,
        k: int | None = None,
        method: str = "zoh",
        time_unit: str | None = None,
    ) -> Comparison:
        r"""Fit of the model on a record, as MATLAB's ``compare``.

        Per output, :math:`\mathrm{fit} = 100\,(1 - \|y - \hat y\| / \|y - \bar y\|)`
        percent.

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Strictly increasing sample times.
        u : array_like, shape (Ns, m)
            Absolute input.
        y : array_like, shape (Ns, l)
            Absolute measured output.
        k : int or None, optional
            ``None``: ``y_hat`` is the simulation (:meth:`fit`, initial state by least
            squares), which diverges for an unstable model; an integer: the ``k``-step-ahead
            prediction (:meth:`predict`, initial state by least squares).
        method : {"zoh", "foh"}, optional
            Input between samples.
        time_unit : str or None, optional
            The unit of ``t``, if known (:meth:`check_record`).

        Returns
        -------
        Comparison
            ``fit`` per output, ``y_hat``, the initial state and ``k``
            (:class:`~hdpbsid.models.assessment.Comparison`).

        Raises
        ------
        ValueError
            If ``k`` is not a positive integer or the signals' shapes disagree with the model's.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.5]])
        >>> rng = np.random.default_rng(0)
        >>> t = np.arange(0.0, 20.0, 0.01)
        >>> u = np.repeat(rng.standard_normal(20), 100)[:, None]
        >>> y = model.simulate(t, u) + 0.05 * rng.standard_normal((t.size, 1))
        >>> bool(model.compare(t, u, y).fit[0] > 85)  # the noise caps the fit below 100 %
        True
        """
        self.check_record(t, time_unit)
        if k is None:
            res = self._fit(t, u, y, "estimate", method)
            y_meas = check_signal(y, "y", limit_energy=False)
            return Comparison(
                fit=fit_percent(y_meas, res.y_sim), y_hat=res.y_sim, x0=res.x0, k=None
            )
        y_hat, x0v, y_meas = self._predict(t, u, y, k, "estimate", method)
        return Comparison(fit=fit_percent(y_meas, y_hat), y_hat=y_hat, x0=x0v, k=int(k))

    @library_call
    def residuals(
        self,
        t: Any,
        u: Any,
        y: Any,
        max_lag: int = 25,
        method: str = "zoh",
        time_unit: str | None = None,
    ) -> ResidualReport:
        """Residual analysis of the one-step prediction errors, as MATLAB's ``resid``.

        The errors ``e = y - y_hat(t | t - 1)`` (:meth:`predict` with ``k=1``, initial state
        by least squares) are tested for whiteness (autocorrelation, Ljung-Box) and for
        independence from the input (cross-correlation) over lags up to ``max_lag``
        (Ljung, *System Identification*, 2nd ed., 1999, sec. 16.6;
        :func:`hdpbsid.models.assessment.residual_tests`).

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Strictly increasing sample times.
        u : array_like, shape (Ns, m)
            Absolute input.
        y : array_like, shape (Ns, l)
            Absolute measured output.
        max_lag : int, optional
            Largest lag ``M`` tested (at most ``Ns - 1``).
        method : {"zoh", "foh"}, optional
            Input between samples.
        time_unit : str or None, optional
            As in :meth:`compare`.

        Returns
        -------
        ResidualReport
            The correlations, their bands and the tests' statistics
            (:class:`~hdpbsid.models.assessment.ResidualReport`).

        Raises
        ------
        ValueError
            If ``max_lag`` is not a positive integer below ``Ns`` or the shapes disagree.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]])
        >>> rng = np.random.default_rng(0)
        >>> t = np.arange(0.0, 20.0, 0.01)
        >>> u = np.repeat(rng.standard_normal(20), 100)[:, None]
        >>> y = model.simulate(t, u) + 0.05 * rng.standard_normal((t.size, 1))
        >>> report = model.residuals(t, u, y)  # output error: white noise, the right model
        >>> report.white, report.independent
        (True, True)
        """
        self.check_record(t, time_unit)
        y_hat, _, y_meas = self._predict(t, u, y, 1, "estimate", method)
        t_arr = check_time(t, "t")
        _, u_arr = self._check_input(t_arr, u, method)
        return residual_tests(y_meas - y_hat, u_arr, max_lag=max_lag)

    # -- frequency domain and conversions -----------------------------------------------
    def frequency_response(self, w: Any) -> NDArray[np.complex128]:
        r"""Frequency response with the dead times entering exactly.

        Parameters
        ----------
        w : array_like, shape (nw,)
            Angular frequencies in rad per ``time_unit``.

        Returns
        -------
        ndarray of complex, shape (l, m, nw)
            :math:`G(j\omega) = \bigl(C (j\omega I - A)^{-1} B + D\bigr)
            \operatorname{diag}(e^{-j\omega \tau_i})`, in python-control's layout.

        Raises
        ------
        ValueError
            If ``w`` is not finite.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]],
        ...                         delay=0.1)
        >>> G = model.frequency_response([1.0])[0, 0, 0]
        >>> round(float(abs(G)), 4), round(float(np.angle(G)), 4)  # |1/(1+j)|, -pi/4 - 0.1
        (0.7071, -0.8854)
        """
        w = as_float_array(w, "w").reshape(-1)
        s = 1j * w
        G = _transfer(self.A, self.B, self.C, self.D, s)
        if self.has_delay:
            G = G * np.exp(-1j * self.delay[None, :, None] * w[None, None, :])
        return G

    def pade_order(self, w_max: float | None = None) -> int:
        """Order of the Pade approximant :meth:`to_control` and :meth:`to_scipy` use by default.

        Parameters
        ----------
        w_max : float or None, optional
            Highest angular frequency (rad per ``time_unit``) at which the approximant's phase
            must be within 1 degree of every dead time's.  Default: a decade above the fastest
            eigenvalue (``10 max |lambda|``, where a strictly proper model's gain has fallen by
            20 dB or more from that mode's), or the Nyquist frequency
            ``pi / sampling_interval`` when that is lower (the data say nothing above it).

        Returns
        -------
        int
            The smallest such order (:func:`hdpbsid.models.dead_time.pade_order`, at most
            :data:`hdpbsid.models.dead_time.MAX_PADE_ORDER`); 0 for a model without delay.
        """
        if not self.has_delay:
            return 0
        if w_max is None:
            top = [10.0 * float(np.max(np.abs(self.eigenvalues), initial=0.0))]
            if self.sampling_interval is not None:
                top.append(np.pi / self.sampling_interval)
            positive = [x for x in top if x > 0]
            w_max = min(positive) if positive else 1.0 / float(np.max(self.delay))
        return pade_order(self.delay, float(w_max))

    def _with_pade(self, order: int | None) -> tuple[Array, Array, Array, Array]:
        """``(A, B, C, D)`` with each delayed input through a Pade approximant of
        ``order`` (default :meth:`pade_order`) before the plant: the approximants' states
        follow the plant's."""
        N = self.pade_order() if order is None else check_positive_int(order, "pade_order", 0)
        if not self.has_delay or N == 0:
            return self.A, self.B, self.C, self.D
        blocks = [pade(float(tau), N) for tau in self.delay]
        Ap = _block_diag([b[0] for b in blocks])
        Bp = _block_diag([b[1] for b in blocks])
        Cp = _block_diag([b[2] for b in blocks])
        Dp = np.diag([float(b[3][0, 0]) for b in blocks])
        n, q = self.n, Ap.shape[0]
        A = np.block([[self.A, self.B @ Cp], [np.zeros((q, n)), Ap]])
        B = np.vstack([self.B @ Dp, Bp])
        C = np.hstack([self.C, self.D @ Cp])
        return A, B, C, self.D @ Dp

    def to_discrete(self, dt: float) -> DiscreteModel:
        """Zero-order-hold sampling of the model.

        Parameters
        ----------
        dt : float
            Sampling interval in ``time_unit``, positive.

        Returns
        -------
        DiscreteModel
            ``(Ad, Bd, C, D, Kd)`` of :func:`hdpbsid.models.conversion.c2d` (``K`` by the hold
            convention), with the operating point and the labels.

        Raises
        ------
        ValueError
            For a model with a dead time (its exact sampled model needs states for the delayed
            inputs, which :class:`DiscreteModel` does not hold: sample ``model.to_control()``,
            the Pade approximant, or simulate the continuous model), or a ``dt`` that is not
            positive.

        Examples
        --------
        >>> import numpy as np
        >>> from hdpbsid import StateSpaceModel
        >>> model = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]])
        >>> sampled = model.to_discrete(0.1)
        >>> bool(np.isclose(sampled.A[0, 0], np.exp(-0.1)))  # Ad = e^{A dt}
        True
        >>> bool(np.allclose(sampled.to_continuous().A, model.A))  # d2c inverts c2d
        True
        """
        if self.has_delay:
            raise ValueError(
                f"to_discrete: the model has dead times {self.delay.tolist()} "
                f"{self.time_unit}; the exact sampled model of a delay needs extra states. "
                f"Simulate the continuous model (exact), or sample its Pade approximant "
                f"(control.sample_system(model.to_control(), dt))"
            )
        Ad, Bd, C, D, Kd = c2d(self.A, self.B, self.C, self.D, self.K, dt)
        return DiscreteModel(
            Ad,
            Bd,
            C,
            D,
            Kd,
            dt=float(dt),
            options={"from": "c2d (zoh)"},
            **self._offsets_kwargs(),
        )

    def to_scipy(self, pade_order: int | None = None) -> Any:
        """The model as ``scipy.signal.StateSpace(A, B, C, D)`` (continuous; the ``u -> y`` part).

        It describes *deviations* from the operating point: feed it ``u - model.u0`` and add
        ``model.y0`` to its output (module docstring); scipy has no place for levels.

        Parameters
        ----------
        pade_order : int or None, optional
            Order of the Pade approximants that replace the dead times on the inputs (their
            states after the model's); default :meth:`pade_order`.

        Returns
        -------
        scipy.signal.StateSpace
            The continuous system.
        """
        from scipy.signal import StateSpace

        return StateSpace(*self._with_pade(pade_order))

    def to_control(
        self, noise_inputs: bool = False, name: str | None = None, pade_order: int | None = None
    ) -> Any:
        """The model as a continuous ``control.StateSpace`` with named signals.

        The signals are named after ``input_names`` and ``output_names``.  Like :meth:`to_scipy`
        it describes deviations (inputs ``u - model.u0``, outputs ``y - model.y0``) and time in
        ``model.time_unit``: python-control has neither operating point nor unit.

        Parameters
        ----------
        noise_inputs : bool, optional
            With it the inputs are ``[u, e]`` (``B -> [B, K]``, ``D -> [D, I]``; the innovations
            named ``e_<output>``, not delayed).
        name : str or None, optional
            The system's name (python-control's default when ``None``).
        pade_order : int or None, optional
            Dead times become ``(N, N)`` Pade approximants
            (:func:`hdpbsid.models.dead_time.pade`) in series with each delayed input,
            ``N = pade_order`` or, by default, :meth:`pade_order`; their ``N m`` states follow
            the model's ``n``.  The exact delayed response is :meth:`frequency_response` and
            :meth:`simulate`.

        Returns
        -------
        control.StateSpace
            With ``dt=0``.

        Raises
        ------
        ImportError
            If python-control is not installed.
        """
        control = _import_control()
        A, B, C, D = self._with_pade(pade_order)
        inputs = list(self.input_names or [])
        if noise_inputs:
            K = np.vstack([self.K, np.zeros((A.shape[0] - self.n, self.l))])
            B, D = np.hstack([B, K]), np.hstack([D, np.eye(self.l)])
            inputs += _innovation_names(inputs, list(self.output_names or []))
        return control.StateSpace(A, B, C, D, 0, **_control_labels(inputs, self.output_names, name))


@dataclass(repr=False)
class DiscreteModel(_ModelBase):
    """Sampled innovation model ``x_{k+1} = A x_k + B u_k + K e_k``, ``y_k = C x_k + D u_k + e_k``.

    Parameters
    ----------
    A, B, C, D, K : array_like
        Shapes ``(n, n)``, ``(n, m)``, ``(l, n)``, ``(l, m)``, ``(n, l)``.
    singular_values, options, noise_covariance, u0, y0, trend, time_unit, input_names, output_names
        As in :class:`StateSpaceModel`.
    report : IdentificationReport or None, optional (keyword only)
        As in :class:`StateSpaceModel`.
    dt : float, optional
        Sampling interval in ``time_unit`` (``1.0`` when the index is just a sample count).

    Examples
    --------
    >>> from hdpbsid import DiscreteModel
    >>> model = DiscreteModel(A=[[0.5]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.0]], dt=0.1)
    >>> model.simulate([[1.0], [0.0], [0.0]]).ravel().tolist()  # impulse response 0, 1, 0.5
    [0.0, 1.0, 0.5]
    """

    dt: float = 1.0

    def __repr__(self) -> str:
        return f"DiscreteModel(dt={self.dt:g}, {self._repr_body()})"

    @library_call
    def simulate(self, u: Any, x0: Any | None = None, t: Any | None = None) -> Array:
        """Deterministic response to an input sequence.

        Parameters
        ----------
        u : array_like, shape (Ns, m)
            Absolute input: ``u0`` is removed and ``y0`` added (module docstring).
        x0 : array_like, shape (n,), optional
            Initial deviation state (default 0).
        t : array_like, shape (Ns,), optional
            The sample times; needed only when the model has a :class:`LinearTrend`.

        Returns
        -------
        ndarray, shape (Ns, l)
            The absolute output.

        Raises
        ------
        ValueError
            If ``u`` has the wrong number of columns, ``x0`` the wrong length, or the model has
            a trend and ``t`` is missing.
        """
        u = check_signal(u, "u", limit_energy=False)
        if u.shape[1] != self.m:
            raise ValueError(f"u must have {self.m} column(s) (inputs), got shape {u.shape}")
        if t is None:
            if self.trend is not None:
                raise ValueError("this model has a linear trend: pass the sample times t")
            t = np.zeros(u.shape[0])
        t = check_signal(t, "t", u.shape[0], limit_energy=False)[:, 0]
        U0, Y0 = self.operating_point(t)
        u = u - U0
        x = np.zeros(self.n) if x0 is None else as_float_array(x0, "x0").reshape(-1)
        if x.shape[0] != self.n:
            raise ValueError(f"x0 must have {self.n} entries, got {x.shape[0]}")
        X = linear_recursion(self.A, (u @ self.B.T)[:-1], x)
        return X @ self.C.T + u @ self.D.T + Y0

    def frequency_response(self, w: Any) -> NDArray[np.complex128]:
        r"""Frequency response :math:`G(e^{j\omega\,dt}) = C (e^{j\omega\,dt} I - A)^{-1} B + D`.

        Parameters
        ----------
        w : array_like, shape (nw,)
            Angular frequencies in rad per time unit.

        Returns
        -------
        ndarray of complex, shape (l, m, nw)
            The response, in python-control's layout.
        """
        w = as_float_array(w, "w").reshape(-1)
        return _transfer(self.A, self.B, self.C, self.D, np.exp(1j * w * self.dt))

    def to_continuous(self) -> StateSpaceModel:
        """The exact zero-order-hold inverse (:func:`hdpbsid.models.conversion.d2c`).

        Returns
        -------
        StateSpaceModel
            With ``discrete`` set to this model and ``sampling_interval = dt``.

        Raises
        ------
        ValueError
            If ``A`` has an eigenvalue on or near the negative real axis or at zero (no real
            logarithm: :func:`~hdpbsid.models.conversion.check_log_exists`).
        """
        A, B, C, D, K = d2c(self.A, self.B, self.C, self.D, self.K, self.dt)
        return StateSpaceModel(
            A,
            B,
            C,
            D,
            K,
            singular_values=self.singular_values,
            options=dict(self.options),
            noise_covariance=self.noise_covariance,
            discrete=self,
            sampling_interval=self.dt,
            **self._offsets_kwargs(),
        )

    def to_scipy(self) -> Any:
        """The model as ``scipy.signal.StateSpace(A, B, C, D, dt=dt)``.

        Returns
        -------
        scipy.signal.StateSpace
            In deviations from the operating point (see :meth:`StateSpaceModel.to_scipy`).
        """
        from scipy.signal import StateSpace

        return StateSpace(self.A, self.B, self.C, self.D, dt=self.dt)

    def to_control(self, name: str | None = None) -> Any:
        """The model as ``control.StateSpace(A, B, C, D, dt)`` with named signals.

        Parameters
        ----------
        name : str or None, optional
            The system's name.

        Returns
        -------
        control.StateSpace
            In deviations from the operating point, signals named as in
            :meth:`StateSpaceModel.to_control`.
        """
        labels = _control_labels(self.input_names, self.output_names, name)
        return _import_control().StateSpace(self.A, self.B, self.C, self.D, self.dt, **labels)


def scale_signals(model: Any, pu: Any, py: Any, px: int = 0) -> Any:
    """The same system for signals scaled by powers of two.

    ``u_new = u 2^pu``, ``y_new = y 2^py`` (per channel) and states ``x_new = x 2^px``:
    ``B -> 2^px B 2^-pu``, ``C -> 2^py C 2^-px``, ``D -> 2^py D 2^-pu``,
    ``K -> 2^px K 2^-py`` (the innovations are in output units), with the operating point
    and trend, the noise covariance (``2^py N 2^py``), the parameter covariance and the
    sampled model (if any); ``A`` and the eigenvalues are unchanged.

    Parameters
    ----------
    model : StateSpaceModel or DiscreteModel
        The model to rescale (not modified).
    pu : array_like of int, shape (m,)
        Power-of-two exponent of each input.
    py : array_like of int, shape (l,)
        Power-of-two exponent of each output.
    px : int, optional
        Power-of-two exponent of the states.

    Returns
    -------
    StateSpaceModel or DiscreteModel
        A new model of the same type.

    Raises
    ------
    ValueError
        If the exponents' lengths do not match the model's channels, or a matrix entry
        leaves the float64 range (the system's gain is not representable in those units).

    Notes
    -----
    Every product is an exact change of exponent (:func:`numpy.ldexp`): scaling and
    unscaling round-trips bit for bit, which is why the identification works on signals
    scaled to unit size and returns the model in the record's own units.
    """
    pu = np.asarray(pu, dtype=np.int64).reshape(-1)
    py = np.asarray(py, dtype=np.int64).reshape(-1)
    if pu.size != model.m or py.size != model.l:
        raise ValueError(
            f"scale_signals: {model.m} input and {model.l} output exponents needed, got "
            f"{pu.size} and {py.size}"
        )
    px = int(px)
    with np.errstate(over="ignore"):
        mats = {
            "B": np.ldexp(model.B, px - pu[None, :]),
            "C": np.ldexp(model.C, py[:, None] - px),
            "D": np.ldexp(model.D, py[:, None] - pu[None, :]),
            "K": np.ldexp(model.K, px - py[None, :]),
        }
    for k, M in mats.items():
        if not np.all(np.isfinite(M)):
            raise ValueError(
                f"the identified {k} overflows float64 in the record's units (its inputs and "
                f"outputs differ by more than the float range); rescale the signals"
            )
    tr = model.trend
    if tr is not None:
        tr = LinearTrend(tr.t_ref, np.ldexp(tr.u_slope, pu), np.ldexp(tr.y_slope, py))
    nc = model.noise_covariance
    if nc is not None:
        with np.errstate(over="ignore"):
            nc = np.ldexp(np.asarray(nc, dtype=float), py[:, None] + py[None, :])
        if not np.all(np.isfinite(nc)):
            nc = None  # the squares of the signals exceed float64: not representable
    cov = getattr(model, "parameter_covariance", None)
    if cov is not None:  # the parameters' factor scales with them
        n, m, l = model.n, model.m, model.l
        cov = cov.scaled(
            n,
            m,
            l,
            np.ldexp(np.ones((n, m)), px - pu[None, :]),
            np.ldexp(np.ones((l, n)), py[:, None] - px),
            np.ldexp(np.ones((l, m)), py[:, None] - pu[None, :]),
        )
    changes: dict[str, Any] = dict(
        mats,
        u0=np.ldexp(model.u0, pu),
        y0=np.ldexp(model.y0, py),
        trend=tr,
        noise_covariance=nc,
    )
    if isinstance(model, StateSpaceModel):
        changes["parameter_covariance"] = cov
        if model.discrete is not None:
            changes["discrete"] = scale_signals(model.discrete, pu, py, px)
    return dataclasses.replace(model, **changes)


def _transfer(A: Array, B: Array, C: Array, D: Array, s: NDArray[np.complex128]) -> Any:
    n = A.shape[0]
    if n == 0:
        return np.repeat(D[:, :, None].astype(complex), s.size, axis=2)
    M = s[:, None, None] * np.eye(n)[None] - A[None]
    X = np.linalg.solve(M, np.broadcast_to(B, (s.size,) + B.shape))
    G = np.einsum("ij,kjl->kil", C, X) + D[None]
    return np.moveaxis(G, 0, -1)


def _block_diag(blocks: list[Array]) -> Array:
    from scipy.linalg import block_diag

    return np.asarray(block_diag(*blocks), dtype=float).reshape(
        sum(b.shape[0] for b in blocks), sum(b.shape[1] for b in blocks)
    )


def _innovation_names(inputs: list[str], outputs: list[str]) -> list[str]:
    """``e_<output>`` for each output, made distinct from the input names."""
    names = []
    for o in outputs:
        e = f"e_{o}"
        while e in inputs or e in names:
            e = "_" + e
        names.append(e)
    return names


def _control_labels(inputs: Any, outputs: Any, name: str | None) -> dict[str, Any]:
    """Keyword arguments naming the signals (and the system) of a python-control model."""
    labels: dict[str, Any] = {"inputs": list(inputs or []), "outputs": list(outputs or [])}
    if name is not None:
        labels["name"] = check_label(name, "name")
    return labels


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


def _import_control() -> Any:
    try:
        import control
    except ImportError as exc:  # pragma: no cover - control is in the test extra
        raise ImportError(
            "to_control() needs python-control: pip install 'slbasis-hdpbsid[studies]' "
            "or pip install control"
        ) from exc
    return control


def _set_levels(model: StateSpaceModel, u0: Any, y0: Any, trend: LinearTrend | None) -> None:
    """Store the operating point in ``model`` (and its sampled model, if it has one)."""
    u0 = np.asarray(u0, dtype=float).reshape(-1)
    y0 = np.asarray(y0, dtype=float).reshape(-1)
    if u0.size != model.m or y0.size != model.l:
        raise TypeError(
            f"the method returned a model with {model.m} input(s) and {model.l} output(s) "
            f"for data with {u0.size} and {y0.size}"
        )
    for mod in (model, model.discrete):
        if mod is not None:
            mod.u0, mod.y0, mod.trend = u0.copy(), y0.copy(), trend
