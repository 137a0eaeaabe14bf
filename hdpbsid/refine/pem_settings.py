"""The settings of the prediction-error refinement (:mod:`hdpbsid.refine.pem`).

Every number the refinement uses to decide something -- how long it searches, when a fit
has converged, when one candidate (a starting point, an input hold) is evidence against
another -- is a field of :class:`RefinementSettings`, with its reason.  The evidence
thresholds are on the scale of the ``-2 log`` likelihood ratio of the whitened one-step
prediction errors, ``n_r log(V_1 / V_2)`` with ``n_r`` residuals and mean squared errors
``V``, which is asymptotically chi-square distributed for nested structures and
comparable on the same scale for structures of equal dimension (Ljung, *System
Identification*, 2nd ed., 1999, sec. 16.4; Soderstrom & Stoica, *System Identification*,
1989, sec. 11.5).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["RefinementSettings", "DEFAULT_SETTINGS"]


@dataclass(frozen=True)
class RefinementSettings:
    """Budget, stopping rule and evidence thresholds of :func:`hdpbsid.refine.pem.refine_pem`.

    The cost is the mean ``V`` of ``n_r`` squared whitened residuals; near a minimum,
    moving the parameters by ``delta`` standard deviations (along any direction of their
    covariance) raises it by about ``delta^2 / n_r`` relative, which sets the scale of
    :attr:`stall_sd`.  A Gauss-Newton step predicts the cost at the minimum of the
    linearised residuals; a candidate is pursued only when that prediction is below the
    best cost by :attr:`evidence` units of ``-2 log`` likelihood ratio.

    Attributes
    ----------
    max_nfev : int
        Levenberg-Marquardt evaluations per input hold, over all starting points.
    xtol : float
        Levenberg-Marquardt step tolerance (:func:`scipy.optimize.least_squares`).
    stall_sd : float
        A run that moves the estimate by less than this many of its standard deviations
        ends the fit (``ftol = stall_sd^2 / n_r`` too).
    run_nfev : int
        Evaluations per Levenberg-Marquardt run before the local coordinates are
        re-centred.
    converged_nfev : int
        A run that converges within this many evaluations ends the fit.
    evidence : float
        Predicted drop of ``-2 log`` likelihood ratio that makes a further start or the
        other input hold worth fitting.
    hold_evidence : float
        Drop of ``-2 log`` likelihood ratio by which the other input hold must beat the
        first to replace it.
    oe_process_noise : float
        Process-noise intensity (unit measurement noise, scaled data) of the second
        starting gain.
    unstable_penalty : float
        Residual per entry returned for an unstable predictor.
    record_memory : int
        Residual vectors one record's evaluation remembers.
    jacobian_memory : int
        Jacobians one record's evaluation remembers.

    Examples
    --------
    >>> from dataclasses import replace
    >>> replace(DEFAULT_SETTINGS, max_nfev=40).max_nfev
    40
    """

    #: bounds the rare long crawl along a flat valley of the cost; a typical fit of both
    #: starts converges in well under a hundred evaluations
    max_nfev: int = 150
    #: scipy's default relative step tolerance: the cost test (``ftol``) is the binding one
    xtol: float = 1e-8
    #: a tenth of a standard deviation is below what a user can see in the estimate
    stall_sd: float = 0.1
    #: far from the optimum the first chart of the local coordinates can be poor
    run_nfev: int = 12
    #: a re-centred chart that converges at once did not move: the fit is at a minimum
    converged_nfev: int = 3
    #: one unit on the chi-square(1) scale (a likelihood ratio of e^(1/2)) is no evidence
    evidence: float = 1.0
    #: chi-square(1) quantile at 1 %: a wrong switch of hold is then a 1 % event
    hold_evidence: float = 6.635
    #: the Kalman predictor of a sensor-noise-dominated record, a start far from the
    #: method's own gain, so that a degenerate noise model has an alternative
    oe_process_noise: float = 1e-6
    #: far above any attainable cost of whitened residuals, so the step is rejected
    unstable_penalty: float = 1e3
    #: a run's start, its end and the screens ask for the same residuals again
    record_memory: int = 4
    #: one Jacobian per starting point of the start screen
    jacobian_memory: int = 2


#: the settings :func:`hdpbsid.refine.pem.refine_pem` uses when given none
DEFAULT_SETTINGS = RefinementSettings()
