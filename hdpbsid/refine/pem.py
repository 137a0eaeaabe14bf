"""Prediction-error refinement of an identified continuous-time model (``refine="pem"``).

Subspace methods give consistent but not efficient estimates; the standard remedy (what
MATLAB's ``ssest`` does after ``n4sid``; Ljung, *System Identification*, 2nd ed.,
sec. 7.3 and 10.6) is to use them as the initial point of a prediction-error (PEM) fit.
The parameters are the continuous-time ``A, B, C`` (``D`` too when the model has a
feedthrough) and ``K``; the criterion is the one-step prediction error of the sampled
innovation model, so it is exact for sampled data and consistent in closed loop
(Ljung sec. 13.4, "direct approach"): the predictor uses only past samples.

Sampling (uniform step ``h``): the innovation ``e`` is held over each interval as in
:mod:`hdpbsid.models.conversion` (``Kd = int_0^h e^{A s} ds K``), the input ``u`` with the hold
the method detected (``"zoh"``; ``"foh"``: linear between samples, handled with the
state ``xi_k = x_k - G2 u_k`` of Franklin, Powell & Workman, *Digital Control*, sec. 6.3,
which gives the feedthrough ``C G2 + D``).  The predictor

    xi_{k+1} = (Phi - Kd C) xi_k + (Gu - Kd Du) u_k + Kd y_k,   yhat_k = C xi_k + Du u_k,

is run by the compiled passes of :mod:`hdpbsid.refine.pem_kernels` (numba), or without
numba in its modal coordinates with :func:`scipy.signal.lfilter` (one first-order
recursion per eigenvalue); the unknown initial state enters linearly and is eliminated by
least squares at every evaluation (variable projection).  Residuals are weighted by the
inverse Cholesky factor of the innovation covariance of the initial model, re-estimated
once after convergence (a two-step approximation of the ``log det`` ML criterion).
The parametrisation is full (``n^2`` similarity directions are free); the search runs in
the data-driven local coordinates (the directions that change the predictor), re-centred
every few Levenberg-Marquardt steps (:func:`scipy.optimize.least_squares`,
``method="lm"``), with the exact Jacobian of the prediction errors (sensitivity
recursions, :mod:`hdpbsid.refine.pem_predictor`) instead of finite differences.
Local minima: the fit starts from the method's ``K`` and from the Kalman gain of a
sensor-noise-only model; the start whose Gauss-Newton step predicts the lower cost is
fitted to convergence, with the method's input hold, and the other only when its own
prediction could beat that minimum (:func:`_fit_starts`).  Unless the hold is known
(:func:`_candidate_holds`), the other hold is then screened from that end point by one
Gauss-Newton step, fitted when the step predicts evidence for it (:data:`EVIDENCE`), and
kept when its cost (same output weighting) is lower by a likelihood ratio significant at
1 % (:data:`HOLD_EVIDENCE`) with every mode resolved by the sampling
(:func:`_other_hold`, :func:`_modes_resolved`).  Measured on a Table-2-like closed loop
(plant eigenvalues -28, -10, 1.2 +- 5.8i, rate output, 250 Hz, 20 dB, seeds 0-4): the
subspace model chose ``foh`` for ``zoh`` data and the ``foh`` fit stopped 22-25 % and
32-45 % off on the two real poles at a stationary point of the ``foh`` cost (the
prediction-error cost of the ``zoh`` predictor falls monotonically on the straight line
from that point to the ``zoh`` optimum: the data prefer the other structure); with the
hold chosen here all four eigenvalues are within 1-6 %; the screen passes the zoh hold
on every one of those seeds.  When the modes are slow against the sampling (``|lambda|
h`` of a few hundredths) a model with either hold absorbs the half-sample shift and the
screen finds no evidence for the other: the first hold is kept at the cost of one
evaluation (10^4-sample binary record: the other hold's fit took 3-9 evaluations and
ended within ``2e-5`` relative of the first's cost).  On noise-free data the first
hold's cost can be so small that the other hold does not beat it and the method's hold
is kept (the bias is then the half-sample shift, ~``h |lambda| / 2``).

A fit ends when a Levenberg-Marquardt run lowers the cost by less than the statistical
resolution (:data:`STALL_SD`).  A stop at the stability boundary of the predictor
(refused unstable trial steps and a small gain) was tried and removed: the same pattern
occurs at good interior minima whose noise model is nearly degenerate (open-loop 2x2
benchmark: the predictor's radius reached 0.999997 along a flat direction of ``K`` while
the plant's eigenvalues were within 0.2 %), so it dropped good fits.  The fits it was
built for (closed-loop CT-PBSID starts pressed against the boundary) came from a free
``D`` (:func:`_fits_feedthrough`) and now converge.

Cost (closed-loop quadrotor, 7500 samples, HD-PBSID start, SNR 20 dB, seed 0, load ~1
on 2 cores): one residual evaluation 3.0 ms with the numpy evaluation, 1.1 ms compiled;
one Jacobian (15 directions) 21 ms and 2.2-3.1 ms.  ``identify(..., method="hermite",
refine="pem")`` on that record and three others (SNR 20/10 dB, seeds 0-1): 510-650 ms ->
220-290 ms, with the same 24-32 evaluations and the same end points (eigenvalues equal
to 1e-13 relative); most of what remains is Levenberg-Marquardt's own QR of the
``15000 x 15`` Jacobian.  Earlier (SNR 10 dB, seeds 0-3, load ~9): 1.1-1.7 s per
refinement; with finite-difference Jacobians and both starts run to convergence it took
26-70 s (89-186 evaluations plus 15 more per Jacobian) and reached the same end points
(eigenvalue errors identical to the printed digits).

Measured on the closed-loop quadrotor at SNR 20 dB (seeds 0-11, order 3, from the
HD-PBSID model): the refinement mostly removes outliers and brings the spread of the
real pole to about the linearised bound at the truth, and the reported standard
deviations match the errors (the numbers are in the benchmark pages).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from functools import partial
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm, solve_discrete_are

# is_uniform: the package's one uniformity test (hdpbsid.data.checks), re-exported here
from hdpbsid.data.checks import check_data, is_uniform
from hdpbsid.models.model import StateSpaceModel
from hdpbsid.models.recursion import select_kernels
from hdpbsid.models.report import WARM_START_OPTION, Choice, Refinement, WarmStart
from hdpbsid.models.uncertainty import ParameterCovariance, covariance_factor, scale_factor
from hdpbsid.refine.pem_predictor import conjugate_representatives, modal_filter, sampled_predictor
from hdpbsid.runtime import library_call, user_stacklevel

__all__ = [
    "refine_pem",
    "one_step_errors",
    "warm_start_option",
    "is_uniform",
    "REFINE_CHOICES",
]

Array = NDArray[np.float64]

#: accepted values of the ``refine`` option of :func:`hdpbsid.identify`
REFINE_CHOICES = ("auto", "pem", None)
#: residual vectors a :class:`_Record` remembers
RECORD_MEMORY = 4
#: Jacobians a :class:`_Record` remembers: one per starting point of :func:`_fit_starts`
JACOBIAN_MEMORY = 2
#: residual returned (per entry, in units of the weighted innovation) for an unstable
#: predictor: far above any attainable cost, so Levenberg-Marquardt rejects the step
UNSTABLE_PENALTY = 1e3
#: Levenberg-Marquardt evaluations per run (each costs one Jacobian as well): measured
#: 95-324 over both starts on the closed-loop quadrotor; the bound stops the rare long
#: crawl along a flat valley (one seed once needed 761 for a 0.1 % change)
DEFAULT_MAX_NFEV = 150
#: Levenberg-Marquardt tolerances.  ``ftol`` (relative cost change of a step, actual
#: and predicted) is set per problem to ``STALL_SD^2 / n_r``, the statistical resolution
#: of :data:`STALL_SD` (a step gaining less moves the estimate by less than a tenth of
#: its standard deviation); measured on the closed-loop quadrotor (seed 0, runs 0-2,
#: 50/20/10 dB, HD-PBSID and CT-PBSID starts) against the former fixed 1e-10: 20-35 %
#: fewer evaluations, eigenvalues equal to 0.01 % of their value.  Scipy's default
#: (1e-8) had stopped early on noisy finite-difference Jacobians (used before the
#: analytic one), which is why a fixed, much smaller value was used.
REFINE_XTOL = 1e-8
#: convergence at the statistical resolution: the cost is the mean of ``n_r`` squared
#: whitened residuals, so near the minimum moving the parameters by ``delta`` standard
#: deviations (along any direction of the parameter covariance) raises it by about
#: ``delta^2 / n_r`` relative.  A chart run that lowers the cost by less than
#: ``STALL_SD^2 / n_r`` therefore moved the estimate by less than ``STALL_SD`` of its own
#: standard deviation: further iterations change nothing a user could see.  (The
#: Levenberg-Marquardt tolerances alone never stop at such a minimum when rounding makes
#: the last rejected steps look productive: the open-loop 2x2 benchmark reached its
#: optimum in 48-60 evaluations and then ran out of the budget without "converging".)
STALL_SD = 0.1
#: Levenberg-Marquardt evaluations per run before the local coordinates are re-centred:
#: far from the optimum the first chart can be poor (closed-loop quadrotor at 10 dB from
#: the subspace K: 96 evaluations in one chart to a cost that two re-centred charts beat
#: in 35)
DDLC_RUN_NFEV = 12
#: a run that converges within this many evaluations ends the fit (the re-centred chart
#: did not move)
DDLC_CONVERGED_NFEV = 3
#: Levenberg-Marquardt statuses of :func:`scipy.optimize.least_squares` (``method="lm"``)
#: of the cost reduction test at ``ftol``, the statistical resolution (:data:`STALL_SD`)
#: (2; 4 with the step test too).  Such a run ends the fit, whatever its length, when it
#: ended where the Gauss-Newton model at its centre predicted (within :data:`EVIDENCE`
#: units): the centre was then in the quadratic region of the minimum, where the chart's
#: directions ``Q`` and the similarity directions (along which the cost is constant)
#: together span the parameter space, so a minimum along ``Q`` is one of the full
#: parametrisation.  The re-centred run that confirms it otherwise cost two evaluations
#: and ended where it started (10^4-sample binary record and closed-loop quadrotor: every
#: fit, status 2 after 5-9 evaluations, then 2 more).  The prediction test keeps the
#: argument where it holds: far from a minimum the chart can be distorted (the reason
#: the local coordinates are re-centred at all, :data:`DDLC_RUN_NFEV`)
FTOL_STATUS = (2, 4)
#: input holds the sampled predictor handles (module docstring)
HOLDS = ("zoh", "foh")
#: the option that carried a further starting point in earlier versions (now the
#: ``warm_start`` argument of :func:`refine_pem`), and the default name of that start in
#: ``options["refine_start"]``
WARM_START = WARM_START_OPTION
WARM_START_NAME = "prediction-error fit on part of the record"
#: a second starting point or the other input hold is fitted only when one Gauss-Newton
#: step predicts a drop of the ``-2 log`` likelihood ratio (``n_r`` times the relative
#: cost drop, whitened residuals) of at least this much below the best minimum found:
#: the candidates are structures (or points) of equal dimension, and a ratio below
#: ``e^(1/2)`` -- one unit on the scale of a chi-square variable with one degree of
#: freedom -- is no evidence for either (:func:`_fit_starts`, :func:`_other_hold`)
EVIDENCE = 1.0
#: the other input hold replaces the first only when its fit lowers the ``-2 log``
#: likelihood ratio (``n_r`` times the log cost ratio, whitened residuals) by at least
#: this much: the chi-square quantile of one degree of freedom at 1 %.  The two holds
#: differ, to first order in ``|lambda| h``, by half a sample of input delay, one
#: direction of the model (Franklin, Powell & Workman, *Digital Control*, sec. 6.3).  A
#: switch on any lower cost chooses the other hold on noise alone whenever the data
#: cannot tell the holds apart, and the continuous-time response then moves by the
#: half-sample phase ``w h / 2``, outside the parameter covariance's band, which is
#: conditional on the hold; keeping the first hold unless the data reject it at 1 %
#: makes that wrong switch a 1 % event.
HOLD_EVIDENCE = 6.635
#: process-noise intensity (relative to unit measurement noise, scaled data) of the
#: second starting gain: the Kalman predictor of a sensor-noise-dominated record.  From
#: the subspace K alone, 1 of 11 quadrotor seeds stopped at a predictor pole on the unit
#: circle (cost above the true system's)
OE_PROCESS_NOISE = 1e-6


class _Layout:
    """Where ``A, B, C, D, K`` sit in the parameter vector."""

    def __init__(self, n: int, m: int, l: int, feedthrough: bool) -> None:
        self.n, self.m, self.l, self.feedthrough = n, m, l, feedthrough
        sizes = [n * n, n * m, l * n, l * m if feedthrough else 0, n * l]
        self.stops = np.cumsum([0, *sizes])

    def pack(self, A: Array, B: Array, C: Array, D: Array, K: Array) -> Array:
        parts = [A, B, C, D if self.feedthrough else np.zeros(0), K]
        return np.concatenate([np.ravel(p) for p in parts])

    def unpack(self, theta: Array) -> tuple[Array, Array, Array, Array, Array]:
        n, m, l = self.n, self.m, self.l
        s = self.stops
        A = theta[s[0] : s[1]].reshape(n, n)
        B = theta[s[1] : s[2]].reshape(n, m)
        C = theta[s[2] : s[3]].reshape(l, n)
        D = theta[s[3] : s[4]].reshape(l, m) if self.feedthrough else np.zeros((l, m))
        K = theta[s[4] : s[5]].reshape(n, l)
        return A, B, C, D, K


class _Record:
    """:func:`_residuals` of one record for one input hold, ``(theta, W, jac=False,
    directions=None)``, remembering the last :data:`RECORD_MEMORY` residual vectors, and
    the buffers of the compiled evaluation (:class:`_Workspace`).

    An evaluation is a pure function of its arguments, and the fit asks for the same
    residuals again: every re-centred Levenberg-Marquardt run starts where the previous
    one ended, and :func:`_lm_fit` evaluates the cost at a run's end point (closed-loop
    quadrotor, 7500 samples: 7 of 32 residual evaluations were repeats; Jacobians are
    not asked twice by :func:`scipy.optimize.least_squares`, which keeps its last one,
    but the Gauss-Newton screens, :func:`_fit_starts` and :func:`_other_hold`, ask for
    the Jacobian at the point and in the directions a run then starts from, so the last
    :data:`JACOBIAN_MEMORY` are remembered too: one per starting point).  A remembered
    result is returned read-only, so no caller can alter it.
    """

    def __init__(self, lay: _Layout, u: Array, y: Array, h: float, hold: str) -> None:
        self.lay, self.h, self.hold = lay, h, hold
        self.u = np.ascontiguousarray(u, dtype=float)
        self.y = np.ascontiguousarray(y, dtype=float)
        self._memory: dict[tuple[Any, ...], Any] = {}
        self._jacobians: list[tuple[tuple[Any, ...], Any]] = []
        self._workspace = _Workspace()

    def __call__(
        self, theta: Array, W: Array, jac: bool = False, directions: Array | None = None
    ) -> Array | tuple[Array, Array]:
        theta = np.asarray(theta, dtype=float)
        key = (theta.tobytes(), np.asarray(W, dtype=float).tobytes())
        if not jac and key in self._memory:
            return self._memory[key]
        if jac:
            jkey = (*key, None if directions is None else np.asarray(directions).tobytes())
            for k, out in self._jacobians:
                if k == jkey:
                    return out
        out = _residuals(
            theta,
            self.lay,
            self.u,
            self.y,
            self.h,
            self.hold,
            W,
            jac,
            directions,
            workspace=self._workspace,
        )
        r = out[0] if jac else out
        r.setflags(write=False)
        if key not in self._memory:
            if len(self._memory) >= RECORD_MEMORY:
                del self._memory[next(iter(self._memory))]  # the oldest
            self._memory[key] = r
        if jac:
            out[1].setflags(write=False)
            self._jacobians = [*self._jacobians[-(JACOBIAN_MEMORY - 1) :], (jkey, out)]
        return out


def _is_stable(lam: NDArray[np.complex128]) -> bool:
    return bool(np.all(np.isfinite(lam)) and np.max(np.abs(lam)) < 1.0)


def _candidate_holds(model: StateSpaceModel, hold: str | None) -> tuple[str, ...]:
    """The input holds the refinement fits: ``hold`` when given; the model's
    ``options["input_hold"]`` when the method was told it (``input_hold_rule ==
    "given"``); with no input, one (the hold is then irrelevant); otherwise both, the
    model's first.

    Why both: a subspace method's choice of hold (the smaller AIC of its least-squares VARX
    fit) is made on biased residuals in closed loop, and the wrong hold is
    not a small error: it shifts the input by half a sample, which a model of fixed order
    absorbs by moving its fast modes (Table-2-like loop, rate output, 20 dB: HD-PBSID
    picked ``foh`` for data held by ``zoh`` on 5 of 5 seeds, and the ``foh``
    refinement put the poles at -28 and -10 22 % and 38 % off, the ``zoh`` one 1 % and
    4 %).  The two sampled predictors have the same parameters and the same data, so
    their prediction-error costs under one weighting compare directly (the likelihood
    ratio of two structures of equal dimension; Ljung, *System Identification*, 2nd ed.,
    sec. 16.4): the hold is chosen with the starting point, by the same criterion.
    """
    if hold is not None:
        return (hold,)
    own = model.report.hold
    own = own if own in HOLDS else "zoh"
    if model.m == 0 or _hold_was_given(model):
        return (own,)
    return (own, *(hd for hd in HOLDS if hd != own))


def _other_hold(
    theta: Array,
    cost: float,
    lay: _Layout,
    residuals: Callable[..., Any],
    kw: dict,
    budget: int,
    starts: dict[str, Array],
) -> tuple[Array, float, int, str, bool]:
    """The other input hold's fit, given the first hold's end point ``theta`` (cost
    ``cost``) and the refinement's starting points ``starts``.

    One Gauss-Newton step from ``theta`` screens it (:func:`_gauss_newton_cost`): without
    a predicted drop below ``cost`` by at least :data:`EVIDENCE` (in units of ``-2 log``
    likelihood ratio) the data give no evidence for the other hold, and it is dropped
    after that one evaluation (returned with an infinite cost).  With evidence, the
    structure the first hold was fitted in is in question, and so is the path it took:
    the other hold is fitted to convergence from ``theta`` *and* from every starting
    point, and the lowest cost among the converged fits is returned (random third-order
    system, input linear between samples fitted first with a hold: from the zoh optimum
    the foh fit stopped at a cost of 0.226 and a 9.6 % pair; from the subspace start it
    reached 0.12 and 0.66 %).  The starting points go first, and the fits share the
    evaluation ``budget``.  Records whose holds the data cannot tell apart (the common
    case: modes slow against the sampling) pay only the screen."""
    _, predicted = _gauss_newton_cost(theta, lay, residuals)
    n_r = residuals(theta).size
    if not predicted < cost * (1.0 - EVIDENCE / n_r):
        message = (
            f"not fitted: one Gauss-Newton step predicts {predicted:.6g}, not below "
            f"{cost:.6g} by {EVIDENCE:g}/{n_r} of it (no evidence for this hold)"
        )
        return theta, float("inf"), 1, message, True
    spent = 1
    best: tuple[Array, float, int, str, bool] | None = None
    for th in (*starts.values(), theta):
        if spent >= budget:
            break
        fit = _lm_fit(th, lay, residuals, kw, budget - spent)
        spent += fit[2]
        # a converged fit beats an unconverged one; then the lower cost wins
        if best is None or (fit[4], -fit[1]) > (best[4], -best[1]):
            best = fit
    assert best is not None
    return best[0], best[1], spent, best[3], best[4]


def _fit_starts(
    starts: dict[str, Array],
    lay: _Layout,
    residuals: Callable[..., Any],
    kw: dict,
    budget: int,
    n_r: int,
) -> tuple[dict[str, tuple], dict[str, float], dict[str, float], int]:
    """Levenberg-Marquardt from the starting points, the most promising first.

    Each start is ranked by the cost one Gauss-Newton step from it predicts
    (:func:`_gauss_newton_cost`) and fitted to convergence in that order; a later start
    is fitted only when its prediction is below the best converged cost so far by
    :data:`EVIDENCE` (``-2 log`` likelihood-ratio units), i.e. when its own local model
    says it may reach a better minimum.  Returns ``(fits by start, start costs,
    predictions, extra evaluations)`` with the skipped starts left out of the fits (the
    screen costs one evaluation per start, counted in the extra evaluations).

    Why a prediction and not a probe of a few iterations from every start (the former
    rule: six evaluations each, the better one continued): the start nearer a minimum is
    in the region where the Gauss-Newton model is accurate, and its prediction is then
    close to where it converges (10^4-sample binary record, the measurement-noise gain:
    predicted 0.9229, reached 0.92295), while the probe of the other start is spent for
    nothing (the subspace gain there: 0.941 predicted, 0.962 after six evaluations).  The
    prediction is not a bound: from a start far from the minimum the fit can also go
    lower than one step predicts, so a start skipped on its prediction can, rarely,
    have led lower; on random stable systems of order 1-4 (open and closed loop) the
    rule reached the same or a lower cost on almost every record at less CPU time than
    probing every start (``bench/regression.py`` guards it).
    """
    screen = {name: _gauss_newton_cost(th, lay, residuals) for name, th in starts.items()}
    predicted = {name: sc[1] for name, sc in screen.items()}
    fits: dict[str, tuple] = {}
    spent = 0
    for name in sorted(starts, key=lambda k: predicted[k]):
        best = min((f[1] for f in fits.values()), default=np.inf)
        if fits and not predicted[name] < best * (1.0 - EVIDENCE / n_r):
            continue
        fit = _lm_fit(starts[name], lay, residuals, kw, budget - spent)
        spent += fit[2]
        fits[name] = fit
    return fits, {name: sc[0] for name, sc in screen.items()}, predicted, len(starts)


def _gauss_newton_cost(
    theta: Array, lay: _Layout, residuals: Callable[..., Any], Q: Array | None = None
) -> tuple[float, float]:
    """Mean squared residual at ``theta`` and at the minimum of the Gauss-Newton model
    of ``residuals`` around ``theta`` (in the local coordinates of :func:`_ddlc_basis`):
    ``(||r||^2 - ||P_J r||^2) / n_r`` with ``P_J`` the projection on the Jacobian's
    columns (Nocedal and Wright, *Numerical Optimization*, 2nd ed., sec. 10.3).  Near a
    minimum with noise-like residuals the neglected second-order term of the Hessian is
    small and this is the cost one step reaches.  ``Q``: the local coordinates at
    ``theta`` when the caller has them already."""
    Q = _ddlc_basis(lay, theta) if Q is None else Q
    r, J = residuals(theta, jac=True, directions=Q)
    cost = float(np.mean(r**2))
    if not np.all(np.isfinite(J)):
        return cost, float("-inf")  # nothing can be concluded: let the fit decide
    coef = np.linalg.lstsq(J, r, rcond=None)[0]
    return cost, float(np.mean((r - J @ coef) ** 2))


def _modes_resolved(lay: _Layout, theta: Array, h: float) -> bool:
    """Whether every eigenvalue of ``A`` satisfies ``|lambda| h < pi``: a mode faster
    than the sampling resolves (beyond the Nyquist frequency, or decaying within a
    fraction of a sample) acts on the sampled data like a delay or a direct term, and
    that is how a model with the wrong hold can absorb the half-sample shift of the
    input (closed-loop quadrotor, 10 dB: the ``foh`` fit of ``zoh`` data lowered the cost
    with a pole at -1293 rad/s, ``h = 4`` ms)."""
    lam = np.linalg.eigvals(lay.unpack(theta)[0])
    return bool(np.all(np.abs(lam) * h < np.pi))


def _hold_was_given(model: StateSpaceModel) -> bool:
    """Whether the method that produced ``model`` was told its input hold (the basis
    methods report the hold's reason ``"given"`` then)."""
    return model.report.input_hold is not None and model.report.input_hold.given


def _kalman_gain(A: Array, C: Array, h: float, q: float) -> Array:
    """Continuous ``K`` of the steady-state Kalman predictor of the sampled model with
    process noise ``q I`` and unit measurement noise (filter DARE; stable whenever
    ``(A, C)`` is detectable), mapped back with ``Kd = int_0^h e^{A s} ds K``
    (:mod:`hdpbsid.models.conversion`)."""
    n, l = A.shape[0], C.shape[0]
    E = expm(np.block([[A * h, np.eye(n) * h], [np.zeros((n, 2 * n))]]))
    Phi, Psi = E[:n, :n], E[:n, n:]
    P = solve_discrete_are(Phi.T, C.T, q * np.eye(n), np.eye(l))
    Kd = Phi @ P @ C.T @ np.linalg.inv(C @ P @ C.T + np.eye(l))
    return np.linalg.solve(Psi, Kd)


def _lm_fit(
    theta: Array,
    lay: _Layout,
    residuals: Callable[..., Any],
    kw: dict,
    budget: int,
) -> tuple[Array, float, int, str, bool]:
    """Levenberg-Marquardt on ``residuals(theta)`` from ``theta`` with the analytic
    Jacobian ``residuals(theta, jac=True, directions=Q)``, in local coordinates ``Q``
    re-centred after every run of at most ``DDLC_RUN_NFEV`` evaluations, until a run
    converges within ``DDLC_CONVERGED_NFEV`` evaluations (the chart no longer moves), a
    run lowers the cost by less than the statistical resolution (:data:`STALL_SD`), or
    ``budget`` evaluations are spent.  Returns ``(theta, cost, nfev, message,
    converged)``; ``converged`` is False when the budget ran out first."""
    nfev, message, converged = 0, "no evaluation budget", False
    while nfev < budget:
        Q = _ddlc_basis(lay, theta)
        centre = theta
        # the Gauss-Newton prediction at the centre (its Jacobian is the run's first one)
        _, predicted = _gauss_newton_cost(theta, lay, residuals, Q)
        trace: list[float] = []  # cost of every evaluation of this run, in order

        def fun(
            beta: Array, centre: Array = centre, Q: Array = Q, trace: list[float] = trace
        ) -> Array:
            r = residuals(centre + Q @ beta)
            trace.append(float(np.mean(r**2)))
            return r

        def jac(beta: Array, centre: Array = centre, Q: Array = Q) -> Array:
            return residuals(centre + Q @ beta, jac=True, directions=Q)[1]

        run = min(DDLC_RUN_NFEV, budget - nfev)
        from scipy.optimize import least_squares  # here: scipy.optimize is slow to import

        sol = least_squares(fun, np.zeros(Q.shape[1]), jac=jac, max_nfev=run, **kw)
        theta = centre + Q @ sol.x
        nfev += int(sol.nfev)
        message = sol.message
        cost = float(np.mean(sol.fun**2))
        if (sol.status > 0 and sol.nfev <= DDLC_CONVERGED_NFEV) or (
            sol.status in FTOL_STATUS and cost <= predicted * (1.0 + EVIDENCE / sol.fun.size)
        ):
            converged = True
            break
        # the gain of this run, from its first evaluation (its start) to its end point
        if trace and trace[0] - cost < STALL_SD**2 * cost / sol.fun.size:
            converged = True
            message = (
                f"a run lowered the cost by less than ({STALL_SD} standard deviation)^2 / "
                f"{sol.fun.size} residuals"
            )
            break
    cost = float(np.mean(residuals(theta) ** 2))
    return theta, cost, nfev, message, converged


def _residuals(
    theta: Array,
    lay: _Layout,
    u: Array,
    y: Array,
    h: float,
    hold: str,
    W: Array,
    jac: bool = False,
    directions: Array | None = None,
    engine: str = "auto",
    workspace: _Workspace | None = None,
) -> Array | tuple[Array, Array]:
    """Weighted one-step prediction errors, initial state eliminated (module docstring),
    and with ``jac=True`` their Jacobian (:func:`_residuals_numpy`).

    ``engine``: ``"numba"`` runs the passes over the samples compiled
    (:mod:`hdpbsid.refine.pem_kernels`, :func:`_residuals_compiled`), ``"numpy"`` with
    :func:`scipy.signal.lfilter` (:func:`_residuals_numpy`); ``"auto"`` is ``"numba"``
    when numba is installed and not switched off (``SLBASIS_NO_NUMBA``).  The two agree
    to rounding.  ``workspace``: buffers the compiled evaluation reuses between calls
    (:class:`_Workspace`; default: new ones).
    """
    kernels = _kernels(engine)
    if kernels is None:
        return _residuals_numpy(theta, lay, u, y, h, hold, W, jac, directions)
    ws = _Workspace() if workspace is None else workspace
    return _residuals_compiled(theta, lay, u, y, h, hold, W, jac, directions, kernels, ws)


class _Workspace:
    """Buffers of the compiled evaluation kept between calls, one per name and shape.

    The passes write ``(Ns, n p + p + l n)`` and ``(l, Ns, n)`` arrays (about 2 MB at
    7500 samples); allocated afresh at every evaluation, they are returned to the
    operating system and faulted in again (Table-1 record, fastest of 100 calls: 3.9 ms
    a Jacobian with fresh buffers, 3.1 ms with these)."""

    def __init__(self) -> None:
        self._buffers: dict[str, Array] = {}
        #: ``(key, results)`` of the last error pass, whose free response the buffers
        #: hold: a Jacobian at the point of the last residual evaluation (each one
        #: Levenberg-Marquardt asks for) starts from it instead of repeating the pass
        self.error_pass: tuple[tuple[Any, ...], tuple[Any, ...]] | None = None

    def get(self, name: str, shape: tuple[int, ...]) -> Array:
        """An uninitialised float array of ``shape`` owned by this workspace."""
        buf = self._buffers.get(name)
        if buf is None or buf.shape != shape:
            buf = np.empty(shape)
            self._buffers[name] = buf
            if name == "free response":
                self.error_pass = None  # it was in the old buffer
        return buf


def _load_kernels() -> ModuleType:
    from hdpbsid.refine import pem_kernels

    return pem_kernels


def _kernels(engine: str) -> ModuleType | None:
    """The refinement's compiled kernels for ``engine`` (``None``: the numpy evaluation)."""
    return select_kernels(engine, _load_kernels)


def _residuals_numpy(
    theta: Array,
    lay: _Layout,
    u: Array,
    y: Array,
    h: float,
    hold: str,
    W: Array,
    jac: bool = False,
    directions: Array | None = None,
) -> Array | tuple[Array, Array]:
    """Weighted one-step prediction errors, initial state eliminated (module docstring).

    With ``jac=True`` also their Jacobian with respect to ``theta`` (``(l Ns, P)``), or
    along the columns of ``directions`` (``P x q``: ``(l Ns, q)``, the derivative matrices
    are combined first, so only ``q`` sensitivities are filtered):
    the exact derivative of the errors at the fitted initial state ``x0``
    (:mod:`hdpbsid.refine.pem_predictor`), projected on the orthogonal complement of the
    free-response columns.  That is Kaufman's form of the variable-projection Jacobian
    (Golub & Pereyra, *Inverse Problems* 19 (2003), sec. 3), and ``J^T J`` equals the
    Schur complement of the joint ``(theta, x0)`` information, so the covariance of
    ``theta`` with ``x0`` marginalised is ``s^2 (J^T J)^+``.
    """
    A, B, C, D, K = lay.unpack(theta)
    pr = sampled_predictor(A, B, C, D, K, h, hold, lay.feedthrough, derivatives=jac)
    ns, n, l = y.shape[0], lay.n, lay.l
    lam, V = np.linalg.eig(pr.F)
    if not _is_stable(lam) or np.linalg.cond(V) > 1.0 / np.finfo(float).eps:
        r = np.full(ns * l, UNSTABLE_PENALTY)
        q = theta.size if directions is None else directions.shape[1]
        return (r, np.zeros((r.size, q))) if jac else r
    Vi = np.linalg.inv(V)
    # a real signal is sum_a V[:, a] z_a over the modes; the conjugate of a complex mode
    # carries the conjugate coordinate, so one mode per pair is filtered and counted twice
    keep, fac = conjugate_representatives(lam)
    lk, Vk, Vik = lam[keep], V[:, keep], Vi[keep]
    uT, yT = u.T, y.T
    Zk = modal_filter(lk, _cr(Vik @ pr.G, uT) + _cr(Vik @ pr.Kd, yT))  # from xi_0 = 0
    CVk = (C @ Vk) * fac[None, :]
    E = yT - _cr(CVk, Zk).real - pr.Du @ uT
    # free response to xi_0 (eliminated by least squares): y_k = C V diag(lam^k) Vi xi_0
    pw = np.cumprod(np.hstack([np.ones((lk.size, 1)), np.repeat(lk[:, None], ns - 1, 1)]), 1)
    F = np.matmul(((W @ CVk)[:, :, None] * pw[None]).transpose(0, 2, 1), Vik).real
    Ew = W @ E
    Fr = F.reshape(-1, n)  # (l Ns, n), rows ordered like Ew.ravel()
    FtF = Fr.T @ Fr
    x0 = np.linalg.solve(FtF, Fr.T @ Ew.ravel())
    r = Ew.ravel() - Fr @ x0
    if not jac:
        return r
    assert pr.dF is not None and pr.dG is not None and pr.dKd is not None
    assert pr.dC is not None and pr.dDu is not None
    xi = ((Vk * fac[None, :]) @ (Zk + pw * (Vik @ x0)[:, None])).real  # with x0, (n, Ns)
    dF, dG, dKd, dC, dDu = pr.dF, pr.dG, pr.dKd, pr.dC, pr.dDu
    if directions is not None:
        dF, dG, dKd, dC, dDu = (
            np.tensordot(directions.T, d, axes=1) for d in (dF, dG, dKd, dC, dDu)
        )
    q, nk, m = dF.shape[0], lk.size, u.shape[1]
    # modal drive of the sensitivities, Vi (dF xi + dG u + dKd y), as 2-D products
    drive = (
        _cr((Vik @ dF).reshape(q * nk, n), xi)
        + _cr((Vik @ dG).reshape(q * nk, m), uT)
        + _cr((Vik @ dKd).reshape(q * nk, l), yT)
    )
    S = modal_filter(lk, drive.reshape(q, nk, ns))
    dE = (dC.reshape(q * l, n) @ xi + dDu.reshape(q * l, m) @ uT).reshape(q, l, ns)
    for a in range(nk):  # C d(xi) = sum over modes of C V[:, a] s_a
        dE += (CVk[None, :, a, None] * S[:, None, a, :]).real
    J = -(W @ dE).reshape(q, -1).T  # (l Ns, q)
    J = J - Fr @ np.linalg.solve(FtF, Fr.T @ J)
    return r, J


def _cr(M: NDArray, X: Array) -> NDArray:
    """``M @ X`` for a complex ``M`` as two products; for a real ``X`` written into
    the real and imaginary parts of the result (the same numbers as ``M.real @ X + 1j *
    (M.imag @ X)`` without its two complex temporaries)."""
    if not np.iscomplexobj(M):
        return M @ X
    if np.iscomplexobj(X):
        return M.real @ X + 1j * (M.imag @ X)
    Z = np.empty((M.shape[0], X.shape[1]), dtype=complex)
    Z.real = M.real @ X
    Z.imag = M.imag @ X
    return Z


def _residuals_compiled(
    theta: Array,
    lay: _Layout,
    u: Array,
    y: Array,
    h: float,
    hold: str,
    W: Array,
    jac: bool,
    directions: Array | None,
    kernels: ModuleType,
    ws: _Workspace,
) -> Array | tuple[Array, Array]:
    """:func:`_residuals_numpy` with the passes over the samples compiled
    (:mod:`hdpbsid.refine.pem_kernels`): the same predictor, the same stability rule,
    the same variable projection; the sensitivities of all directions from the ``n p``
    modal filters of ``w = [xi; u; y]`` and one ``(Ns, n p + p) x (n p + p, q)`` product
    per output (the factorisation in :mod:`hdpbsid.refine.pem_kernels`)."""
    A, B, C, D, K = lay.unpack(theta)
    ns, n, l = y.shape[0], lay.n, lay.l
    u = np.ascontiguousarray(u, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    C = np.ascontiguousarray(C, dtype=float)
    W = np.ascontiguousarray(W, dtype=float)
    # the error pass of this point, when the workspace's buffers still hold it
    key = (theta.tobytes(), W.tobytes(), hold, h, u.ctypes.data, y.ctypes.data, u.shape, y.shape)
    done = ws.error_pass[1] if ws.error_pass is not None and ws.error_pass[0] == key else None
    if done is not None and not jac:
        return done[0]
    pr = sampled_predictor(A, B, C, D, K, h, hold, lay.feedthrough, derivatives=jac)
    if done is None:
        lam, V = np.linalg.eig(pr.F)
        if not _is_stable(lam) or np.linalg.cond(V) > 1.0 / np.finfo(float).eps:
            r = np.full(ns * l, UNSTABLE_PENALTY)
            q = theta.size if directions is None else directions.shape[1]
            return (r, np.zeros((r.size, q))) if jac else r
        F, G, Kd, Du = (np.ascontiguousarray(a, dtype=float) for a in (pr.F, pr.G, pr.Kd, pr.Du))
        Ew, Fr3 = ws.get("errors", (l, ns)), ws.get("free response", (l, ns, n))
        kernels.weighted_errors(F, G, Kd, C, Du, W, u, y, Ew, Fr3)
        Fr = Fr3.reshape(-1, n)  # (l Ns, n), rows ordered like Ew.ravel()
        FtF = Fr.T @ Fr
        x0 = np.linalg.solve(FtF, Fr.T @ Ew.ravel())
        r = Ew.ravel() - Fr @ x0
        ws.error_pass = (key, (r, F, G, Kd, lam, V, FtF, x0))
    else:
        r, F, G, Kd, lam, V, FtF, x0 = done
        Fr3 = ws.get("free response", (l, ns, n))
    if not jac:
        return r
    assert pr.dF is not None and pr.dG is not None and pr.dKd is not None
    assert pr.dC is not None and pr.dDu is not None
    keep, fac = conjugate_representatives(lam)
    lk = lam[keep]
    cplx = lk.imag != 0  # modes whose imaginary part is stored
    # columns: modal filters of w (2 p per pair, p per real mode), w itself (p), then the
    # weighted free response of each output (l n)
    p = n + lay.m + l
    nz = p * int(np.sum(np.where(cplx, 2, 1))) + p
    Z = ws.get("regressors", (ns, nz + l * n))
    kernels.sensitivity_regressors(
        F,
        G,
        Kd,
        u,
        y,
        x0,
        np.ascontiguousarray(lk.real),
        np.ascontiguousarray(lk.imag),
        cplx,
        Fr3,
        Z,
    )
    P = pr.dF.shape[0]
    Dm = np.concatenate([pr.dF, pr.dG, pr.dKd], axis=2)  # (P, n, p): drive of s
    Dd = np.concatenate([pr.dC, pr.dDu, np.zeros((P, l, l))], axis=2)  # (P, l, p): direct
    if directions is not None:
        Dm = np.tensordot(directions.T, Dm, axes=1)
        Dd = np.tensordot(directions.T, Dd, axes=1)
    q = Dm.shape[0]
    CVf = (C @ V[:, keep]) * fac[None, :]  # (l, nk)
    VD = np.matmul(np.linalg.inv(V)[keep], Dm)  # (q, nk, p)
    # coefficient of column (a, b) of Z for output c and direction i:
    # fac_a (C V)[c, a] (V^-1 D_i)[a, b]; real part on Re z, minus imaginary on Im z
    T = CVf[None, :, :, None] * VD[:, None, :, :]  # (q, l, nk, p)
    blocks = []
    for a in range(lk.size):
        blocks.append(T[:, :, a, :].real)
        if cplx[a]:
            blocks.append(-T[:, :, a, :].imag)
    blocks.append(Dd)
    # J = -W (Dd w + C s): weighted and negated coefficients, (l, nz, q)
    Tw = -np.einsum("cd,qdj->cjq", W, np.concatenate(blocks, axis=2))
    # projection on the complement of the free response, J_c - Fr_c M with
    # M = FtF^-1 sum_c Fr_c^T J_c, folded into the coefficients of the Fr_c columns
    FZ = (Z[:, nz:].T @ Z[:, :nz]).reshape(l, n, nz)
    M = np.linalg.solve(FtF, np.einsum("cjz,czq->jq", FZ, Tw))
    coef = np.zeros((l, Z.shape[1], q))
    coef[:, :nz] = Tw
    J = np.empty((l * ns, q))
    for c in range(l):
        coef[c, nz + c * n : nz + (c + 1) * n] = -M
        np.matmul(Z, coef[c], out=J[c * ns : (c + 1) * ns])
    return r, J


@library_call
def refine_pem(
    model: StateSpaceModel,
    t: Any,
    u: Any,
    y: Any,
    *,
    hold: str | None = None,
    max_nfev: int | None = None,
    warm_start: WarmStart | None = None,
) -> StateSpaceModel:
    """Prediction-error refinement of ``model`` on the record ``t, u, y`` (module docstring).

    ``t`` must be uniformly sampled (relative spread ``<= 1e-6``; otherwise
    ``ValueError``).  ``hold``: how ``u`` behaves between samples, ``"zoh"`` or ``"foh"``;
    default (``None``): both are fitted and the smaller prediction-error cost decides,
    unless the method was given its hold (:func:`_candidate_holds`).  ``max_nfev``
    bounds the cost evaluations of Levenberg-Marquardt over all starts of one input hold
    together (default :data:`DEFAULT_MAX_NFEV`; the other hold, when fitted, has its own).

    Starting points: the model, and the model with the gain of a measurement-noise
    Kalman predictor; and, when ``warm_start`` (a
    :class:`~hdpbsid.models.report.WarmStart`) holds the matrices of a model of the same
    dimensions (and its ``input_hold``, then the hold fitted first: a prediction-error fit
    chose it), that model (``method="auto"`` offers its chosen candidate refined on the
    estimation part in ``model.report.warm_start``, which :func:`hdpbsid.identify` passes
    here, :func:`hdpbsid.selection.auto.rejudge_refined`): a prediction-error fit
    on part of the record is a consistent estimate close to the fit on all of it, where
    one Gauss-Newton step is already efficient, and the screen of :func:`_fit_starts`
    fits the most promising start first.  The start is not carried to the result; its
    optional ``name`` names it in ``options["refine_start"]`` (default: that of a
    prediction-error fit on part of the record).

    Returns a new :class:`StateSpaceModel` with the refined ``A, B, C, D, K`` and the
    initial model's options plus ``refine="pem"``, ``input_hold`` (the refined hold;
    the method's in ``input_hold_before_refine``), ``refine_cost`` (initial and final
    mean squared weighted prediction error), ``refine_nfev``, ``refine_status``,
    ``refine_converged`` (False when ``max_nfev`` ran out first; the other hold is then
    not fitted) and ``eigenvalues_before_refine``.  When the fit does not lower the
    cost, the initial model is returned unchanged (with a ``RuntimeWarning``).
    """
    if not isinstance(model, StateSpaceModel):
        raise TypeError(f"model must be a StateSpaceModel, got {type(model).__name__}")
    t, u, y = check_data(t, u, y, min_samples=model.n + 2)
    if u.shape[1] != model.m or y.shape[1] != model.l:
        raise ValueError(
            f"u and y must have {model.m} and {model.l} columns (the model's inputs and "
            f"outputs), got {u.shape[1]} and {y.shape[1]}"
        )
    if not is_uniform(t):
        raise ValueError(
            "t must be uniformly sampled for refine='pem' (the sampled predictor has one "
            "step); resample the record or use refine=None"
        )
    if hold is not None and hold not in HOLDS:
        raise ValueError(f"hold must be 'zoh' or 'foh', got {hold!r}")
    holds = _warm_first(_candidate_holds(model, hold), _check_warm_start(warm_start))
    h = float((t[-1] - t[0]) / (t.size - 1))
    feedthrough = _fits_feedthrough(model)
    lay = _Layout(model.n, model.m, model.l, feedthrough)
    # scale outputs and inputs to unit RMS so the parameters are comparable
    ys = np.sqrt(np.mean(y**2, axis=0)) + np.finfo(float).tiny
    us = np.sqrt(np.mean(u**2, axis=0)) + np.finfo(float).tiny if model.m else np.ones(0)
    A0, B0, C0, D0, K0 = _scale(model, ys, us)
    un, yn = u / us, y / ys
    try:
        K_oe: Array | None = _kalman_gain(A0, C0, h, OE_PROCESS_NOISE)
    except (np.linalg.LinAlgError, ValueError):
        K_oe = None
    # starting points: the method's hold with its K and with the measurement-noise gain
    hold = holds[0]

    def predicts(p: tuple[Array, ...]) -> bool:
        """Whether the sampled predictor of the parameters ``p`` is stable (a start)."""
        return _is_stable(np.linalg.eigvals(sampled_predictor(*p, h, hold, feedthrough).F))

    starts: dict[str, Array] = {}
    if predicts((A0, B0, C0, D0, K0)):
        starts["model K"] = lay.pack(A0, B0, C0, D0, K0)
    if K_oe is not None:  # stable by construction (the Kalman predictor)
        starts["Kalman gain, measurement noise only"] = lay.pack(A0, B0, C0, D0, K_oe)
    warm = _warm_start(model, warm_start, ys, us)
    if warm is not None and predicts(warm):
        starts[_warm_name(warm_start)] = lay.pack(*warm)
    if not starts:
        warnings.warn(
            "refine='pem': the initial model's sampled predictor is unstable and no "
            "stabilising gain exists; keeping the unrefined model",
            RuntimeWarning,
            stacklevel=user_stacklevel(),
        )
        return model
    # residuals of this record for parameters theta and output weighting W, per hold;
    # one W for both holds, so that their costs compare
    record = {hd: _Record(lay, un, yn, h, hd) for hd in holds}
    E0 = record[hold](next(iter(starts.values())), W=np.eye(model.l)).reshape(model.l, -1)
    W = np.linalg.inv(np.linalg.cholesky(E0 @ E0.T / E0.shape[1]))
    weighted = {hd: partial(record[hd], W=W) for hd in holds}

    kw: dict[str, Any] = {
        "method": "lm",
        "x_scale": "jac",
        "ftol": STALL_SD**2 / (model.l * t.size),
        "xtol": REFINE_XTOL,
    }
    budget = DEFAULT_MAX_NFEV if max_nfev is None else int(max_nfev)
    n_r = model.l * t.size
    fits, start_costs, predicted, nfev = _fit_starts(starts, lay, weighted[hold], kw, budget, n_r)
    cost0 = min(start_costs.values())
    k_start = min(fits, key=lambda k: fits[k][1])
    nfev += sum(f[2] for f in fits.values())
    theta, cost, _, status, converged = fits[k_start]
    hold_costs = {hold: cost}
    # the other hold is compared at the first hold's minimum: without one (blocked or
    # out of budget) there is nothing to compare, and the fit is reported unconverged
    for other in holds[1:] if converged else ():
        # the other hold from the converged model: kept when it reaches a lower cost
        # with every mode resolved by the sampling (_other_hold)
        fit = _other_hold(theta, cost, lay, weighted[other], kw, budget, starts)
        nfev += fit[2]
        hold_costs[other] = fit[1] if np.isfinite(fit[1]) else fit[3]
        decisive = fit[1] < cost * np.exp(-HOLD_EVIDENCE / n_r)
        if decisive and _modes_resolved(lay, fit[0], h):
            theta, cost, status, converged, hold = fit[0], fit[1], fit[3], fit[4], other
    if not (np.isfinite(cost) and cost < cost0):
        warnings.warn(
            f"refine='pem' did not lower the prediction-error cost ({cost0:.4g} -> "
            f"{cost:.4g}); keeping the unrefined model",
            RuntimeWarning,
            stacklevel=user_stacklevel(),
        )
        return model
    weighted_fit, record_fit = weighted[hold], record[hold]
    Q = _ddlc_basis(lay, theta)
    A, B, C, D, K = _unscale(lay.unpack(theta), ys, us)
    E = record_fit(theta, W=np.eye(model.l)).reshape(model.l, -1)
    Jq = weighted_fit(theta, jac=True, directions=Q)[1]
    eig_std = _eigenvalue_std(lay, theta, Q, Jq, cost)
    noise_cov = (ys[:, None] * (E @ E.T / E.shape[1])) * ys[None, :]
    options = dict(model.options)
    options.pop(WARM_START, None)
    options.update(
        input_hold=hold,
        input_hold_before_refine=model.report.hold,
        refine="pem",
        refine_hold=hold,
        refine_holds_tried=holds,
        refine_start=k_start,
        refine_start_costs={k: f[1] for k, f in fits.items()},
        refine_start_predicted=predicted,
        refine_hold_costs=hold_costs,
        refine_cost={"initial": cost0, "final": cost},
        refine_nfev=nfev,
        refine_status=status,
        refine_converged=converged,
        refine_parameters=int(Q.shape[1]),
        eigenvalues_before_refine=model.eigenvalues,
        eigenvalue_std=eig_std,
    )
    report = _refined_report(
        model, Refinement(converged, nfev, hold, k_start, (cost0, cost), eig_std)
    )
    return StateSpaceModel(
        A,
        B,
        C,
        D,
        K,
        singular_values=model.singular_values,
        options=options,
        noise_covariance=noise_cov,
        parameter_covariance=ParameterCovariance(
            _abcd_factor(lay, Q, Jq, cost, ys, us), "refine_pem"
        ),
        report=report,
    )


@library_call
def one_step_errors(
    model: StateSpaceModel, t: Any, u: Any, y: Any, hold: str | None = None
) -> Array | None:
    """One-step prediction errors ``y_k - yhat(t_k | t_{k-1})`` of ``model`` on a uniformly
    sampled record, ``(Ns, l)``, the initial state fitted by least squares: the numbers
    of :meth:`~hdpbsid.models.model.StateSpaceModel.predict` (``k=1``, ``x0="estimate"``,
    ``method=hold``), computed by the compiled passes of the refinement
    (:func:`_residuals`).  ``hold``: default the model's ``options["input_hold"]``
    (``"zoh"`` when it has none of :data:`HOLDS`).  ``None`` when the sampled predictor
    is unstable (its errors grow without bound; ``predict`` overflows there)."""
    if hold is None:
        hold = model.report.hold
        hold = hold if hold in HOLDS else "zoh"
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float).reshape(t.size, -1)
    u = np.zeros((t.size, 0)) if u is None else np.asarray(u, dtype=float).reshape(t.size, -1)
    U0, Y0 = model.operating_point(t)  # absolute signals, as predict takes them
    u, y = u - U0, y - Y0
    feedthrough = bool(np.any(model.D != 0)) and model.m > 0
    lay = _Layout(model.n, model.m, model.l, feedthrough)
    theta = lay.pack(model.A, model.B, model.C, model.D, model.K)
    h = float((t[-1] - t[0]) / (t.size - 1))
    pr = sampled_predictor(model.A, model.B, model.C, model.D, model.K, h, hold, feedthrough)
    if not _is_stable(np.linalg.eigvals(pr.F)):
        return None
    r = _residuals(theta, lay, u, y, h, hold, np.eye(model.l))
    return np.asarray(r).reshape(model.l, -1).T


def _fits_feedthrough(model: StateSpaceModel) -> bool:
    """Whether ``D`` is a parameter of the refinement: only when the method was asked for
    a direct term (``model.report.feedthrough.asked``).

    A method that estimates ``D`` as part of its own algebra without being asked (the
    Laguerre-domain ``D_d``, reported as a string) does not make ``D`` a parameter: the
    refinement fixes it at zero, the structure every method assumes by default.  In
    closed loop this matters beyond parsimony: with a controller that reacts to ``y_k``
    within the sample, a free ``D`` lets ``D u_k`` predict the innovation ``e_k`` through
    the controller, the loop is not well posed for the direct approach (Ljung, *System
    Identification*, 2nd ed., sec. 13.4: a delay in the loop is required) and the
    prediction-error minimum is not the system (closed-loop quadrotor, Laguerre starts
    with a free ``D``: 150-4000 % eigenvalue errors at a one-step cost half that of a
    long VARX, i.e. below the innovation variance).
    """
    fd = model.report.feedthrough
    return fd is not None and fd.asked and model.m > 0


def _ddlc_basis(lay: _Layout, theta: Array) -> Array:
    """Orthonormal basis of the directions that change the input-output behaviour.

    A similarity ``x -> (I + T) x`` moves ``(A, B, C, D, K)`` by ``(TA - AT, TB, -CT, 0,
    TK)`` to first order without changing the predictor; the ``n^2`` such directions are
    removed ("data-driven local coordinates", McKelvey, Helmersson & Ribarits, Automatica
    40 (2004); the parametrisation of MATLAB's ``ssest``), leaving
    ``n (m + 2 l) + l m [feedthrough]`` free parameters.
    """
    A, B, C, D, K = lay.unpack(theta)
    n = lay.n
    cols = []
    for i in range(n):
        for j in range(n):
            T = np.zeros((n, n))
            T[i, j] = 1.0
            cols.append(lay.pack(T @ A - A @ T, T @ B, -C @ T, np.zeros_like(D), T @ K))
    S = np.array(cols).T
    U, sv, _ = np.linalg.svd(S, full_matrices=True)
    rank = int(np.sum(sv > sv[0] * S.shape[0] * np.finfo(float).eps)) if sv.size else 0
    return U[:, rank:]


def _eigenvalue_std(lay: _Layout, theta: Array, Q: Array, J: Array, cost: float) -> Array:
    """Asymptotic standard deviation of each eigenvalue of ``A`` (sorted like
    :attr:`StateSpaceModel.eigenvalues`): ``cov(beta) = s^2 (J^T J)^+`` with the
    weighted residual variance ``s^2`` (Ljung sec. 9.3), mapped to the eigenvalues by
    their finite-difference gradient; ``sqrt(var Re + var Im)``."""
    P = cost * np.linalg.pinv(J.T @ J)

    def eig(beta: Array) -> NDArray[np.complex128]:
        A = lay.unpack(theta + Q @ beta)[0]
        ev = np.linalg.eigvals(A)
        return ev[np.lexsort((ev.imag, ev.real))]

    ev0 = eig(np.zeros(Q.shape[1]))
    G = np.empty((ev0.size, Q.shape[1]), dtype=complex)
    step = 1e-6 * max(1.0, float(np.max(np.abs(ev0))))
    for k in range(Q.shape[1]):
        e = np.zeros(Q.shape[1])
        e[k] = step
        evp = eig(e)
        # pair the perturbed eigenvalues with the unperturbed ones (nearest)
        idx = np.argmin(np.abs(evp[None, :] - ev0[:, None]), axis=1)
        G[:, k] = (evp[idx] - ev0) / step
    var = np.einsum("ik,kl,il->i", G.real, P, G.real) + np.einsum("ik,kl,il->i", G.imag, P, G.imag)
    return np.sqrt(np.maximum(var, 0.0))


def _abcd_factor(lay: _Layout, Q: Array, J: Array, cost: float, ys: Array, us: Array) -> Array:
    """The covariance factor of ``[vec A, vec B, vec C, vec D]`` in the record's units
    (:class:`hdpbsid.models.uncertainty.ParameterCovariance`): ``cov(beta) = s^2 (J^T J)^+`` of the
    local coordinates (as :func:`_eigenvalue_std`), mapped by ``theta = theta_0 + Q beta``
    (rows of ``K`` dropped, zero rows for a ``D`` that is not a parameter) and by the
    unit scaling of :func:`_unscale` (``B / us``, ``ys C``, ``ys D / us``)."""
    n, m, l = lay.n, lay.m, lay.l
    F = Q @ covariance_factor(cost * np.linalg.pinv(J.T @ J))
    s = lay.stops
    parts = [F[s[0] : s[1]], F[s[1] : s[2]], F[s[2] : s[3]]]
    parts.append(F[s[3] : s[4]] if lay.feedthrough else np.zeros((l * m, F.shape[1])))
    Fabcd = np.vstack(parts)
    inv_us = 1.0 / us if m else us
    return scale_factor(
        Fabcd,
        n,
        m,
        l,
        np.broadcast_to(inv_us[None, :], (n, m)),
        np.broadcast_to(ys[:, None], (l, n)),
        ys[:, None] * inv_us[None, :],
    )


def _check_warm_start(warm_start: Any) -> WarmStart | None:
    """``warm_start`` of :func:`refine_pem`, checked."""
    if warm_start is not None and not isinstance(warm_start, WarmStart):
        raise TypeError(
            "warm_start must be a hdpbsid.models.report.WarmStart or None, got "
            f"{type(warm_start).__name__}"
        )
    return warm_start


def _warm_first(holds: tuple[str, ...], warm_start: WarmStart | None) -> tuple[str, ...]:
    """``holds`` with the warm start's hold first when it is among them: that hold was
    chosen by a prediction-error fit."""
    warm_hold = None if warm_start is None else warm_start.input_hold
    if warm_hold in holds[1:]:
        return (warm_hold, *[hd for hd in holds if hd != warm_hold])
    return holds


def _warm_name(warm_start: WarmStart | None) -> str:
    """The name of the warm start among the starting points."""
    return str((warm_start.name if warm_start is not None else None) or WARM_START_NAME)


def _refined_report(model: StateSpaceModel, refinement: Refinement) -> Any:
    """The report of the refinement of ``model``: its own, with the hold fitted (given
    when the method was told it) and the refinement's outcome, and no warm start."""
    why = "given" if _hold_was_given(model) else "the smaller prediction-error cost"
    return model.report.but(
        input_hold=Choice(refinement.hold, why), refinement=refinement, warm_start=None
    )


def warm_start_option(model: StateSpaceModel) -> WarmStart:
    """The ``warm_start`` of :func:`refine_pem` that offers ``model`` (a prediction-error
    fit on part of the record) as a starting point: its matrices and its input hold.

    Parameters
    ----------
    model : StateSpaceModel
        The starting model.

    Returns
    -------
    WarmStart

    Examples
    --------
    >>> from hdpbsid import StateSpaceModel
    >>> m = StateSpaceModel(A=[[-1.0]], B=[[1.0]], C=[[1.0]], D=[[0.0]], K=[[0.5]])
    >>> warm_start_option(m)
    WarmStart(n=1, input_hold=None, name=None)
    """
    return WarmStart.of(model, model.report.hold)


def _warm_start(
    model: StateSpaceModel, warm: WarmStart | None, ys: Array, us: Array
) -> tuple[Array, ...] | None:
    """The scaled ``(A, B, C, D, K)`` of the warm start ``warm`` (:func:`refine_pem`), or
    None when there is none or its shapes are not the model's."""
    if warm is None:
        return None
    try:
        wm = StateSpaceModel(*(np.asarray(getattr(warm, k), dtype=float) for k in "ABCDK"))
    except (ValueError, TypeError):
        return None
    if (wm.n, wm.m, wm.l) != (model.n, model.m, model.l):
        return None
    return _scale(wm, ys, us)


def _scale(model: StateSpaceModel, ys: Array, us: Array) -> tuple[Array, ...]:
    """The model for inputs ``u / us`` and outputs ``y / ys`` (same state)."""
    B = model.B * us[None, :] if model.m else model.B
    C = model.C / ys[:, None]
    D = (model.D * us[None, :]) / ys[:, None] if model.m else model.D
    K = model.K * ys[None, :]
    return model.A, B, C, D, K


def _unscale(p: tuple[Array, ...], ys: Array, us: Array) -> tuple[Array, ...]:
    """Inverse of :func:`_scale`."""
    A, B, C, D, K = p
    B = B / us[None, :] if B.shape[1] else B
    C = C * ys[:, None]
    D = (D / us[None, :]) * ys[:, None] if D.shape[1] else D
    K = K / ys[None, :]
    return A, B, C, D, K
