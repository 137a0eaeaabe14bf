"""``hdpbsid identify`` and ``hdpbsid validate``: a model from data files, and a saved
model judged on other records.

``identify`` checks every argument before it reads a file (:mod:`hdpbsid.commands.common`),
identifies one model from all the records (:func:`hdpbsid.identify`), records the column
names and the sampling interval in ``model.options`` (``validate`` reads them back) and
writes ``model.json`` and ``identification.png``.  ``validate`` prints the simulation fit,
the optional ``--k``-step prediction fit and the residual tests
(:mod:`hdpbsid.models.assessment`) of each record and writes its figure.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from hdpbsid.commands.common import (
    EXIT,
    CLIError,
    check_method,
    check_out,
    parse_options,
    print_fit,
    print_model,
    read_records,
    split_columns,
    time_unit,
)

if TYPE_CHECKING:  # annotations only: the library's modules load when a command runs
    from hdpbsid.data.io import Record
    from hdpbsid.models.model import StateSpaceModel

__all__ = ["run_identify", "run_validate", "progress"]


def progress(choice: str, records: list[Record]) -> bool:
    """Whether to show progress bars (stderr) for ``--progress choice``.

    ``on``, ``off``, or ``auto``: only where the work is long, i.e. a record longer than
    :data:`hdpbsid.selection.long_records.LONG_SAMPLES` (a shorter record is identified in
    seconds, and bars would only add lines to the output).

    Parameters
    ----------
    choice : {"auto", "on", "off"}
        The ``--progress`` argument.
    records : list of Record
        The records to identify.

    Returns
    -------
    bool
        Whether bars are shown.
    """
    from hdpbsid.selection.long_records import LONG_SAMPLES

    long = max(r.t.size for r in records) > LONG_SAMPLES
    return choice == "on" or (choice == "auto" and long)


@dataclass(frozen=True)
class _IdentifyRequest:
    """The checked arguments of ``hdpbsid identify``, before any file is read."""

    files: list[str]
    inputs: list[str]
    outputs: list[str]
    options: dict[str, Any]
    unit: str
    outdir: Path


def _identify_request(args: argparse.Namespace) -> _IdentifyRequest:
    """Check the arguments of ``identify`` in the order a user fixes them: columns, files,
    method, options, unit, channel names, ``--out``."""
    from hdpbsid.data.checks import check_names

    inputs = split_columns(args.inputs)
    outputs = split_columns(args.outputs)
    if not outputs:
        raise CLIError("--outputs needs at least one column name")
    files = ([args.file] if args.file else []) + list(args.data or [])
    if not files:
        raise CLIError("identify: give a data file (FILE or --data FILE, repeatable)")
    check_method(args.method)
    options = parse_options(args.option)
    unit = time_unit(args.time_unit or "s")
    try:  # column names become the channel names: printable, short
        check_names(inputs, "--inputs", len(inputs), "u")
        check_names(outputs, "--outputs", len(outputs), "y")
    except (TypeError, ValueError) as exc:
        raise CLIError(f"{exc}; rename the column") from exc
    outdir = check_out(args.out, ["model.json"] + ([] if args.no_plot else ["identification.png"]))
    return _IdentifyRequest(files, inputs, outputs, options, unit, outdir)


def _none(choice: str) -> str | None:
    """``"none"`` on the command line is ``None`` in the library."""
    return None if choice == "none" else choice


def _identify_records(
    args: argparse.Namespace, req: _IdentifyRequest, records: list[Record]
) -> StateSpaceModel | None:
    """The model of all ``records`` (one record: the arrays; several: the list form of
    :func:`hdpbsid.identify`), or ``None`` when the identification failed (said on stderr)."""
    from hdpbsid.identify import identify

    options = dict(req.options)
    options.setdefault("progress", progress(args.progress, records))
    if args.focus != "auto":
        options.setdefault("focus", args.focus)
    data = records[0].as_tuple() if len(records) == 1 else ([r.as_tuple() for r in records],)
    try:
        return identify(
            *data,
            order=args.order,
            method=args.method,
            refine=_none(args.refine),
            detrend=_none(args.detrend),
            input_names=req.inputs,
            output_names=req.outputs,
            time_unit=req.unit,
            **options,
        )
    except (ValueError, TypeError) as exc:
        print(f"hdpbsid identify: identification failed: {exc}", file=sys.stderr)
        return None


def _input_of(rec: Record) -> Any:
    """The record's inputs, an empty (Ns, 0) array for a time series."""
    import numpy as np

    return np.zeros((rec.t.size, 0)) if rec.u is None else rec.u


