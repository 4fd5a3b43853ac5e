"""The command line through click's CliRunner: outputs, exit statuses, one-line errors."""

import json

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from limbstiff.cli import main

from .conftest import PROTOCOLS

SUMMARY_KEYS = {"trial", "source_sha256", "variant", "fs_hz", "n_samples", "ci_level", "inertia", "damping",
                "stiffness", "observable_fraction", "warnings", "units", "seed", "software", "metadata"}


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_help_lists_commands():
    res = run("--help")
    assert res.exit_code == 0
    for name in ("analyze", "simulate", "calibrate"):
        assert name in res.output


def test_analyze_offers_the_protocols_estimators():
    from limbstiff.cli.analyze import command
    from limbstiff.protocol import ESTIMATORS
    option = next(p for p in command.params if p.name == "estimator")
    assert tuple(option.type.choices) == ESTIMATORS


@pytest.mark.slow
def test_analyze_writes_the_contract(trial_file, tmp_path):
    path = trial_file("t1")
    out = tmp_path / "out"
    res = run("analyze", path, "--out", out, "--no-pdf", "--jobs", 1)
    assert res.exit_code == 0, res.output
    frame = pd.read_csv(out / "t1" / "stiffness.csv")
    assert list(frame.columns) == ["time_s", "stiffness", "stiffness_lo", "stiffness_hi", "observable"]
    assert len(frame) == 4000 and set(frame["observable"].unique()) <= {0, 1}
    # stiffness written to 5 significant digits (the mantissa's digits without sign and point),
    # time to the sample
    rows = (out / "t1" / "stiffness.csv").read_text().splitlines()[1:]
    digits = [len(v.lstrip("-").replace(".", "").lstrip("0")) for r in rows for v in r.split(",")[1:4]]
    assert max(digits) == 5 and np.median(digits) >= 4
    np.testing.assert_allclose(np.diff(frame["time_s"]), 1 / 500, rtol=1e-6)
    summary = json.loads((out / "t1" / "summary.json").read_text())
    assert SUMMARY_KEYS <= set(summary)
    assert summary["variant"] == "external" and summary["metadata"]["subject"] == "S01"
    # exact, noise-free torque: identified m and b within 2 % of 0.06 and 0.45, and the
    # median stiffness within 2 % of the true median (15 N·m/rad).
    assert summary["inertia"]["median"] == pytest.approx(0.06, rel=0.02)
    assert summary["damping"]["median"] == pytest.approx(0.45, rel=0.02)
    assert summary["stiffness"]["median"] == pytest.approx(15.0, rel=0.02)
    table = pd.read_csv(out / "summary.csv")
    assert list(table["status"]) == ["ok"] and table["stiffness_median"][0] == pytest.approx(15.0, rel=0.02)


def test_fixed_inertia_and_damping_are_used(trial_file, tmp_path):
    out = tmp_path / "out"
    res = run("analyze", trial_file("t1"), "--out", out, "--no-pdf", "--inertia", 0.07, "--damping", 0.5)
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "t1" / "summary.json").read_text())
    assert summary["inertia"] == {"median": 0.07, "lo": 0.07, "hi": 0.07}
    assert summary["damping"]["median"] == 0.5


@pytest.mark.slow
def test_one_corrupt_file_among_good_ones(trial_file, tmp_path):
    folder = tmp_path / "trials"
    folder.mkdir()
    trial_file("a", folder=folder)
    trial_file("c", folder=folder)
    (folder / "b.csv").write_text("time_s,angle_rad,torque_Nm\n0,0,0\n0.001,abc,0\n")
    out = tmp_path / "out"
    res = run("analyze", folder, "--out", out, "--no-pdf", "--jobs", 1)
    assert res.exit_code == 1
    table = pd.read_csv(out / "summary.csv", keep_default_na=False)
    assert list(table["trial"]) == ["a", "b", "c"]
    assert list(table["status"]) == ["ok", "failed", "ok"]
    assert "b.csv" in table["error"][1] and "non-numeric value 'abc'" in table["error"][1]
    assert (out / "a" / "summary.json").exists() and (out / "c" / "summary.json").exists()
    assert "Traceback" not in res.output


