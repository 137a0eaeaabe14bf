"""Operator matrices in the basis: multiplication by ``x``, ``2 p0 d/dx`` and ``d/dx``.

Convention: a function ``f = sum_n c_n phi_n`` is its coefficient column ``c``; an
operator ``L`` is the matrix with ``(L phi_n) = sum_m M[m, n] phi_m``, so ``L f`` has
coefficients ``M @ c``. Column ``n`` is the image of ``phi_n``.

Truncation is explicit: the image of
``phi_0..phi_{N-1}`` under a tridiagonal operator lives in ``phi_0..phi_N``, so the exact
matrix is rectangular ``(N+1) x N``. The square ``N x N`` cut has exact entries but drops
row ``N``; used as an operator on a series that is *not* band-limited to ``N`` terms it is
also wrong in its last row, by the coupling to the discarded ``c_N`` (Hermite functions:
``sqrt(N/2) |c_N|`` for ``d/dx``).

* :func:`multiplication_matrix` -- the Jacobi matrix ``x phi_n = A_n phi_{n-1} + b_n phi_n
  + A_{n+1} phi_{n+1}`` (exact, tridiagonal, sparse).
* :func:`derivative_operator` -- ``2 p0(x) d/dx`` from ``kernel.derivative_bands`` (exact,
  tridiagonal, sparse; eq. 11).
* :func:`derivative_matrix` -- ``d/dx`` itself. For constant ``p0 = c0`` it is
  ``derivative_operator / (2 c0)``: exact, sparse, ``q = 1`` extra row. Otherwise it is in
  general dense (Laguerre functions: ``l_n' = -l_n/2 - sum_{k<n} l_k``; Legendre:
  ``p_n' = sum_{k<n, n-k odd} sqrt((2n+1)(2k+1)) p_k``) and is obtained by solving
  ``p0(J) G = (2 p0 d/dx) / 2`` with the *exact* ``M x M`` section of the pentadiagonal
  ``p0(J)`` (``(J^2)_M`` taken from ``J_{M+1}``, not ``(J_M)^2``), ``M = N + pad``.
  This is exact (up to rounding, amplified by ``cond p0(J_M)``) whenever the true
  ``phi_n'`` lie in ``span{phi_0..phi_{M-1}}`` -- true for every polynomial family with
  ``p1 - p0'`` divisible by ``p0`` (Laguerre, Legendre, Jacobi with integer exponents).
  When ``phi_n'`` is not in L^2 (e.g. Chebyshev-T functions ``(1-x^2)^{-1/4} T_n``), the
  result depends on ``M``; we solve twice (``M`` and ``M + pad``), and a
  ``RuntimeWarning`` reports the difference if it is not at rounding level.
* :func:`integration_matrix` -- ``int_{x0}^x`` for Legendre functions (constant weight on
  a finite interval; :func:`is_legendre` recognises them from the recurrence). Exact,
  ``(N+1) x N``, tridiagonal plus the row of ``phi_0`` (only ``[0, 0]`` when ``x0`` is an
  end of the interval): ``int P_n = (P_{n+1} - P_{n-1}) / (2n + 1)``.
"""

from __future__ import annotations

import warnings

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from slbasis.runtime import user_stacklevel

from .evaluate import evaluate
from .kernel import Kernel
from .validate import as_int_at_least

__all__ = [
    "multiplication_matrix",
    "derivative_operator",
    "derivative_matrix",
    "extra_rows",
    "is_legendre",
    "integration_matrix",
]

#: relative tolerance of :func:`is_legendre` on the recurrence coefficients: a closed-form
#: kernel computes them with a few roundings (measured <= 1.01 eps for the catalogue
#: Legendre, Jacobi(0, 0) and a generated Legendre problem); any other weight differs by
#: a relative amount of order 1/n at small n, far above this
LEGENDRE_RTOL = 1e-13

_SHAPES = ("square", "rectangular")


def _check_shape(shape: str) -> None:
    if shape not in _SHAPES:
        raise ValueError(f"shape: expected 'square' or 'rectangular', got {shape!r}")


def _tridiag(n_cols: int, n_rows: int, sub, dia, sup) -> sp.csr_matrix:
    """Matrix with column n = sub[n] e_{n-1} + dia[n] e_n + sup[n] e_{n+1}, cut to n_rows."""
    n = np.arange(n_cols)
    rows = np.concatenate((n[1:] - 1, n, n + 1))
    cols = np.concatenate((n[1:], n, n))
    vals = np.concatenate((np.asarray(sub)[1:], dia, sup))
    keep = rows < n_rows
    return sp.csr_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n_rows, n_cols))


