"""Trial CSV files: read one into a checked :class:`~limbstiff.trial.Trial`, or write one.

Scope: the file format of INTERFACE.md section 1 (``# key: value`` metadata lines, one header
row of ``<quantity>_<unit>`` names or names mapped by a protocol), conversion to SI units,
validation with one-line :class:`~limbstiff.errors.TrialError` messages, and resampling of
irregular time bases onto a uniform grid. Nothing here estimates anything.
"""

from __future__ import annotations

import csv as _csv
import hashlib
import io
import re
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import TrialError
from ..trial import MIN_DURATION, MIN_SAMPLES, Trial
from .atomic import atomic_write_text
from .units import FIELDS, ColumnSpec, joint_kind, resolve_columns, to_si

#: Shortest trial accepted, s.
#: A time step larger than this many median steps is a gap (an error, never interpolated).
GAP_FACTOR = 3.0
#: Steps varying by more than this fraction of the median step are resampled (with a warning);
#: smaller jitter is snapped to the uniform grid silently.
JITTER_TOLERANCE = 0.01

_NAN_WORDS = {"nan", "-nan", "+nan", "na", "n/a", "#n/a", "null", "none"}
_HEADERS = {
    "rotational": ("time_s", "angle_rad", "torque_Nm", "elastic_torque_Nm", "stiffness_true_Nm_per_rad"),
    "translational": ("time_s", "position_m", "force_N", "elastic_force_N", "stiffness_true_N_per_m"),
}
_PANDAS_LINE = re.compile(r"Expected (\d+) fields in line (\d+), saw (\d+)")


def read_trial(path, protocol=None, *, name: str | None = None) -> Trial:
    """Read one trial file into a :class:`~limbstiff.trial.Trial` in SI units.

    Parameters
    ----------
    path : str or path-like
        CSV file (UTF-8, BOM tolerated) with ``# key: value`` metadata lines, one header row
        and one row per sample.
    protocol : Protocol or None
        Maps other headers, units, scales and signs (``protocol.columns``) and optionally
        a ``sample_period`` (s) to resample to. Quantities it does not list use the standard
        ``<quantity>_<unit>`` headers.
    name : str or None
        Trial name; the file stem if None.

    Returns
    -------
    Trial
        Uniformly sampled; ``warnings`` says what was resampled or ignored.

    Raises
    ------
    TrialError
        With a one-line message naming the file and the problem.
    """
    path = Path(path)
    where = str(path)
    raw = _read_bytes(where, path)
    metadata, headers, lines, line_numbers = _split(where, _decode(where, raw))
    columns = resolve_columns(where, headers, protocol)
    kind = joint_kind(where, columns)
    values = _parse(where, headers, columns, lines, line_numbers)
    time, angle = values["time"], values["angle"]
    _check_time(where, time, line_numbers)
    label = "angle" if kind == "rotational" else "position"
    distinct = np.unique(angle).size
    if distinct == 1:
        raise TrialError(where, f"no motion: {label} is constant ({angle[0]:g})")
    if distinct < 3:
        raise TrialError(where, f"no motion: {label} takes only {distinct} distinct values")
    warnings = []
    values = _uniform(values, warnings)
    if protocol is not None and protocol.sample_period:
        values = _to_period(where, values, float(protocol.sample_period), warnings)
    used = {c.index for c in columns.values()}
    ignored = [h for i, h in enumerate(headers) if i not in used and h]
    if ignored:
        warnings.append("ignored column(s): " + ", ".join(f"'{h}'" for h in ignored))
    return Trial(name=name if name is not None else path.stem, kind=kind, metadata=metadata,
                 source=where, source_sha256=hashlib.sha256(raw).hexdigest(),
                 warnings=tuple(warnings), **values)


