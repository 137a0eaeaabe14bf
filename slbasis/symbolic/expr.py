"""A safe parser for the expressions users type: strings become sympy expressions without
running any of their text as Python.

``sympy.sympify`` (and ``parse_expr``) *evaluate* a string as Python code, so a string such
as ``"__import__('os').system(...)"`` given as ``p0`` of a problem would run.  This module
reads a string with Python's :mod:`ast` parser (``mode="eval"``: syntax only, nothing is
executed) and builds the sympy expression itself from a strict whitelist of tree nodes:

* numbers: integer and decimal literals (a decimal is read *exactly*, ``0.1 = 1/10``, as
  ``sympify(..., rational=True)`` did); no complex literals (every problem is real);
* names: the symbols the caller allows (the variable, declared parameters, ``n``), the
  constants :data:`CONSTANTS` and, as calls with positional arguments only, the functions
  :data:`FUNCTIONS`; no name containing ``__``;
* operators ``+ - * / **``, unary ``+``/``-``, parentheses.  ``^`` is refused with a hint:
  in Python's grammar it is XOR with a lower precedence than ``+``, so ``1 - x^2`` would be
  ``(1 - x)^2``; accepting it as a power would need a second grammar.

Everything else (attribute access, subscripts, other calls, keyword arguments, strings,
lambdas, comprehensions, comparisons, ...) is a ``ValueError`` that names the argument and
says what is allowed.  sympy's ``str`` output of an expression in this grammar parses back
to the same expression (``tests/slbasis/symbolic/test_symbolic_safe_parse.py`` checks it).

Size bounds keep parsing fast whatever the input: the text length (:data:`MAX_LENGTH`), the
tree depth (:data:`MAX_DEPTH`), decimal exponents (:data:`MAX_DECIMAL_EXPONENT`), numeric
powers (:data:`MAX_EXPONENT`) and the bit length of every exact number (:data:`MAX_BITS`;
both checked before a power is computed, so that ``9**9**9**9`` is refused instead of
computed), the total degree in the symbols (:data:`MAX_DEGREE`, so that expanding the
expression later stays cheap) and numeric arguments of the
factorial-type functions (:data:`MAX_FACTORIAL_ARGUMENT`).  The classical problems need
degrees <= 2 and small integers; every bound is far above any practical input and far below
the sizes at which exact arithmetic becomes slow (a 10^5-bit integer power takes
milliseconds).
"""

from __future__ import annotations

import ast
import keyword
import math
import numbers
from collections.abc import Callable, Mapping
from decimal import Decimal, InvalidOperation

import sympy as sp

__all__ = [
    "CONSTANTS",
    "FUNCTIONS",
    "MAX_LENGTH",
    "check_symbol_name",
    "parse_expression",
    "to_expression",
]

#: Longest accepted text (characters); the longest coefficient of a classical problem has ~20.
MAX_LENGTH = 1000
#: Deepest accepted expression tree (nested operations and calls).
MAX_DEPTH = 64
#: Largest absolute numeric exponent of a power (``2**1000`` is accepted, ``2**1001`` not).
MAX_EXPONENT = 1000
#: Largest bit length of an exact numeric power (bit length of the base times the exponent).
MAX_BITS = 100_000
#: Largest total degree in the symbols (an upper bound counted on the tree): sympy expands a
#: dense polynomial of degree 32 in two symbols in under a second; degree 400 takes minutes.
MAX_DEGREE = 32
#: Largest absolute exponent of a decimal literal (``1e300`` accepted, ``1e1000`` not).
MAX_DECIMAL_EXPONENT = 400
#: Largest absolute numeric argument of factorial, gamma, binomial and RisingFactorial,
#: which sympy evaluates exactly at once.
MAX_FACTORIAL_ARGUMENT = 1000

#: Constants a string may name.
CONSTANTS: dict[str, sp.Expr] = {"pi": sp.pi, "E": sp.E}

#: Functions a string may call: name -> (sympy function, accepted numbers of arguments).
FUNCTIONS: dict[str, tuple[Callable[..., sp.Expr], tuple[int, ...]]] = {
    "sqrt": (sp.sqrt, (1,)),
    "exp": (sp.exp, (1,)),
    "log": (sp.log, (1, 2)),
    "sin": (sp.sin, (1,)),
    "cos": (sp.cos, (1,)),
    "tan": (sp.tan, (1,)),
    "Abs": (sp.Abs, (1,)),
    "gamma": (sp.gamma, (1,)),
    "factorial": (sp.factorial, (1,)),
    "binomial": (sp.binomial, (2,)),
    "RisingFactorial": (sp.RisingFactorial, (2,)),
    "rf": (sp.RisingFactorial, (2,)),
}
_FACTORIAL_TYPE = {"gamma", "factorial", "binomial", "RisingFactorial", "rf"}

