"""``limbstiff stream`` end to end on the LSL loopback: an independent simulated trial published at
1 kHz for 30 s, the command consuming it, a consumer of its stiffness outlet, the recording, the
live estimate and the offline analysis at the end.

The trial comes from tests/support/independent_trials.py (not limbstiff's equations). liblsl is
configured by tests/support/lsl_api.cfg: resolution on this machine only, session limbstiff-tests.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
from click.testing import CliRunner

from .support.lsl_loopback import Publisher, unique_name, use_loopback

use_loopback()          # before the first pylsl call of this process

from limbstiff.cli import main  # noqa: E402
from limbstiff.files import lsl  # noqa: E402

from .support.independent_trials import make_trial, suite  # noqa: E402

pytestmark = [pytest.mark.skipif(importlib.util.find_spec("pylsl") is None, reason="pylsl not installed"),
              pytest.mark.slow]        # real time: `pytest -m "not slow"` is the inner loop
FS = 1000.0
SECONDS = 30.0


class _Consumer(threading.Thread):
    """Reads the stiffness outlet until it has been silent for 3 s."""

    def __init__(self, name):
        super().__init__(daemon=True)
        self.name_ = name
        self.values, self.stamps, self.error = [], [], None

    def run(self):
        try:
            description = lsl.find_stream(name=self.name_, timeout=60.0)
            with lsl.StreamReader(description) as reader:
                quiet_since = time.monotonic()
                while time.monotonic() - quiet_since < 3.0:
                    chunk = reader.pull(timeout=0.2)
                    if chunk.n:
                        quiet_since = time.monotonic()
                        self.values.append(chunk.values)
                        self.stamps.append(chunk.timestamps)
        except Exception as exc:        # reported by the test
            self.error = exc


class _Background:
    """A real-time scenario's processes, started at once and waited for when its test asks: the
    scenarios are independent (own stream names, folders and processes), so the two short ones run
    during the 30 s session instead of after it (the worker waits on real time meanwhile)."""

    def __init__(self, start):
        self._finish = start()          # starts the processes; returns what waits for them
        self._result = None

    def result(self):
        if self._result is None:
            self._result = self._finish()
        return self._result


def _limbstiff(*args):
    return [sys.executable, "-m", "limbstiff", *map(str, args)]


@pytest.fixture(scope="module")
def restarted_run(tmp_path_factory):
    """The restarted sender (a thread here) and ``limbstiff stream`` in a process of its own."""
    from .support.lsl_loopback import restarted

    tmp_path = tmp_path_factory.mktemp("restart")

    def start():
        spec = next(s for s in suite(7100) if s.name == "clean-constant-elbow")
        data, _ = make_trial(spec)
        sent = data[["angle_rad", "torque_Nm"]].to_numpy()[:14000]
        name = unique_name("restart")
        sender = restarted(sent, split=7000, pause_s=0.5, fs=FS, labels=("angle_rad", "torque_Nm"),
                           units=("rad", "Nm"), name=name, source_id=name, wait_consumer_s=60.0, linger_s=0.5)
        sender.start()
        proc = subprocess.Popen(_limbstiff("stream", "--name", name, "--out", tmp_path, "--trial", "s", "--timeout", 5,
                                           "--no-outlet", "--no-pdf", "--quiet"),
                                stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)

        def finish():
            try:
                output = proc.communicate(timeout=240)[0]
            finally:
                sender.stop.set()
                sender.join(10)
            return proc.returncode, output, sent, tmp_path
        return finish

    run = _Background(start)
    yield run
    if run._result is None:             # its test was not selected: end what was started
        run.result()


@pytest.fixture(scope="module")
def quiet_end(tmp_path_factory):
    """``limbstiff simulate --stream`` and ``limbstiff stream`` as a user runs them, two processes,
    liblsl configured by a file that sets no log level (the tests' loopback without its [log])."""
    from .support.lsl_loopback import CONFIG

    tmp_path = tmp_path_factory.mktemp("quiet")

    def start():
        config = tmp_path / "lsl_api.cfg"
        text = CONFIG.read_text()
        config.write_text(text[:text.index("[log]")])
        env = {**os.environ, "LSLAPICFG": str(config)}         # PYTHONPATH: this tree (tests/conftest.py)
        name, out = unique_name("quiet"), tmp_path / "out"
        sender = subprocess.Popen(_limbstiff("simulate", "elbow", "--seed", "2", "--set", "duration=4", "--stream",
                                             "--stream-name", name, "--wait-consumer", "60"),
                                  env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        session = subprocess.Popen(_limbstiff("stream", "--name", name, "--out", out, "--trial", "t",
                                              "--resolve-timeout", "30", "--timeout", "4", "--warmup", "2",
                                              "--no-outlet", "--no-pdf"),
                                   env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

        def finish():
            try:
                session_err = session.communicate(timeout=240)[1]
            finally:
                sent_err = sender.communicate(timeout=60)[1]
            return session.returncode, session_err, sender.returncode, sent_err, out
        return finish

    run = _Background(start)
    yield run
    if run._result is None:
        run.result()


@pytest.fixture(scope="module")
def session(tmp_path_factory, restarted_run, quiet_end):
    # restarted_run and quiet_end are requested only to start them first: they run during this one
    spec = next(s for s in suite(7100) if s.name == "clean-ramp-elbow")
    data, _ = make_trial(spec)
    sent = data[["angle_rad", "torque_Nm", "stiffness_true_Nm_per_rad"]].to_numpy()[:int(SECONDS * FS)]
    name, outlet = unique_name("sim"), unique_name("stiffness")
    out = tmp_path_factory.mktemp("stream")
    publisher = Publisher(sent, fs=FS, labels=("angle_rad", "torque_Nm", "stiffness_true_Nm_per_rad"),
                          units=("rad", "Nm", "Nm_per_rad"), name=name, source_id=name, wait_consumer_s=60.0)
    consumer = _Consumer(outlet)
    publisher.start()
    consumer.start()
    result = CliRunner().invoke(main, ["stream", "--name", name, "--out", str(out), "--trial", "session1",
                                       "--duration", str(SECONDS - 1.0), "--outlet", outlet, "--no-pdf", "--quiet"])
    publisher.stop.set()
    publisher.join(10)
    consumer.join(20)
    return result, sent, out, consumer


def test_the_command_ends_with_the_recording_and_the_offline_analysis(session):
    result, sent, out, _ = session
    assert result.exit_code == 0, result.output
    assert "duration 29 s reached" in result.output
    table = np.loadtxt(out / "session1.csv", delimiter=",", comments="#", skiprows=7)
    n = len(table)
    assert 29000 <= n <= len(sent)
    # the recording is what was sent: the values to the bit, the times on the stream's 1 ms grid
    np.testing.assert_array_equal(table[:, 1:], sent[:n])
    np.testing.assert_array_equal(table[:, 0], np.arange(n) / FS)
    summary = json.loads((out / "session1" / "summary.json").read_text())
    truth = sent[:n, 2]
    assert summary["verdict"] in ("ok", "caution", "unreliable")
    assert abs(summary["stiffness"]["median"] / np.median(truth) - 1) < 0.05
    assert (out / "session1" / "stiffness.csv").exists() and (out / "summary.csv").exists()


def test_the_published_stiffness_follows_the_truth_and_matches_live_csv(session):
    result, sent, out, consumer = session
    assert consumer.error is None
    values, stamps = np.concatenate(consumer.values), np.concatenate(consumer.stamps)
    live = np.loadtxt(out / "session1" / "live.csv", delimiter=",", comments="#", skiprows=2)
    # the consumer connects once the outlet exists (an outlet keeps nothing for consumers not yet
    # there): what it received is the tail of what was written, with the input samples' time stamps
    assert len(live) - 2000 <= len(values) <= len(live)
    live = live[len(live) - len(values):]
    np.testing.assert_array_equal(values, live[:, 2:])
    np.testing.assert_allclose(stamps, live[:, 1], atol=1e-9)
    index = np.round(live[:, 0] * FS).astype(int)
    after = (index >= 5 * FS) & np.isfinite(values[:, 0])
    error = np.abs(values[after, 0] / sent[index[after], 2] - 1)
    # the target: median within 5 % after the first 5 s (1.9 % on this trial in a replay)
    # the estimate starts once the first identification is back (5 s of record plus its 2–5 s in the
    # worker, longer on a loaded machine): at least the last 5 s of the 29 have one
    assert after.sum() >= 5000
    assert np.median(error) < 0.05, f"median {np.median(error):.3f} over {after.sum()} samples"
    assert np.all(values[index < 5 * FS, 4] == -1)               # warming up, said so


def test_stream_json_says_what_happened(session):
    _, _, out, _ = session
    info = json.loads((out / "session1" / "stream.json").read_text())
    assert info["dropped_samples"] == 0 and info["breaks"] == []
    at = [d["at_s"] for d in info["identifications"]]
    # the first at the warm-up; then noise refits and identifications once due and the previous
    # one is back (one at a time: how many fit in 29 s depends on the machine's load)
    assert round(at[0]) == 5 and all(later >= 10 for later in at[1:]) and len(at) <= 3
    assert len(at) + info["noise_refits"] >= 2
    assert all("error" not in d for d in info["identifications"])
    for key in ("processing_us_per_sample", "end_to_end_ms"):
        assert set(info["latency"][key]) >= {"median", "p99_9", "max", "chunks"}
    assert info["stream"]["channels"] == ["angle_rad", "torque_Nm", "stiffness_true_Nm_per_rad"]


def test_a_stream_that_is_not_there_is_one_line_and_exit_2(tmp_path):
    result = CliRunner().invoke(main, ["stream", "--name", unique_name("absent"), "--resolve-timeout", "0.5",
                                       "--out", str(tmp_path)])
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and "no LSL stream" in lines[0]


def test_usage_errors(tmp_path):
    result = CliRunner().invoke(main, ["stream", "--out", str(tmp_path)])
    assert result.exit_code == 2 and "--name or --type" in result.output
    (tmp_path / "taken.csv").write_text("x\n")
    result = CliRunner().invoke(main, ["stream", "--name", "x", "--out", str(tmp_path), "--trial", "taken"])
    assert result.exit_code == 2 and "--overwrite" in result.output


def test_a_restarted_sender_and_a_stall_end_with_both_parts_recorded_and_analysed(restarted_run):
    """The sender stops after 7 s and a new one (same source_id) sends 7 s more, then the stream
    stalls: the session records two segments, says so, and analyses both (the recording is never lost)."""
    returncode, output, sent, tmp_path = restarted_run.result()
    assert returncode == 0, output
    assert "no sample for 5 s" in output
    info = json.loads((tmp_path / "s" / "stream.json").read_text())
    assert info["recordings"] == ["s.csv", "s-2.csv"] and len(info["breaks"]) == 1
    # liblsl loses the first ~1.2 s of the new sender's samples while it reconnects (files.lsl)
    first = np.loadtxt(tmp_path / "s.csv", delimiter=",", comments="#", skiprows=7)
    second = np.loadtxt(tmp_path / "s-2.csv", delimiter=",", comments="#", skiprows=7)
    np.testing.assert_array_equal(first[:, 1:], sent[:len(first)])
    tail = sent[7000:]
    start = int(np.flatnonzero((tail == second[0, 1:]).all(axis=1))[0])
    np.testing.assert_array_equal(second[:, 1:], tail[start:start + len(second)])
    assert len(first) == 7000 and info["dropped_samples"] >= start
    assert (tmp_path / "s" / "summary.json").exists() and (tmp_path / "s-2" / "summary.json").exists()


def test_a_normal_end_of_stream_is_quiet_and_not_an_error(quiet_end):
    """`limbstiff simulate --stream` and `limbstiff stream` as a user runs them, in two processes,
    liblsl configured by a file that sets no log level (the tests' loopback without its [log]):
    neither prints a line of liblsl's on stderr (no INFO, no `ERR| Stream transmission broke off`
    when the simulator closes its outlet); the session says the stream ended and exits 0; the
    recording has unit-bearing headers and no unit row, and reads the same in pandas and limbstiff."""
    import pandas as pd

    from limbstiff.files import read_trial

    returncode, session_err, sender_returncode, sent_err, out = quiet_end.result()
    liblsl = re.compile(r"(INFO|ERR|WARN)\||liblsl|loguru|Stream transmission")
    for stderr in (session_err, sent_err):
        lines = [line for line in re.split(r"[\r\n]", stderr) if line.strip()]
        assert not [line for line in lines if liblsl.search(line)], stderr[-2000:]
    assert returncode == 0, session_err[-2000:]
    assert "stream: the stream ended (its sender closed it; no sample for 4 s)" in session_err
    assert sender_returncode == 0
    lines = (out / "t.csv").read_text().splitlines()
    header = lines.index("time_s,angle_rad,torque_Nm,stiffness_true_Nm_per_rad")
    assert lines[header + 1].startswith("0.0,")                       # no unit row
    table = pd.read_csv(out / "t.csv", comment="#")
    assert len(table) == 4001 and all(dtype == np.float64 for dtype in table.dtypes)
    trial = read_trial(out / "t.csv")
    np.testing.assert_array_equal(trial.angle, table["angle_rad"].to_numpy())
    np.testing.assert_array_equal(trial.torque, table["torque_Nm"].to_numpy())
    info = json.loads((out / "t" / "stream.json").read_text())
    assert info["stopped"].startswith("the stream ended") and (out / "t" / "summary.json").exists()
