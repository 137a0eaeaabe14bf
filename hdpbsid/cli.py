"""Command line: ``hdpbsid identify FILE ...``, ``validate``, ``demo`` and ``study NAME``.

The command-line front end (docs/user-guide.md, "Command line").  :func:`main` takes
an argument list and *returns* an exit code (0 success, 1 identification failed,
2 usage / input error, 130 interrupted); it never calls ``sys.exit`` (a library that
exits takes the caller's process with it).  Only this module prints.  ``--out`` is
checked before any data are read; a closed standard output (``| head``) ends the
printing quietly and the files are still written.

``identify`` reads a data file (CSV, MATLAB, NumPy, Parquet, HDF5: :mod:`hdpbsid.data.io`),
picks the time (or takes ``--dt`` / ``--fs``), input and output columns by name, removes
the operating point (``--detrend``, stored in the model), identifies a continuous-time
model, prints it with its eigenvalues and writes ``model.json``
(:func:`hdpbsid.models.model_io.save_model`: everything needed to rebuild the model, with the
column names as channel names and ``--time-unit``) and ``identification.png`` (singular values,
measured vs simulated output, Bode magnitude; :mod:`hdpbsid.plots`) to ``--out``.
``--data FILE`` (repeatable) adds experiments: the list form of :func:`hdpbsid.identify`.
Every bad file (missing column, text or missing values, unsorted times, empty) exits
with code 2 and a message naming the file and the column; no model is written.

``validate MODEL.json FILE ...`` prints the simulation fit per output (and the
``--k``-step prediction fit), the residual whiteness and input-independence verdicts
(:mod:`hdpbsid.models.assessment`) and writes ``validation.png``; a record whose time unit
(``--time-unit``) or sampling interval does not match the model's draws one warning.

``demo`` simulates the closed-loop quadrotor pitch benchmark
(:func:`hdpbsid.systems.quadrotor.simulate_pitch_closed_loop`), identifies it with the best
available method (``hermite`` if it is available, else ``dt``), prints identified vs
true eigenvalues and the fit, and writes the same files plus ``eigenvalues.png``.

``study NAME`` runs one of the simulation studies of :mod:`hdpbsid.studies` (``snr``,
``samples``, ``basis-order``, ``operator``, ``table1``, ``quadrotor``; the thesis, §5-6) with
a progress bar, serially, on local processes (``--jobs``) or on a Dask cluster
(``--scheduler``), prints its table and writes ``results.jsonl`` (per task, resumable),
``summary.csv``, ``summary.json``, ``records.csv`` and PNG figures to ``--out``.

The command's process keeps an idle OpenBLAS thread spinning for at most
``2^BLAS_SPIN_LOG2_CYCLES`` cycles (:func:`_short_blas_spin`), unless the user set
``OPENBLAS_THREAD_TIMEOUT``.
"""

from __future__ import annotations

import argparse
import ast
import os
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

#: log2 of the cycles an idle OpenBLAS thread of the command's process spins before it
#: sleeps (``OPENBLAS_THREAD_TIMEOUT``; OpenBLAS's own default is 28, about 0.1 s).
#: 2^20 cycles (about 0.4 ms at 2.5 GHz) outlasts by far the wake-up of a sleeping thread
#: (tens of microseconds), so the dispatches inside one threaded factorisation still find
#: their threads awake, while the spin after OpenBLAS starts its threads (at ``import
#: numpy``) and after each threaded call costs a fraction of a millisecond per thread
#: instead of a tenth of a second: the library's calls run their small-matrix work on one
#: thread (:mod:`hdpbsid.runtime`), so nothing else waits for a spinning thread.
BLAS_SPIN_LOG2_CYCLES = 20


def _short_blas_spin() -> None:
    """Set ``OPENBLAS_THREAD_TIMEOUT`` (:data:`BLAS_SPIN_LOG2_CYCLES`) for this process
    when the user has not set it and numpy is not imported yet (OpenBLAS reads it once,
    when it loads): the command's own process, whose BLAS the user did not start."""
    if "numpy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_THREAD_TIMEOUT", str(BLAS_SPIN_LOG2_CYCLES))


_short_blas_spin()

from hdpbsid import frequency_cli  # noqa: E402 (after _short_blas_spin)

