"""A live session's logic, whatever the samples come from: gaps, the identification schedule, the
estimate published for every sample received, the checks.

:class:`LiveSession` takes chunks of time-stamped samples (:meth:`LiveSession.feed`) and returns
what to publish for each: stiffness, band, observable and the verdict code
(:data:`~limbstiff.live.checks.VERDICT_NAMES`). Until the first identification has come back it
publishes NaN with the code "no estimate yet". The identification (:func:`~limbstiff.live.identify.identify_live`)
is asked for at :func:`identification_due` record lengths through an ``identifier`` — run at once
(:class:`Immediately`, for replays and tests) or in a worker process (``limbstiff stream``) — and
when it comes back its estimator, carried to the sample it was given, is brought up to the present
and takes over. Pure numpy: no I/O, no clock (the caller measures times).
"""

from __future__ import annotations

import math
from concurrent.futures import Future
from dataclasses import dataclass, field

import numpy as np

from ..errors import LimbstiffError
from ..settings import OBSERVABLE_PERIODS
from .buffers import PublishedBand, Record, Window
from ..checks.verdict import NO_ESTIMATE
from .checks import Hindsight, LiveChecks, hindsight, window_s
from .identify import LONGEST_RECORD_S, REFIT_RECORD_S, LiveIdentification, identify_live, refit_live

#: The first identification after this many seconds of record (``--warmup``), then each time the
#: record doubles, then every :data:`REIDENTIFY_EVERY_S`.
WARMUP_S = 5.0
REIDENTIFY_EVERY_S = 60.0
#: The stiffness's fading memory, in motion periods: the offline analysis calls a sample observable
#: when the motion of the last as many periods informs it (:data:`~limbstiff.settings.OBSERVABLE_PERIODS`).
#: Without it a stiffness that starts to change after the first identification saw it constant was
#: followed seconds late (the simulated elbow's ramp: 34 % median error; with it 4 %).
MEMORY_PERIODS = OBSERVABLE_PERIODS
#: Between identifications the noise levels are refitted on the recent record (:func:`~limbstiff.live.identify.refit_live`)
#: every this many seconds: on seven clean trials of two simulators (22 s each) the median error
#: after 5 s went from 4.2–7.8 % to 3.3–4.6 % on those whose stiffness changes (refits every 1 s
#: gave no more: 3.3–5.6 %).
REFIT_EVERY_S = 2.0
#: The checks are made again every this many seconds of record.
CHECK_EVERY_S = 0.25
#: Gaps up to this many motion periods (a quarter cycle, the offline readers' default) are bridged
#: by interpolation; longer ones restart the estimate (a break).
BRIDGE_PERIODS = 0.25
#: Seconds of the published band kept for the ``hindsight`` check: a checks window of a slow motion
#: (0.24 Hz: 42 s) and its memory (8 s), and the time an identification takes to come back.
PUBLISHED_S = 120.0


def identification_due(done: int, *, warmup_s: float = WARMUP_S) -> float:
    """Record length (s) at which identification number ``done`` (0-based) is due: the warm-up,
    then doubling while that stays within :data:`REIDENTIFY_EVERY_S`, then every
    :data:`REIDENTIFY_EVERY_S` after the last one."""
    doublings = int(np.floor(np.log2(REIDENTIFY_EVERY_S / warmup_s))) if warmup_s < REIDENTIFY_EVERY_S else 0
    if done <= doublings:
        return warmup_s * 2.0 ** done
    return warmup_s * 2.0 ** doublings + (done - doublings) * REIDENTIFY_EVERY_S


class Identifier:
    """How the session asks for a model: :meth:`submit` (a full identification) and :meth:`refit`
    (the noise levels only), each returning a ``Future``; :meth:`_run` says where they run.

    Parameters
    ----------
    **options
        Keywords of :func:`~limbstiff.live.identify.identify_live` (protocol, seed, name, variant,
        memory_periods: default :data:`MEMORY_PERIODS`).
    """

    def __init__(self, **options):
        self.options = {"memory_periods": MEMORY_PERIODS, **options}

    def submit(self, angle, torque, fs) -> Future:
        return self._run(identify_live, angle, torque, fs=fs, **self.options)

    def refit(self, angle, torque, fs, previous) -> Future:
        return self._run(refit_live, angle, torque, previous=previous, memory_periods=self.options["memory_periods"],
                         variant=self.options.get("variant") or "external", protocol=self.options.get("protocol"))

    def _run(self, call, *args, **kwargs) -> Future:
        raise NotImplementedError


