"""A kernel (:mod:`slbasis.numeric.kernel`) from generated closed forms in ``n``.

The code generator (:mod:`slbasis.codegen`) writes, per family, only the *data*: closed forms
``B_n``, ``A_{n+1}^2``, ``c_{n+1}/c_n``, ``lambda_n`` (rational in ``n``), the exact values at
small ``n`` from direct computation, ``log w(x)`` and ``log ∫ w``.  Everything else is generic
and lives here, once:

* ``jacobi(N)``: ``B_n``, ``A_{n+1} = -sign(p0) sign(c_{n+1}/c_n) sqrt(A_{n+1}^2)`` (the sign
  of ``k_n/k_{n+1}``, slbasis.symbolic.closed_forms), with the first entries replaced by the
  exact small-``n`` values — so removable singularities of a closed form at special
  parameters (Chebyshev T at ``n = 0``, Jacobi ``alpha + beta = 0`` in ``B_0``, Gegenbauer
  ``lambda < 0``) never reach the numbers;
* ``derivative_bands(N)``: ``2 p0 d/dx = (J Lambda - Lambda J) - p0'(J)`` on
  ``phi_n = sqrt(w) p_n`` (eq. 11 in commutator form, proved equal to the ladder form):
  ``sup_n = A_{n+1}(lambda_n - lambda_{n+1} - 2 c2)``, ``diag_n = -(2 c2 B_n + c1)``,
  ``sub_n = A_n(lambda_n - lambda_{n-1} - 2 c2)`` for ``p0 = c0 + c1 x + c2 x^2``;
* ``log_phi0(x) = log(w)/2 - log(∫ w)/2`` with the sign of ``c_0`` (``-inf`` outside the
  interval: ``phi_n = 0`` there).
"""

from __future__ import annotations

import types
from dataclasses import dataclass, field

import numpy as np

__all__ = ["ClosedFormKernel"]


