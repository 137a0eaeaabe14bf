"""A refinement its evaluation budget cut off: continued once (:func:`continued`), and
whether it is kept (:func:`keep_iterate`).

The prediction-error refinement (:func:`hdpbsid.refine.pem.refine_pem`) is a descent
method: the iterate it returns costs less on the record than its start.  When the
evaluation budget stops it before its convergence test holds -- typically a flat valley
along which a fast mode crawls towards the data -- the iterate is not the
prediction-error estimate (its first-order covariance is not the estimate's), yet it can
be a far better model of the record than the subspace estimate it started from.

Rule: the iterate is kept when the record resolves it as better than its start: its
windowed simulation error below the start's by more than ``z`` standard errors of the
window errors, the start listed first
(:func:`~hdpbsid.models.criteria.choose_smallest_adequate`, the selection's
one-standard-error rule), and with ``focus="prediction"`` its windowed one-step
prediction error (the fit's criterion) too.  The simulation error depends on the plant
alone: a descent can lower the prediction cost by moving the noise model ``K`` while the
plant stays where it was, which says nothing for a model that is not at a minimum;
requiring the simulation to be resolved too asks the plant itself to be better.  A
record without an input (a time series) has no simulation: the prediction error alone
decides.  Otherwise the start stays: at the record's resolution the two are the same
model, and the start is an estimator's estimate.  Both have the same parameters, so the
comparison on the record favours neither by its size.  A kept iterate's report says that
the refinement did not converge (``report.refinement.converged`` is False), and its
eigenvalue standard deviations are first-order at the iterate.

Before that rule is asked, such an iterate goes on once from where it stopped
(:func:`continued`), in its own input hold, with a budget of its own: the budget bounds a
crawl, but a descent from a start far from the minimum -- a subspace estimate biased by
feedback, whose refinement must move the fast modes a long way -- is cut off on its way
to a minimum the data resolve.  The continuation is kept when its likelihood on the
record is higher (the same parameters and data: the ``-2 log`` likelihood ratio needs no
price; Ljung, *System Identification*, 2nd ed., 1999, sec. 7.4).  Once: a fit that
stops short twice is the rare long crawl the budget is there to bound, and its iterate
is judged by :func:`keep_iterate`.  Only at an order the user gave, whose estimate is the
minimum of that order's cost: with the order chosen by the data, the final refinement
starts where the order decision left it, and a descent cut off there can be one
of an order above the plant's, whose extra state has no minimum the record resolves
(its mode crawls along a flat valley, towards a lightly damped pair far above the
plant's band): going on moves the plant no nearer.
"""

from __future__ import annotations

import enum
import warnings
from typing import Any

import numpy as np

from hdpbsid.data.checks import check_data
from hdpbsid.models.criteria import (
    SIGNIFICANCE_Z,
    choose_smallest_adequate,
    default_windows,
    windowed_prediction_error,
    windowed_simulation_error,
)
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import Choice

__all__ = ["IterateRule", "continued", "keep_iterate"]


class IterateRule(str, enum.Enum):
    """Which way :func:`keep_iterate` took."""

    #: the refinement converged: nothing to decide
    CONVERGED = "converged"
    #: cut off by the budget, and better than its start by more than ``z`` standard errors
    RESOLVED = "resolved from its start"
    #: cut off by the budget, and not better than its start by ``z`` standard errors
    NOT_RESOLVED = "not resolved from its start"


