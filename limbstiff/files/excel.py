"""Excel workbooks (``.xlsx``): one worksheet read like a delimited text trial.

Scope: the first worksheet, or the one the protocol's ``[format] sheet`` names, read with
openpyxl (``read_only``, ``data_only``: a formula's saved value, never the formula). The layout
is the text format's (docs/interface.md section 1): ``# key: value`` metadata rows (in one cell,
or ``# key`` beside its value), one header row, an optional unit row (detected as in text, or
``[format] unit_row``), one row per sample; blank rows are skipped. Columns are matched, units
checked and values validated as for CSV (:mod:`limbstiff.files.columns`,
:func:`limbstiff.files.validate.checked_trial`). Every used cell must be a number: a text cell,
an empty one or a date is a one-line error naming the row and column as Excel shows them.
Old binary workbooks (``.xls``) are refused by :mod:`limbstiff.files.read`.
"""

from __future__ import annotations

import io
import math
from pathlib import Path
from typing import Iterator, NamedTuple

import numpy as np

from ..errors import TrialError
from ..trial import Trial
from ..units import UNITS
from .column_units import in_si, joint_kind, schedule_unit, units_written
from .columns import READ_FIELDS, ColumnSpec, resolve_columns
from .dialect import is_number, looks_like, shown, unit_cell
from .validate import checked_trial, empty_block


def read_xlsx(path: Path, raw: bytes, protocol=None, *, name: str | None = None) -> Trial:
    """Read one worksheet of an ``.xlsx`` workbook into a checked Trial (the reader of
    :class:`~limbstiff.files.read.FileType` for ``.xlsx``).

    Parameters
    ----------
    path : Path
    raw : bytes
        Its content (an Office Open XML workbook: a ZIP archive).
    protocol : Protocol or None
        Maps headers, units, scales and signs (``columns``); ``sheet`` names the worksheet
        (None: the first); ``unit_row`` replaces the detection; ``sample_period`` (s) resamples.
    name : str or None

    Returns
    -------
    Trial
        The mapped columns; ``# key: value`` rows above the header as metadata.

    Raises
    ------
    TrialError
        Not a workbook (or a damaged one), no such worksheet, no header or data rows, a
        duplicated header, a missing unit row, or a cell that is not a number.
    """
    where = str(path)
    if not raw.startswith(b"PK\x03\x04"):
        kind = looks_like(raw)
        kind = f"it looks like {kind}" if kind else "it is not a ZIP archive"
        raise TrialError(where, f"not an .xlsx workbook ({kind}): save it from Excel as .xlsx, or export CSV")
    workbook = _open(where, raw)
    try:
        rows = _rows(_worksheet(where, workbook, getattr(protocol, "sheet", None)))
        top = _top(where, rows, getattr(protocol, "unit_row", "auto"))
        columns = resolve_columns(where, top.headers, protocol, units=top.units)
        kind = joint_kind(where, columns)
        numbers, cells = _cells(rows, top.first, columns)
    except TrialError:
        raise
    except Exception as exc:  # noqa: BLE001 — read-only sheets are parsed lazily: a damaged sheet fails here
        raise TrialError(where, f"cannot be read as an .xlsx workbook ({type(exc).__name__} in a worksheet): open "
                                "it in Excel and save it as .xlsx again, or export CSV") from None
    finally:
        workbook.close()
    if not numbers:
        raise TrialError(where, "no data rows below the header")
    values = _values(where, columns, numbers, cells)
    used = {c.index for c in columns.values()}
    ignored = [h for i, h in enumerate(top.headers) if i not in used and h]
    warnings = ["ignored column(s): " + ", ".join(f"'{h}'" for h in ignored)] if ignored else []
    return checked_trial(path, raw, values, kind=kind, protocol=protocol, name=name, metadata=top.metadata,
                         warnings=warnings, locate=lambda k: f"row {numbers[k]}", schedule_unit=schedule_unit(columns),
                         units=units_written(columns))


def _open(where: str, raw: bytes):
    """The workbook, read-only with the formulas' saved values; a one-line error if it is not one."""
    try:
        import openpyxl
    except ImportError:       # a dependency of limbstiff: only a broken installation lacks it
        raise TrialError(where, "reading .xlsx needs openpyxl: pip install openpyxl, or export CSV") from None
    try:
        return openpyxl.load_workbook(io.BytesIO(raw), read_only=True, data_only=True)
    except Exception as exc:  # noqa: BLE001 — zipfile, XML and openpyxl errors alike: the file is damaged
        raise TrialError(where, f"cannot be read as an .xlsx workbook ({type(exc).__name__}): open it in "
                                "Excel and save it as .xlsx again, or export CSV") from None


def _worksheet(where: str, workbook, sheet: str | None):
    """The worksheet named ``sheet`` (None: the first)."""
    sheets = list(workbook.worksheets)
    names = ", ".join(f"'{shown(ws.title, 40)}'" for ws in sheets) or "none"
    if sheet is None:
        if not sheets:
            raise TrialError(where, "the workbook has no worksheet")
        return sheets[0]
    for ws in sheets:
        if ws.title == sheet:
            return ws
    raise TrialError(where, f"no sheet '{shown(sheet, 40)}' in the workbook (sheets: {names}); "
                            f"check [format] sheet in the protocol")


