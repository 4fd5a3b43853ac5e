"""MATLAB ``.mat`` trial files: MAT v4, v6 and v7 (what :func:`scipy.io.loadmat` reads).

One variable per quantity. Variables with the standard ``<quantity>_<unit>`` names of
docs/interface.md section 1 (``time_s``, ``angle_deg``, ``torque_Nm``…) are recognised without
configuration; the protocol's ``[columns]`` ``header`` maps any other, as a *variable path*:

- ``tq`` — a top-level variable;
- ``data.torque`` — a field of a struct (any depth);
- ``M[:, 2]`` — a column of a matrix, 0-based (Python); ``M(:, 3)`` — the same, 1-based
  (MATLAB); ``M[2, :]`` / ``M(3, :)`` — a row, for channels stored as rows.

Units and scales are those of the names or of the protocol, exactly as for CSV headers. A
file without a time variable gets its time base from a scalar ``fs``, ``fs_hz`` or
``sample_rate_hz`` variable (Hz) or the protocol's ``[format] sample_rate_hz``. Other scalar
numbers and strings become metadata (``subject = 'S01'``), as ``# key: value`` lines do in CSV.

MAT v7.3 files are HDF5 files, which would need h5py: they are recognised and refused with a
one-line error.
"""

from __future__ import annotations

import io
import math
import re
from pathlib import Path

import numpy as np

from ..errors import TrialError
from ..trial import Trial
from .column_units import in_si, joint_kind, schedule_unit, units_written
from .columns import READ_FIELDS, ColumnSpec, resolve_columns
from ..units import parse_standard_header, split_header
from .validate import checked_trial

#: Names (any case) of scalar variables giving the sample rate in Hz.
RATE_NAMES = ("fs", "fs_hz", "sample_rate_hz")
#: At most this many scalar variables become metadata, strings cut at this many characters.
MAX_METADATA = 50
MAX_TEXT = 200
V73 = "MATLAB v7.3 (HDF5) files are not supported: save with -v7, or export CSV"

_HDF5 = b"\x89HDF\r\n\x1a\n"
_PATH = re.compile(r"^([A-Za-z]\w*(?:\.[A-Za-z]\w*)*)"
                   r"(?:\s*([\[(])\s*(:|\d+)\s*,\s*(:|\d+)\s*([\])]))?$")
_SYNTAX = "name, name.field, name[:, k] (0-based) or name(:, k) (1-based)"


def read_mat(path: Path, raw: bytes, protocol=None, *, name: str | None = None) -> Trial:
    """Read one MATLAB trial file into a checked Trial (the reader of
    :class:`~limbstiff.files.read.FileType` for ``.mat``).

    Parameters
    ----------
    path : Path
    raw : bytes
        Its content (MAT v4, v6 or v7).
    protocol : Protocol or None
        ``columns`` maps quantities to variable paths (see the module docstring), units,
        scales and signs; ``sample_rate_hz`` (Hz) builds the time base of files without
        one; ``sample_period`` (s) resamples.
    name : str or None

    Returns
    -------
    Trial
        The mapped variables; unused scalar numbers and strings as metadata.

    Raises
    ------
    TrialError
        v7.3, a corrupt file, a missing variable or field, a wrong shape, non-numeric or
        non-finite values, no time and no rate.
    """
    where = str(path)
    variables = _load(where, raw)
    arrays, has_time = _protocol_arrays(where, variables, protocol)
    headers = list(variables) + [e for e in arrays if e not in variables]
    columns = resolve_columns(where, headers, protocol, noun="variable", need_time=has_time)
    kind = joint_kind(where, columns, noun="variable")
    for column in columns.values():
        if column.header not in arrays:
            arrays[column.header] = _vector(where, column.header, variables[column.header])
    first = columns["time"] if has_time else columns["angle"]
    n = arrays[first.header].size
    values: dict[str, np.ndarray | None] = dict.fromkeys(READ_FIELDS)
    used = {_root(c.header) for c in columns.values()}
    if not has_time:
        rate, rate_name = _rate(where, variables, protocol)
        values["time"] = np.arange(n) / rate
        used.add(rate_name)
    for field in READ_FIELDS:
        column = columns.get(field)
        if column is not None:
            values[field] = _channel(where, column, arrays[column.header], first.header, n, values["time"])
    metadata, warnings = _leftovers({k: v for k, v in variables.items() if k not in used})
    return checked_trial(path, raw, values, kind=kind, protocol=protocol, name=name, metadata=metadata,
                         warnings=warnings, locate=lambda k: f"sample {k + 1}", schedule_unit=schedule_unit(columns),
                         units=units_written(columns))


