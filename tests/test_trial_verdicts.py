"""Issue 46's trial verdict: a velocity-driven torque of a shape the model lacks is said (and not
taken for an angle-dependent stiffness); a median stiffness wholly below zero is never ``ok``."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import signal as sps
from scipy import stats

from limbstiff.checks.analysis import median_sign
from limbstiff.checks.shape import ShapeMiss, contract_bias, velocity_shape_check
from limbstiff.checks.verdict import ANGLE_WALD, OK, UNRELIABLE
from limbstiff.digest import ANGLE_PROPERTY
from limbstiff.interval import Interval


def test_contract_bias_is_where_a_gaussian_band_falls_to_the_contract():
    """δ = contract_bias·z makes a 90 % Gaussian band hold the truth 85 % of the time (to 1e-9: a
    root), a third of the half-width; none is allowed when the contract asks the band's own level."""
    z = stats.norm.ppf(0.95)
    d = contract_bias(0.9) * z
    assert stats.norm.cdf(z - d) - stats.norm.cdf(-z - d) == pytest.approx(0.85, abs=1e-9)
    assert 0.32 < contract_bias(0.9) < 0.34
    assert contract_bias(0.8) == 0.0


def _miss(wald: float, shift: float, sd: float = 0.0) -> ShapeMiss:
    return ShapeMiss(wald=wald, dof=8, threshold=float(stats.chi2.isf(0.001, 8)), shift=shift, shift_sd=sd,
                     columns=np.zeros((8, 3)))


def test_velocity_shape_check_needs_significance_a_shift_the_band_cannot_hold_and_its_sign_known():
    """Two-sided on the rule: significant, moving the stiffness by more than the contract's bias
    (the shift at which a 90 % band holds 85 %) and by more than 1.96 of its standard errors fails;
    a small shift, a large one that is not significant, or one within 1.96 of its standard errors
    passes."""
    limit = contract_bias(0.9)                           # share of the half-width
    kw = dict(stiffness=30.0, half_width=1.0, level=0.9)
    # the contract's own bias (not a share fitted to a benchmark: RESULTS.md#bias-share)
    assert velocity_shape_check(_miss(500.0, 0.0), **kw).threshold == pytest.approx(limit, rel=1e-12)
    assert not velocity_shape_check(_miss(500.0, 1.5 * limit, sd=0.4 * limit), **kw).passed
    assert velocity_shape_check(_miss(500.0, 0.5 * limit), **kw).passed
    assert velocity_shape_check(_miss(10.0, 5 * limit), **kw).passed
    assert velocity_shape_check(_miss(500.0, 1.5 * limit, sd=limit), **kw).passed
    assert velocity_shape_check(None, **kw) is None


def test_a_median_wholly_below_zero_is_unreliable():
    """Wholly below zero: unreliable with a reason; reaching zero or above, or no interval: passes."""
    check = median_sign(Interval(-5.0, -8.0, -2.0))
    assert not check.passed and check.severity == UNRELIABLE and "below zero" in check.message
    assert median_sign(Interval(-1.0, -3.0, 0.5)).passed
    assert median_sign(Interval(20.0, 18.0, 22.0)).passed
    assert median_sign(Interval(np.nan, np.nan, np.nan)).passed


