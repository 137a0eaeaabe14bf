"""Study objects, their results, and the shared per-run / summary helpers.

A :class:`Study` bundles: how settings become cases (``make_cases``), the task run per
``(case, rng)`` (a module-level function, so it pickles by reference for joblib and
Dask), how records are summarised into table rows, and optional figures.
:func:`run_study` (in :mod:`hdpbsid.studies`) drives it through
:func:`~hdpbsid.studies.runner.run_tasks`.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hdpbsid.models.metrics import match_eigenvalues
from hdpbsid.studies.runner import TaskFunc, _plain

__all__ = [
    "StudySettings",
    "STUDY",
    "Study",
    "StudyResult",
    "model_record",
    "eigen_stats",
    "ok_results",
    "format_table",
    "DIVERGENCE",
]


@dataclass(frozen=True)
class StudySettings:
    """When a study counts a run as divergent.

    Attributes
    ----------
    divergence : float
        Relative eigenvalue error beyond which a run is divergent.
    """

    #: a run is *divergent* when an identified eigenvalue runs away: its error exceeds ten
    #: times the true eigenvalue's magnitude (the thesis, §5: CT-PBSID "divergent behavior";
    #: a biased but bounded estimate, e.g. a real pole pulled to the wrong side of the
    #: axis, is not counted here but shows in the bias and the median error)
    divergence: float = 10.0


#: The settings in force.
STUDY = StudySettings()
#: :attr:`StudySettings.divergence` of :data:`STUDY`
DIVERGENCE = STUDY.divergence


@dataclass(frozen=True)
class Study:
    """A Monte Carlo study: how settings become cases, the task per case, the summary.

    Parameters
    ----------
    name : str
        The study's name (``basis_order`` is ``basis-order`` on the command line).
    title : str
        One line describing it.
    source : str
        The section of the thesis it reproduces.
    task : callable
        ``task(case, rng) -> dict``, a module-level function (it pickles by reference for
        joblib and Dask).
    make_cases : callable
        ``make_cases(settings) -> list[dict]``.
    summarize : callable
        ``summarize(records, settings) -> list[dict]``, the table rows.
    defaults : dict
        Every setting with its default, ``runs`` included.
    columns : tuple of str or None, optional
        Table columns (``None``: every key of the first row).
    figures : callable or None, optional
        ``figures(result, out) -> {name: path}``.
    notes : str, optional
        What the reader should know about the study (written to ``summary.json``).
    """

    name: str
    title: str
    source: str
    task: TaskFunc
    make_cases: Callable[[dict[str, Any]], list[dict[str, Any]]]
    summarize: Callable[[list[dict[str, Any]], dict[str, Any]], list[dict[str, Any]]]
    defaults: dict[str, Any]
    columns: tuple[str, ...] | None = None
    figures: Callable[[StudyResult, Path], dict[str, Path]] | None = None
    notes: str = ""


@dataclass
class StudyResult:
    """What :func:`~hdpbsid.studies.run_study` returns.

    Parameters
    ----------
    name : str
        The study's name.
    settings : dict
        Every setting used, ``runs`` and ``seed`` included.
    records : list of dict
        One plain dict per task (:func:`~hdpbsid.studies.runner.execute_task`).
    summary : list of dict
        The table rows.
    study : Study or None, optional
        The study (``None`` for results loaded without it).
    figures : dict of str to pathlib.Path, optional
        Name -> PNG path, filled by :meth:`write`.
    elapsed : float or None, optional
        Wall seconds of the run (``None`` when loaded).
    """

    name: str
    settings: dict[str, Any]
    records: list[dict[str, Any]]
    summary: list[dict[str, Any]]
    study: Study | None = None
    figures: dict[str, Path] = field(default_factory=dict)
    elapsed: float | None = None

    def table(self, columns: Sequence[str] | None = None) -> str:
        """The summary as an aligned text table (numbers to 4 significant digits).

        Parameters
        ----------
        columns : sequence of str, optional
            Columns shown (default the study's).

        Returns
        -------
        str
            The table with the study's title.
        """
        cols = columns or (self.study.columns if self.study else None)
        title = f"{self.study.title} ({self.study.source})" if self.study else self.name
        return format_table(self.summary, cols, title=title)

    def __repr__(self) -> str:
        failed = sum(not r.get("ok", True) for r in self.records)
        took = "" if self.elapsed is None else f", {self.elapsed:.1f} s"
        return (
            f"StudyResult({self.name!r}, {len(self.records)} tasks ({failed} failed), "
            f"{len(self.summary)} summary rows{took}; .table() prints them)"
        )

    def write(self, out: str | Path, figures: bool = True) -> dict[str, Path]:
        """Write the result's files into a directory.

        Parameters
        ----------
        out : str or path-like
            The directory (created if missing).
        figures : bool, optional
            Also draw the study's PNG figures.

        Returns
        -------
        dict of str to pathlib.Path
            Name -> path of everything written: ``summary.csv``, ``summary.json`` (settings,
            summary and notes), ``records.csv`` (one flattened row per task) and the figures.
        """
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        written: dict[str, Path] = {}
        written["summary.csv"] = _write_csv(out / "summary.csv", self.summary)
        meta = {
            "study": self.name,
            "title": self.study.title if self.study else self.name,
            "source": self.study.source if self.study else "",
            "notes": self.study.notes if self.study else "",
            "settings": _plain(self.settings),
            "elapsed_s": self.elapsed,
            "n_tasks": len(self.records),
            "n_failed": sum(not r["ok"] for r in self.records),
            "summary": _plain(self.summary),
        }
        path = out / "summary.json"
        path.write_text(json.dumps(meta, indent=2) + "\n")
        written["summary.json"] = path
        written["records.csv"] = _write_csv(out / "records.csv", [_flat(r) for r in self.records])
        if figures and self.study is not None and self.study.figures is not None:
            self.figures = dict(self.study.figures(self, out))
            written.update(self.figures)
        return written


def _flat(rec: dict[str, Any]) -> dict[str, Any]:
    """One CSV row per record: case settings, run, ok, time, error and scalar results."""
    row: dict[str, Any] = {"run": rec["run"], "seed": rec["seed"]}
    for k, v in _items(rec["case"]):
        row[k] = v
    row["ok"] = rec["ok"]
    row["time_s"] = rec.get("time")
    if rec["ok"]:
        for k, v in rec["result"].items():
            if isinstance(v, bool | int | float | str) or v is None:
                row[k] = v
            elif k in ("eigenvalues", "matched"):
                row[k] = json.dumps(v)
    else:
        row["error"] = f"{rec['error_type']}: {rec['error']}"
    return row


def _items(d: dict[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    out = []
    for k, v in d.items():
        if isinstance(v, dict):
            out += _items(v, f"{prefix}{k}.")
        else:
            out.append((f"{prefix}{k}", json.dumps(v) if isinstance(v, list) else v))
    return out


def _write_csv(path: Path, rows: list[dict[str, Any]]) -> Path:
    keys: list[str] = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: _cell(v) for k, v in r.items()})
    return path


def _cell(v: Any) -> Any:
    if isinstance(v, list | tuple | dict):
        return json.dumps(_plain(v))
    return v


def _fmt(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int | np.integer):
        return str(int(v))
    if isinstance(v, float | np.floating):
        if not math.isfinite(v):
            return "-"
        return f"{v:.4g}"
    return str(v)


def format_table(
    rows: list[dict[str, Any]], columns: Sequence[str] | None = None, title: str = ""
) -> str:
    """Aligned plain-text table of a list of dicts.

    Parameters
    ----------
    rows : list of dict
        The rows.
    columns : sequence of str, optional
        The columns (default the keys of the first row).
    title : str, optional
        A line above the table.

    Returns
    -------
    str
        Right-aligned columns; floats to 4 significant digits, ``-`` for missing or
        non-finite values, ``yes``/``no`` for booleans.

    Examples
    --------
    >>> print(format_table([{"snr": 20, "err": 0.012345}, {"snr": 6, "err": float("nan")}]))
    snr      err
    ---  -------
     20  0.01235
      6        -
    """
    if not rows:
        return (title + "\n" if title else "") + "(no rows)"
    cols = list(columns) if columns else list(rows[0])
    cells = [[_fmt(r.get(c)) for c in cols] for r in rows]
    widths = [max(len(c), *(len(row[i]) for row in cells)) for i, c in enumerate(cols)]
    lines = [title] if title else []
    lines.append("  ".join(c.rjust(w) for c, w in zip(cols, widths, strict=True)))
    lines.append("  ".join("-" * w for w in widths))
    for row in cells:
        lines.append("  ".join(v.rjust(w) for v, w in zip(row, widths, strict=True)))
    return "\n".join(lines)


# -- per-run records and statistics --------------------------------------------------------
def _pairs(z: Any) -> list[list[float]]:
    return [[float(c.real), float(c.imag)] for c in np.asarray(z, dtype=complex).ravel()]


def _options_summary(options: dict[str, Any]) -> dict[str, Any]:
    """Scalar options of a model (what defaults were used), for the record."""
    keep = {}
    for k, v in options.items():
        if isinstance(v, bool | int | float | str) and k != "lag":
            keep[k] = v
        elif isinstance(v, np.generic):
            keep[k] = v.item()
    return keep


def model_record(model: Any, true_eigenvalues: Any, n_sv: int = 12) -> dict[str, Any]:
    r"""Plain data of an identified model against the truth.

    Parameters
    ----------
    model : StateSpaceModel
        The identified model.
    true_eigenvalues : array_like of complex
        The true eigenvalues.
    n_sv : int, optional
        Number of singular values kept.

    Returns
    -------
    dict
        ``order``; ``eigenvalues`` (``[re, im]`` pairs sorted by real then imaginary part);
        when the order reaches the truth's, ``matched`` (the estimate paired with each true
        eigenvalue by :func:`~hdpbsid.models.metrics.match_eigenvalues`, in the order of the
        truth), ``errors`` (:math:`|\hat\lambda - \lambda| / |\lambda|` per true
        eigenvalue), ``max_error`` and ``divergent`` (``max_error > DIVERGENCE``); the first
        ``n_sv`` singular values and the scalar options the method used.
    """
    ev = np.asarray(model.eigenvalues, dtype=complex)
    ev = ev[np.lexsort((ev.imag, ev.real))]
    true = np.asarray(true_eigenvalues, dtype=complex)
    rec: dict[str, Any] = {"order": int(ev.size), "eigenvalues": _pairs(ev)}
    if ev.size >= true.size:
        est, tru = match_eigenvalues(ev, true)
        err = np.abs(est - tru) / np.abs(tru)
        rec["matched"] = _pairs(est)
        rec["errors"] = [float(e) for e in err]
        rec["max_error"] = float(np.max(err))
        rec["divergent"] = bool(not np.isfinite(rec["max_error"]) or rec["max_error"] > DIVERGENCE)
    sv = model.singular_values
    rec["singular_values"] = [] if sv is None else [float(s) for s in np.ravel(sv)[:n_sv]]
    rec["options"] = _options_summary(model.options)
    return rec


def ok_results(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The ``result`` dicts of the successful records.

    Parameters
    ----------
    records : list of dict
        Task records (:func:`~hdpbsid.studies.runner.execute_task`).

    Returns
    -------
    list of dict
        ``record["result"]`` of each record with ``ok``.
    """
    return [r["result"] for r in records if r["ok"]]


