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

from hdpbsid.runtime import user_stacklevel

__all__ = ["DETREND_CHOICES", "Levels", "detrend_record", "warn_if_levels_dominate"]

Array = NDArray[np.float64]

#: Accepted values of ``identify(..., detrend=...)``.
DETREND_CHOICES = ("mean", "linear", None)


@dataclass
class Levels:
    """What :func:`detrend_record` removed from one record.

    Parameters
    ----------
    u0 : ndarray, shape (m,)
        Input channel means.
    y0 : ndarray, shape (l,)
        Output channel means.
    samples : int
        The record length.
    t_ref : float or None, optional
        With ``"linear"``: the record's mean time.
    u_slope : ndarray, shape (m,), or None, optional
        With ``"linear"``: slopes of the input lines ``level(t) = u0 + slope (t - t_ref)``
        (the least-squares line passes through the means, so ``u0`` is the mean).
    y_slope : ndarray, shape (l,), or None, optional
        With ``"linear"``: slopes of the output lines.
    """

    u0: Array
    y0: Array
    samples: int
    t_ref: float | None = None
    u_slope: Array | None = None
    y_slope: Array | None = None

    def as_dict(self) -> dict[str, object]:
        """The levels as plain lists, for ``model.options``.

        Returns
        -------
        dict
            ``u0``, ``y0``, ``samples`` and, after ``"linear"``, ``t_ref`` and the slopes.
        """
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
    r"""Remove levels from a checked record.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Sample times.
    u : ndarray, shape (Ns, m)
        Input.
    y : ndarray, shape (Ns, l)
        Output.
    kind : {"mean", "linear", None}
        ``"mean"``: each column's mean; ``"linear"``: each column's least-squares line in
        ``t`` (MATLAB ``detrend(data, 1)``); ``None``: nothing (levels reported as 0).

    Returns
    -------
    u_detrended : ndarray, shape (Ns, m)
    y_detrended : ndarray, shape (Ns, l)
    levels : Levels
        What was removed.

    Raises
    ------
    ValueError
        If ``kind`` is not one of :data:`DETREND_CHOICES`.

    Notes
    -----
    The line of a column ``x`` is
    :math:`x_0 + s\,(t - \bar t)` with :math:`x_0 = \bar x` and
    :math:`s = \sum_k (t_k - \bar t)(x_k - \bar x) / \sum_k (t_k - \bar t)^2`.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0.0, 1.0, 5)
    >>> u, y = np.ones((5, 1)), (3.0 + 2.0 * t)[:, None]
    >>> ud, yd, levels = detrend_record(t, u, y, "linear")
    >>> bool(np.allclose(yd, 0.0)), round(float(levels.y_slope[0]), 12), float(levels.y0[0])
    (True, 2.0, 4.0)
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


def warn_if_levels_dominate(
    u: Array, y: Array, where: str = "", stacklevel: int | None = None
) -> None:
    """Warn when a channel's mean outweighs its variation, ``|mean| > std``.

    Then the constant part carries more of the channel's mean-square power than the
    variation does (``mean^2 > var``), so an identification that keeps the level treats
    mostly a constant as signal; the rule is scale-free and refers to no record.

    Parameters
    ----------
    u : ndarray, shape (Ns, m)
        Input.
    y : ndarray, shape (Ns, l)
        Output.
    where : str, optional
        Prefix of the message (e.g. the record's name).
    stacklevel : int, optional
        Passed to :func:`warnings.warn`; by default the user's call
        (:func:`~hdpbsid.runtime.user_stacklevel`).

    Warns
    -----
    UserWarning
        For each channel whose level dominates.
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
                    stacklevel=user_stacklevel() if stacklevel is None else stacklevel,
                )
