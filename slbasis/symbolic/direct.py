"""Exact computations for concrete ``n`` from first principles (the in-house oracle).

Nothing here uses the closed forms in ``n``: polynomials come from Rodrigues' formula
(seed eq. 10), norms from exact integrals of the weight (Euler integrals of its normal form),
and expansions from triangular solves on the monomial coefficients.  The verification
compares the closed forms against these values, and the closed forms fall back to them at
the few small ``n`` where a cancelled factor makes a closed form degenerate (Chebyshev T at
``n = 0``).

Rodrigues by polynomial recursion: ``(d/dx)^k (w p0^n) = w p0^(n-k) Q_k`` with
``Q_0 = 1``, ``Q_{k+1} = p0 Q_k' + (p1 + (n-k-1) p0') Q_k`` (differentiate and use
``w'/w = (p1 - p0')/p0``); so ``P_n = c_n Q_n`` with polynomial arithmetic only.
"""

from __future__ import annotations

from functools import lru_cache

import sympy as sp

from .parse import N, X
from .weight import WeightForm


class DirectComputation:
    """Exact ``P_n``, norms and expansions of a polynomial problem, for integer ``n``."""

    def __init__(self, p0: sp.Expr, p1: sp.Expr, standardization: sp.Expr, form: WeightForm):
        params = sorted((p0.free_symbols | p1.free_symbols) - {X}, key=str)
        self._gens = (X,)
        self._domain_syms = params
        self.p0 = sp.Poly(p0, X)
        self.p1 = sp.Poly(p1, X)
        self.c_n = sp.sympify(standardization)
        self.form = form
        self.rodrigues_poly = lru_cache(maxsize=None)(self._rodrigues_poly)
        self.norm2 = lru_cache(maxsize=None)(self._norm2)

    def _rodrigues_poly(self, n: int) -> sp.Poly:
        """``Q_n`` of the recursion above (``P_n`` with ``c_n = 1``)."""
        q = sp.Poly(1, X, domain=self.p0.domain.unify(self.p1.domain))
        dp0 = self.p0.diff(X)
        for k in range(n):
            q = self.p0 * q.diff(X) + (self.p1 + (n - k - 1) * dp0) * q
        return q

    def polynomial(self, n: int) -> sp.Poly:
        """``P_n = c_n / w (d/dx)^n (w p0^n)`` as a Poly."""
        return self.rodrigues_poly(n) * self.c_n.subs(N, n)

    def _norm2(self, n: int) -> sp.Expr:
        """``d_n^2 = ∫ P_n^2 w`` (seed eq. 7), exactly."""
        return self.form.integrate_polynomial(self.polynomial(n) ** 2)

    def expand(self, q: sp.Expr, degree: int) -> list[sp.Expr]:
        """Coefficients ``e_m`` with ``q = sum_{m<=degree} e_m P_m`` (triangular solve).

        Raises ``ValueError`` if ``q`` has degree above ``degree``.
        """
        rest = sp.Poly(sp.expand(q), X)
        if rest.degree() > degree:
            raise ValueError(f"cannot expand a degree-{rest.degree()} polynomial up to {degree}")
        coeffs: list[sp.Expr] = [sp.Integer(0)] * (degree + 1)
        for m in range(degree, -1, -1):
            pm = self.polynomial(m)
            lead = pm.coeff_monomial(X**m)
            coef = sp.cancel(rest.coeff_monomial(X**m) / lead)
            coeffs[m] = coef
            rest = sp.Poly(sp.expand(rest.as_expr() - coef * pm.as_expr()), X)
        if not rest.is_zero:
            raise ArithmeticError("expansion left a non-zero remainder")
        return coeffs
