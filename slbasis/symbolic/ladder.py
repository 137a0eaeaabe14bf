"""Ladder operators and the banded derivative operator ``2 p0 d/dx`` (eq. 11).

Conventions (the summary's eq. 11 mixes several; these are ours, used everywhere):

* ``P_n`` Rodrigues polynomials with constants ``c_n`` (eq. 10), norms ``d_n^2`` (eq. 7),
  ``p_n = P_n / d_n`` orthonormal polynomials in ``L^2(w)``, Jacobi matrix
  ``x p_n = A_{n+1} p_{n+1} + B_n p_n + A_n p_{n-1}``.
* A *frame* is a family ``psi_n = g p_n`` with ``g'/g = (p1~ - p1f)/(2 p0)``, ``p1~`` the
  polynomial problem's ``p1``: ``p1f = p1~`` gives the orthonormal polynomials (``g = 1``),
  ``p1f = p0'`` the orthonormal *functions* ``sqrt(w) p_n`` in ``L^2(dx)``, and for a gauge
  problem ``p1f`` = its own ``p1`` gives its eigenfunctions.  Then
  ``2 p0 psi_n' = g (2 p0 p_n' + (p1~ - p1f) p_n)``.
* Raising relation ``p0 p_n' = (u_n x + v_n) p_n + tau_n A_{n+1} p_{n+1}`` and lowering
  relation ``p0 p_n' = (u'_n x + v'_n) p_n + (sigma_n / A_n) p_{n-1}``, both from comparing
  the three top coefficients (``tau_n, sigma_n`` rational in ``n``).  The ladder operators on
  a frame are the first-order operators
  ``a^† psi_n = psi_{n+1} = [p0 d/dx - (u_n x + v_n + (p1~ - p1f)/2)] psi_n / (tau_n A_{n+1})``
  and ``a psi_n = psi_{n-1} = (A_n/sigma_n) [p0 d/dx - (u'_n x + v'_n + (p1~ - p1f)/2)] psi_n``.
  (The raising part reproduces Nikiforov–Uvarov's
  ``u_n x + v_n = lambda_n pi_n(x) / (n pi_n')``, ``pi_n = p1~ + n p0'``.)

**Eq. (11), ladder form**: adding the two relations,
``2 p0 psi_n' = tau_n A_{n+1} psi_{n+1} + (sigma_n/A_n) psi_{n-1} + (mu_n x + nu_n) psi_n``
with ``mu_n x + nu_n = (u_n + u'_n) x + v_n + v'_n + p1~ - p1f``; the remaining multiplication
by ``x`` is tridiagonal through the Jacobi matrix, so

``sup_n = A_{n+1} (tau_n + mu_n)``, ``diag_n = mu_n B_n + nu_n``,
``sub_n = A_n (sigma_n / A_n^2 + mu_n)``.

**Commutator form** (independent): ``L = p0 d^2 + p1~ d`` has ``[L, x] = 2 p0 d/dx + p1~``
and ``L p_n = -lambda_n p_n``; on a frame this gives ``2 p0 d/dx = (J Lambda - Lambda J) -
p1f(J)``:

``sup_n = A_{n+1} (lambda_n - lambda_{n+1} - p1f')``, ``diag_n = -(p1f' B_n + p1f(0))``,
``sub_n = A_n (lambda_n - lambda_{n-1} - p1f')``.

Both are ``A_{n+1} U(n)``, ``D(n)``, ``A_n L(n)`` with ``U, D, L`` rational in ``n``; their
agreement is a rational identity, checked exactly by :func:`compare_forms`.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .closed_forms import ClosedForms, _simplify
from .parse import N, X


@dataclass(frozen=True)
class BandedOperator:
    """A tridiagonal operator ``T psi_n = sub_n psi_{n-1} + diag_n psi_n + sup_n psi_{n+1}``.

    Stored as ``sup_n = A_{n+1} sup_factor``, ``sub_n = A_n sub_factor`` with the rational
    factors separate from the Jacobi entries ``A``, so that two forms are compared by a
    rational identity (:func:`compare_forms`).

    Attributes
    ----------
    sup_factor : sympy expression
        Rational in ``n``.
    diag : sympy expression
        ``diag_n``.
    sub_factor : sympy expression
        Rational in ``n``.
    offdiag : sympy expression
        ``A_{n+1}``.
    """

    sup_factor: sp.Expr
    diag: sp.Expr
    sub_factor: sp.Expr
    offdiag: sp.Expr

    @property
    def sup(self) -> sp.Expr:
        """Coefficient of ``psi_{n+1}`` in ``T psi_n``."""
        return self.offdiag * self.sup_factor

    @property
    def sub(self) -> sp.Expr:
        """Coefficient of ``psi_{n-1}`` in ``T psi_n``."""
        return self.offdiag.subs(N, N - 1) * self.sub_factor

    def bands(self) -> dict[str, sp.Expr]:
        """The bands as closed forms in ``n``.

        Returns
        -------
        dict of str to sympy expression
            ``{"sub": ..., "diag": ..., "sup": ...}``.
        """
        return {"sub": sp.simplify(self.sub), "diag": self.diag, "sup": sp.simplify(self.sup)}


@dataclass(frozen=True)
class LadderRelations:
    """Raising and lowering relations of the orthonormal polynomials (module docstring).

    Attributes
    ----------
    raise_mult : sympy expression
        ``u_n x + v_n``.
    raise_coef : sympy expression
        ``tau_n`` (the ``p_{n+1}`` coefficient is ``tau_n A_{n+1}``).
    lower_mult : sympy expression
        ``u'_n x + v'_n``.
    lower_coef : sympy expression
        ``sigma_n`` (the ``p_{n-1}`` coefficient is ``sigma_n / A_n``).
    """

    raise_mult: sp.Expr  # u_n x + v_n
    raise_coef: sp.Expr  # tau_n  (p_{n+1} coefficient is tau_n A_{n+1})
    lower_mult: sp.Expr  # u'_n x + v'_n
    lower_coef: sp.Expr  # sigma_n (p_{n-1} coefficient is sigma_n / A_n)


def ladder_relations(cf: ClosedForms) -> LadderRelations:
    """Solve the top-coefficient equations for the raising and lowering relations.

    Comparing the three top coefficients of ``p0 p_n'`` with ``(u_n x + v_n) p_n + tau_n
    A_{n+1} p_{n+1}`` (and the lowering analogue) gives linear equations in the unknowns,
    rational in ``n``.

    Parameters
    ----------
    cf : ClosedForms
        The problem's closed forms.

    Returns
    -------
    LadderRelations
        The relations.

    References
    ----------
    .. [1] A. F. Nikiforov and V. B. Uvarov, *Special Functions of Mathematical Physics*,
       Birkhauser, 1988, sec. 5.
    """
    k = cf.k
    r1, r2 = cf.rho1, cf.rho2
    u, v, tau = sp.symbols("u v tau")
    lhs = (
        k.a * N,
        k.a * (N - 1) * r1 + k.b * N,
        k.a * (N - 2) * r2 + k.b * (N - 1) * r1 + k.c * N,
    )
    up = sp.solve(
        [
            lhs[0] - (u + tau),
            lhs[1] - (u * r1 + v + tau * r1.subs(N, N + 1)),
            lhs[2] - (u * r2 + v * r1 + tau * r2.subs(N, N + 1)),
        ],
        [u, v, tau],
        dict=True,
    )[0]
    u_low = k.a * N
    v_low = _simplify(lhs[1] - u_low * r1)
    sigma = _simplify(lhs[2] - u_low * r2 - v_low * r1)
    return LadderRelations(
        raise_mult=_simplify(up[u] * X + up[v]),
        raise_coef=_simplify(up[tau]),
        lower_mult=_simplify(u_low * X + v_low),
        lower_coef=sigma,
    )


def _linear(expr: sp.Expr) -> tuple[sp.Expr, sp.Expr]:
    poly = sp.Poly(sp.expand(expr), X)
    if poly.degree() > 1:
        raise ValueError(f"expected a polynomial of degree <= 1 in x, got {expr}")
    return poly.coeff_monomial(X), poly.coeff_monomial(1)


def commutator_form(cf: ClosedForms, p1_frame: sp.Expr) -> BandedOperator:
    """``2 p0 d/dx = (J Lambda - Lambda J) - p1f(J)`` on the frame of ``p1_frame``.

    ``L = p0 d^2 + p1~ d`` has ``[L, x] = 2 p0 d/dx + p1~`` and ``L p_n = -lambda_n p_n``.

    Parameters
    ----------
    cf : ClosedForms
        The problem's closed forms.
    p1_frame : sympy expression
        The frame's ``p1f`` (degree at most 1).

    Returns
    -------
    BandedOperator
        ``sup_n = A_{n+1}(lambda_n - lambda_{n+1} - p1f')``, ``diag_n = -(p1f' B_n +
        p1f(0))``, ``sub_n = A_n(lambda_n - lambda_{n-1} - p1f')``.

    Raises
    ------
    ValueError
        If ``p1_frame`` has degree above 1.
    """
    lam = cf.eigenvalue
    slope, intercept = _linear(p1_frame)
    return BandedOperator(
        sup_factor=_simplify(lam(N) - lam(N + 1) - slope),
        diag=_simplify(-(slope * cf.jacobi_diag + intercept)),
        sub_factor=_simplify(lam(N) - lam(N - 1) - slope),
        offdiag=cf.jacobi_offdiag,
    )


def ladder_form(
    cf: ClosedForms, rel: LadderRelations, p1_poly: sp.Expr, p1_frame: sp.Expr
) -> BandedOperator:
    """Eq. (11) from the ladder relations (raising + lowering + multiplication part).

    Parameters
    ----------
    cf : ClosedForms
        The problem's closed forms.
    rel : LadderRelations
        The ladder relations (:func:`ladder_relations`).
    p1_poly : sympy expression
        ``p1~`` of the polynomial problem.
    p1_frame : sympy expression
        The frame's ``p1f``.

    Returns
    -------
    BandedOperator
        ``sup_n = A_{n+1}(tau_n + mu_n)``, ``diag_n = mu_n B_n + nu_n``, ``sub_n =
        A_n(sigma_n / A_n^2 + mu_n)``.

    Raises
    ------
    ValueError
        If the multiplier is not linear in ``x``.
    """
    mu, nu = _linear(rel.raise_mult + rel.lower_mult + p1_poly - p1_frame)
    a_sq = cf.jacobi_offdiag_squared.subs(N, N - 1)
    return BandedOperator(
        sup_factor=_simplify(rel.raise_coef + mu),
        diag=_simplify(mu * cf.jacobi_diag + nu),
        sub_factor=_simplify(rel.lower_coef / a_sq + mu),
        offdiag=cf.jacobi_offdiag,
    )


def printed_eq11(cf: ClosedForms, p1_poly: sp.Expr, p0: sp.Expr) -> BandedOperator:
    """Eq. (11) exactly as printed in the summary, read on the orthonormal functions.

    Reading: ``a^dagger phi_n = phi_{n+1}``, ``a phi_n = phi_{n-1}``, ``c_n`` the Rodrigues
    constants, ``d_n`` the norms (``d_n^2`` of eq. 7), ``pi_n = p1 + n p0'``; the printed
    ``lambda_{n-1}/((n-1) pi'_{n-1})`` is 0/0 at ``n = 1`` and is taken as its limit.  Kept
    only to document where the printed formula differs from the derivation.

    Parameters
    ----------
    cf : ClosedForms
        The problem's closed forms.
    p1_poly : sympy expression
        ``p1~`` of the polynomial problem.
    p0 : sympy expression
        ``p0``.

    Returns
    -------
    BandedOperator
        The printed formula's bands.
    """
    k = cf.k
    dp0 = sp.diff(p0, X)

    def ell(m: sp.Expr) -> sp.Expr:  # lambda_m / (m pi_m'), with lambda_m/m simplified
        return -(k.d + (m - 1) * k.a) / (k.d + 2 * m * k.a)

    def pi(m: sp.Expr) -> sp.Expr:
        return p1_poly + m * dp0

    mu, nu = _linear(-ell(N) * pi(N) + ell(N - 1) * pi(N - 1) - dp0)
    return BandedOperator(
        sup_factor=_simplify(cf.kappa_free * ell(N) + mu),
        diag=_simplify(mu * cf.jacobi_diag + nu),
        sub_factor=_simplify(-cf.kappa_free.subs(N, N - 1) * ell(N - 1) + mu),
        offdiag=cf.jacobi_offdiag,
    )


def compare_forms(first: BandedOperator, second: BandedOperator) -> dict[str, sp.Expr]:
    """Exact differences of the rational band factors (all zero when the forms agree).

    Parameters
    ----------
    first : BandedOperator
        One form.
    second : BandedOperator
        The other, with the same ``offdiag``.

    Returns
    -------
    dict of str to sympy expression
        ``sup``, ``diag`` and ``sub`` differences, simplified.
    """
    return {
        "sup": _simplify(first.sup_factor - second.sup_factor),
        "diag": _simplify(first.diag - second.diag),
        "sub": _simplify(first.sub_factor - second.sub_factor),
    }
