"""The Laguerre pole ``a``, chosen from the identified dynamics (method ``"laguerre"``).

The Laguerre method identifies the index-domain model ``Ad = (A + aI)(A - aI)^{-1}`` and
maps it back by ``A = a (Ad + I)(Ad - I)^{-1}`` (:mod:`hdpbsid.methods.laguerre`).  A mode
``lambda`` appears as ``mu = (lambda + a)/(lambda - a)`` and is recovered as
``lambda = a (mu + 1)/(mu - 1)``, whose derivative is ``d lambda / d mu = -2a/(mu - 1)^2
= -(lambda - a)^2 / (2a)``.  An index-domain estimate with absolute error ``delta``
therefore gives ``lambda`` a *relative* error of ``g(a, lambda) delta`` with the
amplification

    g(a, lambda) = |lambda - a|^2 / (2 a |lambda|)
                 = (a/|lambda| + |lambda|/a) / 2 + zeta,   zeta = -Re lambda / |lambda|,

smallest (``1 + zeta``) at ``a = |lambda|`` and growing like ``a / (2|lambda|)`` for slow
modes and ``|lambda| / (2a)`` for fast ones.  A pole set by the data bandwidth alone can
sit far above the slow modes: a stiff record (a fast real pole at ``-80`` and a lightly
damped pair at ``|lambda| = 1.5``) excited by fast steps gets ``a`` near 95, where ``g``
of the pair is about 31 and its ``mu`` lies within ``0.006`` of ``-1``, so the map back of
a small index-domain error gives a spurious mode or one 10^4 % off.

:func:`minimax_pole` takes the ``a`` that minimises the largest amplification over the
modes, ``max_i g(a, lambda_i)``.  Each ``g(., lambda_i)`` is a convex function of
``log a`` symmetric about ``log |lambda_i|`` (plus the constant ``zeta_i``), so the
minimiser lies between the slowest and the fastest mode, at their geometric mean when
the damping ratios are equal: the rule is scale-free and needs no constant.

:func:`pole_from_dynamics` is the policy: a first pass at the data-bandwidth pole
``a0``; the modes the samples resolve (:func:`dynamics_band`: between one period of the
record, ``2 pi / T``, and the Nyquist frequency) set the minimax pole (a model with a
mode outside that band, spurious or beyond what the samples resolve, is no guide: the
band's edges, the slowest mode the record resolves and the data bandwidth, stand in for
its modes); the fit is repeated there until ``a`` settles (at most
:data:`~hdpbsid.bases.operator_scale.MAX_PASSES` times, as HD-PBSID's operator scale,
:func:`hdpbsid.bases.operator_scale.alpha_from_dynamics`); the new pole replaces ``a0``
only when its model simulates the record better by more than one standard error of the
windows (:func:`~hdpbsid.bases.operator_scale.in_sample_screen`: the two models have the
same structure, so the noise in their in-sample errors cancels in the difference).  The
result is a :class:`LaguerrePole` with its typed :class:`PoleSource` and :class:`PoleRule`.
:func:`decide_pole` is the whole decision from the user's ``a`` (a number,
``"bandwidth"``, ``"dynamics"`` or None), given the method's fit at a pole.  The default
(None) keeps the bandwidth pole unless the first pass's modes are ill-conditioned there
(:class:`PolePolicy`): the second pass and its in-sample screen, which a feedback loop
biases, are spent only where the bandwidth pole magnifies the index-domain errors.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.operator_scale import OPERATOR_SCALE, AlphaCheck
from hdpbsid.data.checks import is_uniform

__all__ = [
    "PoleSource",
    "PoleRule",
    "PolePolicy",
    "POLE_POLICY",
    "LaguerrePole",
    "map_back_amplification",
    "minimax_pole",
    "pole_from_dynamics",
    "decide_pole",
    "dynamics_band",
]


class PoleSource(enum.Enum):
    """Where the Laguerre pole of a model came from."""

    #: given by the user (``a=``)
    GIVEN = "given"
    #: half the data bandwidth (the first pass, kept)
    BANDWIDTH = "bandwidth"
    #: the minimax map-back amplification of the identified modes (:func:`minimax_pole`)
    DYNAMICS = "dynamics"


class PoleRule(str, enum.Enum):
    """Which way :func:`decide_pole` took to its pole (the typed counterpart of
    ``options["a_rule"]``)."""

    #: a number, used as given
    GIVEN = "given"
    #: ``a="bandwidth"``: half the data bandwidth, one pass
    BANDWIDTH = "bandwidth"
    #: ``a=None``: half the data bandwidth, its modes well conditioned there (one pass)
    CONDITIONED = "conditioned"
    #: ``"dynamics"`` on several records, a time series or non-uniform samples: a change
    #: could not be screened, the first pass is kept
    NOT_SCREENABLE = "not screenable"
    #: the first pass's modes ask for its own pole
    FIRST_PASS_ASKED = "first pass asked for"
    #: the fit at the modes' pole failed: the first pass is kept
    REFIT_FAILED = "refit failed"
    #: from the modes, better in-sample by more than one SE
    SCREEN_WON = "screen won"
    #: the in-sample screen did not prove the change (its :class:`CheckReason
    #: <hdpbsid.bases.operator_scale.CheckReason>` says how): the first pass is kept
    FIRST_PASS_KEPT = "first pass kept"


@dataclass(frozen=True)
class PolePolicy:
    """The default pole's one setting (:func:`decide_pole` with ``a=None``).

    Attributes
    ----------
    max_amplification : float
        The largest map-back amplification (:func:`map_back_amplification`) of the first
        pass's modes at the bandwidth pole that keeps that pole without a second pass.

    Examples
    --------
    >>> POLE_POLICY.max_amplification
    10.0
    """

    #: the largest map-back amplification ``max_i g(a0, lambda_i)`` of the first pass's
    #: modes at which the bandwidth pole is kept without a second pass: ``g`` is the
    #: factor from an index-domain eigenvalue's absolute error to the relative error of
    #: ``lambda``, so above 10 the map back loses a decimal digit of the index-domain
    #: estimate, and ``g = 1/|mu -+ 1|`` to first order: the mode lies within a tenth of
    #: the point where the map back is singular.  A pole inside the band (``a`` between
    #: the slowest and fastest mode) keeps ``g`` of a well-damped set of modes of one
    #: decade near ``(sqrt(10) + 1/sqrt(10))/2 + 1 ~ 2.7``
    max_amplification: float = 10.0


#: the default :class:`PolePolicy`
POLE_POLICY = PolePolicy()


@dataclass(frozen=True)
class LaguerrePole:
    """The Laguerre pole ``a`` (rad per time unit), where it came from, and why.

    Attributes
    ----------
    a : float
        The pole, ``> 0``.
    source : PoleSource
        Where it came from.
    reason : str
        The text for ``model.options["a_rule"]``.
    passes : tuple of float
        The pole of every fit made, the first pass's first.
    rule : PoleRule or None
        The way taken (typed; None for a pole made by hand).
    check : AlphaCheck or None
        The in-sample screen of a change, when one was made.

    Examples
    --------
    >>> pole = LaguerrePole(2.0, PoleSource.GIVEN, "given", (2.0,), PoleRule.GIVEN)
    >>> pole.options()
    {'a_rule': 'given'}
    """

    a: float
    source: PoleSource
    reason: str
    passes: tuple[float, ...] = ()
    rule: PoleRule | None = None
    check: AlphaCheck | None = None

    def options(self) -> dict[str, Any]:
        """The model options of the pole.

        Returns
        -------
        dict
            ``a_rule`` (the reason's text), and ``a_source`` when the pole was asked of the
            dynamics (``a="dynamics"``).
        """
        if self.rule in (None, PoleRule.GIVEN, PoleRule.BANDWIDTH):
            return {"a_rule": self.reason}
        return {"a_rule": self.reason, "a_source": self.source.value}


def map_back_amplification(a: float, eigenvalues: Any) -> NDArray[np.float64]:
    r"""The factor from an index-domain eigenvalue's absolute error to the relative error of
    ``lambda``.

    ``lambda = a (mu + 1) / (mu - 1)`` has ``d lambda / d mu = -(lambda - a)^2 / (2 a)``,
    so an error ``delta`` of ``mu`` moves ``lambda`` by ``g(a, lambda) |lambda| delta``
    (module docstring).

    Parameters
    ----------
    a : float
        The Laguerre pole, ``> 0``.
    eigenvalues : array_like of complex
        Continuous-time eigenvalues, non-zero.

    Returns
    -------
    ndarray of float
        ``g(a, lambda) = |lambda - a|^2 / (2 a |lambda|)`` per eigenvalue.

    Notes
    -----
    .. math::

        g(a, \lambda) = \frac{|\lambda - a|^2}{2 a |\lambda|}
        = \frac{1}{2}\Bigl(\frac{a}{|\lambda|} + \frac{|\lambda|}{a}\Bigr) + \zeta,
        \qquad \zeta = -\frac{\operatorname{Re}\lambda}{|\lambda|} .

    References
    ----------
    .. [1] B. Wahlberg, "System identification using Laguerre models", *IEEE Trans.
       Automatic Control* 36(5), 551-562, 1991.

    Examples
    --------
    >>> float(map_back_amplification(2.0, [-2.0])[0])  # a = |lambda|: 1 + zeta
    2.0
    """
    lam = np.asarray(eigenvalues, dtype=complex)
    return np.abs(lam - a) ** 2 / (2.0 * a * np.abs(lam))


def minimax_pole(eigenvalues: Any) -> float | None:
    """The pole ``a`` minimising the largest map-back amplification over the eigenvalues.

    Each ``g(., lambda_i)`` (:func:`map_back_amplification`) is a convex function of ``log
    a`` symmetric about ``log |lambda_i|``, so the minimiser of their maximum lies between
    the smallest and the largest ``|lambda_i|``; it is searched on a geometric grid of
    :data:`~hdpbsid.bases.operator_scale.GRID_PER_DECADE` points per decade there.  One
    mode gives ``a = |lambda|``; equal damping ratios give the geometric mean.

    Parameters
    ----------
    eigenvalues : array_like of complex
        Continuous-time eigenvalues (zero and non-finite ones are ignored).

    Returns
    -------
    float or None
        The pole, or None when no eigenvalue is non-zero and finite.

    References
    ----------
    .. [1] B. Wahlberg, "System identification using Laguerre models", *IEEE Trans.
       Automatic Control* 36(5), 551-562, 1991.
    .. [2] B. Ninness and F. Gustafsson, "A unifying construction of orthonormal bases for
       system identification", *IEEE Trans. Automatic Control* 42(4), 515-521, 1997.

    Examples
    --------
    >>> round(minimax_pole([-1.0, -100.0]), 1)  # equal damping: the geometric mean
    10.0
    """
    lam = np.asarray(eigenvalues, dtype=complex).ravel()
    lam = lam[np.isfinite(lam) & (np.abs(lam) > 0)]
    if lam.size == 0:
        return None
    w = np.abs(lam)
    lo, hi = float(w.min()), float(w.max())
    k = max(2, int(np.ceil(OPERATOR_SCALE.grid_per_decade * np.log10(hi / lo))) + 1)
    grid = np.geomspace(lo, hi, k)
    worst = np.max(np.abs(lam[None, :] - grid[:, None]) ** 2 / (2 * grid[:, None] * w), axis=1)
    return float(grid[int(np.argmin(worst))])


def pole_from_dynamics(
    fit: Callable[[float], Any],
    a0: float,
    band: tuple[float, float],
    record: tuple | None,
    first_model: Any = None,
) -> tuple[LaguerrePole, Any]:
    """The Laguerre pole chosen from the identified dynamics (module docstring), and the
    model fitted with it.

    Parameters
    ----------
    fit : callable
        ``fit(a)`` identifies the model with pole ``a`` (a
        :class:`~hdpbsid.models.model.StateSpaceModel`).
    a0 : float
        The first pass's pole (half the data bandwidth).
    band : tuple of float
        ``(w_lo, w_hi)``: modes with ``|lambda|`` outside it do not set the pole.
    record : tuple or None
        ``(t, u, y)`` of the single record with an input the models are screened on
        (:func:`~hdpbsid.bases.operator_scale.in_sample_screen`); None (several records,
        a time series) or a non-uniformly sampled record keeps ``a0``: a change could
        not be screened (simulating a time series is no test, and the screen does not
        score non-uniform samples).
    first_model : model, optional
        The fit at ``a0`` when the caller has it already.

    Returns
    -------
    tuple of (LaguerrePole, model)
        The pole with its source and reason, and the model fitted with it.
    """
    model0 = fit(a0) if first_model is None else first_model
    first = f"half the data bandwidth ({a0:.4g})"
    if record is None or not is_uniform(np.asarray(record[0], dtype=float)):
        why = "; kept: several records, no input or non-uniform samples, where a change "
        text = first + why + "could not be screened"
        return LaguerrePole(a0, PoleSource.BANDWIDTH, text, (a0,), PoleRule.NOT_SCREENABLE), model0
    a, model, passes, failed = _pole_passes(fit, a0, model0, band)
    w_lo, w_hi = band
    rule = (
        f"minimax map-back amplification max_i |lambda_i - a|^2 / (2 a |lambda_i|) over "
        f"the modes with {w_lo:.3g} <= |lambda| <= {w_hi:.3g} (over the band's edges for "
        f"a model with a mode outside it), from a first pass at {first}"
    )
    if a == a0:
        # the text predates the typed rule: a failed refit also reads "its modes ask for it"
        kind = PoleRule.REFIT_FAILED if failed else PoleRule.FIRST_PASS_ASKED
        text = first + "; its modes ask for it"
        return LaguerrePole(a0, PoleSource.BANDWIDTH, text, passes, kind), model0
    check = OPERATOR_SCALE.in_sample_screen(model0, model, record, (a0, a))
    if not check.take_new:
        text = (
            f"{first}; {rule} gave {a:.4g}, not better in-sample by more than one SE ({check.how})"
        )
        kept = LaguerrePole(a0, PoleSource.BANDWIDTH, text, passes, PoleRule.FIRST_PASS_KEPT, check)
        return kept, model0
    text = f"{rule} ({check.how})"
    return LaguerrePole(a, PoleSource.DYNAMICS, text, passes, PoleRule.SCREEN_WON, check), model


def _pole_passes(
    fit: Callable[[float], Any], a0: float, model0: Any, band: tuple[float, float]
) -> tuple[float, Any, tuple[float, ...], bool]:
    """The fits at the minimax pole of the last model's modes until the pole settles
    (within :data:`~hdpbsid.bases.operator_scale.SETTLED`, at most
    :data:`~hdpbsid.bases.operator_scale.MAX_PASSES` refits).  Returns the pole of the
    model in hand, that model, the pole of every fit tried (a failed one included) and
    whether the last fit failed."""
    a, model, passes = a0, model0, [a0]
    for _ in range(OPERATOR_SCALE.max_passes):
        new = minimax_pole(_guide_modes(model, a0, band))
        if new is None or abs(new - a) <= OPERATOR_SCALE.settled * a:
            break
        a = new
        passes.append(a)
        try:
            model = fit(a)
        except (ValueError, np.linalg.LinAlgError):
            return passes[-2], model, tuple(passes), True  # the pole of the model in hand
    return a, model, tuple(passes), False


def decide_pole(
    asked: float | str | None, a0: float, fit: Callable[[float], Any], records: Sequence[Any]
) -> tuple[LaguerrePole, Any]:
    """The Laguerre pole of a method, one decision from the user's ``a``.

    A number is used as given; ``"bandwidth"`` takes ``a0`` (half the data bandwidth, so
    the pole sits inside the excited band); ``"dynamics"`` asks the identified modes
    (:func:`pole_from_dynamics`), the change screened on the single record with an
    input; None (the default) takes ``a0`` when the first pass's modes are well
    conditioned there -- their largest map-back amplification
    (:func:`map_back_amplification`) at most :attr:`PolePolicy.max_amplification` -- and
    asks the modes otherwise.  The second pass is thus spent only where the bandwidth
    pole provably magnifies the index-domain errors (a stiff record, whose slow modes it
    maps next to ``-1``); elsewhere the in-sample screen of a change, which a feedback
    loop biases (the simulation error of a closed-loop record favours the model that
    follows the loop's noise), is not run at all.

    Parameters
    ----------
    asked : float, "bandwidth", "dynamics" or None
        The user's ``a`` (a number validated by the method).
    a0 : float
        Half the data bandwidth (rad per time unit).
    fit : callable
        ``fit(a)`` identifies the model with pole ``a``.
    records : sequence of Record
        The records (``t``, ``u``, ``y``); the first is screened when it is the only one
        and has an input.

    Returns
    -------
    tuple of (LaguerrePole, model)
        The pole with its typed rule and texts (:meth:`LaguerrePole.options`), and the
        model fitted with it.

    Examples
    --------
    >>> pole, model = decide_pole(2.0, 1.0, lambda a: f"fit at {a}", [])
    >>> pole.rule, model
    (<PoleRule.GIVEN: 'given'>, 'fit at 2.0')
    """
    if asked == "bandwidth":
        text = "half the data bandwidth"
        return LaguerrePole(a0, PoleSource.BANDWIDTH, text, (a0,), PoleRule.BANDWIDTH), fit(a0)
    if not isinstance(asked, str) and asked is not None:
        a = float(asked)
        return LaguerrePole(a, PoleSource.GIVEN, "given", (a,), PoleRule.GIVEN), fit(a)
    band = dynamics_band(records)
    one = records[0] if len(records) == 1 and records[0].u.shape[1] else None
    record = None if one is None else (one.t, one.u, one.y)
    if asked is None:
        return _conditioned_pole(fit, a0, band, record)
    return pole_from_dynamics(fit, a0, band, record)


def _guide_modes(model: Any, a0: float, band: tuple[float, float]) -> NDArray[np.complex128]:
    """The modes that set the pole: the model's, or the band's edges for a model with a
    mode outside the band the samples resolve.

    Such a model is no guide to the modes; the pole that balances the band's edges (the
    slowest and the fastest mode the data could show, the data bandwidth ``2 a0`` at most)
    stands in for them."""
    w_lo, w_hi = band
    lam = np.linalg.eigvals(model.A)
    inside = (np.abs(lam) >= w_lo) & (np.abs(lam) <= w_hi)
    edges = np.array([-w_lo, -min(2.0 * a0, w_hi)], dtype=complex)
    return lam[inside] if np.all(inside) else edges


def _conditioned_pole(
    fit: Callable[[float], Any], a0: float, band: tuple[float, float], record: tuple | None
) -> tuple[LaguerrePole, Any]:
    """The default pole: half the data bandwidth, unless the first pass's modes are
    ill-conditioned there (:attr:`PolePolicy.max_amplification`), when the pole is asked of
    the dynamics (:func:`pole_from_dynamics`, its change screened as there)."""
    model0 = fit(a0)
    g = float(np.max(map_back_amplification(a0, _guide_modes(model0, a0, band))))
    if g <= POLE_POLICY.max_amplification:
        text = (
            f"half the data bandwidth ({a0:.4g}); the map-back amplification of its modes, "
            f"{g:.3g}, is at most {POLE_POLICY.max_amplification:g}"
        )
        return LaguerrePole(a0, PoleSource.BANDWIDTH, text, (a0,), PoleRule.CONDITIONED), model0
    return pole_from_dynamics(fit, a0, band, record, first_model=model0)


def dynamics_band(records: Any) -> tuple[float, float]:
    """The band of modes the samples resolve, which may set the Laguerre pole
    (:func:`pole_from_dynamics`).

    The lower edge is ``2 pi / T`` of the longest record (one period of the slowest
    component it resolves), the upper edge the Nyquist frequency of the coarsest median
    sampling step (a mode beyond it is no mode of the samples).  Both are limits of the
    samples, not of the output's spectrum: the share of the output energy below a
    frequency is set by the input's spectrum and by how much each mode reaches the output,
    not by where the modes are.  A stiff record driven by fast steps has nearly all its
    output energy near the fast mode while its slow pair, a small share of the energy, is
    determined at a high signal-to-noise ratio; a lower edge at an energy quantile (as
    HD-PBSID's operator scale uses for its ``alpha``,
    :data:`~hdpbsid.bases.operator_scale.MODE_ENERGY_FRACTION`) then lies above that
    pair.  It matters where the first pass at the bandwidth pole resolves the pair least:
    its slow modes then come out as a spurious mode beyond the Nyquist frequency, the
    band's edges stand in for the modes (:func:`_guide_modes`), and a lower edge above
    the pair puts the next pole too high to resolve it either.  A spurious mode inside
    this wider band can pull the pole away; the in-sample screen of the change
    (:func:`pole_from_dynamics`) then judges it.

    Parameters
    ----------
    records : sequence of Record
        Objects with ``t`` (times, s).

    Returns
    -------
    w_lo : float
        Lower edge (rad/s).
    w_hi : float
        Upper edge (rad/s).

    Examples
    --------
    >>> import numpy as np
    >>> from types import SimpleNamespace
    >>> rec = SimpleNamespace(t=np.arange(1001) * 0.01)
    >>> [round(w, 4) for w in dynamics_band([rec])]
    [0.6283, 314.1593]
    """
    longest = max(float(r.t[-1] - r.t[0]) for r in records)
    step = max(float(np.median(np.diff(r.t))) for r in records)
    return 2 * np.pi / longest, float(np.pi / step)
