"""Writing the outputs of ``limbstiff analyze`` (docs/interface.md section 4), atomically.

Each file is written to a temporary name and renamed, so a reader never sees half a file and
an interrupted run leaves the previous complete file (or none). ``summary.json`` is written
last: its presence marks a trial whose outputs are complete.

The per-sample CSVs are formatted by numpy in blocks of rows (:func:`write_csv`), byte for byte
as pandas' ``to_csv(float_format="%.10g")`` would write them, at a tenth of its cost or less.
"""

from __future__ import annotations

import csv
import functools
import io
import json
import os
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from ..errors import LimbstiffError
from .atomic import atomic_output, atomic_write_text

#: Significant digits of the stiffness columns of ``stiffness.csv``: the band is rarely narrower
#: than 0.1 % of the stiffness, so a fifth digit is already below the estimate's uncertainty.
STIFFNESS_DIGITS = 5

STIFFNESS_CSV = "stiffness.csv"
#: The stiffness against the cycle's phase or the schedule (an ensemble or schedule analysis).
CURVE_CSV = {"phase": "stiffness_by_phase.csv", "schedule": "stiffness_by_schedule.csv"}
SUMMARY_JSON = "summary.json"
REPORT_PDF = "report.pdf"

#: Field metadata: the JSON leaves the key out when the value is None.
OMIT_NONE = {"omit_none": True}


def jsonable(value):
    """Plain JSON values: a dataclass as its fields (in order, named as its keys; a field with
    :data:`OMIT_NONE` left out when None), an object with ``to_dict`` as that, numpy scalars and
    arrays converted, non-finite floats as None."""
    if hasattr(value, "to_dict"):
        return jsonable(value.to_dict())
    if is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in fields(value)
                if not (f.metadata.get("omit_none") and getattr(value, f.name) is None)}
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def write_json(path: str | Path, data: dict) -> None:
    """Write ``data`` as indented UTF-8 JSON, atomically."""
    atomic_write_text(path, json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False) + "\n")


def round_significant(x: np.ndarray, *, digits: int) -> np.ndarray:
    """Values rounded to a number of significant digits.

    Parameters
    ----------
    x : ndarray, shape (n,)
    digits : int

    Returns
    -------
    ndarray, shape (n,)
        ``x`` to ``digits`` significant digits; NaN and ±inf kept, 0 stays 0.
    """
    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        exponent = np.floor(np.log10(np.abs(x)))
        scale = np.where(np.isfinite(exponent), 10.0 ** (digits - 1 - exponent), 1.0)
        return np.where(np.isfinite(x) & (x != 0), np.round(x * scale) / scale, x)


#: Rows formatted at once by :func:`write_csv` (a few MB of bytes per block).
CSV_BLOCK_ROWS = 1 << 16
#: 10**k as exact float64, k = 0…22 (every power up to 10**22 is a double).
_POW10 = np.array([float(10 ** k) for k in range(23)])
_NUL, _ZERO, _DOT, _E, _PLUS, _MINUS = (np.uint8(ord(c)) for c in "\0" "0" ".e+-")
#: Offsets in the table of :func:`_chunks`: all five digits, trailing zeros NUL, leading zeros
#: NUL (0 keeps its last), and the one item of five NULs.
_FULL, _TRAILING, _LEADING, _EMPTY = 0, 100000, 200000, 300000


def write_csv(path: str | Path, columns) -> None:
    """Write columns as CSV, atomically, byte for byte as pandas'
    ``to_csv(index=False, float_format="%.10g")`` writes them, formatted by numpy in blocks.

    Parameters
    ----------
    path : str or Path
        The file; its folder is created if needed.
    columns : mapping of str to array, or DataFrame
        The columns in order, of equal length: float (``"%.10g"``; NaN as an empty field, ``""``
        when it is the only column), integer (decimal) or bool (``True``/``False``). The header
        is the names, quoted as the csv module quotes; lines end with ``os.linesep``.

    Raises
    ------
    TypeError
        A column of strings or objects (no per-sample file of limbstiff has one).
    """
    names = [str(name) for name in columns.keys()]
    arrays = [np.asarray(columns[name]) for name in columns.keys()]
    for name, array in zip(names, arrays):
        if array.dtype.kind not in "fiub" or array.ndim != 1:
            raise TypeError(f"write_csv: column {name!r} is {array.ndim}-D {array.dtype}; "
                            "it writes 1-D float, integer and bool columns")
    header = io.StringIO()
    csv.writer(header, lineterminator=os.linesep).writerow(names)
    with atomic_output(path) as tmp, open(tmp, "wb") as handle:
        handle.write(header.getvalue().encode("utf-8"))
        n = len(arrays[0]) if arrays else 0
        for start in range(0, n, CSV_BLOCK_ROWS):
            handle.write(csv_rows([a[start:start + CSV_BLOCK_ROWS] for a in arrays]))


