"""``hdpbsid demo`` and ``hdpbsid study``: the simulation studies from the command line.

``demo`` runs one task of the quadrotor study (:mod:`hdpbsid.studies.quadrotor`, the thesis,
§6): it simulates the closed-loop pitch benchmark, identifies it with the best available
method (``hermite`` if it is available, else ``dt``), prints identified vs true
eigenvalues and the fit of every order, and writes the model of the main order
(:class:`DemoSettings`) with its figures.  ``study NAME`` runs a whole study
(:func:`hdpbsid.studies.run_study`) and prints its table.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from hdpbsid.commands.common import (
    EXIT,
    CLIError,
    best_method,
    check_method,
    check_out,
    fmt_complex,
    parse_options,
    split_columns,
)

if TYPE_CHECKING:  # annotations only: the library's modules load when a command runs
    from hdpbsid.models.model import StateSpaceModel

__all__ = ["DemoSettings", "DEMO", "run_demo", "run_study"]


@dataclass(frozen=True)
class DemoSettings:
    """What the ``demo`` command prints and keeps.

    Attributes
    ----------
    main_order : int
        The order whose model is written and drawn when it was identified (else the
        smallest order identified).
    shown_singular_values : int
        Singular values printed.
    """

    #: the quadrotor pitch loop has three states (pitch rate, pitch, actuator)
    main_order: int = 3
    #: enough to see the gap after an order of a few states on one line
    shown_singular_values: int = 8


#: the settings of ``hdpbsid demo``
DEMO = DemoSettings()


@dataclass(frozen=True)
class _DemoRequest:
    """The checked arguments of ``hdpbsid demo``."""

    method: str
    snr: float | None
    outputs: tuple[str, ...]
    orders: tuple[int, ...]
    outdir: Path


def _demo_request(args: argparse.Namespace) -> _DemoRequest:
    """Check the arguments of ``demo`` before anything is simulated."""
    from hdpbsid import studies

    method = best_method() if args.method == "auto" else args.method
    check_method(method)
    if method not in studies.methods.METHODS:
        raise CLIError(f"demo: method must be one of {list(studies.methods.METHODS)}")
    snr = None if str(args.snr).lower() in ("none", "inf") else float(args.snr)
    outputs = tuple(split_columns(args.outputs))
    orders = tuple(int(o) for o in split_columns([args.orders]))
    outdir = check_out(args.out, ["model.json"])
    return _DemoRequest(method, snr, outputs, orders, outdir)


def _print_header(args: argparse.Namespace, req: _DemoRequest, data: Any, out: TextIO) -> None:
    """The experiment simulated and the call that identifies it."""
    exc = args.excitation + (f" (n_max,u = {args.n_max_u})" if "hermite" in args.excitation else "")
    snr = "none" if req.snr is None else f"{req.snr:g} dB"
    print(
        "quadrotor pitch closed loop (the thesis's §6 experiment, simulated): "
        f"{data.t.size} samples "
        f"at 250 Hz, {args.duration:g} s, excitation {exc}, SNR "
        f"{snr}, seed {args.seed}, "
        f"saturated {100 * data.saturation_fraction:.1f} % of samples",
        file=out,
    )
    print(
        f"identify(t, moment, {list(data.outputs)}, order={list(req.orders)}, "
        f"method={req.method!r})",
        file=out,
    )


def _print_order(o: Any, mrec: dict[str, Any], model: Any, data: Any, out: TextIO) -> None:
    """One order's eigenvalues against the true ones and its fits."""
    import numpy as np

    from hdpbsid.models.metrics import match_eigenvalues

    est, tru = match_eigenvalues(model.eigenvalues, data.true_eigenvalues)
    errs = np.abs(est - tru) / np.abs(tru)
    print(
        f"order {o}: eigenvalues  identified            true                  rel. error",
        file=out,
    )
    for e, tv, err in zip(est, tru, errs, strict=True):
        print(f"  {fmt_complex(e):<22}{fmt_complex(tv):<22}{100 * err:.3f} %", file=out)
    for z in mrec.get("extra") or []:
        print(f"  {fmt_complex(complex(*z)):<22}{'(no true match)':<22}", file=out)
    fit_i = ", ".join(
        f"{n} {v:.1f} %" for n, v in zip(data.outputs, mrec["fit_identification"], strict=True)
    )
    fit_v = ", ".join(
        f"{n} {v:.1f} %" for n, v in zip(data.outputs, mrec["fit_validation"], strict=True)
    )
    print(
        f"  fit, 100 (1 - NRMSE): identification record {fit_i}; new record {fit_v}",
        file=out,
    )


def _models(res: dict[str, Any], data: Any, out: TextIO) -> dict[int, StateSpaceModel]:
    """The models of the study's result by order, each printed against the truth."""
    import numpy as np

    from hdpbsid.models.model import StateSpaceModel

    sv = np.asarray(res["singular_values"], dtype=float)
    print(
        "singular values: "
        + " ".join(f"{v:.3g}" for v in sv[: DEMO.shown_singular_values])
        + (f"  -> order chosen (held-out error): {res['auto_order']}" if res["auto_order"] else ""),
        file=out,
    )
    for o, err in res["order_errors"].items():
        print(f"order {o}: identification failed: {err}", file=out)
    models: dict[int, StateSpaceModel] = {}
    for o, mrec in res["models"].items():
        mats = [np.asarray(mrec["matrices"][k], dtype=float) for k in ("A", "B", "C", "D", "K")]
        model = StateSpaceModel(*mats, singular_values=sv, options=dict(mrec["options"]))
        if res.get("order_selection"):  # what chose the order, for the figure
            model.options["order_selection"] = res["order_selection"]
        models[int(o)] = model
        _print_order(o, mrec, model, data, out)
    return models


