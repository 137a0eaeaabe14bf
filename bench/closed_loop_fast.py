"""Fast modes in closed loop with the defaults: a plant the library was not tuned on.

Run: ``python bench/closed_loop_fast.py [--seeds 10] [--snr 20]``;
writes ``bench/results/closed_loop_fast.md``.

The plant is :func:`cases.table2_plant` (eigenvalues ``-28, -10, 1.2 +- 5.8i``, outputs
the rate ``q`` and the angular acceleration ``dq/dt``, which has a direct term from the
moment), sampled at 250 Hz with the moment held between samples, under a loop that is not
the one of ``bench/cases.py`` (an LQG on the rate alone):

* ``observer``: discrete LQR state feedback ``M_k = -K xhat_k + r_k`` with a predictor
  observer fed by *both* noisy measurements, ``xhat_{k+1} = Phi xhat_k + Gamma M_k +
  L (y_k - C xhat_k - D M_k)``, ``L`` from poles placed at ``exp(s ts)`` for
  ``s = -40, -45, -50, -55`` rad/s (``scipy.signal.place_poles``).
* ``observer-slow``: the same with the observer poles at ``-15, -18, -21, -24`` rad/s,
  inside the band of the fast modes.
* ``observer-fast``: LQR weights ten times larger on both outputs and the observer poles
  at ``-60, -70, -80, -90`` rad/s.

``--plant`` runs the same loops on plants the library was not developed on, with the
same input and output rows (``B``, the rate row ``c_q`` and its derivative):

* ``stable-pair``: the oscillatory pair mirrored into the left half-plane,
  ``-28, -10, -1.2 +- 5.8i``;
* ``slower-fast``: fast modes ``-22, -8`` and a pair ``-0.6 +- 7i``.

No PI loop on the rate: a grid of proportional and integral gains of either sign
(``check_stable``) found none that stabilises the unstable pair from the rate alone.

The excitation ``r`` is a seeded random binary signal held 0.02 s (flat power up to
about 20 Hz, above the fastest mode at 4.5 Hz), 30 s; white sensor noise on both outputs at
``snr`` dB of each sensor's noise-free power.  Per seed and loop it runs
``identify(t, u, y, order=4)`` (every default), the same with ``feedthrough=True`` (and
with ``method="hermite"`` and ``"legendre"``), and ``identify(t, u, y)`` (order chosen,
with and without the direct term), and prints the worst relative eigenvalue error, CPU
seconds per fit and the order picked.  The first row of each loop is the ceiling the
record sets: the prediction-error fit started at the true system in its true hold
(:func:`pem_from_truth`, not a method a user can call), whose error is what the record's
information leaves.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np
from scipy.linalg import block_diag, expm, solve_discrete_are
from scipy.signal import place_poles

sys.path.insert(0, str(Path(__file__).resolve().parent))

import cases as bc  # noqa: E402

from hdpbsid import identify  # noqa: E402
from hdpbsid.models.metrics import eigenvalue_errors  # noqa: E402
from hdpbsid.models.model import StateSpaceModel  # noqa: E402
from hdpbsid.refine.pem import refine_pem  # noqa: E402

TS = 0.004
RESULTS = Path(__file__).resolve().parent / "results" / "closed_loop_fast.md"

#: the plants of ``--plant``: name -> (fast real modes, oscillatory pair ``re, im``) in
#: the modal form of :func:`cases.table2_plant` (``table2``: that plant itself)
PLANTS: dict[str, tuple[tuple[float, float], tuple[float, float]]] = {
    "table2": ((-28.0, -10.0), (1.2, 5.8)),
    "stable-pair": ((-28.0, -10.0), (-1.2, 5.8)),
    "slower-fast": ((-22.0, -8.0), (-0.6, 7.0)),
}
#: the label of the ceiling row (:func:`pem_from_truth`)
ORACLE = "ceiling: prediction-error fit from the true system"
#: the plant in force (``--plant``)
PLANT = "table2"


def plant_matrices(name: str | None = None) -> tuple[np.ndarray, ...]:
    """``A, B, C, D`` of plant ``name`` (:data:`PLANTS`; default :data:`PLANT`): the
    modal ``A``, and the input and output rows of :func:`cases.table2_plant`."""
    (f1, f2), (re, im) = PLANTS[name or PLANT]
    _, B, _, _ = bc.table2_plant()
    A = block_diag(f1, f2, [[re, im], [-im, re]])
    cq = np.array([[1.0, 1.0, 1.0, 0.0]])
    return A, B, np.vstack([cq, cq @ A]), np.vstack([np.zeros((1, 1)), cq @ B])


def sampled_plant(ts: float = TS) -> tuple[np.ndarray, ...]:
    """``Phi, Gamma, C, D`` of the plant sampled with the input held (exact)."""
    A, B, C, D = plant_matrices()
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n:] = A * ts, B * ts
    E = expm(M)
    return E[:n, :n], E[:n, n:], C, D


#: the loops: name -> (LQR output weights on rate and acceleration, observer poles rad/s).
#: ``observer``: poles faster than every plant mode; ``observer-slow``: poles inside the
#: band of the fast modes (the estimate lags them); ``observer-fast``: a stiffer LQR and
#: poles twice as fast
LOOPS: dict[str, tuple[tuple[float, float], tuple[float, ...]]] = {
    "observer": ((1.0, 1e-3), (-40.0, -45.0, -50.0, -55.0)),
    "observer-slow": ((1.0, 1e-3), (-15.0, -18.0, -21.0, -24.0)),
    "observer-fast": ((10.0, 1e-2), (-60.0, -70.0, -80.0, -90.0)),
}


def observer_controller(ts: float = TS, loop: str = "observer") -> dict[str, np.ndarray]:
    """LQR gain and an observer on both outputs by pole placement (:data:`LOOPS`)."""
    if loop not in LOOPS:
        raise ValueError(f"loop must be one of {list(LOOPS)}, got {loop!r}")
    weights, observer = LOOPS[loop]
    Phi, Gam, C, _ = sampled_plant(ts)
    n = Phi.shape[0]
    P = solve_discrete_are(Phi, Gam, C.T @ np.diag(weights) @ C + 0.05 * np.eye(n),
                           np.array([[1e-2]]))  # fmt: skip
    K = np.linalg.solve(1e-2 + Gam.T @ P @ Gam, Gam.T @ P @ Phi)
    L = place_poles(Phi.T, C.T, np.exp(np.array(observer) * ts)).gain_matrix.T
    return {"K": K, "L": L}


def simulate(loop: str, r: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Applied moments ``(Ns,)`` and measured outputs ``(Ns, 2)`` of ``loop``."""
    Phi, Gam, C, D = sampled_plant()
    n, ns = Phi.shape[0], r.shape[0]
    x, xh = np.zeros(n), np.zeros(n)
    mom, Y = np.empty(ns), np.empty((ns, 2))
    g = observer_controller(loop=loop)
    K, L = g["K"][0], g["L"]
    for k in range(ns):
        m = float(r[k] - K @ xh)
        y = C @ x + D[:, 0] * m + v[k]
        xh = Phi @ xh + Gam[:, 0] * m + L @ (y - C @ xh - D[:, 0] * m)
        x = Phi @ x + Gam[:, 0] * m
        mom[k], Y[k] = m, y
    return mom, Y