@dataclass(frozen=True)
class ClosedFormKernel:
    """Kernel of a generated closed-form module with its parameters fixed.

    The parameters are checked by the module's ``check_parameters`` on construction.

    Parameters
    ----------
    module : module
        A generated kernel module (:mod:`slbasis.codegen`).
    params : dict of str to float, optional
        The family's parameters.

    Attributes
    ----------
    module : module
        The module.
    params : dict of str to float
        The parameters.

    Raises
    ------
    ValueError
        If a parameter leaves the admissible range.

    Examples
    --------
    >>> import slbasis
    >>> k = slbasis.kernel("jacobi", alpha=1.0, beta=0.5)
    >>> k.name, k.interval
    ('jacobi(alpha=1, beta=0.5)', (-1.0, 1.0))
    """

    module: types.ModuleType
    params: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.module.check_parameters(**self.params)

    @property
    def name(self) -> str:
        """The family's name with its parameters."""
        args = ", ".join(f"{k}={v:g}" for k, v in self.params.items())
        return f"{self.module.name}({args})" if args else self.module.name

    @property
    def interval(self) -> tuple[float, float]:
        """The family's interval ``(a, b)`` as floats."""
        return tuple(float(v) for v in self.module.interval)

    @property
    def p0(self) -> tuple[float, float, float]:
        """``(c0, c1, c2)`` of ``p0(x) = c0 + c1 x + c2 x^2``."""
        return tuple(self.module.p0)

    def _closed(self, fname: str, n: np.ndarray) -> np.ndarray:
        with np.errstate(all="ignore"):  # degenerate small n are replaced below
            return getattr(self.module, fname)(n, **self.params)

    def jacobi(self, N: int) -> tuple[np.ndarray, np.ndarray]:
        """``B_n`` and ``A_{n+1}`` of the orthonormal recurrence, the small ``n`` exact.

        ``A_{n+1} = -sign(p0) sign(c_{n+1}/c_n) sqrt(A_{n+1}^2)`` (the sign of ``k_n / k_{n+1}``);
        the first entries are the exact small-``n`` values, so removable singularities of a
        closed form at special parameters never reach the numbers.

        Parameters
        ----------
        N : int
            Number of functions.

        Returns
        -------
        diag : ndarray, shape (N,)
            ``B_0, ..., B_{N-1}``.
        offdiag : ndarray, shape (N,)
            ``A_1, ..., A_N``.

        Examples
        --------
        >>> import slbasis
        >>> diag, off = slbasis.kernel("legendre").jacobi(3)
        >>> off.round(4)  # (n + 1) / sqrt((2n + 1)(2n + 3))
        array([0.5774, 0.5164, 0.5071])
        """
        n = np.arange(N, dtype=float)
        diag = self._closed("jacobi_diag", n)
        a_sq = self._closed("jacobi_offdiag_squared", n)
        c_ratio = self._closed("c_ratio", n)
        small = self.module.small_values(**self.params)
        k = min(N, len(small[0]))
        diag[:k], a_sq[:k], c_ratio[:k] = small[0][:k], small[1][:k], small[2][:k]
        return diag, -self.module.P0_SIGN * np.sign(c_ratio) * np.sqrt(a_sq)

    def eigenvalues(self, N: int) -> np.ndarray:
        """``lambda_n`` of the polynomial problem, ``n = 0..N-1``.

        Parameters
        ----------
        N : int
            Number of eigenvalues.

        Returns
        -------
        ndarray, shape (N,)
            The eigenvalues.

        Examples
        --------
        >>> import slbasis
        >>> slbasis.kernel("legendre").eigenvalues(4)  # n (n + 1)
        array([ 0.,  2.,  6., 12.])
        """
        return self._closed("eigenvalue", np.arange(N, dtype=float))

    def derivative_bands(self, N: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The bands of ``2 p0 d/dx`` on ``phi_n`` (eq. 11 in commutator form).

        ``2 p0 d/dx = (J Lambda - Lambda J) - p0'(J)``: ``sup_n = A_{n+1}(lambda_n -
        lambda_{n+1} - 2 c2)``, ``diag_n = -(2 c2 B_n + c1)``, ``sub_n = A_n(lambda_n -
        lambda_{n-1} - 2 c2)`` for ``p0 = c0 + c1 x + c2 x^2`` (module docstring).

        Parameters
        ----------
        N : int
            Number of functions.

        Returns
        -------
        sub, diag, sup : ndarray, shape (N,)
            The bands (``sub[0] = 0``).
        """
        diag_j, off = self.jacobi(N)
        lam = self.eigenvalues(N + 1)
        _, c1, c2 = self.p0
        sup = off * (lam[:-1] - lam[1:] - 2 * c2)
        sub = np.zeros(N)
        sub[1:] = off[:-1] * (lam[1:N] - lam[: N - 1] - 2 * c2)
        return sub, -(2 * c2 * diag_j + c1), sup

    def log_phi0(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``log|phi_0(x)| = log(w) / 2 - log(int w) / 2`` and the sign of ``c_0``.

        Parameters
        ----------
        x : array_like
            Points of the family's variable.

        Returns
        -------
        log_abs : ndarray
            ``log|phi_0(x)|``, ``-inf`` outside the interval (``phi_n = 0`` there).
        sign : ndarray
            The sign of ``phi_0``.

        Examples
        --------
        >>> import slbasis
        >>> slbasis.kernel("legendre").log_phi0(np.array([0.0, 2.0]))[0].round(4)  # log(1 / sqrt 2)
        array([-0.3466,    -inf])
        """
        x = np.asarray(x, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            log_w = self.module.log_weight(x, **self.params)
        value = 0.5 * log_w - 0.5 * self.module.log_mass(**self.params)
        a, b = self.interval
        value = np.where((x < a) | (x > b), -np.inf, value)  # the functions live on (a, b)
        return value, np.full(x.shape, float(self.module.SIGN_C0))
