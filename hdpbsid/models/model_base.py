"""What every identified model holds: the matrices, the operating point, labels, report.

:class:`_ModelBase` is the common part of :class:`~hdpbsid.models.model.StateSpaceModel`
and :class:`~hdpbsid.models.model.DiscreteModel`: the innovation-form matrices
``(A, B, C, D, K)`` (checked on construction), the operating point ``(u0, y0)`` with an
optional :class:`LinearTrend` (Ljung, *System Identification*, 2nd ed., sec. 14.1: a
model identified on signals with their levels removed describes deviations from them),
the channel names and time unit, and the identification report.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import as_float_array, check_label, check_names, check_state_space
from hdpbsid.models.report import IdentificationReport

if TYPE_CHECKING:
    from hdpbsid.models.model import StateSpaceModel

__all__ = ["LinearTrend"]

Array = NDArray[np.float64]


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