# numpy (and with it OpenBLAS, which starts its threads when it loads) is imported by the
# commands that compute, not at module level: ``--help`` and a usage error need neither
if TYPE_CHECKING:  # the library's modules load when a command runs, not for --help
    import numpy as np

    from hdpbsid.data.io import Record
    from hdpbsid.models.model import StateSpaceModel
    from hdpbsid.models.model_io import model_from_dict, model_to_dict  # noqa: F401 (re-exported)

__all__ = [
    "main",
    "build_parser",
    "best_method",
    "read_csv_columns",
    "model_to_dict",
    "model_from_dict",
    "write_model_json",
    "read_model_json",
    "CLIError",
]


def __getattr__(name: str) -> Any:
    """``model_to_dict`` and ``model_from_dict`` (:mod:`hdpbsid.models.model_io`), kept here for
    callers of the earlier CLI helpers, imported on access."""
    if name in ("model_to_dict", "model_from_dict"):
        from hdpbsid.models import model_io

        return getattr(model_io, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_INTERRUPTED = 130


class CLIError(Exception):
    """A usage or input problem: reported on stderr, exit code 2."""


class _Parser(argparse.ArgumentParser):
    """argparse without ``sys.exit``: errors raise :class:`CLIError`."""

    def error(self, message: str) -> Any:  # type: ignore[override]
        raise CLIError(f"{self.prog}: {message}")

    def exit(self, status: int = 0, message: str | None = None) -> Any:  # type: ignore[override]
        if message:
            sys.stderr.write(message)
        raise _HelpExit(status)


class _HelpExit(Exception):
    def __init__(self, status: int) -> None:
        super().__init__(status)
        self.status = status


# -- JSON (hdpbsid.models.model_io; the names below are kept for earlier callers) ------------------
def write_model_json(model: StateSpaceModel, path: str | Path) -> Path:
    """:func:`hdpbsid.models.model_io.save_model`, kept for callers of the earlier CLI helper.

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    path : str or Path
        The JSON file to write.

    Returns
    -------
    Path
        The path written.
    """
    from hdpbsid.models.model_io import save_model

    return save_model(model, path)


def read_model_json(path: str | Path) -> StateSpaceModel:
    """:func:`hdpbsid.load_model`, kept for callers of the earlier CLI helper.

    Parameters
    ----------
    path : str or Path
        A model JSON file (:func:`write_model_json`).

    Returns
    -------
    StateSpaceModel
        The model.
    """
    from hdpbsid.models.model_io import load_model

    return load_model(path)


# -- data files -----------------------------------------------------------------------------
def _split_columns(values: list[str] | None) -> list[str]:
    out: list[str] = []
    for v in values or []:
        out.extend(c.strip() for c in v.split(",") if c.strip())
    return out


def read_csv_columns(
    path: str | Path, columns: list[str], delimiter: str | None = None
) -> dict[str, np.ndarray]:
    r"""The named columns of a data file, kept for callers of the earlier CSV-only reader.

    :func:`hdpbsid.data.io.read_columns` reads CSV, MATLAB, NumPy, Parquet and HDF5 files;
    a missing column or a bad value raises an error naming the file and the column.

    Parameters
    ----------
    path : str or Path
        The data file.
    columns : list of str
        The column names.
    delimiter : str, optional
        CSV delimiter (default: sniffed).

    Returns
    -------
    dict of str to ndarray
        One array per column.

    Examples
    --------
    >>> import os, tempfile
    >>> path = os.path.join(tempfile.mkdtemp(), "data.csv")
    >>> with open(path, "w") as fh:
    ...     _ = fh.write("t,u,y\n0,1,2\n1,1,2\n2,1,2\n")
    >>> read_csv_columns(path, ["t", "y"])
    {'t': array([0., 1., 2.]), 'y': array([2., 2., 2.])}
    """
    from hdpbsid.data.io import read_columns

    return read_columns(path, columns, delimiter)


def _read_records(
    args: argparse.Namespace, files: list[str], columns: dict[str, Any]
) -> list[Record]:
    """Every file of ``files`` as a :class:`~hdpbsid.data.io.Record` with the chosen columns."""
    from hdpbsid.data.io import read_record

    time = columns["time"]
    if args.dt is None and args.fs is None and time is None:
        time = "t"
    return [
        read_record(
            f,
            columns["inputs"],
            columns["outputs"],
            time=time,
            dt=args.dt,
            fs=args.fs,
            delimiter=args.delimiter,
        )
        for f in files
    ]


# -- checks made before any work ---------------------------------------------------------------
def _check_out(out: str | Path, names: list[str]) -> Path:
    """The output directory ``out``: an existing directory, or a path that can be created
    as one, in which ``names`` can be written as files.  Checked before the data are read,
    so a bad ``--out`` costs nothing (it is created only when something is written)."""
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise CLIError(f"--out {path}: exists and is not a directory; give a directory to write to")
    parent = path
    while not parent.exists():  # the nearest existing ancestor must be a writable directory
        parent = parent.parent
    if not parent.is_dir():
        raise CLIError(f"--out {path}: cannot create it, because {parent} is not a directory")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise CLIError(f"--out {path}: cannot write in {parent} (permission denied)")
    for name in names:
        if (path / name).is_dir():
            raise CLIError(f"--out {path}: {path / name} is a directory; cannot write {name}")
    return path


def _saved_columns(model: StateSpaceModel, path: str) -> dict[str, Any]:
    """The column names a model was identified from: ``options["columns"]`` (written by
    ``hdpbsid identify``), else the model's channel names (a model saved from Python)."""
    cols = model.options.get("columns")
    if cols is None:
        return {"time": None, "inputs": model.input_names, "outputs": model.output_names}
    ok = isinstance(cols, dict) and isinstance(cols.get("time"), str | None)
    for key in ("inputs", "outputs"):
        names = cols.get(key) if isinstance(cols, dict) else None
        ok = ok and isinstance(names, list) and all(isinstance(c, str) for c in names)
    if not ok:
        raise CLIError(
            f"{path}: key 'options.columns' must be an object with 'time' (a name or null), "
            f"'inputs' and 'outputs' (lists of names), got {cols!r:.200}"
        )
    return {"time": cols["time"], "inputs": list(cols["inputs"]), "outputs": list(cols["outputs"])}


def _time_unit(unit: str) -> str:
    from hdpbsid.data.checks import check_label

    try:
        return check_label(unit, "--time-unit")
    except (TypeError, ValueError) as exc:
        raise CLIError(str(exc)) from exc


def _warn_time_scale(model: StateSpaceModel, rec: Record, unit: str | None) -> None:
    """The record-against-model time scale check of :meth:`StateSpaceModel.check_record`,
    printed once per record (the evaluations that follow would repeat it)."""
    from hdpbsid.models.model import TimeScaleWarning

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TimeScaleWarning)
        model.check_record(rec.t, unit, name=rec.time or "t")
    for w in caught:
        print(f"warning: {rec.source}: {w.message}", file=sys.stderr)