def test_angle_terms_beside_the_torque_that_made_them_are_not_significant():
    """Two-sided. A spring σ = 20 + β·h(g) (as tests/test_estimators.py): the angle terms' Wald
    statistic is huge alone and stays huge beside an unrelated torque (a rectified velocity). A
    constant spring with a gated velocity torque (ẏ 40 ms earlier above 0.3 rad/s, seeded noise):
    alone the angle terms take it up (measured χ² 236, far beyond the 0.1 % point 13.8); beside that
    torque they fall below the point (measured 6.8)."""
    from limbstiff.estimate.angle_terms import angle_regressors, fit_angle_terms
    from limbstiff.statespace.noise import NoiseLevels
    from limbstiff.statespace.steps import model_steps
    rng = np.random.default_rng(3)
    fs = 100.0
    t = np.arange(0, 60.0, 1 / fs)
    y = 0.1 * np.sin(2 * np.pi * t) + 0.05 * np.sin(2 * np.pi * 1.7 * t + 1)
    noise = NoiseLevels(0.002 ** 2, 1e-8, 1e-6, 1e-6)

    def fit(z, beside=None):
        steps = model_steps(y, z, sample_period=1 / fs, decimation=1, edge=0, motion_frequency=1.0)
        return fit_angle_terms(steps, noise, motion_frequency=1.0, beside=beside).wald

    U, _ = angle_regressors(model_steps(y, np.zeros_like(y), sample_period=1 / fs, decimation=1, edge=0,
                                       motion_frequency=1.0))
    spring = 20.0 * y + np.array([30.0, 400.0]) @ U + 0.002 * rng.standard_normal(len(y))
    unrelated = np.maximum(np.gradient(y, 1 / fs) - 0.2, 0.0)[None, :]
    assert fit(spring) > 1e4 and fit(spring, unrelated) > 1e3
    gate = np.maximum(np.roll(np.gradient(y, 1 / fs), 4) - 0.3, 0.0)
    reflex = 20.0 * y + 0.5 * gate + 0.002 * rng.standard_normal(len(y))
    assert fit(reflex) > 3 * ANGLE_WALD
    assert fit(reflex, gate[None, :]) < ANGLE_WALD


def _gated(trial, share: float = 0.3, percentile: float = 60.0, delay: float = 0.04):
    """The trial with a reflex the library's does not have added to its torque: the velocity 40 ms
    earlier above its 60th percentile of |ẏ| (one direction), through an underdamped activation
    (2.5 Hz, ζ 0.6), its RMS ``share`` of the torque's spread."""
    from limbstiff.signals import zero_phase_lowpass
    fs = 1 / float(np.median(np.diff(trial.time)))
    v = np.gradient(zero_phase_lowpass(trial.angle, fs, 20.0, order=2), 1 / fs)
    n = int(round(delay * fs))
    late = np.concatenate([np.zeros(n), v[:-n]])
    w = 2 * np.pi * 2.5
    r = sps.lfilter(*sps.bilinear([w * w], [1, 2 * 0.6 * w, w * w], fs=fs),
                    np.maximum(late - np.percentile(np.abs(v), percentile), 0.0))
    return dataclasses.replace(trial, torque=trial.torque + share * np.std(trial.torque) / np.std(r) * r)


@pytest.fixture(scope="module")
def elbow():
    from limbstiff.simulate import simulate
    return simulate("elbow", seed=7, params={"duration": 20.0})


@pytest.fixture(scope="module")
def clean_elbow(elbow):
    from limbstiff.analysis import analyze
    return analyze(elbow, seed=7)


def test_velocity_shape_fires_on_a_gated_reflex_and_not_on_the_clean_trial(elbow, clean_elbow):
    """The same 20 s simulated elbow: clean, the check passes and the verdict is ok (measured: χ²
    4–19 on 8 degrees of freedom over the accuracy scenarios, the 0.1 % point 26.1); with a gated
    reflex and the library's reflex in the model (which has no threshold), it fails — the stiffness
    is then 3.7 % off with its band holding the truth on 78 % of the samples — and no reason says the
    stiffness depends on the angle."""
    from limbstiff.analysis import analyze
    clean = clean_elbow
    assert clean.checks["velocity_shape"].passed and clean.verdict == OK
    gated = analyze(_gated(elbow), seed=7, effects=("reflex",))
    check = gated.checks["velocity_shape"]
    assert not check.passed and gated.verdict != OK
    assert "may not hold" in check.message
    assert not any(reason.startswith(ANGLE_PROPERTY) for reason in gated.checks.reasons)


