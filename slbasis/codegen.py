"""Code generation: numeric closed-form modules from the derivations.

For a :class:`~slbasis.symbolic.problem.SturmLiouville` problem this emits a plain
Python + numpy module (no sympy at import or run time) with the *data* of its
L^2-orthonormal functions ``phi_n = sqrt(w) p_n``: the closed forms in ``n`` of ``B_n``,
``A_{n+1}^2`` and ``c_{n+1}/c_n`` (rational in ``n``: Gamma ratios simplified away at
generation time), ``lambda_n``, the exact values for ``n <`` :data:`SMALL_N` from direct
computation (Rodrigues + exact integrals, symbolic in the parameters), ``log w(x)``,
``log ∫ w``, the interval, ``p0`` and the parameter checks.  The generic algorithm that turns
them into a kernel (signs, small-``n`` overrides, the banded derivative operator of eq. 11 in
commutator form) is written once, in :class:`slbasis.numeric.closed_form_kernel.ClosedFormKernel`.

The catalogue's modules are generated into ``slbasis/kernels/`` and committed
(``python -m slbasis.kernels``, or ``make kernels``); a test regenerates them and fails if
they differ.  A custom problem gets its module on demand, compiled in memory
(:func:`kernel_module`).
"""

from __future__ import annotations

import hashlib
import sys
import types
from functools import lru_cache
from pathlib import Path

import sympy as sp
from sympy.core.function import AppliedUndef
from sympy.printing.numpy import NumPyPrinter

from .kernels import CATALOGUE
from .symbolic.closed_forms import gamma_simplify
from .symbolic.parse import N, X
from .symbolic.problem import SturmLiouville

#: Entries ``n < SMALL_N`` come from direct exact computation (see the module docstring).
SMALL_N = 4
KERNEL_DIR = Path(__file__).resolve().parent / "kernels"


class _XLogY(sp.Function):
    """``c * log(z)`` with ``0 * log(0) = 0`` (printed as ``scipy.special.xlogy``)."""


class _Printer(NumPyPrinter):
    """numpy for arrays in ``n`` / ``x``; ``math`` for Gamma functions of the parameters."""

    def _print__XLogY(self, expr: sp.Expr) -> str:
        c, z = (self._print(a) for a in expr.args)
        return f"scipy.special.xlogy({c}, {z})"

    def _print_loggamma(self, expr: sp.Expr) -> str:
        return f"math.lgamma({self._print(expr.args[0])})"

    def _print_gamma(self, expr: sp.Expr) -> str:
        return f"math.gamma({self._print(expr.args[0])})"


def _text(value: object) -> str:
    """``str(value)`` safe inside a generated string literal or docstring: backslashes,
    quotes and line breaks escaped, so that no text (a problem's ``name``) can end the
    literal and become code of the module that :func:`kernel_module` executes."""
    out = str(value).replace("\\", "\\\\").replace('"', '\\"')
    return out.replace("\n", "\\n").replace("\r", "\\r")


#: the generated functions' array argument: (type, description) by its name
_ARGUMENTS = {
    "n": ("ndarray of int", "Degrees, ``n >= 0``."),
    "x": ("ndarray of float", "Points of the interval."),
}


def _docstring(
    summary: str,
    parameters: list[tuple[str, str, str]],
    returns: str,
    raises: str | None = None,
) -> list[str]:
    """A generated function's numpydoc docstring, as indented source lines.

    ``parameters``: ``(name, type, description)``; ``returns`` and ``raises``: the
    section's text, its entry's lines after the first indented by four spaces.
    """
    lines = [f'    """{summary}', ""]
    if parameters:
        lines += ["    Parameters", "    ----------"]
        for name, kind, desc in parameters:
            lines += [f"    {name} : {kind}", f"        {desc}"]
        lines.append("")
    lines += ["    Returns", "    -------"]
    lines += [f"    {line}" for line in returns.split("\n")]
    if raises:
        lines += ["", "    Raises", "    ------"]
        lines += [f"    {line}" for line in raises.split("\n")]
    return [*lines, '    """']


