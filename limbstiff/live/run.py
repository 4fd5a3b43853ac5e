"""``limbstiff stream``: an LSL stream in, the live stiffness out, the recording analysed at the end.

:func:`run_stream` finds the stream, maps its channels through the protocol (by label, or
``channel_<i>`` for the i-th channel without one), and until it stops (``duration_s``, Ctrl-C, or
no sample for ``timeout_s``) feeds every chunk to a :class:`~limbstiff.live.session.LiveSession`,
publishes its rows on the ``limbstiff`` outlet with the input samples' time stamps, and writes the
recording and the live estimate as they arrive (:mod:`limbstiff.files.recording`).
The identification runs in a worker process, so the loop never waits for it. At the end it writes
``stream.json`` and runs the offline analysis on the recording (:func:`~limbstiff.batch.jobs.analyze_files`),
so the session ends with the same outputs as ``limbstiff analyze``.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..batch.jobs import analyze_files
from ..errors import StreamError
from ..files import lsl, lsl_outlet
from ..files.column_units import in_si
from ..files.columns import resolve_columns
from ..files.outputs import jsonable, write_json
from ..files.recording import GrowingTable, SegmentedRecording
from ..protocol import Protocol
from ..provenance import software
from .checks import REASONS, VERDICT_NAMES
from .latency import Latency
from .session import MEMORY_PERIODS, REFIT_EVERY_S, WARMUP_S, Identifier, LiveSession
from .status import status_line

LIVE_COLUMNS = ("time_s", "lsl_time_s", "stiffness", "stiffness_lo", "stiffness_hi", "observable", "verdict")


@dataclass(frozen=True)
class StreamSettings:
    """What ``limbstiff stream`` was asked to do.

    Parameters
    ----------
    name, type : str or None
        The input stream's name or type (one at least).
    out : Path
        Output folder: the recording ``<trial>.csv`` and ``<trial>/`` (live.csv, stream.json and the analysis).
    trial : str
        The recording's name.
    protocol : Protocol
    duration_s : float or None, s
        Stop after this much record (None: at Ctrl-C or when the stream ends).
    timeout_s : float, s
        No sample for this long ends the session (a stalled or ended stream; a sender restarted
        within it is read on).
    warmup_s : float, s
        Record before the first identification.
    resolve_s : float, s
        How long to look for the stream.
    outlet : str or None
        Name of the stiffness outlet (None: no outlet).
    seed : int
    pdf : bool
        Write the offline analysis's report.
    """

    name: str | None
    type: str | None
    out: Path
    trial: str
    protocol: Protocol = field(default_factory=Protocol)
    duration_s: float | None = None
    timeout_s: float = 10.0
    warmup_s: float = WARMUP_S
    resolve_s: float = 5.0
    outlet: str | None = "limbstiff"
    seed: int = 0
    pdf: bool = True


class WorkerIdentifier(Identifier):
    """Runs the identifications in one worker process (spawned, so that it shares no threads or
    sockets with the stream, and the loop never waits on the GIL for it).

    Where no process can be started (a script without the ``if __name__ == "__main__":`` guard that
    spawning needs), it goes on in a thread and says so in :attr:`note`."""

    def __init__(self, **options):
        super().__init__(**options)
        self.pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"), initializer=_ignore_interrupt)
        self.note: str | None = None
        self.pool.submit(_warm_up)      # the worker's imports and compiled kernels, during the warm-up

    def _run(self, call, *args, **kwargs):
        try:
            return self.pool.submit(call, *args, **kwargs)
        except (BrokenProcessPool, RuntimeError) as exc:
            self.pool.shutdown(wait=False, cancel_futures=True)
            self.pool = ThreadPoolExecutor(1)
            self.note = (f"the identification ran in a thread (no worker process: {type(exc).__name__}); "
                         "the live loop shared the processor with it")
            return self.pool.submit(call, *args, **kwargs)

    def close(self):
        self.pool.shutdown(wait=False, cancel_futures=True)


def _ignore_interrupt() -> None:
    """In the worker: Ctrl-C is for the session (which ends and keeps the recording); the worker,
    in the same process group, would otherwise die with a traceback on the terminal."""
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _warm_kernel() -> None:
    """Load the compiled chain in this process before the stream starts (loading it from numba's
    cache at the first take-over held that chunk up by tens of milliseconds)."""
    from ..statespace.noise import NoiseLevels
    from .estimator import LiveEstimator, LiveModel
    model = LiveModel(fs=100.0, corner_hz=10.0, motion_hz=1.0, noise=NoiseLevels(1.0, 1.0, 1.0, 1.0), inertia=0.0,
                      damping=0.0, covariance=np.zeros((2, 2)), initial_cov=(1.0, 1.0), typical_variance=None)
    LiveEstimator(model).push(np.zeros(32), np.zeros(32))


def _warm_up() -> None:
    from . import identify
    del identify      # imported for its imports: the analysis and the compiled kernels


def _headers(description: lsl.StreamDescription) -> list[str]:
    labels = [label.strip() for label in description.labels]
    seen: set[str] = set()
    out = []
    for i, label in enumerate(labels):
        name = label if label and label not in seen and label != "time_s" else f"channel_{i}"
        seen.add(name)
        out.append(name)
    return out


def _columns(description, protocol):
    headers = _headers(description)
    where = description.label
    # a stream's time is its time stamps: a protocol's time column (for its files) is not a channel
    protocol = dataclasses.replace(protocol, columns={k: v for k, v in protocol.columns.items() if k != "time"})
    columns = resolve_columns(where, headers, protocol, units=list(description.units), noun="channel",
                              need_time=False)
    if "torque" in columns and "elastic_torque" in columns:
        raise StreamError(where, "the stream has both an external and an elastic torque channel; map one in the protocol")
    torque = columns.get("elastic_torque") or columns.get("torque")
    # the units are linear: one factor per channel (SI conversion times the protocol's scale)
    picked = [_Channel(c.index, float(in_si(np.ones(1), c)[0]), c.unit) for c in (columns["angle"], torque)]
    return headers, picked[0], picked[1], ("direct" if "elastic_torque" in columns else "external")


@dataclass(frozen=True)
class _Channel:
    index: int
    factor: float
    unit: str


def _open_outputs(settings: StreamSettings, description, headers):
    folder = settings.out / settings.trial
    folder.mkdir(parents=True, exist_ok=True)
    meta = {"stream": description.name, "stream_type": description.type, "source_id": description.source_id,
            "hostname": description.hostname, "nominal_rate_hz": f"{description.fs:g}"}
    units = [u or "" for u in description.units]
    recording = SegmentedRecording(settings.out, settings.trial, headers, units, meta, description.fs)
    live = GrowingTable(folder / "live.csv", LIVE_COLUMNS, metadata={"stream": description.name})
    return folder, recording, live


def _outlet(settings: StreamSettings, description, unit: str):
    if settings.outlet is None:
        return None
    meta = {"input_stream": description.name, "input_source_id": description.source_id,
            "verdict_codes": "; ".join(f"{k} = {v}" for k, v in VERDICT_NAMES.items())}
    return lsl_outlet.StiffnessOutlet(name=settings.outlet, fs=description.fs, unit=unit,
                               source_id=f"limbstiff-{description.source_id or description.name}", metadata=meta)


@dataclass(frozen=True)
class StreamOutcome:
    """What a session did: its files, why it stopped, its events (``stream.json``)."""

    recordings: tuple[Path, ...]
    folder: Path
    stopped: str
    summary: dict
    report: object = None


def _stiffness_unit(angle_column) -> str:
    from ..units import DIMENSION_KIND, UNITS, canonical_unit
    unit = UNITS.get(canonical_unit(angle_column.unit))
    return "N/m" if unit is not None and DIMENSION_KIND[unit.dimension] == "translational" else "N*m/rad"


def _loop(settings, reader, session, recording, live, outlet, columns, progress):
    """Pull, estimate, publish, write, until a stop; returns why it stopped and the latency."""
    latency = Latency()
    last_sample = time.monotonic()
    shown = 0.0
    first_ts = None
    offset = reader.clock_offset
    try:
        while True:
            chunk = reader.pull(timeout=0.05)
            now = time.monotonic()
            if chunk.n == 0:
                sender = reader.sender_present() if now - last_sample > 1.0 else None
                if now - last_sample > settings.timeout_s:
                    return _silence(settings.timeout_s, sender), latency
                if now - last_sample > 1.0:
                    recording.flush()          # a stalled stream's last rows go to disk now
                    if progress and now - shown > 0.5:
                        progress(status_line(session, stalled_s=now - last_sample, ended=sender is False))
                        shown = now
                continue
            last_sample = now
            first_ts = chunk.timestamps[0] if first_ts is None else first_ts
            _one_chunk(chunk, session, recording, live, outlet, columns, latency)
            offset = _clock_step(reader, offset, session, chunk.timestamps[-1])
            if progress and now - shown > 0.5:
                progress(status_line(session))
                shown = now
            if settings.duration_s is not None and chunk.timestamps[-1] - first_ts >= settings.duration_s:
                return f"duration {settings.duration_s:g} s reached", latency
    except KeyboardInterrupt:
        return "stopped by the user", latency
    except StreamError as exc:
        return f"the stream failed: {exc}", latency
    except Exception as exc:    # the recording must be kept whatever went wrong; the error is said
        return (f"stopped by an internal error ({type(exc).__name__}: {exc}); the recording up to it is kept",
                latency)


def _silence(timeout_s: float, sender: bool | None) -> str:
    """Why a session without samples for ``timeout_s`` stopped: its sender closed the stream (a
    normal end), or is there but sends nothing, or (not known yet) either."""
    if sender is False:
        return f"the stream ended (its sender closed it; no sample for {timeout_s:g} s)"
    if sender:
        return f"no sample for {timeout_s:g} s (the stream stalled: its sender is there but sends nothing)"
    return f"no sample for {timeout_s:g} s (stream stalled or ended)"


def _one_chunk(chunk, session, recording, live, outlet, columns, latency):
    """Estimate, publish and write one chunk; a failure of the estimate or the outlet still writes
    the chunk to the recording before it ends the session."""
    started, started_cpu = time.perf_counter(), time.thread_time()
    angle_col, torque_col = columns
    ts, values = chunk.timestamps, chunk.values
    try:
        y = values[:, angle_col.index] * angle_col.factor
        f = values[:, torque_col.index] * torque_col.factor
        published = session.feed(ts, y, f)
        if outlet is not None:
            outlet.push(published.values, ts)
    except Exception:
        if not recording.tables:
            recording.segment(ts[0])
        recording.append(ts, values)
        raise
    done = time.perf_counter()
    latency.processing.add((done - started) / chunk.n)
    latency.processing_cpu.add((time.thread_time() - started_cpu) / chunk.n)
    latency.delay.add(chunk.pulled_at + (done - started) - ts[-1])
    _write(recording, live, ts, values, published)


#: A change of the sender's clock offset larger than this many sample periods is reported.
CLOCK_STEP_PERIODS = 1.0


def _clock_step(reader, offset: float, session, at: float) -> float:
    """Report a step of the clock offset LSL measures (its time stamps then jump by as much: a jump
    forward reads as missing samples, one backward as none)."""
    now = reader.clock_offset
    if np.isfinite(now) and np.isfinite(offset) and abs(now - offset) > CLOCK_STEP_PERIODS / session.fs:
        session.events.clock_steps.append({"at_lsl_time_s": float(at), "step_s": float(now - offset)})
    return now if np.isfinite(now) else offset


def _write(recording, live, ts, values, published):
    if not recording.tables:
        recording.segment(ts[0])
    start = 0
    usable = published.usable
    for cut in [*published.breaks, len(ts)]:
        if cut > start:
            keep = slice(start, cut) if usable is None else np.flatnonzero(usable[start:cut]) + start
            recording.append(ts[keep], values[keep])      # a sample that is not a number: left out
        if cut < len(ts):
            recording.segment(ts[cut])
        start = cut
    live.append(np.column_stack([ts - recording.zero, ts, published.values]))


def run_stream(settings: StreamSettings, *, progress: Callable[[str], None] | None = None,
               announce: Callable[[str], None] | None = None) -> StreamOutcome:
    """Run one live session (module docstring) and the offline analysis of its recording.

    Parameters
    ----------
    settings : StreamSettings
    progress : callable, optional
        Called with the status line (:func:`~limbstiff.live.status.status_line`) about twice a second.
    announce : callable, optional
        Called with one line once the recording and ``stream.json`` are written, before the analysis.

    Returns
    -------
    StreamOutcome

    Raises
    ------
    StreamError
        The stream is not found, or its channels do not map to an angle and a torque.
    """
    description = lsl.find_stream(name=settings.name, type=settings.type, timeout=settings.resolve_s)
    if not description.fs > 0:
        raise StreamError(description.label, "the stream has no nominal sampling rate (irregular); "
                                             "limbstiff needs a regularly sampled stream")
    headers, angle_col, torque_col, variant = _columns(description, settings.protocol)
    outlet = identifier = recording = live = None     # closed whatever happens: nothing left half-written
    try:
        outlet = _outlet(settings, description, _stiffness_unit(angle_col))
        identifier = WorkerIdentifier(protocol=settings.protocol, seed=settings.seed, name=settings.trial,
                                      variant=variant)
        _warm_kernel()
        session = LiveSession(description.fs, identifier, warmup_s=settings.warmup_s,
                              max_gap_s=settings.protocol.max_gap_s)
        folder, recording, live = _open_outputs(settings, description, headers)
        with lsl.StreamReader(description) as reader:
            offsets = [reader.clock_offset]
            stopped, latency = _loop(settings, reader, session, recording, live, outlet, (angle_col, torque_col),
                                     progress)
            offsets.append(reader.clock_offset)
    finally:
        paths = tuple(recording.close()) if recording is not None else ()
        for thing in (live, identifier, outlet):
            if thing is not None:
                thing.close()
    notes = [identifier.note] if identifier.note else []
    summary = _summary(settings, description, session, stopped, latency, offsets, paths, notes)
    write_json(folder / "stream.json", summary)
    if announce:
        recorded = ", ".join(str(p) for p in paths) or "nothing"
        announce(f"stream: {stopped}; {summary['samples']} samples recorded to {recorded}; live estimate and "
                 f"stream.json in {folder}")
    report = analyze_files([str(p) for p in paths], protocol=_analysis_protocol(settings.protocol, session),
                           out=settings.out, seed=settings.seed, pdf=settings.pdf, overwrite=True) if paths else None
    return StreamOutcome(recordings=paths, folder=folder, stopped=stopped, summary=summary, report=report)


def _analysis_protocol(protocol: Protocol, session: LiveSession) -> Protocol:
    """The protocol the recording is analysed with: the session's, bridging at least the gaps the
    live session bridged (a file's reader would otherwise refuse a gap the session took)."""
    longest = session.events.longest_bridged_s
    if protocol.max_gap_s is not None or not longest:
        return protocol
    return protocol.override(max_gap_s=longest + 0.5 / session.fs)


def _summary(settings, description, session, stopped, latency, offsets, paths, notes) -> dict:
    """``stream.json`` as plain JSON values (:func:`~limbstiff.files.outputs.jsonable`: numpy
    scalars converted, a value that is not a number as null)."""
    ev = session.events
    checks = ev.checks
    fs = description.fs
    return jsonable({
        "stream": {"name": description.name, "type": description.type, "source_id": description.source_id,
                   "hostname": description.hostname, "nominal_rate_hz": fs, "channels": list(description.labels)},
        "recordings": [p.name for p in paths], "stopped": stopped, "samples": ev.samples,
        "dropped_samples": ev.dropped_samples, "bridged_gaps": ev.bridged_gaps,
        "longest_bridged_gap_s": ev.longest_bridged_s, "non_finite_samples": ev.non_finite,
        "clock_steps": ev.clock_steps,
        "breaks": [{"from_lsl_time_s": a, "to_lsl_time_s": b} for a, b in ev.breaks],
        "clock_offset_s": {"start": offsets[0] if offsets else None, "end": offsets[-1] if offsets else None},
        "warmup_s": settings.warmup_s, "memory_periods": MEMORY_PERIODS,
        "identifications": [{**d, "at_s": d["at_samples"] / fs} for d in ev.identifications],
        "noise_refits": ev.refits, "noise_refit_every_s": REFIT_EVERY_S,
        "failed_noise_refits": [{**d, "at_s": d["at_samples"] / fs} for d in ev.failed_refits],
        "last_checks": None if checks is None else {
            "motion": checks.motion, "torque_explained": checks.explained,
            "tracking": checks.tracking, "moved": checks.moved, "swing": checks.swing,
            "whiteness": checks.whiteness, "band_width": checks.band_width,
            "negative_share": checks.negative_share, "hindsight": checks.hindsight,
            "verdict": checks.verdict.value,
            "failed": list(checks.failed), "reasons": [REASONS[name] for name in checks.failed]},
        "latency": latency.summary(), "notes": notes, "seed": settings.seed, "software": software(),
    })
