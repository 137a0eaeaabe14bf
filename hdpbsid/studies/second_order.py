"""The task and the summary shared by the second-order parameter studies (the thesis, §5:
``snr``, ``samples``, ``basis_order``, ``operator``).

A case is ``{"data": {...second_order_record settings}, "method": name, "order": 2,
"options": {...identify options}, ...labels}``; the task simulates the record and
identifies it; the summary groups records by the study's label keys and reports the
relative bias and STD of the eigenvalue ``-0.4 + 1.96i`` and the median worst error.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from hdpbsid.studies.base import eigen_stats, model_record
from hdpbsid.studies.data import SECOND_ORDER_TRUE, second_order_record
from hdpbsid.studies.methods import identify_with

__all__ = ["task", "rows", "DATA_DEFAULTS", "COLUMNS"]

#: the record of the thesis's §5: 40 s, 4001 samples, 0.05-1 Hz sweep on 100 Hermite functions
DATA_DEFAULTS: dict[str, Any] = {
    "snr_db": 20.0,
    "samples": 4001,
    "duration": 40.0,
    "f0": 0.05,
    "f1": 1.0,
    "n_max_u": 100,
}

COLUMNS = ("n", "failed", "divergent", "rel bias", "rel std", "median err", "time ms")


def task(case: dict[str, Any], rng: np.random.Generator) -> dict[str, Any]:
    """Simulate the second-order record of a case and identify it.

    These studies measure the subspace methods themselves (the thesis, sec. 5: SNR, samples,
    basis order, operator), so the prediction-error refinement is off unless the case asks
    for it: ``refine="auto"`` would rescue a grossly misfit model (e.g. ``alpha`` far too
    small) and hide what the study is about.

    Parameters
    ----------
    case : dict
        ``data`` (the record's settings, :func:`~hdpbsid.studies.data.second_order_record`),
        ``method``, ``order`` and ``options`` (which may hold ``alpha_factor``:
        ``alpha = alpha_factor * scale`` of the Hermite basis).
    rng : numpy.random.Generator
        The task's generator.

    Returns
    -------
    dict
        :func:`~hdpbsid.studies.base.model_record` of the model against the true
        eigenvalues.
    """
    rec = second_order_record(rng, **case["data"])
    options = {"refine": None, **(case.get("options") or {})}
    factor = options.pop("alpha_factor", None)
    if factor is not None:
        options["alpha"] = float(factor) * _hermite_scale(rec.t, options.get("N"), rec)
    model = identify_with(case["method"], rec.t, rec.u, rec.y, case["order"], options)
    return model_record(model, rec.true)


def _hermite_scale(t: np.ndarray, N: int | None, rec: Any) -> float:
    """The time scale ``s`` of the Hermite basis the method will use (it depends on N
    only): the one a default identification reports (``model.report.basis``)."""
    import slbasis

    if N is None:
        from hdpbsid.identify import identify

        m = identify(rec.t, rec.u, rec.y, 2, method="hermite", detrend=None)
        return float(m.report.basis["scale"])
    return float(slbasis.basis("hermite", int(N), (float(t[0]), float(t[-1]))).scale)


def rows(
    records: list[dict[str, Any]], keys: Sequence[str], true: Any = SECOND_ORDER_TRUE
) -> list[dict[str, Any]]:
    """Summary rows of the second-order studies, grouped by case labels.

    Parameters
    ----------
    records : list of dict
        The task records.
    keys : sequence of str
        The case labels to group by (e.g. ``("snr_db", "method")``), in first-seen order.
    true : array_like of complex, optional
        The true eigenvalues.

    Returns
    -------
    list of dict
        Per group the labels, the counts of runs and failures and
        :func:`~hdpbsid.studies.base.eigen_stats`.
    """
    groups: dict[tuple[Any, ...], list[dict[str, Any]]] = {}
    for r in records:
        groups.setdefault(tuple(_label(r["case"], k) for k in keys), []).append(r)
    z = np.asarray(true)[np.argmax(np.asarray(true).imag)]
    from hdpbsid.studies.base import _eig_tag

    tag = _eig_tag(z)
    return [
        _group_row(dict(zip(keys, label, strict=True)), recs, true, tag)
        for label, recs in groups.items()
    ]


def _group_row(
    row: dict[str, Any], recs: list[dict[str, Any]], true: Any, tag: str
) -> dict[str, Any]:
    """The summary row of one group of records (:func:`rows`): its labels ``row`` with the
    counts, the eigenvalue statistics of the pair ``tag``, the times and the errors."""
    ok = [r["result"] for r in recs if r["ok"]]
    st = eigen_stats(ok, true)
    times = [r["time"] for r in recs if r["ok"] and r.get("time") is not None]
    row.update(
        {
            "n": len(recs),
            "failed": sum(not r["ok"] for r in recs),
            "divergent": st["divergent"],
            "rel bias": st.get(f"rel_bias {tag}"),
            "rel std": st.get(f"rel_std {tag}"),
            "median err": st["median_error"],
            "time ms": 1e3 * float(np.median(times)) if times else None,
            "errors": [
                r["result"]["max_error"] for r in recs if r["ok"] and "max_error" in r["result"]
            ],
            "failures": sorted(
                {f"{r['error_type']}: {r['error'][:80]}" for r in recs if not r["ok"]}
            ),
        }
    )
    return row


def _label(case: dict[str, Any], key: str) -> Any:
    if key in case:
        return case[key]
    if key in case.get("data", {}):
        return case["data"][key]
    return case.get("options", {}).get(key)
