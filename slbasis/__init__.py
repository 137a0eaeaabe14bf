"""slbasis: orthonormal bases from Sturm–Liouville eigenproblems, derived and verified.

* :class:`SturmLiouville` — give it ``p0, p1, q0`` of ``p0 f'' + p1 f' - q0 f = -lambda f``
  and it derives (exactly, with sympy) the weight, interval, eigenvalues, Rodrigues
  eigenfunctions, norms, recurrences, ladder operators and the banded derivative operator,
  and verifies them (:meth:`SturmLiouville.verify`).
* :data:`families` — the catalogue of classical families with their textbook oracles.
* :mod:`slbasis.numeric` — stable evaluation, quadrature, projection and operator matrices.
"""

from typing import Any

from .bases import basis, kernel
from .families import families
from .numeric import Basis, Kernel, KernelSpec, TimeMap, check_kernel, evaluate, gauss


def __getattr__(name: str) -> Any:
    """:class:`SturmLiouville` on first access (PEP 562): it imports sympy, which numeric
    work (``slbasis.basis("hermite", ...)``) never needs."""
    if name == "SturmLiouville":
        from .symbolic.problem import SturmLiouville

        return SturmLiouville
    raise AttributeError(f"module 'slbasis' has no attribute {name!r}")


__all__ = [
    "Basis",
    "Kernel",
    "KernelSpec",
    "SturmLiouville",
    "TimeMap",
    "basis",
    "kernel",
    "check_kernel",
    "evaluate",
    "families",
    "gauss",
]
