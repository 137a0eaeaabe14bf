"""Generated closed forms for Jacobi P_n^(alpha,beta): jacobi. DO NOT EDIT.

Regenerate with ``python -m slbasis.kernels``.
Source: SturmLiouville(p0=1 - x**2, p1=-alpha*x - alpha - beta*x + beta - 2*x, q0=0),
standardisation c_n = (-1)**n/(2**n*factorial(n)). Functions n -> closed forms in n (arrays),
used by slbasis.numeric.closed_form_kernel.ClosedFormKernel (conventions there).
"""

import math

import numpy
import scipy.special

name = "jacobi"
interval = (-1, 1)
p0 = (1.0, 0.0, -1.0)
PARAMETERS = ("alpha", "beta")
DEFAULTS = {"alpha": 0, "beta": 0}
P0_SIGN = 1  # sign of p0 on the interval
SIGN_C0 = 1  # sign of the Rodrigues constant c_0


def check_parameters(alpha, beta):
    """Raise ValueError when the parameters leave the admissible range.

    Parameters
    ----------
    alpha : float
        The family's parameter ``alpha``.
    beta : float
        The family's parameter ``beta``.

    Returns
    -------
    None
        Nothing: the check raises or passes.

    Raises
    ------
    ValueError
        If the parameters violate ``beta + 1 > 0``, ``alpha + 1 > 0``.
    """
    if not (beta + 1) > 0:
        raise ValueError("jacobi: parameters must satisfy beta + 1 > 0")
    if not (alpha + 1) > 0:
        raise ValueError("jacobi: parameters must satisfy alpha + 1 > 0")
    return None


def eigenvalue(n, alpha, beta):
    """lambda_n of the polynomial problem.

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    alpha : float
        The family's parameter ``alpha``.
    beta : float
        The family's parameter ``beta``.

    Returns
    -------
    ndarray of float, shape n.shape
        lambda_n of the polynomial problem.
    """
    return numpy.broadcast_to(alpha * n + beta * n + n**2 + n, n.shape).astype(float)


def jacobi_diag(n, alpha, beta):
    """B_n (closed form).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    alpha : float
        The family's parameter ``alpha``.
    beta : float
        The family's parameter ``beta``.

    Returns
    -------
    ndarray of float, shape n.shape
        B_n (closed form).
    """
    return numpy.broadcast_to(
        -(alpha - beta) * (alpha + beta) / ((alpha + beta + 2 * n) * (alpha + beta + 2 * n + 2)),
        n.shape,
    ).astype(float)


def jacobi_offdiag_squared(n, alpha, beta):
    """A_{n+1}^2 (closed form).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    alpha : float
        The family's parameter ``alpha``.
    beta : float
        The family's parameter ``beta``.

    Returns
    -------
    ndarray of float, shape n.shape
        A_{n+1}^2 (closed form).
    """
    return numpy.broadcast_to(
        4
        * (n + 1)
        * (alpha + n + 1)
        * (beta + n + 1)
        * (alpha + beta + n + 1)
        / (
            (alpha + beta + 2 * n + 1)
            * (alpha + beta + 2 * n + 2) ** 2
            * (alpha + beta + 2 * n + 3)
        ),
        n.shape,
    ).astype(float)


def c_ratio(n, alpha, beta):
    """c_{n+1}/c_n (its sign fixes the sign of A_{n+1}).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    alpha : float
        The family's parameter ``alpha``.
    beta : float
        The family's parameter ``beta``.

    Returns
    -------
    ndarray of float, shape n.shape
        c_{n+1}/c_n (its sign fixes the sign of A_{n+1}).
    """
    return numpy.broadcast_to(-(1 / 2) / (n + 1), n.shape).astype(float)


def small_values(alpha, beta):
    """Exact (B_n, A_{n+1}^2, c_{n+1}/c_n) for n < len, from direct computation.

    Parameters
    ----------
    alpha : float
        The family's parameter ``alpha``.
    beta : float
        The family's parameter ``beta``.

    Returns
    -------
    tuple of three tuples of float
        B_n, A_{n+1}^2 and c_{n+1}/c_n for n < 4.
    """
    return (
        (
            -(alpha - beta) / (alpha + beta + 2),
            -(alpha - beta) * (alpha + beta) / ((alpha + beta + 2) * (alpha + beta + 4)),
            -(alpha - beta) * (alpha + beta) / ((alpha + beta + 4) * (alpha + beta + 6)),
            -(alpha - beta) * (alpha + beta) / ((alpha + beta + 6) * (alpha + beta + 8)),
        ),
        (
            4 * (alpha + 1) * (beta + 1) / ((alpha + beta + 2) ** 2 * (alpha + beta + 3)),
            8
            * (alpha + 2)
            * (beta + 2)
            * (alpha + beta + 2)
            / ((alpha + beta + 3) * (alpha + beta + 4) ** 2 * (alpha + beta + 5)),
            12
            * (alpha + 3)
            * (beta + 3)
            * (alpha + beta + 3)
            / ((alpha + beta + 5) * (alpha + beta + 6) ** 2 * (alpha + beta + 7)),
            16
            * (alpha + 4)
            * (beta + 4)
            * (alpha + beta + 4)
            / ((alpha + beta + 7) * (alpha + beta + 8) ** 2 * (alpha + beta + 9)),
        ),
        (-1 / 2, -1 / 4, -1 / 6, -1 / 8),
    )


def log_weight(x, alpha, beta):
    """log w(x) of the normal-form weight.

    Parameters
    ----------
    x : ndarray of float
        Points of the interval.
    alpha : float
        The family's parameter ``alpha``.
    beta : float
        The family's parameter ``beta``.

    Returns
    -------
    ndarray of float, shape x.shape
        log w(x) of the normal-form weight.
    """
    return numpy.broadcast_to(
        scipy.special.xlogy(alpha, 1 - x) + scipy.special.xlogy(beta, x + 1), x.shape
    ).astype(float)


def log_mass(alpha, beta):
    """log of d_0^2 / c_0^2 = ∫ w.

    Parameters
    ----------
    alpha : float
        The family's parameter ``alpha``.
    beta : float
        The family's parameter ``beta``.

    Returns
    -------
    float
        The log of the weight's mass.
    """
    return (
        alpha * numpy.log(2)
        + beta * numpy.log(2)
        + math.lgamma(alpha + 1)
        + math.lgamma(beta + 1)
        - math.lgamma(alpha + beta + 2)
        + numpy.log(2)
    )
