"""C3D input through a protocol (optional ezc3d extra): analog and point channels, units from the
file or the protocol, time from the rate and first frame; the same trial as CSV and C3D analyses
to the same result; bad files and protocols are one-line errors."""

import sys

import numpy as np
import pytest
from click.testing import CliRunner

import limbstiff
from limbstiff.cli import main
from limbstiff.errors import ProtocolError, TrialError
from limbstiff.protocol import protocol_from_dict
from limbstiff.simulate import simulate

ezc3d = pytest.importorskip("ezc3d")

ANALOG = protocol_from_dict({"columns": {"angle": {"header": "Angle"}, "torque": {"header": "Torque"}}})
POINTS = protocol_from_dict({"columns": {"angle": {"header": "LAnkleAngles", "component": "x"},
                                         "torque": {"header": "LAnkleMoment", "component": "X", "unit": "Nmm",
                                                    "scale": -1}}})


def write_c3d(path, *, analog=None, analog_rate=1000.0, analog_units=("rad", "Nm"), points=None,
              point_rate=100.0, first_frame=0, subject="S07"):
    """A C3D file: analog channels {label: values} and point channels {label: (3, n) values};
    angles in degrees and moments in N·mm, as Vicon's model outputs are."""
    c = ezc3d.c3d()
    points = points or {"LAnkleAngles": np.zeros((3, 10)), "LAnkleMoment": np.zeros((3, 10))}
    n_frames = next(iter(points.values())).shape[1]
    c["parameters"]["POINT"]["RATE"]["value"] = [point_rate]
    c["parameters"]["POINT"]["LABELS"]["value"] = tuple(points)
    c["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]                  # markers' unit
    data = np.ones((4, len(points), n_frames))
    data[:3] = np.stack(list(points.values()), axis=1)
    c["data"]["points"] = data
    c.add_parameter("POINT", "ANGLES", ["LAnkleAngles"])
    c.add_parameter("POINT", "ANGLE_UNITS", ["deg"])
    c.add_parameter("POINT", "MOMENTS", ["LAnkleMoment"])
    c.add_parameter("POINT", "MOMENT_UNITS", ["Nmm"])
    if analog:
        c["parameters"]["ANALOG"]["RATE"]["value"] = [analog_rate]
        c["parameters"]["ANALOG"]["LABELS"]["value"] = tuple(analog)
        c["parameters"]["ANALOG"]["UNITS"]["value"] = tuple(analog_units)
        c["data"]["analogs"] = np.vstack(list(analog.values()))[None]
    c["header"]["points"]["first_frame"] = first_frame
    c.add_parameter("SUBJECTS", "NAMES", [subject])
    c.write(str(path))
    return path


@pytest.fixture(scope="module")
def elbow():
    return simulate("elbow", seed=2, params={"duration": 4.0})


@pytest.mark.slow
def test_same_trial_as_csv_and_c3d_gives_the_same_result(elbow, tmp_path):
    """C3D stores float32: the CSV twin carries the same float32 values, so the two trials are
    equal to float64 round-off and so are their analyses (1e-9 relative: the only difference
    left is the time base's last bits)."""
    n = (elbow.n_samples // 10) * 10                  # whole point frames
    angle, torque = (np.float32(x[:n]).astype(float) for x in (elbow.angle, elbow.torque))
    path = write_c3d(tmp_path / "e.c3d", analog={"Angle": angle, "Torque": torque},
                     points={"LAnkleAngles": np.zeros((3, n // 10)), "LAnkleMoment": np.zeros((3, n // 10))})
    csv = tmp_path / "e.csv"
    csv.write_text("time_s,angle_rad,torque_Nm\n" + "".join(
        f"{k / 1000.0!r},{float(a)!r},{float(f)!r}\n" for k, a, f in zip(range(n), angle, torque)))
    from_c3d = limbstiff.read_trial(path, ANALOG)
    from_csv = limbstiff.read_trial(csv)
    np.testing.assert_allclose(from_c3d.time, from_csv.time, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(from_c3d.angle, from_csv.angle)
    np.testing.assert_array_equal(from_c3d.torque, from_csv.torque)
    assert from_c3d.metadata["subject"] == "S07" and from_c3d.metadata["channel_angle"] == "Angle"
    a, b = (limbstiff.analyze(t, seed=0) for t in (from_c3d, from_csv))
    for key in ("median", "lo", "hi"):
        assert a.summary()["stiffness"][key] == pytest.approx(b.summary()["stiffness"][key], rel=1e-9)
    assert a.inertia.median == pytest.approx(b.inertia.median, rel=1e-9)


def test_point_channels_units_from_the_file_and_first_frame(tmp_path):
    """LAnkleAngles x in degrees (from POINT:ANGLE_UNITS) and LAnkleMoment x in N·mm (the
    protocol's unit, sign flipped by it), at 100 Hz from frame 50: t0 = 0.5 s."""
    t = np.arange(400) / 100.0
    deg = 10 * np.sin(2 * np.pi * t)
    nmm = 2000 * np.cos(2 * np.pi * t)
    path = write_c3d(tmp_path / "gait.c3d", first_frame=50,
                     points={"LAnkleAngles": np.vstack([deg, 0 * t, 0 * t]),
                             "LAnkleMoment": np.vstack([nmm, 0 * t, 0 * t])})
    trial = limbstiff.read_trial(path, POINTS)
    assert trial.fs == pytest.approx(100.0) and trial.time[0] == pytest.approx(0.5)
    np.testing.assert_allclose(trial.angle, np.deg2rad(np.float32(deg)), rtol=1e-6)
    np.testing.assert_allclose(trial.torque, -1e-3 * np.float32(nmm), rtol=1e-6)
    assert trial.metadata["channel_angle"] == "LAnkleAngles (x)"


@pytest.mark.parametrize("columns, phrase", [
    ({"angle": {"header": "Knee"}, "torque": {"header": "Torque"}}, "no channel labelled 'Knee' (analog and point "
                                                                    "labels: Angle, Torque, LAnkleAngles"),
    ({"angle": {"header": "LAnkleAngles"}, "torque": {"header": "LAnkleMoment", "component": "x"}},
     "'LAnkleAngles' is a point channel with components x, y, z: give component"),
    ({"angle": {"header": "Angle", "component": "y"}, "torque": {"header": "Torque"}},
     "'Angle' is an analog channel: it has no component"),
    ({"angle": {"header": "Angle"}, "torque": {"header": "LAnkleMoment", "component": "x", "unit": "Nmm"}},
     "maps analog and point channels"),
    ({"angle": {"header": "Angle"}}, "a C3D file is read through a protocol whose [columns] name the angle and torque"),
])
def test_bad_mappings_are_one_line_errors(tmp_path, columns, phrase):
    path = write_c3d(tmp_path / "t.c3d", analog={"Angle": np.zeros(100), "Torque": np.zeros(100)})
    with pytest.raises(TrialError) as err:
        limbstiff.read_trial(path, protocol_from_dict({"columns": columns}))
    assert phrase in str(err.value) and str(err.value).startswith(str(path)) and "\n" not in str(err.value)


def test_unit_missing_in_file_and_protocol(tmp_path):
    wave = np.sin(np.arange(1000) / 50.0)
    path = write_c3d(tmp_path / "t.c3d", analog={"Angle": wave, "Torque": wave},
                     analog_units=("V", "Nm"), points={"LAnkleAngles": np.zeros((3, 100))})
    with pytest.raises(TrialError, match="channel 'Angle' has unit 'V' in the file: give its unit"):
        limbstiff.read_trial(path, ANALOG)
    given = protocol_from_dict({"columns": {"angle": {"header": "Angle", "unit": "deg"}, "torque": {"header": "Torque"}}})
    assert limbstiff.read_trial(path, given).n_samples == 1000


def test_units_that_cannot_be_right(tmp_path):
    """A model moment needs the protocol's unit (body-mass normalisation); a torque whose unit is
    a length (a marker's POINT:UNITS) and rotational with translational units are refused."""
    t = np.arange(300) / 100.0
    wave = np.vstack([np.sin(t), 0 * t, 0 * t])
    path = write_c3d(tmp_path / "p.c3d", points={"LAnkleAngles": wave, "LAnkleMoment": wave, "LHEE": wave})
    moment = {"angle": {"header": "LAnkleAngles", "component": "x"},
              "torque": {"header": "LAnkleMoment", "component": "x"}}
    with pytest.raises(TrialError, match="'LAnkleMoment' is a model output whose unit the file cannot settle"):
        limbstiff.read_trial(path, protocol_from_dict({"columns": moment}))
    marker = {"angle": {"header": "LAnkleAngles", "component": "x"}, "torque": {"header": "LHEE", "component": "z"}}
    with pytest.raises(TrialError, match="channel 'LHEE': unit 'mm' is not a unit of torque"):
        limbstiff.read_trial(path, protocol_from_dict({"columns": marker}))
    analog = write_c3d(tmp_path / "a.c3d", analog={"Angle": np.sin(t.repeat(10)), "Force": np.sin(t.repeat(10))},
                       analog_units=("deg", "N"), points={"LAnkleAngles": wave})
    mixed = protocol_from_dict({"columns": {"angle": {"header": "Angle"}, "torque": {"header": "Force"}}})
    with pytest.raises(TrialError, match="mixes rotational and translational channels"):
        limbstiff.read_trial(analog, mixed)


def test_wrong_component_in_protocol():
    with pytest.raises(ProtocolError, match="'component' of \\[columns.angle\\] must be"):
        protocol_from_dict({"columns": {"angle": {"header": "LAnkleAngles", "component": "w"}}})


def test_cli_on_a_broken_file_and_without_the_extra(tmp_path, monkeypatch):
    bad = tmp_path / "bad.c3d"
    bad.write_bytes(b"not a c3d file at all" * 20)
    proto = tmp_path / "p.toml"
    proto.write_text('[columns]\nangle = { header = "Angle" }\ntorque = { header = "Torque" }\n')
    res = CliRunner().invoke(main, ["analyze", str(bad), "--protocol", str(proto), "--out", str(tmp_path / "o"),
                                    "--no-pdf", "--jobs", "1"])
    assert res.exit_code == 1 and "bad.c3d: not a readable C3D file" in res.output and "Traceback" not in res.output
    monkeypatch.setitem(sys.modules, "ezc3d", None)                  # as if the extra were not installed
    with pytest.raises(TrialError, match=r"needs the optional extra: pip install 'limbstiff\[c3d\]'"):
        limbstiff.read_trial(bad, ANALOG)
