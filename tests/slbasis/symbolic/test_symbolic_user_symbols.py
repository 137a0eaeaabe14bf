"""The symbols of ``SturmLiouville``: ``prob.x``, ``prob.n`` and a user's own symbols.

Oracles are independent of the derivation: sympy's textbook polynomials (``hermite``,
``legendre``, ``laguerre``), the closed-form weights and eq. (3) of the thesis for the
Hermite-function derivative, and sympy's own differentiation of the returned expressions.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import slbasis
from slbasis import SturmLiouville
from slbasis.symbolic.parse import N, X

# Symbolic work is ~0.1-1 s per example: few examples, no deadline.
SETTINGS = settings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# (p0, p1, q0) in the name "x"; oracle of the eigenfunction f_n(v) and of the weight w(v).
# With the default Rodrigues constant c_n = (-1)^n (p0 > 0) the eigenfunctions are
# H_n (Hermite), 2^n n! P_n (Legendre), (-1)^n n! L_n (Laguerre), e^{-v^2/2} H_n (functions).
PROBLEMS = {
    "hermite": (
        ("1", "-2*x", "0"),
        lambda k, v: sp.hermite(k, v),
        lambda v: sp.exp(-(v**2)),
        (-3, 3),
    ),
    "legendre": (
        ("1 - x**2", "-2*x", "0"),
        lambda k, v: 2**k * sp.factorial(k) * sp.legendre(k, v),
        lambda v: sp.Integer(1),
        (-1, 1),
    ),
    "laguerre": (
        ("x", "1 - x", "0"),
        lambda k, v: (-1) ** k * sp.factorial(k) * sp.laguerre(k, v),
        lambda v: sp.exp(-v),
        (0, 6),
    ),
    "hermite_functions": (
        ("1", "0", "x**2"),
        lambda k, v: sp.exp(-(v**2) / 2) * sp.hermite(k, v),
        lambda v: sp.Integer(1),
        (-3, 3),
    ),
}


def _point(frac: Fraction, interval: tuple[int, int]) -> sp.Rational:
    """A rational point strictly inside ``interval`` from ``frac`` in (0, 1)."""
    a, b = interval
    return a + (b - a) * sp.Rational(frac.numerator, frac.denominator)


@SETTINGS
@given(
    name=st.sampled_from(sorted(PROBLEMS)),
    k=st.integers(min_value=0, max_value=6),
    frac=st.fractions(min_value=Fraction(1, 20), max_value=Fraction(19, 20), max_denominator=20),
    assumptions=st.sampled_from([{}, {"real": True}, {"positive": True}]),
    var=st.sampled_from(["x", "t", "xi"]),
)
def test_user_symbol_substitutes_to_the_textbook_value(
    name: str, k: int, frac: Fraction, assumptions: dict, var: str
) -> None:
    (p0, p1, q0), eigenfunction, weight, interval = PROBLEMS[name]
    sym = sp.Symbol(var, **assumptions)
    coeffs = [c.replace("x", var) for c in (p0, p1, q0)]
    prob = SturmLiouville(*coeffs, x=sym)
    assert prob.x is sym
    v = _point(frac, interval)
    if assumptions.get("positive") and v <= 0:
        v = sp.Rational(1, 3)  # a positive symbol only takes positive values
    f = prob.eigenfunction(k)
    assert f.free_symbols <= {sym}
    # exact rationals (and exp of rationals): equality is exact
    assert sp.simplify(f.subs(sym, v) - eigenfunction(k, v)) == 0
    assert sp.simplify(prob.weight.subs(sym, v) - weight(v)) == 0
    assert prob.p0.free_symbols <= {sym} and prob.p1.free_symbols <= {sym}


@SETTINGS
@given(
    name=st.sampled_from(sorted(PROBLEMS)),
    k=st.integers(min_value=1, max_value=5),
    frac=st.fractions(min_value=Fraction(1, 20), max_value=Fraction(19, 20), max_denominator=20),
)
def test_bands_in_user_symbols_match_sympy_differentiation(
    name: str, k: int, frac: Fraction
) -> None:
    """2 p0 psi_k' = sub_k psi_{k-1} + diag_k psi_k + sup_k psi_{k+1}, all in the user's x, n."""
    (p0, p1, q0), _, _, interval = PROBLEMS[name]
    x, n = sp.Symbol("x"), sp.Symbol("m", integer=True)
    prob = SturmLiouville(p0, p1, q0, x=x, n=n)
    bands = prob.derivative_operator()
    assert all(b.free_symbols <= {n} for b in bands.values())
    psi = [prob.orthonormal_function(j) for j in (k - 1, k, k + 1)]
    lhs = 2 * prob.p0 * sp.diff(psi[1], x)
    rhs = sum(bands[key].subs(n, k) * f for key, f in zip(("sub", "diag", "sup"), psi, strict=True))
    v = _point(frac, interval)
    # 30-digit evaluation of two closed forms that are equal: agreement to ~1e-25
    assert abs(sp.N((lhs - rhs).subs(x, v), 30)) < 1e-20


def test_string_variable_name_is_a_real_symbol_of_that_name() -> None:
    prob = SturmLiouville("1 - t**2", "-2*t", x="t", n="k")
    assert prob.x == sp.Symbol("t", real=True)
    assert prob.n == sp.Symbol("k", integer=True, nonnegative=True)
    v = sp.Rational(2, 7)
    for k in range(5):
        value = prob.orthonormal_polynomial(k).subs(prob.x, v)
        assert sp.simplify(value - sp.sqrt(sp.Rational(2 * k + 1, 2)) * sp.legendre(k, v)) == 0
    # Legendre eigenvalues n (n + 1) in the user's index symbol
    assert sp.expand(prob.eigenvalue() - prob.n * (prob.n + 1)) == 0
    assert prob.eigenvalue().subs(prob.n, 3) == 12
    assert prob.eigenvalue(prob.n) == prob.eigenvalue()


def test_user_index_symbol_hermite_function_derivative_is_eq3() -> None:
    """Eq. (3): d/dx h_n = sqrt(n/2) h_{n-1} - sqrt((n+1)/2) h_{n+1}; 2 p0 = 2."""
    k = sp.Symbol("k", integer=True, nonnegative=True)
    prob = SturmLiouville(1, 0, "x**2", n=k)
    bands = prob.derivative_operator()
    for j in range(1, 8):
        assert sp.simplify(bands["sub"].subs(k, j) - 2 * sp.sqrt(sp.Rational(j, 2))) == 0
        assert sp.simplify(bands["sup"].subs(k, j) + 2 * sp.sqrt(sp.Rational(j + 1, 2))) == 0
        assert bands["diag"].subs(k, j) == 0
    assert prob.norm2().subs(k, 3) == prob.norm2(3)
    assert prob.leading_coefficient().subs(k, 4) == 2**4


def test_default_symbols_are_unchanged() -> None:
    prob = SturmLiouville("1 - x**2", "-2*x")
    assert prob.x is X and prob.n is N
    assert X == sp.Symbol("x", real=True) and N == sp.Symbol("n", integer=True, nonnegative=True)
    assert prob.canonical is prob
    assert prob.eigenfunction(2) == 12 * X**2 - 4
    assert prob.eigenvalue() == N**2 + N
    # the pitfall the x= argument exists for: a plain Symbol("x") is another symbol
    assert prob.eigenfunction(2).subs(sp.Symbol("x"), 1) == 12 * X**2 - 4
    assert prob.eigenfunction(2).subs(prob.x, 1) == 8
    # the older var= names the input variable only; outputs stay in the canonical x
    old = SturmLiouville("1 - t**2", "-2*t", var="t")
    assert old.x is X and old.eigenfunction(2) == 12 * X**2 - 4


def test_user_symbols_give_the_same_verification_report_and_kernel() -> None:
    t = sp.Symbol("t")
    mine = SturmLiouville("t", "1 - t", x=t, name="Laguerre")
    default = SturmLiouville("x", "1 - x", name="Laguerre")
    assert mine.canonical.x is X and mine.x is t
    assert mine.verify(nmax=4).ok
    assert mine.report(nmax=3) == default.report(nmax=3)
    times = np.linspace(0.0, 10.0, 7)
    a = slbasis.basis(mine, N=6, t_span=(0.0, 10.0)).eval(times)
    b = slbasis.basis(default, N=6, t_span=(0.0, 10.0)).eval(times)
    np.testing.assert_array_equal(a, b)  # same generated kernel source: bit-identical


@pytest.mark.parametrize(
    ("kwargs", "error", "message"),
    [
        ({"x": "k", "n": "k"}, ValueError, "different names"),
        ({"x": "t", "var": "s"}, ValueError, "var='s' and x='t'"),
        ({"x": 3}, TypeError, "x must be a sympy Symbol"),
        ({"n": "not a name"}, TypeError, "n must be a sympy Symbol"),
        ({"n": "alpha", "params": ["alpha"]}, ValueError, "index symbol n"),
    ],
)
def test_bad_symbols_raise(kwargs: dict, error: type, message: str) -> None:
    with pytest.raises(error, match=message):
        SturmLiouville("1 - x**2", "-2*x", **kwargs)
