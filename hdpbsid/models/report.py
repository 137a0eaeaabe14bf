"""The identification report: what was decided on the way to a model, and why, typed.

Every stage of :func:`hdpbsid.identify` makes choices -- the method and its order, the
input hold, the direct term, the settings a refit keeps, whether and how the model was
refined -- and later stages act on them (the refinement fits the hold the method was
told; the selection's refit takes the settings its candidate was judged with).  They pass
between the stages in one typed object, :class:`IdentificationReport`, attached to the
model as ``model.report``; ``model.options`` stays the free-form record of the settings
for printing and the model file, and no stage reads its decisions from there.

A report is immutable: a stage that adds to it replaces the model's report by an updated
copy (:meth:`IdentificationReport.but`), so a copy of a model never shares a change made
to another.  A model made from ``options`` alone (by hand, or read from a model file
written before the report existed) gets its report from them
(:meth:`IdentificationReport.from_options`): old files keep their behaviour.

>>> from hdpbsid.models.report import Choice, IdentificationReport
>>> report = IdentificationReport(method="hermite", input_hold=Choice("zoh", "given"))
>>> report
IdentificationReport(method='hermite', input hold zoh (given))
>>> report.hold
'zoh'
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import Enum
from typing import Any, Generic, TypeVar

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "Choice",
    "DirectTerm",
    "Candidate",
    "Refinement",
    "WarmStart",
    "IdentificationReport",
    "WARM_START_OPTION",
]

T_ = TypeVar("T_")
Array = NDArray[np.float64]

#: the ``options`` key under which models of earlier versions carried a warm start of the
#: refinement (read by :meth:`IdentificationReport.from_options` only)
WARM_START_OPTION = "refine_warm_start"


@dataclass(frozen=True)
class Choice(Generic[T_]):
    """A value chosen by a policy and the reason for it (reported beside the model).

    The reason is a text, the one the model's options and files carry, and where the
    policy has a typed way (an :class:`enum.Enum`: the operator scale's
    :class:`~hdpbsid.bases.operator_scale.AlphaRule`, the Laguerre pole's
    :class:`~hdpbsid.bases.laguerre_pole.PoleRule`, ...) that member too, as ``rule``,
    for code that acts on the reason: it compares members, not texts.  Two choices are
    equal when their values and texts are (the text states the rule).

    Parameters
    ----------
    value : any
        What was chosen (a basis size, an operator scale, an input hold, ...).
    reason : str
        Why: ``"given"`` for a user's value, else the rule and its inputs.
    rule : enum.Enum or None, optional
        The policy's typed reason, when it has one.

    Examples
    --------
    >>> Choice(3, "given")
    Choice(value=3, reason='given')
    >>> Choice(3, "given").given
    True
    >>> from hdpbsid.bases.operator_scale import AlphaRule
    >>> c = Choice(2.0, "4 * scale (the basis rule)", AlphaRule.BASIS)
    >>> c.rule is AlphaRule.BASIS, c == Choice(2.0, "4 * scale (the basis rule)")
    (True, True)
    """

    value: T_
    reason: str
    rule: Enum | None = field(default=None, compare=False)

    def __repr__(self) -> str:
        typed = "" if self.rule is None else f", rule={type(self.rule).__name__}.{self.rule.name}"
        return f"Choice(value={self.value!r}, reason={self.reason!r}{typed})"

    @property
    def given(self) -> bool:
        """Whether the value was the user's (``reason == "given"``)."""
        return self.reason == "given"


