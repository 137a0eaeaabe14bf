"""Generated numeric kernels, one module per catalogue family (see slbasis.codegen).

:data:`CATALOGUE` lives here, apart from the generator, so that finding a family's module
needs no sympy (``import slbasis`` does not import it).
"""

__all__ = ["CATALOGUE"]

#: Catalogue families -> (module name, default numeric parameter values).
CATALOGUE = {
    "hermite": ("hermite", {}),
    "hermite_functions": ("hermite_functions", {}),
    "laguerre": ("laguerre", {"alpha": 0}),
    "legendre": ("legendre", {}),
    "chebyshev_t": ("chebyshev_t", {}),
    "chebyshev_u": ("chebyshev_u", {}),
    "gegenbauer": ("gegenbauer", {"lam": 1}),
    "jacobi": ("jacobi", {"alpha": 0, "beta": 0}),
}
