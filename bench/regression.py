"""Regression table of ``hdpbsid.identify(t, u, y)`` with every default, and its guard.

Run: ``python bench/regression.py [--n-jobs N] [--subset PATTERN ...]
[--out bench/results/regression.csv] [--compare OLD.csv]``.

A fixed, reproducible set of records (every random draw from a seeded
``numpy.random.Generator``), each identified once by ``identify(t, u, y)`` with every
default:

* every case of ``bench/cases.py`` x :data:`SEEDS` x the SNRs ``bench/peers.py`` runs it at
  (:data:`CASE_SNRS`; the PBSID toolbox example has its own noise and one SNR), family =
  the case name; scored on the case's true eigenvalues and its validation record
  (``peers.validation_fit``);
* :data:`N_RANDOM` random stable continuous-time systems (:func:`random_record`): orders
  1-6, open loop and closed loop under a digital static or dynamic output feedback with a
  reference input, SISO and MIMO (up to 2 x 2, or 3 outputs), binary / multisine /
  smooth inputs, uniform and jittered sampling, SNR 10-40 dB; families
  ``random-{open,closed}-{siso,mimo}``; scored on the true eigenvalues and on a
  noise-free open-loop validation record of the same system;
* the measured DaISy records of ``bench/data`` (family ``daisy``), scored as
  ``bench/realdata.py`` scores them (its functions): estimation on the first two thirds,
  NRMSE fit of the simulation on the rest from a least-squares initial state.

Per record (one CSV row): the method and order chosen, whether it is the true order, the
worst relative eigenvalue error in percent (:func:`hdpbsid.models.metrics.eigenvalue_errors`,
when the order is the true one; in the z-plane for a discrete-time truth), the
validation fit in percent, whether the model is stable, and the CPU time of the call
(``time.process_time`` in the process that runs it, one BLAS thread through
``threadpoolctl``, caches emptied before, one untimed warm-up call per process).  An
exception becomes a row with its text.  Beside the CSV a JSON file holds the metadata:
the commit measured, the last commit that changed the library, the date and versions.

``--compare OLD.csv`` lists every row whose outcome changed (:func:`compare_rows`: the
true order lost or found, the error or the misfit worse or better by more than the
margin of :func:`beyond_margin`, newly failing or no longer failing, the stability of a
stable truth lost or regained, and, as information, a changed method or order), prints
the totals side by side (:func:`totals`) and exits with status 1 if a guarded total got
worse.  Not a test: nothing is asserted here.
"""

from __future__ import annotations

import argparse
import csv
import fnmatch
import hashlib
import json
import math
import os
import platform
import subprocess
import sys
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from itertools import product
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import block_diag, expm, solve_continuous_lyapunov
from scipy.signal import butter, filtfilt

BENCH = Path(__file__).resolve().parent
REPO = BENCH.parent
sys.path.insert(0, str(BENCH))

import peers  # noqa: E402
import realdata  # noqa: E402
from cases import CASES, SNR_INDEPENDENT, make_case  # noqa: E402

import hdpbsid  # noqa: E402
from hdpbsid.models.metrics import eigenvalue_errors  # noqa: E402

Array = NDArray[np.float64]

#: Seeds of every case of ``bench/cases.py`` (those of ``bench/identify.py --defaults``).
SEEDS = tuple(range(10))
#: SNRs (dB) of the cases, as ``bench/peers.py`` runs them; ``None``: the case's own noise.
CASE_SNRS: tuple[float, ...] = (40.0, 20.0, 10.0)
#: Number of random systems; a multiple of the 24 strata (order x loop x SISO/MIMO).
N_RANDOM = 120
#: Entropy of the random systems: record ``i`` draws from ``default_rng((RANDOM_SEED, i))``.
RANDOM_SEED = 28_2028
#: Families of the random systems, in table order.
RANDOM_FAMILIES = (
    "random-open-siso",
    "random-open-mimo",
    "random-closed-siso",
    "random-closed-mimo",
)
#: ``|lambda_max| dt`` of every random record: about 21 samples per radian-period of the
#: fastest mode, far inside the Nyquist band.
FAST_MODE_STEP = 0.3
#: Record length in time constants ``1 / |lambda_min|`` of the slowest mode, before clipping
#: to :data:`SAMPLES_RANGE`.
SLOW_MODE_SPAN = 20.0
#: Samples per random record (min, max): the whole table runs in minutes.
SAMPLES_RANGE = (1000, 6000)
#: Jittered sampling: ``t_k = dt (k + j_k)``, ``j_k`` uniform on ``[-JITTER, JITTER]``.
JITTER = 0.4
#: Smallest ratio of Hankel singular values of a random plant: every mode visible.
MIN_HSV_RATIO = 1e-2

#: Relative margin of :func:`beyond_margin`: the refinement stops when a step moves the
#: estimate by less than a tenth of its standard deviation, so equivalent fits of one
#: record differ by about a tenth of their error.
MARGIN_REL = 0.10
#: Absolute floor (percentage points) of the eigenvalue-error margin: at 40 dB (1 % noise)
#: on a few thousand samples the error of a well-conditioned eigenvalue is a few hundredths
#: of a percent, so differences below this are noise realisation, not method.
MARGIN_ERR_PP = 0.05
#: Absolute floor (percentage points) of the misfit (``100 - fit``) margin: half the
#: output noise at the best SNR of the set (40 dB, 1 % rms).
MARGIN_FIT_PP = 0.5

