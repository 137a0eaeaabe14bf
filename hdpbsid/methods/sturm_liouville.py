"""Methods ``"legendre"``, ``"chebyshev"`` and any finite-interval ``slbasis`` basis.

PBSID in a Sturm-Liouville basis on the record window (the general theory of the thesis,
§4, and the Legendre/Jacobi bases its §7 names as future research; docs/theory.md, "Any
finite-interval Sturm-Liouville basis").  On a finite window the projected
derivative is nilpotent (Legendre: ``phi_n'`` lies in ``span{phi_0..phi_{n-1}}``), so the
Hermite construction ``M = ((D/alpha + beta I)/gamma)^{-1}`` would be a polynomial in ``D``
with norm ``~ (N^2 / (alpha T))^k``: it amplifies noise instead of averaging it.  We use
the **causal integration operator** ``J`` instead (row form: ``X J`` are the coefficients
of ``int_{t0}^t x``; Legendre: tridiagonal, ``int P_n = (P_{n+1} - P_{n-1})/(2n+1)``) and
its Möbius map

    M = m(J) = alpha gamma J (I + alpha beta J)^{-1},

the coefficient form of the causal first-order filter ``alpha gamma / (s + alpha beta)``
(``J <-> 1/s``).  From ``x(t) = x(t0) + int (A x + B u + K e)``, adding ``alpha beta int x``
and applying ``(I + alpha beta J)^{-1}``:

    X = A' X M + B' U M + K' E M + x(t0) 1 (I + alpha beta J)^{-1} + (truncation),

with the same ``A' = (A/alpha + beta I)/gamma``, ``B' = B/(alpha gamma)``,
``K' = K/(alpha gamma)`` as HD-PBSID and the same map back.  **Why it is stable**: the map
``lambda -> lambda' = (lambda/alpha + beta)/gamma`` sends the disc of radius
``alpha gamma`` about ``-alpha beta`` onto the unit disc (for ``beta = gamma = 1`` the
disc ``|lambda + alpha| < alpha``, tangent to the imaginary axis at 0: it holds the stable
eigenvalues of moderate size, e.g. real ones in ``(-2 alpha, 0)``; unstable ones map
outside, which is harmless because the core's truncation concerns the predictor
``A - K C``, stable by construction), and ``M`` is a causal
convolution with ``alpha gamma e^{-alpha beta t}``, whose L^1 norm is ``gamma / beta = 1``:
``M`` is a contraction, so the regressors ``Z M^j`` are repeated low-pass filterings
("integrations") of the data.

The initial-state term and the truncation of the cut ``J`` (Legendre: the last column,
``X_N J[N, N-1]``) are pseudo-inputs ``w`` with ``w M = v``, i.e. ``w = v J^{-1}``
(``v = 1`` coefficients, resp. ``e_{N-1}``).  ``J`` is exact for Legendre, in closed form
and tridiagonal (:func:`slbasis.numeric.operators.integration_matrix`), so ``W -> W M`` and
``w J = v`` are banded solves, ``O(N)`` per row; for a family whose derivatives stay in
the span it comes from the exact derivative matrix; for other families (Chebyshev,
Gegenbauer, Jacobi functions in ``L^2(dt)``, custom problems) it is computed by quadrature
in ``x = -cos(theta)``, and the truncation is then only approximately confined to the
last column (accurate when the coefficients decay, i.e. for smooth signals and ``N``
above the bandwidth).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from numpy.typing import NDArray

import slbasis
from hdpbsid.bases.basis_domain import (
    P_DEFAULT_RANGE,
    SolveLag,
    bandwidth,
    basis_values,
    resolve_holds,
    shared_basis,
)
from hdpbsid.bases.family import Choice, Integrator, IntegratorFamily, size_policy
from hdpbsid.bases.memo import memoize
from hdpbsid.bases.pipeline import make_blocks, one_or_all, project, solve
from hdpbsid.bases.segments import default_window, records_bandwidth
from hdpbsid.bases.settings import BasisSettings, resolve_settings
from hdpbsid.data.checks import check_order, check_positive_int
from hdpbsid.data.records import Record, as_records
from hdpbsid.methods.hermite import _real
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.runtime import library_call
from slbasis.numeric import operators

__all__ = [
    "identify_sl",
    "identify_legendre",
    "identify_chebyshev",
    "integration_matrix",
    "SturmLiouvilleFamily",
    "default_alpha",
    "default_past_window",
]

Array = NDArray[np.float64]

#: band (rad/s) resolved by N functions on a window of length T: ``2 N / T`` (degree N
#: polynomials resolve x-frequencies up to ~N; ``dx/dt = 2/T``)
N_MIN, N_MAX = 50, 2000  # dense N x N integration matrix: the upper limit bounds the cost
BAND_MARGIN = 1.5
#: default alpha = ALPHA_FACTOR * (bandwidth holding OUTPUT_FRACTION of the output energy)
ALPHA_FACTOR = 0.5
OUTPUT_FRACTION = 0.95
#: relative padding of the basis window for families singular at the interval ends
PAD = 1e-3
#: one-step lag results kept by the (memoised) integrator lag: the data and pseudo-input
#: rows of both input holds at up to 8 powers, plus the order-dependent states
LAG_STEPS_KEPT = 64
#: an integration matrix with at most this many off-diagonals is solved in band form (the
#: Legendre closed form from the window start has 2); a wider one is factored densely
MAX_BANDS = 8


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
    """The ``N x N`` causal integration matrix ``G`` (column ``j`` = ``int_{t0} phi_j``
    projected on ``phi_0..phi_{N-1}``) and how it was computed: in closed form for
    Legendre functions, else from the exact derivative matrix when the derivatives stay
    in the span, else by quadrature with ``K`` points (default ``20 N``)."""
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
    * lag: ``W -> W M`` with ``M = alpha gamma J (I + alpha beta J)^{-1}``, ``J`` the
      causal integration matrix (:func:`integration_matrix`);
    * pseudo-inputs: ``w J = e_{N-1}`` (truncation) and, with ``boundary``, ``w J = 1``
      (the initial state; ``needs_ones``).

    Functions singular at the interval ends get a window padded by ``PAD * T``.

    Parameters
    ----------
    family : str or slbasis.SturmLiouville
        A catalogue name with a finite interval or a problem.
    params : dict
        The family's parameters.
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
        """``1.5 wb / 2`` functions per second."""
        return BAND_MARGIN * wb / 2

    def wanted_size(self, T: float, wb: float) -> float:
        """``1.5 wb T / 2``."""
        return BAND_MARGIN * wb * T / 2

    def too_narrow(self, N: int, T: float, wb: float) -> str | None:
        """Why ``N`` functions on ``T`` s do not resolve ``wb`` (``2 N / T < wb``)."""
        if 2 * N / T >= wb:
            return None
        return (
            f"N={N} functions on a record of {T:g} s resolve only {2 * N / T:.3g} "
            f"rad/s, below the data bandwidth {wb:.3g} rad/s; use N >= "
            f"{int(np.ceil(wb * T / 2))}"
        )

    def basis(self, N: int, T: float) -> Any:
        """The basis on ``[0, T]``, padded when the functions are singular at the ends."""
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
        """The integrator lag of ``basis`` at ``operator`` (:func:`_integrator_lag`)."""
        return _integrator_lag(basis, 0.0, operator.alpha, operator.beta, operator.gamma)[0]

    def pseudo_rows(self, basis: Any, operator: Integrator, boundary: bool, ones: Any) -> Array:
        """``w J = e_{N-1}`` (truncation) and, with ``boundary``, ``w J = 1`` (``ones``)."""
        a = operator
        jinv = _integrator_lag(basis, 0.0, a.alpha, a.beta, a.gamma)[1]
        last = np.zeros(basis.N)
        last[-1] = 1.0
        r = [jinv(last)]
        if boundary:
            r.append(jinv(ones))
        return np.array(r)

    def integration(self, basis: Any) -> str:
        """How the integration matrix of ``basis`` is computed (:func:`integration_matrix`)."""
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
        """The padding (s) of the basis window before the record."""
        return 0.0 - float(basis.t_span[0])


@library_call
def identify_sl(
    t: Any,
    u: Any = None,
    y: Any = None,
    order: int | None = None,
    *,
    family: Any = "legendre",
    N: int | None = None,
    alpha: float | None = None,
    beta: float = 1.0,
    gamma: float = 1.0,
    family_params: dict | None = None,
    settings: BasisSettings | None = None,
    **shared: Any,
) -> StateSpaceModel:
    """PBSID in a finite-interval Sturm-Liouville basis on the record window.

    ``t`` may be a list of ``(t_i, u_i, y_i)`` records (``u = y = None``); each record,
    or window of a long record (``window``, ``n_jobs``: as in
    :func:`hdpbsid.methods.hermite.identify_hermite`), gets its own basis on its own
    window with its own initial-state and truncation pseudo-inputs (common ``alpha``),
    all stacked in one PBSID problem.

    ``family``: an ``slbasis`` catalogue name with a finite interval (``"legendre"``,
    ``"chebyshev_t"``, ``"chebyshev_u"``, ``"gegenbauer"``, ``"jacobi"``) or an
    :class:`slbasis.SturmLiouville` problem; ``family_params`` its parameters; or a
    :class:`SturmLiouvilleFamily` (``family_params`` then unused).  See the
    module docstring for the integrator ``M`` and why it is stable.  Defaults (in
    ``model.options``):

    * ``N = 1.5 * bandwidth * T / 2`` clipped to ``[N_MIN, N_MAX] = [50, 2000]`` and to
      ``Ns / 2`` (a ``RuntimeWarning`` when an upper limit binds); an explicit ``N``
      whose band ``2 N / T`` is below the data bandwidth raises ``ValueError``;
    * ``alpha`` = half the bandwidth holding 95 % of the output energy (the outputs, not
      a possibly broadband input, show the system's dynamics); ``beta = gamma = 1``;
    * ``p = max(2, ceil(n / l))`` (``n`` = order, or 3 for order selection, which then
      considers orders ``1..min(max_order, f l - 1)``; pass ``p`` for more); ``f = p``;
    * ``input_hold="auto"``: ``zoh`` or ``foh``, whichever VARX fit has the smaller AIC
      over the past windows of HD-PBSID's preferred range
      (:func:`~hdpbsid.bases.basis_domain.hold_criterion`; one decision for every
      order): a test of the input's interpolant, for which a longer VARX approximates
      the innovations better, not the variance choice of this method's own ``p``;
    * ``order``: largest log-gap of the singular values.
    """
    records = as_records(t, u, y)
    m, l = records[0].u.shape[1], records[0].y.shape[1]
    st = resolve_settings(settings, shared, "identify_sl")
    order = check_order(order)
    beta = _real(beta, "beta")
    gamma = _real(gamma, "gamma")
    N = None if N is None else check_positive_int(N, "N", 2)
    fam = (
        family
        if isinstance(family, SturmLiouvilleFamily)
        else SturmLiouvilleFamily(family, dict(family_params or {}))
    )
    wb = records_bandwidth(records)
    p_def = default_past_window(order, l)
    q = fam.q[st.boundary]
    blocks = make_blocks(
        records,
        fam,
        st.window,
        lambda: default_window(records, fam.size_rate(wb), q, p_def),
        size_policy(fam, N, wb),
    )
    a = default_alpha(records) if alpha is None else Choice(_real(alpha, "alpha"), "given")
    proj = project(blocks, resolve_holds(st.input_hold, m), st.n_jobs)
    bases = blocks.bases.values()
    options = {
        "method": fam.method,
        "family": fam.name,
        "family_params": dict(fam.params),
        **blocks.options(),
        "bandwidth": wb,
        "scale": blocks.seg_bases[0].scale,
        "centre": records[0].t0 + blocks.seg_bases[0].centre,
        "alpha_rule": a.reason,
        "boundary": st.boundary,
        "integration": one_or_all([fam.integration(b) for b in bases]),
        "window_padding": one_or_all([fam.padding(b) for b in bases]),
    }
    # the hold is judged as in the other basis methods (the VARX over the preferred
    # range of windows), not at this method's own small window: the same for every order
    op = Integrator(a.value, beta, gamma)
    fit = solve(proj, op, st, order, options, hold_range=P_DEFAULT_RANGE, p_range=(p_def, p_def))
    return fit.model


def default_past_window(order: int | None, l: int) -> int:
    """The default past window ``p = max(2, ceil(n / l))`` (``n`` = the order, or 3 for
    order selection): the smallest window that shows the order.

    Larger windows were erratic at SNR 20 dB in this basis (second-order system, 8 seeds:
    median error 0.1 % for ``p = 2``, 0.3 % with outliers to 14 % for ``p = 3``, 11 % for
    AIC over 2..6).

    Parameters
    ----------
    order : int or None
        The model order, or None (order selection).
    l : int
        Number of outputs.

    Returns
    -------
    int
    """
    need = order if order is not None else 3
    return max(2, -(-need // l))


def default_alpha(records: Sequence[Record]) -> Choice[float]:
    """The integrator's pole: ``alpha = ALPHA_FACTOR * omega_y``, ``omega_y`` the largest
    bandwidth holding ``OUTPUT_FRACTION`` of an output's energy.

    ``alpha`` belongs to the system's dynamics, not to the input: a step or ZOH input is
    broadband (half the data bandwidth gave ``alpha ~ 50`` rad/s and 2-3e-2 error on the
    second-order system, whose poles are at ``|lambda| = 2``); the outputs are the input
    low-passed by the system, so their bandwidth is used.

    Parameters
    ----------
    records : sequence of Record

    Returns
    -------
    Choice of float

    Raises
    ------
    ValueError
        When the outputs have no bandwidth (constant outputs).
    """
    wy = max(bandwidth(r.t, r.y, OUTPUT_FRACTION) for r in records)
    if wy <= 0:
        raise ValueError("cannot choose alpha: the outputs have no bandwidth; pass alpha")
    return Choice(
        ALPHA_FACTOR * wy,
        f"{ALPHA_FACTOR} * output bandwidth ({OUTPUT_FRACTION:.0%} of the energy)",
    )


@library_call
def identify_legendre(
    t: Any, u: Any = None, y: Any = None, order: int | None = None, **options: Any
) -> StateSpaceModel:
    """PBSID with Legendre functions on the record window (:func:`identify_sl`)."""
    if "family" in options:
        raise TypeError("identify_legendre: family is fixed to 'legendre'; use identify_sl")
    return identify_sl(t, u, y, order, family="legendre", **options)


@library_call
def identify_chebyshev(
    t: Any, u: Any = None, y: Any = None, order: int | None = None, **options: Any
) -> StateSpaceModel:
    """PBSID with Chebyshev-T functions on the record window (:func:`identify_sl`)."""
    if "family" in options:
        raise TypeError("identify_chebyshev: family is fixed to 'chebyshev_t'; use identify_sl")
    return identify_sl(t, u, y, order, family="chebyshev_t", **options)
