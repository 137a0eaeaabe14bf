"""Basis families: what the basis-domain pipeline needs to know of a family of functions.

A basis method projects a record on ``N`` orthonormal functions ``phi_n`` of a time window
and runs the PBSID core with "one sample back" replaced by an operator ``M`` on the
coefficient rows (docs/theory.md).  Everything else is generic
(:mod:`hdpbsid.bases.pipeline`); a family says only

* how to build its basis of ``N`` functions on a window ``[0, T]`` (:meth:`BasisFamily.basis`),
  how many functions the default rule wants (:meth:`BasisFamily.wanted_size`, clipped by
  :meth:`BasisFamily.default_size`) and whether a given ``N`` resolves the data band
  (:meth:`BasisFamily.too_narrow`);
* its lag operator ``W -> W M`` (:meth:`BasisFamily.lag`, a
  :class:`~hdpbsid.core.varx.LagOperator`) for an operator scale;
* its pseudo-input rows (:meth:`BasisFamily.pseudo_rows`): the known rows of the terms
  whose vector factor is unknown (boundary values, truncation of a cut operator);
* how the core's basis-domain system maps back to ``(A, B, C, D, K)``
  (:meth:`BasisFamily.model`).

A family is a small class; the Hermite (:mod:`hdpbsid.methods.hermite`), Laguerre
(:mod:`hdpbsid.methods.laguerre`), finite-interval Sturm-Liouville
(:mod:`hdpbsid.methods.sturm_liouville`) and Jacobi (:mod:`hdpbsid.methods.jacobi`)
families are instances.  The choices a method makes (basis size, operator scale, input
hold, past window) are values with a reason, :class:`~hdpbsid.models.report.Choice`.

>>> Choice(3, "given")
Choice(value=3, reason='given')
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.basis_domain import CoreOut, clip_basis_size, integrator_model
from hdpbsid.bases.settings import BasisSettings
from hdpbsid.core.varx import LagOperator
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import Choice

__all__ = ["Choice", "Integrator", "BasisFamily", "IntegratorFamily", "size_policy"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class Integrator:
    """The operator scale of the integrator form ``D' = (D / alpha + beta I) / gamma``.

    The core identifies ``A' = (A / alpha + beta I) / gamma``, ``B' = B / (alpha gamma)``,
    ``K' = K / (alpha gamma)`` (the thesis, §3.2); an eigenvalue ``lambda`` maps to
    ``(lambda / alpha + beta) / gamma``, inside the unit disc iff
    ``|lambda + alpha beta| < alpha gamma``.

    Parameters
    ----------
    alpha, beta, gamma : float
        Positive scales (validated by the methods).
    """

    alpha: float
    beta: float = 1.0
    gamma: float = 1.0


class BasisFamily(ABC):
    """A family of basis functions as the pipeline uses it (module docstring).

    Class attributes: ``label`` (name in warnings and options), ``n_min``, ``n_max`` (limits
    of the default size), ``q`` (pseudo-input rows per block without and with the boundary
    rows, for the default window), ``needs_ones`` (the pseudo-input rows need the
    projection of the constant ``1``), ``core_overrides`` (core options the family fixes).
    """

    label: str = "basis"
    n_min: int = 100
    n_max: int = 4000
    q: tuple[int, int] = (1, 2)
    needs_ones: bool = False
    core_overrides: dict[str, Any] = {}

    @abstractmethod
    def size_rate(self, wb: float) -> float:
        """Functions per second of window of the default size rule at data bandwidth ``wb``.

        Parameters
        ----------
        wb : float
            Data bandwidth (rad/s).

        Returns
        -------
        float
            ``wanted_size(T, wb) / T`` (the rule is linear in the window length).
        """

    @abstractmethod
    def wanted_size(self, T: float, wb: float) -> float:
        """The default rule's basis size for a window, before clipping.

        Parameters
        ----------
        T : float
            Window length (s).
        wb : float
            Data bandwidth (rad/s) the basis must cover.

        Returns
        -------
        float
            The size the rule wants (clipped by :meth:`default_size`).
        """

    size_rule: str = "N from the band"

    def default_size(self, T: float, wb: float, ns: int) -> Choice[int]:
        """:meth:`wanted_size` clipped to ``[n_min, n_max]`` and ``Ns / 2``.

        The lower limit keeps enough coefficients for the core's windows, the upper one bounds
        the cost, and ``Ns / 2`` makes the samples resolve the fastest basis function; a warning
        says when an upper limit binds (:func:`~hdpbsid.bases.basis_domain.clip_basis_size`).

        Parameters
        ----------
        T : float
            Window length (s).
        wb : float
            Data bandwidth (rad/s).
        ns : int
            Samples in the window.

        Returns
        -------
        Choice of int
            The size and the rule that chose it.
        """
        N, why = clip_basis_size(
            self.wanted_size(T, wb), self.n_min, self.n_max, ns, self.label, self.size_rule
        )
        return Choice(N, why)

    def too_narrow(self, N: int, T: float, wb: float) -> str | None:
        """Why ``N`` functions on ``T`` seconds do not resolve the band ``wb``, or None.

        The base class accepts every ``N``; families with a band limit override it.

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
            The reason (a message naming the ``N`` needed), or None when ``N`` suffices.
        """
        return None

    @abstractmethod
    def basis(self, N: int, T: float) -> Any:
        """The basis of ``N`` functions on the window ``[0, T]``.

        Parameters
        ----------
        N : int
            Number of functions.
        T : float
            Window length (s).

        Returns
        -------
        object
            The basis (an :class:`slbasis.numeric.basis.Basis` or the family's own type), with
            ``N`` and ``project``.
        """

    @abstractmethod
    def lag(self, basis: Any, operator: Any) -> LagOperator:
        """The lag operator ``W -> W M`` of ``basis`` at the operator scale ``operator``.

        Parameters
        ----------
        basis : object
            A basis of :meth:`basis`.
        operator : object
            The operator scale (e.g. :class:`Integrator`).

        Returns
        -------
        LagOperator
            "One step back" in the coefficient index.
        """

    @abstractmethod
    def pseudo_rows(self, basis: Any, operator: Any, boundary: bool, ones: Array | None) -> Array:
        """The pseudo-input rows of one block.

        Rows whose vector factors are unknown and differ per block: boundary values of the
        state and the truncation of the cut operator, eliminated by the block core.

        Parameters
        ----------
        basis : object
            The block's basis.
        operator : object
            The operator scale.
        boundary : bool
            Include the boundary rows.
        ones : ndarray or None
            Coefficients of the constant 1 (families with ``needs_ones``).

        Returns
        -------
        ndarray, shape (q, N)
            The rows.
        """

    @abstractmethod
    def model(
        self,
        out: CoreOut,
        operator: Any,
        options: dict[str, Any],
        *,
        settings: BasisSettings,
        hold: str,
        hold_criterion: dict[str, float],
        order: int | None,
    ) -> StateSpaceModel:
        """The continuous-time model from the core's basis-domain system.

        Parameters
        ----------
        out : CoreOut
            The core's system in the basis domain.
        operator : object
            The operator scale the core ran at.
        options : dict
            The options to record in the model.
        settings : BasisSettings
            The method's settings.
        hold : str
            The input hold used for the projection.
        hold_criterion : dict of str to float
            The criterion of each hold tried.
        order : int or None
            The order asked for (None: selected).

        Returns
        -------
        StateSpaceModel
            The continuous-time model.
        """


class IntegratorFamily(BasisFamily):
    """A family whose lag is an integrator ``M`` at an :class:`Integrator` scale; the model
    maps back by ``A = alpha (gamma A' - beta I)``, ``B = alpha gamma B'``,
    ``K = alpha gamma K'`` (:func:`~hdpbsid.bases.basis_domain.integrator_model`)."""

    def model(
        self,
        out: CoreOut,
        operator: Integrator,
        options: dict[str, Any],
        *,
        settings: BasisSettings,
        hold: str,
        hold_criterion: dict[str, float],
        order: int | None,
    ) -> StateSpaceModel:
        """The continuous-time model of an integrator-form system.

        The core identifies ``A' = (A / alpha + beta I) / gamma``, ``B' = B / (alpha gamma)``,
        ``K' = K / (alpha gamma)``; inverting gives ``A = alpha (gamma A' - beta I)``, ``B =
        alpha gamma B'``, ``K = alpha gamma K'``
        (:func:`~hdpbsid.bases.basis_domain.integrator_model`).

        Parameters
        ----------
        out : CoreOut
            The core's system in the basis domain.
        operator : Integrator
            The operator scale.
        options : dict
            The options to record in the model.
        settings : BasisSettings
            The method's settings.
        hold : str
            The input hold used.
        hold_criterion : dict of str to float
            The criterion of each hold tried.
        order : int or None
            The order asked for.

        Returns
        -------
        StateSpaceModel
            The continuous-time model.
        """
        a = operator
        return integrator_model(
            out,
            a.alpha,
            a.beta,
            a.gamma,
            options,
            settings=settings,
            hold=hold,
            hold_criterion=hold_criterion,
            order=order,
        )


def size_policy(
    family: BasisFamily, N: int | None, wb: float
) -> Callable[[float, int], Choice[int]]:
    """The basis size of every block: ``N`` when given (checked against the block), else
    the family's default rule at the data bandwidth ``wb``.

    Parameters
    ----------
    family : BasisFamily
        The family whose rule and checks apply.
    N : int or None
        The user's basis size (validated as an integer ``>= 2`` by the method), or None.
    wb : float
        The data bandwidth (rad/s) the basis must cover.

    Returns
    -------
    callable
        ``size(T, ns) -> Choice[int]`` for a block of ``T`` seconds and ``ns`` samples.

    Raises
    ------
    ValueError
        (when called) a given ``N`` that does not resolve ``wb`` on the block or exceeds
        its number of samples.
    """

    def size(T: float, ns: int) -> Choice[int]:
        if N is None:
            return family.default_size(T, wb, ns)
        why = family.too_narrow(N, T, wb)
        if why is not None:
            raise ValueError(why)
        if N > ns:
            raise ValueError(f"N={N} exceeds the number of samples Ns={ns}; reduce N")
        return Choice(N, "given")

    return size
