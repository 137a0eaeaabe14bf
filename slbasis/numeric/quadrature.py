"""Gauss quadrature for the orthonormal *functions* ``phi_n = sqrt(w) p_n``.

Nodes ``x_i`` are the zeros of ``phi_N`` (= those of ``p_N``) and the weights ``W_i`` make

    int_a^b f(x) g(x) dx = sum_i W_i f(x_i) g(x_i)

exact whenever ``f g = w * (polynomial of degree <= 2N - 1)``, in particular for
``f, g`` in ``span{phi_0..phi_{N-1}}``. The classical Christoffel numbers are
``lambda_i = w(x_i) W_i``; they underflow where ``w`` does (``scipy.special.roots_hermite
(1000)`` loses 139 weights to 0, ``numpy.polynomial.hermite.hermgauss(1000)`` returns
NaNs). ``W_i`` itself never underflows:

    W_i = 1 / sum_{k<N} phi_k(x_i)^2            (Christoffel function, Gautschi 2004, 1.2.4)

(for Hermite functions ``= 1 / (N h_{N-1}(x_i)^2)`` by Christoffel–Darboux).

Algorithm:

1. Golub & Welsch (1969), *Calculation of Gauss quadrature rules*, Math. Comp. 23: the
   nodes are the eigenvalues of the symmetric tridiagonal Jacobi matrix ``J_N`` (diagonal
   ``b_n``, off-diagonal ``|A_n|``; the signs of ``A_n`` do not change the spectrum),
   computed with LAPACK (``scipy.linalg.eigh_tridiagonal``, O(N^2)). Eigenvalues carry
   an absolute error ``~ eps ||J_N||``, i.e. relative error up to ``~ sqrt(N) eps`` near 0.
2. Newton refinement ``x <- x - p_N(x) / p_N'(x)`` with the scaled polynomial recurrence
   (``evaluate.polynomial_newton_ratio``); two steps (quadratic convergence from an
   ``O(eps ||J||)`` start) bring the nodes to a few ulp.
3. Weights from the Christoffel sum with the stable mantissa/exponent evaluator (all terms
   positive, so the sum is accurate to a few ulp; O(N^2)), instead of the eigenvector
   components of Golub–Welsch, which lose relative accuracy where they are tiny.

For very large N (>~ 10^4) an O(N) asymptotic method (Townsend, Trogdon & Olver 2016,
*Fast computation of Gauss quadrature nodes and weights on the whole real line*, IMA J.
Numer. Anal. 36; Glaser, Liu & Rokhlin 2007) would be faster; it is not implemented: this
O(N^2) route takes about a second at N = 5000.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh_tridiagonal

from .evaluate import Recurrence, evaluate, polynomial_newton_ratio
from .kernel import Kernel

__all__ = ["gauss", "christoffel_weights"]


def christoffel_weights(kernel: Kernel, N: int, x: np.ndarray) -> np.ndarray:
    """``1 / sum_{k<N} phi_k(x)^2`` at the points ``x`` (the Christoffel function).

    At the Gauss nodes these are the Gauss weights of the functions (Golub & Welsch 1969):
    the sum is computed from the stable evaluation, so it holds where the weight ``w`` itself
    underflows.  Streams over blocks of points (about 32 MB of function values each).

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of functions.
    x : array_like, shape (k,)
        Points.

    Returns
    -------
    ndarray, shape (k,)
        The weights.
    """
    x = np.asarray(x, dtype=float)
    rec = Recurrence(kernel, N)
    s = np.empty_like(x)
    block = max(1, (1 << 22) // N)  # ~32 MB of function values per block
    for i in range(0, x.size, block):
        P = evaluate(kernel, N, x[i : i + block], rec=rec)
        s[i : i + block] = np.einsum("ij,ij->j", P, P)
    return 1.0 / s


def gauss(kernel: Kernel, N: int, *, newton_steps: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Gauss nodes ``x`` (ascending) and function weights ``W`` for the first ``N`` functions.

    The nodes are the eigenvalues of the ``N x N`` Jacobi matrix (Golub-Welsch), polished
    by ``newton_steps`` Newton steps on ``p_N``
    (:func:`~slbasis.numeric.evaluate.polynomial_newton_ratio`); the weights are the
    Christoffel sums (:func:`christoffel_weights`), so that
    ``int f g dx = sum_i W_i f(x_i) g(x_i)`` exactly for ``f, g`` in the span.

    Parameters
    ----------
    kernel : Kernel
        The family.
    N : int
        Number of nodes, ``>= 1``.
    newton_steps : int, optional
        Newton refinements of the nodes, ``>= 0``.

    Returns
    -------
    x : ndarray, shape (N,)
        The nodes, ascending.
    W : ndarray, shape (N,)
        The weights.

    Raises
    ------
    ValueError
        If ``N`` or ``newton_steps`` is not a non-negative integer (``N >= 1``).

    References
    ----------
    .. [1] G. H. Golub and J. H. Welsch, "Calculation of Gauss quadrature rules", *Math.
       Comp.* 23(106), 221-230, 1969.

    Examples
    --------
    Three-point Gauss-Legendre: nodes ``0, +-sqrt(3/5)``, weights ``8/9, 5/9``:

    >>> import slbasis
    >>> x, W = gauss(slbasis.kernel("legendre"), 3)
    >>> x.round(6) + 0.0, W.round(6)
    (array([-0.774597,  0.      ,  0.774597]), array([0.555556, 0.888889, 0.555556]))
    """
    if int(N) != N or N < 1:
        raise ValueError(f"N: expected an integer >= 1, got {N!r}")
    if int(newton_steps) != newton_steps or newton_steps < 0:
        raise ValueError(f"newton_steps: expected an integer >= 0, got {newton_steps!r}")
    N = int(N)
    diag, off = (np.asarray(v, dtype=float) for v in kernel.jacobi(N))
    if N == 1:
        x = diag.copy()
    else:
        x = eigh_tridiagonal(diag, np.abs(off[:-1]), eigvals_only=True)
    for _ in range(int(newton_steps)):
        step = polynomial_newton_ratio(kernel, N, x)
        step = np.where(np.isfinite(step), step, 0.0)
        x = x - step
    x = np.sort(x)
    return x, christoffel_weights(kernel, N, x)
