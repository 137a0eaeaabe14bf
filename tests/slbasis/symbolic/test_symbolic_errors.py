"""Bad input to the symbolic layer: each raises a ValueError/TypeError that says what is wrong."""

from __future__ import annotations

import pytest
import sympy as sp

from slbasis import SturmLiouville, families


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"p0": "sin(x)", "p1": "-2*x"}, r"p0=sin\(x\) is not a polynomial"),
        ({"p0": 1, "p1": "1/x"}, r"p1=1/x is not a polynomial"),
        ({"p0": 1, "p1": "-2*x", "q0": "exp(x)"}, "not a polynomial or rational function"),
        ({"p0": "x**3", "p1": "-x"}, r"deg p0 = 3 > 2"),
        ({"p0": 1, "p1": "x**2"}, r"deg p1 = 2 > 1"),
        ({"p0": "x**2", "p1": "2*x + 2"}, "double root.*Bessel"),
        ({"p0": "1 + x**2", "p1": "x"}, "no real roots"),
        ({"p0": 1, "p1": "2*x"}, "decays like a Gaussian"),
        ({"p0": 1, "p1": 1}, "does not decay"),
        ({"p0": "x", "p1": "-1 - x"}, r"exponent A = p1\(r\)/p0'\(r\)"),
        ({"p0": "1 - t**2", "p1": "-2*t"}, "undeclared symbol.*var='t'"),
        ({"p0": "1 - x**2", "p1": "-a*x"}, "undeclared symbol.*params"),
        ({"p0": 0, "p1": "x"}, "must not be identically zero"),
        ({"p0": "1 - x**2", "p1": "-2*x", "q0": "x**3"}, "not a gauge"),
        ({"p0": "1 +", "p1": "x"}, "not a valid expression"),
    ],
)
def test_bad_problem_raises_clear_value_error(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SturmLiouville(**kwargs)


def test_other_variable_works_when_declared() -> None:
    prob = SturmLiouville("1 - t**2", "-2*t", var="t")
    assert prob.eigenvalue() == sp.Symbol("n", integer=True, nonnegative=True) ** 2 + sp.Symbol(
        "n", integer=True, nonnegative=True
    )


@pytest.mark.parametrize(
    ("family", "params", "message"),
    [
        ("jacobi", {"alpha": -1, "beta": 0}, "alpha must be > -1"),
        ("jacobi", {"alpha": 0, "beta": -2}, "beta must be > -1"),
        ("laguerre", {"alpha": -3}, "alpha must be > -1"),
        ("gegenbauer", {"lam": -1}, "lambda must be > -1/2"),
        ("gegenbauer", {"lam": 0}, "lambda = 0 is excluded"),
    ],
)
def test_family_parameters_out_of_range(family: str, params: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        families[family](**params)


def test_type_errors() -> None:
    with pytest.raises(TypeError, match="p0 must be a string, a number or a sympy expression"):
        SturmLiouville([1, 2], "x")
    with pytest.raises(TypeError, match="takes parameters"):
        families.legendre(alpha=1)
    with pytest.raises(KeyError, match="unknown family"):
        families["bessel"]
    prob = families.hermite()
    with pytest.raises(TypeError, match="n must be a non-negative integer"):
        prob.polynomial(1.5)
    with pytest.raises(ValueError, match="n must be a non-negative integer"):
        prob.polynomial(-1)
    with pytest.raises(ValueError, match="frame must be one of"):
        prob.derivative_operator("wavelets")
    with pytest.raises(ValueError, match="nmax must be an integer >= 2"):
        prob.verify(nmax=1)
    with pytest.raises(ValueError, match="fmt must be one of"):
        prob.report(fmt="html")
