"""The one CSV writer of limbstiff: every CSV it writes (docs/interface.md) is formatted here.

:func:`write_csv` writes a file at once, atomically; :func:`csv_head` and :func:`csv_rows` are its
parts, for a table written as rows arrive (:class:`~.recording.GrowingTable`). A file is
``# key: value`` metadata lines, the header, an optional unit row, then the rows; fields are quoted
as the csv module quotes them, lines end with ``\n``. Numbers are formatted by column:

* float with ``digits=10``: ``"%.10g"`` (``stiffness.csv``, the curves, ``draws.csv``), byte for
  byte as pandas' ``to_csv(float_format="%.10g")`` and formatted by numpy in blocks of rows, at a
  tenth of pandas' cost or less;
* float with ``digits=17`` (``"%.17g"``) or ``digits=None`` (the shortest text that reads back as
  the same float64, Python's ``repr``: the standard trial CSV, the live recording): by Python,
  value by value; both read back to the bit;
* integer in decimal, bool as ``True``/``False``; any other column (object: text, None, numbers
  mixed, ``summary.csv``) cell by cell as the csv module writes it (None empty, a float shortest).

NaN is ``na_rep`` (empty by default; ``""`` when it is a row's only field, as the csv module writes
an empty line).
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np

from .atomic import atomic_output

#: Rows formatted at once by :func:`write_csv` (a few MB of bytes per block).
CSV_BLOCK_ROWS = 1 << 16
#: 10**k as exact float64, k = 0…22 (every power up to 10**22 is a double).
_POW10 = np.array([float(10 ** k) for k in range(23)])
_NUL, _ZERO, _DOT, _E, _PLUS, _MINUS = (np.uint8(ord(c)) for c in "\0" "0" ".e+-")
#: Offsets in the table of :func:`_chunks`: all five digits, trailing zeros NUL, leading zeros
#: NUL (0 keeps its last), and the one item of five NULs.
_FULL, _TRAILING, _LEADING, _EMPTY = 0, 100000, 200000, 300000


def write_csv(path: str | Path, columns, *, digits: int | None = 10, na_rep: str = "",
              metadata: Mapping[str, str] | None = None, units: Sequence[str | None] | None = None) -> None:
    """Write columns as CSV, atomically (its folder is created if needed).

    Parameters
    ----------
    path : str or Path
    columns : mapping of str to array, or DataFrame
        The columns in order, 1-D and of equal length; how each is written is said in the module's
        docstring (an object column, e.g. ``np.array(cells, dtype=object)``, cell by cell).
    digits : {10, 17, None}
        Significant digits of the float columns; None: the shortest that reads back to the bit.
    na_rep : str
        NaN in a float column.
    metadata : mapping of str to str, optional
        ``# key: value`` lines before the header.
    units : sequence of (str or None), optional
        A unit row under the header (omitted when None or all empty).

    Raises
    ------
    TypeError
        A column that is not one-dimensional.
    ValueError
        A metadata key that cannot be written as ``# key: value``.
    """
    names = [str(name) for name in columns.keys()]
    arrays = [_column(name, columns[name]) for name in columns.keys()]
    with atomic_output(path) as tmp, open(tmp, "wb") as handle:
        handle.write(csv_head(names, metadata=metadata, units=units))
        n = len(arrays[0]) if arrays else 0
        for start in range(0, n, CSV_BLOCK_ROWS):
            handle.write(csv_rows([a[start:start + CSV_BLOCK_ROWS] for a in arrays], digits=digits, na_rep=na_rep))


def _column(name, values) -> np.ndarray:
    array = np.asarray(values)
    if array.ndim != 1:
        raise TypeError(f"write_csv: column {name!r} is {array.ndim}-D; it writes 1-D columns")
    return array if array.dtype.kind in "fiubO" else array.astype(object)


def csv_head(names: Sequence[str], *, metadata: Mapping[str, str] | None = None,
             units: Sequence[str | None] | None = None) -> bytes:
    """The lines before the rows: ``# key: value`` metadata (a value's line breaks become spaces),
    the header, the unit row when ``units`` has one (see :func:`write_csv`)."""
    lines = []
    for key, value in (metadata or {}).items():
        key = str(key).strip()
        if not key or ":" in key or "\n" in key:
            raise ValueError(f"metadata key {key!r} cannot be written as '# key: value'")
        lines.append(f"# {key}: {' '.join(str(value).splitlines())}\n")
    lines.append(_line(names))
    if units is not None and any(units):
        lines.append(_line([u or "" for u in units]))
    return "".join(lines).encode("utf-8")


def _line(cells: Sequence[str]) -> str:
    """One line of text fields; an empty field alone on its line is ``""``."""
    cells = [_quoted(c) for c in cells]
    return (",".join(cells) if cells != [""] else '""') + "\n"


def _quoted(text: str) -> str:
    """A field as the csv module writes it (minimal quoting, ``\n`` line ends)."""
    return '"' + text.replace('"', '""') + '"' if any(c in text for c in ',"\n') else text


def _cell(value) -> str:
    """An object column's cell as the csv module writes it: None empty, a float shortest, else ``str``."""
    if value is None:
        return ""
    return _quoted(float.__repr__(value) if isinstance(value, float) else str(value))


