"""The held-out scores and the checks of the selection (:mod:`hdpbsid.selection.auto`).

Every candidate is scored by the better of its two predictors on the held-out part
(:func:`score_model`), ties of one order are broken by the simulation over the whole
held-out part (:func:`break_tie`), and a candidate or its refit is returned only past a
floor: it grows no mode the record does not need (:func:`instability_problem`,
:func:`refinement_instability`; a time series: :func:`stationarity_problem`), and its
refit on the whole record holds (:func:`refit_holds`).  :func:`beats_the_mean` (a model
predicts the held-out part better than its mean) is kept for the caller.  The reasoning
of each rule is in its docstring and in the module docstring of
:mod:`hdpbsid.selection.auto`.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from hdpbsid.data.checks import check_data, is_uniform
from hdpbsid.models.criteria import (
    WindowedError,
    choose_smallest_adequate,
    default_windows,
    windowed_prediction_error,
    windowed_simulation_error,
)
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.selection.policy import SELECTION_POLICY

if TYPE_CHECKING:  # the candidates are scored here; the type is for annotations only
    from hdpbsid.selection.candidates import CandidateRow

__all__ = [
    "score_model",
    "whole_held_out_error",
    "break_tie",
    "beats_the_mean",
    "refit_holds",
    "much_worse",
    "grows",
    "stationarity_problem",
    "instability_problem",
    "refinement_instability",
    "looks_closed_loop",
]


def score_model(model: StateSpaceModel, rec: tuple, windows: int) -> tuple[WindowedError, bool]:
    """The held-out score of ``model`` on the record ``rec = (t, u, y)`` (module
    docstring): the smaller of its windowed one-step prediction error with its gain
    ``K`` and with ``K = 0`` (the simulation error), and whether that is the one with
    ``K``.  Non-uniform samples: the simulation error.

    A time series (``u`` with no columns) is scored by the prediction error with ``K``
    only: with no input the simulated output is the free response of the initial state
    fitted to each window, a fit of ``n`` exponentials to the window, not a prediction
    (more states always fit more of it: on a stationary second-order process observed
    in noise it chose 4-8 states).  The one-step prediction error is the criterion of
    time-series models (Ljung, *System Identification*, 2nd ed., sec. 7.2), computed
    with one initial state for the whole held-out part (``carry_state``): fitted per
    window, the initial state of a slow predictor fits the window's own later outputs.
    A non-uniformly sampled time series has no such score here (``finite=False``).

    Parameters
    ----------
    model : StateSpaceModel
        The candidate, fitted on the estimation part.
    rec : tuple
        The held-out record ``(t, u, y)``.
    windows : int
        The number of scoring windows.

    Returns
    -------
    tuple of (WindowedError, bool)
        The score, and whether it is the one-step prediction error with ``K``.
    """
    t, u, y = check_data(*rec)
    if u.shape[1] == 0:
        if not is_uniform(t):
            return WindowedError(np.full(windows, np.inf), np.inf, -np.inf, False), True
        return windowed_prediction_error(model, t, u, y, windows, carry_state=True), True
    sim = windowed_simulation_error(model, t, u, y, windows)
    if not is_uniform(t):
        return sim, False
    pred = windowed_prediction_error(model, t, u, y, windows)
    if pred.finite and (not sim.finite or pred.total < sim.total):
        return pred, True
    return sim, False


def whole_held_out_error(model: StateSpaceModel, val: tuple) -> WindowedError:
    """The simulation error of ``model`` over the whole held-out record ``val`` from one
    fitted initial state (one window; :func:`break_tie`): the validation a user runs on
    it.  A time series has no simulation to run (:func:`score_model`): its one-step
    prediction over the whole held-out part from one initial state.

    Parameters
    ----------
    model : StateSpaceModel
        The candidate, fitted on the estimation part.
    val : tuple
        The held-out record ``(t, u, y)``.

    Returns
    -------
    WindowedError
        The error over one window, relative to the output variance.
    """
    t, u, y = check_data(*val)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if u.shape[1] == 0:
            return score_model(model, val, 1)[0]
        return windowed_simulation_error(model, t, u, y, 1)


def break_tie(tied: list[CandidateRow], val: tuple) -> list[CandidateRow]:
    """The candidates ``tied`` (one order, every one within one standard error of the
    best held-out error) ordered by their simulation error over the whole held-out
    record ``val`` from one fitted initial state (windows = 1), best first; each row
    gets ``whole_simulation`` (that error, relative).

    Why: the windowed criterion fits an initial state in every window, and a model's
    free response over a window can imitate any error that is slow compared with the
    window, so errors at time scales beyond a window (a wrong slow or unstable mode, a
    wrong static gain) are invisible to it; held-out windows must be short to give the
    several windows a standard error needs.  Among candidates that the windowed
    criterion cannot tell apart, the one-window simulation -- what a user validating
    on the held-out part computes (MATLAB ``compare``) -- sees those errors.  Only
    candidates of the chosen order compete (equal state dimension, so equal numbers of
    parameters: the one-standard-error rule's choice of complexity is unchanged), so
    the closed-loop bias of a simulation criterion (module docstring) can move the
    method, not the order.  Two methods whose windowed scores are a fraction of a standard
    error apart can differ severalfold in the one-window simulation error, and it is that
    error a user's validation reports.

    Parameters
    ----------
    tied : list of CandidateRow
        The candidates of one order (``model`` each); each gets ``whole_simulation``
        when there are two or more.
    val : tuple
        The held-out record ``(t, u, y)``.

    Returns
    -------
    list of CandidateRow
        ``tied``, best whole-simulation error first (as given when fewer than two).
    """
    if len(tied) < 2:
        return tied
    for r in tied:
        e = whole_held_out_error(r.model, val)
        r.whole_simulation = e.total if e.finite else np.inf
    return sorted(tied, key=lambda r: r.whole_simulation)


def beats_the_mean(model: StateSpaceModel, val: tuple) -> tuple[bool, str]:
    """Whether ``model`` predicts the whole held-out record ``val`` better than its mean:
    the better of its two predictors (:func:`score_model`) run over the whole held-out
    part from one fitted initial state (one window, the validation a user runs) has a
    relative error below 1, i.e. a fit above 0 %.

    A floor, not a ranking: a model that does worse than the mean of the data it is
    validated on is no model of them, whatever its windowed score.  The windowed
    criterion fits an initial state in every short window, which hides errors slower
    than a window (:func:`break_tie`), in particular a spurious fast-growing mode: within
    a window its free response can cancel the growth of the forced response, over the
    whole held-out part no initial state can (in floating point, a growth beyond
    ``1/eps``), and the simulation diverges: an over-sized order can win the windowed score
    with a spurious unstable pair and simulate the held-out part with an error beyond any
    scale.  An unstable plant in closed loop passes through its stable innovation
    predictor.

    Parameters
    ----------
    model : StateSpaceModel
        The candidate or its refit.
    val : tuple
        The held-out record ``(t, u, y)``.

    Returns
    -------
    tuple of (bool, str)
        Whether it does, and why not (``""`` when it does).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole, _ = score_model(model, val, 1)
    if whole.finite and whole.total < 1.0:
        return True, ""
    return False, (
        "over the whole held-out part (one initial state) it predicts worse than the mean "
        f"(relative error {whole.total:.3g})"
    )


def refit_holds(
    model: StateSpaceModel, held_out: WindowedError, val: tuple, windows: int
) -> tuple[bool, str]:
    """Whether ``model``, a candidate identified again on the whole record, is as good on
    the held-out part ``val`` as the candidate was, and why not.

    The refit has seen the held-out samples, so its error there (the same criterion,
    :func:`score_model`) is an in-sample error, and a correct refit of the same model
    structure scores no worse than the candidate did out of sample, up to the noise of
    the criterion.  More than one standard error of the candidate's held-out windows
    worse (the one-standard-error rule of :func:`~hdpbsid.models.criteria.choose_smallest_adequate`
    with the refit listed first) means the refit is not the model that was chosen: the
    method's data-driven settings (operator scale, past window, basis size, input hold)
    are chosen again on the whole record and can change with it.  Such a refit is not
    returned; the next candidate is tried, as when the refit raises.

    Parameters
    ----------
    model : StateSpaceModel
        The refit on the whole record.
    held_out : WindowedError
        The candidate's held-out score.
    val : tuple
        The held-out record ``(t, u, y)``.
    windows : int
        The number of scoring windows of ``held_out``.

    Returns
    -------
    tuple of (bool, str)
        Whether the refit holds, and why not (``""`` when it does).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        refit, _ = score_model(model, val, windows)
    if not refit.finite:
        return False, "the refit on the whole record cannot be simulated on the held-out part"
    k, stats = choose_smallest_adequate([refit, held_out])
    if k == 0:
        return True, ""
    return False, (
        f"the refit on the whole record scores {stats[0]:.1f} standard errors worse on the "
        f"held-out part than the candidate did without seeing it"
    )


def much_worse(returned: WindowedError, rejected: WindowedError) -> tuple[bool, float]:
    """Whether the held-out score ``returned`` of the model returned is much worse than
    the score ``rejected`` of a candidate a check rejected, and the ratio of their
    held-out errors.

    Much worse: the returned model leaves more than
    :attr:`~hdpbsid.selection.policy.SelectionPolicy.much_worse_ratio` (2) times the
    held-out residual energy of the rejected one.  Why 2: beyond it the held-out
    data resolve the difference whatever the spread of their windows.  The standard
    error of the one-standard-error rule (:func:`~hdpbsid.models.criteria.choose_smallest_adequate`)
    is ``sqrt(W) std(r_w)`` of the better model's window errors ``r_w >= 0``, at most
    their sum ``T`` (equality when one window holds all of it), so a total above ``2 T``
    is more than one standard error worse on any record; a smaller ratio can be within
    the spread of the windows, a difference the record does not show.

    Parameters
    ----------
    returned : WindowedError
        The held-out score of the model returned.
    rejected : WindowedError
        The held-out score of the rejected candidate.

    Returns
    -------
    tuple of (bool, float)
        Whether ``returned`` is much worse, and the ratio of the held-out errors (``inf``
        when ``returned`` is not finite or ``rejected`` has no finite positive error).
    """
    if not rejected.finite or rejected.total <= 0.0:
        return False, np.inf
    ratio = returned.total / rejected.total if returned.finite else np.inf
    return bool(ratio > SELECTION_POLICY.much_worse_ratio), ratio


def grows(model: StateSpaceModel) -> bool:
    """Whether ``model`` has a growing mode: an eigenvalue of ``A`` with ``Re > 0``
    (compared with 0 exactly; a mode at ``Re = +1e-12`` is one, and is judged as one).

    Parameters
    ----------
    model : StateSpaceModel
        The model.

    Returns
    -------
    bool
        Whether ``A`` has an eigenvalue with a positive real part.
    """
    return model.n > 0 and bool(np.any(np.linalg.eigvals(model.A).real > 0.0))


def _worst_eigenvalue(model: StateSpaceModel) -> complex:
    lam = np.linalg.eigvals(model.A)
    return complex(lam[int(np.argmax(lam.real))])


def stationarity_problem(model: StateSpaceModel) -> str:
    """Why ``model``, a model of a time series (no input), cannot describe a stationary
    process, or ``""``.

    The output of ``dx/dt = A x + K e``, ``y = C x + e`` driven by white ``e`` is
    stationary only when every mode that ``e`` excites decays, i.e. when ``A`` is stable
    (``Re lambda < 0`` for every eigenvalue of a minimal model; an eigenvalue at 0 is a
    random walk, whose variance grows with time).  A time series is identified as a
    stationary process -- its held-out one-step prediction error judges a spectrum, the
    same for a stable and a mirrored unstable pole -- so a model with an unstable ``A``
    describes a process the record, bounded and stationary, is not.  Such a model is not
    a candidate (:func:`select_model`); a non-stationary record (a trend, a random walk)
    should be differenced or detrended first.

    Parameters
    ----------
    model : StateSpaceModel
        The model (a model with inputs, or of order 0, has no problem here).

    Returns
    -------
    str
        The reason, naming the eigenvalues with ``Re >= 0``, or ``""``.
    """
    if model.m > 0 or model.n == 0:
        return ""
    lam = np.linalg.eigvals(model.A)
    bad = lam[~(lam.real < 0.0)]
    if bad.size == 0:
        return ""
    shown = ", ".join(f"{z:.3g}" for z in bad[:4])
    return (
        f"not stationary: A has eigenvalue(s) {shown} with Re >= 0, but a time series "
        f"(no input) is modelled as a stationary process, which needs a stable A"
    )


def instability_problem(row: CandidateRow, pool: Sequence[CandidateRow]) -> str:
    """Why the held-out record does not support the growth of candidate ``row``, or
    ``""`` (a stable candidate, or a growth the record supports).  ``pool``: the
    candidates the one-standard-error rule admits (with ``model``, ``order`` and
    held-out ``criterion``; :func:`select_model` passes those within one standard error
    of the best).

    The rule: an unstable candidate is rejected when a *stable* candidate of no larger
    order, itself admitted, predicts the held-out part as well -- within one standard
    error of it by the held-out score that ranks the candidates (:func:`score_model`;
    :func:`~hdpbsid.models.criteria.choose_smallest_adequate` with the stable one listed first,
    so the burden of proof is on the growth).  Then the record does not need the growth:
    a stable model, no more complex and as good by the selection's own rule, explains
    what it shows, and it is the one chosen instead.  A stable rival the rule does not
    admit is no rival: rejecting the growth for it would hand the choice to a larger
    candidate, not to it.  A time series (no input)
    is modelled as a stationary process: :func:`stationarity_problem`.

    Why not judge the unstable candidate alone.  A bounded record of an unstable plant
    is only possible inside a feedback loop, where the input holds the growth back; the
    feedback test (:func:`looks_closed_loop`) sees the loop only in the part of the output
    the controller reacts to that the model cannot predict, and a loop driven by its
    reference with little noise leaves none.  Without it, no test of
    one model separates a true unstable plant from a spurious growing mode: over a
    horizon ``T`` any error of the state estimated from the past grows as
    ``e^(sigma T)``, so a free run from the state fitted on the record's start diverges
    for the true plant too (a rule built on it rejects every candidate of a plant in such a
    loop); and with the
    initial state fitted on the judged horizon itself, the later inputs cancel any
    growth up to ``1/eps``, so it passes a spurious mode too.  A comparison with the stable
    alternatives needs neither: it asks what the held-out data prefer, at the resolution
    of the held-out data, as the order is chosen (Hastie, Tibshirani & Friedman, *The
    Elements of Statistical Learning*, 2nd ed., sec. 7.10).  A growing mode that the data
    cannot tell from a stable model is not supported; one that every stable candidate of
    its size predicts worse than, beyond the spread of the held-out windows, is.  Larger
    stable candidates are not rivals: the order is chosen first, by the same rule, and
    stability is not bought with states the data do not ask for.

    Parameters
    ----------
    row : CandidateRow
        The candidate: ``model``, ``order``, ``criterion``.
    pool : sequence of CandidateRow
        The admitted candidates, its possible stable rivals.

    Returns
    -------
    str
        The reason, naming the eigenvalue and the stable rival, or ``""``.
    """
    model = row.model
    if model.m == 0:
        return stationarity_problem(model)
    if not grows(model):
        return ""
    err = row.criterion
    for r in pool:
        c = r.criterion
        if r is row or c is None or not c.finite or r.order > row.order:
            continue
        if grows(r.model) or c.per_window.size != err.per_window.size:
            continue
        k, stats = choose_smallest_adequate([c, err])
        if k == 0:
            return (
                f"unstable (eigenvalue {_worst_eigenvalue(model):.3g}) where the record does "
                f"not need the growth: the stable {r.method} order {r.order} predicts "
                f"the held-out part at least as well by the one-standard-error rule (the two "
                f"differ by {abs(stats[0] - stats[1]):.2g} standard errors)"
            )
    return ""


def refinement_instability(start: StateSpaceModel, refined: StateSpaceModel, rec: tuple) -> str:
    """Why the refinement ``refined`` of ``start`` on the record ``rec = (t, u, y)``
    grew a mode the record does not support, or ``""``.

    The prediction-error refinement judges the predictor ``A - K C``, stable either way,
    so by itself it does not keep ``A`` stable.  A refinement that makes a stable
    ``start`` unstable is kept only when the record asks for the growth, by the rule of
    :func:`instability_problem` with ``start`` as the stable rival of equal order: the
    windowed simulation error on the record
    (:func:`~hdpbsid.models.criteria.windowed_simulation_error`, the deterministic
    response whose growth is in question; the refinement did not fit it) of the refined
    model must beat the start's by more than one standard error.  A
    time series' refined model must be stationary (:func:`stationarity_problem`).

    Parameters
    ----------
    start : StateSpaceModel
        The model the refinement started from.
    refined : StateSpaceModel
        The refined model.
    rec : tuple
        The record ``(t, u, y)`` the refinement ran on.

    Returns
    -------
    str
        The reason, or ``""`` (also when the simulations cannot be computed).
    """
    if not grows(refined) or grows(start):
        return ""
    if refined.m == 0:
        return stationarity_problem(refined)
    t, u, y = check_data(*rec)
    windows = max(1, default_windows(t.size, refined.n))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            e_ref = windowed_simulation_error(refined, t, u, y, windows)
            e_start = windowed_simulation_error(start, t, u, y, windows)
        except (ValueError, np.linalg.LinAlgError):
            return ""
    why = f"unstable (eigenvalue {_worst_eigenvalue(refined):.3g}) where the start was stable"
    if not e_ref.finite:
        return why + ", and its simulation of the record overflows"
    if e_start.finite and choose_smallest_adequate([e_start, e_ref])[0] == 0:
        return (
            why + ": the stable start simulates the record as well (within one standard "
            "error), so the record does not need the growth"
        )
    return ""


def looks_closed_loop(model: StateSpaceModel, rec: tuple) -> bool:
    """Whether the feedback test (:func:`hdpbsid.selection.feedback.feedback_statistics`: the
    one-step prediction errors of ``model`` on ``rec = (t, u, y)`` correlated with the
    prewhitened input at positive lags) declares the record closed loop; False when it
    cannot be computed (the predictor diverges on the record).

    Parameters
    ----------
    model : StateSpaceModel
        The candidate whose one-step prediction errors are tested.
    rec : tuple
        The record ``(t, u, y)``.

    Returns
    -------
    bool
        Whether the test declares feedback.
    """
    from hdpbsid.refine.pem import one_step_errors
    from hdpbsid.selection.feedback import feedback_statistics

    t, u, y = rec
    try:
        with warnings.catch_warnings(), np.errstate(over="ignore", invalid="ignore"):
            warnings.simplefilter("ignore")
            errors = one_step_errors(model, t, u, y)
            return bool(feedback_statistics(model, t, u, y, errors=errors)["feedback"])
    except (ValueError, np.linalg.LinAlgError):
        return False
