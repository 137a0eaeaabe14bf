"""No user string runs as code: every string that reaches sympy goes through the safe parser.

Each payload below creates a marker file when it is evaluated as Python (checked first
against ``sympy.sympify`` itself, so that the payloads are live); every API and CLI entry
point must refuse it with a ``ValueError`` (CLI: exit code 2) naming the argument, and the
marker must not exist afterwards.  Accepted expressions are checked against sympy
expressions built directly (the oracle), including a round trip of sympy's ``str`` output.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import sympy as sp
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import slbasis
import slbasis.codegen  # a submodule: not imported by `import slbasis`
from slbasis import SturmLiouville, families
from slbasis.symbolic.expr import (
    MAX_FACTORIAL_ARGUMENT,
    MAX_LENGTH,
    parse_expression,
    to_expression,
)
from slbasis.symbolic.parse import N, X

ROOT = Path(__file__).resolve().parents[3]
MARK = "MARK"
PAYLOADS = [
    f"__import__('os').system('touch {MARK}')",
    f"open('{MARK}', 'w')",
    f"(lambda: __import__('os'))().system('touch {MARK}')",
    f'exec(\'open("{MARK}", "w")\')',
]
Q0_LIMIT_CIRCLE = "1/(4*(1 - x**2))"


@pytest.fixture
def in_tmp(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Run in an empty directory, where a payload would leave its marker."""
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize("payload", PAYLOADS)
def test_payloads_are_live_under_sympify(payload: str, in_tmp: Path) -> None:
    # the oracle for the tests below: sympify runs each payload (this is the hole closed)
    try:
        sp.sympify(payload)
    except Exception:  # noqa: BLE001 - only the side effect matters here
        pass
    assert (in_tmp / MARK).exists()


API_ENTRIES = {
    "p0": lambda s: SturmLiouville(p0=s, p1="-2*x"),
    "p1": lambda s: SturmLiouville(p0="1 - x**2", p1=s),
    "q0": lambda s: SturmLiouville(p0=1, p1=0, q0=s),
    "standardization": lambda s: SturmLiouville("1 - x**2", "-2*x", standardization=s),
    "gauge": lambda s: SturmLiouville("1 - x**2", "-2*x", q0=Q0_LIMIT_CIRCLE, gauge=s),
    "params": lambda s: SturmLiouville("1 - x**2", "-a*x", params=["a", s]),
    "alpha": lambda s: families["laguerre"](alpha=s),
    "beta": lambda s: families.jacobi(alpha="1/2", beta=s),
    "lam": lambda s: families.gegenbauer(lam=s),
    "n": lambda s: families.legendre().eigenvalue(s),
}


@pytest.mark.parametrize("payload", PAYLOADS)
@pytest.mark.parametrize("argument", sorted(API_ENTRIES))
def test_api_refuses_payloads(argument: str, payload: str, in_tmp: Path) -> None:
    with pytest.raises(ValueError, match=rf"^{argument}\b[:=]"):
        API_ENTRIES[argument](payload)
    assert not (in_tmp / MARK).exists()


def test_norm_and_leading_coefficient_refuse_payloads(in_tmp: Path) -> None:
    prob = families.hermite()
    for method in (prob.norm2, prob.leading_coefficient):
        with pytest.raises(ValueError, match=r"^n: "):
            method(PAYLOADS[0])
    assert not (in_tmp / MARK).exists()


def test_problem_name_cannot_inject_code_into_generated_kernel(in_tmp: Path) -> None:
    # the on-demand kernel module is generated source run with exec: the name is text in it
    name = f'x"""\nopen("{MARK}", "w")\n"""\\'
    prob = SturmLiouville("1 - x**2", "-2*x", name=name)
    module = slbasis.codegen.kernel_module(prob)
    assert not (in_tmp / MARK).exists()
    assert module.__doc__.startswith(f"Generated closed forms for {name}: custom.")  # as text


def test_codegen_refuses_undefined_functions() -> None:
    # sympy objects are trusted input, but an undefined function would be printed as code
    evil = sp.Function("evil")
    prob = SturmLiouville(1, -2 * evil(1) * X)
    with pytest.raises(ValueError, match="only sympy's own functions"):
        slbasis.codegen.generate_source(prob, "custom", "test")


def _cli(tmp_path: Path, *args: str) -> subprocess.CompletedProcess[str]:
    env = dict(
        os.environ, PYTHONPATH=os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    )
    return subprocess.run(
        [sys.executable, "-m", "slbasis", "derive", *args],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )


