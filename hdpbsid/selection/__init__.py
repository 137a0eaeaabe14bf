"""The choices above the methods: order, method, refinement, long records.

* :mod:`~hdpbsid.selection.auto` -- ``method="auto"``: candidates scored on held-out data;
* :mod:`~hdpbsid.selection.feedback` -- the ``refine="auto"`` rule, feedback test;
* :mod:`~hdpbsid.selection.long_records` -- the bounded default path for long records.

The method registry (:mod:`hdpbsid.methods.registry`) is below, so nothing here imports
the front end :mod:`hdpbsid.identify`.
"""
