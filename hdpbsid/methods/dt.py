"""Method ``"dt"``: PBSID on the raw samples, then exact ZOH ``d2c``.

:func:`identify_discrete` runs the VARX-form PBSID core (:mod:`hdpbsid.core.pbsid`) on
uniformly sampled data with the sample shift as the past operator and returns the
sampled :class:`~hdpbsid.models.model.DiscreteModel`; :func:`identify_dt` adds the time axis
checks and the exact conversion to continuous time (:func:`hdpbsid.models.conversion.d2c`).

Defaults (all reported in ``model.options``):

* ``normalize=True``: each input and output channel is divided by its RMS before
  identification and the model is scaled back (eigenvalues are unaffected; this only
  balances the least-squares and SVD weighting between channels);
* ``p=None``: the past window minimising AIC of the VARX fit over ``p_min..p_max``
  (:func:`hdpbsid.core.varx.select_past_window`), where ``p_max`` keeps
  ``p (m + l) <= Ns / 10`` and ``p <= 200``, and ``p_min`` makes ``f l`` exceed the order
  (or ``max_order`` when the order is to be selected); the search stops once it covers
  three times the best window (:attr:`hdpbsid.core.varx.PastWindowPolicy.growth`);
* ``f=None``: ``f = p`` (as in the toolbox examples);
* ``order=None``: the largest log-gap of the singular values
  (:func:`hdpbsid.core.pbsid.select_order`) among orders ``1..max_order`` (default 10);
* ``feedthrough=False``: ``D = 0`` (MATLAB ``n4sid``'s default; estimating ``D`` from
  closed-loop data with a static controller is biased);
* ``regularize="gcv"``: ridge (Tikhonov) VARX with the parameter chosen by generalised
  cross validation, as the toolbox's ``'tikh', 'gcv'`` (``lam = 0`` is a candidate, so
  exact data stay exact).  Sampled fast, neighbouring samples are nearly collinear and
  the VARX regressors ill-conditioned, so plain least squares (``False``) amplifies the
  noise along the near-null directions; the ridge damps exactly those (Hansen 1998,
  sec. 4.2).  A float fixes the ridge parameter;
* ``stable_k=False``: ``K`` from least squares (``True``: Kalman gain from the Riccati
  equation with the residual covariances).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.bases.memo import memoize
from hdpbsid.core.blocks import BlockLag
from hdpbsid.core.pbsid import CoreResult, SubspaceStage, pbsid_core, subspace_stage
from hdpbsid.core.varx import (
    LagOperator,
    PastWindowChoice,
    PastWindowPolicy,
    SampleShift,
    choose_past_window,
    search_is_complete,
    select_past_window,
)
from hdpbsid.data.checks import (
    check_method_args,
    check_signal,
    check_uniform,
)
from hdpbsid.data.records import Dataset, as_records
from hdpbsid.models.model import DiscreteModel, StateSpaceModel
from hdpbsid.runtime import library_call

__all__ = ["identify_dt", "fit_dt", "identify_discrete", "default_windows", "WindowBounds"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class WindowBounds:
    """The range of the default past window of method ``"dt"`` (:func:`default_windows`).

    Attributes
    ----------
    samples_per_regressor : int
        Samples per VARX regressor per output: ``p (m + l) <= Ns / samples_per_regressor``.
    p_cap : int
        The largest default past window.

    Examples
    --------
    >>> WindowBounds().rule
    'p*(m+l) <= Ns/10, p <= 200, f*l >= required rows'
    """

    #: the VARX variance grows like ``1 / (Ns - p (m + l))``: ten samples per regressor
    #: keep it within about a tenth of the asymptotic variance ``1 / Ns``
    samples_per_regressor: int = 10
    #: the cost: the past-window criterion factors up to ``p_cap`` lags, the costliest
    #: step of a fit, and windows this long are met only on slowly sampled dead times
    p_cap: int = 200

    @property
    def rule(self) -> str:
        """The bounds as the past-window rule reports them (``options["p_rule"]``)."""
        return (
            f"p*(m+l) <= Ns/{self.samples_per_regressor}, p <= {self.p_cap}, f*l >= required rows"
        )


#: the bounds :func:`default_windows` applies
WINDOW_BOUNDS = WindowBounds()
#: samples per VARX regressor per output of the default ``p`` rule (:class:`WindowBounds`)
SAMPLES_PER_REGRESSOR = WINDOW_BOUNDS.samples_per_regressor
#: upper limit of the default past window (:class:`WindowBounds`)
P_CAP = WINDOW_BOUNDS.p_cap
#: the data-driven settings a refit of this method on a longer record keeps from the
#: candidate it reproduces (:func:`hdpbsid.selection.auto.refit_keeps`): the past and future
#: windows.  The past-window criterion is one QR of the VARX regressors over up to
#: ``P_CAP`` lags -- the costliest step of a fit -- and the held-out
#: judgement validated the candidate's predictor with its windows, not the criterion.
#: Not kept in closed loop, where the window must grow with the record.
REFIT_KEEPS = ("p", "f")


def default_windows(
    ns: int,
    m: int,
    l: int,
    order: int | None,
    max_order: int,
    p: int | None,
    f: int | None,
) -> tuple[int, int]:
    """Check the windows against the data and return the range ``(p_min, p_max)`` for ``p``.

    ``f l`` must be at least the order (``max_order + 1`` when the order is selected, so
    that a gap after every candidate exists), ``f <= p``, and the VARX needs ``p (m + l) <
    Ns - p`` (more equations than unknowns).  The default rule keeps ``p (m + l) <= Ns /
    10`` (:attr:`WindowBounds.samples_per_regressor`: the VARX variance grows like
    ``1 / (Ns - p (m + l))``) and ``p <= 200`` (:attr:`WindowBounds.p_cap`, the cost).

    Parameters
    ----------
    ns : int
        Number of samples.
    m : int
        Number of inputs.
    l : int
        Number of outputs.
    order : int or None
        The order asked for (None: selected).
    max_order : int
        Largest order of the selection.
    p : int or None
        A given past window.
    f : int or None
        A given future window.

    Returns
    -------
    p_min : int
        Smallest window to search (``p`` when given).
    p_max : int
        Largest window to search (``p`` when given).

    Raises
    ------
    ValueError
        With the numbers, when the data cannot support the requested order or windows.

    Examples
    --------
    >>> default_windows(1200, 1, 1, 2, 10, None, None)
    (2, 60)
    """
    need_rows = order if order is not None else max_order + 1
    what = f"order={order}" if order is not None else f"order selection up to {max_order}"
    f_min = -(-need_rows // l)  # ceil(need_rows / l)
    if f is not None and f * l < need_rows:
        raise ValueError(
            f"{what} needs f*l >= {need_rows}, but f*l = {f}*{l} = {f * l}; increase f"
        )
    if p is not None:
        if f is not None and f > p:
            raise ValueError(f"the future window f must satisfy f <= p, got f={f} > p={p}")
        if f is None and p * l < need_rows:
            raise ValueError(
                f"{what} needs f*l >= {need_rows}, but f = p = {p} gives f*l = {p * l}; increase p"
            )
        if p * (m + l) >= ns - p:
            raise ValueError(
                f"p={p} is too large for the data: the VARX has p*(m+l) = {p * (m + l)} "
                f"regressors per output but only Ns - p = {ns - p} samples; reduce p"
            )
        return p, p
    p_min = max(f_min, f or 1)
    bounds = WINDOW_BOUNDS
    p_max = min(bounds.p_cap, ns // (bounds.samples_per_regressor * (m + l)))
    if p_max < p_min:
        raise ValueError(
            f"the record is too short for {what}: it needs a past window p >= {p_min}, but "
            f"with Ns={ns} samples and m+l={m + l} signals the default rule "
            f"p*(m+l) <= Ns/{bounds.samples_per_regressor} allows only p <= {p_max}; supply more "
            f"data, ask for a smaller order, or pass p explicitly"
        )
    return p_min, p_max


def _rms(x: Array, name: str) -> Array:
    r = np.sqrt(np.mean(x**2, axis=0))
    if np.any(r == 0):
        k = int(np.flatnonzero(r == 0)[0])
        raise ValueError(f"{name}[:, {k}] is identically zero: nothing to identify from it")
    return r


@memoize
def _past_window_criteria(
    U: Array, Y: Array, p_max: int, feedthrough: bool, criterion: str
) -> Array:
    """The criterion of :func:`~hdpbsid.core.varx.select_past_window` for every
    ``p = 1..p_max`` (sample shift), memoised: it does not depend on the order, so an
    order selection computes it once per record."""
    return select_past_window(U, Y, p_max, p_min=1, feedthrough=feedthrough, criterion=criterion)[1]


@memoize
def _shared_subspace_stage(
    U: Array, Y: Array, p: int, f: int, feedthrough: bool, regularize: Any
) -> SubspaceStage:
    """:func:`hdpbsid.core.pbsid.subspace_stage` with the sample shift, memoised: the
    VARX fit and the SVD do not depend on the order, so the orders of an order selection
    (which all choose the same ``p`` from the same criterion) compute them once."""
    return subspace_stage(U, Y, p, f, SampleShift(), feedthrough, regularize)


@library_call
def identify_discrete(
    u: Any,
    y: Any,
    order: int | None = None,
    p: int | None = None,
    f: int | None = None,
    regularize: bool | str | float | None = "gcv",
    feedthrough: bool = False,
    stable_k: bool = False,
    normalize: bool = True,
    max_order: int | None = None,
    p_criterion: str = "aic",
    dt: float = 1.0,
    lag: LagOperator | None = None,
) -> DiscreteModel:
    """PBSID (VARX form) on uniformly sampled data; returns the sampled model.

    The pipeline of the PBSID toolbox (``dordvarx -> dmodx -> dx2abcdk``): VARX with past
    window ``p`` -> ``Gamma L`` with future window ``f`` -> SVD and state -> ``C, D`` ->
    ``A, B, K`` (:func:`hdpbsid.core.pbsid.pbsid_core`).  Each channel is scaled to unit
    RMS first when ``normalize`` (eigenvalues are unaffected; only the weighting of the
    least squares and the SVD between channels changes) and the model scaled back.  See the
    module docstring for the defaults; every value used is in ``model.options``.

    Parameters
    ----------
    u : array_like, shape (Ns, m), or None
        Inputs (None: a time series).
    y : array_like, shape (Ns, l)
        Outputs.
    order : int, optional
        Model order; None selects it (largest log-gap of the singular values up to
        ``max_order``).
    p : int, optional
        Past window; None minimises ``p_criterion`` of the VARX fit
        (:func:`hdpbsid.core.varx.select_past_window`) within :func:`default_windows`.
    f : int, optional
        Future window (default ``p``).
    regularize : bool, str or float, optional
        VARX ridge: ``"gcv"``/True (generalised cross-validation, ``lam = 0`` a candidate),
        False/``"none"``, or a ridge parameter.
    feedthrough : bool, optional
        Estimate ``D`` (biased from closed-loop data with a static controller).
    stable_k : bool, optional
        Kalman gain from the Riccati equation instead of the least-squares ``K``.
    normalize : bool, optional
        Scale the channels to unit RMS.
    max_order : int, optional
        Largest order of the selection (default 10).
    p_criterion : {"aic", "bic"}, optional
        The past-window criterion.
    dt : float, optional
        Sampling interval (time units).
    lag : LagOperator, optional
        Replaces "one sample back", e.g. a :class:`~hdpbsid.core.blocks.BlockLag` of
        sample shifts for several records side by side (no lag crosses a record edge).

    Returns
    -------
    DiscreteModel
        ``x_{k+1} = A x_k + B u_k + K e_k``, ``y_k = C x_k + D u_k + e_k`` with ``dt`` and
        its ``options``.

    Raises
    ------
    ValueError
        If ``y`` has no channel, a channel is identically zero with ``normalize``,
        ``p_criterion`` is unknown, ``dt`` is not positive and finite, or the windows do not
        fit the data (:func:`default_windows`).
    TypeError
        If ``dt`` is not a real number, or from the argument checks.

    References
    ----------
    .. [1] A. Chiuso, "The role of vector autoregressive modeling in predictor-based
       subspace identification", *Automatica* 43(6), 1034-1048, 2007.
    .. [2] J.-W. van Wingerden and M. Verhaegen, "Subspace identification of bilinear and
       LPV systems for open- and closed-loop data", *Automatica* 45(2), 372-381, 2009.

    Examples
    --------
    The lightly damped second-order system (eigenvalues ``-0.4 +- 1.9596j``) under a
    random-step input held between samples, noise-free:

    >>> from hdpbsid.systems.linear import random_steps, second_order, simulate_zoh
    >>> A, B, C, D = second_order()
    >>> t = np.arange(0.0, 60.0, 0.05)
    >>> u = random_steps(np.random.default_rng(0), t, hold=0.5)
    >>> y = simulate_zoh(A, B, C, D, t, u)

    >>> dmodel = identify_discrete(u, y, order=2, dt=0.05)
    >>> np.sort_complex(np.linalg.eigvals(dmodel.A)).round(4)  # exp(lambda dt)
    array([0.9755-0.0959j, 0.9755+0.0959j])
    """
    u, y = _signals(u, y)
    (ns, l), m = y.shape, u.shape[1]
    order, p, f, mo = check_method_args(order, p, f, max_order)
    if p_criterion not in ("aic", "bic"):
        raise ValueError(f"p_criterion must be 'aic' or 'bic', got {p_criterion!r}")
    _check_interval(dt)
    if order is None and max_order is None:
        mo = _orders_the_windows_allow(mo, f if f is not None else p, l)
    p_min, p_max = default_windows(ns, m, l, order, mo, p, f)
    su, sy = _channel_scales(u, y, normalize)
    U = (u / su).T
    Y = (y / sy).T
    window = None
    if p is None:
        policy = PastWindowPolicy(criterion=p_criterion)
        window = _past_window(U, Y, p_min, p_max, lag, feedthrough, policy)
        p = window.p
    f_rule = "given" if f is not None else "f = p"
    f = p if f is None else f
    shared = lag is None or type(lag) is SampleShift
    core = pbsid_core(
        U,
        Y,
        p,
        f=f,
        order=order,
        lag=lag,
        feedthrough=feedthrough,
        regularize=regularize,
        stable_k=stable_k,
        max_order=mo if order is None else None,
        stage=_shared_subspace_stage(U, Y, p, f, feedthrough, regularize) if shared else None,
    )
    settings = {"method": "dt", "normalize": normalize, "input_scale": su, "output_scale": sy}
    options = _options(core, settings, window, f_rule, float(dt), ns)
    if order is None:
        options["max_order"] = mo
    return _scaled_back(core, su, sy, options, float(dt))


def _options(
    core: CoreResult,
    settings: dict[str, Any],
    window: PastWindowChoice | None,
    f_rule: str,
    dt: float,
    ns: int,
) -> dict[str, Any]:
    """``model.options`` of :func:`identify_discrete`: the core's, the method's
    ``settings``, the windows and their rules (``window`` None: ``p`` was given)."""
    options = dict(core.options)
    options.update(
        {
            **settings,
            "p_rule": "given" if window is None else window.choice(WINDOW_BOUNDS.rule).reason,
            "p_criterion_values": None if window is None else window.criterion_values,
            "f_rule": f_rule,
            "dt": dt,
            "n_samples": ns,
            "n_columns_used": int(core.columns.size),
        }
    )
    return options


def _signals(u: Any, y: Any) -> tuple[Array, Array]:
    """``u`` (``(Ns, 0)`` for a time series) and ``y`` checked as ``(Ns, k)`` arrays."""
    y = check_signal(y, "y")
    ns, l = y.shape
    if l == 0:
        raise ValueError("y must have at least one output channel, got shape (Ns, 0)")
    u = np.zeros((ns, 0)) if u is None else check_signal(u, "u", ns)
    return u, y


def _channel_scales(u: Array, y: Array, normalize: bool) -> tuple[Array, Array]:
    """The RMS of every channel when ``normalize`` (ones otherwise): the identification
    runs on ``u / su``, ``y / sy``."""
    m, l = u.shape[1], y.shape[1]
    su = _rms(u, "u") if (normalize and m) else np.ones(m)
    sy = _rms(y, "y") if normalize else np.ones(l)
    return su, sy


def _check_interval(dt: Any) -> None:
    """``dt`` a positive finite real number (TypeError, ValueError)."""
    if isinstance(dt, bool) or not isinstance(dt, int | float | np.floating | np.integer):
        raise TypeError(f"dt must be a positive real number, got {type(dt).__name__}")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite sampling interval, got {dt}")


def _orders_the_windows_allow(mo: int, fw: int | None, l: int) -> int:
    """The largest order of a selection with explicit windows: every order the ``f l``
    singular values allow (``mo`` when no window is given)."""
    if fw is None:
        return mo
    mo = min(mo, fw * l - 1)
    if mo < 1:
        raise ValueError(
            f"order selection needs f*l >= 2 singular values, got f*l = {fw * l}; "
            f"increase f/p or pass an order"
        )
    return mo


def _past_window(
    U: Array,
    Y: Array,
    p_min: int,
    p_max: int,
    lag: LagOperator | None,
    feedthrough: bool,
    policy: PastWindowPolicy,
) -> PastWindowChoice:
    """The past window by ``policy`` in ``[p_min, p_max]``.  With the sample shift the
    criterion of every window from 1 on is shared by the orders of an order selection
    (:func:`_past_window_criteria`, memoised) and used when it settles the windows
    ``>= p_min``; otherwise the search runs from ``p_min``."""
    if lag is None or type(lag) is SampleShift:
        # every order of an order selection asks the same question of the same data
        crit = _past_window_criteria(U, Y, p_max, feedthrough, policy.criterion).copy()
        crit[: p_min - 1] = np.inf
        if search_is_complete(crit, p_max, policy.growth):
            return PastWindowChoice(int(np.argmin(crit)) + 1, crit, p_min, p_max, policy)
        # the shared search stopped before it could settle windows >= p_min
        return choose_past_window(U, Y, p_max, p_min, feedthrough=feedthrough, policy=policy)
    return choose_past_window(U, Y, p_max, p_min, lag, feedthrough, policy)


def _scaled_back(
    core: CoreResult, su: Array, sy: Array, options: dict[str, Any], dt: float
) -> DiscreteModel:
    """The sampled model of the core's result on channels scaled to unit RMS, in the
    record's units: ``u = su * us``, ``y = sy * ys``."""
    m = su.size
    B = core.B / su[None, :] if m else core.B
    C = core.C * sy[:, None]
    D = (sy[:, None] * core.D / su[None, :]) if m else core.D
    K = core.K / sy[None, :]
    noise_cov = sy[:, None] * core.noise_covariance * sy[None, :]
    return DiscreteModel(
        core.A,
        B,
        C,
        D,
        K,
        singular_values=core.singular_values,
        options=options,
        noise_covariance=noise_cov,
        dt=dt,
    )