def test_nothing_to_do_is_exit_2(tmp_path):
    res = run("analyze", tmp_path / "missing", "--out", tmp_path / "out")
    assert res.exit_code == 2
    assert "missing: no such file or folder" in res.output and "Traceback" not in res.output
    empty = tmp_path / "empty"
    empty.mkdir()
    assert run("analyze", empty).exit_code == 2


def test_bad_protocol_is_exit_2(trial_file, tmp_path):
    proto = tmp_path / "p.toml"
    proto.write_text("[observer]\ngain = 'fast'\n")
    res = run("analyze", trial_file("t1"), "--protocol", proto, "--out", tmp_path / "out")
    assert res.exit_code == 2
    assert "p.toml" in res.output and res.output.count("\n") == 1


@pytest.mark.slow
def test_outputs_are_not_overwritten_without_overwrite(trial_file, tmp_path):
    path, out = trial_file("t1"), tmp_path / "out"
    assert run("analyze", path, "--out", out, "--no-pdf").exit_code == 0
    before = (out / "t1" / "summary.json").read_text()
    res = run("analyze", path, "--out", out, "--no-pdf", "--inertia", 0.1, "--damping", 0.1)
    assert res.exit_code == 2 and "use --overwrite" in res.output and len(res.output.strip().splitlines()) == 1
    assert (out / "t1" / "summary.json").read_text() == before
    res = run("analyze", path, "--out", out, "--no-pdf", "--inertia", 0.1, "--damping", 0.1, "--overwrite")
    assert res.exit_code == 0
    assert json.loads((out / "t1" / "summary.json").read_text())["inertia"]["median"] == 0.1


@pytest.mark.slow
def test_stem_collisions_keep_both(trial_file, tmp_path):
    for sub in ("day1", "day2"):
        (tmp_path / sub).mkdir()
        trial_file("trial", folder=tmp_path / sub)
    out = tmp_path / "out"
    res = run("analyze", tmp_path / "day1", tmp_path / "day2", "--out", out, "--no-pdf", "--jobs", 1)
    assert res.exit_code == 0, res.output
    assert (out / "trial" / "summary.json").exists() and (out / "trial-2" / "summary.json").exists()
    assert "also named 'trial'" in res.output


@pytest.mark.slow
def test_report_pdf_is_written(trial_file, tmp_path):
    out = tmp_path / "out"
    res = run("analyze", trial_file("t1", duration=3.0), "--out", out)
    assert res.exit_code == 0, res.output
    pdf = (out / "t1" / "report.pdf").read_bytes()
    assert pdf.startswith(b"%PDF") and b"limbstiff" in pdf


@pytest.mark.slow
def test_reklab_protocol_on_real_file(tmp_path):
    from .conftest import REAL
    out = tmp_path / "out"
    res = run("analyze", REAL / "z_df.csv", "--protocol", PROTOCOLS / "reklab-ankle.toml", "--out", out,
              "--no-pdf")
    assert res.exit_code == 0, res.output
    s = json.loads((out / "z_df" / "summary.json").read_text())
    assert s["fs_hz"] == pytest.approx(1000.0) and s["n_samples"] == 60000
    # SOURCE.md: I ≈ 0.0166 kg·m², B ≈ 1.35 N·m·s/rad for z_df (±20–30 %)
    assert 0.010 <= s["inertia"]["median"] <= 0.022
    assert 1.35 / 2 <= s["damping"]["median"] <= 1.35 * 2


@pytest.mark.parametrize("content, phrase", [
    ("time_s,angle_rad,torque_Nm\n", "no data rows"),
    ("time_s,angle_rad\n" + "".join(f"{i / 100},{i % 7}\n" for i in range(200)), "no torque or force column"),
    ("time_s,angle_grad,torque_Nm\n" + "".join(f"{i / 100},{i % 7},1\n" for i in range(200)), "unknown unit 'grad'"),
    ("time_s,angle_rad,torque_Nm\n" + "".join(f"{i / 100},{i % 7},nan\n" for i in range(200)), "NaN in column"),
    ("time_s,angle_rad,torque_Nm\n" + "".join(f"{(i if i != 50 else 49) / 100},{i % 7},1\n" for i in range(200)),
     "time does not increase"),
    ("time_s,angle_rad,torque_Nm\n" + "".join(f"{i / 100 + (5 if i > 100 else 0)},{i % 7},1\n" for i in range(200)),
     "gap in time"),
    ("time_s,angle_rad,torque_Nm\n" + "".join(f"{i / 100},{i % 7},1\n" for i in range(20)), "trial too short"),
    ("time_s,angle_rad,torque_Nm\n" + "".join(f"{i / 100},0.3,{i}\n" for i in range(200)), "no motion"),
])
def test_bad_input_through_the_cli(tmp_path, content, phrase):
    bad = tmp_path / "bad.csv"
    bad.write_text(content)
    out = tmp_path / "out"
    res = run("analyze", bad, "--out", out, "--no-pdf")
    assert res.exit_code == 1                                  # INTERFACE §2: some trials failed
    assert "Traceback" not in res.output
    table = pd.read_csv(out / "summary.csv", keep_default_na=False)
    error = table["error"][0]
    assert phrase in error and "bad.csv" in error and "\n" not in error
    assert not (out / "bad" / "stiffness.csv").exists()       # nothing half-written