def keep_iterate(
    start: StateSpaceModel,
    refined: StateSpaceModel,
    t: Any,
    u: Any,
    y: Any,
    focus: str = "prediction",
) -> Choice[bool]:
    """Whether the refinement ``refined`` of ``start`` on ``(t, u, y)`` is kept although
    its budget cut it off (module docstring).

    Parameters
    ----------
    start : StateSpaceModel
        The model the refinement started from.
    refined : StateSpaceModel
        The refinement's result (``refine_pem``'s).
    t, u, y : array_like
        The uniformly sampled record it was refined on.
    focus : {"prediction", "simulation"}, optional
        The refinement's criterion: with ``"prediction"`` the windowed one-step
        prediction errors are compared as well as the simulation errors.

    Returns
    -------
    Choice of bool
        True to keep ``refined``; ``rule`` an :class:`IterateRule`.

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import identify
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(2000) * 0.05
    >>> u = rng.standard_normal((2000, 1))
    >>> y = np.convolve(u[:, 0], np.exp(-t[:100]), "full")[:2000, None] * 0.05
    >>> m = identify(t, u, y + 0.01 * rng.standard_normal(y.shape), order=1, method="dt")
    >>> keep_iterate(m, m, t, u, y).rule is IterateRule.CONVERGED
    True
    """
    if refined.report.converged:
        return Choice(True, IterateRule.CONVERGED.value, IterateRule.CONVERGED)
    t, u, y = check_data(t, u, y)
    windows = default_windows(t.size, max(start.n, refined.n))
    criteria = {}
    if focus != "simulation":
        criteria["one-step prediction"] = windowed_prediction_error
    if u.shape[1] > 0:
        criteria["simulation"] = windowed_simulation_error
    nfev = refined.report.refinement.nfev
    for what, error in criteria.items():
        chosen, z = choose_smallest_adequate([error(m, t, u, y, windows) for m in (start, refined)])
        if chosen == 0:
            text = (
                f"did not converge in {nfev} evaluations; not kept: its windowed {what} error is "
                f"within {z[0]:.3g} SE of its start's ({windows} windows)"
            )
            return Choice(False, text, IterateRule.NOT_RESOLVED)
    text = (
        f"did not converge in {nfev} evaluations; kept: its windowed {' and '.join(criteria)} "
        f"errors are more than {SIGNIFICANCE_Z:g} SE below its start's ({windows} windows)"
    )
    return Choice(True, text, IterateRule.RESOLVED)


def continued(refined: StateSpaceModel, t: Any, u: Any, y: Any) -> tuple[StateSpaceModel, str]:
    """``refined``, or its refinement continued once from where its evaluation budget
    cut it off when that is likelier on the record, at an order the user gave (module
    docstring), and the note for the refinement's rule (``""`` when ``refined`` is
    kept).

    Parameters
    ----------
    refined : StateSpaceModel
        A prediction-error refinement (:func:`hdpbsid.refine.pem.refine_pem`) on the
        record.
    t, u, y : array_like
        The uniformly sampled record it was refined on (the front end's detrended
        signals).

    Returns
    -------
    tuple of (StateSpaceModel, str)
        The model kept and what the rule adds.

    Examples
    --------
    A model no refinement cut off (here: never refined) goes on no further:

    >>> from hdpbsid import StateSpaceModel
    >>> m = StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]])
    >>> t = np.arange(0.0, 10.0, 0.1)
    >>> u = np.sign(np.sin(t))[:, None]
    >>> kept, note = continued(m, t, u, m.simulate(t, u))
    >>> kept is m, note
    (True, '')
    """
    fit, order = refined.report.refinement, refined.report.order
    if fit is None or fit.converged or order is None or not order.given:
        return refined, ""
    from hdpbsid.refine.pem import refine_pem

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            again = refine_pem(refined, t, u, y, hold=refined.report.hold)
        except (ValueError, np.linalg.LinAlgError):
            return refined, ""
    first, cost = (_likelihood_cost(m, t, u, y) for m in (refined, again))
    if not cost < first:
        return refined, ""
    gain = f", its likelihood higher by {first - cost:.0f} units" if np.isfinite(first) else ""
    state = "converged" if again.report.converged else "did not converge"
    return again, (
        f"; the refinement did not converge in {fit.nfev} evaluations: it went on from "
        f"where it stopped and {state} in {again.report.refinement.nfev} more{gain}"
    )


def _likelihood_cost(model: StateSpaceModel, t: Any, u: Any, y: Any) -> float:
    """``N log det S`` of ``model`` on the record in its own hold (``inf`` when its
    predictor is unstable): :func:`~hdpbsid.refine.pem.prediction_log_det`."""
    from hdpbsid.refine.pem import prediction_log_det

    cost = prediction_log_det(model, t, u, y, model.report.hold)
    return np.inf if cost is None else cost