@library_call
def identify_dt(
    t: Any,
    u: Any = None,
    y: Any = None,
    order: int | None = None,
    p: int | None = None,
    f: int | None = None,
    regularize: bool | str | float | None = "gcv",
    feedthrough: bool = False,
    stable_k: bool = False,
    normalize: bool = True,
    max_order: int | None = None,
    p_criterion: str = "aic",
    uniform_rtol: float = 1e-6,
) -> StateSpaceModel:
    """Identify a continuous-time model from uniformly sampled data (method ``"dt"``).

    Runs :func:`identify_discrete` on the samples and converts exactly with the matrix
    logarithm (:func:`hdpbsid.models.conversion.d2c`), which is the inverse of the
    zero-order-hold sampling: the model is exact for an input held between samples.

    Parameters
    ----------
    t : array_like, shape (Ns,), or list of records
        Sample times, uniform within ``uniform_rtol`` relative plus the resolution of the
        stamps (:func:`hdpbsid.data.checks.check_uniform`; Unix-time stamps pass); or a list
        of ``(t_i, u_i, y_i)`` records with the same sampling interval (then ``u = y =
        None``), concatenated with no lag crossing a record edge.
    u : array_like, shape (Ns, m), optional
        Inputs (None: a time series).
    y : array_like, shape (Ns, l)
        Outputs.
    order : int, optional
        Model order; None selects it.
    p : int, optional
        Past window (:func:`identify_discrete`).
    f : int, optional
        Future window.
    regularize : bool, str or float, optional
        VARX ridge.
    feedthrough : bool, optional
        Estimate ``D``.
    stable_k : bool, optional
        Riccati gain.
    normalize : bool, optional
        Scale the channels to unit RMS.
    max_order : int, optional
        Largest order of the selection.
    p_criterion : {"aic", "bic"}, optional
        The past-window criterion.
    uniform_rtol : float, optional
        Relative tolerance of the uniform sampling check.

    Returns
    -------
    StateSpaceModel
        The continuous-time model; ``discrete`` holds the sampled model and ``options``
        every setting used.

    Raises
    ------
    ValueError
        If the samples are not uniform, the records have different intervals, or the
        discrete model has no continuous counterpart (an eigenvalue on the negative real
        axis: try another order or a basis-domain method).

    References
    ----------
    .. [1] A. Chiuso, "The role of vector autoregressive modeling in predictor-based
       subspace identification", *Automatica* 43(6), 1034-1048, 2007.
    .. [2] G. F. Franklin, J. D. Powell and M. L. Workman, *Digital Control of Dynamic
       Systems*, 3rd ed., Addison-Wesley, 1998, sec. 4.3 (zero-order-hold equivalents).

    Examples
    --------
    The lightly damped second-order system (eigenvalues ``-0.4 +- 1.9596j``) under a
    random-step input held between samples, noise-free:

    >>> from hdpbsid.systems.linear import random_steps, second_order, simulate_zoh
    >>> A, B, C, D = second_order()
    >>> t = np.arange(0.0, 60.0, 0.05)
    >>> u = random_steps(np.random.default_rng(0), t, hold=0.5)
    >>> y = simulate_zoh(A, B, C, D, t, u)

    >>> model = identify_dt(t, u, y)
    >>> model.n, np.sort_complex(model.eigenvalues).round(4)
    (2, array([-0.4-1.9596j, -0.4+1.9596j]))
    """
    return fit_dt(
        Dataset.of(t, u, y), order, p=p, f=f, regularize=regularize, feedthrough=feedthrough,
        stable_k=stable_k, normalize=normalize, max_order=max_order, p_criterion=p_criterion,
        uniform_rtol=uniform_rtol,
    )  # fmt: skip


