"""limbstiff diagnose: the gap-location functions against exact answers, every candidate effect on
a small seeded trial, clean data, the command line and bad input.

The simulated trials here use seeds below 100 and effect sizes outside the benchmark's
(benchmarks/diagnose.py: seeds from 5000, the default size × 0.75–1.5), 15–20 s long.
"""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from limbstiff.cli import main
from limbstiff.diagnosis import selection, where
from limbstiff.effects.registry import CANDIDATES
from limbstiff.provenance import software
from limbstiff.effects.kinds import ModelEffect, TorqueEffect, remove
from limbstiff.diagnosis.run import diagnose
from limbstiff.files import write_trial
from limbstiff.protocol import Protocol
from limbstiff.simulate import effect_defaults, simulate


# --- where: pure functions against exact answers ------------------------------------------------

def test_whiteness_accepts_white_noise_at_its_level():
    rng = np.random.default_rng(1)
    # 200 white series: the 95 % Ljung-Box test rejects about 5 % of them
    rejected = np.mean([not where.whiteness(rng.normal(size=600), max_lag=10, level=0.95).white
                        for _ in range(200)])
    assert 0.01 <= rejected <= 0.10
    out = where.whiteness(rng.normal(size=2000), max_lag=10, level=0.95)
    assert out.bound == pytest.approx(1.96 / np.sqrt(2000), rel=1e-3)


def test_whiteness_rejects_correlated_noise():
    rng = np.random.default_rng(2)
    e = rng.normal(size=3000)
    x = np.empty_like(e)
    x[0] = e[0]
    for k in range(1, len(e)):
        x[k] = 0.5 * x[k - 1] + e[k]            # AR(1): ρ(1) = 0.5
    out = where.whiteness(x, max_lag=10)
    assert not out.white and out.p_value < 1e-6
    assert out.acf[0] == pytest.approx(0.5, abs=0.05)
    # tested against its own autocorrelation as the reference, the same series is "white"
    ref = 0.5 ** np.arange(11)
    assert where.whiteness(x, max_lag=10, reference=ref).p_value > 0.01


def test_cross_correlation_of_a_delayed_copy_peaks_at_the_delay():
    rng = np.random.default_rng(3)
    fs, delay = 1000.0, 0.037
    x = rng.normal(size=20000)
    r = np.roll(x, int(delay * fs)) + 0.5 * rng.normal(size=x.size)     # r(t) = x(t − d) + noise
    out = where.cross_correlation(r, x, max_lag=100, sample_period=1 / fs)
    assert out.peak_lag_s == pytest.approx(delay)
    assert out.significant and out.peak == pytest.approx(1 / np.sqrt(1.25), abs=0.02)
    independent = where.cross_correlation(rng.normal(size=20000), x, max_lag=100, sample_period=1 / fs)
    assert np.mean(np.abs(independent.ccf) > independent.bound) < 0.15


def test_regime_bins_and_gap_ratios():
    v = np.concatenate([np.zeros(100), np.linspace(0.1, 1.0, 400)])
    labels, names, ranges = where.speed_bins(v, still=0.05, k=4)
    assert np.all(labels[:100] == 0) and names[0].startswith("near zero")
    assert np.bincount(labels[100:], minlength=5)[1:].tolist() == [100, 100, 100, 100]
    residual = np.where(labels == 2, 2.0, 1.0)               # bin 2 has twice the residual
    bins = where.binned_gap(residual, 4.0, labels, names)
    overall = np.mean(residual ** 2)
    assert bins[2].ratio == pytest.approx(4.0 / overall)
    assert bins[0].gap == pytest.approx(1.0 / 4.0)
    lo, hi = bins[2].interval
    assert lo < bins[2].ratio < hi


def test_reversal_mask_and_change_points():
    t = np.arange(1000) / 100.0
    v = np.cos(np.pi * t)                                 # reversals at t = 0.5 + k
    u = (t - 0.5) % 1.0
    distance = np.minimum(u, 1.0 - u)                     # to the nearest reversal, s
    mask = where.reversal_mask(v, half_width=5)
    assert np.all(mask[distance < 0.03]) and not np.any(mask[distance > 0.08])
    rng = np.random.default_rng(4)
    series = np.concatenate([np.zeros(30), 3 * np.ones(20)]) + 0.3 * rng.normal(size=50)
    assert where.change_points(series) == [30]
    assert where.change_points(0.3 * rng.normal(size=50)) == []


