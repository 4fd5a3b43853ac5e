"""A folder of one-cycle files analysed as one ensemble (issue 36, item 1): ``read_ensemble`` and
``limbstiff analyze FOLDER --ensemble``."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from limbstiff import cycles
from limbstiff.cli import main
from limbstiff.errors import TrialError
from limbstiff.files import read_ensemble, read_trial
from limbstiff.files.ensemble import MIN_FILES, natural_key
from limbstiff.protocol import ENSEMBLE_MARKER

ARGS = ["--no-pdf", "--inertia", "0.015", "--damping", "0.8"]


def _cycle_files(folder, *, n_cycles=8, fs=1000, seed=5, prefix="cycle"):
    """One file per 1 s cycle (the generator of tests/test_scheduled.py, cut at the cycles): stiffness
    60 + 30·sin(2π·phase) N·m/rad, a reference movement, a smoothed random perturbation that differs
    from cycle to cycle, a background torque that repeats; each file's time from 0."""
    from scipy import signal
    folder.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    n = n_cycles * fs
    t = np.arange(n) / fs
    phase = t % 1.0
    k = 60 + 30 * np.sin(2 * np.pi * phase)
    pert = signal.filtfilt(*signal.butter(2, 25 / (fs / 2)),
                           np.repeat(rng.choice([-1.0, 1.0], n // 40 + 1), 40)[:n]) * 0.03
    y = 0.1 * np.sin(2 * np.pi * phase) + pert
    yd, ydd = np.gradient(y, 1 / fs), np.gradient(np.gradient(y, 1 / fs), 1 / fs)
    torque = 5 * np.cos(2 * np.pi * phase) + 0.015 * ydd + 0.8 * yd + k * pert + 0.05 * rng.standard_normal(n)
    paths = []
    for c in range(n_cycles):
        part = slice(c * fs, (c + 1) * fs)
        path = folder / f"{prefix}{c + 1}.csv"
        pd.DataFrame({"time_s": t[:fs], "angle_rad": y[part], "torque_Nm": torque[part]}).to_csv(path, index=False)
        paths.append(path)
    return paths


@pytest.fixture(scope="module")
def ensemble_run(tmp_path_factory):
    """``analyze DIR --ensemble`` on 8 one-cycle files, run once for the tests that read its outputs."""
    root = tmp_path_factory.mktemp("ensemble")
    _cycle_files(root / "strides")
    out = root / "out"
    run = CliRunner().invoke(main, ["analyze", str(root / "strides"), "--ensemble", "--out", str(out), *ARGS])
    return run, out


def test_min_files_is_the_ensembles_min_cycles():
    assert MIN_FILES == cycles.MIN_CYCLES


def test_natural_order_of_file_names():
    names = ["cycle10.csv", "cycle2.csv", "Cycle1.csv", "cycle11.csv", "cycle3.csv"]
    assert [p for p in sorted(names, key=natural_key)] == ["Cycle1.csv", "cycle2.csv", "cycle3.csv",
                                                           "cycle10.csv", "cycle11.csv"]


def test_read_ensemble_joins_the_files_in_natural_order(tmp_path):
    paths = _cycle_files(tmp_path / "reach", n_cycles=11)          # cycle1 … cycle11: cycle10 after cycle9
    trial = read_ensemble(reversed(paths))
    assert trial.name == "reach" and trial.n_samples == 11 * 1000
    assert trial.source == str((tmp_path / "reach").absolute())
    assert trial.metadata["ensemble_files"] == "11"
    for c in range(11):
        alone = read_trial(tmp_path / "reach" / f"cycle{c + 1}.csv")
        np.testing.assert_array_equal(trial.angle[c * 1000:(c + 1) * 1000], alone.angle)
    np.testing.assert_allclose(np.diff(trial.time), 1e-3, rtol=1e-9)        # continuous time
    # the marker starts a cycle at every file's first sample (and ends the last at the last sample)
    split = cycles.by_marker(trial.marker, header=ENSEMBLE_MARKER)
    assert split.n_cycles == 11 and list(split.starts[:-1]) == [c * 1000 for c in range(11)]
    # 20 ms bridged at both ends of each file
    assert trial.bridged[:20].all() and not trial.bridged[20:980].any() and trial.bridged[980:1020].all()
    assert len(trial.source_sha256) == 64
    assert read_ensemble(paths, name="other").source_sha256 == trial.source_sha256


@pytest.mark.slow
def test_ensemble_through_the_cli(ensemble_run):
    run, out = ensemble_run
    assert run.exit_code == 0, run.output
    frame = pd.read_csv(out / "strides" / "stiffness_by_phase.csv")
    assert list(frame.columns) == ["phase", "stiffness", "stiffness_lo", "stiffness_hi", "n_cycles", "ls_stiffness",
                                   "ls_stiffness_lo", "ls_stiffness_hi"]
    informed = frame["stiffness"].notna()
    assert informed.mean() > 0.8
    assert (frame["n_cycles"][informed] == 8).all()
    summary = json.loads((out / "strides" / "summary.json").read_text())
    assert summary["by_phase"]["n_cycles"] == 8
    assert (out / "strides" / "stiffness.csv").is_file() and not (out / "strides" / "report.pdf").exists()
    table = pd.read_csv(out / "summary.csv")
    assert len(table) == 1 and table["trial"][0] == "strides" and table["status"][0] == "ok"
    assert table["curve_verdict"][0] == summary["by_phase"]["verdict"]


def test_ensemble_outputs_are_not_replaced_without_overwrite(ensemble_run, tmp_path):
    run, out = ensemble_run
    assert run.exit_code == 0, run.output
    folder = out.parent / "strides"
    again = CliRunner().invoke(main, ["analyze", str(folder), "--ensemble", "--out", str(out), *ARGS])
    assert again.exit_code == 0 and "up to date" in again.output          # the same run: kept, not redone
    other = CliRunner().invoke(main, ["analyze", str(folder), "--ensemble", "--out", str(out), "--seed", "3", *ARGS])
    assert other.exit_code == 2 and "--overwrite" in other.output
    assert len(other.output.strip().splitlines()) == 1


def test_ensemble_with_period_or_marker_is_a_usage_error(tmp_path):
    for extra in (["--period", "1"], ["--marker", "trigger"]):
        run = CliRunner().invoke(main, ["analyze", str(tmp_path), "--ensemble", *extra])
        assert run.exit_code == 2 and "--ensemble" in run.output
        assert len(run.output.strip().splitlines()) == 1


def test_fewer_files_than_cycles_needed_is_one_line(tmp_path):
    _cycle_files(tmp_path / "few", n_cycles=4)
    run = CliRunner().invoke(main, ["analyze", str(tmp_path / "few"), "--ensemble", "--out", str(tmp_path / "o"),
                                    *ARGS])
    assert run.exit_code == 2 and "at least 5" in run.output
    assert len(run.output.strip().splitlines()) == 1
    with pytest.raises(TrialError, match="at least 5"):
        read_ensemble(sorted((tmp_path / "few").glob("*.csv")))


def test_mismatched_sample_rate_names_the_file(tmp_path):
    """A file that disagrees makes the ensemble (one trial) fail: exit status 1 as for any trial
    that cannot be read (docs/interface.md section 2), its one-line reason naming the file."""
    paths = _cycle_files(tmp_path / "mixed", n_cycles=6)
    frame = pd.read_csv(paths[3])
    frame.iloc[::2].assign(time_s=np.arange(500) / 500).to_csv(paths[3], index=False)     # 500 Hz
    with pytest.raises(TrialError, match=r"cycle4\.csv: is sampled at 500 Hz"):
        read_ensemble(paths)
    out = tmp_path / "o"
    run = CliRunner().invoke(main, ["analyze", str(tmp_path / "mixed"), "--ensemble", "--out", str(out), *ARGS])
    assert run.exit_code == 1
    failed = [line for line in run.output.splitlines() if "cycle4.csv" in line]
    assert len(failed) == 1 and "500 Hz, cycle1.csv at 1000 Hz" in failed[0]
    table = pd.read_csv(out / "summary.csv")
    assert table["status"][0] == "failed" and "cycle4.csv" in table["error"][0]


@pytest.fixture(scope="module")
def ensemble_result(tmp_path_factory):
    """8 one-cycle files analysed in memory as the CLI's ``--ensemble`` does (a curve by phase)."""
    import dataclasses

    import limbstiff
    from limbstiff.protocol import Cycles
    folder = tmp_path_factory.mktemp("words") / "strides"
    trial = read_ensemble(_cycle_files(folder))
    protocol = dataclasses.replace(limbstiff.Protocol(), cycles=Cycles(marker=ENSEMBLE_MARKER))
    return limbstiff.analyze(trial, protocol, inertia=0.015, damping=0.8, seed=0)


def _words(fig) -> str:
    return " ".join([t.get_text() for t in fig.texts] + [ax.get_title(loc="left") + " " + ax.get_xlabel()
                                                         for ax in fig.axes])


def test_the_curve_names_the_files_not_a_marker(ensemble_result):
    """Issue 47: "one cycle per file, 8 files", never "rising edges of '<files>'"."""
    from limbstiff.report.curve import curve_page
    words = _words(curve_page(ensemble_result))
    assert "one cycle per file, 8 files" in words and ENSEMBLE_MARKER not in words
    assert ensemble_result.curve.to_dict()["how"] == "one cycle per file, 8 files"         # summary.json's
    assert "one cycle per file, 8 files" in ensemble_result.curve.report()


def test_page_one_under_a_curve_names_the_perturbation_beside_the_task_cycles(ensemble_result):
    """Page 1's points are per period of the motion left when the movement every cycle repeats is
    taken off: named the perturbation's, with the task's cycles beside it, never "motion cycle"."""
    from limbstiff.digest import cycle_course, range_text
    from limbstiff.report.pages import summary_page
    course = cycle_course(ensemble_result)
    words = _words(summary_page(ensemble_result))
    assert (f"a point per perturbation period of {course.seconds:.3g} s (the task's cycles are 1 s)" in words)
    assert "motion cycle" not in words
    assert "over one perturbation period" in range_text(ensemble_result)
    assert "the task's cycles are 1 s" in ensemble_result.report()


def test_the_curve_page_carries_the_curves_own_verdict(ensemble_result):
    """The curve's page says the curve's own verdict (issue 46: at least the trial's) with its
    reasons, not a list of ``ok`` checks beside it, and draws the least-squares points."""
    from limbstiff.digest import VERDICT_WORDS
    from limbstiff.report.curve import curve_page
    curve = ensemble_result.curve
    fig = curve_page(ensemble_result)
    words = _words(fig)
    word, meaning, _ = VERDICT_WORDS[curve.verdict]
    assert f"Curve: {word}" in words and meaning in words
    assert curve.verdict.code >= ensemble_result.checks.verdict.code
    for reason in curve.reasons[:5]:
        assert reason[:40] in words.replace("\n  ", " ")
    assert "ok: " not in words and "FAILED" not in words
    assert "worst of the trial's and of its own checks" in words.replace("\n", " ")
    labels = [t.get_label() for t in fig.axes[0].containers]
    assert any(label.startswith("least squares per bin") for label in labels)
