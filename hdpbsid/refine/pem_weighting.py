"""The output weighting of the prediction-error refinement with several outputs
(:mod:`hdpbsid.refine.pem`): the determinant criterion by relaxation
(:func:`relax_weighting`).

With unknown innovation covariance the Gaussian maximum-likelihood estimate minimises
``det`` of the one-step errors' covariance (Ljung, *System Identification*, 2nd ed.,
1999, sec. 7.4; the "determinant" criterion), and the weighted least squares ``V`` of
the refinement, with ``W`` fixed from the first start's errors, has the same minimiser
only when those errors have the estimate's covariance (at the minimiser of ``det``,
``W = Sigma^(-1/2)`` of its own errors is stationary).  A start far from the estimate --
in closed loop, a first pass whose noise model is poor -- weights the outputs by its own
errors' covariance, and the fit then converges to the minimum of that weighting, which
can lie far from the determinant's (on a closed-loop plant with rate and acceleration
outputs, a fast mode tens of per cent off, which the fit under its own errors' weighting
resolved).  Setting the weighting from the end point and fitting again is the
relaxation of the determinant criterion: the covariance that maximises the likelihood
for given parameters is that of their residuals, so the two are estimated in turn
(Jategaonkar, *Flight Vehicle System Identification*, AIAA, 2006, app. E).  With one
output the weighting is a scale, and the minimiser does not depend on it.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["Relaxed", "relax_weighting", "error_covariance", "weighting"]

Array = NDArray[np.float64]


class Relaxed(NamedTuple):
    """The end of :func:`relax_weighting`.

    Attributes
    ----------
    theta : ndarray
        The parameters of the last fit that lowered the determinant.
    cost : float
        Their mean squared residual under ``W``.
    W : ndarray
        The weighting of that fit: the inverse Cholesky factor of its start's errors'
        covariance.
    message : str
        Why that fit stopped.
    nfev : int
        The evaluations of every fit of the relaxation.
    """

    theta: Array
    cost: float
    W: Array
    message: str
    nfev: int


def relax_weighting(
    theta: Array,
    record: Callable[..., Any],
    fit: Callable[[Array, Callable[..., Any], int], Any],
    n_outputs: int,
    budget: int,
    evidence: float,
) -> Relaxed | None:
    """The converged parameters ``theta`` fitted again under the weighting of their own
    errors, while that lowers the determinant of the errors' covariance by more than
    ``evidence`` units of ``-2 log`` likelihood ratio (``N`` times the drop of its
    logarithm; module docstring); None when the first such fit does not.

    Parameters
    ----------
    theta : ndarray
        A converged end point of the refinement.
    record : callable
        ``record(theta, W=W)``: the weighted one-step errors, ``n_outputs`` rows in a
        flat vector.
    fit : callable
        ``fit(theta, residuals, budget)``: a Levenberg-Marquardt fit from ``theta`` of the
        residual function ``residuals``, with ``theta``, ``cost``, ``nfev``, ``message``
        and ``converged``.
    n_outputs : int
        The number of outputs (at least 2).
    budget : int
        Evaluations for all the fits together.
    evidence : float
        The drop that continues the relaxation.

    Returns
    -------
    Relaxed or None
        The last fit that lowered the determinant by the evidence, with every fit's
        evaluations; None when none did.
    """
    S, n_samples = error_covariance(record, theta, n_outputs)
    spent, out = 0, None
    while spent < budget:
        try:
            W = weighting(S)
        except np.linalg.LinAlgError:
            break
        end = fit(theta, partial(record, W=W), budget - spent)
        spent += end.nfev
        S_end = error_covariance(record, end.theta, n_outputs)[0]
        if not (end.converged and n_samples * (_log_det(S) - _log_det(S_end)) > evidence):
            break
        theta, S = end.theta, S_end
        out = Relaxed(end.theta, float(end.cost), W, str(end.message), spent)
    return None if out is None else out._replace(nfev=spent)


def error_covariance(record: Callable[..., Any], theta: Array, n_outputs: int) -> tuple[Array, int]:
    """The covariance of the one-step errors at ``theta`` (``record(theta, W=I)``,
    ``n_outputs`` rows in a flat vector) and the number of samples it is over.

    Parameters
    ----------
    record : callable
        ``record(theta, W=W)``: the weighted one-step errors.
    theta : ndarray
        The parameters.
    n_outputs : int
        The number of outputs.

    Returns
    -------
    tuple of (ndarray, int)
        ``E E^T / N`` and ``N``.
    """
    E = record(theta, W=np.eye(n_outputs)).reshape(n_outputs, -1)
    return E @ E.T / E.shape[1], int(E.shape[1])


def weighting(S: Array) -> Array:
    """The output weighting that whitens errors of covariance ``S``: the inverse of its
    Cholesky factor (``W S W^T = I``); ``LinAlgError`` when ``S`` is not positive
    definite.

    Parameters
    ----------
    S : ndarray
        An error covariance.

    Returns
    -------
    ndarray
        ``W``.
    """
    return np.linalg.inv(np.linalg.cholesky(S))


def _log_det(S: Array) -> float:
    """``log det S`` (``inf`` when ``S`` is not positive definite)."""
    sign, value = np.linalg.slogdet(S)
    return float(value) if sign > 0 and np.isfinite(value) else float("inf")
