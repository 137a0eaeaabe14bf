"""Experiment design: the inputs a record is measured with.

* :mod:`~hdpbsid.design.inputs` -- PRBS, random binary, multisines, sweeps.
"""
