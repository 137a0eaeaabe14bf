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
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import is_uniform
from hdpbsid.models.criteria import (
    MIN_WINDOWS,
    WindowedError,
    choose_smallest_adequate,
    default_windows,
    windowed_simulation_error,
)

__all__ = [
    "contraction_factor",
    "minimax_alpha",
    "alpha_from_dynamics",
    "held_out_check",
    "held_out_comparison",
    "in_sample_screen",
    "HOLDOUT",
    "GRID_PER_DECADE",
    "TRUNCATION_SLACK",
    "MAX_PASSES",
    "MODE_ENERGY_FRACTION",
    "SETTLED",
]

#: grid points per decade of the ``alpha`` search: neighbouring points differ by 1 %,
#: far below the flatness of ``max_i rho`` near its minimum
GRID_PER_DECADE = 240
#: relative excess of the truncation factor ``max_i rho_i^p`` over its minimum within
#: which the smallest ``alpha`` is taken.  A judgement, not derived: ``T`` is flat near
#: its minimum when the modes are spread, so a slack trades a little truncation for a
#: smaller ``alpha`` (less amplification of the slow modes' errors); 0 keeps the flat
#: optimum's arbitrary end, and a larger slack lets ``alpha`` fall below the fast modes
#: (chosen among 0, 2 and 5 % on the systems of bench/identify.py)
TRUNCATION_SLACK = 0.02
#: re-identifications after the first pass: the first update carries ``alpha`` from the
#: basis rule to the modes, the second corrects for the modes having been fitted at the
#: first pass's ``alpha`` and moves it much less; each pass costs one identification
MAX_PASSES = 2
#: modes slower than the frequency below which this fraction of the output energy lies
#: (above the noise floor) do not set ``alpha``: such a mode carries at most about that
#: share of the output, so its eigenvalue is poorly determined, and a spurious slow mode
#: would drag ``alpha`` down to it (spurious modes a decade below the band the output
#: energy occupies appear at high orders).  The output band shows where the input
#: excites, not where the modes are: records swept above their modes lose those modes
#: here and get a too large alpha, which :func:`held_out_check` then rejects
MODE_ENERGY_FRACTION = 0.01
#: share of a record held out by :func:`held_out_check` (as ``method="auto"`` does)
HOLDOUT = 1.0 / 3.0
#: relative change of ``alpha`` below which the passes stop
SETTLED = 0.05


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
    lam = np.asarray(eigenvalues, dtype=complex).ravel()
    lam = lam[np.isfinite(lam) & (lam.real != 0)]
    if lam.size == 0:
        return None
    lam = -np.abs(lam.real) + 1j * lam.imag  # unstable modes by their predictor mirror images
    w = np.abs(lam)
    lo, hi = float(w.min()), float(w.max())
    k = max(2, int(np.ceil(GRID_PER_DECADE * np.log10(hi / lo))) + 1)
    grid = np.geomspace(lo, hi, k)
    rho = np.abs(grid[:, None] + lam[None, :]) / np.abs(grid[:, None] + 1j * w[None, :])
    worst = rho.max(axis=1) ** p
    return float(grid[int(np.flatnonzero(worst <= (1.0 + TRUNCATION_SLACK) * worst.min())[0])])


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
    w_lo, w_hi = band
    alpha = float(alpha0)
    model = fit(alpha)
    path = [alpha]
    for _ in range(MAX_PASSES):
        lam = np.asarray(model.eigenvalues, dtype=complex)
        lam = lam[(np.abs(lam) >= w_lo) & (np.abs(lam) <= w_hi)]
        new = minimax_alpha(lam, int(model.report.windows.get("p", 1)))
        if new is None or abs(new - alpha) <= SETTLED * alpha:
            # settled: the current model's alpha is already within SETTLED of the one its
            # own modes ask for, so it is kept rather than refitted at the new value
            break
        alpha = new
        path.append(alpha)
        model = fit(alpha)
    info = {
        "alpha_rule": (
            "minimax contraction of the identified modes: the smallest alpha within "
            f"{TRUNCATION_SLACK:.0%} of min_alpha max_i (|alpha + lambda_i| / "
            "|alpha + i |lambda_i||)^p over the modes (unstable ones mirrored) with "
            f"{w_lo:.3g} <= |lambda| <= {w_hi:.3g} rad/s, from a first pass at "
            f"alpha = {alpha0:.4g}"
        ),
        "alpha_passes": path,
    }
    return alpha, model, info


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
    ns = t.shape[0]
    split = int(round(ns * (1.0 - HOLDOUT)))
    if default_windows(ns - split, order) < MIN_WINDOWS:
        return False, "record too short for the held-out check"
    models = []
    for a in (alpha_old, alpha_new):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                models.append(identify(t[:split], u[:split], y[:split], a))
        except (ValueError, np.linalg.LinAlgError):
            models.append(None)
    return held_out_comparison(
        models[0], models[1], (t[split:], u[split:], y[split:]), order, (alpha_old, alpha_new)
    )


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
    t, u, y = held_out
    windows = default_windows(t.shape[0], order)
    if windows < MIN_WINDOWS:
        return False, f"{label} part too short for the check"
    errs = []
    for model in (old, new):
        err = WindowedError(np.full(windows, np.inf), np.inf, -np.inf, False)
        if model is not None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    err = windowed_simulation_error(model, t, u, y, windows)
                except (ValueError, np.linalg.LinAlgError):
                    pass
        errs.append(err)
    try:
        k, stats = choose_smallest_adequate(errs)
    except ValueError:
        return False, f"neither alpha could be scored on the {label} part"
    fits = ", ".join(f"{e.fit:.4g} %" for e in errs)
    how = (
        f"{label} fit ({t.shape[0]} samples, {windows} windows) {fits} for alpha = "
        f"{alphas[0]:.4g}, {alphas[1]:.4g}; excess over the best {stats[0]:.2f} SE"
    )
    return k == 1, how


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
    if not is_uniform(record[0]):
        return True, "in-sample screen skipped (non-uniform samples)"
    order = int(np.asarray(old.A).shape[0])
    return held_out_comparison(old, new, record, order, alphas, label="in-sample")
