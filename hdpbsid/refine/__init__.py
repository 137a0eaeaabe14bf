"""Prediction-error refinement of any method's model (``refine="pem"``).

* :mod:`~hdpbsid.refine.pem` -- the refinement: starting points, input holds,
  Levenberg-Marquardt in local coordinates, stopping rule, refined model;
* :mod:`~hdpbsid.refine.pem_settings` -- its budget, stopping rule and evidence thresholds
  (:class:`~hdpbsid.refine.pem_settings.RefinementSettings`);
* :mod:`~hdpbsid.refine.pem_residuals` -- the parametrisation and the prediction errors
  with their Jacobian (variable projection of the initial state);
* :mod:`~hdpbsid.refine.pem_predictor` -- the sampled innovation predictor and its exact
  derivatives;
* :mod:`~hdpbsid.refine.pem_kernels` -- compiled passes (errors, sensitivities).
"""