def test_simulate_writes_a_trial_analyze_can_read(tmp_path):
    path = tmp_path / "elbow.csv"
    res = run("simulate", "elbow", "--seed", 3, "--set", "duration=4", "--effect", "reflex",
              "--effect-param", "delay=0.05", "--out", path)
    assert res.exit_code == 0, res.output
    from limbstiff.files import read_trial
    trial = read_trial(path)
    assert trial.stiffness_true is not None and trial.metadata["effect"] == "reflex"
    assert float(trial.metadata["effect.delay"]) == pytest.approx(0.05)
    assert trial.duration == pytest.approx(4.0, abs=0.01)


def test_simulate_list_and_bad_scenario(tmp_path):
    res = run("simulate", "--list")
    assert res.exit_code == 0 and "paper-exp-spring" in res.output and "coulomb_friction" in res.output
    res = run("simulate", "knee-of-a-giraffe", "--out", tmp_path / "x.csv")
    assert res.exit_code == 2 and "unknown scenario" in res.output and "Traceback" not in res.output
    res = run("simulate", "elbow", "--set", "durashun=3", "--out", tmp_path / "x.csv")
    assert res.exit_code == 2 and "durashun" in res.output


@pytest.mark.slow
def test_identify_writes_posterior_and_draws(tmp_path):
    path = tmp_path / "elbow.csv"
    assert run("simulate", "elbow", "--seed", 11, "--set", "duration=8", "--out", path).exit_code == 0
    out = tmp_path / "id"
    res = run("identify", path, "--out", out, "--seed", 5, "--jobs", 1)
    assert res.exit_code == 0, res.output
    post = json.loads((out / "elbow" / "posterior.json").read_text())
    draws = pd.read_csv(out / "elbow" / "draws.csv")
    assert list(draws.columns[:2]) == ["inertia", "damping"] and len(draws) >= 1000
    # every number has its unit, the noise levels' included (dotted keys name the nested ones)
    assert post["units"]["inertia"] == "kg·m²" and post["units"]["noise_levels.stiffness_walk"] == "(N·m/rad)²/s"
    assert {f"noise_levels.{k}" for k in post["identification"]["noise_levels"]} <= set(post["units"])
    mcmc = post["mcmc"]
    assert {"n_walkers", "n_steps", "autocorr_time", "acceptance_fraction", "converged", "seed"} <= set(mcmc)
    assert mcmc["seed"] == 5 and 0.15 < mcmc["acceptance_fraction"] < 0.7
    # simulated elbow: m = 0.06 kg·m², b = 0.45 N·m·s/rad
    assert post["inertia"]["lo"] < post["inertia"]["median"] < post["inertia"]["hi"]
    assert post["inertia"]["median"] == pytest.approx(0.06, rel=0.05)
    assert post["damping"]["median"] == pytest.approx(0.45, rel=0.05)
    # same seed, same draws
    out2 = tmp_path / "id2"
    assert run("identify", path, "--out", out2, "--seed", 5, "--jobs", 1).exit_code == 0
    assert pd.read_csv(out2 / "elbow" / "draws.csv").equals(draws)
    # the same command again: up to date, kept (not failed); another seed is another run
    stamp = (out / "elbow" / "posterior.json").stat().st_mtime_ns
    res = run("identify", path, "--out", out, "--seed", 5, "--jobs", 1)
    assert res.exit_code == 0 and "1 up to date, skipped" in res.output
    assert (out / "elbow" / "posterior.json").stat().st_mtime_ns == stamp
    res = run("identify", path, "--out", out, "--seed", 6, "--jobs", 1)
    assert res.exit_code == 2 and "were made with other settings: use --overwrite or another --out" in res.output
    assert (out / "elbow" / "posterior.json").stat().st_mtime_ns == stamp
    table = pd.read_csv(out / "summary.csv", keep_default_na=False)
    assert table["status"].tolist() == ["ok"] and table["kind"].tolist() == ["rotational"]
    assert table["inertia_unit"].tolist() == ["kg·m²"]


