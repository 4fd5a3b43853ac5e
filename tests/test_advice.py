"""Advice computed from the file and the protocol as given (issue 47, item 2): each input built as
the issue describes it, and the message it gets."""

import dataclasses
import warnings

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

import limbstiff
from limbstiff.checks.analysis import sign_advice, sign_hint
from limbstiff.checks.units import plausible
from limbstiff.cli import main
from limbstiff.errors import TrialError
from limbstiff.files import read_trial, write_trial
from limbstiff.filtering import filtered_for_analysis
from limbstiff.plausibility import check_angle, check_inertia, check_torque
from limbstiff.protocol import Protocol, protocol_from_dict

from .conftest import multisine_trial

#: The README's own my-lab.toml: a reaction torque, flipped.
MY_LAB = protocol_from_dict({"columns": {
    "time": {"header": "Zeit", "unit": "ms"}, "angle": {"header": "Winkel", "unit": "deg"},
    "torque": {"header": "Moment", "unit": "Nm", "scale": -1.0}},
    "format": {"delimiter": ";", "decimal": ","}})


def test_sign_advice_starts_from_the_protocol():
    assert "add scale = -1" in sign_advice(1.0)
    flip = sign_advice(-1.0)
    assert "already flips it" in flip and "remove it (scale = 1)" in flip and "scale = -1 to" not in flip
    assert "set scale = -2" in sign_advice(2.0)
    assert "[columns.elastic_torque]" in sign_advice(1.0, "elastic_torque")


def test_an_applied_torque_under_my_lab_is_told_to_remove_the_flip(tmp_path):
    # the README's my-lab.toml on an export whose torque is applied to the joint, not a reaction one
    trial = multisine_trial("S01")
    frame = pd.DataFrame({"Zeit (ms)": trial.time * 1e3, "Winkel (°)": np.degrees(trial.angle),
                          "Moment (Nm)": trial.torque})
    path = tmp_path / "S01.csv"
    frame.to_csv(path, sep=";", decimal=",", index=False, float_format="%.9g")
    read = read_trial(path, MY_LAB)
    assert np.allclose(read.torque, -trial.torque)
    hint = sign_hint(filtered_for_analysis(read, MY_LAB).filtered, scale=-1.0)
    assert hint is not None and "remove it (scale = 1)" in hint
    assert "remove it" not in sign_hint(filtered_for_analysis(read, Protocol()).filtered)


@pytest.mark.slow
def test_the_my_lab_error_says_remove_the_flip(tmp_path):
    # the whole analysis from the file: the identification fails, the error leads to the flip
    trial = multisine_trial("S01")
    path = tmp_path / "S01.csv"
    pd.DataFrame({"Zeit (ms)": trial.time * 1e3, "Winkel (°)": np.degrees(trial.angle),
                  "Moment (Nm)": trial.torque}).to_csv(path, sep=";", decimal=",", index=False, float_format="%.9g")
    with pytest.raises(TrialError, match=r"already flips it \(scale = -1\).*remove it \(scale = 1\)") as caught:
        limbstiff.analyze(path, MY_LAB, seed=0)
    assert "--inertia" not in str(caught.value)


@pytest.mark.slow
def test_a_failed_sign_check_says_what_to_change(tmp_path):
    elbow = multisine_trial("reaction")
    flipped = dataclasses.replace(elbow, torque=-elbow.torque)
    given = dict(inertia=0.06, damping=0.45, seed=0)
    sign = limbstiff.analyze(flipped, Protocol(), **given).checks["torque_sign"]
    assert not sign.passed and "add scale = -1" in sign.message
    flipping = protocol_from_dict({"columns": {"torque": {"scale": -1.0}}})
    sign = limbstiff.analyze(flipped, flipping, **given).checks["torque_sign"]
    assert not sign.passed and "remove it (scale = 1)" in sign.message


def test_a_still_angle_under_angle_rad_is_not_told_to_write_angle_rad(tmp_path):
    trial = multisine_trial("tiny")
    trial = dataclasses.replace(trial, angle=trial.angle * 4e-6 / np.ptp(trial.angle))
    path = write_trial(trial, tmp_path / "tiny.csv")
    assert "angle_rad" in path.read_text().splitlines()[2]
    (found,) = plausible(read_trial(path), Protocol())
    assert found.name == "angle_range" and "angle_rad" not in found.message
    assert "barely moves" in found.message


