"""Study ``snr``: the second-order system at decreasing SNR (the thesis, §5, first study).

Second-order benchmark (:func:`hdpbsid.systems.second_order`; eigenvalues
``-0.4 +- 1.9596i``), 40 s, 4001 samples, a 0.05-1 Hz linear sweep projected on
``n_max,u = 100`` Hermite functions (the thesis, §5), white output noise at each SNR;
methods with their :func:`hdpbsid.identify` defaults, order 2.  The thesis reports:
accurate at low noise, deviations grow as the SNR falls.
"""

from __future__ import annotations

from typing import Any

from hdpbsid.studies import second_order
from hdpbsid.studies.base import Study
from hdpbsid.studies.methods import check_methods

__all__ = ["STUDY", "DEFAULTS", "make_cases"]

DEFAULTS: dict[str, Any] = {
    "runs": 20,
    "snrs": (40.0, 30.0, 20.0, 10.0, 6.0, 0.0),
    "methods": ("hermite", "laguerre"),
    **{k: v for k, v in second_order.DATA_DEFAULTS.items() if k != "snr_db"},
}


def make_cases(s: dict[str, Any]) -> list[dict[str, Any]]:
    """One case per SNR and method; the methods of one SNR share the record of a run.

    Parameters
    ----------
    s : dict
        Every setting of the study (its ``DEFAULTS`` updated by the user's).

    Returns
    -------
    list of dict
        Cases with ``data`` (the record's settings), ``method``, ``order`` 2 and ``options``.

    Raises
    ------
    ValueError
        If a method name is unknown (:func:`~hdpbsid.studies.methods.check_methods`).
    """
    methods = check_methods(s["methods"])
    cases = []
    for snr in s["snrs"]:
        data = {k: s[k] for k in second_order.DATA_DEFAULTS if k != "snr_db"}
        data["snr_db"] = None if snr is None else float(snr)
        for m in methods:
            cases.append({"data": data, "method": m, "order": 2, "options": {}})
    return cases


def summarize(records: list[dict[str, Any]], s: dict[str, Any]) -> list[dict[str, Any]]:
    return second_order.rows(records, ("snr_db", "method"))


def _figures(result: Any, out: Any) -> dict[str, Any]:
    from hdpbsid.studies.figures import curve_figure

    return curve_figure(result, out, x="snr_db", xlabel="SNR [dB]", name="snr")


STUDY = Study(
    name="snr",
    title="Second-order system: eigenvalue error vs SNR",
    source="thesis §5",
    task=second_order.task,
    make_cases=make_cases,
    summarize=summarize,
    defaults=DEFAULTS,
    columns=("snr_db", "method", *second_order.COLUMNS),
    figures=_figures,
    notes=__doc__ or "",
)
