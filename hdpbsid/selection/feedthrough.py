"""``feedthrough="auto"``: whether the model has a direct term ``D``, decided from the data.

The direct term is a structural choice like the order, and it is judged the same way
(:mod:`hdpbsid.selection.auto`): candidates with ``D = 0`` and with ``D`` estimated are
fitted on the estimation part and scored on the held-out part by the selection's own
criterion (the windowed one-step prediction error, :func:`~hdpbsid.selection.auto.
score_model`); they are ranked by order first and, within an order, without ``D`` before
with ``D`` (:func:`structure_key`), and the one-standard-error rule
(:func:`~hdpbsid.models.criteria.choose_smallest_adequate`) takes the first candidate
within one standard error of the best.  So ``D`` is estimated only when a candidate
with it predicts the held-out part better than every candidate without it of its order,
by more than one standard error: no new threshold, and the burden of proof is on the
extra parameters, as it is on an extra state.

Closed loop.  With a controller that reacts to ``y_k`` within the sample, ``u_k``
depends on the innovation ``e_k``, and a free ``D`` lets ``D u_k`` predict ``e_k``
through the controller: the direct term is then not identifiable from ``u`` and ``y``,
and the prediction-error minimum is not the system (Ljung, *System Identification*,
2nd ed., sec. 13.4: the direct approach needs a delay in the loop; Forssell & Ljung,
"Closed-loop identification revisited", Automatica 35(7), 1999).  Whether the loop has
that delay cannot be read from the data: the correlation of ``u_k`` with ``e_k`` at lag
0 is the same for a controller that reacts within the sample and for a direct term.  So
the candidates with ``D`` are offered only when the feedback test
(:func:`hdpbsid.selection.feedback.feedback_statistics`, the residuals of a strictly
causal ARX predictor against the prewhitened input at lags ``1..M``) finds no loop
(:func:`feedthrough_offered`); in open loop ``u`` does not depend on the noise and
``D`` is identifiable.  In a loop with at least one sample of delay (a digital controller
that computes ``u_k`` from ``y_{k-1}``) the user says so with ``feedthrough=True``.  The
test is valid whether or not the record has a direct term: the predictor's errors then
contain ``D u_k``, which depends on ``u_j, j <= k`` only, and the test looks at positive
lags.
Where the test cannot be computed (non-uniform samples, no input, a diverging
predictor) no ``D`` is offered.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from hdpbsid.data.checks import is_uniform
from hdpbsid.models.model import StateSpaceModel

__all__ = [
    "FEEDTHROUGH_CHOICES",
    "check_feedthrough",
    "honours_feedthrough",
    "feedthrough_offered",
    "structure_key",
    "with_d",
    "arx_residuals",
    "takes_feedthrough",
]

#: the values of ``feedthrough=``: estimate ``D``, keep ``D = 0``, or decide from the data
FEEDTHROUGH_CHOICES = (True, False, "auto")


def check_feedthrough(value: Any) -> bool | str:
    """``value`` as one of :data:`FEEDTHROUGH_CHOICES` (``numpy.bool_`` accepted).

    Raises
    ------
    ValueError
        When ``value`` is none of them.
    """
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, str) and value == "auto":
        return "auto"
    raise ValueError(f"feedthrough must be True, False or 'auto', got {value!r}")


def honours_feedthrough(model: StateSpaceModel) -> bool:
    """Whether the method that fitted ``model`` takes ``feedthrough=`` as the choice of
    ``D``: it reports the boolean ``feedthrough`` option (the PBSID core does), typed in
    ``model.report.feedthrough``.  A method that estimates ``D`` as part of its own
    algebra whatever it is asked (the Laguerre-domain ``D_d``, reported as a text:
    ``by_method``) has no candidate with ``D`` to add."""
    fd = model.report.feedthrough
    return fd is not None and not fd.by_method and model.m > 0


def takes_feedthrough(method: str) -> bool:
    """Whether the registered method ``method`` is a built-in one of the library
    (:data:`~hdpbsid.methods.registry.LAZY_METHODS`, not replaced by the user), whose
    ``feedthrough=`` setting is known.  A user's own method is never called with a
    setting it did not ask for: ``feedthrough="auto"`` keeps ``D = 0`` for it."""
    from hdpbsid.methods.registry import LAZY_METHODS, get_method

    func = get_method(method)
    return any(
        getattr(func, "__module__", None) == mod and getattr(func, "__name__", None) == name
        for mod, name in LAZY_METHODS.get(method, ())
    )


def with_d(row: dict[str, Any]) -> bool:
    """Whether the selection candidate ``row`` was fitted with ``D`` asked for by the
    judgement (its ``settings``)."""
    return bool(row.get("settings", {}).get("feedthrough", False))


def structure_key(row: dict[str, Any]) -> tuple[int, bool, float]:
    """The ranking of scored candidates for the one-standard-error rule: order first,
    then without ``D`` before with ``D`` (module docstring), then held-out error."""
    return (row["order"], with_d(row), row["criterion"].total)


def arx_residuals(u: Any, y: Any, lags: int) -> Any:
    """Residuals ``(Ns, l)`` of the least-squares ARX predictor of ``y_k`` from ``y`` and
    ``u`` at lags ``1..lags`` (no ``u_k``: strictly causal, no direct term); the first
    ``lags`` rows are zero.  A causal predictor's errors depend on ``u_j, j <= k`` and
    the noise only, which is all the feedback test needs in open loop, and they do not
    depend on any candidate model being sound (a candidate without ``D`` fitted to a
    loop that reacts within the sample can diverge, and its errors then test nothing)."""
    ns = u.shape[0]
    z = np.hstack([y, u])
    X = np.hstack([z[lags - i : ns - i] for i in range(1, lags + 1)])
    X = np.hstack([X, np.ones((X.shape[0], 1))])
    target = y[lags:]
    coef = np.linalg.lstsq(X, target, rcond=None)[0]
    out = np.zeros_like(y)
    out[lags:] = target - X @ coef
    return out


def feedthrough_offered(model: StateSpaceModel, rec: tuple) -> tuple[bool, str]:
    """Whether candidates with ``D`` are offered for the record ``rec = (t, u, y)``
    (module docstring), and the reason.  Offered only for a uniformly sampled record
    with an input whose feedback test finds no loop; the test correlates the residuals
    of a strictly causal least-squares ARX predictor (:func:`arx_residuals`, lags up to
    :data:`~hdpbsid.selection.feedback.AR_ORDER`, at least ten samples per regressor)
    with the prewhitened input.  ``model``: a candidate of the record (its input hold)."""
    from hdpbsid.selection.feedback import AR_ORDER, feedback_statistics

    t, u, y = rec
    if isinstance(t, list | tuple):
        return False, "not judged: several estimation records; D = 0"
    if model.m == 0:
        return False, "no input, no direct term"
    if not is_uniform(np.asarray(t, dtype=float)):
        return False, (
            "not judged: the feedback test that tells whether D is identifiable needs "
            "uniformly sampled times; D = 0"
        )
    u = np.asarray(u, dtype=float).reshape(len(t), -1)
    y = np.asarray(y, dtype=float).reshape(len(t), -1)
    try:
        with warnings.catch_warnings(), np.errstate(over="ignore", invalid="ignore"):
            warnings.simplefilter("ignore")
            lags = min(AR_ORDER, len(t) // (10 * (u.shape[1] + y.shape[1])))
            errors = arx_residuals(u, y, max(lags, 1))
            st = feedback_statistics(model, t, u, y, errors=errors)
    except (ValueError, np.linalg.LinAlgError):
        return False, "not judged: the feedback test cannot be computed"
    test = f"feedback test S = {st['statistic']:.4g} vs {st['threshold']:.4g}"
    if st["feedback"]:
        return False, (
            f"not offered: closed loop ({test}), where a controller that reacts within the "
            f"sample makes D unidentifiable from u and y; pass feedthrough=True when the "
            f"loop has at least one sample of delay"
        )
    return True, f"offered: open loop ({test})"
