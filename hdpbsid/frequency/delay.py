"""Estimating input-output dead times: :func:`estimate_delay` (a record) and
:func:`delay_from_frf` (a frequency response).

A dead time ``tau`` multiplies the response by ``e^{-j w tau}``: a phase falling linearly
with frequency, which a rational model of low order cannot follow.  The estimate is the
delay whose removal, ``H(jw) e^{+j w tau}``, a rational model fits best in the weighted
least-squares sense of :func:`hdpbsid.frequency.fit.identify_frequency` (the maximum-likelihood
criterion for circular Gaussian errors, Pintelon & Schoukens, *System Identification: A
Frequency Domain Approach*, 2nd ed., 2012, sec. 9.2 and 10.4: the delay is one more
parameter of the model, profiled here on a grid).

A rational model of higher order imitates a delay over a band (a Pade approximant is
one), so the delay and the order are chosen together: for every order ``n = 1 ..
max_order`` and every candidate ``d step`` (``d = 0 .. max_delay / step``) the refined
fit's cost ``V(n, d)`` is computed, and the pair minimising Akaike's criterion
``N log V(n, d) + 2 p(n)`` is kept (``N`` real equations, ``p(n)`` the model's parameters;
the delay's one parameter is the same for every pair and drops out).  A higher order
that only imitates the delay pays for its parameters; the true order at the true delay
does not.  The parabola through the chosen candidate's cost and its neighbours' places
the delay to a fraction of ``step``.

The phase of the delay at the highest coherent line, ``w_max tau``, is what the data
resolve: a step of one sample changes it by ``w_max dt``, so the resolution is a sample
or better when the record is coherent up to a fraction of the Nyquist frequency.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import as_columns, check_positive_int, check_step
from hdpbsid.frequency.fit import FrequencyResponse, _frequency_data, frf_welch, identify_frequency
from hdpbsid.models.dead_time import SNAP, check_delay

__all__ = ["DelayEstimate", "estimate_delay", "delay_from_frf", "MAX_LINES", "DEFAULT_MAX_ORDER"]

Array = NDArray[np.float64]

#: Lines used by the delay search: a longer estimate is thinned to this many, log-spaced
#: in index (every decade alike, the highest lines kept, where the delay's phase is
#: largest).  Each candidate delay costs a fit; 200 lines determine a model of order up
#: to about 20 many times over.
MAX_LINES = 200
#: Orders tried by default: the dynamics a delay is estimated against are those of a
#: low-order model (flight-dynamics modes, actuators); a user with more passes
#: ``max_order``.
DEFAULT_MAX_ORDER = 4


@dataclass
class DelayEstimate:
    """Dead times estimated by :func:`delay_from_frf` / :func:`estimate_delay`.

    Attributes
    ----------
    delay : (m,) dead time of each input (time unit of the frequencies' inverse).
    samples : (m,) the best candidate of each input in steps (whole numbers).
    step : the spacing of the candidates (the sampling interval for a record).
    order : (m,) the model order chosen with each input's delay.
    criterion : list of (orders, candidates) Akaike criteria, one array per input.
    """

    delay: Array
    samples: NDArray[np.intp]
    step: float
    order: NDArray[np.intp]
    criterion: list[Array] = field(default_factory=list)
    options: dict[str, Any] = field(default_factory=dict)


def _thin(nf: int) -> NDArray[np.intp]:
    if nf <= MAX_LINES:
        return np.arange(nf)
    return np.unique(np.round(np.logspace(0, np.log10(nf), MAX_LINES)).astype(np.intp) - 1)


def _cost(w: Array, H: Any, W: Array, tau: float, order: int) -> float:
    """Weighted cost of the refined fit of order ``order`` to ``H e^{j w tau}``."""
    model = identify_frequency(w, H * np.exp(1j * w * tau)[None, None, :], order=order, weight=W)
    return float(model.options["cost"])


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


def delay_from_frf(
    w: Any,
    H: Any | None = None,
    *,
    step: float | None = None,
    max_delay: float | None = None,
    weight: Any = "auto",
    order: int | None = None,
    max_order: int = DEFAULT_MAX_ORDER,
) -> DelayEstimate:
    """Dead time of each input from a frequency response (module docstring).

    Parameters
    ----------
    w : (nf,) angular frequencies, or a :class:`~hdpbsid.frequency.fit.FrequencyResponse`.
    H : (nf,) or (l, m, nf) response (not with a ``FrequencyResponse``).
    step : spacing of the candidate delays; default the estimate's sampling interval
        (``options["dt"]`` of a ``FrequencyResponse``) or else ``pi / max(w)``.
    max_delay : the largest delay tried; default 100 steps.
    weight : as :func:`~hdpbsid.frequency.fit.identify_frequency`'s.
    order : the order of the delay-free dynamics, when known: only that order is
        fitted (sharper and ``max_order`` times faster than the joint search, which can
        trade a sample of delay for a spurious mode when the data are short or noisy).
    max_order : largest model order tried with the delays (``order=None``).

    Returns
    -------
    DelayEstimate

    Raises
    ------
    ValueError
        As :func:`~hdpbsid.frequency.fit.identify_frequency` for the data, or on a
        non-positive ``step`` / negative ``max_delay``.

    Examples
    --------
    >>> w = np.logspace(-1, 1.5, 80)
    >>> H = np.exp(-0.3j * w) / (1j * w + 1.0)  # 1 / (s + 1) delayed by 0.3
    >>> est = delay_from_frf(w, H, step=0.05, max_delay=1.0)
    >>> round(float(est.delay[0]), 2)
    0.3
    """
    frf = w if isinstance(w, FrequencyResponse) else None
    w_arr, Hc, W, _ = _frequency_data(w, H, weight)
    if step is None:
        dt = frf.options.get("dt") if frf is not None else None
        step = float(dt) if dt else float(np.pi / np.max(w_arr))
    step = check_step(step, "step")
    dmax = (
        100 if max_delay is None else int(check_delay(max_delay, 1, "max_delay")[0] / step + SNAP)
    )
    max_order = check_positive_int(max_order, "max_order")
    tried = range(1, max_order + 1) if order is None else [check_positive_int(order, "order")]
    keep = _thin(w_arr.size)
    w_arr, Hc, W = w_arr[keep], Hc[..., keep], W[..., keep]
    l, m = Hc.shape[:2]
    n_eq = 2 * keep.size * l
    cands = np.arange(dmax + 1)
    delays, samples, orders, crit = [], [], [], []
    for j in range(m):
        Hj, Wj = Hc[:, j : j + 1], W[:, j : j + 1]
        rows = []
        for n in tried:
            if n + n * (1 + l) >= n_eq or keep.size < n + 1:
                break
            cost = np.array([_cost(w_arr, Hj, Wj, d * step, n) for d in cands])
            rows.append(
                n_eq * np.log(np.maximum(cost, np.finfo(float).tiny)) + 2 * (n + n * (1 + l))
            )
        if not rows:
            raise ValueError(f"too few lines ({keep.size}) to fit a model with a delay")
        aic = np.array(rows)
        n_best, d_best = np.unravel_index(int(np.argmin(aic)), aic.shape)
        delays.append(max(_parabola_min(cands.astype(float), aic[n_best], int(d_best)), 0.0) * step)
        samples.append(int(d_best))
        orders.append(int(list(tried)[n_best]))
        crit.append(aic)
    return DelayEstimate(
        delay=np.array(delays),
        samples=np.array(samples, dtype=np.intp),
        step=step,
        order=np.array(orders, dtype=np.intp),
        criterion=crit,
        options=dict(max_delay_steps=dmax, lines=int(keep.size), weight=weight),
    )


def estimate_delay(
    t: Any,
    u: Any,
    y: Any,
    max_delay: float | None = None,
    *,
    order: int | None = None,
    nperseg: int | None = None,
) -> DelayEstimate:
    """Dead time of each input of a uniformly sampled record: the Welch H1 frequency
    response (:func:`hdpbsid.frequency.fit.frf_welch`, variance-weighted) searched by
    :func:`delay_from_frf` on the grid of whole samples.

    Parameters
    ----------
    t : (Ns,) uniformly sampled times.
    u : (Ns,) or (Ns, m) inputs (open loop: H1 is biased under feedback).
    y : (Ns,) or (Ns, l) outputs.
    max_delay : largest delay tried (time unit of ``t``); default a tenth of the
        record, at most 100 samples.
    order : order of the delay-free dynamics if known (:func:`delay_from_frf`).
    nperseg : Welch segment length (default :func:`~hdpbsid.frequency.fit.frf_welch`'s).

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
    >>> int(estimate_delay(t, u, m.simulate(t, u)).samples[0])
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
    return delay_from_frf(est, step=dt, max_delay=max_delay, order=order)
