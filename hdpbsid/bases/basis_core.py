"""The PBSID core on the coefficient rows of a basis method's blocks, and its default rules.

:func:`run_core` scales the rows to unit RMS, eliminates the pseudo-input rows (boundary
and truncation terms, different in every block) from every least-squares step
(:func:`hdpbsid.core.blocks.pbsid_core_blocks`), chooses the past window by the AIC of
the VARX fit (:func:`default_past_window`, a :class:`PastWindow` with a typed reason) and
scales the result back to the user's units.  :func:`best_hold` chooses the input hold of
the projection by the same criterion (:func:`hold_criterion`).  The rules' constants are
the fields of :class:`CoreRules`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.memo import past_window_aic, varx_stage
from hdpbsid.core.blocks import BlockLag, BlockPseudo, best_window, pbsid_core_blocks
from hdpbsid.core.pbsid import CoreResult

__all__ = [
    "CoreRules",
    "CORE",
    "BasisTooSmall",
    "CoreOut",
    "WindowReason",
    "PastWindow",
    "default_past_window",
    "window_criteria",
    "hold_criterion",
    "best_hold",
    "run_core",
    "P_DEFAULT_RANGE",
    "COLS_PER_REGRESSOR",
    "RIDGE_FLOOR",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class CoreRules:
    """The default rules of :func:`run_core`, each with its reason.

    Parameters
    ----------
    p_default_range : tuple of int, optional
        Past windows tried by the AIC rule.
    cols_per_regressor : int, optional
        Basis coefficients per VARX regressor and output kept by the default window.
    ridge_floor : float, optional
        Lower bound of the GCV ridge relative to the largest singular value.
    selection_rows : int, optional
        Rows of ``Gamma L`` the default window gives a selected order.

    Examples
    --------
    >>> CoreRules().p_default_range
    (2, 4)
    """

    #: default past windows tried by the AIC rule.  Every lag adds ``m + q + l``
    #: regressors per output; over a wider range (up to 6) AIC chose windows of 5-6 on
    #: closed-loop records, where the basis-domain VARX was poorly determined and the
    #: models spread more (the Laguerre projection broke down at high SNR), while
    #: open-loop records are as accurate with 2..4
    p_default_range: tuple[int, int] = (2, 4)
    #: basis-domain "samples" per VARX regressor and output kept by the default p rule
    #: (a precision rule: the VARX variance grows like ``1 / (N_b - p d)``)
    cols_per_regressor: int = 6
    #: lower bound of the GCV ridge parameter relative to the largest singular value of
    #: the VARX regressors: projected data are exact only to the quadrature/interpolation
    #: precision (~1e-5..1e-4 relative), and on noise-free closed-loop data GCV picks 0,
    #: letting near-collinear regressors (u ~ controller(y)) blow the VARX up; a floor
    #: below that precision costs no accuracy and keeps those directions damped
    ridge_floor: float = 1e-6
    #: rows of ``Gamma L`` (``f l``) the default window gives when the order is
    #: selected: orders 1 and 2 to choose from (``max_order <= f l - 1``)
    selection_rows: int = 3


#: the rules :func:`run_core` uses
CORE = CoreRules()
#: the fields of :data:`CORE` under their former names
P_DEFAULT_RANGE = CORE.p_default_range
COLS_PER_REGRESSOR = CORE.cols_per_regressor
RIDGE_FLOOR = CORE.ridge_floor


def _rms_rows(W: Array, name: str) -> Array:
    r = np.sqrt(np.mean(W**2, axis=1))
    if np.any(r == 0):
        k = int(np.flatnonzero(r == 0)[0])
        raise ValueError(f"{name}[:, {k}] is identically zero: nothing to identify from it")
    return r


class BasisTooSmall(ValueError):
    """The default past-window rule cannot give the requested order a window.

    The order needs ``p >= p_needed`` (``f l >= n`` rows of ``Gamma L``), the precision
    rule ``p (m + q + l) <= N / 6`` allows less; the VARX is still determined up to
    ``p_max``.  A caller that must answer at that order (the user asked for it) may pass
    ``p=p_needed`` when ``p_needed <= p_max``: a less precise model, not none.

    Parameters
    ----------
    message : str
        The error message.
    p_needed : int
        The smallest window the order needs.
    p_max : int
        The largest window for which the VARX is determined.

    Attributes
    ----------
    p_needed : int
        As above.
    p_max : int
        As above.
    """

    def __init__(self, message: str, p_needed: int, p_max: int) -> None:
        super().__init__(message)
        self.p_needed, self.p_max = p_needed, p_max


@dataclass
class CoreOut:
    """Core result in the basis domain, scaled back to the user's units.

    Attributes
    ----------
    A : ndarray, shape (n, n)
        The index-domain ``A'``.
    B : ndarray, shape (n, m)
        Input matrix of the real inputs (user units).
    C : ndarray, shape (l, n)
        Output matrix (user units).
    D : ndarray, shape (l, m)
        Feedthrough (user units).
    K : ndarray, shape (n, l)
        Predictor gain (user units).
    B_pseudo : ndarray, shape (n, 0)
        Empty: the pseudo-inputs' coefficients differ per block and are eliminated, not
        reported.
    noise_covariance : ndarray, shape (l, l)
        Innovation covariance (user units).
    core : CoreResult
        The core's own result (normalised units).
    options : dict
        The core's options and the window rules.
    window : PastWindow or None
        The past window and its typed reason (None when the core does not report one).
    """

    A: Array
    B: Array
    C: Array
    D: Array
    K: Array
    B_pseudo: Array
    noise_covariance: Array
    core: CoreResult
    options: dict
    window: PastWindow | None = None


def _largest_determined_p(nb: int, d: int, ncols: int, z: int) -> int:
    """Largest past window ``p`` for which the VARX least squares is determined: in the
    tightest block of ``nb`` columns, ``p d`` regressors (``d = m + q + l``) and ``p``
    columns lost to the lags leave more equations than unknowns, ``p d < nb - p``; over
    all ``ncols`` columns, ``p z < ncols - p`` (``z = m + l``)."""
    return int(max(0, min((nb - 1) // (d + 1), (ncols - 1) // (z + 1))))


@dataclass
class _Scaled:
    """The core's rows scaled to unit RMS (``normalize``) and the sizes of the tightest
    block: ``nb`` columns for ``d = m + q_b + l`` regressor rows per lag, ``p_cap`` the
    largest past window of the default rule ``p d <= nb / 6`` (:func:`run_core`)."""

    Uz: Array
    Yz: Array
    su: Array
    sy: Array
    pseudo: BlockPseudo | None
    qs: list[int]
    nb: int
    d: int
    worst: int
    p_cap: int


def _scaled(
    U: Array, Y: Array, P: Sequence[Array] | None, lag: BlockLag, normalize: bool
) -> _Scaled:
    m, l = U.shape[0], Y.shape[0]
    su = _rms_rows(U, "u") if (normalize and m) else np.ones(m)
    sy = _rms_rows(Y, "y") if normalize else np.ones(l)
    pseudo = BlockPseudo(lag, P) if P is not None else None
    qs = [0] * len(lag.sizes)
    if pseudo is not None:
        for _, _, bs, _, Pn in pseudo.groups:
            for b in bs:
                qs[b] = Pn.shape[0]
    # the tightest block: fewest columns per (m + q_b + l) regressor rows
    worst = int(np.argmin([n / (m + q + l) for n, q in zip(lag.sizes, qs, strict=True)]))
    nb, d = lag.sizes[worst], m + qs[worst] + l
    ncols = Y.shape[1]
    k = COLS_PER_REGRESSOR
    p_cap = min(nb // (k * d), ncols // (k * (m + l)))
    return _Scaled(U / su[:, None], Y / sy[:, None], su, sy, pseudo, qs, nb, d, worst, p_cap)


def window_criteria(
    sc: _Scaled,
    lag: BlockLag,
    P: Sequence[Array] | None,
    feedthrough: bool,
    p_range: tuple[int, int] | None,
    hi: int,
) -> Array:
    """AIC of the VARX fit for every past window from the lower end of the preferred
    range (``p_range``, default :data:`P_DEFAULT_RANGE`) to ``hi``, on the scaled rows
    ``sc`` (:func:`hdpbsid.core.blocks.select_past_window_blocks`, memoised: one
    computation for every order of a sweep and for the input-hold decision); ``inf``
    below the range.

    Parameters
    ----------
    sc : _Scaled
        The scaled rows (:func:`run_core`).
    lag : BlockLag
        The block lag.
    P : sequence of ndarray or None
        Pseudo-input rows per block.
    feedthrough : bool
        Include ``D u_k``.
    p_range : tuple of int or None
        The preferred range.
    hi : int
        The largest window.

    Returns
    -------
    ndarray, shape (hi,)
        The criterion of the windows ``1..hi``.
    """
    lo = (p_range if p_range is not None else P_DEFAULT_RANGE)[0]
    _, crit = past_window_aic(sc.Uz, sc.Yz, hi, min(lo, hi), lag, P, feedthrough)
    return np.asarray(crit)


def hold_criterion(
    U: Array,
    Y: Array,
    P: Sequence[Array] | None,
    lag: BlockLag,
    *,
    p: int | None = None,
    p_range: tuple[int, int] | None = None,
    feedthrough: bool = False,
    normalize: bool = True,
    **_: Any,
) -> float:
    """The input-hold criterion of the input rows ``U``: the smallest AIC of the VARX fit.

    The VARX of ``Y`` on the past of ``U, Y`` (pseudo-input rows ``P`` eliminated) over the
    past windows of the default rule (:func:`run_core`: the preferred range capped at ``p
    (m + q + l) <= N / 6``), or at the given ``p``.  ``AIC = N log det Sigma + 2 l d``
    compares the holds directly: both projections regress the same output rows with the
    same number of coefficients, so at each window the AIC difference is ``N`` times the
    log-ratio of the innovation determinants, and the minimum over the windows chooses the
    hold and the window jointly.  The VARX is the order-free first step of the core, so the
    decision does not depend on the order (the hold is a property of the record), and every
    order of a sweep shares it.

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Input rows of one hold.
    Y : ndarray, shape (l, N)
        Output rows.
    P : sequence of ndarray or None
        Pseudo-input rows per block.
    lag : BlockLag
        The block lag.
    p : int, optional
        A given past window.
    p_range : tuple of int, optional
        The preferred range (default :data:`P_DEFAULT_RANGE`).
    feedthrough : bool, optional
        Include ``D u_k``.
    normalize : bool, optional
        Scale the rows to unit RMS.
    _ : any
        Other core options, ignored (the caller passes them all).

    Returns
    -------
    float
        The criterion; ``inf`` when no window fits.

    References
    ----------
    .. [1] H. Akaike, "A new look at the statistical model identification", *IEEE Trans.
       Automatic Control* 19(6), 716-723, 1974.
    """
    sc = _scaled(U, Y, P, lag, normalize)
    if p is not None:
        lo = hi = p
        if p * sc.d >= sc.nb - p:
            return float("inf")
    else:
        lo, hi = p_range if p_range is not None else P_DEFAULT_RANGE
        hi = min(hi, sc.p_cap)
        if hi < max(lo, 1):
            return float("inf")
    _, crit = past_window_aic(sc.Uz, sc.Yz, hi, lo, lag, P, feedthrough)
    crit = np.asarray(crit)[lo - 1 : hi]
    return float(np.min(crit)) if crit.size else float("inf")


class WindowReason(str, Enum):
    """Why the past window ``p`` of :func:`run_core` is what it is."""

    #: the user's ``p``
    GIVEN = "given"
    #: the order needs more rows of ``Gamma L`` (``f l >= n``) than the preferred range
    #: gives: the smallest window that shows it
    ORDER_NEEDS = "order needs"
    #: the smallest AIC of the VARX fit over the preferred range (or its only window)
    AIC = "min AIC"
    #: the window the held-out selection's candidate chose on the estimation part, kept
    #: by its refit on the whole record (:func:`hdpbsid.selection.auto.refit_keeps`)
    KEPT = "kept from the candidate"


@dataclass(frozen=True)
class PastWindow:
    """The past window of the core, its reason and the criterion it was chosen by.

    Parameters
    ----------
    value : int
        The past window ``p``.
    reason : WindowReason
        Why (typed).
    text : str
        The rule's text (``options["p_rule"]``).
    criterion : ndarray or None
        The AIC of every window ``1..hi`` (``inf`` below the range) when windows were
        compared, else None.

    Examples
    --------
    >>> PastWindow(3, WindowReason.GIVEN, "given").value
    3
    """

    value: int
    reason: WindowReason
    text: str
    criterion: Array | None = None


def _given_window(sc: _Scaled, p: int, f: int | None, order: int | None, l: int) -> PastWindow:
    """The user's ``p``, checked: the VARX must be determined in the tightest block, and
    ``f = p`` must give the order its rows of ``Gamma L``."""
    need = order if order is not None else CORE.selection_rows
    if p * sc.d >= sc.nb - p:
        raise ValueError(
            f"p={p} is too large for the basis: the VARX has p*(m+q+l) = {p}*{sc.d} = "
            f"{p * sc.d} regressors per output (q = {sc.qs[sc.worst]} boundary/truncation "
            f"rows) but only {sc.nb} basis coefficients in block {sc.worst}; reduce p or "
            f"increase N"
        )
    if f is None and p * l < need:
        raise ValueError(
            f"order {order if order is not None else 'selection'} needs f*l >= {need}, "
            f"but f = p = {p}; increase p"
        )
    return PastWindow(p, WindowReason.GIVEN, "given")


def _too_small(sc: _Scaled, lo: int, ncols: int, z: int) -> BasisTooSmall:
    """The error of a default window that the precision rule cannot give the order."""
    p_max = _largest_determined_p(sc.nb, sc.d, ncols, z)
    return BasisTooSmall(
        f"the basis is too small for the requested order by the default rule: "
        f"it needs a past window p >= {lo}, but N = {sc.nb} coefficients and "
        f"m+q+l = {sc.d} rows give p <= {sc.p_cap} by p*(m+q+l) <= "
        f"N/{COLS_PER_REGRESSOR}; the VARX is determined up to p = {p_max} "
        f"(p*(m+q+l) < N - p): pass p explicitly (less precise), increase N, or "
        f"ask for a smaller order",
        lo,
        p_max,
    )


def default_past_window(
    sc: _Scaled,
    lag: BlockLag,
    P: Sequence[Array] | None,
    *,
    f: int | None,
    order: int | None,
    feedthrough: bool,
    p_range: tuple[int, int] | None,
) -> PastWindow:
    """The default past window of :func:`run_core` (its rule).

    Parameters
    ----------
    sc : _Scaled
        The scaled rows and the sizes of the tightest block.
    lag : BlockLag
        The block lag.
    P : sequence of ndarray or None
        Pseudo-input rows per block.
    f : int or None
        A given future window (the window is at least ``f``).
    order : int or None
        The order (None: selected; the window then gives
        :attr:`CoreRules.selection_rows` rows of ``Gamma L``).
    feedthrough : bool
        Include ``D u_k`` in the VARX.
    p_range : tuple of int or None
        The preferred range (default :data:`P_DEFAULT_RANGE`).

    Returns
    -------
    PastWindow
        The window and its reason.

    Raises
    ------
    BasisTooSmall
        If the precision rule cannot give the order a window.
    """
    l, ncols = sc.Yz.shape
    need = order if order is not None else CORE.selection_rows
    lo, hi = p_range if p_range is not None else P_DEFAULT_RANGE
    lo = max(lo, -(-need // l), f or 1)
    hi = min(hi, sc.p_cap)
    if hi < lo:
        if lo > sc.p_cap:
            raise _too_small(sc, lo, ncols, sc.Uz.shape[0] + l)
        text = (
            f"p = {lo}, the smallest window with f*l >= the order (above the preferred "
            f"range {P_DEFAULT_RANGE if p_range is None else p_range}; "
            f"p*(m+q+l) <= N/{COLS_PER_REGRESSOR})"
        )
        return PastWindow(lo, WindowReason.ORDER_NEEDS, text)
    text = (
        f"min AIC of the VARX fit over p in [{lo}, {hi}] "
        f"(p*(m+q+l) <= N/{COLS_PER_REGRESSOR}, f*l >= required rows)"
    )
    if hi == lo:
        return PastWindow(lo, WindowReason.AIC, text)
    # the criterion of every window of the range, shared by all orders and by the
    # input-hold decision (hold_criterion); this order may use p >= lo
    crit = window_criteria(sc, lag, P, feedthrough, p_range, hi)
    crit = np.where(np.arange(1, hi + 1) >= lo, crit, np.inf)
    return PastWindow(best_window(crit, lo, hi, ncols), WindowReason.AIC, text, crit)


def _future_window(f: int | None, p: int, order: int | None, l: int, max_order: int):
    """The future window used and the largest order of a selection (None: order given),
    checked against ``p`` and the order."""
    need = order if order is not None else CORE.selection_rows
    if f is not None and f > p:
        raise ValueError(f"the future window f must satisfy f <= p, got f={f} > p={p}")
    if f is not None and f * l < need:
        raise ValueError(f"order needs f*l >= {need}, but f*l = {f * l}; increase f")
    f_used = p if f is None else f
    mo = min(max_order, f_used * l - 1) if order is None else None
    if mo is not None and mo < 1:
        raise ValueError("order selection needs f*l >= 2; increase p/f or pass an order")
    return f_used, mo


def _core_options(
    core: CoreResult, sc: _Scaled, window: PastWindow, f_given: bool, normalize: bool, blocks: int
) -> dict[str, Any]:
    """The core's options with the scaling and the window rules of :func:`run_core`."""
    opts: dict[str, Any] = dict(core.options)
    opts.update(
        {
            "normalize": normalize,
            "input_scale": sc.su,
            "output_scale": sc.sy,
            "p_rule": window.text,
            "p_criterion_values": window.criterion,
            "f_rule": "given" if f_given else "f = p",
            "n_pseudo_inputs": sc.pseudo.count if sc.pseudo is not None else 0,
            "n_blocks": blocks,
        }
    )
    return opts


