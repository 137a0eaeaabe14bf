"""Generated closed forms for Chebyshev U_n: chebyshev_u. DO NOT EDIT.

Regenerate with ``python -m slbasis.kernels``.
Source: SturmLiouville(p0=1 - x**2, p1=-3*x, q0=0),
standardisation c_n = (-2)**n*(n + 1)*factorial(n)/factorial(2*n + 1). Functions n -> closed forms in n (arrays),
used by slbasis.numeric.closed_form_kernel.ClosedFormKernel (conventions there).
"""

import numpy
import scipy.special

name = "chebyshev_u"
interval = (-1, 1)
p0 = (1.0, 0.0, -1.0)
PARAMETERS = ()
DEFAULTS = {}
P0_SIGN = 1  # sign of p0 on the interval
SIGN_C0 = 1  # sign of the Rodrigues constant c_0


def check_parameters():
    """Raise ValueError when the parameters leave the admissible range.

    Returns
    -------
    None
        Nothing: the check raises or passes.
    """
    return None


def eigenvalue(n):
    """lambda_n of the polynomial problem.

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.

    Returns
    -------
    ndarray of float, shape n.shape
        lambda_n of the polynomial problem.
    """
    return numpy.broadcast_to(n**2 + 2 * n, n.shape).astype(float)


def jacobi_diag(n):
    """B_n (closed form).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.

    Returns
    -------
    ndarray of float, shape n.shape
        B_n (closed form).
    """
    return numpy.broadcast_to(0, n.shape).astype(float)


def jacobi_offdiag_squared(n):
    """A_{n+1}^2 (closed form).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.

    Returns
    -------
    ndarray of float, shape n.shape
        A_{n+1}^2 (closed form).
    """
    return numpy.broadcast_to(1 / 4, n.shape).astype(float)


def c_ratio(n):
    """c_{n+1}/c_n (its sign fixes the sign of A_{n+1}).

    Parameters
    ----------
    n : ndarray of int
        Degrees, ``n >= 0``.

    Returns
    -------
    ndarray of float, shape n.shape
        c_{n+1}/c_n (its sign fixes the sign of A_{n+1}).
    """
    return numpy.broadcast_to(-(n + 2) / ((n + 1) * (2 * n + 3)), n.shape).astype(float)


def small_values():
    """Exact (B_n, A_{n+1}^2, c_{n+1}/c_n) for n < len, from direct computation.

    Returns
    -------
    tuple of three tuples of float
        B_n, A_{n+1}^2 and c_{n+1}/c_n for n < 4.
    """
    return (0, 0, 0, 0), (1 / 4, 1 / 4, 1 / 4, 1 / 4), (-2 / 3, -3 / 10, -4 / 21, -5 / 36)


def log_weight(x):
    """log w(x) of the normal-form weight.

    Parameters
    ----------
    x : ndarray of float
        Points of the interval.

    Returns
    -------
    ndarray of float, shape x.shape
        log w(x) of the normal-form weight.
    """
    return numpy.broadcast_to(
        scipy.special.xlogy(1 / 2, 1 - x) + scipy.special.xlogy(1 / 2, x + 1), x.shape
    ).astype(float)


def log_mass():
    """log of d_0^2 / c_0^2 = ∫ w.

    Returns
    -------
    float
        The log of the weight's mass.
    """
    return -numpy.log(2) + numpy.log(numpy.pi)
