"""The order and the method of the held-out selection (:mod:`hdpbsid.selection.auto`) as
small named choices, each with its inputs and a typed reason.

The order (:func:`choose_order`, :class:`OrderChoice`).  The scored candidates are listed
by order (at one order, those without ``D`` before those with ``D``, then by held-out
error: :func:`~hdpbsid.selection.feedthrough.structure_key`), and the first whose
held-out error is within one standard error of the best candidate's is kept
(:func:`~hdpbsid.models.criteria.choose_smallest_adequate`): the smallest model the
held-out data cannot tell from the best, the one-standard-error rule of cross-validation
(Hastie, Tibshirani & Friedman, *The Elements of Statistical Learning*, 2nd ed., sec.
7.10).  When the model will be refined, the order is decided again between refined
candidates where the subspace bias could have decided it
(:func:`hdpbsid.selection.rejudge.rejudge_refined`), with the reason
:attr:`OrderReason.REFINED` or :attr:`OrderReason.REFINED_LARGER`.

The method (:func:`rank_candidates`, :class:`MethodChoice`).  The candidates of the chosen
order and structure within one standard error are tied at the resolution of the
held-out windows; the one with the smallest simulation error over the whole held-out
part from one initial state is tried first
(:func:`~hdpbsid.selection.scoring.break_tie`: it sees the slow errors each window's
fitted initial state hides), then the others, then the larger adequate orders.  That
ranking is the order in which the candidates are refitted and checked
(:mod:`hdpbsid.selection.refits`).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from hdpbsid.models.criteria import SIGNIFICANCE_Z, choose_smallest_adequate
from hdpbsid.selection.candidates import CandidateRow, _among, _index
from hdpbsid.selection.feedthrough import structure_key
from hdpbsid.selection.scoring import break_tie

__all__ = [
    "OrderReason",
    "OrderChoice",
    "MethodReason",
    "MethodChoice",
    "choose_order",
    "rank_candidates",
]


class OrderReason(str, Enum):
    """Why the held-out selection settled on its order (:class:`OrderChoice`)."""

    #: the smallest order within one standard error of the best held-out error
    ONE_STANDARD_ERROR = "the smallest order within one standard error of the best"
    #: decided again between refined candidates: the smallest refined held-out error
    REFINED = "decided again between refined candidates: the smallest refined error"
    #: closed loop: refined, a larger order beats the decision by more than one SE
    REFINED_LARGER = "closed loop: refined, a larger order beats it by more than one SE"
    #: refined, the order's extra mode is a drift of the record: the next smaller order
    DRIFT = "refined, its extra mode is a drift of the record: the smaller order"


@dataclass(frozen=True)
class OrderChoice:
    """The order decision of the held-out selection: the candidate chosen among a pool
    sorted by :func:`~hdpbsid.selection.feedthrough.structure_key`, its inputs and the
    typed reason.

    Attributes
    ----------
    index : int
        The position of the chosen candidate in the pool.
    stats : tuple of float
        Every candidate's distance to the best held-out error, in standard errors (the
        input of the one-standard-error rule).
    reason : OrderReason
        Why.
    rule : str
        What the decision adds to the selection rule's text (``""`` for the
        one-standard-error rule, stated by the rule itself).

    Examples
    --------
    >>> OrderChoice(1, (0.8, 0.0)).reason.value
    'the smallest order within one standard error of the best'
    """

    index: int
    stats: tuple[float, ...]
    reason: OrderReason = OrderReason.ONE_STANDARD_ERROR
    rule: str = ""


def choose_order(pool: list[CandidateRow]) -> OrderChoice:
    """The one-standard-error rule on the scored candidates ``pool`` (module docstring).

    Parameters
    ----------
    pool : list of CandidateRow
        Scored candidates (finite ``criterion``), sorted by
        :func:`~hdpbsid.selection.feedthrough.structure_key`.

    Returns
    -------
    OrderChoice
        The first candidate within one standard error of the best, and every
        candidate's distance to the best.
    """
    k, stats = choose_smallest_adequate([r.criterion for r in pool])
    return OrderChoice(k, tuple(stats))


class MethodReason(str, Enum):
    """Why the candidate tried first heads the ranking (:class:`MethodChoice`)."""

    #: the only candidate of the chosen order and structure within one standard error
    ALONE = "the only candidate of its order within one standard error"
    #: of the tied candidates, the smallest simulation error over the whole held-out part
    WHOLE_SIMULATION = "the smallest simulation error over the whole held-out part"


@dataclass(frozen=True)
class MethodChoice:
    """The ranking of the admitted candidates, the method tried first and why.

    Attributes
    ----------
    queue : tuple of CandidateRow
        The candidates in the order they are tried: the chosen order's tied
        candidates, best whole-held-out simulation first, then the larger adequate
        orders.
    tied : int
        How many candidates at the head of ``queue`` were tied.
    reason : MethodReason
        Why ``queue[0]`` heads it.

    Examples
    --------
    >>> MethodChoice((CandidateRow("dt", 2),), 1, MethodReason.ALONE).method
    'dt'
    """

    queue: tuple[CandidateRow, ...]
    tied: int
    reason: MethodReason

    @property
    def method(self) -> str:
        """The method of the candidate tried first."""
        return self.queue[0].method


def rank_candidates(pool: list[CandidateRow], order: OrderChoice, val: tuple) -> MethodChoice:
    """The candidates of ``pool`` that the one-standard-error rule admits, in the order
    they are tried (module docstring).

    Candidates more than one standard error worse than the best are not listed: the
    held-out data reject them against the best.  The ties are of one structure: one
    order, with or without ``D`` as the chosen candidate (the whole-simulation
    tie-break does not trade the preference for no ``D``).

    Parameters
    ----------
    pool : list of CandidateRow
        Scored candidates sorted by :func:`~hdpbsid.selection.feedthrough.structure_key`.
    order : OrderChoice
        The order decision on ``pool`` (its ``index`` and ``stats``).
    val : tuple
        The held-out record ``(t, u, y)`` of the tie-break.

    Returns
    -------
    MethodChoice
        The ranking and why its head is first.
    """
    adequate = [r for r, z in zip(pool, order.stats, strict=True) if z <= SIGNIFICANCE_Z]
    chosen = pool[order.index]
    queue = adequate[_index(adequate, chosen) :]
    tied = break_tie([r for r in queue if structure_key(r)[:2] == structure_key(chosen)[:2]], val)
    reason = MethodReason.WHOLE_SIMULATION if len(tied) > 1 else MethodReason.ALONE
    return MethodChoice(tuple(tied + [r for r in queue if not _among(r, tied)]), len(tied), reason)


def _ranked(pool: list[CandidateRow], k: int, stats: list[float], val: tuple) -> list[CandidateRow]:
    """The ranking of :func:`rank_candidates` for the candidate ``pool[k]`` chosen with
    the distances ``stats``, as a list."""
    return list(rank_candidates(pool, OrderChoice(k, tuple(stats)), val).queue)


def _admitted(pool: list[CandidateRow]) -> list[CandidateRow]:
    """The candidates of ``pool`` the one-standard-error rule admits: held-out error
    within :data:`~hdpbsid.models.criteria.SIGNIFICANCE_Z` standard errors of the best's
    (:func:`~hdpbsid.models.criteria.choose_smallest_adequate`); the rivals of
    :func:`~hdpbsid.selection.scoring.instability_problem`."""
    _, stats = choose_smallest_adequate([r.criterion for r in pool])
    return [r for r, z in zip(pool, stats, strict=True) if z <= SIGNIFICANCE_Z]
