"""The LSL transport (limbstiff.files.lsl) on the loopback: publish, find, read, the outlet of the
estimate, gaps, a restarted sender, and pylsl missing.

Every stream has a unique name (and type where the type is searched), in the session of
tests/support/lsl_api.cfg, which keeps resolution on this machine.
"""

from __future__ import annotations

import importlib.util
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from .support.lsl_loopback import Publisher, restarted, unique_name, use_loopback

use_loopback()          # before the first pylsl call of this process

from limbstiff.errors import StreamError  # noqa: E402
from limbstiff.files import lsl, lsl_config, lsl_outlet  # noqa: E402

needs_pylsl = pytest.mark.skipif(importlib.util.find_spec("pylsl") is None, reason="pylsl not installed")


def _read(reader: lsl.StreamReader, *, n: int, done, timeout: float = 10.0):
    """Pull until ``n`` samples arrived, or ``done()`` and nothing more comes, or ``timeout`` s."""
    values, stamps, arrivals = [], [], []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        chunk = reader.pull(timeout=0.1)
        values.append(chunk.values)
        stamps.append(chunk.timestamps)
        arrivals.append(np.full(chunk.n, chunk.pulled_at))
        got = sum(s.size for s in stamps)
        if got >= n or (chunk.n == 0 and done()):
            break
    return np.concatenate(values), np.concatenate(stamps), np.concatenate(arrivals)


def _started(pub: Publisher) -> list:
    """Install an on_start that records (t0, connected) into the returned list."""
    seen: list = []
    pub._call[1]["on_start"] = lambda t0, connected: seen.append((t0, connected))
    return seen


@needs_pylsl
def test_publish_and_read_round_trip_bit_for_bit():
    name, fs = unique_name(), 200.0
    values = np.random.default_rng(1).standard_normal((400, 3)) * [1e-3, 10.0, 1e5]
    pub = Publisher(values, fs=fs, labels=("angle_rad", "torque_Nm", "extra"), units=("rad", "Nm", None),
                    name=name, type="Motion", source_id=name, wait_consumer_s=5.0)
    started = _started(pub)
    pub.start()
    description = lsl.find_stream(name=name, timeout=5.0)
    assert (description.name, description.type, description.source_id) == (name, "Motion", name)
    assert description.fs == fs and description.channel_format == "double64"
    assert description.labels == ("angle_rad", "torque_Nm", "extra")
    assert description.units == ("rad", "Nm", None)
    assert description.info.session_id() == "limbstiff-tests"      # tests/support/lsl_api.cfg in effect
    with lsl.StreamReader(description, recover=False) as reader:
        got, stamps, arrived = _read(reader, n=400, done=lambda: not pub.is_alive())
        assert abs(reader.clock_offset) < 1e-3          # one machine
    pub.join(5)
    assert pub.error is None and pub.result == 400
    assert got.dtype == np.float64 and np.array_equal(got, values)    # to the bit
    (t0, connected), = started
    assert connected
    np.testing.assert_allclose(stamps, t0 + np.arange(400) / fs, rtol=0, atol=1e-3)
    assert np.all(arrived >= stamps - 1e-3)          # real time: no sample before its time


@pytest.mark.slow
@needs_pylsl
def test_find_stream_by_name_type_both_and_not_found():
    name, kind = unique_name(), unique_name("type")
    pub = Publisher(np.zeros((100_000, 1)), fs=100.0, labels=("x",), units=(None,), name=name, type=kind,
                    source_id=name, linger_s=0)
    pub.start()
    try:
        assert lsl.find_stream(name=name, timeout=5.0).type == kind
        assert lsl.find_stream(type=kind, timeout=5.0).name == name
        assert lsl.find_stream(name=name, type=kind, timeout=5.0).uid
        with pytest.raises(StreamError, match="no LSL stream found"):
            lsl.find_stream(name=name, type=kind + "-other", timeout=0.5)
        missing = unique_name("missing")
        with pytest.raises(StreamError) as caught:
            lsl.find_stream(name=missing, timeout=0.5)
        message = str(caught.value)
        assert "\n" not in message and missing in message and "0.5 s" in message
        assert "--resolve-timeout" in message
    finally:
        pub.stop.set()
        pub.join(5)
    with pytest.raises(StreamError, match="give a stream name or type"):
        lsl.find_stream(timeout=0.1)


