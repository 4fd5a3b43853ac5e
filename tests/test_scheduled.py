"""Stiffness by phase and by schedule (issue 36): cycles, the basis, held-out scoring, and one
ensemble analysed end to end through the command line."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from limbstiff import cycles
from limbstiff.cli import main
from limbstiff.scheduled.basis import phase_basis, schedule_basis
from limbstiff.scheduled.checks import disagreeing
from limbstiff.scheduled.resolution import heldout_score


def test_cycles_by_period_phase_is_linear_in_time_and_whole_cycles_only():
    split = cycles.by_period(1050, sample_period=0.01, period_s=2.0, start_s=0.5)
    # 10.5 s from 0.5 s: cycles at 0.5, 2.5, 4.5, 6.5, 8.5 (the last ends at 10.5 = sample 1050)
    assert split.n_cycles == 5 and list(split.starts) == [50, 250, 450, 650, 850, 1050]
    phase = split.phase_of(1050)
    assert np.isnan(phase[:50]).all()
    assert phase[50] == 0 and phase[150] == pytest.approx(0.5) and phase[249] == pytest.approx(0.995)


def test_marker_edges_debounced_and_unequal_cycles_normalised():
    marker = np.zeros(1000)
    for start in (100, 300, 520, 700):
        marker[start:start + 5] = 5.0
    marker[302] = 0.0                     # a bounce inside a pulse: one edge more, within 25 % of a cycle
    split = cycles.by_marker(marker, header="trigger")
    assert list(split.starts) == [100, 300, 520, 700]
    phase = split.phase_of(1000)
    assert phase[300 + 110] == pytest.approx(0.5)          # the 220-sample cycle, half way
    assert phase[520 + 90] == pytest.approx(0.5)           # the 180-sample one


def test_ensemble_mean_of_a_repeated_signal_is_the_signal():
    split = cycles.by_period(3000, sample_period=0.001, period_s=0.5)
    phase = split.phase_of(3000)
    x = np.sin(2 * np.pi * phase) + 0.3 * np.cos(6 * np.pi * phase)
    mean = cycles.ensemble_mean(x, phase, bins=cycles.mean_bins(split))
    # 125 bins of 4 samples: the interpolated bin means differ from the signal by its curvature
    # over a bin (≈ (2π·3/125)²/8 of 0.3 ≈ 9e-4)
    assert np.max(np.abs(mean - x)) < 2e-3


def test_hats_sum_to_one_and_wrap_on_the_phase():
    basis = phase_basis(8)
    u = np.linspace(0, 0.999, 500)
    hats = basis.hats(u)
    assert np.allclose(hats.sum(axis=0), 1.0)
    assert hats[0, -1] == pytest.approx(0.999 * 8 - 7)           # the last stretch rises back to knot 0
    assert basis.design(u).shape == (7, 500)
    sched = schedule_basis(4, np.linspace(-0.4, 0.2, 1000), unit="rad")
    assert np.allclose(sched.hats(np.array([-1.0, 1.0])), [[1, 0], [0, 0], [0, 0], [0, 1]])   # flat beyond


def test_heldout_score_recovers_a_linear_channel_and_flags_an_odd_unit():
    rng = np.random.default_rng(3)
    m = 6000
    x = rng.standard_normal(m)
    unit = np.repeat(np.arange(30), m // 30)
    noise = rng.standard_normal(m)
    noise[unit == 7] *= 3.0                                  # one unit three times as noisy
    e = np.vstack([2.0 * x + noise, x])
    score = heldout_score(e, np.ones(m), unit, guard=0)
    assert score.model_error == pytest.approx(np.mean(noise ** 2), rel=0.01)
    assert list(disagreeing(score.unit_error)) == [7]
    # without the odd unit none stands out: a mean of 200 squared normals has sd 0.1, the
    # threshold is 5 robust sd and 1.5× the median
    noise[unit == 7] /= 3.0
    clean = heldout_score(np.vstack([2.0 * x + noise, x]), np.ones(m), unit, guard=0)
    assert len(disagreeing(clean.unit_error)) == 0


def _ensemble_csv(path, *, n_cycles=14, period=1.0, seed=5):
    """A small ensemble written the way ensemble_sim writes it (not its equations): stiffness
    60 + 30·sin(2π·phase) N·m/rad, a reference movement, a smoothed random perturbation that
    differs from cycle to cycle, and a background torque that repeats."""
    from scipy import signal
    rng = np.random.default_rng(seed)
    fs = 1000
    n = int(n_cycles * period * fs)
    t = np.arange(n) / fs
    phase = (t / period) % 1.0
    k = 60 + 30 * np.sin(2 * np.pi * phase)
    pert = signal.filtfilt(*signal.butter(2, 25 / 500), np.repeat(rng.choice([-1.0, 1.0], n // 40 + 1), 40)[:n]) * 0.03
    y = 0.1 * np.sin(2 * np.pi * phase) + pert
    yd, ydd = np.gradient(y, 1 / fs), np.gradient(np.gradient(y, 1 / fs), 1 / fs)
    torque = 5 * np.cos(2 * np.pi * phase) + 0.015 * ydd + 0.8 * yd + k * pert + 0.05 * rng.standard_normal(n)
    marker = ((t % period) < 0.01).astype(float)
    pd.DataFrame({"time_s": t, "angle_rad": y, "torque_Nm": torque, "trigger": marker}).to_csv(path, index=False)
    return lambda ph: 60 + 30 * np.sin(2 * np.pi * ph)


@pytest.mark.slow
def test_ensemble_through_the_cli(tmp_path):
    truth = _ensemble_csv(tmp_path / "ens.csv")
    out = tmp_path / "out"
    run = CliRunner().invoke(main, ["analyze", str(tmp_path / "ens.csv"), "--marker", "trigger", "--no-pdf",
                                    "--inertia", "0.015", "--damping", "0.8", "--out", str(out)])
    assert run.exit_code == 0, run.output
    frame = pd.read_csv(out / "ens" / "stiffness_by_phase.csv")
    assert list(frame.columns) == ["phase", "stiffness", "stiffness_lo", "stiffness_hi", "n_cycles", "ls_stiffness",
                                   "ls_stiffness_lo", "ls_stiffness_hi"]
    assert len(frame) == 50 and frame["phase"].iloc[0] == pytest.approx(0.01)
    ok = frame["stiffness"].notna()
    err = np.abs(frame["stiffness"][ok] - truth(frame["phase"][ok])) / truth(frame["phase"][ok])
    # 14 cycles of 1 s: the curve's bins hold ~14 × 20 ms of perturbation each; 10 % median error
    # is twice what the issue asks of ≥ 40 cycles (5 %), for a third of the data
    assert ok.mean() > 0.9 and np.median(err) < 0.10
    assert (frame["n_cycles"][ok] >= 10).all()
    summary = json.loads((out / "ens" / "summary.json").read_text())
    block = summary["by_phase"]
    assert block["n_cycles"] == 13                      # 14 pulses, the last cycle has no end
    assert block["resolution"]["chosen_knots"] > 0            # a curve, not the walk alone
    assert {c["name"] for c in summary["checks"]} >= {"curve_heldout", "curve_outlier_units", "curve_coverage"}
    # issue 46: the curve's own verdict, at least the trial's, and the least-squares cross-check beside it
    assert block["verdict"] in ("ok", "caution", "unreliable") and isinstance(block["reasons"], list)
    order = ["ok", "caution", "unreliable"]
    assert order.index(block["verdict"]) >= order.index(summary["verdict"])
    assert {c["name"] for c in block["checks"]} >= {"curve_least_squares", "curve_negative"}
    ls = frame["ls_stiffness"].notna()
    # the least-squares fit of 13 cycles: within 10 % of the truth at the median (the same room as the curve's)
    assert ls.mean() > 0.9 and np.median(np.abs(frame["ls_stiffness"][ls] / truth(frame["phase"][ls]) - 1)) < 0.10
    assert "stiffness_by_phase.csv" in summary["files"]
    # the same file analysed without cycles into the same folder: no curve of the earlier run is left
    again = CliRunner().invoke(main, ["analyze", str(tmp_path / "ens.csv"), "--no-pdf", "--overwrite", "--inertia",
                                      "0.015", "--damping", "0.8", "--out", str(out)])
    assert again.exit_code == 0, again.output
    assert not (out / "ens" / "stiffness_by_phase.csv").exists()


def test_period_and_marker_together_is_a_usage_error(tmp_path):
    run = CliRunner().invoke(main, ["analyze", str(tmp_path / "x.csv"), "--marker", "m", "--period", "1"])
    assert run.exit_code == 2 and "--period or --marker" in run.output


def test_short_trigger_pulses_are_found():
    """Pulses of 10 ms every 1.5 s are 0.7 % of the samples: below a 1st–99th percentile range."""
    marker = np.zeros(15000)
    for start in range(100, 15000, 1500):
        marker[start:start + 10] = 1.0
    assert list(cycles.rising_edges(marker)) == list(range(100, 15000, 1500))


@pytest.mark.slow
def test_stiffness_by_schedule_of_a_swept_operating_point():
    """A joint whose operating position is swept slowly from −0.3 to 0.3 rad under a smoothed random
    perturbation, the torque the integral of K(s)·dθ with K(s) = 60 + 40·s/0.3 N·m/rad (20 → 100
    over the sweep): the curve against the recorded position."""
    import limbstiff
    from limbstiff.protocol import Protocol
    from scipy import signal
    rng = np.random.default_rng(11)
    fs, n = 1000, 30000
    t = np.arange(n) / fs
    s = -0.3 + 0.6 * t / t[-1]
    pert = signal.filtfilt(*signal.butter(2, 25 / 500), np.repeat(rng.choice([-1.0, 1.0], n // 40 + 1), 40)[:n]) * 0.02
    y = s + pert
    k = 60 + 40 * s / 0.3                                    # 20 → 100 N·m/rad
    dy = np.diff(y, prepend=y[0])
    torque = (np.cumsum(k * dy) + 0.015 * np.gradient(np.gradient(y, 1 / fs), 1 / fs) + 0.8 * np.gradient(y, 1 / fs)
              + 0.05 * rng.standard_normal(n))
    trial = limbstiff.Trial(name="sweep", time=t, angle=y, torque=torque, schedule=s, schedule_unit="rad")
    result = limbstiff.analyze(trial, Protocol(variant="external", inertia=0.015, damping=0.8))
    curve = result.by_schedule
    assert result.by_phase is None and curve is not None
    frame = curve.to_frame()
    assert list(frame.columns) == ["schedule", "stiffness", "stiffness_lo", "stiffness_hi", "n_samples"]
    ok = curve.informed
    truth = 60 + 40 * curve.at / 0.3
    err = np.abs(curve.stiffness[ok] - truth[ok]) / truth[ok]
    # 30 s, one sweep: each of the 30 bins holds 1 s of perturbation; 10 % median error leaves
    # room for the smoothing of a curve from 30 s of data (the benchmark asks 5 % of 100 s trials)
    assert ok.mean() > 0.9 and np.median(err) < 0.10
    assert result.summary()["by_schedule"]["unit"] == "rad"
    # drawn by the report's plot_curve: the curve (pure maths) imports no drawing
    from matplotlib.figure import Figure
    ax = Figure().subplots()
    assert result.plot(ax=ax, against="schedule") is ax and ax.has_data()
    with pytest.raises(ValueError, match="no stiffness by phase"):
        result.plot(ax=ax, against="phase")


def test_cycles_too_short_and_a_constant_schedule_are_one_line_errors(tmp_path):
    truth = _ensemble_csv(tmp_path / "ens.csv", n_cycles=6)
    assert truth is not None
    short = CliRunner().invoke(main, ["analyze", str(tmp_path / "ens.csv"), "--period", "0.02", "--no-pdf",
                                      "--out", str(tmp_path / "o1")])
    assert short.exit_code == 1 and "needs at least 40" in short.output and "Traceback" not in short.output
    frame = pd.read_csv(tmp_path / "ens.csv")
    frame["level"] = 0.25
    frame.to_csv(tmp_path / "flat.csv", index=False)
    flat = CliRunner().invoke(main, ["analyze", str(tmp_path / "flat.csv"), "--schedule", "level:rad", "--no-pdf",
                                     "--out", str(tmp_path / "o2")])
    assert flat.exit_code == 1 and "does not vary" in flat.output and "Traceback" not in flat.output
