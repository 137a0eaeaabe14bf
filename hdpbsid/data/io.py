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
and every error, by a reader that checks field by field and names the line and column
(:mod:`hdpbsid.data.csv_reader`).

A variable may be stored as a row or a column (``(1, N)``, ``(N, 1)`` or ``(N,)``);
anything with more than one non-singleton dimension is refused.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hdpbsid.data.checks import check_step
from hdpbsid.data.csv_reader import _missing, _read_csv, _vector

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


# -- readers ------------------------------------------------------------------------------
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
