"""Study ``basis_order`` (CLI ``basis-order``): Hermite basis size N from 10 to 1000
(the thesis, §5: "orders below 30 result in poor identification, beyond 50 negligible
improvements").

Second-order benchmark at SNR 20 dB, 40 s, 4001 samples, 0.05-1 Hz sweep on 100
Hermite functions; HD-PBSID with ``N`` given and every other option at its default.
An ``N`` whose band ``3.6 N / T`` is below the data bandwidth is refused by
:func:`~hdpbsid.methods.hermite.identify_hermite` (``ValueError``); such runs are recorded as
failures, which is how "poor identification" shows up here.
"""

from __future__ import annotations

from typing import Any

from hdpbsid.studies import second_order
from hdpbsid.studies.base import Study

__all__ = ["STUDY", "DEFAULTS", "make_cases"]

DEFAULTS: dict[str, Any] = {
    "runs": 20,
    "basis_sizes": (10, 20, 30, 50, 60, 70, 80, 100, 150, 200, 300, 500, 1000),
    **second_order.DATA_DEFAULTS,
}


def make_cases(s: dict[str, Any]) -> list[dict[str, Any]]:
    """One case per Hermite basis size ``N``.

    Parameters
    ----------
    s : dict
        Every setting of the study (its ``DEFAULTS`` updated by the user's).

    Returns
    -------
    list of dict
        Cases with the option ``N``; all share the record of a run.

    Raises
    ------
    ValueError
        If a basis size is below 2.
    """
    data = {k: s[k] for k in second_order.DATA_DEFAULTS}
    cases = []
    for N in s["basis_sizes"]:
        if int(N) < 2:
            raise ValueError(f"basis_sizes must be >= 2, got {N}")
        cases.append({"data": data, "method": "hermite", "order": 2, "options": {"N": int(N)}})
    return cases


def summarize(records: list[dict[str, Any]], s: dict[str, Any]) -> list[dict[str, Any]]:
    return second_order.rows(records, ("N",))


def _figures(result: Any, out: Any) -> dict[str, Any]:
    from hdpbsid.studies.figures import curve_figure

    return curve_figure(
        result, out, x="N", xlabel="Hermite basis size N", name="basis_order", logx=True
    )


STUDY = Study(
    name="basis-order",
    title="Second-order system: eigenvalue error vs Hermite basis size N (SNR 20 dB)",
    source="thesis §5",
    task=second_order.task,
    make_cases=make_cases,
    summarize=summarize,
    defaults=DEFAULTS,
    columns=("N", *second_order.COLUMNS),
    figures=_figures,
    notes=__doc__ or "",
)
