"""The starting points of the prediction-error refinement (:mod:`hdpbsid.refine.pem`):
the Kalman gain of a measurement-noise model (:func:`_kalman_gain`) and the warm start,
a prediction-error fit on part of the record offered by the selection
(:func:`warm_start_option`)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm, solve_discrete_are

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import WarmStart
from hdpbsid.refine.pem_residuals import _scale

__all__ = ["warm_start_option", "WARM_START_NAME"]

Array = NDArray[np.float64]

#: the default name of the warm start in ``options["refine_start"]``
WARM_START_NAME = "prediction-error fit on part of the record"


def _kalman_gain(A: Array, C: Array, h: float, q: float) -> Array:
    """Continuous ``K`` of the steady-state Kalman predictor of the sampled model with
    process noise ``q I`` and unit measurement noise (filter DARE; stable whenever
    ``(A, C)`` is detectable), mapped back with ``Kd = int_0^h e^{A s} ds K``
    (:mod:`hdpbsid.models.conversion`)."""
    n, l = A.shape[0], C.shape[0]
    E = expm(np.block([[A * h, np.eye(n) * h], [np.zeros((n, 2 * n))]]))
    Phi, Psi = E[:n, :n], E[:n, n:]
    P = solve_discrete_are(Phi.T, C.T, q * np.eye(n), np.eye(l))
    Kd = Phi @ P @ C.T @ np.linalg.inv(C @ P @ C.T + np.eye(l))
    return np.linalg.solve(Psi, Kd)


def _check_warm_start(warm_start: Any) -> WarmStart | None:
    """``warm_start`` of :func:`refine_pem`, checked."""
    if warm_start is not None and not isinstance(warm_start, WarmStart):
        raise TypeError(
            "warm_start must be a hdpbsid.models.report.WarmStart or None, got "
            f"{type(warm_start).__name__}"
        )
    return warm_start


def _warm_first(holds: tuple[str, ...], warm_start: WarmStart | None) -> tuple[str, ...]:
    """``holds`` with the warm start's hold first when it is among them: that hold was
    chosen by a prediction-error fit."""
    warm_hold = None if warm_start is None else warm_start.input_hold
    if warm_hold in holds[1:]:
        return (warm_hold, *[hd for hd in holds if hd != warm_hold])
    return holds


def _warm_name(warm_start: WarmStart | None) -> str:
    """The name of the warm start among the starting points."""
    return str((warm_start.name if warm_start is not None else None) or WARM_START_NAME)


def warm_start_option(model: StateSpaceModel) -> WarmStart:
    """The ``warm_start`` of :func:`refine_pem` that offers ``model`` (a prediction-error
    fit on part of the record) as a starting point: its matrices and its input hold.

    Parameters
    ----------
    model : StateSpaceModel
        The starting model.

    Returns
    -------
    WarmStart

    Examples
    --------
    >>> from hdpbsid import StateSpaceModel
    >>> m = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.5]])
    >>> warm_start_option(m)
    WarmStart(n=1, input_hold=None, name=None)
    """
    return WarmStart.of(model, model.report.hold)


def _warm_start(
    model: StateSpaceModel, warm: WarmStart | None, ys: Array, us: Array
) -> tuple[Array, ...] | None:
    """The scaled ``(A, B, C, D, K)`` of the warm start ``warm`` (:func:`refine_pem`), or
    None when there is none or its shapes are not the model's."""
    if warm is None:
        return None
    try:
        wm = StateSpaceModel(*(np.asarray(getattr(warm, k), dtype=float) for k in "ABCDK"))
    except (ValueError, TypeError):
        return None
    if (wm.n, wm.m, wm.l) != (model.n, model.m, model.l):
        return None
    return _scale(wm, ys, us)
