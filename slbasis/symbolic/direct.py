"""Exact computations for concrete ``n`` from first principles (the in-house oracle).

Nothing here uses the closed forms in ``n``: polynomials come from Rodrigues' formula
(eq. 10), norms from exact integrals of the weight (Euler integrals of its normal form),
and expansions from triangular solves on the monomial coefficients.  The verification
compares the closed forms against these values, and the closed forms fall back to them at
the few small ``n`` where a cancelled factor makes a closed form degenerate (Chebyshev T at
``n = 0``).

Rodrigues by polynomial recursion: ``(d/dx)^k (w p0^n) = w p0^(n-k) Q_k`` with
``Q_0 = 1``, ``Q_{k+1} = p0 Q_k' + (p1 + (n-k-1) p0') Q_k`` (differentiate and use
``w'/w = (p1 - p0')/p0``); so ``P_n = c_n Q_n``.  All arithmetic is on the *free* polynomials
``Q_n`` (``c_n = 1``) with coefficients in the field of rational functions of the parameters,
so it stays fast for symbolic ``alpha, beta``; the constants ``c_n`` (which may hold Gamma
functions) enter only at the end, through ratios ``c_n/c_m`` and signs.
"""

from __future__ import annotations

from functools import cache, lru_cache

import sympy as sp

from .closed_forms import gamma_simplify
from .parse import N, X
from .weight import WeightForm


def _domain(*exprs: sp.Expr):
    params = sorted(set().union(*(e.free_symbols for e in exprs)) - {X}, key=str)
    try:
        dom = sp.QQ.frac_field(*params) if params else sp.QQ
        for e in exprs:
            sp.Poly(e, X, domain=dom)
        return dom
    except (sp.polys.polyerrors.PolynomialError, sp.polys.polyerrors.CoercionFailed):
        return sp.EX  # irrational constants: fall back to expression coefficients


def _ring(domain):
    """The polynomial ring under a fraction field (``QQ`` and ``EX`` are their own)."""
    return domain.get_ring() if domain.is_FractionField else domain


