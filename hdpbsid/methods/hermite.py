"""Method ``"hermite"``: HD-PBSID, PBSID in the Hermite-function domain (seed §3.2).

The record ``t, u, y`` is projected onto ``N`` Hermite functions ``phi_n`` (the record
fills 90 % of their effective support, :func:`slbasis.basis`'s default time scale).  With
coefficient rows ``X, U, Y, E`` (columns = Hermite index) the state equation becomes
(seed eqs. (3)-(4); the windowed state picks up the boundary terms)

    X Dd = A X + B U + K E + x(t0) phi(t0)^T - x(tN) phi(tN)^T,      Y = C X + D U + E,

where ``Dd = -Dmat`` (= ``Dmat^T``, ``Dmat`` the tridiagonal d/dt matrix of
:meth:`slbasis.Basis.derivative_matrix`, column ``n`` = image of ``phi_n``) is the
projected derivative in row form.  The seed's modified operator
``D' = (Dd/alpha + beta I)/gamma`` gives ``X D' = A' X + B' U + K' E + ...`` with
``A' = (A/alpha + beta I)/gamma``, ``B' = B/(alpha gamma)``, ``K' = K/(alpha gamma)``, and
the **integrator form** with ``M = D'^{-1}``:

    X = A' X M + B' U M + K' E M + (pseudo-inputs) M,

so the PBSID core runs with the lag ``W -> W M`` (regressors ``Z M^j``), ``M`` applied by
a tridiagonal (banded) solve.  Map back: ``A = alpha (gamma A' - beta I)``,
``B = alpha gamma B'``, ``K = alpha gamma K'``; ``C, D`` unchanged.

Truncation: the ``N x N`` cut of ``Dd`` misses, in its last column only, the coupling
``X_N Dd[N, N-1]`` to the discarded coefficient ``X_N`` (an unknown ``n``-vector).  It is
absorbed exactly as a pseudo-input with row ``e_{N-1}^T``, like the two boundary rows
``phi(t0)^T``, ``phi(tN)^T`` (DESIGN.md: 17-21 % -> 0.6-3 % on records not at rest).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import solve_banded

import slbasis

from ..checks import check_data, check_positive_int
from ..model import StateSpaceModel
from .basis_domain import (
    SolveLag,
    best_hold,
    check_method_args,
    clip_basis_size,
    data_bandwidth,
    integrator_model,
    project_record,
    resolve_holds,
)
from .hermite_iv import resolve_estimator

__all__ = ["identify_hermite", "hermite_lag", "default_hermite_N", "HERMITE_BAND"]

Array = NDArray[np.float64]

#: highest angular frequency (rad/s) of N Hermite functions filling 90 % of the support
#: over a record of length T: ``scale * sqrt(2N) = 0.9 * 2 N * 2 / T = 3.6 N / T``
HERMITE_BAND = 3.6
#: default N covers this multiple of the data bandwidth
BAND_MARGIN = 2.0
#: limits of the default N; the upper one only bounds the cost (evaluation is exact to
#: rounding at N = 5000, bench/basis.py): it binds on records longer than ~10^3 bandwidth
#: periods, with a warning
N_MIN, N_MAX = 100, 4000


def default_hermite_N(T: float, omega_b: float, ns: int) -> tuple[int, str]:
    """``N`` so that the basis covers ``BAND_MARGIN`` times the data bandwidth ``omega_b``.

    ``N = BAND_MARGIN omega_b T / 3.6`` clipped to ``[N_MIN, N_MAX]`` (DESIGN.md: N =
    200-300 worked on 20-40 s records; below ~30 the seed reports poor identification)
    and to ``Ns / 2`` (the samples must resolve the fastest basis function), with a
    warning when an upper limit binds (:func:`~hdpbsid.methods.basis_domain.clip_basis_size`).
    """
    return clip_basis_size(
        BAND_MARGIN * omega_b * T / HERMITE_BAND,
        N_MIN,
        N_MAX,
        ns,
        "hermite",
        f"N = {BAND_MARGIN} * bandwidth * T / {HERMITE_BAND}",
    )


def hermite_lag(
    Dmat: Any, alpha: float, beta: float, gamma: float
) -> tuple[SolveLag, NDArray[np.float64]]:
    """The integrator lag ``W -> W D'^{-1}`` for ``D' = (Dd/alpha + beta I)/gamma``.

    ``Dmat`` is the square ``N x N`` d/dt matrix (tridiagonal); ``Dd = -Dmat``.  Returns
    the :class:`~hdpbsid.methods.basis_domain.SolveLag` (banded solve with ``D'^T``) and the
    banded storage used.
    """
    Dd = -np.asarray(Dmat.toarray() if hasattr(Dmat, "toarray") else Dmat, dtype=float)
    N = Dd.shape[0]
    Dp = (Dd / alpha + beta * np.eye(N)) / gamma
    DpT = Dp.T
    ab = np.zeros((3, N))
    ab[0, 1:] = np.diagonal(DpT, 1)
    ab[1] = np.diagonal(DpT)
    ab[2, :-1] = np.diagonal(DpT, -1)

    def solve(W: Array) -> Array:
        # W M = W D'^{-1}  <=>  D'^T (W M)^T = W^T
        return solve_banded((1, 1), ab, W.T).T

    return SolveLag(solve, f"D'^-1, D' = (D/{alpha:.4g} + {beta:g} I)/{gamma:g}"), ab


def _real(x: Any, name: str, positive: bool = True) -> float:
    if isinstance(x, bool) or not isinstance(x, int | float | np.integer | np.floating):
        raise TypeError(f"{name} must be a real number, got {type(x).__name__}")
    x = float(x)
    if not np.isfinite(x) or (positive and x <= 0):
        raise ValueError(f"{name} must be a finite number{' > 0' if positive else ''}, got {x}")
    return x


def identify_hermite(
    t: Any,
    u: Any,
    y: Any,
    order: int | None = None,
    *,
    N: int | None = None,
    alpha: float | None = None,
    beta: float = 1.0,
    gamma: float = 1.0,
    p: int | None = None,
    f: int | None = None,
    boundary: bool = True,
    regularize: bool | str | float | None = "gcv",
    feedthrough: bool = False,
    stable_k: bool = False,
    normalize: bool = True,
    max_order: int | None = None,
    scale: float | None = None,
    input_hold: str = "auto",
    estimator: str = "ls",
    reference: Any = None,
) -> StateSpaceModel:
    """HD-PBSID (seed §3.2): continuous-time ``A, B, C, D, K`` from ``t, u, y``.

    ``t`` (Ns,) increasing, need not be uniform (projection weights from the spacing);
    ``u`` (Ns, m) or None, ``y`` (Ns, l).  See the module docstring for the equations.

    Defaults (all reported in ``model.options``):

    * ``N``: the basis covers twice the data bandwidth (:func:`default_hermite_N`);
      an explicit ``N`` whose band ``3.6 N / T`` is below the data bandwidth raises
      ``ValueError``;
    * ``scale``: the record fills 90 % of the effective support (``slbasis.basis``);
    * ``alpha = 4 * scale``, ``beta = gamma = 1`` (DESIGN.md: 0.1-1 % errors at SNR 20 dB;
      an eigenvalue ``lambda`` maps to ``(lambda/alpha + beta)/gamma``, inside the unit
      disc iff ``|lambda + alpha beta| < alpha gamma``: the stable predictor eigenvalues of
      moderate size; an unstable plant eigenvalue maps outside, e.g. +3.08 -> 1.49 on
      the quadrotor, which is fine: the truncation ``A'^p ~ 0`` concerns ``A - K C``);
    * ``p``: AIC over 2..4 with ``p (m + q + l) <= N / 6``; ``f = p`` (closed-loop
      quadrotor at 20 dB: with 2..6 AIC picked 6, and p = 4 has about half the spread);
    * ``order``: largest log-gap of the singular values (orders ``1..max_order``, 10);
    * ``input_hold="auto"``: how the input behaves between samples (``"zoh"`` held,
      ``"foh"`` linear, ``"trapezoid"`` the old product quadrature); ``"auto"`` fits both
      ``zoh`` and ``foh`` and keeps the smaller innovation variance
      (:func:`~hdpbsid.methods.basis_domain.project_record`);
    * ``boundary=True``: boundary rows ``phi(t0)``, ``phi(tN)`` as pseudo-inputs;
    * ``regularize="gcv"``, ``feedthrough=False``, ``stable_k=False``, ``normalize=True``
      as in :func:`hdpbsid.methods.dt.identify_dt`;
    * ``estimator="ls"``: least squares, HD-PBSID as published; biased when the noise is
      correlated with the regressors, i.e. always in the basis domain and more so in
      closed loop (:mod:`hdpbsid.methods.hermite_iv`).  ``"iv"``: instrumental variables
      built from ``reference`` ((Ns,) or (Ns, m_r): an external signal independent of
      the noise, e.g. the excitation added to the command in closed loop, or the input
      in open loop), with ``C`` from the observability matrix.  Chosen by measurement
      (closed-loop quadrotor, 12-30 runs, median worst eigenvalue error LS -> IV): 6 dB
      46 -> 25 %, 10 dB 23 -> 19 %, 20 dB 3.0 -> 5.2 %, 50 dB 0.14 -> 0.33 %: IV removes
      most of the bias but its variance is larger, so it wins only at low SNR and least
      squares stays the default.
    """
    t, u, y = check_data(t, u, y)
    ns, m = u.shape
    order, p, f, mo = check_method_args(order, p, f, max_order)
    beta = _real(beta, "beta")
    gamma = _real(gamma, "gamma")
    T = float(t[-1] - t[0])
    wb = data_bandwidth(t, u, y)
    if N is None:
        N, n_rule = default_hermite_N(T, wb, ns)
    else:
        N = check_positive_int(N, "N", 2)
        n_rule = "given"
        if HERMITE_BAND * N / T < wb:
            raise ValueError(
                f"N={N} Hermite functions over a record of {T:g} s cover only "
                f"{HERMITE_BAND * N / T:.3g} rad/s, below the data bandwidth {wb:.3g} rad/s "
                f"(99 % of the energy); use N >= {int(np.ceil(wb * T / HERMITE_BAND))}"
            )
        if N > ns:
            raise ValueError(f"N={N} exceeds the number of samples Ns={ns}; reduce N")
    if scale is not None:
        scale = _real(scale, "scale")
    basis = slbasis.basis("hermite", N, (float(t[0]), float(t[-1])), scale=scale)
    s = basis.scale
    alpha = 4.0 * s if alpha is None else _real(alpha, "alpha")
    holds = resolve_holds(input_hold, m)
    Us, Yc = project_record(basis, t, u, y, holds)
    lag, _ = hermite_lag(basis.derivative_matrix("square"), alpha, beta, gamma)
    est, Psi = resolve_estimator(estimator, reference, basis, t, lag, p, m, y.shape[1])
    rows = [np.eye(N)[N - 1]]  # truncation of the last column of the cut operator
    if boundary:
        rows += list(basis.eval(np.array([t[0], t[-1]])).T)
    P = np.array(rows)

    out, hold, hold_crit = best_hold(
        holds,
        Us,
        Yc,
        P,
        lag,
        order=order,
        p=p,
        f=f,
        max_order=mo,
        regularize=regularize,
        feedthrough=feedthrough,
        stable_k=stable_k,
        normalize=normalize,
        instruments=Psi,
    )
    options = {
        "method": "hermite",
        "N": N,
        "N_rule": n_rule,
        "bandwidth": wb,
        "scale": s,
        "centre": basis.centre,
        "alpha_rule": "4 * scale" if alpha == 4.0 * s else "given",
        "boundary": boundary,
        "truncation": "last column of the cut D absorbed as a pseudo-input",
        "n_samples": ns,
        "t0": float(t[0]),
        "estimator": est,
        "estimator_rule": "given" if estimator != "ls" else "default: least squares",
    }
    return integrator_model(
        out,
        alpha,
        beta,
        gamma,
        options,
        input_hold=input_hold,
        hold=hold,
        hold_criterion=hold_crit,
        order=order,
        max_order=mo,
    )
