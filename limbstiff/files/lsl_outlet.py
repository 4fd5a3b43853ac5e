"""Live streams published on the Lab Streaming Layer (LSL): the stiffness outlet of ``limbstiff
stream``, and a trial published in real time (``limbstiff simulate --stream``, the tests).

I/O only (numpy; pylsl imported inside the functions). Finding and reading streams is
:mod:`limbstiff.files.lsl`. liblsl stamps nothing itself: the outlets send the timestamps they
are given, which consumers on other machines receive clock-corrected.
"""

from __future__ import annotations

import threading
import time
from typing import Callable, Mapping, Sequence

import numpy as np

from ..errors import StreamError
from ..trial import Trial
from ..units import parse_standard_header
from .lsl import _XML_NAME, _label, _pylsl, _why
from .trial_csv import _HEADERS, schedule_header


def _outlet(pylsl, *, name: str, type: str, fs: float, labels: Sequence[str],
            units: Sequence[str | None], source_id: str, metadata: Mapping[str, str] | None = None,
            channel_types: Sequence[str] | None = None):
    """A float64 outlet with ``desc/channels`` (label, unit, type) and ``metadata`` as desc
    children; it is discoverable as soon as it exists."""
    label = _label(name, type)
    if len(labels) != len(units):
        raise ValueError(f"{len(labels)} labels for {len(units)} units")
    info = pylsl.StreamInfo(name, type, len(labels), float(fs), pylsl.cf_double64, source_id)
    channels = info.desc().append_child("channels")
    for i, (text, unit) in enumerate(zip(labels, units)):
        channel = channels.append_child("channel")
        channel.append_child_value("label", str(text))
        if unit:
            channel.append_child_value("unit", str(unit))
        if channel_types is not None:
            channel.append_child_value("type", channel_types[i])
    for key, value in (metadata or {}).items():
        if not _XML_NAME.match(str(key)) or key == "channels":
            raise ValueError(f"metadata key {key!r} is not an XML element name")
        info.desc().append_child_value(str(key), str(value))
    try:
        return pylsl.StreamOutlet(info, chunk_size=0, max_buffered=360)
    except Exception as exc:
        raise StreamError(label, f"cannot publish the stream ({_why(exc)})") from None


class StiffnessOutlet:
    """The live estimate published as an LSL stream (a context manager around a pylsl outlet).

    Stream type ``Stiffness``, five float64 channels (:attr:`CHANNELS`), labels and units in
    ``desc/channels`` (the three stiffness channels in ``unit``, ``observable`` and ``verdict``
    unitless), ``metadata`` as children of ``desc`` (the input stream, the verdict codes…). liblsl
    keeps up to 360 s for a slow consumer and stamps nothing itself: :meth:`push` sends the
    timestamps it is given, which consumers on other machines receive clock-corrected.

    Parameters
    ----------
    name : str
    fs : float
        Nominal rate of the estimate, Hz (0: irregular).
    unit : str
        Unit of the stiffness channels, e.g. ``"N*m/rad"``.
    source_id : str
        Stable identifier (the same across restarts lets consumers recover).
    metadata : mapping of str to str
        Keys must be XML element names.
    """

    CHANNELS = ("stiffness", "stiffness_lo", "stiffness_hi", "observable", "verdict")
    TYPE = "Stiffness"

    def __init__(self, *, name: str = "limbstiff", fs: float, unit: str, source_id: str,
                 metadata: Mapping[str, str] | None = None):
        pylsl = _pylsl(_label(name, self.TYPE))
        self.name = name
        self._outlet = _outlet(pylsl, name=name, type=self.TYPE, fs=fs, labels=self.CHANNELS,
                               units=(unit, unit, unit, None, None), source_id=source_id,
                               metadata=metadata,
                               channel_types=("Stiffness",) * 3 + ("Observability", "Verdict"))

    def __enter__(self) -> "StiffnessOutlet":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def push(self, values: np.ndarray, timestamps: np.ndarray) -> None:
        """Send samples with their own timestamps (pylsl ``push_chunk``, one per sample).

        Parameters
        ----------
        values : ndarray, shape (n, 5)
            Rows in the order of :attr:`CHANNELS`.
        timestamps : ndarray, shape (n,), s
            In this machine's :func:`pylsl.local_clock` (e.g. the input samples' own timestamps).
        """
        values = np.ascontiguousarray(values, dtype=np.float64)
        timestamps = np.asarray(timestamps, dtype=np.float64)
        if values.ndim != 2 or values.shape[1] != len(self.CHANNELS) or timestamps.shape != values.shape[:1]:
            raise ValueError(f"push wants values (n, {len(self.CHANNELS)}) and timestamps (n,), "
                             f"got {values.shape} and {timestamps.shape}")
        if self._outlet is None:
            raise StreamError(_label(self.name, self.TYPE), "the outlet is closed")
        if values.shape[0]:
            self._outlet.push_chunk(values, timestamps.tolist())

    @property
    def have_consumers(self) -> bool:
        """Whether an inlet is connected."""
        return self._outlet is not None and self._outlet.have_consumers()

    def close(self) -> None:
        """Withdraw the stream (idempotent)."""
        outlet, self._outlet = self._outlet, None
        del outlet


