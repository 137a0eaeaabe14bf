"""Generated kernel for Jacobi P_n^(alpha,beta): jacobi. DO NOT EDIT.

Regenerate with ``python -m slbasis.kernels``. Source: SturmLiouville(p0=1 - x**2, p1=-alpha*x - alpha - beta*x + beta - 2*x, q0=0),
standardisation c_n = (-1)**n/(2**n*factorial(n)). Functions frame phi_n = sqrt(w) p_n,
L^2-orthonormal on the interval; conventions in slbasis.numeric.kernel.
"""

import math

import numpy

name = "jacobi"
interval = (-1, 1)
p0 = (1.0, 0.0, -1.0)
PARAMETERS = ("alpha", "beta")
DEFAULTS = {"alpha": 0, "beta": 0}
SMALL_N = 4


def check_parameters(alpha, beta):
    """Raise ValueError when the parameters leave the admissible range."""
    if not (beta + 1) > 0:
        raise ValueError("jacobi: parameters must satisfy beta + 1 > 0")
    if not (alpha + 1) > 0:
        raise ValueError("jacobi: parameters must satisfy alpha + 1 > 0")
    return None


def eigenvalues(N, alpha, beta):
    """lambda_n of the polynomial problem, n = 0..N-1."""
    n = numpy.arange(N, dtype=float)
    return numpy.broadcast_to(alpha * n + beta * n + n**2 + n, (N,)).astype(float)


def jacobi(N, alpha, beta):
    """(B_n, A_{n+1}), n < N: x phi_n = A_{n+1} phi_{n+1} + B_n phi_n + A_n phi_{n-1}."""
    check_parameters(alpha=alpha, beta=beta)
    n = numpy.arange(N, dtype=float)
    with numpy.errstate(all="ignore"):
        diag = numpy.broadcast_to(
            -(alpha - beta)
            * (alpha + beta)
            / ((alpha + beta + 2 * n) * (alpha + beta + 2 * n + 2)),
            (N,),
        ).astype(float)
        a_sq = numpy.broadcast_to(
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
            (N,),
        ).astype(float)
        c_ratio = numpy.broadcast_to(-(1 / 2) / (n + 1), (N,)).astype(float)
    small_b = (
        -(alpha - beta) / (alpha + beta + 2),
        -(alpha - beta) * (alpha + beta) / ((alpha + beta + 2) * (alpha + beta + 4)),
        -(alpha - beta) * (alpha + beta) / ((alpha + beta + 4) * (alpha + beta + 6)),
        -(alpha - beta) * (alpha + beta) / ((alpha + beta + 6) * (alpha + beta + 8)),
    )
    small_a = (
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
    )
    small_c = (
        -1 / 2,
        -1 / 4,
        -1 / 6,
        -1 / 8,
    )
    for k in range(min(N, SMALL_N)):
        diag[k], a_sq[k], c_ratio[k] = small_b[k], small_a[k], small_c[k]
    offdiag = -1 * numpy.sign(c_ratio) * numpy.sqrt(a_sq)
    return diag, offdiag


def derivative_bands(N, alpha, beta):
    """(sub, diag, sup) of 2 p0 d/dx phi_n = sub phi_{n-1} + diag phi_n + sup phi_{n+1}.

    Commutator form (J Lambda - Lambda J) - p0'(J), exact for the infinite operator.
    """
    diag_j, off = jacobi(N, alpha=alpha, beta=beta)
    lam = eigenvalues(N + 1, alpha=alpha, beta=beta)
    sup = off * (lam[:-1] - lam[1:] - -2)
    sub = numpy.zeros(N)
    sub[1:] = off[:-1] * (lam[1:N] - lam[: N - 1] - -2)
    diag = -(-2 * diag_j + 0)
    return sub, diag, sup


def log_phi0(x, alpha, beta):
    """(log|phi_0(x)|, sign phi_0(x)) with phi_0 = sqrt(w) c_0 / d_0."""
    x = numpy.asarray(x, dtype=float)
    with numpy.errstate(divide="ignore", invalid="ignore"):
        log_w = numpy.broadcast_to(alpha * numpy.log(1 - x) + beta * numpy.log(x + 1), x.shape)
    value = 0.5 * log_w - 0.5 * (
        (alpha + beta + 1) * numpy.log(2)
        + math.lgamma(alpha + 1)
        + math.lgamma(beta + 1)
        - math.lgamma(alpha + beta + 2)
    )
    return value, numpy.full(x.shape, 1.0)
