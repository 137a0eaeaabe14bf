"""``Basis``: N orthonormal functions of one family on a record's time window.

An affine map ``x = (t - centre) * scale`` (:class:`~slbasis.numeric.timemap.TimeMap`)
takes the time window ``t_span = (t0, t1)`` into the family's interval ``(a, b)``. The
functions ``phi_n(t) = sqrt(scale) phi_n(x(t))`` are orthonormal in L^2(dt) on the mapped
interval (the orthonormal basis of eq. (1) of the thesis; docs/theory.md).

Default map (``scale``/``centre`` not given). Let ``x_1 < ... < x_N`` be the Gauss nodes
(zeros of ``phi_N``, the region where the first ``N`` functions oscillate; outside it
they decay) and ``fill = 0.9``:

* finite ``(a, b)`` (Legendre, Chebyshev, Jacobi): the window maps onto ``(a, b)``;
* ``(a, inf)`` (Laguerre): ``t0 -> a`` and ``t1 -> a + fill (x_N - a)``
  (Laguerre functions: ``x_N ~ 4N``; a Laguerre basis with pole ``p``, i.e.
  ``sqrt(2p) e^{-pt} L_n(2pt)``, is ``scale = 2p``, ``centre = t0``);
* ``(-inf, b)``: mirrored, ``t1 -> b``;
* ``(-inf, inf)`` (Hermite): the window's centre maps to the middle of the nodes and the
  window fills the fraction ``fill`` of ``[x_1, x_N]`` (Hermite functions: ``x_N ~
  sqrt(2N) - 1.86 (2N)^{-1/6}``, so the record covers 90 % of the effective support
  ``+-sqrt(2N)`` up to that 2 % difference between ``x_N`` and ``sqrt(2N)``: the margin
  keeps the record's ends where the first ``N`` functions still resolve it).

If only ``scale`` is given, ``centre`` follows the same rule; if only ``centre`` is given,
``scale`` does.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.linalg import eigh_tridiagonal

from . import operators, projection, quadrature
from .evaluate import evaluate
from .kernel import Kernel, check_kernel
from .timemap import TimeMap
from .validate import as_int_at_least, as_times

__all__ = ["Basis"]


def _extreme_nodes(kernel: Kernel, N: int) -> tuple[float, float]:
    N = max(N, 2)  # one node has no spread: use the two nodes of phi_2 for N = 1
    diag, off = (np.asarray(v, dtype=float) for v in kernel.jacobi(N))
    lo = eigh_tridiagonal(
        diag, np.abs(off[:-1]), eigvals_only=True, select="i", select_range=(0, 0)
    )
    hi = eigh_tridiagonal(
        diag, np.abs(off[:-1]), eigvals_only=True, select="i", select_range=(N - 1, N - 1)
    )
    return float(lo[0]), float(hi[0])


class Basis:
    """``N`` L^2(dt)-orthonormal functions of ``kernel`` on the time window ``t_span``.

    ``phi_n(t) = sqrt(scale) phi_n(x(t))`` with ``x = (t - centre) * scale``: the factor
    ``sqrt(scale)`` keeps them orthonormal in time (``dx = scale dt``).  See the module
    docstring for the default map.

    Parameters
    ----------
    kernel : Kernel
        The family's numeric data (:mod:`slbasis.numeric.kernel`).
    N : int
        Number of functions, ``>= 1``.
    t_span : tuple of float
        The window ``(t0, t1)``, ``t0 < t1``.
    scale : float, optional
        ``dx/dt``, ``> 0``.
    centre : float, optional
        The time that maps to ``x = 0``.
    fill : float, optional
        Fraction of the effective support the record covers for infinite intervals, ``0 <
        fill <= 1``.

    Attributes
    ----------
    kernel : Kernel
        The kernel.
    N : int
        Number of functions.
    t_span : tuple of float
        The window.
    interval : tuple of float
        The family's interval ``(a, b)``.
    tmap : TimeMap
        The affine map.

    Raises
    ------
    ValueError
        If ``N``, ``t_span``, ``fill``, ``scale`` or ``centre`` is out of range, or the
        default scale rule fails.
    TypeError
        If the kernel lacks a member (:func:`~slbasis.numeric.kernel.check_kernel`).

    Examples
    --------
    >>> import slbasis
    >>> B = Basis(slbasis.kernel("legendre"), 4, (0.0, 2.0))
    >>> B.scale, B.centre  # [0, 2] onto [-1, 1]
    (1.0, 1.0)
    >>> B.eval(np.array([0.0, 2.0])).round(4)
    array([[ 0.7071,  0.7071],
           [-1.2247,  1.2247],
           [ 1.5811,  1.5811],
           [-1.8708,  1.8708]])
    """

    def __init__(
        self,
        kernel: Kernel,
        N: int,
        t_span: tuple[float, float],
        scale: float | None = None,
        centre: float | None = None,
        *,
        fill: float = 0.9,
    ) -> None:
        check_kernel(kernel)
        self.kernel = kernel
        self.N = as_int_at_least(N, "N")
        span = as_times(t_span, "t_span", min_len=2)
        if span.size != 2:
            raise ValueError(f"t_span: expected (t0, t1), got {t_span!r}")
        self.t_span = (float(span[0]), float(span[1]))
        if not (0 < fill <= 1):
            raise ValueError(f"fill: expected 0 < fill <= 1, got {fill!r}")
        if scale is not None and not (np.isfinite(scale) and scale > 0):
            raise ValueError(f"scale: expected a finite number > 0, got {scale!r}")
        if centre is not None and not np.isfinite(centre):
            raise ValueError(f"centre: expected a finite number, got {centre!r}")
        a, b = (float(v) for v in kernel.interval)
        self.interval = (a, b)
        t0, t1 = self.t_span
        T = t1 - t0
        if np.isfinite(a) and np.isfinite(b):
            s = (b - a) / T if scale is None else float(scale)
            c = t0 - a / s
        else:
            xmin, xmax = _extreme_nodes(kernel, self.N)
            if np.isfinite(a):
                s = fill * (xmax - a) / T if scale is None else float(scale)
                c = t0 - a / s
            elif np.isfinite(b):
                s = fill * (b - xmin) / T if scale is None else float(scale)
                c = t1 - b / s
            else:
                s = fill * (xmax - xmin) / T if scale is None else float(scale)
                c = 0.5 * (t0 + t1) - 0.5 * (xmin + xmax) / s
        if not (np.isfinite(s) and s > 0):
            raise ValueError(
                f"N: the default scale rule failed for N = {self.N} (got {s!r}); pass scale="
            )
        self.tmap = TimeMap(float(c) if centre is None else float(centre), float(s))

    # -- the map ---------------------------------------------------------------------
    @property
    def scale(self) -> float:
        """``dx/dt``."""
        return self.tmap.scale

    @property
    def centre(self) -> float:
        """The time mapped to ``x = 0``."""
        return self.tmap.centre

    def __repr__(self) -> str:
        return (
            f"Basis({getattr(self.kernel, 'name', '?')!s}, N={self.N}, t_span={self.t_span}, "
            f"scale={self.scale:.6g}, centre={self.centre:.6g})"
        )

    def _times_in_interval(self, t, name: str) -> np.ndarray:
        """Check that ``t`` maps into the interval; times whose ``x`` lies outside it by
        rounding only (``<= 16 eps`` relative: ``t = 3999`` of ``arange(4000.)`` mapped to
        ``x = 1 + 2.2e-16``) are moved onto the end so that ``x`` is exactly inside."""
        ta = as_times(t, name, increasing=False)
        x = self.tmap.to_x(ta)
        a, b = self.interval
        tol = 16 * np.finfo(float).eps * max([1.0, *(abs(e) for e in (a, b) if np.isfinite(e))])
        if np.any(x < a - tol) or np.any(x > b + tol):
            raise ValueError(
                f"{name}: times outside the basis interval [{self.tmap.to_t(a)}, "
                f"{self.tmap.to_t(b)}] (x in {self.interval})"
            )
        for end, outside, inward in ((a, x < a, np.inf), (b, x > b, -np.inf)):
            if np.any(outside):
                te = float(self.tmap.to_t(end))
                while not (a <= float(self.tmap.to_x(te)) <= b):
                    te = float(np.nextafter(te, np.sign(inward) * np.inf * self.scale))
                ta = np.where(outside, te, ta)
        return ta

    def _times_in_window(self, t, name: str) -> np.ndarray:
        ta = as_times(t, name, min_len=2)
        t0, t1 = self.t_span
        tol = 1e-12 * (t1 - t0)
        if ta[0] < t0 - tol or ta[-1] > t1 + tol:
            raise ValueError(
                f"{name}: sample times [{ta[0]}, {ta[-1]}] extend outside t_span = {self.t_span}"
            )
        return ta

    # -- functions -------------------------------------------------------------------
    def eval(self, t: np.ndarray, *, engine: str = "auto") -> np.ndarray:
        """The ``(N, len(t))`` matrix ``phi_n(t_j) = sqrt(scale) phi_n(x(t_j))``.

        Evaluated by the three-term recurrence of the orthonormal functions, started from
        ``log phi_0`` so that large ``N`` and far arguments neither overflow nor underflow
        (:mod:`slbasis.numeric.evaluate`).

        Parameters
        ----------
        t : array_like, shape (k,)
            Times inside the mapped interval (times outside it by rounding only are moved onto
            its end).
        engine : {"auto", "numpy", "numba"}, optional
            The evaluation engine (:mod:`slbasis.numeric.engine`).

        Returns
        -------
        ndarray, shape (N, k)
            The values.

        Raises
        ------
        ValueError
            If a time lies outside the basis interval.
        """
        ta = self._times_in_interval(t, "t")
        P = evaluate(self.kernel, self.N, self.tmap.to_x(ta), engine=engine)
        P *= np.sqrt(self.scale)
        return P

    def project(
        self,
        t: np.ndarray,
        y: np.ndarray,
        method: str = "quadrature",
        chunk: int | None = None,
        *,
        weights: str | np.ndarray = "trapezoid",
        engine: str = "auto",
    ) -> np.ndarray:
        """Coefficients ``c_n = int y phi_n dt`` over the samples' span (streaming).

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Increasing sample times inside ``t_span``.
        y : array_like, shape (Ns,) or (Ns, k)
            The samples.
        method : {"quadrature", "lstsq"}, optional
            Sample weights from the spacing, or weighted least squares
            (:mod:`slbasis.numeric.projection`).
        chunk : int, optional
            Samples per block of the streaming evaluation.
        weights : str or ndarray, optional
            The quadrature rule (``"trapezoid"``, ...) or the weights themselves.
        engine : {"auto", "numpy", "numba"}, optional
            The evaluation engine.

        Returns
        -------
        ndarray, shape (N,) or (N, k)
            The coefficients.

        Raises
        ------
        ValueError
            If the times extend outside ``t_span`` or are not increasing, or an option is
            unknown.

        Examples
        --------
        >>> import slbasis
        >>> B = slbasis.basis("legendre", 4, (0.0, 2.0))
        >>> t = np.linspace(0.0, 2.0, 2001)
        >>> B.project(t, t**2).round(4)
        array([1.8856, 1.633 , 0.4216, 0.    ])
        """
        ta = self._times_in_window(t, "t")
        return projection.project(
            self.kernel,
            self.N,
            self.tmap,
            ta,
            y,
            method=method,
            weights=weights,
            chunk=chunk,
            engine=engine,
        )

    def project_alternating(
        self,
        t: np.ndarray,
        y_even: np.ndarray,
        y_odd: np.ndarray,
        *,
        weights: str | np.ndarray = "trapezoid",
        engine: str = "auto",
    ) -> np.ndarray:
        """Even rows ``c_n = int y_even phi_n dt``, odd rows ``int y_odd phi_n dt``.

        The projection of mirrored sample pairs on a basis with parity
        (:func:`slbasis.numeric.projection.project_alternating`): each row sums only the
        combination its parity needs.

        Parameters
        ----------
        t : array_like, shape (Ns,)
            Increasing sample times inside ``t_span``.
        y_even : array_like, shape (Ns,) or (Ns, k)
            The samples projected on the even functions.
        y_odd : array_like, shape (Ns,) or (Ns, k)
            The samples projected on the odd functions.
        weights : str or ndarray, optional
            The quadrature rule or the weights.
        engine : {"auto", "numpy", "numba"}, optional
            The evaluation engine.

        Returns
        -------
        ndarray, shape (N,) or (N, k)
            The coefficients.
        """
        ta = self._times_in_window(t, "t")
        return projection.project_alternating(
            self.kernel, self.N, self.tmap, ta, y_even, y_odd, weights=weights, engine=engine
        )

    def reconstruct(self, c: np.ndarray, t: np.ndarray, *, engine: str = "auto") -> np.ndarray:
        """``sum_n c_n phi_n(t)``.

        Parameters
        ----------
        c : array_like, shape (N,) or (N, k)
            Coefficients.
        t : array_like, shape (m,)
            Times inside the mapped interval.
        engine : {"auto", "numpy", "numba"}, optional
            The evaluation engine.

        Returns
        -------
        ndarray, shape (m,) or (m, k)
            The function values.

        Examples
        --------
        >>> import slbasis
        >>> B = slbasis.basis("legendre", 4, (0.0, 2.0))
        >>> t = np.linspace(0.0, 2.0, 2001)
        >>> B.reconstruct(B.project(t, t**2), np.array([0.5, 1.5])).round(4)
        array([0.25, 2.25])
        """
        ta = self._times_in_interval(t, "t")
        return projection.reconstruct(self.kernel, self.N, self.tmap, c, ta, engine=engine)

    # -- operators (time units) --------------------------------------------------------
    def derivative_matrix(self, shape: str = "square") -> sp.csr_matrix | np.ndarray:
        """``d/dt = scale d/dx`` on the coefficients (:mod:`slbasis.numeric.operators`).

        The derivative of ``phi_n`` is a finite combination of neighbouring functions (the
        ladder relations of the Sturm-Liouville problem), so the matrix is banded and exact.

        Parameters
        ----------
        shape : {"square", "rectangular"}, optional
            ``"rectangular"``: the exact image of the first ``N`` functions (Hermite: ``(N+1) x
            N``); ``"square"``: its ``N x N`` cut, whose last row misses the contribution of
            ``c_N`` when the signal is not band-limited to ``N`` terms.

        Returns
        -------
        scipy.sparse.csr_matrix or ndarray
            The matrix: ``D @ c`` are the coefficients of the derivative.

        Examples
        --------
        >>> import slbasis
        >>> B = slbasis.basis("legendre", 4, (0.0, 2.0))
        >>> t = np.linspace(0.0, 2.0, 2001)
        >>> (B.derivative_matrix() @ B.project(t, t**2)).round(4) + 0.0  # of 2 t
        array([2.8284, 1.633 , 0.    , 0.    ])
        """
        D = operators.derivative_matrix(self.kernel, self.N, shape)
        return D * self.scale

    def multiplication_matrix(self, shape: str = "square") -> sp.csr_matrix:
        """Multiplication by ``t`` (``= centre + x / scale``) on the coefficients.

        ``x phi_n`` is the three-term recurrence, so the matrix is the Jacobi matrix of the
        family, shifted and scaled to time.

        Parameters
        ----------
        shape : {"square", "rectangular"}, optional
            ``N x N`` or ``(N+1) x N``.

        Returns
        -------
        scipy.sparse.csr_matrix
            The matrix.
        """
        J = operators.multiplication_matrix(self.kernel, self.N, shape)
        eye = sp.eye(J.shape[0], J.shape[1], format="csr")
        return (eye * self.centre + J / self.scale).tocsr()

    def quadrature(self) -> tuple[np.ndarray, np.ndarray]:
        """Gauss nodes (times) and weights of the basis.

        ``int f g dt = sum_i W_i f(t_i) g(t_i)`` exactly for ``f, g`` in the span (nodes may
        lie outside ``t_span`` for infinite intervals): the nodes are the eigenvalues of the
        Jacobi matrix (Golub & Welsch 1969).

        Returns
        -------
        t : ndarray, shape (N,)
            The nodes (times).
        W : ndarray, shape (N,)
            The weights.

        References
        ----------
        .. [1] G. H. Golub and J. H. Welsch, "Calculation of Gauss quadrature rules", *Math.
           Comp.* 23(106), 221-230, 1969.

        Examples
        --------
        >>> import slbasis
        >>> t, W = slbasis.basis("legendre", 4, (0.0, 2.0)).quadrature()
        >>> t.round(4), W.round(4)
        (array([0.1389, 0.66  , 1.34  , 1.8611]), array([0.3479, 0.6521, 0.6521, 0.3479]))
        """
        x, W = quadrature.gauss(self.kernel, self.N)
        return self.tmap.to_t(x), W / self.scale
