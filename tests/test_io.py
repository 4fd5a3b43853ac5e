"""Tests of limbstiff.files: reading and writing trial CSVs, units, atomic writes."""

from __future__ import annotations

import hashlib
import math
import os
from pathlib import Path

import numpy as np
import pytest

from limbstiff.errors import ProtocolError

from limbstiff.errors import TrialError
from limbstiff.files import UNITS, atomic_write_bytes, atomic_write_text, read_trial, sha256_file, write_trial
from limbstiff.files import atomic as atomic_module
from limbstiff.files.atomic import atomic_output
from limbstiff.units import parse_standard_header, to_si, unit_in_header
from limbstiff.protocol import protocol_from_dict
from limbstiff.trial import MIN_SAMPLES, Trial

from .conftest import REAL as REKLAB  # noqa: E402


def signals(n=200, dt=0.005):
    """Time, angle, torque of a smooth test trial (SI units)."""
    t = np.arange(n) * dt
    return t, 0.1 * np.sin(2 * np.pi * 1.5 * t), 2.0 * np.sin(2 * np.pi * 1.5 * t + 0.3)


def write_csv(path, header, columns, meta=(), fmt="{!r}"):
    """Write rows of ``columns`` under ``header``; returns the path."""
    lines = [*meta, header]
    lines += [",".join(fmt.format(float(v)) for v in row) for row in zip(*columns)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def standard(tmp_path, name="trial.csv", **kw):
    return write_csv(tmp_path / name, "time_s,angle_rad,torque_Nm", signals(**kw))


def edit_line(path, lineno, new):
    lines = path.read_text().split("\n")
    lines[lineno - 1] = new
    path.write_text("\n".join(lines))


def expect_error(path, phrase, protocol=None):
    with pytest.raises(TrialError) as info:
        read_trial(path, protocol)
    message = str(info.value)
    assert Path(path).name in message, message
    assert phrase in message, message
    assert "\n" not in message
    return message


# ---------------------------------------------------------------- reading good files

def test_standard_file(tmp_path):
    path = write_csv(tmp_path / "s01.csv", "time_s,angle_rad,torque_Nm", signals(),
                     meta=["# subject: S01", "# side : left", "# a line without colon", "#date: 2024-01-02"])
    trial = read_trial(path)
    t, a, tau = signals()
    assert isinstance(trial, Trial)
    assert trial.name == "s01" and trial.kind == "rotational" and trial.variant == "external"
    np.testing.assert_allclose(trial.time, t, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(trial.angle, a)
    np.testing.assert_array_equal(trial.torque, tau)
    assert trial.elastic_torque is None and trial.stiffness_true is None
    assert dict(trial.metadata) == {"subject": "S01", "side": "left", "date": "2024-01-02"}
    assert trial.source == str(path)
    assert trial.source_sha256 == sha256_file(path) == hashlib.sha256(path.read_bytes()).hexdigest()
    assert trial.warnings == ()
    assert read_trial(path, name="other").name == "other"


def test_unit_conversions(tmp_path):
    t, a, tau = signals()
    path = write_csv(tmp_path / "u.csv", "time_ms,angle_deg,torque_Nmm,elastic_torque_Nm,stiffness_true_Nm_per_rad",
                     [t * 1e3, np.degrees(a), tau * 1e3, tau / 2, np.full(t.size, 30.0)])
    trial = read_trial(path)
    np.testing.assert_allclose(trial.time, t, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(trial.angle, a, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(trial.torque, tau, rtol=1e-12)
    np.testing.assert_allclose(trial.elastic_torque, tau / 2, rtol=1e-12)
    np.testing.assert_allclose(trial.stiffness_true, 30.0)
    assert trial.variant == "direct"


def test_translational_units(tmp_path):
    t, a, tau = signals()
    path = write_csv(tmp_path / "lin.csv", "time_s,position_mm,force_N,elastic_force_N,stiffness_true_N_per_m",
                     [t, a * 1e3, tau, tau, np.full(t.size, 500.0)])
    trial = read_trial(path)
    assert trial.kind == "translational" and trial.units["angle"] == "m"
    np.testing.assert_allclose(trial.angle, a, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(trial.elastic_torque, tau)


def test_bom_crlf_and_ignored_columns(tmp_path):
    t, a, tau = signals()
    text = "# subject: S02\r\ntime_s,emg_V,angle_rad,torque_Nm\r\n"
    text += "".join(f"{x!r},hello,{y!r},{z!r}\r\n" for x, y, z in zip(t.tolist(), a.tolist(), tau.tolist()))
    path = tmp_path / "bom.csv"
    path.write_bytes(b"\xef\xbb\xbf" + text.encode())
    trial = read_trial(path)
    assert trial.metadata["subject"] == "S02"
    np.testing.assert_array_equal(trial.angle, a)
    assert any("ignored column(s): 'emg_V'" in w for w in trial.warnings)


def test_unit_table():
    assert parse_standard_header("elastic_torque_Nm") == ("elastic_torque", "Nm")
    assert parse_standard_header("stiffness_true_Nm_per_rad") == ("stiffness_true", "Nm_per_rad")
    assert parse_standard_header("Time_ms") == ("time", "ms")
    assert parse_standard_header("pos1") is None
    assert unit_in_header("Torque (Nm)") == "Nm" and unit_in_header("k [N/m]") == "N/m"
    assert unit_in_header("stiff_Nm_per_rad") == "Nm_per_rad" and unit_in_header("pos1") is None
    np.testing.assert_allclose(to_si([180.0], "deg"), [math.pi])
    np.testing.assert_allclose(to_si([1500.0], "ms"), [1.5])
    np.testing.assert_allclose(to_si([2500.0], "Nmm"), [2.5])
    np.testing.assert_allclose(to_si([12.0], "mm"), [0.012])
    np.testing.assert_allclose(to_si([1.0], "Nm_per_deg"), [180 / math.pi])
    assert UNITS["N·m"].factor == 1.0 and UNITS["kN"].dimension == "force"


# ---------------------------------------------------------------- protocols

def test_protocol_custom_headers(tmp_path):
    t, a, tau = signals()
    path = write_csv(tmp_path / "lab.csv", "t,pos1,Torque (Nm),other",
                     [t * 1e3, np.degrees(a), tau, tau])
    protocol = protocol_from_dict({"columns": {
        "time": {"header": "t", "unit": "ms"},
        "angle": {"header": "pos1", "unit": "deg"},
        "torque": {"header": "Torque (Nm)", "scale": -1.0}}})
    trial = read_trial(path, protocol)
    np.testing.assert_allclose(trial.angle, a, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(trial.torque, -tau, rtol=1e-12)
    np.testing.assert_allclose(trial.time, t, atol=1e-12)


def test_protocol_unit_override_and_fallback(tmp_path):
    t, a, tau = signals()
    path = write_csv(tmp_path / "ovr.csv", "time_s,angle_rad,torque_Nm", [t, np.degrees(a), tau])
    # the file says rad but holds degrees; the protocol overrides the unit and flips the torque
    protocol = protocol_from_dict({"columns": {"angle": {"unit": "deg"}, "torque": {"scale": -1.0}}})
    trial = read_trial(path, protocol)
    np.testing.assert_allclose(trial.angle, a, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(trial.torque, -tau)


def test_protocol_translational_kind(tmp_path):
    t, a, tau = signals()
    path = write_csv(tmp_path / "vsa.csv", "time_s,x,F", [t, a * 1e3, tau])
    protocol = protocol_from_dict({"columns": {"angle": {"header": "x", "unit": "mm"},
                                               "torque": {"header": "F", "unit": "N"}}})
    trial = read_trial(path, protocol)
    assert trial.kind == "translational"
    np.testing.assert_allclose(trial.angle, a, atol=1e-15)


def test_reklab_real_file():
    path = REKLAB / "z_df.csv"
    protocol = protocol_from_dict({"columns": {
        "angle": {"header": "position_rad", "unit": "rad"},
        "torque": {"header": "torque_Nm", "unit": "Nm", "scale": -1.0}}})
    trial = read_trial(path, protocol)
    assert trial.kind == "rotational" and trial.name == "z_df"
    assert trial.n_samples == 60000 and trial.fs == pytest.approx(1000.0)
    with open(path) as handle:
        handle.readline()
        first = [float(v) for v in handle.readline().split(",")]
    assert trial.angle[0] == first[1] and trial.torque[0] == -first[2]
    assert trial.warnings == ()
    # without the protocol, position_rad is not a standard header
    expect_error(path, "unit 'rad' is not a unit of position")


# ---------------------------------------------------------------- sampling

def test_irregular_sampling_resampled(tmp_path):
    rng = np.random.default_rng(1)
    t = np.cumsum(np.r_[0.0, 0.01 * (1 + rng.uniform(-0.2, 0.2, 299))])
    path = write_csv(tmp_path / "irr.csv", "time_s,angle_rad,torque_Nm", [t, 2 * t + 1, 3 * t ** 2])
    trial = read_trial(path)
    assert any("irregular sampling" in w and "resampled" in w for w in trial.warnings)
    step = np.median(np.diff(t))
    assert trial.sample_period == pytest.approx(step, rel=1e-9)
    assert trial.time[0] == t[0] and trial.time[-1] <= t[-1]
    np.testing.assert_allclose(trial.angle, 2 * trial.time + 1, rtol=1e-12)  # linear: exact


def test_small_jitter_snapped_silently(tmp_path):
    rng = np.random.default_rng(2)
    t, a, tau = signals(n=300, dt=0.002)
    t = t + rng.uniform(-1e-6, 1e-6, t.size)
    trial = read_trial(write_csv(tmp_path / "jit.csv", "time_s,angle_rad,torque_Nm", [t, a, tau]))
    assert trial.warnings == ()
    assert np.ptp(np.diff(trial.time)) < 1e-9 * 0.002
    assert trial.sample_period == pytest.approx(0.002, rel=1e-5)
    np.testing.assert_array_equal(trial.angle, a)


def test_protocol_sample_period(tmp_path):
    path = standard(tmp_path, n=1000, dt=0.001)
    trial = read_trial(path, protocol_from_dict({"signals": {"sample_period": 0.005}}))
    assert trial.sample_period == pytest.approx(0.005)
    assert any("resampled from 1000 Hz to 200 Hz" in w and "low-pass" in w for w in trial.warnings)
    t, a, _ = signals(n=1000, dt=0.001)
    np.testing.assert_allclose(trial.angle, np.interp(trial.time, t, a), atol=2e-3)
    trial = read_trial(path, protocol_from_dict({"signals": {"sample_period": 0.0015}}))
    assert trial.sample_period == pytest.approx(0.0015) and "low-pass" not in trial.warnings[0]


# ---------------------------------------------------------------- bad files

def test_file_not_found(tmp_path):
    expect_error(tmp_path / "missing.csv", "file not found")


def test_directory(tmp_path):
    (tmp_path / "folder.csv").mkdir()
    expect_error(tmp_path / "folder.csv", "is a directory")


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0, reason="root reads anything")
def test_unreadable(tmp_path):
    path = standard(tmp_path, name="locked.csv")
    path.chmod(0)
    expect_error(path, "cannot read file")


def test_not_utf8(tmp_path):
    # a Windows export: read as Windows-1252 with a warning, never refused
    path = tmp_path / "latin.csv"
    t, a, tau = signals()
    rows = "\n".join(f"{x},{y},{z}" for x, y, z in zip(t, a, tau))
    path.write_bytes(("# subject: Jos\xe9\ntime_s,angle_rad,torque_Nm\n" + rows + "\n").encode("latin-1"))
    trial = read_trial(path)
    assert trial.metadata["subject"] == "José"
    assert "not UTF-8 text (byte 0xe9 at line 1): read as Windows-1252" in trial.warnings[0]


@pytest.mark.parametrize("content, phrase", [
    ("", "empty file"),
    ("\n  \n", "empty file"),
    ("# subject: S01\n# side: left\n", "no header row"),
    ("time_s,angle_rad,torque_Nm\n", "no data rows below the header"),
    ("time_s,time_s,angle_rad,torque_Nm\n0,0,0,0\n", "duplicated column header 'time_s' (columns 1 and 2)"),
    ("time_s angle_rad torque_Nm\n0 0 0\n", "separate the fields with commas, tabs or semicolons"),
])
def test_bad_structure(tmp_path, content, phrase):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    expect_error(path, phrase)


@pytest.mark.parametrize("header, phrase", [
    ("t,angle_rad,torque_Nm", "no time column (expected time_s, time_ms or 'Time (s)'; headers found: t, angle_rad"),
    ("time_s,theta,torque_Nm", "no angle or position column"),
    ("time_s,angle_rad,tau", "no torque or force column"),
    ("time_s,angle_grad,torque_Nm", "column 'angle_grad': unknown unit 'grad' for angle (accepted: rad, deg"),
    ("time_min,angle_rad,torque_Nm", "unknown unit 'min' for time (accepted: s, ms"),
    ("time_s,angle_rad,torque_N", "unit 'N' is not a unit of torque (accepted: Nm"),
    ("time_s,angle_rad,force_N", "mixes rotational and translational columns ('angle_rad' and 'force_N')"),
    ("time_s,angle_rad,position_m,torque_Nm", "mixes rotational and translational columns"),
    ("time_s,angle_rad,angle_deg,torque_Nm", "more than one angle/position column ('angle_rad' and 'angle_deg')"),
])
def test_bad_columns(tmp_path, header, phrase):
    t, a, tau = signals()
    width = header.count(",") + 1
    expect_error(write_csv(tmp_path / "cols.csv", header, [t, a, tau, tau][:width]), phrase)


@pytest.mark.parametrize("line, phrase", [
    ("0.020,abc,1.0", "non-numeric value 'abc' in column 'angle_rad' at line 7 (t = 0.02 s)"),
    ("0.020,0.1,nan", "NaN in column 'torque_Nm' at line 7 (t = 0.02 s)"),
    ("0.020,0.1,", "empty cell in column 'torque_Nm' at line 7"),
    ("0.020,0.1", "empty cell in column 'torque_Nm' at line 7"),
    (",0.1,1.0", "empty cell in column 'time_s' at line 7"),
    ("0.020,inf,1.0", "infinite value 'inf' in column 'angle_rad' at line 7"),
    ("0.020,0.1,1.0,4", "line 7 has 4 fields, the header has 3"),
    ("0.010,0.1,1.0", "time does not increase at line 7 (t = 0.01 s after 0.015 s)"),
    ("0.015,0.1,1.0", "time does not increase at line 7 (t = 0.015 s after 0.015 s)"),
])
def test_bad_cells(tmp_path, line, phrase):
    path = write_csv(tmp_path / "cells.csv", "time_s,angle_rad,torque_Nm", signals(),
                     meta=["# subject: S01"])
    edit_line(path, 7, line)  # line 1 metadata, line 2 header, line 7 is t = 0.020 s
    expect_error(path, phrase)


def test_bad_cell_in_unused_column_is_ignored(tmp_path):
    t, a, tau = signals()
    path = write_csv(tmp_path / "extra.csv", "time_s,angle_rad,torque_Nm,note", [t, a, tau, t])
    edit_line(path, 5, path.read_text().split("\n")[4].rsplit(",", 1)[0] + ",text")
    assert read_trial(path).n_samples == t.size


def test_gap(tmp_path):
    t, a, tau = signals()
    t = np.where(t > 0.5, t + 0.25, t)
    # longer than a quarter of the motion's period (0.156 s here): refused, naming the setting
    expect_error(write_csv(tmp_path / "gap.csv", "time_s,angle_rad,torque_Nm", [t, a, tau]),
                 "gap in time at line 103: 0.255 s without samples after t = 0.5 s, longer than the longest "
                 "bridged gap max_gap_s = 0.156 s (from the data: a quarter of the motion's period); set "
                 "[format] max_gap_s in a protocol")
    # bridged when the protocol allows it, and marked as not data
    trial = read_trial(tmp_path / "gap.csv", protocol_from_dict({"format": {"max_gap_s": 0.3}}))
    assert abs(trial.bridged.sum() - 0.255 / 0.005) <= 1 and "1 gap(s) in time bridged" in trial.warnings[0]


@pytest.mark.parametrize("n, dt, phrase", [
    (MIN_SAMPLES - 1, 0.01, f"trial too short: {MIN_SAMPLES - 1} samples (at least {MIN_SAMPLES} needed)"),
    (100, 0.001, "trial too short: 0.099 s (at least 0.5 s needed)"),
])
def test_too_short(tmp_path, n, dt, phrase):
    expect_error(standard(tmp_path, name="short.csv", n=n, dt=dt), phrase)


def test_no_motion(tmp_path):
    t, _, tau = signals()
    expect_error(write_csv(tmp_path / "still.csv", "time_s,angle_rad,torque_Nm", [t, np.full(t.size, 0.2), tau]),
                 "no motion: angle is constant")
    two = np.where(t > 0.3, 0.1, 0.0)
    expect_error(write_csv(tmp_path / "two.csv", "time_s,position_m,force_N", [t, two, tau]),
                 "no motion: position takes only 2 distinct values")


def test_protocol_errors(tmp_path):
    path = standard(tmp_path, name="proto.csv")
    missing = protocol_from_dict({"columns": {"torque": {"header": "Torque (Nm)"}}})
    expect_error(path, "column 'Torque (Nm)' given by the protocol for torque/force is not in the file "
                       "(headers found: time_s, angle_rad, torque_Nm)", missing)
    path = write_csv(tmp_path / "nounit.csv", "time_s,pos1,torque_Nm", signals())
    expect_error(path, "column 'pos1' (angle/position) has no unit in its name",
                 protocol_from_dict({"columns": {"angle": {"header": "pos1"}}}))
    expect_error(path, "column 'pos1': unit 'N' is not a unit of angle/position (accepted: rad, deg",
                 protocol_from_dict({"columns": {"angle": {"header": "pos1", "unit": "N"}}}))
    with pytest.raises(ProtocolError, match="unknown unit 'furlong' for angle"):   # caught at load
        protocol_from_dict({"columns": {"angle": {"header": "pos1", "unit": "furlong"}}})
    expect_error(path, "mixes rotational and translational columns",
                 protocol_from_dict({"columns": {"angle": {"header": "pos1", "unit": "mm"}}}))
    expect_error(path, "column 'torque_Nm' is given by the protocol for both torque/force and elastic",
                 protocol_from_dict({"columns": {"angle": {"header": "pos1", "unit": "rad"},
                                                 "torque": {"header": "torque_Nm"},
                                                 "elastic_torque": {"header": "torque_Nm"}}}))


# ---------------------------------------------------------------- writing

@pytest.mark.parametrize("kind", ["rotational", "translational"])
def test_write_round_trip(tmp_path, kind):
    rng = np.random.default_rng(3)
    n = 800
    time = 12.3 + np.arange(n) / 1234.5
    trial = Trial(name="x", time=time, angle=rng.standard_normal(n) * 1e-3,
                  torque=rng.standard_normal(n) * 1e4, elastic_torque=rng.standard_normal(n),
                  stiffness_true=np.full(n, 1 / 3), kind=kind,
                  metadata={"subject": "S01", "note": "two\nlines"})
    path = write_trial(trial, tmp_path / "out" / "x.csv")
    back = read_trial(path)
    assert back.kind == kind and back.metadata == {"subject": "S01", "note": "two lines"}
    for field in ("time", "angle", "torque", "elastic_torque", "stiffness_true"):
        np.testing.assert_allclose(getattr(back, field), getattr(trial, field), rtol=1e-9, atol=0)
    header = path.read_text().split("\n")[2]
    assert header == ("time_s,angle_rad,torque_Nm,elastic_torque_Nm,stiffness_true_Nm_per_rad"
                      if kind == "rotational" else
                      "time_s,position_m,force_N,elastic_force_N,stiffness_true_N_per_m")


def test_write_minimal(tmp_path):
    t, a, tau = signals()
    path = write_trial(Trial(name="m", time=t, angle=a, torque=tau), tmp_path / "m.csv")
    assert path.read_text().startswith("time_s,angle_rad,torque_Nm\n")
    np.testing.assert_array_equal(read_trial(path).torque, tau)


# ---------------------------------------------------------------- atomic writes

def test_atomic_write_creates_and_replaces(tmp_path):
    path = tmp_path / "a" / "b" / "out.txt"
    atomic_write_text(path, "first\n")
    atomic_write_bytes(path, b"second\n")
    assert path.read_bytes() == b"second\n"
    assert sha256_file(path) == hashlib.sha256(b"second\n").hexdigest()
    assert sorted(p.name for p in path.parent.iterdir()) == ["out.txt"]
    assert path.stat().st_mode & 0o777 == 0o666 & ~atomic_module._UMASK  # not mkstemp's 0600


def test_atomic_write_failure_keeps_old_file(tmp_path):
    path = tmp_path / "keep.txt"
    atomic_write_text(path, "old")
    with pytest.raises(TypeError):
        atomic_write_bytes(path, None)
    with pytest.raises(RuntimeError):
        with atomic_output(path) as tmp:
            tmp.write_text("half")
            raise RuntimeError("disk full")
    with pytest.raises(UnicodeEncodeError):
        atomic_write_text(path, "\udc80")
    assert path.read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["keep.txt"]