def test_identify_with_m_and_b_given_runs_again_as_a_no_op(tmp_path):
    # m and b given: no posterior, so no draws.csv; the same command again is up to date, not refused
    path = tmp_path / "elbow.csv"
    assert run("simulate", "elbow", "--seed", 12, "--set", "duration=4", "--out", path).exit_code == 0
    protocol = tmp_path / "given.toml"
    protocol.write_text("[mechanics]\ninertia = 0.06\ndamping = 0.45\n")
    out = tmp_path / "id"
    first = run("identify", path, "--protocol", protocol, "--out", out, "--jobs", 1)
    assert first.exit_code == 0, first.output
    assert not (out / "elbow" / "draws.csv").exists()
    again = run("identify", path, "--protocol", protocol, "--out", out, "--jobs", 1)
    assert again.exit_code == 0 and "1 up to date, skipped" in again.output, again.output


def _refused(res, path):
    """One line, exit 2, naming the file and what to do."""
    lines = res.output.strip().splitlines()
    return (res.exit_code == 2 and len(lines) == 1 and "Traceback" not in res.output and str(path) in lines[0]
            and lines[0].startswith("limbstiff: error: "))


def test_simulate_never_overwrites_without_overwrite(tmp_path):
    path = tmp_path / "elbow.csv"
    assert run("simulate", "elbow", "--set", "duration=2", "--out", path).exit_code == 0
    before = path.read_bytes()
    res = run("simulate", "elbow", "--set", "duration=2", "--seed", 4, "--out", path)
    assert _refused(res, path) and "use --overwrite" in res.output and "another path" in res.output
    assert path.read_bytes() == before
    res = run("simulate", "elbow", "--set", "duration=2", "--seed", 4, "--out", path, "--overwrite")
    assert res.exit_code == 0, res.output
    assert path.read_bytes() != before and "seed: 4" in path.read_text()


@pytest.mark.parametrize("where", ["under-a-file", "missing-folder", "a-folder"])
def test_simulate_to_an_unwritable_path_is_one_line(tmp_path, where):
    (tmp_path / "file.txt").write_text("x")
    (tmp_path / "folder").mkdir()
    path = {"under-a-file": tmp_path / "file.txt" / "out.csv", "missing-folder": tmp_path / "no" / "out.csv",
            "a-folder": tmp_path / "folder"}[where]
    for extra in ([], ["--overwrite"]):
        res = run("simulate", "elbow", "--set", "duration=2", "--out", path, *extra)
        assert _refused(res, path), res.output
    assert not (tmp_path / "no").exists() and (tmp_path / "file.txt").read_text() == "x"


def test_simulate_default_name_is_not_overwritten(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert run("simulate", "elbow", "--set", "duration=2").exit_code == 0
    res = run("simulate", "elbow", "--set", "duration=2")
    assert _refused(res, "elbow.csv")


def test_diagnose_never_overwrites_without_overwrite(trial_file, tmp_path):
    out = tmp_path / "diag"
    out.mkdir()
    (out / "diagnosis.json").write_text("{}")
    res = run("diagnose", trial_file("t1"), "--out", out)
    assert _refused(res, out) and "diagnosis.json" in res.output and "--overwrite" in res.output
    assert (out / "diagnosis.json").read_text() == "{}"


def test_an_unwritable_file_is_one_line_not_a_traceback(monkeypatch, tmp_path):
    # a write that fails after the checks (a full disk, a race) is still one line, exit 2
    import limbstiff.files
    def denied(trial, path):
        raise PermissionError(13, "Permission denied", str(path))
    monkeypatch.setattr(limbstiff.files, "write_trial", denied)
    res = run("simulate", "elbow", "--set", "duration=2", "--out", tmp_path / "x.csv")
    assert _refused(res, tmp_path / "x.csv") and "Permission denied" in res.output