def multiplication_matrix(kernel: Kernel, N: int, shape: str = "square") -> sp.csr_matrix:
    """The Jacobi matrix of multiplication by ``x``: ``N x N`` or exact ``(N+1) x N``.

    ``x phi_n = A_n phi_{n-1} + b_n phi_n + A_{n+1} phi_{n+1}`` (the three-term recurrence),
    so the matrix is exact and tridiagonal.

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions, ``>= 1``.
    shape : {"square", "rectangular"}, optional
        The ``N x N`` cut or the exact ``(N+1) x N`` matrix.

    Returns
    -------
    scipy.sparse.csr_matrix
        The matrix (column ``n`` is the image of ``phi_n``).

    Raises
    ------
    ValueError
        If ``N`` or ``shape`` is invalid.

    Examples
    --------
    >>> import slbasis
    >>> multiplication_matrix(slbasis.kernel("legendre"), 3).toarray().round(4)
    array([[0.    , 0.5774, 0.    ],
           [0.5774, 0.    , 0.5164],
           [0.    , 0.5164, 0.    ]])
    """
    N = as_int_at_least(N, "N")
    _check_shape(shape)
    diag, off = (np.asarray(v, dtype=float) for v in kernel.jacobi(N))
    sub = np.concatenate(([0.0], off[:-1]))  # A_n on phi_{n-1}
    return _tridiag(N, N + (shape == "rectangular"), sub, diag, off)


def derivative_operator(kernel: Kernel, N: int, shape: str = "rectangular") -> sp.csr_matrix:
    """``2 p0(x) d/dx``: the exact ``(N+1) x N`` matrix (or its ``N x N`` cut).

    From ``kernel.derivative_bands`` (eq. 11): exact and tridiagonal for every
    Sturm-Liouville family of the catalogue.

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions, ``>= 1``.
    shape : {"square", "rectangular"}, optional
        The ``N x N`` cut or the exact ``(N+1) x N`` matrix.

    Returns
    -------
    scipy.sparse.csr_matrix
        The matrix.

    Raises
    ------
    ValueError
        If ``N`` or ``shape`` is invalid.
    """
    N = as_int_at_least(N, "N")
    _check_shape(shape)
    sub, dia, sup = (np.asarray(v, dtype=float) for v in kernel.derivative_bands(N))
    return _tridiag(N, N + (shape == "rectangular"), sub, dia, sup)


def _p0_section(kernel: Kernel, M: int) -> np.ndarray:
    """Banded storage (2 sub, 2 super) of the exact M x M section of p0(J)."""
    c0, c1, c2 = (float(c) for c in kernel.p0)
    # J is tridiagonal, so J^2 is pentadiagonal: sparse products keep this O(M)
    J = sp.csr_matrix(multiplication_matrix(kernel, M + 1, "square"))
    P = c0 * sp.identity(M, format="csr") + c1 * J[:M, :M] + c2 * (J[:M, :] @ J[:, :M])
    P = sp.dia_matrix(P)
    ab = np.zeros((5, M))
    for k in range(-2, 3):
        d = P.diagonal(k)
        if k >= 0:
            ab[2 - k, k:] = d
        else:
            ab[2 - k, : M + k] = d
    return ab


def _solve_derivative(kernel: Kernel, N: int, M: int) -> np.ndarray:
    D2 = derivative_operator(kernel, N, "rectangular").toarray()
    rhs = np.zeros((M, N))
    rhs[: N + 1] = 0.5 * D2[: min(N + 1, M)]
    return sla.solve_banded((2, 2), _p0_section(kernel, M), rhs)


def extra_rows(kernel: Kernel) -> int | None:
    """``q``: rows beyond ``N`` in the exact image of the first ``N`` functions under ``d/dx``.

    Parameters
    ----------
    kernel : Kernel
        The family.

    Returns
    -------
    int or None
        1 for constant ``p0`` (tridiagonal ``d/dx``); None (decided numerically by
        :func:`derivative_matrix`) otherwise.

    Examples
    --------
    >>> import slbasis
    >>> extra_rows(slbasis.kernel("hermite_functions")), extra_rows(slbasis.kernel("legendre"))
    (1, None)
    """
    c0, c1, c2 = (float(c) for c in kernel.p0)
    return 1 if (c1 == 0 and c2 == 0) else None