CSV_FIELDS = (
    "id",
    "family",
    "seed",
    "snr",
    "sampling",
    "loop",
    "input",
    "m",
    "l",
    "ns",
    "true_order",
    "method",
    "order",
    "order_found",
    "err_pct",
    "fit_pct",
    "stable",
    "true_stable",
    "cpu_s",
    "wall_s",
    "data",
    "error",
)


# -- the set of records ----------------------------------------------------------------
@dataclass(frozen=True)
class RecordSpec:
    """One record of the table: ``source`` is ``"case"``, ``"random"`` or ``"daisy"``;
    ``name`` the case, the random index or the DaISy record."""

    id: str
    family: str
    source: str
    name: str
    seed: int | None = None
    snr: float | None = None


def record_specs(n_random: int = N_RANDOM, seeds: Sequence[int] = SEEDS) -> list[RecordSpec]:
    """Every record of the table, in table order (cases, random systems, DaISy)."""
    specs = []
    for name in CASES:
        snrs: tuple[float | None, ...] = (None,) if name in SNR_INDEPENDENT else CASE_SNRS
        for snr, seed in product(snrs, seeds):
            tag = "own" if snr is None else f"{snr:g}dB"
            specs.append(RecordSpec(f"{name}/{tag}/{seed}", name, "case", name, seed, snr))
    for i in range(n_random):
        order, loop, io = _stratum(i)
        family = f"random-{loop}-{io}"
        specs.append(RecordSpec(f"random/{i:03d}", family, "random", str(i), i, None))
    for name in realdata.RECORDS:
        specs.append(RecordSpec(f"daisy/{name}", "daisy", "daisy", name))
    return specs


def select(specs: Sequence[RecordSpec], patterns: Sequence[str] | None) -> list[RecordSpec]:
    """The specs whose id or family matches one of the shell ``patterns`` (all if none)."""
    if not patterns:
        return list(specs)
    return [
        s
        for s in specs
        if any(fnmatch.fnmatch(s.id, p) or fnmatch.fnmatch(s.family, p) for p in patterns)
    ]


# -- random systems ----------------------------------------------------------------------
def _stratum(index: int) -> tuple[int, str, str]:
    """``(order, loop, io)`` of random record ``index``: the 24 combinations of order
    1-6, open/closed loop and SISO/MIMO in turn, so that every stratum is equally full."""
    combos = list(product(range(1, 7), ("open", "closed"), ("siso", "mimo")))
    return combos[index % len(combos)]


@dataclass
class RandomRecord:
    """A random system, its estimation record and a noise-free validation record."""

    t: Array
    u: Array
    y: Array
    t_val: Array
    u_val: Array
    y_val: Array
    A: Array
    B: Array
    C: Array
    dt: float
    loop: str  # "open", "closed-static", "closed-dynamic"
    sampling: str  # "uniform", "jittered"
    input: str  # "binary", "multisine", "smooth"
    snr: float


