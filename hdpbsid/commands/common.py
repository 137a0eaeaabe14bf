"""What the ``hdpbsid`` sub-commands share: exit codes, usage errors and their checks.

Every check here runs before any data are read, so a bad argument costs nothing and no
file is written; a failed check raises :class:`CLIError`, which :func:`hdpbsid.cli.main`
reports on stderr with exit code 2.  numpy is imported inside the functions that print
numbers, never at module level (:mod:`hdpbsid.cli`: ``--help`` loads no numerical library).
"""

from __future__ import annotations

import argparse
import ast
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

if TYPE_CHECKING:  # annotations only: the library's modules load when a command runs
    from hdpbsid.data.io import Record
    from hdpbsid.models.model import StateSpaceModel

__all__ = [
    "ExitCodes",
    "EXIT",
    "CLIError",
    "best_method",
    "split_columns",
    "parse_options",
    "check_out",
    "check_method",
    "time_unit",
    "read_records",
    "fmt_complex",
    "print_model",
    "print_fit",
]


@dataclass(frozen=True)
class ExitCodes:
    """The exit codes of ``hdpbsid`` (:func:`hdpbsid.cli.main` returns them, never exits).

    Attributes
    ----------
    ok : int
        Success.
    failed : int
        The identification failed (message on stderr).
    usage : int
        A usage or input error (message on stderr).
    interrupted : int
        Ctrl-C.
    """

    #: success, the shell's convention
    ok: int = 0
    #: the computation ran and failed: not the user's arguments
    failed: int = 1
    #: a usage error, the code argparse itself uses for one
    usage: int = 2
    #: 128 + SIGINT, the shell's convention for a process ended by Ctrl-C
    interrupted: int = 130


#: the exit codes every command returns
EXIT = ExitCodes()


@dataclass(frozen=True)
class PrintSettings:
    """How the commands print matrices and eigenvalues.

    Attributes
    ----------
    precision : int
        Significant digits of a matrix entry.
    linewidth : int
        Characters per printed matrix row.
    imag_tol : float
        An eigenvalue whose imaginary part is below this fraction of its modulus (or of 1)
        prints as a real number.
    """

    #: six digits tell apart the eigenvalues of a model identified from noisy data
    precision: int = 6
    #: a row of a matrix of order 10 on one line of a wide terminal
    linewidth: int = 100
    #: rounding of a real eigenvalue computed as complex (about 1e4 unit roundoffs)
    imag_tol: float = 1e-12


#: the printing settings of the commands
PRINT = PrintSettings()


class CLIError(Exception):
    """A usage or input problem: reported on stderr, exit code 2."""


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


def split_columns(values: list[str] | None) -> list[str]:
    """Column names given space or comma separated (``--inputs a,b c``), blanks dropped.

    Parameters
    ----------
    values : list of str or None
        The arguments of the option.

    Returns
    -------
    list of str
        The names in order.

    Examples
    --------
    >>> split_columns(["a,b", " c "])
    ['a', 'b', 'c']
    """
    out: list[str] = []
    for v in values or []:
        out.extend(c.strip() for c in v.split(",") if c.strip())
    return out


def parse_options(items: list[str] | None) -> dict[str, Any]:
    """``KEY=VALUE`` settings (``--option``, ``--set``): the value as a Python literal
    when it is one (``20``, ``(50, 6)``, ``'hermite'``), else the text.

    Parameters
    ----------
    items : list of str or None
        The ``KEY=VALUE`` arguments.

    Returns
    -------
    dict
        Key to value.

    Raises
    ------
    CLIError
        If an item has no ``=``.

    Examples
    --------
    >>> parse_options(["p=20", "mode=fast"])
    {'p': 20, 'mode': 'fast'}
    """
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


def check_out(out: str | Path, names: list[str]) -> Path:
    """The output directory ``out``: an existing directory, or a path that can be created
    as one, in which ``names`` can be written as files.

    Checked before the data are read, so a bad ``--out`` costs nothing (the directory is
    created only when something is written).

    Parameters
    ----------
    out : str or Path
        The ``--out`` argument.
    names : list of str
        The files the command will write there.

    Returns
    -------
    Path
        The directory.

    Raises
    ------
    CLIError
        If ``out`` is a file, cannot be created or written in, or one of ``names`` is a
        directory there.
    """
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