def _user_units(core: CoreResult, sc: _Scaled, m: int) -> tuple[Array, Array, Array, Array, Array]:
    """``B, C, D, K`` and the innovation covariance of the core scaled back to the user's
    units (the rows were divided by ``su``, ``sy``)."""
    su, sy = sc.su, sc.sy
    B = core.B[:, :m] / su[None, :] if m else core.B[:, :0]
    C = core.C * sy[:, None]
    D = (sy[:, None] * core.D[:, :m] / su[None, :]) if m else core.D[:, :0]
    K = core.K / sy[None, :]
    ncov = sy[:, None] * core.noise_covariance * sy[None, :]
    return B, C, D, K, ncov


def best_hold(
    holds: tuple[str, ...],
    Us: list[Array],
    Y: Array,
    P: Sequence[Array] | None,
    lag: BlockLag,
    hold_range: tuple[int, int] | None = None,
    **core_options: Any,
) -> tuple[CoreOut, str, dict[str, float]]:
    """:func:`run_core` on the input projection with the smallest :func:`hold_criterion`.

    The wrong hold leaves a deterministic misfit in the innovations (on noise-free data the
    right one wins by orders of magnitude), so the AIC of the order-free VARX fit tells the
    holds apart; a tie keeps the first hold listed.  One core run per call whatever the
    number of holds.

    Parameters
    ----------
    holds : tuple of str
        The holds projected.
    Us : list of ndarray, shape (m, N)
        The input rows, one per hold.
    Y : ndarray, shape (l, N)
        Output rows.
    P : sequence of ndarray or None
        Pseudo-input rows per block.
    lag : BlockLag
        The block lag.
    hold_range : tuple of int, optional
        The past windows the criterion compares over when they are not the core's
        ``p_range`` (a method whose window follows the order passes its order-free one).
    **core_options
        Keyword arguments of :func:`run_core`.

    Returns
    -------
    out : CoreOut
        The core's result on the hold chosen.
    hold : str
        The hold.
    criterion : dict of str to float
        The criterion of each hold (empty when only one was projected).
    """
    crit: dict[str, float] = {}
    if len(holds) > 1:
        judged = {**core_options, "p_range": hold_range or core_options.get("p_range")}
        crit = {h: hold_criterion(U, Y, P, lag, **judged) for h, U in zip(holds, Us, strict=True)}
    hold = min(holds, key=lambda h: (crit.get(h, 0.0), holds.index(h)))
    return run_core(Us[holds.index(hold)], Y, P, lag, **core_options), hold, crit


