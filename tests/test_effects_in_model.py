"""Effects in the analysis's model (``--effect``) and the ``reflex`` check (issue 34, items 2 and 3).

The simulated elbow's reflex (limbstiff.simulate, effect ``reflex``): delay 40 ms, direction +1, gain
0.3·RMS torque/RMS velocity (0.287 N·m·s/rad on seed 1, in its metadata), m 0.06 kg·m², b 0.45
N·m·s/rad. Seeds here are below 100 (benchmarks/reflex_study.py uses its own generator).
"""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from limbstiff.analysis import analyze
from limbstiff.checks.reflex import WRONG_SHIFT, MechanicsMove, ReflexShift, amplitude_threshold, reflex_check
from limbstiff.cli import main
from limbstiff.effects.channels import Channels
from limbstiff.effects.in_model import IN_MODEL
from limbstiff.effects.kinds import Scales, filtered_torque
from limbstiff.effects.registry import CANDIDATES
from limbstiff.errors import TrialError
from limbstiff.files import write_trial
from limbstiff.filtered import filter_trial
from limbstiff.mechanics.likelihood import MechanicsProblem
from limbstiff.mechanics.least_squares import LeastSquaresFit
from limbstiff.protocol import MODEL_EFFECTS, Protocol, ProtocolError, protocol_from_dict
from limbstiff.simulate import simulate
from limbstiff.statespace.noise import NoiseLevels


@pytest.fixture(scope="module")
def reflex_elbow():
    return simulate("elbow", seed=1, params={"duration": 12}, effect="reflex")


def _error(result) -> float:
    return float(result.reference_error()["median"])


def test_the_protocols_effects_are_the_librarys_torque_effects():
    assert set(MODEL_EFFECTS) == set(IN_MODEL)


def test_protocol_key_and_its_errors():
    assert protocol_from_dict({"mechanics": {"effects": ["reflex"]}}).effects == ("reflex",)
    assert "effects" not in Protocol().to_dict()      # the settings hash of protocols without effects unchanged
    assert Protocol(effects=("reflex",)).to_dict()["effects"] == ["reflex"]
    for bad in (["backlash"], ["reflex", "reflex"], 3):
        with pytest.raises(ProtocolError, match="'effects' must be a list of distinct effects"):
            protocol_from_dict({"mechanics": {"effects": bad}})


def test_amplitudes_are_linear_coefficients_beside_m_and_b():
    # an exact linear torque f = m·ÿ + b·ẏ + a·φ + k·y with white noise: the conditional mean of
    # (m, b, a) recovers the truth within 4 of its own standard errors (the noise is the model's)
    rng = np.random.default_rng(3)
    n, dt = 8000, 0.002
    t = np.arange(n) * dt
    y = 0.1 * np.sin(2 * np.pi * 1.3 * t) + 0.05 * np.sin(2 * np.pi * 3.1 * t + 1)
    v, a = np.gradient(y, dt), np.gradient(np.gradient(y, dt), dt)
    phi = np.maximum(np.interp(t - 0.04, t, v), 0.0)
    truth = np.array([0.05, 0.4, 0.3])
    f = truth @ np.vstack([a, v, phi]) + 20.0 * y + 0.01 * rng.standard_normal(n)
    guess = LeastSquaresFit(inertia=0.05, damping=0.4, inertia_se=0.0, damping_se=0.0, window=1.0, residual_sd=0.01,
                            condition=1.0)
    problem = MechanicsProblem.build(y, v, a, f, sample_period=dt, decimation=1, motion_frequency=2.0, guess=guess,
                                     extra=phi[None])
    _, mean, cov = problem.conditional(NoiseLevels(1e-4, 1e-8, 1e-6, 1e-8).logs())
    assert len(mean) == 3
    assert np.all(np.abs(mean - truth) < 4 * np.sqrt(np.diag(cov)))