def csv_rows(arrays: list[np.ndarray], *, digits: int | None = 10, na_rep: str = "") -> bytes:
    """The CSV lines of a block of columns (see :func:`write_csv`), each ended by ``\n``.

    A field comes as places side by side (arrays of a byte per row, or of a few), NUL in the
    rows where it is shorter; the block of every field's places is filled and its NULs dropped,
    which closes each line up to its characters.
    """
    places = []
    for i, x in enumerate(arrays):
        places += [np.uint8(ord(","))] if i else []
        places += _places(x, digits=digits, na_rep=na_rep, alone=len(arrays) == 1)
    places.append(np.uint8(ord("\n")))
    widths = [p.shape[1] if p.ndim == 2 else 1 for p in places]
    block = np.empty((len(arrays[0]), sum(widths)), dtype=np.uint8)
    for place, at, width in zip(places, np.cumsum([0] + widths), widths):
        block[:, at:at + width] = place if place.ndim == 2 else np.reshape(place, (-1, 1))
    block = block.ravel()
    return block[block != _NUL].tobytes()


def _places(x: np.ndarray, *, digits: int | None, na_rep: str, alone: bool) -> list[np.ndarray]:
    """The places of one column (see :func:`csv_rows`); an empty field alone on its line is ``""``."""
    if x.dtype.kind == "b":
        return [np.frombuffer(b"False" + b"True\0", dtype=np.uint8).reshape(2, 5)[x.astype(np.intp)]]
    if x.dtype.kind in "iu":
        return _int_places(x)
    if x.dtype.kind == "f" and digits == 10:
        return _g10_places(x.astype(np.float64, copy=False), na=na_rep or ('""' if alone else ""))
    if x.dtype.kind == "f":
        text = repr if digits is None else f"%.{digits}g".__mod__
        cells = [na_rep if v != v else text(v) for v in x.astype(np.float64, copy=False).tolist()]
    else:
        cells = [_cell(v) for v in x.tolist()]
    return _apart(len(x), [], np.arange(len(x)), [c or '""' for c in cells] if alone else cells)


@functools.lru_cache(maxsize=1)
def _chunks() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """0…99999 as five ASCII digits in the first bytes of a uint64 (little-endian; at the offsets
    ``_FULL``, ``_TRAILING``, ``_LEADING``, and five NULs at ``_EMPTY``), and the numbers of
    trailing and of leading zeros of each (5 for 0)."""
    digits = np.indices((10,) * 5, dtype=np.uint8).reshape(5, -1).T     # row k: the digits of k
    nonzero = digits != 0
    zero = ~nonzero.any(axis=1)
    trailing = np.where(zero, 5, np.argmax(nonzero[:, ::-1], axis=1))
    leading = np.where(zero, 5, np.argmax(nonzero, axis=1))
    place, ascii_ = np.arange(5), digits + _ZERO
    table = np.zeros((3 * 100000 + 1, 8), dtype=np.uint8)
    table[_FULL:_TRAILING, :5] = ascii_
    table[_TRAILING:_LEADING, :5] = np.where(place < 5 - trailing[:, None], ascii_, _NUL)
    table[_LEADING:_EMPTY, :5] = np.where(place >= np.minimum(leading, 4)[:, None], ascii_, _NUL)
    return table.view("<u8").ravel(), trailing, leading


