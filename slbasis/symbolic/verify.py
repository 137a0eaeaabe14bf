"""Verification of every derived object: ``SturmLiouville.verify(nmax)``.

Each check is a row ``(name, scope, ok, detail)``; ``scope`` says whether it was proved
symbolically in ``n`` or checked for every ``n <= nmax``.  The oracles are independent of the
closed forms: Rodrigues polynomials by polynomial recursion, exact integrals of the weight's
normal form, direct differentiation, sympy's own textbook polynomials, the DLMF closed forms of
the catalogue, and mpmath at 50 digits for the functions (with their non-polynomial factors).
"""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import sympy as sp

from .closed_forms import _simplify, gamma_simplify
from .ladder import compare_forms
from .parse import N, X

if TYPE_CHECKING:
    from .problem import SturmLiouville

SYMBOLIC = "symbolic in n"


@dataclass(frozen=True)
class Check:
    """One verification check and its outcome.

    Attributes
    ----------
    name : str
        What is checked.
    scope : str
        For which ``n`` (or ``"symbolic in n"``).
    ok : bool
        Whether it passed.
    detail : str
        What failed, or how it was checked.
    """

    name: str
    scope: str
    ok: bool
    detail: str = ""


@dataclass
class VerificationReport:
    """Result of :func:`verify`; ``ok`` is True when every check passed.

    Attributes
    ----------
    problem : str
        The problem's name.
    nmax : int
        The largest ``n`` checked.
    checks : list of Check
        The checks.
    """

    problem: str
    nmax: int
    checks: list[Check] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        """Whether there are checks and every one passed."""
        return bool(self.checks) and all(c.ok for c in self.checks)

    @property
    def failures(self) -> list[Check]:
        """The checks that failed."""
        return [c for c in self.checks if not c.ok]

    def add(self, name: str, scope: str, ok: bool, detail: str = "") -> None:
        """Record a check.

        Parameters
        ----------
        name : str
            What is checked.
        scope : str
            For which ``n``.
        ok : bool
            Whether it passed.
        detail : str, optional
            What failed, or how it was checked.
        """
        self.checks.append(Check(name, scope, bool(ok), detail))

    def to_markdown(self) -> str:
        """The checks as a Markdown table.

        Returns
        -------
        str
            The table (check, scope, result, detail).
        """
        rows = ["| check | scope | result | detail |", "|---|---|---|---|"]
        for c in self.checks:
            detail = c.detail.replace("|", "\\|")
            rows.append(f"| {c.name} | {c.scope} | {'pass' if c.ok else 'FAIL'} | {detail} |")
        return "\n".join(rows)

    def __str__(self) -> str:
        width = max(len(c.name) for c in self.checks) if self.checks else 10
        lines = [f"verify({self.problem}, nmax={self.nmax}): {'OK' if self.ok else 'FAILED'}"]
        for c in self.checks:
            flag = "pass" if c.ok else "FAIL"
            lines.append(f"  [{flag}] {c.name:<{width}}  ({c.scope}) {c.detail}")
        return "\n".join(lines)

    __repr__ = __str__


def _zero(expr: sp.Expr) -> bool:
    expr = sp.sympify(expr, strict=True)
    if expr == 0:
        return True
    if expr.has(sp.gamma, sp.factorial, sp.RisingFactorial, sp.binomial):
        expr = gamma_simplify(expr)
        if expr == 0:
            return True
    if sp.simplify(expr) == 0:
        return True
    if sp.simplify(sp.gammasimp(sp.expand(expr))) == 0:
        return True
    if not expr.free_symbols:  # constants such as Γ(1/4)Γ(3/4)/π that sympy leaves alone:
        return abs(sp.N(expr, 60)) < sp.Float(10) ** -50  # 60-digit mpmath evaluation
    return False


def _equal_radicals(a: sp.Expr, b: sp.Expr, sample: dict) -> bool:
    """``a == b`` for expressions ``rational * sqrt(rational)``: equal squares (a rational
    identity) and equal signs at an admissible sample point of the parameters."""
    a, b = sp.sympify(a, strict=True), sp.sympify(b, strict=True)
    if _zero(a - b):
        return True
    if not _zero(sp.factor(sp.cancel(sp.expand(a**2 - b**2)))):
        return False
    va, vb = (sp.N(v.subs(sample), 30) for v in (a, b))
    return sp.sign(va) == sp.sign(vb)


