"""The refinement's focus chosen from the record (:func:`hdpbsid.identify`'s
``focus="auto"``, the default).

The prediction-error refinement fits the plant and the noise model together
(``focus="prediction"``): maximum likelihood, and consistent in closed loop, when the
disturbance has the innovation form the model assumes.  Its noise model is tied to the
plant (``K`` enters through the same ``A``, ``C``), so when the disturbance has another
form -- coloured by dynamics of its own, or the record carries a nonlinear distortion --
the plant bends to serve the one-step prediction.  The output-error plant
(``focus="simulation"``, :mod:`hdpbsid.refine.pem_focus`) is consistent in open loop
whatever the disturbance (Ljung, *System Identification*, 2nd ed., 1999, sec. 8.5) and
is the best linear approximation of a process with a nonlinear distortion (Pintelon &
Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed., 2012, ch. 3);
it is less efficient when the innovation form holds, and biased in closed loop.

Rule (:func:`choose_focus`), after the prediction-error refinement:

1. A record the feedback test finds closed loop keeps the prediction focus (the
   output-error plant is biased there); so does a record the output-error fit does not
   apply to (no input, non-uniform samples, a plant that is not stable: its simulation
   diverges from any initial state).
2. When the refined model's windowed simulation error is within ``z`` standard errors of
   its windowed one-step prediction error (the one-standard-error rule,
   :func:`~hdpbsid.models.criteria.choose_smallest_adequate`), its noise model predicts
   nothing the simulation does not: the prediction criterion is the simulation
   criterion at the resolution of the record, and the output-error fit would return the
   same plant.  No further fit.
3. Otherwise the output-error plant is fitted (the refined model's input hold kept) from
   whichever of the refined model's plant and, when given, the plant the
   prediction-error refinement started from simulates the record better: the
   output-error cost has local minima of its own (Ljung, sec. 10.5), and the
   prediction-error plant sits where the noise model pulled it, not necessarily in the
   basin of the output-error cost's minimum nearest the data.  The
   output-error plant replaces the refined model only when its windowed simulation error,
   multiplied by Akaike's final-prediction-error factor ``(1 + d/N) / (1 - d/N)`` (``d``
   the plant's identifiable parameters ``n (m + l)`` plus the direct term's, ``N`` the
   samples), is below the prediction plant's by more than ``z`` standard errors of its
   window errors, the prediction plant listed first.  This is a specification test in
   the spirit of Hausman (Econometrica 46, 1978): under the innovation form both plants
   estimate the same system, the efficient one (prediction) is kept, and their
   simulations differ within the spread of the windows; a difference the record
   resolves says the innovation form does not hold and the prediction plant is biased.
   The factor removes the output-error fit's advantage of minimising this very
   criterion on the record it is scored on (Akaike, Ann. Inst. Stat. Math. 21, 1969):
   with many parameters on a short record that optimism reaches a standard error of the
   window errors.  The prediction plant did not minimise this criterion and is not
   corrected, so the test errs towards the efficient estimate.

The windows are those of the held-out selection (:func:`~hdpbsid.models.criteria.default_windows`),
each with its initial state fitted: a slow drift of the operating point between windows
does not decide.
"""

from __future__ import annotations

import dataclasses
import enum
import warnings
from typing import Any

import numpy as np

from hdpbsid.data.checks import check_time, is_uniform
from hdpbsid.models.criteria import (
    WindowedError,
    choose_smallest_adequate,
    default_windows,
    windowed_prediction_error,
    windowed_simulation_error,
)
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import Choice
from hdpbsid.refine.pem_focus import stable_plant

__all__ = ["FocusRule", "choose_focus", "given"]


class FocusRule(str, enum.Enum):
    """Which way :func:`choose_focus` took (the typed counterpart of its reason)."""

    #: the user's ``focus=``
    GIVEN = "given"
    #: the feedback test found the record closed loop
    CLOSED_LOOP = "closed loop"
    #: no input, non-uniform samples or a plant not stable: no output-error fit applies
    NOT_APPLICABLE = "not applicable"
    #: the noise model predicts nothing the simulation does not (rule 2)
    NOISE_MODEL_IDLE = "noise model idle"
    #: the output-error plant did not simulate the record better by a standard error
    PREDICTION_HOLDS = "prediction holds"
    #: the output-error plant simulates the record better by more than a standard error
    SIMULATION_BETTER = "simulation better"


def choose_focus(
    model: StateSpaceModel,
    t: Any,
    u: Any,
    y: Any,
    feedback: bool,
    start: StateSpaceModel | None = None,
) -> tuple[StateSpaceModel, Choice[str]]:
    """The model the focus rule returns (module docstring) and its choice.

    Parameters
    ----------
    model : StateSpaceModel
        The prediction-error refinement on the record.
    t, u, y : array_like
        The record it was refined on.
    feedback : bool
        The feedback test's verdict on the record
        (:func:`hdpbsid.selection.feedback.feedback_statistics`).
    start : StateSpaceModel, optional
        The model the prediction-error refinement started from: a second start of the
        output-error fit (rule 3 of the module docstring).

    Returns
    -------
    StateSpaceModel
        ``model``, or the output-error plant fitted from it with its noise model
        (:func:`~hdpbsid.refine.pem.refine_pem` with ``focus="simulation"``); the choice
        written to its ``report.focus`` and ``options["refine_focus"]``,
        ``options["focus_rule"]``.
    Choice of str
        ``"prediction"`` or ``"simulation"`` with the reason; ``rule`` a
        :class:`FocusRule`.
    """
    out, choice = _choose(model, t, u, y, feedback, start)
    out.report = out.report.but(focus=choice)
    out.options.update(refine_focus=choice.value, focus_rule=choice.reason)
    return out, choice


