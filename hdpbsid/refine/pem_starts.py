"""The starting points of the prediction-error refinement (:mod:`hdpbsid.refine.pem`):
the Kalman gain of a measurement-noise model (:func:`_kalman_gain`), the warm start,
a prediction-error fit on part of the record offered by the selection
(:func:`warm_start_option`), and the input holds it is fitted with
(:func:`_candidate_holds`)."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm, solve_discrete_are

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import WarmStart
from hdpbsid.refine.pem_residuals import _scale

__all__ = ["warm_start_option", "WARM_START_NAME", "HOLDS"]

Array = NDArray[np.float64]

#: input holds the sampled predictor handles (:mod:`hdpbsid.refine.pem`)
HOLDS = ("zoh", "foh")
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


def _candidate_holds(model: StateSpaceModel, hold: str | None) -> tuple[str, ...]:
    """The input holds the refinement fits: ``hold`` when given; the model's
    ``options["input_hold"]`` when the method was told it (``input_hold_rule ==
    "given"``); with no input, one (the hold is then irrelevant); otherwise both, the
    model's first.

    Why both: a subspace method's choice of hold (the smaller AIC of its least-squares
    VARX fit) is made on biased residuals in closed loop, and the wrong hold is not a
    small error: it shifts the input by half a sample, which a model of fixed order
    absorbs by moving its fast modes.  The two sampled predictors have the same
    parameters and the same data, so their prediction-error costs under one weighting
    compare directly (the likelihood ratio of two structures of equal dimension; Ljung,
    *System Identification*, 2nd ed., sec. 16.4): the hold is chosen with the starting
    point, by the same criterion.
    """
    if hold is not None:
        return (hold,)
    own = model.report.hold
    own = own if own in HOLDS else "zoh"
    if model.m == 0 or _hold_was_given(model):
        return (own,)
    return (own, *(hd for hd in HOLDS if hd != own))


def _hold_was_given(model: StateSpaceModel) -> bool:
    """Whether the method that produced ``model`` was told its input hold (the basis
    methods report the hold's reason ``"given"`` then)."""
    return model.report.input_hold is not None and model.report.input_hold.given