def _every_n(nmax: int, fn: Callable[[int], bool], start: int = 0) -> tuple[bool, str]:
    bad = [n for n in range(start, nmax + 1) if not fn(n)]
    return (not bad, f"failed at n = {bad}" if bad else "")


def verify(problem: SturmLiouville, nmax: int = 10) -> VerificationReport:
    """Run all checks on ``problem`` for ``n <= nmax`` and symbolically in ``n``.

    Every closed form is checked against first-principles computation
    (:mod:`slbasis.symbolic.direct`): the ODE, orthogonality, the norms, the recurrences, the
    Jacobi entries, the ladder relations and eq. 11 in both forms, and, for a catalogue
    family, the textbook oracles (DLMF Table 18.3.1, 18.9).

    Parameters
    ----------
    problem : SturmLiouville
        The problem.
    nmax : int, optional
        The largest ``n`` checked at integer values, ``>= 2``.

    Returns
    -------
    VerificationReport
        The checks and their outcome.

    Raises
    ------
    ValueError
        If ``nmax`` is not an integer ``>= 2``.

    References
    ----------
    .. [1] F. W. J. Olver et al. (eds.), *NIST Handbook of Mathematical Functions*,
       Cambridge University Press, 2010, ch. 18.

    Examples
    --------
    >>> from slbasis.families import families
    >>> verify(families["legendre"](), nmax=3).ok
    True
    """
    if isinstance(nmax, bool) or not isinstance(nmax, int) or nmax < 2:
        raise ValueError(f"nmax must be an integer >= 2, got {nmax!r}")
    rep = VerificationReport(problem.name, nmax)
    p = problem
    subst = p.positive_substitution()

    def _is_zero(expr: sp.Expr) -> bool:  # noqa: F811 - parameters made positive first
        return _zero(sp.sympify(expr, strict=True).subs(subst))

    sample = {
        u: sp.Rational(4, 3) + sp.Rational(i, 7)
        for i, u in enumerate(
            sorted(
                set().union(*(e.free_symbols for e in subst.values())) if subst else set(), key=str
            )
        )
    }
    sample.update({s: v for s, v in _sample(p).items() if s not in subst})

    def _same(a: sp.Expr, b: sp.Expr) -> bool:
        return _equal_radicals(
            sp.sympify(a, strict=True).subs(subst), sp.sympify(b, strict=True).subs(subst), sample
        )

    cf = p.closed
    d = p.direct
    p0, p1 = p.p0, p.p1_poly
    scope_n = f"n <= {nmax}"

    # --- weight, interval --------------------------------------------------------------
    # (p0 w)' = p1 w  <=>  p0' + p0 (log w)' = p1; log w expanded on the interval where
    # every base of the normal form is positive.
    log_w = sp.expand_log(sp.log(p.polynomial_weight), force=True)
    rep.add(
        "Pearson equation (p0 w)' = p1 w",
        "symbolic in x",
        _is_zero(sp.cancel(sp.diff(p0, X) + p0 * sp.diff(log_w, X) - p1)),
    )
    rep.add(
        "eigenvalue from the x^n coefficient",
        SYMBOLIC,
        _is_zero(cf.k.a * N * (N - 1) + cf.k.d * N + cf.eigenvalue(N)),
        f"lambda_n = {p.eigenvalue()}",
    )

    # --- Rodrigues polynomials: ODE, orthogonality, leading coefficients ----------------
    # The ODE and the orthogonality are linear in P_n = c_n Q_n: checked on Q_n.
    dp0, dp1 = d.p0, d.p1

    def ode(n: int) -> bool:
        q = d.free(n)
        lam = d.poly(cf.eigenvalue(n))
        return (dp0 * q.diff((X, 2)) + dp1 * q.diff(X) + q * lam).is_zero

    ok, detail = _every_n(nmax, ode)
    rep.add("ODE p0 P'' + p1 P' + lambda P = 0 (Rodrigues P_n)", scope_n, ok, detail)
    if p.gauge is not None:
        h = p.gauge.log_derivative

        def gauge_ode(n: int) -> bool:
            q = d.free(n).as_expr()
            f1 = sp.diff(q, X) + h * q  # f'/g
            f2 = sp.diff(q, X, 2) + 2 * h * sp.diff(q, X) + (sp.diff(h, X) + h**2) * q
            return _is_zero(sp.cancel(p0 * f2 + p.p1 * f1 - p.q0 * q + p.eigenvalue(n) * q))

        ok, detail = _every_n(nmax, gauge_ode)
        rep.add("ODE of the gauge problem for f_n = g P_n (with q0)", scope_n, ok, detail)
        rep.add(
            "gauge factor: g'/g = h",
            "symbolic in x",
            _is_zero(sp.simplify(sp.diff(p.gauge.factor, X) / p.gauge.factor - h)),
            f"g = {p.gauge.factor}",
        )
    ortho_max = min(nmax, 8)

    def orthogonal(n: int) -> bool:
        q = d.free(n)
        return all(_is_zero(d.integrate(q * d.poly(X**j))) for j in range(n))

    ok, detail = _every_n(ortho_max, orthogonal)
    rep.add("orthogonality ∫ P_n x^j w = 0, j < n (exact)", f"n <= {ortho_max}", ok, detail)
    ok, detail = _every_n(
        nmax, lambda n: _is_zero(d.polynomial(n).LC() - cf.leading.subs(N, n).doit())
    )
    rep.add("leading coefficient k_n closed form", scope_n, ok, detail)
    start = p.norm_start
    closed_start = p.norm2(start)

    def norm_matches(n: int) -> bool:
        # ratio to the anchor: Gamma factors of the parameters cancel, leaving a rational
        # identity (fast); the anchor itself is compared once, in full
        closed = gamma_simplify(p.norm_squared.subs(N, n) / closed_start)
        return _is_zero(closed - d.norm2(n) / d.norm2(start))

    ok, detail = _every_n(nmax, norm_matches, start=start)
    ok = ok and _is_zero(closed_start - d.norm2(start))
    rep.add(
        "norm d_n^2 closed form vs exact integral",
        scope_n + (f", n >= {p.norm_start}" if p.norm_start else ""),
        ok,
        detail,
    )

    # --- recurrences -------------------------------------------------------------------
    # x P_n = alpha P_{n+1} + beta P_n + gamma P_{n-1}  <=>  (dividing by c_n)
    # x Q_n = alpha (c_{n+1}/c_n) Q_{n+1} + beta Q_n + gamma (c_{n-1}/c_n) Q_{n-1}.
    alpha, beta, gamma = cf.recurrence
    exc = set(p.exceptional)

    def recurrence_holds(n: int) -> bool:
        e = d.expand_free(d.poly(X) * d.free(n), n + 1)
        expected = [sp.Integer(0)] * (n + 2)
        expected[n + 1] = alpha.subs(N, n) * d.c(n + 1) / d.c(n)
        expected[n] = beta.subs(N, n)
        if n > 0:
            expected[n - 1] = gamma.subs(N, n) * d.c(n - 1) / d.c(n)
        return all(_is_zero(a - b) for a, b in zip(e, expected, strict=True))

    ok, detail = _every_n(nmax, lambda n: n in exc or recurrence_holds(n))
    rep.add(
        "three-term recurrence x P_n = alpha P_{n+1} + beta P_n + gamma P_{n-1}",
        scope_n + (f", n not in {sorted(exc)}" if exc else ""),
        ok,
        detail,
    )

    def jacobi_entries(n: int) -> bool:
        coeffs = d.orthonormal_coefficients(d.poly(X) * d.free(n), n, n + 1)
        return _same(p._value("A_next", n), coeffs[n + 1]) and _is_zero(
            p._value("B", n) - coeffs[n]
        )

    ok, detail = _every_n(nmax, jacobi_entries)
    rep.add("orthonormal Jacobi matrix A_{n+1}, B_n vs direct expansion", scope_n, ok, detail)

    # --- ladder relations ----------------------------------------------------------------
    # p0 P_n' = (u x + v) P_n + t P_{n+1} with t = tau/kappa; on Q_n the P_{n+1} coefficient
    # becomes tau/kappa_free, and the lowering one sigma kappa_free(n-1).
    rel = p.ladder

    def ladder_holds(n: int) -> bool:
        if n in exc:
            return True
        q = d.free(n)
        deriv = dp0 * q.diff(X)
        up = d.expand_free(deriv - d.poly(rel.raise_mult.subs(N, n)) * q, n + 1)
        ok_up = all(_is_zero(c) for c in up[: n + 1]) and _is_zero(
            up[n + 1] - rel.raise_coef.subs(N, n) / cf.kappa_free.subs(N, n)
        )
        down = d.expand_free(deriv - d.poly(rel.lower_mult.subs(N, n)) * q, n + 1)
        if n == 0:
            return ok_up and all(_is_zero(c) for c in down)
        ok_down = all(_is_zero(c) for i, c in enumerate(down) if i != n - 1) and _is_zero(
            down[n - 1] - rel.lower_coef.subs(N, n) * cf.kappa_free.subs(N, n - 1)
        )
        return ok_up and ok_down

    ok, detail = _every_n(nmax, ladder_holds)
    rep.add("raising and lowering relations vs direct differentiation", scope_n, ok, detail)
    k = cf.k
    pi_n = p1 + N * sp.diff(p0, X)
    nu_form = -(k.d + (N - 1) * k.a) / (k.d + 2 * N * k.a) * pi_n  # lambda_n pi_n/(n pi_n')
    rep.add(
        "raising multiplier = lambda_n pi_n(x)/(n pi_n') (Nikiforov-Uvarov)",
        SYMBOLIC,
        _is_zero(_simplify(rel.raise_mult - nu_form)),
    )

    # --- derivative operator: two derivations, direct differentiation -------------------
    for frame in ("functions", "polynomials") + (("eigenfunctions",) if p.gauge else ()):
        comm = p.derivative_operator_form(frame, "commutator")
        lad = p.derivative_operator_form(frame, "ladder")
        diff = compare_forms(comm, lad)
        rep.add(
            f"eq. (11) ladder form == commutator form ({frame})",
            SYMBOLIC,
            all(v == 0 for v in diff.values()),
            "" if all(v == 0 for v in diff.values()) else str(diff),
        )

        def direct_bands(n: int, frame: str = frame) -> bool:
            if n in exc:
                return True
            closed = p.derivative_band_values(n, frame)
            direct = p._direct_bands(n, frame)
            return all(_same(c, e) for c, e in zip(closed, direct, strict=True))

        ok, detail = _every_n(nmax, direct_bands)
        rep.add(f"2 p0 d/dx bands vs direct differentiation ({frame})", scope_n, ok, detail)
    ok, detail = _function_check(p, min(nmax, 12))
    rep.add(
        "2 p0 d/dx on psi_n = sqrt(w) p_n at random points (50 digits)",
        f"n <= {min(nmax, 12)}",
        ok,
        detail,
    )

    # --- textbook oracles (catalogue families) ------------------------------------------
    oracle = getattr(p, "oracle", None)
    if oracle is not None:
        _oracle_checks(rep, p, oracle, nmax)
    return rep


