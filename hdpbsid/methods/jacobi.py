"""Method ``"jacobi"``: PBSID in Jacobi functions on the record window.

The Jacobi polynomials ``P_n^{(a,b)}`` are orthogonal on ``[-1, 1]`` with the weight
``w(x) = (1 - x)^a (1 + x)^b``, ``a, b > -1`` (DLMF 18.3); the functions
``phi_n = sqrt(w) P_n^{(a,b)} / ||P_n^{(a,b)}||_w`` are orthonormal in ``L^2(dx)`` and,
mapped affinely onto the window, in ``L^2(dt)`` (``slbasis`` family ``"jacobi"``).  They
solve a Sturm-Liouville problem on a finite interval, so the integrator form of
:mod:`hdpbsid.methods.sturm_liouville` holds unchanged,

    X = A' X M + B' U M + K' E M + (pseudo-inputs),   M = alpha gamma J (I + alpha beta J)^{-1},

with ``J`` the causal integration matrix (by quadrature: ``phi_n'`` leaves the span unless
``a = b = 0``).  The exponents set how the functions behave at the window ends,
``phi_n ~ (1 - x)^{a/2}``: ``a = b = 0`` gives the Legendre functions, ``a = b = 1``
functions vanishing at both ends.  This module is the whole family; the rest is generic
(:class:`~hdpbsid.methods.sturm_liouville.SturmLiouvilleFamily`,
:mod:`hdpbsid.bases.pipeline`).
"""

from __future__ import annotations

from typing import Any

from hdpbsid.bases.sl_family import SturmLiouvilleFamily
from hdpbsid.data.records import Dataset
from hdpbsid.methods.hermite import _real
from hdpbsid.methods.sturm_liouville import fit_sl
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.runtime import library_call

__all__ = ["JacobiFamily", "identify_jacobi", "fit_jacobi"]


class JacobiFamily(SturmLiouvilleFamily):
    """Jacobi functions with exponents ``a``, ``b`` (module docstring).

    Parameters
    ----------
    a, b : float
        Exponents of the weight ``(1 - x)^a (1 + x)^b``, each ``> -1``.

    Raises
    ------
    ValueError
        An exponent not a finite number ``> -1``.

    Examples
    --------
    >>> JacobiFamily(1, 0.5).params
    {'alpha': 1.0, 'beta': 0.5}
    """

    def __init__(self, a: float = 1.0, b: float = 1.0) -> None:
        exps = {"alpha": _real(a, "a", False), "beta": _real(b, "b", False)}
        for name, v in zip("ab", exps.values(), strict=True):
            if v <= -1:
                raise ValueError(f"{name} must be > -1 (an integrable weight), got {v}")
        super().__init__("jacobi", exps)

    @property
    def method(self) -> str:
        """The method name the models report."""
        return "jacobi"


@library_call
def identify_jacobi(
    t: Any, u: Any = None, y: Any = None, order: int | None = None, **options: Any
) -> StateSpaceModel:
    """PBSID with Jacobi functions on the record window.

    Parameters
    ----------
    t, u, y, order
        As in :func:`~hdpbsid.methods.sturm_liouville.identify_sl`.
    **options
        ``a``, ``b`` (default 1, 1: :class:`JacobiFamily`) and the options of
        :func:`~hdpbsid.methods.sturm_liouville.identify_sl` but ``family``.

    Returns
    -------
    StateSpaceModel
        ``options["method"] == "jacobi"``, ``options["family_params"]`` the exponents.

    Raises
    ------
    TypeError
        ``family`` or ``family_params`` passed (the family is Jacobi's).
    ValueError
        Bad exponents, or as :func:`~hdpbsid.methods.sturm_liouville.identify_sl`.
    """
    _family_fixed(options)
    return fit_jacobi(Dataset.of(t, u, y), order, **options)


@library_call
def fit_jacobi(data: Dataset, order: int | None = None, **options: Any) -> StateSpaceModel:
    """:func:`identify_jacobi` on the records of ``data`` (the registry's call shape,
    :func:`hdpbsid.methods.registry.get_fit`).

    Parameters
    ----------
    data : Dataset
        The records, checked.
    order : int, optional
        Model order; None selects it.
    **options
        ``a``, ``b`` and the options of :func:`~hdpbsid.methods.sturm_liouville.fit_sl`
        but ``family``.

    Returns
    -------
    StateSpaceModel
        ``options["method"] == "jacobi"``, ``options["family_params"]`` the exponents.

    Raises
    ------
    TypeError
        ``family`` or ``family_params`` passed (the family is Jacobi's).
    """
    _family_fixed(options)
    family = JacobiFamily(options.pop("a", 1.0), options.pop("b", 1.0))
    return fit_sl(data, order, family=family, **options)


def _family_fixed(options: dict[str, Any]) -> None:
    """Refuse ``family`` and ``family_params`` (the family is Jacobi's)."""
    if "family" in options or "family_params" in options:
        raise TypeError("identify_jacobi: the family is Jacobi's; pass a and b, or use identify_sl")


identify_jacobi.fit = fit_jacobi  # type: ignore[attr-defined]