class Immediately(Identifier):
    """An identifier that identifies at once, in this process (replays, tests)."""

    def _run(self, call, *args, **kwargs) -> Future:
        done: Future = Future()
        try:
            done.set_result(call(*args, **kwargs))
        except LimbstiffError as exc:
            done.set_exception(exc)
        return done


@dataclass
class SessionEvents:
    """What happened to the stream and the model during a session (``stream.json``)."""

    samples: int = 0
    non_finite: int = 0
    longest_bridged_s: float = 0.0
    clock_steps: list = field(default_factory=list)
    refits: int = 0
    failed_refits: list = field(default_factory=list)
    dropped_samples: int = 0
    bridged_gaps: int = 0
    breaks: list = field(default_factory=list)
    identifications: list = field(default_factory=list)
    checks: LiveChecks | None = None


@dataclass(frozen=True)
class Published:
    """The rows to publish for one chunk: one per sample received.

    Parameters
    ----------
    timestamps : ndarray, shape (n,), s
        The input samples' time stamps.
    values : ndarray, shape (n, 5)
        stiffness, stiffness_lo, stiffness_hi, observable (0/1), verdict code.
    breaks : tuple of int
        The samples that start a new segment (after a gap too long to bridge; 0 when the gap is
        before the chunk): the recording starts a new file there.
    usable : ndarray of bool, shape (n,), or None
        False for the samples left out (angle or torque not a number); None when all are used.
    """

    timestamps: np.ndarray
    values: np.ndarray
    breaks: tuple = ()
    usable: np.ndarray | None = None


