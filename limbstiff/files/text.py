"""Delimited text trial files: CSV, tab- and semicolon-separated, with an optional unit row.

Scope: the text format of docs/interface.md section 1 (``# key: value`` metadata lines, one header
row of ``<quantity>_<unit>`` names or names mapped by a protocol) and its common variants:

- the delimiter (comma, tab or semicolon) is detected from the header line;
- semicolon-separated files may write numbers with a decimal comma (``1,25``), detected from
  the data;
- a row of units may follow the header (``time;angle;torque`` above ``s;deg;Nm``): it is
  detected when none of its cells is a number and at least one is a known unit, and it turns
  a plain quantity header (``angle``) into a standard one (``angle_deg``).

The protocol's ``[format]`` settings (``delimiter``, ``decimal``, ``unit_row``) replace the
detection (:mod:`limbstiff.files.dialect`). Every cell of a used column is checked; nothing is
coerced silently.
"""

from __future__ import annotations

import io
import re
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from ..errors import TrialError
from ..trial import Trial
from .column_units import in_si, joint_kind, schedule_unit, units_written
from .columns import READ_FIELDS, ColumnSpec, resolve_columns
from .dialect import DECIMAL_COMMA, SNIFF_LINES, binary_kind, detect_layout, shown
from .validate import checked_trial, empty_block

_NAN_WORDS = {"nan", "-nan", "+nan", "na", "n/a", "#n/a", "null", "none"}
_PANDAS_LINE = re.compile(r"Expected (\d+) fields in line (\d+), saw (\d+)")


def read_text(path: Path, raw: bytes, protocol=None, *, name: str | None = None) -> Trial:
    """Read one delimited text trial (``.csv``, ``.tsv``, ``.txt``) into a checked Trial (the
    reader of :class:`~limbstiff.files.read.FileType` for text).

    Parameters
    ----------
    path : Path
    raw : bytes
        Its content: UTF-8 text (BOM tolerated), ``# key: value`` metadata lines, one header
        row, an optional unit row, one row per sample.
    protocol : Protocol or None
        Maps headers, units, scales and signs (``columns``); ``delimiter``, ``decimal`` and
        ``unit_row`` replace the detection; ``sample_period`` (s) resamples.
    name : str or None

    Returns
    -------
    Trial
        The mapped columns; ``# key: value`` lines above the header as metadata.

    Raises
    ------
    TrialError
        Not text in the encoding, no header or data rows, a single column, a duplicated
        header, a missing unit row, a row of the wrong length, or a cell that is not a number.
    """
    where = str(path)
    text, notes = _decode(where, raw, getattr(protocol, "encoding", "auto"))
    source_bytes = raw
    if notes or getattr(protocol, "encoding", "auto") not in ("auto", "utf-8", "utf-8-sig", "utf8") \
            or raw[:2] in (b"\xff\xfe", b"\xfe\xff"):
        raw = text.encode("utf-8")          # the row reader and its byte offsets work on UTF-8
    body = _body(text, raw)
    if body is None:   # blank lines or bare CR line ends among the rows: line by line
        metadata, header_line, rest = _split(where, text)
    else:
        metadata, header_line, rest = body.metadata, body.header, body.head
    del text
    layout = detect_layout(where, header_line, rest, protocol)
    columns = resolve_columns(where, layout.headers, protocol, units=layout.units)
    kind = joint_kind(where, columns)
    numbers, source = _data_rows(raw, body, layout.rows, skipped=len(rest) - len(layout.rows))
    values = _parse(where, layout.headers, columns, source, numbers, layout.delimiter, layout.decimal)
    return checked_trial(path, source_bytes, values, kind=kind, protocol=protocol, name=name, metadata=metadata,
                         warnings=notes + _ignored(layout.headers, columns), locate=lambda k: f"line {numbers[k]}",
                         schedule_unit=schedule_unit(columns),
                         units=units_written(columns))


def _data_rows(raw: bytes, body: _Body | None, rows: list, skipped: int):
    """The file's line number of every data row, and a function giving a fresh file object over them.

    Parameters
    ----------
    raw : bytes
        The file's content.
    body : _Body or None
        As :func:`_body` found it; None when the rows were split line by line.
    rows : list of (int, str)
        The first data rows (all of them when ``body`` is None).
    skipped : int
        Rows of ``body.head`` above the data (the unit row).

    Returns
    -------
    numbers : sequence of int
        ``numbers[k]`` is the line number of data row k.
    source : callable
        ``source()`` gives a new text or bytes file object over the data rows.
    """
    if body is None:
        numbers = [n for n, _ in rows]
        lines = [line for _, line in rows]
        return numbers, lambda: io.StringIO("\n".join(lines))
    # the rows straight from the file's bytes: no list of lines, no second copy as text, and no
    # copy of the bytes either (a BytesIO shares the bytes object it starts from; it is read on
    # from the first data row)
    start = body.offsets[skipped]
    numbers = range(rows[0][0], rows[0][0] + body.rows - skipped)

    def source():
        rows_ = io.BytesIO(raw)
        rows_.seek(start)
        return rows_
    return numbers, source


