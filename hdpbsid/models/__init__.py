"""The identified model and what is done with it.

* :mod:`~hdpbsid.models.model` -- ``StateSpaceModel``, ``DiscreteModel``, ``FitResult``;
* :mod:`~hdpbsid.models.model_base`, :mod:`~hdpbsid.models.fit_result`,
  :mod:`~hdpbsid.models.time_scale`, :mod:`~hdpbsid.models.simulation`,
  :mod:`~hdpbsid.models.interop`, :mod:`~hdpbsid.models.scaling` -- its parts;
* :mod:`~hdpbsid.models.model_io` -- the strict JSON model file;
* :mod:`~hdpbsid.models.conversion` -- exact ``c2d`` / ``d2c``;
* :mod:`~hdpbsid.models.recursion` -- ``x_{k+1} = F x_k + w_k`` (simulation, prediction);
* :mod:`~hdpbsid.models.assessment` -- validation: fit, k-step prediction, residual tests;
* :mod:`~hdpbsid.models.criteria` -- windowed simulation / prediction error of a model;
* :mod:`~hdpbsid.models.metrics` -- eigenvalue matching and errors.

Every method returns a model, so this layer sits below the methods: it imports only the
data layer.
"""
