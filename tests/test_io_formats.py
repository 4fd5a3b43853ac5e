"""Trial formats besides comma-separated CSV: MATLAB .mat, tab/semicolon text with a unit row.

The same numbers written in every format must read into the same arrays; every bad file is a
one-line TrialError naming the file.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
import scipy.io as sio
from click.testing import CliRunner

from limbstiff.errors import ProtocolError, TrialError
from limbstiff.files import read_trial, write_trial
from limbstiff.files.mat import V73
from limbstiff.protocol import load_protocol, protocol_from_dict

from .conftest import multisine_trial

N, DT = 400, 0.005


def signals():
    """Time (s), angle (rad), torque (N·m) of a smooth 2 s test trial."""
    t = np.arange(N) * DT
    return t, 0.1 * np.sin(2 * np.pi * 1.5 * t), 2.0 * np.sin(2 * np.pi * 1.5 * t + 0.3)


def text_rows(columns, sep, decimal="."):
    rows = (sep.join(repr(float(v)) for v in row) for row in zip(*columns))
    if decimal == ",":
        rows = (row.replace(".", ",") for row in rows)
    return "\n".join(rows) + "\n"


def expect_error(path, phrase, protocol=None):
    with pytest.raises(TrialError) as info:
        read_trial(path, protocol)
    message = str(info.value)
    assert Path(path).name in message and phrase in message, message
    assert "\n" not in message
    return message


def proto(**columns):
    return protocol_from_dict({"columns": columns})


# ---------------------------------------------------------------- same numbers, every format

def test_same_trial_in_every_format(tmp_path):
    t, a, tau = signals()
    csv = tmp_path / "t.csv"
    csv.write_text("# subject: S01\ntime_s,angle_rad,torque_Nm\n" + text_rows([t, a, tau], ","))
    mat = tmp_path / "t.mat"
    sio.savemat(mat, {"time_s": t, "angle_rad": a, "torque_Nm": tau, "subject": "S01"})
    tsv = tmp_path / "t.tsv"   # plain headers, a unit row, angle in degrees, time in ms
    tsv.write_text("# subject: S01\ntime\tangle\ttorque\nms\tdeg\tNm\n"
                   + text_rows([t * 1e3, np.degrees(a), tau], "\t"))
    semi = tmp_path / "t.txt"  # semicolons and decimal commas
    semi.write_text("# subject: S01\ntime_s;angle_rad;torque_Nm\n" + text_rows([t, a, tau], ";", ","))
    trials = [read_trial(p) for p in (csv, mat, tsv, semi)]
    reference = trials[0]
    np.testing.assert_array_equal(reference.angle, a)
    for trial in trials[1:]:
        # same numbers, only the format (and for the TSV the units) differ
        for field in ("time", "angle", "torque"):
            np.testing.assert_allclose(getattr(trial, field), getattr(reference, field), rtol=1e-12, atol=1e-15)
        assert trial.metadata == {"subject": "S01"} and trial.warnings == ()
        assert trial.kind == "rotational" and trial.n_samples == N
    for path, trial in zip((csv, mat, tsv, semi), trials):
        assert trial.name == "t" and trial.source == str(path)
        assert trial.source_sha256 == hashlib.sha256(path.read_bytes()).hexdigest()


# ---------------------------------------------------------------- MAT

def test_mat_standard_names_metadata_and_ignored(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "s01.mat"
    sio.savemat(path, {"time_ms": (t * 1e3)[:, None], "angle_deg": np.degrees(a)[None, :], "torque_Nmm": tau * 1e3,
                       "subject": "S01", "side": "left\nelbow", "age": 31, "gain": 0.25, "emg": np.ones((N, 2)),
                       "note": "x" * 500})
    trial = read_trial(path)
    np.testing.assert_allclose(trial.time, t, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(trial.angle, a, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(trial.torque, tau, rtol=1e-12)
    assert trial.metadata["subject"] == "S01" and trial.metadata["side"] == "left elbow"
    assert trial.metadata["age"] == "31" and trial.metadata["gain"] == "0.25"
    assert len(trial.metadata["note"]) == 200 and trial.metadata["note"].endswith("…")
    assert trial.warnings == ("ignored variable(s): 'emg'",)


def test_mat_v4_file(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "old.mat"
    sio.savemat(path, {"time_s": t, "angle_rad": a, "torque_Nm": tau}, format="4")
    np.testing.assert_array_equal(read_trial(path).torque, tau)


def test_mat_struct_fields_and_matrix_columns(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "lab.mat"
    sio.savemat(path, {"rec": {"t": t, "sensors": {"pos": np.degrees(a), "tq_Nm": tau}},
                       "M": np.c_[t, a, tau], "Mt": np.c_[t, a, tau].T})
    structs = proto(time={"header": "rec.t", "unit": "s"}, angle={"header": "rec.sensors.pos", "unit": "deg"},
                    torque={"header": "rec.sensors.tq_Nm", "scale": -1.0})   # unit from the name
    trial = read_trial(path, structs)
    np.testing.assert_allclose(trial.angle, a, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(trial.torque, -tau)
    assert trial.warnings == ("ignored variable(s): 'M', 'Mt'",)
    zero_based = proto(time={"header": "M[:, 0]", "unit": "s"}, angle={"header": "M[:, 1]", "unit": "rad"},
                       torque={"header": "M[:,2]", "unit": "Nm"})
    one_based = proto(time={"header": "M(:, 1)", "unit": "s"}, angle={"header": "M(:, 2)", "unit": "rad"},
                      torque={"header": "M(:, 3)", "unit": "Nm"})
    rows = proto(time={"header": "Mt[0, :]", "unit": "s"}, angle={"header": "Mt(2, :)", "unit": "rad"},
                 torque={"header": "Mt[2, :]", "unit": "Nm"})
    for protocol, ignored in ((zero_based, "'rec', 'Mt'"), (one_based, "'rec', 'Mt'"), (rows, "'rec', 'M'")):
        trial = read_trial(path, protocol)
        np.testing.assert_array_equal(trial.time, t)
        np.testing.assert_array_equal(trial.angle, a)
        np.testing.assert_array_equal(trial.torque, tau)
        assert trial.warnings == (f"ignored variable(s): {ignored}",)


def test_mat_time_from_sample_rate(tmp_path):
    _, a, tau = signals()
    path = tmp_path / "fs.mat"
    sio.savemat(path, {"angle_rad": a, "torque_Nm": tau, "Fs": 200.0, "subject": "S02"})
    trial = read_trial(path)
    np.testing.assert_allclose(trial.time, np.arange(N) / 200.0, rtol=0, atol=1e-12)
    assert trial.fs == pytest.approx(200.0) and dict(trial.metadata) == {"subject": "S02"}
    by_protocol = protocol_from_dict({"format": {"sample_rate_hz": 200}})
    assert read_trial(path, by_protocol).fs == pytest.approx(200.0)        # agreeing: fine
    expect_error(path, "the file's Fs = 200 Hz and the protocol's sample_rate_hz = 500 Hz disagree",
                 protocol_from_dict({"format": {"sample_rate_hz": 500}}))
    bare = tmp_path / "bare.mat"
    sio.savemat(bare, {"angle_rad": a, "torque_Nm": tau})
    expect_error(bare, "no time variable (expected time_s or time_ms) and no sample rate")
    trial = read_trial(bare, protocol_from_dict({"format": {"sample_rate_hz": 250.0}}))
    assert trial.fs == pytest.approx(250.0) and trial.duration == pytest.approx((N - 1) / 250.0)
    sio.savemat(bare, {"angle_rad": a, "torque_Nm": tau, "fs": -1.0})
    expect_error(bare, "variable 'fs' should be the sample rate in Hz")


def test_mat_v73_is_refused(tmp_path):
    v73 = tmp_path / "new.mat"   # MATLAB's 512-byte text header, then the HDF5 superblock
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Jan  1 00:00:00 2024 HDF5 schema 1.00 ."
    v73.write_bytes(header.ljust(512, b" ") + b"\x89HDF\r\n\x1a\n" + bytes(200))
    assert expect_error(v73, V73) == f"{v73}: MATLAB v7.3 (HDF5) files are not supported: save with -v7, or export CSV"
    plain = tmp_path / "plain.mat"   # an HDF5 file without MATLAB's header
    plain.write_bytes(bytes(512) + b"\x89HDF\r\n\x1a\n" + bytes(100))
    expect_error(plain, V73)


def test_mat_corrupt_files(tmp_path):
    t, a, tau = signals()
    good = tmp_path / "good.mat"
    sio.savemat(good, {"time_s": t, "angle_rad": a, "torque_Nm": tau})
    cut = tmp_path / "cut.mat"
    cut.write_bytes(good.read_bytes()[:300])
    expect_error(cut, "not a readable MATLAB file")
    junk = tmp_path / "junk.mat"
    junk.write_text("time_s,angle_rad,torque_Nm\n0,0,0\n" * 20)
    expect_error(junk, "not a readable MATLAB file")
    empty = tmp_path / "empty.mat"
    empty.write_bytes(b"")
    expect_error(empty, "empty file")


def test_mat_bad_variables(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "bad.mat"
    angle_nan = a.copy()
    angle_nan[16] = np.nan
    sio.savemat(path, {"time_s": t, "angle_rad": a, "torque_Nm": tau, "M": np.c_[a, tau], "rec": {"tq": tau},
                       "short": tau[:-1], "name": "S01", "z": tau + 1j, "nan_angle": angle_nan})
    torque = {"header": "M[:, 1]", "unit": "Nm"}
    cases = [
        (proto(torque={"header": "rec.force", "unit": "Nm"}), "struct 'rec' has no field 'force' (fields: tq)"),
        (proto(torque={"header": "tq", "unit": "Nm"}), "no variable 'tq' (given by the protocol as 'tq'; variables:"),
        (proto(torque={"header": "M", "unit": "Nm"}), "variable 'M' is a 400×2 matrix; name one column"),
        (proto(torque={"header": "M[:, 2]", "unit": "Nm"}), "variable 'M' is 400×2, it has no column 2 (0-based)"),
        (proto(torque={"header": "M(:, 0)", "unit": "Nm"}), "it has no column 0 (1-based)"),
        (proto(torque={"header": "M[:, 1)", "unit": "Nm"}), "is not a variable path"),
        (proto(torque={"header": "rec", "unit": "Nm"}), "variable 'rec' is a struct (fields: tq)"),
        (proto(torque={"header": "name", "unit": "Nm"}), "variable 'name' is text, not numbers"),
        (proto(torque={"header": "z", "unit": "Nm"}), "variable 'z' has complex values"),
        (proto(torque={"header": "short", "unit": "Nm"}), "variable 'short' has 399 samples, 'time_s' has 400"),
        (proto(torque={"header": "M[:, 1]"}), "variable 'M[:, 1]' (torque/force) has no unit in its name"),
        (proto(torque=torque, angle={"header": "nan_angle", "unit": "rad"}),
         "NaN in variable 'nan_angle' at sample 17 (t = 0.08 s)"),
    ]
    for protocol, phrase in cases:
        expect_error(path, phrase, protocol)
    sio.savemat(path, {"time_s": t, "angle_rad": a})
    expect_error(path, "no torque or force variable (expected torque_Nm, force_N, elastic_torque_Nm, "
                       "elastic_force_N or 'Torque (Nm)'; variables found: time_s, angle_rad)")
    sio.savemat(path, {"time_s": t, "angle_rad": a, "torque_Nm": 3.0})
    expect_error(path, "variable 'torque_Nm' is a single number, not a recording")


def test_mat_goes_through_the_common_checks(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "checks.mat"
    gap = np.where(t > 1.0, t + 0.5, t)
    sio.savemat(path, {"time_s": gap, "angle_rad": a, "torque_Nm": tau})
    expect_error(path, "gap in time at sample 202: 0.505 s without samples after t = 1 s")
    sio.savemat(path, {"time_s": t, "angle_rad": np.full(N, 0.2), "torque_Nm": tau})
    expect_error(path, "no motion: angle is constant")
    sio.savemat(path, {"time_s": t[:50], "angle_rad": a[:50], "torque_Nm": tau[:50]})
    expect_error(path, "trial too short: 50 samples")
    sio.savemat(path, {"time_s": t, "angle_rad": a, "torque_Nm": tau})
    trial = read_trial(path, protocol_from_dict({"signals": {"sample_period": 0.01}}))
    assert trial.sample_period == pytest.approx(0.01) and "resampled from 200 Hz to 100 Hz" in trial.warnings[0]


# ---------------------------------------------------------------- tab / semicolon text

def test_tsv_unit_row_in_degrees(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "deg.tsv"
    path.write_text("# subject: S03\ntime\tAngle\ttorque\tnote\n[s]\t[deg]\t(Nm)\t-\n"
                    + "".join(f"{x!r}\t{np.degrees(y).item()!r}\t{z!r}\tok\n"
                              for x, y, z in zip(t.tolist(), a.tolist(), tau.tolist())))
    trial = read_trial(path)
    # the file holds degrees (peak 5.73); the trial holds radians (peak 0.1)
    assert np.abs(np.degrees(a)).max() > 5.7 and np.abs(trial.angle).max() < 0.1 + 1e-12
    np.testing.assert_allclose(trial.angle, a, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(trial.time, t)
    np.testing.assert_array_equal(trial.torque, tau)
    assert trial.metadata == {"subject": "S03"} and trial.warnings == ("ignored column(s): 'note'",)
    # line numbers count the unit row: line 3 is the unit row, line 4 the first sample
    lines = path.read_text().split("\n")
    lines[4] = "0.005\tabc\t1.0\tok"
    path.write_text("\n".join(lines))
    expect_error(path, "non-numeric value 'abc' in column 'Angle' at line 5 (t = 0.005 s)")


def test_unit_row_with_protocol_headers(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "lab.txt"
    path.write_text("Zeit;Winkel;Moment\ns;deg;N·m\n" + text_rows([t, np.degrees(a), tau], ";", ","))
    mapping = dict(time={"header": "Zeit"}, angle={"header": "Winkel"}, torque={"header": "Moment", "scale": -1.0})
    trial = read_trial(path, proto(**mapping))
    np.testing.assert_allclose(trial.angle, a, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(trial.torque, -tau, rtol=1e-12)
    agreeing = {**mapping, "angle": {"header": "Winkel", "unit": "degree"}}   # same unit, other spelling
    np.testing.assert_array_equal(read_trial(path, proto(**agreeing)).angle, trial.angle)
    expect_error(path, "column 'Winkel': the protocol says unit 'rad', the unit row says 'deg'",
                 proto(**{**mapping, "angle": {"header": "Winkel", "unit": "rad"}}))
    expect_error(path, "no time column", None)   # plain non-standard headers need the protocol


def test_unit_row_disagreements(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "dis.tsv"
    path.write_text("time_s\tangle_rad\ttorque_Nm\ns\tdeg\tNm\n" + text_rows([t, a, tau], "\t"))
    expect_error(path, "column 'angle_rad': its name says unit 'rad', the unit row says 'deg'")
    path.write_text("time\tangle\ttorque\ns\tdeg\tNm\n" + text_rows([t, a, tau], "\t"))
    expect_error(path, "column 'angle': the protocol says unit 'rad', the unit row says 'deg'",
                 proto(angle={"unit": "rad"}))
    path.write_text("time\tangle\ttorque\ns\tgrad\tNm\n" + text_rows([t, a, tau], "\t"))
    expect_error(path, "column 'angle': unknown unit 'grad' for angle (accepted: rad, deg")


def test_semicolon_decimal_comma(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "comma.csv"
    path.write_text("# Versuch: 3\ntime_ms;angle_rad;torque_Nm\n" + text_rows([t * 1e3, a, tau], ";", ","))
    assert "0,1" in path.read_text()
    trial = read_trial(path)
    np.testing.assert_allclose(trial.time, t, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(trial.angle, a)
    np.testing.assert_array_equal(trial.torque, tau)
    assert trial.metadata == {"Versuch": "3"}
    lines = path.read_text().split("\n")
    lines[5] = "15,0;1.5;2,0"     # line 6: t = 15 ms, a decimal point among decimal commas
    path.write_text("\n".join(lines))
    expect_error(path, "non-numeric value '1.5' in column 'angle_rad' at line 6 (t = 0.015 s) "
                       "(the file uses decimal commas)")


def test_semicolon_with_decimal_points_and_integers(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "points.csv"
    path.write_text("time_s;angle_rad;torque_Nm\n" + text_rows([t, a, tau], ";"))
    np.testing.assert_array_equal(read_trial(path).angle, a)


def test_format_section(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "forced.txt"
    path.write_text("time\tangle\ttorque\ns\trad\tNm\n" + text_rows([t, a, tau], "\t", ","))
    # a decimal comma in a tab-separated file is detected as in a semicolon one, or set
    np.testing.assert_array_equal(read_trial(path).angle, a)
    trial = read_trial(path, protocol_from_dict({"format": {"delimiter": "tab", "decimal": ","}}))
    np.testing.assert_array_equal(trial.angle, a)
    expect_error(path, "non-numeric value '0,0' in column 'time' at line 3 (a decimal comma? set decimal",
                 protocol_from_dict({"format": {"decimal": "."}}))
    expect_error(path, "no time column", protocol_from_dict({"format": {"unit_row": False, "decimal": ","}}))
    semi = tmp_path / "semi.csv"
    semi.write_text("time_s;angle_rad;torque_Nm\n" + text_rows([t, a, tau], ";"))
    expect_error(semi, "not separated by ',' as the protocol says (it uses ';')",
                 protocol_from_dict({"format": {"delimiter": ","}}))
    expect_error(semi, "line 2 should be the unit row (the protocol says unit_row = true) but holds the number",
                 protocol_from_dict({"format": {"unit_row": True}}))
    toml = tmp_path / "p.toml"
    toml.write_text('[format]\ndelimiter = "\\t"\ndecimal = ","\nunit_row = "auto"\nsample_rate_hz = 100\n')
    p = load_protocol(toml)
    assert (p.delimiter, p.decimal, p.unit_row, p.sample_rate_hz) == ("\t", ",", "auto", 100)
    assert p.to_dict()["delimiter"] == "\t" and p.to_dict()["sample_rate_hz"] == 100
    for bad, phrase in [({"separator": ";"}, "unknown key(s) in [format]: separator"),
                        ({"delimiter": "|"}, "'delimiter' in [format] must be one of"),
                        ({"unit_row": "yes"}, "'unit_row' in [format] must be true, false or"),
                        ({"delimiter": ",", "decimal": ","}, "cannot both be ','"),
                        ({"sample_rate_hz": 0}, "'sample_rate_hz' must be a positive number")]:
        with pytest.raises(ProtocolError) as info:
            protocol_from_dict({"format": bad})
        assert phrase in str(info.value), str(info.value)


# ---------------------------------------------------------------- dispatch

def test_unknown_extension_and_case(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "trial.xlsb"
    path.write_bytes(b"PK\x03\x04")
    expect_error(path, "unknown file type '.xlsb' (accepted: .csv, .tsv, .txt, .mat, .c3d, .xlsx)")
    expect_error(tmp_path / "noext", "unknown file type '(no extension)'")
    upper = tmp_path / "UP.MAT"
    sio.savemat(upper, {"time_s": t, "angle_rad": a, "torque_Nm": tau})
    np.testing.assert_array_equal(read_trial(upper).angle, a)
    expect_error(tmp_path / "missing.mat", "file not found")


# ---------------------------------------------------------------- through the command line

def test_cli_analyze_mat_file(tmp_path):
    from limbstiff.cli import main

    trial = multisine_trial("arm", duration=4.0)
    path = tmp_path / "arm.mat"
    sio.savemat(path, {"time_s": trial.time, "angle_deg": np.degrees(trial.angle), "torque_Nm": trial.torque,
                       "subject": "S01"})
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["analyze", str(path), "--no-pdf", "--out", str(out), "--jobs", "1",
                                    "--inertia", "0.06", "--damping", "0.45"])   # m, b fixed: no MCMC, about 1 s
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "arm" / "summary.json").read_text())
    assert summary["trial"] == "arm" and summary["n_samples"] == trial.n_samples
    assert summary["source_sha256"] == hashlib.sha256(path.read_bytes()).hexdigest()
    assert summary["metadata"] == {"subject": "S01"} and summary["fs_hz"] == pytest.approx(500.0)
    # exact torque, m and b fixed at their true values: the median of the true 10→20 N·m/rad ramp
    assert summary["stiffness"]["median"] == pytest.approx(15.0, rel=0.02)
    write_trial(trial, tmp_path / "arm.csv")   # the same trial as CSV reads into the same arrays
    np.testing.assert_allclose(read_trial(path).angle, read_trial(tmp_path / "arm.csv").angle, rtol=1e-12, atol=1e-18)


def test_rows_read_straight_from_the_bytes_match_the_line_by_line_path(tmp_path):
    # Files whose rows are all non-blank are parsed from the file's bytes (no list of lines:
    # a one-hour trial would need ~2 GB that way); blank lines send the file down the
    # line-by-line path. Both must give the same numbers, metadata and line numbers.
    rows = "".join(f"{k / 100},{np.sin(k / 10):.6f},{np.cos(k / 7):.6f}\n" for k in range(300))
    base = "\ufeff# subject: S1\n\ntime_s,angle_rad,torque_Nm\n" + rows
    fast, slow = tmp_path / "fast.csv", tmp_path / "slow.csv"
    fast.write_bytes(base.replace("\n", "\r\n").encode("utf-8"))
    slow.write_bytes(base.replace("\n0.5,", "\n\n0.5,").encode("utf-8"))
    a, b = read_trial(fast), read_trial(slow)
    np.testing.assert_array_equal(a.angle, b.angle)
    np.testing.assert_array_equal(a.torque, b.torque)
    assert a.metadata == b.metadata == {"subject": "S1"}
    lines = base.split("\n")
    lines[153] = "1.5,abc,0.6"                       # line 154 of the file
    fast.write_text("\n".join(lines), encoding="utf-8")
    with pytest.raises(TrialError, match="'abc' in column 'angle_rad' at line 154"):
        read_trial(fast)


# ---------------------------------------------------------------- files that are not text (issue 35)

def _printable_line(message: str) -> bool:
    """One line of printable text: no control character (C0, DEL, C1) anywhere."""
    return all(ch.isprintable() for ch in message)


PNG = (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR\x00\x00\x00\x01\x00\x00\x00\x01\x08\x06\x00\x00\x00\x1f\x15\xc4\x89"
       b"\x00\x00\x00\rIDATx\x9cc\xf8\x0f\x00\x00\x01\x01\x00\x05\x18\xd8N\x00\x00\x00\x00IEND\xaeB`\x82")


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_random_bytes_named_csv_are_not_a_text_file(tmp_path, seed):
    raw = np.random.default_rng(seed).integers(0, 256, 4096, dtype=np.uint8).tobytes()
    path = tmp_path / "trial.csv"
    path.write_bytes(raw)
    message = expect_error(path, "not a text file (it holds binary data): export the trial as CSV")
    assert _printable_line(message)
    assert message.startswith(f"{path}: ")          # the file's name, then only limbstiff's words
    # with the protocol's encoding (no binary sniffing of the bytes): still refused, nothing copied
    message = expect_error(path, "not a text file", protocol_from_dict({"format": {"encoding": "latin-1"}}))
    assert _printable_line(message)


def test_a_png_named_txt_is_not_a_text_file(tmp_path):
    path = tmp_path / "figure.txt"
    path.write_bytes(PNG)
    message = expect_error(path, "not a text file (it looks like a PNG image)")
    assert _printable_line(message) and "IHDR" not in message
    workbook = tmp_path / "book.csv"                # an .xlsx saved under the wrong name
    workbook.write_bytes(b"PK\x03\x04" + bytes(range(256)))
    expect_error(workbook, "not a text file (it looks like a ZIP archive, or an .xlsx workbook)")


def test_control_characters_deep_in_a_text_file_are_not_copied(tmp_path):
    t, a, tau = signals()
    lines = ("time_s,angle_rad,torque_Nm\n" + text_rows([t, a, tau], ",")).split("\n")
    lines[300] = "1.495,\x07\x1b[31mred\x00,0.1"         # past the sniffed start: a bell, an escape, a NUL
    path = tmp_path / "t.csv"
    path.write_text("#" * 70000 + "\n" + "\n".join(lines), encoding="utf-8")   # past the sniffed characters
    message = expect_error(path, "non-numeric value")
    assert _printable_line(message) and "\\x07\\x1b[31mred\\x00" in message


def test_utf16_text_as_excel_saves_unicode_text(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "unicode.txt"
    path.write_bytes(("Zeit (s)\tWinkel (°)\tMoment (Nm)\n" + text_rows([t, np.degrees(a), tau], "\t"))
                     .encode("utf-16"))
    mapping = dict(time={"header": "Zeit"}, angle={"header": "Winkel"}, torque={"header": "Moment"})
    read = read_trial(path, proto(**mapping))
    np.testing.assert_allclose(read.angle, a, rtol=1e-12, atol=1e-15)
    # without its byte-order mark: said so, with the setting that reads it
    path.write_bytes(path.read_bytes()[2:])
    expect_error(path, 'it looks like UTF-16 without a byte-order mark; set [format] encoding = "utf-16-le"',
                 proto(**mapping))
    given = protocol_from_dict({"columns": mapping, "format": {"encoding": "utf-16-le"}})
    np.testing.assert_array_equal(read_trial(path, given).angle, read.angle)


def test_a_binary_file_fails_its_trial_like_any_unreadable_one(tmp_path):
    from limbstiff.cli import main

    binary = tmp_path / "binary" / "trial.csv"
    binary.parent.mkdir()
    binary.write_bytes(np.random.default_rng(7).integers(0, 256, 2048, dtype=np.uint8).tobytes())
    unreadable = tmp_path / "unreadable" / "trial.csv"
    unreadable.parent.mkdir()
    unreadable.write_text("a,b,c\n1,2,3\n")
    codes = {}
    for path in (binary, unreadable):
        res = CliRunner().invoke(main, ["analyze", str(path), "--no-pdf", "--jobs", "1",
                                        "--out", str(path.parent / "out")])
        codes[path.parent.name] = res.exit_code
        assert _printable_line(res.output.replace("\n", "")), res.output
    assert codes["binary"] == codes["unreadable"] == 1
    assert "not a text file" in res_output(binary.parent / "out")


def res_output(out: Path) -> str:
    """The error column of a batch's summary.csv."""
    return (out / "summary.csv").read_text(encoding="utf-8")


def test_a_mat_variable_is_found_by_its_name_without_the_unit(tmp_path):
    t, a, tau = signals()
    path = tmp_path / "lab.mat"
    sio.savemat(path, {"Zeit_ms": t * 1e3, "Winkel_deg": np.degrees(a), "Moment_Nm": tau})
    mapping = dict(time={"header": "Zeit"}, angle={"header": "Winkel"}, torque={"header": "Moment", "scale": -1.0})
    read = read_trial(path, proto(**mapping))
    np.testing.assert_allclose(read.time, t, atol=1e-12)
    np.testing.assert_allclose(read.angle, a, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(read.torque, -tau, rtol=1e-12)
    expect_error(path, "variable 'Zeit_ms': the protocol says unit 's', its name says 'ms'",
                 proto(**{**mapping, "time": {"header": "Zeit", "unit": "s"}}))