def _ignored(headers: list[str], columns: dict[str, ColumnSpec]) -> list[str]:
    """The warning naming the columns no Trial field uses (empty list when all are used)."""
    used = {c.index for c in columns.values()}
    ignored = [h for i, h in enumerate(headers) if i not in used and h]
    return ["ignored column(s): " + ", ".join(f"'{h}'" for h in ignored)] if ignored else []


def _decode(where: str, raw: bytes, encoding: str = "auto") -> tuple[str, list[str]]:
    """The file's text and the warnings of its decoding.

    ``auto``: UTF-8 (BOM tolerated); a file that is not UTF-8 — a Windows export, ``# subject:
    Müller`` in cp1252 — is read as Windows-1252, or Latin-1 where cp1252 leaves a byte undefined,
    with a warning that says so. Any other ``encoding`` (the protocol's ``[format] encoding``) is
    used as given.
    """
    notes: list[str] = []
    if encoding == "auto" and raw[:2] in (b"\xff\xfe", b"\xfe\xff"):    # Excel's "Unicode text": UTF-16
        encoding = "utf-16"
    if encoding == "auto":
        binary_kind(where, raw)         # NUL bytes, a PNG's signature: before any decoding
    if encoding != "auto":
        try:
            text = raw.decode(encoding)
        except UnicodeDecodeError as exc:
            line = raw[:exc.start].count(b"\n") + 1
            raise TrialError(where, f"not {encoding} text (byte 0x{raw[exc.start]:02x} at line {line}); "
                                    f"check [format] encoding in the protocol") from None
        text = text.lstrip("\ufeff")
    else:
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            line = raw[:exc.start].count(b"\n") + 1
            fallback = "cp1252"
            try:
                text = raw.decode(fallback)
            except UnicodeDecodeError:
                fallback = "latin-1"
                text = raw.decode(fallback)
            notes.append(f"not UTF-8 text (byte 0x{raw[exc.start]:02x} at line {line}): read as "
                         f"{'Windows-1252' if fallback == 'cp1252' else 'Latin-1'}; set [format] encoding in "
                         "a protocol if that is wrong")
    binary_kind(where, raw if encoding == "auto" else b"", text)
    if not text or text.isspace():      # text.strip() would copy a long file's text to say so
        raise TrialError(where, "empty file")
    return text, notes


def _above_header(line: str, metadata: dict[str, str]) -> bool:
    """True for a blank or ``#`` line (above the header); a ``# key: value`` one is recorded."""
    stripped = line.strip()
    if stripped and not stripped.startswith("#"):
        return False
    key, colon, value = stripped[1:].partition(":")
    if colon and key.strip():
        metadata[key.strip()] = value.strip()
    return True


def _split(where: str, text: str):
    """Metadata, the header line, and the non-blank lines below it as (line number, line)."""
    all_lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    metadata: dict[str, str] = {}
    for k, line in enumerate(all_lines):
        if _above_header(line, metadata):
            continue
        break
    else:
        raise TrialError(where, "no header row (only '#' metadata lines)")
    rest = [(j + 1, all_lines[j]) for j in range(k + 1, len(all_lines)) if all_lines[j].strip()]
    return metadata, all_lines[k], rest


class _Body(NamedTuple):
    metadata: dict
    header: str
    head: list          # the first rows below the header, as (line number, line)
    offsets: list       # byte offset in the file of each of those rows
    rows: int           # rows below the header in all


_BLANK = re.compile(r"\n[ \t\r]*\n|\n[ \t\r]+$")
_BARE_CR = re.compile(r"\r(?!\n)")