def eigen_stats(results: list[dict[str, Any]], true: Any) -> dict[str, Any]:
    r"""Bias and STD of matched eigenvalues over runs (the thesis's Table 1 quantities).

    Parameters
    ----------
    results : list of dict
        Per-run results of :func:`model_record` (those without ``matched`` are skipped).
    true : array_like of complex
        The true eigenvalues.

    Returns
    -------
    dict
        ``n`` (runs with a model), ``median_error`` (median over runs of the worst relative
        error), ``divergent`` (runs with worst relative error above :data:`DIVERGENCE`),
        and per true eigenvalue (only ``Im >= 0`` of a conjugate pair) ``bias``, ``std``
        (absolute, in rad/s) and ``rel_bias``, ``rel_std`` (divided by
        :math:`|\lambda_j|`).

    Notes
    -----
    Over the runs, :math:`\mathrm{bias}_j = |\overline{\hat\lambda_j} - \lambda_j|` and
    :math:`\mathrm{std}_j = \sqrt{\overline{|\hat\lambda_j -
    \overline{\hat\lambda_j}|^2}}`.
    """
    true = np.asarray(true, dtype=complex).ravel()
    res = [r for r in results if "matched" in r]
    out: dict[str, Any] = {"n": len(res)}
    keep = [j for j, z in enumerate(true) if z.imag >= -1e-12]
    if res:
        M = np.array([[complex(a, b) for a, b in r["matched"]] for r in res])
        mean = M.mean(axis=0)
        bias = np.abs(mean - true)
        std = np.sqrt(np.mean(np.abs(M - mean) ** 2, axis=0))
        worst = np.array([r["max_error"] for r in res])
        out["median_error"] = float(np.median(worst))
        out["divergent"] = int(np.sum(~np.isfinite(worst) | (worst > DIVERGENCE)))
    else:
        bias = std = np.full(true.size, np.nan)
        out["median_error"] = float("nan")
        out["divergent"] = 0
    for j in keep:
        tag = _eig_tag(true[j])
        out[f"bias {tag}"] = float(bias[j])
        out[f"std {tag}"] = float(std[j])
        out[f"rel_bias {tag}"] = float(bias[j] / abs(true[j]))
        out[f"rel_std {tag}"] = float(std[j] / abs(true[j]))
    return out


def _eig_tag(z: complex) -> str:
    if abs(z.imag) < 1e-12:
        return f"{z.real:.3g}"
    return f"{z.real:.3g}±{abs(z.imag):.3g}j"
