"""Model checks and the verdict: each check trips on a trial it should and passes on one it should not.

Trials are made with the simulator plus a defect with a known cause (a torque the angle does
not explain, a periodic torque, a reversed sign…); seeds and sizes differ from those the
thresholds were set on (seeds 101–102, 20 s; see limbstiff/checks/verdict.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import signal

import limbstiff
from limbstiff.checks import CAUTION, OK, UNRELIABLE
from limbstiff.checks.analysis import _innovations
from limbstiff.checks.model import InnovationStatistics, elastic_slopes
from limbstiff.checks.verdict import VELOCITY_CORRELATION_MAX, WHITENESS_MAX, Check, ModelChecks
from limbstiff.protocol import Protocol
from limbstiff.simulate import simulate


@pytest.fixture(scope="module")
def elbow():
    return simulate("elbow", seed=21, params={"duration": 12.0})


@pytest.fixture(scope="module")
def elbow_result(elbow):
    return limbstiff.analyze(elbow, seed=0)


def _failed(result) -> set[str]:
    return {c.name for c in result.checks.failed}


@pytest.mark.parametrize("scenario, params", [
    ("elbow", {"duration": 12.0}), ("wrist", {"duration": 12.0}), ("ankle", {"duration": 20.0}),
    ("paper-exp-spring", {"duration": 10.0}), ("paper-vsa-exp", {"duration": 15.0}),
])
@pytest.mark.slow
def test_clean_scenarios_the_model_fits_are_ok(scenario, params):
    result = limbstiff.analyze(simulate(scenario, seed=31, params=params), seed=0)
    assert result.verdict == OK, result.checks.reasons
    # and the model does fit them: the stiffness is right
    assert result.reference_error()["median"] < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("scenario", ["paper-vsa-hogan", "paper-vsa-feldman"])
def test_generalized_damping_is_flagged_with_default_settings(scenario):
    # b(d) = 2β|θ̇| (the paper's Sec. II) is not a constant b: the default analysis misses it by
    # 40–110 % (measured), and the verdict must say so
    result = limbstiff.analyze(simulate(scenario, seed=31, params={"duration": 12.0}), seed=0)
    assert result.reference_error()["median"] > 0.2
    assert result.verdict == UNRELIABLE


@pytest.mark.slow
def test_an_unexplained_torque_fails_the_heldout_check(elbow, elbow_result):
    # band-limited torque (0.2–3 Hz) independent of the angle, twice the torque's spread
    rng = np.random.default_rng(4)
    b, a = signal.butter(2, [0.2, 3.0], btype="band", fs=elbow.fs)
    extra = signal.filtfilt(b, a, rng.standard_normal(elbow.n_samples))
    extra *= 2 * np.std(elbow.torque) / np.std(extra)
    result = limbstiff.analyze(dataclasses.replace(elbow, torque=elbow.torque + extra), seed=0)
    assert "heldout_torque_explained" in _failed(result) and result.verdict != OK
    # the clean trial is predicted almost entirely out of sample (measured 0.95)
    assert elbow_result.checks["heldout_torque_explained"].value > 0.9


def test_a_periodic_torque_fails_whiteness_and_the_verdict(elbow, elbow_result):
    wave = 2 * np.std(elbow.torque) * np.sin(2 * np.pi * 3.0 * elbow.time)
    result = limbstiff.analyze(dataclasses.replace(elbow, torque=elbow.torque + wave), seed=0)
    assert {"residual_whiteness", "heldout_torque_explained"} <= _failed(result)
    assert elbow_result.checks["residual_whiteness"].passed


def test_innovation_checks_compare_with_their_thresholds():
    # the residual-velocity check never tripped alone in the simulations (a reflex large enough
    # is absorbed and caught by the held-out and agreement checks); its logic is tested here
    share = 1e-2                                   # a residual large enough to be judged
    above = _innovations(InnovationStatistics(WHITENESS_MAX + 0.05, VELOCITY_CORRELATION_MAX + 0.05), False, share)
    below = _innovations(InnovationStatistics(WHITENESS_MAX - 0.05, VELOCITY_CORRELATION_MAX - 0.05), False, share)
    assert [c.passed for c in above] == [False, False]
    assert [c.passed for c in below] == [True, True]
    # a negligible residual (noise-free data) passes whatever its structure
    assert all(c.passed for c in _innovations(InnovationStatistics(0.99, 0.9), True, 1e-7))


@pytest.mark.slow
def test_noise_level_at_its_bound_fails():
    # hysteresis on the ankle: the stiffness walk reaches its bound (measured 13 % error)
    result = limbstiff.analyze(simulate("ankle", seed=101, params={"duration": 20.0}, effect="hysteresis"), seed=101)
    assert "noise_levels_at_bounds" in _failed(result) and result.verdict == CAUTION


@pytest.mark.slow
def test_mechanics_disagreement_fails():
    # backlash on the ankle: least squares and likelihood disagree by 26 % (stiffness 22–35 % off)
    result = limbstiff.analyze(simulate("ankle", seed=101, params={"duration": 20.0}, effect="backlash"), seed=101)
    assert "mechanics_agreement" in _failed(result) and result.verdict != OK


def test_noisy_torque_fails_band_width_and_band_reaches_zero():
    # torque noise of 1 N·m on an elbow whose torque spreads ~1 N·m: nothing is pinned down; the
    # band reaches zero (its width is tens of times the stiffness), and the estimate may or may not
    # stray below zero (it did with the stiffness walk of one kind, not with two)
    result = limbstiff.analyze(simulate("elbow", seed=21, params={"duration": 12.0, "torque_noise": 1.0}), seed=0)
    assert {"band_width_relative", "band_excludes_zero"} <= _failed(result)
    assert result.verdict == UNRELIABLE


def test_inertia_outside_the_expected_range(elbow, elbow_result):
    result = limbstiff.analyze(elbow, Protocol(inertia_range=(1.0, 2.0)), seed=0)
    assert "inertia_in_expected_range" in _failed(result) and result.verdict == CAUTION
    assert "inertia_in_expected_range" not in _failed(elbow_result)


def test_reversed_torque_with_inertia_and_damping_given(elbow, elbow_result):
    truth = (0.06, 0.45)                            # near this elbow's own m and b
    flipped = limbstiff.analyze(dataclasses.replace(elbow, torque=-elbow.torque), seed=0,
                                inertia=truth[0], damping=truth[1])
    sign = flipped.checks["torque_sign"]
    assert not sign.passed and "scale = -1" in sign.message and flipped.verdict == UNRELIABLE
    assert elbow_result.checks["torque_sign"].passed


def test_reversed_torque_with_inertia_and_damping_identified(elbow):
    with pytest.raises(limbstiff.TrialError, match="opposite sign.*scale = -1"):
        limbstiff.analyze(dataclasses.replace(elbow, torque=-elbow.torque), seed=0)


def test_reversed_elastic_torque_direct_variant():
    spring = simulate("paper-exp-spring", params={"duration": 5.0})
    result = limbstiff.analyze(dataclasses.replace(spring, elastic_torque=-spring.elastic_torque), seed=0)
    assert {"torque_sign", "negative_stiffness_share"} <= _failed(result) and result.verdict == UNRELIABLE


@pytest.mark.slow
def test_a_delay_is_not_mistaken_for_a_reversed_sign():
    # a 20 ms channel delay on the ankle makes the identified inertia negative; the message
    # must not blame the sign
    trial = simulate("ankle", seed=101, params={"duration": 20.0}, effect="time_delay")
    with pytest.raises(limbstiff.TrialError) as err:
        limbstiff.analyze(trial, seed=101)
    assert "opposite sign" not in str(err.value)


def test_elastic_slopes_of_a_line():
    y = np.sin(np.linspace(0, 20, 2000))
    slope, explained = elastic_slopes(3.0 * y + 1.0, y, window=500)
    np.testing.assert_allclose(slope, 3.0)
    np.testing.assert_allclose(explained, 1.0)
    # a window longer than the signal is one window
    assert elastic_slopes(-2.0 * y, y, window=10_000)[0] == pytest.approx([-2.0])


def test_verdict_is_the_worst_failed_severity():
    ok = Check("a", 1.0, 0.5, True, "fine")
    caution = Check("b", 0.1, 0.5, False, "look", CAUTION)
    bad = Check("c", 0.9, 0.05, False, "no", UNRELIABLE)
    assert ModelChecks((ok,)).verdict == OK
    assert ModelChecks((ok, caution)).verdict == CAUTION
    assert ModelChecks((caution, bad, ok)).verdict == UNRELIABLE
    assert ModelChecks((caution, bad)).reasons == ("no", "look")


def test_summary_carries_verdict_and_checks(elbow_result):
    s = elbow_result.summary()
    assert s["verdict"] == OK and s["verdict_reasons"] == []
    assert {c["name"] for c in s["checks"]} >= {"heldout_torque_explained", "residual_whiteness",
                                                "negative_stiffness_share", "torque_sign"}
    assert all(set(c) >= {"name", "value", "threshold", "passed", "message"} for c in s["checks"])


@pytest.mark.slow
def test_a_reflex_on_a_platform_is_flagged():
    # nearly noise-free torque, but the model misses 4-5 % of it out of sample: the residual's
    # structure is judged. The stiffness is off (measured: median 25-42 % with one kind of stiffness
    # walk; 9.5 %, 90th percentile 128 %, with the coupled walk of issue 14 taking up part of the
    # reflex torque), so the precondition is only that it is clearly off
    result = limbstiff.analyze(simulate("ankle-platform", seed=2, params={"duration": 20.0}, effect="reflex"),
                               seed=2)
    assert result.reference_error()["median"] > 0.05
    assert result.verdict != OK and "residual_whiteness" in _failed(result)


@pytest.mark.slow
def test_walkers_starting_on_a_bound_do_not_fail():
    # the likelihood's optimum on a noise level's bound put every walker on it: emcee's snooker
    # move then divided by zero ("At least one parameter value was NaN")
    result = limbstiff.analyze(simulate("ankle", seed=4, params={"duration": 20.0}, effect="reflex"), seed=4)
    assert np.isfinite(result.stiffness).all() and result.identification.posterior.diagnostics.converged


@pytest.mark.parametrize("spring", [2, 3])
def test_steep_exponential_springs_the_estimator_misses_are_flagged(spring):
    # A known failure, kept visible: the paper's springs 2 and 3 (stiffness ×25 within a cycle)
    # outrun the stiffness walk's bound (σ²·f_motion). With the secant stiffness as σ the estimate
    # was 75–350 % off; with the steepest slope over 16 windows (kalman.initial_cov) 38 % and 109 %
    # (measured; a bound 100× higher gives 0.02 % on spring 2): the windows are longer than the
    # cycle the stiffness changes within. The verdict must say so (the bundled example is spring 2).
    result = limbstiff.analyze(simulate("paper-exp-spring", params={"spring": spring, "duration": 10.0}), seed=0)
    assert result.reference_error()["median"] > 0.3
    assert result.verdict != OK and "noise_levels_at_bounds" in _failed(result)


def _independent_trial(tmp_path, seed: int, name: str):
    """A trial of the independent simulator (``tests/support/independent_trials.py``, written without
    limbstiff's code), analysed with m and b identified."""
    from limbstiff.files import read_trial

    from .support import independent_trials
    spec = next(s for s in independent_trials.suite(seed) if s.name == name)
    independent_trials.write_trial(spec, tmp_path)
    return limbstiff.analyze(read_trial(tmp_path / f"{name}.csv"), seed=0)


@pytest.mark.slow
def test_a_spring_stiffening_within_the_cycle_is_flagged(tmp_path):
    """The independent simulator's co-contracting elbow with a cubic spring (suite seed 7200): its
    tangent stiffness rises by 3·k₃·θ² at every excursion (k₃ = 84 N·m/rad³, ±0.3 rad), which the
    model averages over the cycle; every other check passed and the band held the truth in 30 % of
    the samples. The angle terms' Wald statistic is 150 (χ²₂: 13.8 at 0.1 %) and what the course
    misses of them is 3.2 band half-widths (measured), so the check fails and says why."""
    result = _independent_trial(tmp_path, 7200, "clean-cocontraction-cubic-elbow")
    check = result.checks["angle_dependence"]
    assert not check.passed and result.verdict == CAUTION
    assert check.value > 2.0                       # measured 3.2; 1.0 is the threshold
    assert "average over the cycle" in check.message
    assert result.reference_error()["coverage"] < 0.75   # the flag is deserved: the band misses


def test_a_constant_spring_of_the_independent_simulator_is_not_flagged(tmp_path):
    """Its constant elbow of the same suite: Wald 5.9 (measured), below χ²₂'s 0.1 % point 13.8, so
    no angle dependence is claimed, and the verdict stays ok."""
    result = _independent_trial(tmp_path, 7200, "clean-constant-elbow")
    assert result.checks["angle_dependence"].passed and result.verdict == OK


def test_the_carried_stiffness_is_held_beyond_the_fitted_angles():
    # σ(y) = 1 + y² fitted on y ∈ [−1, 1]: inside, ∫σ dy exactly (1 + 2·0.5³/3 from −0.5 to 0.5);
    # outside, σ stays at its edge value 2, so 2 rad beyond the edge add 2·2 and not ∫(1 + y²)
    from limbstiff.checks.model import _clipped_antiderivative
    elastic = _clipped_antiderivative(np.array([1.0, 0.0, 1.0]), -1.0, 1.0)
    assert elastic(0.5) - elastic(-0.5) == pytest.approx(1.0 + 0.25 / 3, rel=1e-12)
    assert elastic(-1.0) - elastic(-3.0) == pytest.approx(4.0, rel=1e-12)
    assert elastic(3.0) - elastic(1.0) == pytest.approx(4.0, rel=1e-12)
    assert np.allclose(np.diff(elastic(np.array([0.999999, 1.0, 1.000001]))), 2e-6, rtol=1e-5)


# --- issue 34 item 5: detection ≥ 90 % of trials more than 20 % off, false alarms ≤ 5 % --------------
# Seeds here are neither the benchmark's (1–5; suite seeds 7300–7600) nor, where a threshold is
# concerned, those it was argued on (101–102; suite seeds 7100, 7200), unless said.


def test_the_band_width_limit_is_where_a_calibrated_band_expects_the_fitting_error():
    """BAND_WIDTH_MAX follows from the band's definition: a calibrated Gaussian 90 % band of relative
    width w has median |error| Φ⁻¹(0.75)/Φ⁻¹(0.95)·w/2; at the limit that is FITS (10 %)."""
    from scipy import stats

    from limbstiff.checks.verdict import BAND_WIDTH_MAX, FITS
    ratio = stats.norm.ppf(0.75) / stats.norm.ppf(0.95)
    assert BAND_WIDTH_MAX * ratio / 2 == pytest.approx(FITS, rel=1e-3)
    # and by sampling: errors drawn with the sd of such a band (half-width 1.645 sd); 10⁵ draws put
    # the sample median within ±1 % of itself (its standard error is 0.4 %), so ±2 % both ways
    rng = np.random.default_rng(5)
    sd = BAND_WIDTH_MAX / 2 / stats.norm.ppf(0.95)
    assert np.median(np.abs(rng.normal(0.0, sd, 100_000))) == pytest.approx(FITS, rel=0.02)


@pytest.mark.slow
def test_hysteresis_on_the_platform_ankle_is_flagged():
    """Dahl hysteresis on the platform's binary steps saturates within each step and adds a torque
    that steps with the angle: the stiffness reads 30–35 % high (seeds 101–102: 33 %) and every
    residual check passes, but the stiffness walk takes the transitions up and the band widens to
    0.8–0.9 of the stiffness (clean: 0.04), beyond what a fit to 10 % allows."""
    result = limbstiff.analyze(simulate("ankle-platform", seed=43, params={"duration": 20.0},
                                        effect="hysteresis"), seed=43)
    assert result.reference_error()["median"] > 0.2            # the flag is deserved
    assert "band_width_relative" in _failed(result) and result.verdict != OK


@pytest.mark.slow
def test_the_platform_ankle_clean_keeps_a_narrow_band():
    result = limbstiff.analyze(simulate("ankle-platform", seed=43, params={"duration": 20.0}), seed=43)
    assert result.verdict == OK, result.checks.reasons
    assert result.checks["band_width_relative"].value < 0.1      # measured 0.04 on seeds 101–102


@pytest.mark.slow
def test_a_pause_does_not_count_against_the_residual():
    """The paper's antagonistic exponential springs, 20 s: the torque stops at 10 s and the free
    motion dies out within 1.5 s. Over every step the noise-free residual of that decay made the
    innovations' autocorrelation 0.80 (seeds 101–102, threshold 0.8); over the steps the motion
    informs, 0.74, and the verdict is ok (the stiffness is 2.6 % off)."""
    result = limbstiff.analyze(simulate("paper-vsa-exp", seed=43, params={"duration": 20.0}), seed=43)
    assert result.reference_error()["median"] < 0.05
    assert result.verdict == OK, result.checks.reasons
    assert result.checks["residual_whiteness"].value < WHITENESS_MAX - 0.02


def test_innovation_statistics_over_every_informed_step_are_those_over_all(elbow_result):
    from limbstiff.checks.model import innovation_statistics
    ident = elbow_result.identification
    kw = dict(inertia=ident.inertia.median, damping=ident.damping.median, noise=ident.noise_levels)
    f, n = elbow_result.filtered, elbow_result.trial.n_samples
    assert innovation_statistics(f, **kw, informed=np.ones(n, bool)) == innovation_statistics(f, **kw)
    # too few informed steps: not computed (the check then passes)
    assert innovation_statistics(f, **kw, informed=np.zeros(n, bool)) is None


def test_stiffness_shift_is_linear_in_the_change_of_inertia_and_damping(elbow_result):
    from limbstiff.checks.model import stiffness_shift
    from limbstiff.estimate.observer import informed_samples
    ident = elbow_result.identification
    m, b = ident.inertia.median, ident.damping.median
    kw = dict(inertia=m, damping=b, stiffness=elbow_result.stiffness,
              informed=informed_samples(elbow_result.observable))
    f = elbow_result.filtered
    assert stiffness_shift(f, other=(m, b), **kw) == 0.0
    one = stiffness_shift(f, other=(1.1 * m, b), **kw)
    assert stiffness_shift(f, other=(1.2 * m, b), **kw) == pytest.approx(2 * one, rel=1e-9)
    # more inertia takes more of the torque at the motion's frequencies, which lie below the
    # resonance: ÿ ≈ −ω²y, so the elastic torque and the stiffness rise, by m·ω²/K per unit of Δm/m
    assert one > 0


def test_a_disagreement_on_inertia_that_leaves_the_stiffness_is_not_flagged(tmp_path):
    """The independent simulator's clean gait ankle (suite seed 7100, on which the threshold was
    argued): least squares finds an inertia 50 % above the posterior's (measured), but with it the
    stiffness would move by 3 %, well inside WRONG (20 %): no caution for that."""
    result = _independent_trial(tmp_path, 7100, "clean-gait-ankle")
    check = result.checks["mechanics_agreement"]
    ls = result.identification.least_squares
    assert abs(ls.inertia / result.identification.inertia.median - 1) > 0.2    # the old check's failure
    assert check.passed and check.value < 0.1
