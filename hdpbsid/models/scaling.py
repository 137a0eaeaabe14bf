"""The same system for signals in other units: :func:`scale_signals`.

The identification works on signals scaled by powers of two to unit size and returns the
model in the record's own units; a power-of-two scaling is an exact change of exponent,
so the round trip is bit for bit (IEEE 754: :func:`numpy.ldexp` rounds only on overflow
or underflow).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from hdpbsid.models.model_base import LinearTrend

__all__ = ["scale_signals"]


def scale_signals(model: Any, pu: Any, py: Any, px: int = 0) -> Any:
    """The same system for signals scaled by powers of two.

    ``u_new = u 2^pu``, ``y_new = y 2^py`` (per channel) and states ``x_new = x 2^px``:
    ``B -> 2^px B 2^-pu``, ``C -> 2^py C 2^-px``, ``D -> 2^py D 2^-pu``,
    ``K -> 2^px K 2^-py`` (the innovations are in output units), with the operating point
    and trend, the noise covariance (``2^py N 2^py``), the parameter covariance and the
    sampled model (if any); ``A`` and the eigenvalues are unchanged.

    Parameters
    ----------
    model : StateSpaceModel or DiscreteModel
        The model to rescale (not modified).
    pu : array_like of int, shape (m,)
        Power-of-two exponent of each input.
    py : array_like of int, shape (l,)
        Power-of-two exponent of each output.
    px : int, optional
        Power-of-two exponent of the states.

    Returns
    -------
    StateSpaceModel or DiscreteModel
        A new model of the same type.

    Raises
    ------
    ValueError
        If the exponents' lengths do not match the model's channels, or a matrix entry
        leaves the float64 range (the system's gain is not representable in those units).

    Notes
    -----
    Every product is an exact change of exponent (:func:`numpy.ldexp`): scaling and
    unscaling round-trips bit for bit, which is why the identification works on signals
    scaled to unit size and returns the model in the record's own units.
    """
    pu = np.asarray(pu, dtype=np.int64).reshape(-1)
    py = np.asarray(py, dtype=np.int64).reshape(-1)
    if pu.size != model.m or py.size != model.l:
        raise ValueError(
            f"scale_signals: {model.m} input and {model.l} output exponents needed, got "
            f"{pu.size} and {py.size}"
        )
    px = int(px)
    with np.errstate(over="ignore"):
        mats = {
            "B": np.ldexp(model.B, px - pu[None, :]),
            "C": np.ldexp(model.C, py[:, None] - px),
            "D": np.ldexp(model.D, py[:, None] - pu[None, :]),
            "K": np.ldexp(model.K, px - py[None, :]),
        }
    for k, M in mats.items():
        if not np.all(np.isfinite(M)):
            raise ValueError(
                f"the identified {k} overflows float64 in the record's units (its inputs and "
                f"outputs differ by more than the float range); rescale the signals"
            )
    tr = model.trend
    if tr is not None:
        tr = LinearTrend(tr.t_ref, np.ldexp(tr.u_slope, pu), np.ldexp(tr.y_slope, py))
    nc = model.noise_covariance
    if nc is not None:
        with np.errstate(over="ignore"):
            nc = np.ldexp(np.asarray(nc, dtype=float), py[:, None] + py[None, :])
        if not np.all(np.isfinite(nc)):
            nc = None  # the squares of the signals exceed float64: not representable
    cov = getattr(model, "parameter_covariance", None)
    if cov is not None:  # the parameters' factor scales with them
        n, m, l = model.n, model.m, model.l
        cov = cov.scaled(
            n,
            m,
            l,
            np.ldexp(np.ones((n, m)), px - pu[None, :]),
            np.ldexp(np.ones((l, n)), py[:, None] - px),
            np.ldexp(np.ones((l, m)), py[:, None] - pu[None, :]),
        )
    changes: dict[str, Any] = dict(
        mats,
        u0=np.ldexp(model.u0, pu),
        y0=np.ldexp(model.y0, py),
        trend=tr,
        noise_covariance=nc,
    )
    if hasattr(model, "discrete"):  # a StateSpaceModel (a DiscreteModel has neither)
        changes["parameter_covariance"] = cov
        if model.discrete is not None:
            changes["discrete"] = scale_signals(model.discrete, pu, py, px)
    return dataclasses.replace(model, **changes)