# -- commands -----------------------------------------------------------------------------
def best_method() -> str:
    """The method of the ``demo`` command: ``"hermite"`` (HD-PBSID) when it is available,
    else ``"dt"``.

    Returns
    -------
    str
        The method name.
    """
    from hdpbsid.methods.registry import is_available

    return "hermite" if is_available("hermite") else "dt"


def _parse_options(items: list[str] | None) -> dict[str, Any]:
    opts: dict[str, Any] = {}
    for item in items or []:
        if "=" not in item:
            raise CLIError(f"--option expects KEY=VALUE, got {item!r}")
        key, val = item.split("=", 1)
        try:
            opts[key.strip()] = ast.literal_eval(val)
        except (ValueError, SyntaxError):
            opts[key.strip()] = val
    return opts


def _fmt_complex(z: complex) -> str:
    if abs(z.imag) <= 1e-12 * max(1.0, abs(z)):
        return f"{z.real:+.6g}"
    return f"{z.real:+.6g} {z.imag:+.6g}j"


def _print_model(model: StateSpaceModel, out: TextIO) -> None:
    import numpy as np

    np.set_printoptions(precision=6, suppress=False, linewidth=100)
    print(repr(model), file=out)
    for name in ("A", "B", "C", "D", "K"):
        print(f"{name} =\n{getattr(model, name)}", file=out)
    print(f"eigenvalues (rad/{model.time_unit}):", file=out)
    for z in model.eigenvalues:
        print(f"  {_fmt_complex(complex(z))}", file=out)


def _print_fit(
    model: StateSpaceModel, t: Any, u: Any, y: Any, names: list[str], out: TextIO
) -> None:
    from hdpbsid.plots import display_fit

    shown = display_fit(model, t, u, y)
    print(f"fit, 100 (1 - NRMSE) as MATLAB's compare ({shown.kind}):", file=out)
    for name, fit in zip(names, shown.fit, strict=True):
        print(f"  {name}: {fit:.1f} %", file=out)


