"""Command line: ``hdpbsid identify FILE ...``, ``validate``, ``demo`` and ``study NAME``.

The command-line front end (docs/user-guide.md, "Command line").  :func:`main` takes
an argument list and *returns* an exit code (0 success, 1 identification failed,
2 usage / input error, 130 interrupted); it never calls ``sys.exit`` (a library that
exits takes the caller's process with it).  Only the command line prints (this module,
the commands of :mod:`hdpbsid.commands` and :mod:`hdpbsid.frequency_cli`); this module
parses the arguments and dispatches them.  ``--out`` is checked before any data are
read; a closed standard output (``| head``) ends the printing quietly and the files are
still written.

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
``2^BLAS_SPIN.log2_cycles`` cycles (:func:`_short_blas_spin`), unless the user set
``OPENBLAS_THREAD_TIMEOUT``.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO


@dataclass(frozen=True)
class BlasSpin:
    """How long an idle OpenBLAS thread of the command's process spins before it sleeps.

    ``OPENBLAS_THREAD_TIMEOUT`` is the log2 of the cycles (OpenBLAS's own default is 28,
    about 0.1 s).  2^20 cycles (about 0.4 ms at 2.5 GHz) outlasts by far the wake-up of a
    sleeping thread (tens of microseconds), so the dispatches inside one threaded
    factorisation still find their threads awake, while the spin after OpenBLAS starts its
    threads (at ``import numpy``) and after each threaded call costs a fraction of a
    millisecond per thread instead of a tenth of a second: the library's calls run their
    small-matrix work on one thread (:mod:`hdpbsid.runtime`), so nothing else waits for a
    spinning thread.

    Attributes
    ----------
    log2_cycles : int
        The value given to ``OPENBLAS_THREAD_TIMEOUT``.
    """

    #: a fraction of a millisecond of spin, far above a thread's wake-up time (see above)
    log2_cycles: int = 20


#: the OpenBLAS spin of the command's process (:func:`_short_blas_spin`)
BLAS_SPIN = BlasSpin()
#: :attr:`BlasSpin.log2_cycles`, under the name earlier callers import
BLAS_SPIN_LOG2_CYCLES = BLAS_SPIN.log2_cycles


def _short_blas_spin() -> None:
    """Set ``OPENBLAS_THREAD_TIMEOUT`` (:data:`BLAS_SPIN`) for this process
    when the user has not set it and numpy is not imported yet (OpenBLAS reads it once,
    when it loads): the command's own process, whose BLAS the user did not start."""
    if "numpy" not in sys.modules:
        os.environ.setdefault("OPENBLAS_THREAD_TIMEOUT", str(BLAS_SPIN.log2_cycles))


_short_blas_spin()

# the commands import numpy (and with it OpenBLAS, which starts its threads when it loads)
# when they compute, not at module level: ``--help`` and a usage error need neither
from hdpbsid import frequency_cli  # noqa: E402 (after _short_blas_spin)
from hdpbsid.commands.common import EXIT, CLIError, best_method  # noqa: E402
from hdpbsid.commands.demo import run_demo as _cmd_demo  # noqa: E402
from hdpbsid.commands.demo import run_study as _cmd_study  # noqa: E402
from hdpbsid.commands.identify import progress as _progress  # noqa: E402, F401 (re-exported)
from hdpbsid.commands.identify import run_identify as _cmd_identify  # noqa: E402
from hdpbsid.commands.identify import run_validate as _cmd_validate  # noqa: E402

if TYPE_CHECKING:  # the library's modules load when a command runs, not for --help
    import numpy as np

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


STUDY_NAMES = ("snr", "samples", "basis-order", "operator", "table1", "quadrotor")


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
    _add_identify_parser(sub)
    _add_validate_parser(sub)
    _add_demo_parser(sub)
    _add_study_parser(sub)
    frequency_cli.add_parsers(sub)
    return parser


def _add_identify_parser(sub: Any) -> None:
    """The ``identify`` command's arguments."""
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
    _add_identification_settings(p)
    p.add_argument("--delimiter", default=None, help="CSV delimiter (default: sniffed)")
    p.add_argument("--out", default="hdpbsid-out", help="output directory (default: hdpbsid-out)")
    p.add_argument("--no-plot", action="store_true", help="do not write the figure")


def _add_identification_settings(p: argparse.ArgumentParser) -> None:
    """The ``identify`` command's choices of the identification: operating point, order,
    method, refinement, method options and progress bars."""
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
        "--focus",
        choices=("auto", "prediction", "simulation"),
        default="auto",
        help="what the refinement fits the plant for: 'prediction' (one-step prediction "
        "error, consistent in closed loop), 'simulation' (output error, then the noise "
        "model; open-loop records, the best linear model of a nonlinear process) or "
        "'auto' (default: prediction, and the output-error plant in open loop when it "
        "simulates the record better by more than a standard error; "
        "hdpbsid.selection.focus)",
    )
    p.add_argument(
        "--option",
        action="append",
        metavar="KEY=VALUE",
        help="extra option for the method, e.g. --option p=20 (repeatable)",
    )


def _add_validate_parser(sub: Any) -> None:
    """The ``validate`` command's arguments."""
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


def _add_demo_parser(sub: Any) -> None:
    """The ``demo`` command's arguments."""
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


def _add_study_parser(sub: Any) -> None:
    """The ``study`` command's arguments."""
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
        return EXIT.usage
    except (ValueError, TypeError, ImportError) as exc:  # bad data file, --option, ...
        print(f"error: {exc}", file=sys.stderr)
        return EXIT.usage
    except KeyboardInterrupt:  # Ctrl-C: the shell's convention, 128 + SIGINT, no traceback
        print("interrupted", file=sys.stderr)
        return EXIT.interrupted
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
