"""The CSV reader of :mod:`hdpbsid.data.io`: decoding, header, fast and checked parsing.

A plain text (numbers only, every line with the header's fields) is parsed by
:func:`numpy.loadtxt`'s compiled reader (:func:`_read_csv_fast`); any other text, and every
error, by a reader that checks field by field and names the line and column
(:func:`_read_csv_checked`).  Both give the same numbers: ``loadtxt`` and ``float`` round
a decimal string correctly (IEEE 754-2008, sec. 5.12).  The column checks every reader of
:mod:`hdpbsid.data.io` shares (:func:`_missing`, :func:`_vector`) are here too.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["CsvTextSettings", "CSV_TEXT"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class CsvTextSettings:
    """How much of a CSV text the fast reader scans for its header.

    Attributes
    ----------
    head_chars : int
        Characters of the text scanned for the header.
    """

    #: comment, blank and ``sep=`` lines come first: 64 KiB holds any header a person
    #: writes, and a text whose header lies beyond it goes to the checked reader
    head_chars: int = 1 << 16


#: The settings in force.
CSV_TEXT = CsvTextSettings()


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
    :attr:`CsvTextSettings.head_chars` characters (found as the checked reader finds it);
    None when the header is not complete there."""
    head = text[: CSV_TEXT.head_chars].splitlines(keepends=True)
    lines = [(k, ln) for k, ln in enumerate(head) if ln.strip() and not ln.lstrip().startswith("#")]
    if len(text) > CSV_TEXT.head_chars:
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