@needs_pylsl
def test_several_matches_the_newest_outlet_first():
    import pylsl
    name = unique_name()
    outlets = []
    for k in range(2):
        info = pylsl.StreamInfo(name, "Motion", 1, 10.0, pylsl.cf_double64, f"{name}-{k}")
        outlets.append(pylsl.StreamOutlet(info))
        time.sleep(0.05)
    listed = lsl.find_streams(name=name, wait=1.0)
    assert [d.source_id for d in listed] == [f"{name}-1", f"{name}-0"]
    assert lsl.find_stream(name=name, timeout=5.0).source_id == f"{name}-1"
    assert name in [d.name for d in lsl.find_streams(wait=0.5)]    # every stream of the session
    del outlets


@needs_pylsl
def test_stiffness_outlet_sends_values_and_given_timestamps():
    import pylsl
    name = unique_name("limbstiff-estimate")
    meta = {"input_stream": "sim-elbow", "verdict_codes": "0 ok, 1 caution, 2 unreliable"}
    rows = np.random.default_rng(2).uniform(0, 50, (60, 5))
    with lsl_outlet.StiffnessOutlet(name=name, fs=100.0, unit="N*m/rad", source_id=name, metadata=meta) as outlet:
        description = lsl.find_stream(name=name, type="Stiffness", timeout=5.0)
        assert description.labels == lsl_outlet.StiffnessOutlet.CHANNELS
        assert description.units == ("N*m/rad",) * 3 + (None, None)
        full = pylsl.StreamInlet(description.info).info(timeout=5.0)
        assert full.desc().child_value("input_stream") == "sim-elbow"
        assert full.desc().child_value("verdict_codes") == meta["verdict_codes"]
        with lsl.StreamReader(description, recover=False) as reader:
            deadline = time.monotonic() + 5
            while not outlet.have_consumers and time.monotonic() < deadline:
                time.sleep(0.01)
            stamps = pylsl.local_clock() - 2.0 + np.arange(60) / 100.0
            outlet.push(rows[:30], stamps[:30])
            outlet.push(rows[30:], stamps[30:])
            got, seen, _ = _read(reader, n=60, done=lambda: False, timeout=5.0)
    assert np.array_equal(got, rows)
    np.testing.assert_allclose(seen, stamps, rtol=0, atol=1e-3)
    with pytest.raises(ValueError, match=r"\(n, 5\)"):
        lsl_outlet.StiffnessOutlet.push(outlet, rows[:, :4], stamps)


@needs_pylsl
def test_dropped_samples_show_as_a_gap_in_the_timestamps():
    name, fs = unique_name(), 300.0
    values = np.arange(600.0)[:, None] * [1.0, -1.0]
    pub = Publisher(values, fs=fs, labels=("a", "b"), units=(None, None), name=name, source_id=name,
                    wait_consumer_s=5.0, drop=slice(200, 260))
    pub.start()
    with lsl.StreamReader(lsl.find_stream(name=name, timeout=5.0), recover=False) as reader:
        got, stamps, _ = _read(reader, n=540, done=lambda: not pub.is_alive())
    pub.join(5)
    assert pub.result == 540
    keep = np.ones(600, bool)
    keep[200:260] = False
    assert np.array_equal(got, values[keep])
    steps = np.round(np.diff(stamps) * fs).astype(int)
    assert int((steps - 1).sum()) == 60                 # missing samples, from the timestamps alone
    assert np.flatnonzero(steps > 1).tolist() == [199] and steps[199] == 61


