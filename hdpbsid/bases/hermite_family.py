"""The Hermite family: HD-PBSID's basis, size rule, lag and pseudo-inputs.

The equations are those of :mod:`hdpbsid.methods.hermite`: the record is projected on
``N`` Hermite functions filling 90 % of their effective support; with the projected
derivative ``Dd = -Dmat`` (tridiagonal) and ``D' = (Dd / alpha + beta I) / gamma`` the
coefficient rows obey the integrator form ``X = A' X M + B' U M + K' E M + (pseudo-inputs) M``
with ``M = D'^{-1}``, applied by a tridiagonal solve (:func:`hermite_lag`).  The pseudo-input
rows are the truncation of the last column of the cut ``Dd`` (``e_{N-1}^T``) and the
boundary values ``phi(t0)^T``, ``phi(tN)^T``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg.lapack import dgttrf, dgttrs

from hdpbsid.bases.basis_domain import SolveLag, basis_values, clip_basis_size, shared_basis
from hdpbsid.bases.family import Integrator, IntegratorFamily

__all__ = ["HermiteFamily", "hermite_lag", "default_hermite_N", "HERMITE_BAND", "BAND_MARGIN"]

Array = NDArray[np.float64]

#: highest angular frequency (rad/s) of N Hermite functions filling 90 % of the support
#: over a record of length T: ``scale * sqrt(2N) = 0.9 * 2 N * 2 / T = 3.6 N / T``
HERMITE_BAND = 3.6
#: default N covers this multiple of the data bandwidth
BAND_MARGIN = 2.0
#: limits of the default N; the upper one only bounds the cost (evaluation is exact to
#: rounding at N = 5000, bench/basis.py): it binds on records longer than ~10^3 bandwidth
#: periods, with a warning
N_MIN, N_MAX = 100, 4000


def default_hermite_N(T: float, omega_b: float, ns: int) -> tuple[int, str]:
    """``N`` so that the basis covers ``BAND_MARGIN`` times the data bandwidth ``omega_b``.

    ``N = BAND_MARGIN omega_b T / 3.6`` clipped to ``[N_MIN, N_MAX]`` (measured in
    early runs: N = 200-300 worked on 20-40 s records; below ~30 the thesis, §5, reports poor
    identification)
    and to ``Ns / 2`` (the samples must resolve the fastest basis function), with a
    warning when an upper limit binds (:func:`~hdpbsid.bases.basis_domain.clip_basis_size`).

    Why the band includes the input's (``omega_b`` from
    :func:`~hdpbsid.bases.basis_domain.data_bandwidth`), not only the outputs': the
    coefficient equation holds for any ``N`` (the cut of the derivative operator is a
    pseudo-input), so input energy above the basis band does no harm by itself, but the
    coefficients between the outputs' energy band and the input band are where a fast,
    weakly visible mode is seen.  Sizing ``N`` from the outputs' band alone is cheaper
    but loses a fast mode whose output share is small (systems with modes a decade
    apart), and a band read from where the output spectrum leaves its noise floor moves
    with the noise; the comparisons are in the benchmark pages.
    """
    return clip_basis_size(
        BAND_MARGIN * omega_b * T / HERMITE_BAND,
        N_MIN,
        N_MAX,
        ns,
        "hermite",
        f"N = {BAND_MARGIN} * bandwidth * T / {HERMITE_BAND}",
    )


def _hermite_basis(N: int, T: float, scale: float | None) -> Any:
    """``slbasis.basis("hermite", N, (0, T), scale=scale)``, the same object for the same
    arguments (:func:`~hdpbsid.bases.basis_domain.shared_basis`)."""
    return shared_basis("hermite", N, (0.0, T), scale=scale)


def _boundary_rows(N: int, T: float, scale: float | None) -> Array:
    """``phi_n(0)``, ``phi_n(T)`` of :func:`_hermite_basis` (``N x 2``, read-only)."""
    return basis_values(_hermite_basis(N, T, scale), (0.0, T))


@functools.lru_cache(maxsize=16)
def _derivative_matrix(N: int, T: float, scale: float | None) -> Any:
    """The square d/dt matrix of :func:`_hermite_basis` (``N x N`` CSR), kept like the
    basis: every operator-scale pass builds its lag from it (not modified by
    :func:`hermite_lag`, which reads its diagonals)."""
    return _hermite_basis(N, T, scale).derivative_matrix("square")


def _diagonal(Dmat: Any, k: int) -> Array:
    return np.asarray(Dmat.diagonal(k), dtype=float)


class _TridiagonalSolve:
    """``W -> W D'^{-1}`` from the LU factors of the tridiagonal ``D'^T`` (LAPACK
    ``gttrs``).  A module-level class, not a closure, so that a lag operator pickles:
    ``dask.distributed`` ships the chunked path's tasks, lag operators included, to its
    workers by pickle, and a closure over a LAPACK routine does not pickle."""

    def __init__(self, dl: Array, d: Array, du: Array, du2: Array, ipiv: Array) -> None:
        self.factors = (dl, d, du, du2, ipiv)

    def __call__(self, W: Array) -> Array:
        # W M = W D'^{-1}  <=>  D'^T (W M)^T = W^T
        if W.shape[0] == 0:
            return np.zeros_like(W)
        X, err = dgttrs(*self.factors, np.asfortranarray(W.T, dtype=float))
        if err != 0:
            raise ValueError(f"LAPACK gttrs failed (info = {err})")
        return X.T


def hermite_lag(
    Dmat: Any, alpha: float, beta: float, gamma: float
) -> tuple[SolveLag, NDArray[np.float64]]:
    """The integrator lag ``W -> W D'^{-1}`` for ``D' = (Dd/alpha + beta I)/gamma``.

    ``Dmat`` is the square ``N x N`` d/dt matrix (tridiagonal, sparse or dense);
    ``Dd = -Dmat``.  The banded storage of ``D'^T`` (``scipy.linalg.solve_banded``
    layout, rows: super-, main, sub-diagonal) is filled from the three diagonals of
    ``Dmat`` directly, never forming an ``N x N`` array, and factored once.  Returns the
    :class:`~hdpbsid.bases.basis_domain.SolveLag` (banded solve with ``D'^T``) and the
    banded storage.
    """
    N = Dmat.shape[0]
    ab = np.zeros((3, N))
    # D'^T = (-Dmat^T / alpha + beta I) / gamma: its super-diagonal is Dmat's sub-diagonal
    ab[0, 1:] = -_diagonal(Dmat, -1) / (alpha * gamma)
    ab[1] = (-_diagonal(Dmat, 0) / alpha + beta) / gamma
    ab[2, :-1] = -_diagonal(Dmat, 1) / (alpha * gamma)

    # LU factors of the tridiagonal D'^T (partial pivoting, LAPACK gttrf) computed once:
    # the core applies the lag some twenty times per fit, each then one O(N) gttrs
    dl, d, du, du2, ipiv, info = dgttrf(ab[2, :-1], ab[1], ab[0, 1:])
    if info != 0:
        raise ValueError(f"D' is singular (LAPACK gttrf info = {info}); change alpha or beta")

    solve = _TridiagonalSolve(dl, d, du, du2, ipiv)
    name = f"D'^-1, D' = (D/{alpha:.4g} + {beta:g} I)/{gamma:g}"
    return SolveLag(solve, name, key=ab), ab


@dataclass(frozen=True)
class HermiteFamily(IntegratorFamily):
    """Hermite functions filling 90 % of their effective support on the window
    (``scale=None``) or at a given time scale, as a basis family
    (:class:`~hdpbsid.bases.family.BasisFamily`).

    * size: ``N = BAND_MARGIN omega_b T / 3.6`` (:func:`default_hermite_N`); a given ``N``
      must cover the data band, ``3.6 N / T >= omega_b``;
    * lag: ``W -> W D'^{-1}`` with ``D' = (Dd / alpha + beta I) / gamma``
      (:func:`hermite_lag`);
    * pseudo-inputs: the truncation row ``e_{N-1}^T`` and, with ``boundary``, the boundary
      rows ``phi(0)^T``, ``phi(T)^T`` (module docstring).

    Parameters
    ----------
    scale : float or None
        Time scale of the functions (None: ``slbasis.basis``'s default).
    """

    scale: float | None = None
    label = "hermite"
    n_min, n_max = N_MIN, N_MAX
    q = (1, 3)
    size_rule = f"N = {BAND_MARGIN} * bandwidth * T / {HERMITE_BAND}"

    def size_rate(self, wb: float) -> float:
        """``BAND_MARGIN wb / 3.6`` functions per second (:func:`default_hermite_N`)."""
        return BAND_MARGIN * wb / HERMITE_BAND

    def wanted_size(self, T: float, wb: float) -> float:
        """``BAND_MARGIN wb T / 3.6`` (:func:`default_hermite_N`)."""
        return BAND_MARGIN * wb * T / HERMITE_BAND

    def band(self, basis: Any) -> float:
        """Highest angular frequency (rad/s) of ``basis``: ``3.6 N / T``."""
        return HERMITE_BAND * basis.N / basis.t_span[1]

    def too_narrow(self, N: int, T: float, wb: float) -> str | None:
        """Why ``N`` functions over ``T`` s do not cover ``wb`` (``3.6 N / T < wb``)."""
        if HERMITE_BAND * N / T >= wb:
            return None
        return (
            f"N={N} Hermite functions over a record of {T:g} s cover only "
            f"{HERMITE_BAND * N / T:.3g} rad/s, below the data bandwidth {wb:.3g} "
            f"rad/s (99 % of the energy); use N >= {int(np.ceil(wb * T / HERMITE_BAND))}"
        )

    def basis(self, N: int, T: float) -> Any:
        """:func:`slbasis.basis` ``("hermite", N, (0, T), scale)``, shared."""
        return _hermite_basis(N, T, self.scale)

    def lag(self, basis: Any, operator: Integrator) -> SolveLag:
        """:func:`hermite_lag` of the basis's d/dt matrix at ``operator``."""
        D = _derivative_matrix(basis.N, basis.t_span[1], self.scale)
        return hermite_lag(D, operator.alpha, operator.beta, operator.gamma)[0]

    def pseudo_rows(self, basis: Any, operator: Any, boundary: bool, ones: Any) -> Array:
        """``e_{N-1}^T`` (truncation) and, with ``boundary``, ``phi(0)^T``, ``phi(T)^T``."""
        r = [np.eye(1, basis.N, basis.N - 1)[0]]
        if boundary:
            r += list(_boundary_rows(basis.N, basis.t_span[1], self.scale).T)
        return np.array(r)