def random_eigenvalues(rng: np.random.Generator, order: int) -> NDArray[np.complex128]:
    """Stable eigenvalues of a random plant of ``order``: real poles and pairs (damping
    0.1-0.7) whose magnitudes spread over one to two decades from a slowest
    ``|lambda|`` log-uniform on ``[0.1, 10]``, each block at least 30 % apart from the
    next (nearly repeated eigenvalues are ill-conditioned: their errors would measure
    the conditioning, not the method)."""
    n_pairs = int(rng.integers(0, order // 2 + 1))
    n_blocks = order - n_pairs
    w_min = 10.0 ** rng.uniform(-1.0, 1.0)
    while True:
        spread = rng.uniform(1.0, 2.0) if n_blocks > 1 else 0.0
        inner = rng.uniform(0.0, spread, max(n_blocks - 2, 0))
        logs = np.sort(np.r_[0.0, inner, spread][:n_blocks])
        if n_blocks == 1 or np.min(np.diff(logs)) >= np.log10(1.3):
            break
    w = w_min * 10.0**logs
    kinds = rng.permutation([True] * n_pairs + [False] * (n_blocks - n_pairs))
    ev: list[complex] = []
    for wi, pair in zip(w, kinds, strict=True):
        if pair:
            z = rng.uniform(0.1, 0.7)
            ev += [wi * complex(-z, np.sqrt(1 - z * z)), wi * complex(-z, -np.sqrt(1 - z * z))]
        else:
            ev.append(complex(-wi, 0.0))
    return np.array(ev)


def modal_realization(
    rng: np.random.Generator, ev: NDArray[np.complex128], m: int, l: int
) -> tuple[Array, Array, Array]:
    """Real modal ``(A, B, C)`` with eigenvalues ``ev`` (pairs adjacent) and random
    Gaussian ``B`` and ``C``; each block's input gain is scaled by its ``|lambda|`` so that
    every mode has a static gain of order one (a fast mode is not hidden under a slow
    one)."""
    blocks, rows = [], []
    i = 0
    while i < ev.size:
        lam = ev[i]
        if lam.imag != 0.0:
            blocks.append(np.array([[lam.real, lam.imag], [-lam.imag, lam.real]]))
            rows.append(abs(lam) * rng.standard_normal((2, m)))
            i += 2
        else:
            blocks.append(np.array([[lam.real]]))
            rows.append(abs(lam) * rng.standard_normal((1, m)))
            i += 1
    return block_diag(*blocks), np.vstack(rows), rng.standard_normal((l, ev.size))


def hankel_ratio(A: Array, B: Array, C: Array) -> float:
    """Smallest over largest Hankel singular value of a stable ``(A, B, C)`` (the square
    roots of the eigenvalues of the product of the Gramians; Zhou, Doyle and Glover,
    *Robust and Optimal Control*, 1996, sec. 7.1)."""
    Wc = solve_continuous_lyapunov(A, -B @ B.T)
    Wo = solve_continuous_lyapunov(A.T, -C.T @ C)
    hsv = np.sqrt(np.abs(np.linalg.eigvals(Wc @ Wo)))
    return float(hsv.min() / hsv.max())


def step_matrices(A: Array, B: Array, h: Array, hold: str) -> tuple[Array, Array, Array]:
    """Exact one-step matrices ``(Phi, G0, G1)`` (stacked over the steps ``h``):
    ``x_{k+1} = Phi x_k + G0 u_k + G1 (u_{k+1} - u_k)``, ``G1 = 0`` for ``hold="zoh"``;
    from ``expm([[A h, B h, 0], [0, 0, I], [0, 0, 0]])`` (Franklin, Powell and Workman,
    *Digital Control of Dynamic Systems*, sec. 6.3), computed with scipy alone so that
    the records do not depend on the library they test."""
    n, m = B.shape
    h = np.asarray(h, dtype=float).reshape(-1)
    M = np.zeros((h.size, n + 2 * m, n + 2 * m))
    M[:, :n, :n] = A[None] * h[:, None, None]
    M[:, :n, n : n + m] = B[None] * h[:, None, None]
    if hold == "foh":
        M[:, n : n + m, n + m :] = np.eye(m)
    E = expm(M)
    G1 = E[:, :n, n + m :] if hold == "foh" else np.zeros((h.size, n, m))
    return E[:, :n, :n], E[:, :n, n : n + m], G1


def _steps(
    t: Array, A: Array, B: Array, hold: str, uniform: bool
) -> tuple[Array, Array, Array, Array]:
    """Step matrices for ``t`` and the index of each step's matrices."""
    h = np.diff(t)
    if uniform:
        Phi, G0, G1 = step_matrices(A, B, np.array([np.mean(h)]), hold)
        return Phi, G0, G1, np.zeros(h.size, dtype=int)
    Phi, G0, G1 = step_matrices(A, B, h, hold)
    return Phi, G0, G1, np.arange(h.size)


def simulate_open(
    A: Array, B: Array, C: Array, t: Array, u: Array, hold: str, uniform: bool
) -> Array:
    """Exact noise-free output ``C x_k`` from rest, ``u`` held (``"zoh"``) or linear
    between samples (``"foh"``)."""
    Phi, G0, G1, idx = _steps(t, A, B, hold, uniform)
    x = np.zeros(A.shape[0])
    y = np.empty((t.size, C.shape[0]))
    for k in range(t.size):
        y[k] = C @ x
        if k + 1 < t.size:
            i = idx[k]
            x = Phi[i] @ x + G0[i] @ u[k] + G1[i] @ (u[k + 1] - u[k])
    return y


def simulate_loop(
    A: Array,
    B: Array,
    C: Array,
    t: Array,
    r: Array,
    v: Array,
    K: Array,
    pole: float | None,
    uniform: bool,
) -> tuple[Array, Array]:
    """Plant under a digital output feedback at the sample times: the measured output
    ``y_k = C x_k + v_k``, the applied input ``u_k = r_k - K z_k`` held to the next sample,
    ``z_k = y_k`` (static) or the first-order lag ``z_{k+1} = a_k z_k + (1 - a_k) y_k``,
    ``a_k = exp(-pole h_k)`` (dynamic, ``pole`` not None).  Returns ``(u, y)``."""
    Phi, G0, _, idx = _steps(t, A, B, "zoh", uniform)
    h = np.diff(t)
    x, z = np.zeros(A.shape[0]), np.zeros(C.shape[0])
    u, y = np.empty((t.size, B.shape[1])), np.empty((t.size, C.shape[0]))
    for k in range(t.size):
        y[k] = C @ x + v[k]
        u[k] = r[k] - K @ (y[k] if pole is None else z)
        if k + 1 < t.size:
            x = Phi[idx[k]] @ x + G0[idx[k]] @ u[k]
            if pole is not None:
                a = math.exp(-pole * h[k])
                z = a * z + (1.0 - a) * y[k]
    return u, y


def loop_is_stable(
    A: Array, B: Array, C: Array, K: Array, pole: float | None, steps: Array
) -> bool:
    """Spectral radius of the sampled loop (:func:`simulate_loop`, no input) below one at
    each of ``steps`` (the shortest, nominal and longest sampling interval)."""
    l = C.shape[0]
    Phi, G0, _ = step_matrices(A, B, steps, "zoh")
    for P, G, h in zip(Phi, G0, steps, strict=True):
        if pole is None:
            M = P - G @ K @ C
        else:
            a = math.exp(-pole * h)
            M = np.block([[P, -G @ K], [(1.0 - a) * C, a * np.eye(l)]])
        if np.max(np.abs(np.linalg.eigvals(M))) >= 1.0:
            return False
    return True


def _input(
    rng: np.random.Generator, kind: str, t: Array, m: int, dt: float, f_lo: float, f_hi: float
) -> Array:
    """Zero-mean input ``(Ns, m)``: ``binary`` (random signs held 1-3 samples),
    ``multisine`` (20 log-spaced tones on ``[f_lo, f_hi]`` Hz, random phases) or
    ``smooth`` (white noise through a 4th-order Butterworth at ``f_hi``, zero phase, on a
    grid four times finer, read at ``t``); unit standard deviation per channel."""
    ns = t.size
    if kind == "binary":
        hold = int(rng.integers(1, 4))
        levels = np.sign(rng.standard_normal((ns // hold + 1, m)))
        return levels[np.arange(ns) // hold]
    if kind == "multisine":
        f = np.geomspace(f_lo, f_hi, 20)
        phases = rng.uniform(0.0, 2.0 * np.pi, (m, f.size))
        u = np.stack(
            [np.cos(2 * np.pi * np.outer(t, f) + phases[j]).sum(axis=1) for j in range(m)], 1
        )
    else:
        fine = np.arange(0.0, t[-1] + dt, dt / 4.0)
        b, a = butter(4, min(2.0 * f_hi * dt / 4.0, 0.99))
        w = filtfilt(b, a, rng.standard_normal((fine.size, m)), axis=0)
        u = np.stack([np.interp(t, fine, w[:, j]) for j in range(m)], 1)
    u = u - u.mean(axis=0)
    return u / u.std(axis=0)


def _noise(rng: np.random.Generator, y_clean: Array, snr: float) -> Array:
    """White output noise at ``snr`` dB on each channel's mean-square power (the SNR of
    :func:`hdpbsid.systems.add_noise` and ``bench/cases.py``)."""
    sigma = np.sqrt(np.mean(y_clean**2, axis=0)) * 10.0 ** (-snr / 20.0)
    return rng.standard_normal(y_clean.shape) * sigma


def random_record(index: int) -> RandomRecord:
    """Random record ``index`` of the table, the same on every run and machine up to
    rounding: everything is drawn from ``default_rng((RANDOM_SEED, index))``.

    Order, loop and SISO/MIMO from :func:`_stratum`; the rest drawn: eigenvalues
    (:func:`random_eigenvalues`), a modal realization (:func:`modal_realization`, redrawn
    until every Hankel singular value is above :data:`MIN_HSV_RATIO` of the largest),
    MIMO shape among 2 x 2, 1 x 2, 2 x 1 and 1 x 3, the input kind, the sampling, the
    SNR (integer dB on ``[10, 40]``).  ``dt = FAST_MODE_STEP / |lambda_max|`` and the length
    spans :data:`SLOW_MODE_SPAN` time constants of the slowest mode within
    :data:`SAMPLES_RANGE`.  Open loop: binary inputs held (ZOH), multisine and smooth
    inputs linear between samples (FOH), simulated exactly.  Closed loop: the input drives
    the reference of a digital static or first-order dynamic output feedback (
    :func:`simulate_loop`) with gain ``kappa pinv(G(0))``, ``kappa`` uniform on
    ``[0.5, 2]`` and halved until the sampled loop is stable at the shortest, nominal and
    longest step (:func:`loop_is_stable`); the noise enters the controller.  The
    validation record: the same plant, open loop, binary input, uniform ``dt``, noise
    free.
    """
    rng = np.random.default_rng((RANDOM_SEED, index))
    order, loop, io = _stratum(index)
    m, l = (1, 1) if io == "siso" else [(2, 2), (1, 2), (2, 1), (1, 3)][int(rng.integers(4))]
    ev = random_eigenvalues(rng, order)
    while True:
        A, B, C = modal_realization(rng, ev, m, l)
        if hankel_ratio(A, B, C) >= MIN_HSV_RATIO:
            break
    w = np.abs(ev)
    dt = FAST_MODE_STEP / w.max()
    ns = int(np.clip(round(SLOW_MODE_SPAN / (w.min() * dt)), *SAMPLES_RANGE))
    sampling = ("uniform", "jittered")[int(rng.integers(2))]
    kind = ("binary", "multisine", "smooth")[int(rng.integers(3))]
    snr = float(rng.integers(10, 41))
    k = np.arange(ns, dtype=float)
    uniform = sampling == "uniform"
    t = dt * k if uniform else dt * (k + np.r_[0.0, rng.uniform(-JITTER, JITTER, ns - 1)])
    T = t[-1]
    f_lo = max(w.min() / (2 * np.pi) / 3.0, 2.0 / T)
    f_hi = min(2.0 * w.max() / (2 * np.pi), 0.25 / dt)
    excitation = _input(rng, kind, t, m, dt, f_lo, f_hi)
    if loop == "open":
        hold = "zoh" if kind == "binary" else "foh"
        y_clean = simulate_open(A, B, C, t, excitation, hold, uniform)
        u, y = excitation, y_clean + _noise(rng, y_clean, snr)
        loop_name = "open"
    else:
        G0 = -C @ np.linalg.solve(A, B)
        pole = None if rng.integers(2) == 0 else float(np.sqrt(w.min() * w.max()))
        kappa = rng.uniform(0.5, 2.0)
        h = np.diff(t)
        steps = np.array([h.min(), np.mean(h), h.max()])
        while not loop_is_stable(A, B, C, kappa * np.linalg.pinv(G0), pole, steps):
            kappa /= 2.0
        K = kappa * np.linalg.pinv(G0)
        _, y_clean = simulate_loop(A, B, C, t, excitation, np.zeros((ns, l)), K, pole, uniform)
        u, y = simulate_loop(A, B, C, t, excitation, _noise(rng, y_clean, snr), K, pole, uniform)
        loop_name = "closed-static" if pole is None else "closed-dynamic"
    t_val = dt * k
    u_val = np.sign(rng.standard_normal((ns // 2 + 1, m)))[np.arange(ns) // 2]
    y_val = simulate_open(A, B, C, t_val, u_val, "zoh", True)
    return RandomRecord(t, u, y, t_val, u_val, y_val, A, B, C, dt, loop_name, sampling, kind, snr)


# -- one record ----------------------------------------------------------------------------
@dataclass
class Trial:
    """What one row identifies from and is scored on: the record, the truth (``None`` for
    measured data), the plane of the eigenvalue comparison (``z_dt``: compare
    ``exp(lambda z_dt)`` in the z-plane) and the scorer of a model's validation fit."""

    t: Array
    u: Array
    y: Array
    true_eigenvalues: NDArray[np.complex128] | None
    fit: Callable[[Any], float]
    sampling: str
    loop: str
    input: str
    snr: float | None
    z_dt: float | None = None


def _identified(model: Any) -> peers.Identified:
    return peers.Identified(model.A, model.B, model.C, model.D, None)


def _case_trial(spec: RecordSpec) -> Trial:
    case = make_case(spec.name, int(spec.seed or 0), spec.snr)
    rec = case.estimation
    return Trial(
        rec.t,
        rec.u,
        rec.y,
        np.asarray(case.true_eigenvalues),
        lambda model: peers.validation_fit(_identified(model), case),
        "uniform" if case.uniform else "nonuniform",
        "closed" if case.closed_loop else "open",
        "case",
        spec.snr,
        float(rec.t[1] - rec.t[0]) if case.discrete else None,
    )


def _random_fit(model: Any, r: RandomRecord) -> float:
    """Fit (percent) of ``model`` on the noise-free validation record: ZOH-sampled at its
    ``dt``, run on the input's deviation from the model's operating point from the
    least-squares initial state (``peers.discrete_ls_simulation``)."""
    Phi, G0, _ = step_matrices(model.A, model.B, np.array([r.dt]), "zoh")
    u0, y0 = model.operating_point(r.t_val)
    with np.errstate(all="ignore"):
        yhat = peers.discrete_ls_simulation(
            Phi[0], G0[0], model.C, model.D, r.u_val - u0, r.y_val - y0
        )
        fit = peers.fit_percent(r.y_val, yhat + y0)
    return fit if np.isfinite(fit) else -np.inf


def _random_trial(spec: RecordSpec) -> Trial:
    r = random_record(int(spec.name))
    ev = np.linalg.eigvals(r.A)
    return Trial(
        r.t, r.u, r.y, ev, lambda model: _random_fit(model, r), r.sampling, r.loop, r.input, r.snr
    )


def _daisy_trial(spec: RecordSpec) -> Trial:
    u, y, dt = realdata.load_record(spec.name)
    split = realdata.split_record(u, y, dt)
    est = split.estimation
    return Trial(
        est.t,
        est.u,
        est.y,
        None,
        lambda model: realdata.validation_fit(_identified(model), split),
        "uniform",
        "unknown",
        "measured",
        None,
    )


TRIALS: dict[str, Callable[[RecordSpec], Trial]] = {
    "case": _case_trial,
    "random": _random_trial,
    "daisy": _daisy_trial,
}


def make_trial(spec: RecordSpec) -> Trial:
    """The data and scorers of record ``spec``."""
    return TRIALS[spec.source](spec)


def data_digest(t: Array, u: Array, y: Array) -> str:
    """Short digest of a record's data in single precision (it tells a changed record
    from a changed identification; single precision ignores last-bit rounding)."""
    arr = np.hstack(
        [np.reshape(t, (-1, 1)), np.reshape(u, (len(t), -1)), np.reshape(y, (len(t), -1))]
    )
    return hashlib.sha1(np.ascontiguousarray(arr, dtype=np.float32).tobytes()).hexdigest()[:10]


def _chosen_method(model: Any) -> str:
    """The method the model came from (the report's, else ``options["method"]``)."""
    report = getattr(model, "report", None)
    if report is not None and getattr(report, "method", None):
        return str(report.method)
    return str(getattr(model, "options", {}).get("method", ""))


def _clear_caches() -> None:
    try:
        from hdpbsid.bases.memo import clear_caches
    except ImportError:  # moved: nothing to clear, or the script must follow it
        return
    clear_caches()


_WARM = False


def _warm_up() -> None:
    """One small untimed call per process: imports and compiled kernels are not counted."""
    global _WARM
    if _WARM:
        return
    rec = make_case("second-order", 0, 20.0).estimation
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hdpbsid.identify(rec.t[:800], rec.u[:800], rec.y[:800])
    _WARM = True


def worst_error_pct(estimated: Any, true: Any) -> float:
    """Largest relative eigenvalue error in percent, NaN if the numbers differ."""
    est, tru = np.asarray(estimated).ravel(), np.asarray(true).ravel()
    if est.size != tru.size:
        return float("nan")
    return 100.0 * float(np.max(eigenvalue_errors(est, tru)))


def _is_stable(ev: Any, z_dt: float | None) -> bool:
    ev = np.asarray(ev)
    return bool(np.all(np.abs(ev) < 1.0)) if z_dt is not None else bool(np.all(ev.real < 0.0))


def run_record(spec: RecordSpec) -> dict[str, Any]:
    """One row of the table (module docstring); an exception anywhere is a row with its
    text, never a crash."""
    from threadpoolctl import threadpool_limits

    row: dict[str, Any] = dict.fromkeys(CSV_FIELDS, "")
    row.update(id=spec.id, family=spec.family, seed="" if spec.seed is None else spec.seed)
    try:
        with threadpool_limits(limits=1):
            _warm_up()
            trial = make_trial(spec)
            _fill_record(row, trial)
            _clear_caches()
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                c0, w0 = time.process_time(), time.perf_counter()
                model = hdpbsid.identify(trial.t, trial.u, trial.y)
                row["cpu_s"] = round(time.process_time() - c0, 4)
                row["wall_s"] = round(time.perf_counter() - w0, 4)
            _score(row, trial, model)
    except Exception as exc:  # noqa: BLE001 - every failure is a row of the table
        row["error"] = f"{type(exc).__name__}: {exc}"[:300].replace("\n", " ")
    return row


def _fill_record(row: dict[str, Any], trial: Trial) -> None:
    u = np.reshape(trial.u, (len(trial.t), -1))
    y = np.reshape(trial.y, (len(trial.t), -1))
    true = trial.true_eigenvalues
    row.update(
        snr="own"
        if trial.snr is None and trial.input == "case"
        else (trial.snr if trial.snr is not None else ""),
        sampling=trial.sampling,
        loop=trial.loop,
        input=trial.input,
        m=u.shape[1],
        l=y.shape[1],
        ns=len(trial.t),
        true_order="" if true is None else true.size,
        true_stable="" if true is None else _is_stable(true, trial.z_dt),
        data=data_digest(trial.t, u, y),
    )


def _score(row: dict[str, Any], trial: Trial, model: Any) -> None:
    ev = np.linalg.eigvals(model.A)
    if trial.z_dt is not None:
        ev = np.exp(ev * trial.z_dt)
    row.update(
        method=_chosen_method(model), order=model.A.shape[0], stable=_is_stable(ev, trial.z_dt)
    )
    if trial.true_eigenvalues is not None:
        row["order_found"] = ev.size == trial.true_eigenvalues.size
        row["err_pct"] = _round(worst_error_pct(ev, trial.true_eigenvalues))
    row["fit_pct"] = _round(trial.fit(model))


def _round(x: float) -> Any:
    return "" if not np.isfinite(x) else float(f"{x:.6g}")


def run_table(specs: Sequence[RecordSpec], n_jobs: int = 1) -> list[dict[str, Any]]:
    """Every row, in the order of ``specs``; ``n_jobs > 1`` runs records in parallel
    (joblib), each task on one BLAS thread; a tqdm bar shows the progress."""
    from tqdm import tqdm

    bar = tqdm(total=len(specs), desc="records", unit="rec", file=sys.stderr)
    rows: dict[str, dict[str, Any]] = {}
    if n_jobs > 1:
        from joblib import Parallel, delayed

        par = Parallel(n_jobs=n_jobs, return_as="generator_unordered")
        results: Iterable[dict[str, Any]] = par(delayed(run_record)(s) for s in specs)
    else:
        results = (run_record(s) for s in specs)
    for row in results:
        rows[row["id"]] = row
        bar.update()
    bar.close()
    return [rows[s.id] for s in specs]


# -- reading and summarising ----------------------------------------------------------------
def _num(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def _bool(x: Any) -> bool | None:
    if isinstance(x, bool):
        return x
    return {"True": True, "False": False}.get(str(x))


def read_csv(path: Path) -> list[dict[str, str]]:
    """The rows of a table written by this script."""
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def write_csv(rows: Sequence[dict[str, Any]], path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(CSV_FIELDS))
        w.writeheader()
        w.writerows(rows)


def _stats(values: Sequence[float]) -> tuple[float, float]:
    v = np.array([x for x in values if np.isfinite(x)])
    if v.size == 0:
        return float("nan"), float("nan")
    return float(np.median(v)), float(np.percentile(v, 90))


def family_summary(rows: Sequence[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per family (table order) and in total: records, failures, true order found (of the
    records with a truth), median and 90th percentile of the eigenvalue error (true order
    found), median validation fit and median CPU time."""
    fams = list(dict.fromkeys(r["family"] for r in rows))
    out = []
    for fam in [*fams, "total"]:
        rr = [r for r in rows if fam in ("total", r["family"])]
        truth = [r for r in rr if str(r["true_order"]) != ""]
        found = sum(_bool(r["order_found"]) is True for r in truth)
        err_med, err_p90 = _stats([_num(r["err_pct"]) for r in rr])
        fit_med, _ = _stats([_num(r["fit_pct"]) for r in rr])
        cpu_med, _ = _stats([_num(r["cpu_s"]) for r in rr])
        out.append(
            {
                "family": fam,
                "records": len(rr),
                "failed": sum(bool(r["error"]) for r in rr),
                "found": f"{found}/{len(truth)}" if truth else "n/a",
                "err_median": err_med,
                "err_p90": err_p90,
                "fit_median": fit_med,
                "cpu_median": cpu_med,
            }
        )
    return out


def _f(x: float, fmt: str = ".3g") -> str:
    return "n/a" if not np.isfinite(x) else format(x, fmt)


def summary_text(rows: Sequence[dict[str, Any]]) -> str:
    """The summary table (markdown)."""
    lines = [
        "| family | records | failed | true order | err % median | err % p90 | fit % median "
        "| CPU s median |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for s in family_summary(rows):
        name = f"**{s['family']}**" if s["family"] == "total" else s["family"]
        lines.append(
            f"| {name} | {s['records']} | {s['failed']} | {s['found']} | {_f(s['err_median'])} | "
            f"{_f(s['err_p90'])} | {_f(s['fit_median'], '.1f')} | {_f(s['cpu_median'], '.2f')} |"
        )
    return "\n".join(lines)


# -- comparison --------------------------------------------------------------------------
def beyond_margin(old: float, new: float, floor: float, rel: float = MARGIN_REL) -> int:
    """``+1`` if the error-like ``new`` is worse than ``old`` by more than the margin
    ``rel * old + floor``, ``-1`` if better by more than ``rel * new + floor``, else 0
    (NaN on either side: 0).  Relative, because equivalent fits of one record differ in
    proportion to their error (:data:`MARGIN_REL`); with a floor, because below it a
    difference is the noise realisation's (:data:`MARGIN_ERR_PP`, :data:`MARGIN_FIT_PP`)."""
    if not (np.isfinite(old) and np.isfinite(new)):
        return 0
    if new > old * (1.0 + rel) + floor:
        return 1
    if old > new * (1.0 + rel) + floor:
        return -1
    return 0


def _misfit(row: dict[str, Any]) -> float:
    fit = _num(row.get("fit_pct"))
    return 100.0 - fit if np.isfinite(fit) else float("nan")


def compare_rows(old: dict[str, Any], new: dict[str, Any]) -> tuple[str, list[str]]:
    """Verdict on one record: ``"worse"``, ``"better"``, ``"mixed"``, ``"changed"`` (method,
    order or data only) or ``"same"``, with the reasons."""
    worse, better, info = [], [], []
    old_fail, new_fail = bool(old.get("error")), bool(new.get("error"))
    if new_fail and not old_fail:
        worse.append(f"newly failing: {new['error'][:80]}")
    elif old_fail and not new_fail:
        better.append("no longer failing")
    if old.get("data") and new.get("data") and old["data"] != new["data"]:
        info.append("record data changed")
    if not (old_fail or new_fail):
        of, nf = _bool(old.get("order_found")), _bool(new.get("order_found"))
        if of is True and nf is False:
            worse.append(f"true order lost ({old['order']} -> {new['order']})")
        elif of is False and nf is True:
            better.append(f"true order found ({old['order']} -> {new['order']})")
        e_old, e_new = _num(old.get("err_pct")), _num(new.get("err_pct"))
        v = beyond_margin(e_old, e_new, MARGIN_ERR_PP)
        if v:
            (worse if v > 0 else better).append(f"err {e_old:.3g} -> {e_new:.3g} %")
        f_old, f_new = _misfit(old), _misfit(new)
        v = beyond_margin(f_old, f_new, MARGIN_FIT_PP)
        if v:
            (worse if v > 0 else better).append(f"fit {100 - f_old:.1f} -> {100 - f_new:.1f} %")
        if _bool(old.get("true_stable")) is True:
            os_, ns_ = _bool(old.get("stable")), _bool(new.get("stable"))
            if os_ is True and ns_ is False:
                worse.append("model no longer stable")
            elif os_ is False and ns_ is True:
                better.append("model now stable")
        if str(old.get("method")) != str(new.get("method")) or str(old.get("order")) != str(
            new.get("order")
        ):
            info.append(f"{old['method']} n={old['order']} -> {new['method']} n={new['order']}")
    verdict = (
        "mixed"
        if worse and better
        else "worse"
        if worse
        else "better"
        if better
        else "changed"
        if info
        else "same"
    )
    return verdict, worse + better + info


def totals(rows: Sequence[dict[str, Any]], paired: set[str] | None = None) -> dict[str, float]:
    """Totals of a table: records, failures, true order found, median and 90th percentile
    of the eigenvalue error and median misfit; with ``paired`` (ids), the error and misfit
    statistics only over those rows (the rows scored in both tables, so that a record
    whose order is newly found does not count against the new table)."""
    sel = [r for r in rows if paired is None or r["id"] in paired]
    errs = [_num(r["err_pct"]) for r in sel]
    misfits = [_misfit(r) for r in sel]
    e_med, e_p90 = _stats(errs)
    f_med, _ = _stats(misfits)
    return {
        "records": len(rows),
        "failed": sum(bool(r["error"]) for r in rows),
        "found": sum(_bool(r["order_found"]) is True for r in rows),
        "err_median": e_med,
        "err_p90": e_p90,
        "misfit_median": f_med,
        "cpu_median": _stats([_num(r["cpu_s"]) for r in rows])[0],
    }


#: total -> (direction, margin floor): +1 if more is worse, -1 if less is worse; None: not
#: guarded (CPU time depends on the machine and its load)
GUARDED: dict[str, tuple[int, float] | None] = {
    "records": None,
    "failed": (1, 0.0),
    "found": (-1, 0.0),
    "err_median": (1, MARGIN_ERR_PP),
    "err_p90": (1, MARGIN_ERR_PP),
    "misfit_median": (1, MARGIN_FIT_PP),
    "cpu_median": None,
}


def compare_tables(
    old_rows: Sequence[dict[str, Any]], new_rows: Sequence[dict[str, Any]]
) -> tuple[list[tuple[str, str, list[str]]], dict[str, tuple[float, float, str]], bool]:
    """Changed rows ``(id, verdict, reasons)``, the totals ``name -> (old, new, mark)`` over
    the records of both tables and whether a guarded total got worse."""
    old_by = {r["id"]: r for r in old_rows}
    new_by = {r["id"]: r for r in new_rows}
    common = [i for i in new_by if i in old_by]
    changes = []
    for i in common:
        verdict, reasons = compare_rows(old_by[i], new_by[i])
        if verdict != "same":
            changes.append((i, verdict, reasons))
    o_rows = [old_by[i] for i in common]
    n_rows = [new_by[i] for i in common]
    both = {
        i
        for i in common
        if np.isfinite(_num(old_by[i]["err_pct"])) and np.isfinite(_num(new_by[i]["err_pct"]))
    }
    both_fit = {
        i for i in common if np.isfinite(_misfit(old_by[i])) and np.isfinite(_misfit(new_by[i]))
    }
    t_old, t_new = totals(o_rows, both), totals(n_rows, both)
    t_old["misfit_median"] = totals(o_rows, both_fit)["misfit_median"]
    t_new["misfit_median"] = totals(n_rows, both_fit)["misfit_median"]
    out, any_worse = {}, False
    for name, rule in GUARDED.items():
        a, b = t_old[name], t_new[name]
        mark = ""
        if rule is not None:
            sign, floor = rule
            if floor == 0.0:
                v = int(np.sign(b - a)) * sign
            else:
                v = beyond_margin(a, b, floor)
            mark = "WORSE" if v > 0 else "better" if v < 0 else "same"
            any_worse |= v > 0
        out[name] = (a, b, mark)
    return changes, out, any_worse


def print_comparison(
    old_rows: Sequence[dict[str, Any]], new_rows: Sequence[dict[str, Any]], out: Any = None
) -> bool:
    """Print the changed rows and the totals; return whether a guarded total got worse."""
    out = out or sys.stdout
    changes, tot, worse = compare_tables(old_rows, new_rows)
    n_old, n_new = len(old_rows), len(new_rows)
    common = len({r["id"] for r in old_rows} & {r["id"] for r in new_rows})
    print(f"\ncompared on {common} records (old table {n_old}, new {n_new})", file=out)
    order = {"worse": 0, "mixed": 1, "better": 2, "changed": 3}
    for i, verdict, reasons in sorted(changes, key=lambda c: order[c[1]]):
        print(f"  {verdict:7s} {i:34s} {'; '.join(reasons)}", file=out)
    counts = {v: sum(c[1] == v for c in changes) for v in order}
    print("rows: " + ", ".join(f"{k} {v}" for k, v in counts.items()), file=out)
    print(
        "\n| total | old | new | |\n|---|---:|---:|---|\n"
        + "\n".join(
            f"| {k} | {_f(a, '.4g')} | {_f(b, '.4g')} | {m} |" for k, (a, b, m) in tot.items()
        ),
        file=out,
    )
    print(
        "(err and misfit totals over the records scored in both tables; margin "
        f"{MARGIN_REL:.0%} relative + {MARGIN_ERR_PP} / {MARGIN_FIT_PP} percentage points; "
        "CPU not guarded)",
        file=out,
    )
    return worse


# -- metadata and main ---------------------------------------------------------------------
def _git(*args: str) -> str:
    try:
        return subprocess.run(
            ["git", "-C", str(REPO), *args], capture_output=True, text=True, check=True
        ).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def metadata(
    command: str, n_jobs: int, wall: float, n_rows: int, load: tuple[float, ...]
) -> dict[str, Any]:
    """The commit measured, the last commit that changed the library, whether the library
    had uncommitted edits, the date, the machine, its load (1-minute average at the start
    and the end: the CPU times rise with it on shared cores) and the versions."""
    from importlib.metadata import PackageNotFoundError, version

    import scipy

    try:
        pkg = version("slbasis-hdpbsid")
    except PackageNotFoundError:
        pkg = "unknown"
    return {
        "commit": _git("rev-parse", "HEAD"),
        "library_commit": _git("log", "-1", "--format=%H", "--", "hdpbsid", "slbasis"),
        "library_dirty": bool(_git("status", "--porcelain", "hdpbsid", "slbasis")),
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "command": command,
        "n_jobs": n_jobs,
        "records": n_rows,
        "wall_seconds": round(wall, 1),
        "machine": f"{platform.machine()}, {os.cpu_count()} cores (shared)",
        "load_average": [round(x, 1) for x in load],
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "hdpbsid": pkg,
        "margins": {"rel": MARGIN_REL, "err_pp": MARGIN_ERR_PP, "fit_pp": MARGIN_FIT_PP},
    }


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n-jobs", type=int, default=1, help="records in parallel (joblib)")
    ap.add_argument("--subset", nargs="+", help="shell patterns of record ids or families")
    ap.add_argument("--out", type=Path, default=BENCH / "results" / "regression.csv")
    ap.add_argument("--compare", type=Path, help="an earlier table: list changes, guard totals")
    args = ap.parse_args(argv)
    if args.n_jobs < 1:
        raise SystemExit(f"--n-jobs must be >= 1, got {args.n_jobs}")
    if args.compare is not None and not args.compare.is_file():
        raise SystemExit(f"--compare: no such file {args.compare}")
    specs = select(record_specs(), args.subset)
    if not specs:
        raise SystemExit(f"--subset {args.subset} matches no record")
    command = "python bench/regression.py " + " ".join(sys.argv[1:] if argv is None else argv)
    w0, load0 = time.perf_counter(), os.getloadavg()[0]
    rows = run_table(specs, args.n_jobs)
    wall = time.perf_counter() - w0
    write_csv(rows, args.out)
    meta = metadata(command.strip(), args.n_jobs, wall, len(rows), (load0, os.getloadavg()[0]))
    args.out.with_suffix(".json").write_text(json.dumps(meta, indent=1) + "\n")
    print(f"{len(rows)} records in {wall:.0f} s wall; {args.out}")
    print(summary_text(rows))
    if args.compare is not None:
        old = read_csv(args.compare)
        new = [{k: str(v) for k, v in r.items()} for r in rows]
        if print_comparison(old, new):
            print("a guarded total got worse", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