@library_call
def fit_dt(
    data: Dataset,
    order: int | None = None,
    p: int | None = None,
    f: int | None = None,
    regularize: bool | str | float | None = "gcv",
    feedthrough: bool = False,
    stable_k: bool = False,
    normalize: bool = True,
    max_order: int | None = None,
    p_criterion: str = "aic",
    uniform_rtol: float = 1e-6,
) -> StateSpaceModel:
    """Method ``"dt"`` on the records of ``data``: :func:`identify_dt` in the registry's
    call shape (:func:`hdpbsid.methods.registry.get_fit`).

    Parameters
    ----------
    data : Dataset
        The records, checked (one record is a Dataset of one), uniformly sampled with one
        sampling interval.
    order : int, optional
        Model order; None selects it.
    p : int, optional
        Past window.
    f : int, optional
        Future window.
    regularize : bool, str or float, optional
        VARX ridge.
    feedthrough : bool, optional
        Estimate ``D``.
    stable_k : bool, optional
        Riccati gain.
    normalize : bool, optional
        Scale the channels to unit RMS.
    max_order : int, optional
        Largest order of the selection.
    p_criterion : {"aic", "bic"}, optional
        The past-window criterion.
    uniform_rtol : float, optional
        Relative tolerance of the uniform sampling check.

    Returns
    -------
    StateSpaceModel
        As :func:`identify_dt` returns it.

    Raises
    ------
    ValueError
        As :func:`identify_dt` raises it.
    """
    records = as_records(data)
    steps = []
    for i, r in enumerate(records):
        try:
            steps.append(check_uniform(r.t + r.t0, rtol=uniform_rtol))
        except ValueError as exc:
            raise ValueError(f"record {i}: {exc}" if len(records) > 1 else str(exc)) from exc
    dt = float(np.mean(steps))
    if max(abs(h - dt) for h in steps) > uniform_rtol * dt + max(r.resolution for r in records):
        raise ValueError(
            f"all records must have the same sampling interval for method 'dt', got "
            f"{sorted(set(round(h, 12) for h in steps))}"
        )
    # records side by side, the first p columns of each invalid (no lag across records)
    lag = BlockLag([SampleShift()] * len(records), [r.ns for r in records])
    dmodel = identify_discrete(
        np.vstack([r.u for r in records]),
        np.vstack([r.y for r in records]),
        order=order,
        p=p,
        f=f,
        regularize=regularize,
        feedthrough=feedthrough,
        stable_k=stable_k,
        normalize=normalize,
        max_order=max_order,
        p_criterion=p_criterion,
        dt=dt,
        lag=lag if len(records) > 1 else None,
    )
    try:
        model = dmodel.to_continuous()
    except ValueError as exc:
        raise ValueError(
            f"identify_dt: the identified discrete model (order {dmodel.n}) cannot be "
            f"converted to continuous time: {exc}"
        ) from exc
    model.options.update(
        {
            "t0": records[0].t0,
            "uniform_rtol": uniform_rtol,
            "d2c": "zoh logm",
            "n_records": len(records),
        }
    )
    return model


identify_dt.refit_keeps = REFIT_KEEPS  # type: ignore[attr-defined]
identify_dt.fit = fit_dt  # type: ignore[attr-defined]