def write_trial(trial: Trial, path) -> Path:
    """Write a trial as a standard CSV file, atomically.

    Metadata become ``# key: value`` lines; the header is ``time_s,angle_rad,torque_Nm``
    (``time_s,position_m,force_N`` for translational trials), then ``elastic_torque_Nm`` /
    ``elastic_force_N`` and ``stiffness_true_Nm_per_rad`` / ``stiffness_true_N_per_m`` when
    present. Floats are written at full precision, so :func:`read_trial` gives the same arrays.

    Parameters
    ----------
    trial : Trial
    path : str or path-like
        Destination; parent directories are created, an existing file is replaced.

    Returns
    -------
    Path
        ``path``.
    """
    lines = []
    for key, value in trial.metadata.items():
        key = str(key).strip()
        if not key or ":" in key or "\n" in key:
            raise ValueError(f"metadata key {key!r} cannot be written as '# key: value'")
        value = " ".join(str(value).splitlines())
        lines.append(f"# {key}: {value}\n")
    data = {}
    for field, header in zip(FIELDS, _HEADERS[trial.kind]):
        array = getattr(trial, field)
        if array is not None:
            data[header] = np.asarray(array, dtype=float)
    body = pd.DataFrame(data).to_csv(index=False, lineterminator="\n")
    atomic_write_text(path, "".join(lines) + body)
    return Path(path)


def _read_bytes(where: str, path: Path) -> bytes:
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise TrialError(where, "file not found") from None
    except IsADirectoryError:
        raise TrialError(where, "is a directory, not a trial file") from None
    except OSError as exc:
        raise TrialError(where, f"cannot read file ({exc.strerror or exc})") from None


def _decode(where: str, raw: bytes) -> str:
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise TrialError(where, f"not UTF-8 text (byte 0x{raw[exc.start]:02x} at line {line}); "
                                f"save the file as UTF-8") from None
    if not text.strip():
        raise TrialError(where, "empty file")
    return text


def _split(where: str, text: str):
    """Metadata, header names, non-blank data lines and their 1-based line numbers."""
    all_lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    metadata: dict[str, str] = {}
    for k, line in enumerate(all_lines):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith("#"):
            key, colon, value = stripped[1:].partition(":")
            if colon and key.strip():
                metadata[key.strip()] = value.strip()
            continue
        headers = [h.strip() for h in next(_csv.reader([line]))]
        break
    else:
        raise TrialError(where, "no header row (only '#' metadata lines)")
    if len(headers) == 1 and (";" in headers[0] or "\t" in headers[0]):
        sep = "';'" if ";" in headers[0] else "tabs"
        raise TrialError(where, f"the header has a single column: the file is not comma-separated (it uses {sep})")
    seen: dict[str, int] = {}
    for i, h in enumerate(headers):
        if h and h in seen:
            raise TrialError(where, f"duplicated column header '{h}' (columns {seen[h] + 1} and {i + 1})")
        seen[h] = i
    numbers = [j + 1 for j in range(k + 1, len(all_lines)) if all_lines[j].strip()]
    lines = [all_lines[j - 1] for j in numbers]
    if not lines:
        raise TrialError(where, "no data rows below the header")
    return metadata, headers, lines, numbers


def _parse(where, headers, columns, lines, numbers) -> dict[str, np.ndarray | None]:
    """Numeric SI arrays of the used columns; every cell checked, none coerced silently."""
    used = {c.index for c in columns.values()}
    try:  # fast path: the used columns parse as floats (no NaN words: na_filter is off)
        frame = _read_rows(where, lines, numbers, len(headers), {i: float for i in used})
    except TrialError:
        raise
    except ValueError:  # some cell is not a number: read text, find it and say which
        frame = _read_rows(where, lines, numbers, len(headers), object)
    values: dict[str, np.ndarray | None] = dict.fromkeys(FIELDS)
    for field in FIELDS:
        column = columns.get(field)
        if column is None:
            continue
        numeric = frame[column.index].to_numpy()
        if numeric.dtype != float or not np.all(np.isfinite(numeric)):
            cells = frame[column.index].astype(str).str.strip()
            numeric = pd.to_numeric(cells, errors="coerce").to_numpy(dtype=float)
            bad = ~np.isfinite(numeric)
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                raise TrialError(where, _bad_cell(cells.iloc[k], numeric[k], column, numbers[k],
                                                  None if field == "time" else values["time"][k]))
        values[field] = to_si(numeric, column.unit) * column.scale
    return values


def _read_rows(where, lines, numbers, width, dtype) -> pd.DataFrame:
    try:
        return pd.read_csv(io.StringIO("\n".join(lines)), header=None, names=list(range(width)),
                           index_col=False, dtype=dtype, na_filter=False, skip_blank_lines=False)
    except pd.errors.ParserError as exc:
        match = _PANDAS_LINE.search(str(exc))
        if match:
            want, line, saw = (int(g) for g in match.groups())
            raise TrialError(where, f"line {numbers[line - 1]} has {saw} fields, the header has {want}") from None
        raise TrialError(where, f"cannot parse the CSV rows ({str(exc).splitlines()[-1]})") from None