def _main_model(
    args: argparse.Namespace, req: _DemoRequest, models: dict[int, Any], data: Any
) -> tuple[int, Any]:
    """The model written: the main order's (:attr:`DemoSettings.main_order`) if it was
    identified, else the smallest order's, with its labels and the demo's settings."""
    import numpy as np

    order = DEMO.main_order if DEMO.main_order in models else min(models)
    model = models[order]
    model.set_labels(input_names=["moment"], output_names=list(data.outputs), time_unit="s")
    model.sampling_interval = float(np.median(np.diff(data.t)))
    model.options["demo"] = {
        "seed": args.seed,
        "snr_db": req.snr,
        "duration": args.duration,
        "excitation": args.excitation,
        "order": order,
    }
    return order, model


def _write_figures(
    req: _DemoRequest, result: Any, data: Any, model: Any, order: int, out: TextIO
) -> None:
    """The identification figure against the truth and the study's figures."""
    import numpy as np

    from hdpbsid.models.model import StateSpaceModel
    from hdpbsid.plots import plot_identification, save_figure
    from hdpbsid.studies.figures import quadrotor_figures

    truth = StateSpaceModel(data.A, data.B, data.C, data.D, np.zeros((3, data.C.shape[0])))
    fig = plot_identification(
        model,
        data.t,
        data.u,
        data.y,
        output_names=list(data.outputs),
        input_names=["moment"],
        true_model=truth,
        title=f"Quadrotor pitch, closed loop: method {req.method!r}, order {order}",
    )
    print(f"wrote {save_figure(fig, req.outdir / 'identification.png')}", file=out)
    for _name, path in sorted(quadrotor_figures(result, req.outdir).items()):
        print(f"wrote {path}", file=out)


def run_demo(args: argparse.Namespace, out: TextIO) -> int:
    """Run ``hdpbsid demo``: the quadrotor study (:mod:`hdpbsid.studies.quadrotor`, the
    thesis, §6) for one run.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    out : text stream
        Where the report is printed.

    Returns
    -------
    int
        :data:`~hdpbsid.commands.common.EXIT` ``ok``, or ``failed`` when the
        identification failed.
    """
    from hdpbsid import studies
    from hdpbsid.models.model_io import save_model
    from hdpbsid.studies.data import quadrotor_record
    from hdpbsid.studies.runner import task_rng

    req = _demo_request(args)
    result = studies.run_study(
        "quadrotor",
        runs=1,
        seed=args.seed,
        out=None,
        progress=False,
        resume=False,
        snr_db=req.snr,
        duration=args.duration,
        excitation=args.excitation,
        n_max_u=args.n_max_u,
        outputs=req.outputs,
        orders=req.orders,
        method=req.method,
    )
    rec = result.records[0]
    data = quadrotor_record(task_rng(args.seed, rec["case"], 0), **rec["case"]["data"])
    _print_header(args, req, data, out)
    if not rec["ok"]:
        print(
            f"hdpbsid demo: identification with {req.method!r} failed: {rec['error']}",
            file=sys.stderr,
        )
        return EXIT.failed
    models = _models(rec["result"], data, out)
    order, model = _main_model(args, req, models, data)
    print(f"wrote {save_model(model, req.outdir / 'model.json')} (order {order})", file=out)
    if not args.no_plot:
        _write_figures(req, result, data, model, order, out)
    return EXIT.ok


def run_study(args: argparse.Namespace, out: TextIO) -> int:
    """Run ``hdpbsid study NAME``: a simulation study (:func:`hdpbsid.studies.run_study`),
    its table printed and its files written to ``--out``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    out : text stream
        Where the table is printed.

    Returns
    -------
    int
        :data:`~hdpbsid.commands.common.EXIT` ``ok``.

    Raises
    ------
    CLIError
        On unknown ``--set`` keys or wrongly typed values.
    """
    from hdpbsid import studies

    settings = parse_options(args.set)
    outdir = check_out(args.out or Path("hdpbsid-study") / args.name, [])
    try:
        result = studies.run_study(
            args.name,
            runs=args.runs,
            seed=args.seed,
            jobs=args.jobs,
            scheduler=args.scheduler,
            out=outdir,
            progress=not args.no_progress,
            resume=not args.no_resume,
            **settings,
        )
    except TypeError as exc:  # unknown --set keys or wrongly typed values
        raise CLIError(str(exc)) from exc
    print(result.table(), file=out)
    n_fail = sum(not r["ok"] for r in result.records)
    print(
        f"{len(result.records)} tasks ({n_fail} failed identifications recorded), "
        f"runs {result.settings['runs']}, seed {args.seed}, "
        f"{result.elapsed:.1f} s",
        file=out,
    )
    print(f"wrote {outdir}/: results.jsonl summary.csv summary.json records.csv", file=out)
    for name in sorted(result.figures):
        print(f"wrote {result.figures[name]}", file=out)
    return EXIT.ok