@pytest.mark.slow
@needs_pylsl
def test_restarted_sender_is_recovered():
    """liblsl notices the closed outlet, re-resolves name, type, host and source_id and reconnects;
    what the new outlet pushed before that is not delivered (~3 s measured on one machine)."""
    name, fs, split = unique_name(), 100.0, 100
    values = np.arange(700.0)[:, None]
    sender = restarted(values, split=split, pause_s=0.5, fs=fs, labels=("i",), units=(None,), name=name,
                       source_id=name, wait_consumer_s=5.0, linger_s=0.3)
    sender.start()
    with lsl.StreamReader(lsl.find_stream(name=name, timeout=5.0), recover=True) as reader:
        got, stamps, arrived = _read(reader, n=700, done=lambda: not sender.is_alive(), timeout=12.0)
    sender.join(5)
    assert sender.results == [split, 600]
    index = got[:, 0].astype(int)
    assert index[:split].tolist() == list(range(split))           # the first outlet, complete
    second = index[split:]
    assert second.size >= 100, "recovered after more than 5 s (or not at all)"
    assert second.tolist() == list(range(second[0], 700))          # then a contiguous tail
    lost_s = (second[0] - split) / fs
    print(f"restart: recovered after {lost_s:.2f} s of the new outlet's samples")
    assert np.all(np.diff(stamps) > 0)


@needs_pylsl
def test_reading_without_min_samples_as_older_pylsl():
    name = unique_name()
    values = np.random.default_rng(3).standard_normal((100, 2)).astype(np.float32)
    pub = Publisher(values, fs=200.0, labels=("a", "b"), units=(None, None), name=name, source_id=name,
                    wait_consumer_s=5.0)
    pub.start()
    with lsl.StreamReader(lsl.find_stream(name=name, timeout=5.0), recover=False) as reader:
        reader._min_samples = False                     # pylsl < 1.18: no min_samples, no as_numpy
        got, stamps, _ = _read(reader, n=100, done=lambda: not pub.is_alive())
    pub.join(5)
    assert np.array_equal(got, values.astype(np.float64)) and stamps.size == 100


@needs_pylsl
def test_lost_stream_without_recovery_is_a_one_line_stream_error():
    name = unique_name()
    pub = Publisher(np.ones((50, 1)), fs=100.0, labels=("x",), units=(None,), name=name, source_id=name,
                    wait_consumer_s=5.0, linger_s=0.2)
    pub.start()
    received = 0
    with lsl.StreamReader(lsl.find_stream(name=name, timeout=5.0), recover=False) as reader:
        with pytest.raises(StreamError) as caught:
            deadline = time.monotonic() + 5.0
            while time.monotonic() < deadline:
                received += reader.pull(timeout=0.1).n
    pub.join(5)
    assert received == 50                               # everything sent, then the loss
    message = str(caught.value)
    assert "\n" not in message and name in message and "was lost" in message


def test_pylsl_missing_is_a_one_line_stream_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "pylsl", None)     # import pylsl -> ImportError
    calls = [lambda: lsl.find_stream(name="EMG", timeout=0.1),
             lambda: lsl.find_streams(type="EMG"),
             lambda: lsl_outlet.StiffnessOutlet(fs=100.0, unit="N*m/rad", source_id="x"),
             lambda: lsl_outlet.publish(np.zeros((3, 1)), fs=10.0, labels=("x",), units=(None,), name="sim",
                                 source_id="sim")]
    for call in calls:
        with pytest.raises(StreamError) as caught:
            call()
        assert str(caught.value).endswith("pylsl is not installed: pip install 'limbstiff[stream]'")
        assert "\n" not in str(caught.value)
    assert "EMG" in str(pytest.raises(StreamError, calls[0]).value)


class _FakeClock:
    """time.monotonic and time.sleep of limbstiff.files.lsl on a clock that only sleeping advances."""

    def __init__(self):
        self.now = 1000.0

    def monotonic(self):
        return self.now

    def sleep(self, seconds):
        self.now += max(seconds, 0.0)


class _NothingResolver:
    """A pylsl ContinuousResolver that never sees a stream; counts its polls."""
    polls = 0

    def __init__(self, pred, forget_after):
        pass

    def results(self):
        type(self).polls += 1
        if self.polls > 10_000:         # a loop that ignores its deadline fails instead of hanging
            raise AssertionError("the lookup polled past its deadline")
        return []


def test_the_lookup_stops_at_its_own_deadline(monkeypatch):
    """The resolution is polled against limbstiff's deadline, not liblsl's (its one-shot resolve
    overran a 0.5 s timeout by 5 s): on a clock that only the poll's sleeps advance, a 0.5 s lookup
    ends after 0.5 s of that clock, with polls every 20 ms (25, plus the last one at the deadline)."""
    clock = _FakeClock()
    monkeypatch.setattr(lsl, "time", clock)
    fake = type("pylsl", (), {"ContinuousResolver": _NothingResolver})
    _NothingResolver.polls = 0
    began = clock.now
    assert lsl._resolve(fake, "name='x'", 0.5, settle=0.1) == []
    assert clock.now - began == pytest.approx(0.5, abs=1e-9)
    assert 25 <= _NothingResolver.polls <= 27


