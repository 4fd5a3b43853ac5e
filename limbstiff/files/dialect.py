"""How a delimited text trial file is written: delimiter, header, unit row and decimal mark.

Detected from the header line and the first rows below it (:func:`detect_layout`), or set by the
protocol's ``[format]`` (``delimiter``, ``decimal``, ``unit_row``). Reading the rows is
:mod:`limbstiff.files.text`'s.
"""

from __future__ import annotations

import csv as _csv
import re
from typing import NamedTuple

from ..errors import TrialError
from ..units import UNITS

DECIMAL_COMMA = re.compile(r"^[-+]?\d*,\d+(?:[eE][-+]?\d+)?$")
_QUOTED = re.compile(r'"[^"]*"')
_NAMES = {",": "','", ";": "';'", "\t": "tabs"}
#: Data lines looked at to detect a decimal comma (and kept with their byte offsets).
SNIFF_LINES = 50
#: Characters of a decoded file looked at for control characters (binary data).
SNIFF_CHARS = 65536
#: Control characters no text trial holds (C0 but tab, line feed and carriage return; DEL; C1).
CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]")
#: Every control character, tab and line ends included: none is ever quoted in a message.
ANY_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")
#: What a binary file that is not text starts with, and what it is.
_MAGIC = ((b"\x89PNG", "a PNG image"), (b"\xff\xd8\xff", "a JPEG image"), (b"GIF8", "a GIF image"),
          (b"%PDF", "a PDF document"), (b"PK\x03\x04", "a ZIP archive, or an .xlsx workbook"),
          (b"\xd0\xcf\x11\xe0", "an old Office file, such as an .xls workbook"),
          (b"\x1f\x8b", "a gzip archive"), (b"MATLAB", "a MATLAB .mat file"),
          (b"\x89HDF", "an HDF5 file"))


def looks_like(raw: bytes) -> str | None:
    """What a file is by the start of a known binary format (``"a PNG image"``), or None."""
    return next((what for magic, what in _MAGIC if raw.startswith(magic)), None)


def binary_kind(where: str, raw: bytes, text: str | None = None) -> None:
    """Refuse a file that is not text: one line naming the file and what to do, nothing copied
    from its content.

    Parameters
    ----------
    where : str
        File name, for the message.
    raw : bytes
        The file's content, looked at for the start of a known binary format.
    text : str or None
        Its decoded text (None before decoding), looked at for control characters in its first
        :data:`SNIFF_CHARS` characters.

    Raises
    ------
    TrialError
        ``not a text file``.
    """
    kind = looks_like(raw)
    if kind is None and text is not None and CONTROL.search(text, 0, SNIFF_CHARS):
        kind = "it holds binary data"
    elif kind is None and text is None and b"\x00" in raw[:SNIFF_CHARS]:
        kind = "it holds binary data"
        head = raw[:2000]
        for order, zeros in (("le", head[1::2]), ("be", head[0::2])):
            if len(zeros) > 8 and zeros.count(0) == len(zeros):
                raise TrialError(where, f"not UTF-8 text: it looks like UTF-16 without a byte-order mark; "
                                        f"set [format] encoding = \"utf-16-{order}\" in a protocol, or export UTF-8")
    elif kind is not None:
        kind = f"it looks like {kind}"
    if kind is not None:
        raise TrialError(where, f"not a text file ({kind}): export the trial as CSV (UTF-8 text), or give "
                                f"the file the extension of its format (.csv, .tsv, .txt, .xlsx, .mat, .c3d)")


class TextLayout(NamedTuple):
    """How the rows of a text trial are written, detected or as the protocol says.

    Parameters
    ----------
    headers : list of str
        Column headers, stripped.
    units : list of (str or None) or None
        The unit row, aligned with ``headers``; None without one.
    rows : list of (int, str)
        The first data rows (line number, line), below the unit row if any.
    delimiter : str
        ``,``, ``\\t`` or ``;``.
    decimal : str
        ``.`` or ``,``.
    """

    headers: list
    units: list | None
    rows: list
    delimiter: str
    decimal: str


