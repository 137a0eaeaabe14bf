"""Thread counts of hdpbsid's calls (BLAS and compiled kernels): :mod:`slbasis.runtime`.

Every public entry point (:func:`hdpbsid.identify`, the ``identify_*`` methods, the
selection, the refinement, the model's simulation and fit) runs with one BLAS thread for
its small-matrix work, the caller's threads for single factorisations of at least
:data:`LARGE_FLOPS` operations, and numba's threads for the projection kernels.
``HDPBSID_NUM_THREADS=n`` (:data:`ENV_VAR`) or ``with hdpbsid.num_threads(n): ...`` sets
one count for all of them.
"""

from slbasis.runtime import (
    ENV_VAR,
    LARGE_FLOPS,
    blas_threads,
    compiled_threads,
    large_work,
    library_call,
    num_threads,
    requested_threads,
    user_stacklevel,
)

__all__ = [
    "ENV_VAR",
    "LARGE_FLOPS",
    "blas_threads",
    "compiled_threads",
    "large_work",
    "library_call",
    "num_threads",
    "requested_threads",
    "user_stacklevel",
]
