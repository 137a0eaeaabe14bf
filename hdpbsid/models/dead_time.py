"""Input-output dead times: checking them, simulating them exactly, approximating them by
Pade.

A model with dead times ``tau_j >= 0`` (one per input) is

    dx/dt = A x(t) + sum_j B_j u_j(t - tau_j) + K e(t),
    y(t)  = C x(t) + sum_j D_j u_j(t - tau_j) + e(t),

its transfer matrix ``G(s) = (C (sI - A)^{-1} B + D) diag(e^{-s tau_j})``.  Before the
record's first sample the input is at its operating point (zero deviation), the
convention under which a zero initial state means "at rest".

**Exact simulation** (:func:`delayed_input_terms`).  Let ``z_j`` be the state of the
delay-free system driven by input ``j`` alone from ``z_j(t_0) = 0`` (``z_j = 0`` before
``t_0``).  Then the forced part of ``x`` is ``sum_j z_j(t - tau_j)``, and over any step
``[t_k, t_{k+1}]`` its increment is ``z(t_{k+1} - tau) - Phi_k z(t_k - tau)`` because
``z`` solves the delay-free equation on the shifted interval, whose length is the same
``h_k``.  ``z`` at a shifted time ``t_k - tau`` is propagated exactly from the last sample
``t_i <= t_k - tau`` over the part step ``t_k - tau - t_i`` with the input's hold on
``[t_i, t_{i+1})`` (held for ``"zoh"``; for ``"foh"`` the ramp over the part step, whose
increment is the fraction ``(t_k - tau - t_i) / h_i`` of the whole step's).  So the
delayed model is simulated by the same exact step recursion as the delay-free one, on any
grid and for any (fractional) dead time.

**Pade** (:func:`pade`): the ``(N, N)`` approximant ``P(-s tau) / P(s tau)``,
``P(x) = sum_k c_k x^k``, ``c_k = (2N - k)! N! / ((2N)! k! (N - k)!)`` (Baker &
Graves-Morris, *Pade Approximants*, 2nd ed., 1996, sec. 1.2), is all-pass; its phase is
within 1 degree of ``-w tau`` for ``w tau`` below :data:`PADE_PHASE_RANGE` ``[N]``.

Estimation is in :mod:`hdpbsid.frequency.delay`.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import factorial
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_positive_int
from hdpbsid.models.conversion import sampled_steps

__all__ = [
    "DeadTimeSettings",
    "DEAD_TIME",
    "check_delay",
    "pade",
    "pade_order",
    "delayed_input_terms",
    "PADE_PHASE_RANGE",
    "MAX_PADE_ORDER",
    "SNAP",
]

Array = NDArray[np.float64]

#: ``w tau`` up to which the ``(N, N)`` Pade approximant's phase is within 1 degree of the
#: delay's (index ``N``; computed on a grid of step 1e-4 from the coefficients above).
PADE_PHASE_RANGE = (0.0, 0.60, 1.72, 3.07, 4.55, 6.12, 7.73, 9.39, 11.09, 12.80, 14.54)
#: Largest Pade order chosen or accepted: the coefficients span ``(2N)!`` and the
#: companion realisation of higher orders loses digits to rounding.
MAX_PADE_ORDER = len(PADE_PHASE_RANGE) - 1


@dataclass(frozen=True)
class DeadTimeSettings:
    """How shifted times are matched to samples.

    Attributes
    ----------
    snap : float
        Fraction of the smallest step within which a shifted time is a sample.
    """

    #: A shifted time within this fraction of the smallest step of a sample counts as that
    #: sample: ``t_k - tau`` computed in floating point lands a few ulps off a sample for a
    #: delay of whole steps, and must select that sample's held input, not the previous one.
    snap: float = 1e-9


#: The settings in force.
DEAD_TIME = DeadTimeSettings()
#: :attr:`DeadTimeSettings.snap` of :data:`DEAD_TIME`
SNAP = DEAD_TIME.snap


def check_delay(delay: Any, m: int, name: str = "delay") -> Array:
    """Dead times as one number per input.

    Parameters
    ----------
    delay : float, array_like of shape (m,), or None
        ``None`` is no delay, a scalar is the same delay on every input.
    m : int
        Number of inputs.
    name : str, optional
        The argument's name in the messages.

    Returns
    -------
    ndarray, shape (m,)
        The dead times, finite and ``>= 0`` (negative zeros made positive).

    Raises
    ------
    TypeError
        When ``delay`` is not numeric.
    ValueError
        Naming ``name``: a negative or non-finite entry, or a count other than 1 or ``m``.

    Examples
    --------
    >>> check_delay(0.2, 3).tolist(), check_delay(None, 2).tolist()
    ([0.2, 0.2, 0.2], [0.0, 0.0])
    """
    if delay is None:
        return np.zeros(m)
    if isinstance(delay, bool | str):
        raise TypeError(f"{name} must be a number or one number per input, got {delay!r}")
    try:
        arr = np.asarray(delay, dtype=float).reshape(-1)
    except (TypeError, ValueError) as exc:
        raise TypeError(f"{name} must be a number or one number per input, got {delay!r}") from exc
    if arr.size == 1 and m != 1:
        arr = np.full(m, arr[0])
    if arr.size != m:
        raise ValueError(f"{name} must be one number or {m} (one per input), got {arr.size}")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"{name} must be finite and >= 0 (a dead time), got {arr.tolist()}")
    return arr + 0.0  # no negative zeros


def _pade_coefficients(order: int) -> Array:
    N = order
    return np.array(
        [factorial(2 * N - k) * factorial(N) / (factorial(2 * N) * factorial(k) * factorial(N - k))
         for k in range(N + 1)]
    )  # fmt: skip


def pade(tau: float, order: int) -> tuple[Array, Array, Array, Array]:
    """State-space ``(A, B, C, D)`` of the ``(order, order)`` Pade approximant of
    ``e^{-s tau}`` (module docstring).

    Realised for the normalised variable ``x = s tau`` (coefficients of order one) in
    controllable canonical form and scaled back, ``A = A_x / tau``, ``B = B_x / tau``, so
    no coefficient carries a power of ``tau``.  ``tau = 0`` (or ``order = 0``) is the
    static gain 1 with no state.

    Parameters
    ----------
    tau : float
        The dead time (``>= 0``).
    order : int
        ``N`` in ``0 .. MAX_PADE_ORDER``.

    Returns
    -------
    tuple of arrays
        ``A (N, N)``, ``B (N, 1)``, ``C (1, N)``, ``D (1, 1)``.

    Raises
    ------
    ValueError
        On a negative ``tau`` or an order outside the range.

    Examples
    --------
    >>> A, B, C, D = pade(0.5, 1)  # (1 - s/4) / (1 + s/4)
    >>> float(A[0, 0]), float(D[0, 0])
    (-4.0, -1.0)
    """
    tau = float(check_delay(tau, 1, "tau")[0])
    order = check_positive_int(order, "order", 0)
    if order > MAX_PADE_ORDER:
        raise ValueError(f"order must be at most {MAX_PADE_ORDER}, got {order}")
    if tau == 0.0 or order == 0:
        return np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), np.ones((1, 1))
    from scipy.signal import tf2ss

    c = _pade_coefficients(order)
    sign = (-1.0) ** np.arange(order + 1)
    num, den = (c * sign)[::-1], c[::-1]  # descending powers of x
    Ax, Bx, Cx, Dx = tf2ss(num, den)
    return Ax / tau, Bx / tau, Cx, Dx


def pade_order(tau: Array, w_max: float) -> int:
    """The smallest Pade order whose phase is within 1 degree of every delay up to ``w_max``.

    Parameters
    ----------
    tau : ndarray, shape (m,)
        The dead times.
    w_max : float
        Highest angular frequency (rad per time unit) where the phase must hold.

    Returns
    -------
    int
        From :data:`PADE_PHASE_RANGE` (the ``(N, N)`` approximant's phase is within 1 degree
        of ``-w tau`` for ``w tau`` up to ``PADE_PHASE_RANGE[N]``); 0 without delay; at most
        :data:`MAX_PADE_ORDER`, where the approximation holds only up to
        ``PADE_PHASE_RANGE[-1] / max(tau)``.

    Examples
    --------
    >>> import numpy as np
    >>> pade_order(np.array([0.1, 0.5]), 4.0)  # w tau = 2 needs N = 3 (range 3.07)
    3
    """
    x = float(np.max(tau, initial=0.0)) * float(w_max)
    if x == 0.0:
        return 0
    for N in range(1, MAX_PADE_ORDER + 1):
        if PADE_PHASE_RANGE[N] >= x:
            return N
    return MAX_PADE_ORDER


def _shifted_times(t: Array, tau: float) -> tuple[NDArray[np.intp], Array]:
    """For each ``t_k - tau``: the last sample ``i`` at or before it (``-1`` before the
    record) and the part step ``t_k - tau - t_i >= 0`` (0 before the record).  Within
    :data:`SNAP` of a sample is that sample."""
    s = t - tau
    tol = SNAP * float(np.min(np.diff(t))) if t.size > 1 else 0.0
    i = np.searchsorted(t, s + tol, side="right") - 1
    part = np.where(i >= 0, np.maximum(s - t[np.maximum(i, 0)], 0.0), 0.0)
    return i, part


def _groups(x: Array) -> tuple[Array, NDArray[np.intp]]:
    """Representatives of the values of ``x >= 0`` equal to 1e-12 of the largest, and each
    entry's group (as :func:`hdpbsid.models.simulation.step_groups` groups steps)."""
    top = float(np.max(x, initial=0.0))
    if top == 0.0:
        return np.zeros(1), np.zeros(x.size, dtype=np.intp)
    key = np.round(x / top, 12)
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    return x[first], inv.reshape(-1)