#: Where digit j (0…9) of :func:`_ten_digits` lies in its 16 bytes; the others are NUL.
_DIGIT_AT = np.array([0, 1, 2, 3, 4, 8, 9, 10, 11, 12])
#: Which digit lies at each of the 16 bytes (99 for a NUL byte).
_DIGIT_OF = np.array([0, 1, 2, 3, 4, 99, 99, 99, 5, 6, 7, 8, 9, 99, 99, 99])


def _halves(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The upper and the lower five digits of integers 0 ≤ m < 10¹⁰ held as float64."""
    high = np.floor(m / 1e5)                  # exact: the fraction is at most 0.99999
    return high.astype(np.intp), (m - high * 1e5).astype(np.intp)


def _ten_digits(high_at: np.ndarray, low_at: np.ndarray) -> np.ndarray:
    """Ten ASCII digits as 16 bytes a row (n, 16), digit j at ``_DIGIT_AT[j]``, NUL between: the
    items ``high_at`` and ``low_at`` of :func:`_chunks` side by side."""
    table = _chunks()[0]
    digits = np.empty((len(high_at), 2), dtype="<u8")
    digits[:, 0], digits[:, 1] = table[high_at], table[low_at]
    return digits.view(np.uint8)


def _int_places(x: np.ndarray) -> list[np.ndarray]:
    """The places of integers in decimal (see :func:`csv_rows`); magnitudes from 10¹⁰ on by Python."""
    big = (x >= 10 ** 10) | (x <= -10 ** 10)
    value = np.where(big, 0, x).astype(np.float64)
    high, low = _halves(np.abs(value))
    lone = high == 0                                          # below 10⁵
    digits = _ten_digits(np.where(lone, _EMPTY, _LEADING + high), np.where(lone, _LEADING, _FULL) + low)
    digits[big] = _NUL
    leading = _chunks()[2]
    first = int(np.where(lone, 5 + leading[low], leading[high]).min(initial=9))
    places = [np.where(value < 0, _MINUS, _NUL)] if (value < 0).any() else []
    big = np.flatnonzero(big)
    return places + [digits[:, _DIGIT_AT[min(first, 9)]:]] + _apart(len(x), [], big, [str(v) for v in x[big].tolist()])


def _apart(n: int, groups: list[tuple[np.ndarray, str]], rows=(), texts=()) -> list[np.ndarray]:
    """A place (n, longest text) holding the text of each group in its rows, and ``texts[i]`` in
    row ``rows[i]``, NUL elsewhere; none when no row is written apart."""
    groups = [(where, text.encode("utf-8")) for where, text in groups if len(where) and text]
    texts = [text.encode("utf-8") for text in texts]
    width = max((len(text) for text in texts + [t for _, t in groups]), default=0)
    if not width:
        return []
    place = np.zeros((n, width), dtype=np.uint8)
    for where, text in groups:
        place[where, :len(text)] = np.frombuffer(text, np.uint8)
    if texts:
        place[np.asarray(rows)] = np.array(texts, dtype=f"S{place.shape[1]}").view(np.uint8).reshape(len(texts), -1)
    return [place]


def _g10_places(x: np.ndarray, *, na: str) -> list[np.ndarray]:
    """The places of ``"%.10g" % v`` of every float64 ``v``, NaN as ``na`` (see :func:`csv_rows`).

    numpy rounds each value to ten significant digits where it can be sure of printf's answer
    (:func:`_decimal10`); zeros, infinities and the rare rest (a decimal exponent beyond
    −13…31, a value within 10⁻⁴ of a tie at the tenth digit; by Python) are written apart.
    """
    magnitude = np.abs(x)
    mantissa, exponent, fast = _decimal10(magnitude)
    rest = ~fast & np.isfinite(x) & (magnitude != 0)
    negative = np.signbit(x) & ~np.isnan(x) & ~rest
    places = [np.where(negative, _MINUS, _NUL)] if negative.any() else []
    if fast.any():
        places += _g10_fast(mantissa, exponent, fast)
    groups = [(np.flatnonzero(magnitude == 0), "0"), (np.flatnonzero(np.isinf(x)), "inf"),
              (np.flatnonzero(np.isnan(x)), na)]
    rest = np.flatnonzero(rest)
    return places + _apart(len(x), groups, rest, ["%.10g" % v for v in x[rest].tolist()])


def _decimal10(magnitude: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Positive floats as ``mantissa`` · 10^(``exponent`` − 9), the mantissa a ten-digit integer
    (as float64) rounded half to even as printf rounds, and where that rounding is certain
    (``fast``).

    ``magnitude`` · 10^(9 − exponent) is computed with a single rounding (10^k is exact to k = 22),
    so within 1.2·10⁻⁶ of its true value below 10¹⁰: its nearest integer is the true one unless
    the fraction lies within 10⁻⁴ of one half, and those are not ``fast``.
    """
    usable = np.isfinite(magnitude) & (magnitude != 0)
    a = np.where(usable, magnitude, 1.0)
    exponent = np.floor(np.log10(a)).astype(np.int64)
    scaled = _scale(a, exponent)
    off = np.flatnonzero((scaled >= 1e10) | (scaled < 1e9))            # log10's last bit
    exponent[off] += np.where(scaled[off] >= 1e10, 1, -1)
    scaled[off] = _scale(a[off], exponent[off])
    fast = (usable & (exponent >= -13) & (exponent <= 31) & (scaled >= 1e9) & (scaled < 1e10)
            & (np.abs(scaled - np.floor(scaled) - 0.5) > 1e-4))
    mantissa = np.where(fast, np.rint(scaled), 1e9)
    carry = mantissa >= 1e10                                          # 9999999999.5 → 1e+E+1
    return np.where(carry, 1e9, mantissa), exponent + carry, fast


def _scale(a: np.ndarray, exponent: np.ndarray) -> np.ndarray:
    """``a`` · 10^(9 − exponent) in one rounding, for exponents −13…31 (others clipped)."""
    power = np.clip(9 - exponent, -22, 22)
    return a * _POW10[np.maximum(power, 0)] / _POW10[np.maximum(-power, 0)]     # one of them 1


def _g10_fast(mantissa: np.ndarray, e: np.ndarray, fast: np.ndarray) -> list[np.ndarray]:
    """The places of ``"%.10g"`` (no sign) of the ``fast`` rows, from a ten-digit mantissa and
    its exponent, NUL in the other rows: ``0.`` and up to three zeros (exponents −4…−1), the
    digits with a place for the point after each (where exponents 0…9 put it, or after the first
    in d.ddde±XX from 10 on and below −4), the exponent. Trailing zeros of a fraction are NUL."""
    fixed = fast & (e >= -4) & (e < 10)
    whole, small, sci = fixed & (e >= 0), fixed & (e < 0), fast & ~fixed
    high, low = _halves(mantissa)
    tail = low == 0                                           # the last five digits zeros
    digits = _ten_digits(high + tail * (_TRAILING - _FULL), low + np.where(tail, _EMPTY, _TRAILING))
    trailing = _chunks()[1]
    shown = 10 - np.where(tail, 5 + trailing[high], trailing[low])
    zeros = np.flatnonzero(whole & (shown <= e))            # 1200 keeps the zeros of its integer
    digits[zeros] = np.where(_DIGIT_OF <= e[zeros, None], np.maximum(digits[zeros], _ZERO), _NUL)
    shown[zeros] = e[zeros] + 1
    digits[~fast] = _NUL
    point = np.where(whole, e + 1, 1) * (shown > np.where(whole, e + 1, 1)) * (whole | sci)
    places = []
    if small.any():
        places += [np.where(small, _ZERO, _NUL), np.where(small, _DOT, _NUL)]
        places += [np.where(small & (z < -e - 1), _ZERO, _NUL) for z in range(int((-e[small] - 1).max()))]
    used = np.bincount(point, minlength=11)
    for j in range(int(shown[fast].max())):
        places += [digits[:, _DIGIT_AT[j]]] + ([np.where(point == j + 1, _DOT, _NUL)] if used[j + 1] else [])
    if sci.any():
        size = np.abs(e)
        places += [np.where(sci, _E, _NUL), np.where(sci, np.where(e < 0, _MINUS, _PLUS), _NUL),
                   np.where(sci, _ZERO + size // 10, _NUL).astype(np.uint8), np.where(sci, _ZERO + size % 10, _NUL).astype(np.uint8)]
    return places
