"""Recognising ``q0 != 0`` problems as gauge (Liouville) transforms of polynomial problems.

Put ``f = g(x) y`` in ``p0 f'' + p1 f' - q0 f = -lambda f`` and divide by ``g``; with
``h = g'/g``:

``p0 y'' + (p1 + 2 p0 h) y' + (p0 (h' + h^2) + p1 h - q0) y = -lambda y``.

This is a classical polynomial problem ``p0 y'' + p1~ y' = -lambda~ y`` exactly when

* ``p1~ = p1 + 2 p0 h`` is a polynomial of degree <= 1, i.e. ``h = (p1~ - p1)/(2 p0)``, and
* ``p0 (h' + h^2) + p1 h - q0 = K`` is a constant; then ``lambda = lambda~ - K``.

Both conditions are polynomial identities in ``x`` after clearing denominators, so the
unknown ``p1~ = D x + E`` and ``K`` solve a small polynomial system.  Of its solutions we keep
those whose polynomial problem has an orthogonality interval (Bochner); e.g. for
``p0 = 1, p1 = 0, q0 = x^2`` the solutions are ``p1~ = ±2x`` and only ``-2x`` (Hermite,
``g = exp(-x^2/2)``, ``lambda = 2n + 1``) qualifies.  Since ``g^2 w = w~`` (``w, w~`` the weights
of eq. 9 for ``p1`` and ``p1~``), the eigenfunctions ``g P~_n`` are orthogonal in ``L^2(w)``
with the norms of the polynomial problem.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .parse import X
from .weight import NotClassicalError, WeightForm, classify


@dataclass(frozen=True)
class Gauge:
    """``f = g y`` maps the given problem onto the polynomial problem ``(p0, p1_poly)``.

    Attributes
    ----------
    p1_poly : sympy expression
        ``p1~`` of the polynomial problem.
    log_derivative : sympy expression
        ``h = g'/g``.
    shift : sympy expression
        ``K``, with ``lambda = lambda~ - K``.
    factor : sympy expression
        ``g = exp(int h)``.
    weight_form : WeightForm
        The weight of the polynomial problem.
    alternatives : tuple of sympy expressions
        Other admissible ``p1~`` (different boundary conditions; rare).
    """

    p1_poly: sp.Expr  # p1~ of the polynomial problem
    log_derivative: sp.Expr  # h = g'/g
    shift: sp.Expr  # K, with lambda = lambda~ - K
    factor: sp.Expr  # g = exp(∫ h)
    weight_form: WeightForm  # of the polynomial problem
    alternatives: tuple[sp.Expr, ...] = ()  # other admissible p1~ (rare)


def _exp_integral(h: sp.Expr, interval: tuple[sp.Expr, sp.Expr]) -> sp.Expr:
    """``g = exp(∫ h)`` written with bases that are positive on ``interval``.

    ``h`` is rational with denominator ``p0``: partial fractions give
    ``c/(x - r) -> |x - r|^c`` (``(x - r)^c`` left of the interval, ``(r - x)^c`` right of
    it) and a polynomial part integrated in the exponent.
    """
    left = interval[0]
    powers, rest = sp.Integer(1), sp.Integer(0)
    for term in sp.Add.make_args(sp.apart(sp.together(h), X)):
        num, den = sp.fraction(sp.together(term))
        den_poly = sp.Poly(den, X)
        if den_poly.degree() == 1 and not num.has(X):
            root = sp.solve(den, X)[0]
            c = sp.simplify(num / den_poly.LC())
            base = (X - root) if (left == -sp.oo or sp.simplify(root - left) <= 0) else (root - X)
            powers *= base**c
        else:
            rest += term
    return powers * sp.exp(sp.simplify(sp.integrate(rest, X))) if rest != 0 else powers


def find_gauge(p0: sp.Expr, p1: sp.Expr, q0: sp.Expr, prefer: sp.Expr | None = None) -> Gauge:
    """Solve for the gauge that turns ``(p0, p1, q0)`` into a classical polynomial problem.

    The unknown ``p1~ = D x + E`` and ``K`` solve a small polynomial system (module
    docstring).  With singular endpoints in the limit-circle case (rational ``q0``) several
    gauges may be admissible -- they are different boundary conditions, e.g. ``(1-x^2)^(1/4)
    U_n`` and ``(1-x^2)^(-1/4) T_n`` for ``q0 = 1/(4(1-x^2))`` -- and a problem may be
    admissible on two intervals.  The default has ``p0 > 0`` on its interval (eigenvalues
    bounded below) and is the most regular (largest weight exponents: the principal
    solutions at the endpoints, i.e. the Friedrichs extension); ``prefer`` selects another.

    Parameters
    ----------
    p0 : sympy expression
        ``p0`` in ``x``.
    p1 : sympy expression
        ``p1`` in ``x``.
    q0 : sympy expression
        ``q0`` in ``x``, non-zero.
    prefer : sympy expression, optional
        The ``p1~`` to select among the admissible ones.

    Returns
    -------
    Gauge
        The gauge, the others in :attr:`Gauge.alternatives`.

    Raises
    ------
    ValueError
        If no gauge with a linear ``p1~`` and constant ``K`` exists, none of the candidate
        polynomial problems has an orthogonality interval, or ``prefer`` is not admissible.

    References
    ----------
    .. [1] A. Zettl, *Sturm-Liouville Theory*, Mathematical Surveys and Monographs 121,
       AMS, 2005 (principal solutions and the Friedrichs extension).

    Examples
    --------
    The harmonic oscillator ``f'' - x^2 f = -lambda f`` is the Hermite problem in the gauge
    ``g = exp(-x^2 / 2)``:

    >>> import sympy as sp
    >>> from slbasis.symbolic.parse import X
    >>> gauge = find_gauge(sp.Integer(1), sp.Integer(0), X**2)
    >>> gauge.p1_poly, gauge.factor, gauge.shift
    (-2*x, exp(-x**2/2), -1)
    """
    D, E, K = sp.symbols("D_ E_ K_")
    h = (D * X + E - p1) / (2 * p0)
    residual = sp.together(p0 * (sp.diff(h, X) + h**2) + p1 * h - q0 - K)
    numerator = sp.expand(sp.numer(residual))
    equations = sp.Poly(numerator, X).coeffs()
    solutions = sp.solve(equations, [D, E, K], dict=True)
    candidates: list[tuple[sp.Expr, sp.Expr, sp.Expr, WeightForm]] = []
    reasons: list[str] = []
    for sol in solutions:
        if not all(v in sol for v in (D, E, K)):
            continue  # an under-determined branch is not a gauge of this form
        p1_poly = sp.expand(sol[D] * X + sol[E])
        if any(
            s.free_symbols - p0.free_symbols - p1.free_symbols - q0.free_symbols
            for s in sol.values()
        ):
            continue
        try:
            form = classify(p0, p1_poly)
        except NotClassicalError as exc:
            reasons.append(f"p1~ = {p1_poly}: {exc}")
            continue
        candidates.append((p1_poly, sp.simplify(h.subs(sol)), sp.simplify(sol[K]), form))
    if not candidates:
        detail = "; ".join(reasons) if reasons else "the gauge equations have no solution"
        raise ValueError(
            f"q0 = {q0} is not a gauge (Liouville) transform of a classical polynomial "
            f"problem with p0 = {p0}, p1 = {p1}: {detail}"
        )

    def regularity(candidate: tuple) -> tuple:
        # p0 > 0 on the interval first (eigenvalues bounded below), then the most regular
        data = candidate[3].data
        exps = [data[k] for k in ("A1", "A2", "A") if k in data]
        total = sp.Add(*exps) if exps else sp.Integer(0)
        return (candidate[3].p0_sign, float(total), str(candidate[0]))

    if prefer is not None:
        chosen = [c for c in candidates if sp.expand(c[0] - prefer) == 0]
        if not chosen:
            raise ValueError(
                f"gauge: p1~ = {prefer} is not admissible; admissible: "
                f"{[str(c[0]) for c in candidates]}"
            )
    else:
        try:
            chosen = sorted(candidates, key=regularity, reverse=True)
        except TypeError:  # symbolic exponents cannot be ordered: keep sympy's order
            chosen = candidates
    p1_poly, hh, shift, form = chosen[0]
    factor = _exp_integral(hh, form.interval)
    others = tuple(c[0] for c in candidates if c[0] != p1_poly)
    return Gauge(p1_poly, hh, shift, factor, form, others)
