"""Generated kernel for Laguerre L_n^(alpha): laguerre. DO NOT EDIT.

Regenerate with ``python -m slbasis.kernels``. Source: SturmLiouville(p0=x, p1=alpha - x + 1, q0=0),
standardisation c_n = 1/factorial(n). Functions frame phi_n = sqrt(w) p_n,
L^2-orthonormal on the interval; conventions in slbasis.numeric.kernel.
"""

import math

import numpy

name = "laguerre"
interval = (0, math.inf)
p0 = (0.0, 1.0, 0.0)
PARAMETERS = ("alpha",)
DEFAULTS = {"alpha": 0}
SMALL_N = 4


def check_parameters(alpha):
    """Raise ValueError when the parameters leave the admissible range."""
    if not (alpha + 1) > 0:
        raise ValueError("laguerre: parameters must satisfy alpha + 1 > 0")
    return None


def eigenvalues(N, alpha):
    """lambda_n of the polynomial problem, n = 0..N-1."""
    n = numpy.arange(N, dtype=float)
    return numpy.broadcast_to(n, (N,)).astype(float)


def jacobi(N, alpha):
    """(B_n, A_{n+1}), n < N: x phi_n = A_{n+1} phi_{n+1} + B_n phi_n + A_n phi_{n-1}."""
    check_parameters(alpha=alpha)
    n = numpy.arange(N, dtype=float)
    with numpy.errstate(all="ignore"):
        diag = numpy.broadcast_to(alpha + 2 * n + 1, (N,)).astype(float)
        a_sq = numpy.broadcast_to((n + 1) * (alpha + n + 1), (N,)).astype(float)
        c_ratio = numpy.broadcast_to((n + 1) ** (-1.0), (N,)).astype(float)
    small_b = (
        alpha + 1,
        alpha + 3,
        alpha + 5,
        alpha + 7,
    )
    small_a = (
        alpha + 1,
        2 * alpha + 4,
        3 * alpha + 9,
        4 * alpha + 16,
    )
    small_c = (
        1,
        1 / 2,
        1 / 3,
        1 / 4,
    )
    for k in range(min(N, SMALL_N)):
        diag[k], a_sq[k], c_ratio[k] = small_b[k], small_a[k], small_c[k]
    offdiag = -1 * numpy.sign(c_ratio) * numpy.sqrt(a_sq)
    return diag, offdiag


def derivative_bands(N, alpha):
    """(sub, diag, sup) of 2 p0 d/dx phi_n = sub phi_{n-1} + diag phi_n + sup phi_{n+1}.

    Commutator form (J Lambda - Lambda J) - p0'(J), exact for the infinite operator.
    """
    diag_j, off = jacobi(N, alpha=alpha)
    lam = eigenvalues(N + 1, alpha=alpha)
    sup = off * (lam[:-1] - lam[1:] - 0)
    sub = numpy.zeros(N)
    sub[1:] = off[:-1] * (lam[1:N] - lam[: N - 1] - 0)
    diag = -(0 * diag_j + 1)
    return sub, diag, sup


def log_phi0(x, alpha):
    """(log|phi_0(x)|, sign phi_0(x)) with phi_0 = sqrt(w) c_0 / d_0."""
    x = numpy.asarray(x, dtype=float)
    with numpy.errstate(divide="ignore", invalid="ignore"):
        log_w = numpy.broadcast_to(alpha * numpy.log(x) - x, x.shape)
    value = 0.5 * log_w - 0.5 * (math.lgamma(alpha + 1))
    return value, numpy.full(x.shape, 1.0)
