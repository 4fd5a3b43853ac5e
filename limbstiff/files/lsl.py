"""Live streams on the Lab Streaming Layer (LSL): finding and reading them (publishing is
:mod:`limbstiff.files.lsl_outlet`).

I/O only (numpy; pylsl imported inside the functions, so the package imports without it). A
missing pylsl, like every failure of a stream, is a one-line :class:`~limbstiff.errors.StreamError`.

What liblsl does underneath:

* **Resolution**: UDP multicast (and unicast to ``KnownPeers``) within the config's
  ``ResolveScope`` and ``SessionID`` (``lsl_api.cfg``, or the file named by ``LSLAPICFG``, read
  once, at the process's first LSL call); then TCP to the outlet (ports 16572-16603).
* **Clock correction** (``proc_clocksync``): the inlet measures the sender's clock offset every
  few seconds (``time_correction``) and adds it, so timestamps come out in this machine's
  :func:`pylsl.local_clock`.
* **Dejitter** (``proc_dejitter``) replaces the timestamps by a regression line over the sample
  index, which assumes no sample is missing: a gap is smeared over the following seconds (50
  samples dropped at 200 Hz came out as a step of 2.3 periods, stamps off by up to 243 ms).
  :class:`StreamReader` leaves it off unless asked.
* **Recovery**: an inlet whose outlet disappears re-resolves name, type, host and ``source_id``
  and reconnects by itself. Measured (loopback, new outlet 0.5 s after the old one closed): the
  new outlet's samples arrive from 1.24 s after its start (the earlier ones are lost), 2.8 s after
  its start, and one pull blocks ~1.6 s inside liblsl while it reconnects.
* **Its log**: liblsl writes INFO lines, and an ``ERR`` line whenever a sender closes its outlet
  (``Stream transmission broke off … re-connecting``: a normal end of a stream), on stderr, over the
  terminal's status line: limbstiff's first LSL call hands liblsl the user's configuration with
  ``[log] level = -3`` added unless it sets a level (:mod:`.lsl_config`).
"""

from __future__ import annotations

import inspect
import re
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import StreamError
from .lsl_config import hand_over

INSTALL_HINT = "pylsl is not installed: pip install 'limbstiff[stream]'"
_NOT_FOUND = ("no LSL stream found within {timeout:g} s; check that the acquisition software is "
              "streaming and that this computer is on the same network (and LSL SessionID), or wait "
              "longer with --resolve-timeout")
#: liblsl's channel formats (lsl_channel_format_t) by number
_FORMATS = {1: "float32", 2: "double64", 3: "string", 4: "int32", 5: "int16", 6: "int8", 7: "int64"}
_XML_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_.-]*\Z")
#: How long :meth:`StreamReader.sender_present` listens before it answers, s (a resolver's first
#: replies come within a few of its 0.5 s query waves on a network, within 0.1 s on one machine).
WATCH_S = 1.5
_configured = False


def _pylsl(source: str):
    """pylsl, imported; StreamError(source, install hint) when it is missing or cannot load liblsl.
    The first time, liblsl is handed its configuration (:mod:`.lsl_config`) before any LSL call."""
    global _configured
    try:
        import pylsl
    except ImportError:
        raise StreamError(source, INSTALL_HINT) from None
    except (OSError, RuntimeError) as exc:     # pylsl present, liblsl not loadable
        problem = " ".join(str(exc).split())
        raise StreamError(source, f"pylsl cannot load liblsl ({problem}); reinstall pylsl or set "
                                  f"PYLSL_LIB to liblsl's path") from None
    if not _configured:
        _configured = True
        hand_over(pylsl)
    return pylsl


def _label(name: str | None, type: str | None) -> str:
    if name and type:
        return f"LSL stream {name!r} of type {type!r}"
    return f"LSL stream {name!r}" if name else f"LSL stream of type {type!r}"


@dataclass(frozen=True)
class StreamDescription:
    """What a stream says of itself, as resolved on the network.

    Parameters
    ----------
    name, type, source_id, uid, hostname : str
        The stream's header (``uid`` changes with every outlet, ``source_id`` does not).
    fs : float
        Nominal sampling rate, Hz (0 for an irregular stream).
    labels : tuple of str, shape (c,)
        ``desc/channels/channel/label`` of each channel, ``""`` where missing.
    units : tuple of (str or None), shape (c,)
        ``desc/channels/channel/unit`` of each channel, None where missing.
    channel_format : str
        ``"double64"``, ``"float32"``, ``"int16"``…; the reader converts every format to float64.
    created_at : float
        When the outlet was created, s, in the sender's :func:`pylsl.local_clock`.
    """

    name: str
    type: str
    source_id: str
    uid: str
    hostname: str
    fs: float
    labels: tuple[str, ...]
    units: tuple[str | None, ...]
    channel_format: str = "double64"
    created_at: float = 0.0
    info: object = field(default=None, repr=False, compare=False)   # the pylsl.StreamInfo

    @property
    def n_channels(self) -> int:
        """Channels per sample."""
        return len(self.labels)

    @property
    def label(self) -> str:
        """How errors name the stream: ``LSL stream 'name' of type 'type'``."""
        return _label(self.name, self.type)