def _sample(p: SturmLiouville) -> dict[sp.Symbol, sp.Expr]:
    """A fixed admissible point for symbolic parameters (used only for signs / numerics)."""
    values = {}
    for i, sym in enumerate(p.params):
        values[sym] = sp.Rational(1, 3) + sp.Rational(i, 7)
    return values


def _function_check(p: SturmLiouville, nmax: int) -> tuple[bool, str]:
    """Differentiate ``psi_n = sqrt(w) P_n / d_n`` with sympy (parameters at a sample
    point) and compare ``2 p0 psi_n'`` with the band expansion at random points, 50 digits."""
    sub = _sample(p)
    a, b = (sp.N(e.subs(sub)) for e in p.interval)
    rng = random.Random(20261121)
    # sample inside the interval: a window of width 6 at the finite end(s)
    if a.is_finite and b.is_finite:
        lo, hi = float(a), float(b)
    elif a.is_finite:
        lo, hi = float(a), float(a) + 6.0
    elif b.is_finite:  # (-oo, b): e.g. Laguerre under x -> -x (hypothesis found it)
        lo, hi = float(b) - 6.0, float(b)
    else:
        lo, hi = -3.0, 3.0
    points = [sp.Float(lo + (hi - lo) * rng.uniform(0.05, 0.95), 50) for _ in range(3)]
    root_w = sp.sqrt(p.polynomial_weight.subs(sub))
    d = p.direct
    funcs = []
    for n in range(nmax + 2):
        const = sp.N((d.c(n) / sp.sqrt(p.norm2(n))).subs(sub), 50)
        funcs.append(root_w * d.free(n).as_expr().subs(sub) * const)
    p0 = p.p0.subs(sub)
    worst = 0.0
    for n in range(nmax + 1):
        sub_n, diag_n, sup_n = (sp.N(v.subs(sub), 50) for v in p.derivative_band_values(n))
        lhs = 2 * p0 * sp.diff(funcs[n], X)
        rhs = diag_n * funcs[n] + sup_n * funcs[n + 1] + (sub_n * funcs[n - 1] if n else 0)
        for xv in points:
            left, right = (sp.N(e.subs(X, xv), 50) for e in (lhs, rhs))
            worst = max(worst, abs(float(left - right)) / max(1.0, abs(float(left))))
    # 50-digit evaluation of moderately sized polynomials: agreement to 1e-30 or better.
    return worst < 1e-30, f"max relative difference {worst:.1e}"


