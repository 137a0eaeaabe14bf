"""The generated kernels (slbasis/kernels/, via slbasis.kernel) under the fixture's names.

The numeric tests run on these — the library's own path; the hand-written textbook kernels
of ``numeric_kernels_fixture`` are the oracles they are compared with in test_codegen.py.
"""

from __future__ import annotations

import slbasis

HERMITE = slbasis.kernel("hermite_functions")
LAGUERRE = slbasis.kernel("laguerre", alpha=0)
LEGENDRE = slbasis.kernel("legendre")
CHEBYSHEV_T = slbasis.kernel("chebyshev_t")
ALL = {k.name: k for k in (HERMITE, LAGUERRE, LEGENDRE, CHEBYSHEV_T)}
