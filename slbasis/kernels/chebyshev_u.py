"""Generated kernel for Chebyshev U_n: chebyshev_u. DO NOT EDIT.

Regenerate with ``python -m slbasis.kernels``. Source: SturmLiouville(p0=1 - x**2, p1=-3*x, q0=0),
standardisation c_n = (-2)**n*(n + 1)*factorial(n)/factorial(2*n + 1). Functions frame phi_n = sqrt(w) p_n,
L^2-orthonormal on the interval; conventions in slbasis.numeric.kernel.
"""

import numpy

name = "chebyshev_u"
interval = (-1, 1)
p0 = (1.0, 0.0, -1.0)
PARAMETERS = ()
DEFAULTS = {}
SMALL_N = 4


def check_parameters():
    """Raise ValueError when the parameters leave the admissible range."""
    return None


def eigenvalues(N):
    """lambda_n of the polynomial problem, n = 0..N-1."""
    n = numpy.arange(N, dtype=float)
    return numpy.broadcast_to(n**2 + 2 * n, (N,)).astype(float)


def jacobi(N):
    """(B_n, A_{n+1}), n < N: x phi_n = A_{n+1} phi_{n+1} + B_n phi_n + A_n phi_{n-1}."""
    check_parameters()
    n = numpy.arange(N, dtype=float)
    with numpy.errstate(all="ignore"):
        diag = numpy.broadcast_to(0, (N,)).astype(float)
        a_sq = numpy.broadcast_to(1 / 4, (N,)).astype(float)
        c_ratio = numpy.broadcast_to(-(n + 2) / ((n + 1) * (2 * n + 3)), (N,)).astype(float)
    small_b = (
        0,
        0,
        0,
        0,
    )
    small_a = (
        1 / 4,
        1 / 4,
        1 / 4,
        1 / 4,
    )
    small_c = (
        -2 / 3,
        -3 / 10,
        -4 / 21,
        -5 / 36,
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
    sup = off * (lam[:-1] - lam[1:] - -2)
    sub = numpy.zeros(N)
    sub[1:] = off[:-1] * (lam[1:N] - lam[: N - 1] - -2)
    diag = -(-2 * diag_j + 0)
    return sub, diag, sup


def log_phi0(x):
    """(log|phi_0(x)|, sign phi_0(x)) with phi_0 = sqrt(w) c_0 / d_0."""
    x = numpy.asarray(x, dtype=float)
    with numpy.errstate(divide="ignore", invalid="ignore"):
        log_w = numpy.broadcast_to((1 / 2) * numpy.log(1 - x) + (1 / 2) * numpy.log(x + 1), x.shape)
    value = 0.5 * log_w - 0.5 * (-numpy.log(2) + numpy.log(numpy.pi))
    return value, numpy.full(x.shape, 1.0)
