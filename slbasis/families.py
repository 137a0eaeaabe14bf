"""The catalogue of classical families, each a :class:`SturmLiouville` plus textbook oracles.

Each entry is ``(p0, p1, q0)`` and the Rodrigues constant ``c_n`` of the textbook
standardisation (DLMF 18.5.5 and Table 18.5.1), so that ``P_n`` are the textbook polynomials.
The textbook closed forms (DLMF Table 18.3.1 norms, 18.9.1-18.9.2 recurrences, sympy's
polynomials) are used *only* as oracles in :func:`slbasis.symbolic.verify.verify`: the
derivations never read them.

>>> from slbasis import families
>>> families.legendre().eigenvalue()
n**2 + n
>>> sorted(families)[:3]
['chebyshev_t', 'chebyshev_u', 'gegenbauer']
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import sympy as sp

    from .symbolic.expr import to_expression
    from .symbolic.parse import N, X
    from .symbolic.problem import SturmLiouville

#: a parameter value: a number, a string or sympy expression, or None (symbolic)
Param = Any


def _symbolic() -> None:
    """Bind ``sp``, ``N``, ``X`` and ``SturmLiouville`` here on the first derivation.

    The catalogue itself (names, parameters, descriptions) needs no sympy, so
    ``import slbasis`` does not import it; the builders below run only through
    :meth:`Family.with_oracle`, which calls this first.
    """
    global sp, N, X, SturmLiouville, to_expression
    import sympy as sp

    from .symbolic.expr import to_expression
    from .symbolic.parse import N, X
    from .symbolic.problem import SturmLiouville


@dataclass(frozen=True)
class Oracle:
    """Textbook closed forms of one family member (functions of ``n`` and ``x``).

    Used only by :func:`slbasis.symbolic.verify.verify` to check the derivations, which
    never read them.

    Attributes
    ----------
    polynomial : callable
        ``polynomial(n)``: ``P_n(x)`` for an integer ``n``, from sympy.
    norm2 : sympy expression or None
        ``d_n^2`` in closed form (DLMF 18.3.1).
    norm2_from : int
        ``norm2`` holds for ``n >=`` this.
    recurrence : tuple of sympy expressions or None
        ``(alpha, beta, gamma)`` of the textbook recurrence (DLMF 18.9.1-18.9.2).
    recurrence_from : int
        ``recurrence`` holds for ``n >=`` this.
    derivative : tuple or None
        Closed forms of the bands of ``2 p0 d/dx``: ``(frame, {"sub", "diag", "sup"}, valid
        from n)``.
    """

    polynomial: Callable[[int], sp.Expr]  # P_n(x) for integer n, from sympy
    norm2: sp.Expr | None = None  # d_n^2 in closed form (DLMF 18.3.1)
    norm2_from: int = 0  # closed form valid for n >= this
    recurrence: tuple[sp.Expr, sp.Expr, sp.Expr] | None = None  # alpha, beta, gamma
    recurrence_from: int = 0
    # closed forms of the bands of 2 p0 d/dx: (frame, {"sub", "diag", "sup"}, valid from n)
    derivative: tuple[str, dict[str, sp.Expr], int] | None = None


@dataclass(frozen=True)
class Family:
    """A catalogue entry: ``family(**params)`` gives the problem, ``with_oracle`` also its
    oracle.

    Attributes
    ----------
    name : str
        The catalogue name.
    parameters : tuple of str
        The names of its parameters.
    description : str
        One line: the polynomials, weight and interval.

    Examples
    --------
    >>> from slbasis.families import families
    >>> families["jacobi"].parameters
    ('alpha', 'beta')
    >>> families["legendre"]().eigenvalue()
    n**2 + n
    """

    name: str
    parameters: tuple[str, ...]
    description: str
    _build: Callable[..., tuple[SturmLiouville, Oracle]]

    def __call__(self, **params: Param) -> SturmLiouville:
        """The :class:`SturmLiouville` of this family (symbolic parameters if omitted)."""
        return self.with_oracle(**params)[0]

    def with_oracle(self, **params: Param) -> tuple[SturmLiouville, Oracle]:
        """The :class:`~slbasis.symbolic.problem.SturmLiouville` of this family and its textbook
        oracle.

        Strings go through the safe parser (numbers, constants, whitelisted functions), never
        through ``sympify``; an omitted parameter stays symbolic.

        Parameters
        ----------
        **params : number, str or sympy expression
            The family's parameters.

        Returns
        -------
        problem : SturmLiouville
            The problem (with ``oracle`` and ``family`` set).
        oracle : Oracle
            The textbook closed forms.

        Raises
        ------
        TypeError
            If a parameter is unknown or of the wrong type.
        ValueError
            If a parameter value is decidably outside the admissible range.
        """
        unknown = set(params) - set(self.parameters)
        if unknown:
            raise TypeError(
                f"{self.name} takes parameters {self.parameters or '()'}; got {sorted(unknown)}"
            )
        _symbolic()
        values = {p: _parameter(p, params.get(p)) for p in self.parameters}
        problem, oracle = self._build(**values)
        problem.oracle = oracle
        problem.family = self.name
        return problem, oracle


def _parameter(name: str, value: Param) -> sp.Expr:
    """A family parameter: symbolic if ``None`` (or its own name), else an exact value.

    Strings go through the safe parser (numbers, constants, whitelisted functions; the
    parameter's own name stands for the symbolic parameter), never through ``sympify``.
    """
    symbol = sp.Symbol(name, real=True)
    if value is None:
        return symbol
    if isinstance(value, bool):
        raise TypeError(f"{name} must be a number or a sympy expression, got {value!r}")
    return to_expression(value, argument=name, symbols={name: symbol})


def _require(condition: sp.Basic | bool, message: str) -> None:
    """Raise ``ValueError`` when a parameter condition is decidably false."""
    if condition is sp.false or condition is False:
        raise ValueError(message)


def _params(*values: sp.Expr) -> tuple[sp.Symbol, ...]:
    return tuple(v for v in values if isinstance(v, sp.Symbol))


def _hermite() -> tuple[SturmLiouville, Oracle]:
    prob = SturmLiouville(1, -2 * X, standardization=(-1) ** N, name="Hermite H_n")
    oracle = Oracle(
        polynomial=lambda n: sp.hermite(n, X),
        norm2=sp.sqrt(sp.pi) * 2**N * sp.factorial(N),
        recurrence=(sp.Rational(1, 2), sp.Integer(0), N),
    )
    return prob, oracle


def _hermite_functions() -> tuple[SturmLiouville, Oracle]:
    prob = SturmLiouville(1, 0, X**2, standardization=(-1) ** N, name="Hermite functions h_n")
    # eq. (3) of the thesis: d/dx h_n = sqrt(n/2) h_{n-1} - sqrt((n+1)/2) h_{n+1}; times 2:
    bands = {"sub": sp.sqrt(2 * N), "diag": sp.Integer(0), "sup": -sp.sqrt(2 * (N + 1))}
    oracle = Oracle(
        polynomial=lambda n: sp.hermite(n, X),
        norm2=sp.sqrt(sp.pi) * 2**N * sp.factorial(N),
        recurrence=(sp.Rational(1, 2), sp.Integer(0), N),
        derivative=("functions", bands, 0),
    )
    return prob, oracle


def _laguerre(alpha: sp.Expr) -> tuple[SturmLiouville, Oracle]:
    _require(alpha > -1, f"laguerre: alpha must be > -1, got {alpha}")
    prob = SturmLiouville(
        X,
        alpha + 1 - X,
        params=_params(alpha),
        standardization=1 / sp.factorial(N),
        name=f"Laguerre L_n^({alpha})",
    )
    oracle = Oracle(
        polynomial=lambda n: sp.assoc_laguerre(n, alpha, X),
        norm2=sp.gamma(N + alpha + 1) / sp.factorial(N),
        # DLMF 18.9.13: (n+1) L_{n+1} = (2n+alpha+1-x) L_n - (n+alpha) L_{n-1}
        recurrence=(-(N + 1), 2 * N + alpha + 1, -(N + alpha)),
        # textbook sign (alpha = 0): t d/dt l_n = ((n+1) l_{n+1} - l_n - n l_{n-1})/2
        derivative=(
            ("functions", {"sub": -N, "diag": sp.Integer(-1), "sup": N + 1}, 0)
            if alpha == 0
            else None
        ),
    )
    return prob, oracle


def _jacobi_like(
    alpha: sp.Expr, beta: sp.Expr, constant: sp.Expr, name: str, params: tuple
) -> SturmLiouville:
    return SturmLiouville(
        1 - X**2,
        beta - alpha - (alpha + beta + 2) * X,
        params=params,
        standardization=constant,
        name=name,
    )


def _jacobi(alpha: sp.Expr, beta: sp.Expr) -> tuple[SturmLiouville, Oracle]:
    _require(alpha > -1, f"jacobi: alpha must be > -1, got {alpha}")
    _require(beta > -1, f"jacobi: beta must be > -1, got {beta}")
    prob = _jacobi_like(
        alpha,
        beta,
        (-1) ** N / (2**N * sp.factorial(N)),
        f"Jacobi P_n^({alpha},{beta})",
        _params(alpha, beta),
    )
    s = alpha + beta
    # DLMF 18.9.2: P_{n+1} = (A x + B) P_n - C P_{n-1}
    big_a = (2 * N + s + 1) * (2 * N + s + 2) / (2 * (N + 1) * (N + s + 1))
    big_b = (alpha**2 - beta**2) * (2 * N + s + 1) / (2 * (N + 1) * (N + s + 1) * (2 * N + s))
    big_c = (N + alpha) * (N + beta) * (2 * N + s + 2) / ((N + 1) * (N + s + 1) * (2 * N + s))
    oracle = Oracle(
        polynomial=lambda n: sp.jacobi(n, alpha, beta, X),
        norm2=2 ** (s + 1)
        * sp.gamma(N + alpha + 1)
        * sp.gamma(N + beta + 1)
        / ((2 * N + s + 1) * sp.gamma(N + s + 1) * sp.factorial(N)),
        norm2_from=1,  # the printed form is 0/0 at n = 0 when alpha + beta = -1
        recurrence=(1 / big_a, -big_b / big_a, big_c / big_a),
        recurrence_from=1,
    )
    return prob, oracle


def _legendre() -> tuple[SturmLiouville, Oracle]:
    prob = _jacobi_like(0, 0, (-1) ** N / (2**N * sp.factorial(N)), "Legendre P_n", ())
    # Legendre structure relation: (1-x^2) p_n' = n(n+1)/sqrt((2n-1)(2n+1)) p_{n-1}
    #                          - n(n+1)/sqrt((2n+1)(2n+3)) p_{n+1}   (w = 1: functions = p_n)
    bands = {
        "sub": 2 * N * (N + 1) / sp.sqrt((2 * N - 1) * (2 * N + 1)),
        "diag": sp.Integer(0),
        "sup": -2 * N * (N + 1) / sp.sqrt((2 * N + 1) * (2 * N + 3)),
    }
    oracle = Oracle(
        polynomial=lambda n: sp.legendre(n, X),
        norm2=2 / (2 * N + 1),
        recurrence=((N + 1) / (2 * N + 1), sp.Integer(0), N / (2 * N + 1)),
        derivative=("functions", bands, 0),
    )
    return prob, oracle


def _chebyshev_t() -> tuple[SturmLiouville, Oracle]:
    half = sp.Rational(-1, 2)
    constant = (-1) ** N * 2**N * sp.factorial(N) / sp.factorial(2 * N)
    prob = _jacobi_like(half, half, constant, "Chebyshev T_n", ())
    oracle = Oracle(
        polynomial=lambda n: sp.chebyshevt(n, X),
        norm2=sp.pi / 2,
        norm2_from=1,  # d_0^2 = pi
        recurrence=(sp.Rational(1, 2), sp.Integer(0), sp.Rational(1, 2)),
        recurrence_from=1,  # x T_0 = T_1
        # DLMF 18.9.20 with 18.9.1: (1-x^2) T_n' = n (T_{n-1} - T_{n+1})/2, so on the
        # orthonormal polynomials (T_n sqrt(2/pi) for n >= 1) 2 p0 p_n' = n p_{n-1} - n p_{n+1}
        derivative=("polynomials", {"sub": N, "diag": sp.Integer(0), "sup": -N}, 2),
    )
    return prob, oracle


def _chebyshev_u() -> tuple[SturmLiouville, Oracle]:
    half = sp.Rational(1, 2)
    constant = (-1) ** N * (N + 1) * 2**N * sp.factorial(N) / sp.factorial(2 * N + 1)
    prob = _jacobi_like(half, half, constant, "Chebyshev U_n", ())
    oracle = Oracle(
        polynomial=lambda n: sp.chebyshevu(n, X),
        norm2=sp.pi / 2,
        recurrence=(sp.Rational(1, 2), sp.Integer(0), sp.Rational(1, 2)),
    )
    return prob, oracle


def _gegenbauer(lam: sp.Expr) -> tuple[SturmLiouville, Oracle]:
    _require(lam > sp.Rational(-1, 2), f"gegenbauer: lambda must be > -1/2, got {lam}")
    if lam == 0:
        raise ValueError(
            "gegenbauer: lambda = 0 is excluded (C_n^0 = 0 for n >= 1 in DLMF's "
            "standardisation); use chebyshev_t"
        )
    half = sp.Rational(1, 2)
    constant = (
        (-1) ** N
        * sp.gamma(lam + half)
        * sp.gamma(N + 2 * lam)
        / (2**N * sp.factorial(N) * sp.gamma(2 * lam) * sp.gamma(lam + N + half))
    )
    prob = _jacobi_like(lam - half, lam - half, constant, f"Gegenbauer C_n^({lam})", _params(lam))
    oracle = Oracle(
        polynomial=lambda n: sp.gegenbauer(n, lam, X),
        norm2=2 ** (1 - 2 * lam)
        * sp.pi
        * sp.gamma(N + 2 * lam)
        / ((N + lam) * sp.gamma(lam) ** 2 * sp.factorial(N)),
        # DLMF 18.9.1 form: (n+1) C_{n+1} = 2(n+lam) x C_n - (n+2lam-1) C_{n-1}
        recurrence=((N + 1) / (2 * (N + lam)), sp.Integer(0), (N + 2 * lam - 1) / (2 * (N + lam))),
    )
    return prob, oracle


class Catalogue(Mapping[str, Family]):
    """Name -> :class:`Family`; entries are also attributes (``families.hermite()``).

    Parameters
    ----------
    entries : list of Family
        The families.

    Examples
    --------
    >>> from slbasis.families import families
    >>> "legendre" in families, len(families) >= 8
    (True, True)
    """

    def __init__(self, entries: list[Family]):
        self._entries = {f.name: f for f in entries}

    def __getitem__(self, name: str) -> Family:
        try:
            return self._entries[name]
        except KeyError:
            raise KeyError(f"unknown family {name!r}; known: {sorted(self._entries)}") from None

    def __getattr__(self, name: str) -> Family:
        try:
            return self._entries[name]
        except KeyError:
            raise AttributeError(name) from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._entries)

    def __len__(self) -> int:
        return len(self._entries)

    def __repr__(self) -> str:
        return "families(" + ", ".join(self._entries) + ")"


families = Catalogue(
    [
        Family("hermite", (), "Hermite polynomials H_n, weight exp(-x^2) on R", _hermite),
        Family(
            "hermite_functions",
            (),
            "Hermite functions from p0=1, p1=0, q0=x^2 (gauge of H_n)",
            _hermite_functions,
        ),
        Family("laguerre", ("alpha",), "generalised Laguerre L_n^(alpha) on (0, oo)", _laguerre),
        Family("legendre", (), "Legendre P_n on (-1, 1)", _legendre),
        Family("chebyshev_t", (), "Chebyshev T_n, weight (1-x^2)^(-1/2)", _chebyshev_t),
        Family("chebyshev_u", (), "Chebyshev U_n, weight (1-x^2)^(1/2)", _chebyshev_u),
        Family("gegenbauer", ("lam",), "Gegenbauer C_n^(lam), lam > -1/2", _gegenbauer),
        Family("jacobi", ("alpha", "beta"), "Jacobi P_n^(alpha,beta) on (-1, 1)", _jacobi),
    ]
)