def csv_rows(arrays: list[np.ndarray]) -> bytes:
    """The CSV lines of a block of columns (see :func:`write_csv`), each ended by ``os.linesep``.

    A field comes as places side by side (arrays of a byte per row, or of a few), NUL in the
    rows where it is shorter; the block of every field's places is filled and its NULs dropped,
    which closes each line up to its characters.
    """
    places = []
    for i, x in enumerate(arrays):
        places += [np.uint8(ord(","))] if i else []
        if x.dtype.kind == "b":
            places.append(np.frombuffer(b"False" + b"True\0", dtype=np.uint8).reshape(2, 5)[x.astype(np.intp)])
        elif x.dtype.kind in "iu":
            places += _int_places(x)
        else:
            places += _g10_places(x.astype(np.float64, copy=False), alone=len(arrays) == 1)
    places += list(np.frombuffer(os.linesep.encode(), dtype=np.uint8))
    widths = [p.shape[1] if p.ndim == 2 else 1 for p in places]
    block = np.empty((len(arrays[0]), sum(widths)), dtype=np.uint8)
    for place, at, width in zip(places, np.cumsum([0] + widths), widths):
        block[:, at:at + width] = place if place.ndim == 2 else np.reshape(place, (-1, 1))
    block = block.ravel()
    return block[block != _NUL].tobytes()


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
    groups = [(where, text.encode("ascii")) for where, text in groups if len(where)]
    texts = [text.encode("ascii") for text in texts]
    if not groups and not texts:
        return []
    place = np.zeros((n, max(len(text) for text in texts + [t for _, t in groups])), dtype=np.uint8)
    for where, text in groups:
        place[where, :len(text)] = np.frombuffer(text, np.uint8)
    if texts:
        place[np.asarray(rows)] = np.array(texts, dtype=f"S{place.shape[1]}").view(np.uint8).reshape(len(texts), -1)
    return [place]


def _g10_places(x: np.ndarray, *, alone: bool) -> list[np.ndarray]:
    """The places of ``"%.10g" % v`` of every float64 ``v``, NaN as nothing (see :func:`csv_rows`).

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
    groups = [(np.flatnonzero(magnitude == 0), "0"), (np.flatnonzero(np.isinf(x)), "inf")]
    groups += [(np.flatnonzero(np.isnan(x)), '""')] if alone else []   # the csv module's empty line
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


def write_result(result, directory: str | Path, *, extra: dict | None = None) -> dict:
    """Write ``stiffness.csv`` and ``summary.json`` of one result into ``directory``, and
    ``stiffness_by_phase.csv`` or ``stiffness_by_schedule.csv`` for an ensemble or schedule analysis.

    Parameters
    ----------
    result : StiffnessResult
    directory : str or Path
        Created if needed.
    extra : dict, optional
        More keys for ``summary.json`` (for example the outputs written alongside).

    Returns
    -------
    dict
        The summary that was written.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    # time keeps ten digits: a microsecond an hour into a trial
    write_csv(directory / STIFFNESS_CSV, _rounded(result.columns()))
    if getattr(result, "curve", None) is not None:
        frame = result.curve.curve.to_frame()
        write_csv(directory / CURVE_CSV[result.curve.against], _rounded({c: frame[c].to_numpy() for c in frame}))
    summary = result.summary()
    if extra:
        summary.update(extra)
    write_json(directory / SUMMARY_JSON, summary)
    return summary


def _rounded(columns: dict) -> dict:
    """``columns`` with the stiffness and its band to :data:`STIFFNESS_DIGITS` significant digits."""
    return {name: round_significant(values, digits=STIFFNESS_DIGITS)
            if name in ("stiffness", "stiffness_lo", "stiffness_hi") else values
            for name, values in columns.items()}


class OutputExists(LimbstiffError):
    """A file a command would write is there already and ``--overwrite`` was not given (exit 2)."""


class OutputPathError(LimbstiffError):
    """A file a command would write cannot be written there (exit 2)."""


def writable_file(path: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """``path``, once checked that a command may write it as a file, before anything is computed
    or written.

    Parameters
    ----------
    path : str or path-like
        The file to write (its folder must exist).
    overwrite : bool
        Whether an existing file may be replaced (``--overwrite``).

    Returns
    -------
    Path

    Raises
    ------
    OutputExists
        ``path`` exists and ``overwrite`` is false.
    OutputPathError
        ``path`` is a folder, its folder is missing, is a file or cannot be written in.
    """
    import tempfile

    path = Path(path)
    if path.is_dir():
        raise OutputPathError(f"{path}: is a folder, not a file; give a file path")
    if path.exists() and not overwrite:
        raise OutputExists(f"{path} exists: use --overwrite to replace it, or another path")
    parent = path.parent
    if not parent.is_dir():
        through = next((a for a in (parent, *parent.parents) if a.exists() and not a.is_dir()), None)
        why = f"{through} is a file, not a folder" if through else f"its folder {parent} does not exist"
        raise OutputPathError(f"{path}: cannot write it ({why}); choose another path")
    try:
        with tempfile.NamedTemporaryFile(dir=parent, prefix=".limbstiff-probe-"):
            pass
    except OSError as exc:
        raise OutputPathError(f"{path}: cannot write in {parent} ({exc.strerror or type(exc).__name__}); "
                              "choose another path") from None
    return path


def refuse_existing(directory: str | os.PathLike, names: Iterable[str], *, overwrite: bool = False) -> None:
    """Refuse, before anything runs, to replace the outputs ``names`` in ``directory`` without
    ``overwrite`` (``limbstiff diagnose``).

    Raises
    ------
    OutputExists
        One line naming the folder and the files there.
    """
    there = [n for n in names if (Path(directory) / n).exists()]
    if there and not overwrite:
        raise OutputExists(f"outputs in {directory} exist ({', '.join(there)}): use --overwrite to replace them, "
                           "or another --out")
