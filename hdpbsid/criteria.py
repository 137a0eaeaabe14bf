"""Model-based criteria that compare identified models on a record (order and method choice).

The question "which of these models describes the record best?" must be asked of the
*models*, identically for every method and order, not of a by-product of one method such
as a gap in singular values.  The criterion used here is the **windowed simulation
error**, the quantity a user judges a model by (MATLAB ``compare``):

* the record is cut into ``W`` consecutive windows of equal length;
* in each window the model is simulated from the measured input with its initial state
  fitted by least squares (the output is affine in it:
  ``y_w = O_w x_w + y_w^forced``, ``O_w`` the window's observability matrix), so
  transients, slow drifts of the state and an unstable plant (whose free simulation over
  a whole record diverges) are all handled;
* the residual sum of squares of window ``w``, with every output weighted by the inverse
  of its variance (each output counts equally, whatever its unit), is ``r_w``.

The statistic ``r_w`` per window makes **paired comparisons** possible: two models
evaluated on the same windows differ by ``d_w = r_w(a) - r_w(b)``, whose mean over windows
has the standard error ``std(d) / sqrt(W)``.  :func:`choose_smallest_adequate` keeps the
smallest model whose excess over the best is not significant (a one-sided paired test at
about 2 standard errors) -- the "one standard error" rule of cross-validation (Hastie,
Tibshirani & Friedman, *The Elements of Statistical Learning*, 2nd ed., sec. 7.10) with
the standard error of the paired differences.  No threshold is a fixed number of fit
points: an additional mode is kept when it improves the fit consistently across the
record, however little output variance it carries, and dropped when the improvement is
within the window-to-window noise.

Simulation uses the exact sampled model for the hold of the input (``zoh``: held
between samples, ``foh``: linear), as :meth:`hdpbsid.model.StateSpaceModel.simulate`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from .model import StateSpaceModel

__all__ = [
    "WindowedError",
    "windowed_simulation_error",
    "default_windows",
    "choose_smallest_adequate",
    "SIGNIFICANCE_Z",
    "MIN_WINDOWS",
]

Array = NDArray[np.float64]

#: paired differences below this many standard errors are not significant: one-sided
#: 2.3 % level for normal errors; with W >= 8 windows the t-quantile is within 10 % of it
SIGNIFICANCE_Z = 2.0
#: windows per record: enough for a standard error of the paired differences (a t
#: statistic on fewer than ~8 differences is too noisy to test anything)
MAX_WINDOWS = 16
MIN_WINDOWS = 4
#: an excess of the residual energy below this fraction is immaterial: 2 % of the residual
#: sum of squares is 1 % of its root (the NRMSE), below what a fit plot shows and below
#: the spread between noise realisations of the same record length
MATERIAL = 0.02
#: samples per window per fitted initial-state entry: the least-squares initial state of
#: a window must be determined by many more samples than it has entries
SAMPLES_PER_STATE = 3


@dataclass
class WindowedError:
    """Windowed simulation error of one model on one record.

    ``per_window`` (W,): variance-weighted residual sum of squares of each window;
    ``total``: their sum divided by the weighted sum of squares of the detrended
    windows' outputs (0 = perfect, 1 = no better than each window's mean);
    ``fit``: ``100 (1 - sqrt(total))`` (MATLAB-style fit percent, pooled over outputs).
    ``finite`` is False when the simulation overflowed (a model unusable on this record).
    """

    per_window: Array
    total: float
    fit: float
    finite: bool


def default_windows(ns: int, max_states: int) -> int:
    """Number of windows: ``MAX_WINDOWS`` if every window keeps at least
    ``SAMPLES_PER_STATE * max_states`` samples, fewer otherwise (at least 1)."""
    per = SAMPLES_PER_STATE * max(max_states, 1)
    return int(max(1, min(MAX_WINDOWS, ns // per)))


def _sampled(model: StateSpaceModel, h: float, hold: str) -> tuple[Array, Array, Array | None]:
    """Exact one-step matrices ``(Phi, G1, G2)`` for step ``h`` (``G2`` only for foh)."""
    n, m = model.n, model.m
    size = n + m + (m if hold == "foh" else 0)
    M = np.zeros((size, size))
    M[:n, :n] = model.A * h
    M[:n, n : n + m] = model.B * h
    if hold == "foh":
        M[n : n + m, n + m :] = np.eye(m)
    E = expm(M)
    G2 = E[:n, n + m :] if hold == "foh" else None
    return E[:n, :n], E[:n, n : n + m], G2


def windowed_simulation_error(
    model: StateSpaceModel,
    t: Array,
    u: Array,
    y: Array,
    windows: int,
    hold: str | None = None,
    weights: Array | None = None,
) -> WindowedError:
    """Windowed simulation error of ``model`` on a uniformly sampled record (module docstring).

    ``t`` (Ns,) uniform, ``u`` (Ns, m), ``y`` (Ns, l) (already checked); ``windows``
    consecutive windows of ``Ns // windows`` samples (the remainder at the end is not
    scored).  ``hold``: the model's ``options["input_hold"]`` when ``None`` (``"zoh"`` if
    it has none).  ``weights`` (l,): per-output weights of the squared residuals, default
    ``1 / var(y)``.
    """
    ns, l = y.shape
    L = ns // windows
    if windows < 1 or L <= model.n:
        raise ValueError(
            f"windows={windows} leaves {L} samples per window for a model with {model.n} "
            f"states; use fewer windows or a longer record"
        )
    if hold is None:
        hold = model.options.get("input_hold", "zoh")
        hold = hold if hold in ("zoh", "foh") else "zoh"
    d = np.diff(t)
    h = float((t[-1] - t[0]) / (ns - 1))
    if np.max(np.abs(d - h)) > 1e-6 * h:
        return _windowed_nonuniform(model, t, u, y, windows, hold, weights)
    wgt = 1.0 / np.maximum(np.var(y, axis=0), np.finfo(float).tiny) if weights is None else weights
    sw = np.sqrt(wgt)
    n = model.n
    yw = y[: windows * L].reshape(windows, L, l)
    uw = u[: windows * L].reshape(windows, L, -1)
    Phi, G1, G2 = _sampled(model, h, hold)
    # forced response in every window from a zero state, all windows at once
    X = np.zeros((windows, n))
    Yf = np.empty((windows, L, l))
    O = np.empty((L, l, n))
    P = np.eye(n)
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(L):
            Yf[:, k] = X @ model.C.T + uw[:, k] @ model.D.T
            O[k] = model.C @ P
            if k + 1 < L:
                du = (uw[:, k + 1] - uw[:, k]) @ G2.T if G2 is not None else 0.0
                X = X @ Phi.T + uw[:, k] @ G1.T + du
                P = Phi @ P
        R = (yw - Yf) * sw  # (W, L, l)
        Ow = (O * sw[None, :, None]).reshape(L * l, n)
        finite = bool(np.all(np.isfinite(R)) and np.all(np.isfinite(Ow)))
        if finite and n:
            # least-squares initial state of each window: residual of the projection of
            # R_w onto the complement of the column space of O (one SVD for all windows)
            Uo, so, _ = np.linalg.svd(Ow, full_matrices=False)
            keep = so > so[0] * Ow.shape[0] * np.finfo(float).eps if so.size and so[0] > 0 else []
            Q = Uo[:, keep]
            Rf = R.reshape(windows, L * l)
            Rf = Rf - (Rf @ Q) @ Q.T
            # degrees of freedom: the fitted initial state removes Q.shape[1] of them, so
            # RSS / (L l - rank) is the unbiased residual variance (without it a model with
            # more states fits each window's noise better by ~rank/(L l), which made a
            # spurious slow state "win" on held-out data)
            per = np.sum(Rf**2, axis=1) * (L * l) / (L * l - Q.shape[1])
        else:
            per = np.sum(R.reshape(windows, -1) ** 2, axis=1)
    if not (finite and np.all(np.isfinite(per))):
        return WindowedError(np.full(windows, np.inf), np.inf, -np.inf, False)
    dev = (yw - yw.mean(axis=1, keepdims=True)) * sw
    total = float(per.sum() / max(np.sum(dev**2), np.finfo(float).tiny))
    return WindowedError(per, total, 100.0 * (1.0 - np.sqrt(total)), True)


def _windowed_nonuniform(
    model: StateSpaceModel,
    t: Array,
    u: Array,
    y: Array,
    windows: int,
    hold: str,
    weights: Array | None,
) -> WindowedError:
    """:func:`windowed_simulation_error` for non-uniform times: each window is simulated
    with :meth:`StateSpaceModel.fit` (exact steps for every spacing, fitted initial state)."""
    ns, l = y.shape
    L = ns // windows
    wgt = 1.0 / np.maximum(np.var(y, axis=0), np.finfo(float).tiny) if weights is None else weights
    per = np.empty(windows)
    dev = 0.0
    with np.errstate(over="ignore", invalid="ignore"):
        for w in range(windows):
            s = slice(w * L, (w + 1) * L)
            res = model.fit(t[s], u[s], y[s], method=hold)
            per[w] = float(np.sum((y[s] - res.y_sim) ** 2 * wgt))
            dev += float(np.sum((y[s] - y[s].mean(axis=0)) ** 2 * wgt))
    if not np.all(np.isfinite(per)):
        return WindowedError(np.full(windows, np.inf), np.inf, -np.inf, False)
    total = float(per.sum() / max(dev, np.finfo(float).tiny))
    return WindowedError(per, total, 100.0 * (1.0 - np.sqrt(total)), True)


def choose_smallest_adequate(
    errors: Sequence[WindowedError], z: float = SIGNIFICANCE_Z
) -> tuple[int, list[float]]:
    """Index of the first (smallest) model whose windowed error is not significantly
    larger than the best model's, and the paired z-statistic of every model.

    ``errors`` are ordered by complexity (e.g. orders 1, 2, ...).  With ``d_w`` the
    per-window excess over the best model, the statistic is
    ``mean(d) / (std(d) / sqrt(W))`` (``0`` for the best model itself; ``inf`` for a
    model that could not be simulated), on the logarithms of the per-window errors so
    that windows with large errors (an unstable plant, a burst of excitation) do not
    dominate.  The first model with statistic ``< z``, or with a total error within
    :data:`MATERIAL` of the best, is kept.
    """
    finite = [i for i, e in enumerate(errors) if e.finite]
    if not finite:
        raise ValueError("no candidate model could be simulated on the record")
    best = min(finite, key=lambda i: errors[i].total)
    ref = errors[best].per_window
    stats: list[float] = []
    for e in errors:
        if not e.finite:
            stats.append(np.inf)
            continue
        tiny = np.finfo(float).tiny
        d = np.log(np.maximum(e.per_window, tiny)) - np.log(np.maximum(ref, tiny))
        W = d.size
        sd = float(np.std(d, ddof=1)) if W > 1 else 0.0
        mean = float(np.mean(d))
        stats.append(0.0 if mean == 0 else mean / max(sd / np.sqrt(W), tiny))
    excess = [e.total / errors[best].total - 1.0 for e in errors]
    chosen = next(i for i, s in enumerate(stats) if s < z or excess[i] < MATERIAL)
    return chosen, stats
