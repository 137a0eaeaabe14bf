"""hdpbsid: continuous-time predictor-based subspace identification in a basis domain."""

from .conversion import c2d, d2c
from .dt import identify_discrete, identify_dt
from .model import DiscreteModel, FitResult, StateSpaceModel
from .pbsid import pbsid_core
from .varx import LagOperator, MatrixLag, SampleShift

__all__: list[str] = [
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
]