@dataclass(frozen=True)
class DirectTerm:
    """The model's direct term ``D``: whether it was estimated, and who decided.

    Parameters
    ----------
    estimated : bool
        Whether ``D`` is estimated (False: fixed at zero).
    by_method : bool
        True when the method estimates ``D`` as part of its own algebra whatever it is
        asked (the Laguerre-domain ``D_d``): ``feedthrough=`` is then no choice of the
        method, and the refinement keeps ``D`` fixed.  False when ``D`` is estimated
        exactly when ``feedthrough=True`` was asked (the PBSID core).
    reason : str, optional
        The method's description of its own ``D`` (``by_method``), else empty.

    Examples
    --------
    >>> DirectTerm.from_option(True)
    DirectTerm(estimated=True, by_method=False, reason='')
    >>> DirectTerm.from_option("Laguerre-domain Dd estimated").by_method
    True
    """

    estimated: bool
    by_method: bool
    reason: str = ""

    @property
    def asked(self) -> bool:
        """Whether ``D`` is estimated because it was asked for (a parameter of the model
        structure, and so of the prediction-error refinement)."""
        return self.estimated and not self.by_method

    @classmethod
    def from_option(cls, value: Any) -> DirectTerm | None:
        """The direct term of a method's ``feedthrough`` option: a boolean is the choice
        of ``D`` (the core's), a text the method's own estimate; anything else (absent,
        ``None``) is unknown.

        Parameters
        ----------
        value : bool, str or None
            The value a method recorded.

        Returns
        -------
        DirectTerm or None
            ``None`` when ``value`` is neither a boolean nor a text.
        """
        if isinstance(value, bool | np.bool_):
            return cls(bool(value), False)
        if isinstance(value, str):
            return cls(bool(value), True, value)
        return None


#: the columns of a selection row, in the order of the selection table
_CANDIDATE_COLUMNS = (
    "method",
    "order",
    "feedthrough",
    "error",
    "fit",
    "z",
    "whole_simulation",
    "refined_error",
    "refined_fit",
    "predictor",
    "first_pass_error",
    "time",
    "status",
)


@dataclass(frozen=True)
class Candidate:
    """One candidate of the held-out selection (:mod:`hdpbsid.selection.auto`).

    Parameters
    ----------
    method : str
        The method fitted.
    order : int or None
        Its order (``None`` for a method skipped before fitting).
    feedthrough : bool
        Whether the selection fitted it with ``D`` asked for.
    error, fit : float or None
        Held-out windowed error (0 perfect, 1 no better than the mean) and its fit.
    z : float or None
        Its error above the best candidate's, in standard errors.
    whole_simulation : float or None
        Simulation error over the whole held-out part (ties of the one-SE rule).
    refined_error, refined_fit : float or None
        The same scores after a prediction-error refinement on the estimation part.
    predictor : str or None
        The predictor scored: with its ``K`` or with ``K = 0``.
    first_pass_error : float or None
        The error of the sweep's first fit, when a second one replaced it.
    time : float
        Seconds spent on the candidate.
    status : str
        ``"ok"``, or why it was not scored.

    Examples
    --------
    >>> row = Candidate.from_dict({"method": "dt", "order": 2, "error": 0.1, "status": "ok"})
    >>> row.method, row.order, row.error, row.z
    ('dt', 2, 0.1, None)
    """

    method: str
    order: int | None
    feedthrough: bool = False
    error: float | None = None
    fit: float | None = None
    z: float | None = None
    whole_simulation: float | None = None
    refined_error: float | None = None
    refined_fit: float | None = None
    predictor: str | None = None
    first_pass_error: float | None = None
    time: float = 0.0
    status: str = ""

    @classmethod
    def from_dict(cls, row: Mapping[str, Any], method: str = "") -> Candidate:
        """A candidate from a row of the selection table (``options["selection"]``).

        Parameters
        ----------
        row : mapping
            The row; columns it lacks take their defaults, unknown ones are ignored.
        method : str, optional
            The method of a row that names none (a method's own order table, e.g. the
            frequency-domain fit's, lists orders of one method).

        Returns
        -------
        Candidate
        """
        values = {k: row[k] for k in _CANDIDATE_COLUMNS if k in row}
        values.setdefault("method", method)
        values.setdefault("order", None)
        return cls(**values)

    def as_dict(self) -> dict[str, Any]:
        """The row as plain values, in the columns of the selection table.

        Returns
        -------
        dict
        """
        return {k: getattr(self, k) for k in _CANDIDATE_COLUMNS}


