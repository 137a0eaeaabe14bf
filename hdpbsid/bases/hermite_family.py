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

__all__ = [
    "HermiteSettings",
    "HERMITE",
    "HermiteFamily",
    "hermite_lag",
    "default_hermite_N",
    "HERMITE_BAND",
    "BAND_MARGIN",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class HermiteSettings:
    """The size rule of the Hermite functions, each constant with its reason.

    Parameters
    ----------
    band : float, optional
        Band of ``N`` functions on a record of length ``T``, in units of ``N / T``.
    band_margin : float, optional
        Multiple of the data bandwidth the default basis covers.
    n_min, n_max : int, optional
        Limits of the default ``N``.

    Examples
    --------
    >>> HermiteSettings().band
    3.6
    """

    #: highest angular frequency (rad/s) of N Hermite functions filling 90 % of the
    #: support over a record of length T: ``scale * sqrt(2N) = 0.9 * 2 N * 2 / T = 3.6 N / T``
    band: float = 3.6
    #: default N covers this multiple of the data bandwidth
    band_margin: float = 2.0
    #: lower limit of the default N: a few functions per mode and boundary term
    n_min: int = 100
    #: upper limit of the default N, only a bound on the cost (evaluation is exact to
    #: rounding at N = 5000, bench/basis.py): it binds on records longer than ~10^3
    #: bandwidth periods, with a warning
    n_max: int = 4000


#: the settings of the Hermite family
HERMITE = HermiteSettings()
#: the fields of :data:`HERMITE` under their former names
HERMITE_BAND = HERMITE.band
BAND_MARGIN = HERMITE.band_margin
N_MIN, N_MAX = HERMITE.n_min, HERMITE.n_max


def default_hermite_N(T: float, omega_b: float, ns: int) -> tuple[int, str]:
    """``N`` so that the basis covers ``BAND_MARGIN`` times the data bandwidth ``omega_b``.

    ``N = BAND_MARGIN omega_b T / 3.6`` (``3.6 N / T`` is the band of ``N`` functions
    filling 90 % of their support on ``T``), clipped to ``[N_MIN, N_MAX]`` and to ``Ns / 2``
    (the samples must resolve the fastest basis function), with a warning when an upper
    limit binds (:func:`~hdpbsid.bases.basis_domain.clip_basis_size`).  The lower limit
    keeps enough coefficients for the past and future windows of the core; the upper one
    only bounds the cost.

    Why the band includes the input's (``omega_b`` from
    :func:`~hdpbsid.bases.basis_domain.data_bandwidth`), not only the outputs': the
    coefficient equation holds for any ``N`` (the cut of the derivative operator is a
    pseudo-input), so input energy above the basis band does no harm by itself, but the
    coefficients between the outputs' energy band and the input band are where a fast,
    weakly visible mode is seen.  Sizing ``N`` from the outputs' band alone loses a fast
    mode whose output share is small (systems with modes a decade apart), and a band read
    from where the output spectrum leaves its noise floor moves with the noise.

    Parameters
    ----------
    T : float
        Record (window) length (s).
    omega_b : float
        Data bandwidth (rad/s).
    ns : int
        Number of samples.

    Returns
    -------
    N : int
        The basis size.
    rule : str
        The rule and the limits applied.

    Examples
    --------
    >>> default_hermite_N(20.0, 10.0, 5000)
    (112, 'N = 2.0 * bandwidth * T / 3.6, clipped to [100, 4000] and <= Ns/2')
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
    r"""The integrator lag ``W -> W D'^{-1}`` for ``D' = (Dd / alpha + beta I) / gamma``.

    In the Hermite domain the derivative is the tridiagonal ``Dd = -Dmat`` (the ladder
    operators of the harmonic oscillator, ``d/dt = (a - a^\dagger) / \sqrt{2}`` in the
    scaled time), so "one step back" of the integrator form is a tridiagonal solve: the
    LU factors of ``D'^T`` (LAPACK ``gttrf``, partial pivoting) are computed once and each
    application costs ``O(N)`` per row (``gttrs``).  The banded storage is filled from the
    three diagonals of ``Dmat`` directly, never forming an ``N x N`` array.

    Parameters
    ----------
    Dmat : sparse matrix or ndarray, shape (N, N)
        The square d/dt matrix of the basis (tridiagonal).
    alpha : float
        Operator scale (rad/s): ``D / alpha`` is dimensionless.
    beta : float
        Shift: ``D' = (Dd / alpha + beta I) / gamma`` is invertible for ``beta > 0``.
    gamma : float
        Gain of the integrator form.

    Returns
    -------
    lag : SolveLag
        The lag operator (banded solve with ``D'^T``).
    ab : ndarray, shape (3, N)
        The banded storage of ``D'^T`` (super-, main, sub-diagonal, the
        ``scipy.linalg.solve_banded`` layout); the exact key of the operator.

    Raises
    ------
    ValueError
        If ``D'`` is singular (change ``alpha`` or ``beta``), or the solve fails.

    Notes
    -----
    With coefficient rows ``X`` (states), ``U`` (inputs):

    .. math::

        X D' = A' X + B' U + \ldots \;\Longrightarrow\;
        X = A' X M + B' U M + \ldots, \qquad M = D'^{-1} .

    References
    ----------
    .. [1] G. Szego, *Orthogonal Polynomials*, 4th ed., AMS Colloquium Publications 23,
       1975, sec. 5.5 (Hermite functions and their recurrences).

    Examples
    --------
    >>> import slbasis
    >>> D = slbasis.basis("hermite", 50, (0.0, 10.0)).derivative_matrix("square")
    >>> lag, ab = hermite_lag(D, 2.0, 1.0, 1.0)
    >>> W = np.random.default_rng(0).standard_normal((2, 50))
    >>> Dp = -D.toarray() / 2.0 + np.eye(50)  # D' = Dd / alpha + beta I
    >>> bool(np.allclose(lag.apply(W, 1) @ Dp, W))
    True
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
    """Hermite functions as a basis family (:class:`~hdpbsid.bases.family.BasisFamily`).

    The functions fill 90 % of their effective support on the window (``scale=None``) or
    have a given time scale.

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

    Examples
    --------
    >>> fam = HermiteFamily()
    >>> basis = fam.basis(50, 10.0)
    >>> fam.band(basis)  # rad/s
    18.0
    >>> fam.pseudo_rows(basis, None, True, None).shape
    (3, 50)
    """

    scale: float | None = None
    label = "hermite"
    n_min, n_max = N_MIN, N_MAX
    q = (1, 3)
    size_rule = f"N = {BAND_MARGIN} * bandwidth * T / {HERMITE_BAND}"

    def size_rate(self, wb: float) -> float:
        """``BAND_MARGIN wb / 3.6`` functions per second (:func:`default_hermite_N`).

        Parameters
        ----------
        wb : float
            Data bandwidth (rad/s).

        Returns
        -------
        float
            Functions per second of window.
        """
        return BAND_MARGIN * wb / HERMITE_BAND

    def wanted_size(self, T: float, wb: float) -> float:
        """``BAND_MARGIN wb T / 3.6``, before clipping (:func:`default_hermite_N`).

        Parameters
        ----------
        T : float
            Window length (s).
        wb : float
            Data bandwidth (rad/s).

        Returns
        -------
        float
            The size the rule wants.
        """
        return BAND_MARGIN * wb * T / HERMITE_BAND

    def band(self, basis: Any) -> float:
        """Highest angular frequency (rad/s) of ``basis``: ``3.6 N / T``.

        Parameters
        ----------
        basis : Basis
            A Hermite basis of :meth:`basis`.

        Returns
        -------
        float
            The band (rad/s).
        """
        return HERMITE_BAND * basis.N / basis.t_span[1]

    def too_narrow(self, N: int, T: float, wb: float) -> str | None:
        """Why ``N`` functions over ``T`` s do not cover ``wb`` (``3.6 N / T < wb``), or None.

        Parameters
        ----------
        N : int
            Basis size.
        T : float
            Window length (s).
        wb : float
            Data bandwidth (rad/s).

        Returns
        -------
        str or None
            The message (with the ``N`` needed), or None when ``N`` covers the band.

        Examples
        --------
        >>> HermiteFamily().too_narrow(50, 10.0, 30.0)[:45]
        'N=50 Hermite functions over a record of 10 s '
        """
        if HERMITE_BAND * N / T >= wb:
            return None
        return (
            f"N={N} Hermite functions over a record of {T:g} s cover only "
            f"{HERMITE_BAND * N / T:.3g} rad/s, below the data bandwidth {wb:.3g} "
            f"rad/s (99 % of the energy); use N >= {int(np.ceil(wb * T / HERMITE_BAND))}"
        )

    def basis(self, N: int, T: float) -> Any:
        """:func:`slbasis.basis` ``("hermite", N, (0, T), scale)``, shared between calls.

        Parameters
        ----------
        N : int
            Number of functions.
        T : float
            Window length (s).

        Returns
        -------
        Basis
            The Hermite basis (the same object for the same arguments).
        """
        return _hermite_basis(N, T, self.scale)

    def lag(self, basis: Any, operator: Integrator) -> SolveLag:
        """:func:`hermite_lag` of the basis's d/dt matrix at ``operator``.

        Parameters
        ----------
        basis : Basis
            A Hermite basis of :meth:`basis`.
        operator : Integrator
            The operator scale ``(alpha, beta, gamma)``.

        Returns
        -------
        SolveLag
            The lag ``W -> W D'^{-1}``.
        """
        D = _derivative_matrix(basis.N, basis.t_span[1], self.scale)
        return hermite_lag(D, operator.alpha, operator.beta, operator.gamma)[0]

    def pseudo_rows(self, basis: Any, operator: Any, boundary: bool, ones: Any) -> Array:
        """``e_{N-1}^T`` (truncation) and, with ``boundary``, ``phi(0)^T``, ``phi(T)^T``.

        The projected derivative of a function on ``[0, T]`` differs from ``Dd`` applied to its
        coefficients by the boundary terms ``x(0) phi(0)^T - x(T) phi(T)^T`` and by the
        coupling to the functions beyond ``N`` cut by the truncation, which enters through the
        last coefficient only (``Dd`` is tridiagonal).

        Parameters
        ----------
        basis : Basis
            The block's basis.
        operator : object
            The operator scale (unused: the rows do not depend on it).
        boundary : bool
            Include the boundary rows.
        ones : object
            Unused (the Hermite rows need no projection of 1).

        Returns
        -------
        ndarray, shape (1 or 3, N)
            The rows.
        """
        r = [np.eye(1, basis.N, basis.N - 1)[0]]
        if boundary:
            r += list(_boundary_rows(basis.N, basis.t_span[1], self.scale).T)
        return np.array(r)