def _oracle_checks(rep: VerificationReport, p: SturmLiouville, oracle, nmax: int) -> None:
    subst = p.positive_substitution()

    def _is_zero(expr: sp.Expr) -> bool:
        return _zero(sp.sympify(expr, strict=True).subs(subst))

    cf = p.closed
    d = p.direct

    def same_polynomial(n: int) -> bool:
        # rational part: the textbook polynomial is a multiple of Q_n; constant part: c_n.
        ref = sp.Poly(sp.expand(oracle.polynomial(n)), X)
        q = d.free(n)
        scale = sp.cancel(ref.LC() / q.LC().as_expr() if hasattr(q.LC(), "as_expr") else q.LC())
        rest = sp.expand(ref.as_expr() - scale * q.as_expr())
        return _is_zero(rest) and _is_zero(scale - d.c(n))

    ok, detail = _every_n(nmax, same_polynomial)
    rep.add("Rodrigues P_n == sympy's textbook polynomial", f"n <= {nmax}", ok, detail)
    if oracle.norm2 is not None:
        start = max(oracle.norm2_from, p.norm_start)
        ratio = sp.simplify(gamma_simplify(p.norm2(N) / oracle.norm2))
        if isinstance(ratio, sp.Piecewise):  # sympy splits on parameter signs: every branch
            ratio = sp.Integer(all(sp.trigsimp(sp.simplify(e)) == 1 for e, _ in ratio.args))
        rep.add(
            "norm d_n^2 == DLMF 18.3.1",
            SYMBOLIC + (f", n >= {start}" if start else ""),
            ratio == 1,
            "" if ratio == 1 else f"ratio {ratio}",
        )
        ok, detail = _every_n(
            nmax,
            lambda n: _is_zero(p.norm2(n) - oracle.norm2.subs(N, n).doit()),
            start=oracle.norm2_from,
        )
        rep.add("norm d_n^2 == DLMF 18.3.1", f"n <= {nmax}", ok, detail)
    if oracle.recurrence is not None:
        diffs = [
            _simplify(gamma_simplify(o - t))
            for o, t in zip(cf.recurrence, oracle.recurrence, strict=True)
        ]
        rep.add(
            "recurrence (alpha, beta, gamma) == DLMF 18.9",
            SYMBOLIC,
            all(v == 0 for v in diffs),
            "" if all(v == 0 for v in diffs) else f"differences {diffs}",
        )
    if oracle.derivative is not None:
        frame, expected, start = oracle.derivative
        bands = p.derivative_operator(frame)
        diffs = {
            key: sp.simplify(sp.radsimp(bands[key] - expected[key]))
            for key in ("sub", "diag", "sup")
        }
        symbolic = all(v == 0 for v in diffs.values())
        ok = symbolic or all(  # sqrt expressions sympy cannot merge: every n up to nmax
            _is_zero(bands[key].subs(N, n) - expected[key].subs(N, n))
            for key in ("sub", "diag", "sup")
            for n in range(max(start, 1), nmax + 1)
        )
        rep.add(
            f"derivative operator ({frame}) == closed form (thesis eq. 3 / DLMF)",
            (SYMBOLIC if symbolic else f"{max(start, 1)} <= n <= {nmax}")
            + (f", n >= {start}" if start and symbolic else ""),
            ok,
            ", ".join(f"{k}_n = {bands[k]}" for k in ("sub", "diag", "sup")),
        )
