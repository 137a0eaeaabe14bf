"""Weight, interval and class of a polynomial eigenproblem ``p0 P'' + p1 P' = -lambda P``.

The weight of eq. (9), ``w = exp(∫ p1/p0 dx) / p0``, is fixed only up to a constant
factor and a sign.  We take the positive multiple in *normal form*:

=========  ==========================  ============================================
class      ``p0``                      ``w`` on the interval
=========  ==========================  ============================================
hermite    ``c`` (degree 0)            ``exp(-s (x - m)^2)`` on ``(-oo, oo)``
laguerre   ``b (x - r)`` (degree 1)    ``|x - r|^(A-1) exp(-s |x - r|)`` on ``(r, oo)``
                                       or ``(-oo, r)``
jacobi     ``a (x - r1)(x - r2)``      ``(x - r1)^(A1-1) (r2 - x)^(A2-1)`` on ``(r1, r2)``
=========  ==========================  ============================================

with ``A_i = p1(r_i) / p0'(r_i)`` the residues of ``p1/p0`` at the roots of ``p0``.  This
reproduces the textbook weights (``e^{-x^2}``, ``x^α e^{-x}``, ``(1-x)^α (1+x)^β``).

An interval qualifies when every polynomial has a finite weighted integral and the boundary
terms ``p0 w f g`` of Green's identity vanish for polynomial ``f, g`` — i.e. all exponents
``A_i > 0`` and Gaussian/exponential decay at infinite ends.  Any other ``(p0, p1)`` (double
or complex roots of ``p0``, no decay at infinity, ``A_i <= 0``) has no such interval: that
is Bochner's classification, and such input gets a ``ValueError`` saying which condition
fails (e.g. the Bessel polynomials ``p0 = x^2, p1 = 2x + 2``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import sympy as sp

from .parse import X


class NotClassicalError(ValueError):
    """``(p0, p1)`` admits no interval with a positive weight and vanishing boundary terms."""


def _sign(expr: sp.Expr, what: str, assumptions: list[sp.Expr]) -> int:
    """+1 / -1 when decidable; otherwise assume positive and record the assumption."""
    expr = sp.simplify(expr)
    if expr.is_positive:
        return 1
    if expr.is_negative:
        return -1
    if expr.is_zero:
        raise NotClassicalError(f"{what} is zero")
    assumptions.append(expr)
    return 1


def _require_positive(expr: sp.Expr, message: str, assumptions: list[sp.Expr]) -> None:
    expr = sp.simplify(expr)
    if expr.is_positive:
        return
    if expr.is_positive is False:
        raise NotClassicalError(message + f" (here {expr} <= 0)")
    assumptions.append(expr)


@dataclass(frozen=True)
class WeightForm:
    """The weight in normal form, its interval and the data needed for exact moments.

    Attributes
    ----------
    kind : {"hermite", "laguerre", "jacobi"}
        The class.
    interval : tuple of sympy expressions
        The orthogonality interval.
    weight : sympy expression
        The weight ``w`` (eq. 9).
    p0_sign : int
        The sign of ``p0`` on the interval.
    data : dict of str to sympy expression
        Normal-form data (``s, m`` | ``r, A, s, side`` | ``r1, r2, A1, A2``).
    endpoints : tuple of str
        Boundary behaviour, human readable.
    assumptions : tuple of sympy expressions
        Expressions assumed ``> 0`` (conditions on symbolic parameters).
    """

    kind: str  # "hermite" | "laguerre" | "jacobi"
    interval: tuple[sp.Expr, sp.Expr]
    weight: sp.Expr
    p0_sign: int  # sign of p0 on the interval
    data: dict[str, sp.Expr]  # s, m | r, A, s, side | r1, r2, A1, A2
    endpoints: tuple[str, str]  # boundary behaviour, human readable
    assumptions: tuple[sp.Expr, ...] = field(default=())  # each assumed > 0

    @cached_property
    def total_mass(self) -> sp.Expr:
        """``d_0^2 = ∫ w dx``, by Euler's integrals of the normal form.

        ``∫_0^1 t^(p-1)(1-t)^(q-1) dt = Γ(p)Γ(q)/Γ(p+q)``, ``∫_0^oo y^(p-1) e^(-s y) dy =
        Γ(p)/s^p``, ``∫ e^(-s y^2) dy = sqrt(pi/s)``.  Independent of the Sturm–Liouville theory.
        """
        d = self.data
        if self.kind == "jacobi":
            a1, a2 = d["A1"], d["A2"]
            length = d["r2"] - d["r1"]
            return length ** (a1 + a2 - 1) * sp.gamma(a1) * sp.gamma(a2) / sp.gamma(a1 + a2)
        if self.kind == "laguerre":
            return sp.gamma(d["A"]) / d["s"] ** d["A"]
        return sp.sqrt(sp.pi / d["s"])


def classify(p0: sp.Expr, p1: sp.Expr) -> WeightForm:
    """Weight, interval and class of ``p0 P'' + p1 P' = -lambda P`` (eq. 9).

    The weight solves ``(p0 w)' = p1 w``; by Bochner's classification a problem has
    polynomial eigenfunctions orthogonal on an interval only in the Hermite, Laguerre and
    Jacobi classes, told apart by the degree and roots of ``p0``.

    Parameters
    ----------
    p0 : sympy expression
        Polynomial of degree at most 2.
    p1 : sympy expression
        Polynomial of degree at most 1.

    Returns
    -------
    WeightForm
        The weight in normal form.

    Raises
    ------
    NotClassicalError
        A ``ValueError`` with the failing condition, when the problem has no polynomial
        eigenfunctions orthogonal on an interval.

    References
    ----------
    .. [1] S. Bochner, "Uber Sturm-Liouvillesche Polynomsysteme", *Math. Z.* 29, 730-736,
       1929.

    Examples
    --------
    >>> from slbasis.symbolic.parse import X
    >>> w = classify(1 - X**2, -2 * X)  # Legendre
    >>> w.kind, w.interval, w.weight, w.total_mass
    ('jacobi', (-1, 1), 1, 2)
    """
    P0, P1 = sp.Poly(p0, X), sp.Poly(p1, X)
    deg0, deg1 = P0.degree(), P1.degree()
    if deg0 > 2:
        raise NotClassicalError(
            f"deg p0 = {deg0} > 2: p0 {p0} must have degree at most 2 for polynomial "
            "eigenfunctions (eq. 10)"
        )
    if deg1 > 1:
        raise NotClassicalError(
            f"deg p1 = {deg1} > 1: p1 = {p1} must have degree at most 1 for polynomial "
            "eigenfunctions (eq. 10)"
        )
    d = P1.coeff_monomial(X)
    e = P1.coeff_monomial(1)
    assumptions: list[sp.Expr] = []
    if deg0 == 0:
        c = P0.coeff_monomial(1)
        if d == 0:
            raise NotClassicalError(
                f"p0 = {p0} is constant and p1 = {p1} has no x term: the weight "
                "exp(∫p1/p0) does not decay at ±oo, so no orthogonality interval exists"
            )
        s = sp.simplify(-d / (2 * c))
        _require_positive(
            s, "p1'/p0 must be negative so that the weight decays like a Gaussian", assumptions
        )
        m = sp.simplify(-e / d)
        weight = sp.exp(-s * (X - m) ** 2)
        return WeightForm(
            "hermite",
            (-sp.oo, sp.oo),
            weight,
            _sign(c, "p0", assumptions),
            {"s": s, "m": m},
            ("Gaussian decay at -oo", "Gaussian decay at +oo"),
            tuple(assumptions),
        )
    if deg0 == 1:
        b = P0.coeff_monomial(X)
        r = sp.simplify(-P0.coeff_monomial(1) / b)
        if d == 0:
            raise NotClassicalError(
                f"p0 = {p0} is linear and p1 = {p1} has no x term: the weight is a power "
                "of |x - r| without exponential decay, so not every polynomial is "
                "square integrable"
            )
        ratio = sp.simplify(d / b)
        side = -_sign(ratio, "p1'/p0'", assumptions)  # +1: (r, oo); -1: (-oo, r)
        a_exp = sp.simplify(P1.as_expr().subs(X, r) / b)
        _require_positive(
            a_exp,
            f"the exponent A = p1(r)/p0'(r) at the root r = {r} of p0 must be positive for "
            "an integrable weight with vanishing boundary terms",
            assumptions,
        )
        s = sp.simplify(side * -ratio)
        interval = (r, sp.oo) if side > 0 else (-sp.oo, r)
        dist = (X - r) if side > 0 else (r - X)
        weight = dist ** (a_exp - 1) * sp.exp(-s * dist)
        p0_sign = _sign(b * side, "p0 on the interval", assumptions)
        ends = (f"w ~ |x - ({r})|^({a_exp - 1}), p0 w -> 0", "exponential decay")
        return WeightForm(
            "laguerre",
            interval,
            weight,
            p0_sign,
            {"r": r, "A": a_exp, "s": s, "side": sp.Integer(side)},
            ends if side > 0 else ends[::-1],
            tuple(assumptions),
        )
    a = P0.LC()
    disc = sp.simplify(P0.coeff_monomial(X) ** 2 - 4 * a * P0.coeff_monomial(1))
    if disc.is_zero:
        raise NotClassicalError(
            f"p0 = {p0} has a double root: the weight has an essential singularity there "
            "and only power growth at infinity, so no interval carries all polynomials "
            "(e.g. the Bessel polynomials p0 = x**2, p1 = 2*x + 2)"
        )
    if disc.is_negative:
        raise NotClassicalError(
            f"p0 = {p0} has no real roots: the weight on the real line decays only like a "
            "power of x, so not every polynomial is square integrable (Romanovski case)"
        )
    roots = sp.Poly(P0, X).all_roots() if not P0.free_symbols - {X} else sp.solve(p0, X)
    if len(roots) != 2:
        raise NotClassicalError(f"could not find the two real roots of p0 = {p0}")
    r1, r2 = roots
    order = sp.simplify(r2 - r1)
    if order.is_negative:
        r1, r2 = r2, r1
    elif not order.is_positive:
        raise NotClassicalError(
            f"cannot order the roots {r1}, {r2} of p0 = {p0}: give numeric values to the "
            "parameters in p0"
        )
    dp0 = sp.diff(p0, X)
    a1 = sp.simplify(p1.subs(X, r1) / dp0.subs(X, r1))
    a2 = sp.simplify(p1.subs(X, r2) / dp0.subs(X, r2))
    for root, expo in ((r1, a1), (r2, a2)):
        _require_positive(
            expo,
            f"the exponent A = p1(r)/p0'(r) at the root r = {root} of p0 must be positive "
            "for an integrable weight with vanishing boundary terms (Jacobi: alpha, beta > -1)",
            assumptions,
        )
    weight = (X - r1) ** (a1 - 1) * (r2 - X) ** (a2 - 1)
    return WeightForm(
        "jacobi",
        (r1, r2),
        weight,
        _sign(-a, "p0 on (r1, r2)", assumptions),
        {"r1": r1, "r2": r2, "A1": a1, "A2": a2},
        (f"w ~ (x - ({r1}))^({a1 - 1}), p0 w -> 0", f"w ~ ({r2} - x)^({a2 - 1}), p0 w -> 0"),
        tuple(assumptions),
    )