@dataclass(frozen=True)
class StreamChunk:
    """Samples pulled at once from a :class:`StreamReader` (possibly none).

    Parameters
    ----------
    timestamps : ndarray, shape (n,), float64, s
        In this machine's :func:`pylsl.local_clock` (the clock offset already applied).
    values : ndarray, shape (n, c), float64
    pulled_at : float
        :func:`pylsl.local_clock` when they were pulled, s.
    """

    timestamps: np.ndarray
    values: np.ndarray
    pulled_at: float

    @property
    def n(self) -> int:
        """Samples in the chunk."""
        return int(self.timestamps.size)


def _channel_fields(info, count: int) -> tuple[tuple[str, ...], tuple[str | None, ...]]:
    """Labels and units of ``desc/channels/channel``, padded to ``count`` channels."""
    labels: list[str] = []
    units: list[str | None] = []
    channel = info.desc().child("channels").child("channel")
    while not channel.empty() and len(labels) < count:
        labels.append(channel.child_value("label"))
        units.append(channel.child_value("unit") or None)
        channel = channel.next_sibling("channel")
    pad = count - len(labels)
    return tuple(labels) + ("",) * pad, tuple(units) + (None,) * pad


def _describe(info, full) -> StreamDescription:
    labels, units = _channel_fields(full, info.channel_count())
    return StreamDescription(
        name=info.name(), type=info.type(), source_id=info.source_id(), uid=info.uid(),
        hostname=info.hostname(), fs=float(info.nominal_srate()), labels=labels, units=units,
        channel_format=_FORMATS.get(info.channel_format(), str(info.channel_format())),
        created_at=float(info.created_at()), info=info)


def _predicate(label: str, **props: str | None) -> str:
    parts = []
    for key, value in props.items():
        if value is None:
            continue
        if "'" in value and '"' in value:
            raise StreamError(label, "a stream name or type cannot hold both ' and \"")
        quote = '"' if "'" in value else "'"
        parts.append(f"{key}={quote}{value}{quote}")
    return " and ".join(parts)


def _resolve(pylsl, predicate: str, timeout: float, settle: float) -> list:
    """Stream infos matching ``predicate``: polled until one is seen or ``timeout`` s pass, then
    ``settle`` s more (all of ``timeout`` when ``settle`` is None) to collect the others.

    A ContinuousResolver polled against our own deadline: liblsl's one-shot ``resolve`` sometimes
    overran a 0.5 s timeout by 5 s when nothing matched (pylsl 1.18.6)."""
    resolver = pylsl.ContinuousResolver(pred=predicate, forget_after=max(5.0, 2 * timeout))
    deadline = time.monotonic() + max(0.0, timeout)
    found = []
    while True:
        found = resolver.results()
        now = time.monotonic()
        if now >= deadline or (found and settle is not None):
            break
        time.sleep(min(0.02, deadline - now))
    if found and settle:
        time.sleep(settle)
        found = resolver.results() or found
    return sorted(found, key=lambda info: (-info.created_at(), info.uid()))


def find_streams(*, name: str | None = None, type: str | None = None,
                 wait: float = 1.0) -> list[StreamDescription]:
    """Every stream on the network (of this name and/or type) seen within ``wait`` s, newest first.

    Resolution by UDP multicast within the LSL config's scope and session (see the module); each
    stream's full description (channel labels and units) is fetched from its outlet over TCP.
    """
    pylsl = _pylsl(_label(name, type) if (name or type) else "LSL")
    infos = _resolve(pylsl, _predicate("LSL", name=name, type=type) or "true()", wait, settle=None)
    return [_full_description(pylsl, info, 2.0) for info in infos]