@dataclass(frozen=True)
class Refinement:
    """The outcome of a prediction-error refinement (:func:`hdpbsid.refine.pem.refine_pem`).

    Parameters
    ----------
    converged : bool
        False when the evaluation budget ran out before the fit converged.
    nfev : int
        Cost evaluations over all starts and holds.
    hold : str
        The input hold fitted (``"zoh"`` or ``"foh"``).
    start : str
        The starting point the result came from.
    cost : tuple of float
        Initial and final mean squared weighted prediction error.
    eigenvalue_std : ndarray or None
        Standard deviation of each eigenvalue (first-order, from the fit's Jacobian).

    Examples
    --------
    >>> Refinement(True, 12, "zoh", "model K", (1.0, 0.5))
    Refinement(converged in 12 evaluations, zoh, from 'model K')
    """

    converged: bool
    nfev: int
    hold: str
    start: str
    cost: tuple[float, float]
    eigenvalue_std: Array | None = field(default=None, compare=False)

    def __repr__(self) -> str:
        how = "converged" if self.converged else "not converged"
        return f"Refinement({how} in {self.nfev} evaluations, {self.hold}, from {self.start!r})"

    @classmethod
    def from_options(cls, options: Mapping[str, Any]) -> Refinement | None:
        """The refinement recorded in a model's options (``refine="pem"``), else None.

        Parameters
        ----------
        options : mapping
            A model's options.

        Returns
        -------
        Refinement or None
        """
        if options.get("refine") != "pem":
            return None
        cost = options.get("refine_cost") or {}
        std = options.get("eigenvalue_std")
        return cls(
            converged=bool(options.get("refine_converged", True)),
            nfev=int(options.get("refine_nfev", 0) or 0),
            hold=str(options.get("refine_hold", options.get("input_hold", ""))),
            start=str(options.get("refine_start", "")),
            cost=(float(cost.get("initial", np.nan)), float(cost.get("final", np.nan))),
            eigenvalue_std=None if std is None else np.asarray(std),
        )


@dataclass(frozen=True)
class WarmStart:
    """A further starting point offered to the prediction-error refinement.

    Parameters
    ----------
    A, B, C, D, K : ndarray
        The starting model's matrices (the dimensions of the model refined).
    input_hold : str or None
        The hold it was fitted with (then fitted first), or None.
    name : str or None
        How the refinement names the start (default: a prediction-error fit on part of the
        record).

    Examples
    --------
    >>> import numpy as np
    >>> from hdpbsid import StateSpaceModel
    >>> m = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.5]])
    >>> WarmStart.of(m, "zoh")
    WarmStart(n=1, input_hold='zoh', name=None)
    """

    A: Array = field(repr=False)
    B: Array = field(repr=False)
    C: Array = field(repr=False)
    D: Array = field(repr=False)
    K: Array = field(repr=False)
    input_hold: str | None = None
    name: str | None = None

    def __repr__(self) -> str:
        n = np.shape(self.A)[0]
        return f"WarmStart(n={n}, input_hold={self.input_hold!r}, name={self.name!r})"

    @classmethod
    def of(cls, model: Any, input_hold: str | None = None, name: str | None = None) -> WarmStart:
        """The matrices of ``model`` as a starting point.

        Parameters
        ----------
        model : StateSpaceModel
            The starting model.
        input_hold : str or None, optional
            The hold it was fitted with.
        name : str or None, optional
            The start's name.

        Returns
        -------
        WarmStart
        """
        return cls(*(getattr(model, k) for k in "ABCDK"), input_hold=input_hold, name=name)

    @classmethod
    def from_option(cls, value: Any) -> WarmStart | None:
        """A warm start from the ``refine_warm_start`` option of earlier versions (a dict
        with ``"A"`` .. ``"K"``, ``"input_hold"``, ``"name"``), else None.

        Parameters
        ----------
        value : dict or None
            The option's value.

        Returns
        -------
        WarmStart or None
        """
        if not isinstance(value, Mapping) or any(k not in value for k in "ABCDK"):
            return None
        return cls(
            *(value[k] for k in "ABCDK"),
            input_hold=value.get("input_hold"),
            name=value.get("name"),
        )


def _copied(mapping: Mapping[str, Any] | None) -> dict[str, Any]:
    """A copy of ``mapping``: a report does not share a dictionary with its maker (a plain
    dict, so that a report pickles, e.g. to and from the workers of a parallel sweep)."""
    return dict(mapping or {})


def _numbers(options: Mapping[str, Any], keys: tuple[str, ...]) -> dict[str, float]:
    """The entries of ``options`` among ``keys`` that are numbers (not flags), as floats."""
    return {
        k: float(options[k])
        for k in keys
        if isinstance(options.get(k), int | float) and not isinstance(options[k], bool)
    }


