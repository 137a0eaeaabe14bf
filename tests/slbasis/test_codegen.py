"""Generated kernels: in sync with the derivations, and numerically right.

Oracles: the committed modules must equal a fresh generation; the hand-written textbook
kernels of ``numeric_kernels_fixture`` (themselves checked against scipy/mpmath); the exact
sympy Jacobi matrix and derivative matrix of the symbolic layer; scipy.special.
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from numeric_kernels_fixture import CHEBYSHEV_T, HERMITE, LAGUERRE, LEGENDRE
from scipy.special import eval_legendre

import slbasis
from slbasis.codegen import CATALOGUE, KERNEL_DIR, catalogue_source


@pytest.mark.parametrize("family", sorted(CATALOGUE))
def test_committed_kernel_is_current(family: str) -> None:
    committed = (KERNEL_DIR / f"{CATALOGUE[family][0]}.py").read_text(encoding="utf-8")
    assert committed == catalogue_source(family), (
        f"slbasis/kernels/{family}.py is stale: run `make kernels`"
    )


@pytest.mark.parametrize(
    ("family", "params", "fixture"),
    [
        ("hermite_functions", {}, HERMITE),
        ("hermite", {}, HERMITE),
        ("laguerre", {"alpha": 0}, LAGUERRE),
        ("legendre", {}, LEGENDRE),
        ("jacobi", {"alpha": 0, "beta": 0}, LEGENDRE),
        ("chebyshev_t", {}, CHEBYSHEV_T),
        ("jacobi", {"alpha": -0.5, "beta": -0.5}, CHEBYSHEV_T),
    ],
)
def test_generated_kernel_matches_textbook_kernel(family, params, fixture) -> None:
    gen = slbasis.kernel(family, **params)
    size = 300
    # closed forms evaluated in float64: agreement to a few ulps of the largest entry
    for mine, ref in zip(gen.jacobi(size), fixture.jacobi(size), strict=True):
        np.testing.assert_allclose(mine, ref, rtol=1e-13, atol=1e-13)
    bands, ref_bands = gen.derivative_bands(size), fixture.derivative_bands(size)
    for k, (mine, ref) in enumerate(zip(bands, ref_bands, strict=True)):
        lo = 1 if k == 0 else 0  # sub[0] is unused by convention
        # bands grow like n (Laguerre) or n^2/n (Legendre): relative 1e-13
        np.testing.assert_allclose(mine[lo:], ref[lo:], rtol=1e-13, atol=1e-12)
    a, b = gen.interval
    x = np.linspace(max(a, -3.0), min(b, 3.0), 9)[1:-1]
    np.testing.assert_allclose(gen.log_phi0(x)[0], fixture.log_phi0(x)[0], rtol=1e-14, atol=1e-14)


def _exact(prob: slbasis.SturmLiouville, size: int) -> tuple[np.ndarray, ...]:
    jac = prob.jacobi_matrix(size + 1)
    diag = np.array([float(jac[n, n]) for n in range(size)])
    off = np.array([float(jac[n + 1, n]) for n in range(size)])
    der = prob.derivative_matrix(size)
    sub = np.array([0.0] + [float(der[n - 1, n]) for n in range(1, size)])
    dia = np.array([float(der[n, n]) for n in range(size)])
    sup = np.array([float(der[n + 1, n]) for n in range(size)])
    return diag, off, sub, dia, sup


def _frac(low: int, high: int) -> st.SearchStrategy:
    return st.fractions(min_value=low, max_value=high, max_denominator=6).filter(lambda v: v > low)


@settings(max_examples=10, deadline=None)
@given(
    family=st.sampled_from(["jacobi", "gegenbauer", "laguerre"]),
    a=_frac(-1, 5),
    b=_frac(-1, 5),
)
def test_generated_kernel_equals_exact_symbolic_values(family: str, a: Fraction, b: Fraction):
    """Random parameters, including the degenerate ones (alpha + beta = -1 or 0,
    Gegenbauer lambda < 0) where a closed form has a removable singularity at small n."""
    q = {k: sp.Rational(v.numerator, v.denominator) for k, v in (("a", a), ("b", b))}
    if family == "jacobi":
        params = {"alpha": q["a"], "beta": q["b"]}
    elif family == "laguerre":
        params = {"alpha": q["a"]}
    else:
        lam = q["a"] / 2  # > -1/2
        if lam == 0:
            lam = sp.Rational(1, 3)
        params = {"lam": lam}
    prob = slbasis.families[family](**params)
    exact = _exact(prob, 7)
    gen = slbasis.kernel(family, **{k: float(v) for k, v in params.items()})
    got = (*gen.jacobi(7), *gen.derivative_bands(7))
    for name, mine, ref in zip(["B", "A", "sub", "diag", "sup"], got, exact, strict=True):
        lo = 1 if name == "sub" else 0
        # float64 evaluation of O(10) closed forms with rational parameters
        np.testing.assert_allclose(mine[lo:], ref[lo:], rtol=1e-12, atol=1e-12, err_msg=name)


def test_custom_problem_kernel_end_to_end() -> None:
    """Shifted Legendre on [0, 1] (p0 = x - x^2, p1 = 1 - 2x), generated on demand."""
    prob = slbasis.SturmLiouville("x - x**2", "1 - 2*x")
    B = slbasis.basis(prob, N=40, t_span=(0.0, 2.0))
    nodes, weights = B.quadrature()
    V = B.eval(nodes)
    # Gauss rule with 40 nodes integrates products of degree < 80 exactly: rounding only
    np.testing.assert_allclose((V * weights) @ V.T, np.eye(40), atol=1e-13)
    t = np.linspace(0.05, 1.95, 11)
    x = t / 2.0  # the window [0, 2] maps onto [0, 1]
    ref = np.array([np.sqrt(2 * n + 1) * eval_legendre(n, 2 * x - 1) for n in range(40)])
    # L^2(dt) normalisation: phi_n(t) = sqrt(1/2) p_n(t/2); scipy's values carry ~1e-14
    np.testing.assert_allclose(B.eval(t), ref / np.sqrt(2.0), atol=1e-12)


def test_kernel_parameter_errors() -> None:
    with pytest.raises(ValueError, match="alpha \\+ 1 > 0"):
        slbasis.kernel("laguerre", alpha=-2.0)
    with pytest.raises(TypeError, match="unknown parameter"):
        slbasis.kernel("legendre", alpha=1.0)
    with pytest.raises(ValueError, match="family must be one of"):
        slbasis.kernel("bessel")
    with pytest.raises(TypeError, match="family must be a catalogue name"):
        slbasis.kernel(3)