def find_stream(*, name: str | None = None, type: str | None = None,
                timeout: float = 5.0) -> StreamDescription:
    """The stream of this name and/or type (both must match when both are given).

    Resolution by UDP multicast (and unicast to ``KnownPeers``) within the LSL config's scope and
    session; polls until a stream is seen or ``timeout`` s pass. Several matches (two outlets of
    one name): the newest outlet (largest ``created_at``, then smallest ``uid``) is returned, so
    the answer does not depend on the order of replies; :func:`find_streams` lists them all.

    Raises
    ------
    StreamError
        Neither name nor type given; nothing found within ``timeout`` s (one line, naming the
        stream and what to check); the outlet did not send its description.
    """
    label = _label(name, type)
    if not name and not type:
        raise StreamError("LSL", "give a stream name or type to look for")
    pylsl = _pylsl(label)
    infos = _resolve(pylsl, _predicate(label, name=name, type=type), timeout, settle=0.1)
    if not infos:
        raise StreamError(label, _NOT_FOUND.format(timeout=timeout))
    return _full_description(pylsl, infos[0], max(1.0, timeout))


def _full_description(pylsl, info, timeout: float) -> StreamDescription:
    """The description with ``desc`` (labels, units), asked of the outlet by a short-lived inlet."""
    label = _label(info.name(), info.type())
    try:
        inlet = pylsl.StreamInlet(info, max_buflen=1, recover=False)
        try:
            full = inlet.info(timeout=timeout)
        finally:
            del inlet
    except Exception as exc:   # pylsl's own errors (timeout, lost) and liblsl's RuntimeError
        raise StreamError(label, f"the stream was found but did not send its description within "
                                 f"{timeout:g} s ({_why(exc)}); is a firewall blocking TCP ports "
                                 f"16572-16603?") from None
    return _describe(info, full)


def _why(exc: BaseException) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