@dataclass(frozen=True)
class IdentificationReport:
    """What the identification decided, and why: the typed channel between its stages.

    Parameters
    ----------
    method : str or None, optional
        The method that produced the model.
    order : Choice of int or None, optional
        The model's order and how it was chosen (set by :func:`hdpbsid.identify`).
    input_hold : Choice of str or None, optional
        How the inputs behave between samples (``"zoh"``, ``"foh"``, ...), and why
        (``"given"`` when the method was told).
    feedthrough : DirectTerm or None, optional
        The direct term (None: the method did not say).
    windows : mapping of str to int, optional
        The past and future windows ``"p"``, ``"f"`` of the PBSID core, when the method
        reports them.
    basis : mapping of str to float, optional
        The basis a basis method projected on, when it reports them: its size ``"N"``
        (one size for every block), the time scale ``"scale"`` of its functions and the
        operator scale ``"alpha"`` of the integrator form.
    alpha : Choice of float or None, optional
        The operator scale of the integrator form and how it was decided (Hermite: ``rule``
        an :class:`~hdpbsid.bases.operator_scale.AlphaRule`; its text is
        ``options["alpha_rule"]``), when the method has one.
    pole : Choice of float or None, optional
        The Laguerre pole ``a`` and how it was decided (``rule`` a
        :class:`~hdpbsid.bases.laguerre_pole.PoleRule`; its text is ``options["a_rule"]``).
    past_window : Choice of int or None, optional
        The past window ``p`` of a basis method's core and why (``rule`` a
        :class:`~hdpbsid.bases.basis_core.WindowReason`; its text is ``options["p_rule"]``).
    strictly_causal_lag : bool or None, optional
        Whether the lag operator of the method's PBSID core is strictly causal
        (:func:`hdpbsid.core.varx.is_strictly_causal`): with one that is not, the
        noise-driven part of the output biases the subspace estimate (None when the
        method did not say).
    refit_settings : Choice of dict or None, optional
        Settings the method chose on held-out data, which a refit of the model on a longer
        record takes as given.
    candidates : tuple of Candidate, optional
        The held-out selection's candidates (empty when nothing was selected).
    selection_rule : str, optional
        How the candidates were ranked and which were not kept.
    selection_fallback : str, optional
        Set when the selection returned its candidate fitted on part of the record.
    refinement : Refinement or None, optional
        The prediction-error refinement the model is the result of, if any.
    refine_decision : Choice of bool or None, optional
        Whether the returned model is the refined one, and why (``refine=`` of
        :func:`hdpbsid.identify`; None without a refinement asked for).
    focus : Choice of str or None, optional
        What the refinement fitted the plant for, ``"prediction"`` or ``"simulation"``,
        and why (``rule`` a :class:`~hdpbsid.selection.focus.FocusRule`; None without a
        refinement).
    warm_start : WarmStart or None, optional
        A starting point the next refinement of this model should be offered (not part of
        a finished identification's result).
    restarts : tuple of WarmStart, optional
        Other candidates' models of the same order the refinement may start from again
        when its result has a mode the input does not drive
        (:mod:`hdpbsid.selection.restarts`; not part of a finished identification's
        result).
    timings : mapping of str to float, optional
        Seconds spent per stage.
    warnings : tuple of str, optional
        Texts of the warnings the identification issued about the result.

    Examples
    --------
    >>> report = IdentificationReport(method="dt", feedthrough=DirectTerm(False, False))
    >>> report.but(refinement=Refinement(False, 400, "zoh", "model K", (1.0, 0.9))).refinement
    Refinement(not converged in 400 evaluations, zoh, from 'model K')
    >>> report.refinement is None  # the original is unchanged
    True
    """

    method: str | None = None
    order: Choice[int] | None = None
    input_hold: Choice[str] | None = None
    feedthrough: DirectTerm | None = None
    windows: Mapping[str, int] = field(default_factory=dict)
    basis: Mapping[str, float] = field(default_factory=dict)
    alpha: Choice[float] | None = None
    pole: Choice[float] | None = None
    past_window: Choice[int] | None = None
    strictly_causal_lag: bool | None = None
    refit_settings: Choice[Mapping[str, Any]] | None = None
    candidates: tuple[Candidate, ...] = ()
    selection_rule: str = ""
    selection_fallback: str = ""
    refinement: Refinement | None = None
    refine_decision: Choice[bool] | None = None
    focus: Choice[str] | None = None
    warm_start: WarmStart | None = None
    restarts: tuple[WarmStart, ...] = ()
    timings: Mapping[str, float] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "windows", _copied(self.windows))
        object.__setattr__(self, "basis", _copied(self.basis))
        object.__setattr__(self, "timings", _copied(self.timings))
        object.__setattr__(self, "candidates", tuple(self.candidates))
        object.__setattr__(self, "warnings", tuple(self.warnings))
        object.__setattr__(self, "restarts", tuple(self.restarts))

    def __repr__(self) -> str:
        parts = [f"method={self.method!r}"]
        if self.order is not None:
            parts.append(f"order {self.order.value}")
        if self.input_hold is not None:
            parts.append(f"input hold {self.input_hold.value} ({self.input_hold.reason})")
        if self.feedthrough is not None:
            parts.append("D estimated" if self.feedthrough.estimated else "D = 0")
        if self.candidates:
            parts.append(f"{len(self.candidates)} candidates")
        if self.refinement is not None:
            parts.append(repr(self.refinement))
        if self.focus is not None:
            parts.append(f"focus {self.focus.value}")
        if self.warnings:
            parts.append(f"{len(self.warnings)} warnings")
        return f"IdentificationReport({', '.join(parts)})"

    @property
    def converged(self) -> bool:
        """False only when the model is a refinement that ran out of its evaluation budget
        (:attr:`refinement`); True for a converged one and for an unrefined model."""
        return self.refinement is None or self.refinement.converged

    @property
    def hold(self) -> str | None:
        """The input hold's value, or None when the method did not report one."""
        return None if self.input_hold is None else self.input_hold.value

    def order_candidates(self, method: str | None = None) -> tuple[Candidate, ...]:
        """The candidates of one method (default the chosen one): its order selection.

        Parameters
        ----------
        method : str or None, optional
            The method; default :attr:`method`.

        Returns
        -------
        tuple of Candidate
        """
        name = self.method if method is None else method
        return tuple(c for c in self.candidates if c.method == name)

    def but(self, **changes: Any) -> IdentificationReport:
        """A copy with ``changes`` (field names and new values).

        Parameters
        ----------
        **changes
            New values of fields.

        Returns
        -------
        IdentificationReport

        Raises
        ------
        TypeError
            For a name that is not a field.
        """
        return dataclasses.replace(self, **changes)

    def warned(self, text: str) -> IdentificationReport:
        """A copy with ``text`` appended to :attr:`warnings`.

        Parameters
        ----------
        text : str
            The warning's text.

        Returns
        -------
        IdentificationReport
        """
        return self.but(warnings=(*self.warnings, text))

    @classmethod
    def from_options(cls, options: Mapping[str, Any]) -> IdentificationReport:
        """The report of a model known by its options only: a model built by hand, one
        a method returned with its settings recorded, or one read from a model file
        (earlier versions wrote no report; their options hold the same facts).

        Parameters
        ----------
        options : mapping
            A model's options.

        Returns
        -------
        IdentificationReport
        """
        hold = (
            Choice(options["input_hold"], str(options.get("input_hold_rule", "")))
            if "input_hold" in options
            else None
        )
        refit = options.get("refit_settings")
        table = options.get("selection")
        if not isinstance(table, list):
            table = options.get("order_selection")
        rows = [r for r in table if isinstance(r, Mapping)] if isinstance(table, list) else []
        method = str(options.get("method") or "")
        return cls(
            method=options.get("method"),
            input_hold=hold,
            feedthrough=DirectTerm.from_option(options.get("feedthrough")),
            windows={k: options[k] for k in ("p", "f") if k in options},
            basis=_numbers(options, ("N", "scale", "alpha")),
            strictly_causal_lag=(
                bool(options["lag_strictly_causal"])
                if isinstance(options.get("lag_strictly_causal"), bool | np.bool_)
                else None
            ),
            refit_settings=(
                Choice(dict(refit), str(options.get("alpha_rule", "")))
                if isinstance(refit, Mapping)
                else None
            ),
            candidates=tuple(Candidate.from_dict(r, method) for r in rows),
            selection_rule=str(options.get("selection_rule", "")),
            selection_fallback=str(options.get("selection_fallback") or ""),
            refinement=Refinement.from_options(options),
            warm_start=WarmStart.from_option(options.get(WARM_START_OPTION)),
            timings=_numbers(options, ("refine_time",)),
            focus=(
                Choice(str(options["refine_focus"]), str(options.get("focus_rule", "given")))
                if "refine_focus" in options
                else None
            ),
        )