_BINARY = {
    ast.Add: lambda a, b: a + b,
    ast.Sub: lambda a, b: a - b,
    ast.Mult: lambda a, b: a * b,
    ast.Div: lambda a, b: a / b,
}


class _Refused(Exception):
    """A part of the text outside the grammar (turned into the caller's ValueError)."""


def check_symbol_name(name: str, argument: str) -> str:
    """``name`` if it can name a symbol in an expression string, else ``ValueError``.

    A symbol name must be a Python identifier, not a keyword and without ``__``: only such
    names can be written in an expression, and generated code (:mod:`slbasis.codegen`)
    uses parameter names as Python identifiers.

    Parameters
    ----------
    name : str
        The proposed symbol name.
    argument : str
        The argument the name came from (used in the error message).

    Returns
    -------
    str
        ``name`` unchanged.

    Raises
    ------
    ValueError
        When ``name`` is not an identifier, is a keyword or contains ``__``.

    Examples
    --------
    >>> check_symbol_name("alpha", "params")
    'alpha'
    """
    if not isinstance(name, str) or not name.isidentifier() or keyword.iskeyword(name):
        raise ValueError(f"{argument}: {name!r} is not a valid symbol name (a Python identifier)")
    if "__" in name:
        raise ValueError(f"{argument}: symbol names must not contain '__', got {name!r}")
    return name


def _grammar(symbols: Mapping[str, sp.Basic], free_names: bool) -> str:
    names = ", ".join(sorted(symbols)) if symbols else "none"
    named = f"symbol names (declared: {names})" if free_names else f"the symbols {names}"
    return (
        f"allowed: numbers, {named}, the constants "
        f"{', '.join(CONSTANTS)}, the functions {', '.join(FUNCTIONS)}, "
        "+ - * / ** and parentheses"
    )


def parse_expression(
    text: str,
    *,
    argument: str,
    symbols: Mapping[str, sp.Basic],
    free_names: bool = False,
) -> sp.Expr:
    """The sympy expression written in ``text``, built from its syntax tree (never run).

    Parameters
    ----------
    text : str
        The expression, e.g. ``"1 - x**2"`` or ``"(-1)**n/factorial(n)"``.
    argument : str
        Name of the argument ``text`` came from; every error message starts with it.
    symbols : mapping of str to sympy object
        The names ``text`` may use and the object each stands for (the caller's symbols).
        They take precedence over :data:`CONSTANTS` and :data:`FUNCTIONS`.
    free_names : bool, default False
        Read any other valid identifier as a plain ``sympy.Symbol`` of that name (for a
        caller that checks free symbols itself and explains what to declare); a function
        name used without a call, and names with ``__``, stay refused.

    Returns
    -------
    sympy.Expr
        The expression, with exact rational numbers.

    Raises
    ------
    TypeError
        When ``text`` is not a string.
    ValueError
        When ``text`` is empty, too long, not valid syntax, uses anything outside the
        grammar (see the module docstring), exceeds a size bound, or evaluates to an
        undefined value (division by zero).

    Examples
    --------
    >>> x = sp.Symbol("x")
    >>> parse_expression("1 - x**2/2 + 0.25", argument="p0", symbols={"x": x})
    5/4 - x**2/2
    >>> parse_expression("__import__('os')", argument="p0", symbols={"x": x})
    Traceback (most recent call last):
    ...
    ValueError: p0: '__import__' is not allowed (names must not contain '__'); allowed: ...
    """
    if not isinstance(text, str):
        raise TypeError(f"{argument} must be a string, got {type(text).__name__}")
    shown = text if len(text) <= 60 else text[:57] + "..."
    if len(text) > MAX_LENGTH:
        raise ValueError(
            f"{argument}: the expression has {len(text)} characters, more than {MAX_LENGTH}"
        )
    if not text.strip():
        raise ValueError(f"{argument}: the expression is empty")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError, MemoryError, RecursionError) as exc:
        reason = getattr(exc, "msg", None) or str(exc) or type(exc).__name__
        raise ValueError(
            f"{argument}={shown!r} is not a valid expression ({reason}); "
            f"{_grammar(symbols, free_names)}"
        ) from None
    builder = _Builder(text.strip(), symbols, free_names)
    try:
        expr = builder.build(tree.body, 0)
    except _Refused as exc:
        raise ValueError(f"{argument}: {exc}; {_grammar(symbols, free_names)}") from None
    except (TypeError, ValueError, ArithmeticError) as exc:  # sympy refusing an operation
        raise ValueError(f"{argument}={shown!r} cannot be evaluated: {exc}") from None
    if not isinstance(expr, sp.Expr):
        raise ValueError(f"{argument}={shown!r} is not a scalar expression")
    if expr.has(sp.zoo, sp.nan, sp.oo, -sp.oo):
        raise ValueError(f"{argument}={shown!r} is undefined or infinite (division by zero?)")
    return expr