def test_stop_event_ends_publish_early():
    pytest.importorskip("pylsl")
    stop = threading.Event()
    threading.Timer(0.3, stop.set).start()
    sent = lsl_outlet.publish(np.zeros((10_000, 1)), fs=1000.0, labels=("x",), units=(None,), name=unique_name(),
                       source_id="stop-test", stop=stop, linger_s=0)
    # 10 s of samples pushed in real time; stopped after 0.3 s. The bound is generous (a stop seen up
    # to 7 s late on a loaded machine passes) but a stop that is ignored sends all 10 000.
    assert 0 < sent < 7_500


def test_liblsl_config_adds_a_quiet_log_level_to_the_users_own(tmp_path, monkeypatch):
    """The user's configuration is kept whole, with ``[log] level = -3`` added unless it sets a
    level; LSLAPICFG is the file read (else liblsl's own places: lsl_api.cfg here first)."""
    mine = tmp_path / "mine.cfg"
    mine.write_text("[lab]\nSessionID = my-lab ; ours\n\n[log]\nfile = lsl.log\n")
    text = lsl_config.liblsl_config(mine)
    assert text.startswith("[lab]\nSessionID = my-lab ; ours\n\n[log]\nfile = lsl.log\n")
    assert text.rstrip().endswith("[log]\nlevel = -3") and lsl_config.LOG_LEVEL == -3
    chosen = tmp_path / "chosen.cfg"
    chosen.write_text("[Log]\n level = 0  ; liblsl's INFO lines, please\n")
    assert lsl_config.liblsl_config(chosen) == chosen.read_text()          # the user's level stands
    commented = tmp_path / "commented.cfg"
    commented.write_text("[log]\n; level = 0\n")
    assert "level = -3" in lsl_config.liblsl_config(commented)
    monkeypatch.setenv("LSLAPICFG", str(mine))
    assert lsl_config.user_config() == mine and lsl_config.liblsl_config() == text
    monkeypatch.delenv("LSLAPICFG")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("HOME", str(tmp_path))
    (tmp_path / "lsl_api.cfg").write_text("[ports]\nIPv6 = disable\n")
    assert lsl_config.user_config() == tmp_path / "lsl_api.cfg"
    assert lsl_config.liblsl_config().startswith("[ports]\nIPv6 = disable\n\n")
    (tmp_path / "lsl_api.cfg").unlink()
    if not Path("/etc/lsl_api/lsl_api.cfg").exists():
        assert lsl_config.user_config() is None
        assert lsl_config.liblsl_config().endswith("[log]\nlevel = -3\n")


@needs_pylsl
def test_sender_present_tells_an_ended_stream_from_a_stalled_one():
    """While no sample comes the reader asks the network whether the sender is still there: yes
    while its outlet is open (a stall), no once it has closed it (the stream ended)."""
    name = unique_name()
    pub = Publisher(np.ones((100, 1)), fs=100.0, labels=("x",), units=(None,), name=name, source_id=name,
                    wait_consumer_s=5.0, linger_s=4.0)
    pub.start()
    with lsl.StreamReader(lsl.find_stream(name=name, timeout=5.0)) as reader:
        assert len(_read(reader, n=100, done=lambda: False, timeout=5.0)[0]) == 100
        answers = []                               # the outlet stays open 4 s after its last sample
        deadline = time.monotonic() + 3.0
        while time.monotonic() < deadline and not answers:
            assert reader.pull(timeout=0.05).n == 0
            answer = reader.sender_present()
            answers += [answer] if answer is not None else []
        assert answers == [True]
        deadline = time.monotonic() + 12.0         # closed: gone once the resolver forgets it
        while time.monotonic() < deadline and reader.sender_present() is not False:
            reader.pull(timeout=0.05)
        assert reader.sender_present() is False
    pub.join(5)