def check_stable(loop: str) -> float:
    """Spectral radius of the noise-free loop (must be below 1)."""
    Phi, Gam, C, _ = sampled_plant()
    g = observer_controller(loop=loop)
    K, L = g["K"], g["L"]
    Acl = np.block([[Phi, -Gam @ K], [L @ C, Phi - Gam @ K - L @ C]])
    return float(np.max(np.abs(np.linalg.eigvals(Acl))))


def record(loop: str, seed: int, snr: float, duration: float = 30.0) -> tuple[np.ndarray, ...]:
    """One seeded record ``t, u, y`` of ``loop`` (module docstring)."""
    rng = np.random.default_rng(seed)
    ns = int(round(duration / TS)) + 1
    t = np.arange(ns) * TS
    hold = int(round(0.02 / TS))
    r = np.repeat(rng.choice([-1.0, 1.0], size=ns // hold + 1), hold)[:ns]
    _, clean = simulate(loop, r, np.zeros((ns, 2)))
    sigma = np.sqrt(np.mean(clean**2, axis=0)) * 10.0 ** (-snr / 20.0)
    v = rng.standard_normal((ns, 2)) * sigma
    mom, y = simulate(loop, r, v)
    return t, mom[:, None], y


def fit(t: Any, u: Any, y: Any, **kw: Any) -> tuple[float, float, int, str]:
    """Worst eigenvalue error (%; inf when the order differs or the call raised), CPU s,
    order (0 when it raised), method (the exception's class when it raised)."""
    c0 = time.process_time()
    try:
        m = identify(t, u, y, **kw)
    except ValueError as exc:  # a method that cannot answer says so: counted, not hidden
        return float("inf"), time.process_time() - c0, 0, f"raised {type(exc).__name__}"
    cpu = time.process_time() - c0
    ev = m.eigenvalues
    true = np.linalg.eigvals(plant_matrices()[0])
    err = 100 * float(np.max(eigenvalue_errors(ev, true))) if ev.size == 4 else float("inf")
    return err, cpu, int(ev.size), str(m.options.get("method"))


def pem_from_truth(t: Any, u: Any, y: Any) -> tuple[float, float, int, str]:
    """:func:`fit`'s outcome for the prediction-error fit started at the true system
    (innovation gain zero, direct term estimated) in the true hold, on the record with
    its means removed: the minimum the record's information puts the estimate at."""
    A, B, C, D = plant_matrices()
    c0 = time.process_time()
    truth = StateSpaceModel(A, B, C, D, np.zeros((4, 2)), options={"feedthrough": True})
    m = refine_pem(truth, t, u - u.mean(axis=0), y - y.mean(axis=0), hold="zoh")
    err = 100 * float(np.max(eigenvalue_errors(m.eigenvalues, np.linalg.eigvals(A))))
    return err, time.process_time() - c0, m.n, "pem from the truth"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--snr", type=float, default=20.0)
    ap.add_argument("--loops", nargs="+", default=list(LOOPS), choices=list(LOOPS))
    ap.add_argument("--no-auto-order", action="store_true", help="skip the order-not-given runs")
    ap.add_argument("--calls", nargs="+", default=None, help="only these calls (labels)")
    ap.add_argument("--plant", default="table2", choices=list(PLANTS))
    ap.add_argument("--out", type=Path, default=None)
    a = ap.parse_args()
    global PLANT
    PLANT = a.plant
    if a.out is None:
        a.out = RESULTS if a.plant == "table2" else RESULTS.with_stem(f"{RESULTS.stem}_{a.plant}")
    warnings.simplefilter("ignore")
    runs: list[tuple[str, dict[str, Any]]] = [
        (ORACLE, {}),
        ("order=4", {"order": 4}),
        ("order=4, feedthrough=True", {"order": 4, "feedthrough": True}),
        (
            "order=4, hermite, feedthrough=True",
            {"order": 4, "method": "hermite", "feedthrough": True},
        ),
        (
            "order=4, legendre, feedthrough=True",
            {"order": 4, "method": "legendre", "feedthrough": True},
        ),
    ]
    if not a.no_auto_order:
        runs.append(("order not given", {}))
        runs.append(("order not given, feedthrough=True", {"feedthrough": True}))
    if a.calls:
        runs = [r for r in runs if r[0] in a.calls]
    lines = [
        f"# Fast modes in closed loop ({a.seeds} seeds, {a.snr:g} dB, plant {a.plant})",
        "",
        f"`python bench/closed_loop_fast.py --plant {a.plant}` (module docstring: plant, "
        "loops, excitation).",
        f"CPU seconds per call (process time), load average {os.getloadavg()[0]:.1f} at the "
        "start on a shared 2-core machine.",
        "",
        "| loop | call | worst eig. err % per seed | <= 10 % | CPU s median | orders | method |",
        "|---|---|---|---:|---:|---|---|",
    ]
    for loop in a.loops:
        print(f"{loop}: spectral radius of the loop {check_stable(loop):.4f}")
        recs = [record(loop, s, a.snr) for s in range(a.seeds)]
        for label, kw in runs:
            res = [pem_from_truth(*rec) if label == ORACLE else fit(*rec, **kw) for rec in recs]
            errs = [r[0] for r in res]
            ok = sum(e <= 10.0 for e in errs)
            cpu = float(np.median([r[1] for r in res]))
            orders = ",".join(str(r[2]) for r in res)
            methods = ",".join(sorted({r[3] for r in res}))
            cells = " ".join(f"{e:.3g}" for e in errs)
            row = (
                f"| {loop} | {label} | {cells} | {ok}/{len(errs)} | {cpu:.2f} | {orders} "
                f"| {methods} |"
            )
            print(row, flush=True)
            lines.append(row)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    a.out.write_text("\n".join(lines) + "\n")
    print(f"written {a.out}")


if __name__ == "__main__":
    main()