def _protocol_arrays(where: str, variables: dict, protocol) -> tuple[dict[str, np.ndarray], bool]:
    """The arrays the protocol's variable paths point to, and whether the file has a time variable.

    Returns
    -------
    arrays : dict of str to ndarray, shape (n,)
        By variable path, as the protocol writes it.
    has_time : bool
        True when the protocol maps time or a variable has a standard time name.
    """
    mapped = {f: c.header.strip() for f, c in protocol.columns.items() if c.header} if protocol else {}
    marker = getattr(getattr(protocol, "cycles", None), "marker", None)
    if marker is not None:
        mapped["marker"] = marker.strip()
    names = {split_header(v)[0] for v in variables}
    # a plain name of a variable with a unit ('Zeit' for 'Zeit_ms') is found by resolve_columns
    arrays = {expr: _lookup(where, variables, expr) for expr in mapped.values()
              if expr in variables or expr not in names}
    has_time = "time" in mapped or any((parse_standard_header(v) or ("",))[0] == "time" for v in variables)
    return arrays, has_time


def _channel(where: str, column: ColumnSpec, data: np.ndarray, first: str, n: int,
             time: np.ndarray | None) -> np.ndarray:
    """One recorded channel in SI units, after checking its length and that every value is finite.

    Parameters
    ----------
    where : str
        File name, for error messages.
    column : ColumnSpec
        Where the channel comes from, its unit and scale.
    data : ndarray, shape (m,)
        Its values in the file's unit.
    first : str
        The variable that set the length ``n``, for messages.
    n : int
        Samples expected.
    time : ndarray, shape (n,), s, or None
        The time base, for messages; None while reading the time itself.
    """
    if data.size != n:
        raise TrialError(where, f"variable '{column.header}' has {data.size} samples, "
                                f"'{first}' has {n}")
    bad = ~np.isfinite(data)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        what = "NaN" if np.isnan(data[k]) else "infinite value"
        at = "" if column.field == "time" else f" (t = {time[k]:g} s)"
        raise TrialError(where, f"{what} in variable '{column.header}' at sample {k + 1}{at}")
    return in_si(data, column)


def is_v73(raw: bytes) -> bool:
    """Whether the bytes are a MAT v7.3 (HDF5) file: its text header, or an HDF5 signature
    where HDF5 puts one (offset 0, or 512 after the MATLAB user block, doubling)."""
    if raw.startswith(b"MATLAB 7.3"):
        return True
    if raw.startswith(b"MATLAB 5.0"):  # v5–v7 text header: not HDF5, whatever bytes follow
        return False
    offset = 0
    while offset + len(_HDF5) <= len(raw):
        if raw[offset:offset + len(_HDF5)] == _HDF5:
            return True
        offset = 512 if offset == 0 else 2 * offset
    return False


def _load(where: str, raw: bytes) -> dict:
    """The file's variables (structs as dicts, 1×n and n×1 arrays as vectors)."""
    from scipy.io import loadmat

    if not raw:
        raise TrialError(where, "empty file")
    if is_v73(raw):
        raise TrialError(where, V73)
    try:
        content = loadmat(io.BytesIO(raw), simplify_cells=True)
    except NotImplementedError:  # scipy's own v7.3 refusal
        raise TrialError(where, V73) from None
    except Exception as exc:  # noqa: BLE001 — scipy raises many types on corrupt files
        reason = (str(exc).splitlines() or [type(exc).__name__])[0][:100]
        raise TrialError(where, f"not a readable MATLAB file ({reason})") from None
    variables = {k: v for k, v in content.items() if not k.startswith("__")}
    if not variables:
        raise TrialError(where, "the MATLAB file holds no variables")
    return variables


def _names(mapping) -> str:
    names = list(mapping)
    return ", ".join(names[:10]) + (f" and {len(names) - 10} more" if len(names) > 10 else "")


def _root(expr: str) -> str:
    return re.split(r"[.\[(\s]", expr, maxsplit=1)[0]


def _lookup(where: str, variables: dict, expr: str) -> np.ndarray:
    """The 1-D array a protocol's variable path points to."""
    match = _PATH.match(expr)
    if not match:
        raise TrialError(where, f"'{expr}' in the protocol is not a variable path ({_SYNTAX})")
    path, bracket, row, col, close = match.groups()
    value, trail = variables, []
    for part in path.split("."):
        if not isinstance(value, dict):
            raise TrialError(where, f"variable '{'.'.join(trail)}' is not a struct, so '{expr}' does not exist")
        if part not in value:
            if trail:
                raise TrialError(where, f"struct '{'.'.join(trail)}' has no field '{part}' "
                                        f"(fields: {_names(value) or 'none'})")
            raise TrialError(where, f"no variable '{part}' (given by the protocol as '{expr}'; "
                                    f"variables: {_names(value)})")
        value, trail = value[part], trail + [part]
    if bracket is None:
        return _vector(where, expr, value)
    if (bracket + close) not in ("[]", "()") or (row == ":") == (col == ":"):
        raise TrialError(where, f"'{expr}' in the protocol is not a variable path ({_SYNTAX})")
    matrix = _numeric(where, path, value)
    if matrix.ndim != 2:
        raise TrialError(where, f"variable '{path}' has shape {_shape(matrix)}, not a matrix: "
                                f"name it without an index")
    axis = 1 if row == ":" else 0
    index = int(col if axis == 1 else row) - (1 if bracket == "(" else 0)
    if not 0 <= index < matrix.shape[axis]:
        what = "column" if axis == 1 else "row"
        base = "1-based" if bracket == "(" else "0-based"
        raise TrialError(where, f"'{expr}': variable '{path}' is {_shape(matrix)}, it has no {what} "
                                f"{int(col if axis == 1 else row)} ({base})")
    return matrix[:, index] if axis == 1 else matrix[index, :]


