"""The numbers of the held-out selection (:mod:`hdpbsid.selection.auto`), its warning and
its failure.

The numbers are the fields of one frozen :class:`SelectionPolicy`, each with the reason
for its value; the module-level names (:data:`HOLDOUT`, :data:`AUTO_MAX_ORDER`,
:data:`MUCH_WORSE_RATIO`, :data:`REJUDGE_Z`) are its fields, kept for the callers that
import them.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "SelectionPolicy",
    "SELECTION_POLICY",
    "SelectionWarning",
    "NoCandidate",
    "AUTO_METHODS",
    "HOLDOUT",
    "AUTO_MAX_ORDER",
    "MUCH_WORSE_RATIO",
    "REJUDGE_Z",
]

#: methods tried by ``method="auto"`` (in this order; ``dt`` only on uniform samples)
AUTO_METHODS = ("hermite", "laguerre", "legendre", "dt")


@dataclass(frozen=True)
class SelectionPolicy:
    """The numbers of the held-out selection, each with its reason.

    Attributes
    ----------
    holdout : float
        Share of the record held out for scoring.
    max_order : int
        Largest order tried by default.
    much_worse_ratio : float
        Held-out error ratio beyond which a returned model is much worse than a
        rejected one (:func:`hdpbsid.selection.scoring.much_worse`).
    rejudge_z : float
        Standard errors from the best within which an order's best candidate is refined
        before the order is decided again (:func:`hdpbsid.selection.rejudge.
        rejudge_refined`).

    Examples
    --------
    >>> SelectionPolicy().max_order
    8
    """

    #: the last third, as users validate: two thirds estimate, one third scores
    holdout: float = 1.0 / 3.0
    #: the default sweep's upper end: 8 orders of 4 methods, the 32 candidates the
    #: default path's cost is sized for (:mod:`hdpbsid.selection.long_records`)
    max_order: int = 8
    #: the smallest ratio the one-standard-error rule resolves for any spread of the
    #: held-out windows (:func:`hdpbsid.selection.scoring.much_worse`)
    much_worse_ratio: float = 2.0
    #: a judgement, three times the one-standard-error rule's margin: the closed-loop
    #: bias of the subspace candidates can put the true order 1.4-2.2 standard errors
    #: behind a larger one
    rejudge_z: float = 3.0


#: the policy :mod:`hdpbsid.selection.auto` applies
SELECTION_POLICY = SelectionPolicy()

#: share of the record held out for scoring (:attr:`SelectionPolicy.holdout`)
HOLDOUT = SELECTION_POLICY.holdout
#: largest order tried by default (:attr:`SelectionPolicy.max_order`)
AUTO_MAX_ORDER = SELECTION_POLICY.max_order
#: :func:`~hdpbsid.selection.scoring.much_worse`'s ratio (:attr:`SelectionPolicy.much_worse_ratio`)
MUCH_WORSE_RATIO = SELECTION_POLICY.much_worse_ratio
#: :func:`~hdpbsid.selection.rejudge.rejudge_refined`'s margin (:attr:`SelectionPolicy.rejudge_z`)
REJUDGE_Z = SELECTION_POLICY.rejudge_z


class SelectionWarning(UserWarning):
    """The held-out selection took a decision the user should know of: it returned a
    candidate fitted on part of the record, a model much worse on the held-out part than
    one it rejected, or a model no candidate of which passed its checks.  The message
    says what was rejected, why, and what to pass (``order=``, ``method=``) instead."""


class NoCandidate(ValueError):
    """No candidate of the held-out selection can be identified and scored, or no
    scored candidate's refit on the whole record holds
    (:func:`hdpbsid.selection.auto.select_model`)."""
