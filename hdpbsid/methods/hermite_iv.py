"""Instrumental variables for HD-PBSID: a consistent estimator in closed loop.

Why least squares is biased in the basis domain.  The VARX of HD-PBSID regresses the
output coefficients ``Y`` on ``Z M^j`` (``Z = [U; Y]``, ``M = D'^{-1}`` the integrator lag
of :mod:`hdpbsid.methods.hermite`).  For sampled data the lag is the shift ``S``, strictly
causal: ``(Z S^j)_k`` holds only ``z_{k-j}``, so with white innovations
``E[e_k (e S^j)_k] = 0``.  ``M`` is instead a full matrix with ``diag M != 0``: projected
white noise has (nearly) white coefficients ``E`` with covariance ``sigma^2 I``, and

    E[E (E M^j)^T] = sigma^2 tr(M^j) != 0,

so every regressor ``Y M^j`` (and ``U M^j`` in closed loop, where ``U`` carries the
fed-back noise) is correlated with the equation error and least squares converges to the
wrong predictor.  The diagonal of ``M^j`` is largest for the low (slow) indices, where
``D'`` is close to ``beta I / gamma``, and grows with ``alpha`` (``D' -> beta I / gamma``
as ``alpha -> inf``).  The bias does not shrink with more data.

The remedy here: instruments that are functions of an external signal ``r`` (the
reference or excitation added in the loop), which is independent of the noise.  Its
coefficient row ``R`` (projected like the input) lagged by the same operator,

    Psi = [R; R M; R M^2; ...; R M^L],

is uncorrelated with ``E`` for every ``L`` and correlated with the regressors (their
noise-free parts are filtered ``r``).  The pseudo-input rows (boundary and truncation
terms) are deterministic and are their own instruments.  Two-stage least squares on
``Psi`` (:func:`hdpbsid.core.varx.two_stage_ls`) gives a consistent VARX, and ``C`` is read
from ``Gamma`` (:func:`hdpbsid.core.pbsid.pbsid_core`).

What remains.  IV removes the correlation with the noise, not the truncation of the
VARX: ``y = sum_{j<=p} Xi_j z M^j + C At^p x M^p + e``, and the neglected term is a
filtered version of the reference too, so it biases IV as well.  The predictor
eigenvalue ``lambda`` maps to ``lambda / alpha + 1``, of modulus at least
``sqrt(1 - Re(lambda)^2 / |lambda|^2)`` for any ``alpha``: a lightly damped pair contracts
slowly (quadrotor pair ``-2.92 +- 3.24i``: 0.74 per lag, ``0.74^4 = 0.3`` at ``p = 4``),
and a larger ``p`` needs more instruments than the ``N`` coefficients support.  IV also
has a larger variance than least squares (in closed loop most of the input's power is
fed-back noise, which the reference does not explain).

Measured (closed-loop quadrotor, ``hdpbsid.studies.data.quadrotor_record`` with the
Hermite sweep, order 3, seeds ``[7, i]``; bias / STD in rad/s; median worst error):

========  =====================================  =====================================
SNR       least squares                          IV (``estimator="iv"``)
========  =====================================  =====================================
6 dB      pair 0.72/0.38, real 1.45/0.37, 46 %   pair 0.76/1.18, real 0.76/0.91, 25 %
10 dB     pair 0.36/0.23, real 0.71/0.30, 23 %   pair 0.53/0.77, real 0.22/0.77, 19 %
20 dB     pair 0.04/0.08, real 0.12/0.11, 3.0 %  pair 0.05/0.12, real 0.04/0.20, 5.2 %
========  =====================================  =====================================

(10 dB: 30 runs, else 12.)  With 4x longer records (120 s, 6 runs at 10 dB) least
squares keeps its bias (pair 0.40, real 0.47, STD 0.06/0.11) while IV's shrinks (0.12,
0.25): least squares is inconsistent, IV is not, up to the truncation term.

The least-squares bias grows with ``alpha`` (``diag M`` grows): with ``alpha`` about half
the default (3.04 rad/s against ``4 * scale`` = 6.1) least squares on the same records
(12 runs) gave median errors 22 % at 6 dB, 13 % at 10 dB, 3.1 % at 20 dB and 0.20 % at
50 dB (default: 46, 23, 3.0, 0.14 %); IV at that ``alpha``, 10 dB: 15 %, bias / STD 0.37
(pair) and 0.36 (real pole).

Number of lags: two-stage least squares needs at least as many instruments as regressors
that are not their own instruments, ``p (m + l)`` per output; more instruments lower the
variance but move the finite-sample estimate towards least squares (the bias of 2SLS
grows with the number of instruments over the concentration of the instruments; Bound,
Jaeger & Baker 1995).  :data:`INSTRUMENT_FACTOR` sets ``(L + 1) m_r = factor * p_max (m + l)``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..core.varx import LagOperator
from .basis_domain import P_DEFAULT_RANGE, project_record

__all__ = [
    "ESTIMATORS",
    "INSTRUMENT_FACTOR",
    "check_reference",
    "reference_instruments",
    "resolve_estimator",
]

Array = NDArray[np.float64]

#: accepted values of ``estimator`` of :func:`hdpbsid.methods.hermite.identify_hermite`
ESTIMATORS = ("ls", "iv")
#: instruments per non-exogenous regressor (module docstring).  Measured on the
#: closed-loop quadrotor at SNR 10 dB (8 runs, p = 4, median worst eigenvalue error):
#: factor 1 -> 62 %, 2 -> 26 %, 4 -> 15 %, 6 -> 17 %, 8 -> 16 % (least squares: 24 %):
#: with too few instruments 2SLS is weak (large spread), beyond ~4 nothing is gained
INSTRUMENT_FACTOR = 4.0


def check_reference(reference: Any, ns: int) -> Array:
    """``reference`` as an ``(Ns, m_r)`` finite float array with ``Ns`` rows."""
    try:
        r = np.asarray(reference, dtype=float)
    except (TypeError, ValueError) as exc:
        raise TypeError(
            f"reference must be a numeric array of Ns = {ns} samples, got "
            f"{type(reference).__name__}"
        ) from exc
    if r.ndim == 1:
        r = r[:, None]
    if r.ndim != 2 or r.shape[0] != ns:
        raise ValueError(
            f"reference must have Ns = {ns} samples (shape (Ns,) or (Ns, m_r)), got shape {r.shape}"
        )
    if not np.all(np.isfinite(r)):
        raise ValueError("reference must be finite (no NaN/inf)")
    if not np.any(r):
        raise ValueError("reference is identically zero: it cannot serve as an instrument")
    return r


def reference_instruments(
    basis: Any,
    t: Array,
    reference: Array,
    lag: LagOperator,
    n_regressors: int,
    hold: str = "zoh",
) -> Array:
    """The instrument rows ``[R; R M; ...; R M^L]`` (module docstring).

    ``reference`` (Ns, m_r) is projected like an input with ``hold`` (any deterministic
    function of ``r`` is a valid instrument; the hold only changes how strong it is).
    ``n_regressors`` is the number of regressors to instrument, ``p_max (m + l)``; ``L``
    gives ``ceil(INSTRUMENT_FACTOR * n_regressors)`` rows at least.  Rows are scaled to
    unit RMS.
    """
    m_r = reference.shape[1]
    R = project_record(basis, t, reference, reference[:, :1], (hold,))[0][0]
    n_lags = int(np.ceil(INSTRUMENT_FACTOR * n_regressors / m_r))
    rows = [R]
    W = R
    for _ in range(1, n_lags):
        W = lag.apply(W, 1)
        rows.append(W)
    Psi = np.vstack(rows)
    rms = np.sqrt(np.mean(Psi**2, axis=1))
    return Psi[rms > 0] / rms[rms > 0, None]


def resolve_estimator(
    estimator: Any,
    reference: Any,
    basis: Any,
    t: Array,
    lag: LagOperator,
    p: int | None,
    m: int,
    l: int,
) -> tuple[str, Array | None]:
    """``(estimator, instrument rows or None)`` for the ``estimator``/``reference``
    options of :func:`hdpbsid.methods.hermite.identify_hermite`.

    ``reference`` is checked whenever given; ``"iv"`` needs it.  The instruments cover
    the largest past window the core may use (``p``, else the top of the default range).
    """
    if not isinstance(estimator, str) or estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {ESTIMATORS}, got {estimator!r}")
    r = None if reference is None else check_reference(reference, t.size)
    if estimator == "ls":
        return estimator, None
    if r is None:
        raise ValueError(
            "estimator='iv' needs reference= (an external signal independent of the noise)"
        )
    p_max = p if p is not None else P_DEFAULT_RANGE[1]
    return estimator, reference_instruments(basis, t, r, lag, p_max * (m + l))