def publish(values: np.ndarray, *, fs: float, labels: Sequence[str], units: Sequence[str | None],
            name: str, type: str = "Motion", source_id: str, realtime: bool = True,
            chunk_s: float = 0.01, start_delay_s: float = 0.0, wait_consumer_s: float = 0.0,
            stop: threading.Event | None = None, drop: slice | None = None,
            metadata: Mapping[str, str] | None = None, linger_s: float = 0.5,
            on_start: Callable[[float, bool], None] | None = None) -> int:
    """Publish the rows of ``values`` as an LSL stream at ``fs``, as if recorded now.

    Sample i is stamped ``t0 + i/fs`` (``t0`` = :func:`pylsl.local_clock` at the start) and, with
    ``realtime``, pushed no earlier than that time, in chunks every ``chunk_s`` s; the sleeps are
    scheduled against ``t0`` (no drift). Without ``realtime`` everything is pushed at once, with
    the same stamps.

    Parameters
    ----------
    values : ndarray, shape (n, c)
    fs : float
        Hz.
    labels, units : sequence, length c
        ``desc/channels/channel/label`` and ``unit`` (None: no unit element).
    name, type, source_id : str
    wait_consumer_s, start_delay_s : float
        Wait up to ``wait_consumer_s`` s for an inlet (then start anyway), then ``start_delay_s`` s.
    stop : threading.Event, optional
        Set it to stop early (checked between chunks and while waiting).
    drop : slice, optional
        Samples not sent (a gap, as a lost connection would make); their stamps are skipped.
    metadata : mapping of str to str, optional
        Children of ``desc``.
    linger_s : float
        The outlet stays open this long after the last push, so consumers get the last chunk.
    on_start : callable, optional
        ``on_start(t0, connected)``, just before the first push: ``t0`` (s, this machine's
        :func:`pylsl.local_clock`) and whether a consumer is connected.

    Returns
    -------
    int
        Samples pushed (dropped ones not counted).
    """
    values = np.ascontiguousarray(values, dtype=np.float64)
    if values.ndim != 2 or values.shape[1] != len(labels) or not fs > 0:
        raise ValueError(f"publish wants values (n, {len(labels)}) and fs > 0, got {values.shape}, {fs}")
    pylsl = _pylsl(_label(name, type))
    keep = np.ones(values.shape[0], dtype=bool)
    if drop is not None:
        keep[drop] = False
    stop = stop or threading.Event()
    outlet = _outlet(pylsl, name=name, type=type, fs=fs, labels=labels, units=units,
                     source_id=source_id, metadata=metadata)
    try:
        t0 = _start(outlet, pylsl.local_clock, wait_consumer_s, start_delay_s, stop, on_start)
        sent = _push_all(outlet, values, keep, t0, fs, chunk_s, realtime, stop, pylsl.local_clock)
        if linger_s > 0:
            stop.wait(linger_s)
        return sent
    finally:
        del outlet


