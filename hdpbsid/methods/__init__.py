"""Identification methods: each turns a record ``(t, u, y)`` into a continuous-time model.

* :mod:`~hdpbsid.methods.dt` -- PBSID on the samples, then the exact ZOH ``d2c``;
* :mod:`~hdpbsid.methods.hermite` -- HD-PBSID (Hermite functions, integrator form);
* :mod:`~hdpbsid.methods.laguerre` -- CT-PBSID (Laguerre projection or filters);
* :mod:`~hdpbsid.methods.sturm_liouville` -- any finite-interval Sturm-Liouville basis
  (Legendre, Chebyshev, Jacobi, a custom problem);
* :mod:`~hdpbsid.methods.chunked` -- HD-PBSID of records read in chunks (files larger
  than memory, Dask).

What the basis methods share is in :mod:`hdpbsid.bases`; the prediction-error
refinement of any method's model in :mod:`hdpbsid.refine`.  The methods are imported on
first use by :func:`hdpbsid.identify` (a light ``import hdpbsid``).
"""
