"""Closed forms in the symbolic index ``n`` for ``p0 P'' + p1 P' + lambda P = 0``.

Notation: ``p0 = a x^2 + b x + c``, ``p1 = d x + e``; the Rodrigues polynomials (eq. 10)
``P_n = c_n / w * (d/dx)^n (w p0^n)`` with standardisation constants ``c_n``; leading
coefficients ``P_n = k_n x^n + k'_n x^(n-1) + k''_n x^(n-2) + ...``.

Derivations (each a few lines, each re-checked in :mod:`slbasis.symbolic.verify`):

* **Eigenvalue.**  The ``x^n`` coefficient of ``p0 P'' + p1 P'`` is
  ``k_n (a n(n-1) + d n)``, hence ``lambda_n = -n (d + (n-1) a) = -n (p1' + (n-1) p0''/2)``.
  (The summary prints ``p0'`` instead of ``p0''``; ``p0'`` is not constant when
  ``deg p0 = 2``, so the printed formula cannot be an eigenvalue.)
* **Leading coefficient.**  ``k_n = c_n prod_{j=0}^{n-1} (d + (n+j-1) a)`` (Nikiforov &
  Uvarov 1988, §3), so ``kappa_n = k_{n+1}/k_n = (c_{n+1}/c_n) (d+(2n-1)a)(d+2na)/(d+(n-1)a)``
  after the telescoping of the two products.
* **Sub-leading coefficients.**  The ``x^j`` coefficient of the ODE gives
  ``(lambda_n - lambda_j) k_j = -(j+1)(b j + e) k_{j+1} - c (j+1)(j+2) k_{j+2}``; with
  ``j = n-1, n-2`` this yields ``rho1 = k'_n/k_n`` and ``rho2 = k''_n/k_n``, rational in n.
* **Recurrence** ``x P_n = alpha_n P_{n+1} + beta_n P_n + gamma_n P_{n-1}``: compare the
  coefficients of ``x^(n+1), x^n, x^(n-1)``:
  ``alpha_n = 1/kappa_n``, ``beta_n = rho1(n) - rho1(n+1)``,
  ``gamma_n = (rho2(n) - rho2(n+1) - beta_n rho1(n)) kappa_(n-1)``.
* **Norms.**  ``<x P_n, P_{n+1}> = alpha_n d_{n+1}^2 = gamma_{n+1} d_n^2`` so
  ``d_n^2 = d_0^2 prod_{j<n} gamma_{j+1} kappa_j``; ``d_0^2 = ∫ w`` (Euler integral).
* **Orthonormal Jacobi matrix** ``x p_n = A_{n+1} p_{n+1} + B_n p_n + A_n p_{n-1}`` with
  ``p_n = P_n/d_n``: ``B_n = beta_n`` and ``A_{n+1} = alpha_n d_{n+1}/d_n``, i.e.
  ``A_{n+1}^2 = alpha_n gamma_{n+1}`` with the sign of ``alpha_n``.

All quantities split into a standardisation-free part (``c_n = 1``) times powers of
``c_{n+1}/c_n``, so every ``n``-dependence that matters for orthonormal objects is
*rational* in ``n`` up to one square root.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import sympy as sp

from .parse import N, X

_J = sp.Symbol("j", integer=True, nonnegative=True)


def gamma_simplify(expr: sp.Expr) -> sp.Expr:
    """Simplify ratios of Gamma functions whose arguments differ by integers.

    ``gammasimp`` alone misses ``Gamma(lambda + n + 3/2) / Gamma(lambda + n + 1/2)``;
    ``expand_func`` first peels the integer offsets off.

    Parameters
    ----------
    expr : sympy expression
        The expression.

    Returns
    -------
    sympy expression
        The simplified expression.

    Examples
    --------
    >>> import sympy as sp
    >>> lam, n = sp.symbols("lambda n", positive=True)
    >>> half = sp.Rational(1, 2)
    >>> gamma_simplify(sp.gamma(lam + n + 3 * half) / sp.gamma(lam + n + half))
    lambda + n + 1/2
    """
    return sp.gammasimp(sp.expand_func(expr))


def _simplify(expr: sp.Expr) -> sp.Expr:
    """Canonical form for rational expressions in n (fast and deterministic)."""
    return sp.factor(sp.cancel(sp.together(expr)))


@dataclass(frozen=True)
class PolynomialData:
    """The coefficients of ``p0 = a x^2 + b x + c`` and ``p1 = d x + e``.

    Attributes
    ----------
    a, b, c : sympy expression
        Coefficients of ``p0``.
    d, e : sympy expression
        Coefficients of ``p1``.
    """

    a: sp.Expr
    b: sp.Expr
    c: sp.Expr
    d: sp.Expr
    e: sp.Expr

    @classmethod
    def from_exprs(cls, p0: sp.Expr, p1: sp.Expr) -> PolynomialData:
        """The coefficients of two polynomials in :data:`~slbasis.symbolic.parse.X`.

        Parameters
        ----------
        p0 : sympy expression
            ``p0``, of degree at most 2.
        p1 : sympy expression
            ``p1``, of degree at most 1.

        Returns
        -------
        PolynomialData
            Their coefficients.
        """
        P0, P1 = sp.Poly(p0, X), sp.Poly(p1, X)
        return cls(
            P0.coeff_monomial(X**2),
            P0.coeff_monomial(X),
            P0.coeff_monomial(1),
            P1.coeff_monomial(X),
            P1.coeff_monomial(1),
        )


class ClosedForms:
    """Closed forms in ``n`` of a polynomial problem with standardisation ``c_n``
    (module docstring for the derivations).

    Parameters
    ----------
    coeffs : PolynomialData
        The coefficients of ``p0`` and ``p1``.
    standardization : sympy expression
        The Rodrigues constant ``c_n`` as an expression in ``n``.
    d0_squared : sympy expression
        ``d_0^2 = int w`` (Euler integral).
    p0_sign : int
        The sign of ``p0`` on the interval.

    Attributes
    ----------
    k : PolynomialData
        The coefficients.
    c_n : sympy expression
        The standardisation.
    d0_squared : sympy expression
        ``d_0^2``.
    p0_sign : int
        The sign of ``p0``.

    References
    ----------
    .. [1] A. F. Nikiforov and V. B. Uvarov, *Special Functions of Mathematical Physics*,
       Birkhauser, 1988, sec. 3.
    """

    def __init__(
        self,
        coeffs: PolynomialData,
        standardization: sp.Expr,
        d0_squared: sp.Expr,
        p0_sign: int,
    ):
        self.k = coeffs
        self.c_n = sp.sympify(standardization, strict=True)
        self.d0_squared = d0_squared
        self.p0_sign = p0_sign

    # ----- building blocks -------------------------------------------------------------
    def c(self, n: sp.Expr) -> sp.Expr:
        """Rodrigues standardisation constant ``c_n`` of eq. (10).

        Parameters
        ----------
        n : sympy expression
            The index.

        Returns
        -------
        sympy expression
            ``c_n``.
        """
        return self.c_n.subs(N, n)

    @cached_property
    def c_ratio(self) -> sp.Expr:
        """``c_{n+1}/c_n``."""
        return sp.simplify(gamma_simplify(self.c(N + 1) / self.c(N)))

    def eigenvalue(self, n: sp.Expr = N) -> sp.Expr:
        """``lambda_n = -n (p1' + (n-1) p0''/2)``.

        The ``x^n`` coefficient of ``p0 P'' + p1 P'`` is ``k_n (a n(n-1) + d n)``.

        Parameters
        ----------
        n : sympy expression, optional
            The index (default the symbol ``n``).

        Returns
        -------
        sympy expression
            ``lambda_n``, expanded.
        """
        k = self.k
        return sp.expand(-n * (k.d + (n - 1) * k.a))

    @cached_property
    def leading(self) -> sp.Expr:
        """``k_n = c_n prod_{j=0}^{n-1} (d + (n+j-1) a)`` in closed form."""
        k = self.k
        prod = sp.product(k.d + (N + _J - 1) * k.a, (_J, 0, N - 1))
        return self.c_n * prod

    @cached_property
    def kappa_free(self) -> sp.Expr:
        """``k_{n+1}/k_n`` for ``c_n = 1``: ``(d+(2n-1)a)(d+2na)/(d+(n-1)a)``."""
        k = self.k
        return _simplify((k.d + (2 * N - 1) * k.a) * (k.d + 2 * N * k.a) / (k.d + (N - 1) * k.a))

    @cached_property
    def kappa(self) -> sp.Expr:
        """``kappa_n = k_{n+1}/k_n``."""
        return self.c_ratio * self.kappa_free

    @cached_property
    def rho1(self) -> sp.Expr:
        """``k'_n / k_n`` (sub-leading over leading coefficient)."""
        k = self.k
        lam = self.eigenvalue
        return _simplify(-N * (k.b * (N - 1) + k.e) / (lam(N) - lam(N - 1)))

    @cached_property
    def rho2(self) -> sp.Expr:
        """``k''_n / k_n``."""
        k = self.k
        lam = self.eigenvalue
        num = -(N - 1) * (k.b * (N - 2) + k.e) * self.rho1 - k.c * N * (N - 1)
        return _simplify(num / (lam(N) - lam(N - 2)))

    # ----- three-term recurrence of the standard polynomials ----------------------------
    @cached_property
    def recurrence(self) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        """``(alpha, beta, gamma)``: ``x P_n = alpha P_{n+1} + beta P_n + gamma P_{n-1}``."""
        r1, r2 = self.rho1, self.rho2
        alpha = _simplify(1 / self.kappa)
        beta = _simplify(r1 - r1.subs(N, N + 1))
        gamma = _simplify((r2 - r2.subs(N, N + 1) - beta * r1) * self.kappa.subs(N, N - 1))
        return alpha, beta, gamma

    @cached_property
    def recurrence_free(self) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        """The recurrence for ``c_n = 1`` (standardisation-free rational functions of n)."""
        r1, r2 = self.rho1, self.rho2
        kap = self.kappa_free
        beta = _simplify(r1 - r1.subs(N, N + 1))
        gamma = _simplify((r2 - r2.subs(N, N + 1) - beta * r1) * kap.subs(N, N - 1))
        return _simplify(1 / kap), beta, gamma

    @cached_property
    def norm_ratio_free(self) -> sp.Expr:
        """``d_{n+1}^2 / d_n^2`` for ``c_n = 1``: ``gamma_{n+1} kappa_n`` (rational in n)."""
        _, _, gamma = self.recurrence_free
        return _simplify(gamma.subs(N, N + 1) * self.kappa_free)

    def norm_squared(self, start: int = 0, start_value: sp.Expr | None = None) -> sp.Expr:
        """``d_n^2 = (c_n/c_s)^2 d_s^2 prod_{s<=j<n} gamma_{j+1} kappa_j`` (eq. 7).

        ``<x P_n, P_{n+1}> = alpha_n d_{n+1}^2 = gamma_{n+1} d_n^2`` gives the ratio of
        successive norms.

        Parameters
        ----------
        start : int, optional
            ``s``: anchors the product above degenerate small indices (Chebyshev T: ``s = 1``).
        start_value : sympy expression, optional
            ``d_s^2`` (default ``d_0^2``).

        Returns
        -------
        sympy expression
            ``d_n^2`` in ``n`` (a product, simplified by the caller).
        """
        value = self.d0_squared if start_value is None else start_value
        prod = sp.product(self.norm_ratio_free.subs(N, _J), (_J, start, N - 1))
        return (self.c_n / self.c(start)) ** 2 * value * prod

    # ----- orthonormal three-term recurrence (the Jacobi matrix) -------------------------
    @cached_property
    def jacobi_offdiag_squared(self) -> sp.Expr:
        """``A_{n+1}^2 = alpha_n gamma_{n+1}`` (standardisation-free)."""
        alpha, _, gamma = self.recurrence_free
        return _simplify(alpha * gamma.subs(N, N + 1))

    @cached_property
    def jacobi_sign(self) -> sp.Expr:
        """Sign of ``A_{n+1}``: the sign of ``alpha_n = k_n/k_{n+1}``.

        Every factor ``d + m a`` (``m >= 0``) of ``k_n`` has the sign of ``-p0`` on the
        interval (``d = a (A1 + A2)`` with ``A_i > 0`` for Jacobi, ``d/b < 0`` for Laguerre,
        ``d/c < 0`` for Hermite), so ``sign(kappa_free) = -sign(p0)`` and the sign of
        ``A_{n+1}`` is ``-sign(p0) sign(c_{n+1}/c_n)``.
        """
        s_c = sp.sign(self.c_ratio)
        if not s_c.is_number:  # the standardisation's sign pattern is fixed: read it at n = 1
            s_c = sp.sign(self.c_ratio.subs(N, 1))
        return -self.p0_sign * s_c

    @cached_property
    def jacobi_offdiag(self) -> sp.Expr:
        """``A_{n+1}`` of ``x p_n = A_{n+1} p_{n+1} + B_n p_n + A_n p_{n-1}``."""
        return self.jacobi_sign * sp.sqrt(self.jacobi_offdiag_squared)

    @cached_property
    def jacobi_diag(self) -> sp.Expr:
        """``B_n = beta_n``."""
        return self.recurrence_free[1]