def test_the_benchmarks_hold_the_median_interval_against_the_median_of_the_figures_own_samples(clean_elbow):
    """benchmarks/trial_verdicts.py compares the median's interval with the true course's median
    over the samples the figure is taken over (TrialLevel.index where informed, from the trial's
    start), not over the informed samples after the first 2 s: on this elbow, whose stiffness
    changes in time, the two truths differ by 16 % (measured), and the interval holds only the first."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    try:
        from trial_verdicts import verdict_fields
    finally:
        sys.path.pop(0)
    level = clean_elbow.trial_level
    own = float(np.median(clean_elbow.reference[level.index[level.informed]]))
    after = float(np.median(clean_elbow.reference[clean_elbow.reference_samples()]))
    assert abs(after / own - 1) > 0.05                  # the case tells the two definitions apart
    median = level.median_stiffness
    assert median.lo <= own <= median.hi and not median.lo <= after <= median.hi
    assert verdict_fields(clean_elbow)["median_holds"]


def test_model_form_weights_and_mixture_draws():
    """One alternative as likely as the chosen model holds half the weight; the band's spread is the
    mixture's root mean square about the chosen course; the draws pick each model at its weight
    (4000 seeded draws: within 4 binomial standard errors). An alternative 20 nats less likely weighs
    e⁻²⁰ ≈ 2·10⁻⁹: below 10⁻⁶, no model form at all."""
    from limbstiff.effects.model_form import model_form
    change = np.array([0.0, 1.0, 2.0, 4.0])
    form = model_form([0.0], [change])
    assert form.weights == pytest.approx([0.5])
    assert form.spread() == pytest.approx(np.sqrt(0.5) * change)
    draws = form.draws(np.random.default_rng(5), 4000, np.array([1, 3]))
    picked = np.mean(draws[:, 1] == 4.0)
    assert set(np.unique(draws[:, 1])) <= {0.0, 4.0} and abs(picked - 0.5) < 4 * np.sqrt(0.25 / 4000)
    two = model_form([np.log(3.0), 0.0], [change, 2 * change])   # weights 3/5 and 1/5
    assert two.weights == pytest.approx([0.6, 0.2])
    assert model_form([-20.0], [change]) is None and model_form([], []) is None


@pytest.fixture(scope="module")
def reflex_elbow():
    from limbstiff.simulate import simulate
    return simulate("elbow", seed=1, params={"duration": 12}, effect="reflex")


def test_the_reflex_in_or_out_is_weighed_by_its_evidence(elbow, reflex_elbow, monkeypatch):
    """Two-sided, on the model form the analysis builds (caught as it is made). With ``--effect
    reflex`` on the clean elbow the reflex is not needed (its log-evidence gain −5.3 less ln 130
    shapes: measured 10.2 nats for leaving it out): the reflex out holds nearly all the weight and the
    trial-level figures draw the model form. On the elbow with the simulator's reflex the reflex out
    lies beyond 100 nats (measured −117) and the runner-up shapes hold about 1 % between them (−5.1,
    −5.4 nats): their spread adds under 5 % of the band's half-width (measured 2 %)."""
    import limbstiff.analysis as pipeline
    made = []
    build = pipeline.model_form
    monkeypatch.setattr(pipeline, "model_form", lambda logs, changes: made.append((list(logs), build(logs, changes)))
                        or made[-1][1])
    clean = pipeline.analyze(elbow, seed=7, effects=("reflex",))
    logs, form = made[-1]
    assert logs[0] > 5 and form.weights[0] > 0.99 and "model form" in clean.trial_level.sources
    strong = pipeline.analyze(reflex_elbow, seed=1, effects=("reflex",))
    logs, form = made[-1]
    assert logs[0] < -100 and form.weights.sum() < 0.02
    obs = strong.observable
    half = np.median((strong.stiffness_hi - strong.stiffness_lo)[obs]) / 2
    assert np.median(form.spread()[obs]) < 0.05 * half


def test_the_verdict_of_a_median_wholly_below_zero_is_unreliable():
    """Two-sided, end to end: the paper's exponential spring (direct variant), its elastic torque
    reversed, has a negative median stiffness whose interval lies wholly below zero — the
    ``median_stiffness_sign`` check fails with its reason and the verdict is unreliable; the same
    spring as recorded passes it."""
    from limbstiff.analysis import analyze
    from limbstiff.simulate import simulate
    spring = simulate("paper-exp-spring", params={"duration": 5.0})
    right = analyze(spring, seed=0)
    assert right.checks["median_stiffness_sign"].passed and right.trial_level.median_stiffness.lo > 0
    flipped = analyze(dataclasses.replace(spring, elastic_torque=-spring.elastic_torque), seed=0)
    check = flipped.checks["median_stiffness_sign"]
    assert flipped.trial_level.median_stiffness.hi < 0
    assert not check.passed and flipped.verdict == UNRELIABLE
    assert any("wholly below zero" in reason for reason in flipped.checks.reasons)


