"""Generated kernel for Hermite H_n: hermite. DO NOT EDIT.

Regenerate with ``python -m slbasis.kernels``. Source: SturmLiouville(p0=1, p1=-2*x, q0=0),
standardisation c_n = (-1)**n. Functions frame phi_n = sqrt(w) p_n,
L^2-orthonormal on the interval; conventions in slbasis.numeric.kernel.
"""

import math

import numpy

name = "hermite"
interval = (-math.inf, math.inf)
p0 = (1.0, 0.0, 0.0)
PARAMETERS = ()
DEFAULTS = {}
SMALL_N = 4


def check_parameters():
    """Raise ValueError when the parameters leave the admissible range."""
    return None


def eigenvalues(N):
    """lambda_n of the polynomial problem, n = 0..N-1."""
    n = numpy.arange(N, dtype=float)
    return numpy.broadcast_to(2 * n, (N,)).astype(float)


def jacobi(N):
    """(B_n, A_{n+1}), n < N: x phi_n = A_{n+1} phi_{n+1} + B_n phi_n + A_n phi_{n-1}."""
    check_parameters()
    n = numpy.arange(N, dtype=float)
    with numpy.errstate(all="ignore"):
        diag = numpy.broadcast_to(0, (N,)).astype(float)
        a_sq = numpy.broadcast_to((1 / 2) * n + 1 / 2, (N,)).astype(float)
        c_ratio = numpy.broadcast_to(-1, (N,)).astype(float)
    small_b = (
        0,
        0,
        0,
        0,
    )
    small_a = (
        1 / 2,
        1,
        3 / 2,
        2,
    )
    small_c = (
        -1,
        -1,
        -1,
        -1,
    )
    for k in range(min(N, SMALL_N)):
        diag[k], a_sq[k], c_ratio[k] = small_b[k], small_a[k], small_c[k]
    offdiag = -1 * numpy.sign(c_ratio) * numpy.sqrt(a_sq)
    return diag, offdiag


def derivative_bands(N):
    """(sub, diag, sup) of 2 p0 d/dx phi_n = sub phi_{n-1} + diag phi_n + sup phi_{n+1}.

    Commutator form (J Lambda - Lambda J) - p0'(J), exact for the infinite operator.
    """
    diag_j, off = jacobi(N)
    lam = eigenvalues(N + 1)
    sup = off * (lam[:-1] - lam[1:] - 0)
    sub = numpy.zeros(N)
    sub[1:] = off[:-1] * (lam[1:N] - lam[: N - 1] - 0)
    diag = -(0 * diag_j + 0)
    return sub, diag, sup


def log_phi0(x):
    """(log|phi_0(x)|, sign phi_0(x)) with phi_0 = sqrt(w) c_0 / d_0."""
    x = numpy.asarray(x, dtype=float)
    with numpy.errstate(divide="ignore", invalid="ignore"):
        log_w = numpy.broadcast_to(-(x**2), x.shape)
    value = 0.5 * log_w - 0.5 * ((1 / 2) * numpy.log(numpy.pi))
    return value, numpy.full(x.shape, 1.0)
