"""From named SI arrays to a checked :class:`~limbstiff.trial.Trial`: the one validation path.

Every reader (delimited text, MAT) parses its file into SI arrays by Trial field, checks
each value is a finite number (it knows where a bad one sits: a line, a sample), and hands
them to :func:`checked_trial`, which applies the checks and fixes that do not depend on the
format: time strictly increasing, no gaps, long enough, some motion; snapping of sub-percent
jitter and resampling of irregular sampling onto a uniform grid; the protocol's sample
period; the file's SHA-256. Errors are one-line :class:`~limbstiff.errors.TrialError`\\ s.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Callable, Mapping

import numpy as np

from ..errors import TrialError
from ..plausibility import check_time
from ..trial import MIN_DURATION, MIN_SAMPLES, Trial

#: A time step larger than this many median steps is a gap (an error, never interpolated).
GAP_FACTOR = 3.0
#: Steps varying by more than this fraction of the median step are resampled (with a warning);
#: smaller jitter is snapped to the uniform grid silently.
JITTER_TOLERANCE = 0.01


def read_bytes(path: Path) -> bytes:
    """The bytes of a trial file, or a one-line :class:`TrialError` saying why not."""
    where = str(path)
    try:
        return path.read_bytes()
    except FileNotFoundError:
        raise TrialError(where, "file not found") from None
    except IsADirectoryError:
        raise TrialError(where, "is a directory, not a trial file") from None
    except OSError as exc:
        raise TrialError(where, f"cannot read file ({exc.strerror or exc})") from None


def checked_trial(path: Path, raw: bytes, values: Mapping[str, np.ndarray | None], *, kind: str,
                  protocol=None, name: str | None = None, metadata: Mapping[str, str] | None = None,
                  warnings: list[str] | None = None, locate: Callable[[int], str],
                  schedule_unit: str | None = None, units: Mapping[str, str] | None = None) -> Trial:
    """Check and regularise the arrays read from one file, and build the Trial.

    Parameters
    ----------
    path : Path
        The file (named in errors; its stem is the default trial name).
    raw : bytes
        The file's content, hashed into ``source_sha256``.
    values : mapping of str to ndarray or None
        By Trial field (``time`` in s, ``angle`` in rad or m, ``torque`` and
        ``elastic_torque`` in N·m or N, ``stiffness_true`` in N·m/rad or N/m; ``schedule`` in
        ``schedule_unit``, ``marker`` raw), finite, all of the same length; None (or absent) for
        fields the file does not have. Resampling interpolates every field linearly but the
        marker, which takes the largest value recorded since the grid's previous sample (a
        trigger's rising edges and short pulses are kept, never smeared into ramps).
    kind : {"rotational", "translational"}
    protocol : Protocol or None
        Its ``sample_period`` (s), if set, is the period every trial is resampled to.
    name : str or None
        Trial name; the file stem if None.
    metadata : mapping of str to str, optional
    warnings : list of str, optional
        What the reader noticed (ignored columns…); they follow the resampling notes.
    locate : callable
        ``locate(k)`` says where sample ``k`` (0-based) is in the file, e.g. ``"line 7"``.
    schedule_unit : str or None
        The unit of ``values["schedule"]`` (an SI unit or a free one); None without a schedule.
    units : mapping of str to str, optional
        The unit each quantity was written in (the Trial's ``units_written``).

    Returns
    -------
    Trial

    Raises
    ------
    TrialError
        Non-increasing time, a gap, too few samples or too short, no motion.
    """
    where = str(path)
    _check_time(where, values["time"], locate)
    values, gaps, notes = _trim_and_bridge(where, dict(values), protocol, locate)
    _check_motion(where, values["angle"], kind)
    values = _uniform(dict(values), notes)
    if protocol is not None and protocol.sample_period:
        values = _to_period(where, values, float(protocol.sample_period), notes)
    bridged = _bridged(values["time"], gaps)
    if values.get("schedule") is None:
        schedule_unit = None
    return Trial(name=name if name is not None else path.stem, kind=kind, metadata=dict(metadata or {}),
                 source=where, source_sha256=hashlib.sha256(raw).hexdigest(),
                 warnings=(*notes, *(warnings or ())), bridged=bridged if gaps else None,
                 schedule_unit=schedule_unit, units_written=dict(units or {}), **values)


def empty_block(empty: np.ndarray, k: int, time: np.ndarray | None, locate: Callable[[int], str]) -> str:
    """How to proceed past the run of empty cells of one column that starts at row ``k``.

    Parameters
    ----------
    empty : ndarray of bool, shape (n,)
        Which cells of the column are empty.
    k : int
        The first empty one (0-based row).
    time : ndarray, shape (n,), s, or None
        The time column (None when the empty column is the time itself).
    locate : callable
        ``locate(i)`` says where row ``i`` is in the file (``"line 9002"``).

    Returns
    -------
    str
        What the block is and what to do: cut the trial there, or delete its rows and bridge the gap
        they leave with the protocol's ``[format] max_gap_s`` (the value that bridges it given).
    """
    after = np.flatnonzero(~empty[k:])
    stop = k + int(after[0]) if after.size else empty.size
    block = f"{stop - k} empty cell(s) up to {locate(stop - 1)}" if stop - k > 1 else "one empty cell"
    if time is None or k == 0 or stop == empty.size:
        return f"{block}: delete those rows, or cut the trial before them"
    gap = float(time[stop] - time[k - 1])
    power = 10.0 ** (np.floor(np.log10(gap)) - 1)
    bridge = float(np.ceil(gap / power * (1 + 1e-9)) * power)
    return (f"{block} ({gap:.3g} s): delete those rows and bridge the gap they leave with [format] "
            f"max_gap_s = {bridge:.2g} in the protocol, or cut the trial there")


def _check_motion(where: str, angle: np.ndarray, kind: str) -> None:
    """Error unless the angle (position) takes at least three distinct values."""
    label = "angle" if kind == "rotational" else "position"
    distinct = np.unique(angle).size
    if distinct == 1:
        raise TrialError(where, f"no motion: {label} is constant ({angle[0]:g})")
    if distinct < 3:
        raise TrialError(where, f"no motion: {label} takes only {distinct} distinct values")


def _bridged(grid: np.ndarray, gaps) -> np.ndarray:
    """Samples of the time ``grid`` (s, shape (n,)) strictly inside a bridged gap ``(a, b)``, s."""
    bridged = np.zeros(grid.size, dtype=bool)
    for a, b in gaps:
        bridged |= (grid > a) & (grid < b)
    return bridged


def _check_time(where: str, time: np.ndarray, locate: Callable[[int], str]) -> None:
    step = np.diff(time)
    if np.any(step <= 0):
        k = int(np.flatnonzero(step <= 0)[0]) + 1
        raise TrialError(where, f"time does not increase at {locate(k)} "
                                f"(t = {time[k]:.9g} s after {time[k - 1]:.9g} s)")
    if time.size < MIN_SAMPLES:
        raise TrialError(where, f"trial too short: {time.size} samples (at least {MIN_SAMPLES} needed)")
    if time[-1] - time[0] < MIN_DURATION:
        for finding in check_time(time):       # a unit slip says so (s read as ms) rather than "too short"
            raise TrialError(where, finding.message)
        raise TrialError(where, f"trial too short: {time[-1] - time[0]:.3g} s (at least {MIN_DURATION:g} s needed)")


#: Runs of samples at either end cut off by a gap that hold fewer samples than the larger of this
#: share of the trial and :data:`EDGE_MIN_SAMPLES` are dropped: a logger's first sample written
#: 0.2 s before the rest is not part of the recording.
EDGE_FRACTION, EDGE_MIN_SAMPLES = 0.01, 10
#: The default longest bridged gap, as a share of the motion's typical period (the angle's
#: crossings of its median): a gap that long is interpolated over a quarter of a cycle at most.
GAP_PERIOD_FRACTION = 0.25


def default_max_gap(time: np.ndarray, angle: np.ndarray) -> float:
    """The longest gap bridged when the protocol does not say: :data:`GAP_PERIOD_FRACTION` of the
    motion's typical period, s, estimated as twice the duration over the angle's crossings of its
    median (with a hysteresis of 5 % of its 5–95 % spread, so that encoder dither does not count),
    and at least :data:`GAP_FACTOR` median steps."""
    y = np.asarray(angle, dtype=float) - float(np.median(angle))
    band = 0.05 * float(np.subtract(*np.percentile(y, [95, 5])))
    state = np.where(y > band, 1, np.where(y < -band, -1, 0))
    signs = state[state != 0]
    crossings = int(np.count_nonzero(np.diff(signs))) if signs.size else 0
    duration = float(time[-1] - time[0])
    period = 2.0 * duration / crossings if crossings else duration
    return max(GAP_PERIOD_FRACTION * period, GAP_FACTOR * float(np.median(np.diff(time))))


def _trim_and_bridge(where: str, values: dict, protocol, locate) -> tuple[dict, list, list[str]]:
    """Drop isolated samples cut off at either end by a gap; refuse a gap longer than the
    longest bridged one; return the gaps left (to be interpolated over) as (t_before, t_after).

    A gap is a step longer than :data:`GAP_FACTOR` median steps.
    """
    time = values["time"]
    step = np.diff(time)
    median = float(np.median(step))
    gaps = np.flatnonzero(step > GAP_FACTOR * median)
    if not gaps.size:
        return values, [], []
    n, notes = time.size, []
    edge = max(EDGE_MIN_SAMPLES, int(EDGE_FRACTION * n))
    start = int(gaps[0]) + 1 if gaps[0] + 1 < edge else 0
    stop = int(gaps[-1]) + 1 if n - gaps[-1] - 1 < edge and gaps[-1] + 1 > start else n
    if start or stop < n:
        notes.append(f"{start + n - stop} isolated sample(s) dropped at the "
                     f"{'start and end' if start and stop < n else 'start' if start else 'end'} of the "
                     "file (cut off from the rest by a gap in time)")
        values = {f: None if v is None else v[start:stop] for f, v in values.items()}
        time = values["time"]
        _check_time(where, time, locate)                  # still long enough without them?
        step = np.diff(time)
        gaps = np.flatnonzero(step > GAP_FACTOR * float(np.median(step)))
    given = getattr(protocol, "max_gap_s", None)
    longest = float(given) if given else default_max_gap(time, values["angle"])
    origin = "protocol" if given else "from the data: a quarter of the motion's period"
    too_long = [int(k) for k in gaps if step[k] > longest]
    if too_long:
        k = too_long[0]
        raise TrialError(where, f"gap in time at {locate(start + k + 1)}: {step[k]:.6g} s without samples after "
                                f"t = {time[k]:.9g} s, longer than the longest bridged gap max_gap_s = "
                                f"{longest:.3g} s ({origin}); set [format] max_gap_s in a protocol to bridge it, "
                                "or split the file there")
    if gaps.size:
        notes.append(f"{gaps.size} gap(s) in time bridged by linear interpolation (longest {step[gaps].max():.3g} s, "
                     f"{step[gaps].sum():.3g} s in all; max_gap_s {longest:.3g} s, {origin}); "
                     "the bridged stretches count as not informed by motion")
    return values, [(float(time[k]), float(time[k + 1])) for k in gaps], notes


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
        values = {f: (v if v is None or f in ("time", "marker") else sosfiltfilt(sos, v)) for f, v in values.items()}
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
    out = {f: (None if v is None else _held(time, v, grid) if f == "marker" else np.interp(grid, time, v))
           for f, v in values.items()}
    out["time"] = grid
    return out


def _held(time: np.ndarray, values: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """A marker on a new time grid: at each grid time the largest value recorded since the grid's
    previous time (after it, up to and including this one), else the last value before it.

    A rising edge appears at the first grid time at or after it, as with the previous sample; a
    pulse shorter than the new step is kept rather than fall between two grid times.
    """
    values = np.asarray(values, dtype=float)
    out = np.full(grid.size, -np.inf)
    bucket = np.searchsorted(grid, time, side="left")       # the first grid time at or after each sample
    inside = bucket < grid.size
    np.maximum.at(out, bucket[inside], values[inside])
    empty = np.isneginf(out)
    if empty.any():
        previous = np.clip(np.searchsorted(time, grid[empty], side="right") - 1, 0, time.size - 1)
        out[empty] = values[previous]
    return out