def _code(expr: sp.Expr, names: dict[sp.Symbol, str]) -> str:
    expr = sp.sympify(expr, strict=True)
    undefined = expr.atoms(AppliedUndef)
    odd = [s.name for s in expr.free_symbols if s not in names]
    if undefined or odd:
        raise ValueError(
            f"codegen: only sympy's own functions and the symbols {sorted(map(str, names))} "
            f"can be generated; got {sorted(map(str, undefined)) + sorted(odd)}"
        )
    expr = expr.subs({s: sp.Symbol(v) for s, v in names.items()})
    if expr.has(sp.gamma) and expr.free_symbols & {sp.Symbol("n"), sp.Symbol("x")}:
        raise ValueError(f"codegen: Gamma function of n or x left in {expr}")
    return _Printer({"fully_qualified_modules": True}).doprint(expr)


def _log_expr(expr: sp.Expr) -> sp.Expr:
    """``log(expr)`` expanded (positive factors on the interval) with ``log Γ -> loggamma``
    and ``c log(z) -> xlogy(c, z)`` (so that ``w = x^0 e^-x`` is finite at ``x = 0``)."""
    out = sp.expand_log(sp.log(expr), force=True)
    out = out.replace(
        lambda e: isinstance(e, sp.log) and isinstance(e.args[0], sp.gamma),
        lambda e: sp.loggamma(e.args[0].args[0]),
    )
    terms = []
    for term in sp.Add.make_args(sp.expand(out)):
        factors = sp.Mul.make_args(term)
        logs = [f for f in factors if isinstance(f, sp.log) and f.has(X)]
        if len(logs) == 1:
            coeff = sp.Mul(*[f for f in factors if f is not logs[0]])
            terms.append(_XLogY(coeff, logs[0].args[0]))
        else:
            terms.append(term)
    return sp.Add(*terms)


def _rational(expr: sp.Expr) -> sp.Expr:
    return sp.factor(sp.cancel(gamma_simplify(expr)))


