"""Figures of the studies : Monte Carlo eigenvalue scatter per method
with the truth (the thesis, Figure 1), singular values, measured vs simulated outputs
(the thesis, Figure 2), Bode plots of the true and identified models, and the study curves
(error vs SNR / samples / basis size / operator parameters).

Matplotlib through :mod:`hdpbsid.plots` (Agg canvas, never ``pyplot``: no window, no
global backend change).  Every function takes a :class:`~hdpbsid.studies.StudyResult`
and an output directory and returns ``{name: path}`` of the PNGs written.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from hdpbsid.plots import (
    new_figure,
    plot_bode,
    plot_eigenvalue_scatter,
    plot_outputs,
    plot_singular_values,
    save_figure,
)
from hdpbsid.studies.methods import LABELS

__all__ = ["table1_figures", "curve_figure", "operator_figure", "quadrotor_figures"]


def _log_if_positive(ax: Any) -> None:
    """Log y-axis when the drawn data have positive values (one run has STD 0: matplotlib
    would warn and draw nothing on a log axis)."""
    ys = [np.asarray(line.get_ydata(), dtype=float) for line in ax.get_lines()]
    ys = [y[np.isfinite(y)] for y in ys]
    if any(np.any(y > 0) for y in ys):
        ax.set_yscale("log")


def _eigs(results: list[dict[str, Any]]) -> np.ndarray:
    z = [complex(a, b) for r in results for a, b in r.get("eigenvalues", [])]
    return np.array(z, dtype=complex)


def table1_figures(result: Any, out: str | Path) -> dict[str, Path]:
    """The figures of the ``table1`` study.

    Parameters
    ----------
    result : StudyResult
        The study's result.
    out : str or path-like
        Directory written to.

    Returns
    -------
    dict of str to pathlib.Path
        Per SNR the eigenvalue scatter of all runs per method (``table1_eig_<snr>dB.png``,
        zoomed on the truth) and the STD of the pair and of the real pole vs SNR per method
        (``table1_std.png``).
    """
    from hdpbsid.systems.quadrotor import pitch_model

    out = Path(out)
    true = np.linalg.eigvals(pitch_model()[0])
    files: dict[str, Path] = {}
    snrs = list(dict.fromkeys(r["case"]["data"]["snr_db"] for r in result.records))
    for snr in snrs:
        groups, failed = _runs_by_method(result.records, snr)
        labels = {
            m: LABELS.get(m, m) + (f" [{failed[m]} runs failed]" if failed.get(m) else "")
            for m in groups
        }
        fig = plot_eigenvalue_scatter(
            {labels[m]: _eigs(res) for m, res in groups.items()},
            true,
            zoom=1.0,
            title=f"Closed-loop quadrotor, SNR {snr:g} dB: {result.settings['runs']} runs",
        )
        name = f"table1_eig_{snr:g}dB.png"
        files[name] = save_figure(fig, out / name)
    files["table1_std.png"] = save_figure(_std_figure(result.summary), out / "table1_std.png")
    return files


def _runs_by_method(
    records: list[dict[str, Any]], snr: Any
) -> tuple[dict[str, list[Any]], dict[str, int]]:
    """The results of the successful runs at ``snr`` per method, and the failed runs'
    count per method."""
    groups: dict[str, Any] = {}
    failed: dict[str, int] = {}
    for r in records:
        if r["case"]["data"]["snr_db"] == snr:
            m = r["case"]["method"]
            groups.setdefault(m, [])
            if r["ok"]:
                groups[m].append(r["result"])
            else:
                failed[m] = failed.get(m, 0) + 1
    return groups, failed


def _std_figure(summary: list[dict[str, Any]]) -> Any:
    """The STD of the pair and of the real pole against the SNR, one curve per method."""
    fig = new_figure((10.0, 4.0))
    for k, key in enumerate(("std pair", "std real")):
        ax = fig.add_subplot(1, 2, k + 1)
        methods = list(dict.fromkeys(row["method"] for row in summary))
        for c, m in enumerate(methods):
            rows = [row for row in summary if row["method"] == m]
            x = [row["snr_db"] for row in rows]
            y = [np.nan if row[key] is None else row[key] for row in rows]
            ax.plot(x, y, "o-", color=f"C{c}", label=LABELS.get(m, m))
        _log_if_positive(ax)
        ax.set_xlabel("SNR [dB]")
        ax.set_ylabel(f"{key} [rad/s]")
        ax.set_title(f"STD of the {'pair -2.92±3.24j' if k == 0 else 'real pole +3.08'}")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize="small")
    return fig


def curve_figure(
    result: Any, out: str | Path, *, x: str, xlabel: str, name: str, logx: bool = False
) -> dict[str, Path]:
    """Median worst relative error and relative STD against a setting, one curve per method.

    Parameters
    ----------
    result : StudyResult
        The study's result.
    out : str or path-like
        Directory written to.
    x : str
        The case label on the horizontal axis (e.g. ``"snr_db"``).
    xlabel : str
        Its axis label.
    name : str
        The file's stem (``<name>.png``).
    logx : bool, optional
        Logarithmic horizontal axis.

    Returns
    -------
    dict of str to pathlib.Path
        ``{name: path}``; every run is drawn as a dot and failed runs are counted in the
        legend.
    """
    fig = new_figure((10.0, 4.2))
    ax1 = fig.add_subplot(1, 2, 1)
    ax2 = fig.add_subplot(1, 2, 2)
    methods = list(dict.fromkeys(row.get("method", "hermite") for row in result.summary))
    for c, m in enumerate(methods):
        rows = [row for row in result.summary if row.get("method", "hermite") == m]
        _method_curves(ax1, ax2, rows, x, f"C{c}", LABELS.get(m, m))
    for ax, lab in ((ax1, "worst relative eigenvalue error"), (ax2, "relative STD of -0.4+1.96j")):
        _log_if_positive(ax)
        if logx:
            ax.set_xscale("log")
        ax.set_xlabel(xlabel)
        ax.set_ylabel(lab)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize="small")
    ax1.set_title("median (line) and every run (dots)")
    ax2.set_title("spread over runs")
    fig.suptitle(result.study.title if result.study else name)
    return {f"{name}.png": save_figure(fig, Path(out) / f"{name}.png")}


def _method_curves(
    ax1: Any, ax2: Any, rows: list[dict[str, Any]], x: str, color: str, name: str
) -> None:
    """One method's curves of :func:`curve_figure`: every run's error as a dot and the
    median on ``ax1``, the relative STD on ``ax2``; the legend counts the failed runs."""
    xs = np.array([row[x] for row in rows], dtype=float)
    med = np.array([np.nan if row["median err"] is None else row["median err"] for row in rows])
    std = np.array([np.nan if row["rel std"] is None else row["rel std"] for row in rows])
    fails = sum(row["failed"] for row in rows)
    label = name + (f" ({fails} failed runs)" if fails else "")
    for row in rows:
        e = np.asarray(row["errors"], dtype=float)
        ax1.plot(np.full(e.size, float(row[x])), e, ".", color=color, alpha=0.3, ms=3)
    ax1.plot(xs, med, "o-", color=color, label=label)
    ax2.plot(xs, std, "o-", color=color, label=label)


def operator_figure(result: Any, out: str | Path) -> dict[str, Path]:
    """Median worst relative error against each differentiation-operator parameter.

    Parameters
    ----------
    result : StudyResult
        The ``operator`` study's result.
    out : str or path-like
        Directory written to.

    Returns
    -------
    dict of str to pathlib.Path
        ``{"operator": path}``; the default value is marked and failed runs are drawn as
        crosses at the top.
    """
    fig = new_figure((12.0, 4.0))
    params = list(dict.fromkeys(row["parameter"] for row in result.summary))
    defaults = {"alpha/s": 4.0, "beta": 1.0, "gamma": 1.0}
    for k, p in enumerate(params):
        ax = fig.add_subplot(1, len(params), k + 1)
        rows = [row for row in result.summary if row["parameter"] == p]
        xs = np.array([row["value"] for row in rows], dtype=float)
        med = np.array([np.nan if row["median err"] is None else row["median err"] for row in rows])
        ax.plot(xs, med, "o-", label="median worst error")
        for row in rows:
            e = np.asarray(row["errors"], dtype=float)
            ax.plot(np.full(e.size, row["value"]), e, ".", color="C0", alpha=0.3, ms=3)
            if row["failed"]:
                ax.plot([row["value"]], [1.0], "x", color="C3", ms=8)
        ax.axvline(defaults.get(p, np.nan), color="0.5", ls="--", label="default")
        ax.set_xscale("log")
        _log_if_positive(ax)
        ax.set_xlabel(p)
        ax.set_ylabel("worst relative eigenvalue error")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize="small", title="x at 1: runs that failed")
    fig.suptitle(result.study.title if result.study else "operator")
    return {"operator.png": save_figure(fig, Path(out) / "operator.png")}


def quadrotor_figures(result: Any, out: str | Path, run: int = 0) -> dict[str, Path]:
    """The figures of the ``quadrotor`` study for one run.

    Singular values, eigenvalues vs truth, measured vs simulated outputs on the validation
    record and the Bode diagrams true vs identified.  The models come from the records'
    matrices and the records are re-simulated from the seed (exactly; cached in the same
    process).

    Parameters
    ----------
    result : StudyResult
        The study's result.
    out : str or path-like
        Directory written to.
    run : int, optional
        The Monte Carlo run drawn.

    Returns
    -------
    dict of str to pathlib.Path
        Name -> PNG path.
    """
    from hdpbsid.models.model import StateSpaceModel
    from hdpbsid.studies.data import quadrotor_record, validation_rng
    from hdpbsid.studies.runner import task_rng

    out = Path(out)
    recs = [r for r in result.records if r["run"] == run and r["ok"]]
    if not recs:
        return {}
    case, res = recs[0]["case"], recs[0]["result"]
    rng = task_rng(result.settings["seed"], case, run)
    data = quadrotor_record(rng, **case["data"])
    val = quadrotor_record(validation_rng(rng), **case["data"])
    models = {
        int(o): StateSpaceModel(
            *[np.asarray(m["matrices"][k], dtype=float) for k in ("A", "B", "C", "D", "K")]
        )
        for o, m in res["models"].items()
    }
    names = list(data.outputs)
    files: dict[str, Path] = {}
    auto = res["auto_order"]
    fig = plot_singular_values(
        res["singular_values"],
        auto,
        title="Singular values" + ("" if auto is None else f" (order chosen: {auto})"),
    )
    files["singular_values.png"] = save_figure(fig, out / "singular_values.png")
    fig = _eigenvalue_figure(models, data.true_eigenvalues)
    files["eigenvalues.png"] = save_figure(fig, out / "eigenvalues.png")
    files["outputs.png"] = save_figure(_output_figure(models, val, names), out / "outputs.png")
    truth = StateSpaceModel(data.A, data.B, data.C, data.D, np.zeros((3, data.C.shape[0])))
    w = np.logspace(-1, 2.5, 400)
    fig = plot_bode(
        {f"order {o}": m for o, m in models.items()},
        w,
        true_model=truth,
        input_names=["moment"],
        output_names=names,
        title="Bode: true (dashed) and identified; the sweep excites 6.3-25 rad/s",
    )
    files["bode.png"] = save_figure(fig, out / "bode.png")
    return files


def _eigenvalue_figure(models: dict[int, Any], true: np.ndarray) -> Any:
    """The identified models' eigenvalues against the true ones, one panel per order."""
    fig = new_figure((5.0 * len(models), 4.5))
    for k, (o, m) in enumerate(models.items()):
        ax = fig.add_subplot(1, len(models), k + 1)
        ax.plot(true.real, true.imag, "o", mfc="none", mec="k", ms=11, label="true")
        ax.plot(m.eigenvalues.real, m.eigenvalues.imag, "x", ms=9, mew=2, label="identified")
        ax.axvline(0.0, color="0.6", lw=0.8)
        ax.axhline(0.0, color="0.6", lw=0.8)
        ax.set_title(f"order {o}")
        ax.set_xlabel("Re")
        ax.set_ylabel("Im")
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.suptitle("Open-loop eigenvalues: identified vs true")
    return fig


def _output_figure(models: dict[int, Any], val: Any, names: list[str]) -> Any:
    """Measured against simulated outputs on the validation record ``val``, 4 s shown."""
    from hdpbsid.plots import display_fit

    sims = {}
    for o, m in models.items():
        fit = display_fit(m, val.t, val.u, val.y)
        pct = "/".join(f"{v:.1f}" for v in fit.fit)
        sims[f"order {o} (fit {pct} %)"] = fit.y_sim
    T = float(val.t[-1])
    return plot_outputs(
        val.t,
        val.y,
        sims,
        output_names=names,
        title="Validation record (new noise), 4 s shown: measured vs simulated "
        "(unstable model: segments re-initialised by least squares)",
        window=(0.4 * T, 0.4 * T + 4.0),
    )
