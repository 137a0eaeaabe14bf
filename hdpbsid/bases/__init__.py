"""What the basis-domain methods share: settings, projection, windows, operator scale.

* :mod:`~hdpbsid.bases.settings` -- ``BasisSettings``, the settings they share;
* :mod:`~hdpbsid.bases.basis_domain` -- projection of the sample interpolants, lags,
  the map back of the integrator form;
* :mod:`~hdpbsid.bases.spectra` -- the bandwidths the default rules start from;
* :mod:`~hdpbsid.bases.basis_core` -- running the core: scaling, past window, input hold;
* :mod:`~hdpbsid.bases.segments` -- several records and windows of one record as blocks;
* :mod:`~hdpbsid.bases.memo` -- content-keyed cache of projections across orders;
* :mod:`~hdpbsid.bases.operator_scale` -- ``alpha`` of the integrator form from the
  identified modes.
"""
