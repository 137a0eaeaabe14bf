"""Estimating input-output dead times: :func:`estimate_delay` (a record) and
:func:`delay_from_frf` (a frequency response).

A dead time ``tau`` multiplies the response by ``e^{-j w tau}``: a phase falling linearly
with frequency, which a rational model of low order cannot follow.  The estimate is the
delay whose removal, ``H e^{+j w tau}``, a rational model fits best in the weighted
least-squares sense of :func:`hdpbsid.frequency.fit.identify_frequency` (the maximum-likelihood
criterion for circular Gaussian errors, Pintelon & Schoukens, *System Identification: A
Frequency Domain Approach*, 2nd ed., 2012, sec. 9.2 and 10.4: the delay is one more
parameter of the model, profiled here on a grid).

**Sampled records are discrete-time responses.**  The frequency response of a record
``u_k -> y_k`` is that of the sampled system, not ``G(j w)``: with the input held between
samples (zero-order hold) it is ``G_d(e^{j w h}) = sum_k G(j w_k) (1 - e^{-j w_k h}) /
(j w_k h)``, ``w_k = w + 2 pi k / h`` (Franklin, Powell & Workman, *Digital Control of
Dynamic Systems*, 3rd ed., 1998, sec. 4.3 and 6.3): the hold adds half a sample of phase,
``e^{-j w h / 2}``, and the aliases bend the response towards the Nyquist frequency.  A
continuous-time model plus a delay fitted to it therefore finds the delay half a sample
to a sample too long.  Exactly instead: for ``tau = d h`` the sampled response is ``z^{-d}
G_zoh(z)`` with ``G_zoh`` strictly proper of the same order ``n`` as ``G``, so each
candidate ``d`` is scored by the best discrete-time model of order ``n``.  That fit is
the continuous-time fit of :func:`~hdpbsid.frequency.fit.identify_frequency` in the frequency
variable of the bilinear map ``z = (1 + s h / 2) / (1 - s h / 2)``: on the unit circle
``s = j w'``, ``w' = (2 / h) tan(w h / 2)``, and a strictly proper ``G_d(z) = C (zI -
Phi)^{-1} Gamma`` equals ``(1 - s h / 2) C' (sI - A')^{-1} B'`` with ``A' = (2 / h) (I +
Phi)^{-1} (Phi - I)``, ``B' = (2 / h) (I + Phi)^{-1} Gamma`` (expand ``zI - Phi``), so
``H / (1 - j w' h / 2)`` is fitted at ``w'`` with the weights times ``|1 - j w' h / 2|``.
A first-order hold (input linear between samples) makes ``G_d`` biproper of order ``n``:
then ``H`` itself is fitted at ``w'`` with a direct term.  Noise-free, the cost at the
true whole-sample delay is rounding and every other candidate needs more states.  A
fractional delay ``(d + f) h`` is no whole-sample shift (the modified z-transform adds a
numerator term): candidate ``d`` misses a term of order ``f h``, candidate ``d + 1`` a
direct term, which is of order ``h^r`` for a system of relative degree ``r``, so the
profile's minimum is one of the two neighbours, not always the nearer.  A response of
a continuous-time system (``hold=None``, e.g. the lines of a band-limited periodic
input) is fitted by continuous-time models as it is.

**Order and delay.**  A rational model of higher order imitates a delay (in discrete
time ``z^{-1}`` is one state at the origin), so the delay and the order are chosen
together: for every order ``n = 1 .. max_order`` and every candidate ``d step`` (``d = 0
.. max_delay / step``) the refined fit's cost ``V(n, d)`` is computed, and the pair
minimising Schwarz's criterion ``N log V(n, d) + p(n) log N`` is kept (``N`` real
equations, ``p(n)`` the model's parameters; the delay's one parameter is the same for
every pair and drops out; Schwarz, "Estimating the dimension of a model", Ann. Stat.
6(2), 1978).  Its penalty grows with ``N``, so an extra mode that only imitates a sample
of delay (it lowers ``N log V`` by a chi-square amount of about its ``p`` degrees of
freedom) is refused with a probability tending to one; Akaike's fixed ``2 p`` accepted it
about one time in ten per comparison, and the profile makes dozens.  The parabola
through the chosen candidate's criterion and its neighbours' places the delay to a
fraction of ``step`` (an interpolation: within half a step on exact data, tests).

The phase of one sample of delay at the highest coherent line, ``w_max h``, is what the
data resolve: where the output is small against the noise above the system's bandwidth,
neighbouring whole-sample candidates have costs within the noise and the estimate
scatters by about a sample (a second-order system at 2 rad/s sampled at 100 Hz, 20 dB,
120 s: within one sample, bench/frequency.py).  Give the order when you know it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import as_columns, check_positive_int, check_step
from hdpbsid.frequency.estimate import FrequencyResponse, frf_welch
from hdpbsid.frequency.fit import _frequency_data, fit_cost
from hdpbsid.models.dead_time import SNAP, check_delay

__all__ = [
    "DelayEstimate",
    "estimate_delay",
    "delay_from_frf",
    "DelaySettings",
    "DELAY",
    "MAX_LINES",
    "DEFAULT_MAX_ORDER",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class DelaySettings:
    """Sizes of the delay search of :func:`delay_from_frf`.

    Attributes
    ----------
    max_lines : int
        Lines used by the search: a longer estimate is thinned to this many, log-spaced in
        index (every decade alike, the highest lines kept, where the delay's phase is
        largest).
    max_order : int
        Orders tried by default.
    """

    #: each candidate delay costs a fit; 200 lines determine a model of order up to about
    #: 20 many times over
    max_lines: int = 200
    #: the dynamics a delay is estimated against are those of a low-order model
    #: (flight-dynamics modes, actuators); a user with more passes ``max_order``
    max_order: int = 4


#: the settings of the delay search
DELAY = DelaySettings()
#: :attr:`DelaySettings.max_lines`, under its earlier name
MAX_LINES = DELAY.max_lines
#: :attr:`DelaySettings.max_order`, under its earlier name
DEFAULT_MAX_ORDER = DELAY.max_order


@dataclass
class DelayEstimate:
    """Dead times estimated by :func:`delay_from_frf` / :func:`estimate_delay`.

    Attributes
    ----------
    delay : ndarray, shape (m,)
        Dead time of each input (time unit of the frequencies' inverse).
    samples : ndarray, shape (m,)
        The best candidate of each input in steps (whole numbers).
    step : float
        The spacing of the candidates (the sampling interval for a record).
    order : ndarray, shape (m,)
        The model order chosen with each input's delay.
    criterion : list of ndarray
        Schwarz criteria, one ``(orders, candidates)`` array per input.
    options : dict
        Every setting used, defaults included.
    """

    delay: Array
    samples: NDArray[np.intp]
    step: float
    order: NDArray[np.intp]
    criterion: list[Array] = field(default_factory=list)
    options: dict[str, Any] = field(default_factory=dict)


def _thin(nf: int) -> NDArray[np.intp]:
    if nf <= DELAY.max_lines:
        return np.arange(nf)
    return np.unique(np.round(np.logspace(0, np.log10(nf), DELAY.max_lines)).astype(np.intp) - 1)


HOLDS = ("zoh", "foh")


def _sampled_frame(w: Array, H: Any, W: Array, dt: float, hold: str) -> tuple[Array, Any, Array]:
    """The lines of a sampled-data response mapped so that a continuous-time fit of
    order ``n`` is the discrete-time fit of order ``n`` (module docstring): the warped
    frequencies ``w' = (2 / dt) tan(w dt / 2)`` of the lines below the Nyquist
    frequency, and for ``"zoh"`` the response and weights divided and multiplied by
    ``|1 - j w' dt / 2|``."""
    keep = w * dt < np.pi * (1.0 - 1e-9)  # the Nyquist line maps to infinity
    w, H, W = w[keep], H[..., keep], W[..., keep]
    wp = 2.0 / dt * np.tan(0.5 * w * dt)
    if hold == "foh":
        return wp, H, W
    f = 1.0 - 0.5j * wp * dt
    return wp, H / f, W * np.abs(f)


def _cost(w: Array, H: Any, W: Array, tau: float, order: int, frame: Any = None) -> float:
    """Weighted cost of the refined fit of order ``order`` to ``H e^{j w tau}``; with
    ``frame = (dt, hold)`` the discrete-time fit of a sampled-data response."""
    Hd = H * np.exp(1j * w * tau)[None, None, :]
    if frame is None:
        return fit_cost(w, Hd, order, weight=W)
    dt, hold = frame
    wp, Hp, Wp = _sampled_frame(w, Hd, W, dt, hold)
    return fit_cost(wp, Hp, order, weight=Wp, feedthrough=hold == "foh")


def _parabola_min(x: Array, c: Array, i: int) -> float:
    """Abscissa of the minimum of the parabola through ``(x, c)`` at ``i - 1, i, i + 1``,
    or ``x[i]`` at an end of the grid or where the three points are not convex."""
    if i == 0 or i == x.size - 1:
        return float(x[i])
    c0, c1, c2 = c[i - 1], c[i], c[i + 1]
    curv = c0 - 2 * c1 + c2
    if not curv > 0:
        return float(x[i])
    return float(x[i] + 0.5 * (c0 - c2) / curv * (x[i + 1] - x[i]))


def _penalty(n_eq: int) -> float:
    """Criterion cost of one parameter (module docstring): Schwarz's ``log N``."""
    return float(np.log(n_eq))


def delay_from_frf(
    w: Any,
    H: Any | None = None,
    *,
    step: float | None = None,
    max_delay: float | None = None,
    weight: Any = "auto",
    order: int | None = None,
    max_order: int = DELAY.max_order,
    hold: str | None = None,
) -> DelayEstimate:
    """Dead time of each input from a frequency response (module docstring).

    Parameters
    ----------
    w : ndarray, shape (nf,), or FrequencyResponse
        Angular frequencies, or a :class:`~hdpbsid.frequency.fit.FrequencyResponse`.
    H : ndarray of complex, shape (nf,) or (l, m, nf), optional
        Response (not with a ``FrequencyResponse``).
    step : float or None, optional
        Spacing of the candidate delays.  With ``hold`` it is the sampling interval of the
        record (default a ``FrequencyResponse``'s ``dt``); without, default that or
        else ``pi / max(w)``.
    max_delay : float or None, optional
        The largest delay tried; default 100 steps.
    weight : str, array_like or None, optional
        As :func:`~hdpbsid.frequency.fit.identify_frequency`'s.
    order : int or None, optional
        The order of the delay-free dynamics, when known: only that order is fitted
        (``max_order`` times faster than the joint search).
    max_order : int, optional
        Largest model order tried with the delays (``order=None``).
    hold : {None, "zoh", "foh"}, optional
        ``None``: ``H`` is a continuous-time response ``G(jw)`` (e.g. the lines of a
        band-limited periodic input); ``"zoh"`` / ``"foh"``: ``H`` is the response of a record
        sampled every ``step`` whose input is held between samples (zero order) or linear
        between them (first order), fitted by discrete-time models (module docstring).

    Returns
    -------
    DelayEstimate

    Raises
    ------
    ValueError
        As :func:`~hdpbsid.frequency.fit.identify_frequency` for the data, or on a
        non-positive ``step`` / negative ``max_delay``, an unknown ``hold``, or a
        ``hold`` without a sampling interval.

    Examples
    --------
    >>> w = np.logspace(-1, 1.5, 80)
    >>> H = np.exp(-0.3j * w) / (1j * w + 1.0)  # 1 / (s + 1) delayed by 0.3
    >>> est = delay_from_frf(w, H, step=0.05, max_delay=0.5, order=1)
    >>> round(float(est.delay[0]), 2)
    0.3
    """
    frf = w if isinstance(w, FrequencyResponse) else None
    w_arr, Hc, W, _ = _frequency_data(w, H, weight)
    if hold is not None and hold not in HOLDS:
        raise ValueError(f"hold must be None, 'zoh' or 'foh', got {hold!r}")
    step = _delay_step(step, hold, frf, w_arr)
    frame = None if hold is None else (step, hold)
    dmax = (
        100 if max_delay is None else int(check_delay(max_delay, 1, "max_delay")[0] / step + SNAP)
    )
    max_order = check_positive_int(max_order, "max_order")
    tried = list(range(1, max_order + 1)) if order is None else [check_positive_int(order, "order")]
    if frame is not None:
        below = w_arr * step < np.pi * (1.0 - 1e-9)
        w_arr, Hc, W = w_arr[below], Hc[..., below], W[..., below]
    keep = _thin(w_arr.size)
    w_arr, Hc, W = w_arr[keep], Hc[..., keep], W[..., keep]
    cands = np.arange(dmax + 1)
    extra = Hc.shape[0] if hold == "foh" else 0  # the direct term of a first-order hold
    delays, samples, orders, crit = [], [], [], []
    for j in range(Hc.shape[1]):
        crit_j = _input_criterion(
            w_arr, Hc[:, j : j + 1], W[:, j : j + 1], cands * step, tried, frame, extra
        )
        n_best, d_best = np.unravel_index(int(np.argmin(crit_j)), crit_j.shape)
        frac = _parabola_min(cands.astype(float), crit_j[n_best], int(d_best))
        delays.append(max(frac, 0.0) * step)
        samples.append(int(d_best))
        orders.append(int(tried[n_best]))
        crit.append(crit_j)
    return DelayEstimate(
        delay=np.array(delays),
        samples=np.array(samples, dtype=np.intp),
        step=step,
        order=np.array(orders, dtype=np.intp),
        criterion=crit,
        options=dict(max_delay_steps=dmax, lines=int(keep.size), weight=weight, hold=hold),
    )


def _delay_step(step: Any, hold: str | None, frf: Any, w: Array) -> float:
    """The spacing of the candidate delays: ``step``; else the record's sampling interval
    (a ``FrequencyResponse``'s ``dt``), which a ``hold`` requires; else
    ``pi / max(w)``, the interval whose Nyquist frequency is the highest line."""
    dt = frf.dt if frf is not None else None
    if step is None:
        if hold is not None and not dt:
            raise ValueError(f"hold={hold!r} needs step (the sampling interval of the record)")
        step = float(dt) if dt else float(np.pi / np.max(w))
    return check_step(step, "step")


def _input_criterion(
    w: Array, H: Any, W: Any, delays: Array, tried: list[int], frame: Any, extra: int
) -> Array:
    """The information criterion of one input's column ``H`` (``l x 1 x nf``) for every
    order in ``tried`` (rows; the orders whose parameters the ``2 nf l`` equations still
    determine) and every candidate delay (columns):
    ``n_eq log(cost) + p penalty(n_eq)`` with ``p = n + n (1 + l) + extra`` parameters."""
    l, nf = H.shape[0], w.size
    n_eq = 2 * nf * l
    rows = []
    for n in tried:
        p = n + n * (1 + l) + extra
        if p >= n_eq or nf < n + 1:
            break
        cost = np.array([_cost(w, H, W, d, n, frame) for d in delays])
        rows.append(n_eq * np.log(np.maximum(cost, np.finfo(float).tiny)) + p * _penalty(n_eq))
    if not rows:
        raise ValueError(f"too few lines ({nf}) to fit a model with a delay")
    return np.array(rows)


def estimate_delay(
    t: Any,
    u: Any,
    y: Any,
    max_delay: float | None = None,
    *,
    order: int | None = None,
    nperseg: int | None = None,
    hold: str | None = "zoh",
) -> DelayEstimate:
    """Dead time of each input of a uniformly sampled record: the Welch H1 frequency
    response (:func:`hdpbsid.frequency.fit.frf_welch`, variance-weighted) searched by
    :func:`delay_from_frf` on the grid of whole samples with discrete-time models of
    the sampled record.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Uniformly sampled times.
    u : ndarray, shape (Ns,) or (Ns, m)
        Inputs (open loop: H1 is biased under feedback).
    y : ndarray, shape (Ns,) or (Ns, l)
        Outputs.
    max_delay : float or None, optional
        Largest delay tried (time unit of ``t``); default a tenth of the record, at most 100
        samples.
    order : int or None, optional
        Order of the delay-free dynamics if known (:func:`delay_from_frf`).
    nperseg : int or None, optional
        Welch segment length (default :func:`~hdpbsid.frequency.fit.frf_welch`'s).
    hold : {None, "zoh", "foh"}, optional
        The input between samples, ``"zoh"`` (held, as a random binary or a digital controller's
        output, and as :func:`hdpbsid.identify`'s discrete-time method assumes), ``"foh"``
        (linear) or ``None`` (band-limited, e.g. a multisine well below the Nyquist frequency:
        the response is ``G(jw)``); :func:`delay_from_frf`.

    Returns
    -------
    DelayEstimate
        ``samples`` the whole-sample delays, ``delay`` refined to a fraction of a sample.

    Raises
    ------
    ValueError
        When ``t`` is not uniform or the lengths differ.

    Examples
    --------
    >>> from hdpbsid import StateSpaceModel
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(6000) * 0.01
    >>> u = rng.standard_normal(6000)
    >>> m = StateSpaceModel([[-5.0]], [[5.0]], [[1.0]], [[0.0]], [[0.0]], delay=0.07)
    >>> est = estimate_delay(t, u, m.simulate(t, u), order=1, max_delay=0.1)  # order known
    >>> int(est.samples[0])
    7
    """
    from hdpbsid.data.checks import check_uniform

    tt = np.asarray(t, dtype=float).reshape(-1)
    U, Y = as_columns(u, "u"), as_columns(y, "y")
    if U.shape[0] != tt.size or Y.shape[0] != tt.size:
        raise ValueError(
            f"t, u and y must have the same number of samples, got {tt.size}, {U.shape[0]}, "
            f"{Y.shape[0]}"
        )
    dt = check_step(check_uniform(tt), "t (sampling interval)")
    if max_delay is None:
        max_delay = min(100, tt.size // 10) * dt
    if nperseg is not None:
        nperseg = check_positive_int(nperseg, "nperseg")
    est = frf_welch(U, Y, dt, nperseg=nperseg)
    return delay_from_frf(est, step=dt, max_delay=max_delay, order=order, hold=hold)
