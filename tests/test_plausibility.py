"""Units and ranges checked before any fit (issue 34): each unit slip named with its protocol line."""

import math

import numpy as np
import pytest
from click.testing import CliRunner

import limbstiff
from limbstiff.analysis import analyze, identify_trial
from limbstiff.checks.units import plausible
from limbstiff.cli import main
from limbstiff.errors import ProtocolError, TrialError
from limbstiff.files import read_trial, write_trial
from limbstiff.plausibility import ANY_JOINT, LIMBS, check_inertia, check_recording, limb_of
from limbstiff.protocol import Protocol, load_protocol, protocol_from_dict
from limbstiff.simulate import simulate

from .conftest import PROTOCOLS, REAL

EXAMPLES = PROTOCOLS.parent / "examples"


@pytest.fixture(scope="module")
def elbow():
    return simulate("elbow", seed=1, params={"duration": 6.0})


def _slip(tmp_path, trial, column, *, factor=None, header=None, counts=None):
    """The trial's file rewritten as a lab's slip leaves it."""
    path = write_trial(trial, tmp_path / "trial.csv")
    lines = path.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    names = lines[start].split(",")
    k = names.index(column)
    if header is not None:
        names[k] = header
        lines[start] = ",".join(names)
    for i in range(start + 1, len(lines)) if header is None else ():
        cells = lines[i].split(",")
        x = float(cells[k]) * (factor or counts)
        cells[k] = str(round(x)) if counts else repr(x)
        lines[i] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    return path


def _said(path, protocol=Protocol()):
    """What the units check says of a file: the error's message, or the first finding's."""
    try:
        found = plausible(read_trial(path, protocol), protocol)
    except TrialError as exc:
        return str(exc), True
    return (found[0].message, False) if found else ("", False)


@pytest.mark.parametrize("slip, phrase, fatal", [
    (dict(column="angle_rad", factor=180 / math.pi), '[columns.angle] unit = "deg"', None),
    (dict(column="angle_rad", header="angle_deg"), '[columns.angle] unit = "rad"', False),
    (dict(column="angle_rad", counts=4096 / (2 * math.pi)), "probably encoder counts", True),
    (dict(column="time_s", factor=1000.0), '[columns.time] unit = "ms"', True),
    (dict(column="time_s", header="time_ms"), '[columns.time] unit = "s"', True),
    (dict(column="torque_Nm", header="torque_Nmm"), '[columns.torque] unit = "Nm"', False),
], ids=["deg-as-rad", "rad-as-deg", "counts-as-rad", "ms-as-s", "s-as-ms", "Nm-as-Nmm"])
def test_each_slip_is_named_with_its_protocol_line(tmp_path, elbow, slip, phrase, fatal):
    message, was_fatal = _said(_slip(tmp_path, elbow, **slip))
    assert phrase in message and "probably" in message and "\n" not in message
    assert fatal is None or was_fatal == fatal
    with_limb, _ = _said(_slip(tmp_path, elbow, **slip), Protocol(limb="elbow"))
    assert phrase in with_limb


def test_a_fatal_slip_stops_analyze_before_the_fit(tmp_path, elbow):
    trial = read_trial(_slip(tmp_path, elbow, column="time_s", factor=1000.0))   # was a ZeroDivisionError
    with pytest.raises(TrialError, match=r'sample rate of 1 Hz .*\[columns.time\] unit = "ms"'):
        analyze(trial)
    trial = read_trial(_slip(tmp_path, elbow, column="angle_rad", counts=4096 / (2 * math.pi)))
    with pytest.raises(TrialError, match=r'more than the elbow can turn .*probably encoder counts'):
        identify_trial(trial, Protocol(limb="elbow"))


def test_torque_in_Nmm_is_an_error_with_the_limb_and_the_inertia_without(tmp_path, elbow):
    trial = read_trial(_slip(tmp_path, elbow, column="torque_Nm", factor=1000.0))
    with pytest.raises(TrialError, match=r'torque reaches .* the elbow .*\[columns.torque\] unit = "Nmm"'):
        plausible(trial, Protocol(limb="elbow"))
    assert plausible(trial, Protocol()) == ()             # 425 N·m: some joint could bear it
    finding = check_inertia(60.0, limb=ANY_JOINT)          # ... but not with the inertia it gives
    assert finding is not None and '[columns.torque] unit = "Nmm"' in finding.message


def test_an_implausible_inertia_makes_the_analysis_unreliable(elbow):
    trial = elbow.segment(0, 4001)
    result = analyze(trial, Protocol(limb="finger"))      # an elbow's 0.06 kg·m² on a "finger"
    failed = [c for c in result.checks.failed if c.name == "units_inertia"]
    assert result.checks.verdict == "unreliable" and "far outside the finger's" in failed[0].message


def test_ms_read_as_s_through_the_cli_is_one_line_without_traceback(tmp_path, elbow):
    path = _slip(tmp_path, elbow, column="time_s", factor=1000.0)
    res = CliRunner().invoke(main, ["analyze", str(path), "--out", str(tmp_path / "out"), "--no-pdf"])
    assert res.exit_code == 1                                  # docs/interface.md §2: a trial failed
    assert "Traceback" not in res.output and "ZeroDivisionError" not in res.output
    assert '[columns.time] unit = "ms"' in res.output