def _check_method(method: str) -> None:
    from hdpbsid.methods.registry import available_methods, is_available

    if not is_available(method):
        raise CLIError(
            f"unknown or unavailable method {method!r}; available: {available_methods()}"
        )


def _progress(choice: str, records: list[Record]) -> bool:
    """Progress bars (stderr): ``on``, ``off``, or ``auto``: only where the work is long,
    i.e. a record longer than :data:`hdpbsid.selection.long_records.LONG_SAMPLES` (a
    shorter record is identified in seconds, and bars would only add lines to the
    output)."""
    from hdpbsid.selection.long_records import LONG_SAMPLES

    long = max(r.t.size for r in records) > LONG_SAMPLES
    return choice == "on" or (choice == "auto" and long)


def _cmd_identify(args: argparse.Namespace, out: TextIO) -> int:
    import numpy as np

    from hdpbsid.data.checks import check_names
    from hdpbsid.identify import identify
    from hdpbsid.models.model_io import save_model

    inputs = _split_columns(args.inputs)
    outputs = _split_columns(args.outputs)
    if not outputs:
        raise CLIError("--outputs needs at least one column name")
    files = ([args.file] if args.file else []) + list(args.data or [])
    if not files:
        raise CLIError("identify: give a data file (FILE or --data FILE, repeatable)")
    method = args.method
    _check_method(method)
    options = _parse_options(args.option)
    unit = _time_unit(args.time_unit or "s")
    try:  # column names become the channel names: printable, short
        check_names(inputs, "--inputs", len(inputs), "u")
        check_names(outputs, "--outputs", len(outputs), "y")
    except (TypeError, ValueError) as exc:
        raise CLIError(f"{exc}; rename the column") from exc
    outdir = _check_out(args.out, ["model.json"] + ([] if args.no_plot else ["identification.png"]))
    columns = {"time": args.time, "inputs": inputs, "outputs": outputs}
    records = _read_records(args, files, columns)
    detrend = None if args.detrend == "none" else args.detrend
    refine = None if args.refine == "none" else args.refine
    options.setdefault("progress", _progress(args.progress, records))
    labels = {"input_names": inputs, "output_names": outputs, "time_unit": unit}
    try:
        if len(records) == 1:
            t, u, y = records[0].as_tuple()
            model = identify(
                t,
                u,
                y,
                order=args.order,
                method=method,
                refine=refine,
                detrend=detrend,
                **labels,
                **options,
            )
        else:
            model = identify(
                [r.as_tuple() for r in records],
                order=args.order,
                method=method,
                refine=refine,
                detrend=detrend,
                **labels,
                **options,
            )
    except (ValueError, TypeError) as exc:
        print(f"hdpbsid identify: identification failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    first = records[0]
    model.options["columns"] = {"time": first.time, "inputs": inputs, "outputs": outputs}
    model.options["sampling_interval"] = first.dt
    model.options["source"] = files[0] if len(files) == 1 else files
    for rec in records:
        print(
            f"data: {rec.source}  samples: {rec.t.size}  "
            + (f"time column: {rec.time}" if rec.time else f"dt: {rec.dt:g}"),
            file=out,
        )
    print(f"method: {method}  inputs: {inputs}  outputs: {outputs}  detrend: {detrend}", file=out)
    _print_model(model, out)
    for rec in records:
        uu = np.zeros((rec.t.size, 0)) if rec.u is None else rec.u
        if len(records) > 1:
            print(f"{rec.source}:", file=out)
        _print_fit(model, rec.t, uu, rec.y, outputs, out)
    path = save_model(model, outdir / "model.json")
    print(f"wrote {path}", file=out)
    if not args.no_plot:
        from hdpbsid.plots import plot_identification, save_figure

        uu = np.zeros((first.t.size, 0)) if first.u is None else first.u
        fig = plot_identification(
            model, first.t, uu, first.y, output_names=outputs, input_names=inputs
        )
        print(f"wrote {save_figure(fig, outdir / 'identification.png')}", file=out)
    return EXIT_OK


def _cmd_validate(args: argparse.Namespace, out: TextIO) -> int:
    """Fit and residual tests of a saved model on other records
    (:mod:`hdpbsid.models.assessment`)."""
    from hdpbsid.models.model import TimeScaleWarning
    from hdpbsid.models.model_io import load_model

    model = load_model(args.model)
    saved = _saved_columns(model, args.model)
    inputs = _split_columns(args.inputs) if args.inputs else saved["inputs"]
    outputs = _split_columns(args.outputs) if args.outputs else saved["outputs"]
    if not outputs:
        raise CLIError("validate: the model file names no output columns; give --outputs")
    if len(inputs) != model.m or len(outputs) != model.l:
        raise CLIError(
            f"validate: the model has {model.m} input(s) and {model.l} output(s), the "
            f"columns are inputs {inputs} and outputs {outputs}"
        )
    time = args.time
    if time is None and args.dt is None and args.fs is None:
        dt = model.options.get("sampling_interval")
        if saved["time"] is None and isinstance(dt, int | float) and dt > 0:
            args.dt = float(dt)  # identified with --dt
        else:
            time = saved["time"] or "t"
    if args.k is not None and args.k < 1:
        raise CLIError(f"--k must be a positive number of steps, got {args.k}")
    unit = None if args.time_unit is None else _time_unit(args.time_unit)
    names = [] if args.no_plot else ["validation.png"]
    if not args.no_plot and len(args.files) > 1:
        names = [f"validation-{Path(f).stem}.png" for f in args.files]
    outdir = _check_out(args.out, names)
    records = _read_records(args, args.files, {"time": time, "inputs": inputs, "outputs": outputs})
    for rec in records:
        _warn_time_scale(model, rec, unit)
        name = "validation.png" if len(records) == 1 else f"validation-{Path(rec.source).stem}.png"
        with warnings.catch_warnings():  # said once above; the evaluations would repeat it
            warnings.simplefilter("ignore", TimeScaleWarning)
            _validate_record(args, model, rec, inputs, outputs, outdir / name, out)
    return EXIT_OK


def _validate_record(
    args: argparse.Namespace,
    model: StateSpaceModel,
    rec: Record,
    inputs: list[str],
    outputs: list[str],
    figure: Path,
    out: TextIO,
) -> None:
    """Fits, residual tests and figure of ``model`` on one record (``hdpbsid validate``)."""
    import numpy as np

    uu = np.zeros((rec.t.size, 0)) if rec.u is None else rec.u
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


def _cmd_demo(args: argparse.Namespace, out: TextIO) -> int:
    """The quadrotor study (:mod:`hdpbsid.studies.quadrotor`, the thesis, §6) for one run."""
    import numpy as np

    from hdpbsid import studies
    from hdpbsid.models.metrics import match_eigenvalues
    from hdpbsid.models.model import StateSpaceModel
    from hdpbsid.models.model_io import save_model
    from hdpbsid.studies.data import quadrotor_record
    from hdpbsid.studies.runner import task_rng

    method = best_method() if args.method == "auto" else args.method
    _check_method(method)
    if method not in studies.methods.METHODS:
        raise CLIError(f"demo: method must be one of {list(studies.methods.METHODS)}")
    snr = None if str(args.snr).lower() in ("none", "inf") else float(args.snr)
    outputs = tuple(_split_columns(args.outputs))
    orders = tuple(int(o) for o in _split_columns([args.orders]))
    outdir = _check_out(args.out, ["model.json"])
    result = studies.run_study(
        "quadrotor",
        runs=1,
        seed=args.seed,
        out=None,
        progress=False,
        resume=False,
        snr_db=snr,
        duration=args.duration,
        excitation=args.excitation,
        n_max_u=args.n_max_u,
        outputs=outputs,
        orders=orders,
        method=method,
    )
    rec = result.records[0]
    case = rec["case"]
    data = quadrotor_record(task_rng(args.seed, case, 0), **case["data"])
    exc = args.excitation + (f" (n_max,u = {args.n_max_u})" if "hermite" in args.excitation else "")
    print(
        "quadrotor pitch closed loop (the thesis's §6 experiment, simulated): "
        f"{data.t.size} samples "
        f"at 250 Hz, {args.duration:g} s, excitation {exc}, SNR "
        f"{'none' if snr is None else f'{snr:g} dB'}, seed {args.seed}, "
        f"saturated {100 * data.saturation_fraction:.1f} % of samples",
        file=out,
    )
    print(
        f"identify(t, moment, {list(data.outputs)}, order={list(orders)}, method={method!r})",
        file=out,
    )
    if not rec["ok"]:
        print(
            f"hdpbsid demo: identification with {method!r} failed: {rec['error']}", file=sys.stderr
        )
        return EXIT_FAILED
    res = rec["result"]
    sv = np.asarray(res["singular_values"], dtype=float)
    print(
        "singular values: "
        + " ".join(f"{v:.3g}" for v in sv[:8])
        + (f"  -> order chosen (held-out error): {res['auto_order']}" if res["auto_order"] else ""),
        file=out,
    )
    true = data.true_eigenvalues
    models: dict[int, StateSpaceModel] = {}
    for o, err in res["order_errors"].items():
        print(f"order {o}: identification failed: {err}", file=out)
    for o, mrec in res["models"].items():
        mats = [np.asarray(mrec["matrices"][k], dtype=float) for k in ("A", "B", "C", "D", "K")]
        model = StateSpaceModel(*mats, singular_values=sv, options=dict(mrec["options"]))
        if res.get("order_selection"):  # what chose the order, for the figure
            model.options["order_selection"] = res["order_selection"]
        models[int(o)] = model
        est, tru = match_eigenvalues(model.eigenvalues, true)
        errs = np.abs(est - tru) / np.abs(tru)
        print(
            f"order {o}: eigenvalues  identified            true                  rel. error",
            file=out,
        )
        for e, tv, err in zip(est, tru, errs, strict=True):
            print(f"  {_fmt_complex(e):<22}{_fmt_complex(tv):<22}{100 * err:.3f} %", file=out)
        for z in mrec.get("extra") or []:
            print(f"  {_fmt_complex(complex(*z)):<22}{'(no true match)':<22}", file=out)
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
    main_order = 3 if 3 in models else min(models)
    model = models[main_order]
    model.set_labels(input_names=["moment"], output_names=list(data.outputs), time_unit="s")
    model.sampling_interval = float(np.median(np.diff(data.t)))
    model.options["demo"] = {
        "seed": args.seed,
        "snr_db": snr,
        "duration": args.duration,
        "excitation": args.excitation,
        "order": main_order,
    }
    print(f"wrote {save_model(model, outdir / 'model.json')} (order {main_order})", file=out)
    if not args.no_plot:
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
            title=f"Quadrotor pitch, closed loop: method {method!r}, order {main_order}",
        )
        print(f"wrote {save_figure(fig, outdir / 'identification.png')}", file=out)
        for _name, path in sorted(quadrotor_figures(result, outdir).items()):
            print(f"wrote {path}", file=out)
    return EXIT_OK


