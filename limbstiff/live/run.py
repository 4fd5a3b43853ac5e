"""``limbstiff stream``: an LSL stream in, the live stiffness out, the recording analysed at the end.

:func:`run_stream` finds the stream, maps its channels through the protocol (by label, or
``channel_<i>`` for the i-th channel without one), and until it stops (``duration_s``, ``stop``
set — Ctrl-C —, or no sample for ``timeout_s``) feeds every chunk to a :class:`~limbstiff.live.session.LiveSession`,
publishes its rows on the ``limbstiff`` outlet with the input samples' time stamps, and writes the
recording and the live estimate as they arrive (:class:`~limbstiff.files.recording.GrowingTable`).
The identification runs in a worker process, so the loop never waits for it. At the end it writes
``stream.json`` and runs the offline analysis on the recording (:func:`~limbstiff.batch.jobs.analyze_files`),
so the session ends with the same outputs as ``limbstiff analyze``.
"""

from __future__ import annotations

import dataclasses
import json
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
from ..files.atomic import atomic_write_text
from ..files.columns import in_si, resolve_columns
from ..files.recording import GrowingTable
from ..protocol import Protocol
from ..result import software
from .checks import VERDICT_NAMES
from .identify import identify_live, refit_live
from .session import MEMORY_PERIODS, REFIT_EVERY_S, WARMUP_S, LiveSession
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
        No sample for this long ends the session (a stalled or ended stream).
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


class WorkerIdentifier:
    """Runs :func:`~limbstiff.live.identify.identify_live` in one worker process (spawned, so that
    it shares no threads or sockets with the stream, and the loop never waits on the GIL for it).

    Where no process can be started (a script without the ``if __name__ == "__main__":`` guard that
    spawning needs), it goes on in a thread and says so in :attr:`note`."""

    def __init__(self, **options):
        self.options = {"memory_periods": MEMORY_PERIODS, **options}
        self.pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"), initializer=_ignore_interrupt)
        self.note: str | None = None
        self.pool.submit(_warm_up)      # the worker's imports and compiled kernels, during the warm-up

    def submit(self, angle, torque, fs):
        return self._submit(identify_live, angle, torque, fs=fs, **self.options)

    def _submit(self, call, *args, **kwargs):
        try:
            return self.pool.submit(call, *args, **kwargs)
        except (BrokenProcessPool, RuntimeError) as exc:
            self.pool.shutdown(wait=False, cancel_futures=True)
            self.pool = ThreadPoolExecutor(1)
            self.note = (f"the identification ran in a thread (no worker process: {type(exc).__name__}); "
                         "the live loop shared the processor with it")
            return self.pool.submit(call, *args, **kwargs)

    def refit(self, angle, torque, fs, previous):
        return self._submit(refit_live, angle, torque, previous=previous, memory_periods=self.options["memory_periods"],
                            variant=self.options.get("variant") or "external")

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


@dataclass
class _Latency:
    processing: list = field(default_factory=list)     # s per sample (wall), one per chunk
    processing_cpu: list = field(default_factory=list)  # s per sample (this thread's CPU), one per chunk
    delay: list = field(default_factory=list)          # s, publication − input time stamp, per chunk's last sample

    def summary(self) -> dict:
        def stats(values, scale):
            if not values:
                return None
            v = np.asarray(values) * scale
            return {"median": float(np.median(v)), "p99": float(np.percentile(v, 99)),
                    "p99_9": float(np.percentile(v, 99.9)), "max": float(v.max()), "chunks": len(v)}
        return {"processing_us_per_sample": stats(self.processing, 1e6),
                "processing_cpu_us_per_sample": stats(self.processing_cpu, 1e6),
                "end_to_end_ms": stats(self.delay, 1e3)}


class _Recording:
    """The raw samples as received, one file per segment (a break starts ``<trial>-2.csv``…)."""

    def __init__(self, out: Path, trial: str, headers, units, metadata, fs: float):
        self.out, self.trial, self.headers, self.units, self.metadata = out, trial, headers, units, metadata
        self.fs = fs
        self.tables: list[GrowingTable] = []
        self.t0 = self.zero = 0.0

    def segment(self, t0: float):
        if self.tables:
            self.tables[-1].close()
        suffix = "" if not self.tables else f"-{len(self.tables) + 1}"
        meta = {**self.metadata, "lsl_time_at_zero_s": repr(float(t0))}
        self.tables.append(GrowingTable(self.out / f"{self.trial}{suffix}.csv", ["time_s", *self.headers],
                                        units=["s", *self.units], metadata=meta))
        self.t0 = float(t0)
        if len(self.tables) == 1:
            self.zero = self.t0

    def append(self, timestamps, values):
        # on the stream's nominal grid: LSL's clock correction moves the stamps by ~1 % of a period
        # from sample to sample, which a reader would resample; the raw stamps are in live.csv
        grid = np.round((timestamps - self.t0) * self.fs) / self.fs
        self.tables[-1].append(np.column_stack([grid, values]))

    def close(self) -> list[Path]:
        return [table.close() for table in self.tables]