def test_reflex_check_thresholds():
    # Bonferroni over the grid: with 130 shapes each is tested at 0.05/260 two-sided, |z| > 3.6
    assert amplitude_threshold(130) == pytest.approx(3.55, abs=0.02)
    quiet = ReflexShift(amplitude_z=2.0, shapes_tried=130, stiffness=0.5, band=0.02, mechanics=(), description="")
    assert reflex_check(quiet).passed
    within = ReflexShift(amplitude_z=50, shapes_tried=130, stiffness=0.01, band=0.02, mechanics=(), description="")
    assert reflex_check(within).passed
    moved = ReflexShift(amplitude_z=50, shapes_tried=130, stiffness=0.01, band=0.02,
                        mechanics=(MechanicsMove("damping", 0.53, 0.45, True),), description="")
    assert not reflex_check(moved).passed and reflex_check(moved).severity == "caution"
    assert "damping 0.45 instead of 0.53" in reflex_check(moved).message
    # outside a narrow interval but by less than a tenth: not material (the real ankle z_df3: 3.6 %)
    slight = ReflexShift(amplitude_z=50, shapes_tried=130, stiffness=0.01, band=0.02,
                         mechanics=(MechanicsMove("damping", 1.37, 1.42, True),), description="")
    assert reflex_check(slight).passed
    wrong = ReflexShift(amplitude_z=50, shapes_tried=130, stiffness=-1.5 * WRONG_SHIFT, band=0.02, mechanics=(),
                        description="")
    assert reflex_check(wrong).severity == "unreliable" and "--effect reflex" in reflex_check(wrong).message


@pytest.mark.slow
def test_a_reflex_left_out_is_named_and_put_in_it_is_identified(reflex_elbow):
    gain = float(reflex_elbow.metadata["effect.gain"])
    plain = analyze(reflex_elbow, seed=1)
    check = plain.checks["reflex"]
    # left out, the reflex goes into b (0.53 against 0.45): the check fails and says what to do
    assert not check.passed and plain.verdict != "ok"
    assert "delay 40 ms" in check.message and "--effect reflex" in check.message
    fitted = analyze(reflex_elbow, seed=1, effects=("reflex",))
    (effect,) = fitted.identification.effects
    # the grid's delays are 5 ms apart: the simulator's 40 ms is on it
    assert effect.name == "reflex" and effect.shape["delay"] == pytest.approx(0.04)
    assert effect.shape["direction"] == 1.0
    # the simulator's reflex is not low-passed by activation dynamics, and its torque reads the true
    # velocity; the fitted gain within 5 % of it (its own interval is ~±1.5 % wide)
    assert effect.amplitude.median == pytest.approx(gain, rel=0.05)
    # m and b within 3 % of the simulator's (against 7 % and 18 % off without the reflex)
    assert fitted.inertia.median == pytest.approx(0.06, rel=0.03)
    assert fitted.damping.median == pytest.approx(0.45, rel=0.03)
    assert fitted.verdict == "ok" and _error(fitted) < 0.02
    # the amplitude's uncertainty is carried: the band is at least as wide as with the gain fixed
    assert fitted.identification.coefficient_covariance.shape == (3, 3)
    summary = fitted.summary()
    assert summary["details"]["identification"]["effects"][0]["name"] == "reflex"


@pytest.mark.slow
def test_m_and_b_given_the_amplitude_is_still_identified(reflex_elbow):
    fitted = analyze(reflex_elbow, seed=1, inertia=0.06, damping=0.45, effects=("reflex",))
    (effect,) = fitted.identification.effects
    assert fitted.identification.given and fitted.inertia.median == 0.06
    assert effect.amplitude.median == pytest.approx(float(reflex_elbow.metadata["effect.gain"]), rel=0.05)
    # m and b given, the reflex left out: 14 % off on this trial, and the check says so
    plain = analyze(reflex_elbow, seed=1, inertia=0.06, damping=0.45)
    assert _error(plain) > 0.1 and not plain.checks["reflex"].passed
    assert _error(fitted) < 0.02
    # the posterior page shows the gain's posterior, the only coefficient fitted
    import matplotlib.pyplot as plt
    from limbstiff.report.mechanics import mechanics_page
    fig = mechanics_page(fitted)
    assert any("reflex gain" in ax.get_xlabel() for ax in fig.axes)
    plt.close(fig)


def test_a_clean_trial_passes_the_reflex_check():
    result = analyze(simulate("elbow", seed=2, params={"duration": 12}), seed=2)
    assert result.checks["reflex"].passed and result.verdict == "ok"


def test_effects_need_the_external_variant_and_the_kalman_estimator(reflex_elbow):
    with pytest.raises(TrialError, match="kalman estimator only"):
        analyze(reflex_elbow, estimator="observer", effects=("reflex",))
    direct = simulate("paper-exp-spring", seed=1, params={"duration": 10})
    if direct.elastic_torque is not None:
        with pytest.raises(TrialError, match="direct variant"):
            analyze(direct, effects=("reflex",))


