"""hdpbsid: continuous-time predictor-based subspace identification in a basis domain.

Entry point: :func:`identify` (docs/user-guide.md).  Every public name is imported on
first access (PEP 562), so that ``import hdpbsid`` costs little more than the interpreter
(scipy, the methods and their compiled kernels load with the first name used:
``hdpbsid.identify`` or ``from hdpbsid import identify``); a name that is a submodule
(``hdpbsid.methods``) is imported on access too.

Threads: the library limits BLAS to one thread for its small-matrix work and uses the
cores for large factorisations and the compiled projection (:mod:`hdpbsid.runtime`);
``HDPBSID_NUM_THREADS=n`` or ``with hdpbsid.num_threads(n): ...`` overrides it.
"""

from __future__ import annotations

import copyreg
import importlib
import importlib.util
import sys
import types
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the names for type checkers and editors; at run time see _EXPORTS
    from hdpbsid.bases.settings import BasisSettings
    from hdpbsid.core.pbsid import pbsid_core
    from hdpbsid.core.varx import LagOperator, MatrixLag, SampleShift
    from hdpbsid.identify import identify
    from hdpbsid.methods.dt import identify_discrete, identify_dt
    from hdpbsid.methods.hermite import identify_hermite  # noqa: F401 (not in __all__)
    from hdpbsid.methods.laguerre import identify_laguerre  # noqa: F401
    from hdpbsid.methods.registry import (
        METHODS,
        available_methods,
        get_method,
        is_available,
        register_method,
    )
    from hdpbsid.methods.sturm_liouville import (  # noqa: F401
        identify_chebyshev,
        identify_legendre,
        identify_sl,
    )
    from hdpbsid.models.conversion import c2d, d2c
    from hdpbsid.models.metrics import eigenvalue_errors, match_eigenvalues
    from hdpbsid.models.model import DiscreteModel, FitResult, StateSpaceModel, TimeScaleWarning
    from hdpbsid.models.model_io import load_model, save_model
    from hdpbsid.runtime import num_threads
    from hdpbsid.selection.auto import SelectionWarning
    from hdpbsid.systems.quadrotor import PitchData, pitch_model, simulate_pitch_closed_loop

#: public name -> the module (relative to this package) that defines it
_EXPORTS: dict[str, str] = {
    **dict.fromkeys(("c2d", "d2c"), ".models.conversion"),
    "pbsid_core": ".core.pbsid",
    **dict.fromkeys(("LagOperator", "MatrixLag", "SampleShift"), ".core.varx"),
    "identify": ".identify",
    **dict.fromkeys(
        ("METHODS", "available_methods", "get_method", "is_available", "register_method"),
        ".methods.registry",
    ),
    **dict.fromkeys(("identify_discrete", "identify_dt"), ".methods.dt"),
    "identify_hermite": ".methods.hermite",
    "identify_laguerre": ".methods.laguerre",
    **dict.fromkeys(
        ("identify_legendre", "identify_chebyshev", "identify_sl"), ".methods.sturm_liouville"
    ),
    "BasisSettings": ".bases.settings",
    **dict.fromkeys(("match_eigenvalues", "eigenvalue_errors"), ".models.metrics"),
    **dict.fromkeys(
        ("DiscreteModel", "FitResult", "StateSpaceModel", "TimeScaleWarning"), ".models.model"
    ),
    **dict.fromkeys(("load_model", "save_model"), ".models.model_io"),
    "num_threads": ".runtime",
    "SelectionWarning": ".selection.auto",
    **dict.fromkeys(
        ("PitchData", "pitch_model", "simulate_pitch_closed_loop"), ".systems.quadrotor"
    ),
}


class _Package(types.ModuleType):
    """The package's module type: a submodule named like one of its functions
    (``hdpbsid.identify``) does not replace the function when it is imported.

    The import system sets the attribute ``identify`` of the package to the submodule
    ``hdpbsid.identify`` when it first loads it (``from hdpbsid.identify import ...``
    anywhere); the function of that name is kept instead.
    """

    def __setattr__(self, name: str, value: Any) -> None:
        if (
            isinstance(value, types.ModuleType)
            and value.__name__ == f"{__name__}.{name}"
            and _EXPORTS.get(name) == f".{name}"
        ):
            value = getattr(value, name)
        super().__setattr__(name, value)


def _reduce_package(module: types.ModuleType) -> tuple[Any, tuple[str]]:
    """Pickle the package by reference, as a plain module is: pickle and cloudpickle
    (joblib's workers) look up reducers by exact type, and a module subclass would
    otherwise be pickled as an object (and fail)."""
    return importlib.import_module, (module.__name__,)


copyreg.pickle(_Package, _reduce_package)
sys.modules[__name__].__class__ = _Package


def __getattr__(name: str) -> Any:
    """The public names (``_EXPORTS``) and the submodules, imported on first access."""
    if name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name], __name__), name)
    elif name.isidentifier() and importlib.util.find_spec(f"{__name__}.{name}") is not None:
        value = importlib.import_module(f".{name}", __name__)
    else:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_EXPORTS))


__all__: list[str] = [
    "identify",
    "register_method",
    "available_methods",
    "is_available",
    "get_method",
    "METHODS",
    "identify_dt",
    "identify_discrete",
    "BasisSettings",
    "StateSpaceModel",
    "DiscreteModel",
    "FitResult",
    "TimeScaleWarning",
    "SelectionWarning",
    "load_model",
    "save_model",
    "c2d",
    "d2c",
    "pbsid_core",
    "LagOperator",
    "SampleShift",
    "MatrixLag",
    "match_eigenvalues",
    "eigenvalue_errors",
    "pitch_model",
    "simulate_pitch_closed_loop",
    "PitchData",
    "num_threads",
]
