"""Parsing and validating the coefficients ``p0, p1, q0`` of the eigenproblem (eq. 8).

``p0(x) f'' + p1(x) f' - q0(x) f = -lambda f``.  ``p0`` and ``p1`` must be polynomials in the
independent variable; ``q0`` a polynomial or a rational function (rational ``q0`` arise from
the Liouville normal form of Jacobi-type problems).  Everything is converted to the one
canonical real symbol :data:`X`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import sympy as sp

from .expr import check_symbol_name, to_expression

#: The canonical independent variable of every derivation.
X = sp.Symbol("x", real=True)
#: The canonical (non-negative integer) index of eigenfunctions.
N = sp.Symbol("n", integer=True, nonnegative=True)

Coefficient = str | int | float | sp.Expr


@dataclass(frozen=True)
class Coefficients:
    """Validated coefficients, polynomials in :data:`X` with the parameters as symbols.

    Attributes
    ----------
    p0 : sympy expression
        Polynomial of degree at most 2.
    p1 : sympy expression
        Polynomial.
    q0 : sympy expression
        Rational function.
    params : tuple of sympy.Symbol
        The parameter symbols.
    """

    p0: sp.Expr
    p1: sp.Expr
    q0: sp.Expr
    params: tuple[sp.Symbol, ...]

    def poly(self, which: str) -> sp.Poly:
        """``p0`` or ``p1`` as a :class:`sympy.Poly` in ``x`` (parameters in the domain).

        Parameters
        ----------
        which : {"p0", "p1"}
            The coefficient.

        Returns
        -------
        sympy.Poly
            The polynomial.
        """
        return sp.Poly(getattr(self, which), X)


def parse_coefficients(
    p0: Coefficient,
    p1: Coefficient,
    q0: Coefficient = 0,
    *,
    var: str | sp.Symbol = "x",
    params: Iterable[str | sp.Symbol] = (),
    names: tuple[str, str, str] = ("p0", "p1", "q0"),
) -> Coefficients:
    """Convert and validate ``p0, p1, q0``.

    Any free symbol other than the variable and the declared parameters is an error, so
    that ``p0="1 - t**2"`` without ``var="t"`` is caught.  Strings are read by the safe
    parser :func:`slbasis.symbolic.expr.parse_expression` (never evaluated as Python).

    Parameters
    ----------
    p0 : str, number or sympy expression
        Polynomial in the variable.
    p1 : str, number or sympy expression
        Polynomial in the variable.
    q0 : str, number or sympy expression, optional
        Rational function of the variable.
    var : str or sympy.Symbol, optional
        The independent variable used in the inputs (the outputs are in :data:`X`).
    params : iterable of str or sympy.Symbol, optional
        The symbols that are parameters (e.g. Jacobi's ``alpha, beta``): identifiers
        without ``__`` (generated code uses them).
    names : tuple of str, optional
        The argument names used in error messages.

    Returns
    -------
    Coefficients
        The validated coefficients.

    Raises
    ------
    ValueError
        If ``p0`` or ``p1`` is not a polynomial in the variable, ``q0`` is not rational in
        it, an undeclared symbol appears, a parameter is the variable or an invalid name, or
        a string is outside the grammar of the safe parser.

    Examples
    --------
    >>> c = parse_coefficients("1 - t**2", "-2*t", var="t")
    >>> c.p0, c.p1
    (1 - x**2, -2*x)
    """
    var_name = var.name if isinstance(var, sp.Symbol) else str(var)
    param_syms = []
    local: dict[str, sp.Symbol] = {}
    for prm in params:
        sym = prm if isinstance(prm, sp.Symbol) else sp.Symbol(str(prm), real=True)
        check_symbol_name(sym.name, "params")
        if sym.name == var_name:
            raise ValueError(f"params: {sym.name!r} is the independent variable, not a parameter")
        param_syms.append(sym)
        local[sym.name] = sym
    user_var = var if isinstance(var, sp.Symbol) else sp.Symbol(var_name)
    local[var_name] = user_var
    exprs = {}
    for key, name, value in zip(("p0", "p1", "q0"), names, (p0, p1, q0), strict=True):
        expr = to_expression(value, argument=name, symbols=local, free_names=True)
        # Symbols given as sympy objects may carry other assumptions: match them by name.
        by_name = {s.name: s for s in expr.free_symbols}
        if var_name in by_name:
            expr = expr.subs(by_name[var_name], X)
        for sym in param_syms:
            if sym.name in by_name and by_name[sym.name] != sym:
                expr = expr.subs(by_name[sym.name], sym)
        unknown = sorted(s.name for s in expr.free_symbols if s != X and s not in param_syms)
        if unknown:
            if not any(s == X for s in expr.free_symbols) and len(unknown) == 1:
                hint = f"; if {unknown[0]!r} is the independent variable pass var={unknown[0]!r}"
            else:
                hint = "; declare parameters with params=[...]"
            raise ValueError(
                f"{name}={value!s} contains the undeclared symbol(s) {', '.join(unknown)} "
                f"(independent variable is {var_name!r}){hint}"
            )
        exprs[key] = sp.expand(expr)
    for key, name in zip(("p0", "p1"), names, strict=False):
        if not exprs[key].is_polynomial(X):
            raise ValueError(
                f"{name}={exprs[key]} is not a polynomial in {var_name}; "
                "the classical theory (eq. 8-10) needs polynomial p0 and p1"
            )
    if not exprs["q0"].is_rational_function(X):
        raise ValueError(
            f"{names[2]}={exprs['q0']} is not a polynomial or rational function of {var_name}"
        )
    if exprs["p0"] == 0:
        raise ValueError(
            f"{names[0]} must not be identically zero (the problem must be second order)"
        )
    return Coefficients(
        p0=exprs["p0"],
        p1=exprs["p1"],
        q0=sp.cancel(exprs["q0"]),
        params=tuple(param_syms),
    )
