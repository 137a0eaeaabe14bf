"""Study ``samples``: number of samples 100 ... 10 000 over the same 40 s record
(the thesis, §5: "an increasing number of samples leads to improved accuracy").

Second-order benchmark at SNR 20 dB (per-sample white noise, so more samples of the
same record average more noise), 0.05-1 Hz sweep on 100 Hermite functions, HD-PBSID
defaults (its N is capped at ``Ns / 2``), order 2.
"""

from __future__ import annotations

from typing import Any

from hdpbsid.studies import second_order
from hdpbsid.studies.base import Study
from hdpbsid.studies.methods import check_methods

__all__ = ["STUDY", "DEFAULTS", "make_cases"]

DEFAULTS: dict[str, Any] = {
    "runs": 20,
    "sample_counts": (100, 300, 1000, 3000, 10000),
    "methods": ("hermite",),
    **{k: v for k, v in second_order.DATA_DEFAULTS.items() if k != "samples"},
}


def make_cases(s: dict[str, Any]) -> list[dict[str, Any]]:
    """One case per sample count and method.

    Parameters
    ----------
    s : dict
        Every setting of the study (its ``DEFAULTS`` updated by the user's).

    Returns
    -------
    list of dict
        Cases with ``data``, ``method``, ``order`` 2 and ``options``.

    Raises
    ------
    ValueError
        If a sample count is below 10 or a method name is unknown.
    """
    methods = check_methods(s["methods"])
    cases = []
    for ns in s["sample_counts"]:
        if int(ns) < 10:
            raise ValueError(f"sample_counts must be >= 10, got {ns}")
        data = {k: s[k] for k in second_order.DATA_DEFAULTS if k != "samples"}
        data["samples"] = int(ns)
        for m in methods:
            cases.append({"data": data, "method": m, "order": 2, "options": {}})
    return cases


def summarize(records: list[dict[str, Any]], s: dict[str, Any]) -> list[dict[str, Any]]:
    return second_order.rows(records, ("samples", "method"))


def _figures(result: Any, out: Any) -> dict[str, Any]:
    from hdpbsid.studies.figures import curve_figure

    return curve_figure(
        result, out, x="samples", xlabel="number of samples", name="samples", logx=True
    )


STUDY = Study(
    name="samples",
    title="Second-order system: eigenvalue error vs number of samples (SNR 20 dB)",
    source="thesis §5",
    task=second_order.task,
    make_cases=make_cases,
    summarize=summarize,
    defaults=DEFAULTS,
    columns=("samples", "method", *second_order.COLUMNS),
    figures=_figures,
    notes=__doc__ or "",
)