def _bad_cell(cell: str, number: float, column: ColumnSpec, line: int, time: float | None) -> str:
    at = f"in column '{column.header}' at line {line}"
    if time is not None:
        at += f" (t = {time:g} s)"
    if cell == "":
        return f"empty cell {at}"
    if cell.lower() in _NAN_WORDS:
        return f"NaN {at}"
    if np.isinf(number):
        return f"infinite value '{cell}' {at}"
    return f"non-numeric value '{cell[:30]}' {at}"


def _check_time(where: str, time: np.ndarray, numbers: list[int]) -> None:
    step = np.diff(time)
    if np.any(step <= 0):
        k = int(np.flatnonzero(step <= 0)[0]) + 1
        raise TrialError(where, f"time does not increase at line {numbers[k]} "
                                f"(t = {time[k]:.9g} s after {time[k - 1]:.9g} s)")
    if time.size < MIN_SAMPLES:
        raise TrialError(where, f"trial too short: {time.size} samples (at least {MIN_SAMPLES} needed)")
    if time[-1] - time[0] < MIN_DURATION:
        raise TrialError(where, f"trial too short: {time[-1] - time[0]:.3g} s (at least {MIN_DURATION:g} s needed)")
    median = float(np.median(step))
    if np.any(step > GAP_FACTOR * median):
        k = int(np.flatnonzero(step > GAP_FACTOR * median)[0])
        raise TrialError(where, f"gap in time at line {numbers[k + 1]}: {step[k]:.6g} s without samples "
                                f"after t = {time[k]:.9g} s (median step {median:.6g} s)")


def _uniform(values: dict, warnings: list[str]) -> dict:
    """Put the samples on a uniform grid: snap tiny jitter, interpolate irregular sampling."""
    time = values["time"]
    n = time.size
    step = np.diff(time)
    median = float(np.median(step))
    mean = float((time[-1] - time[0]) / (n - 1))
    grid = time[0] + np.arange(n) * mean
    jitter = np.max(np.abs(step - median)) / median
    drift = np.max(np.abs(time - grid)) / mean
    if jitter <= JITTER_TOLERANCE and drift <= JITTER_TOLERANCE:
        return {**values, "time": grid}
    grid = time[0] + np.arange(int(np.floor((time[-1] - time[0]) / median * (1 + 1e-12))) + 1) * median
    warnings.append(f"irregular sampling (steps {step.min() * 1e3:.4g} to {step.max() * 1e3:.4g} ms) "
                    f"resampled by linear interpolation to a uniform {1 / median:.6g} Hz")
    return _interpolate(values, grid)


def _to_period(where: str, values: dict, period: float, warnings: list[str]) -> dict:
    """Resample to the protocol's sample period (zero-phase anti-alias filter if needed)."""
    time = values["time"]
    step = float((time[-1] - time[0]) / (time.size - 1))
    if abs(period - step) <= 1e-6 * period:
        return values
    ratio = period / step
    note = ""
    if ratio > 2:
        from scipy.signal import butter, sosfiltfilt
        cutoff = 0.8 * 0.5 / period
        sos = butter(8, cutoff, fs=1 / step, output="sos")
        values = {f: (v if v is None or f == "time" else sosfiltfilt(sos, v)) for f, v in values.items()}
        note = f", low-pass filtered at {cutoff:.4g} Hz first (zero-phase Butterworth)"
    count = int(np.floor((time[-1] - time[0]) / period * (1 + 1e-12))) + 1
    if count < MIN_SAMPLES:
        raise TrialError(where, f"trial too short: {count} samples after resampling to the protocol's "
                                f"sample period {period:g} s (at least {MIN_SAMPLES} needed)")
    warnings.append(f"resampled from {1 / step:.6g} Hz to {1 / period:.6g} Hz "
                    f"(protocol sample_period {period:g} s){note}")
    return _interpolate(values, time[0] + np.arange(count) * period)


def _interpolate(values: dict, grid: np.ndarray) -> dict:
    time = values["time"]
    out = {f: (None if v is None else np.interp(grid, time, v)) for f, v in values.items()}
    out["time"] = grid
    return out