def delayed_input_terms(
    A: Array,
    B: Array,
    t: Array,
    u: Array,
    delay: Array,
    hold: str,
    Phi: Array,
    inv: NDArray[np.intp],
) -> tuple[Array, Array]:
    """The delayed input's contribution to each step and its value at each sample.

    With ``x_{k+1} = Phi[inv[k]] x_k + Bu[k]`` the exact step recursion of the delay-free
    system on the grid ``t`` (``Ns >= 2``), returns ``Bu (Ns - 1, n)`` for the input
    delayed by ``delay`` (module docstring) and ``ud (Ns, m)``, each input at ``t_k -
    tau_j`` under its hold (zero deviation before the record), for the direct term ``D
    ud``.

    Parameters
    ----------
    A, B : ndarray
        The delay-free system's matrices.
    t : ndarray, shape (Ns,)
        Sample times.
    u : ndarray, shape (Ns, m)
        Deviation input.
    delay : ndarray, shape (m,)
        Dead times.
    hold : str
        ``"zoh"`` or ``"foh"``.
    Phi, inv : ndarray
        The step matrices of the grid and each step's index into them.

    Returns
    -------
    tuple of arrays
        ``Bu (Ns - 1, n)``, ``ud (Ns, m)``.
    """
    from hdpbsid.models.recursion import linear_recursion

    ns, n = t.size, A.shape[0]
    h = np.diff(t)
    Bu = np.zeros((ns - 1, n))
    ud = np.zeros_like(u)
    for tau in np.unique(delay):
        cols = np.flatnonzero(delay == tau)
        Bj, uj = B[:, cols], u[:, cols]
        # the delay-free response z of these inputs on the grid, from zero
        hg, ginv = _groups(h)
        _, G1, G2, _ = sampled_steps(A, Bj, None, hg, hold)
        W = np.einsum("kij,kj->ki", G1[ginv], uj[:-1])
        if G2 is not None:
            W += np.einsum("kij,kj->ki", G2[ginv], np.diff(uj, axis=0))
        Z = linear_recursion(Phi[0], W, np.zeros(n)) if Phi.shape[0] == 1 else _loop(Phi, inv, W)
        # z and u at the shifted times
        i, part = _shifted_times(t, float(tau))
        inside = i >= 0
        ii = np.maximum(i, 0)
        nxt = np.minimum(ii + 1, ns - 1)
        frac = np.where(part > 0, part / np.where(ii < ns - 1, h[np.minimum(ii, ns - 2)], 1.0), 0.0)
        du = uj[nxt] - uj[ii]
        pg, pinv = _groups(part)
        Pp, P1, P2, _ = sampled_steps(A, Bj, None, pg, hold)
        Zs = np.einsum("kij,kj->ki", Pp[pinv], Z[ii]) + np.einsum("kij,kj->ki", P1[pinv], uj[ii])
        us = uj[ii].copy()
        if P2 is not None:
            Zs += np.einsum("kij,kj->ki", P2[pinv], frac[:, None] * du)
            us += frac[:, None] * du
        Zs[~inside] = 0.0
        us[~inside] = 0.0
        ud[:, cols] = us
        Bu += Zs[1:] - np.einsum("kij,kj->ki", Phi[inv], Zs[:-1])
    return Bu, ud


def _loop(Phi: Array, inv: NDArray[np.intp], W: Array) -> Array:
    X = np.zeros((W.shape[0] + 1, Phi.shape[1]))
    for k in range(W.shape[0]):
        X[k + 1] = Phi[inv[k]] @ X[k] + W[k]
    return X
