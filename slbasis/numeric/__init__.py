"""slbasis.numeric: generic numeric machinery for kernels of orthonormal function bases.

Modules (one job each): :mod:`.kernel` (the interface a generated kernel implements),
:mod:`.evaluate` (stable three-term recurrence), :mod:`.compiled` (the same recurrence as
numba kernels, fused with projection sums; optional), :mod:`.engine` (numpy or compiled,
threads), :mod:`.quadrature` (Gauss rules),
:mod:`.projection` (streaming projection / reconstruction), :mod:`.operators`
(multiplication, derivative and, for Legendre functions, integration matrices),
:mod:`.timemap` (affine time map),
:mod:`.basis` (the :class:`Basis` object).
"""

from .basis import Basis
from .evaluate import evaluate, evaluate_derivative
from .kernel import Kernel, KernelSpec, check_kernel
from .operators import (
    derivative_matrix,
    derivative_operator,
    integration_matrix,
    is_legendre,
    multiplication_matrix,
)
from .projection import project, reconstruct, sample_weights
from .quadrature import christoffel_weights, gauss
from .timemap import TimeMap

__all__ = [
    "Basis",
    "Kernel",
    "KernelSpec",
    "TimeMap",
    "check_kernel",
    "christoffel_weights",
    "derivative_matrix",
    "derivative_operator",
    "evaluate",
    "evaluate_derivative",
    "gauss",
    "integration_matrix",
    "is_legendre",
    "multiplication_matrix",
    "project",
    "reconstruct",
    "sample_weights",
]