def _terms(beside: bool, wald: float = 1e4):
    from limbstiff.estimate.angle_terms import AngleTerms
    phase = np.linspace(0, 20 * np.pi, 400)
    return AngleTerms(coefficients=np.array([1.0, 0.0]), covariance=np.eye(2) * 1e-4, wald=wald,
                      missed=np.vstack([np.sin(phase), np.zeros_like(phase)]), index=np.arange(400), beside=beside)


def test_an_angle_change_is_the_joints_property_only_without_a_rival():
    """Two-sided on the reason: the same well-determined change (±7 % of a stiffness of 10, seven
    band half-widths, its size known to 1 %) is said to be the joint's property when fitted alone,
    and not when fitted beside a velocity-driven torque the model lacks (the gated reflex's case);
    both fail with caution."""
    from limbstiff.checks.analysis import _angle_dependence  # noqa: PLC2701 - the check itself
    stiffness, observable = np.full(400, 10.0), np.ones(400, bool)
    alone = _angle_dependence(_terms(False), stiffness, stiffness - 0.1, stiffness + 0.1, observable)
    rival = _angle_dependence(_terms(True), stiffness, stiffness - 0.1, stiffness + 0.1, observable)
    assert not alone.passed and alone.message.startswith(ANGLE_PROPERTY)
    assert not rival.passed and not rival.message.startswith(ANGLE_PROPERTY) and "velocity_shape" in rival.message


def test_the_figures_add_the_angle_change_only_where_the_check_tells_it_from_noise():
    """told_angle: the terms beyond the 0.1 % point are kept, those within it dropped (the check
    calls them noise)."""
    from limbstiff.figure_draws import told_angle
    assert told_angle(_terms(False, wald=ANGLE_WALD + 1)) is not None
    assert told_angle(_terms(False, wald=ANGLE_WALD - 1)) is None and told_angle(None) is None


def test_wide_band_names_the_models_spread_only_when_it_is_most_of_the_width():
    """Issue 46, true reasons: a band wider than the stiffness because two models of comparable
    evidence disagree says so (and what to decide), not that the recording lacks motion; a band
    whose width is the recording's own keeps the recording's causes."""
    from limbstiff.checks.analysis import MODEL_FORM_SHARE, MODEL_FORM_WIDE, _stiffness_course
    n = 200
    stiffness = np.full(n, 10.0)
    lo, hi = stiffness - 12.0, stiffness + 12.0            # width 2.4× the stiffness: both checks fail
    observable = np.ones(n, dtype=bool)
    for share, said in ((MODEL_FORM_SHARE + 0.3, True), (MODEL_FORM_SHARE - 0.3, False)):
        checks = {c.name: c for c in _stiffness_course(stiffness, lo, hi, observable, share)}
        for name in ("band_width_relative", "band_excludes_zero"):
            assert not checks[name].passed
            assert (MODEL_FORM_WIDE in checks[name].message) is said, (name, share)


def test_model_form_share_is_the_alternatives_part_of_the_band_variance():
    """band.model_form_share: an alternative whose change equals the estimator's own standard
    deviation holds half the band's variance; none, zero."""
    from types import SimpleNamespace

    from limbstiff.band import ModelForm, model_form_share
    n = 50
    estimate = SimpleNamespace(variance_with=lambda cov: np.full(n, 4.0))     # sd 2
    form = ModelForm(weights=np.array([1.0]), changes=np.full((1, n), 2.0))  # rms spread 2
    assert model_form_share(estimate, None, form, np.arange(n)) == pytest.approx(0.5)
    assert model_form_share(estimate, None, None, np.arange(n)) == 0.0