STUDY_NAMES = ("snr", "samples", "basis-order", "operator", "table1", "quadrotor")


def _cmd_study(args: argparse.Namespace, out: TextIO) -> int:
    from hdpbsid import studies

    settings = _parse_options(args.set)
    outdir = _check_out(args.out or Path("hdpbsid-study") / args.name, [])
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
    return EXIT_OK


def _add_time_arguments(p: argparse.ArgumentParser, unit_help: str) -> None:
    p.add_argument("--time", default=None, help="time column name (default: t)")
    p.add_argument("--time-unit", default=None, metavar="UNIT", help=unit_help)
    g = p.add_mutually_exclusive_group()
    g.add_argument(
        "--dt", type=float, default=None, help="sampling interval, when there is no time column"
    )
    g.add_argument(
        "--fs", type=float, default=None, help="sampling rate, when there is no time column"
    )


def build_parser() -> argparse.ArgumentParser:
    """The ``hdpbsid`` argument parser; its errors raise :class:`CLIError` instead of exiting.

    Returns
    -------
    argparse.ArgumentParser
        The parser of the commands ``identify``, ``validate``, ``demo``, ``study`` and the
        frequency-domain commands.

    Examples
    --------
    >>> args = build_parser().parse_args(
    ...     ["identify", "data.csv", "--time", "t", "--input", "u", "--output", "y"]
    ... )
    >>> args.command, args.inputs, args.method
    ('identify', ['u'], 'auto')
    """
    parser = _Parser(
        prog="hdpbsid",
        description="Continuous-time subspace identification (PBSID in a basis domain).",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    p = sub.add_parser(
        "identify",
        help="identify a continuous-time model from a data file",
        description="Identify from a data file (CSV with a header row, MATLAB .mat, NumPy "
        ".npz, Parquet, HDF5; signals chosen by name).",
    )
    p.add_argument("file", metavar="FILE", nargs="?", default=None)
    p.add_argument(
        "--data",
        action="append",
        metavar="FILE",
        help="a further experiment of the same system (repeatable; each record is "
        "detrended on its own)",
    )
    p.add_argument(
        "--inputs",
        nargs="+",
        default=[],
        metavar="COLS",
        help="input column names (space or comma separated; none = time series)",
    )
    p.add_argument(
        "--outputs",
        nargs="+",
        required=True,
        metavar="COLS",
        help="output column names (space or comma separated)",
    )
    _add_time_arguments(
        p, "unit of the times, recorded in the model (eigenvalues in rad/UNIT; default s)"
    )
    p.add_argument(
        "--detrend",
        choices=("mean", "linear", "none"),
        default="mean",
        help="operating point removed before identification and stored in the model "
        "(default: mean)",
    )
    p.add_argument(
        "--order",
        type=int,
        default=None,
        help="model order (default: chosen by held-out simulation error)",
    )
    p.add_argument(
        "--progress",
        choices=("auto", "on", "off"),
        default="auto",
        help="progress bars on stderr (auto: when the record is long)",
    )
    p.add_argument(
        "--method",
        default="auto",
        help="identification method (default: auto, every method compared on held-out data)",
    )
    p.add_argument(
        "--refine",
        choices=("none", "pem", "auto"),
        default="auto",
        help="prediction-error refinement of the subspace model "
        "(hdpbsid.refine.pem.refine_pem; needs uniform t; 'auto' (default): every "
        "single uniformly sampled record, kept when it converges; hdpbsid.selection.feedback)",
    )
    p.add_argument(
        "--option",
        action="append",
        metavar="KEY=VALUE",
        help="extra option for the method, e.g. --option p=20 (repeatable)",
    )
    p.add_argument("--delimiter", default=None, help="CSV delimiter (default: sniffed)")
    p.add_argument("--out", default="hdpbsid-out", help="output directory (default: hdpbsid-out)")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")

    v = sub.add_parser(
        "validate",
        help="fit and residual tests of a saved model on other records",
        description="Validate MODEL.json (written by identify) on one or more data files: "
        "simulation fit per output, optional k-step prediction fit, residual whiteness and "
        "input-independence tests (Ljung, System Identification, sec. 16.6) and a figure.",
    )
    v.add_argument("model", metavar="MODEL.json")
    v.add_argument("files", metavar="FILE", nargs="+")
    v.add_argument("--k", type=int, default=None, help="also the k-step-ahead prediction fit")
    v.add_argument(
        "--max-lag", type=int, default=25, help="largest lag M of the residual tests (25)"
    )
    v.add_argument(
        "--inputs", nargs="+", default=None, metavar="COLS", help="default: as identified"
    )
    v.add_argument(
        "--outputs", nargs="+", default=None, metavar="COLS", help="default: as identified"
    )
    _add_time_arguments(
        v,
        "unit of the record's times; a warning when it is not the model's (default: the model's)",
    )
    v.add_argument("--delimiter", default=None, help="CSV delimiter (default: sniffed)")
    v.add_argument("--out", default="hdpbsid-out", help="output directory (default: hdpbsid-out)")
    v.add_argument("--no-plot", action="store_true", help="do not write the figure")

    d = sub.add_parser(
        "demo",
        help="closed-loop quadrotor pitch example end to end",
        description="Simulate the quadrotor pitch closed loop (hdpbsid.systems.quadrotor) "
        "and identify it.",
    )
    d.add_argument(
        "--method",
        default="auto",
        help="identification method (default: hermite if available, else dt)",
    )
    d.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    d.add_argument("--snr", default="20", help="sensor SNR in dB, or 'none' (default 20)")
    d.add_argument("--duration", type=float, default=30.0, help="seconds (default 30)")
    d.add_argument(
        "--excitation",
        choices=("hermite-sweep", "sweep", "3211"),
        default="hermite-sweep",
        help="1-4 Hz sweep projected on --n-max-u Hermite functions (thesis §5-6, default), "
        "the plain sweep or a 3211",
    )
    d.add_argument(
        "--n-max-u", type=int, default=300, help="Hermite terms of the excitation (default 300)"
    )
    d.add_argument(
        "--orders", default="3,4", help="model orders to identify (default 3,4; thesis §6: 4)"
    )
    d.add_argument(
        "--outputs",
        nargs="+",
        default=["q,theta"],
        metavar="NAMES",
        help="outputs among u, q, theta, a_x, q_dot (default: q theta; thesis §6: q q_dot)",
    )
    d.add_argument("--out", default="hdpbsid-demo", help="output directory")
    d.add_argument("--no-plot", action="store_true", help="do not write figures")

    st = sub.add_parser(
        "study",
        help="run a simulation study of the thesis (§5-6)",
        description="Run a Monte Carlo study; prints its table, writes CSV/JSON/PNG to --out.",
    )
    st.add_argument("name", choices=STUDY_NAMES, metavar="NAME", help=", ".join(STUDY_NAMES))
    st.add_argument("--runs", type=int, default=None, help="runs per case (default: study's)")
    st.add_argument("--seed", type=int, default=0, help="base random seed (default 0)")
    st.add_argument("--jobs", type=int, default=1, help="local processes (joblib; default 1)")
    st.add_argument(
        "--scheduler", default=None, metavar="ADDRESS", help="Dask scheduler, e.g. tcp://host:8786"
    )
    st.add_argument("--out", default=None, help="output directory (default hdpbsid-study/NAME)")
    st.add_argument("--no-progress", action="store_true", help="no progress bar")
    st.add_argument(
        "--no-resume", action="store_true", help="recompute tasks already in results.jsonl"
    )
    st.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="study setting, e.g. --set snrs=(50,6) --set methods=('hermite',) (repeatable)",
    )
    frequency_cli.add_parsers(sub)
    return parser