def test_coherence_of_a_linear_residual():
    rng = np.random.default_rng(5)
    fs = 200.0
    angle = np.cumsum(rng.normal(size=8000)) * 1e-3
    angle -= np.mean(angle)
    linear = np.convolve(angle, np.ones(5) / 5, mode="same")      # a linear dynamics of the angle
    out = where.spectrum(linear, angle, angle, fs, max_hz=20.0)
    f = out.freq_hz
    assert np.all(out.coherence[(f > 0.5) & (f < 15)] > out.bound)
    noise = where.spectrum(rng.normal(size=8000), angle, angle, fs, max_hz=20.0)
    assert np.mean(noise.coherence > noise.bound) < 0.15


def test_sign_flip_test_and_holm():
    rng = np.random.default_rng(6)
    assert selection.sign_flip_pvalue(np.ones(20), rng) < 1e-3
    assert selection.sign_flip_pvalue(np.ones(8), rng) == pytest.approx(1 / 256)       # exact enumeration
    assert selection.sign_flip_pvalue(rng.normal(size=40), rng) > 0.01
    adj = selection.holm({"a": 0.01, "b": 0.04, "c": 0.03})
    assert adj == {"a": 0.03, "c": 0.06, "b": 0.06}


def test_parts_become_json_by_their_fields():
    # a part's fields are its JSON keys, in order; an optional key is left out when None
    from dataclasses import replace
    from limbstiff.diagnosis.parts import After, Mechanics, StiffnessBias, TrialBias
    from limbstiff.files.outputs import jsonable
    bias = StiffnessBias(per_trial={"t": TrialBias(60.0, None, None, error="why")}, median_relative=None)
    after = After(effects=(), gap_train=0.1, gap_heldout=float("nan"), shrink_heldout=None,
                  shrink_heldout_interval=(0.0, 0.0), params={}, units={}, stiffness_walk=(1.0,), mechanics=None,
                  stiffness_bias=bias)
    data = jsonable(after)
    assert list(data) == ["effects", "gap_train", "gap_heldout", "shrink_heldout", "shrink_heldout_interval", "params",
                          "units", "stiffness_walk", "stiffness_bias"]
    assert data["gap_heldout"] is None and data["effects"] == [] and data["shrink_heldout_interval"] == [0.0, 0.0]
    assert data["stiffness_bias"] == {"per_trial": {"t": {"nominal": 60.0, "corrected": None, "relative": None,
                                                          "error": "why"}}, "median_relative": None}
    assert list(jsonable(TrialBias(60.0, 59.0, 60 / 59 - 1))) == ["nominal", "corrected", "relative"]
    with_mechanics = jsonable(replace(after, mechanics={"t": Mechanics(0.01, 1.0)}))
    assert list(with_mechanics)[-2:] == ["mechanics", "stiffness_bias"]
    assert with_mechanics["mechanics"] == {"t": {"inertia": 0.01, "damping": 1.0}}


def test_a_trials_own_selection_becomes_json_by_its_fields():
    from limbstiff.diagnosis.per_trial import TrialEffect, TrialSelection
    from limbstiff.diagnosis.per_trial import disagreements
    from limbstiff.files.outputs import jsonable
    reflex = TrialEffect(effect="reflex", step=1, shrink_heldout=0.7, share_of_nominal_gap=0.7,
                         params={"delay": 0.04, "gain": 0.3}, units={"delay": "s", "gain": "N·m·s/rad"})
    alone = (TrialSelection(trial="elbow", diagnosis=("reflex",), agrees=False, effects=(reflex,), gap_heldout=0.01,
                            shrink_heldout=0.7),
             TrialSelection(trial="wrist", diagnosis=(), agrees=True, effects=(), gap_heldout=0.002,
                            shrink_heldout=0.0))
    data = jsonable(list(alone))
    assert list(data[0]) == ["trial", "diagnosis", "agrees", "effects", "gap_heldout", "shrink_heldout"]
    assert list(data[0]["effects"][0]) == ["effect", "step", "shrink_heldout", "share_of_nominal_gap", "params",
                                           "units"]
    assert data[1]["diagnosis"] == [] and data[1]["effects"] == []
    # the warning names the trials that differ and their effects, not those that agree, and says what to do
    (text,) = disagreements((), alone)
    assert "elbow alone: reflex" in text and "wrist" not in text and "separately" in text
    assert disagreements((), alone[1:]) == ()