def _shape(array: np.ndarray) -> str:
    return "×".join(str(s) for s in array.shape) or "scalar"


def _numeric(where: str, label: str, value) -> np.ndarray:
    """A real numeric array (float), or an error saying what the variable is instead."""
    if isinstance(value, dict):
        raise TrialError(where, f"variable '{label}' is a struct (fields: {_names(value) or 'none'}); "
                                f"name one of its fields in the protocol, e.g. '{label}.field'")
    if isinstance(value, str):
        raise TrialError(where, f"variable '{label}' is text, not numbers")
    if isinstance(value, list):
        raise TrialError(where, f"variable '{label}' is a struct or cell array, not numbers")
    array = np.asarray(value)
    if array.dtype == object or array.dtype.names is not None:
        raise TrialError(where, f"variable '{label}' is a cell array or MATLAB object (a table, timetable or "
                                f"string?), not numbers: save numeric arrays, e.g. with "
                                f"table2struct(T, 'ToScalar', true)")
    if np.iscomplexobj(array):
        raise TrialError(where, f"variable '{label}' has complex values")
    if array.dtype == bool or not np.issubdtype(array.dtype, np.number):
        kind = "logical" if array.dtype == bool else "text"
        raise TrialError(where, f"variable '{label}' is {kind}, not numbers")
    return array.astype(float)


def _vector(where: str, label: str, value) -> np.ndarray:
    """A 1-D float array of one recorded channel."""
    array = _numeric(where, label, value)
    if array.ndim == 0:
        raise TrialError(where, f"variable '{label}' is a single number, not a recording")
    if array.ndim == 2:
        r, c = array.shape
        raise TrialError(where, f"variable '{label}' is a {r}×{c} matrix; name one column in the protocol, "
                                f"e.g. '{label}[:, 0]' (0-based) or '{label}(:, 1)' (1-based)")
    if array.ndim > 2:
        raise TrialError(where, f"variable '{label}' has {array.ndim} dimensions ({_shape(array)})")
    return array


def _rate(where: str, variables: dict, protocol) -> tuple[float, str | None]:
    """The sample rate (Hz) of a file without time, and the variable it came from."""
    found = []
    for key, value in variables.items():
        if key.lower() in RATE_NAMES:
            number = _scalar(value)
            if number is None or not (math.isfinite(number) and number > 0):
                raise TrialError(where, f"variable '{key}' should be the sample rate in Hz "
                                        f"(a positive number)")
            found.append((key, number))
    if len({v for _, v in found}) > 1:
        listed = ", ".join(f"{k} = {v:g}" for k, v in found)
        raise TrialError(where, f"sample rate variables disagree ({listed})")
    given = getattr(protocol, "sample_rate_hz", None)
    if found and given and not math.isclose(found[0][1], given, rel_tol=1e-9):
        raise TrialError(where, f"the file's {found[0][0]} = {found[0][1]:g} Hz and the protocol's "
                                f"sample_rate_hz = {given:g} Hz disagree")
    if found:
        return found[0][1], found[0][0]
    if given:
        return float(given), None
    raise TrialError(where, "no time variable (expected time_s or time_ms) and no sample rate: add a scalar "
                            "'fs' (Hz) to the file or set sample_rate_hz in the protocol's [format]")


def _scalar(value) -> float | None:
    """The number held by a scalar numeric variable, else None."""
    if isinstance(value, (bool, np.bool_, str, dict, list)) or np.iscomplexobj(value):
        return None
    array = np.asarray(value)
    if array.size == 1 and np.issubdtype(array.dtype, np.number):
        return float(array.reshape(-1)[0])
    return None


def _leftovers(variables: dict) -> tuple[dict[str, str], list[str]]:
    """Metadata from scalar numbers and strings; a warning naming the other unused variables."""
    metadata, ignored = {}, []
    for key, value in variables.items():
        number = _scalar(value)
        if isinstance(value, str):
            text = " ".join(value.split())
            text = text if len(text) <= MAX_TEXT else text[:MAX_TEXT - 1] + "…"
        elif number is not None:
            text = str(int(number)) if number.is_integer() and abs(number) < 1e15 else f"{number:.15g}"
        else:
            ignored.append(key)
            continue
        if len(metadata) < MAX_METADATA:
            metadata[key] = text
        else:
            ignored.append(key)
    warnings = ["ignored variable(s): " + ", ".join(f"'{k}'" for k in ignored[:10])
                + (f" and {len(ignored) - 10} more" if len(ignored) > 10 else "")] if ignored else []
    return metadata, warnings
