"""Tests of limbstiff.simulate: scenarios, plants, effects, excitation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from limbstiff.simulate import (EFFECTS, SCENARIOS, describe_scenarios, effect_defaults,
                                simulate, simulate_with_truth, trial_scales)
from limbstiff.unmodelled import dahl, dahl_along, delay_signal, play
from limbstiff.effects.simulated import REFERENCE_SCALES
from limbstiff.simulate.excitation import (chirp, draw_binary_steps, draw_random_steps, gate,
                                           multisine, smoothed_steps)
from limbstiff.simulate.paper import EXP_SPRINGS
from limbstiff.simulate.plants import internal_step
from limbstiff.trial import Trial

#: Short trials for the fast tests.
SHORT = {name: {"duration": 3.0} for name in SCENARIOS}
TORQUE_DRIVEN = ["paper-vsa-hogan", "paper-vsa-feldman", "paper-vsa-exp", "elbow", "wrist"]
RANDOM = ["elbow", "ankle", "wrist", "ankle-coupled", "ankle-platform"]


def derivative(x, ts):
    """Fourth-order central difference (the two samples at each end are left 0)."""
    d = np.zeros_like(x)
    d[2:-2] = (x[:-4] - 8 * x[1:-3] + 8 * x[3:-1] - x[4:]) / (12 * ts)
    return d


def quiet(name, **extra):
    """Short, noise-free parameters."""
    return {**SHORT[name], "torque_noise": 0.0, **extra}


@pytest.fixture(scope="module")
def short_runs():
    return {name: simulate_with_truth(name, seed=3, params=SHORT[name]) for name in SCENARIOS}


@pytest.fixture(scope="module")
def long_links():
    return {name: simulate_with_truth(name)[1]
            for name in ("paper-vsa-hogan", "paper-vsa-feldman", "paper-vsa-exp")}


# --- scenarios --------------------------------------------------------------------------------

@pytest.mark.parametrize("name", list(SCENARIOS))
def test_scenario_returns_valid_trial(name, short_runs):
    trial, truth = short_runs[name]
    sc = SCENARIOS[name]
    assert isinstance(trial, Trial)
    assert trial.name == name
    expected_kind = "translational" if name == "paper-exp-spring" else "rotational"
    assert trial.kind == sc.kind == expected_kind
    assert trial.n_samples == int(round(3.0 * sc.defaults["fs"])) + 1
    assert trial.fs == pytest.approx(sc.defaults["fs"])
    assert trial.torque is not None and trial.stiffness_true is not None
    assert (trial.elastic_torque is not None) == (name == "paper-exp-spring")
    assert np.all(trial.stiffness_true > 0)
    meta = trial.metadata
    assert all(isinstance(v, str) for v in meta.values())
    assert meta["scenario"] == name and meta["seed"] == "3" and meta["effect"] == "none"
    for key, value in sc.defaults.items():
        assert f"param.{key}" in meta
    assert float(meta["param.duration"]) == 3.0
    assert "true_inertia" in meta
    assert sc.description and sc.doc


def test_common_parameters_everywhere():
    for sc in SCENARIOS.values():
        assert {"fs", "duration", "torque_noise"} <= set(sc.defaults)
        quant = "position_resolution" if sc.kind == "translational" else "encoder_counts"
        assert quant in sc.defaults


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_same_seed_same_arrays(name):
    a = simulate(name, seed=7, params={"duration": 1.0})
    b = simulate(name, seed=7, params={"duration": 1.0})
    for field in ("angle", "torque", "stiffness_true"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert dict(a.metadata) == dict(b.metadata)


@pytest.mark.parametrize("name", RANDOM)
def test_different_seeds_differ(name):
    a = simulate_with_truth(name, seed=1, params=quiet(name, duration=2.0))[1]
    b = simulate_with_truth(name, seed=2, params=quiet(name, duration=2.0))[1]
    assert not np.allclose(a.angle, b.angle)


def test_noise_differs_between_seeds_and_has_given_sd():
    params = {"duration": 2.0, "torque_noise": 0.01}
    a, ta = simulate_with_truth("paper-vsa-hogan", seed=1, params=params)
    b, _ = simulate_with_truth("paper-vsa-hogan", seed=2, params=params)
    assert not np.array_equal(a.torque, b.torque)
    np.testing.assert_array_equal(a.angle, b.angle)
    assert np.std(a.torque - ta.external_torque) == pytest.approx(0.01, rel=0.05)


def test_encoder_quantisation():
    trial, truth = simulate_with_truth("elbow", params={"duration": 1.0})
    q = 2 * math.pi / 8000
    np.testing.assert_allclose(trial.angle / q, np.round(trial.angle / q), atol=1e-6)
    assert np.max(np.abs(trial.angle - truth.angle)) <= q / 2 + 1e-12
    spring = simulate("paper-exp-spring", params={"duration": 1.0, "position_resolution": 1e-5})
    np.testing.assert_allclose(spring.angle / 1e-5, np.round(spring.angle / 1e-5), atol=1e-6)


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_stiffness_is_derivative_of_elastic_torque(name, short_runs):
    sc = SCENARIOS[name]
    setup = sc.build({**sc.defaults, **SHORT[name]}, np.random.default_rng(0))
    _, truth = short_runs[name]
    y, u = truth.angle[::10], truth.control[::10]
    if sc.kind == "rotational":       # also well outside the motion
        y = np.concatenate([y, np.linspace(-0.2, 0.2, y.size)])
        u = np.concatenate([u, u])
    d = 1e-6 if sc.kind == "rotational" else 1e-8
    s = setup.joint.elastic_torque
    numeric = (s(y + d, u, np) - s(y - d, u, np)) / (2 * d)
    np.testing.assert_allclose(setup.joint.stiffness(y, u, np), numeric, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(truth.stiffness, setup.joint.stiffness(
        truth.angle, truth.control, np))


@pytest.mark.parametrize("name", TORQUE_DRIVEN)
def test_ode_solution_satisfies_equation_of_motion(name, short_runs):
    trial, truth = short_runs[name]
    ts = trial.sample_period
    y, v = truth.angle, truth.velocity
    inner = slice(2, -2)
    np.testing.assert_allclose(derivative(y, ts)[inner], v[inner], atol=1e-4 * np.max(np.abs(v)))
    acc = derivative(v, ts)
    np.testing.assert_allclose(acc[inner], truth.acceleration[inner],
                               atol=1e-4 * np.max(np.abs(acc)))
    residual = (truth.inertia * acc + truth.damping_torque + truth.elastic_torque
                + truth.effect_torque - truth.external_torque)
    assert np.max(np.abs(residual[inner])) < 1e-4 * np.std(truth.external_torque)
    jerk = derivative(truth.acceleration, ts)
    np.testing.assert_allclose(jerk[inner], truth.jerk[inner], atol=1e-3 * np.max(np.abs(jerk)))


@pytest.mark.parametrize("name", ["paper-exp-spring", "ankle", "ankle-platform"])
def test_position_drive_derivatives_are_exact(name, short_runs):
    trial, truth = short_runs[name]
    ts = trial.sample_period
    for low, high in (("angle", "velocity"), ("velocity", "acceleration"),
                      ("acceleration", "jerk")):
        numeric = derivative(getattr(truth, low), ts)[2:-2]
        np.testing.assert_allclose(numeric, getattr(truth, high)[2:-2],
                                   atol=1e-3 * np.max(np.abs(getattr(truth, high))))
    external = (truth.inertia * truth.acceleration + truth.damping_torque
                + truth.elastic_torque)
    np.testing.assert_allclose(truth.external_torque, external)


@pytest.mark.parametrize("effect", ["reflex", "hysteresis", "coulomb_friction", "gravity",
                                    "inertia_error", "damping_error", "quadratic_damping"])
def test_ode_with_effect_satisfies_equation_of_motion(effect):
    trial, truth = simulate_with_truth("elbow", params=quiet("elbow", duration=2.0),
                                       effect=effect)
    acc = derivative(truth.velocity, trial.sample_period)
    residual = (truth.inertia * acc + truth.damping_torque + truth.elastic_torque
                + truth.effect_torque - truth.external_torque)
    # Finite differences are poor only at the kinks of friction/reflex (reversals, onsets).
    assert np.max(np.abs(residual[2:-2])) < 1e-2 * np.std(truth.external_torque)
    assert np.median(np.abs(residual[2:-2])) < 1e-5 * np.std(truth.external_torque)
    # Convergence: a 4× smaller internal step gives the same motion.
    used = {k.split(".", 1)[1]: float(v) for k, v in trial.metadata.items()
            if k.startswith("effect.")}
    _, fine = simulate_with_truth("elbow", params=quiet("elbow", duration=2.0, fs=4000.0),
                                  effect=effect, effect_params=used)
    assert fine.internal_step == truth.internal_step / 4
    np.testing.assert_allclose(fine.angle[::4], truth.angle,
                               atol=1e-5 * np.max(np.abs(truth.angle)))


def test_internal_step_bounds():
    h, sub = internal_step(1000.0, 0.05, 1.9, 0.4)
    assert h <= 1e-3 / 4 and sub * h == pytest.approx(1e-3)
    h, sub = internal_step(100.0, 0.001, 400.0, 0.0)     # f_n = 100 Hz
    assert h <= 1.0 / (20 * math.sqrt(400.0 / 0.001) / (2 * math.pi)) + 1e-15


# --- paper scenarios ----------------------------------------------------------------------------

def test_exp_spring_deformation_and_springs():
    for spring, (a, b) in EXP_SPRINGS.items():
        trial, truth = simulate_with_truth("paper-exp-spring",
                                           params={"spring": spring, "duration": 5.0})
        y = truth.angle
        assert y.min() == pytest.approx(0.0025, abs=1e-9)
        assert y.max() == pytest.approx(0.0225, abs=1e-6)
        assert y[0] == pytest.approx(0.0025) and truth.velocity[0] == pytest.approx(0.0)
        np.testing.assert_allclose(trial.torque, trial.elastic_torque)
        np.testing.assert_allclose(truth.elastic_torque, a * np.exp(100 * b * y))
        np.testing.assert_allclose(truth.stiffness, 100 * a * b * np.exp(100 * b * y))
        setup = SCENARIOS["paper-exp-spring"].build(
            {**SCENARIOS["paper-exp-spring"].defaults, "spring": spring}, None)
        assert setup.joint.elastic_torque(0.02, 0.0, math) == pytest.approx(2.7 * b)
        assert trial.metadata["sweep"] == "logarithmic"


@pytest.mark.slow
def test_vsa_motion_ranges_match_documentation(long_links):
    for name in ("paper-vsa-hogan", "paper-vsa-feldman"):
        truth = long_links[name]
        assert 0.025 < np.max(np.abs(truth.angle)) <= 0.031
        assert np.max(np.abs(truth.angle[:2000])) < 0.023       # quasi-static start
        assert np.max(np.abs(truth.velocity)) <= 0.16
        assert np.all(truth.stiffness > 0.35)
        np.testing.assert_allclose(truth.generalized_damping, 2.0 * np.abs(truth.velocity))
        assert truth.inertia == 0.05
    hogan, feldman = long_links["paper-vsa-hogan"], long_links["paper-vsa-feldman"]
    assert hogan.stiffness.min() == pytest.approx(0.4, abs=0.01)
    assert hogan.stiffness.max() == pytest.approx(1.7, abs=0.01)
    assert feldman.stiffness.min() == pytest.approx(0.6 * math.pi / 3 - 0.1, abs=0.01)
    assert feldman.stiffness.max() == pytest.approx(0.6 * math.pi - 0.1, abs=0.01)
    exp = long_links["paper-vsa-exp"]
    assert np.max(np.abs(exp.angle)) <= 0.013
    assert np.max(np.abs(exp.velocity)) <= 0.07
    pause = (exp.time > 11.5) & (exp.time < 20.0)
    assert np.max(np.abs(exp.angle[pause])) < 1e-3
    assert exp.stiffness[-1] / exp.stiffness[0] > 8


def test_include_elastic_records_elastic_torque():
    trial, truth = simulate_with_truth("paper-vsa-feldman",
                                       params={"duration": 2.0, "include_elastic": 1})
    assert trial.variant == "direct"
    np.testing.assert_allclose(trial.elastic_torque, truth.elastic_torque)
    assert simulate("paper-vsa-feldman", params={"duration": 2.0}).variant == "external"


# --- limbs ------------------------------------------------------------------------------------

def test_elbow_amplitude_ramp_and_pause():
    trial, truth = simulate_with_truth("elbow", params={"duration": 20.0, "pause_start": 12.0,
                                                        "pause_duration": 3.0})
    assert 0.03 < np.max(np.abs(truth.angle)) < 0.06
    assert truth.stiffness[0] == pytest.approx(6.0)
    assert truth.stiffness[-1] == pytest.approx(30.0)
    quiet_part = (truth.time > 12.1) & (truth.time < 14.9)
    assert np.all(truth.external_torque[quiet_part] == 0)
    assert trial.metadata["true_inertia"] == "0.06" and trial.metadata["true_damping"] == "0.45"


@pytest.mark.parametrize("name, extra", [
    ("elbow", {"stiffness_nonlinearity": 50.0, "rest_angle": 0.3, "duration": 2.0}),
    ("ankle", {"stiffness_variation": 0.3, "variation_period": 1.0, "duration": 2.0}),
])
def test_nonlinear_and_varying_stiffness(name, extra):
    trial, truth = simulate_with_truth(name, params=extra)
    setup = SCENARIOS[name].build({**SCENARIOS[name].defaults, **extra}, np.random.default_rng(0))
    y, u, d = truth.angle, truth.control, 1e-6
    s = setup.joint.elastic_torque
    np.testing.assert_allclose(truth.stiffness, (s(y + d, u, np) - s(y - d, u, np)) / (2 * d),
                               rtol=1e-6)
    assert np.ptp(truth.stiffness) > 0.1 * np.mean(truth.stiffness) or name == "elbow"
    if name == "elbow":
        assert abs(np.mean(truth.angle) - 0.3) < 0.01
        assert np.max(truth.stiffness) > 6.0 * 1.05           # stiffening away from rest
        acc = derivative(truth.velocity, trial.sample_period)
        residual = (truth.inertia * acc + truth.damping_torque + truth.elastic_torque
                    - truth.external_torque)
        assert np.max(np.abs(residual[2:-2])) < 1e-4 * np.std(truth.external_torque)


def test_ankle_perturbation():
    _, truth = simulate_with_truth("ankle", params={"duration": 20.0})
    assert 0.025 < np.max(np.abs(truth.angle)) <= 0.03 + 1e-9
    assert 0.5 < np.max(np.abs(truth.velocity)) < 5.0
    np.testing.assert_allclose(truth.stiffness, 60.0)


# --- effects ----------------------------------------------------------------------------------

def test_effect_metadata_and_name():
    trial = simulate("elbow", params={"duration": 1.0}, effect="reflex",
                     effect_params={"gain": 0.5})
    assert trial.name == "elbow-reflex"
    assert trial.metadata["effect"] == "reflex" and trial.metadata["effect_kind"] == "dynamics"
    assert trial.metadata["effect.gain"] == "0.5" and trial.metadata["effect.delay"] == "0.04"
    assert set(EFFECTS) >= {"coulomb_friction", "quadratic_damping", "hysteresis", "backlash",
                            "time_delay", "reflex", "gravity", "sensor_drift",
                            "inertia_error", "damping_error"}
    for effect in EFFECTS.values():
        assert effect.kind in ("dynamics", "measurement") and effect.description


def test_one_registry_for_simulator_and_model():
    from dataclasses import replace
    from limbstiff.effects.registry import CANDIDATES, IN_MODEL
    from limbstiff.protocol import MODEL_EFFECTS
    assert CANDIDATES == {n: e.model for n, e in EFFECTS.items() if e.model is not None}
    assert set(EFFECTS) - set(CANDIDATES) == {"gravity", "sensor_drift"}
    assert all((e.model is None) == bool(e.held_by_nominal) for e in EFFECTS.values())
    assert IN_MODEL == MODEL_EFFECTS
    reflex = EFFECTS["reflex"]
    with pytest.raises(ValueError, match="holds the model of"):
        replace(reflex, model=CANDIDATES["hysteresis"])
    with pytest.raises(ValueError, match="one of them"):
        replace(reflex, model=None)


def test_elbow_reference_defaults():
    scales = trial_scales(simulate_with_truth("elbow", seed=0)[1])
    assert set(scales) == set(REFERENCE_SCALES)
    for key, value in scales.items():
        assert REFERENCE_SCALES[key] == pytest.approx(value, rel=0.001)
    for effect in EFFECTS.values():
        for key, value in effect.defaults_for(scales).items():
            assert effect.defaults[key] == pytest.approx(value, rel=0.01)
    sized = effect_defaults("reflex", "ankle", params={"duration": 5.0})
    assert sized["delay"] == 0.04 and 0.5 < sized["gain"] < 2.0


def test_time_delay_shifts_cross_correlation():
    trial, truth = simulate_with_truth("ankle", params=quiet("ankle", duration=10.0),
                                       effect="time_delay", effect_params={"delay": 0.025})
    a = truth.external_torque - truth.external_torque.mean()
    b = trial.torque - trial.torque.mean()
    lags = np.arange(-60, 61)
    xc = [np.dot(a[60:-60], np.roll(b, -k)[60:-60]) for k in lags]
    assert lags[int(np.argmax(xc))] == 25
    np.testing.assert_array_equal(trial.angle, truth.angle)


@pytest.mark.parametrize("name", ["ankle", "elbow"])
@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_reflex_after_delay_in_stretch_direction_only(name, direction):
    trial, truth = simulate_with_truth(name, params=quiet(name), effect="reflex",
                                       effect_params={"direction": direction})
    delay = float(trial.metadata["effect.delay"])
    lag = int(round(delay * trial.fs))
    r, v = truth.effect_torque, truth.velocity
    assert np.all(r[:lag + 1] == 0)
    delayed = np.concatenate([np.zeros(lag), v[:-lag]])
    assert np.all(direction * r >= 0)
    assert np.all(r[direction * delayed <= 0] == 0)
    stretch = direction * delayed > 1e-3
    np.testing.assert_allclose(r[stretch], float(trial.metadata["effect.gain"]) * delayed[stretch],
                               rtol=1e-9)
    ratio = np.std(r) / np.std(truth.external_torque)
    assert 0.1 < ratio < 0.3


def test_coulomb_friction_has_sign_of_velocity():
    nominal = simulate("ankle", params=quiet("ankle"))
    trial, truth = simulate_with_truth("ankle", params=quiet("ankle"), effect="coulomb_friction")
    extra = trial.torque - nominal.torque
    v = truth.velocity
    moving = np.abs(v) > 0.05
    assert np.all(np.sign(extra[moving]) == np.sign(v[moving]))
    assert np.max(np.abs(extra)) <= float(trial.metadata["effect.friction_torque"]) + 1e-12
    # Torque drive: friction slows the joint down.
    _, free = simulate_with_truth("elbow", params=quiet("elbow"))
    _, rubbing = simulate_with_truth("elbow", params=quiet("elbow"), effect="coulomb_friction")
    assert np.std(rubbing.velocity) < np.std(free.velocity)
    assert np.all(rubbing.effect_torque[np.abs(rubbing.velocity) > 0.05]
                  * rubbing.velocity[np.abs(rubbing.velocity) > 0.05] > 0)


def test_quadratic_damping_and_gravity_torques():
    _, truth = simulate_with_truth("ankle", params=quiet("ankle"), effect="quadratic_damping",
                                   effect_params={"coefficient": 2.0})
    v = truth.velocity
    np.testing.assert_allclose(truth.effect_torque, 2.0 * v * np.abs(v))
    _, free = simulate_with_truth("elbow", params=quiet("elbow"))
    _, heavy = simulate_with_truth("elbow", params=quiet("elbow"), effect="gravity")
    np.testing.assert_allclose(heavy.effect_torque, -1.2 * np.sin(heavy.angle))
    assert np.std(heavy.angle) > np.std(free.angle)      # gravity makes it look softer


def test_hysteresis_dissipates_and_saturates():
    _, truth = simulate_with_truth("ankle", params=quiet("ankle"), effect="hysteresis",
                                   effect_params={"amplitude": 0.1, "characteristic_angle": 0.003})
    z, y = truth.effect_torque, truth.angle
    assert np.max(np.abs(z)) <= 0.1 + 1e-12 and np.max(np.abs(z)) > 0.09
    assert np.sum(z[:-1] * np.diff(y)) > 0                    # positive work: a loop
    _, tdrive = simulate_with_truth("elbow", params=quiet("elbow"), effect="hysteresis")
    z, y = tdrive.effect_torque, tdrive.angle
    assert np.sum(z[:-1] * np.diff(y)) > 0


def test_backlash_dead_band():
    trial, truth = simulate_with_truth("ankle", params=quiet("ankle"), effect="backlash",
                                       effect_params={"width": 0.004})
    gap = trial.angle - truth.angle
    assert np.max(np.abs(gap)) <= 0.002 + 1e-12 and np.max(np.abs(gap)) > 0.0019
    np.testing.assert_array_equal(trial.torque, truth.external_torque)
    np.testing.assert_array_equal(play(np.array([0.0, 0.5, 1.0, 0.8, 0.2]), 0.4),
                                  [0.0, 0.3, 0.8, 0.8, 0.4])


def test_sensor_drift():
    params = quiet("ankle", duration=10.0)
    trial, truth = simulate_with_truth("ankle", params=params, effect="sensor_drift",
                                       effect_params={"slope": 0.01, "random_walk": 0.0})
    np.testing.assert_allclose(trial.torque - truth.external_torque, 0.01 * truth.time,
                               atol=1e-12)
    a = simulate("ankle", seed=1, params=params, effect="sensor_drift")
    b = simulate("ankle", seed=2, params=params, effect="sensor_drift")
    da = a.torque - simulate("ankle", seed=1, params=params).torque
    db = b.torque - simulate("ankle", seed=2, params=params).torque
    assert not np.allclose(da, db)
    assert np.max(np.abs(np.diff(da, 2))) < 1e-6              # smooth, low-frequency


def test_inertia_and_damping_errors():
    nominal = simulate_with_truth("ankle", params=quiet("ankle"))[1]
    trial, truth = simulate_with_truth("ankle", params=quiet("ankle"), effect="inertia_error")
    np.testing.assert_allclose(truth.external_torque - nominal.external_torque,
                               0.2 * 0.015 * nominal.acceleration, atol=1e-9)
    assert trial.metadata["param.inertia"] == "0.015"
    assert trial.metadata["nominal_inertia"] == "0.015"
    assert float(trial.metadata["true_inertia"]) == pytest.approx(0.018)
    trial, truth = simulate_with_truth("ankle", params=quiet("ankle"), effect="damping_error",
                                       effect_params={"fraction": -0.5})
    np.testing.assert_allclose(truth.external_torque - nominal.external_torque,
                               -0.5 * 1.0 * nominal.velocity, atol=1e-9)
    assert float(trial.metadata["true_damping"]) == pytest.approx(0.5)
    assert trial.metadata["nominal_damping"] == "1"
    hogan = simulate("paper-vsa-hogan", params={"duration": 1.0}, effect="damping_error")
    assert float(hogan.metadata["true_quadratic_damping"]) == pytest.approx(1.3)


@pytest.mark.parametrize("effect", list(EFFECTS))
def test_every_effect_changes_the_recording(effect):
    base = simulate("paper-vsa-hogan", params={"duration": 2.0})
    trial = simulate("paper-vsa-hogan", params={"duration": 2.0}, effect=effect)
    assert not (np.array_equal(base.angle, trial.angle)
                and np.array_equal(base.torque, trial.torque))


# --- errors -----------------------------------------------------------------------------------

def test_unknown_names_and_parameters():
    with pytest.raises(ValueError, match="available: paper-exp-spring"):
        simulate("knee")
    with pytest.raises(ValueError, match="available: coulomb_friction"):
        simulate("elbow", effect="magic")
    with pytest.raises(ValueError, match="accepted: .*duration"):
        simulate("elbow", params={"durration": 1.0})
    with pytest.raises(ValueError, match="accepted: delay, direction, gain"):
        simulate("elbow", effect="reflex", effect_params={"lag": 0.04})
    with pytest.raises(ValueError, match="without an effect"):
        simulate("elbow", effect_params={"gain": 1.0})
    with pytest.raises(ValueError, match="spring"):
        simulate("paper-exp-spring", params={"spring": 4})
    with pytest.raises(ValueError, match="direction"):
        simulate("ankle", effect="reflex", effect_params={"direction": 0.5})
    with pytest.raises(ValueError, match="fs"):
        simulate("ankle", params={"fs": 0})
    text = describe_scenarios()
    assert all(name in text for name in SCENARIOS) and "reflex" in text


# --- excitation -------------------------------------------------------------------------------

@pytest.mark.parametrize("method", ["logarithmic", "linear"])
def test_chirp_derivatives(method):
    t = np.arange(0, 5, 1e-4)
    c = chirp(t, 0.1, 10.0, 5.0, method=method, derivatives=3)
    for d in range(3):
        numeric = np.gradient(c[d], 1e-4)[1:-1]
        np.testing.assert_allclose(numeric, c[d + 1][1:-1], atol=1e-3 * np.abs(c[d + 1]).max())
    crossings = t[1:][np.diff(np.sign(c[0])) != 0]
    mid = 0.5 * (crossings[-1] + crossings[-2])
    expected = 0.1 * 100 ** (mid / 5) if method == "logarithmic" else 0.1 + 9.9 * mid / 5
    assert 1.0 / (2 * (crossings[-1] - crossings[-2])) == pytest.approx(expected, rel=0.02)


def test_multisine_periodic_shortcut_matches_direct_sum():
    rng = np.random.default_rng(0)
    f = np.arange(0.5, 8.05, 0.1)
    t = np.arange(25001) * 1e-3
    fast = multisine(t, f, 1.0, rng=rng, derivatives=1)          # 10 s period, repeated
    phases = np.random.default_rng(0).uniform(0, 2 * math.pi, f.size)
    w = 2 * math.pi * f[:, None]
    slow = np.sin(w * t + phases[:, None]).sum(axis=0)
    np.testing.assert_allclose(fast[0], slow, atol=1e-9)
    np.testing.assert_allclose(fast[1], (w * np.cos(w * t + phases[:, None])).sum(axis=0),
                               atol=1e-8)


def test_smoothed_steps_and_gate():
    rng = np.random.default_rng(1)
    times, levels = draw_random_steps(rng, 5.0, 0.03, 0.2, 0.3)
    assert np.all(np.diff(times) >= 0.2) and np.all(np.abs(levels) <= 0.03)
    t = np.arange(0, 5, 1e-4)
    y = smoothed_steps(t, times, levels, 0.009, derivatives=3)
    for d in range(3):
        numeric = np.gradient(y[d], 1e-4)[1:-1]
        np.testing.assert_allclose(numeric, y[d + 1][1:-1], atol=2e-3 * np.abs(y[d + 1]).max())
    w = gate(t, 1.0, 2.0, taper=0.1)
    assert w[0] == 1 and w[np.searchsorted(t, 2.0)] == 0 and w[-1] == 1
    assert np.all((w >= 0) & (w <= 1))


def test_dahl_along_saturates():
    y = np.concatenate([np.linspace(0, 0.05, 500), np.linspace(0.05, -0.05, 1000)])
    z = dahl_along(y, 1.0, 0.005)
    assert z[499] == pytest.approx(1.0, abs=1e-3) and z[-1] == pytest.approx(-1.0, abs=1e-3)


def test_dahl_forms_agree():
    # the simulator's relaxation form and the diagnosis's recursion are one solution, up to rounding
    rng = np.random.default_rng(7)
    y = np.cumsum(rng.normal(0.0, 1e-3, 2000))
    np.testing.assert_allclose(dahl_along(y, 2.5, 0.004), 2.5 * dahl(y, 0.004), rtol=0, atol=1e-12)


def test_delay_signal():
    t = np.arange(10) * 0.1
    x = t ** 2
    np.testing.assert_allclose(delay_signal(t, x, 0.2)[2:], x[:-2], atol=1e-15)
    assert delay_signal(t, x, 0.2)[0] == x[0] and delay_signal(t, x, 0.2, before=-1.0)[0] == -1.0
    np.testing.assert_allclose(delay_signal(t, x, -0.2)[:-2], x[2:], atol=1e-15)


def test_binary_steps_alternate_with_uniform_holds():
    rng = np.random.default_rng(0)
    times, levels = draw_binary_steps(rng, 30.0, 0.06, 0.05, 0.2)
    assert times[-1] > 30.0 and levels.size == times.size + 1
    np.testing.assert_array_equal(np.abs(levels), 0.06)
    np.testing.assert_array_equal(levels[1:], -levels[:-1])
    holds = np.diff(np.concatenate([[0.0], times]))
    assert holds.min() >= 0.05 and holds.max() <= 0.2
    assert np.mean(holds) == pytest.approx(0.125, rel=0.05)
    with pytest.raises(ValueError, match="hold_min"):
        draw_binary_steps(rng, 1.0, 0.06, 0.2, 0.1)
