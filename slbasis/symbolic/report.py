"""Derivation reports (Markdown or LaTeX) for a :class:`SturmLiouville` problem.

One function, :func:`render_report`, used by ``slbasis derive`` and by
``derivations/generate.py``; the output is deterministic so that committed reports can be
checked for staleness.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import sympy as sp

from .ladder import compare_forms
from .parse import X

if TYPE_CHECKING:
    from .problem import SturmLiouville

FORMATS = ("markdown", "latex")


@dataclass(frozen=True)
class Item:
    """One row of a report section.

    Attributes
    ----------
    label : str
        What the value is.
    value : sympy expression or str
        The value.
    """

    label: str
    value: sp.Expr | str


@dataclass(frozen=True)
class Section:
    """One section of the derivation report.

    Attributes
    ----------
    title : str
        The heading.
    items : tuple of Item
        The rows.
    text : str
        Text before the rows.
    """

    title: str
    items: tuple[Item, ...]
    text: str = ""


def _expr(value: sp.Expr | str, fmt: str) -> str:
    if isinstance(value, str):
        return value
    if fmt == "latex":
        return f"${sp.latex(value)}$"
    return f"$`{sp.latex(value)}`$"


def _bands(bands: dict[str, sp.Expr]) -> tuple[Item, ...]:
    return tuple(Item(f"{k}_n", sp.simplify(bands[k])) for k in ("sub", "diag", "sup"))


def _printed_comparison(p: SturmLiouville) -> Section:
    derived = p.derivative_operator_form("functions", "commutator")
    printed = p.derivative_operator_form("functions", "printed")
    diff = compare_forms(derived, printed)
    flipped = compare_forms(derived, _negated(printed))
    if all(v == 0 for v in diff.values()):
        verdict = "The printed eq. (11) agrees with the derivation for this family."
    elif all(v == 0 for v in flipped.values()):
        verdict = (
            "The printed eq. (11) gives exactly the negative of the derived operator "
            "(a global sign error) for this family."
        )
    else:
        verdict = (
            "The printed eq. (11), read literally (a^dagger phi_n = phi_{n+1}, "
            "a phi_n = phi_{n-1}, c_n Rodrigues constants, d_n norms, "
            "pi_n = p1 + n p0', the 0/0 at n = 1 taken as its limit), does NOT give "
            "2 p0 d/dx for this family; the derivation wins."
        )
    items = (
        Item("printed sub_n", printed.sub),
        Item("printed diag_n", printed.diag),
        Item("printed sup_n", printed.sup),
        Item("derived - printed, sup factor", diff["sup"]),
        Item("derived - printed, diag", diff["diag"]),
        Item("derived - printed, sub factor", diff["sub"]),
    )
    return Section("The printed eq. (11) against the derivation", items, verdict)


def _negated(op):
    from .ladder import BandedOperator

    return BandedOperator(-op.sup_factor, -op.diag, -op.sub_factor, op.offdiag)


def build_sections(p: SturmLiouville, nmax: int = 4) -> list[Section]:
    """The content of the report, independent of the output format.

    Parameters
    ----------
    p : SturmLiouville
        The problem.
    nmax : int, optional
        List ``P_n`` for ``n <= nmax``.

    Returns
    -------
    list of Section
        The sections.
    """
    sections = [
        Section(
            "Problem",
            (
                Item("p0(x)", p.p0),
                Item("p1(x)", p.p1),
                Item("q0(x)", p.q0),
                Item("class", f"{p.kind}-like (deg p0 = {sp.degree(p.p0, X)})"),
                Item("interval", sp.Interval.open(*p.interval)),
                Item("boundary", "; ".join(p.boundary)),
                Item("weight w(x) (eq. 9)", p.weight),
            )
            + tuple(Item("assumption", a) for a in p.assumptions),
        )
    ]
    if p.gauge is not None:
        g = p.gauge
        sections.append(
            Section(
                "Gauge (Liouville) transform",
                (
                    Item("polynomial problem p1~(x)", g.p1_poly),
                    Item("g(x), f_n = g P_n", g.factor),
                    Item("g'/g", g.log_derivative),
                    Item("shift K (lambda = lambda~ - K)", g.shift),
                    Item("weight of the polynomial problem", p.polynomial_weight),
                )
                + tuple(
                    Item("other admissible p1~ (other boundary conditions)", alt)
                    for alt in g.alternatives
                ),
                "f = g y turns p0 f'' + p1 f' - q0 f = -lambda f into "
                "p0 y'' + p1~ y' = -(lambda + K) y.",
            )
        )
    cf = p.closed
    norm_note = f" (for n >= {p.norm_start}; exact smaller values below)" if p.norm_start else ""
    sections.append(
        Section(
            "Eigenvalues, Rodrigues formula, norms",
            (
                Item("lambda_n", p.eigenvalue()),
                Item("c_n (eq. 10)", p.standardization),
                Item("leading coefficient k_n", cf.leading),
                Item("d_n^2 (eq. 7)" + norm_note, sp.simplify(p.norm_squared)),
            )
            + tuple(Item(f"P_{n}(x)", p.polynomial(n)) for n in range(nmax + 1))
            + tuple(Item(f"d_{n}^2", p.norm2(n)) for n in range(p.norm_start)),
            "lambda_n = -n (p1~' + (n-1) p0''/2): the summary prints p0' for p0'', which is "
            "not constant when deg p0 = 2.",
        )
    )
    alpha, beta, gamma = cf.recurrence
    sections.append(
        Section(
            "Three-term recurrences",
            (
                Item("alpha_n", alpha),
                Item("beta_n", beta),
                Item("gamma_n", gamma),
                Item("A_{n+1} (orthonormal)", cf.jacobi_offdiag),
                Item("B_n (orthonormal)", cf.jacobi_diag),
            ),
            "x P_n = alpha_n P_{n+1} + beta_n P_n + gamma_n P_{n-1}; "
            "x p_n = A_{n+1} p_{n+1} + B_n p_n + A_n p_{n-1} for p_n = P_n/d_n."
            + (
                f" Closed forms degenerate at n in {sorted(p.exceptional)}; exact values there "
                "come from direct computation."
                if p.exceptional
                else ""
            ),
        )
    )
    rel = p.ladder
    ops = p.ladder_operators("functions")
    sections.append(
        Section(
            "Ladder relations and operators",
            (
                Item("raising multiplier u_n x + v_n", rel.raise_mult),
                Item("raising coefficient tau_n", rel.raise_coef),
                Item("lowering multiplier u'_n x + v'_n", rel.lower_mult),
                Item("lowering coefficient sigma_n", rel.lower_coef),
                Item("a^dagger on functions: scale", ops["raise_scale"]),
                Item("a^dagger on functions: multiplier", ops["raise_mult"]),
                Item("a on functions: scale", ops["lower_scale"]),
                Item("a on functions: multiplier", ops["lower_mult"]),
            ),
            "p0 p_n' = (u_n x + v_n) p_n + tau_n A_{n+1} p_{n+1} = (u'_n x + v'_n) p_n + "
            "(sigma_n/A_n) p_{n-1}; on the orthonormal functions psi_n = sqrt(w) p_n, "
            "a^dagger psi_n = scale * (p0 psi_n' - multiplier * psi_n) = psi_{n+1} and "
            "likewise a psi_n = psi_{n-1}.",
        )
    )
    frames = ["functions", "polynomials"] + (["eigenfunctions"] if p.gauge else [])
    for frame in frames:
        sections.append(
            Section(
                f"Derivative operator 2 p0 d/dx on the orthonormal {frame} (eq. 11)",
                _bands(p.derivative_operator(frame)),
                "2 p0 psi_n' = sub_n psi_{n-1} + diag_n psi_n + sup_n psi_{n+1}; ladder form "
                "and commutator form (J Lambda - Lambda J) - p1f(J) agree exactly.",
            )
        )
    sections.append(_printed_comparison(p))
    return sections


def render_report(p: SturmLiouville, fmt: str = "markdown", nmax: int = 4) -> str:
    """The derivation report with the verification table (``verify(max(nmax, 10))``).

    Parameters
    ----------
    p : SturmLiouville
        The problem.
    fmt : {"markdown", "latex"}, optional
        The format.
    nmax : int, optional
        List ``P_n`` for ``n <= nmax``.

    Returns
    -------
    str
        The report.

    Raises
    ------
    ValueError
        If ``fmt`` is unknown.
    """
    if fmt not in FORMATS:
        raise ValueError(f"fmt must be one of {FORMATS}, got {fmt!r}")
    sections = build_sections(p, nmax=nmax)
    report = p.verify(nmax=max(nmax, 10))
    if fmt == "latex":
        return _latex(p, sections, report)
    out = [
        f"# {p.name}",
        "",
        f"Derived by `slbasis` from `p0 = {p.p0}`, `p1 = {p.p1}`, "
        f"`q0 = {p.q0}`. Symbols: `x` variable, `n` index.",
        "",
    ]
    for sec in sections:
        out += [f"## {sec.title}", ""]
        if sec.text:
            out += [sec.text, ""]
        out += ["| quantity | value |", "|---|---|"]
        out += [f"| {it.label} | {_expr(it.value, 'markdown')} |" for it in sec.items]
        out.append("")
    verdict = "all checks passed" if report.ok else "SOME CHECKS FAILED"
    out += [f"## Verification (`verify(nmax={report.nmax})`): {verdict}", ""]
    out += [report.to_markdown(), ""]
    return "\n".join(out)


def _latex(p: SturmLiouville, sections: list[Section], report) -> str:
    def esc(text: str) -> str:
        for a, b in (("_", r"\_"), ("^", r"\^{}"), ("#", r"\#"), ("&", r"\&")):
            text = text.replace(a, b)
        return text

    out = [rf"\section*{{{esc(p.name)}}}"]
    for sec in sections:
        out.append(rf"\subsection*{{{esc(sec.title)}}}")
        if sec.text:
            out.append(esc(sec.text))
        out.append(r"\begin{tabular}{ll}")
        for it in sec.items:
            value = it.value if isinstance(it.value, str) else sp.latex(it.value)
            value = esc(value) if isinstance(it.value, str) else f"${value}$"
            out.append(rf"{esc(it.label)} & {value} \\")
        out.append(r"\end{tabular}")
    out.append(rf"\subsection*{{Verification (nmax = {report.nmax})}}")
    out.append(r"\begin{tabular}{lll}")
    for c in report.checks:
        out.append(rf"{esc(c.name)} & {esc(c.scope)} & {'pass' if c.ok else 'FAIL'} \\")
    out.append(r"\end{tabular}")
    return "\n".join(out) + "\n"
