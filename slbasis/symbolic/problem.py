"""``SturmLiouville``: everything derivable from ``p0, p1, q0`` (seed §4, eqs. 6-11)."""

from __future__ import annotations

from collections.abc import Iterable
from functools import cache, cached_property

import sympy as sp

from .closed_forms import ClosedForms, PolynomialData, gamma_simplify
from .direct import DirectComputation
from .gauge import Gauge, find_gauge
from .ladder import (
    BandedOperator,
    LadderRelations,
    commutator_form,
    ladder_form,
    ladder_relations,
    printed_eq11,
)
from .parse import Coefficient, N, X, parse_coefficients
from .weight import WeightForm, classify

FRAMES = ("functions", "polynomials", "eigenfunctions")
#: Indices below this are checked against direct computation (see :meth:`exceptional`).
_SMALL_N = 4


class SturmLiouville:
    """The eigenproblem ``p0 f'' + p1 f' - q0 f = -lambda f`` (seed eq. 8), derived exactly.

    Parameters
    ----------
    p0, p1 : polynomials in ``x`` (strings, numbers or sympy expressions); ``deg p0 <= 2``
        and, for polynomial eigenfunctions, ``deg p1 <= 1``.
    q0 : polynomial or rational function; ``q0 != 0`` must be a gauge (Liouville) transform
        of a polynomial problem (e.g. ``p0=1, p1=0, q0=x**2``: Hermite functions).
    var : name of the independent variable used in the inputs (default ``"x"``).
    params : names of parameter symbols (e.g. ``("alpha", "beta")``).
    standardization : Rodrigues constant ``c_n`` of eq. (10) as an expression in ``n``;
        default ``(-1)^n`` if ``p0 > 0`` on the interval (else ``1``), which makes every
        leading coefficient positive.
    name : label used in reports.
    gauge : for ``q0 != 0`` with several admissible gauges (limit-circle endpoints), the
        ``p1~`` of the polynomial problem to use; default: the most regular one.

    Everything is a sympy expression in the canonical symbols ``x`` (:data:`X`) and ``n``
    (:data:`N`).  Closed forms in ``n`` hold for all ``n >= 0`` except the indices in
    :attr:`exceptional`, where a cancelled factor makes them degenerate; the per-``n``
    accessors (``norm2(3)``, ``jacobi_matrix(N)``, ...) handle those exactly.
    """

    def __init__(
        self,
        p0: Coefficient,
        p1: Coefficient,
        q0: Coefficient = 0,
        *,
        var: str | sp.Symbol = "x",
        params: Iterable[str | sp.Symbol] = (),
        standardization: Coefficient | None = None,
        name: str | None = None,
        gauge: Coefficient | None = None,
    ) -> None:
        self.coefficients = parse_coefficients(p0, p1, q0, var=var, params=params)
        c = self.coefficients
        self.p0, self.p1, self.q0 = c.p0, c.p1, c.q0
        self.params = c.params
        self.name = name or f"p0={self.p0}, p1={self.p1}" + (f", q0={self.q0}" if self.q0 else "")
        self.gauge: Gauge | None
        if self.q0 == 0:
            self.gauge = None
            self.weight_form: WeightForm = classify(self.p0, self.p1)
        else:
            prefer = None
            if gauge is not None:
                prefer = parse_coefficients(self.p0, gauge, var=var, params=self.params).p1
            self.gauge = find_gauge(self.p0, self.p1, self.q0, prefer)
            self.weight_form = self.gauge.weight_form
        #: ``p1`` of the underlying polynomial problem (``p1~``; equal to ``p1`` if ``q0 = 0``).
        self.p1_poly = self.p1 if self.gauge is None else self.gauge.p1_poly
        if standardization is None:
            self.standardization = (-sp.Integer(self.weight_form.p0_sign)) ** N
        else:
            self.standardization = sp.sympify(standardization, locals={"n": N})
            self.standardization = self.standardization.subs(sp.Symbol("n"), N)
        self.closed = ClosedForms(
            PolynomialData.from_exprs(self.p0, self.p1_poly),
            self.standardization,
            self.weight_form.total_mass,
            self.weight_form.p0_sign,
        )
        self._verified: dict[int, object] = {}
        #: Textbook closed forms (set by the catalogue; used only by :meth:`verify`).
        self.oracle = None
        self.direct = DirectComputation(
            self.p0, self.p1_poly, self.standardization, self.weight_form
        )

    def __repr__(self) -> str:
        return (
            f"SturmLiouville(p0={self.p0}, p1={self.p1}, q0={self.q0}) "
            f"[{self.kind}, interval {self.interval}]"
        )

    # ----- weight, interval, class ------------------------------------------------------
    @property
    def kind(self) -> str:
        """``"hermite"``, ``"laguerre"`` or ``"jacobi"`` (by ``deg p0`` = 0, 1, 2)."""
        return self.weight_form.kind

    @property
    def interval(self) -> tuple[sp.Expr, sp.Expr]:
        """``(a, b)``: positive weight, vanishing boundary terms ``p0 w f g``."""
        return self.weight_form.interval

    @property
    def boundary(self) -> tuple[str, str]:
        """Behaviour of the weight at the two ends of the interval."""
        return self.weight_form.endpoints

    @property
    def assumptions(self) -> tuple[str, ...]:
        """Conditions on symbolic parameters assumed (not decidable from their symbols)."""
        return tuple(f"{e} > 0" for e in dict.fromkeys(self.weight_form.assumptions))

    def positive_substitution(self) -> dict[sp.Symbol, sp.Expr]:
        """``{param: u - c}`` with positive symbols ``u`` encoding the assumptions.

        Each assumption ``param + c > 0`` linear in one parameter becomes ``param = u - c``
        with ``u > 0``, so that sympy may simplify ``sqrt((alpha+1)^2) = alpha + 1``.
        """
        subst: dict[sp.Symbol, sp.Expr] = {}
        for expr in dict.fromkeys(self.weight_form.assumptions):
            syms = [s for s in expr.free_symbols if s in self.params]
            if len(syms) != 1 or syms[0] in subst or not expr.is_polynomial(syms[0]):
                continue
            (sym,) = syms
            if sp.degree(expr, sym) != 1:
                continue
            u = sp.Symbol(f"{sym.name}_pos", positive=True)
            subst[sym] = sp.solve(sp.Eq(expr, u), sym)[0]
        return subst

    @property
    def polynomial_weight(self) -> sp.Expr:
        """Weight ``w~`` of the polynomial problem in normal form (eq. 9)."""
        return self.weight_form.weight

    @cached_property
    def weight(self) -> sp.Expr:
        """Weight of *this* problem (eq. 9); ``w = w~ / g^2`` for a gauge problem."""
        if self.gauge is None:
            return self.polynomial_weight
        return sp.simplify(sp.powsimp(self.polynomial_weight / self.gauge.factor**2, force=True))

    @property
    def is_gauge_transform(self) -> bool:
        """True when ``q0 != 0`` and the problem was recognised as a gauge transform."""
        return self.gauge is not None

    # ----- eigenvalues, eigenfunctions ---------------------------------------------------
    def eigenvalue(self, n: int | sp.Expr = N) -> sp.Expr:
        """``lambda_n = -n (p1~' + (n-1) p0''/2) - K`` (``K`` the gauge shift)."""
        shift = 0 if self.gauge is None else self.gauge.shift
        return sp.expand(self.closed.eigenvalue(sp.sympify(n)) - shift)

    def polynomial(self, n: int) -> sp.Expr:
        """Rodrigues polynomial ``P_n`` of the polynomial problem (eq. 10), expanded."""
        return self.direct.polynomial(_index(n)).as_expr()

    def eigenfunction(self, n: int) -> sp.Expr:
        """Eigenfunction ``f_n``: ``P_n`` (``q0 = 0``) or ``g P~_n`` for a gauge problem."""
        poly = self.polynomial(n)
        return poly if self.gauge is None else self.gauge.factor * poly

    def leading_coefficient(self, n: int | sp.Expr = N) -> sp.Expr:
        """``k_n = c_n prod_{j<n} (p1~' + (n+j-1) p0''/2)``."""
        return self.closed.leading.subs(N, n)

    @cache  # noqa: B019 - one instance per problem
    def norm2(self, n: int | sp.Expr = N) -> sp.Expr:
        """``d_n^2 = ∫ f_n^2 w`` (eq. 7), closed form in ``n`` or its exact value."""
        if isinstance(n, sp.Basic) and not n.is_Integer:
            return self.norm_squared.subs(N, n)
        n = _index(n)
        if n < self.norm_start:
            return self.direct.norm2(n)
        return sp.simplify(gamma_simplify(self.norm_squared.subs(N, n)))

    def orthonormal_polynomial(self, n: int) -> sp.Expr:
        """``p_n = P_n / d_n`` (orthonormal in ``L^2(w~)``)."""
        return self.polynomial(n) / sp.sqrt(self.norm2(n))

    def orthonormal_function(self, n: int, frame: str = "functions") -> sp.Expr:
        """``psi_n = g p_n`` of a frame (see :mod:`slbasis.symbolic.ladder`)."""
        return self.frame_factor(frame) * self.orthonormal_polynomial(n)

    # ----- recurrences -------------------------------------------------------------------
    def recurrence(self) -> dict[str, sp.Expr]:
        """Closed forms: ``x P_n = alpha P_{n+1} + beta P_n + gamma P_{n-1}`` and the
        orthonormal ``x p_n = A_{n+1} p_{n+1} + B_n p_n + A_n p_{n-1}``."""
        alpha, beta, gamma = self.closed.recurrence
        return {
            "alpha": alpha,
            "beta": beta,
            "gamma": gamma,
            "A_next": self.closed.jacobi_offdiag,
            "B": self.closed.jacobi_diag,
        }

    def jacobi_matrix(self, size: int) -> sp.Matrix:
        """Exact ``size x size`` symmetric Jacobi matrix of multiplication by ``x``."""
        size = _index(size, "size")
        mat = sp.zeros(size, size)
        for n in range(size):
            mat[n, n] = self._value("B", n)
            if n + 1 < size:
                mat[n + 1, n] = mat[n, n + 1] = self._value("A_next", n)
        return mat

    # ----- frames, ladder operators, derivative operator ---------------------------------
    def frame_p1(self, frame: str = "functions") -> sp.Expr:
        """Effective ``p1f`` of a frame: ``p0'`` (functions), ``p1~`` (polynomials), ``p1``."""
        if frame == "functions":
            return sp.diff(self.p0, X)
        if frame == "polynomials":
            return self.p1_poly
        if frame == "eigenfunctions":
            return self.p1
        raise ValueError(f"frame must be one of {FRAMES}, got {frame!r}")

    def frame_factor(self, frame: str = "functions") -> sp.Expr:
        """``g`` with ``psi_n = g p_n``: ``sqrt(w~)``, ``1`` or the gauge factor."""
        if frame == "functions":
            return sp.sqrt(self.polynomial_weight)
        if frame == "polynomials":
            return sp.Integer(1)
        if frame == "eigenfunctions":
            return sp.Integer(1) if self.gauge is None else self.gauge.factor
        raise ValueError(f"frame must be one of {FRAMES}, got {frame!r}")

    @cached_property
    def ladder(self) -> LadderRelations:
        """Raising/lowering relations of the orthonormal polynomials (closed forms in n)."""
        return ladder_relations(self.closed)

    def ladder_operators(self, frame: str = "functions") -> dict[str, sp.Expr]:
        """First-order ladder operators on a frame as ``(coefficient of p0 d/dx, multiplier)``.

        ``a^† psi_n = raise_scale * (p0 psi_n' - raise_mult * psi_n) = psi_{n+1}`` and
        ``a psi_n = lower_scale * (p0 psi_n' - lower_mult * psi_n) = psi_{n-1}``.
        """
        rel = self.ladder
        shift = (self.p1_poly - self.frame_p1(frame)) / 2
        a_next = self.closed.jacobi_offdiag
        return {
            "raise_scale": sp.simplify(1 / (rel.raise_coef * a_next)),
            "raise_mult": sp.expand(rel.raise_mult + shift),
            "lower_scale": sp.simplify(a_next.subs(N, N - 1) / rel.lower_coef),
            "lower_mult": sp.expand(rel.lower_mult + shift),
        }

    def derivative_operator(
        self, frame: str = "functions", method: str = "commutator"
    ) -> dict[str, sp.Expr]:
        """Band coefficients (closed forms in ``n``) of ``2 p0 d/dx`` on a frame (eq. 11).

        ``2 p0 psi_n' = sub_n psi_{n-1} + diag_n psi_n + sup_n psi_{n+1}``; ``method`` is
        ``"commutator"`` (``(J Lambda - Lambda J) - p1f(J)``) or ``"ladder"`` (eq. 11 from the
        ladder relations); the two agree exactly (:meth:`verify` proves it).
        """
        return self.derivative_operator_form(frame, method).bands()

    def derivative_operator_form(
        self, frame: str = "functions", method: str = "commutator"
    ) -> BandedOperator:
        """The banded operator object behind :meth:`derivative_operator`."""
        p1f = self.frame_p1(frame)
        if method == "commutator":
            return commutator_form(self.closed, p1f)
        if method == "ladder":
            return ladder_form(self.closed, self.ladder, self.p1_poly, p1f)
        if method == "printed":
            if frame != "functions":
                raise ValueError("the printed eq. (11) is read on the orthonormal functions")
            return printed_eq11(self.closed, self.p1_poly, self.p0)
        raise ValueError(f"method must be 'commutator', 'ladder' or 'printed', got {method!r}")

    def derivative_matrix(self, size: int, frame: str = "functions") -> sp.Matrix:
        """Exact ``(size+1) x size`` matrix of ``2 p0 d/dx``: column ``n`` holds the
        coefficients of ``2 p0 psi_n'``.  The extra last row is what a square cut loses."""
        size = _index(size, "size")
        mat = sp.zeros(size + 1, size)
        for n in range(size):
            sub, diag, sup = self.derivative_band_values(n, frame)
            if n > 0:
                mat[n - 1, n] = sub
            mat[n, n] = diag
            mat[n + 1, n] = sup
        return mat

    def derivative_band_values(self, n: int, frame: str = "functions") -> tuple[sp.Expr, ...]:
        """Exact ``(sub_n, diag_n, sup_n)`` at integer ``n`` (direct at exceptional n)."""
        n = _index(n)
        if n in self.exceptional:
            return self._direct_bands(n, frame)
        form = self.derivative_operator_form(frame)

        def rational(expr: sp.Expr) -> sp.Expr:
            return sp.factor(sp.cancel(expr.subs(N, n)))

        sub = sp.Integer(0) if n == 0 else rational(form.sub_factor) * self._value("A_next", n - 1)
        return (sub, rational(form.diag), rational(form.sup_factor) * self._value("A_next", n))

    # ----- exact values at integer n, with the degenerate indices handled ----------------
    @cached_property
    def exceptional(self) -> frozenset[int]:
        """Indices ``n < 4`` at which a local closed form (``B_n``, ``A_{n+1}^2``,
        ``d_{n+1}^2/d_n^2``) degenerates through a cancelled factor.

        The closed forms divide by ``d + m a`` (``m = n-1 .. 2n``), ``lambda_n - lambda_{n-1}``
        and ``lambda_n - lambda_{n-2}``; for an admissible problem (``A_i > 0``) these vanish
        only for ``n <= 2`` (e.g. Chebyshev T, ``A1 + A2 = 1``: ``n = 0``), so comparing
        ``n < 4`` with direct computation finds every such index.  Empty for symbolic
        parameters (generic values).
        """
        if self._symbolic:
            return frozenset()
        return frozenset(n for n in range(_SMALL_N) if self._local_mismatch(n))

    @property
    def _symbolic(self) -> bool:
        syms = self.p0.free_symbols | self.p1_poly.free_symbols
        return any(s in self.params for s in syms)

    @cached_property
    def norm_start(self) -> int:
        """First index from which the norm product of :meth:`norm2` is valid."""
        bad = [n for n in self.exceptional if "norm_ratio" in self._local_mismatch(n)]
        return max(bad) + 1 if bad else 0

    @cached_property
    def norm_squared(self) -> sp.Expr:
        """Closed form of ``d_n^2`` in ``n`` (valid for ``n >= norm_start``)."""
        start = self.norm_start
        value = None if start == 0 else self.direct.norm2(start)
        return self.closed.norm_squared(start, value)

    def _local_mismatch(self, n: int) -> set[str]:
        """Names of the local closed forms that differ from direct computation at ``n``."""
        direct = self._direct_local(n)
        cf = self.closed
        closed = {
            "B": cf.jacobi_diag,
            "A_sq": cf.jacobi_offdiag_squared,
            "norm_ratio": cf.norm_ratio_free,
        }
        bad = set()
        for key, value in direct.items():
            if key == "A_sign":
                continue
            cval = closed[key].subs(N, n)
            if cval.has(sp.nan, sp.zoo) or sp.simplify(cval - value) != 0:
                bad.add(key)
        # the sign of A_{n+1} is the sign of c_{n+1}/c_n, which need not be constant
        # (Gegenbauer with lambda < 0: C_0 = 1 but the leading coefficients of C_n, n >= 1,
        # are negative)
        if self.closed.jacobi_sign != direct["A_sign"]:
            bad.add("A_sign")
        return bad

    def _direct_local(self, n: int) -> dict[str, sp.Expr]:
        """``B_n``, ``A_{n+1}^2`` and the standardisation-free ``d_{n+1}^2/d_n^2`` directly."""
        d = self.direct
        coeffs = d.orthonormal_coefficients(d.poly(X) * d.free(n), n, n + 1)
        return {
            "A_sign": sp.sign(sp.N(coeffs[n + 1], 30)),
            "B": coeffs[n],
            "A_sq": sp.factor(sp.cancel(coeffs[n + 1] ** 2)),
            "norm_ratio": sp.factor(sp.cancel(d.norm2_ratio(n + 1) / d.norm2_ratio(n))),
        }

    @cache  # noqa: B019 - one instance per problem
    def _value(self, key: str, n: int) -> sp.Expr:
        """Exact ``A_{n+1}`` (``"A_next"``) or ``B_n`` (``"B"``) at integer ``n``."""
        if n in self.exceptional:
            d = self.direct
            coeffs = d.orthonormal_coefficients(d.poly(X) * d.free(n), n, n + 1)
            return coeffs[n] if key == "B" else coeffs[n + 1]
        cf = self.closed
        if key == "B":
            return sp.factor(sp.cancel(cf.jacobi_diag.subs(N, n)))
        return cf.jacobi_sign * sp.sqrt(sp.factor(sp.cancel(cf.jacobi_offdiag_squared.subs(N, n))))

    def _direct_bands(self, n: int, frame: str) -> tuple[sp.Expr, ...]:
        """Bands of ``2 p0 d/dx`` at ``n`` by expanding ``2 p0 p_n' + (p1~ - p1f) p_n``."""
        d = self.direct
        q = d.free(n)
        image = 2 * d.p0 * q.diff(X) + d.poly(self.p1_poly - self.frame_p1(frame)) * q
        coeffs = d.orthonormal_coefficients(image, n, n + 1)
        return (sp.Integer(0) if n == 0 else coeffs[n - 1], coeffs[n], coeffs[n + 1])

    # ----- verification and reports ------------------------------------------------------
    def verify(self, nmax: int = 10):  # -> VerificationReport (import cycle avoided)
        """Run every check (ODE, orthogonality, textbook oracles, recurrences, eq. 11)."""
        from .verify import verify

        if nmax not in self._verified:
            self._verified[nmax] = verify(self, nmax=nmax)
        return self._verified[nmax]

    def report(self, fmt: str = "markdown", nmax: int = 6) -> str:
        """The derivation report (Markdown or LaTeX)."""
        from .report import render_report

        return render_report(self, fmt=fmt, nmax=nmax)


def _index(n: object, name: str = "n") -> int:
    if isinstance(n, bool) or not isinstance(n, int | sp.Integer):
        raise TypeError(f"{name} must be a non-negative integer, got {n!r}")
    n = int(n)
    if n < 0:
        raise ValueError(f"{name} must be a non-negative integer, got {n}")
    return n