def main(argv: list[str] | None = None, stdout: TextIO | None = None) -> int:
    """Run the command line on ``argv`` and return the exit code.

    The library never exits the caller's process: errors are reported on stderr and mapped
    to exit codes.  A closed standard output (``| head``) ends the printing quietly; the
    files are still written (:class:`_PipeSafe`).

    Parameters
    ----------
    argv : list of str, optional
        The arguments (default ``sys.argv[1:]``).
    stdout : text stream, optional
        Where the results are printed (default ``sys.stdout``).

    Returns
    -------
    int
        0 success, 1 identification failed (message on stderr), 2 usage or input error
        (missing file, unknown column, unknown method, bad arguments; message on stderr),
        130 interrupted (Ctrl-C).

    Examples
    --------
    A missing data file is an input error, reported before anything is written:

    >>> import os, tempfile
    >>> out = tempfile.mkdtemp()
    >>> main(["identify", os.path.join(out, "missing.csv"), "--time", "t", "--input", "u",
    ...       "--output", "y", "--out", out])
    2
    """
    out = _PipeSafe(sys.stdout if stdout is None else stdout)
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        args = build_parser().parse_args(argv)
        if args.command == "identify":
            return _cmd_identify(args, out)
        if args.command == "validate":
            return _cmd_validate(args, out)
        if args.command == "study":
            return _cmd_study(args, out)
        if args.command in frequency_cli.COMMANDS:
            return frequency_cli.run(args, out)
        return _cmd_demo(args, out)
    except _HelpExit as exc:
        return exc.status
    except CLIError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except (ValueError, TypeError, ImportError) as exc:  # bad data file, --option, ...
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:  # Ctrl-C: the shell's convention, 128 + SIGINT, no traceback
        print("interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        out.flush()


class _PipeSafe:
    """A text stream that stops writing, quietly, once its reader has gone.

    ``hdpbsid identify data.csv | head`` closes the pipe after a few lines; Unix tools
    then stop printing without a message, and so does this one -- but the files it was
    asked for (model, figures) are still written, since they do not depend on the
    pipe.  When the stream is the process's standard output its descriptor is pointed at
    ``os.devnull``, so the interpreter's final flush cannot raise either (Python
    documentation, "Note on SIGPIPE").
    """

    def __init__(self, stream: TextIO) -> None:
        self.stream = stream
        self.broken = False

    def write(self, text: str) -> int:
        if not self.broken:
            try:
                self.stream.write(text)
            except BrokenPipeError:
                self._gone()
        return len(text)

    def flush(self) -> None:
        if not self.broken:
            try:
                self.stream.flush()
            except BrokenPipeError:
                self._gone()

    def _gone(self) -> None:
        self.broken = True
        if self.stream is sys.stdout:
            try:
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, sys.stdout.fileno())
                os.close(devnull)
            except (OSError, ValueError, AttributeError):  # no descriptor: nothing to redirect
                pass


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
