"""Accuracy measures used by tests, studies and benchmarks."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["match_eigenvalues", "eigenvalue_errors"]


def match_eigenvalues(
    estimated: Any, true: Any
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    r"""Pair estimated with true eigenvalues minimising the total distance.

    Parameters
    ----------
    estimated : array_like of complex
        Estimated eigenvalues (any count).
    true : array_like of complex
        True eigenvalues (any count).

    Returns
    -------
    est_paired, true_paired : ndarray of complex
        Of length ``min(len(estimated), len(true))``, in the order of ``true``.

    Notes
    -----
    The assignment minimising :math:`\sum |\hat\lambda_i - \lambda_{\pi(i)}|` is found
    by the Hungarian algorithm (Kuhn 1955; :func:`scipy.optimize.linear_sum_assignment`):
    pairing by sorted order would mismatch a complex pair with a nearby real eigenvalue.

    Examples
    --------
    >>> from hdpbsid import match_eigenvalues
    >>> est, tru = match_eigenvalues([-2.1, -0.9], [-1.0, -2.0])
    >>> est.real.tolist(), tru.real.tolist()
    ([-0.9, -2.1], [-1.0, -2.0])
    """
    from scipy.optimize import linear_sum_assignment  # here: scipy.optimize is slow to import

    est = np.asarray(estimated, dtype=complex).ravel()
    tru = np.asarray(true, dtype=complex).ravel()
    cost = np.abs(est[:, None] - tru[None, :])
    r, c = linear_sum_assignment(cost)
    order = np.argsort(c)
    return est[r[order]], tru[c[order]]


def eigenvalue_errors(estimated: Any, true: Any) -> NDArray[np.float64]:
    r"""Relative errors of estimated eigenvalues after :func:`match_eigenvalues`.

    Parameters
    ----------
    estimated : array_like of complex
        Estimated eigenvalues.
    true : array_like of complex
        True eigenvalues, as many as ``estimated``, none zero.

    Returns
    -------
    ndarray, shape (n,)
        :math:`|\hat\lambda - \lambda| / |\lambda|` per true eigenvalue, in the order of
        ``true``.

    Raises
    ------
    ValueError
        If the numbers of eigenvalues differ (a wrong order is not an accuracy figure).

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import eigenvalue_errors
    >>> np.round(eigenvalue_errors([-1.1, -1 + 2.2j, -1 - 2.2j], [-1, -1 + 2j, -1 - 2j]), 3)
    array([0.1  , 0.089, 0.089])
    """
    est = np.asarray(estimated, dtype=complex).ravel()
    tru = np.asarray(true, dtype=complex).ravel()
    if est.size != tru.size:
        raise ValueError(
            f"estimated has {est.size} eigenvalues but true has {tru.size}: orders differ"
        )
    e, t = match_eigenvalues(est, tru)
    return np.abs(e - t) / np.abs(t)