class LiveSession:
    """The live estimate over a stream of chunks.

    Parameters
    ----------
    fs : float, Hz
        The stream's nominal rate.
    identifier : Identifier
        Runs the identifications (:class:`Immediately`, or a worker process).
    warmup_s : float, s
        Record before the first identification.
    max_gap_s : float, optional, s
        The longest gap bridged (the protocol's ``[format] max_gap_s``, as the file readers take
        it); by default a quarter of a motion period.
    """

    def __init__(self, fs: float, identifier, *, warmup_s: float = WARMUP_S, max_gap_s: float | None = None):
        self.fs, self.identifier, self.warmup_s = float(fs), identifier, float(warmup_s)
        self.max_gap_s = max_gap_s
        self.record = Record(LONGEST_RECORD_S * self.fs)
        self.events = SessionEvents()
        self.estimator = None
        self.model = None
        self.pending: Future | None = None
        self._pending_at = 0
        self._pending_kind = "full"
        self._done = 0
        self._due_for, self._due_s = -1, 0.0
        self._last_time: float | None = None
        self._window = Window(1)
        self._verdict = NO_ESTIMATE
        self._since_check = 0
        self._band = PublishedBand(int(PUBLISHED_S * self.fs))
        self._looked_back: Hindsight | None = None
        self.last: np.ndarray | None = None

    def feed(self, timestamps: np.ndarray, angle: np.ndarray, torque: np.ndarray) -> Published:
        """Take the next samples (SI units, in order) and return what to publish for them.

        A sample whose angle or torque is not a number (a sensor's dropout) is left out, as a
        missing one: bridged or a break, counted in ``events.non_finite``; its row is NaN.
        """
        timestamps = np.asarray(timestamps, dtype=float)
        angle, torque = np.asarray(angle, dtype=float), np.asarray(torque, dtype=float)
        # an estimator that came back takes over before these samples (its catch-up ends where the
        # record does now), and before the gaps are judged, by the model that will feed them
        self._take_identification()
        finite = None          # rare: then sample by sample
        if len(angle) and not (math.isfinite(angle.min()) and math.isfinite(angle.max())
                               and math.isfinite(torque.min()) and math.isfinite(torque.max())):
            finite = np.isfinite(angle) & np.isfinite(torque)
        if finite is not None and not finite.all():
            keep = np.flatnonzero(finite)
            inner = self.feed(timestamps[keep], angle[keep], torque[keep])
            values = np.full((len(timestamps), 5), np.nan)
            values[:, 3], values[:, 4] = 0.0, self._verdict if self.estimator is not None else NO_ESTIMATE
            values[keep] = inner.values
            self.events.samples += len(timestamps) - len(keep)
            self.events.non_finite += len(timestamps) - len(keep)
            return Published(timestamps, values, tuple(int(keep[b]) for b in inner.breaks), finite)
        values = np.full((len(timestamps), 5), np.nan)
        values[:, 4] = NO_ESTIMATE
        gaps, breaks = self._gaps_in(timestamps)
        start = 0
        for cut in gaps:             # each piece bridges or breaks from the sample before it
            self._segment(timestamps[start:cut], angle[start:cut], torque[start:cut], values[start:cut])
            start = cut
        self._segment(timestamps[start:], angle[start:], torque[start:], values[start:])
        self.events.samples += len(timestamps)
        if len(values):
            self.last = values[-1]
        return Published(timestamps, values, tuple(breaks))

    def _gaps_in(self, timestamps: np.ndarray) -> tuple[list[int], list[int]]:
        """The samples of a chunk after a missing sample (1.5 periods or more), and of those the
        ones after a gap too long to bridge (0 when that gap is before the chunk)."""
        n = len(timestamps)
        if not n:
            return [], []
        longest = self._longest_gap()
        first = self._last_time is not None and timestamps[0] - self._last_time > longest
        # a chunk no longer than its samples at the nominal rate misses none (most chunks: no diff)
        if n < 2 or timestamps[-1] - timestamps[0] <= (n - 0.5) / self.fs:
            gaps = []
        else:
            step = np.diff(timestamps)
            gaps = (np.flatnonzero(step > 1.5 / self.fs) + 1).tolist()
        breaks = [i for i in gaps if timestamps[i] - timestamps[i - 1] > longest]
        return gaps, ([0] if first else []) + breaks

    def _longest_gap(self) -> float:
        if self.max_gap_s is not None:
            return float(self.max_gap_s)
        motion = self.model.motion_hz if self.model is not None else None
        return max(BRIDGE_PERIODS / motion if motion else 0.1, 3.0 / self.fs)

    def _segment(self, t, y, f, values):
        if not len(t):
            return
        if self._last_time is not None:
            gap = t[0] - self._last_time
            if gap > self._longest_gap():
                self._break(self._last_time, t[0])
            elif gap > 1.5 / self.fs:
                self._bridge(t[0], y[0], f[0], gap)
        self._last_time = float(t[-1])
        position = self.record.total
        self.record.append(y, f)
        if self.estimator is None:
            self._band.add(position, None, len(t))
        else:
            out = self.estimator.push(y, f)
            values[:, :4] = out.rows[:, :4]
            self._band.add(position, out.rows)
            steps = out.steps
            if steps.any():
                self._window.add(out.rows[steps])
            self._since_check += len(t)
            fresh = self._verdict == NO_ESTIMATE and np.isfinite(out.rows[-1, 0])     # a first estimate
            if self._since_check >= CHECK_EVERY_S * self.fs or fresh:
                self._since_check = 0
                self.events.checks = self._window.checks(self._looked_back, self._recent())
                self._verdict = self.events.checks.verdict.code
            values[:, 4] = self._verdict
            if np.isnan(values[0, 0]):        # the estimate's first samples (a prefix): none yet
                values[np.isnan(values[:, 0]), 4] = NO_ESTIMATE
        self._ask_identification()

    def _bridge(self, t_next, y_next, f_next, gap):
        """Samples missing between the last one and the next: filled by linear interpolation."""
        missing = int(round(gap * self.fs)) - 1
        if missing <= 0:
            return
        self.events.dropped_samples += missing
        self.events.bridged_gaps += 1
        self.events.longest_bridged_s = max(self.events.longest_bridged_s, float(gap))
        w = np.arange(1, missing + 1) / (missing + 1)
        y = self.record.angle[self.record.n - 1] * (1 - w) + y_next * w
        f = self.record.torque[self.record.n - 1] * (1 - w) + f_next * w
        self._band.add(self.record.total, None, missing)        # not published: not judged
        self.record.append(y, f)
        if self.estimator is not None:
            self.estimator.push(y, f)

    def _break(self, before: float, after: float):
        """A gap too long to bridge: the estimate starts again (the model is kept)."""
        self.events.breaks.append((before, after))
        self.events.dropped_samples += max(int(round((after - before) * self.fs)) - 1, 0)
        self.record = Record(LONGEST_RECORD_S * self.fs)
        self._band = PublishedBand(len(self._band.rows))
        self._looked_back = None
        self._done = 0 if self.model is None else 1
        self.pending, self._pending_at = None, 0
        if self.estimator is not None:
            self.estimator.reset()
            self._window = self._new_window()
            self._verdict, self.events.checks = NO_ESTIMATE, None

    def _ask_identification(self):
        if self.pending is not None:
            return
        n = self.record.total
        due = self._due(self._done)
        refit_due = self.model is not None and n - self._pending_at >= REFIT_EVERY_S * self.fs
        # a full identification when due, but never two in a row while a model runs (on a busy
        # machine they take longer than their spacing, and the noise refits would never come)
        if n >= due * self.fs and not (refit_due and self._pending_kind == "full"):
            self._pending_kind = "full"
            self.pending = self.identifier.submit(*self.record.last(self.record.keep), self.fs)
        elif refit_due:
            self._pending_kind = "noise"
            self.pending = self.identifier.refit(*self.record.last(int(REFIT_RECORD_S * self.fs)), self.fs, self.model)
        else:
            return
        self._pending_at = n

    def _take_identification(self):
        if self.pending is None or not self.pending.done():
            return
        future, at, full = self.pending, self._pending_at, self._pending_kind == "full"
        self.pending = None
        self._done += full
        exc = future.exception()
        found: LiveIdentification | None = None if exc is not None else future.result()
        if exc is not None:
            problem = str(exc) if isinstance(exc, LimbstiffError) else f"{type(exc).__name__}: {exc}"
        else:
            problem = self._unusable(found, at)
        if problem:                # said on the status line and in stream.json; the estimate goes on
            (self.events.identifications if full else self.events.failed_refits).append(
                {"at_samples": at, "error": problem})
            return
        est = found.estimator
        est.push(*self.record.since(at))        # catch up with the samples that came meanwhile
        self.estimator, self.model = est, est.model
        looked = self._look_back(found.smoothed, at)
        if full:
            self._window = self._new_window(keep=self._window)
            direct = found.variant == "direct"      # the elastic torque is measured: no m, b
            self.events.identifications.append({"at_samples": at, "inertia": None if direct else self.model.inertia,
                                                "damping": None if direct else self.model.damping,
                                                "corner_hz": self.model.corner_hz, "warnings": list(found.warnings),
                                                "hindsight": None if looked is None else looked.to_dict()})
        else:
            self.events.refits += 1

    def _look_back(self, smoothed: np.ndarray | None, at: int) -> Hindsight | None:
        """The band published before segment position ``at`` against the identification's smoothed
        course (kept for the checks until the next identification that can look back)."""
        if smoothed is None:
            return None
        lo, hi = self._band.between(at - len(smoothed), at)
        m = self.model
        memory_s = m.memory_s if m.memory_s is not None else MEMORY_PERIODS / m.motion_hz
        found = hindsight(smoothed, lo, hi, memory_samples=int(round(memory_s * self.fs)), ci_level=m.ci_level)
        if found is not None:
            self._looked_back = found
        return found

    def _recent(self) -> np.ndarray | None:
        """The estimate published over its memory (the ``changing`` and ``settling`` checks), or None
        for a model without one."""
        m = self.model
        return None if m.memory_s is None else self._band.recent(max(1, int(round(m.memory_s * self.fs))))

    def _due(self, done: int) -> float:
        """:func:`identification_due`, remembered (it is asked for every chunk)."""
        if self._due_for != done:
            self._due_for, self._due_s = done, identification_due(done, warmup_s=self.warmup_s)
        return self._due_s

    def _unusable(self, found: LiveIdentification, at: int) -> str | None:
        """Why an identification that came back cannot take over, or None."""
        noise = found.model.noise
        if not all(np.isfinite([noise.measurement, noise.torque_walk, noise.stiffness_walk, noise.coupled_walk])):
            return "the noise levels fitted are not numbers"
        if at < self.record.offset:
            return "it came back after the record it started from was dropped (longer than 10 minutes)"
        return None

    def _window_steps(self) -> int:
        return int(window_s(self.model.motion_hz) * self.fs / self.model.decimation)

    def _new_window(self, keep: "Window | None" = None) -> "Window":
        """A window for the model now; with the steps of ``keep`` when they are the same steps (the
        checks then look back across a take-over, which a change that starts then needs)."""
        m = self.model
        window = Window(self._window_steps())
        if keep is not None and keep.count and keep.decimation == m.decimation:
            window.add(keep.tail(keep.count))
        window.decimation = m.decimation
        return window

    @property
    def checks(self) -> LiveChecks | None:
        """The last checks made."""
        return self.events.checks