def _open_outputs(settings: StreamSettings, description, headers):
    folder = settings.out / settings.trial
    folder.mkdir(parents=True, exist_ok=True)
    meta = {"stream": description.name, "stream_type": description.type, "source_id": description.source_id,
            "hostname": description.hostname, "nominal_rate_hz": f"{description.fs:g}"}
    units = [u or "" for u in description.units]
    recording = _Recording(settings.out, settings.trial, headers, units, meta, description.fs)
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
    angle_col, torque_col = columns
    latency = _Latency()
    last_sample = time.monotonic()
    shown = 0.0
    first_ts = None
    stopped = "the stream ended"
    try:
        while True:
            chunk = reader.pull(timeout=0.05)
            now = time.monotonic()
            if chunk.n == 0:
                if now - last_sample > settings.timeout_s:
                    stopped = f"no sample for {settings.timeout_s:g} s (stream stalled or ended)"
                    break
                if progress and now - last_sample > 1.0 and now - shown > 0.5:
                    progress(status_line(session, stalled_s=now - last_sample))
                    shown = now
                continue
            started, started_cpu = time.perf_counter(), time.thread_time()
            last_sample = now
            ts, values = chunk.timestamps, chunk.values
            first_ts = ts[0] if first_ts is None else first_ts
            y = values[:, angle_col.index] * angle_col.factor
            f = values[:, torque_col.index] * torque_col.factor
            published = session.feed(ts, y, f)
            if outlet is not None:
                outlet.push(published.values, ts)
            done = time.perf_counter()
            latency.processing.append((done - started) / chunk.n)
            latency.processing_cpu.append((time.thread_time() - started_cpu) / chunk.n)
            latency.delay.append(chunk.pulled_at + (done - started) - ts[-1])
            _write(recording, live, ts, values, published)
            if progress and now - shown > 0.5:
                progress(status_line(session))
                shown = now
            if settings.duration_s is not None and ts[-1] - first_ts >= settings.duration_s:
                stopped = f"duration {settings.duration_s:g} s reached"
                break
    except KeyboardInterrupt:
        stopped = "stopped by the user"
    except StreamError as exc:
        stopped = f"the stream failed: {exc}"
    except Exception as exc:    # the recording must be kept whatever went wrong; the error is said
        stopped = f"stopped by an internal error ({type(exc).__name__}: {exc}); the recording up to it is kept"
    return stopped, latency


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


def run_stream(settings: StreamSettings, *, progress: Callable[[str], None] | None = None) -> StreamOutcome:
    """Run one live session (module docstring) and the offline analysis of its recording.

    Parameters
    ----------
    settings : StreamSettings
    progress : callable, optional
        Called with the status line (:func:`~limbstiff.live.status.status_line`) about twice a second.

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
    folder, recording, live = _open_outputs(settings, description, headers)
    identifier = WorkerIdentifier(protocol=settings.protocol, seed=settings.seed, name=settings.trial, variant=variant)
    _warm_kernel()
    session = LiveSession(description.fs, identifier, warmup_s=settings.warmup_s)
    outlet = _outlet(settings, description, _stiffness_unit(angle_col))
    offsets = []
    try:
        with lsl.StreamReader(description) as reader:
            offsets.append(reader.clock_offset)
            stopped, latency = _loop(settings, reader, session, recording, live, outlet, (angle_col, torque_col),
                                     progress)
            offsets.append(reader.clock_offset)
    finally:
        paths = tuple(recording.close())
        live.close()
        identifier.close()
        if outlet is not None:
            outlet.close()
    notes = [identifier.note] if identifier.note else []
    summary = _summary(settings, description, session, stopped, latency, offsets, paths, notes)
    atomic_write_text(folder / "stream.json", json.dumps(summary, indent=2, allow_nan=False, default=_jsonable) + "\n")
    report = analyze_files([str(p) for p in paths], protocol=settings.protocol, out=settings.out,
                           seed=settings.seed, pdf=settings.pdf, overwrite=True) if paths else None
    return StreamOutcome(recordings=paths, folder=folder, stopped=stopped, summary=summary, report=report)


def _jsonable(value):
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    raise TypeError(type(value).__name__)


def _summary(settings, description, session, stopped, latency, offsets, paths, notes) -> dict:
    ev = session.events
    checks = ev.checks
    fs = description.fs
    return {
        "stream": {"name": description.name, "type": description.type, "source_id": description.source_id,
                   "hostname": description.hostname, "nominal_rate_hz": fs, "channels": list(description.labels)},
        "recordings": [p.name for p in paths], "stopped": stopped, "samples": ev.samples,
        "dropped_samples": ev.dropped_samples, "bridged_gaps": ev.bridged_gaps, "non_finite_samples": ev.non_finite,
        "breaks": [{"from_lsl_time_s": a, "to_lsl_time_s": b} for a, b in ev.breaks],
        "clock_offset_s": {"start": _finite(offsets[0]) if offsets else None,
                           "end": _finite(offsets[-1]) if offsets else None},
        "warmup_s": settings.warmup_s, "memory_periods": MEMORY_PERIODS,
        "identifications": [{**d, "at_s": d["at_samples"] / fs} for d in ev.identifications],
        "noise_refits": ev.refits, "noise_refit_every_s": REFIT_EVERY_S,
        "failed_noise_refits": [{**d, "at_s": d["at_samples"] / fs} for d in ev.failed_refits],
        "last_checks": None if checks is None else {
            "motion": checks.motion, "torque_explained": _finite(checks.explained),
            "tracking": _finite(checks.tracking), "moved": _finite(checks.moved),
            "whiteness": _finite(checks.whiteness), "band_width": _finite(checks.band_width),
            "negative_share": checks.negative_share, "verdict": VERDICT_NAMES[checks.verdict],
            "failed": list(checks.failed)},
        "latency": latency.summary(), "notes": notes, "seed": settings.seed, "software": software(),
    }


def _finite(x: float):
    return float(x) if np.isfinite(x) else None
