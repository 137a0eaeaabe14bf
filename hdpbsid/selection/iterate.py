"""Whether a refinement its evaluation budget cut off is kept (:func:`keep_iterate`).

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
"""

from __future__ import annotations

import enum
from typing import Any

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

__all__ = ["IterateRule", "keep_iterate"]


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
