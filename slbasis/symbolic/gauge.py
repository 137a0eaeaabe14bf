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
    """``f = g y`` maps the given problem onto the polynomial problem ``(p0, p1_poly)``."""

    p1_poly: sp.Expr  # p1~ of the polynomial problem
    log_derivative: sp.Expr  # h = g'/g
    shift: sp.Expr  # K, with lambda = lambda~ - K
    factor: sp.Expr  # g = exp(∫ h)
    weight_form: WeightForm  # of the polynomial problem
    alternatives: tuple[sp.Expr, ...] = ()  # other admissible p1~ (rare)


def find_gauge(p0: sp.Expr, p1: sp.Expr, q0: sp.Expr) -> Gauge:
    """Solve for the gauge that turns ``(p0, p1, q0)`` into a classical polynomial problem.

    Raises ``ValueError`` when no gauge with a linear ``p1~`` and constant ``K`` exists, or
    when none of the candidate polynomial problems has an orthogonality interval.
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
    p1_poly, hh, shift, form = candidates[0]
    factor = sp.simplify(sp.exp(sp.integrate(hh, X)))
    return Gauge(p1_poly, hh, shift, factor, form, tuple(c[0] for c in candidates[1:]))