class StreamReader:
    """Samples of one stream, pulled as they arrive (a context manager around a pylsl inlet).

    The inlet runs with ``proc_clocksync``: liblsl measures the sender's clock offset every few
    seconds (``time_correction``) and adds it, so :attr:`StreamChunk.timestamps` are in this
    machine's :func:`pylsl.local_clock`. ``dejitter=True`` adds ``proc_dejitter`` (a regression
    line through the timestamps), which smooths a sender's jittery stamps but hides dropped
    samples (see the module); it is off by default so that a gap shows as a gap.

    With ``recover=True`` liblsl reconnects by itself to a restarted outlet of the same name,
    type, host and ``source_id``; meanwhile :meth:`pull` returns empty chunks (watch
    :attr:`last_data_at`). With ``recover=False``, or a stream without ``source_id``, a lost stream
    is a :class:`StreamError`.

    Parameters
    ----------
    description : StreamDescription
        From :func:`find_stream`.
    max_buffer_s : float
        Seconds of data liblsl keeps for us when :meth:`pull` is late; older samples are dropped.
    recover : bool
    dejitter : bool
    open_timeout : float
        Seconds to wait for the outlet to accept the connection.

    Raises
    ------
    StreamError
        pylsl missing; the stream cannot be opened within ``open_timeout`` s.
    """

    def __init__(self, description: StreamDescription, *, max_buffer_s: float = 360,
                 recover: bool = True, dejitter: bool = False, open_timeout: float = 5.0):
        self.description = description
        self._label = description.label
        pylsl = self._pylsl = _pylsl(self._label)
        if description.info is None:
            raise StreamError(self._label, "the description was not resolved on the network; get it "
                                           "from find_stream")
        flags = pylsl.proc_clocksync | (pylsl.proc_dejitter if dejitter else 0)
        self._watch = None          # (resolver, since when) while no sample comes: sender_present
        self._buffer = np.empty((0, max(1, description.n_channels)), dtype=_dtype(description))
        self._offset, self._offset_at = float("nan"), -np.inf
        self.last_data_at = float("nan")
        try:
            self._inlet = pylsl.StreamInlet(description.info, max_buflen=max(1, int(np.ceil(max_buffer_s))),
                                            recover=recover, processing_flags=flags)
            self._inlet.open_stream(timeout=open_timeout)
            self._min_samples = "min_samples" in inspect.signature(self._inlet.pull_chunk).parameters
        except Exception as exc:
            self._inlet = None
            raise StreamError(self._label, f"cannot open the stream within {open_timeout:g} s "
                                           f"({_why(exc)}); is it still streaming, and are TCP ports "
                                           f"16572-16603 open?") from None
        self._refresh_offset(timeout=1.0)

    def __enter__(self) -> "StreamReader":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def pull(self, *, timeout: float = 0.05, max_samples: int = 4096) -> StreamChunk:
        """The samples that have arrived: waits up to ``timeout`` s for the first one, then takes
        what is there without waiting (at most ``max_samples``). May be empty (n = 0).

        pylsl's ``pull_chunk`` writes straight into a buffer kept between calls (``dest_obj``);
        the values are returned as a float64 copy. While liblsl reconnects to a restarted sender
        one call can block longer than ``timeout`` (~1.6 s measured).

        Raises
        ------
        StreamError
            The stream was lost and is not recovered (``recover=False`` or no ``source_id``), or
            liblsl failed.
        """
        if self._inlet is None:
            raise StreamError(self._label, "the reader is closed")
        max_samples = max(1, int(max_samples))
        if self._buffer.shape[0] < max_samples:
            self._buffer = np.empty((max_samples, self._buffer.shape[1]), dtype=self._buffer.dtype)
        buffer = self._buffer[:max_samples]
        try:
            stamps = self._pull_into(buffer, timeout, max_samples)
        except self._pylsl.util.LostError:
            raise StreamError(self._label, "the stream was lost (its sender stopped or the network "
                                           "broke) and cannot be recovered; restart the sender and "
                                           "this command") from None
        except Exception as exc:
            raise StreamError(self._label, f"reading failed ({_why(exc)})") from None
        pulled_at = self._pylsl.local_clock()
        n = stamps.size
        if n:
            self.last_data_at = pulled_at
            self._watch = None
        if pulled_at - self._offset_at > 5.0:
            self._refresh_offset(timeout=0.0)
        return StreamChunk(timestamps=np.array(stamps, dtype=np.float64),
                           values=buffer[:n].astype(np.float64), pulled_at=pulled_at)

    def _pull_into(self, buffer: np.ndarray, timeout: float, max_samples: int) -> np.ndarray:
        pull = self._inlet.pull_chunk
        if self._min_samples:      # pylsl >= 1.18: wait for the first sample only, then drain
            _, stamps = pull(timeout=timeout, max_samples=max_samples, dest_obj=buffer,
                             min_samples=1, as_numpy=True)
            return np.asarray(stamps)
        deadline = time.monotonic() + timeout   # older pylsl: poll, then drain without waiting
        while not self._inlet.samples_available() and time.monotonic() < deadline:
            time.sleep(0.001)
        _, stamps = pull(timeout=0.0, max_samples=max_samples, dest_obj=buffer)
        return np.asarray(stamps, dtype=np.float64)

    def sender_present(self) -> bool | None:
        """Whether an outlet of this stream (its name, type and ``source_id``) is on the network now:
        asked while no sample comes, to tell a stream that ended (its sender closed the outlet) from
        one that stalled. None until :data:`WATCH_S` s after the first call since the last sample (a
        resolver's first replies); then what the resolver has seen within the last 2 s."""
        if self._inlet is None:
            return None
        if self._watch is None:
            d = self.description
            predicate = _predicate(self._label, name=d.name, type=d.type, source_id=d.source_id or None)
            try:
                resolver = self._pylsl.ContinuousResolver(pred=predicate, forget_after=2.0)
            except Exception:       # not known: the caller says "stalled or ended"
                return None
            self._watch = (resolver, time.monotonic())
        resolver, since = self._watch
        if time.monotonic() - since < WATCH_S:
            return None
        return bool(resolver.results())

    def _refresh_offset(self, timeout: float) -> None:
        try:
            self._offset = float(self._inlet.time_correction(timeout=timeout))
            self._offset_at = self._pylsl.local_clock()
        except Exception:        # no estimate yet (timeout) or stream lost: keep the last one
            pass

    @property
    def clock_offset(self) -> float:
        """What liblsl adds to the sender's timestamps to put them in our clock, s, as last
        estimated (``time_correction``; refreshed at most every 5 s; NaN before the first
        estimate; ~0 on one machine). Already applied to the timestamps: for display and checks."""
        if self._inlet is not None and self._pylsl.local_clock() - self._offset_at > 5.0:
            self._refresh_offset(timeout=0.0)
        return self._offset

    def close(self) -> None:
        """Close the inlet (idempotent)."""
        inlet, self._inlet, self._watch = self._inlet, None, None
        if inlet is not None:
            try:
                inlet.close_stream()
            except Exception:
                pass
            del inlet


def _dtype(description: StreamDescription) -> np.dtype:
    formats = {"float32": np.float32, "double64": np.float64, "int8": np.int8, "int16": np.int16,
               "int32": np.int32, "int64": np.int64}
    if description.channel_format not in formats:
        raise StreamError(description.label, f"channels of format {description.channel_format!r} "
                                             "cannot be read as numbers; choose a numeric stream")
    return np.dtype(formats[description.channel_format])