def generate_source(problem: SturmLiouville, name: str, regenerate: str) -> str:
    """Source code of the kernel module for ``problem`` (functions frame).

    The closed forms of the recurrence (``B_n``, ``A_{n+1}^2``, ``c_{n+1}/c_n``), the
    eigenvalues, the exact values for ``n < SMALL_N``, the log-weight and its mass are
    derived symbolically and printed as numpy; Gamma functions of ``n`` are simplified
    away at generation time, so the module needs no sympy at run time.

    Parameters
    ----------
    problem : SturmLiouville
        The problem (its canonical form is used).
    name : str
        The module's family name (catalogue key or ``"custom"``).
    regenerate : str
        The command that regenerates the module, for its docstring.

    Returns
    -------
    str
        The module's source (not yet formatted).

    Raises
    ------
    ValueError
        If ``p0`` has symbolic parameters, or an expression contains functions or symbols
        that cannot be generated (a Gamma function of ``n`` or ``x`` left over).
    """
    p = problem.canonical
    cf = p.closed
    params = tuple(p.params)
    pnames = {s: f"{s.name}" for s in params}
    names = {N: "n", X: "x", **pnames}
    signature = "".join(f", {s.name}" for s in params)
    p0 = sp.Poly(p.p0, X)
    p0_coeffs = tuple(sp.sympify(p0.coeff_monomial(X**k), strict=True) for k in range(3))
    if any(c.free_symbols for c in p0_coeffs):
        raise ValueError("codegen: p0 with symbolic parameters is not supported")
    a_sq = _rational(cf.jacobi_offdiag_squared)
    diag = _rational(cf.jacobi_diag)
    c_ratio = _rational(cf.c_ratio)
    lam = sp.expand(cf.eigenvalue(N))
    d = p.direct
    small_a, small_b, small_c = [], [], []
    for k in range(SMALL_N):
        coeffs = d.expand_free(d.poly(X) * d.free(k), k + 1)
        ratio = d.norm2_ratio(k + 1) / d.norm2_ratio(k)
        small_b.append(_rational(coeffs[k]))
        small_a.append(_rational(coeffs[k + 1] ** 2 * ratio))
        small_c.append(_rational(d.c(k + 1) / d.c(k)))
    log_w = _log_expr(p.polynomial_weight)
    log_mass = _log_expr(p.weight_form.total_mass)
    sign_c0 = int(sp.sign(d.c(0)))
    a, b = p.interval
    checks = "".join(
        f"    if not ({_code(e, names)}) > 0:\n"
        f'        raise ValueError("{_text(name)}: parameters must satisfy {_text(e)} > 0")\n'
        for e in dict.fromkeys(p.weight_form.assumptions)
    )
    defaults = CATALOGUE.get(name, (name, {}))[1]

    def function(fname: str, args: str, doc: str, expr: sp.Expr, shape: str) -> list[str]:
        arg = _ARGUMENTS[args]
        returns = f"ndarray of float, shape {args}.shape\n    {doc}"
        return [
            f"def {fname}({args}{signature}):",
            *_docstring(doc, [(args, *arg), *param_docs], returns),
            f"    return numpy.broadcast_to({_code(expr, names)}, {shape}).astype(float)",
            "",
            "",
        ]

    param_docs = [(s.name, "float", f"The family's parameter ``{_text(s.name)}``.") for s in params]
    raises = (
        "ValueError\n    If the parameters violate "
        + ", ".join(f"``{_text(e)} > 0``" for e in dict.fromkeys(p.weight_form.assumptions))
        + "."
        if p.weight_form.assumptions
        else None
    )

    def values(vals: list[sp.Expr]) -> str:
        return "(" + ", ".join(_code(v, names) for v in vals) + ")"

    lines = [
        f'"""Generated closed forms for {_text(p.name)}: {_text(name)}. DO NOT EDIT.',
        "",
        f"Regenerate with ``{_text(regenerate)}``.",
        f"Source: SturmLiouville(p0={_text(p.p0)}, p1={_text(p.p1)}, q0={_text(p.q0)}),",
        f"standardisation c_n = {_text(p.standardization)}. Functions n -> closed forms in n "
        "(arrays),",
        "used by slbasis.numeric.closed_form_kernel.ClosedFormKernel (conventions there).",
        '"""',
        "",
        "import math",
        "",
        "import numpy",
        "import scipy.special",
        "",
        f"name = {name!r}",
        f"interval = ({_code(a, names)}, {_code(b, names)})".replace("numpy.inf", "math.inf"),
        f"p0 = ({float(p0_coeffs[0])!r}, {float(p0_coeffs[1])!r}, {float(p0_coeffs[2])!r})",
        f"PARAMETERS = {tuple(s.name for s in params)!r}",
        f"DEFAULTS = {dict(defaults.items())!r}",
        f"P0_SIGN = {p.weight_form.p0_sign}  # sign of p0 on the interval",
        f"SIGN_C0 = {sign_c0}  # sign of the Rodrigues constant c_0",
        "",
        "",
        f"def check_parameters({signature.lstrip(', ')}):",
        *_docstring(
            "Raise ValueError when the parameters leave the admissible range.",
            param_docs,
            "None\n    Nothing: the check raises or passes.",
            raises,
        ),
        checks + "    return None",
        "",
        "",
        *function("eigenvalue", "n", "lambda_n of the polynomial problem.", lam, "n.shape"),
        *function("jacobi_diag", "n", "B_n (closed form).", diag, "n.shape"),
        *function("jacobi_offdiag_squared", "n", "A_{n+1}^2 (closed form).", a_sq, "n.shape"),
        *function(
            "c_ratio",
            "n",
            "c_{n+1}/c_n (its sign fixes the sign of A_{n+1}).",
            c_ratio,
            "n.shape",
        ),
        f"def small_values({signature.lstrip(', ')}):",
        *_docstring(
            "Exact (B_n, A_{n+1}^2, c_{n+1}/c_n) for n < len, from direct computation.",
            param_docs,
            "tuple of three tuples of float\n    B_n, A_{n+1}^2 and c_{n+1}/c_n for "
            f"n < {SMALL_N}.",
        ),
        f"    return {values(small_b)}, {values(small_a)}, {values(small_c)}",
        "",
        "",
        *function("log_weight", "x", "log w(x) of the normal-form weight.", log_w, "x.shape"),
        f"def log_mass({signature.lstrip(', ')}):",
        *_docstring(
            "log of d_0^2 / c_0^2 = ∫ w.", param_docs, "float\n    The log of the weight's mass."
        ),
        f"    return {_code(log_mass, names)}",
        "",
    ]
    source = "\n".join(lines)
    body = source.split('"""', 2)[2]
    if "math." not in body:
        source = source.replace("import math\n\n", "", 1)
    if "scipy.special." not in body.replace("import scipy.special", ""):
        source = source.replace("import scipy.special\n", "", 1)
    return source