def check_method(method: str) -> None:
    """Refuse a method the registry does not know or cannot run here.

    Parameters
    ----------
    method : str
        The ``--method`` argument.

    Raises
    ------
    CLIError
        If the method is unknown or unavailable.
    """
    from hdpbsid.methods.registry import available_methods, is_available

    if not is_available(method):
        raise CLIError(
            f"unknown or unavailable method {method!r}; available: {available_methods()}"
        )


def time_unit(unit: str) -> str:
    """The ``--time-unit`` label, checked as the model's labels are.

    Parameters
    ----------
    unit : str
        The argument.

    Returns
    -------
    str
        The label.

    Raises
    ------
    CLIError
        If it is not a short printable label (:func:`hdpbsid.data.checks.check_label`).
    """
    from hdpbsid.data.checks import check_label

    try:
        return check_label(unit, "--time-unit")
    except (TypeError, ValueError) as exc:
        raise CLIError(str(exc)) from exc


def read_records(
    args: argparse.Namespace, files: list[str], columns: dict[str, Any]
) -> list[Record]:
    """Every file of ``files`` as a :class:`~hdpbsid.data.io.Record` with the chosen columns.

    Without ``--time``, ``--dt`` and ``--fs`` the time column is the one named ``t``.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line (``dt``, ``fs``, ``delimiter``).
    files : list of str
        The data files.
    columns : dict
        ``time`` (a name or None), ``inputs`` and ``outputs`` (lists of names).

    Returns
    -------
    list of Record
        One per file, in order.
    """
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


def fmt_complex(z: complex) -> str:
    """An eigenvalue as printed by the commands: signed, six digits, real when its
    imaginary part is rounding (:attr:`PrintSettings.imag_tol`).

    Parameters
    ----------
    z : complex
        The value.

    Returns
    -------
    str
        ``"+1.5"`` or ``"-0.5 +2j"``.

    Examples
    --------
    >>> fmt_complex(-0.5 + 2j), fmt_complex(1.5 + 1e-17j)
    ('-0.5 +2j', '+1.5')
    """
    if abs(z.imag) <= PRINT.imag_tol * max(1.0, abs(z)):
        return f"{z.real:+.6g}"
    return f"{z.real:+.6g} {z.imag:+.6g}j"


def print_model(model: StateSpaceModel, out: TextIO) -> None:
    """Print the model, its matrices and its eigenvalues.

    The matrices are printed under numpy's print options of :data:`PRINT`, set for these
    lines only (:func:`numpy.printoptions`): the caller's own options are left as they were.

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    out : text stream
        Where to print.
    """
    import numpy as np

    with np.printoptions(precision=PRINT.precision, suppress=False, linewidth=PRINT.linewidth):
        print(repr(model), file=out)
        for name in ("A", "B", "C", "D", "K"):
            print(f"{name} =\n{getattr(model, name)}", file=out)
        print(f"eigenvalues (rad/{model.time_unit}):", file=out)
        for z in model.eigenvalues:
            print(f"  {fmt_complex(complex(z))}", file=out)


def print_fit(
    model: StateSpaceModel, t: Any, u: Any, y: Any, names: list[str], out: TextIO
) -> None:
    """Print the fit of ``model`` on a record per output, as the figure shows it
    (:func:`hdpbsid.plots.display_fit`).

    Parameters
    ----------
    model : StateSpaceModel
        The model.
    t, u, y : ndarray
        The record.
    names : list of str
        The output names.
    out : text stream
        Where to print.
    """
    from hdpbsid.plots import display_fit

    shown = display_fit(model, t, u, y)
    print(f"fit, 100 (1 - NRMSE) as MATLAB's compare ({shown.kind}):", file=out)
    for name, fit in zip(names, shown.fit, strict=True):
        print(f"  {name}: {fit:.1f} %", file=out)