def test_a_unit_advice_never_names_the_unit_stated():
    angle = 0.0005 * np.sin(np.linspace(0, 20, 2000))          # rad read as deg would make a test's motion
    assert 'unit = "rad"' in check_angle(angle)[0].message
    assert "rad\"" not in check_angle(angle, written="rad")[0].message
    torque = 0.0002 * np.sin(np.linspace(0, 20, 2000))
    assert "torque_Nm" in check_torque(torque)[0].message
    assert "torque_Nm" not in check_torque(torque, written="N·m")[0].message


def test_a_torque_of_zeros_is_named_before_any_fit_without_warnings(tmp_path):
    trial = multisine_trial("zeros")
    path = write_trial(dataclasses.replace(trial, torque=np.zeros_like(trial.torque)), tmp_path / "zeros.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(TrialError, match="the torque is 0 N·m throughout: no torque was recorded"):
            limbstiff.analyze(path, seed=0)
    result = CliRunner().invoke(main, ["analyze", str(path), "--out", str(tmp_path / "out")])
    assert result.exit_code != 0
    assert "no torque was recorded" in result.output and "Warning" not in result.output


def test_the_units_written_in_the_file_are_never_the_fix(tmp_path):
    # 0.002 rad of motion under angle_rad: radians read as degrees would fit the numbers, but the
    # header already says rad
    trial = multisine_trial("small")
    trial = dataclasses.replace(trial, angle=trial.angle * 0.002 / np.ptp(trial.angle))
    read = read_trial(write_trial(trial, tmp_path / "small.csv"))
    assert read.units_written["angle"] == "rad"
    (found,) = plausible(read, Protocol())
    assert 'unit = "rad"' not in found.message and "angle_rad" not in found.message
    (unread,) = plausible(dataclasses.replace(read, units_written={}), Protocol())
    assert "angle_rad" in unread.message
    inertia = check_inertia(500.0, written={"angle": "rad", "torque": "N·m"})
    assert "Nmm" in inertia.message and 'unit = "rad"' not in inertia.message
    assert 'unit = "deg"' not in check_inertia(1e-9, written={"angle": "°"}).message


def test_a_constant_angle_is_named():
    (found,) = check_angle(np.full(100, 0.3))
    assert found.fatal and "did not move" in found.message


def _gappy(tmp_path):
    """10 s at 1 kHz with 500 empty angle cells from line 9002 (the issue's block)."""
    path = write_trial(multisine_trial("gappy", duration=10.0, fs=1000.0), tmp_path / "gappy.csv")
    lines = path.read_text().splitlines()
    for i in range(9001, 9501):
        time_s, _, *rest = lines[i].split(",")
        lines[i] = ",".join([time_s, "", *rest])
    path.write_text("\n".join(lines) + "\n")
    return path, lines


def test_an_empty_block_says_how_to_proceed(tmp_path):
    path, lines = _gappy(tmp_path)
    with pytest.raises(TrialError) as caught:
        read_trial(path)
    message = str(caught.value)
    assert "empty cell in column 'angle_rad' at line 9002" in message
    assert "500 empty cell(s) up to line 9501" in message and "max_gap_s = 0.51" in message
    assert "cut the trial" in message
    # the advice followed: the rows deleted, the gap bridged with the value given
    cut = tmp_path / "cut.csv"
    cut.write_text("\n".join(lines[:9001] + lines[9501:]) + "\n")
    bridge = protocol_from_dict({"format": {"max_gap_s": 0.51}})
    trial = read_trial(cut, bridge)
    assert trial.bridged is not None and trial.bridged.sum() >= 499


def test_an_empty_block_in_a_workbook_says_how_to_proceed(tmp_path):
    trial = multisine_trial("book", duration=4.0)
    frame = pd.DataFrame({"time_s": trial.time, "angle_rad": trial.angle, "torque_Nm": trial.torque})
    frame.loc[1000:1099, "angle_rad"] = np.nan
    frame.to_excel(tmp_path / "book.xlsx", index=False)
    with pytest.raises(TrialError, match=r"100 empty cell\(s\) up to row 1101 .*max_gap_s = 0\.2"):
        read_trial(tmp_path / "book.xlsx")


def test_a_trial_done_with_a_poor_verdict_is_not_called_ok():
    from limbstiff.batch.runner import TrialOutcome
    from limbstiff.cli.progress import _mark
    row = type("Row", (), {"verdict": "unreliable", "output": "out/tiny"})()
    mark = _mark(TrialOutcome("tiny", "tiny.csv", "ok", "", row))
    assert mark.startswith("done, verdict unreliable") and "out/tiny/summary.json" in mark
    assert _mark(TrialOutcome("a", "a.csv", "ok", "", type("Row", (), {"verdict": "ok"})())) == "ok"
