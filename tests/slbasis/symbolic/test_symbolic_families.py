"""The closed forms the issue names (``verify(nmax=10)`` of every catalogue family runs with
its derivation report: ``tests/slbasis/test_derivations.py``).

Oracles: exact arithmetic (sympy) throughout; the textbook closed forms (DLMF, sympy's own
polynomials) live in ``slbasis.families`` and are compared inside ``verify``.
"""

from __future__ import annotations

import pytest
import sympy as sp

from slbasis import SturmLiouville, families
from slbasis.symbolic.parse import N, X


def test_hermite_functions_reproduce_seed_eq_3_exactly() -> None:
    prob = SturmLiouville(p0=1, p1=0, q0="x**2")
    assert prob.is_gauge_transform
    assert sp.simplify(prob.eigenvalue() - (2 * N + 1)) == 0
    assert prob.gauge.factor == sp.exp(-(X**2) / 2)
    # d/dx h_n = (a - a^dagger)/sqrt(2) h_n = sqrt(n/2) h_{n-1} - sqrt((n+1)/2) h_{n+1}
    bands = prob.derivative_operator("eigenfunctions")
    expected = {"sub": 2 * sp.sqrt(N / 2), "diag": 0, "sup": -2 * sp.sqrt((N + 1) / 2)}
    for key, value in expected.items():
        assert sp.simplify(bands[key] - value) == 0, key
    # and the functions frame of the same problem is the same basis
    assert prob.derivative_operator("functions") == bands


def test_legendre_derivative_operator_matches_design_closed_form() -> None:
    bands = families.legendre().derivative_operator("functions")
    assert sp.simplify(bands["sub"] - 2 * N * (N + 1) / sp.sqrt((2 * N - 1) * (2 * N + 1))) == 0
    assert bands["diag"] == 0
    assert sp.simplify(bands["sup"] + 2 * N * (N + 1) / sp.sqrt((2 * N + 1) * (2 * N + 3))) == 0


def test_laguerre_functions_derivative_matches_design_closed_form() -> None:
    # t d/dt l_n = ((n+1) l_{n+1} - l_n - n l_{n-1}) / 2
    bands = families.laguerre(alpha=0).derivative_operator("functions")
    assert (bands["sub"], bands["diag"], sp.expand(bands["sup"])) == (-N, -1, N + 1)


def test_chebyshev_derivative_operators_match_dlmf() -> None:
    prob = families.chebyshev_t()
    bands = prob.derivative_operator("polynomials")
    assert (bands["sub"], bands["diag"], bands["sup"]) == (N, 0, -N)
    # n = 1 touches the exceptional n = 0 (T_0 has the other norm): exact value sqrt(2)
    assert prob.derivative_band_values(1, "polynomials")[0] == sp.sqrt(2)
    assert prob.exceptional == frozenset({0})
    u_bands = families.chebyshev_u().derivative_operator("polynomials")
    assert sp.expand(u_bands["sub"]) == N + 2 and sp.expand(u_bands["sup"]) == -N


def test_eigenvalue_uses_second_derivative_of_p0() -> None:
    # the summary prints lambda_n = -n (p1' + (n-1)/2 p0'); only p0'' gives a constant
    prob = families.jacobi()
    alpha, beta = prob.params
    assert sp.expand(prob.eigenvalue() - N * (N + alpha + beta + 1)) == 0


def test_derivative_matrix_is_rectangular_and_exact() -> None:
    prob = families.hermite_functions()
    mat = prob.derivative_matrix(4)
    assert mat.shape == (5, 4)
    assert mat[4, 3] == -sp.sqrt(8)  # the row a square cut would lose: -sqrt(2 (n+1)), n = 3
    assert sp.simplify(mat[:4, :] + mat[:4, :].T) == sp.zeros(4, 4)  # skew part is all of it


@pytest.mark.parametrize("name", ["hermite", "laguerre", "legendre", "chebyshev_t", "jacobi"])
def test_printed_eq11_pattern_documented_in_derivations(name: str) -> None:
    """derivations/README.md: printed (11) == -(J Lambda - Lambda J) - p0'' (A_n on phi_{n-1})."""
    prob = families[name]()
    printed = prob.derivative_operator_form("functions", "printed")
    lam = prob.closed.eigenvalue
    p0_second = sp.diff(prob.p0, X, 2)
    assert sp.simplify(printed.sup_factor + (lam(N) - lam(N + 1))) == 0
    assert sp.simplify(printed.sub_factor + (lam(N) - lam(N - 1)) + p0_second) == 0
    assert sp.simplify(printed.diag) == 0
