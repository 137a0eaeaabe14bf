"""Why HD-PBSID misses the fast real poles of the Table-2-like closed loop (a diagnosis).

Run: ``.venv/bin/python bench/fastmodes.py [--seeds 3] [--snr 20]``.

The cases ``table2-closed-loop`` and ``table2-closed-loop-rate`` of ``bench/cases.py``
(plant eigenvalues ``-28, -10, 1.2 +- 5.8i``, LQG loop on the noisy rate, 1-4 Hz sweep,
30 s at 250 Hz).  Prints the relative error (%) of each eigenvalue, paired with the truth,
for:

1. ``pem from truth``: :func:`hdpbsid.refine.pem.refine_pem` started at the true
   model (sensor-noise-only Kalman gain as its second start), with the linearised
   standard deviation it reports -- what the data can give (the prediction-error method
   is efficient; Ljung, *System Identification*, 2nd ed., sec. 9.3);
2. HD-PBSID with its defaults, noise-free and with the operator scale ``alpha``, the
   basis size ``N``, the past window ``p`` and the ridge changed one at a time;
3. the closed-loop test: the same loop simulated with the noise only in the measured
   output (controller fed the clean rate: the input is then noise-free, as in open loop)
   and only in the controller (measured output clean).

Not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import cases as bc  # noqa: E402

from hdpbsid import identify  # noqa: E402
from hdpbsid.models.metrics import match_eigenvalues  # noqa: E402
from hdpbsid.models.model import StateSpaceModel  # noqa: E402
from hdpbsid.refine.pem import refine_pem  # noqa: E402

TRUE = bc.TABLE2_EIGENVALUES


def rel_err(ev: Any) -> np.ndarray:
    """Relative errors (%) of ``ev`` paired with the true eigenvalues (their order)."""
    est, tru = match_eigenvalues(ev, TRUE)
    return 100.0 * np.abs(est - tru) / np.abs(tru)


def show(label: str, errs: list[np.ndarray]) -> None:
    e = np.array(errs)
    cells = "  ".join(f"{np.mean(e[:, i]):6.1f}" for i in range(e.shape[1]))
    print(f"  {label:38s} {cells}   (mean over {len(errs)} seeds)")


def hermite_errors(t: Any, u: Any, y: Any, **kw: Any) -> np.ndarray:
    return rel_err(identify(t, u, y, 4, method="hermite", detrend=None, **kw).eigenvalues)


def split_noise(seed: int, snr: float, where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rate-output record with sensor noise only in the output (``"output"``) or only
    in the controller (``"controller"``)."""
    ctrl = bc.table2_controller()
    _, _, C, D = bc.table2_plant()
    ns = int(round(30.0 / bc.TABLE2_TS)) + 1
    t = np.arange(ns) * bc.TABLE2_TS
    r = bc.pitch_excitation("sweep", t, amplitude=1.0, f0=1.0, f1=4.0)
    X, mom = bc._table2_loop(ctrl, r, np.zeros(ns))
    sigma = np.sqrt(np.mean((X @ C.T + mom[:, None] @ D.T) ** 2, axis=0)) * 10 ** (-snr / 20)
    v = np.random.default_rng(seed).standard_normal((ns, 2)) * sigma
    X, mom = bc._table2_loop(ctrl, r, v[:, 0] if where == "controller" else np.zeros(ns))
    y = X @ C.T + mom[:, None] @ D.T + (v if where == "output" else 0.0)
    return t, mom[:, None], y[:, :1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--snr", type=float, default=20.0)
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    seeds = range(a.seeds)
    print(f"relative eigenvalue error %, columns: {', '.join(f'{z:g}' for z in TRUE)}")
    A, B, C, D = bc.table2_plant()
    for name in ("table2-closed-loop", "table2-closed-loop-rate"):
        print(f"\n{name}, SNR {a.snr:g} dB")
        data = [bc.make_case(name, s, a.snr) for s in seeds]
        l = data[0].estimation.y.shape[1]
        errs, stds = [], []
        for c in data:
            r = c.estimation
            opts = {"feedthrough": l == 2}
            m0 = StateSpaceModel(A, B, C[:l], D[:l], np.zeros((4, l)), options=opts)
            m = refine_pem(m0, r.t, r.u, r.y, hold="zoh")
            errs.append(rel_err(m.eigenvalues))
            ev = m.eigenvalues
            sd = 100.0 * np.asarray(m.options["eigenvalue_std"]) / np.abs(ev)
            stds.append(sd[[int(np.argmin(np.abs(ev - z))) for z in TRUE]])
        show("pem from truth: error", errs)
        show("pem from truth: linearised std", stds)
        clean = bc.make_case(name, 0, None).estimation
        noise_free = hermite_errors(clean.t, clean.u, clean.y, **data[0].options)
        show("hermite defaults, noise-free", [noise_free])
        variants: list[tuple[str, dict[str, Any]]] = [
            ("hermite defaults", {}),
            ("hermite alpha=20", {"alpha": 20.0}),
            ("hermite alpha=50", {"alpha": 50.0}),
            ("hermite N=1000", {"N": 1000}),
            ("hermite p=8", {"p": 8}),
            ("hermite regularize=None", {"regularize": None}),
            ("hermite refine='pem'", {"refine": "pem"}),
        ]
        for label, kw in variants:
            errs = [
                hermite_errors(c.estimation.t, c.estimation.u, c.estimation.y, **c.options, **kw)
                for c in data
            ]
            show(label, errs)
    print(f"\ntable2-closed-loop-rate, SNR {a.snr:g} dB, where the sensor noise enters")
    for where in ("output", "controller"):
        errs = [hermite_errors(*split_noise(s, a.snr, where)) for s in seeds]
        show(f"hermite, noise only in the {where}", errs)


if __name__ == "__main__":
    main()
