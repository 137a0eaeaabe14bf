"""``slbasis.basis(...)``: a numeric :class:`~slbasis.numeric.Basis` for a catalogue family,
a custom :class:`~slbasis.symbolic.problem.SturmLiouville` problem, or any kernel.

>>> import numpy as np, slbasis
>>> B = slbasis.basis("hermite", N=64, t_span=(0.0, 10.0))
>>> t = np.linspace(0.0, 10.0, 2001)
>>> c = B.project(t, np.exp(-(t - 5.0) ** 2))
>>> float(np.max(np.abs(B.reconstruct(c, t) - np.exp(-(t - 5.0) ** 2)))) < 1e-8
True
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING

from .kernels import CATALOGUE
from .numeric import Basis, Kernel
from .numeric.closed_form_kernel import ClosedFormKernel

if TYPE_CHECKING:
    from .symbolic.problem import SturmLiouville


def _is_problem(obj: object) -> bool:
    """Whether ``obj`` is a :class:`SturmLiouville` problem, without importing sympy: no
    problem can exist before its module (and sympy) has been imported."""
    module = sys.modules.get("slbasis.symbolic.problem")
    return module is not None and isinstance(obj, module.SturmLiouville)


def catalogue_kernel_module(family: str) -> types.ModuleType:
    """The committed generated kernel module of a catalogue family.

    Parameters
    ----------
    family : str
        A catalogue name (``"hermite"``, ``"laguerre"``, ``"legendre"``, ...).

    Returns
    -------
    module
        ``slbasis.kernels.<module>`` (:mod:`slbasis.codegen`).

    Raises
    ------
    ValueError
        If ``family`` is not in the catalogue (the message lists it).

    Examples
    --------
    >>> catalogue_kernel_module("legendre").__name__
    'slbasis.kernels.legendre'
    """
    if family not in CATALOGUE:
        raise ValueError(f"family must be one of {sorted(CATALOGUE)}, got {family!r}")
    return importlib.import_module(f"slbasis.kernels.{CATALOGUE[family][0]}")


def bind_kernel(module: types.ModuleType, **params: float) -> ClosedFormKernel:
    """Fix the parameters of a generated closed-form module: a kernel.

    Parameters
    ----------
    module : module
        A generated kernel module (:func:`catalogue_kernel_module`,
        :func:`slbasis.codegen.kernel_module`).
    **params : float
        The family's parameters; missing ones take the module's ``DEFAULTS``.

    Returns
    -------
    ClosedFormKernel
        The kernel.

    Raises
    ------
    TypeError
        If a parameter is unknown, or has no default and is not given.
    ValueError
        If a value leaves the admissible range (the module's ``check_parameters``).

    Examples
    --------
    >>> bind_kernel(catalogue_kernel_module("laguerre"), alpha=0.5).params
    {'alpha': 0.5}
    """
    unknown = set(params) - set(module.PARAMETERS)
    if unknown:
        raise TypeError(
            f"{module.name}: unknown parameter(s) {sorted(unknown)}; "
            f"it takes {module.PARAMETERS or 'none'}"
        )
    values = {}
    for name in module.PARAMETERS:
        if name in params:
            values[name] = float(params[name])
        elif name in module.DEFAULTS:
            values[name] = float(module.DEFAULTS[name])
        else:
            raise TypeError(f"{module.name}: parameter {name!r} has no default; pass it")
    return ClosedFormKernel(module, values)


def kernel(family: str | SturmLiouville, **params: float) -> ClosedFormKernel:
    """The numeric kernel of a catalogue family name or of a custom problem.

    A custom :class:`~slbasis.symbolic.problem.SturmLiouville` problem gets its kernel
    module generated on demand from its derivations (:func:`slbasis.codegen.kernel_module`).

    Parameters
    ----------
    family : str or SturmLiouville
        A catalogue name or a problem.
    **params : float
        The family's parameters.

    Returns
    -------
    ClosedFormKernel
        The kernel.

    Raises
    ------
    TypeError
        If ``family`` is neither, or a parameter is unknown.
    ValueError
        If ``family`` is not in the catalogue or a parameter is out of range.

    Examples
    --------
    >>> kernel("laguerre", alpha=0.5).params
    {'alpha': 0.5}
    """
    if _is_problem(family):
        from .codegen import kernel_module

        return bind_kernel(kernel_module(family), **params)
    if isinstance(family, str):
        return bind_kernel(catalogue_kernel_module(family), **params)
    raise TypeError(
        f"family must be a catalogue name or a SturmLiouville problem, got {type(family).__name__}"
    )


def basis(
    family: str | SturmLiouville | Kernel,
    N: int,
    t_span: tuple[float, float],
    scale: float | None = None,
    centre: float | None = None,
    **params: float,
) -> Basis:
    """A numeric basis of ``N`` orthonormal functions on the time window ``t_span``.

    The functions are the orthonormal eigenfunctions of a Sturm-Liouville problem, mapped
    affinely from the family's interval to time (:class:`~slbasis.numeric.basis.Basis`);
    ``scale``/``centre`` override the default map, which fits the window to the region where
    the first ``N`` functions oscillate.

    Parameters
    ----------
    family : str, SturmLiouville or Kernel
        A catalogue name (``"hermite"``, ``"laguerre"``, ``"legendre"``, ...), a problem (its
        kernel is generated on demand) or a kernel object.
    N : int
        Number of functions, ``>= 1``.
    t_span : tuple of float
        The window ``(t0, t1)``, ``t0 < t1``.
    scale : float, optional
        ``dx/dt`` of the map, ``> 0``.
    centre : float, optional
        The time mapped to ``x = 0``.
    **params : float
        Family parameters (``alpha`` for Laguerre, ...); not with a kernel object.

    Returns
    -------
    Basis
        The basis.

    Raises
    ------
    TypeError
        If parameters are passed with a kernel object, or the family is not accepted.
    ValueError
        If an argument is out of range.

    References
    ----------
    .. [1] A. Zettl, *Sturm-Liouville Theory*, Mathematical Surveys and Monographs 121,
       AMS, 2005.

    Examples
    --------
    Orthonormal Legendre functions on ``[0, 2]``; the coefficients of ``t^2`` and of its
    derivative ``2 t``, which the derivative matrix maps one to the other:

    >>> import numpy as np
    >>> B = basis("legendre", 4, (0.0, 2.0))
    >>> t = np.linspace(0.0, 2.0, 2001)
    >>> c = B.project(t, t**2)
    >>> c.round(4)
    array([1.8856, 1.633 , 0.4216, 0.    ])
    >>> (B.derivative_matrix() @ c).round(4) + 0.0
    array([2.8284, 1.633 , 0.    , 0.    ])
    """
    if isinstance(family, str) or _is_problem(family):
        k = kernel(family, **params)
    elif params:
        raise TypeError("parameters apply to a family name or a problem, not to a kernel")
    else:
        k = family
    return Basis(k, N, t_span, scale=scale, centre=centre)
