"""``limbstiff simulate … --stream``: a simulated trial published on LSL (loopback only), read by an
inlet in a thread, channel for channel as the CSV of the same trial."""

from __future__ import annotations

import importlib.util
import sys
import threading
import time

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from .support.lsl_loopback import unique_name, use_loopback

use_loopback()          # before the first pylsl call of this process

from limbstiff.cli import main  # noqa: E402
from limbstiff.files import write_trial  # noqa: E402
from limbstiff.files.lsl_outlet import trial_channels  # noqa: E402
from limbstiff.simulate import simulate  # noqa: E402

needs_pylsl = pytest.mark.skipif(importlib.util.find_spec("pylsl") is None, reason="pylsl not installed")


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _consume(name: str, n: int, into: dict) -> None:
    """Find the stream (the command simulates first), read ``n`` samples or for 15 s (a count of
    pulls ran out first when each returned one 10-sample push: 1794 of 2000 samples)."""
    from limbstiff.files.lsl import StreamReader, find_stream
    try:
        description = find_stream(name=name, timeout=15.0)
        into["description"] = description
        values, stamps = [], []
        deadline = time.monotonic() + 15.0
        with StreamReader(description, recover=False) as reader:
            while time.monotonic() < deadline:
                chunk = reader.pull(timeout=0.05)
                values.append(chunk.values)
                stamps.append(chunk.timestamps)
                if sum(s.size for s in stamps) >= n:
                    break
        into["values"], into["stamps"] = np.concatenate(values), np.concatenate(stamps)
    except BaseException as exc:
        into["error"] = exc


@needs_pylsl
def test_simulate_stream_publishes_the_csv_columns_in_real_time(tmp_path):
    name, path, got = unique_name("limbstiff-sim"), tmp_path / "elbow.csv", {}
    consumer = threading.Thread(target=_consume, args=(name, 2000, got), daemon=True)
    consumer.start()
    res = run("simulate", "elbow", "--seed", 4, "--set", "duration=3", "--duration", 2, "--stream",
              "--stream-name", name, "--wait-consumer", 10, "--out", path)
    consumer.join(20)
    assert res.exit_code == 0, res.output
    assert "error" not in got, got.get("error")
    csv = pd.read_csv(path, comment="#")
    assert len(csv) == 2000                               # --duration cut the file too
    description = got["description"]
    assert description.labels == tuple(csv.columns[1:])  # the CSV header without time_s
    assert description.labels == ("angle_rad", "torque_Nm", "stiffness_true_Nm_per_rad")
    assert description.units == ("rad", "Nm", "Nm_per_rad")
    assert (description.type, description.fs) == ("Motion", 1000.0)
    assert np.array_equal(got["values"], csv.to_numpy()[:, 1:])           # to the bit
    np.testing.assert_allclose(np.diff(got["stamps"]), 1e-3, rtol=0, atol=1e-6)
    lines = [line for line in res.stderr.splitlines() if line.startswith("elbow:")]
    assert any("publishing 2000 samples" in line for line in lines)
    assert any("sent 2000 samples at 1000 Hz" in line and "a consumer connected" in line for line in lines)


def test_duration_longer_than_the_scenario_is_one_line(tmp_path):
    res = run("simulate", "wrist", "--set", "duration=1", "--duration", 3, "--out", tmp_path / "w.csv")
    assert res.exit_code == 2
    message = res.stderr.strip()
    assert "\n" not in message and "is only 1 s" in message and "--set duration=3" in message
    assert not (tmp_path / "w.csv").exists()


def test_stream_without_pylsl_is_one_line_with_the_install_hint(monkeypatch):
    monkeypatch.setitem(sys.modules, "pylsl", None)
    res = run("simulate", "wrist", "--set", "duration=0.5", "--stream", "--wait-consumer", 0)
    assert res.exit_code == 2
    assert res.stderr.strip().splitlines()[-1].endswith("pip install 'limbstiff[stream]'")


@pytest.mark.parametrize("scenario, params", [("elbow", {}), ("paper-exp-spring", {}),
                                              ("paper-vsa-hogan", {"include_elastic": 1.0})])
def test_stream_channels_are_the_csv_header_without_time(tmp_path, scenario, params):
    trial = simulate(scenario, params={"duration": 0.2, **params})
    values, labels, units = trial_channels(trial)
    write_trial(trial, tmp_path / "t.csv")
    csv = pd.read_csv(tmp_path / "t.csv", comment="#")
    assert labels == tuple(csv.columns[1:])
    assert np.array_equal(values, csv.to_numpy()[:, 1:])
    assert all(label.endswith("_" + unit) for label, unit in zip(labels, units))
