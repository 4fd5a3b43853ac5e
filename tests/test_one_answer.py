"""One question, one answer (issue 45): the diagnosis's nominal stiffness is the analysis's median,
a reflex has one direction and delay in the ``reflex`` check, ``--effect reflex`` and ``diagnose``,
page 1's headline lies within the course it draws, and the noise levels have one fit."""

import numpy as np
import pytest

from limbstiff import analyze, diagnose
from limbstiff.diagnosis.bias import analysis_stiffness
from limbstiff.digest import cycle_course
from limbstiff.effects.channels import channels_from
from limbstiff.files import read_trial
from limbstiff.protocol import Protocol, load_protocol
from limbstiff.simulate import simulate
from limbstiff.statespace.noise import fit_levels, noise_bounds, starts

from .conftest import PROTOCOLS, REAL


def _reflex_trial(direction: float):
    return simulate("elbow", seed=3, params={"duration": 20.0}, effect="reflex", effect_params={"direction": direction})


def _printed(x: float) -> str:
    return f"{x:.4g}"


@pytest.fixture(scope="module")
def reflex_cases():
    """A simulated elbow with a stretch reflex towards positive and towards negative angles: the
    analysis, the analysis with the reflex in the model, and the diagnosis, each."""
    out = {}
    for direction in (1.0, -1.0):
        trial = _reflex_trial(direction)
        result = analyze(trial, seed=0)
        out[direction] = (trial, result, analyze(trial, seed=0, effects=("reflex",)),
                          diagnose([trial], seed=0, results=[result]))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_a_reflex_has_one_direction_and_delay_and_it_is_the_simulated_one(reflex_cases, direction):
    trial, result, with_reflex, diag = reflex_cases[direction]
    check = next(c for c in result.checks.checks if c.name == "reflex")
    towards = "positive" if direction > 0 else "negative"
    assert f"stretch towards {towards} angles" in check.message and "delay 40 ms" in check.message
    shape = with_reflex.identification.effects[0].shape
    assert shape["direction"] == direction and shape["delay"] == pytest.approx(0.04)
    found = next(c for c in diag.candidates if c.effect == "reflex").params
    assert found["direction"] == direction and found["delay"] == pytest.approx(0.04)
    assert "reflex" in diag.diagnosis
    assert diag.after.params["reflex"]["direction"] == direction


@pytest.mark.slow
@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_diagnose_states_the_analysis_stiffness_on_a_simulated_trial(reflex_cases, direction):
    trial, result, _, diag = reflex_cases[direction]
    median = result.informed_stiffness()[0].median
    nominal = diag.after.stiffness_bias.per_trial[trial.name].nominal
    assert _printed(nominal) == _printed(median) and nominal == median
    # the corrected trial's stiffness is taken by the same model and summary: on the trial as
    # recorded that summary is the analysis's median itself
    assert analysis_stiffness(trial, result, channels_from(trial, result), Protocol()) == pytest.approx(median,
                                                                                                      rel=1e-12)
    assert diag.stiffness[0].reported.median == median


@pytest.fixture(scope="module")
def z_pf():
    """The first 20 s of the real z_pf (its reflex, the change with the angle): the diagnosis of all
    60 s cost 17 s. The properties below hold for any trial; on this excerpt the per-sample course's
    median (66.05) differs from the analysis's (65.89) in the printed digits, so a diagnosis stating
    the other summary fails, and the reflex is diagnosed (every candidate's bias is computed).
    tests/test_real_ankle.py checks the nominal stiffness on the five whole recordings."""
    protocol = load_protocol(PROTOCOLS / "reklab-ankle.toml")
    trial = read_trial(REAL / "z_pf.csv", protocol).segment(0, 20_000)
    return trial, protocol, analyze(trial, protocol, seed=0)


@pytest.mark.slow
def test_diagnose_states_the_analysis_stiffness_on_a_real_ankle(z_pf):
    trial, protocol, result = z_pf
    median = result.informed_stiffness()[0].median
    assert analysis_stiffness(trial, result, channels_from(trial, result), protocol) == pytest.approx(median,
                                                                                                     rel=1e-12)
    diag = diagnose([trial], protocol, seed=0, results=[result])
    biases = [diag.after.stiffness_bias] + [c.stiffness_bias for c in diag.candidates]
    for bias in (b for b in biases if b is not None):
        assert _printed(bias.per_trial["z_pf"].nominal) == _printed(median)