class DirectComputation:
    """Exact ``P_n``, norms and expansions of a polynomial problem, for integer ``n``.

    All arithmetic is on the free polynomials ``Q_n`` (``c_n = 1``) over the field of
    rational functions of the parameters (module docstring).

    Parameters
    ----------
    p0 : sympy expression
        ``p0`` in :data:`~slbasis.symbolic.parse.X`.
    p1 : sympy expression
        ``p1`` of the polynomial problem.
    standardization : sympy expression
        The Rodrigues constant ``c_n`` in ``n``.
    form : WeightForm
        The weight's normal form (:func:`~slbasis.symbolic.weight.classify`).

    Attributes
    ----------
    domain : sympy domain
        The coefficient field.
    p0, p1 : sympy.Poly
        The coefficients as polynomials.
    c_n : sympy expression
        The standardisation.
    form : WeightForm
        The weight's normal form.
    """

    def __init__(self, p0: sp.Expr, p1: sp.Expr, standardization: sp.Expr, form: WeightForm):
        self.domain = _domain(p0, p1)
        self.p0 = sp.Poly(p0, X, domain=self.domain)
        self.p1 = sp.Poly(p1, X, domain=self.domain)
        self.c_n = sp.sympify(standardization, strict=True)
        self.form = form
        self.free = lru_cache(maxsize=None)(self._free)
        # Integration runs in the polynomial ring of the parameters (no gcd per operation);
        # the normal-form data are rational numbers or polynomials in the parameters.
        self.ring = _ring(self.domain)
        self._ring_data = {k: self.ring.from_sympy(v) for k, v in form.data.items()}
        self.norm2_ratio = lru_cache(maxsize=None)(self._norm2_ratio)

    def poly(self, expr: sp.Expr) -> sp.Poly:
        """``expr`` as a Poly in ``x`` over the working domain.

        Parameters
        ----------
        expr : sympy expression
            A polynomial in ``x``.

        Returns
        -------
        sympy.Poly
            The polynomial.
        """
        return sp.Poly(sp.expand(expr), X, domain=self.domain)

    def _free(self, n: int) -> sp.Poly:
        """``Q_n = P_n / c_n`` by the recursion above."""
        q = sp.Poly(1, X, domain=self.domain)
        dp0 = self.p0.diff(X)
        for k in range(n):
            q = self.p0 * q.diff(X) + (self.p1 + (n - k - 1) * dp0) * q
        return q

    @cache  # noqa: B019 - one instance per problem
    def c(self, n: int) -> sp.Expr:
        """``c_n`` at integer ``n``.

        Parameters
        ----------
        n : int
            The degree.

        Returns
        -------
        sympy expression
            The constant, Gamma ratios simplified.
        """
        return gamma_simplify(self.c_n.subs(N, n))

    def polynomial(self, n: int) -> sp.Poly:
        """``P_n = c_n / w (d/dx)^n (w p0^n)`` as a Poly (expression coefficients).

        Parameters
        ----------
        n : int
            The degree.

        Returns
        -------
        sympy.Poly
            ``P_n``.
        """
        return sp.Poly(self.free(n).as_expr() * self.c(n), X)

    def _norm2_ratio(self, n: int) -> sp.Expr:
        """``∫ Q_n^2 w / ∫ w`` (rational in the parameters)."""
        return self.integrate(self.free(n) ** 2)

    @cache  # noqa: B019 - one instance per problem
    def norm2(self, n: int) -> sp.Expr:
        """``d_n^2 = int P_n^2 w`` (eq. 7), exactly.

        Parameters
        ----------
        n : int
            The degree.

        Returns
        -------
        sympy expression
            The squared norm.
        """
        return gamma_simplify(self.c(n) ** 2 * self.form.total_mass * self.norm2_ratio(n))

    def integrate(self, poly: sp.Poly) -> sp.Expr:
        """``int poly w / int w`` exactly, for a Poly over the working domain.

        In the normal-form variable ``t`` (``x = shift + scale t``) the moment ratios are
        products ``M_i = prod_{j<=i} a_j / b_j`` (ratios of Euler integrals, Pochhammer
        symbols): ``a_j/b_j = (A1+j-1)/(A1+A2+j-1)`` (Jacobi), ``(A+j-1)/s`` (Laguerre); Hermite
        has ``M_odd = 0`` and ``M_{2j} = M_{2j-2} (2j-1)/(2s)``.  Summing over the common
        denominator ``prod b_j`` keeps every step polynomial in the parameters, with a single
        division at the end (a fraction-field sum would compute a gcd per term).

        Parameters
        ----------
        poly : sympy.Poly
            The polynomial.

        Returns
        -------
        sympy expression
            The normalised integral, rational in the parameters.
        """
        dom, d, kind = self.ring, self._ring_data, self.form.kind
        if kind == "jacobi":
            shift, scale = d["r1"], d["r2"] - d["r1"]
        elif kind == "laguerre":
            shift, scale = d["r"], d["side"]
        else:
            shift, scale = d["m"], dom.one
        variable = sp.Poly(dom.to_sympy(shift) + dom.to_sympy(scale) * X, X, domain=dom)
        coeffs = poly.set_domain(dom).compose(variable).all_coeffs()[::-1]  # c_0..c_K in t
        if kind == "hermite":
            coeffs = coeffs[::2]
            factors = [(dom.convert(2 * j - 1), 2 * d["s"]) for j in range(1, len(coeffs))]
        elif kind == "jacobi":
            factors = [(d["A1"] + j - 1, d["A1"] + d["A2"] + j - 1) for j in range(1, len(coeffs))]
        else:
            factors = [(d["A"] + j - 1, d["s"]) for j in range(1, len(coeffs))]
        tail = [dom.one] * len(coeffs)  # tail[i] = prod_{j > i} b_j
        for i in range(len(coeffs) - 2, -1, -1):
            tail[i] = tail[i + 1] * factors[i][1]
        total, head = dom.zero, dom.one  # head = prod_{j <= i} a_j
        for i, c in enumerate(coeffs):
            if i:
                head = head * factors[i - 1][0]
            if c:
                total += dom.convert(c) * head * tail[i]
        return sp.factor(sp.cancel(dom.to_sympy(total) / dom.to_sympy(tail[0])))

    def expand_free(self, q: sp.Poly, degree: int) -> list[sp.Expr]:
        """Coefficients ``e_m`` with ``q = sum_{m<=degree} e_m Q_m`` (triangular solve).

        Parameters
        ----------
        q : sympy.Poly
            The polynomial.
        degree : int
            The largest ``m``, at least ``deg q``.

        Returns
        -------
        list of sympy expressions
            ``e_0, ..., e_degree``.

        Raises
        ------
        ValueError
            If ``deg q > degree``.
        ArithmeticError
            If the expansion leaves a non-zero remainder.
        """
        if q.degree() > degree:
            raise ValueError(f"cannot expand a degree-{q.degree()} polynomial up to {degree}")
        coeffs: list[sp.Expr] = [sp.Integer(0)] * (degree + 1)
        rest = q
        for m in range(degree, -1, -1):
            qm = self.free(m)
            coef = sp.cancel(rest.nth(m) / qm.LC())
            coeffs[m] = coef
            if coef != 0:
                rest = rest - qm * sp.Poly(coef, X, domain=self.domain)
        if not rest.is_zero:
            raise ArithmeticError("expansion left a non-zero remainder")
        return coeffs

    def orthonormal_coefficients(self, q: sp.Poly, n: int, degree: int) -> list[sp.Expr]:
        """Coefficients on ``p_m`` of the image ``q`` of ``Q_n`` under a linear map ``T``:
        ``<p_m, T p_n>``.

        ``T p_n = (c_n/d_n) T Q_n = sum_m e_m (c_n/c_m)(d_m/d_n) p_m`` and ``d_m = |c_m|
        dfree_m``, so the coefficient is ``e_m sign(c_n c_m) sqrt(dfree_m^2 / dfree_n^2)``.

        Parameters
        ----------
        q : sympy.Poly
            The image of ``Q_n``.
        n : int
            The degree of the function mapped.
        degree : int
            The largest ``m``.

        Returns
        -------
        list of sympy expressions
            The coefficients on ``p_0, ..., p_degree``.
        """
        coeffs = self.expand_free(q, degree)
        out = []
        for m, e in enumerate(coeffs):
            if e == 0:
                out.append(sp.Integer(0))
                continue
            sign = self.sign_c(n) * self.sign_c(m)
            ratio = sp.factor(sp.cancel(self.norm2_ratio(m) / self.norm2_ratio(n)))
            out.append(sign * e * sp.sqrt(ratio))
        return out

    def sign_c(self, n: int) -> int:
        """Sign of ``c_n`` (read at a sample point for symbolic parameters).

        Parameters
        ----------
        n : int
            The degree.

        Returns
        -------
        int
            ``1`` or ``-1``.
        """
        value = self.c(n)
        if value.is_positive:
            return 1
        if value.is_negative:
            return -1
        syms = sorted(value.free_symbols, key=str)
        sample = {s: sp.Rational(1, 3) + sp.Rational(i, 7) for i, s in enumerate(syms)}
        return 1 if sp.N(value.subs(sample)) > 0 else -1