CLI_CASES = {
    "p0": lambda s: ["--p0", s, "--p1=-2*x"],
    "p1": lambda s: ["--p0", "1 - x**2", "--p1", s],
    "q0": lambda s: ["--p0", "1", "--p1", "0", "--q0", s],
    "alpha": lambda s: ["--family", "laguerre", "--param", f"alpha={s}"],
    "beta": lambda s: ["--family", "jacobi", "--param", "alpha=1/2", "--param", f"beta={s}"],
}


@pytest.mark.parametrize("argument", sorted(CLI_CASES))
def test_cli_refuses_payloads(argument: str, tmp_path: Path) -> None:
    out = _cli(tmp_path, *CLI_CASES[argument](PAYLOADS[0]))
    assert out.returncode == 2, out.stderr
    assert re.search(rf"slbasis: error: {argument}\b[:=]", out.stderr), out.stderr
    assert "Traceback" not in out.stderr
    assert not (tmp_path / MARK).exists()


def test_cli_refuses_payload_as_parameter_name(tmp_path: Path) -> None:
    out = _cli(tmp_path, "--p0", "1 - x**2", "--p1=-2*x", "--params", PAYLOADS[0])
    assert out.returncode == 2 and "params: " in out.stderr, out.stderr
    assert not (tmp_path / MARK).exists()


# ----- the grammar ----------------------------------------------------------------------
ALPHA = sp.Symbol("alpha", real=True)
SYMBOLS = {"x": X, "alpha": ALPHA, "n": N}


def _parse(text: str) -> sp.Expr:
    return parse_expression(text, argument="expr", symbols=SYMBOLS)


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("1 - x**2", 1 - X**2),
        ("-2*x + alpha/3", -2 * X + ALPHA / 3),
        ("0.1 + 2.5e-1*x", sp.Rational(1, 10) + sp.Rational(1, 4) * X),
        ("(-1)**n/(2**n*factorial(n))", (-1) ** N / (2**N * sp.factorial(N))),
        ("RisingFactorial(alpha + 1, n)", sp.RisingFactorial(ALPHA + 1, N)),
        ("rf(alpha, 2)", sp.RisingFactorial(ALPHA, 2)),
        ("gamma(n + alpha + 1)/binomial(n, 2)", sp.gamma(N + ALPHA + 1) / sp.binomial(N, 2)),
        ("sqrt(pi)*exp(-x**2/2)", sp.sqrt(sp.pi) * sp.exp(-(X**2) / 2)),
        ("log(x, 2) + Abs(alpha) - E", sp.log(X, 2) + sp.Abs(ALPHA) - sp.E),
        ("+x - -x", 2 * X),
        ("x" + "+x" * 300, 301 * X),  # a long flat sum is not a deep tree
    ],
)
def test_accepted_expressions(text: str, expected: sp.Expr) -> None:
    assert _parse(text) == expected


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("x^2", r"write powers with \*\*"),
        ("x.real", "attribute access"),
        ("[x][0]", "not allowed"),
        ("x[0]", "subscript"),
        ("f(x)", "calling 'f' is not allowed"),
        ("sqrt", "is a function"),
        ("sqrt(x=1)", "only positional arguments"),
        ("sqrt(*[x])", "only positional arguments"),
        ("sqrt(x, 2)", "takes 1 argument"),
        ("x(2)", "calling 'x' is not allowed"),
        ("y + x", "the name 'y' is not allowed"),
        ("__class__", "must not contain '__'"),
        ("x.__class__", "attribute access"),
        ("'x'", "literal"),
        ("1j", "complex"),
        ("x < 1", "comparison"),
        ("x and 1", "boolean operator"),
        ("x if 1 else 2", "conditional"),
        ("[i for i in x]", "comprehension"),
        ("lambda: x", "lambda"),
        ("x % 2", "Mod"),
        ("1 +", "not a valid expression"),
        ("", "empty"),
        ("x" * (MAX_LENGTH + 1), "more than"),
        ("1/0", "undefined or infinite"),
        # sizes: refused before any large computation
        ("9**9**9**9", "numeric exponents must be at most"),
        ("(2**1000)**1000", "bits"),
        ("sqrt(2)**10**6", "numeric exponents must be at most"),
        ("((1 + x)**30)**30", "degree above"),
        ("(1 + x)**32*(1 + alpha)", "degree above"),
        ("factorial(10**6)", "factorial: numeric arguments"),
        ("1e999", "outside"),
        ("1e-99999", "outside"),
        ("-" * 100 + "x", "nested more than"),
        ("(" * 300 + "x" + ")" * 300, "not a valid expression"),
    ],
)
def test_refused_expressions(text: str, message: str) -> None:
    with pytest.raises(ValueError, match=rf"^expr\b[:=].*{message}"):
        _parse(text)


