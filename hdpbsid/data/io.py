"""Reading measured records from the files users have: CSV, MATLAB, NumPy, Parquet, HDF5.

Every reader selects signals by name -- a CSV header, a MATLAB or NumPy variable, a
Parquet column, an HDF5 dataset path -- and :func:`read_record` turns them into an
identification record ``(t, u, y)``.  Nothing is read silently wrong: a missing column,
text in a numeric column, a missing / NaN / infinite value, columns of different
lengths, unsorted or repeated times, an empty file or a variable that is not a vector
raise ``ValueError`` naming the file, the column and what was expected.

=========================  ====================================================
suffix                     reader
=========================  ====================================================
``.csv .txt .tsv .dat``    header row + numbers; delimiter sniffed (``, ; tab``
                           space) unless given; ``#`` lines and blank lines skipped
``.mat``                   :func:`scipy.io.loadmat` (MATLAB v4-v7.2); v7.3 files
                           are HDF5 and go to the HDF5 reader
``.npz``                   :func:`numpy.load` (no pickles)
``.parquet .pq``           ``pyarrow.parquet`` (extra ``io``)
``.h5 .hdf5 .hdf``         ``h5py`` datasets, names may be paths ``group/name``
                           (extra ``io``)
=========================  ====================================================

CSV text is UTF-8 (a leading byte-order mark, as spreadsheets write, is dropped) or
UTF-16 with its byte-order mark; other encodings are refused with the line of the first
byte that is not UTF-8.  Numbers take a decimal point: a decimal comma is refused with a
hint, as are digit separators and numbers beyond the float64 range; a spreadsheet's
``sep=;`` first line sets the delimiter.  A plain text (numbers only, every line with the
header's fields) is parsed by :func:`numpy.loadtxt`'s compiled reader; any other text,
and every error, by a reader that checks field by field and names the line and column.

A variable may be stored as a row or a column (``(1, N)``, ``(N, 1)`` or ``(N,)``);
anything with more than one non-singleton dimension is refused.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_step

__all__ = [
    "Record",
    "read_columns",
    "read_record",
    "SUFFIXES",
    "open_chunked",
]

Array = NDArray[np.float64]

SUFFIXES: dict[str, str] = {
    ".csv": "csv",
    ".txt": "csv",
    ".tsv": "csv",
    ".dat": "csv",
    ".mat": "mat",
    ".npz": "npz",
    ".parquet": "parquet",
    ".pq": "parquet",
    ".h5": "hdf5",
    ".hdf5": "hdf5",
    ".hdf": "hdf5",
}


@dataclass
class Record:
    """A measured record and the names its signals were read from.

    Parameters
    ----------
    t : ndarray, shape (Ns,)
        Sample times, strictly increasing.
    u : ndarray, shape (Ns, m), or None
        Input (``None`` for a time series).
    y : ndarray, shape (Ns, l)
        Output.
    inputs : list of str
        The input columns.
    outputs : list of str
        The output columns.
    time : str or None
        The time column; ``None`` when ``t`` was built from ``dt``.
    source : str
        The file read.
    dt : float or None, optional
        The sampling interval given instead of a time column.
    extra : dict, optional
        Further information a reader keeps.
    """

    t: Array
    u: Array | None
    y: Array
    inputs: list[str]
    outputs: list[str]
    time: str | None
    source: str
    dt: float | None = None
    extra: dict[str, Any] = field(default_factory=dict)

    def as_tuple(self) -> tuple[Array, Array | None, Array]:
        """The record as :func:`hdpbsid.identify` takes it.

        Returns
        -------
        tuple
            ``(t, u, y)``.
        """
        return self.t, self.u, self.y

    def __repr__(self) -> str:
        step = f"time column {self.time!r}" if self.time else f"dt={self.dt:g}"
        return (
            f"Record({self.source!r}, {self.t.size} samples, {step}, inputs {self.inputs}, "
            f"outputs {self.outputs})"
        )


def _fmt(path: Path) -> str:
    fmt = SUFFIXES.get(path.suffix.lower())
    if fmt is None:
        raise ValueError(
            f"{path}: unknown file type {path.suffix!r}; expected one of "
            f"{sorted(SUFFIXES)} (CSV, MATLAB .mat, NumPy .npz, Parquet, HDF5)"
        )
    return fmt


def _missing(path: Path, columns: Sequence[str], available: Sequence[str]) -> None:
    missing = [c for c in columns if c not in available]
    if missing:
        raise ValueError(f"{path}: unknown column(s) {missing}; the file has {list(available)}")


def _vector(path: Path, name: str, values: Any) -> Array:
    """A named variable as a float vector; refuses text, complex, matrices, non-finite."""
    arr = np.asarray(values)
    if arr.dtype.kind not in "biuf":
        raise ValueError(f"{path}: column {name!r} holds {arr.dtype} values, expected real numbers")
    if sum(s > 1 for s in arr.shape) > 1:
        raise ValueError(
            f"{path}: column {name!r} has shape {arr.shape}, expected a vector "
            f"(one value per sample); store each signal as its own variable"
        )
    arr = arr.astype(np.float64).reshape(-1)
    bad = ~np.isfinite(arr)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(
            f"{path}: column {name!r} has {int(bad.sum())} missing/NaN/inf value(s) "
            f"(first at sample {k}: {float(arr[k])!r}); fill or cut them before identifying"
        )
    return arr


# -- readers ------------------------------------------------------------------------------
_DECIMAL_COMMA = re.compile(r"[+-]?(\d{1,3}(\.\d{3})+|\d*),\d+([eE][+-]?\d+)?")
_SEP_LINE = re.compile(r"sep=(.)")


def _decode(path: Path, raw: bytes) -> str:
    """The text of a CSV file: UTF-8 (a byte-order mark, as spreadsheets write, is
    dropped) or UTF-16 with its byte-order mark (a spreadsheet's "Unicode text"); any
    other encoding is refused with the position of the first byte that is not UTF-8,
    since guessing it could rename the columns."""
    if raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        try:
            return raw.decode("utf-16")
        except UnicodeDecodeError as exc:
            raise ValueError(f"{path}: starts like UTF-16 text but is not: {exc}") from exc
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise ValueError(
            f"{path}: not a UTF-8 text (CSV) file: byte 0x{raw[exc.start]:02x} on line {line} "
            f"(offset {exc.start}) is not UTF-8; save the file as UTF-8 text (a spreadsheet's "
            f"'CSV UTF-8'), or store the data as .npz / .mat / .parquet / .h5"
        ) from exc


def _cell_value(path: Path, lineno: int, column: str, cell: str) -> float:
    """One CSV field as a finite float; ``ValueError`` naming the file, line and column
    (with a hint for a decimal comma) otherwise."""
    where = f"{path}: line {lineno}, column {column!r}"
    if cell == "":
        raise ValueError(f"{where}: missing value")
    try:
        value = float(cell)
    except ValueError:
        value = None
    if value is None or "_" in cell or not cell.isascii():  # float() takes '1_0', '١'
        hint = ""
        if _DECIMAL_COMMA.fullmatch(cell):
            hint = (
                "; this looks like a decimal comma: the reader takes decimal points "
                "('1.5'), so export the file with a decimal point (the spreadsheet's "
                "locale or number format) or replace the commas"
            )
        raise ValueError(f"{where}: not a number: {cell!r}{hint}")
    if not np.isfinite(value):
        what = "NaN" if np.isnan(value) else "infinite"
        if not cell.strip("+-").lower().startswith(("inf", "nan")):
            what = "beyond the float64 range (1.8e308)"
        raise ValueError(
            f"{where}: {cell!r} is {what}; fill or cut such samples before identifying"
        )
    return value


def _field_count_error(
    path: Path, lineno: int, row: list[str], header: list[str], delimiter: str
) -> str:
    msg = f"{path}: line {lineno} has {len(row)} field(s), the header {len(header)}"
    if delimiter == "," and len(row) > len(header):
        msg += (
            "; if the numbers have decimal commas ('1,5'), the commas split them: export "
            "the file with decimal points, or with ';' between the fields"
        )
    return msg


#: characters that end a line for :meth:`str.splitlines` besides ``\n`` and ``\r``: a body
#: holding any of them is left to the checked reader, whose line numbers count them
_OTHER_LINE_ENDS = ("\x0b", "\x0c", "\x1c", "\x1d", "\x1e", "\x85", "\u2028", "\u2029")
#: characters of the text scanned for the header (comment, blank and ``sep=`` lines first)
_HEAD_CHARS = 1 << 16


def _data_lines(text: str) -> list[tuple[int, str]]:
    """``(line number, line)`` of the lines that are neither blank nor ``#`` comments."""
    return [
        (no, ln)
        for no, ln in enumerate(text.splitlines(), start=1)
        if ln.strip() and not ln.lstrip().startswith("#")
    ]


def _csv_header(
    path: Path, lines: list[tuple[int, str]], delimiter: str | None
) -> tuple[list[str], str, int]:
    """The header row of the data lines ``lines`` (a spreadsheet's ``sep=;`` line first
    sets the delimiter), the delimiter (sniffed unless given) and the index of the header
    in ``lines``; ``ValueError`` for an empty file or a name used twice."""
    first = 0
    if lines and _SEP_LINE.fullmatch(lines[0][1].strip()):  # a spreadsheet's "sep=;" line
        delimiter = delimiter or _SEP_LINE.fullmatch(lines[0][1].strip()).group(1)
        first = 1
    if len(lines) <= first:
        raise ValueError(f"{path}: empty file; expected a header row and data rows")
    if delimiter is None:
        try:
            delimiter = csv.Sniffer().sniff(lines[first][1], delimiters=",;\t ").delimiter
        except csv.Error:
            delimiter = ","
    row = next(csv.reader([lines[first][1]], delimiter=delimiter, skipinitialspace=True))
    header = [h.strip() for h in row]
    dup = sorted({h for h in header if h and header.count(h) > 1})
    if dup:
        raise ValueError(f"{path}: the header names column(s) {dup} more than once")
    return header, delimiter, first


def _read_csv(path: Path, columns: Sequence[str], delimiter: str | None) -> dict[str, Array]:
    text = _decode(path, path.read_bytes())
    fast = _read_csv_fast(path, text, columns, delimiter)
    return fast if fast is not None else _read_csv_checked(path, text, columns, delimiter)


def _read_csv_fast(
    path: Path, text: str, columns: Sequence[str], delimiter: str | None
) -> dict[str, Array] | None:
    """The columns of a plain CSV text parsed by :func:`numpy.loadtxt` (its C reader), or
    ``None`` when the text is not plain or does not parse, for :func:`_read_csv_checked`
    to read (and to name the line of the problem).

    The header is found and checked as the checked reader does (an unknown column is
    named before the rows are read).  Plain: no comment lines, quotes or other line ends
    after the header; every non-blank line with as many fields as the header (counted
    here: :func:`numpy.loadtxt` ignores the fields after the selected ones); every
    selected value finite.  On such a text both readers return the same numbers: both
    parse a field with the correctly rounded ``PyOS_string_to_double`` after stripping
    its spaces, and what :func:`numpy.loadtxt` refuses (underscores, non-ASCII digits,
    decimal commas, empty fields) goes to the checked reader.
    """
    found = _plain_header(path, text, delimiter)
    if found is None:
        return None
    header, delimiter, body = found
    _missing(path, columns, header)
    if not _plain_body(body, delimiter, len(header)):
        return None
    use = [header.index(c) for c in columns]
    try:
        values = np.loadtxt(
            io.StringIO(body), delimiter=delimiter, comments=None, usecols=use, ndmin=2
        )
    except ValueError:
        return None
    if values.shape[0] == 0 or not np.isfinite(values).all():
        return None
    return {c: np.ascontiguousarray(values[:, i]) for i, c in enumerate(columns)}


def _plain_header(
    path: Path, text: str, delimiter: str | None
) -> tuple[list[str], str, str] | None:
    """``(header, delimiter, body)`` of a CSV text whose header lies in its first
    :data:`_HEAD_CHARS` characters (found as the checked reader finds it); None when the
    header is not complete there."""
    head = text[:_HEAD_CHARS].splitlines(keepends=True)
    lines = [(k, ln) for k, ln in enumerate(head) if ln.strip() and not ln.lstrip().startswith("#")]
    if len(text) > _HEAD_CHARS:
        lines = lines[:2]  # the "sep=" line and the header: complete only when not the last
        if len(lines) < 2 or lines[-1][0] == len(head) - 1:
            return None
    header, delimiter, first = _csv_header(
        path, [(k, ln.rstrip("\r\n")) for k, ln in lines], delimiter
    )
    body = text[sum(len(ln) for ln in head[: lines[first][0] + 1]) :]
    return header, delimiter, body


def _plain_body(body: str, delimiter: str, fields: int) -> bool:
    """Whether :func:`numpy.loadtxt` reads ``body`` as the checked reader would: a
    one-character ASCII delimiter that is no quote, comment or line end; no quotes,
    comments or other line ends; every non-blank line with ``fields`` fields."""
    return (
        len(delimiter) == 1
        and delimiter.isascii()
        and delimiter not in "\r\n\"'#"
        and bool(body.strip())
        and not any(c in body for c in ('"', "'", "#", *_OTHER_LINE_ENDS))
        and _fields_match(body, delimiter, fields)
    )


def _fields_match(body: str, delimiter: str, fields: int) -> bool:
    """Whether every line of ``body`` that is not blank (empty or a lone ``\\r``) has
    ``fields`` fields separated by the one-character ``delimiter``."""
    raw = np.frombuffer(body.encode(), dtype=np.uint8)
    bounds = np.concatenate([[-1], np.flatnonzero(raw == ord("\n")), [raw.size]])
    length = np.diff(bounds) - 1  # line i: raw[bounds[i] + 1 : bounds[i + 1]]
    last = raw[np.clip(bounds[1:] - 1, 0, None)] if raw.size else np.zeros(length.size)
    length -= (length > 0) & (last == ord("\r"))  # a Windows line end is no content
    per_line = np.diff(np.searchsorted(np.flatnonzero(raw == ord(delimiter)), bounds))
    return bool(np.all(per_line[length > 0] == fields - 1) and np.all(per_line[length == 0] == 0))


def _read_csv_checked(
    path: Path, text: str, columns: Sequence[str], delimiter: str | None
) -> dict[str, Array]:
    """The columns of a CSV text read field by field, every field checked (the line and
    column of the first bad one in the error)."""
    lines = _data_lines(text)
    header, delimiter, first = _csv_header(path, lines, delimiter)
    lines = lines[first:]
    rows = list(csv.reader([ln for _, ln in lines], delimiter=delimiter, skipinitialspace=True))
    _missing(path, columns, header)
    if len(rows) < 2:
        raise ValueError(f"{path}: has a header but no data rows")
    out: dict[str, Array] = {}
    for c in columns:
        j = header.index(c)
        vals = np.empty(len(rows) - 1)
        for r, row in enumerate(rows[1:]):
            lineno = lines[r + 1][0]
            if len(row) != len(header):
                raise ValueError(_field_count_error(path, lineno, row, header, delimiter))
            vals[r] = _cell_value(path, lineno, c, row[j].strip())
        out[c] = _vector(path, c, vals)
    return out


def _read_mat(path: Path, columns: Sequence[str]) -> dict[str, Array]:
    from scipy.io import loadmat

    try:
        data = loadmat(str(path), squeeze_me=False)
    except NotImplementedError:  # MATLAB v7.3 = HDF5
        return _read_hdf5(path, columns)
    except (ValueError, TypeError, OSError) as exc:
        raise ValueError(f"{path}: not a readable MATLAB file: {exc}") from exc
    names = [k for k in data if not k.startswith("__")]
    if not names:
        raise ValueError(f"{path}: empty file (no variables); expected one vector per signal")
    _missing(path, columns, names)
    return {c: _vector(path, c, data[c]) for c in columns}


def _read_npz(path: Path, columns: Sequence[str]) -> dict[str, Array]:
    try:
        data = np.load(path, allow_pickle=False)
    except (ValueError, OSError) as exc:
        raise ValueError(f"{path}: not a readable NumPy .npz file: {exc}") from exc
    with data:
        names = list(data.files)
        if not names:
            raise ValueError(f"{path}: empty file (no arrays); expected one vector per signal")
        _missing(path, columns, names)
        try:
            return {c: _vector(path, c, data[c]) for c in columns}
        except ValueError as exc:
            if "pickled" in str(exc) or "allow_pickle" in str(exc):
                raise ValueError(f"{path}: a column holds Python objects, not numbers") from exc
            raise


def _optional(module: str) -> Any:
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise ImportError(
            f"reading this file needs {module.split('.')[0]}: pip install 'slbasis-hdpbsid[io]'"
        ) from exc


def _read_parquet(path: Path, columns: Sequence[str]) -> dict[str, Array]:
    pq = _optional("pyarrow.parquet")
    try:
        schema = pq.read_schema(str(path))
    except Exception as exc:  # pyarrow raises its own ArrowInvalid / OSError types
        raise ValueError(f"{path}: not a readable Parquet file: {exc}") from exc
    _missing(path, columns, schema.names)
    table = pq.read_table(str(path), columns=list(columns))
    if table.num_rows == 0:
        raise ValueError(f"{path}: empty file (no rows)")
    out = {}
    for c in columns:
        col = table.column(c)
        if col.null_count:
            first = next(i for i, v in enumerate(col.to_pylist()) if v is None)
            raise ValueError(
                f"{path}: column {c!r} has {col.null_count} missing value(s) "
                f"(first at sample {first})"
            )
        out[c] = _vector(path, c, col.to_numpy(zero_copy_only=False))
    return out


def _read_hdf5(path: Path, columns: Sequence[str]) -> dict[str, Array]:
    h5py = _optional("h5py")
    try:
        f = h5py.File(str(path), "r")
    except OSError as exc:
        raise ValueError(f"{path}: not a readable HDF5 file: {exc}") from exc
    with f:
        names: list[str] = []
        f.visititems(lambda n, obj: names.append(n) if isinstance(obj, h5py.Dataset) else None)
        if not names:
            raise ValueError(f"{path}: empty file (no datasets); expected one vector per signal")
        _missing(path, [c.strip("/") for c in columns], names)
        return {c: _vector(path, c, f[c.strip("/")][()]) for c in columns}


def read_columns(
    path: str | Path, columns: Sequence[str], delimiter: str | None = None
) -> dict[str, Array]:
    r"""The named columns of a file as float vectors of equal length (module docstring).

    Parameters
    ----------
    path : str or path-like
        A CSV-like text, ``.mat``, ``.npz``, Parquet or HDF5 file (:data:`SUFFIXES`).
    columns : sequence of str
        Column, variable or dataset names, each once.
    delimiter : str or None, optional
        The CSV delimiter; sniffed (``, ; tab`` space) when ``None``.

    Returns
    -------
    dict of str to ndarray
        One 1-D float64 vector per column, all of the same length.

    Raises
    ------
    ValueError
        Naming the file (and the column and line where it applies): a missing file, an
        unknown type, an unknown column (the message lists the available ones), a column
        selected twice, non-numeric, missing or non-finite values, a non-vector variable,
        columns of different lengths, an empty file, or an unreadable file.
    ImportError
        When the Parquet / HDF5 reader is not installed (extra ``io``).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = pathlib.Path(tmp) / "r.csv"
    ...     _ = path.write_text("t;u;y\n0;1;2\n0.1;1;2.5\n")  # the delimiter is sniffed
    ...     cols = read_columns(path, ["y", "t"])
    >>> {k: v.tolist() for k, v in cols.items()}
    {'y': [2.0, 2.5], 't': [0.0, 0.1]}
    """
    path = Path(path)
    _check_file(path, "data file")
    columns = list(columns)
    dup = sorted({c for c in columns if columns.count(c) > 1})
    if dup:
        raise ValueError(f"{path}: column(s) {dup} selected more than once")
    fmt = _fmt(path)
    try:
        if fmt == "csv":
            out = _read_csv(path, columns, delimiter)
        elif fmt == "mat":
            out = _read_mat(path, columns)
        elif fmt == "npz":
            out = _read_npz(path, columns)
        elif fmt == "parquet":
            out = _read_parquet(path, columns)
        else:
            out = _read_hdf5(path, columns)
    except OSError as exc:  # permissions, a file that vanished, a device error
        raise ValueError(f"{path}: cannot read the file: {exc.strerror or exc}") from exc
    lengths = {c: v.size for c, v in out.items()}
    if len(set(lengths.values())) > 1:
        raise ValueError(f"{path}: the columns have different lengths {lengths}")
    if any(n == 0 for n in lengths.values()):
        raise ValueError(f"{path}: empty columns {lengths}; expected samples")
    return out


def _check_file(path: Path, what: str) -> None:
    """``ValueError`` unless ``path`` is an existing regular file (a directory is named
    as such: "not found" would mislead)."""
    if path.is_dir():
        raise ValueError(f"{path}: is a directory; give the {what} inside it")
    if not path.is_file():
        raise ValueError(f"{what} not found: {path}")


def _check_times(path: Path, name: str, t: Array) -> None:
    d = np.diff(t)
    if np.any(d <= 0):
        k = int(np.argmax(d <= 0))
        what = "repeated" if d[k] == 0 else "decreasing (unsorted)"
        raise ValueError(
            f"{path}: time column {name!r} must be strictly increasing, but samples {k} and "
            f"{k + 1} have {what} times {float(t[k])!r}, {float(t[k + 1])!r}; sort the "
            f"record or drop the duplicate"
        )


def read_record(
    path: str | Path,
    inputs: Sequence[str],
    outputs: Sequence[str],
    time: str | None = "t",
    dt: float | None = None,
    fs: float | None = None,
    delimiter: str | None = None,
) -> Record:
    r"""Read an identification record ``(t, u, y)`` from a file.

    Parameters
    ----------
    path : str or path-like
        The file (:func:`read_columns`).
    inputs : sequence of str
        Input columns; may be empty (a time series).
    outputs : sequence of str
        Output columns, at least one.
    time : str or None, optional
        The time column; ``None`` when ``dt`` or ``fs`` is given.
    dt : float or None, optional
        Sampling interval: ``t = k dt``.
    fs : float or None, optional
        Sampling rate, ``dt = 1 / fs``.  Exactly one of ``time``, ``dt``, ``fs``.
    delimiter : str or None, optional
        The CSV delimiter (sniffed when ``None``).

    Returns
    -------
    Record
        ``t``, ``u`` (``None`` without inputs), ``y`` and the names.

    Raises
    ------
    ValueError
        As :func:`read_columns` does, and for unsorted or repeated times, fewer than two
        samples, a column used twice, no output, a missing time column (the message says
        how to give ``dt`` instead), or both or none of a time column and ``dt``/``fs``.
    TypeError
        If ``dt`` or ``fs`` is not a number.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = pathlib.Path(tmp) / "r.csv"
    ...     _ = path.write_text("force,pos\n1.0,0.0\n1.0,0.1\n0.0,0.3\n")
    ...     rec = read_record(path, inputs=["force"], outputs=["pos"], time=None, fs=100.0)
    >>> rec.t.tolist(), rec.u.shape, rec.y.shape
    ([0.0, 0.01, 0.02], (3, 1), (3, 1))
    """
    path = Path(path)
    inputs, outputs = list(inputs), list(outputs)
    if not outputs:
        raise ValueError("outputs: name at least one output column")
    step = _sampling_step(dt, fs)
    if step is not None and time is not None:
        raise ValueError(
            f"give either a time column ({time!r}) or the sampling interval (dt/fs), not both"
        )
    if step is None and time is None:
        raise ValueError("no time: name the time column or give the sampling interval dt/fs")
    used = ([time] if time is not None else []) + inputs + outputs
    twice = sorted({c for c in used if used.count(c) > 1})
    if twice:
        raise ValueError(f"columns used twice (time/inputs/outputs): {twice}")
    cols = _read_with_time_hint(path, used, delimiter, time)
    ns = next(iter(cols.values())).size
    if ns < 2:
        raise ValueError(f"{path}: {ns} sample(s); a record needs at least 2")
    if time is not None:
        t = cols[time]
        _check_times(path, time, t)
    else:
        t = step * np.arange(ns)
    u = np.column_stack([cols[c] for c in inputs]) if inputs else None
    y = np.column_stack([cols[c] for c in outputs])
    return Record(t, u, y, inputs, outputs, time, str(path), dt=step)


def _sampling_step(dt: Any, fs: Any) -> float | None:
    """The sampling interval from ``dt`` or ``fs`` (at most one given), checked; None when
    neither is given."""
    if dt is not None and fs is not None:
        raise ValueError("give the sampling interval dt or the rate fs, not both")
    if dt is None and fs is None:
        return None
    return check_step(dt, "dt") if dt is not None else 1.0 / check_step(fs, "fs")


def _read_with_time_hint(
    path: Path, used: list[str], delimiter: str | None, time: str | None
) -> dict[str, Array]:
    """:func:`read_columns`; a missing time column's error says how to give ``dt``."""
    try:
        return read_columns(path, used, delimiter)
    except ValueError as exc:
        head = str(exc).split(";")[0]  # "<path>: unknown column(s) [...]"
        if time is not None and "unknown column" in head and f"'{time}'" in head:
            raise ValueError(
                f"{exc}; if the file has no time column, give the sampling interval "
                f"(dt=..., command line --dt or --fs)"
            ) from exc
        raise


# -- records read in chunks (larger than memory) -----------------------------------------
class _Hdf5Chunks:
    """Picklable reader of samples ``a..b-1`` of HDF5 vector datasets (the file is
    opened per read, so it can run on any worker of a cluster)."""

    def __init__(self, path: str, inputs: list[str], outputs: list[str]) -> None:
        self.path, self.inputs, self.outputs = path, inputs, outputs

    def __call__(self, a: int, b: int) -> tuple[Array, Array]:
        h5py = _optional("h5py")
        with h5py.File(self.path, "r") as f:
            u = [np.asarray(f[c.strip("/")][a:b], dtype=float).ravel() for c in self.inputs]
            y = [np.asarray(f[c.strip("/")][a:b], dtype=float).ravel() for c in self.outputs]
        return (np.column_stack(u) if u else np.zeros((b - a, 0))), np.column_stack(y)


class _NpyChunks:
    """Picklable reader of rows ``a..b-1`` of a 2-D ``.npy`` array, memory-mapped per
    read; ``inputs``/``outputs`` are column indices."""

    def __init__(self, path: str, inputs: list[int], outputs: list[int]) -> None:
        self.path, self.inputs, self.outputs = path, inputs, outputs

    def __call__(self, a: int, b: int) -> tuple[Array, Array]:
        x = np.load(self.path, mmap_mode="r")
        return (
            np.array(x[a:b, self.inputs], dtype=float),
            np.array(x[a:b, self.outputs], dtype=float),
        )


class _ParquetChunks:
    """Picklable reader of rows ``a..b-1`` of Parquet columns (only the row groups that
    overlap ``a..b-1`` are read)."""

    def __init__(self, path: str, inputs: list[str], outputs: list[str]) -> None:
        self.path, self.inputs, self.outputs = path, inputs, outputs
        pq = _optional("pyarrow.parquet")
        meta = pq.ParquetFile(path).metadata
        sizes = [meta.row_group(i).num_rows for i in range(meta.num_row_groups)]
        self.starts = np.concatenate([[0], np.cumsum(sizes)]).astype(int)

    def __call__(self, a: int, b: int) -> tuple[Array, Array]:
        pq = _optional("pyarrow.parquet")
        g0 = int(np.searchsorted(self.starts, a, side="right")) - 1
        g1 = int(np.searchsorted(self.starts, b, side="left"))
        table = pq.ParquetFile(self.path).read_row_groups(
            list(range(g0, g1)), columns=self.inputs + self.outputs
        )
        off = a - int(self.starts[g0])

        def cols(names: list[str]) -> Array:
            if not names:
                return np.zeros((b - a, 0))
            return np.column_stack(
                [table.column(c).to_numpy()[off : off + b - a].astype(float) for c in names]
            )

        return cols(self.inputs), cols(self.outputs)


def open_chunked(
    path: str | Path,
    inputs: Sequence[Any],
    outputs: Sequence[Any],
    dt: float | None = None,
    fs: float | None = None,
    t0: float = 0.0,
) -> Any:
    """A uniformly sampled record in a file, read chunk by chunk during identification.

    Nothing but the lengths is read here.

    Parameters
    ----------
    path : str or path-like
        ``.h5 .hdf5 .hdf`` (vector datasets), ``.parquet .pq`` (columns, read by row group)
        or ``.npy`` (a memory-mapped 2-D ``(Ns, channels)`` array).
    inputs : sequence
        Dataset paths ``group/name``, column names, or column indices for ``.npy``; may be
        empty.
    outputs : sequence
        As ``inputs``, at least one.
    dt : float or None, optional
        Sampling interval.
    fs : float or None, optional
        Sampling rate; exactly one of ``dt`` and ``fs``.
    t0 : float, optional
        Absolute time of the first sample.

    Returns
    -------
    ChunkedRecord
        For :func:`hdpbsid.methods.chunked.identify_chunked`.

    Raises
    ------
    ValueError
        For a missing file, an unknown suffix, missing signals, signals of different
        lengths, a ``.npy`` that is not 2-D or an index outside it, no output, or not
        exactly one of ``dt``/``fs``.
    TypeError
        If a ``.npy`` column is not an integer index.
    ImportError
        When the HDF5 / Parquet reader is not installed (extra ``io``).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> with tempfile.TemporaryDirectory() as tmp:
    ...     path = pathlib.Path(tmp) / "r.npy"
    ...     np.save(path, np.arange(30.0).reshape(10, 3))
    ...     rec = open_chunked(path, inputs=[0], outputs=[1, 2], dt=0.5)
    ...     first = rec.checked(0, 2)[1].tolist()  # read while the file exists
    >>> rec.ns, rec.m, rec.l, first
    (10, 1, 2, [[1.0, 2.0], [4.0, 5.0]])
    """
    from hdpbsid.data.chunked import ChunkedRecord

    path = Path(path)
    _check_file(path, "data file")
    if dt is None and fs is None:
        raise ValueError("give exactly one of the sampling interval dt and the rate fs")
    step = _sampling_step(dt, fs)
    inputs, outputs = list(inputs), list(outputs)
    if not outputs:
        raise ValueError("outputs: name at least one output")
    suffix = path.suffix.lower()
    kind = "npy" if suffix == ".npy" else SUFFIXES.get(suffix)
    if kind not in _CHUNK_OPENERS:
        raise ValueError(
            f"{path}: chunked reading supports .npy, HDF5 (.h5 .hdf5 .hdf) and Parquet "
            f"(.parquet .pq), got {path.suffix!r}"
        )
    reader, ns = _CHUNK_OPENERS[kind](path, inputs, outputs)
    return ChunkedRecord(reader, ns, len(inputs), len(outputs), step, t0)


def _open_npy(path: Path, inputs: list[Any], outputs: list[Any]) -> tuple[_NpyChunks, int]:
    """The reader of a 2-D ``.npy`` array and its length; columns are integer indices."""
    x = np.load(path, mmap_mode="r")
    if x.ndim != 2:
        raise ValueError(f"{path}: expected a 2-D (Ns, channels) array, got shape {x.shape}")
    for c in inputs + outputs:
        if isinstance(c, bool) or not isinstance(c, int | np.integer):
            raise TypeError(f"{path}: .npy columns are integer indices, got {c!r}")
        if not 0 <= int(c) < x.shape[1]:
            raise ValueError(f"{path}: column index {c} outside 0..{x.shape[1] - 1}")
    reader = _NpyChunks(str(path), [int(c) for c in inputs], [int(c) for c in outputs])
    return reader, int(x.shape[0])


def _open_hdf5(path: Path, inputs: list[Any], outputs: list[Any]) -> tuple[_Hdf5Chunks, int]:
    """The reader of HDF5 vector datasets and their common length."""
    h5py = _optional("h5py")
    with h5py.File(str(path), "r") as f:
        lengths = {}
        for c in inputs + outputs:
            key = str(c).strip("/")
            if key not in f or not isinstance(f[key], h5py.Dataset):
                raise ValueError(f"{path}: no dataset {c!r}")
            shape = f[key].shape
            if sum(s > 1 for s in shape) > 1:
                raise ValueError(f"{path}: dataset {c!r} is not a vector (shape {shape})")
            lengths[c] = int(np.prod(shape))
    reader = _Hdf5Chunks(str(path), [str(c) for c in inputs], [str(c) for c in outputs])
    return reader, _equal_lengths(path, lengths)


def _open_parquet(path: Path, inputs: list[Any], outputs: list[Any]) -> tuple[_ParquetChunks, int]:
    """The reader of Parquet columns and the number of rows."""
    pf = _optional("pyarrow.parquet").ParquetFile(str(path))
    _missing(path, inputs + outputs, pf.schema_arrow.names)
    reader = _ParquetChunks(str(path), [str(c) for c in inputs], [str(c) for c in outputs])
    return reader, int(pf.metadata.num_rows)


#: How :func:`open_chunked` opens each kind of file: ``(reader, Ns)``.
_CHUNK_OPENERS: dict[str | None, Callable[[Path, list[Any], list[Any]], tuple[Any, int]]] = {
    "npy": _open_npy,
    "hdf5": _open_hdf5,
    "parquet": _open_parquet,
}


def _equal_lengths(path: Path, lengths: dict[Any, int]) -> int:
    if len(set(lengths.values())) > 1:
        raise ValueError(f"{path}: the signals have different lengths {lengths}")
    return next(iter(lengths.values()))
