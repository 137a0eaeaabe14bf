"""hdpbsid: continuous-time predictor-based subspace identification in a basis domain.

Entry point: :func:`identify` (docs/user-guide.md).  The basis-domain
methods (``identify_hermite``, ``identify_laguerre``, ``identify_legendre``,
``identify_chebyshev``, ``identify_sl``) are
imported on first access so that ``import hdpbsid`` stays light.

Threads: the library limits BLAS to one thread for its small-matrix work and uses the
cores for large factorisations and the compiled projection (:mod:`hdpbsid.runtime`);
``HDPBSID_NUM_THREADS=n`` or ``with hdpbsid.num_threads(n): ...`` overrides it.
"""

from typing import Any

from .conversion import c2d, d2c
from .core.pbsid import pbsid_core
from .core.varx import LagOperator, MatrixLag, SampleShift
from .identify import (
    METHODS,
    available_methods,
    get_method,
    identify,
    is_available,
    register_method,
)
from .methods.dt import identify_discrete, identify_dt
from .methods.settings import BasisSettings
from .metrics import eigenvalue_errors, match_eigenvalues
from .model import DiscreteModel, FitResult, StateSpaceModel, TimeScaleWarning
from .model_io import load_model, save_model
from .runtime import num_threads
from .selection import SelectionWarning
from .systems.quadrotor import PitchData, pitch_model, simulate_pitch_closed_loop

_LAZY_ATTRS = {
    "identify_hermite": "hdpbsid.methods.hermite",
    "identify_laguerre": "hdpbsid.methods.laguerre",
    "identify_legendre": "hdpbsid.methods.sturm_liouville",
    "identify_chebyshev": "hdpbsid.methods.sturm_liouville",
    "identify_sl": "hdpbsid.methods.sturm_liouville",
}


def __getattr__(name: str) -> Any:
    """Lazy access to the basis-domain identification functions (PEP 562)."""
    if name in _LAZY_ATTRS:
        import importlib

        return getattr(importlib.import_module(_LAZY_ATTRS[name]), name)
    if name == "studies":  # the simulation studies, loaded on first use
        import importlib

        return importlib.import_module("hdpbsid.studies")
    raise AttributeError(f"module 'hdpbsid' has no attribute {name!r}")


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
