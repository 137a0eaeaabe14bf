"""Accuracy measures used by tests, studies and benchmarks."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["match_eigenvalues", "eigenvalue_errors"]


def match_eigenvalues(
    estimated: Any, true: Any
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Pair estimated with true eigenvalues minimising the total distance.

    Uses the Hungarian algorithm (:func:`scipy.optimize.linear_sum_assignment`) on
    ``|est_i - true_j|``.  Returns ``(est_paired, true_paired)`` of length
    ``min(len(estimated), len(true))``, in the order of ``true``.
    """
    from scipy.optimize import linear_sum_assignment  # here: scipy.optimize is slow to import

    est = np.asarray(estimated, dtype=complex).ravel()
    tru = np.asarray(true, dtype=complex).ravel()
    cost = np.abs(est[:, None] - tru[None, :])
    r, c = linear_sum_assignment(cost)
    order = np.argsort(c)
    return est[r[order]], tru[c[order]]


def eigenvalue_errors(estimated: Any, true: Any) -> NDArray[np.float64]:
    """Relative errors ``|est - true| / |true|`` after :func:`match_eigenvalues`.

    Raises ``ValueError`` if the numbers of eigenvalues differ (a wrong order is not an
    accuracy figure).
    """
    est = np.asarray(estimated, dtype=complex).ravel()
    tru = np.asarray(true, dtype=complex).ravel()
    if est.size != tru.size:
        raise ValueError(
            f"estimated has {est.size} eigenvalues but true has {tru.size}: orders differ"
        )
    e, t = match_eigenvalues(est, tru)
    return np.abs(e - t) / np.abs(t)