def run_core(
    U: Array,
    Y: Array,
    P: Sequence[Array] | None,
    lag: BlockLag,
    *,
    order: int | None,
    p: int | None,
    f: int | None,
    max_order: int,
    regularize: bool | str | float | None,
    feedthrough: bool,
    stable_k: bool,
    normalize: bool,
    p_range: tuple[int, int] | None = None,
    ridge_floor: float | None = None,
    instruments: Array | None = None,
) -> CoreOut:
    """Run the PBSID core on the coefficient rows of all blocks.

    The pseudo-inputs' factors are unknown and different in every block; they are
    eliminated from every least-squares step block by block
    (:func:`hdpbsid.core.blocks.pbsid_core_blocks`), so the regression keeps the size of
    one record's whatever the number of blocks.  Defaults: ``p`` minimises the AIC of the
    VARX fit (:func:`hdpbsid.core.blocks.select_past_window_blocks`) over ``p_range``
    (default :data:`P_DEFAULT_RANGE`), capped so that ``p (m + q_b + l) <= N_b / 6`` in
    every block; ``f = p``.

    Which limit is real: the preferred range's upper end is a variance choice, so an order
    that needs ``f l >= n`` rows of ``Gamma L`` beyond it gets ``p = ceil(n / l)``.
    ``N_b / 6`` is a precision rule (the VARX variance grows like ``1 / (N_b - p d)``) and
    stays for the default ``p``: lifting it lets held-out order selection pick orders the
    short records cannot support.  The mathematical limit is that the VARX be determined,
    ``p d < N_b - p``: an explicit ``p`` may go up to it, and the error for a default ``p``
    says so (:class:`BasisTooSmall`).

    Parameters
    ----------
    U : ndarray, shape (m, N)
        Input rows of all blocks side by side.
    Y : ndarray, shape (l, N)
        Output rows.
    P : sequence of ndarray or None
        ``P[b]`` the pseudo-input rows (``q_b x N_b``) of block ``b``.
    lag : BlockLag
        The block-diagonal lag.
    order : int or None
        Model order; None selects it.
    p : int or None
        Past window; None by the rule above.
    f : int or None
        Future window; None: ``f = p``.
    max_order : int
        Largest order of the selection.
    regularize : bool, str, float or None
        VARX regularisation (:func:`hdpbsid.core.varx.varx`).
    feedthrough : bool
        Estimate ``D``.
    stable_k : bool
        Riccati gain in place of the least-squares one.
    normalize : bool
        Scale the rows to unit RMS.
    p_range : tuple of int, optional
        The preferred range of the default window.
    ridge_floor : float, optional
        Lower bound of the GCV ridge (default :data:`RIDGE_FLOOR`: projected data are exact
        only to the quadrature precision).
    instruments : ndarray, optional
        Instrument rows on the ``N`` columns: the instrumental-variable core
        (:mod:`hdpbsid.methods.hermite_iv`).

    Returns
    -------
    CoreOut
        The basis-domain system in user units.

    Raises
    ------
    ValueError
        If an explicit ``p`` does not fit the basis, ``f`` is inconsistent with ``p`` or
        the order, order selection has fewer than 2 rows of ``Gamma L``, or a row is
        identically zero.
    BasisTooSmall
        If the default rule cannot give the order a window (a ``ValueError``).
    """
    m, l = U.shape[0], Y.shape[0]
    sc = _scaled(U, Y, P, lag, normalize)
    if p is not None:
        window = _given_window(sc, p, f, order, l)
    else:
        window = default_past_window(
            sc, lag, P, f=f, order=order, feedthrough=feedthrough, p_range=p_range
        )
    p = window.value
    f_used, mo = _future_window(f, p, order, l, max_order)
    # the order-independent VARX and SVD, shared by the orders of a sweep (memo.py)
    rf = RIDGE_FLOOR if ridge_floor is None else ridge_floor
    stage = varx_stage(sc.Uz, sc.Yz, p, lag, P, f_used, feedthrough, regularize, rf, instruments)
    core = pbsid_core_blocks(
        sc.Uz,
        sc.Yz,
        p,
        lag,
        sc.pseudo,
        stage=stage,
        f=f_used,
        order=order,
        feedthrough=feedthrough,
        regularize=regularize,
        stable_k=stable_k,
        max_order=mo,
        ridge_floor=rf,
        instruments=instruments,
    )
    B, C, D, K, ncov = _user_units(core, sc, m)
    opts = _core_options(core, sc, window, f is not None, normalize, len(lag.sizes))
    return CoreOut(core.A, B, C, D, K, np.zeros((core.A.shape[0], 0)), ncov, core, opts, window)
