"""The refinement started again from another candidate (:func:`restarted`) when its
result has a mode the record carries no evidence of.

The prediction-error cost of a state-space model of fixed order has local minima, and
which one the refinement ends in depends on where it starts.  The selection starts it
from the candidate the held-out part ranked first (:mod:`hdpbsid.selection.auto`), a
subspace estimate; in closed loop that estimate is biased, and it can lie in the basin of
a minimum that spends a state on a mode no part of the record supports -- a lightly
damped pair near the Nyquist frequency, or a real mode far beyond the input's band,
while a mode of the plant is lost.  Such a minimum shows: the input drives the spurious
mode, in every output, less than the noise (:func:`~hdpbsid.selection.drift.
undriven_modes`).  When the refined model of a record the feedback test declares closed
loop has one, the refinement of the same structure runs again from the next candidate of
the same order in the held-out ranking (:func:`same_order_starts`), and the model with
the larger likelihood on the record is kept (:func:`restart_search`).  The two have the
same order, the same parameters and the same data, so their likelihoods compare
directly, with no price for complexity (the maximum-likelihood estimate is the global
minimum of the cost; Ljung, *System Identification*, 2nd ed., 1999, secs. 7.4 and
10.5, on multiple starts of the prediction-error search).

One restart, the next-best answer the selection has (as the drift step tries the next
smaller order): each costs a refinement, and a model of too large an order has modes
the input does not drive whatever its start, so more restarts would multiply the time
of exactly the fits they cannot mend.  Only the symptom triggers it, so a record whose
refined model has every mode driven pays nothing.  It runs in the final refinement on
the whole record when the order was given.  With the order chosen, the final refinement
is offered the chosen candidate's refinement on the estimation part as a warm start
where the order decision refined it.  Restarting also the refinements the order decision
compares would let a larger order show a mode its own start hid, but every order above
the plant's would pay for restarts it cannot use, each the time of a fit.

In open loop the subspace candidates are consistent and a mode the input does not drive
is the noise model's (a coloured disturbance the innovation model spends a state on):
no restart.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.report import Choice, WarmStart
from hdpbsid.selection.candidates import CandidateRow
from hdpbsid.selection.drift import undriven_modes
from hdpbsid.selection.feedthrough import with_d
from hdpbsid.selection.iterate import _likelihood_cost

__all__ = ["same_order_starts", "restarted", "restart_search"]

#: the name of a restart among the refinement's starting points
RESTART_NAME = "the {method} candidate of the same order"


def same_order_starts(ok: Sequence[CandidateRow], model: StateSpaceModel) -> tuple[WarmStart, ...]:
    """The best scored candidate of ``model``'s order of every method and structure (with
    ``D`` asked for or not) but ``model``'s own, as starting points of a refinement of
    ``model``'s structure, the best held-out error first (its model refined on the
    estimation part when it was).  A start without ``D`` starts a free ``D`` at zero; a
    start's ``D`` where the structure has none is fixed at zero by the refinement.

    Parameters
    ----------
    ok : sequence of CandidateRow
        The scored candidates of the selection.
    model : StateSpaceModel
        The model the selection returns.

    Returns
    -------
    tuple of WarmStart
        One per other method and structure with a candidate of that order.

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> from hdpbsid.models.report import DirectTerm
    >>> from hdpbsid.models.criteria import WindowedError
    >>> def row(method, a, err):
    ...     r = CandidateRow(method, 1)
    ...     r.model = StateSpaceModel([[a]], [[1.0]], [[1.0]], [[0.0]], [[0.0]])
    ...     r.model.report = r.model.report.but(method=method, feedthrough=DirectTerm(False, False))
    ...     r.criterion = WindowedError(np.array([err]), err, 1.0, True)
    ...     return r
    >>> ok = [row("dt", -1.0, 0.1), row("hermite", -2.0, 0.2), row("hermite", -3.0, 0.1)]
    >>> [float(s.A[0, 0]) for s in same_order_starts(ok, ok[0].model)]
    [-3.0]
    """
    rows = _same_order_rows(ok, model.n, model.report.method, _asked(model))
    return tuple(_as_start(r) for r in rows)


def _same_order_rows(
    ok: Sequence[CandidateRow], order: int, method: str | None, asked: bool
) -> list[CandidateRow]:
    """The best scored candidate of every method and structure (``D`` asked for or not)
    among ``ok`` of order ``order`` but ``method`` with structure ``asked`` (the model's
    own), best held-out error first (:func:`same_order_starts`)."""
    best: dict[tuple[str, bool], CandidateRow] = {}
    for r in ok:
        key = (r.method, _structure(r))
        if r.order != order or key == (method, asked):
            continue
        if r.criterion is None or not r.criterion.finite:
            continue
        if key not in best or r.criterion.total < best[key].criterion.total:
            best[key] = r
    return sorted(best.values(), key=lambda r: r.criterion.total)


def _asked(model: StateSpaceModel) -> bool:
    """Whether ``D`` is a parameter of ``model``'s refinement (asked for): the
    refinement's own test (:func:`hdpbsid.refine.pem._fits_feedthrough`)."""
    from hdpbsid.refine.pem import _fits_feedthrough

    return _fits_feedthrough(model)


def _structure(row: CandidateRow) -> bool:
    """Whether candidate ``row`` is of the structure with ``D``: judged as one
    (:func:`~hdpbsid.selection.feedthrough.with_d`) or fitted with ``D`` asked for (the
    user's ``feedthrough=True``)."""
    return with_d(row) or _asked(row.model)


