"""A trial's scheduling variable and cycle marker, and the protocol's [cycles] (issue 36, item 1)."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from limbstiff.errors import ProtocolError, TrialError
from limbstiff.files import read_trial
from limbstiff.files.trial_csv import write_trial
from limbstiff.protocol import Cycles, Protocol, load_protocol, protocol_from_dict
from limbstiff.provenance import settings_hash
from limbstiff.trial import Trial

ROOT = Path(__file__).resolve().parents[1]
FS, N = 100.0, 201                  # 2 s at 100 Hz


def _signals():
    t = np.arange(N) * (1.0 / FS)                # as the reader's uniform grid has it: round trips exactly
    angle = 0.3 * np.sin(2 * np.pi * t)
    torque = 4.0 * angle + 0.5 * np.cos(2 * np.pi * t)
    schedule = 10.0 + 5.0 * t                         # deg, or %MVC
    trigger = ((t % 0.5) < 0.1).astype(float) * 5.0  # rising edges at 0, 0.5, 1.0, 1.5 s (5 V pulses)
    return t, angle, torque, schedule, trigger


def _csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    names = list(columns)
    rows = [",".join(names)]
    rows += [",".join(repr(float(columns[c][k])) for c in names) for k in range(N)]
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def _protocol(tmp_path: Path, text: str) -> Protocol:
    path = tmp_path / "lab.toml"
    path.write_text(text, encoding="utf-8")
    return load_protocol(path)


# ---- protocol ----------------------------------------------------------------------------------

def test_cycles_parsed_and_written_in_the_settings(tmp_path):
    fixed = _protocol(tmp_path, "[cycles]\nperiod_s = 2\nstart_s = 0.5\n")
    assert fixed.cycles == Cycles(period_s=2.0, start_s=0.5, marker=None)
    assert isinstance(fixed.cycles.period_s, float)
    assert fixed.to_dict()["cycles"] == {"period_s": 2.0, "start_s": 0.5, "marker": None}
    marked = _protocol(tmp_path, '[cycles]\nmarker = "trigger"\n')
    assert marked.cycles == Cycles(period_s=None, start_s=0.0, marker="trigger")
    assert marked.to_dict()["cycles"] == {"period_s": None, "start_s": 0.0, "marker": "trigger"}
    changed = fixed.override(cycles=Cycles(marker="sync"))
    assert changed.cycles.marker == "sync" and changed.cycles.period_s is None
    assert fixed.override(cycles=None) is fixed


@pytest.mark.parametrize("section, phrase", [
    ('period_s = 1.0\nmarker = "trigger"', "both period_s and marker"),
    ("start_s = 1.0", "neither period_s nor marker"),
    ("", "neither period_s nor marker"),
    ("period_s = -1.0", "'period_s' in [cycles] must be a positive number"),
    ("period_s = 0", "'period_s' in [cycles] must be a positive number"),
    ("period_s = 1.0\nstart_s = -0.5", "'start_s' in [cycles] must be a number of seconds ≥ 0"),
    ('marker = "trigger"\nstart_s = 1.0', "remove start_s"),
    ("period_s = 1.0\nperiod = 2.0", "unknown key(s) in [cycles]: period"),
    ('period_s = "one"', "'period_s' in [cycles] must be a positive number"),
])
def test_bad_cycles_are_one_line_errors_naming_the_file(tmp_path, section, phrase):
    with pytest.raises(ProtocolError) as info:
        _protocol(tmp_path, f"[cycles]\n{section}\n")
    message = str(info.value)
    assert "\n" not in message and "lab.toml" in message and phrase in message


def test_settings_hash_unchanged_without_cycles():
    # the hashes as they were before [cycles] and schedule existed
    assert "cycles" not in Protocol().to_dict()
    assert settings_hash(Protocol().to_dict()) == "ec1c7aa8b7b2"
    before = {"elbow-lab.toml": "e2a76fd932f6", "reklab-ankle.toml": "2d305c8579dc", "vsa-bench.toml": "d93df758391f"}
    for name, expected in before.items():
        settings = load_protocol(ROOT / "protocols" / name).to_dict()
        settings.pop("source")
        assert settings_hash(settings) == expected, name


def test_schedule_units_free_or_of_the_table():
    for unit in ("%MVC", "V", "mV", "1", "%", "deg", "mm", "Nmm"):
        p = protocol_from_dict({"columns": {"schedule": {"header": "EMG", "unit": unit}}})
        assert p.columns["schedule"].unit == unit
    with pytest.raises(ProtocolError, match="'deg' is"):        # the table's unit in another case: a slip
        protocol_from_dict({"columns": {"schedule": {"header": "pos", "unit": "Deg"}}})
    with pytest.raises(ProtocolError, match="unknown unit 'V' for angle"):   # free units for the schedule only
        protocol_from_dict({"columns": {"angle": {"header": "pos", "unit": "V"}}})


# ---- readers -----------------------------------------------------------------------------------

def test_standard_schedule_header_converted_to_si(tmp_path):
    t, angle, torque, schedule, _ = _signals()
    path = _csv(tmp_path / "t.csv", {"time_s": t, "angle_rad": angle, "torque_Nm": torque, "schedule_deg": schedule})
    trial = read_trial(path)
    assert trial.schedule_unit == "rad"
    np.testing.assert_allclose(trial.schedule, np.deg2rad(schedule), rtol=1e-14)
    assert trial.schedule[0] == pytest.approx(10.0 * math.pi / 180.0)
    assert trial.marker is None
    assert not any("ignored" in w for w in trial.warnings)
    assert trial.kind == "rotational"


def test_schedule_in_mm_does_not_make_a_rotational_trial_translational(tmp_path):
    t, angle, torque, schedule, _ = _signals()
    path = _csv(tmp_path / "t.csv", {"time_s": t, "angle_deg": angle, "torque_Nm": torque, "schedule_mm": schedule})
    trial = read_trial(path)
    assert trial.kind == "rotational" and trial.schedule_unit == "m"
    np.testing.assert_allclose(trial.schedule, schedule * 1e-3, rtol=1e-14)


def test_free_unit_through_the_protocol_kept_unconverted(tmp_path):
    t, angle, torque, schedule, _ = _signals()
    path = _csv(tmp_path / "t.csv", {"time_s": t, "angle_rad": angle, "torque_Nm": torque, "EMG": schedule})
    protocol = _protocol(tmp_path, '[columns.schedule]\nheader = "EMG"\nunit = "%MVC"\nscale = 2.0\n')
    trial = read_trial(path, protocol)
    assert trial.schedule_unit == "%MVC"
    np.testing.assert_allclose(trial.schedule, 2.0 * schedule, rtol=1e-14)
    assert trial.schedule[-1] == pytest.approx(40.0)


def test_marker_column_named_by_cycles(tmp_path):
    t, angle, torque, _, trigger = _signals()
    path = _csv(tmp_path / "t.csv", {"time_s": t, "angle_rad": angle, "torque_Nm": torque, "trigger": trigger})
    unmarked = read_trial(path)                        # no [cycles] marker: an ignored column, as before
    assert unmarked.marker is None and "ignored column(s): 'trigger'" in unmarked.warnings
    trial = read_trial(path, _protocol(tmp_path, '[cycles]\nmarker = "trigger"\n'))
    np.testing.assert_array_equal(trial.marker, trigger)
    rising = np.flatnonzero(np.diff(trial.marker) > 0) + 1
    np.testing.assert_allclose(trial.time[rising], [0.5, 1.0, 1.5, 2.0])
    assert not any("ignored" in w for w in trial.warnings)
    assert trial.schedule is None and trial.schedule_unit is None


def test_column_headed_marker_read_only_when_the_protocol_asks(tmp_path):
    t, angle, torque, _, trigger = _signals()
    path = _csv(tmp_path / "t.csv", {"time_s": t, "angle_rad": angle, "torque_Nm": torque, "marker": trigger})
    assert read_trial(path).marker is None
    assert read_trial(path, _protocol(tmp_path, "[cycles]\nperiod_s = 1.0\n")).marker is None
    trial = read_trial(path, _protocol(tmp_path, '[cycles]\nmarker = "marker"\n'))
    assert trial.marker.sum() == pytest.approx(5.0 * np.count_nonzero(trigger))


def test_missing_marker_or_schedule_column_is_a_one_line_error(tmp_path):
    t, angle, torque, _, trigger = _signals()
    path = _csv(tmp_path / "t.csv", {"time_s": t, "angle_rad": angle, "torque_Nm": torque, "sync": trigger})
    with pytest.raises(TrialError) as info:
        read_trial(path, _protocol(tmp_path, '[cycles]\nmarker = "trigger"\n'))
    message = str(info.value)
    assert "\n" not in message and "t.csv" in message and "'trigger'" in message
    assert "time_s, angle_rad, torque_Nm, sync" in message
    with pytest.raises(TrialError) as info:
        read_trial(path, _protocol(tmp_path, '[columns.schedule]\nheader = "EMG"\nunit = "V"\n'))
    message = str(info.value)
    assert "\n" not in message and "t.csv" in message and "'EMG'" in message and "sync" in message


def test_nan_in_schedule_or_marker_is_the_usual_error(tmp_path):
    t, angle, torque, schedule, trigger = _signals()
    schedule = schedule.copy()
    schedule[7] = np.nan
    path = _csv(tmp_path / "t.csv", {"time_s": t, "angle_rad": angle, "torque_Nm": torque, "schedule_deg": schedule})
    with pytest.raises(TrialError, match=r"NaN in column 'schedule_deg' at line 9 \(t = 0.07 s\)"):
        read_trial(path)
    with pytest.raises(TrialError, match="'marker' is not finite at sample 3"):
        Trial(name="x", time=t, angle=angle, torque=torque, marker=np.where(np.arange(N) == 3, np.inf, 0.0))


def test_resampling_keeps_the_markers_edges(tmp_path):
    t = np.arange(1000) / 500.0                         # 500 Hz, 2 s
    angle, torque = 0.3 * np.sin(2 * np.pi * t), 2.0 * np.cos(2 * np.pi * t)
    trigger = np.zeros(t.size)
    trigger[[100, 351, 602]] = 1.0                      # one-sample pulses at 0.2, 0.702, 1.204 s
    rows = ["time_s,angle_rad,torque_Nm,schedule_deg,trigger"]
    rows += [",".join(repr(float(x)) for x in (t[k], angle[k], torque[k], 10 + 5 * t[k], trigger[k]))
             for k in range(t.size)]
    path = tmp_path / "fast.csv"
    path.write_text("\n".join(rows) + "\n")
    protocol = _protocol(tmp_path, '[cycles]\nmarker = "trigger"\n[signals]\nsample_period = 0.02\n')
    trial = read_trial(path, protocol)
    assert trial.fs == pytest.approx(50.0)
    assert set(np.unique(trial.marker)) == {0.0, 1.0}           # never filtered nor interpolated into ramps
    rising = np.flatnonzero(np.diff(trial.marker) > 0) + 1
    np.testing.assert_allclose(trial.time[rising], [0.2, 0.72, 1.22])   # the first grid time at or after each pulse
    expected = np.deg2rad(10 + 5 * trial.time)       # filtered and interpolated as the angle is: edges of the filter aside
    np.testing.assert_allclose(trial.schedule, expected, atol=5e-5)
    np.testing.assert_allclose(trial.schedule[15:-15], expected[15:-15], atol=1e-6)


def test_segment_and_replace_carry_schedule_and_marker():
    t, angle, torque, schedule, trigger = _signals()
    trial = Trial(name="x", time=t, angle=angle, torque=torque, schedule=schedule, schedule_unit="%MVC",
                  marker=trigger)
    part = trial.segment(10, 110)
    np.testing.assert_array_equal(part.schedule, schedule[10:110])
    np.testing.assert_array_equal(part.marker, trigger[10:110])
    assert part.schedule_unit == "%MVC"
    assert dataclasses.replace(trial, angle=angle * 2).marker is trial.marker
    with pytest.raises(TrialError, match="go together"):
        Trial(name="x", time=t, angle=angle, torque=torque, schedule=schedule)
    with pytest.raises(TrialError, match=r"SI units \(rad\), not 'deg'"):
        Trial(name="x", time=t, angle=angle, torque=torque, schedule=schedule, schedule_unit="deg")
    with pytest.raises(TrialError, match="has 5 samples"):
        Trial(name="x", time=t, angle=angle, torque=torque, marker=trigger[:5])


# ---- writer ------------------------------------------------------------------------------------

@pytest.mark.parametrize("unit, header", [("rad", "schedule_rad"), ("N·m", "schedule_Nm"), ("%MVC", "schedule_%MVC"),
                                          ("1", "schedule_1")])
def test_round_trip_through_write_trial(tmp_path, unit, header):
    t, angle, torque, schedule, trigger = _signals()
    trial = Trial(name="rt", time=t, angle=angle, torque=torque, schedule=schedule * 0.1, schedule_unit=unit,
                  marker=trigger, metadata={"subject": "S01"})
    path = write_trial(trial, tmp_path / "rt.csv")
    head = path.read_text().splitlines()[1]
    assert head == f"time_s,angle_rad,torque_Nm,{header},marker"
    back = read_trial(path, _protocol(tmp_path, '[cycles]\nmarker = "marker"\n'))
    for field in ("time", "angle", "torque", "schedule", "marker"):
        np.testing.assert_array_equal(getattr(back, field), getattr(trial, field), err_msg=field)
    assert back.schedule_unit == unit and back.metadata["subject"] == "S01"
    assert back.warnings == ()


def test_write_trial_without_the_new_fields_unchanged(tmp_path):
    t, angle, torque, _, _ = _signals()
    path = write_trial(Trial(name="x", time=t, angle=angle, torque=torque), tmp_path / "x.csv")
    assert path.read_text().splitlines()[0] == "time_s,angle_rad,torque_Nm"


# ---- other formats -----------------------------------------------------------------------------

def test_mat_schedule_and_marker_through_the_protocol(tmp_path):
    from scipy.io import savemat

    t, angle, torque, schedule, trigger = _signals()
    path = tmp_path / "m.mat"
    savemat(path, {"time_s": t, "angle_rad": angle, "torque_Nm": torque, "emg": schedule, "sync": trigger})
    protocol = _protocol(tmp_path, '[columns.schedule]\nheader = "emg"\nunit = "mV"\n[cycles]\nmarker = "sync"\n')
    trial = read_trial(path, protocol)
    assert trial.schedule_unit == "mV"
    np.testing.assert_allclose(trial.schedule, schedule, rtol=1e-14)
    np.testing.assert_array_equal(trial.marker, trigger)
    with pytest.raises(TrialError, match="no variable 'trigger'"):
        read_trial(path, _protocol(tmp_path, '[cycles]\nmarker = "trigger"\n'))


def test_xlsx_schedule_header_and_marker(tmp_path):
    openpyxl = pytest.importorskip("openpyxl")
    t, angle, torque, schedule, trigger = _signals()
    book = openpyxl.Workbook()
    sheet = book.active
    sheet.append(["time_s", "angle_rad", "torque_Nm", "schedule_deg", "trigger"])
    for k in range(N):
        sheet.append([float(t[k]), float(angle[k]), float(torque[k]), float(schedule[k]), float(trigger[k])])
    path = tmp_path / "x.xlsx"
    book.save(path)
    trial = read_trial(path, _protocol(tmp_path, '[cycles]\nmarker = "trigger"\n'))
    assert trial.schedule_unit == "rad"
    np.testing.assert_allclose(trial.schedule, np.deg2rad(schedule), rtol=1e-14)
    np.testing.assert_array_equal(trial.marker, trigger)


def test_c3d_schedule_channel_in_a_free_unit(tmp_path):
    pytest.importorskip("ezc3d")
    from tests.test_c3d import write_c3d

    t = np.arange(2000) / 1000.0
    angle, torque, emg = 0.3 * np.sin(2 * np.pi * t), 2.0 * np.cos(2 * np.pi * t), 0.5 + 0.1 * t
    path = write_c3d(tmp_path / "s.c3d", analog={"Angle": angle, "Torque": torque, "EMG": emg},
                     analog_units=("rad", "Nm", "V"),
                     points={"LAnkleAngles": np.zeros((3, 200)), "LAnkleMoment": np.zeros((3, 200))})
    columns = {"angle": {"header": "Angle"}, "torque": {"header": "Torque"}, "schedule": {"header": "EMG"}}
    trial = read_trial(path, protocol_from_dict({"columns": columns}))
    assert trial.schedule_unit == "V" and trial.kind == "rotational"
    np.testing.assert_allclose(trial.schedule, emg, rtol=1e-6)
    columns["schedule"]["unit"] = "mV"
    assert read_trial(path, protocol_from_dict({"columns": columns})).schedule_unit == "mV"
    with pytest.raises(TrialError, match=r"\[cycles\] marker\) is not read from C3D files"):
        read_trial(path, protocol_from_dict({"columns": columns, "cycles": {"marker": "Sync"}}))


def test_the_angle_itself_can_be_the_schedule(tmp_path):
    """Stiffness against position: the schedule names the angle's own standard column."""
    from limbstiff.files import read_trial
    from limbstiff.protocol import Column, Protocol
    path = tmp_path / "t.csv"
    t = np.arange(200) / 100.0
    path.write_text("time_s,angle_rad,torque_Nm\n" + "".join(f"{a},{np.sin(a)},{np.cos(a)}\n" for a in t))
    trial = read_trial(path, Protocol(columns={"schedule": Column(header="angle_rad")}))
    assert trial.schedule_unit == "rad"
    np.testing.assert_array_equal(trial.schedule, trial.angle)