def test_non_strings() -> None:
    assert to_expression(0.1, argument="a", symbols={}) == sp.Rational(1, 10)
    assert to_expression(3, argument="a", symbols={}) == 3
    assert to_expression(X + 1, argument="a", symbols={}) == X + 1
    with pytest.raises(TypeError, match="^a must be"):
        to_expression(True, argument="a", symbols={})
    with pytest.raises(ValueError, match="^a must be finite"):
        to_expression(float("nan"), argument="a", symbols={})
    with pytest.raises(TypeError, match="^expr must be a string"):
        parse_expression(b"x", argument="expr", symbols={})  # type: ignore[arg-type]


def test_strings_and_sympy_objects_give_the_same_problem() -> None:
    # the documented string forms against the same inputs built as sympy objects
    std = "(-1)**n/(2**n*factorial(n))"
    a = SturmLiouville("1 - x**2", "-2*x", standardization=std)
    b = SturmLiouville(1 - X**2, -2 * X, standardization=(-1) ** N / (2**N * sp.factorial(N)))
    assert a.polynomial(3) == b.polynomial(3) == sp.legendre(3, X)
    assert families.laguerre(alpha="1/2").norm2(2) == families.laguerre(
        alpha=sp.Rational(1, 2)
    ).norm2(2)
    assert families.laguerre(alpha="alpha").params == families.laguerre().params
    lag = SturmLiouville("x", "1 - a*x", params=["a"])
    assert sp.expand(lag.eigenvalue("n + 1") - lag.eigenvalue(N + 1)) == 0


# ----- round trip of sympy's printed form ------------------------------------------------
coefficients = st.fractions(min_value=-(10**6), max_value=10**6, max_denominator=1000)
monomials = st.tuples(
    coefficients, st.integers(0, 6), st.integers(0, 3), st.integers(0, 3)
)  # c * x**i * alpha**j * n**k


@settings(max_examples=60, deadline=None)
@given(terms=st.lists(monomials, min_size=1, max_size=8))
def test_printed_polynomials_round_trip(terms: list) -> None:
    expr = sp.Add(
        *(sp.Rational(c.numerator, c.denominator) * X**i * ALPHA**j * N**k for c, i, j, k in terms)
    )
    assert _parse(str(expr)) == expr


leaves = st.one_of(
    st.sampled_from([X, ALPHA, N, sp.pi, sp.E]),
    st.fractions(min_value=1, max_value=50, max_denominator=9).map(
        lambda f: sp.Rational(f.numerator, f.denominator)
    ),
)
positive_functions = [sp.sqrt, sp.exp, sp.log, sp.gamma, sp.factorial, sp.sin, sp.cos]


def _extend(children: st.SearchStrategy) -> st.SearchStrategy:
    # no integer powers of subtrees here (nested powers would leave the degree bound;
    # the polynomial test above covers powers): degree <= number of leaves
    pairs = st.tuples(children, children)
    return st.one_of(
        pairs.map(lambda ab: ab[0] + ab[1]),
        pairs.map(lambda ab: ab[0] - ab[1]),
        pairs.map(lambda ab: ab[0] * ab[1]),
        pairs.map(lambda ab: ab[0] / ab[1]),
        st.tuples(st.sampled_from(positive_functions), children).map(lambda fa: fa[0](fa[1])),
        st.tuples(children, st.integers(0, 3)).map(lambda ab: sp.binomial(ab[0], ab[1])),
        st.tuples(children, st.integers(0, 3)).map(lambda ab: sp.RisingFactorial(ab[0], ab[1])),
    )


@settings(max_examples=60, deadline=None)
@given(expr=st.recursive(leaves, _extend, max_leaves=8))
def test_printed_expressions_round_trip(expr: sp.Expr) -> None:
    # complex or undefined values (log of a negative number, 1/0) are outside the grammar
    assume(not expr.has(sp.I, sp.zoo, sp.nan, sp.oo, -sp.oo))
    # inside the grammar's documented bounds: no number longer than the text may be (3.33
    # bits a digit; Python would not even print one past 4300 digits), no factorial-type
    # function of a number beyond its bound (parsing refuses both, with the bound named)
    assume(all(max(abs(r.p), r.q).bit_length() <= 3 * MAX_LENGTH for r in expr.atoms(sp.Rational)))
    factorial_type = (sp.gamma, sp.factorial, sp.binomial, sp.RisingFactorial)
    assume(
        not any(
            a.is_Number and abs(a) > MAX_FACTORIAL_ARGUMENT
            for f in expr.atoms(*factorial_type)
            for a in f.args
        )
    )
    assume(len(str(expr)) <= MAX_LENGTH)
    parsed = _parse(str(expr))
    # the same expression, not always the same tree: sympy distributes a number over a
    # sum when it builds 2*(alpha + x) from the text, which the printed tree had kept
    assert parsed == expr or sp.simplify(parsed - expr) == 0