# --- the library: effects as objects --------------------------------------------------------------

def test_every_effect_knows_its_parameters_grid_and_removal():
    from limbstiff.analysis import analyze
    from limbstiff.effects.channels import channels_from
    from limbstiff.effects.kinds import Scales
    trial = simulate("ankle", seed=3, params={"duration": 8.0}, effect="time_delay",
                     effect_params={"delay": 0.02})
    proto = Protocol(inertia=float(trial.metadata["nominal_inertia"]),
                     damping=float(trial.metadata["nominal_damping"]))
    ch = channels_from(trial, analyze(trial, proto, seed=0))
    scales = Scales.of([ch])
    for name, eff in CANDIDATES.items():
        assert isinstance(eff, ModelEffect) and eff.name == name and eff.description and eff.grid_reason
        shape = eff.grid(scales)[0]
        eff.evaluate(ch, shape)
        coef = np.ones(len(eff.amplitudes))
        corr = remove(ch, [(eff, shape, coef)])
        assert set(eff.params(shape, coef)) == set(shape) | set(eff.amplitudes)
        assert set(eff.units_of(eff.params(shape, coef))) <= set(eff.units) | {"fraction"}
        if eff.kind == "mechanics":
            assert corr.angle is None and corr.torque is None
            assert corr.inertia + corr.damping == pytest.approx(ch.inertia + ch.damping + 1.0)
        elif eff.corrects_channel:
            assert (corr.angle is None) != (corr.torque is None)
        else:
            assert corr.angle is None and corr.torque is not None
    # the delay's correction advances the recorded torque by the delay
    corr = CANDIDATES["time_delay"].correction(ch, {"delay": 0.02}, np.zeros(0))
    k = int(round(0.02 * ch.fs))
    np.testing.assert_allclose(corr.torque[:-k], ch.raw_torque[k:], atol=1e-9)


@pytest.mark.slow
def test_a_new_effect_is_one_object():
    # a made-up torque ∝ y³ (a hardening spring is a stiffness, which the model's static spring
    # holds): the library is a plain dict of objects, and diagnose asks the objects for everything
    cubic = TorqueEffect(name="cubic", description="a torque ∝ y³", amplitudes=("coefficient",),
                         grid=lambda s: [{}], grid_reason="no shape parameter",
                         torque=lambda ch, sh: ch.angle ** 3, smooth=True, units={"coefficient": "N·m/rad³"})
    trial = simulate("ankle", seed=5, params={"duration": 8.0}, effect="coulomb_friction")
    d = diagnose([trial], seed=0, effects={"cubic": cubic, "coulomb_friction": CANDIDATES["coulomb_friction"]})
    assert {c.effect for c in d.candidates if c.evidence.tried} == {"cubic", "coulomb_friction"}
    assert d.candidate("cubic").units == {"coefficient": "N·m/rad³"}
    assert d.diagnosis == ("coulomb_friction",)


# --- every candidate on a small seeded trial --------------------------------------------------------

def _trial(joint, effect, seed, factor=1.6, duration=15.0, **extra):
    params = None
    if effect is not None:
        params = dict(effect_defaults(effect, joint, seed=seed, params={"duration": duration}))
        for key in {"coulomb_friction": ("friction_torque",), "quadratic_damping": ("coefficient",),
                    "hysteresis": ("amplitude",), "backlash": ("width",), "time_delay": ("delay",),
                    "reflex": ("gain",), "gravity": ("mgl",), "sensor_drift": ("slope", "random_walk"),
                    "inertia_error": ("fraction",), "damping_error": ("fraction",)}[effect]:
            params[key] *= factor
        params.update(extra)
    return simulate(joint, seed=seed, params={"duration": duration}, effect=effect, effect_params=params)


