"""Generated closed forms for Gegenbauer C_n^(lam): gegenbauer. DO NOT EDIT.

Regenerate with ``python -m slbasis.kernels``.
Source: SturmLiouville(p0=1 - x**2, p1=-2*lam*x - x, q0=0),
standardisation c_n = (-1)**n*gamma(lam + 1/2)*gamma(2*lam + n)/(2**n*factorial(n)*gamma(2*lam)*gamma(lam + n + 1/2)). Functions n -> closed forms in n (arrays),
used by slbasis.numeric.closed_form_kernel.ClosedFormKernel (conventions there).
"""

import math

import numpy
import scipy.special

name = "gegenbauer"
interval = (-1, 1)
p0 = (1.0, 0.0, -1.0)
PARAMETERS = ("lam",)
DEFAULTS = {"lam": 1}
P0_SIGN = 1  # sign of p0 on the interval
SIGN_C0 = 1  # sign of the Rodrigues constant c_0


def check_parameters(lam):
    """Raise ValueError when the parameters leave the admissible range.

    Parameters
    ----------
    lam : float
        The family's parameter ``lam``.

    Returns
    -------
    None
        Nothing: the check raises or passes.

    Raises
    ------
    ValueError
        If the parameters violate ``lam + 1/2 > 0``.
    """
    if not (lam + 1 / 2) > 0:
        raise ValueError("gegenbauer: parameters must satisfy lam + 1/2 > 0")
    return None


def eigenvalue(n, lam):
    """lambda_n of the polynomial problem.

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    lam : float
        The family's parameter ``lam``.

    Returns
    -------
    ndarray of float, shape n.shape
        lambda_n of the polynomial problem.
    """
    return numpy.broadcast_to(2 * lam * n + n**2, n.shape).astype(float)


def jacobi_diag(n, lam):
    """B_n (closed form).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    lam : float
        The family's parameter ``lam``.

    Returns
    -------
    ndarray of float, shape n.shape
        B_n (closed form).
    """
    return numpy.broadcast_to(0, n.shape).astype(float)


def jacobi_offdiag_squared(n, lam):
    """A_{n+1}^2 (closed form).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    lam : float
        The family's parameter ``lam``.

    Returns
    -------
    ndarray of float, shape n.shape
        A_{n+1}^2 (closed form).
    """
    return numpy.broadcast_to(
        (1 / 4) * (2 * lam + n) * (n + 1) / ((lam + n) * (lam + n + 1)), n.shape
    ).astype(float)


def c_ratio(n, lam):
    """c_{n+1}/c_n (its sign fixes the sign of A_{n+1}).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.
    lam : float
        The family's parameter ``lam``.

    Returns
    -------
    ndarray of float, shape n.shape
        c_{n+1}/c_n (its sign fixes the sign of A_{n+1}).
    """
    return numpy.broadcast_to(-(2 * lam + n) / ((n + 1) * (2 * lam + 2 * n + 1)), n.shape).astype(
        float
    )


def small_values(lam):
    """Exact (B_n, A_{n+1}^2, c_{n+1}/c_n) for n < len, from direct computation.

    Parameters
    ----------
    lam : float
        The family's parameter ``lam``.

    Returns
    -------
    tuple of three tuples of float
        B_n, A_{n+1}^2 and c_{n+1}/c_n for n < 4.
    """
    return (
        (0, 0, 0, 0),
        (
            (1 / 2) / (lam + 1),
            (1 / 2) * (2 * lam + 1) / ((lam + 1) * (lam + 2)),
            (3 / 2) * (lam + 1) / ((lam + 2) * (lam + 3)),
            (2 * lam + 3) / ((lam + 3) * (lam + 4)),
        ),
        (
            -2 * lam / (2 * lam + 1),
            -1 / 2 * (2 * lam + 1) / (2 * lam + 3),
            -2 / 3 * (lam + 1) / (2 * lam + 5),
            -1 / 4 * (2 * lam + 3) / (2 * lam + 7),
        ),
    )


def log_weight(x, lam):
    """log w(x) of the normal-form weight.

    Parameters
    ----------
    x : ndarray of float
        Points of the interval.
    lam : float
        The family's parameter ``lam``.

    Returns
    -------
    ndarray of float, shape x.shape
        log w(x) of the normal-form weight.
    """
    return numpy.broadcast_to(
        scipy.special.xlogy(-1 / 2, 1 - x)
        + scipy.special.xlogy(-1 / 2, x + 1)
        + scipy.special.xlogy(lam, 1 - x)
        + scipy.special.xlogy(lam, x + 1),
        x.shape,
    ).astype(float)


def log_mass(lam):
    """log of d_0^2 / c_0^2 = ∫ w.

    Parameters
    ----------
    lam : float
        The family's parameter ``lam``.

    Returns
    -------
    float
        The log of the weight's mass.
    """
    return 2 * lam * numpy.log(2) + 2 * math.lgamma(lam + 1 / 2) - math.lgamma(2 * lam + 1)
