"""Property tests (hypothesis): random rational parameters and random affine maps of x.

Every example is checked exactly (sympy); ``verify`` compares the closed forms in ``n``
against Rodrigues polynomials, exact weight integrals and direct differentiation.
"""

from __future__ import annotations

from fractions import Fraction

import sympy as sp
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from slbasis import SturmLiouville, families
from slbasis.symbolic.parse import N, X

# Symbolic work is ~0.3-2 s per example: few examples, no deadline.
SETTINGS = settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def rationals(low: Fraction, high: Fraction, open_low: bool = True) -> st.SearchStrategy:
    values = st.fractions(min_value=low, max_value=high, max_denominator=8)
    return values.filter(lambda v: v > low) if open_low else values


def _q(value: Fraction) -> sp.Rational:
    return sp.Rational(value.numerator, value.denominator)


@SETTINGS
@given(alpha=rationals(Fraction(-1), Fraction(6)), beta=rationals(Fraction(-1), Fraction(6)))
def test_jacobi_random_parameters(alpha: Fraction, beta: Fraction) -> None:
    report = families.jacobi(alpha=_q(alpha), beta=_q(beta)).verify(nmax=6)
    assert report.ok, str(report)


@SETTINGS
@given(alpha=rationals(Fraction(-1), Fraction(8)))
def test_laguerre_random_parameter(alpha: Fraction) -> None:
    report = families.laguerre(alpha=_q(alpha)).verify(nmax=6)
    assert report.ok, str(report)


@SETTINGS
@given(lam=rationals(Fraction(-1, 2), Fraction(6)).filter(lambda v: v != 0))
def test_gegenbauer_random_parameter(lam: Fraction) -> None:
    report = families.gegenbauer(lam=_q(lam)).verify(nmax=6)
    assert report.ok, str(report)


BASES = {
    "hermite": (sp.Integer(1), -2 * X),
    "laguerre": (X, sp.Rational(3, 2) - X),
    "jacobi": (1 - X**2, sp.Rational(1, 3) - sp.Rational(7, 3) * X),
}


@SETTINGS
@given(
    name=st.sampled_from(sorted(BASES)),
    scale=rationals(Fraction(-5), Fraction(5), open_low=False).filter(lambda v: v != 0),
    shift=rationals(Fraction(-3), Fraction(3), open_low=False),
)
def test_affine_change_of_variable(name: str, scale: Fraction, shift: Fraction) -> None:
    """x = s y + t maps p0 f'' + p1 f' = -lambda f to p0(s y + t)/s^2, p1(s y + t)/s.

    Same eigenvalues; interval mapped by y = (x - t)/s; 2 p0~ d/dy = (2 p0 d/dx)/s, and with
    positive leading coefficients psi~_n = sign(s)^n sqrt|s| psi_n, so the off-diagonal
    bands scale by 1/|s| and the diagonal by 1/s.
    """
    s, t = _q(scale), _q(shift)
    p0, p1 = BASES[name]
    y = sp.Symbol("y")
    base = SturmLiouville(p0, p1)
    moved = SturmLiouville(p0.subs(X, s * y + t) / s**2, p1.subs(X, s * y + t) / s, var="y")
    assert moved.verify(nmax=5).ok
    assert sp.expand(moved.eigenvalue() - base.eigenvalue()) == 0
    mapped = sorted(((e - t) / s for e in base.interval), key=lambda v: float(v))
    assert list(moved.interval) == mapped
    old, new = base.derivative_operator(), moved.derivative_operator()
    assert sp.simplify(new["diag"] - old["diag"] / s) == 0
    for key in ("sub", "sup"):
        for n in range(1, 6):
            assert sp.simplify((new[key] - old[key] / abs(s)).subs(N, n)) == 0, (key, n)


def test_laguerre_reflected_onto_a_left_half_line_verifies() -> None:
    # found by hypothesis: on (-oo, b) the numeric derivative check sampled points outside
    # the interval (sqrt of a negative weight -> complex -> TypeError)
    y = sp.Symbol("y")
    s, t = sp.Rational(-1, 2), sp.Integer(-2)
    p0, p1 = BASES["laguerre"]
    moved = SturmLiouville(p0.subs(X, s * y + t) / s**2, p1.subs(X, s * y + t) / s, var="y")
    assert moved.interval == (-sp.oo, -4)
    assert moved.verify(nmax=5).ok


def test_shifted_legendre_on_unit_interval() -> None:
    prob = SturmLiouville(p0="x - x**2", p1="1 - 2*x")
    assert prob.interval == (0, 1) and prob.weight == 1 and prob.kind == "jacobi"
    assert prob.verify(nmax=8).ok
    # orthonormal shifted Legendre: sqrt(2n+1) P_n(2x - 1)
    for n in range(5):
        expected = sp.sqrt(2 * n + 1) * sp.legendre(n, 2 * X - 1)
        assert sp.expand(prob.orthonormal_polynomial(n) - expected) == 0


def test_probabilists_hermite_and_scaled_laguerre() -> None:
    he = SturmLiouville(p0=1, p1="-x")
    assert he.weight == sp.exp(-(X**2) / 2)
    assert he.eigenvalue() == N and he.verify(nmax=8).ok
    for n in range(6):  # He_n(x) = 2^(-n/2) H_n(x/sqrt 2), monic
        assert (
            sp.expand(he.polynomial(n) - 2 ** sp.Rational(-n, 2) * sp.hermite(n, X / sp.sqrt(2)))
            == 0
        )
    a = sp.Symbol("a", positive=True)
    lag = SturmLiouville(p0="x", p1="1 - a*x", params=[a])
    assert lag.interval == (0, sp.oo) and lag.weight == sp.exp(-a * X)
    assert sp.expand(lag.eigenvalue() - a * N) == 0
    assert lag.verify(nmax=6).ok


def test_gauge_transforms_are_recognised() -> None:
    # Laguerre functions e^{-x/2} L_n(x): x f'' + f' - x/4 f = -(n + 1/2) f
    lag = SturmLiouville(p0="x", p1=1, q0="x/4")
    assert lag.gauge.p1_poly == 1 - X and lag.gauge.factor == sp.exp(-X / 2)
    assert sp.expand(lag.eigenvalue() - (N + sp.Rational(1, 2))) == 0
    # ((1-x^2) f')' - f/(4(1-x^2)) = -lambda f: limit-circle endpoints, four admissible
    # gauges (Chebyshev U, T, V, W).  Default: the most regular, (1-x^2)^(1/4) U_n.
    q0 = "1/(4*(1 - x**2))"
    cheb_u = SturmLiouville(p0="1 - x**2", p1="-2*x", q0=q0)
    assert sp.expand(cheb_u.gauge.p1_poly + 3 * X) == 0
    assert len(cheb_u.gauge.alternatives) == 3
    assert sp.expand(cheb_u.eigenvalue() - ((N + 1) ** 2 - sp.Rational(1, 4))) == 0
    assert (
        cheb_u.gauge.factor == (1 - X**2) ** sp.Rational(1, 4)
        or sp.simplify(
            cheb_u.gauge.factor - (1 - X) ** sp.Rational(1, 4) * (1 + X) ** sp.Rational(1, 4)
        )
        == 0
    )
    # (1-x^2)^(-1/4) T_n on request: eigenvalues n^2 - 1/4
    cheb_t = SturmLiouville(p0="1 - x**2", p1="-2*x", q0=q0, gauge="-x")
    assert sp.expand(cheb_t.eigenvalue() - (N**2 - sp.Rational(1, 4))) == 0
    assert cheb_u.verify(nmax=6).ok and cheb_t.verify(nmax=6).ok