def _quantities(trial):
    torque = trial.torque if trial.torque is not None else trial.elastic_torque
    return trial.time, trial.angle, torque


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.csv")), ids=lambda p: p.stem)
def test_no_false_alarm_on_the_examples(path):
    trial = read_trial(path)
    assert check_recording(*_quantities(trial), rotational=trial.kind == "rotational") == ()
    assert plausible(read_trial(path, load_protocol(PROTOCOLS / "elbow-lab.toml")),
                     load_protocol(PROTOCOLS / "elbow-lab.toml")) == ()


@pytest.mark.parametrize("path", sorted(REAL.glob("*.csv")), ids=lambda p: p.stem)
def test_no_false_alarm_on_the_real_ankles(path):
    trial = read_trial(path, load_protocol(PROTOCOLS / "reklab-ankle.toml"))
    trial = trial.segment(0, 15001)
    for limb in (ANY_JOINT, LIMBS["ankle"]):
        assert check_recording(*_quantities(trial), limb=limb) == ()
    assert check_inertia(0.0166, limb=LIMBS["ankle"]) is None


@pytest.mark.parametrize("scenario", ["elbow", "wrist", "ankle", "ankle-coupled", "ankle-platform",
                                      "paper-vsa-hogan", "paper-vsa-feldman", "paper-vsa-exp", "paper-exp-spring"])
def test_no_false_alarm_on_the_simulators_scenarios(scenario):
    trial = simulate(scenario, seed=1, params={"duration": 5.0})
    assert check_recording(*_quantities(trial), rotational=trial.kind == "rotational") == ()
    limb = {"elbow": "elbow", "wrist": "wrist"}.get(scenario, "ankle" if "ankle" in scenario else "vsa")
    assert check_recording(*_quantities(trial), rotational=trial.kind == "rotational", limb=LIMBS[limb]) == ()


def test_the_limb_key_is_validated(tmp_path):
    path = tmp_path / "p.toml"
    path.write_text('limb = "elbow"\n')
    assert load_protocol(path).limb == "elbow" and load_protocol(path).to_dict()["limb"] == "elbow"
    assert "limb" not in Protocol().to_dict()              # settings hash of other protocols unchanged
    path.write_text('limb = "elbo"\n')
    with pytest.raises(ProtocolError, match="'limb' must be one of finger, wrist, elbow.*not 'elbo'"):
        load_protocol(path)
    with pytest.raises(ProtocolError, match="wrong type"):
        protocol_from_dict({"limb": 3})


def test_the_table_is_coherent():
    for limb in (*LIMBS.values(), ANY_JOINT):
        assert 0 < limb.inertia[0] < limb.inertia[1] and limb.torque_min_range < limb.torque_max
        assert limb.source
    assert np.isclose(LIMBS["elbow"].inertia[0], 0.02) and limbstiff.__version__


def test_the_inertia_is_bounded_by_the_protocols_expected_range_or_prior():
    elbow_lab = load_protocol(PROTOCOLS / "elbow-lab.toml")
    by_prior = limb_of(None, prior=(elbow_lab.inertia_prior.median, elbow_lab.inertia_prior.sigma))
    assert check_inertia(0.06, limb=by_prior) is None
    finding = check_inertia(3.4, limb=by_prior)                       # radians read as degrees: ×57
    assert finding is not None and "far outside the set-up's" in finding.message
    by_range = limb_of(None, expected_inertia=load_protocol(PROTOCOLS / "reklab-ankle.toml").inertia_range)
    assert check_inertia(0.0166, limb=by_range) is None and check_inertia(1.5e-5, limb=by_range) is not None
    assert limb_of("ankle", expected_inertia=(1.0, 2.0)) is LIMBS["ankle"] and limb_of(None) is ANY_JOINT


@pytest.mark.parametrize("path, protocol", [
    (REAL / "z_df3.csv", "reklab-ankle.toml"), (EXAMPLES / "elbow.csv", "elbow-lab.toml"),
], ids=["z_df3-reklab", "elbow-elbow-lab"])
@pytest.mark.slow
def test_no_units_finding_in_a_whole_analysis_with_the_bundled_protocols(path, protocol):
    proto = load_protocol(PROTOCOLS / protocol)
    trial = read_trial(path, proto)
    result = analyze(trial.segment(0, int(10 * trial.fs) + 1), proto)
    assert not [c.name for c in result.checks.checks if c.name.startswith("units_")]


@pytest.mark.parametrize("scenario", ["paper-vsa-hogan", "paper-vsa-feldman", "paper-vsa-exp"])
def test_no_false_alarm_with_the_vsa_bench_protocol(tmp_path, scenario):
    vsa = load_protocol(PROTOCOLS / "vsa-bench.toml")
    path = write_trial(simulate(scenario, seed=1, params={"duration": 5.0}), tmp_path / f"{scenario}.csv")
    assert plausible(read_trial(path, vsa), vsa) == ()
    assert plausible(read_trial(path, vsa), vsa.override(limb="vsa")) == ()


def test_no_false_alarm_on_the_independent_simulator():
    from .support.independent_trials import make_trial, suite
    specs = {s.name: s for s in suite(7100)}
    for name, limb in (("clean-ramp-elbow", "elbow"), ("clean-gait-ankle", "ankle"), ("clean-vsa", "vsa")):
        data, truth = make_trial(specs[name])
        arrays = [data[c].to_numpy() for c in ("time_s", "angle_rad", "torque_Nm")]
        for bounds in (ANY_JOINT, LIMBS[limb]):
            assert check_recording(*arrays, limb=bounds) == (), name
            assert check_inertia(truth.get("m", truth.get("inertia")), limb=bounds) is None, name