def derivative_matrix(
    kernel: Kernel, N: int, shape: str = "rectangular", *, pad: int = 32
) -> sp.csr_matrix | np.ndarray:
    """``d/dx`` on the first ``N`` functions (see the module docstring for what is exact).

    For constant ``p0`` it is ``2 p0 d/dx`` over ``2 c0``: exact, sparse, one extra row.
    Otherwise it solves ``p0(J) G = (2 p0 d/dx) / 2`` with the exact section of ``p0(J)``,
    which is exact up to rounding, amplified by ``cond p0(J_M)``, whenever the derivatives
    lie in the span; solved at two truncations, a ``RuntimeWarning`` reports a difference
    above rounding level (derivatives not in ``L^2``).

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions, ``>= 1``.
    shape : {"rectangular", "square"}, optional
        ``"rectangular"``: all rows with a non-zero coefficient of the image (``(N+1) x N``
        for constant ``p0``; ``N x N`` when the images stay in the span, as for Laguerre and
        Legendre; otherwise the rows up to ``N + 2 pad`` above the rounding noise);
        ``"square"``: the ``N x N`` cut.
    pad : int, optional
        Extra rows of the section of ``p0(J)``, ``>= 2``.

    Returns
    -------
    scipy.sparse.csr_matrix or ndarray
        CSR for constant ``p0``, else a dense array.

    Raises
    ------
    ValueError
        If ``p0`` is identically zero, or an argument is invalid.

    Examples
    --------
    Hermite functions: ``h_n' = sqrt(n/2) h_{n-1} - sqrt((n+1)/2) h_{n+1}``:

    >>> import slbasis
    >>> derivative_matrix(slbasis.kernel("hermite_functions"), 3).toarray().round(4) + 0.0
    array([[ 0.    ,  0.7071,  0.    ],
           [-0.7071,  0.    ,  1.    ],
           [ 0.    , -1.    ,  0.    ],
           [ 0.    ,  0.    , -1.2247]])
    """
    N = as_int_at_least(N, "N")
    pad = as_int_at_least(pad, "pad", 2)
    _check_shape(shape)
    c0, c1, c2 = (float(c) for c in kernel.p0)
    if c1 == 0 and c2 == 0:
        if c0 == 0:
            raise ValueError("kernel.p0: p0 is identically zero")
        return (derivative_operator(kernel, N, shape) / (2 * c0)).tocsr()
    G1 = _solve_derivative(kernel, N, N + pad)
    G2 = _solve_derivative(kernel, N, N + 2 * pad)
    scale = np.abs(G2).max()
    diff = np.abs(G2[: N + pad] - G1).max()
    if diff > 1e-8 * scale:
        warnings.warn(
            f"derivative_matrix: d/dx of these functions is not well represented in the "
            f"basis (changing the truncation from {N + pad} to {N + 2 * pad} rows changes "
            f"the result by {diff:.1e} relative to {scale:.1e}); the matrix depends on the "
            f"truncation.",
            RuntimeWarning,
            stacklevel=user_stacklevel(),
        )
    if shape == "square":
        return G2[:N].copy()
    # rows whose entries stand above the rounding noise (estimated by the M-dependence)
    noise = max(1e-12 * scale, 10 * diff)
    big = np.flatnonzero(np.abs(G2).max(axis=1) > noise)
    last = max(N, int(big[-1]) + 1 if big.size else N)
    return G2[:last].copy()


def is_legendre(kernel: Kernel, N: int) -> bool:
    """Whether the first ``N + 1`` functions of ``kernel`` are Legendre functions.

    True when the interval ``(a, b)`` is finite and the recurrence coefficients are those of
    the constant weight on it: ``b_n = (a + b) / 2``, ``|A_n| = h n / sqrt(4 n^2 - 1)`` with
    ``h = (b - a) / 2`` (to :data:`LEGENDRE_RTOL` relative).  The Jacobi matrix of a measure
    on a bounded interval fixes the measure (the moment problem is determinate), so the
    functions are then ``+-sqrt(1/h) hat P_n((x - (a + b)/2) / h)``.

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions, ``>= 1``.

    Returns
    -------
    bool
        Whether they are.

    Examples
    --------
    >>> import slbasis
    >>> is_legendre(slbasis.kernel("legendre"), 5), is_legendre(slbasis.kernel("chebyshev_t"), 5)
    (True, False)
    """
    N = as_int_at_least(N, "N")
    a, b = (float(v) for v in kernel.interval)
    if not (np.isfinite(a) and np.isfinite(b)):
        return False
    diag, off = (np.asarray(v, dtype=float) for v in kernel.jacobi(N + 1))
    h, mid = 0.5 * (b - a), 0.5 * (a + b)
    n = np.arange(1, N + 2, dtype=float)
    ref = h * n / np.sqrt(4 * n * n - 1)
    return bool(
        np.all(np.abs(diag - mid) <= LEGENDRE_RTOL * h)
        and np.all(np.abs(np.abs(off) - ref) <= LEGENDRE_RTOL * ref)
    )


