"""Frequency-domain data: frequency responses and models fitted to them.

* :mod:`~hdpbsid.frequency.estimate` -- FRF and coherence estimates with their confidence;
* :mod:`~hdpbsid.frequency.fit` -- ``identify_frequency`` and the Bode figure (the
  estimates re-exported);
* :mod:`~hdpbsid.frequency.delay` -- dead-time estimates.
"""
