"""The affine map between a record's time axis and a family's natural variable.

``x = (t - centre) * scale`` and ``t = centre + x / scale`` (``scale > 0``). Under this map
the L^2(dt)-orthonormal functions are ``phi_n(t) = sqrt(scale) phi_n(x(t))``, derivatives
obey ``d/dt = scale d/dx`` and integrals ``int f dt = int f dx / scale``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["TimeMap"]


@dataclass(frozen=True)
class TimeMap:
    """``x = (t - centre) * scale``; ``centre`` is the time that maps to ``x = 0``.

    Parameters
    ----------
    centre : float
        Finite.
    scale : float
        ``dx/dt``, finite and ``> 0``.

    Raises
    ------
    ValueError
        If ``centre`` is not finite or ``scale`` not a finite positive number.

    Examples
    --------
    >>> tm = TimeMap(centre=1.0, scale=1.0)
    >>> tm.to_x(np.array([0.0, 2.0])), tm.to_t(np.array([-1.0]))
    (array([-1.,  1.]), array([0.]))
    """

    centre: float
    scale: float

    def __post_init__(self) -> None:
        if not np.isfinite(self.centre):
            raise ValueError(f"centre: expected a finite number, got {self.centre!r}")
        if not (np.isfinite(self.scale) and self.scale > 0):
            raise ValueError(f"scale: expected a finite number > 0, got {self.scale!r}")

    def to_x(self, t: np.ndarray) -> np.ndarray:
        """Natural variable ``x`` of the times ``t``.

        Parameters
        ----------
        t : array_like
            Times.

        Returns
        -------
        ndarray
            ``(t - centre) * scale``.
        """
        return (np.asarray(t, dtype=float) - self.centre) * self.scale

    def to_t(self, x: np.ndarray) -> np.ndarray:
        """Times ``t`` of the natural variable ``x``.

        Parameters
        ----------
        x : array_like
            Points of the family's variable.

        Returns
        -------
        ndarray
            ``centre + x / scale``.
        """
        return self.centre + np.asarray(x, dtype=float) / self.scale