def _diagnose(trial):
    proto = Protocol(inertia=float(trial.metadata["nominal_inertia"]), damping=float(trial.metadata["nominal_damping"]))
    return diagnose([trial], proto, seed=1)


# Why the bounds: at 1.6× the default size each effect's torque is several times the sensor noise, so
# most of the held-out gap is the effect's; 0.5 is the target. Backlash on the ankle's
# noise-free encoder is reconstructed from the recorded angle's dwell times, also above 0.5.
CASES = [
    ("ankle", "coulomb_friction", 11, {}),
    ("ankle", "quadratic_damping", 12, {}),
    ("elbow", "hysteresis", 13, {}),
    ("ankle", "backlash", 14, {}),
    ("ankle", "time_delay", 15, {}),
    ("ankle", "reflex", 16, {"direction": -1.0, "delay": 0.065}),
    ("ankle", "inertia_error", 18, {}),
    ("ankle", "damping_error", 19, {}),
]


@pytest.mark.slow
@pytest.mark.parametrize("joint,effect,seed,extra", CASES, ids=[f"{c[0]}-{c[1]}" for c in CASES])
def test_the_right_effect_is_found(joint, effect, seed, extra):
    trial = _trial(joint, effect, seed, **extra)
    d = _diagnose(trial)
    first = d.diagnosis[0] if d.diagnosis else None
    ambiguous = {a.effects[1] for a in d.ambiguities if a.effects[0] == first}
    assert first == effect or effect in ambiguous, (d.diagnosis, d.ambiguities)
    c = d.candidate(effect)
    assert c.shrink_heldout > 0.5
    lo, hi = c.shrink_interval
    assert lo <= c.shrink_heldout <= hi
    assert c.evidence.significant and c.evidence.relevant
    if effect == "reflex":
        assert c.params["direction"] == extra.get("direction", 1.0)
        assert c.params["delay"] == pytest.approx(extra["delay"], abs=0.006)
    if effect == "time_delay":
        assert c.params["delay"] == pytest.approx(float(trial.metadata["effect.delay"]), abs=0.0015)


@pytest.mark.slow
def test_gravity_and_drift_are_held_by_the_model_and_said_so():
    # a torque of the angle alone is a (generalized) stiffness, a slow offset drift a walk of the
    # elastic torque: neither is a candidate, neither is diagnosed, and the notes say why
    trial = _trial("ankle", "gravity", 22)
    d = _diagnose(trial)
    assert d.diagnosis == ()
    for name in ("gravity", "sensor_drift"):
        c = d.candidate(name)
        assert not c.evidence.tried and c.shrink_heldout == 0.0 and c.evidence.reason
    assert any(n.startswith("gravity") and "operating angle" in n for n in d.notes)
    assert any(n.startswith("sensor drift") for n in d.notes)
    # the stiffness the tool reports includes −mgl (20 % × 1.6 of the stiffness here): the bias the
    # effect causes is real, and the diagnosis cannot see it
    assert d.trials[0].stiffness_median < 0.8 * np.median(trial.stiffness_true)


