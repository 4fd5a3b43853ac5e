"""Files as labs write them (issue 15): logger files with gaps, Windows exports, unmapped columns."""

import re
import tomllib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import limbstiff
from limbstiff.errors import TrialError
from limbstiff.files import read_trial
from limbstiff.protocol import protocol_from_dict

from .conftest import multisine_trial

LOGGER = protocol_from_dict({"columns": {
    "time": {"header": "time", "unit": "s"}, "angle": {"header": "displacement", "unit": "deg"},
    "elastic_torque": {"header": "torque_out", "unit": "Nm"}}})


def logger_file(path, stiffness, *, seed=0, duration=35.0):
    """A series-elastic bench's CAN logger, as described in issue 15 (the real files are not ours
    to ship): a pandas index column, ``time`` in s at an irregular ~1.9 ms median step with ~500
    steps longer than 3× the median (the longest 0.05–0.18 s), a 0.2 s gap after the first
    sample, ``displacement`` in degrees on a 0.0008° grid, and an unmapped ``torque_in``. The
    spring is linear, so the bench's own linear fit of torque_out on displacement is its
    stiffness."""
    rng = np.random.default_rng(seed)
    n = int(duration / 1.9e-3)
    step = rng.gamma(20.0, 1.9e-3 / 20.0, n)
    long = rng.choice(np.arange(2, n), 500, replace=False)
    step[long] = rng.uniform(3.5, 12.0, 500) * 1.9e-3
    step[long[:6]] = rng.uniform(0.05, 0.18, 6)
    step[0] = 0.2
    t = np.cumsum(np.r_[0.0, step])
    t = t[t <= duration]
    deg = sum(0.8 * np.sin(2 * np.pi * f * t + rng.uniform(0, 6.3)) for f in (0.4, 0.7, 1.1, 1.7))
    deg = np.round(deg / 0.0008) * 0.0008
    torque_out = stiffness * np.deg2rad(deg) + rng.normal(0, 0.3, t.size)
    frame = pd.DataFrame({"time": t, "torque_in": 1.1 * torque_out + rng.normal(0, 0.3, t.size),
                          "torque_out": torque_out, "displacement": deg})
    frame.to_csv(path)
    return frame


@pytest.mark.parametrize("stiffness", [2050.0, 1692.0, 1298.0])
def test_a_gappy_logger_file_is_read_and_analysed(tmp_path, stiffness):
    # the bench's figures (issue 15): linear fits 2050 / 1692 / 1298 N·m/rad; the analysis must
    # come within 15 % of the file's own linear fit, and say how many gaps it bridged
    path = tmp_path / "bench.csv"
    frame = logger_file(path, stiffness)
    trial = read_trial(path, LOGGER)
    bridged = [w for w in trial.warnings if "gap(s) in time bridged" in w]
    assert len(bridged) == 1 and int(bridged[0].split()[0]) > 100
    assert any("ignored column(s): 'torque_in'" in w for w in trial.warnings)
    assert trial.bridged is not None and 0 < trial.bridged.mean() < 0.5
    result = limbstiff.analyze(trial, LOGGER, seed=0)
    assert not result.observable[trial.bridged].any()
    fit = np.polyfit(np.deg2rad(frame["displacement"]), frame["torque_out"], 1)[0]
    assert abs(np.median(result.stiffness[result.observable]) / fit - 1) < 0.15


def test_a_gap_longer_than_max_gap_is_refused_naming_the_setting(tmp_path):
    path = tmp_path / "bench.csv"
    logger_file(path, 1500.0)
    tight = protocol_from_dict({"columns": {q: {"header": c.header, "unit": c.unit} for q, c in LOGGER.columns.items()},
                                "format": {"max_gap_s": 0.02}})
    with pytest.raises(TrialError, match=r"bench\.csv: gap in time .*max_gap_s = 0\.02 s \(protocol\)"):
        read_trial(path, tight)


def test_an_isolated_first_sample_is_dropped(tmp_path):
    trial = multisine_trial(duration=6.0)
    t = np.r_[trial.time[0] - 0.3, trial.time]
    rows = zip(t, np.r_[0.0, trial.angle], np.r_[0.0, trial.torque])
    body = "\n".join(f"{a:.6f},{b:.9g},{c:.9g}" for a, b, c in rows)
    path = tmp_path / "t.csv"
    path.write_text("time_s,angle_rad,torque_Nm\n" + body + "\n")
    read = read_trial(path)
    assert read.n_samples == trial.n_samples and read.bridged is None
    assert any("1 isolated sample(s) dropped at the start" in w for w in read.warnings)
    np.testing.assert_allclose(read.angle, trial.angle, atol=1e-9)