def _as_start(row: CandidateRow) -> WarmStart:
    """Candidate ``row``'s model (refined on the estimation part when it was) as a start."""
    model = row.model if row.refined_model is None else row.refined_model
    return WarmStart.of(model, model.report.hold, RESTART_NAME.format(method=row.method))


def restarted(
    start: StateSpaceModel, refined: StateSpaceModel, t: Any, u: Any, y: Any, closed: bool
) -> tuple[StateSpaceModel, str]:
    """``refined`` (the prediction-error refinement of ``start`` on the record ``t, u,
    y``), or a refinement from one of ``start.report.restarts`` with a larger likelihood
    (module docstring), and the note for the refinement's rule.

    Only on a record the feedback test declares closed loop (``closed``), when
    ``refined`` has a mode the input drives less than the noise in every output
    (:func:`~hdpbsid.selection.drift.undriven_modes`): :func:`restart_search` from the
    first of the restarts (module docstring).

    Parameters
    ----------
    start : StateSpaceModel
        The model the refinement started from, offering the restarts
        (``report.restarts``, :func:`same_order_starts`).
    refined : StateSpaceModel
        Its refinement (:func:`hdpbsid.refine.pem.refine_pem`).
    t, u, y : array_like
        The record (the front end's detrended signals).
    closed : bool
        Whether the feedback test declares the record closed loop.

    Returns
    -------
    tuple of (StateSpaceModel, str)
        The refined model kept and what the rule adds (``""`` when ``refined``).

    Examples
    --------
    A refined model whose modes the input all drives is kept without a restart:

    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> m = StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]])
    >>> t = np.arange(0.0, 50.0, 0.05)
    >>> u = np.sign(np.sin(t))[:, None]
    >>> y = m.simulate(t, u) + 0.01 * np.random.default_rng(0).standard_normal((t.size, 1))
    >>> kept, note = restarted(m, m, t, u, y, closed=True)
    >>> kept is m, note
    (True, '')
    """
    if not (closed and start.report.restarts) or refined.report.refinement is None:
        return refined, ""
    undriven = _count_undriven(refined, (t, u, y))
    if undriven == 0:
        return refined, ""
    kept, name, gain = restart_search(start, refined, (t, u, y), start.report.restarts)
    if name is None:
        return refined, ""
    return kept, (
        f"; the refined model had {undriven} mode(s) the input drives less than the "
        f"noise (closed loop): refined again from {name}, whose likelihood on the record "
        f"is higher by {gain:.0f} units (-2 log ratio, same order and structure)"
    )


def restart_search(
    start: StateSpaceModel, refined: StateSpaceModel, rec: tuple, starts: Sequence[WarmStart]
) -> tuple[StateSpaceModel, str | None, float]:
    """The refinement of ``start``'s structure on ``rec`` from the first of ``starts`` (a
    fit its evaluation budget cut off goes on once from where it stopped), when it is
    likelier than ``refined``: the model kept, the name of the start it came from (None:
    ``refined``) and its gain in ``-2 log`` likelihood units (module docstring: one
    restart).

    Parameters
    ----------
    start : StateSpaceModel
        The model whose structure, options and report the refinements take.
    refined : StateSpaceModel
        Its refinement on ``rec``.
    rec : tuple
        The record ``(t, u, y)``.
    starts : sequence of WarmStart
        The starting points, the next-best first (only that one is tried).

    Returns
    -------
    tuple of (StateSpaceModel, str or None, float)
        The model kept, the start's name and the likelihood gain.

    Examples
    --------
    With no starts the refined model stands:

    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> m = StateSpaceModel([[-1.0]], [[1.0]], [[1.0]], [[0.0]], [[0.0]])
    >>> t = np.arange(0.0, 20.0, 0.05)
    >>> u = np.sign(np.sin(t))[:, None]
    >>> restart_search(m, m, (t, u, m.simulate(t, u)), ())[1:]
    (None, 0.0)
    """
    first = _likelihood_cost(refined, *rec)
    for ws in starts[:1]:
        again = _refined_from(start, ws, rec)
        cost = np.inf if again is None else _likelihood_cost(again, *rec)
        if cost < first:
            return again, ws.name, first - cost
    return refined, None, 0.0


def _count_undriven(model: StateSpaceModel, rec: tuple) -> int:
    """The number of :func:`~hdpbsid.selection.drift.undriven_modes` (0 if not judged)."""
    mask = undriven_modes(model, rec)
    return 0 if mask is None else int(np.sum(mask))


def _refined_from(start: StateSpaceModel, ws: WarmStart, rec: tuple) -> StateSpaceModel | None:
    """The prediction-error refinement of ``start``'s structure on ``rec`` from the
    restart ``ws`` (its hold fitted first, both fitted: a start in the basin of a wrong
    hold's minimum is what the restart is for), once more from its end point when the
    evaluation budget cut it off; None when it fails."""
    from hdpbsid.refine.pem import refine_pem

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            again = refine_pem(_from(start, ws), *rec)
            if not again.report.converged:  # cut off on its way: go on from there
                again = refine_pem(again, *rec)
        except (ValueError, np.linalg.LinAlgError):
            return None
    return again


def _from(start: StateSpaceModel, ws: WarmStart) -> StateSpaceModel:
    """``start`` with the matrices and input hold of ``ws`` (the structure, options and
    report otherwise ``start``'s), offering no further starts."""
    report = start.report.but(warm_start=None, restarts=())
    if ws.input_hold is not None:
        report = report.but(input_hold=Choice(ws.input_hold, "the restart's own hold"))
    mats = {k: np.asarray(getattr(ws, k), dtype=float) for k in "ABCDK"}
    return dataclasses.replace(start, **mats, options=dict(start.options), report=report)
