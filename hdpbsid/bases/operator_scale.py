"""The operator scale ``alpha`` of the integrator form, chosen from the identified dynamics.

HD-PBSID and the finite-interval methods regress the state on the data filtered ``j``
times by ``M = D'^{-1}``, ``D' = (D/alpha + beta I)/gamma`` (the thesis, §3.2; with
``beta = gamma = 1``).  In the frequency domain ``M`` acts on a component at ``omega``
as ``alpha / (alpha + i omega)`` and ``A' = A/alpha + I`` acts on a mode ``lambda`` as
``(alpha + lambda)/alpha``; the VARX drops the term ``A'^p X M^p`` of the expansion

    X = sum_{j=1..p} A'^{j-1} B' Z M^j + A'^p X M^p,

which, for a mode ``lambda`` carrying its state near its natural frequency
``omega = |lambda|`` (the resonance of a pair, the corner of a real pole), is scaled by
``rho(alpha, lambda)^p`` with the **contraction factor**

    rho(alpha, lambda) = |alpha + lambda| / |alpha + i |lambda||,
    rho^2 = 1 - 2 zeta |lambda| alpha / (alpha^2 + |lambda|^2),   zeta = -Re lambda / |lambda|.

``rho < 1`` for every stable mode and every ``alpha > 0``; for one mode it is smallest,
``sqrt(1 - zeta)``, at ``alpha = |lambda|`` and tends to 1 as ``alpha / |lambda|`` goes to
0 or infinity.  A fixed ``p`` therefore truncates a mode well only when ``alpha`` is
within a moderate factor of ``|lambda|`` -- fast and slow modes pull ``alpha`` in opposite
directions, and a rule tied to the basis (``alpha = 4 * scale``, which grows with
``sqrt(N) / T``) serves neither (a stiff system with modes ``-50`` and ``-0.5 +- 2i``
gets ``alpha = 11`` from it, where ``rho = 0.955`` for the slow pair, which a short past
window then truncates badly).

:func:`minimax_alpha` minimises the *largest* truncation factor over the modes,
``T(alpha) = max_i rho(alpha, lambda_i)^p``.  Since every ``rho(., lambda_i)`` is
unimodal with its minimum at ``|lambda_i|``, the minimiser lies in
``[min |lambda_i|, max |lambda_i|]``.  ``T`` is flat near its minimum when the modes are
spread, and the map back ``lambda = alpha (lambda' - 1)`` multiplies the error of an
index-domain eigenvalue by ``alpha`` (a slow mode's relative error grows like
``alpha / |lambda|``), so the *smallest* ``alpha`` whose ``T`` is within
:data:`TRUNCATION_SLACK` of the minimum is taken.  It may lie above or below the basis
rule's ``alpha`` (``4 * scale``): both failures occur (far above the slow modes of a
stiff system; below every mode of a record with many slow modes, where the models
diverge).  The cost: on a single lightly damped mode ``alpha = |lambda|`` is taken,
where the variance is not the smallest (``T`` models neither the variance nor the noise
bias, both of which grow with ``alpha``), which is why the new ``alpha`` must prove
itself on held-out data (:func:`held_out_check`) before it replaces the basis rule's.

The modes come from a first-pass model (:func:`alpha_from_dynamics`): identified with the
basis rule, then re-identified with ``alpha*`` until ``alpha`` settles.  The truncation
concerns the predictor ``A - K C``, stable by construction: an unstable plant mode
enters by its mirror image (:func:`minimax_alpha`).  Modes outside the band the data
resolve (slower than the frequency below which :data:`MODE_ENERGY_FRACTION` of the
output energy lies, or faster than the basis band) are left out: a spurious slow mode would
otherwise pull ``alpha`` down to it.

The rule is one policy object, :class:`OperatorScalePolicy` (its thresholds are its
fields, each with its reason; :data:`OPERATOR_SCALE` is the default): its choice is an
:class:`AlphaChoice` with a typed :class:`AlphaReason`, its checks :class:`AlphaCheck`
with a typed :class:`CheckReason`.  The module functions are that default policy's.
The whole decision a method makes from the user's ``alpha`` (a number, ``"basis"``,
``"dynamics"`` or None) is :meth:`OperatorScalePolicy.decide`: given the method's fit at
an ``alpha`` and the evidence (:class:`AlphaEvidence`: the records, the band of the
modes, a refit of part of the record, the caller's held-out data), it returns an
:class:`AlphaDecision` whose typed :class:`AlphaRule` names the way taken, beside the
texts the model's options report.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_data, is_uniform
from hdpbsid.models.criteria import (
    MIN_WINDOWS,
    WindowedError,
    choose_smallest_adequate,
    default_windows,
    windowed_simulation_error,
)

__all__ = [
    "AlphaReason",
    "AlphaChoice",
    "CheckReason",
    "AlphaCheck",
    "AlphaRule",
    "AlphaEvidence",
    "AlphaDecision",
    "OperatorScalePolicy",
    "OPERATOR_SCALE",
    "contraction_factor",
    "minimax_alpha",
    "alpha_from_dynamics",
    "held_out_check",
    "held_out_comparison",
    "in_sample_screen",
    "compare",
    "HOLDOUT",
    "GRID_PER_DECADE",
    "TRUNCATION_SLACK",
    "MAX_PASSES",
    "MODE_ENERGY_FRACTION",
    "SETTLED",
]


class AlphaReason(str, Enum):
    """Why the passes of :meth:`OperatorScalePolicy.choose` stopped at their ``alpha``."""

    #: the current model's modes ask for an ``alpha`` within ``settled`` of its own
    SETTLED = "settled"
    #: no mode in the band has a non-zero real part: the last ``alpha`` is kept
    NO_MODE = "no informative mode"
    #: ``max_passes`` re-identifications were made
    PASSES_USED = "passes used"


@dataclass(frozen=True)
class AlphaChoice:
    """The operator scale chosen from the identified modes, its inputs and its reason.

    Parameters
    ----------
    value : float
        The operator scale taken (rad/s).
    reason : AlphaReason
        Why the passes stopped there (typed).
    first : float
        The first pass's ``alpha`` (the basis rule's).
    band : tuple of float
        ``(w_lo, w_hi)``: the band of ``|lambda|`` whose modes set ``alpha``.
    passes : tuple of float
        The ``alpha`` of every identification made, the first pass's first.
    rule : str
        The rule's text (``model.options["alpha_rule"]``).

    Examples
    --------
    >>> c = AlphaChoice(2.0, AlphaReason.SETTLED, 2.0, (0.1, 10.0), (2.0,), "rule")
    >>> c.info()
    {'alpha_rule': 'rule', 'alpha_passes': [2.0]}
    """

    value: float
    reason: AlphaReason
    first: float
    band: tuple[float, float]
    passes: tuple[float, ...]
    rule: str

    def info(self) -> dict[str, Any]:
        """The model options of the choice.

        Returns
        -------
        dict
            ``alpha_rule`` (the rule's text) and ``alpha_passes`` (the ``alpha`` of every
            pass, a list).
        """
        return {"alpha_rule": self.rule, "alpha_passes": list(self.passes)}


class CheckReason(str, Enum):
    """How a comparison of two operator scales (:class:`AlphaCheck`) ended."""

    #: the candidate is better by more than one standard error
    WON = "won"
    #: the candidate is not better by more than one standard error
    LOST = "lost"
    #: too few samples for :data:`~hdpbsid.models.criteria.MIN_WINDOWS` windows
    TOO_SHORT = "too short"
    #: neither model could be scored
    UNSCORED = "unscored"
    #: the comparison was not made (non-uniform samples: the screen passes)
    SKIPPED = "skipped"


@dataclass(frozen=True)
class AlphaCheck:
    """The outcome of a comparison of two operator scales.

    Parameters
    ----------
    take_new : bool
        Whether the candidate ``alpha`` wins (or, for a skipped screen, passes).
    reason : CheckReason
        How the comparison ended (typed).
    how : str
        The comparison's text, for the model's options.

    Examples
    --------
    >>> AlphaCheck(False, CheckReason.TOO_SHORT, "record too short").pair()
    (False, 'record too short')
    """

    take_new: bool
    reason: CheckReason
    how: str

    def pair(self) -> tuple[bool, str]:
        """The outcome as ``(take_new, how)``.

        Returns
        -------
        tuple of (bool, str)
            Whether the candidate wins, and the comparison's text.
        """
        return self.take_new, self.how


class AlphaRule(str, Enum):
    """Which way :meth:`OperatorScalePolicy.decide` took to its ``alpha`` (the typed
    counterpart of ``options["alpha_rule"]``)."""

    #: a number, used as given in one pass
    GIVEN = "given"
    #: ``alpha="basis"``: ``4 * scale`` in one pass (HD-PBSID as published)
    BASIS = "basis"
    #: several records: ``4 * scale``, no held-out check of a change can be made
    SEVERAL_RECORDS = "several records"
    #: ``alpha="dynamics"``: from the identified modes, taken without a check
    DYNAMICS = "dynamics"
    #: the first pass's modes ask for its own ``alpha``: nothing to check
    FIRST_PASS_ASKED = "first pass asked for"
    #: from the modes, better on the caller's held-out data by more than one SE
    HELD_OUT_DATA_WON = "held-out data won"
    #: from the modes, through the in-sample screen and better on the held-out part
    HELD_OUT_PART_WON = "held-out part won"
    #: the first pass's ``alpha`` kept: the change was not proved (the last check's
    #: :class:`CheckReason` says how: lost, too short, unscored)
    FIRST_PASS_KEPT = "first pass kept"


@dataclass(frozen=True)
class AlphaEvidence:
    """What :meth:`OperatorScalePolicy.decide` may judge an ``alpha`` on.

    Parameters
    ----------
    n_records : int
        The number of records fitted (several: no check of a change).
    record : tuple
        ``(t, u, y)`` of the first record, for the in-sample screen and the held-out part.
    band : callable
        ``band()`` returns ``(w_lo, w_hi)``, the band of modes that may set ``alpha``
        (computed only when the modes are asked).
    refit : callable
        ``refit(order, t, u, y, alpha)`` fits the method on part of the record (the
        held-out check; no recursion into the method's entry point).
    held_out : tuple or None, optional
        The caller's ``(t, u, y)`` held out of the record: a change is judged there
        instead (checked by :func:`~hdpbsid.data.checks.check_data` when used).

    Examples
    --------
    >>> ev = AlphaEvidence(2, (), lambda: (0.1, 10.0), lambda *a: None)
    >>> ev.n_records, ev.held_out
    (2, None)
    """

    n_records: int
    record: tuple
    band: Callable[[], tuple[float, float]]
    refit: Callable[..., Any]
    held_out: tuple | None = None


@dataclass(frozen=True)
class AlphaDecision:
    """The operator scale a method fits with, the way it was decided, and the evidence.

    Parameters
    ----------
    value : float
        The operator scale taken (rad per time unit).
    rule : AlphaRule
        The way taken (typed).
    text : str
        The rule's text (``model.options["alpha_rule"]``).
    modes : AlphaChoice or None, optional
        The choice from the identified modes, when they were asked.
    checks : tuple of AlphaCheck, optional
        The checks made of a change, in order (the last one decided).
    refit_settings : dict or None, optional
        The rule a refit on a longer record takes (``{"alpha": "basis"}`` or
        ``{"alpha": "dynamics"}``), set when the caller's held-out data judged.

    Examples
    --------
    >>> d = AlphaDecision(3.0, AlphaRule.GIVEN, "given")
    >>> d.options(), d.check is None
    ({'alpha_rule': 'given'}, True)
    """

    value: float
    rule: AlphaRule
    text: str
    modes: AlphaChoice | None = None
    checks: tuple[AlphaCheck, ...] = ()
    refit_settings: dict[str, str] | None = None

    @property
    def check(self) -> AlphaCheck | None:
        """The check that decided (the last one made), or None."""
        return self.checks[-1] if self.checks else None

    def options(self) -> dict[str, Any]:
        """The model options of the decision, in the order a model file lists them.

        Returns
        -------
        dict
            ``alpha_rule``; with the modes asked, ``alpha_passes``; with a check,
            ``alpha_check`` (the deciding check's text); ``refit_settings`` when set.
        """
        out: dict[str, Any] = {"alpha_rule": self.text}
        if self.modes is not None:
            out["alpha_passes"] = list(self.modes.passes)
        if self.checks:
            out["alpha_check"] = self.checks[-1].how
        if self.refit_settings is not None:
            out["refit_settings"] = self.refit_settings
        return out


@dataclass(frozen=True)
class OperatorScalePolicy:
    """How HD-PBSID chooses the operator scale ``alpha`` from the identified modes.

    Inputs: a first pass's model (its modes and past window) and the band of modes the
    record resolves; the choice: :meth:`choose`, an :class:`AlphaChoice` with a typed
    reason; the proof a change must give: :meth:`held_out_check` (refits on part of the
    record, judged on the rest) after the necessary condition :meth:`in_sample_screen`
    (module docstring; the one-standard-error rule of Hastie, Tibshirani & Friedman,
    *The Elements of Statistical Learning*, 2nd ed., 2009, sec. 7.10).

    Parameters
    ----------
    grid_per_decade : int, optional
        Grid points per decade of the ``alpha`` search.
    truncation_slack : float, optional
        Relative excess of the truncation factor over its minimum within which the
        smallest ``alpha`` is taken.
    max_passes : int, optional
        Re-identifications after the first pass.
    mode_energy_fraction : float, optional
        Share of the output energy below the lowest mode frequency that may set ``alpha``.
    holdout : float, optional
        Share of a record held out by :meth:`held_out_check`.
    settled : float, optional
        Relative change of ``alpha`` below which the passes stop.

    Examples
    --------
    >>> OperatorScalePolicy().minimax_alpha([-2.0])
    2.0
    """

    #: grid points per decade of the ``alpha`` search: neighbouring points differ by 1 %,
    #: far below the flatness of ``max_i rho`` near its minimum
    grid_per_decade: int = 240
    #: relative excess of the truncation factor ``max_i rho_i^p`` over its minimum within
    #: which the smallest ``alpha`` is taken.  A judgement, not derived: ``T`` is flat near
    #: its minimum when the modes are spread, so a slack trades a little truncation for a
    #: smaller ``alpha`` (less amplification of the slow modes' errors); 0 keeps the flat
    #: optimum's arbitrary end, and a larger slack lets ``alpha`` fall below the fast
    #: modes (chosen among 0, 2 and 5 % on the systems of bench/identify.py)
    truncation_slack: float = 0.02
    #: re-identifications after the first pass: the first update carries ``alpha`` from
    #: the basis rule to the modes, the second corrects for the modes having been fitted
    #: at the first pass's ``alpha`` and moves it much less; each pass costs one
    #: identification
    max_passes: int = 2
    #: modes slower than the frequency below which this fraction of the output energy
    #: lies (above the noise floor) do not set ``alpha``: such a mode carries at most
    #: about that share of the output, so its eigenvalue is poorly determined, and a
    #: spurious slow mode would drag ``alpha`` down to it (spurious modes a decade below
    #: the band the output energy occupies appear at high orders).  The output band shows
    #: where the input excites, not where the modes are: records swept above their modes
    #: lose those modes here and get a too large alpha, which :meth:`held_out_check` then
    #: rejects
    mode_energy_fraction: float = 0.01
    #: share of a record held out by :meth:`held_out_check` (as ``method="auto"`` does)
    holdout: float = 1.0 / 3.0
    #: relative change of ``alpha`` below which the passes stop
    settled: float = 0.05

    def minimax_alpha(self, eigenvalues: Any, p: int = 1) -> float | None:
        """:func:`minimax_alpha` with this policy's grid and slack.

        Parameters
        ----------
        eigenvalues : array_like of complex
            Continuous-time eigenvalues.
        p : int, optional
            The past window (the power of ``rho``).

        Returns
        -------
        float or None
            The operator scale, or None when no eigenvalue has a non-zero real part.
        """
        lam = np.asarray(eigenvalues, dtype=complex).ravel()
        lam = lam[np.isfinite(lam) & (lam.real != 0)]
        if lam.size == 0:
            return None
        lam = -np.abs(lam.real) + 1j * lam.imag  # unstable modes by their predictor mirrors
        w = np.abs(lam)
        lo, hi = float(w.min()), float(w.max())
        k = max(2, int(np.ceil(self.grid_per_decade * np.log10(hi / lo))) + 1)
        grid = np.geomspace(lo, hi, k)
        rho = np.abs(grid[:, None] + lam[None, :]) / np.abs(grid[:, None] + 1j * w[None, :])
        worst = rho.max(axis=1) ** p
        near = worst <= (1.0 + self.truncation_slack) * worst.min()
        return float(grid[int(np.flatnonzero(near)[0])])

    def rule_text(self, alpha0: float, band: tuple[float, float]) -> str:
        """The rule's text for ``model.options["alpha_rule"]``.

        Parameters
        ----------
        alpha0 : float
            The first pass's operator scale.
        band : tuple of float
            ``(w_lo, w_hi)``, the band of the modes that set ``alpha``.

        Returns
        -------
        str
            The rule, its slack, band and first pass.
        """
        w_lo, w_hi = band
        return (
            "minimax contraction of the identified modes: the smallest alpha within "
            f"{self.truncation_slack:.0%} of min_alpha max_i (|alpha + lambda_i| / "
            "|alpha + i |lambda_i||)^p over the modes (unstable ones mirrored) with "
            f"{w_lo:.3g} <= |lambda| <= {w_hi:.3g} rad/s, from a first pass at "
            f"alpha = {alpha0:.4g}"
        )

    def asked_by(self, model: Any, band: tuple[float, float]) -> float | None:
        """The ``alpha`` the modes of ``model`` inside ``band`` ask for.

        Parameters
        ----------
        model : object
            A model with ``eigenvalues`` and ``report.windows`` (its past window ``p``).
        band : tuple of float
            ``(w_lo, w_hi)``: modes with ``|lambda|`` outside it are ignored.

        Returns
        -------
        float or None
            :meth:`minimax_alpha` of those modes at the model's past window.
        """
        w_lo, w_hi = band
        lam = np.asarray(model.eigenvalues, dtype=complex)
        lam = lam[(np.abs(lam) >= w_lo) & (np.abs(lam) <= w_hi)]
        return self.minimax_alpha(lam, int(model.report.windows.get("p", 1)))

    def choose(
        self, fit: Callable[[float], Any], alpha0: float, band: tuple[float, float]
    ) -> tuple[AlphaChoice, Any]:
        """:func:`alpha_from_dynamics` as a typed choice.

        Parameters
        ----------
        fit : callable
            ``fit(alpha)`` returns a model with ``eigenvalues`` and ``report.windows``.
        alpha0 : float
            The first pass's operator scale (the basis rule's).
        band : tuple of float
            ``(w_lo, w_hi)``: modes with ``|lambda|`` outside it are ignored.

        Returns
        -------
        choice : AlphaChoice
            The operator scale, its passes and the reason the passes stopped.
        model : object
            The model fitted with it.
        """
        alpha = float(alpha0)
        model = fit(alpha)
        path = [alpha]
        reason = AlphaReason.PASSES_USED
        for _ in range(self.max_passes):
            new = self.asked_by(model, band)
            if new is None or abs(new - alpha) <= self.settled * alpha:
                # settled: the current model's alpha is already within `settled` of the
                # one its own modes ask for, so it is kept rather than refitted
                reason = AlphaReason.NO_MODE if new is None else AlphaReason.SETTLED
                break
            alpha = new
            path.append(alpha)
            model = fit(alpha)
        rule = self.rule_text(alpha0, band)
        return AlphaChoice(alpha, reason, float(alpha0), band, tuple(path), rule), model

    def held_out_check(
        self,
        identify: Callable[[Any, Any, Any, float], Any],
        record: tuple,
        alphas: tuple[float, float],
        order: int,
    ) -> AlphaCheck:
        """:func:`held_out_check` as a typed outcome.

        Parameters
        ----------
        identify : callable
            ``identify(t, u, y, alpha)`` returns a model.
        record : tuple
            ``(t, u, y)`` of the record.
        alphas : tuple of float
            ``(alpha_old, alpha_new)``, the incumbent and the candidate.
        order : int
            The model order.

        Returns
        -------
        AlphaCheck
            Whether ``alpha_new`` wins on the held-out part, and how.
        """
        t, u, y = record
        ns = t.shape[0]
        split = int(round(ns * (1.0 - self.holdout)))
        if default_windows(ns - split, order) < MIN_WINDOWS:
            return AlphaCheck(
                False, CheckReason.TOO_SHORT, "record too short for the held-out check"
            )
        models = [_fit_quietly(identify, (t[:split], u[:split], y[:split]), a) for a in alphas]
        return compare(models[0], models[1], (t[split:], u[split:], y[split:]), order, alphas)

    def in_sample_screen(
        self, old: Any, new: Any, record: tuple, alphas: tuple[float, float]
    ) -> AlphaCheck:
        """:func:`in_sample_screen` as a typed outcome.

        Parameters
        ----------
        old : model
            The incumbent (operator scale ``alphas[0]``).
        new : model
            The candidate (``alphas[1]``).
        record : tuple
            ``(t, u, y)`` of the record both were fitted on.
        alphas : tuple of float
            The two operator scales, for the text.

        Returns
        -------
        AlphaCheck
            Whether ``new`` passes the screen (skipped, and passed, on non-uniform
            samples), and how.
        """
        if not is_uniform(record[0]):
            how = "in-sample screen skipped (non-uniform samples)"
            return AlphaCheck(True, CheckReason.SKIPPED, how)
        order = int(np.asarray(old.A).shape[0])
        return compare(old, new, record, order, alphas, label="in-sample")

    def decide(
        self,
        asked: float | str | None,
        basis_alpha: float,
        fit: Callable[[float], Any],
        evidence: AlphaEvidence,
    ) -> tuple[AlphaDecision, Any]:
        """The operator scale of a method, one decision from the user's ``alpha``.

        A number is used as given; ``"basis"``, and any request on several records (no
        check of a change is possible there), take ``basis_alpha`` (``4 * scale``, HD-PBSID
        as published); otherwise :meth:`choose` asks the identified modes, and unless
        ``"dynamics"`` took them unchecked, a change from ``basis_alpha`` must prove itself
        (:meth:`prove`) or the first pass's model is kept.  The burden of proof is on the
        change because the truncation factor models neither the variance nor the noise
        bias, which grow with ``alpha`` (module docstring).

        Parameters
        ----------
        asked : float, {"basis", "dynamics"} or None
            The user's ``alpha`` (validated by the method).
        basis_alpha : float
            The basis rule's operator scale, the first pass of the modes' rule.
        fit : callable
            ``fit(alpha)`` returns the method's model of the whole data at ``alpha`` (a
            model with ``n``, ``eigenvalues`` and ``report.windows``).
        evidence : AlphaEvidence
            The records, the band of the modes, the part refit and the held-out data.

        Returns
        -------
        decision : AlphaDecision
            The operator scale, the way taken (typed) and its texts.
        model : object
            The model fitted at it.

        Examples
        --------
        >>> ev = AlphaEvidence(1, (), lambda: (0.1, 10.0), lambda *a: None)
        >>> d, model = OPERATOR_SCALE.decide("basis", 2.0, lambda a: f"fit at {a}", ev)
        >>> d.rule, d.value, model
        (<AlphaRule.BASIS: 'basis'>, 2.0, 'fit at 2.0')
        """
        if asked is not None and not isinstance(asked, str):
            value = float(asked)
            return AlphaDecision(value, AlphaRule.GIVEN, "given"), fit(value)
        if asked == "basis" or evidence.n_records > 1:
            rule = AlphaRule.BASIS if asked == "basis" else AlphaRule.SEVERAL_RECORDS
            return AlphaDecision(basis_alpha, rule, _BASIS_TEXTS[rule]), fit(basis_alpha)
        return self._from_modes(asked == "dynamics", basis_alpha, fit, evidence)

    def _from_modes(
        self, unchecked: bool, alpha0: float, fit: Callable[[float], Any], ev: AlphaEvidence
    ) -> tuple[AlphaDecision, Any]:
        """:meth:`decide` by the modes: :meth:`choose`, then :meth:`prove` a change."""
        modes, model = self.choose(fit, alpha0, ev.band())
        text = modes.rule + " (4 * scale, median over blocks)"
        checks: tuple[AlphaCheck, ...] = ()
        value = modes.value
        if unchecked:
            rule = AlphaRule.DYNAMICS
            text += "; taken without a held-out check (alpha='dynamics')"
        elif value == alpha0:
            rule = AlphaRule.FIRST_PASS_ASKED
        else:
            checks, where = self.prove(fit(alpha0), model, modes, ev)
            rule = AlphaRule.HELD_OUT_PART_WON
            if ev.held_out is not None:
                rule = AlphaRule.HELD_OUT_DATA_WON
            if not checks[-1].take_new:
                rule, value, model = AlphaRule.FIRST_PASS_KEPT, alpha0, fit(alpha0)
                text += (
                    f"; not better on the {where} by more than one SE: the first pass's alpha kept"
                )
        refit = None
        if ev.held_out is not None:
            # the rule the held-out data chose, for the refit on a longer record (whose
            # basis rule gives another 4 * scale and whose modes ask for their own alpha)
            refit = {"alpha": "basis" if value == alpha0 else "dynamics"}
        return AlphaDecision(value, rule, text, modes, checks, refit), model

    def prove(
        self, old: Any, new: Any, modes: AlphaChoice, evidence: AlphaEvidence
    ) -> tuple[tuple[AlphaCheck, ...], str]:
        """The checks a change of ``alpha`` from the first pass must pass.

        On the caller's held-out data when there are some (:func:`compare`); else the
        necessary condition :meth:`in_sample_screen` (no refits), then
        :meth:`held_out_check` (refits on the first part of the record, judged on the
        rest).

        Parameters
        ----------
        old : model
            The first pass's model (at ``modes.first``).
        new : model
            The model at ``modes.value`` (its ``n`` is the order of the refits).
        modes : AlphaChoice
            The choice from the modes.
        evidence : AlphaEvidence
            The record, the part refit and the held-out data.

        Returns
        -------
        checks : tuple of AlphaCheck
            The checks made, in order; the last one decides.
        where : str
            The data that decide, for the rule's text (``"held-out data"`` or
            ``"held-out part"``, the latter also when the screen refused the change).
        """
        alphas = (modes.first, modes.value)
        if evidence.held_out is not None:
            held_out = check_data(*evidence.held_out)
            return (compare(old, new, held_out, new.n, alphas),), "held-out data"
        screen = self.in_sample_screen(old, new, evidence.record, alphas)
        if not screen.take_new:
            return (screen,), "held-out part"
        refit = functools.partial(evidence.refit, new.n)
        check = self.held_out_check(refit, evidence.record, alphas, new.n)
        return (screen, check), "held-out part"


#: the texts of the basis rule's two ways (``model.options["alpha_rule"]``)
_BASIS_TEXTS = {
    AlphaRule.BASIS: "4 * scale (median over blocks); asked for (alpha='basis')",
    AlphaRule.SEVERAL_RECORDS: (
        "4 * scale (median over blocks); several records: no held-out check of a change"
    ),
}

#: the policy of :func:`alpha_from_dynamics` and the checks (its fields' reasons there)
OPERATOR_SCALE = OperatorScalePolicy()
#: the fields of :data:`OPERATOR_SCALE` under their former names
GRID_PER_DECADE = OPERATOR_SCALE.grid_per_decade
TRUNCATION_SLACK = OPERATOR_SCALE.truncation_slack
MAX_PASSES = OPERATOR_SCALE.max_passes
MODE_ENERGY_FRACTION = OPERATOR_SCALE.mode_energy_fraction
HOLDOUT = OPERATOR_SCALE.holdout
SETTLED = OPERATOR_SCALE.settled


def contraction_factor(alpha: float, eigenvalues: Any) -> NDArray[np.float64]:
    r"""The factor by which one lag of ``M`` scales a mode's truncated term.

    ``M = D'^{-1}`` acts on a component at ``omega`` as ``alpha / (alpha + i omega)`` and
    ``A' = A / alpha + I`` on a mode ``lambda`` as ``(alpha + lambda) / alpha``; at the
    mode's natural frequency ``omega = |lambda|`` their product has modulus ``rho``
    (module docstring).

    Parameters
    ----------
    alpha : float
        Operator scale (rad/s), ``> 0``.
    eigenvalues : array_like of complex
        Continuous-time eigenvalues.

    Returns
    -------
    ndarray of float
        ``rho(alpha, lambda) = |alpha + lambda| / |alpha + i |lambda||`` per eigenvalue;
        ``< 1`` for every stable mode.

    Notes
    -----
    .. math::

        \rho^2 = 1 - \frac{2 \zeta |\lambda| \alpha}{\alpha^2 + |\lambda|^2},
        \qquad \zeta = -\frac{\operatorname{Re}\lambda}{|\lambda|},

    smallest, :math:`\sqrt{1 - \zeta}`, at :math:`\alpha = |\lambda|`.

    Examples
    --------
    >>> contraction_factor(2.0, [-1.0 + 1j * np.sqrt(3.0)]).round(6)  # zeta = 1/2, alpha = |lambda|
    array([0.707107])
    """
    lam = np.asarray(eigenvalues, dtype=complex)
    return np.abs(alpha + lam) / np.abs(alpha + 1j * np.abs(lam))


def minimax_alpha(eigenvalues: Any, p: int = 1) -> float | None:
    """The smallest ``alpha`` whose truncation factor is within :data:`TRUNCATION_SLACK` of
    its minimum.

    ``T(alpha) = max_i rho(alpha, lambda_i)^p`` (:func:`contraction_factor`); every
    ``rho(., lambda_i)`` is unimodal with its minimum at ``|lambda_i|``, so the minimiser
    lies in ``[min |lambda_i|, max |lambda_i|]``, searched on a geometric grid of
    :data:`GRID_PER_DECADE` points per decade.  The smallest near-minimal ``alpha`` is taken
    because the map back ``lambda = alpha (lambda' - 1)`` multiplies the error of an
    index-domain eigenvalue by ``alpha``.  An unstable ``lambda`` enters as its mirror
    image ``-conj(lambda)``: the truncation concerns the predictor, whose eigenvalue for an
    unstable mode tends to that mirror image as the process noise vanishes (the reflection
    property of the Riccati equation).

    Parameters
    ----------
    eigenvalues : array_like of complex
        Continuous-time eigenvalues.
    p : int, optional
        The past window (the power of ``rho``).

    Returns
    -------
    float or None
        The operator scale, or None when no eigenvalue has a non-zero real part (``rho =
        1`` for every ``alpha``: such a mode says nothing about ``alpha``).

    References
    ----------
    .. [1] H. Kwakernaak and R. Sivan, *Linear Optimal Control Systems*, Wiley, 1972,
       sec. 4.4.

    Examples
    --------
    >>> minimax_alpha([-2.0])  # one real mode: alpha = |lambda|
    2.0
    >>> print(minimax_alpha([1j]))  # undamped: no information
    None
    """
    return OPERATOR_SCALE.minimax_alpha(eigenvalues, p)


def alpha_from_dynamics(
    fit: Callable[[float], Any],
    alpha0: float,
    band: tuple[float, float],
) -> tuple[float, Any, dict[str, Any]]:
    """Identify with ``alpha0``, then with :func:`minimax_alpha` of the model's modes, until
    ``alpha`` settles.

    At most :data:`MAX_PASSES` re-identifications.  Settled means the modes of the
    current model ask for an ``alpha`` within :data:`SETTLED` of the one it was fitted with;
    that model is then kept, not refitted at the new value: the refit would differ from it
    only by a change of ``alpha`` below the tolerance that declares ``alpha`` converged, at
    the cost of one more identification.  In particular a first pass whose modes ask for
    ``alpha0`` itself is the result, identified once.  When no mode qualifies, the last
    ``alpha`` is kept.

    Parameters
    ----------
    fit : callable
        ``fit(alpha)`` returns a model with ``eigenvalues`` and ``options["p"]``.
    alpha0 : float
        The first pass's operator scale (the basis rule's).
    band : tuple of float
        ``(w_lo, w_hi)``: modes with ``|lambda|`` outside it (not resolved by the record)
        are ignored.

    Returns
    -------
    alpha : float
        The operator scale.
    model : object
        The model fitted with it.
    info : dict
        ``alpha_rule`` (the rule's text) and ``alpha_passes`` (the ``alpha`` of every pass).
    """
    choice, model = OPERATOR_SCALE.choose(fit, alpha0, band)
    return choice.value, model, choice.info()


def held_out_check(
    identify: Callable[[Any, Any, Any, float], Any],
    t: Any,
    u: Any,
    y: Any,
    alpha_new: float,
    alpha_old: float,
    order: int,
) -> tuple[bool, str]:
    """Whether ``alpha_new`` is better than ``alpha_old`` out of sample.

    Both identify (order ``order``) on the first ``1 - HOLDOUT`` of the record and are
    compared on the rest by :func:`held_out_comparison`.  The truncation factor models
    neither the variance nor the bias of the noise in the lagged regressors, which grows
    with ``alpha``, nor modes the first pass got wrong; the held-out data see all of them,
    and where they cannot tell the two apart the basis rule stands.  A record too short to
    hold out :data:`~hdpbsid.models.criteria.MIN_WINDOWS` windows keeps ``alpha_old``.

    Parameters
    ----------
    identify : callable
        ``identify(t, u, y, alpha)`` returns a model.
    t : ndarray, shape (Ns,)
        Sample times (s).
    u : ndarray, shape (Ns, m)
        Inputs.
    y : ndarray, shape (Ns, l)
        Outputs.
    alpha_new : float
        The candidate operator scale.
    alpha_old : float
        The incumbent.
    order : int
        The model order.

    Returns
    -------
    take_new : bool
        Whether ``alpha_new`` wins.
    how : str
        The comparison, for the model's options.
    """
    check = OPERATOR_SCALE.held_out_check(identify, (t, u, y), (alpha_old, alpha_new), order)
    return check.pair()


def _fit_quietly(identify: Callable[..., Any], record: tuple, alpha: float) -> Any:
    """``identify(*record, alpha)`` without its warnings; None when the fit fails."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return identify(*record, alpha)
    except (ValueError, np.linalg.LinAlgError):
        return None


def _score_quietly(model: Any, record: tuple, windows: int) -> WindowedError:
    """The windowed simulation error of ``model`` on ``record``, without its warnings;
    infinite when ``model`` is None or cannot be simulated."""
    err = WindowedError(np.full(windows, np.inf), np.inf, -np.inf, False)
    if model is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                err = windowed_simulation_error(model, *record, windows)
            except (ValueError, np.linalg.LinAlgError):
                pass
    return err


def compare(
    old: Any,
    new: Any,
    record: tuple,
    order: int,
    alphas: tuple[float, float],
    label: str = "held-out",
) -> AlphaCheck:
    """:func:`held_out_comparison` as a typed outcome.

    Parameters
    ----------
    old : model or None
        The incumbent (operator scale ``alphas[0]``).
    new : model or None
        The candidate (``alphas[1]``).
    record : tuple
        ``(t, u, y)`` of the record scored on.
    order : int
        The model order (sets the number of windows).
    alphas : tuple of float
        The two operator scales, for the text.
    label : str, optional
        Names the data in the text.

    Returns
    -------
    AlphaCheck
        Whether ``new`` wins, how the comparison ended and its text.
    """
    t = record[0]
    windows = default_windows(t.shape[0], order)
    if windows < MIN_WINDOWS:
        return AlphaCheck(False, CheckReason.TOO_SHORT, f"{label} part too short for the check")
    errs = [_score_quietly(model, record, windows) for model in (old, new)]
    try:
        k, stats = choose_smallest_adequate(errs)
    except ValueError:
        how = f"neither alpha could be scored on the {label} part"
        return AlphaCheck(False, CheckReason.UNSCORED, how)
    fits = ", ".join(f"{e.fit:.4g} %" for e in errs)
    how = (
        f"{label} fit ({t.shape[0]} samples, {windows} windows) {fits} for alpha = "
        f"{alphas[0]:.4g}, {alphas[1]:.4g}; excess over the best {stats[0]:.2f} SE"
    )
    return AlphaCheck(k == 1, CheckReason.WON if k == 1 else CheckReason.LOST, how)


def held_out_comparison(
    old: Any,
    new: Any,
    held_out: tuple,
    order: int,
    alphas: tuple[float, float],
    label: str = "held-out",
) -> tuple[bool, str]:
    """Whether the model ``new`` simulates a record better than ``old`` by more than one
    standard error.

    The criterion is the windowed simulation error (:mod:`hdpbsid.models.criteria`, as
    ``method="auto"`` scores).  The burden of proof is on the change: ``new`` is taken only
    when its error is smaller than ``old``'s by more than one standard error of the windows
    (the one-standard-error rule of
    :func:`~hdpbsid.models.criteria.choose_smallest_adequate` with ``old`` listed first;
    Hastie, Tibshirani & Friedman, *The Elements of Statistical Learning*, 2nd ed., 2009,
    sec. 7.10).  A model that is None (its fit failed) scores infinity; a record too short
    for :data:`~hdpbsid.models.criteria.MIN_WINDOWS` windows keeps ``old``.

    Parameters
    ----------
    old : model or None
        The incumbent (operator scale ``alphas[0]``).
    new : model or None
        The candidate (``alphas[1]``).
    held_out : tuple
        ``(t, u, y)`` of the record scored on, not used by either fit (or the whole record,
        :func:`in_sample_screen`).
    order : int
        The model order (sets the number of windows).
    alphas : tuple of float
        The two operator scales, for ``how``.
    label : str, optional
        Names the data in ``how``.

    Returns
    -------
    take_new : bool
        Whether ``new`` wins.
    how : str
        The fits and the excess in standard errors.
    """
    return compare(old, new, held_out, order, alphas, label).pair()


def in_sample_screen(
    old: Any, new: Any, record: tuple, alphas: tuple[float, float]
) -> tuple[bool, str]:
    """The necessary condition checked before :func:`held_out_check`.

    The model ``new``, fitted on the whole record, must simulate it better than ``old`` by
    more than one standard error of the windows (:func:`held_out_comparison` on the record
    itself).  Why a change that fails it would not pass the held-out check either: the two
    models have the same structure and number of parameters, fitted to the same samples, so
    the optimism of their in-sample errors (the part of the fit that is noise) is the same
    to first order and cancels in the difference, which therefore estimates the
    out-of-sample difference from all the samples; the held-out standard error, from a third
    of the samples, is larger.  On a non-uniform time grid the screen passes without
    scoring: simulating there takes one matrix exponential per sample interval, and the two
    simulations cost more than the refits they would save.

    Parameters
    ----------
    old : model
        The incumbent (operator scale ``alphas[0]``).
    new : model
        The candidate (``alphas[1]``).
    record : tuple
        ``(t, u, y)`` of the record both were fitted on.
    alphas : tuple of float
        The two operator scales, for ``how``.

    Returns
    -------
    passed : bool
        Whether ``new`` passes the screen.
    how : str
        The comparison.
    """
    return OPERATOR_SCALE.in_sample_screen(old, new, record, alphas).pair()
