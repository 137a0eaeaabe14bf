"""The discrete PBSID core, generic over the "one step back" operator.

``varx`` estimates the VARX predictor, ``pbsid`` builds ``Gamma L``, takes the SVD, the
state sequence and the least-squares ``(A, B, C, D, K)``.  Nothing here knows about time,
bases or continuous-time models: a :class:`~hdpbsid.core.varx.LagOperator` says what
"the previous sample" means (a sample shift, or a basis-domain operator such as the
Hermite integrator ``D'^{-1}``).  Imports go one way: ``methods`` use the core, the core
uses nothing of ``hdpbsid`` but the input checks.
"""

from hdpbsid.core.pbsid import CoreResult, pbsid_core
from hdpbsid.core.varx import LagOperator, MatrixLag, SampleShift, VarxResult, two_stage_ls, varx

__all__ = [
    "pbsid_core",
    "CoreResult",
    "varx",
    "two_stage_ls",
    "VarxResult",
    "LagOperator",
    "MatrixLag",
    "SampleShift",
]