def _print_identification(
    args: argparse.Namespace, req: _IdentifyRequest, records: list[Record], model: Any, out: TextIO
) -> None:
    """The records read, the settings, the model and its fit on each record."""
    for rec in records:
        print(
            f"data: {rec.source}  samples: {rec.t.size}  "
            + (f"time column: {rec.time}" if rec.time else f"dt: {rec.dt:g}"),
            file=out,
        )
    print(
        f"method: {args.method}  inputs: {req.inputs}  outputs: {req.outputs}  "
        f"detrend: {_none(args.detrend)}",
        file=out,
    )
    print_model(model, out)
    for rec in records:
        if len(records) > 1:
            print(f"{rec.source}:", file=out)
        print_fit(model, rec.t, _input_of(rec), rec.y, req.outputs, out)


def run_identify(args: argparse.Namespace, out: TextIO) -> int:
    """Run ``hdpbsid identify``: read, identify, print, write ``model.json`` and the figure.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    out : text stream
        Where the report is printed.

    Returns
    -------
    int
        :data:`~hdpbsid.commands.common.EXIT` ``ok``, or ``failed`` when the identification
        failed.
    """
    from hdpbsid.models.model_io import RecordColumns, save_model

    req = _identify_request(args)
    columns = {"time": args.time, "inputs": req.inputs, "outputs": req.outputs}
    records = read_records(args, req.files, columns)
    model = _identify_records(args, req, records)
    if model is None:
        return EXIT.failed
    first = records[0]
    source = req.files[0] if len(req.files) == 1 else req.files
    columns = RecordColumns(first.time, req.inputs, req.outputs, first.dt, source)
    model.options.update(columns.to_options())
    _print_identification(args, req, records, model, out)
    print(f"wrote {save_model(model, req.outdir / 'model.json')}", file=out)
    if not args.no_plot:
        from hdpbsid.plots import plot_identification, save_figure

        fig = plot_identification(
            model,
            first.t,
            _input_of(first),
            first.y,
            output_names=req.outputs,
            input_names=req.inputs,
        )
        print(f"wrote {save_figure(fig, req.outdir / 'identification.png')}", file=out)
    return EXIT.ok


# -- validate -----------------------------------------------------------------------------
def _saved_columns(model: StateSpaceModel, path: str) -> dict[str, Any]:
    """The column names a model was identified from (:class:`RecordColumns`, written by
    ``hdpbsid identify``), else the model's channel names (a model saved from Python);
    ``dt``: the sampling interval it was identified with, when known."""
    from hdpbsid.models.model_io import RecordColumns

    try:
        saved = RecordColumns.from_options(model.options)
    except ValueError as exc:
        raise CLIError(f"{path}: {exc}") from None
    if saved is None:
        return {"time": None, "inputs": model.input_names, "outputs": model.output_names}
    return {
        "time": saved.time,
        "inputs": saved.inputs,
        "outputs": saved.outputs,
        "dt": saved.sampling_interval,
    }


def _validate_channels(
    args: argparse.Namespace, model: StateSpaceModel, saved: dict[str, Any]
) -> tuple[list[str], list[str]]:
    """The input and output columns: given, else as identified; as many as the model has."""
    inputs = split_columns(args.inputs) if args.inputs else saved["inputs"]
    outputs = split_columns(args.outputs) if args.outputs else saved["outputs"]
    if not outputs:
        raise CLIError("validate: the model file names no output columns; give --outputs")
    if len(inputs) != model.m or len(outputs) != model.l:
        raise CLIError(
            f"validate: the model has {model.m} input(s) and {model.l} output(s), the "
            f"columns are inputs {inputs} and outputs {outputs}"
        )
    return inputs, outputs


