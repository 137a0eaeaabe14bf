"""Study ``operator``: the differentiation-operator parameters of HD-PBSID (the thesis, §3.2,
``D' = (D/alpha + beta I)/gamma``; §5: "alpha and beta have minimal impact, provided they
stay within stable, numerically sound ranges").

One-at-a-time sweeps around the defaults (``alpha = 4 s`` with ``s`` the Hermite time
scale, ``beta = gamma = 1``): ``alpha_factor`` (``alpha = factor * s``), ``beta`` and
``gamma``, on the second-order benchmark at SNR 20 dB with the other options at their
defaults.  ``A' = (A/alpha + beta I)/gamma`` must be a stable discrete matrix, i.e. every
``|lambda/alpha + beta| < gamma``; the sweeps include values where this fails.
"""

from __future__ import annotations

from typing import Any

from hdpbsid.studies import second_order
from hdpbsid.studies.base import Study

__all__ = ["STUDY", "DEFAULTS", "make_cases"]

DEFAULTS: dict[str, Any] = {
    "runs": 10,
    "alpha_factors": (0.05, 0.25, 0.5, 1.0, 2.0, 4.0, 16.0, 64.0, 256.0),
    "betas": (0.1, 0.5, 0.9, 1.0, 1.1, 2.0, 10.0),
    "gammas": (0.1, 0.5, 1.0, 2.0, 10.0),
    **second_order.DATA_DEFAULTS,
}


def make_cases(s: dict[str, Any]) -> list[dict[str, Any]]:
    """One case per value of each differentiation-operator parameter.

    Parameters
    ----------
    s : dict
        Every setting of the study (its ``DEFAULTS`` updated by the user's).

    Returns
    -------
    list of dict
        Cases labelled ``parameter`` (``alpha/s``, ``beta``, ``gamma``) and ``value``; all
        share the record of a run, so the parameters are compared on the same data.
    """
    data = {k: s[k] for k in second_order.DATA_DEFAULTS}
    cases = []
    for name, key, values in (
        ("alpha/s", "alpha_factor", s["alpha_factors"]),
        ("beta", "beta", s["betas"]),
        ("gamma", "gamma", s["gammas"]),
    ):
        for v in values:
            cases.append(
                {
                    "data": data,
                    "method": "hermite",
                    "order": 2,
                    "parameter": name,
                    "value": float(v),
                    "options": {key: float(v)},
                }
            )
    return cases


def summarize(records: list[dict[str, Any]], s: dict[str, Any]) -> list[dict[str, Any]]:
    return second_order.rows(records, ("parameter", "value"))


def _figures(result: Any, out: Any) -> dict[str, Any]:
    from hdpbsid.studies.figures import operator_figure

    return operator_figure(result, out)


STUDY = Study(
    name="operator",
    title="HD-PBSID operator parameters alpha, beta, gamma (SNR 20 dB)",
    source="thesis §3.2 and §5",
    task=second_order.task,
    make_cases=make_cases,
    summarize=summarize,
    defaults=DEFAULTS,
    columns=("parameter", "value", *second_order.COLUMNS),
    figures=_figures,
    notes=__doc__ or "",
)
