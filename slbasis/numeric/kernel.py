"""The kernel interface: what the numeric layer needs to know about one basis family.

A *kernel* describes the L^2(a, b)-orthonormal functions ``phi_n = sqrt(w) p_n`` of one
Sturm–Liouville family in its natural variable ``x`` (``p_n`` the orthonormal polynomials
of the weight ``w``). The numeric layer is generic: it only ever touches these members.

Conventions (every array is float64, ``n = 0, 1, ...``):

``interval``
    ``(a, b)``, either end may be ``-inf`` / ``inf``.
``p0``
    ``(c0, c1, c2)``: ``p0(x) = c0 + c1 x + c2 x^2`` (Hermite ``(1, 0, 0)``, Laguerre
    ``(0, 1, 0)``, Legendre / Chebyshev ``(1, 0, -1)``).
``jacobi(N) -> (diag, offdiag)``
    ``diag = (b_0, ..., b_{N-1})``, ``offdiag = (A_1, ..., A_N)`` (length ``N``: ``A_N``
    is included, it is needed for ``phi_N`` and the rectangular operators) of the
    orthonormal three-term recurrence

        x phi_n = A_{n+1} phi_{n+1} + b_n phi_n + A_n phi_{n-1},   phi_{-1} = 0.

    ``A_n`` may be negative (textbook Laguerre functions: ``A_n = -n``); only ``A_n != 0``
    is assumed.
``log_phi0(x) -> (log|phi_0(x)|, sign(phi_0(x)))``
    ``phi_0 = sqrt(w) / d_0`` in log form, so that ``exp(-x^2/2)`` never underflows.
    ``log|phi_0| = -inf`` where ``phi_0 = 0``.
``derivative_bands(N) -> (sub, diag, sup)``
    each of length ``N``: the exact (infinite) tridiagonal operator

        2 p0(x) d/dx phi_n = sub[n] phi_{n-1} + diag[n] phi_n + sup[n] phi_{n+1}

    (``sub[0]`` is ignored).

Any object with these attributes is a kernel (``typing.Protocol``); a generated kernel
*module* with module-level ``name``, ``interval``, ``p0`` and the three functions
qualifies as it is. :class:`KernelSpec` is a frozen dataclass for building one by hand.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Kernel", "KernelSpec", "check_kernel"]


@runtime_checkable
class Kernel(Protocol):
    """Structural type of a basis kernel (see the module docstring for the conventions)."""

    name: str
    interval: tuple[float, float]
    p0: tuple[float, float, float]

    def jacobi(self, N: int) -> tuple[np.ndarray, np.ndarray]:
        """The orthonormal three-term recurrence's coefficients.

        Parameters
        ----------
        N : int
            Number of functions.

        Returns
        -------
        diag : ndarray, shape (N,)
            ``b_0, ..., b_{N-1}``.
        offdiag : ndarray, shape (N,)
            ``A_1, ..., A_N`` (``A_N`` included: ``phi_N`` and the rectangular operators need
            it), all non-zero.
        """
        ...

    def log_phi0(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``phi_0`` in log form, so that ``exp(-x^2 / 2)`` never underflows.

        Parameters
        ----------
        x : ndarray
            Points of the family's variable.

        Returns
        -------
        log_abs : ndarray
            ``log|phi_0(x)|`` (``-inf`` where ``phi_0 = 0``).
        sign : ndarray
            ``sign(phi_0(x))``.
        """
        ...

    def derivative_bands(self, N: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The exact tridiagonal operator ``2 p0(x) d/dx``.

        Parameters
        ----------
        N : int
            Number of functions.

        Returns
        -------
        sub, diag, sup : ndarray, shape (N,)
            The bands of ``2 p0(x) d/dx phi_n = sub[n] phi_{n-1} + diag[n] phi_n + sup[n]
            phi_{n+1}`` (``sub[0]`` ignored).
        """
        ...


@dataclass(frozen=True)
class KernelSpec:
    """A kernel assembled from callables (satisfies :class:`Kernel`).

    Attributes
    ----------
    name : str
        The family's name.
    interval : tuple of float
        ``(a, b)``; either end may be infinite.
    p0 : tuple of float
        ``(c0, c1, c2)`` of ``p0(x) = c0 + c1 x + c2 x^2``.
    jacobi : callable
        ``jacobi(N) -> (diag, offdiag)`` (module docstring).
    log_phi0 : callable
        ``log_phi0(x) -> (log|phi_0|, sign)``.
    derivative_bands : callable
        ``derivative_bands(N) -> (sub, diag, sup)``.
    """

    name: str
    interval: tuple[float, float]
    p0: tuple[float, float, float]
    jacobi: Callable[[int], tuple[np.ndarray, np.ndarray]]
    log_phi0: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    derivative_bands: Callable[[int], tuple[np.ndarray, np.ndarray, np.ndarray]]


def check_kernel(kernel: Kernel, N: int = 8) -> None:
    """Check that ``kernel`` follows the interface (shapes, finiteness, ``A_n != 0``).

    Parameters
    ----------
    kernel : Kernel
        The object to check.
    N : int, optional
        The number of functions the checks evaluate.

    Raises
    ------
    TypeError
        If a member is missing.
    ValueError
        If a value is wrong (interval, ``p0``, shapes, non-finite or zero coefficients).

    Examples
    --------
    >>> import slbasis
    >>> check_kernel(slbasis.kernel("legendre"))
    >>> check_kernel(object())
    Traceback (most recent call last):
    ...
    TypeError: kernel: missing member 'name' (see slbasis.numeric.kernel)
    """
    for attr in ("name", "interval", "p0", "jacobi", "log_phi0", "derivative_bands"):
        if not hasattr(kernel, attr):
            raise TypeError(f"kernel: missing member {attr!r} (see slbasis.numeric.kernel)")
    a, b = (float(v) for v in kernel.interval)
    if not a < b:
        raise ValueError(f"kernel.interval: need a < b, got {kernel.interval!r}")
    if len(tuple(kernel.p0)) != 3:
        raise ValueError(f"kernel.p0: need 3 coefficients (c0, c1, c2), got {kernel.p0!r}")
    diag, off = (np.asarray(v, dtype=float) for v in kernel.jacobi(N))
    if diag.shape != (N,) or off.shape != (N,):
        raise ValueError(
            f"kernel.jacobi({N}): need two arrays of shape ({N},), got {diag.shape}, {off.shape}"
        )
    if not (np.all(np.isfinite(diag)) and np.all(np.isfinite(off))):
        raise ValueError(f"kernel.jacobi({N}): non-finite coefficients")
    if np.any(off == 0):
        raise ValueError(f"kernel.jacobi({N}): an off-diagonal A_n is zero")
    bands = kernel.derivative_bands(N)
    if len(bands) != 3 or any(np.shape(v) != (N,) for v in bands):
        raise ValueError(f"kernel.derivative_bands({N}): need three arrays of shape ({N},)")
    lo = a if np.isfinite(a) else -1.0 + (b if np.isfinite(b) else 0.0)
    hi = b if np.isfinite(b) else lo + 2.0
    xs = np.linspace(lo, hi, 5)[1:-1]
    logv, sign = kernel.log_phi0(xs)
    if np.shape(logv) != xs.shape or np.shape(sign) != xs.shape:
        raise ValueError("kernel.log_phi0(x): need two arrays shaped like x")
