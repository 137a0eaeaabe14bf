"""Operating points of measured records: levels (and trends) removed before identification.

A linear model describes *deviations* from an operating point (Ljung, *System
Identification*, 2nd ed., sec. 14.1).  Measured signals carry levels: a sensor offset,
the equilibrium the experiment ran around.  Left in, a level is an input the model must
explain with its dynamics -- a constant step that the PBSID regressions fit as if it
were excitation -- so the identified eigenvalues change when the same record is shifted
by a constant.  Removing each channel's mean makes the estimate invariant to such shifts
(exactly, up to the rounding of the subtraction).  The price: the mean of a finite
record is not the equilibrium, so a record that starts at rest carries an O(1/T) level
error that the model cannot explain (noise-free data simulated from rest then lose
their exactness; identify those with ``detrend=None``).

:func:`detrend_record` removes the levels (``"mean"``) or least-squares lines
(``"linear"``, MATLAB ``detrend(data, 1)``) of one record and returns what it removed;
:func:`warn_if_levels_dominate` warns when a record is identified with its levels in and
they dominate its variation.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["DETREND_CHOICES", "Levels", "detrend_record", "warn_if_levels_dominate"]

Array = NDArray[np.float64]

#: Accepted values of ``identify(..., detrend=...)``.
DETREND_CHOICES = ("mean", "linear", None)


@dataclass
class Levels:
    """What :func:`detrend_record` removed from one record.

    ``u0 (m,)``, ``y0 (l,)``: the channel means; with ``"linear"`` also ``t_ref`` (the
    record's mean time) and the slopes ``u_slope (m,)``, ``y_slope (l,)`` of the
    least-squares lines ``level(t) = x0 + slope (t - t_ref)`` (the line through the
    means, so ``x0`` is the mean).  ``samples``: the record length.
    """

    u0: Array
    y0: Array
    samples: int
    t_ref: float | None = None
    u_slope: Array | None = None
    y_slope: Array | None = None

    def as_dict(self) -> dict[str, object]:
        """Plain lists, for ``model.options``."""
        d: dict[str, object] = {
            "u0": self.u0.tolist(),
            "y0": self.y0.tolist(),
            "samples": self.samples,
        }
        if self.t_ref is not None:
            d.update(
                t_ref=self.t_ref,
                u_slope=np.asarray(self.u_slope).tolist(),
                y_slope=np.asarray(self.y_slope).tolist(),
            )
        return d


def _line(t: Array, x: Array) -> tuple[Array, Array]:
    """Least-squares slope of each column of ``x`` against ``t`` and the residual."""
    tc = t - t.mean()
    slope = (tc @ (x - x.mean(axis=0))) / (tc @ tc)
    return slope, x - x.mean(axis=0) - tc[:, None] * slope[None, :]


def detrend_record(t: Array, u: Array, y: Array, kind: str | None) -> tuple[Array, Array, Levels]:
    """Remove levels from a checked record ``t (Ns,)``, ``u (Ns, m)``, ``y (Ns, l)``.

    ``kind="mean"``: ``u - mean(u)``, ``y - mean(y)`` per column; ``"linear"``: the
    least-squares line in ``t`` per column; ``None``: nothing (levels reported as 0).
    Returns ``(u_detrended, y_detrended, Levels)``.
    """
    if kind not in DETREND_CHOICES:
        raise ValueError(f"detrend must be one of {DETREND_CHOICES}, got {kind!r}")
    ns = t.shape[0]
    if kind is None:
        return u, y, Levels(np.zeros(u.shape[1]), np.zeros(y.shape[1]), ns)
    u0, y0 = u.mean(axis=0), y.mean(axis=0)
    if kind == "mean":
        return u - u0, y - y0, Levels(u0, y0, ns)
    us, ud = _line(t, u)
    ys, yd = _line(t, y)
    return ud, yd, Levels(u0, y0, ns, float(t.mean()), us, ys)


def warn_if_levels_dominate(u: Array, y: Array, where: str = "", stacklevel: int = 3) -> None:
    """``UserWarning`` when a channel's mean outweighs its variation, ``|mean| > std``.

    Then the constant part carries more of the channel's mean-square power than the
    variation does (``mean^2 > var``), so an identification that keeps the level treats
    mostly a constant as signal; the rule is scale-free and refers to no record.
    """
    for name, x in (("u", u), ("y", y)):
        for j in range(x.shape[1]):
            mean, std = float(np.mean(x[:, j])), float(np.std(x[:, j]))
            if abs(mean) > std:
                ratio = "a constant" if std == 0 else f"{abs(mean) / std:.3g} times its std"
                warnings.warn(
                    f"{where}{name}[:, {j}] has mean {mean:.6g}, {ratio} ({std:.3g}): its "
                    f"level dominates its variation and detrend=None keeps it, so the "
                    f"model fits the level as if it were dynamics (the eigenvalues change "
                    f"with a constant shift); use detrend='mean' (the default)",
                    UserWarning,
                    stacklevel=stacklevel,
                )
