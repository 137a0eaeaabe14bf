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
    """The committed generated kernel module of a catalogue family."""
    if family not in CATALOGUE:
        raise ValueError(f"family must be one of {sorted(CATALOGUE)}, got {family!r}")
    return importlib.import_module(f"slbasis.kernels.{CATALOGUE[family][0]}")


def bind_kernel(module: types.ModuleType, **params: float) -> ClosedFormKernel:
    """Fix the parameters of a generated closed-form module: a kernel.

    Missing parameters take the module's ``DEFAULTS``; unknown ones are a ``TypeError``;
    values outside the admissible range a ``ValueError`` (from ``check_parameters``).
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
    """The numeric kernel of a catalogue family name or of a custom problem."""
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

    ``family``: a catalogue name (``"hermite"``, ``"laguerre"``, ``"legendre"``, ...), a
    :class:`SturmLiouville` problem (its kernel is generated on demand) or a kernel object.
    ``params``: family parameters (``alpha`` for Laguerre, ...).  ``scale``/``centre``
    override the default affine time map (see :class:`~slbasis.numeric.Basis`).
    """
    if isinstance(family, str) or _is_problem(family):
        k = kernel(family, **params)
    elif params:
        raise TypeError("parameters apply to a family name or a problem, not to a kernel")
    else:
        k = family
    return Basis(k, N, t_span, scale=scale, centre=centre)