def to_expression(
    value: object,
    *,
    argument: str,
    symbols: Mapping[str, sp.Basic],
    free_names: bool = False,
) -> sp.Expr:
    """A user's value as a sympy expression: strings through :func:`parse_expression`.

    Parameters
    ----------
    value : str, int, rational or float number, or sympy expression
        Numbers become exact (a float by its shortest decimal form, ``0.1 -> 1/10``);
        sympy expressions are returned as given.
    argument, symbols, free_names
        As in :func:`parse_expression` (used for strings only).

    Returns
    -------
    sympy.Expr

    Raises
    ------
    TypeError
        For any other type (booleans included).
    ValueError
        For a string outside the grammar or a non-finite float.

    Examples
    --------
    >>> to_expression(0.5, argument="alpha", symbols={})
    1/2
    """
    if isinstance(value, str):
        return parse_expression(value, argument=argument, symbols=symbols, free_names=free_names)
    if isinstance(value, sp.Basic):
        if not isinstance(value, sp.Expr):
            raise TypeError(f"{argument} must be a scalar expression, got {value!r}")
        return value
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(
            f"{argument} must be a string, a number or a sympy expression; "
            f"got {type(value).__name__}"
        )
    if isinstance(value, numbers.Rational):
        return sp.Rational(int(value.numerator), int(value.denominator))
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{argument} must be finite, got {value}")
    return sp.nsimplify(value, rational=True)


class _Builder:
    """Walks a syntax tree and builds its sympy expression, node type by node type."""

    def __init__(self, text: str, symbols: Mapping[str, sp.Basic], free_names: bool):
        self.text = text
        self.symbols = dict(symbols)
        self.free_names = free_names

    def build(self, node: ast.AST, depth: int) -> sp.Expr:
        if depth > MAX_DEPTH:
            raise _Refused(f"the expression is nested more than {MAX_DEPTH} levels deep")
        if isinstance(node, ast.Constant):
            return self.number(node)
        if isinstance(node, ast.Name):
            return self.name(node.id)
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.UAdd | ast.USub):
            operand = self.build(node.operand, depth + 1)
            return -operand if isinstance(node.op, ast.USub) else operand
        if isinstance(node, ast.BinOp):
            return self.binary(node, depth)
        if isinstance(node, ast.Call):
            return self.call(node, depth)
        raise _Refused(f"{self.describe(node)} is not allowed")

    def describe(self, node: ast.AST) -> str:
        """The offending part of the text, for the message."""
        segment = ast.get_source_segment(self.text, node) or type(node).__name__
        if len(segment) > 40:
            segment = segment[:37] + "..."
        kinds = {
            ast.Attribute: "attribute access",
            ast.Subscript: "subscript",
            ast.Lambda: "lambda",
            ast.Compare: "comparison",
            ast.BoolOp: "boolean operator",
            ast.IfExp: "conditional expression",
        }
        kind = next((v for k, v in kinds.items() if isinstance(node, k)), None)
        if isinstance(node, ast.ListComp | ast.SetComp | ast.DictComp | ast.GeneratorExp):
            kind = "comprehension"
        if isinstance(node, ast.BinOp | ast.UnaryOp):
            kind = f"operator {type(node.op).__name__}"
        return f"{segment!r} ({kind})" if kind else repr(segment)

    def number(self, node: ast.Constant) -> sp.Expr:
        value = node.value
        if isinstance(value, bool) or not isinstance(value, int | float):
            kind = "complex numbers" if isinstance(value, complex) else "literal"
            raise _Refused(f"{self.describe(node)} is not allowed ({kind}; numbers are real)")
        if isinstance(value, int):
            return sp.Integer(value)
        literal = (ast.get_source_segment(self.text, node) or repr(value)).replace("_", "")
        try:
            exact = Decimal(literal)
        except InvalidOperation:  # pragma: no cover - the parser accepted the literal
            exact = Decimal(repr(value))
        if not exact.is_finite() or abs(exact.adjusted()) > MAX_DECIMAL_EXPONENT:
            raise _Refused(
                f"the number {literal!r} is outside 1e-{MAX_DECIMAL_EXPONENT} .. "
                f"1e{MAX_DECIMAL_EXPONENT}"
            )
        num, den = exact.as_integer_ratio()
        return sp.Rational(num, den)

    def name(self, name: str) -> sp.Expr:
        if "__" in name:
            raise _Refused(f"{name!r} is not allowed (names must not contain '__')")
        if name in self.symbols:
            return self.symbols[name]
        if name in CONSTANTS:
            return CONSTANTS[name]
        if name in FUNCTIONS:
            raise _Refused(f"{name!r} is a function: call it, e.g. {name}(x)")
        if self.free_names:
            return sp.Symbol(name)
        raise _Refused(f"the name {name!r} is not allowed")

    def binary(self, node: ast.BinOp, depth: int) -> sp.Expr:
        if isinstance(node.op, ast.BitXor):
            raise _Refused(f"{self.describe(node)} is not allowed: write powers with ** (x**2)")
        if isinstance(node.op, ast.Pow):
            left = self.build(node.left, depth + 1)
            right = self.build(node.right, depth + 1)
            _check_power(left, right)
            return _check_size(left**right)
        if type(node.op) not in _BINARY:
            raise _Refused(f"{self.describe(node)} is not allowed")
        # a chain a + b - c + ... (or a * b / c ...) is one level, built in a loop: a long
        # sum is flat, not deep (and does not exhaust Python's recursion limit)
        chain = []
        while isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            chain.append((node.op, node.right))
            node = node.left
        value = self.build(node, depth + 1)
        for op, right in reversed(chain):
            value = _check_size(_BINARY[type(op)](value, self.build(right, depth + 1)))
        return value

    def call(self, node: ast.Call, depth: int) -> sp.Expr:
        if not isinstance(node.func, ast.Name):
            raise _Refused(f"{self.describe(node.func)} is not allowed (only named functions)")
        fname = node.func.id
        if "__" in fname:
            raise _Refused(f"{fname!r} is not allowed (names must not contain '__')")
        if fname in self.symbols or fname not in FUNCTIONS:
            raise _Refused(f"calling {fname!r} is not allowed")
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            raise _Refused(f"{fname}: only positional arguments are allowed")
        function, arities = FUNCTIONS[fname]
        if len(node.args) not in arities:
            counts = " or ".join(str(k) for k in arities)
            raise _Refused(f"{fname} takes {counts} argument(s), got {len(node.args)}")
        args = [self.build(a, depth + 1) for a in node.args]
        if fname in _FACTORIAL_TYPE:
            for a in args:
                if a.is_Number and abs(a) > MAX_FACTORIAL_ARGUMENT:
                    raise _Refused(
                        f"{fname}: numeric arguments must be at most {MAX_FACTORIAL_ARGUMENT} "
                        f"in absolute value, got {a}"
                    )
        return _check_size(function(*args))


