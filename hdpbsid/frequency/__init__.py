"""Frequency-domain data: frequency responses and models fitted to them.

* :mod:`~hdpbsid.frequency.fit` -- FRF and coherence estimates, ``identify_frequency``.
"""
