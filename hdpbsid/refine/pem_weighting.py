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
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

__all__ = ["Relaxed", "relax_weighting"]

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
    eye = np.eye(n_outputs)
    logdet, spent, out = _log_det(record, theta, eye), 0, None
    while spent < budget:
        E = record(theta, W=eye).reshape(n_outputs, -1)
        try:
            W = np.linalg.inv(np.linalg.cholesky(E @ E.T / E.shape[1]))
        except np.linalg.LinAlgError:
            break
        end = fit(theta, lambda th, W=W, **kw: record(th, W=W, **kw), budget - spent)
        spent += end.nfev
        new = _log_det(record, end.theta, eye)
        if not (end.converged and E.shape[1] * (logdet - new) > evidence):
            break
        theta, logdet = end.theta, new
        out = Relaxed(end.theta, float(end.cost), W, str(end.message), spent)
    return None if out is None else out._replace(nfev=spent)


def _log_det(record: Callable[..., Any], theta: Array, eye: Array) -> float:
    """``log det`` of the covariance of the one-step errors at ``theta`` (``inf`` when it
    is not positive definite)."""
    E = record(theta, W=eye).reshape(eye.shape[0], -1)
    sign, value = np.linalg.slogdet(E @ E.T / E.shape[1])
    return float(value) if sign > 0 and np.isfinite(value) else float("inf")