def shown(cell: str, limit: int = 30) -> str:
    """A file's text as a message may quote it: at most ``limit`` characters, control characters
    written as ``\\xNN`` (a message is one printable line whatever the file holds)."""
    return ANY_CONTROL.sub(lambda m: f"\\x{ord(m.group()):02x}", cell[:limit])


def detect_layout(where: str, header_line: str, rest: list, protocol) -> TextLayout:
    """Delimiter, headers, unit row and decimal mark, from the protocol's ``[format]`` or detected
    in ``header_line`` and the first rows below it, ``rest`` (line number, line)."""
    if CONTROL.search(header_line):
        binary_kind(where, b"", header_line)
    forced = getattr(protocol, "delimiter", "auto")
    delimiter = _detect_delimiter(header_line) if forced == "auto" else forced
    headers = _headers(where, header_line, delimiter, forced=forced != "auto")
    units, rows = _unit_row(where, rest, delimiter, getattr(protocol, "unit_row", "auto"))
    if not rows:
        raise TrialError(where, "no data rows below the header")
    decimal = _detect_decimal(where, rows, delimiter, getattr(protocol, "decimal", "auto"))
    return TextLayout(headers, units, rows, delimiter, decimal)


def _detect_delimiter(line: str) -> str:
    """The most frequent of comma, tab and semicolon outside quotes (comma on a tie)."""
    bare = _QUOTED.sub("", line)
    counts = {d: bare.count(d) for d in (",", "\t", ";")}
    return max(counts, key=lambda d: (counts[d], d == ","))


def _cells(line: str, delimiter: str) -> list[str]:
    return [c.strip() for c in next(_csv.reader([line], delimiter=delimiter))]


def _headers(where: str, line: str, delimiter: str, forced: bool) -> list[str]:
    headers = _cells(line, delimiter)
    if len(headers) == 1:
        others = [d for d in (",", ";", "\t") if d != delimiter and d in headers[0]]
        if forced and others:
            raise TrialError(where, f"the header has a single column: the file is not separated by "
                                    f"{_NAMES[delimiter]} as the protocol says (it uses {_NAMES[others[0]]})")
        if len(headers[0].split()) > 1:
            raise TrialError(where, f"the header '{shown(headers[0], 40)}' is a single column: separate the "
                                    f"fields with commas, tabs or semicolons (spaces are not supported)")
    seen: dict[str, int] = {}
    for i, h in enumerate(headers):
        if h and h in seen:
            raise TrialError(where, f"duplicated column header '{h}' (columns {seen[h] + 1} and {i + 1})")
        seen[h] = i
    return headers


def unit_cell(cell: str) -> str | None:
    """A unit-row cell without brackets (``[deg]`` → ``deg``); None when empty or ``-``."""
    cell = cell.strip()
    if len(cell) > 2 and cell[0] + cell[-1] in ("[]", "()"):
        cell = cell[1:-1].strip()
    return None if cell in ("", "-") else cell


def is_number(cell: str) -> bool:
    try:
        float(cell.replace(",", "."))
    except ValueError:
        return False
    return True


def _unit_row(where: str, rest, delimiter: str, setting):
    """The unit row (a list aligned with the headers, or None) and the data lines below it.

    With ``setting == "auto"`` the first line below the header is a unit row when none of its
    cells is a number and at least one is a known unit.
    """
    if not rest or setting is False:
        return None, rest
    number, line = rest[0]
    cells = _cells(line, delimiter)
    units = [unit_cell(c) for c in cells]
    numeric = [c for c in cells if c and is_number(c)]
    if setting == "auto" and (numeric or not any(u in UNITS for u in units)):
        return None, rest
    if numeric:
        raise TrialError(where, f"line {number} should be the unit row (the protocol says unit_row = true) "
                                f"but holds the number '{shown(numeric[0], 20)}'")
    return units, rest[1:]


def _detect_decimal(where: str, rest, delimiter: str, setting: str) -> str:
    if setting == "auto":
        if delimiter == ",":
            return "."
        sample = (c for _, line in rest[:SNIFF_LINES] for c in _cells(line, delimiter))
        return "," if any(DECIMAL_COMMA.match(c) for c in sample) else "."
    if setting == "," and delimiter == ",":
        raise TrialError(where, "the protocol says decimal = ',' but the file is comma-separated")
    return setting