def _choose(
    model: StateSpaceModel, t: Any, u: Any, y: Any, feedback: bool, start: Any
) -> tuple[StateSpaceModel, Choice[str]]:
    """:func:`choose_focus` before the choice is written to the model."""
    t = np.asarray(t, dtype=float)
    u = None if u is None else np.asarray(u, dtype=float).reshape(t.size, -1)
    if feedback:
        return model, _prediction(FocusRule.CLOSED_LOOP, "the feedback test found feedback")
    if u is None or u.shape[1] == 0 or model.n == 0 or not is_uniform(check_time(t, "t")):
        return model, _prediction(FocusRule.NOT_APPLICABLE, "no input or non-uniform samples")
    if not stable_plant(model):
        return model, _prediction(FocusRule.NOT_APPLICABLE, "the plant is not stable")
    y = np.asarray(y, dtype=float).reshape(t.size, -1)
    windows = default_windows(t.size, model.n)
    simulated = windowed_simulation_error(model, t, u, y, windows)
    predicted = windowed_prediction_error(model, t, u, y, windows)
    chosen, z = choose_smallest_adequate([simulated, predicted])
    if chosen == 0:
        return model, _prediction(
            FocusRule.NOISE_MODEL_IDLE,
            f"its simulation error is within {z[0]:.2g} SE of its prediction error",
        )
    return _output_error_or(model, (t, u, y), windows, simulated, start)


def _output_error_fit(
    model: StateSpaceModel, rec: tuple, windows: int, simulated: WindowedError, start: Any
) -> tuple[StateSpaceModel, WindowedError] | None:
    """The output-error fit from whichever of ``model`` (windowed simulation error
    ``simulated``) and ``start`` simulates the record better, with its windowed
    simulation error; None unless it converged to a stable plant."""
    from hdpbsid.refine.pem import refine_pem

    starts = [(model, simulated)]
    if start is not None and stable_plant(start):
        starts.append((start, windowed_simulation_error(start, *rec, windows)))
    s = min(starts, key=lambda c: c[1].total)[0]
    with warnings.catch_warnings():  # a fit that does not lower the cost returns s
        warnings.simplefilter("ignore", RuntimeWarning)
        oe = refine_pem(s, *rec, hold=model.report.hold, focus="simulation")
    if oe is s or not oe.report.converged or not stable_plant(oe):
        return None
    return oe, windowed_simulation_error(oe, *rec, windows)


def _output_error_or(
    model: StateSpaceModel, rec: tuple, windows: int, simulated: WindowedError, start: Any
) -> tuple[StateSpaceModel, Choice[str]]:
    """Rule 3 of the module docstring: the output-error plant (from ``model``'s or
    ``start``'s) when it simulates the record better by more than ``z`` standard errors
    after its optimism is removed, else ``model``."""
    fit = _output_error_fit(model, rec, windows, simulated, start)
    if fit is None:
        why = "the output-error fit did not converge to a stable plant"
        return model, _prediction(FocusRule.PREDICTION_HOLDS, why)
    oe, output_error = fit
    chosen, z = choose_smallest_adequate([simulated, _out_of_sample(output_error, oe, rec)])
    text = (
        f"the prediction plant's simulation error is {z[0]:.3g} SE above the "
        f"output-error plant's ({windows} windows, the latter times its final-prediction-"
        f"error factor)"
    )
    if chosen == 0:
        return model, _prediction(FocusRule.PREDICTION_HOLDS, text)
    return oe, Choice("simulation", text, FocusRule.SIMULATION_BETTER)


def _out_of_sample(err: WindowedError, oe: StateSpaceModel, rec: tuple) -> WindowedError:
    """``err`` of the output-error plant ``oe`` times Akaike's final-prediction-error
    factor (rule 3 of the module docstring)."""
    m, l = oe.B.shape[1], oe.C.shape[0]
    d = oe.n * (m + l) + (m * l if np.any(oe.D) else 0)
    ns = np.size(rec[0])
    factor = (1.0 + d / ns) / (1.0 - d / ns) if d < ns else np.inf
    total = err.total * factor
    return dataclasses.replace(
        err, per_window=err.per_window * factor, total=total, fit=100.0 * (1.0 - np.sqrt(total))
    )


def _prediction(rule: FocusRule, why: str) -> Choice[str]:
    return Choice("prediction", f"{rule.value}: {why}", rule)


def given(focus: str) -> Choice[str]:
    """The choice of a ``focus`` the user gave.

    Parameters
    ----------
    focus : str
        The focus asked for.

    Returns
    -------
    Choice of str
        ``Choice(focus, "given", FocusRule.GIVEN)``.
    """
    return Choice(focus, "given", FocusRule.GIVEN)