def _within_the_drawing(result):
    course = cycle_course(result)
    drawn = course.stiffness[course.informed]
    median = result.informed_stiffness()[0].median
    return float(drawn.min()) <= median <= float(drawn.max()), (median, drawn.min(), drawn.max())


@pytest.mark.slow
def test_page_one_headline_lies_within_the_course_it_draws(z_pf, reflex_cases):
    for result in [z_pf[2]] + [case[1] for case in reflex_cases.values()]:
        inside, numbers = _within_the_drawing(result)
        assert inside, numbers


@pytest.mark.slow
def test_page_one_draws_the_course_the_headline_summarises(z_pf):
    """The per-cycle values are medians of the trial-level figures' course (with the change with the
    angle within the cycle), not of the smoothed course alone, which lacks it."""
    result = z_pf[2]
    level = result.trial_level
    assert "angle" in level.sources and level.course is not None
    assert np.median(level.course[level.informed]) == pytest.approx(result.informed_stiffness()[0].median)
    course = cycle_course(result)
    first = np.flatnonzero(course.informed)[0]
    width = int(round(course.seconds * result.trial.fs))
    in_bin = (level.index >= first * width) & (level.index < (first + 1) * width) & level.informed
    assert course.stiffness[first] == pytest.approx(np.median(level.course[in_bin]))


def test_the_noise_fit_finds_the_optimum_a_shifted_walk_alone_misses():
    """Two optima: the guess's basin (a constant stiffness, all measurement noise) and a better one
    with a large measurement noise and a small walk, which neither the guess nor its walks moved by
    10³ reach (their own basin holds them); the grid's best point is in the better basin."""
    bounds = noise_bounds(1.0, 10.0, 1.0)
    lo, hi = np.array(bounds).T
    good = np.array([hi[0] - 1.0, 0.5 * (lo[1] + hi[1]), lo[2] + 1.0, lo[2] + 1.0])
    guess = np.array([lo[0] + 1.0, 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2]), 0.5 * (lo[2] + hi[2])])

    def loglik(x):
        near_good = np.sum((x - good) ** 2)
        near_guess = np.sum((x - guess) ** 2)
        return max(10.0 - near_good, 5.0 - near_guess) if min(near_good, near_guess) < 9.0 else -50.0

    first = starts(loglik, guess, bounds)
    assert np.array_equal(first[0], guess) and len(first) == 4
    best, value = fit_levels(loglik, guess, bounds, 400)
    assert value > 8.0 and np.linalg.norm(best - good) < 1.5        # the better basin (the guess's peaks at 5)
    from limbstiff.statespace.noise import _nelder_mead
    without_grid = max(-_nelder_mead(lambda x: -loglik(x), x, bounds, 400).fun for x in first[:3])
    assert without_grid < 5.5                                       # the grid's start is what finds it


def test_the_analysis_and_the_diagnosis_fit_one_optimum_on_one_likelihood():
    """The estimator's noise fit (:func:`limbstiff.estimate.kalman.fit_noise`) and the diagnosis's
    (:func:`limbstiff.diagnosis.nominal.fit_noise`) on the same model's steps, from different
    guesses, find the same levels: one fit, one answer."""
    from limbstiff.diagnosis import nominal
    from limbstiff.estimate.kalman import data_guess, fit_noise
    from limbstiff.filtered import filter_trial
    from limbstiff.statespace.steps import kalman_decimation, model_steps

    trial = simulate("elbow", seed=5, params={"duration": 10.0})
    filtered = filter_trial(trial, Protocol())
    z = filtered.torque - 0.06 * filtered.acceleration - 0.45 * filtered.velocity
    steps = model_steps(filtered.angle, z, sample_period=filtered.sample_period,
                        decimation=kalman_decimation(filtered.sample_period, filtered.cutoff_hz),
                        edge=filtered.edge, motion_frequency=filtered.motion_hz)
    analysis = fit_noise(steps, motion_frequency=filtered.motion_hz)
    guess = data_guess(steps)
    other = type(guess)(guess.measurement * 30, guess.torque_walk, guess.stiffness_walk / 30, guess.coupled_walk)
    diagnosis = nominal.fit_noise(steps, start=other, motion_hz=filtered.motion_hz)
    np.testing.assert_allclose(analysis.logs(), diagnosis.logs(), atol=0.3)
