"""One result protocol: the analysis, its curve, the diagnosis and the batch each answer
``to_dict()``, ``to_frame()``, ``plot(ax=…)`` and ``report()`` (the diagnosis's own check is in
tests/test_diagnose.py, beside the diagnosis it is made on)."""

import numpy as np
import pytest

import limbstiff
from limbstiff.protocol import Protocol
from limbstiff.trial import Trial

from .conftest import multisine_trial
from .support.result_protocol import check_protocol


@pytest.fixture(scope="module")
def swept():
    """A 12 s joint whose operating position is swept under a random perturbation, K rising with it,
    analysed against its recorded schedule (m and b given: no MCMC)."""
    from scipy import signal
    rng = np.random.default_rng(11)
    fs, n = 500, 6000
    t = np.arange(n) / fs
    s = -0.3 + 0.6 * t / t[-1]
    pert = signal.filtfilt(*signal.butter(2, 25 / 250), np.repeat(rng.choice([-1.0, 1.0], n // 20 + 1), 20)[:n]) * 0.02
    y = s + pert
    k = 60 + 40 * s / 0.3
    torque = (np.cumsum(k * np.diff(y, prepend=y[0])) + 0.015 * np.gradient(np.gradient(y, 1 / fs), 1 / fs)
              + 0.8 * np.gradient(y, 1 / fs) + 0.05 * rng.standard_normal(n))
    trial = Trial(name="sweep", time=t, angle=y, torque=torque, schedule=s, schedule_unit="rad")
    return limbstiff.analyze(trial, Protocol(variant="external", inertia=0.015, damping=0.8))


def test_the_analysis_answers_the_protocol_and_summary_is_to_dict():
    result = limbstiff.analyze(multisine_trial(), Protocol(inertia=0.06, damping=0.45))
    data, frame, text = check_protocol(result)
    assert data == result.summary() | {"software": data["software"]}
    assert data["trial"] == "synthetic" and list(frame.columns)[:2] == ["time_s", "stiffness"]
    assert text == result.report() and "stiffness" in text


def test_the_curve_answers_the_protocol(swept):
    curve = swept.curve
    data, frame, text = check_protocol(curve, unit_stiffness="N·m/rad")
    assert data == swept.to_dict()["by_schedule"]
    assert list(frame.columns) == ["schedule", "stiffness", "stiffness_lo", "stiffness_hi", "n_samples",
                                   "ls_stiffness", "ls_stiffness_lo", "ls_stiffness_hi"]
    # its own verdict and reasons first (issue 46), not a list of ok/FAILED checks
    assert text.startswith(f"Curve verdict: {curve.verdict}") and "Stiffness by schedule" in text
    assert all(r in text for r in curve.reasons) and "FAILED" not in text
    # the analysis draws its curve through the curve's own plot
    from matplotlib.figure import Figure
    mine, theirs = Figure().subplots(), Figure().subplots()
    swept.plot(ax=mine, against="schedule")
    curve.plot(ax=theirs)
    assert [tuple(map(tuple, line.get_xydata())) for line in mine.lines] == \
        [tuple(map(tuple, line.get_xydata())) for line in theirs.lines]


def test_the_batch_answers_the_protocol(trial_file, tmp_path):
    import pandas as pd
    good = trial_file("good")
    batch = limbstiff.analyze_files([str(good), str(tmp_path / "nothing*.csv")], out=tmp_path / "out", pdf=False,
                                    protocol=Protocol(inertia=0.06, damping=0.45))
    data, frame, text = check_protocol(batch)
    # to_frame is the summary.csv of the run, cell for cell
    table = pd.read_csv(tmp_path / "out" / "summary.csv", keep_default_na=False)
    assert list(frame.columns) == list(table.columns) and list(frame["trial"]) == list(table["trial"])
    assert frame["stiffness_median"][0] == pytest.approx(float(table["stiffness_median"][0]), rel=1e-9)
    assert data["exit_status"] == 1 and [t["status"] for t in data["trials"]] == ["ok", "failed"]
    assert text.splitlines()[0].startswith("1 of 2 trials done") and "failed" in text
