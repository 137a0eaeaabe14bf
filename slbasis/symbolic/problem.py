"""``SturmLiouville``: everything derivable from ``p0, p1, q0`` (eqs. 6-11 of the thesis
"Continuous-time system identification with functional basis expansions", §4)."""

from __future__ import annotations

import copy
from collections.abc import Iterable
from functools import cache, cached_property
from typing import TypeVar

import sympy as sp

from .closed_forms import ClosedForms, PolynomialData, gamma_simplify
from .direct import DirectComputation
from .expr import to_expression
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
_T = TypeVar("_T")
#: Indices below this are checked against direct computation (see :meth:`exceptional`).
_SMALL_N = 4


class SturmLiouville:
    """The eigenproblem ``p0 f'' + p1 f' - q0 f = -lambda f`` (eq. 8), derived exactly.

    Parameters
    ----------
    p0, p1 : str, number or sympy expression
        Polynomials in the independent variable; ``deg p0 <= 2`` and, for polynomial
        eigenfunctions, ``deg p1 <= 1``.
    q0 : str, number or sympy expression, default 0
        Polynomial or rational function; ``q0 != 0`` must be a gauge (Liouville) transform
        of a polynomial problem (e.g. ``p0=1, p1=0, q0=x**2``: Hermite functions).
    x : str or sympy.Symbol, optional
        The independent variable: the name used in the inputs *and* the symbol every
        returned expression is written in.  A symbol is used as given (its own
        assumptions), so ``expr.subs(my_x, 0.3)`` works; a string ``"t"`` means
        ``Symbol("t", real=True)``.  Default: ``Symbol("x", real=True)``.
    n : str or sympy.Symbol, optional
        The index symbol of closed forms in ``n`` (``eigenvalue()``, ``norm2()``, bands of
        ``derivative_operator()``).  A string means a non-negative integer symbol.
        Default: ``Symbol("n", integer=True, nonnegative=True)``.
    var : str or sympy.Symbol, default "x"
        Older spelling: names the variable in the inputs only; the outputs stay in the
        default ``x``.  Give ``x`` instead to get the outputs in your symbol.
    params : iterable of str or sympy.Symbol
        Parameter symbols (e.g. ``("alpha", "beta")``); symbols are kept as given.
    standardization : str or sympy expression, optional
        Rodrigues constant ``c_n`` of eq. (10) as an expression in ``n`` (and the
        parameters); default
        ``(-1)^n`` if ``p0 > 0`` on the interval (else ``1``), which makes every leading
        coefficient positive.
    name : str, optional
        Label used in reports.
    gauge : str or sympy expression, optional
        For ``q0 != 0`` with several admissible gauges (limit-circle endpoints), the ``p1~``
        of the polynomial problem to use; default: the most regular one.

    Notes
    -----
    Every public expression is written in :attr:`x` and :attr:`n`.  sympy treats two
    symbols with the same name but different assumptions as *different*, so substituting
    ``sp.Symbol("x")`` into an expression in the default real ``x`` silently changes nothing:
    substitute :attr:`x` (``prob.weight.subs(prob.x, 0.5)``) or pass your symbol as ``x=``.
    The derivation itself runs in the canonical symbols (:attr:`canonical`); the internal
    objects (:attr:`closed`, :attr:`direct`, :attr:`ladder`, :attr:`gauge`) stay in them.

    Closed forms in ``n`` hold for all ``n >= 0`` except the indices in
    :attr:`exceptional`, where a cancelled factor makes them degenerate; the per-``n``
    accessors (``norm2(3)``, ``jacobi_matrix(N)``, ...) handle those exactly.

    Examples
    --------
    >>> import sympy as sp
    >>> t = sp.Symbol("t")
    >>> prob = SturmLiouville("1 - t**2", "-2*t", x=t)   # Legendre in your own symbol
    >>> prob.eigenfunction(2)
    12*t**2 - 4
    >>> prob.eigenfunction(2).subs(t, sp.Rational(1, 2))
    -1
    >>> prob.eigenvalue()
    n**2 + n
    """

    def __init__(
        self,
        p0: Coefficient,
        p1: Coefficient,
        q0: Coefficient = 0,
        *,
        x: str | sp.Symbol | None = None,
        n: str | sp.Symbol | None = None,
        var: str | sp.Symbol | None = None,
        params: Iterable[str | sp.Symbol] = (),
        standardization: Coefficient | None = None,
        name: str | None = None,
        gauge: Coefficient | None = None,
    ) -> None:
        #: The symbol of the independent variable in every returned expression.
        self.x: sp.Symbol = _user_symbol(x, "x", X, real=True)
        #: The index symbol of every closed form in ``n``.
        self.n: sp.Symbol = _user_symbol(n, "n", N, integer=True, nonnegative=True)
        if self.x.name == self.n.name:
            raise ValueError(f"x and n must have different names, both are {self.x.name!r}")
        if var is not None and x is not None and _name(var) != self.x.name:
            raise ValueError(f"var={_name(var)!r} and x={self.x.name!r} name different variables")
        if var is None:
            var = self.x if x is not None else "x"
        params = tuple(params)
        if n is not None and any(_name(p) == self.n.name for p in params):
            raise ValueError(f"params: {self.n.name!r} is the index symbol n, not a parameter")
        self._user = {} if (self.x == X and self.n == N) else {X: self.x, N: self.n}
        self.coefficients = parse_coefficients(p0, p1, q0, var=var, params=params)
        c = self.coefficients
        self.params = c.params
        self.name = name or f"p0={self._out(c.p0)}, p1={self._out(c.p1)}" + (
            f", q0={self._out(c.q0)}" if c.q0 else ""
        )
        self.gauge: Gauge | None
        if c.q0 == 0:
            self.gauge = None
            self.weight_form: WeightForm = classify(c.p0, c.p1)
        else:
            prefer = None
            if gauge is not None:
                prefer = parse_coefficients(
                    c.p0, gauge, var=var, params=self.params, names=("p0", "gauge", "q0")
                ).p1
            self.gauge = find_gauge(c.p0, c.p1, c.q0, prefer)
            self.weight_form = self.gauge.weight_form
        self._p1_poly = c.p1 if self.gauge is None else self.gauge.p1_poly
        if standardization is None:
            self._standardization = (-sp.Integer(self.weight_form.p0_sign)) ** N
        else:
            local = {p.name: p for p in self.params} | {"n": N, self.n.name: N}
            std = to_expression(standardization, argument="standardization", symbols=local)
            self._standardization = std.subs({sp.Symbol("n"): N, self.n: N})
        self.closed = ClosedForms(
            PolynomialData.from_exprs(c.p0, self._p1_poly),
            self._standardization,
            self.weight_form.total_mass,
            self.weight_form.p0_sign,
        )
        self._verified: dict[int, object] = {}
        #: Textbook closed forms (set by the catalogue; used only by :meth:`verify`).
        self.oracle = None
        self.direct = DirectComputation(
            c.p0, self._p1_poly, self._standardization, self.weight_form
        )

    # ----- symbols -------------------------------------------------------------------------
    def _out(self, value: _T) -> _T:
        """``value`` (expression, matrix, tuple or dict of them) in the user's symbols."""
        if not self._user:
            return value
        if isinstance(value, dict):
            return {k: self._out(v) for k, v in value.items()}  # type: ignore[return-value]
        if isinstance(value, tuple):
            return tuple(self._out(v) for v in value)  # type: ignore[return-value]
        if isinstance(value, sp.Basic | sp.MatrixBase):
            return value.xreplace(self._user)  # type: ignore[return-value]
        return value

    @cached_property
    def canonical(self) -> SturmLiouville:
        """This problem with the canonical symbols (:data:`~slbasis.symbolic.parse.X`,
        :data:`~slbasis.symbolic.parse.N`): what verification, reports and code
        generation read.  ``self`` when the defaults are in use."""
        if not self._user:
            return self
        twin = copy.copy(self)
        twin.__dict__ = {
            k: v for k, v in self.__dict__.items() if k not in ("canonical", "_verified")
        }
        twin.x, twin.n, twin._user, twin._verified = X, N, {}, {}
        return twin

    @property
    def p0(self) -> sp.Expr:
        """``p0`` as parsed (a polynomial in :attr:`x`)."""
        return self._out(self.coefficients.p0)

    @property
    def p1(self) -> sp.Expr:
        """``p1`` as parsed (a polynomial in :attr:`x`)."""
        return self._out(self.coefficients.p1)

    @property
    def q0(self) -> sp.Expr:
        """``q0`` as parsed (a rational function of :attr:`x`)."""
        return self._out(self.coefficients.q0)

    @property
    def p1_poly(self) -> sp.Expr:
        """``p1`` of the underlying polynomial problem (``p1~``; equal to ``p1`` if ``q0 = 0``)."""
        return self._out(self._p1_poly)

    @property
    def standardization(self) -> sp.Expr:
        """The Rodrigues constant ``c_n`` of eq. (10), in :attr:`n`."""
        return self._out(self._standardization)

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
        return self._out(self.weight_form.interval)

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

        Each assumption ``param + c > 0`` linear in one parameter becomes ``param = u - c`` with
        ``u > 0``, so that sympy may simplify ``sqrt((alpha+1)^2) = alpha + 1``.

        Returns
        -------
        dict of sympy.Symbol to sympy expression
            The substitution (empty without such assumptions).

        Examples
        --------
        >>> from slbasis.families import families
        >>> families["jacobi"]().positive_substitution()
        {beta: beta_pos - 1, alpha: alpha_pos - 1}
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
        """Weight ``w~`` of the polynomial problem in normal form (eq. 9), in :attr:`x`."""
        return self._out(self.weight_form.weight)

    @cached_property
    def _weight(self) -> sp.Expr:
        if self.gauge is None:
            return self.weight_form.weight
        return sp.simplify(sp.powsimp(self.weight_form.weight / self.gauge.factor**2, force=True))

    @property
    def weight(self) -> sp.Expr:
        """Weight of *this* problem (eq. 9), in :attr:`x`; ``w = w~ / g^2`` for a gauge
        problem."""
        return self._out(self._weight)

    @property
    def is_gauge_transform(self) -> bool:
        """True when ``q0 != 0`` and the problem was recognised as a gauge transform."""
        return self.gauge is not None

    # ----- eigenvalues, eigenfunctions ---------------------------------------------------
    def _index_in(self, n: int | sp.Expr | None) -> int | sp.Expr:
        """An index argument with the user's ``n`` read as the canonical one."""
        if n is None:
            return N
        if isinstance(n, str):
            local = {p.name: p for p in self.params} | {self.n.name: self.n}
            n = to_expression(n, argument="n", symbols=local)
        n = sp.sympify(n, strict=True)
        return n.xreplace({self.n: N}) if self._user else n

    def eigenvalue(self, n: int | sp.Expr | None = None) -> sp.Expr:
        """``lambda_n = -n (p1~' + (n-1) p0''/2) - K`` (``K`` the gauge shift).

        Parameters
        ----------
        n : int, str or sympy expression, optional
            The index: an integer gives the exact value, a symbol or expression the closed form
            there; None: the closed form in :attr:`n`.

        Returns
        -------
        sympy expression
            The eigenvalue.

        Examples
        --------
        >>> p = SturmLiouville("1 - x**2", "-2*x")  # Legendre, default standardisation
        >>> p.eigenvalue(), p.eigenvalue(3)
        (n**2 + n, 12)
        """
        shift = 0 if self.gauge is None else self.gauge.shift
        return self._out(sp.expand(self.closed.eigenvalue(self._index_in(n)) - shift))

    def _polynomial(self, n: int) -> sp.Expr:
        return self.direct.polynomial(_index(n)).as_expr()

    def polynomial(self, n: int) -> sp.Expr:
        """Rodrigues polynomial ``P_n`` of the polynomial problem (eq. 10), expanded.

        Parameters
        ----------
        n : int
            The degree, ``>= 0``.

        Returns
        -------
        sympy expression
            ``P_n`` in :attr:`x`.

        Examples
        --------
        >>> p = SturmLiouville("1 - x**2", "-2*x")  # Legendre, default standardisation
        >>> p.polynomial(2)
        12*x**2 - 4
        """
        return self._out(self._polynomial(n))

    def eigenfunction(self, n: int) -> sp.Expr:
        """Eigenfunction ``f_n``: ``P_n`` (``q0 = 0``) or ``g P~_n`` for a gauge problem.

        Parameters
        ----------
        n : int
            The degree, ``>= 0``.

        Returns
        -------
        sympy expression
            ``f_n`` in :attr:`x`.
        """
        poly = self._polynomial(n)
        return self._out(poly if self.gauge is None else self.gauge.factor * poly)

    def leading_coefficient(self, n: int | sp.Expr | None = None) -> sp.Expr:
        """``k_n = c_n prod_{j<n} (p1~' + (n+j-1) p0''/2)``, the leading coefficient of ``P_n``.

        Parameters
        ----------
        n : int, str or sympy expression, optional
            The index: an integer gives the exact value, a symbol or expression the closed form
            there; None: the closed form in :attr:`n`.

        Returns
        -------
        sympy expression
            ``k_n``.
        """
        return self._out(self.closed.leading.subs(N, self._index_in(n)))

    def norm2(self, n: int | sp.Expr | None = None) -> sp.Expr:
        """``d_n^2 = int f_n^2 w`` (eq. 7), closed form in ``n`` or its exact value.

        Parameters
        ----------
        n : int, str or sympy expression, optional
            The index: an integer gives the exact value, a symbol or expression the closed form
            there; None: the closed form in :attr:`n`.

        Returns
        -------
        sympy expression
            The squared norm.

        Examples
        --------
        >>> p = SturmLiouville("1 - x**2", "-2*x")  # Legendre, default standardisation
        >>> p.norm2(2)  # int_{-1}^{1} (12 x^2 - 4)^2 dx
        128/5
        """
        return self._out(self._norm2(self._index_in(n)))

    @cache  # noqa: B019 - one instance per problem
    def _norm2(self, n: int | sp.Expr) -> sp.Expr:
        if isinstance(n, sp.Basic) and not n.is_Integer:
            return self._norm_squared.subs(N, n)
        n = _index(n)
        if n < self.norm_start:
            return self.direct.norm2(n)
        return sp.simplify(gamma_simplify(self._norm_squared.subs(N, n)))

    def _orthonormal_polynomial(self, n: int) -> sp.Expr:
        return self._polynomial(n) / sp.sqrt(self._norm2(n))

    def orthonormal_polynomial(self, n: int) -> sp.Expr:
        """``p_n = P_n / d_n`` (orthonormal in ``L^2(w~)``).

        Parameters
        ----------
        n : int
            The degree, ``>= 0``.

        Returns
        -------
        sympy expression
            ``p_n`` in :attr:`x`.

        Examples
        --------
        >>> p = SturmLiouville("1 - x**2", "-2*x")  # Legendre, default standardisation
        >>> p.orthonormal_polynomial(1)
        sqrt(6)*x/2
        """
        return self._out(self._orthonormal_polynomial(n))

    def orthonormal_function(self, n: int, frame: str = "functions") -> sp.Expr:
        """``psi_n = g p_n`` of a frame (see :mod:`slbasis.symbolic.ladder`).

        Parameters
        ----------
        n : int
            The degree, ``>= 0``.
        frame : {"functions", "polynomials", "eigenfunctions"}, optional
            The frame (:mod:`slbasis.symbolic.ladder`).

        Returns
        -------
        sympy expression
            ``psi_n`` in :attr:`x`.
        """
        return self._out(self._frame_factor(frame) * self._orthonormal_polynomial(n))

    # ----- recurrences -------------------------------------------------------------------
    def recurrence(self) -> dict[str, sp.Expr]:
        """Closed forms of the three-term recurrences.

        ``x P_n = alpha P_{n+1} + beta P_n + gamma P_{n-1}`` and the orthonormal ``x p_n =
        A_{n+1} p_{n+1} + B_n p_n + A_n p_{n-1}``.

        Returns
        -------
        dict of str to sympy expression
            ``alpha``, ``beta``, ``gamma``, ``A_next`` (``A_{n+1}``) and ``B`` (``B_n``), in
            :attr:`n`.

        Examples
        --------
        >>> p = SturmLiouville("1 - x**2", "-2*x")  # Legendre, default standardisation
        >>> p.recurrence()["A_next"]
        (n + 1)/(sqrt(2*n + 1)*sqrt(2*n + 3))
        """
        alpha, beta, gamma = self.closed.recurrence
        return self._out(
            {
                "alpha": alpha,
                "beta": beta,
                "gamma": gamma,
                "A_next": self.closed.jacobi_offdiag,
                "B": self.closed.jacobi_diag,
            }
        )

    def jacobi_matrix(self, size: int) -> sp.Matrix:
        """Exact ``size x size`` symmetric Jacobi matrix of multiplication by ``x``.

        Parameters
        ----------
        size : int
            Its size.

        Returns
        -------
        sympy.Matrix
            ``B_n`` on the diagonal, ``A_{n+1}`` beside it.

        Examples
        --------
        >>> p = SturmLiouville("1 - x**2", "-2*x")  # Legendre, default standardisation
        >>> p.jacobi_matrix(2)
        Matrix([
        [        0, sqrt(3)/3],
        [sqrt(3)/3,         0]])
        """
        size = _index(size, "size")
        mat = sp.zeros(size, size)
        for n in range(size):
            mat[n, n] = self._value("B", n)
            if n + 1 < size:
                mat[n + 1, n] = mat[n, n + 1] = self._value("A_next", n)
        return self._out(mat)

    # ----- frames, ladder operators, derivative operator ---------------------------------
    def _frame_p1(self, frame: str) -> sp.Expr:
        if frame == "functions":
            return sp.diff(self.coefficients.p0, X)
        if frame == "polynomials":
            return self._p1_poly
        if frame == "eigenfunctions":
            return self.coefficients.p1
        raise ValueError(f"frame must be one of {FRAMES}, got {frame!r}")

    def frame_p1(self, frame: str = "functions") -> sp.Expr:
        """Effective ``p1f`` of a frame: ``p0'`` (functions), ``p1~`` (polynomials), ``p1``.

        Parameters
        ----------
        frame : {"functions", "polynomials", "eigenfunctions"}, optional
            The frame (:mod:`slbasis.symbolic.ladder`).

        Returns
        -------
        sympy expression
            ``p1f`` in :attr:`x`.

        Raises
        ------
        ValueError
            If ``frame`` is unknown.
        """
        return self._out(self._frame_p1(frame))

    def _frame_factor(self, frame: str) -> sp.Expr:
        if frame == "functions":
            return sp.sqrt(self.weight_form.weight)
        if frame == "polynomials":
            return sp.Integer(1)
        if frame == "eigenfunctions":
            return sp.Integer(1) if self.gauge is None else self.gauge.factor
        raise ValueError(f"frame must be one of {FRAMES}, got {frame!r}")

    def frame_factor(self, frame: str = "functions") -> sp.Expr:
        """``g`` with ``psi_n = g p_n``: ``sqrt(w~)``, ``1`` or the gauge factor.

        Parameters
        ----------
        frame : {"functions", "polynomials", "eigenfunctions"}, optional
            The frame (:mod:`slbasis.symbolic.ladder`).

        Returns
        -------
        sympy expression
            ``g`` in :attr:`x`.

        Raises
        ------
        ValueError
            If ``frame`` is unknown.
        """
        return self._out(self._frame_factor(frame))

    @cached_property
    def ladder(self) -> LadderRelations:
        """Raising/lowering relations of the orthonormal polynomials (closed forms in the
        canonical ``n``)."""
        return ladder_relations(self.closed)

    def ladder_operators(self, frame: str = "functions") -> dict[str, sp.Expr]:
        """First-order ladder operators on a frame as ``(coefficient of p0 d/dx, multiplier)``.

        ``a^dagger psi_n = raise_scale (p0 psi_n' - raise_mult psi_n) = psi_{n+1}`` and ``a psi_n
        = lower_scale (p0 psi_n' - lower_mult psi_n) = psi_{n-1}``.

        Parameters
        ----------
        frame : {"functions", "polynomials", "eigenfunctions"}, optional
            The frame (:mod:`slbasis.symbolic.ladder`).

        Returns
        -------
        dict of str to sympy expression
            ``raise_scale``, ``raise_mult``, ``lower_scale``, ``lower_mult``.
        """
        rel = self.ladder
        shift = (self._p1_poly - self._frame_p1(frame)) / 2
        a_next = self.closed.jacobi_offdiag
        return self._out(
            {
                "raise_scale": sp.simplify(1 / (rel.raise_coef * a_next)),
                "raise_mult": sp.expand(rel.raise_mult + shift),
                "lower_scale": sp.simplify(a_next.subs(N, N - 1) / rel.lower_coef),
                "lower_mult": sp.expand(rel.lower_mult + shift),
            }
        )

    def derivative_operator(
        self, frame: str = "functions", method: str = "commutator"
    ) -> dict[str, sp.Expr]:
        """Band coefficients (closed forms in ``n``) of ``2 p0 d/dx`` on a frame (eq. 11).

        ``2 p0 psi_n' = sub_n psi_{n-1} + diag_n psi_n + sup_n psi_{n+1}``; the commutator form
        ``(J Lambda - Lambda J) - p1f(J)`` and eq. 11 from the ladder relations agree exactly
        (:meth:`verify` proves it).

        Parameters
        ----------
        frame : {"functions", "polynomials", "eigenfunctions"}, optional
            The frame (:mod:`slbasis.symbolic.ladder`).
        method : {"commutator", "ladder", "printed"}, optional
            Which derivation.

        Returns
        -------
        dict of str to sympy expression
            ``sub``, ``diag``, ``sup`` in :attr:`n`.

        Raises
        ------
        ValueError
            If ``frame`` or ``method`` is unknown.

        Examples
        --------
        >>> p = SturmLiouville("1 - x**2", "-2*x")  # Legendre, default standardisation
        >>> p.derivative_operator()["sub"]
        2*n*(n + 1)/sqrt(4*n**2 - 1)
        """
        return self._out(self.derivative_operator_form(frame, method).bands())

    def derivative_operator_form(
        self, frame: str = "functions", method: str = "commutator"
    ) -> BandedOperator:
        """The banded operator object behind :meth:`derivative_operator` (canonical symbols).

        Parameters
        ----------
        frame : {"functions", "polynomials", "eigenfunctions"}, optional
            The frame (:mod:`slbasis.symbolic.ladder`).
        method : {"commutator", "ladder", "printed"}, optional
            ``"printed"``: eq. (11) as printed, read on the orthonormal functions only.

        Returns
        -------
        BandedOperator
            The bands.

        Raises
        ------
        ValueError
            If ``method`` is unknown, or ``"printed"`` is asked for another frame.
        """
        p1f = self._frame_p1(frame)
        if method == "commutator":
            return commutator_form(self.closed, p1f)
        if method == "ladder":
            return ladder_form(self.closed, self.ladder, self._p1_poly, p1f)
        if method == "printed":
            if frame != "functions":
                raise ValueError("the printed eq. (11) is read on the orthonormal functions")
            return printed_eq11(self.closed, self._p1_poly, self.coefficients.p0)
        raise ValueError(f"method must be 'commutator', 'ladder' or 'printed', got {method!r}")

    def derivative_matrix(self, size: int, frame: str = "functions") -> sp.Matrix:
        """Exact ``(size+1) x size`` matrix of ``2 p0 d/dx``.

        Column ``n`` holds the coefficients of ``2 p0 psi_n'``.  The extra last row is what a
        square cut loses.

        Parameters
        ----------
        size : int
            Number of functions.
        frame : {"functions", "polynomials", "eigenfunctions"}, optional
            The frame (:mod:`slbasis.symbolic.ladder`).

        Returns
        -------
        sympy.Matrix
            The matrix.

        Examples
        --------
        >>> p = SturmLiouville("1 - x**2", "-2*x")  # Legendre, default standardisation
        >>> p.derivative_matrix(2)
        Matrix([
        [0,   4*sqrt(3)/3],
        [0,             0],
        [0, -4*sqrt(15)/15]])
        """
        size = _index(size, "size")
        mat = sp.zeros(size + 1, size)
        for n in range(size):
            sub, diag, sup = self._band_values(n, frame)
            if n > 0:
                mat[n - 1, n] = sub
            mat[n, n] = diag
            mat[n + 1, n] = sup
        return self._out(mat)

    def derivative_band_values(self, n: int, frame: str = "functions") -> tuple[sp.Expr, ...]:
        """Exact ``(sub_n, diag_n, sup_n)`` at integer ``n`` (direct at exceptional ``n``).

        Parameters
        ----------
        n : int
            The degree, ``>= 0``.
        frame : {"functions", "polynomials", "eigenfunctions"}, optional
            The frame (:mod:`slbasis.symbolic.ladder`).

        Returns
        -------
        tuple of sympy expressions
            The three bands at ``n``.
        """
        return self._out(self._band_values(n, frame))

    def _band_values(self, n: int, frame: str) -> tuple[sp.Expr, ...]:
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
        syms = self.coefficients.p0.free_symbols | self._p1_poly.free_symbols
        return any(s in self.params for s in syms)

    @cached_property
    def norm_start(self) -> int:
        """First index from which the norm product of :meth:`norm2` is valid."""
        bad = [n for n in self.exceptional if "norm_ratio" in self._local_mismatch(n)]
        return max(bad) + 1 if bad else 0

    @cached_property
    def _norm_squared(self) -> sp.Expr:
        start = self.norm_start
        value = None if start == 0 else self.direct.norm2(start)
        return self.closed.norm_squared(start, value)

    @property
    def norm_squared(self) -> sp.Expr:
        """Closed form of ``d_n^2`` in ``n`` (valid for ``n >= norm_start``)."""
        return self._out(self._norm_squared)

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
        image = 2 * d.p0 * q.diff(X) + d.poly(self._p1_poly - self._frame_p1(frame)) * q
        coeffs = d.orthonormal_coefficients(image, n, n + 1)
        return (sp.Integer(0) if n == 0 else coeffs[n - 1], coeffs[n], coeffs[n + 1])

    # ----- verification and reports ------------------------------------------------------
    def verify(self, nmax: int = 10):  # -> VerificationReport (import cycle avoided)
        """Run every check (ODE, orthogonality, textbook oracles, recurrences, eq. 11).

        Parameters
        ----------
        nmax : int, optional
            The largest degree checked.

        Returns
        -------
        VerificationReport
            The checks and their outcome (cached per ``nmax``).

        Examples
        --------
        >>> p = SturmLiouville("1 - x**2", "-2*x")  # Legendre, default standardisation
        >>> p.verify(4).ok
        True
        """
        from .verify import verify

        if nmax not in self._verified:
            self._verified[nmax] = verify(self.canonical, nmax=nmax)
        return self._verified[nmax]

    def report(self, fmt: str = "markdown", nmax: int = 6) -> str:
        """The derivation report (Markdown or LaTeX).

        Parameters
        ----------
        fmt : {"markdown", "latex"}, optional
            The format.
        nmax : int, optional
            List ``P_n`` for ``n <= nmax``.

        Returns
        -------
        str
            The report.
        """
        from .report import render_report

        return render_report(self.canonical, fmt=fmt, nmax=nmax)


def _index(n: object, name: str = "n") -> int:
    if isinstance(n, bool) or not isinstance(n, int | sp.Integer):
        raise TypeError(f"{name} must be a non-negative integer, got {n!r}")
    n = int(n)
    if n < 0:
        raise ValueError(f"{name} must be a non-negative integer, got {n}")
    return n


def _name(sym: str | sp.Symbol) -> str:
    return sym.name if isinstance(sym, sp.Symbol) else str(sym)


def _user_symbol(
    value: str | sp.Symbol | None, arg: str, default: sp.Symbol, **assumptions: bool
) -> sp.Symbol:
    """The user's symbol for ``arg``: a Symbol as given, a string with ``assumptions``."""
    if value is None:
        return default
    if isinstance(value, sp.Symbol):
        return value
    if isinstance(value, str) and value.isidentifier():
        return sp.Symbol(value, **assumptions)
    raise TypeError(f"{arg} must be a sympy Symbol or an identifier string, got {value!r}")