def _start(outlet, clock: Callable[[], float], wait_consumer_s: float, start_delay_s: float,
           stop: threading.Event, on_start: Callable[[float, bool], None] | None) -> float:
    """Wait for a consumer (up to ``wait_consumer_s`` s), then ``start_delay_s`` s; the start time
    ``t0`` (s, ``clock``), told to ``on_start`` with whether a consumer is connected."""
    _wait_for_consumer(outlet, wait_consumer_s, stop)
    if start_delay_s > 0:
        stop.wait(start_delay_s)
    t0 = clock()
    if on_start is not None:
        on_start(t0, outlet.have_consumers())
    return t0


def _wait_for_consumer(outlet, seconds: float, stop: threading.Event) -> None:
    """liblsl's ``wait_for_consumers`` in 0.1 s slices, so that ``stop`` and Ctrl-C get through."""
    deadline = time.monotonic() + seconds
    while not stop.is_set() and time.monotonic() < deadline:
        if outlet.wait_for_consumers(min(0.1, max(0.0, deadline - time.monotonic()))):
            return


def _push_all(outlet, values: np.ndarray, keep: np.ndarray, t0: float, fs: float, chunk_s: float,
              realtime: bool, stop: threading.Event, clock: Callable[[], float]) -> int:
    step = max(1, int(round(chunk_s * fs))) if realtime else values.shape[0] or 1
    stamps = t0 + np.arange(values.shape[0]) / fs
    sent = 0
    for start in range(0, values.shape[0], step):
        if stop.is_set():
            break
        end = min(start + step, values.shape[0])
        if realtime:
            wait = stamps[end - 1] - clock()
            if wait > 0 and stop.wait(wait):
                break
        rows = keep[start:end]
        if rows.any():
            outlet.push_chunk(values[start:end][rows], stamps[start:end][rows].tolist())
            sent += int(rows.sum())
    return sent


def desc_metadata(metadata: Mapping[str, object]) -> dict[str, str]:
    """The entries of ``metadata`` that can be ``desc`` children of a stream (keys that are XML
    element names, ``channels`` excepted), values as one-line strings."""
    return {str(key): " ".join(str(value).split()) for key, value in metadata.items()
            if _XML_NAME.match(str(key)) and key != "channels"}


def trial_channels(trial: Trial) -> tuple[np.ndarray, tuple[str, ...], tuple[str | None, ...]]:
    """A trial's columns as stream channels, named as :func:`~limbstiff.files.write_trial`'s CSV
    header without the time column (``angle_rad``, ``torque_Nm``…, ``stiffness_true_Nm_per_rad``
    when known), so a recording of the stream reads back like the CSV.

    Returns
    -------
    values : ndarray, shape (n, c), SI units
    labels : tuple of str, length c
    units : tuple of (str or None), length c
        The unit part of each label (``rad``, ``Nm``, ``Nm_per_rad``…; None for ``marker``).
    """
    columns, labels = [], []
    for name, header in zip(("angle", "torque", "elastic_torque", "stiffness_true"), _HEADERS[trial.kind][1:]):
        array = getattr(trial, name)
        if array is not None:
            columns.append(np.asarray(array, dtype=float))
            labels.append(header)
    if trial.schedule is not None:
        columns.append(np.asarray(trial.schedule, dtype=float))
        labels.append(schedule_header(trial.schedule_unit))
    units = tuple(parse_standard_header(text)[1] for text in labels)
    if trial.marker is not None:
        columns.append(np.asarray(trial.marker, dtype=float))
        labels.append("marker")
        units += (None,)
    return np.column_stack(columns), tuple(labels), units
