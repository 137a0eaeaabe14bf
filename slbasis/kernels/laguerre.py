"""Generated closed forms for Laguerre L_n^(alpha): laguerre. DO NOT EDIT.

Regenerate with ``python -m slbasis.kernels``.
Source: SturmLiouville(p0=x, p1=alpha - x + 1, q0=0),
standardisation c_n = 1/factorial(n). Functions n -> closed forms in n (arrays),
used by slbasis.numeric.closed_form_kernel.ClosedFormKernel (conventions there).
"""

import math

import numpy
import scipy.special

name = "laguerre"
interval = (0, math.inf)
p0 = (0.0, 1.0, 0.0)
PARAMETERS = ("alpha",)
DEFAULTS = {"alpha": 0}
P0_SIGN = 1  # sign of p0 on the interval
SIGN_C0 = 1  # sign of the Rodrigues constant c_0


def check_parameters(alpha):
    """Raise ValueError when the parameters leave the admissible range.

    Parameters
    ----------
    alpha : float
        The family's parameter ``alpha``.

    Returns
    -------
    None
        Nothing: the check raises or passes.

    Raises
    ------
    ValueError
        If the parameters violate ``alpha + 1 > 0``.
    """
    if not (alpha + 1) > 0:
        raise ValueError("laguerre: parameters must satisfy alpha + 1 > 0")
    return None


def eigenvalue(n, alpha):
    """lambda_n of the polynomial problem.

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    alpha : float
        The family's parameter ``alpha``.

    Returns
    -------
    ndarray of float, shape n.shape
        lambda_n of the polynomial problem.
    """
    return numpy.broadcast_to(n, n.shape).astype(float)


def jacobi_diag(n, alpha):
    """B_n (closed form).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    alpha : float
        The family's parameter ``alpha``.

    Returns
    -------
    ndarray of float, shape n.shape
        B_n (closed form).
    """
    return numpy.broadcast_to(alpha + 2 * n + 1, n.shape).astype(float)


def jacobi_offdiag_squared(n, alpha):
    """A_{n+1}^2 (closed form).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    alpha : float
        The family's parameter ``alpha``.

    Returns
    -------
    ndarray of float, shape n.shape
        A_{n+1}^2 (closed form).
    """
    return numpy.broadcast_to((n + 1) * (alpha + n + 1), n.shape).astype(float)


def c_ratio(n, alpha):
    """c_{n+1}/c_n (its sign fixes the sign of A_{n+1}).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    alpha : float
        The family's parameter ``alpha``.

    Returns
    -------
    ndarray of float, shape n.shape
        c_{n+1}/c_n (its sign fixes the sign of A_{n+1}).
    """
    return numpy.broadcast_to((n + 1) ** (-1.0), n.shape).astype(float)


def small_values(alpha):
    """Exact (B_n, A_{n+1}^2, c_{n+1}/c_n) for n < len, from direct computation.

    Parameters
    ----------
    alpha : float
        The family's parameter ``alpha``.

    Returns
    -------
    tuple of three tuples of float
        B_n, A_{n+1}^2 and c_{n+1}/c_n for n < 4.
    """
    return (
        (alpha + 1, alpha + 3, alpha + 5, alpha + 7),
        (alpha + 1, 2 * alpha + 4, 3 * alpha + 9, 4 * alpha + 16),
        (1, 1 / 2, 1 / 3, 1 / 4),
    )


def log_weight(x, alpha):
    """log w(x) of the normal-form weight.

    Parameters
    ----------
    x : ndarray of float
        Points of the interval.
    alpha : float
        The family's parameter ``alpha``.

    Returns
    -------
    ndarray of float, shape x.shape
        log w(x) of the normal-form weight.
    """
    return numpy.broadcast_to(-x + scipy.special.xlogy(alpha, x), x.shape).astype(float)


def log_mass(alpha):
    """log of d_0^2 / c_0^2 = ∫ w.

    Parameters
    ----------
    alpha : float
        The family's parameter ``alpha``.

    Returns
    -------
    float
        The log of the weight's mass.
    """
    return math.lgamma(alpha + 1)
