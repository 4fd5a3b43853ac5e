"""Spring calibration of Sec. V: regression in semi-logarithmic space."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from limbstiff.calibrate import fit_exponential_spring
from limbstiff.cli import main


def test_exact_pairs_recover_the_spring():
    x = np.linspace(0.0025, 0.0225, 50)
    a, b = 0.365, 300.0
    cal = fit_exponential_spring(x, a * np.exp(b * x))
    assert cal.a == pytest.approx(a, rel=1e-10) and cal.b == pytest.approx(b, rel=1e-10)
    assert cal.error_margin < 1e-10
    np.testing.assert_allclose(cal.stiffness(x), a * b * np.exp(b * x), rtol=1e-9)


def test_error_margin_reflects_multiplicative_scatter():
    # ln f scattered with sd 0.2 gives an RMS log residual ≈ 0.2 (n = 4000: ±2 %) and a
    # margin e^0.2 − 1 ≈ 22 %, the size the paper reports for its hysteretic bench (25 %).
    rng = np.random.default_rng(7)
    x = rng.uniform(0, 0.02, 4000)
    f = 2.0 * np.exp(150 * x) * np.exp(0.2 * rng.standard_normal(x.size))
    cal = fit_exponential_spring(x, f)
    assert cal.rms_log_error == pytest.approx(0.2, rel=0.03)
    assert cal.error_margin == pytest.approx(np.expm1(0.2), rel=0.04)
    assert cal.b == pytest.approx(150, rel=0.03)


@pytest.mark.parametrize("x, f, phrase", [
    ([0.0, 1.0], [1.0, 2.0], "at least 3"),
    ([0.0, 1.0, 2.0], [1.0, -2.0, 3.0], "strictly positive"),
    ([1.0, 1.0, 1.0], [1.0, 2.0, 3.0], "same displacement"),
])
def test_bad_pairs(x, f, phrase):
    with pytest.raises(ValueError, match=phrase):
        fit_exponential_spring(np.array(x), np.array(f))


def test_calibrate_command(tmp_path):
    x = np.linspace(2.5, 22.5, 30)                       # mm
    pairs = tmp_path / "pairs.csv"
    pairs.write_text("# spring: left\nposition_mm,elastic_force_N\n"
                     + "".join(f"{xi},{0.5 * np.exp(0.1 * xi)}\n" for xi in x))
    out = tmp_path / "cal.json"
    res = CliRunner().invoke(main, ["calibrate", str(pairs), "--out", str(out)])
    assert res.exit_code == 0, res.output
    cal = json.loads(out.read_text())
    assert cal["b"] == pytest.approx(100.0, rel=1e-9)    # 0.1 /mm = 100 /m
    assert cal["a"] == pytest.approx(0.5, rel=1e-9)
    assert cal["kind"] == "translational"
    assert cal["units"] == {"a": "N", "b": "1/m", "x_range": "m", "rms_log_error": "1", "error_margin": "1",
                            "stiffness": "N/m"}


def test_calibrate_command_rotational_units(tmp_path):
    """Angle and torque pairs give a rotational calibration in N·m and 1/rad (b = 0.1 /deg =
    5.7296 /rad), which reads back as such."""
    from limbstiff.calibrate import SpringCalibration
    x = np.linspace(1.0, 20.0, 12)                       # deg
    pairs = tmp_path / "pairs.csv"
    pairs.write_text("angle_deg,torque_Nm\n" + "".join(f"{xi},{2.0 * np.exp(0.1 * xi)}\n" for xi in x))
    out = tmp_path / "cal.json"
    res = CliRunner().invoke(main, ["calibrate", str(pairs), "--out", str(out)])
    assert res.exit_code == 0, res.output
    cal = json.loads(out.read_text())
    assert cal["kind"] == "rotational" and cal["units"]["a"] == "N·m" and cal["units"]["b"] == "1/rad"
    assert cal["b"] == pytest.approx(0.1 * 180 / np.pi, rel=1e-9)
    assert SpringCalibration.from_dict(cal).kind == "rotational"


def test_calibrate_command_bad_file(tmp_path):
    pairs = tmp_path / "pairs.csv"
    pairs.write_text("position_mm,elastic_force_N\n1,2\n2,oops\n3,4\n")
    res = CliRunner().invoke(main, ["calibrate", str(pairs)])
    assert res.exit_code == 2
    assert "pairs.csv" in res.output and "non-numeric" in res.output
    assert "Traceback" not in res.output


def test_pairs_of_mixed_kinds_and_a_calibration_of_the_wrong_kind(tmp_path):
    """An angle with a force is refused; a calibration file with an unknown kind is a one-line
    error; a rotational calibration given to a translational trial fails that trial (exit 1)."""
    from limbstiff.files import write_trial
    from limbstiff.simulate import simulate
    pairs = tmp_path / "pairs.csv"
    pairs.write_text("angle_deg,force_N\n1,2\n2,3\n3,5\n")
    res = CliRunner().invoke(main, ["calibrate", str(pairs), "--out", str(tmp_path / "c.json")])
    assert res.exit_code == 2 and "pairs are an angle with a torque or a length with a force" in res.output
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"a": 1, "b": 1, "rms_log_error": 0, "error_margin": 0, "n_pairs": 3,
                               "x_range": [0, 1], "kind": "Rotational"}))
    trial = tmp_path / "bench.csv"
    write_trial(simulate("paper-exp-spring", seed=1, params={"duration": 3.0}), trial)
    res = CliRunner().invoke(main, ["analyze", str(trial), "--reference", str(bad), "--no-pdf", "--jobs", "1",
                                    "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "not a limbstiff calibration file" in res.output and "Traceback" not in res.output
    rotational = tmp_path / "rot.json"
    rotational.write_text(bad.read_text().replace('"Rotational"', '"rotational"'))
    res = CliRunner().invoke(main, ["analyze", str(trial), "--reference", str(rotational), "--no-pdf", "--jobs", "1",
                                    "--out", str(tmp_path / "o")])
    assert res.exit_code == 1 and "the --reference calibration is rotational but the trial is translational" \
        in res.output


def _pairs_file(tmp_path):
    x = np.linspace(0.0, 0.02, 12)
    pairs = tmp_path / "pairs.csv"
    pairs.write_text("position_m,force_N\n" + "".join(f"{a},{2.0 * np.exp(40.0 * a)}\n" for a in x))
    return pairs


def _refused(res, path):
    lines = res.output.strip().splitlines()
    return (res.exit_code == 2 and len(lines) == 1 and "Traceback" not in res.output and str(path) in lines[0]
            and lines[0].startswith("limbstiff: error: "))


def test_calibrate_never_overwrites_without_overwrite(tmp_path):
    pairs, out = _pairs_file(tmp_path), tmp_path / "cal.json"
    out.write_text("{}")
    res = CliRunner().invoke(main, ["calibrate", str(pairs), "--out", str(out)])
    assert _refused(res, out) and "use --overwrite" in res.output and "another path" in res.output
    assert out.read_text() == "{}"
    res = CliRunner().invoke(main, ["calibrate", str(pairs), "--out", str(out), "--overwrite"])
    assert res.exit_code == 0, res.output
    assert json.loads(out.read_text())["b"] == pytest.approx(40.0)


@pytest.mark.parametrize("where", ["under-a-file", "missing-folder", "a-folder"])
def test_calibrate_to_an_unwritable_path_is_one_line(tmp_path, where):
    pairs = _pairs_file(tmp_path)
    (tmp_path / "file.txt").write_text("x")
    (tmp_path / "folder").mkdir()
    out = {"under-a-file": tmp_path / "file.txt" / "out.json", "missing-folder": tmp_path / "no" / "out.json",
           "a-folder": tmp_path / "folder"}[where]
    for extra in ([], ["--overwrite"]):
        res = CliRunner().invoke(main, ["calibrate", str(pairs), "--out", str(out), *extra])
        assert _refused(res, out), res.output
    assert not (tmp_path / "no").exists() and (tmp_path / "file.txt").read_text() == "x"