@pytest.mark.slow
def test_identified_mechanics_are_fitted_with_the_effects():
    # m and b identified: an error of either is not a separate effect (dropped, and said so), and
    # each candidate's model carries its own m and b
    trial = _trial("ankle", "reflex", 16, direction=-1.0, delay=0.065)
    d = diagnose([trial], Protocol(), seed=1)
    names = {c.effect for c in d.candidates if c.evidence.tried}
    assert not names & {"inertia_error", "damping_error"}
    assert any("inertia_error and damping_error are not separate effects" in n for n in d.notes)
    assert d.diagnosis[:1] == ("reflex",)
    c = d.candidate("reflex")
    assert c.params["delay"] == pytest.approx(0.065, abs=0.006) and c.params["direction"] == -1.0
    m, b = float(trial.metadata["nominal_inertia"]), float(trial.metadata["nominal_damping"])
    fitted = c.mechanics[trial.name]
    # the simulator's own m and b: identified within 10 % once the reflex is in the model
    assert fitted.inertia == pytest.approx(m, rel=0.1) and fitted.damping == pytest.approx(b, rel=0.1)
    # the stiffness summary.csv reports, and the analysis's with the reflex in the model, each with
    # its interval: the latter within 10 % of the simulator's (the tolerance)
    (row,) = d.stiffness
    assert row.effects == ("reflex",) and row.reported.lo <= row.reported.median <= row.reported.hi
    assert row.with_effects.median == pytest.approx(np.median(trial.stiffness_true), rel=0.1)
    assert row.with_effects.lo < row.with_effects.median < row.with_effects.hi
    assert row.damping_with_effects.median == pytest.approx(b, rel=0.1)
    # the result protocol: diagnosis.json's dict, the candidates' table, their bars, the answer in words
    from .support.result_protocol import check_protocol
    data, frame, text = check_protocol(d)
    assert data["diagnosis"][:1] == ["reflex"] and list(frame["effect"]) == [c.effect for c in d.candidates]
    assert frame.set_index("effect").loc["reflex", "chosen"] and "reflex" in text.splitlines()[0]
    assert f"{row.with_effects.median:.4g}" in text
    with pytest.raises(TypeError, match="write_pdf"):
        d.plot("diagnosis.pdf")                   # the PDF is write_pdf's, as plot(path) wrote it before


@pytest.mark.slow
@pytest.mark.parametrize("joint,seed", [("elbow", 31), ("ankle", 32)])
def test_clean_trials_get_an_empty_diagnosis(joint, seed):
    d = _diagnose(_trial(joint, None, seed))
    assert d.diagnosis == ()
    assert d.after.shrink_heldout == 0.0 and d.after.stiffness_bias is None
    assert d.gap_heldout < 0.01
    assert d.per_trial == () and d.disagreements == ()


# --- command line ------------------------------------------------------------------------------------

@pytest.mark.slow
def test_cli_writes_the_contract(tmp_path):
    path = write_trial(_trial("ankle", "reflex", 41, duration=15.0), tmp_path / "t.csv")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["diagnose", str(path), "--out", str(out), "--inertia", "0.015",
                                    "--damping", "1.0", "--seed", "3"])
    assert res.exit_code == 0, res.output
    data = json.loads((out / "diagnosis.json").read_text())
    assert {"gap", "where", "candidates", "diagnosis"} <= set(data)
    assert {"metric", "train", "heldout"} <= set(data["gap"])
    assert data["diagnosis"][0] == "reflex" and data["seed"] == 3
    assert data["software"] == software()          # the one provenance block, as summary.json's
    names = {c["effect"] for c in data["candidates"]}
    # every effect name of the interface has its entry; gravity and drift say why they are not tried
    assert {"coulomb_friction", "quadratic_damping", "hysteresis", "backlash", "time_delay", "reflex", "gravity",
            "sensor_drift", "inertia_error", "damping_error"} == names
    assert {c["effect"] for c in data["candidates"] if not c["evidence"]["tried"]} == {"gravity", "sensor_drift"}
    for c in data["candidates"]:
        assert {"effect", "params", "units", "gap_train", "gap_heldout", "shrink_heldout", "shrink_heldout_interval",
                "evidence", "stiffness_bias"} <= set(c)
        assert set(c["units"]) == {k for k, v in c["params"].items() if not isinstance(v, dict)}
    assert {"time", "frequency", "regime", "whiteness", "cross_correlation"} <= set(data["where"]["t"])
    assert {"speed", "reversal", "angle", "torque", "stiffness"} <= set(data["where"]["t"]["regime"])
    assert (out / "diagnosis.pdf").read_bytes()[:4] == b"%PDF"
    # one trial: its own selection is the diagnosis, so no per-trial block and nothing to disagree with
    assert data["per_trial"] == [] and data["disagreements"] == []
    (row,) = data["stiffness"]
    assert {"trial", "reported", "verdict", "effects", "with_effects", "verdict_with_effects", "note"} <= set(row)
    assert row["effects"] == ["reflex"] and {"median", "lo", "hi"} <= set(row["with_effects"])
    assert "disagree" not in res.output
    # --no-pdf into the same folder: the json again, and no report of the earlier run left beside it
    again = CliRunner().invoke(main, ["diagnose", str(path), "--out", str(out), "--inertia", "0.015", "--damping",
                                      "1.0", "--seed", "3", "--no-pdf", "--overwrite"])
    assert again.exit_code == 0, again.output
    assert json.loads((out / "diagnosis.json").read_text())["diagnosis"] == data["diagnosis"]
    assert not (out / "diagnosis.pdf").exists()


