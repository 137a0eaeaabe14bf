"""The finite-interval Sturm-Liouville family: basis on the window, integrator lag, rows.

The equations are those of :mod:`hdpbsid.methods.sturm_liouville`: on a finite window the
lag is the Möbius map ``M = alpha gamma J (I + alpha beta J)^{-1}`` of the causal
integration matrix ``J`` (row form: ``X J`` are the coefficients of ``int_{t0}^t x``), a
contraction (the causal filter ``alpha gamma / (s + alpha beta)``); the pseudo-input rows
``w`` solve ``w J = v`` for the truncation (``v = e_{N-1}``) and the initial state
(``v`` = coefficients of 1).  ``J`` is in closed form for Legendre functions
(:func:`slbasis.numeric.operators.integration_matrix`, tridiagonal: banded solves), from
the exact derivative matrix when the derivatives stay in the span, else by quadrature in
``x = -cos(theta)`` (:func:`integration_matrix`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from numpy.typing import NDArray

import slbasis
from hdpbsid.bases.basis_domain import SolveLag, basis_values, shared_basis
from hdpbsid.bases.family import Integrator, IntegratorFamily
from hdpbsid.bases.memo import memoize
from slbasis.numeric import operators

__all__ = ["SLSettings", "SL", "SturmLiouvilleFamily", "integration_matrix"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class SLSettings:
    """The size rule and the numerical limits of the finite-interval families.

    Parameters
    ----------
    n_min, n_max : int, optional
        Limits of the default basis size.
    band_margin : float, optional
        Multiple of the data bandwidth the default basis covers.
    pad : float, optional
        Relative padding of the window for families singular at the interval ends.
    lag_steps_kept : int, optional
        One-step lag results kept by the integrator lag.
    max_bands : int, optional
        Off-diagonals up to which an integration matrix is solved in band form.

    Examples
    --------
    >>> SLSettings().band_margin
    1.5
    """

    #: smallest default basis size (a handful of functions per mode and boundary term)
    n_min: int = 50
    #: largest default basis size: a dense N x N integration matrix, so it bounds the cost
    n_max: int = 2000
    #: the default N covers this multiple of the data bandwidth; N functions on a window of
    #: length T resolve ``2 N / T`` rad/s (degree N polynomials resolve x-frequencies up
    #: to ~N; ``dx/dt = 2/T``)
    band_margin: float = 1.5
    #: relative padding of the basis window for families singular at the interval ends
    pad: float = 1e-3
    #: one-step lag results kept by the (memoised) integrator lag: the data and
    #: pseudo-input rows of both input holds at up to 8 powers, plus the order-dependent
    #: states
    lag_steps_kept: int = 64
    #: an integration matrix with at most this many off-diagonals is solved in band form
    #: (the Legendre closed form from the window start has 2); a wider one is factored
    #: densely
    max_bands: int = 8


#: the settings of the finite-interval families
SL = SLSettings()
#: the fields of :data:`SL` under their former names
N_MIN, N_MAX = SL.n_min, SL.n_max
BAND_MARGIN = SL.band_margin
PAD = SL.pad
LAG_STEPS_KEPT = SL.lag_steps_kept
MAX_BANDS = SL.max_bands


def _legendre_integration(basis: Any, N: int, t0: float) -> sp.csr_matrix | None:
    """``J`` in closed form (:func:`slbasis.numeric.operators.integration_matrix`) in time
    units, ``(N + 1) x N`` and sparse, or None when the functions are not Legendre's.

    ``phi_n(t) = sqrt(s) phi_n(x(t))`` and ``dt = dx / s`` (``s`` = scale) give the time
    matrix as the ``x`` matrix divided by ``s``.  A ``t0`` that maps within rounding of an
    end of the interval (the window start maps to ``a`` by construction, up to the
    rounding of ``(t0 - centre) * scale``) is that end, as :meth:`slbasis.Basis.eval`
    treats times outside by rounding.
    """
    kernel = basis.kernel
    if not operators.is_legendre(kernel, N):
        return None
    a, b = basis.interval
    x0 = float(basis.tmap.to_x(np.float64(t0)))
    tol = 16 * np.finfo(float).eps * max(1.0, abs(a), abs(b))
    for end in (a, b):
        if abs(x0 - end) <= tol:
            x0 = end
    if not a <= x0 <= b:
        raise ValueError(f"t0: {t0} lies outside the basis window {basis.t_span}")
    return (operators.integration_matrix(kernel, N, x0) / basis.scale).tocsr()


def _integration_exact(basis: Any, N: int, t0: float) -> Array | None:
    """``J`` (column ``j`` = coefficients of ``int_{t0} phi_j``) from the exact derivative
    matrix on ``N + 1`` functions, or None when the derivatives leave the span."""
    b1 = slbasis.Basis(basis.kernel, N + 1, basis.t_span, scale=basis.scale, centre=basis.centre)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        try:
            D = b1.derivative_matrix("rectangular")
        except RuntimeWarning:
            return None
    D = D.toarray() if hasattr(D, "toarray") else np.asarray(D)
    if D.shape[0] != N + 1:
        return None
    # int phi_j = g with D g = e_j (j < N) and g(t0) = 0: a consistent (N+2) x (N+1) system
    phi0 = b1.eval(np.array([t0]))[:, 0]
    upper = D[:N, 1:]
    # the numerically solved derivative matrix carries rounding noise (~1e-11 relative,
    # slbasis.numeric.operators) below the diagonal; 1e-8 relative separates it from terms
    below = np.max(np.abs(np.tril(D, 0))) <= 1e-8 * np.max(np.abs(D))
    if below and phi0[0] != 0 and np.all(np.diagonal(upper) != 0):
        # polynomial families: d/dt lowers the degree, so rows 0..N-1 are an upper
        # triangular system for g_1..g_N (diagonal D[i, i+1] != 0) and g_0 follows from
        # g(t0) = 0 -- O(N^3 / 3) by back substitution instead of a dense least squares
        G = np.zeros((N + 1, N))
        G[1:] = sla.solve_triangular(upper, np.eye(N), lower=False)
        G[0] = -(phi0[1:] @ G[1:]) / phi0[0]
        return G
    lhs = np.vstack([D, phi0[None, :]])
    rhs = np.vstack([np.eye(N + 1)[:, :N], np.zeros((1, N))])
    G = np.linalg.lstsq(lhs, rhs, rcond=None)[0]
    return G


def _integration_quadrature(basis: Any, N: int, K: int) -> Array:
    """``J`` by quadrature in ``x = -cos(theta)`` (tames endpoint power singularities)."""
    th = (np.arange(K) + 0.5) * np.pi / K
    x = -np.cos(th)
    tt = basis.tmap.to_t(x)
    phi = basis.eval(tt)  # (N, K), time units
    dt = np.sin(th) * (np.pi / K) / basis.scale  # dt = dx/scale, dx = sin(th) dth
    integrand = phi * dt[None, :]
    F = np.cumsum(integrand, axis=1) - 0.5 * integrand  # int_{t0}^{t_i} phi_j (midpoint)
    G = (phi * dt[None, :]) @ F.T  # G[k, j] = int phi_k F_j dt
    return G


@memoize
def _integration(basis: Any, t0: float, K: int | None = None) -> tuple[Any, str]:
    """:func:`integration_matrix` with the closed form kept sparse (``N x N`` CSR)."""
    N = basis.N
    G = _legendre_integration(basis, N, t0)
    if G is not None:
        return G[:N].tocsr(), "exact (closed form: int P_n = (P_{n+1} - P_{n-1}) / (2n + 1))"
    G = _integration_exact(basis, N, t0)
    if G is not None:
        return G[:N], "exact (from the derivative matrix on N+1 functions)"
    K = 20 * N if K is None else K
    return _integration_quadrature(basis, N, K), f"quadrature in x = -cos(theta), {K} points"


def integration_matrix(basis: Any, t0: float, K: int | None = None) -> tuple[Array, str]:
    """The ``N x N`` causal integration matrix of a basis and how it was computed.

    Column ``j`` holds the coefficients of ``int_{t0}^t phi_j`` on ``phi_0..phi_{N-1}``.
    For Legendre functions it is in closed form (``int P_n = (P_{n+1} - P_{n-1}) / (2n +
    1)``, tridiagonal); else it comes from the exact derivative matrix on ``N + 1``
    functions when the derivatives stay in the span (polynomial families: a triangular
    system); else by quadrature in ``x = -cos(theta)`` with ``K`` points, which tames the
    power singularities of the weight at the interval ends.

    Parameters
    ----------
    basis : Basis
        A basis on a finite interval.
    t0 : float
        The lower limit of the integrals (s), inside the basis window.
    K : int, optional
        Quadrature points of the last resort (default ``20 N``).

    Returns
    -------
    G : ndarray, shape (N, N)
        The matrix.
    how : str
        Which of the three ways computed it.

    References
    ----------
    .. [1] M. Abramowitz and I. A. Stegun, *Handbook of Mathematical Functions*, Dover,
       1965, eq. 22.8.8.

    Examples
    --------
    ``int_0^t phi_0 = t / sqrt(2)`` on ``[0, 2]``, whose coefficients are ``1`` and
    ``1 / sqrt(3)``:

    >>> import slbasis
    >>> G, how = integration_matrix(slbasis.basis("legendre", 6, (0.0, 2.0)), 0.0)
    >>> np.round(G[:, 0], 6)
    array([1.     , 0.57735, 0.     , 0.     , 0.     , 0.     ])
    """
    G, how = _integration(basis, t0, K)
    return (G.toarray() if sp.issparse(G) else np.array(G)), how


def _band_storage(G: sp.csr_matrix, lower: int, upper: int) -> Array:
    """LAPACK band storage of ``G`` (``ab[upper + i - j, j] = G[i, j]``), as
    :func:`scipy.linalg.solve_banded` takes it."""
    C = G.tocoo()
    ab = np.zeros((lower + upper + 1, G.shape[1]))
    ab[upper + C.row - C.col, C.col] = C.data
    return ab


@memoize
def _integrator_lag(
    basis: Any, t0: float, alpha: float, beta: float, gamma: float
) -> tuple[SolveLag, Callable[[Array], Array], str]:
    """``W -> W M``, ``M = alpha gamma J (I + alpha beta J)^{-1}`` (module docstring), with
    ``J = G^T``; also ``v -> w`` solving ``w J = v`` (pseudo-input rows) and how ``G`` was
    computed.

    ``(W M)^T = alpha gamma S^{-T} G W^T`` with ``S^T = I + alpha beta G``: a banded ``G``
    (the Legendre closed form, tridiagonal) gives banded solves, ``O(N)`` per row of ``W``
    (LAPACK ``gbsv``, LU with partial pivoting as the dense ``getrf`` but inside the band);
    a dense ``G`` is LU-factored once.  Memoised by the basis (its kernel, ``N`` and time
    map), not by the contents of ``G``.
    """
    G, how = _integration(basis, t0)
    N = G.shape[0]
    ab_ = alpha * beta
    lower = upper = N
    if sp.issparse(G):
        C = G.tocoo()
        lower = int(np.max(C.row - C.col, initial=0))
        upper = int(np.max(C.col - C.row, initial=0))
        if lower + upper > MAX_BANDS:
            G = G.toarray()  # a lower limit inside the window fills row 0 of G
    if sp.issparse(G):
        ab_G = _band_storage(G, lower, upper)
        ab_S = ab_ * ab_G
        ab_S[upper] += 1.0  # S^T = I + alpha beta G
        bands = (lower, upper)

        def solve(W: Array) -> Array:
            rhs = np.asarray(G @ W.T)
            return alpha * gamma * sla.solve_banded(bands, ab_S, rhs, overwrite_b=True).T

        def solve_rows(v: Array) -> Array:
            return sla.solve_banded(bands, ab_G, v)

        key: Any = ("banded", lower, upper, ab_G, alpha, beta, gamma)
        remember = 0  # a banded step costs about what hashing W for a lookup would
    else:
        J = G.T  # row form: (X J)_k = sum_j X_j G[k, j]
        lu = sla.lu_factor(np.eye(N) + ab_ * G)  # S^T

        def solve(W: Array) -> Array:
            return alpha * gamma * sla.lu_solve(lu, (W @ J).T).T

        lu_G = sla.lu_factor(G)

        def solve_rows(v: Array) -> Array:
            return sla.lu_solve(lu_G, v)

        key = (J, alpha, beta, gamma)
        remember = LAG_STEPS_KEPT
    # memoised, so the orders of a sweep share this object (and, for a dense M, its
    # remembered steps)
    lag = SolveLag(
        solve,
        f"alpha gamma J (I + alpha beta J)^-1 [{how}]",
        key=key,
        remember=remember,
    )
    return lag, solve_rows, how


@dataclass(frozen=True, eq=False)
class SturmLiouvilleFamily(IntegratorFamily):
    """A finite-interval ``slbasis`` family on the window, as a basis family
    (:class:`~hdpbsid.bases.family.BasisFamily`; module docstring).

    * size: ``N = 1.5 omega_b T / 2`` (degree-``N`` functions resolve ``2 N / T`` rad/s on
      a window of ``T`` s); a given ``N`` must resolve the data band;
    * lag: ``W -> W M`` with ``M = alpha gamma J (I + alpha beta J)^{-1}``, ``J`` the causal
      integration matrix (:func:`integration_matrix`): the causal filter ``alpha gamma / (s +
      alpha beta)`` in the basis, a contraction;
    * pseudo-inputs: ``w J = e_{N-1}`` (truncation) and, with ``boundary``, ``w J = 1``
      (the initial state; ``needs_ones``).

    Functions singular at the interval ends get a window padded by ``PAD * T``.

    Parameters
    ----------
    family : str or slbasis.SturmLiouville
        A catalogue name with a finite interval or a problem.
    params : dict
        The family's parameters.

    References
    ----------
    .. [1] A. Zettl, *Sturm-Liouville Theory*, Mathematical Surveys and Monographs 121,
       AMS, 2005.

    Examples
    --------
    >>> fam = SturmLiouvilleFamily("legendre")
    >>> basis = fam.basis(50, 10.0)
    >>> fam.padding(basis), fam.method
    (0.0, 'legendre')
    >>> fam.pseudo_rows(basis, Integrator(1.0), True, basis.project(
    ...     np.linspace(0.0, 10.0, 101), np.ones((101, 1))).ravel()).shape
    (2, 50)
    """

    family: Any = "legendre"
    params: dict = field(default_factory=dict)
    n_min, n_max = N_MIN, N_MAX
    q = (1, 2)
    needs_ones = True
    size_rule = f"N = {BAND_MARGIN} * bandwidth * T / 2"

    @property
    def label(self) -> str:  # type: ignore[override]
        """The family's name in warnings."""
        return f"{self.family}"

    def size_rate(self, wb: float) -> float:
        """``1.5 wb / 2`` functions per second.

        Parameters
        ----------
        wb : float
            Data bandwidth (rad/s).

        Returns
        -------
        float
            Functions per second of window.
        """
        return BAND_MARGIN * wb / 2

    def wanted_size(self, T: float, wb: float) -> float:
        """``1.5 wb T / 2``, before clipping.

        Parameters
        ----------
        T : float
            Window length (s).
        wb : float
            Data bandwidth (rad/s).

        Returns
        -------
        float
            The size the rule wants.
        """
        return BAND_MARGIN * wb * T / 2

    def too_narrow(self, N: int, T: float, wb: float) -> str | None:
        """Why ``N`` functions on ``T`` s do not resolve ``wb`` (``2 N / T < wb``), or None.

        Parameters
        ----------
        N : int
            Basis size.
        T : float
            Window length (s).
        wb : float
            Data bandwidth (rad/s).

        Returns
        -------
        str or None
            The message (with the ``N`` needed), or None.
        """
        if 2 * N / T >= wb:
            return None
        return (
            f"N={N} functions on a record of {T:g} s resolve only {2 * N / T:.3g} "
            f"rad/s, below the data bandwidth {wb:.3g} rad/s; use N >= "
            f"{int(np.ceil(wb * T / 2))}"
        )

    def basis(self, N: int, T: float) -> Any:
        """The basis on ``[0, T]``, padded when the functions are singular at the ends.

        Parameters
        ----------
        N : int
            Number of functions.
        T : float
            Window length (s).

        Returns
        -------
        Basis
            The basis (shared between calls).

        Raises
        ------
        TypeError
            If the family or its parameters are not accepted by :func:`slbasis.basis`.
        ValueError
            If the family lives on an infinite interval (use the Hermite or Laguerre method).
        """
        span = (0.0, T)
        try:
            basis = shared_basis(self.family, N, span, **self.params)
        except TypeError as exc:
            raise TypeError(f"family/family_params: {exc}") from exc
        if not np.all(np.isfinite(basis_values(basis, span))):
            # functions singular at the interval ends (Chebyshev-T, ...): the basis window
            # is padded by PAD * T on both sides; the record is the windowed signal in it
            pad = PAD * T
            basis = shared_basis(self.family, N, (-pad, T + pad), **self.params)
        a_, b_ = basis.interval
        if not (np.isfinite(a_) and np.isfinite(b_)):
            raise ValueError(
                f"family {self.family!r} lives on an infinite interval {basis.interval}; use "
                f"identify_hermite / identify_laguerre for it"
            )
        return basis

    def lag(self, basis: Any, operator: Integrator) -> SolveLag:
        """The integrator lag of ``basis`` at ``operator``.

        Parameters
        ----------
        basis : Basis
            A basis of :meth:`basis`.
        operator : Integrator
            The operator scale.

        Returns
        -------
        SolveLag
            ``W -> W M``, ``M = alpha gamma J (I + alpha beta J)^{-1}``: banded solves for the
            tridiagonal Legendre ``J``, one LU factorisation otherwise (memoised by the basis).
        """
        return _integrator_lag(basis, 0.0, operator.alpha, operator.beta, operator.gamma)[0]

    def pseudo_rows(self, basis: Any, operator: Integrator, boundary: bool, ones: Any) -> Array:
        """The rows ``w`` with ``w J = e_{N-1}`` (truncation) and, with ``boundary``, ``w J = 1``.

        Integrating the state equation from the window start, ``x(t) = x(t0) + int (A x + B
        u)``: the unknown initial state multiplies the coefficients of 1, and the integral of
        the last function leaves the span of the ``N`` functions (the truncation, on the last
        coefficient); both are known rows with unknown factors, moved to the lag's side by
        ``J^{-1}``.

        Parameters
        ----------
        basis : Basis
            The block's basis.
        operator : Integrator
            The operator scale (the rows do not depend on it, the solve object does).
        boundary : bool
            Include the initial-state row.
        ones : ndarray, shape (N,)
            Coefficients of the constant 1 on the block.

        Returns
        -------
        ndarray, shape (1 or 2, N)
            The rows.
        """
        a = operator
        jinv = _integrator_lag(basis, 0.0, a.alpha, a.beta, a.gamma)[1]
        last = np.zeros(basis.N)
        last[-1] = 1.0
        r = [jinv(last)]
        if boundary:
            r.append(jinv(ones))
        return np.array(r)

    def integration(self, basis: Any) -> str:
        """How the integration matrix of ``basis`` is computed (:func:`integration_matrix`).

        Parameters
        ----------
        basis : Basis
            A basis of :meth:`basis`.

        Returns
        -------
        str
            The method's description.
        """
        return _integration(basis, 0.0)[1]

    @property
    def name(self) -> str:
        """The family as reported: its catalogue name, or the problem's ``repr``."""
        return self.family if isinstance(self.family, str) else repr(self.family)

    @property
    def method(self) -> str:
        """The method name the models report (``"legendre"`` or ``"sl"``)."""
        return "legendre" if self.family == "legendre" else "sl"

    @staticmethod
    def padding(basis: Any) -> float:
        """The padding (s) of the basis window before the record.

        Parameters
        ----------
        basis : Basis
            A basis of :meth:`basis`.

        Returns
        -------
        float
            0 for functions regular at the ends, ``PAD * T`` otherwise.
        """
        return 0.0 - float(basis.t_span[0])
