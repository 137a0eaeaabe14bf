"""Simulation studies of the thesis (§5-6), one command each.

``run_study(name, *, runs, seed, jobs, scheduler, out, progress, resume, **settings)``
runs a study through the Monte Carlo engine (:mod:`hdpbsid.studies.runner`): serial,
joblib (``jobs > 1``) or Dask (``scheduler``), reproducible from ``seed``, resumable
from ``out/results.jsonl``.  Studies (:data:`STUDIES`; CLI names in brackets):

* ``snr``: second-order system, eigenvalue error vs SNR (the thesis, §5);
* ``samples``: error vs number of samples, 100 ... 10 000 (the thesis, §5);
* ``basis_order`` [``basis-order``]: Hermite basis size N, 10 ... 1000 (the thesis, §5);
* ``operator``: the differentiation-operator parameters alpha, beta, gamma (the thesis, §3.2, §5);
* ``table1``: closed-loop quadrotor, HD-PBSID vs CT-PBSID (projection, filters) vs DT,
  SNR 50/20/10/6 dB (the thesis, §5, Table 1, Figure 1);
* ``quadrotor``: the §6 example, simulated: Hermite-projected sweep, moment in, rate and
  angular acceleration out, singular values, order choice, validation (Figure 2).

Each also has a function of the same name, e.g. ``table1(runs=100, snrs=(50, 6))``.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from hdpbsid.studies import basis_order as _basis_order
from hdpbsid.studies import operator as _operator
from hdpbsid.studies import quadrotor as _quadrotor
from hdpbsid.studies import samples as _samples
from hdpbsid.studies import snr as _snr
from hdpbsid.studies import table1 as _table1
from hdpbsid.studies.base import Study, StudyResult
from hdpbsid.studies.runner import check_runs, load_records, run_tasks

__all__ = [
    "STUDIES",
    "Study",
    "StudyResult",
    "run_study",
    "get_study",
    "snr",
    "samples",
    "basis_order",
    "operator",
    "table1",
    "quadrotor",
    "load_records",
]

#: study name -> :class:`Study` (``basis_order`` is ``basis-order`` on the command line)
STUDIES: dict[str, Study] = {
    "snr": _snr.STUDY,
    "samples": _samples.STUDY,
    "basis_order": _basis_order.STUDY,
    "operator": _operator.STUDY,
    "table1": _table1.STUDY,
    "quadrotor": _quadrotor.STUDY,
}


def get_study(name: str) -> Study:
    """The study called ``name``.

    Parameters
    ----------
    name : str
        A key of :data:`STUDIES`; ``-`` and ``_`` are interchangeable (``basis-order``).

    Returns
    -------
    Study
        The study.

    Raises
    ------
    TypeError
        If ``name`` is not a string.
    ValueError
        If no study has that name (the message lists the known ones).

    Examples
    --------
    >>> get_study("basis_order") is get_study("basis-order")
    True
    """
    if not isinstance(name, str):
        raise TypeError(f"name must be a study name (str), got {type(name).__name__}")
    key = name.replace("-", "_")
    if key not in STUDIES:
        raise ValueError(
            f"name: unknown study {name!r}; known: {sorted(s.replace('_', '-') for s in STUDIES)}"
        )
    return STUDIES[key]


def run_study(
    name: str,
    *,
    runs: int | None = None,
    seed: int = 0,
    jobs: int = 1,
    scheduler: Any | None = None,
    out: str | Path | None = None,
    progress: bool = True,
    resume: bool = True,
    **settings: Any,
) -> StudyResult:
    """Run a study and return its result.

    Parameters
    ----------
    name : str
        The study (:func:`get_study`).
    runs : int or None, optional
        Monte Carlo runs per case (default: the study's).
    seed : int, optional
        Base seed: task ``(case, run)`` draws from
        ``SeedSequence([seed, data_id(case), run])`` (:func:`hdpbsid.studies.runner.task_rng`).
    jobs : int, optional
        Local processes (joblib/loky) when above 1; -1 for every core.
    scheduler : str or dask.distributed.Client, optional
        Dask scheduler address (``"tcp://host:port"``) or client; takes precedence over
        ``jobs``.
    out : str or path-like, optional
        Directory for ``results.jsonl`` (per task, for resuming), ``summary.csv``,
        ``summary.json``, ``records.csv`` and the PNG figures.
    progress : bool, optional
        Show a tqdm progress bar.
    resume : bool, optional
        Reuse the finished tasks of ``out/results.jsonl``.
    **settings
        The study's own settings (``STUDIES[name].defaults``).

    Returns
    -------
    StudyResult
        Records, summary rows, settings and the time taken.

    Raises
    ------
    TypeError
        On an unknown setting, or a ``runs`` / ``jobs`` that is not an integer.
    ValueError
        On an unknown study, ``runs < 1``, a negative ``seed``, or a bad setting value.
    """
    study = get_study(name)
    unknown = sorted(set(settings) - set(study.defaults))
    if unknown:
        known = sorted(k for k in study.defaults if k != "runs")
        raise TypeError(f"{study.name}: unknown setting(s) {unknown}; known: {known}")
    s = {**study.defaults, **settings}
    s["runs"] = check_runs(study.defaults["runs"] if runs is None else runs)
    s["seed"] = seed
    cases = study.make_cases(s)
    t0 = time.perf_counter()
    records = run_tasks(
        study.task,
        cases,
        s["runs"],
        study=study.name,
        seed=seed,
        jobs=jobs,
        scheduler=scheduler,
        out=out,
        progress=progress,
        resume=resume,
    )
    elapsed = time.perf_counter() - t0
    result = StudyResult(
        name=study.name,
        settings=s,
        records=records,
        summary=study.summarize(records, s),
        study=study,
        elapsed=elapsed,
    )
    if out is not None:
        result.write(out)
    return result


def _runner(key: str) -> Any:
    study = STUDIES[key]

    def run(
        *,
        runs: int | None = None,
        seed: int = 0,
        jobs: int = 1,
        scheduler: Any | None = None,
        out: str | Path | None = None,
        progress: bool = True,
        resume: bool = True,
        **settings: Any,
    ) -> StudyResult:
        return run_study(
            key,
            runs=runs,
            seed=seed,
            jobs=jobs,
            scheduler=scheduler,
            out=out,
            progress=progress,
            resume=resume,
            **settings,
        )

    run.__name__ = run.__qualname__ = key
    run.__doc__ = (
        f"Study {study.name!r}: {study.title} ({study.source}).\n\n"
        f"Same keywords as :func:`run_study`; settings and defaults: {study.defaults}.\n\n"
        + (study.notes or "")
    )
    return run


snr = _runner("snr")
samples = _runner("samples")
basis_order = _runner("basis_order")
operator = _runner("operator")
table1 = _runner("table1")
quadrotor = _runner("quadrotor")