def _format(source: str) -> str:
    """Format with ruff when available (committed modules pass ``ruff format --check``)."""
    import shutil
    import subprocess

    ruff = shutil.which("ruff") or str(Path(sys.executable).with_name("ruff"))
    try:
        out = subprocess.run(
            [ruff, "format", "--quiet", "--line-length", "100", "-"],
            input=source,
            capture_output=True,
            text=True,
            check=True,
        )
    except (OSError, subprocess.CalledProcessError):
        return source
    return out.stdout


def catalogue_source(family: str) -> str:
    """The committed source of the catalogue family's kernel module (formatted with ruff when
    it is available).

    Parameters
    ----------
    family : str
        A catalogue family name.

    Returns
    -------
    str
        The source, as committed in ``slbasis/kernels/``.
    """
    from .families import families

    return _format(
        generate_source(families[family](), CATALOGUE[family][0], "python -m slbasis.kernels")
    )


def write_catalogue(names: list[str] | None = None) -> list[Path]:
    """(Re)write ``slbasis/kernels/<family>.py`` for the catalogue.

    Parameters
    ----------
    names : list of str, optional
        The families (default: the whole catalogue).

    Returns
    -------
    list of Path
        The files written.
    """
    KERNEL_DIR.mkdir(exist_ok=True)
    written = []
    for family in names or list(CATALOGUE):
        path = KERNEL_DIR / f"{CATALOGUE[family][0]}.py"
        path.write_text(catalogue_source(family), encoding="utf-8")
        written.append(path)
    return written


@lru_cache(maxsize=64)
def _compile(source: str, module_name: str) -> types.ModuleType:
    module = types.ModuleType(module_name)
    exec(compile(source, f"<slbasis kernel {module_name}>", "exec"), module.__dict__)  # noqa: S102
    return module


def kernel_module(problem: SturmLiouville) -> types.ModuleType:
    """Kernel module for any problem, generated on demand and compiled in memory (cached).

    The source is generated from the problem's derivations; text taken from the problem
    (its name) is escaped (``_text``), so no problem can inject code into the module.

    Parameters
    ----------
    problem : SturmLiouville
        The problem.

    Returns
    -------
    module
        The compiled module (the same object for the same source).

    Examples
    --------
    >>> import numpy as np
    >>> from slbasis.families import families
    >>> mod = kernel_module(families["legendre"]())
    >>> mod.eigenvalue(np.arange(4))
    array([ 0.,  2.,  6., 12.])
    """
    source = generate_source(problem, "custom", "slbasis.codegen.kernel_module(problem)")
    digest = hashlib.sha256(source.encode()).hexdigest()[:12]
    return _compile(source, f"slbasis_kernel_{digest}")


def main(argv: list[str] | None = None) -> int:
    """``python -m slbasis.kernels [FAMILY ...]``: regenerate the catalogue's kernels.

    Parameters
    ----------
    argv : list of str, optional
        The families (default: the whole catalogue).

    Returns
    -------
    int
        The exit code, 0.
    """
    for path in write_catalogue(argv or None):
        print(f"wrote {path}")
    return 0