def _rows(ws) -> Iterator[tuple[int, tuple]]:
    """The worksheet's non-blank rows as (row number as Excel shows it, cell values)."""
    ws.reset_dimensions()     # a writer's stated dimensions may be wrong: read the cells there are
    for number, row in enumerate(ws.iter_rows(values_only=True), start=1):
        if any(v is not None and not (isinstance(v, str) and not v.strip()) for v in row):
            yield number, tuple(row)


class _Top(NamedTuple):
    """What lies above the data: metadata, headers, the unit row (or None), the first data row."""

    metadata: dict
    headers: list
    units: list | None
    first: tuple | None


def _top(where: str, rows: Iterator[tuple[int, tuple]], setting) -> _Top:
    """Metadata rows, the header row and the unit row, read from ``rows`` up to the first data row."""
    metadata: dict[str, str] = {}
    header = None
    for number, row in rows:
        cells = [c for c in row if c is not None]
        first = cells[0]
        if isinstance(first, str) and first.strip().startswith("#"):
            key, colon, value = first.strip()[1:].partition(":")
            if not colon and len(cells) > 1:
                value = str(cells[1])
            if key.strip() and (colon or len(cells) > 1):
                metadata[key.strip()] = str(value).strip()
            continue
        header = row
        break
    if header is None:
        raise TrialError(where, "no header row in the sheet")
    headers = [_text(c) for c in header]
    while headers and not headers[-1]:
        headers.pop()
    seen: dict[str, int] = {}
    for i, h in enumerate(headers):
        if h and h in seen:
            raise TrialError(where, f"duplicated column header '{shown(h, 40)}' (columns {_letter(seen[h])} "
                                    f"and {_letter(i)})")
        seen[h] = i
    following = next(rows, None)
    if following is None or setting is False:
        return _Top(metadata, headers, None, following)
    number, row = following
    texts = [_text(c) for c in row[:len(headers)]]
    numeric = [t for c, t in zip(row, texts) if t and (_is_numeric_cell(c) or is_number(t))]
    units = [unit_cell(t) for t in texts] + [None] * (len(headers) - len(texts))
    if setting == "auto" and (numeric or not any(u in UNITS for u in units)):
        return _Top(metadata, headers, None, following)
    if numeric:
        raise TrialError(where, f"row {number} should be the unit row (the protocol says unit_row = true) "
                                f"but holds the number '{shown(numeric[0], 20)}'")
    return _Top(metadata, headers, units, next(rows, None))


def _cells(rows, first, columns: dict[str, ColumnSpec]) -> tuple[list[int], dict[int, list]]:
    """The row numbers of the data rows and, by column index, the used columns' cell values."""
    used = sorted({c.index for c in columns.values()})
    numbers: list[int] = []
    cells: dict[int, list] = {i: [] for i in used}
    if first is None:
        return numbers, cells
    for number, row in _chain(first, rows):
        numbers.append(number)
        for i in used:
            cells[i].append(row[i] if i < len(row) else None)
    return numbers, cells


def _chain(first, rows):
    yield first
    yield from rows


def _values(where: str, columns: dict[str, ColumnSpec], numbers: list[int],
            cells: dict[int, list]) -> dict[str, np.ndarray | None]:
    """Numeric SI arrays of the used columns; every cell checked, none coerced."""
    values: dict[str, np.ndarray | None] = dict.fromkeys(READ_FIELDS)
    for field in READ_FIELDS:
        column = columns.get(field)
        if column is None:
            continue
        raw = cells[column.index]
        ok = [_is_numeric_cell(v) and math.isfinite(v) for v in raw]
        if not all(ok):
            k = ok.index(False)
            time = None if field == "time" else values["time"][k]
            problem = _bad_cell(raw[k], column, numbers[k], time)
            if _empty(raw[k]):
                problem += "; " + empty_block(np.array([_empty(v) for v in raw]), k, values["time"],
                                              lambda i: f"row {numbers[i]}")
            raise TrialError(where, problem)
        values[field] = in_si(np.array(raw, dtype=float), column)
    return values


def _empty(cell) -> bool:
    return cell is None or (isinstance(cell, str) and not cell.strip())


def _bad_cell(cell, column: ColumnSpec, row: int, time: float | None) -> str:
    at = f"in column '{column.header}' ({_letter(column.index)}) at row {row}"
    if time is not None:
        at += f" (t = {time:g} s)"
    if _empty(cell):
        return f"empty cell {at}"
    if isinstance(cell, str):
        hint = " (a number stored as text: format the column as numbers)" if is_number(cell.strip()) else ""
        return f"non-numeric value '{shown(cell.strip())}' {at}{hint}"
    if isinstance(cell, float) and math.isnan(cell):
        return f"NaN {at}"
    if isinstance(cell, float):
        return f"infinite value {at}"
    return f"non-numeric value '{shown(str(cell))}' {at} (a {type(cell).__name__}; format the column as numbers)"


def _is_numeric_cell(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _text(cell) -> str:
    """A header or unit cell as text, stripped (an empty cell is ``""``)."""
    if cell is None:
        return ""
    if isinstance(cell, float) and cell.is_integer():
        cell = int(cell)
    return str(cell).strip()


def _letter(index: int) -> str:
    """Excel's letters of the 0-based column ``index`` (0 → A, 26 → AA)."""
    letters = ""
    index += 1
    while index:
        index, rest = divmod(index - 1, 26)
        letters = chr(ord("A") + rest) + letters
    return letters