def _validate_time(
    args: argparse.Namespace, model: StateSpaceModel, saved: dict[str, Any]
) -> str | None:
    """The time column of the records; none given, a model identified with ``--dt`` sets
    ``args.dt`` to its sampling interval, else the column it was identified from (or ``t``)."""
    if args.time is not None or args.dt is not None or args.fs is not None:
        return args.time
    dt = saved.get("dt")
    if saved["time"] is None and dt is not None:
        args.dt = dt  # identified with --dt
        return None
    return saved["time"] or "t"


def _figure_name(records: int, source: str) -> str:
    """``validation.png`` for one record, ``validation-STEM.png`` for each of several."""
    return "validation.png" if records == 1 else f"validation-{Path(source).stem}.png"


def run_validate(args: argparse.Namespace, out: TextIO) -> int:
    """Run ``hdpbsid validate``: fit and residual tests of a saved model on other records
    (:mod:`hdpbsid.models.assessment`).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.
    out : text stream
        Where the report is printed.

    Returns
    -------
    int
        :data:`~hdpbsid.commands.common.EXIT` ``ok``.

    Raises
    ------
    CLIError
        On columns that do not match the model, or a ``--k`` below 1.
    """
    from hdpbsid.models.model import TimeScaleWarning
    from hdpbsid.models.model_io import load_model

    model = load_model(args.model)
    saved = _saved_columns(model, args.model)
    inputs, outputs = _validate_channels(args, model, saved)
    time = _validate_time(args, model, saved)
    if args.k is not None and args.k < 1:
        raise CLIError(f"--k must be a positive number of steps, got {args.k}")
    unit = None if args.time_unit is None else time_unit(args.time_unit)
    names = [] if args.no_plot else [_figure_name(len(args.files), f) for f in args.files]
    outdir = check_out(args.out, names)
    records = read_records(args, args.files, {"time": time, "inputs": inputs, "outputs": outputs})
    for rec in records:
        _warn_time_scale(model, rec, unit)
        figure = outdir / _figure_name(len(records), rec.source)
        with warnings.catch_warnings():  # said once above; the evaluations would repeat it
            warnings.simplefilter("ignore", TimeScaleWarning)
            _validate_record(args, model, rec, (inputs, outputs), figure, out)
    return EXIT.ok


def _warn_time_scale(model: StateSpaceModel, rec: Record, unit: str | None) -> None:
    """The record-against-model time scale check of :meth:`StateSpaceModel.check_record`,
    printed once per record (the evaluations that follow would repeat it)."""
    from hdpbsid.models.model import TimeScaleWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TimeScaleWarning)
        model.check_record(rec.t, unit, name=rec.time or "t")
    for w in caught:
        print(f"warning: {rec.source}: {w.message}", file=sys.stderr)


def _validate_record(
    args: argparse.Namespace,
    model: StateSpaceModel,
    rec: Record,
    channels: tuple[list[str], list[str]],
    figure: Path,
    out: TextIO,
) -> None:
    """Fits, residual tests and figure of ``model`` on one record (``hdpbsid validate``)."""
    inputs, outputs = channels
    uu = _input_of(rec)
    sim = model.compare(rec.t, uu, rec.y)
    print(f"{rec.source}: {rec.t.size} samples, model {args.model}", file=out)
    for name, f in zip(outputs, sim.fit, strict=True):
        print(f"  fit {name} ({sim.kind}, x0 estimated): {f:.2f} %", file=out)
    if args.k is not None:
        pred = model.compare(rec.t, uu, rec.y, k=args.k)
        for name, f in zip(outputs, pred.fit, strict=True):
            print(f"  fit {name} ({pred.kind}): {f:.2f} %", file=out)
    try:
        report = model.residuals(rec.t, uu, rec.y, max_lag=args.max_lag)
    except ValueError as exc:
        print(f"  residual tests not possible: {exc}", file=out)
        return
    print(report.summary(outputs, inputs), file=out)
    if not args.no_plot:
        from hdpbsid.plots import plot_validation, save_figure

        fig = plot_validation(
            model,
            rec.t,
            uu,
            rec.y,
            k=args.k,
            report=report,
            output_names=outputs,
            input_names=inputs,
            title=f"Validation of {Path(args.model).name} on {Path(rec.source).name}",
        )
        print(f"wrote {save_figure(fig, figure)}", file=out)