def test_cli_bad_input_is_one_line_and_exit_status(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,angle_rad,torque_Nm\n0,0,0\n0.001,nan,1\n")
    res = CliRunner().invoke(main, ["diagnose", str(bad), "--out", str(tmp_path / "o")])
    assert res.exit_code == 1
    lines = [ln for ln in res.output.splitlines() if ln.startswith("limbstiff: error")]
    assert lines and "bad.csv" in lines[0] and "Traceback" not in res.output
    assert not (tmp_path / "o" / "diagnosis.json").exists()
    res = CliRunner().invoke(main, ["diagnose", str(tmp_path / "missing.csv")])
    assert res.exit_code == 2 and "missing.csv" in res.output and "Traceback" not in res.output


# --- the nominal model: the analysis's Kalman model with the effects as measurement terms -------------

def _steps(seed=4, channels=3, n=400):
    from limbstiff.statespace.steps import channel_steps
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.02
    y = 0.1 * np.sin(2 * np.pi * 0.9 * t) + 0.05 * np.sin(2 * np.pi * 2.3 * t)
    torque = 40 * y + rng.normal(0, 0.2, n)
    chans = np.vstack([torque] + [rng.normal(0, 1, n) for _ in range(channels - 1)])
    return channel_steps(y, chans, scale_from=torque, step=0.02, deflection=y - y.mean())


def test_innovations_are_linear_in_the_channels():
    # the filter's gains do not depend on the data: the innovations of Σ w_c·channel_c are Σ w_c·e_c,
    # which is what lets every linear coefficient be fitted on the innovations (to rounding)
    from limbstiff.statespace.linear import innovations
    from limbstiff.statespace.noise import NoiseLevels
    from limbstiff.statespace.steps import channel_steps
    st = _steps()
    noise = NoiseLevels(0.05, 0.01, 30.0, 10.0)
    e, var = innovations(st, noise)
    w = np.array([1.0, -0.3, 0.7])
    combined = channel_steps(st.angle, (w @ st.channels)[None], scale_from=st.channels[0], step=st.step,
                             deflection=st.deflection)
    e1, var1 = innovations(combined, noise)
    np.testing.assert_allclose(e1[0], w @ e, atol=1e-9)
    np.testing.assert_allclose(var1, var)


@pytest.mark.slow
def test_a_pooled_diagnosis_shows_each_trials_own_selection(tmp_path):
    # an elbow with a reflex pooled with a clean wrist: pooled, the reflex is diluted (issue 34: a folder
    # of an elbow with a reflex, a wrist and an ankle said "effects: none"); each trial's own selection
    # says what it says alone, and the disagreement is a warning in the JSON and one line of the CLI
    from limbstiff.files import read_trial
    write_trial(simulate("elbow", seed=1, params={"duration": 12.0}, effect="reflex"), tmp_path / "a.csv")
    write_trial(simulate("wrist", seed=2, params={"duration": 12.0}), tmp_path / "b.csv")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["diagnose", str(tmp_path), "--out", str(out), "--seed", "4", "--jobs", "1"])
    assert res.exit_code == 0, res.output
    data = json.loads((out / "diagnosis.json").read_text())
    assert data["diagnosis"] == []
    alone = {s["trial"]: s for s in data["per_trial"]}
    assert list(alone) == ["a", "b"]
    assert alone["a"]["diagnosis"] == ["reflex"] and not alone["a"]["agrees"]
    assert alone["b"]["diagnosis"] == [] and alone["b"]["agrees"] and alone["b"]["shrink_heldout"] == 0.0
    (reflex,) = alone["a"]["effects"]
    assert reflex["effect"] == "reflex" and reflex["step"] == 1 and reflex["shrink_heldout"] > 0.5
    assert reflex["params"]["delay"] == pytest.approx(0.04, abs=0.006) and reflex["units"]["delay"] == "s"
    assert alone["a"]["shrink_heldout"] == pytest.approx(reflex["shrink_heldout"])
    (warning,) = data["disagreements"]
    assert "a alone: reflex" in warning and "b alone" not in warning and "separately" in warning
    lines = [ln for ln in res.output.splitlines() if "disagree" in ln]
    assert len(lines) == 1 and "a alone: reflex" in lines[0] and "separately" in lines[0]
    # the trial's own selection is its diagnosis alone (same library, seed and blocks)
    assert diagnose([read_trial(tmp_path / "a.csv")], seed=4).diagnosis == ("reflex",)


