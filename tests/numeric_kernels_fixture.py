"""Hand-written kernels for four families (textbook closed forms), used by the numeric tests.

They stand in for the generated kernels until the code generator exists. Each one is
checked against scipy.special / mpmath in ``tests/slbasis/numeric/test_numeric_kernels.py``.

Conventions: ``phi_n = sqrt(w) p_n`` orthonormal in L^2(a, b) (see slbasis.numeric.kernel).

* Hermite functions ``h_n = H_n e^{-x^2/2} / sqrt(2^n n! sqrt(pi))`` (DLMF 18.9.1, 18.9.25):
  ``b_n = 0``, ``A_n = sqrt(n/2)``, ``2 h_n' = sqrt(2n) h_{n-1} - sqrt(2(n+1)) h_{n+1}``.
* Laguerre functions ``l_n = e^{-x/2} L_n`` on (0, inf) (DLMF 18.9.13, 18.9.23):
  ``x l_n = -(n+1) l_{n+1} + (2n+1) l_n - n l_{n-1}`` so ``b_n = 2n+1``, ``A_n = -n``;
  ``2x l_n' = -n l_{n-1} - l_n + (n+1) l_{n+1}``.
* Legendre ``sqrt((2n+1)/2) P_n`` on (-1, 1): ``b_n = 0``, ``A_n = n/sqrt((2n-1)(2n+1))``;
  ``2(1-x^2) p_n' = 2n(n+1)/sqrt((2n-1)(2n+1)) p_{n-1} - 2n(n+1)/sqrt((2n+1)(2n+3)) p_{n+1}``
  (DLMF 18.9.20; ``p1 - p0' = 0`` so there is no diagonal term).
* Chebyshev-T functions ``(1-x^2)^{-1/4} T_n / d_n`` on (-1, 1), ``d_0^2 = pi``,
  ``d_n^2 = pi/2`` (``w = (1-x^2)^{-1/2}``; note the exponent is -1/4, not +1/4, for
  L^2(dx) orthonormality): ``A_1 = 1/sqrt(2)``, ``A_n = 1/2`` (n >= 2);
  ``p0 phi' = sqrt(w) [(1-x^2) T_n' + x T_n / 2] / d_n`` and
  ``(1-x^2) T_n' = n (T_{n-1} - T_{n+1}) / 2``, ``x T_n = (T_{n+1} + T_{n-1}) / 2`` give
  ``2 p0 phi_n' = (n + 1/2) (d_{n-1}/d_n) phi_{n-1} + (1/2 - n) (d_{n+1}/d_n) phi_{n+1}``
  for n >= 1 and ``2 p0 phi_0' = (d_1/d_0) phi_1``.
"""

from __future__ import annotations

import numpy as np

from slbasis.numeric.kernel import KernelSpec


def _hermite_jacobi(N):
    n = np.arange(N, dtype=float)
    return np.zeros(N), np.sqrt((n + 1) / 2)


def _hermite_bands(N):
    n = np.arange(N, dtype=float)
    return np.sqrt(2 * n), np.zeros(N), -np.sqrt(2 * (n + 1))


def _hermite_log_phi0(x):
    x = np.asarray(x, dtype=float)
    return -0.5 * x * x - 0.25 * np.log(np.pi), np.ones_like(x)


HERMITE = KernelSpec(
    name="hermite_functions",
    interval=(-np.inf, np.inf),
    p0=(1.0, 0.0, 0.0),
    jacobi=_hermite_jacobi,
    log_phi0=_hermite_log_phi0,
    derivative_bands=_hermite_bands,
)


def _laguerre_jacobi(N):
    n = np.arange(N, dtype=float)
    return 2 * n + 1, -(n + 1)


def _laguerre_bands(N):
    n = np.arange(N, dtype=float)
    return -n, -np.ones(N), n + 1


def _laguerre_log_phi0(x):
    x = np.asarray(x, dtype=float)
    with np.errstate(invalid="ignore"):
        return np.where(x >= 0, -0.5 * x, -np.inf), np.ones_like(x)


LAGUERRE = KernelSpec(
    name="laguerre_functions",
    interval=(0.0, np.inf),
    p0=(0.0, 1.0, 0.0),
    jacobi=_laguerre_jacobi,
    log_phi0=_laguerre_log_phi0,
    derivative_bands=_laguerre_bands,
)


def _legendre_jacobi(N):
    n = np.arange(1, N + 1, dtype=float)
    return np.zeros(N), n / np.sqrt((2 * n - 1) * (2 * n + 1))


def _legendre_bands(N):
    n = np.arange(N, dtype=float)
    sub = 2 * n * (n + 1) / np.sqrt(np.maximum((2 * n - 1) * (2 * n + 1), 1.0))
    sup = -2 * n * (n + 1) / np.sqrt((2 * n + 1) * (2 * n + 3))
    return sub, np.zeros(N), sup


def _legendre_log_phi0(x):
    x = np.asarray(x, dtype=float)
    inside = np.abs(x) <= 1
    return np.where(inside, -0.5 * np.log(2.0), -np.inf), np.ones_like(x)


LEGENDRE = KernelSpec(
    name="legendre",
    interval=(-1.0, 1.0),
    p0=(1.0, 0.0, -1.0),
    jacobi=_legendre_jacobi,
    log_phi0=_legendre_log_phi0,
    derivative_bands=_legendre_bands,
)


def _cheb_d(n):
    n = np.asarray(n, dtype=float)
    return np.where(n == 0, np.sqrt(np.pi), np.sqrt(np.pi / 2))


def _cheb_jacobi(N):
    off = np.full(N, 0.5)
    off[0] = np.sqrt(0.5)
    return np.zeros(N), off


def _cheb_bands(N):
    n = np.arange(N, dtype=float)
    d = _cheb_d
    sub = (n + 0.5) * d(np.maximum(n - 1, 0)) / d(n)
    sup = (0.5 - n) * d(n + 1) / d(n)
    sup[0] = d(1) / d(0)
    sub[0] = 0.0
    return sub, np.zeros(N), sup


def _cheb_log_phi0(x):
    x = np.asarray(x, dtype=float)
    inside = np.abs(x) < 1
    with np.errstate(divide="ignore", invalid="ignore"):
        v = -0.25 * (np.log1p(-x) + np.log1p(x)) - 0.5 * np.log(np.pi)
    return np.where(inside, v, np.where(np.abs(x) == 1, np.inf, -np.inf)), np.ones_like(x)


CHEBYSHEV_T = KernelSpec(
    name="chebyshev_t_functions",
    interval=(-1.0, 1.0),
    p0=(1.0, 0.0, -1.0),
    jacobi=_cheb_jacobi,
    log_phi0=_cheb_log_phi0,
    derivative_bands=_cheb_bands,
)

ALL = {k.name: k for k in (HERMITE, LAGUERRE, LEGENDRE, CHEBYSHEV_T)}
