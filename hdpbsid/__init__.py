"""hdpbsid: continuous-time predictor-based subspace identification in a basis domain.

Entry point: :func:`identify` (DESIGN.md, "The public surface").  The basis-domain
methods (``identify_hermite``, ``identify_laguerre``, ``identify_legendre``,
``identify_chebyshev``, ``identify_sl``) are
imported on first access so that ``import hdpbsid`` stays light.
"""

from typing import Any

from .conversion import c2d, d2c
from .dt import identify_discrete, identify_dt
from .identify import (
    METHODS,
    available_methods,
    get_method,
    identify,
    is_available,
    register_method,
)
from .metrics import eigenvalue_errors, match_eigenvalues
from .model import DiscreteModel, FitResult, StateSpaceModel
from .pbsid import pbsid_core
from .quadrotor import PitchData, pitch_model, simulate_pitch_closed_loop
from .varx import LagOperator, MatrixLag, SampleShift

_LAZY_ATTRS = {
    "identify_hermite": "hdpbsid.hermite",
    "identify_laguerre": "hdpbsid.laguerre",
    "identify_legendre": "hdpbsid.sl_basis_method",
    "identify_chebyshev": "hdpbsid.sl_basis_method",
    "identify_sl": "hdpbsid.sl_basis_method",
}


def __getattr__(name: str) -> Any:
    """Lazy access to the basis-domain identification functions (PEP 562)."""
    if name in _LAZY_ATTRS:
        import importlib

        return getattr(importlib.import_module(_LAZY_ATTRS[name]), name)
    if name == "studies":  # the simulation studies (issue 5), loaded on first use
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
    "StateSpaceModel",
    "DiscreteModel",
    "FitResult",
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
]