@pytest.mark.slow
def test_cli_effect_option(tmp_path, reflex_elbow):
    path = write_trial(reflex_elbow, tmp_path / "t.csv")
    res = CliRunner().invoke(main, ["analyze", str(path), "--out", str(tmp_path / "o"), "--no-pdf",
                                    "--effect", "reflex"])
    assert res.exit_code == 0, res.output
    data = json.loads((tmp_path / "o" / "t" / "summary.json").read_text())
    assert data["settings"]["effects"] == ["reflex"]
    assert data["details"]["identification"]["effects"][0]["shape"]["delay"] == pytest.approx(0.04)
    # one name as a string is one effect (not its letters)
    assert Protocol().override(effects=("reflex",)) == Protocol(effects="reflex")
    bad = CliRunner().invoke(main, ["analyze", str(path), "--effect", "backlash"])
    assert bad.exit_code == 2 and "backlash" in bad.output


@pytest.mark.slow
@pytest.mark.parametrize("effect", [None, "reflex"])
def test_the_screened_profile_keeps_the_exhaustive_best_shape(effect):
    # the screen (every shape's torque at a quarter or an eighth of the rate) only decides which shapes
    # are evaluated at the full rate: the best of all of them is among those, so the profile is the
    # exhaustive one to the bit
    import dataclasses
    from limbstiff.effects import in_model
    from limbstiff.effects.channels import Channels
    from limbstiff.effects.kinds import Scales
    from limbstiff.mechanics.identification import mechanics_problem
    trial = simulate("elbow", seed=5, params={"duration": 12}, effect=effect)
    result = analyze(trial, seed=0)
    ch = Channels.before_analysis(trial, result.filtered)
    problem, _ = mechanics_problem(result.filtered, given=None)
    noise = result.identification.noise_levels
    effect_ = in_model.CANDIDATES["reflex"]
    shapes = effect_.grid(in_model.Scales.of([ch]))
    kept = in_model._screened(ch, effect_, shapes, problem, noise.logs())
    assert len(kept) < len(shapes) / 4
    idx, logs = problem.steps.index, noise.logs()
    exhaustive = [in_model._shape_loglik(problem, logs, effect_.evaluate(ch, s).regressors[0][idx]) for s in shapes]
    assert shapes[int(np.argmax(exhaustive))] in kept
    coarse = ch.every(4, 1)
    assert coarse.fs == ch.fs / 4 and np.array_equal(coarse.velocity, ch.velocity[1::4])
    assert dataclasses.replace(coarse.filtered.chain, fs=ch.fs) == ch.chain


@pytest.mark.slow
def test_a_long_trials_shapes_are_screened_around_the_models_blocks():
    # a long ankle (corner ~64 Hz: no coarser rate qualifies) is identified on six blocks spread
    # over it; its shapes are screened on the samples near them only, and the exhaustive best shape
    # survives the screen (measured on 15–30 min ankles, elbows and wrists with and without a
    # reflex: the same profile, 5–8× cheaper on the ankles)
    from limbstiff.effects import in_model
    from limbstiff.effects.channels import Channels
    from limbstiff.effects.kinds import Scales
    from limbstiff.filtered import filter_trial
    from limbstiff.mechanics.identification import mechanics_problem
    from limbstiff.mechanics.likelihood import kalman_mechanics
    from limbstiff.protocol import Protocol
    trial = simulate("ankle", seed=4, params={"duration": 240.0}, effect="reflex")
    filtered = filter_trial(trial, Protocol())
    problem, guess = mechanics_problem(filtered)
    logs = kalman_mechanics(problem, guess=guess).noise.logs()
    ch = Channels.before_analysis(trial, filtered)
    rows = in_model._around_blocks(problem, ch)
    assert rows is not None and len(rows) < ch.n / 2
    assert np.all(np.isin(problem.steps.index, rows))
    effect = in_model.CANDIDATES["reflex"]
    shapes = effect.grid(in_model.Scales.of([ch]))
    kept = in_model._screened(ch, effect, shapes, problem, logs)
    assert len(kept) < len(shapes) / 4
    idx = problem.steps.index
    exhaustive = [in_model._shape_loglik(problem, logs, effect.evaluate(ch, s).regressors[0][idx]) for s in shapes]
    assert shapes[int(np.argmax(exhaustive))] in kept


def test_shapes_filtered_together_are_each_as_alone(reflex_elbow):
    # the probe filters its shapes' torques in blocks (TorqueEffect.columns): every row must be
    # the very torque the shape gives alone, so that the chosen shape cannot depend on the blocks
    ch = Channels.before_analysis(reflex_elbow, filter_trial(reflex_elbow, Protocol()))
    effect = CANDIDATES["reflex"]
    shapes = effect.grid(Scales.of([ch]))[::13]
    together = effect.columns(ch, shapes)
    for shape, row in zip(shapes, together):
        assert np.array_equal(filtered_torque(ch, effect.torque(ch, shape)), row)
    assert np.array_equal(ch.linear_part(together)[1], ch.linear_part(together[1]))