@pytest.mark.slow
def test_a_windows_export_is_analysed_without_a_protocol(tmp_path):
    # cp1252 metadata, semicolons, decimal commas, CRLF, headers 'Time (s);Angle (deg);Torque (Nm)'
    trial = multisine_trial(duration=8.0)
    rows = [f"{t:.6f};{np.rad2deg(y):.9f};{f:.9f}".replace(".", ",")
            for t, y, f in zip(trial.time, trial.angle, trial.torque)]
    text = "# subject: Müller\r\nTime (s);Angle (deg);Torque (Nm)\r\n" + "\r\n".join(rows) + "\r\n"
    path = tmp_path / "export.csv"
    path.write_bytes(text.encode("cp1252"))
    read = read_trial(path)
    assert read.metadata["subject"] == "Müller"
    assert any("not UTF-8 text" in w and "Windows-1252" in w for w in read.warnings)
    np.testing.assert_allclose(read.angle, trial.angle, atol=1e-9)
    np.testing.assert_allclose(read.torque, trial.torque, atol=1e-8)
    result = limbstiff.analyze(read, seed=0)
    assert abs(np.median(result.stiffness[result.observable]) / np.median(trial.stiffness_true) - 1) < 0.1


def test_the_protocols_encoding_is_used_as_given(tmp_path):
    path = tmp_path / "t.csv"
    trial = multisine_trial(duration=4.0)
    rows = "\n".join(f"{t:.6f},{y:.9g},{f:.9g}" for t, y, f in zip(trial.time, trial.angle, trial.torque))
    path.write_bytes(("# site: Zürich\ntime_s,angle_rad,torque_Nm\n" + rows + "\n").encode("latin-1"))
    read = read_trial(path, protocol_from_dict({"format": {"encoding": "latin-1"}}))
    assert read.metadata["site"] == "Zürich" and not any("UTF-8" in w for w in read.warnings)


def test_unrecognised_headers_get_a_ready_to_paste_protocol(tmp_path):
    import tomllib
    path = tmp_path / "t.csv"
    path.write_text("Zeit;Winkel (deg);Moment (Nm)\n0;0,1;1\n0,01;0,2;2\n")
    with pytest.raises(TrialError) as info:
        read_trial(path)
    message = str(info.value)
    assert "\n" not in message and "a protocol can map them" in message
    line = message.split("the line: ")[1].split("; check each unit")[0]
    columns = tomllib.loads(line)["columns"]
    # the header by its name (the protocol finds 'Winkel (deg)' by it), the unit read from it
    assert columns["angle"] == {"header": "Winkel", "unit": "deg"}
    assert columns["torque"] == {"header": "Moment", "unit": "Nm"}
    assert columns["time"] == {"header": "Zeit", "unit": "?"}     # no unit in the file: the user's to say


# ---------------------------------------------------------------- headers with units (issue 35)

README = Path(__file__).resolve().parents[1] / "README.md"


def _readme_lab_example():
    """The README's "My lab's columns" protocol (TOML) and the export it shows, as written there."""
    text = README.read_text(encoding="utf-8")
    section = text.split("## My lab's columns", 1)[1].split("\n## ", 1)[0]
    toml = re.search(r"```toml\n(.*?)```", section, re.S).group(1)
    export = re.search(r"```text\n(.*?)```", section, re.S).group(1)
    return tomllib.loads(toml), export


def _lab_export(path, header: str, trial, decimal=","):
    """``trial`` written under ``header`` (ms, degrees, N·m; semicolons, decimal commas)."""
    rows = [f"{t * 1e3:.3f};{np.degrees(y):.9g};{f:.9g}" for t, y, f in zip(trial.time, trial.angle, trial.torque)]
    text = header + "\n" + "\n".join(rows) + "\n"
    path.write_text(text.replace(".", decimal) if decimal == "," else text, encoding="utf-8")
    return path


def test_the_readme_lab_protocol_reads_the_export_it_shows(tmp_path):
    settings, export = _readme_lab_example()
    header = export.splitlines()[0]
    assert header == "Zeit (ms);Winkel (°);Moment (Nm)"
    assert settings["columns"]["time"]["header"] == "Zeit"
    protocol = protocol_from_dict(settings)
    # the README's own rows, then a recording written the same way
    shown = tmp_path / "shown.csv"
    shown.write_text(export, encoding="utf-8")
    with pytest.raises(TrialError, match="trial too short"):     # the columns and units were understood
        read_trial(shown, protocol)
    trial = multisine_trial(duration=4.0)
    read = read_trial(_lab_export(tmp_path / "export.csv", header, trial), protocol)
    np.testing.assert_allclose(read.time, trial.time, atol=1e-9)            # ms → s
    np.testing.assert_allclose(read.angle, trial.angle, rtol=1e-7, atol=1e-12)   # ° → rad
    np.testing.assert_allclose(read.torque, -trial.torque, rtol=1e-7, atol=1e-12)  # N·m, flipped
    assert read.warnings == ()
    # the same export in cp1252 (a Windows export's '°'), read with a warning
    cp = tmp_path / "cp1252.csv"
    cp.write_bytes((tmp_path / "export.csv").read_text(encoding="utf-8").encode("cp1252"))
    np.testing.assert_array_equal(read_trial(cp, protocol).angle, read.angle)


