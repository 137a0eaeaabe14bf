"""Records in, checked: the first stage of the pipeline.

* :mod:`~hdpbsid.data.checks` -- input checks (``check_data``, ``check_time``, ...);
* :mod:`~hdpbsid.data.records` -- several records, windows of one record;
* :mod:`~hdpbsid.data.detrend` -- operating points: levels removed and stored;
* :mod:`~hdpbsid.data.io` -- readers of CSV, .mat, .npz, Parquet and HDF5 files.

Imports nothing of ``hdpbsid`` above it.
"""