def _body(text: str, raw: bytes) -> _Body | None:
    """Metadata, header and the first rows, with the byte offsets of those rows, for a file
    whose rows are all non-blank and end in LF or CRLF; None otherwise."""
    if _BARE_CR.search(text):
        return None
    lines = _lines(text)
    metadata: dict[str, str] = {}
    pos = 3 if raw.startswith(b"\xef\xbb\xbf") else 0    # the BOM, dropped from text
    number, header, char = 0, None, 0
    for line in lines:
        number += 1
        char += len(line)
        pos += len(line.encode("utf-8"))
        if _above_header(line, metadata):
            continue
        header = line.rstrip("\r\n")
        break
    if header is None or _BLANK.search(text, char - 1):
        return None
    head, offsets = [], []
    for line in lines:
        number += 1
        head.append((number, line.rstrip("\r\n")))
        offsets.append(pos)
        pos += len(line.encode("utf-8"))
        if len(head) > SNIFF_LINES:
            break
    rows = text.count("\n", char) + (0 if text.endswith("\n") else 1) if len(text) > char else 0
    return _Body(metadata, header, head, offsets, rows)


def _lines(text: str):
    """The lines of ``text`` with their ends, lazily (no list of millions of strings)."""
    start = 0
    while start < len(text):
        end = text.find("\n", start)
        end = len(text) if end < 0 else end + 1
        yield text[start:end]
        start = end


def _parse(where, headers, columns, source, numbers, delimiter, decimal) -> dict[str, np.ndarray | None]:
    """Numeric SI arrays of the used columns; every cell checked, none coerced silently.

    ``source()`` gives a fresh file object over the data rows; ``numbers[k]`` is the file's
    line number of row k.
    """
    used = {c.index for c in columns.values()}
    read = dict(where=where, source=source, numbers=numbers, width=len(headers), sep=delimiter, decimal=decimal)
    try:  # fast path: the used columns parse as floats (no NaN words: na_filter is off)
        frame = _read_rows(**read, dtype={i: float for i in used})
    except TrialError:
        raise
    except ValueError:  # some cell is not a number: read text, find it and say which
        frame = _read_rows(**read, dtype=object)
    values: dict[str, np.ndarray | None] = dict.fromkeys(READ_FIELDS)
    for field in READ_FIELDS:
        column = columns.get(field)
        if column is None:
            continue
        numeric = frame[column.index].to_numpy()
        if numeric.dtype != float or not np.all(np.isfinite(numeric)):
            cells = frame[column.index].astype(str).str.strip()
            if decimal == ",":
                numeric = np.array(pd.to_numeric(cells.str.replace(",", ".", regex=False), errors="coerce"),
                                   dtype=float)
                # a point in a decimal-comma file is a mistake (or a thousands mark): never a number
                numeric[cells.str.contains(".", regex=False).to_numpy()] = np.nan
            else:
                numeric = pd.to_numeric(cells, errors="coerce").to_numpy(dtype=float)
            bad = ~np.isfinite(numeric)
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                problem = _bad_cell(cells.iloc[k], numeric[k], column, numbers[k],
                                    None if field == "time" else values["time"][k], decimal)
                if cells.iloc[k] == "":
                    problem += "; " + empty_block((cells == "").to_numpy(), k, values["time"],
                                                  lambda i: f"line {numbers[i]}")
                raise TrialError(where, problem)
        values[field] = in_si(numeric, column)
    return values


def _read_rows(where, source, numbers, width, sep, decimal, dtype) -> pd.DataFrame:
    try:
        return pd.read_csv(source(), header=None, encoding="utf-8", names=list(range(width)), sep=sep,
                           decimal=decimal, index_col=False, dtype=dtype, na_filter=False,
                           skip_blank_lines=False)
    except pd.errors.ParserError as exc:
        match = _PANDAS_LINE.search(str(exc))
        if match:
            want, line, saw = (int(g) for g in match.groups())
            raise TrialError(where, f"line {numbers[line - 1]} has {saw} fields, the header has {want}") from None
        raise TrialError(where, f"cannot parse the rows ({shown(str(exc).splitlines()[-1], 200)})") from None


def _bad_cell(cell: str, number: float, column: ColumnSpec, line: int, time: float | None,
              decimal: str) -> str:
    at = f"in column '{column.header}' at line {line}"
    if time is not None:
        at += f" (t = {time:g} s)"
    quoted = shown(cell, 30)
    if cell == "":
        return f"empty cell {at}"
    if cell.lower() in _NAN_WORDS:
        return f"NaN {at}"
    if np.isinf(number):
        return f"infinite value '{quoted}' {at}"
    if decimal == "," and "." in cell:
        return f"non-numeric value '{quoted}' {at} (the file uses decimal commas)"
    if decimal == "." and DECIMAL_COMMA.match(cell):
        return (f"non-numeric value '{quoted}' {at} (a decimal comma? set decimal = \",\" "
                f"in the protocol's [format])")
    return f"non-numeric value '{quoted}' {at}"
