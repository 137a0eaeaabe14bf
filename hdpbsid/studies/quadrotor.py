"""Study ``quadrotor``: the thesis's §6 experiment, simulated.

The flight data of §6 are not public, so the ANT-X pitch model flies in its cascade
closed loop (:mod:`hdpbsid.systems.quadrotor`).  As in §5-6, the excitation added to the moment
command is the Hermite projection of a 1-4 Hz sine sweep on ``n_max,u`` functions
(:func:`~hdpbsid.systems.quadrotor.hermite_sweep_excitation`); the identified input is the
total moment and the outputs are the pitch rate ``q`` and the angular acceleration
``q_dot`` (§6: "measurements of angular velocity and acceleration"; ``outputs`` can
pick the angle ``theta`` instead).  ``q_dot = Mu u + Mq q + Md delta`` has a direct
feedthrough of the moment, so HD-PBSID runs with ``feedthrough=True``.

§6 identifies a *fourth-order* model "motivated by singular value analysis" with a
400-term basis.  Our simulated plant has three states, so the study records the
singular values and the order identify chooses (held-out simulation error), and identifies both
``orders`` (default 3 and 4): the eigenvalues against the truth (a 4th-order model has
one extra eigenvalue that the truth does not explain) and the fit (NRMSE, and VAF) on the
identification record and on a fresh validation record (same excitation, new noise)
- the simulated-vs-measured comparison of the thesis's Figure 2.

What to look for (the study's table and figures give the numbers): a high validation
fit does not mean the eigenvalues are right.  With ``q, q_dot`` the singular values
have one dominant direction and the unstable real pole is poorly determined, although
both outputs are fitted well; with ``q, theta`` two directions dominate and the order-3
eigenvalues are close to the truth.  Neither set of singular values motivates order 4:
a fourth-order model adds an eigenvalue the truth does not have.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hdpbsid.studies.base import Study, model_record
from hdpbsid.studies.data import quadrotor_record, validation_rng
from hdpbsid.studies.methods import check_methods, identify_with
from hdpbsid.systems.quadrotor import pitch_output_matrices

__all__ = ["STUDY", "DEFAULTS", "make_cases", "task", "identify_case", "validation_rng"]

DEFAULTS: dict[str, Any] = {
    "runs": 1,
    "snr_db": 20.0,
    "duration": 30.0,
    "excitation": "hermite-sweep",
    "n_max_u": 300,
    "amplitude": 0.05,
    "outputs": ("q", "q_dot"),
    "orders": (3, 4),
    "method": "hermite",
    "options": None,
}

COLUMNS = (
    "run",
    "order",
    "auto order",
    "max err (3 true)",
    "extra eigenvalue",
    "fit ident",
    "fit valid",
    "eigenvalues",
)


def _default_options(method: str, outputs: tuple[str, ...]) -> dict[str, Any]:
    opts: dict[str, Any] = {}
    if method == "hermite":
        opts["N"] = 400  # the thesis, §6: a 400-term Hermite basis (the default would be ~340)
    if "q_dot" in outputs or "a_x" in outputs:
        if method in ("hermite", "dt", "legendre", "chebyshev"):
            opts["feedthrough"] = True  # the accelerations have a moment feedthrough
    return opts


def make_cases(s: dict[str, Any]) -> list[dict[str, Any]]:
    """The study's one case: the record and every order are handled in one task.

    Parameters
    ----------
    s : dict
        Every setting of the study (its ``DEFAULTS`` updated by the user's).

    Returns
    -------
    list of dict
        One case with ``data``, ``method``, ``orders`` and ``options``.

    Raises
    ------
    ValueError
        If the method or an output name is unknown, or ``orders`` is empty or not positive.
    """
    (method,) = check_methods((s["method"],))
    outputs = pitch_output_matrices(s["outputs"])[2]  # ValueError for unknown names
    orders = [int(o) for o in s["orders"]]
    if not orders or min(orders) < 1:
        raise ValueError(f"orders must be positive integers, got {s['orders']}")
    snr = s["snr_db"]
    data = {
        "snr_db": None if snr is None else float(snr),
        "duration": float(s["duration"]),
        "excitation": s["excitation"],
        "outputs": list(outputs),
        "amplitude": float(s["amplitude"]),
        "n_max_u": int(s["n_max_u"]) if s["excitation"] == "hermite-sweep" else None,
    }
    options = {**_default_options(method, outputs), **(s["options"] or {})}
    return [{"data": data, "method": method, "orders": orders, "options": options}]


def identify_case(case: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    """Records and models of a case, every order identified.

    Parameters
    ----------
    case : dict
        The case (:func:`make_cases`).
    rng : numpy.random.Generator
        The task's generator; the validation record draws from its first child
        (:func:`~hdpbsid.studies.data.validation_rng`).

    Returns
    -------
    dict
        ``data`` and ``validation`` (the records), ``models`` (order -> model), ``errors``
        (order -> ``"Type: message"`` for an order whose identification raised; the others
        still count), ``auto`` (the model with the order chosen from the singular values,
        or ``None``).

    Raises
    ------
    Exception
        The first order's error, when every order fails.
    """
    data = quadrotor_record(rng, **case["data"])
    val = quadrotor_record(validation_rng(rng), **case["data"])
    models: dict[int, Any] = {}
    errors: dict[int, str] = {}
    first: Exception | None = None
    for o in case["orders"]:
        try:
            models[o] = identify_with(case["method"], data.t, data.u, data.y, o, case["options"])
        except (ValueError, np.linalg.LinAlgError) as exc:
            errors[o] = f"{type(exc).__name__}: {exc}"
            first = first or exc
    if not models and first is not None:
        raise first
    try:
        auto = identify_with(case["method"], data.t, data.u, data.y, None, case["options"])
    except (ValueError, np.linalg.LinAlgError):
        auto = None
    return {"data": data, "validation": val, "models": models, "errors": errors, "auto": auto}


def _singular_values(r: dict[str, Any]) -> list[float]:
    m = r["auto"] or next(iter(r["models"].values()))
    sv = m.singular_values
    return [] if sv is None else [float(s) for s in np.ravel(sv)[:12]]


def _fits(model: Any, d: Any) -> tuple[list[float], list[float]]:
    """The fit (NRMSE, percent) and the VAF (percent) per output of the simulation
    (:func:`~hdpbsid.plots.display_fit`)."""
    from hdpbsid.plots import display_fit

    shown = display_fit(model, d.t, d.u, d.y)
    return [float(v) for v in shown.fit], [float(v) for v in shown.vaf]


def task(case: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    """Identify every order of the case and compare with the truth.

    Parameters
    ----------
    case : dict
        The case (:func:`make_cases`).
    rng : numpy.random.Generator
        The task's generator.

    Returns
    -------
    dict
        Per order the eigenvalues vs truth, fit (NRMSE) and VAF on the identification and
        validation records, the singular values, and the held-out criterion per order of the
        order choice.
    """
    r = identify_case(case, rng)
    data, val = r["data"], r["validation"]
    true = data.true_eigenvalues
    out: dict[str, Any] = {
        "true": [[float(z.real), float(z.imag)] for z in true],
        "outputs": list(data.outputs),
        "saturation": data.saturation_fraction,
        "auto_order": None if r["auto"] is None else int(r["auto"].n),
        "singular_values": _singular_values(r),
        "order_selection": _order_rows(r["auto"]),
        "models": {},
        "order_errors": {str(o): e for o, e in r["errors"].items()},
    }
    for o, m in r["models"].items():
        rec = model_record(m, true)
        if m.n > true.size:
            from hdpbsid.models.metrics import match_eigenvalues

            est, _ = match_eigenvalues(m.eigenvalues, true)
            extra = [z for z in m.eigenvalues if not np.any(np.isclose(z, est))]
            rec["extra"] = [[float(z.real), float(z.imag)] for z in extra]
        rec["fit_identification"], rec["vaf_identification"] = _fits(m, data)
        rec["fit_validation"], rec["vaf_validation"] = _fits(m, val)
        rec["matrices"] = {k: getattr(m, k).tolist() for k in ("A", "B", "C", "D", "K")}
        out["models"][str(o)] = rec
    return out


def summarize(records: list[dict[str, Any]], s: dict[str, Any]) -> list[dict[str, Any]]:
    """One row per run and order."""
    rows = []
    for r in records:
        if not r["ok"]:
            rows.append({"run": r["run"], "order": None, "eigenvalues": r["error"][:60]})
            continue
        res = r["result"]
        for o, e in res.get("order_errors", {}).items():
            rows.append({"run": r["run"], "order": int(o), "eigenvalues": e[:60]})
        for o, m in res["models"].items():
            extra = m.get("extra") or []
            rows.append(
                {
                    "run": r["run"],
                    "order": int(o),
                    "auto order": res["auto_order"],
                    "max err (3 true)": m.get("max_error"),
                    "extra eigenvalue": ", ".join(_fmt(z) for z in extra) or "-",
                    "fit ident": "/".join(f"{v:.1f}" for v in m["fit_identification"]),
                    "fit valid": "/".join(f"{v:.1f}" for v in m["fit_validation"]),
                    "eigenvalues": ", ".join(_fmt(z) for z in m["eigenvalues"]),
                }
            )
    return rows


def _order_rows(model: Any) -> list[dict[str, Any]] | None:
    """The order choice's table as plain rows (order, held-out error, its distance to the
    best in standard errors), or ``None`` when the order was not chosen on held-out data."""
    rows = () if model is None else model.report.order_candidates()
    if not rows:
        return None
    return [{"method": r.method, "order": r.order, "error": r.error, "z": r.z} for r in rows]


def _fmt(z: list[float]) -> str:
    re, im = z
    return f"{re:.3g}" if abs(im) < 1e-9 else f"{re:.3g}{im:+.3g}j"


def _figures(result: Any, out: Any) -> dict[str, Any]:
    from hdpbsid.studies.figures import quadrotor_figures

    return quadrotor_figures(result, out)


STUDY = Study(
    name="quadrotor",
    title="Quadrotor pitch (thesis §6, simulated): HD-PBSID, orders 3 and 4",
    source="thesis §5-6, Tables 2-3, Figure 2",
    task=task,
    make_cases=make_cases,
    summarize=summarize,
    defaults=DEFAULTS,
    columns=COLUMNS,
    figures=_figures,
    notes=__doc__ or "",
)