@pytest.mark.slow
def test_cli_diagnoses_several_trials_in_processes(tmp_path):
    # --jobs 2: both trials read and analysed in worker processes, each reported once, in input order
    # in the outputs; a missing-channel file among them is one failed line, the others still diagnosed
    for i, seed in enumerate((51, 52)):
        write_trial(_trial("ankle", "coulomb_friction", seed, duration=5.0), tmp_path / f"t{i}.csv")
    (tmp_path / "t2.csv").write_text("time_s,angle_rad\n0,0\n0.001,0.1\n0.002,0.2\n")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["diagnose", str(tmp_path), "--out", str(out), "--inertia", "0.015",
                                    "--damping", "1.0", "--jobs", "2", "--no-pdf"])
    assert res.exit_code == 1, res.output
    assert sum("[" in ln and "/3]" in ln for ln in res.output.splitlines()) == 3
    data = json.loads((out / "diagnosis.json").read_text())
    assert [t["trial"] for t in data["trials"]] == ["t0", "t1"]
    assert len(data["failed"]) == 1 and "t2.csv" in data["failed"][0]
    assert [s["trial"] for s in data["per_trial"]] == ["t0", "t1"]


# --- trials from the independent simulator (tests/support/independent_trials.py, not the method's forms) ---

def _independent(tmp_path, name, form, joint, course, seed):
    from limbstiff.files import read_trial

    from .support import independent_trials as it
    truth = it.write_trial(it.TrialSpec(name=name, family="t", form=form, joint=joint, course=course, seed=seed,
                                        duration_s=20.0), tmp_path)
    proto = Protocol(inertia=truth["inertia"], damping=truth["damping"])
    return diagnose([read_trial(tmp_path / f"{name}.csv", proto)], proto, seed=0), truth


@pytest.mark.parametrize("form,joint,course,expected", [
    ("stribeck", "elbow", "ramp", ("coulomb_friction",)),          # Stribeck map, stiffness ramping 6 → 30
    ("quaddampsat", "ankle", "constant", ("quadratic_damping",)),  # c·v|v|/(1 + |v|/v_sat), not c·v|v|
    (None, "elbow", "cocontraction", ()),                           # clean, stiffness swinging ±50 %
])
@pytest.mark.slow
def test_effects_of_an_independent_simulator(tmp_path, form, joint, course, expected):
    # seeds outside the benchmark's (benchmarks/diagnose_independent.py uses 7100–7223), 20 s instead of 30
    seed = {"stribeck": 9001, "quaddampsat": 9002}.get(form, 9003)
    d, truth = _independent(tmp_path, "t", form, joint, course, seed=seed)
    assert d.diagnosis == expected, (d.diagnosis, truth["effect_params"])
    if expected:
        # the effects are 11–34 % of the torque's RMS, 2–6× its noise: most of the gap is theirs
        assert d.candidate(expected[0]).shrink_heldout > 0.5