def test_a_header_unit_and_a_protocol_unit_that_disagree_are_one_error(tmp_path):
    path = _lab_export(tmp_path / "export.csv", "Zeit (ms);Winkel (°);Moment (Nm)", multisine_trial(duration=4.0))
    columns = {"time": {"header": "Zeit", "unit": "s"}, "angle": {"header": "Winkel", "unit": "deg"},
               "torque": {"header": "Moment"}}
    with pytest.raises(TrialError) as info:
        read_trial(path, protocol_from_dict({"columns": columns}))
    assert str(info.value) == f"{path}: column 'Zeit (ms)': the protocol says unit 's', its name says 'ms'"
    # the same spelled otherwise agrees (° and deg, N·m and Nm); the whole header is found too
    columns = {"time": {"header": "Zeit (ms)", "unit": "ms"}, "angle": {"header": "winkel", "unit": "°"},
               "torque": {"header": "Moment", "unit": "N·m"}}
    assert read_trial(path, protocol_from_dict({"columns": columns})).n_samples > 0
    with pytest.raises(TrialError, match=r"column 'Winkel \(°\)': the protocol says unit 'rad', its name says '°'"):
        read_trial(path, protocol_from_dict({"columns": {**columns, "angle": {"header": "Winkel", "unit": "rad"}}}))
    with pytest.raises(TrialError, match=r"column 'Kraft' given by the protocol for torque/force is not in the file "
                                         r"\(headers found: Zeit \(ms\), Winkel \(°\), Moment \(Nm\)\)"):
        read_trial(path, protocol_from_dict({"columns": {**columns, "torque": {"header": "Kraft"}}}))


@pytest.mark.parametrize("headers, factors", [
    ("Time_s;angle [deg];torque_Nm", (1.0, np.pi / 180, 1.0)),
    ("time (ms);Angle (°);Torque [N·mm]", (1e-3, np.pi / 180, 1e-3)),
    ("Time [sec];angle_rad;torque (mNm)", (1.0, 1.0, 1e-3)),
    ("time_us;angle (mrad);torque (N m)", (1e-6, 1e-3, 1.0)),
])
def test_headers_with_units_are_found_without_a_protocol(tmp_path, headers, factors):
    trial = multisine_trial(duration=4.0)
    path = tmp_path / "t.csv"
    rows = [";".join(f"{v / k:.12g}" for v, k in zip(row, factors))
            for row in zip(trial.time, trial.angle, trial.torque)]
    path.write_text(headers + "\n" + "\n".join(rows) + "\n", encoding="utf-8")
    read = read_trial(path)
    np.testing.assert_allclose(read.time, trial.time, atol=1e-9)
    np.testing.assert_allclose(read.angle, trial.angle, rtol=1e-9, atol=1e-14)
    np.testing.assert_allclose(read.torque, trial.torque, rtol=1e-9, atol=1e-14)


def test_without_a_protocol_the_suggested_line_gives_the_units_in_the_headers(tmp_path):
    path = _lab_export(tmp_path / "export.csv", "Zeit (ms);Winkel (°);Moment (Nm)", multisine_trial(duration=4.0))
    with pytest.raises(TrialError) as info:
        read_trial(path)
    message = str(info.value)
    line = message.split("the line: ")[1].split("; check each unit")[0]
    assert 'unit = "?"' not in line
    columns = tomllib.loads(line)["columns"]
    assert columns == {"time": {"header": "Zeit", "unit": "ms"}, "angle": {"header": "Winkel", "unit": "deg"},
                       "torque": {"header": "Moment", "unit": "Nm"}}
    # and the line pasted into a protocol reads the file
    read = read_trial(path, protocol_from_dict({"columns": columns}))
    assert read.n_samples > 0


def test_a_name_two_headers_share_is_refused(tmp_path):
    path = tmp_path / "t.csv"
    path.write_text("Zeit (ms);Winkel (deg);Moment (Nm);Moment (Nmm)\n0;1;2;3\n", encoding="utf-8")
    columns = {"time": {"header": "Zeit"}, "angle": {"header": "Winkel"}, "torque": {"header": "Moment"}}
    with pytest.raises(TrialError, match=r"column 'Moment' given by the protocol for torque/force matches both "
                                         r"'Moment \(Nm\)' and 'Moment \(Nmm\)'; give the whole header"):
        read_trial(path, protocol_from_dict({"columns": columns}))
