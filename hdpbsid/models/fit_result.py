"""The simulation fit of a model on a record: :class:`FitResult` and :func:`fit_statistics`.

Two measures per output, the normalised root-mean-square error (whose complement is the
fit of MATLAB's ``compare``) and the variance accounted for (Ljung, *System
Identification*, 2nd ed., 1999, sec. 16.6, model validation by simulation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import scale_exponents

__all__ = ["FitResult", "fit_statistics"]

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