def _bits(expr: sp.Basic) -> int:
    """Largest bit length of a numerator or denominator of a rational number in ``expr``."""
    atoms = [expr] if isinstance(expr, sp.Rational) else expr.atoms(sp.Rational)
    return max((max(int(r.p).bit_length(), int(r.q).bit_length()) for r in atoms), default=0)


def _degree(expr: sp.Basic) -> sp.Rational | int:
    """An upper bound of the total degree of ``expr`` in its symbols (powers counted)."""
    if isinstance(expr, sp.Symbol):
        return 1
    if not expr.free_symbols:
        return 0
    parts = [_degree(a) for a in expr.args]
    if isinstance(expr, sp.Pow) and expr.exp.is_Rational:
        return parts[0] * abs(expr.exp)
    if isinstance(expr, sp.Mul | sp.Pow):
        return sum(parts)
    return max(parts, default=0)


def _check_power(base: sp.Expr, exponent: sp.Expr) -> None:
    """Refuse, before computing it, a power whose exact value or expansion would be huge."""
    if not exponent.is_Number:
        return
    size = abs(exponent)
    if size > MAX_EXPONENT:
        raise _Refused(f"numeric exponents must be at most {MAX_EXPONENT}, got {exponent}")
    if _bits(base) * size > MAX_BITS:
        raise _Refused(f"a power has more than {MAX_BITS} bits ({exponent} times {_bits(base)})")
    if _degree(base) * size > MAX_DEGREE:
        raise _Refused(f"a power has degree above {MAX_DEGREE} (({base})**{exponent})")


def _check_size(expr: sp.Expr) -> sp.Expr:
    """``expr`` if its numbers and degree stay within :data:`MAX_BITS` / :data:`MAX_DEGREE`."""
    if _bits(expr) > MAX_BITS:
        raise _Refused(f"a number in the expression has more than {MAX_BITS} bits")
    if _degree(expr) > MAX_DEGREE:
        raise _Refused(f"the expression has degree above {MAX_DEGREE}")
    return expr
