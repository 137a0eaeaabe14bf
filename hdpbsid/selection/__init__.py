"""The choices above the methods: order, method, refinement, long records.

* :mod:`~hdpbsid.selection.auto` -- ``method="auto"``: candidates scored on held-out data,
  in the stages :mod:`~hdpbsid.selection.candidates` (the sweep),
  :mod:`~hdpbsid.selection.scoring` (scores and checks),
  :mod:`~hdpbsid.selection.order_rule` (the order and method choices),
  :mod:`~hdpbsid.selection.rejudge` (the order among refined candidates; a drift mode,
  :mod:`~hdpbsid.selection.drift`, is not counted as one of the plant),
  :mod:`~hdpbsid.selection.refits` (the model returned) and
  :mod:`~hdpbsid.selection.direct_term` (``feedthrough="auto"``), with the numbers of
  :mod:`~hdpbsid.selection.policy`;
* :mod:`~hdpbsid.selection.feedthrough` -- the ``feedthrough="auto"`` rule;
* :mod:`~hdpbsid.selection.feedback` -- the ``refine="auto"`` rule, feedback test;
* :mod:`~hdpbsid.selection.long_records` -- the bounded default path for long records.

The method registry (:mod:`hdpbsid.methods.registry`) is below, so nothing here imports
the front end :mod:`hdpbsid.identify`.
"""
