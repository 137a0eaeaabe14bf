"""The refinement's simulation focus (``refine_pem(..., focus="simulation")``): the
plant by its output error, then the noise model with the plant held.

The innovation model ties its noise model to the plant (``K`` enters through the same
``A`` and ``C``), so the prediction-error plant is consistent only when the disturbance
has that form; the output-error plant (``K = 0``: the one-step predictor is the
simulation) is consistent in open loop whatever the disturbance (Ljung, *System
Identification*, 2nd ed., 1999, sec. 8.5), and on a process with a nonlinear
distortion it is the best linear approximation (Pintelon & Schoukens, *System
Identification: A Frequency Domain Approach*, 2nd ed., 2012, ch. 3).  Both fits are
the prediction-error search of :mod:`hdpbsid.refine.pem` restricted to part of the
parameters (:class:`~hdpbsid.refine.pem_residuals._Layout`'s ``free``), composed here.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable

import numpy as np

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.runtime import user_stacklevel

__all__ = ["FOCUSES", "simulation_focus", "stable_plant", "warn_if_closed_loop"]

#: what the refinement fits the plant for (``refine_pem``'s ``focus``)
FOCUSES = ("prediction", "simulation")

#: ``fit(start, hold, free)``: the refinement of ``start`` with the input ``hold`` (None:
#: chosen) moving the parameters ``free`` (``"all"``, ``"plant"``, ``"noise"``)
Fit = Callable[[StateSpaceModel, "str | None", str], StateSpaceModel]


def simulation_focus(fit: Fit, model: StateSpaceModel, hold: str | None) -> StateSpaceModel:
    """The output-error plant from ``model``'s own plant, then ``K`` with that plant and
    its input hold held (module docstring).

    The plant fit starts from ``K = 0``, whose predictor (the simulation) is stable when
    the plant is; the noise fit starts from ``K = 0`` and from the Kalman gain of a
    measurement-noise model.  An unstable plant has no simulation to fit (it diverges
    from any initial state): it is refined with the prediction focus, with a
    ``RuntimeWarning``.

    Parameters
    ----------
    fit : callable
        ``fit(start, hold, free)``, the restricted refinement on the record.
    model : StateSpaceModel
        The start model.
    hold : {"zoh", "foh"} or None
        The input hold, or None to choose it by the simulation error.

    Returns
    -------
    StateSpaceModel
        The output-error plant with its fitted ``K``; the plant's covariance, eigenvalue
        standard deviations and :class:`~hdpbsid.models.report.Refinement` are the
        output-error fit's, ``K``, the noise covariance and ``options["refine_cost"]`` the
        noise fit's, ``options["refine_simulation_cost"]`` the output-error fit's costs;
        ``options["refine_focus"] == "simulation"``.  ``model`` itself when the output
        error was not lowered (the refinement's ``RuntimeWarning`` says so).
    """
    if not stable_plant(model):
        warnings.warn(
            "focus='simulation' needs a stable plant (the simulation of an unstable one "
            "diverges from any initial state); refining with focus='prediction'",
            RuntimeWarning,
            stacklevel=user_stacklevel(),
        )
        return fit(model, hold, "all")
    start = dataclasses.replace(model, K=np.zeros_like(model.K), options=dict(model.options))
    plant = fit(start, hold, "plant")
    if plant is start:  # kept, with the refinement's warning: the cost was not lowered
        return model
    with warnings.catch_warnings():  # a K that cannot beat K = 0 leaves K = 0 (below)
        warnings.simplefilter("ignore", RuntimeWarning)
        noise = fit(plant, plant.report.hold, "noise")
    if noise is plant:  # K = 0 already predicts as well as any K
        noise = dataclasses.replace(plant, options=dict(plant.options))
    out, noise_fit = plant.report.refinement, noise.report.refinement
    assert out is not None  # a refined model has its Refinement
    noise.parameter_covariance = plant.parameter_covariance
    noise.report = noise.report.but(refinement=out)
    noise.options.update(
        refine_focus="simulation",
        eigenvalue_std=out.eigenvalue_std,
        refine_converged=bool(out.converged and (noise_fit is None or noise_fit.converged)),
        refine_simulation_cost={"initial": out.cost[0], "final": out.cost[1]},
        eigenvalues_before_refine=model.eigenvalues,
        input_hold_before_refine=model.report.hold,
    )
    return noise


def stable_plant(model: StateSpaceModel) -> bool:
    """Whether ``model``'s plant has a simulation to fit: every eigenvalue of ``A`` in the
    open left half plane (a marginal mode's free response does not decay, and an
    unstable one's diverges from any initial state); a static model has.

    Parameters
    ----------
    model : StateSpaceModel
        The model.

    Returns
    -------
    bool
        Whether ``A`` is Hurwitz (True without states).
    """
    return model.n == 0 or bool(np.max(np.linalg.eigvals(model.A).real) < 0.0)


def warn_if_closed_loop(focus: str, stats: dict | None) -> bool:
    """Warn (``UserWarning``) when ``focus="simulation"`` meets a record the feedback
    test finds closed loop: there the output-error plant ignores the noise the loop
    feeds back through the input and is biased.

    Parameters
    ----------
    focus : str
        The refinement's focus (:data:`FOCUSES`).
    stats : dict or None
        The feedback test's statistics
        (:func:`hdpbsid.selection.feedback.feedback_statistics`; ``"feedback"`` is its
        verdict), None when it was not run.

    Returns
    -------
    bool
        Whether it warned.
    """
    if focus != "simulation" or not (stats or {}).get("feedback"):
        return False
    warnings.warn(
        "focus='simulation' on a record the feedback test finds closed loop: the "
        "output-error plant ignores the noise the loop feeds back through u and is "
        "biased; use the default focus='prediction' for closed-loop records",
        UserWarning,
        stacklevel=user_stacklevel(),
    )
    return True