def integration_matrix(
    kernel: Kernel, N: int, x0: float | None = None, shape: str = "rectangular"
) -> sp.csr_matrix:
    """``int_{x0}^x`` on the first ``N`` Legendre functions, exact.

    Column ``n`` holds the coefficients of ``int_{x0}^x phi_n``.  For the orthonormal
    recurrence of Legendre functions (:func:`is_legendre`),

        F_n = A_{n+1} / (n + 1) phi_{n+1} - A_n / n phi_{n-1}    (F_0 = A_1 phi_1)

    is an antiderivative of ``phi_n``: on ``(-1, 1)`` it is ``(P_{n+1} - P_{n-1}) / sqrt(2
    (2n + 1))``, whose derivative is ``hat P_n`` by ``P'_{n+1} - P'_{n-1} = (2n + 1) P_n``
    (Abramowitz & Stegun 22.8.8).  The lower limit enters as ``- F_n(x0) / phi_0`` in row
    0; at the ends ``x0 = a`` or ``b`` the matrix is exactly tridiagonal.

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions, ``>= 1``.
    x0 : float, optional
        The lower limit, a point of ``[a, b]`` (default ``a``).
    shape : {"square", "rectangular"}, optional
        The ``N x N`` cut or the exact ``(N+1) x N`` matrix.

    Returns
    -------
    scipy.sparse.csr_matrix
        The matrix, ``(N+1) x N`` or ``N x N``.

    Raises
    ------
    ValueError
        If the functions are not Legendre's, ``x0`` lies outside the interval, or an
        argument is invalid.

    References
    ----------
    .. [1] M. Abramowitz and I. A. Stegun, *Handbook of Mathematical Functions*, Dover,
       1965, eq. 22.8.8.

    Examples
    --------
    >>> import slbasis
    >>> integration_matrix(slbasis.kernel("legendre"), 3).toarray().round(4)
    array([[ 1.    , -0.5774,  0.    ],
           [ 0.5774,  0.    , -0.2582],
           [ 0.    ,  0.2582,  0.    ],
           [ 0.    ,  0.    ,  0.169 ]])
    """
    N = as_int_at_least(N, "N")
    _check_shape(shape)
    if not is_legendre(kernel, N):
        raise ValueError(
            f"kernel: integration_matrix needs Legendre functions (constant weight on a "
            f"finite interval), got {getattr(kernel, 'name', kernel)!r}"
        )
    a, b = (float(v) for v in kernel.interval)
    x0 = a if x0 is None else float(x0)
    if not a <= x0 <= b:
        raise ValueError(f"x0: expected a point of the interval [{a}, {b}], got {x0!r}")
    diag, off = (np.asarray(v, dtype=float) for v in kernel.jacobi(N + 1))
    n = np.arange(N, dtype=float)
    sup = off[:N] / (n + 1)  # F_n on phi_{n+1}
    sub = np.zeros(N)
    sub[1:] = -off[: N - 1] / n[1:]  # F_n on phi_{n-1}
    row0 = np.zeros(N)
    if x0 == a or x0 == b:
        row0[0] = diag[0] - x0  # -F_0(x0) / phi_0
    else:
        P = evaluate(kernel, N + 1, np.array([x0]))[:, 0]  # phi_0(x0) .. phi_N(x0)
        F_at = sup * P[1 : N + 1]
        F_at[1:] += sub[1:] * P[: N - 1]
        row0 = -F_at / P[0]
    cols = np.flatnonzero(row0)
    first = sp.csr_matrix((row0[cols], (np.zeros(cols.size, int), cols)), shape=(N + 1, N))
    G = sp.csr_matrix(_tridiag(N, N + 1, sub, np.zeros(N), sup) + first)
    G.eliminate_zeros()
    return G if shape == "rectangular" else G[:N].tocsr()
