"""Prediction-error refinement of any method's model (``refine="pem"``).

* :mod:`~hdpbsid.refine.pem` -- the refinement: parametrisation, least squares, checks;
* :mod:`~hdpbsid.refine.pem_predictor` -- the sampled innovation predictor and its exact
  derivatives;
* :mod:`~hdpbsid.refine.pem_kernels` -- compiled passes (errors, sensitivities).
"""
