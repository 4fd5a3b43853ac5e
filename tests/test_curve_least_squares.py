"""The curve's least-squares cross-check, its band measured from the data, and its own verdict (issue 46)."""

import dataclasses

import numpy as np
import pytest
from scipy.signal import butter, lfilter

from limbstiff.checks.verdict import Check, ModelChecks, Verdict
from limbstiff.curve_result import CurveAnalysis
from limbstiff.scheduled.checks import chance_share, least_squares_check, negative_check
from limbstiff.scheduled.curve import ScheduleCurve, resampled_band
from limbstiff.scheduled.least_squares import binned_least_squares, phase_channels, schedule_channels

BINS, FS = 50, 1000.0


def _ensemble(seed: int, *, n_cycles: int = 40, period: float = 1.0, noise: float = 0.05):
    """An ensemble with an exact answer: K constant within each of 50 phase bins (40 + 30·sin over
    the bins' centres), B 0.8, I 0.012, a large imposed movement and a background torque that
    repeat, a filtered random binary perturbation, white torque noise ``noise`` of its sd."""
    rng = np.random.default_rng(seed)
    n = int(n_cycles * period * FS)
    t = np.arange(n) / FS
    phase, cycle = (t / period) % 1.0, (t // period).astype(int)
    which = np.minimum((phase * BINS).astype(int), BINS - 1)
    k_bins = 40 + 30 * np.sin(2 * np.pi * (np.arange(BINS) + 0.5) / BINS)
    x = lfilter(*butter(2, 15 / (FS / 2)), rng.choice([-1.0, 1.0], n // 40 + 1).repeat(40)[:n] * 0.02)
    xv = np.gradient(x, 1 / FS)
    xa = np.gradient(xv, 1 / FS)
    big = 0.3 * np.sin(2 * np.pi * phase)
    big_v, big_a = 0.6 * np.pi / period * np.cos(2 * np.pi * phase), -(2 * np.pi / period) ** 2 * big
    tau = 5 * np.cos(2 * np.pi * phase) + k_bins[which] * x + 0.8 * xv + 0.012 * xa
    tau = tau + rng.normal(0.0, noise * np.std(tau), n)
    signals = phase_channels(np.stack([tau, big + x, big_v + xv, big_a + xa]), phase, bins=200)
    return signals, which, cycle, k_bins


def _least_squares(seed: int, *, n_cycles: int = 40):
    signals, which, cycle, k_bins = _ensemble(seed, n_cycles=n_cycles)
    ls = binned_least_squares(*signals, which=which, unit=cycle, bins=BINS, level=0.9, resolution=1e-5,
                              rng=np.random.default_rng([seed, 1]), how="test")
    return ls, k_bins


def test_least_squares_interval_holds_the_exact_stiffness_at_its_level():
    # 6 seeded ensembles × 50 bins: a calibrated 90 % interval holds K in 90 % of the 300 bins,
    # sd √(0.9·0.1/300) = 1.7 %; 0.84–0.96 is ±3.5 sd (too narrow and too wide both fail)
    inside, errors = [], []
    for seed in range(6):
        ls, k = _least_squares(seed)
        assert ls.informed.all()
        inside.append((ls.lo <= k) & (k <= ls.hi))
        errors.append(np.abs(ls.stiffness / k - 1))
    coverage = np.mean(inside)
    assert 0.84 <= coverage <= 0.96, coverage
    # 40 cycles × 20 ms of perturbation per bin at 5 % noise: about 1 % off (measured 0.6–0.9 %)
    assert np.median(errors) < 0.02


def test_least_squares_leaves_a_bin_without_perturbation_out():
    signals, which, cycle, _ = _ensemble(3)
    quiet = which == 10
    signals[1:, quiet] = 0.0              # no motion at all there: θ̃, θ̃', θ̃'' zero
    ls = binned_least_squares(*signals, which=which, unit=cycle, bins=BINS, level=0.9, resolution=1e-5,
                              rng=np.random.default_rng(0), how="test")
    assert not ls.informed[10] and ls.informed[np.arange(BINS) != 10].all()


def test_schedule_channels_take_each_stretch_trend_off():
    t = np.arange(4000) / FS
    u = 0.1 * t + 0.05 * np.sin(2 * np.pi * 0.3 * t)
    unit = (t // 1.0).astype(int)
    wiggle = np.sin(2 * np.pi * 7 * t)
    out = schedule_channels(np.stack([3.0 + 2.0 * t + 0.7 * t ** 2 + 5.0 * u, wiggle]), u, unit, t)
    # what is quadratic in time and linear in the schedule goes (to rounding)
    assert np.abs(out[0]).max() < 1e-9
    # a 7 Hz wiggle stays: its projection on a line over a 1 s stretch holds (12/(2π·7))²/12 / ½
    # = 1.2 % of its variance, correlation ≈ 0.994 (the square and the schedule's slow sine take a little more)
    assert np.corrcoef(out[1], wiggle)[0, 1] > 0.98


def _curve(stiffness, lo, hi, *, correlation=0.0):
    edges = np.linspace(0, 1, BINS + 1)
    nan = np.full(BINS, np.nan)
    return ScheduleCurve("phase", "1", (edges[1:] + edges[:-1]) / 2, edges, np.asarray(stiffness, float),
                         np.asarray(lo, float), np.asarray(hi, float), np.full(BINS, 40), nan, nan, 0.9,
                         np.linspace(0, 1, 8), np.asarray(lo, float), np.asarray(hi, float), correlation)


def test_cross_check_is_quiet_on_a_correct_curve_and_fires_on_one_off_by_half():
    """Two independent honest estimates (least squares on two realisations of the same ensemble)
    agree; the same curve at half its level does not, on every seed."""
    for seed in range(4):
        other, _ = _least_squares(100 + seed)
        ls, _ = _least_squares(seed)
        right = _curve(other.stiffness, other.lo, other.hi, correlation=other.adjacent_correlation)
        assert least_squares_check(right, ls).passed, least_squares_check(right, ls).message
        wrong = _curve(0.5 * other.stiffness, 0.5 * other.lo, 0.5 * other.hi)
        check = least_squares_check(wrong, ls)
        assert not check.passed and check.severity == Verdict.CAUTION
        assert "phase 0–1" in check.message and "band may not hold" in check.message


def test_chance_share_from_the_binomial_tail():
    # 50 independent bins at 10 % each: P(X ≥ 11) = 0.009 ≤ 1 %, P(X ≥ 10) = 0.025: 11 of 50
    assert chance_share(50, 0.0, 0.9) == pytest.approx(11 / 50)
    # neighbours correlated 0.6: worth 50·0.4/1.6 = 12.5 → 12 comparisons, P(X ≥ 5) = 0.004, P(X ≥ 4) = 0.026
    assert chance_share(50, 0.6, 0.9) == pytest.approx(5 / 12)


def test_a_band_wholly_below_zero_is_unreliable_and_named():
    k = np.full(BINS, 20.0)
    k[20:24] = -8.0
    curve = _curve(k, k - 3, k + 3)
    check = negative_check(curve)
    assert not check.passed and check.severity == Verdict.UNRELIABLE and check.value == 4
    assert "phase 0.4–0.48" in check.message
    # a band that reaches zero from below is not wholly below it
    assert negative_check(_curve(k, k - 3, np.where(k < 0, 0.5, k + 3))).passed


def _analysis(band_checks, trial_checks=()):
    curve = _curve(np.full(BINS, 20.0), np.full(BINS, 19.0), np.full(BINS, 21.0))
    return CurveAnalysis(curve, None, {}, (), np.zeros(1), None, tuple(band_checks),
                         ModelChecks(tuple(trial_checks)))


def test_curve_verdict_rules():
    fine = Check("curve_least_squares", 0.0, 0.2, True, "agrees")
    below = Check("curve_negative", 3.0, 0.0, False, "below zero at phase 0.4–0.46", Verdict.UNRELIABLE)
    apart = Check("curve_least_squares", 0.6, 0.2, False, "the model lacks a feature of the data there")
    trial_caution = Check("whiteness", 0.9, 0.8, False, "the residual is not white", Verdict.CAUTION)
    assert _analysis([fine]).verdict == Verdict.OK and _analysis([fine]).reasons == ()
    assert _analysis([apart]).verdict == Verdict.CAUTION
    assert _analysis([apart]).reasons[0] == "the model lacks a feature of the data there"
    # the below-zero rule wins over everything: never ok
    assert _analysis([apart, below]).verdict == Verdict.UNRELIABLE
    assert _analysis([apart, below]).reasons[0].startswith("below zero")
    # the trial's verdict carries to the curve, its reason after the curve's own
    mixed = _analysis([apart], [trial_caution])
    assert mixed.verdict == Verdict.CAUTION and mixed.reasons == (apart.message, trial_caution.message)
    assert _analysis([fine], [trial_caution]).verdict == Verdict.CAUTION


def test_resampled_band_shows_the_units_spread():
    rng = np.random.default_rng(0)
    hits = np.full((3, 40), 10.0)
    means = np.stack([np.full(40, 5.0), rng.normal(5.0, 1.0, 40), rng.normal(5.0, 4.0, 40)])
    lo, hi = resampled_band(hits, means * hits, level=0.9, rng=np.random.default_rng(1))
    width = hi - lo
    # equal units: no width; sd 1 and 4 over 40 units: the mean's 90 % width 2·1.645·sd/√40 = 0.52 sd
    assert width[0] == pytest.approx(0.0, abs=1e-12)
    assert width[1] == pytest.approx(0.52 * np.std(means[1]), rel=0.3)
    assert width[2] == pytest.approx(0.52 * np.std(means[2]), rel=0.3)


def test_a_level_off_on_correlated_bins_is_found_by_the_mean_difference():
    """Neighbouring bins correlated 0.95 leave ~1 independent comparison: the count of disagreeing
    bins cannot tell, the mean difference can (a curve at 0.7 of the fit's level, bands ±5 %)."""
    ls, _ = _least_squares(7)
    k = ls.stiffness
    assert chance_share(50, 0.95, 0.9) > 1.0                   # one comparison: never by count
    low = _curve(0.7 * k, 0.7 * k * 0.95, 0.7 * k * 1.05, correlation=0.95)
    check = least_squares_check(low, dataclasses.replace(ls, adjacent_correlation=0.95))
    assert not check.passed and "below the fit on average" in check.message
    # the message leads with what failed (the level), not with a count chance allows
    assert "differ in level" in check.message and "disagree beyond their bands in" not in check.message
    same = _curve(k, k * 0.95, k * 1.05, correlation=0.95)
    assert least_squares_check(same, dataclasses.replace(ls, adjacent_correlation=0.95)).passed


def test_summary_csv_row_has_the_curve_verdict_blank_without_a_curve():
    from limbstiff.batch.runner import TrialOutcome
    from limbstiff.batch.table import TrialRow, summary_row
    with_curve = TrialRow.from_summary({"verdict": "ok", "by_schedule": {"verdict": "caution"}})
    assert summary_row(TrialOutcome("a", "a.csv", "ok", "", with_curve))["curve_verdict"] == "caution"
    plain = TrialRow.from_summary({"verdict": "ok", "by_phase": None})
    assert summary_row(TrialOutcome("b", "b.csv", "ok", "", plain))["curve_verdict"] is None


def test_misfit_share_measures_the_error_the_band_does_not_hold():
    """A curve 4 % off (rms, a slow wave over the phase) with a band of ±0.5 %: the misfit against
    an honest least-squares fit is an upper bound of that 4 %, and the widened band then holds the
    truth; a curve that is right gets no more than the fit's own precision leaves open."""
    from limbstiff.scheduled.least_squares import misfit_share
    for seed in (11, 12):
        ls, k = _least_squares(seed)
        wave = 0.04 * np.sqrt(2) * np.sin(2 * np.pi * np.arange(BINS) / BINS * 3)       # rms 4 %
        off = _curve(k * (1 + wave), k * (1 + wave) * 0.995, k * (1 + wave) * 1.005)
        share = misfit_share(off, ls)
        # an upper 90 % bound: at least the 4 %, and (the fit ~1 % precise, 50 bins) at most half more
        # (measured 4.5–5.1 % on seeds 11–14)
        assert 0.04 <= share <= 0.06
        wide = off.widened(share)
        assert wide.misfit == share and np.mean((wide.lo <= k) & (k <= wide.hi)) >= 0.85
        assert np.mean((off.lo <= k) & (k <= off.hi)) < 0.2                # the band it had did not
        right = _curve(k, k * 0.99, k * 1.01)
        # the fit's own relative σ is ~1.1 %: a right curve's bound stays below three of them
        # (measured 0–2.3 σ on seeds 11–14)
        sigma = np.median((ls.hi - ls.lo) / (2 * 1.645) / k)
        assert misfit_share(right, ls) < 3 * sigma


def test_interpolation_error_is_the_straight_lines_error_between_the_knots():
    """Hat functions draw the curve as straight lines between the knots: against a quadratic
    through the knot values the error ½·t·(1 − t)·h²·|f″| is exact (f″ constant: the knots'
    second differences are it), and against a sinusoid over the phase it is within 2 % of the
    largest true error at 12 and 24 knots (the second difference understates f″ by the factor
    sinc², under 2 % there); zero at the knots and beyond a schedule's end knots."""
    from limbstiff.scheduled.basis import phase_basis, schedule_basis

    b = schedule_basis(6, np.linspace(0.0, 1.0, 500), unit="rad")
    at_knots = 3.0 * b.knots ** 2
    u = np.linspace(b.knots[0], b.knots[-1], 1001)
    err = b.interpolation_error(at_knots[1:] - at_knots[0], u)
    np.testing.assert_allclose(err, np.abs(3.0 * u ** 2 - (at_knots[0] + b.curve(at_knots[1:] - at_knots[0], u))),
                               atol=1e-12)
    assert np.all(b.interpolation_error(at_knots[1:] - at_knots[0], np.array([-0.5, 1.5])) == 0.0)
    for knots in (12, 24):
        p = phase_basis(knots)
        at_knots = 10.0 * np.sin(2 * np.pi * p.knots)
        u = np.linspace(0.0, 1.0, 4001)[:-1]
        bound = p.interpolation_error(at_knots[1:] - at_knots[0], u)
        true = np.abs(10.0 * np.sin(2 * np.pi * u) - (at_knots[0] + p.curve(at_knots[1:] - at_knots[0], u)))
        assert abs(bound.max() / true.max() - 1) < 0.02
        assert np.all(p.interpolation_error(at_knots[1:] - at_knots[0], p.knots) < 1e-12)


def test_the_band_holds_the_interpolation_error_in_quadrature():
    """widened(misfit=0, interpolation) widens the posterior's half-width h to √(h² + e²) bin by
    bin, and leaves bins without an error as they were."""
    from limbstiff.scheduled.curve import ScheduleCurve

    k = np.full(4, 50.0)
    curve = ScheduleCurve("phase", "1", np.arange(4) / 4 + 0.125, np.linspace(0, 1, 5), k, k - 1.0, k + 1.0,
                          np.full(4, 20), np.full(4, np.nan), np.full(4, np.nan), 0.9, np.arange(4) / 4,
                          k - 1.0, k + 1.0)
    wide = curve.widened(0.0, np.array([0.0, 1.0, 3.0, 0.0]))
    np.testing.assert_allclose(wide.hi - k, [1.0, np.sqrt(2.0), np.sqrt(10.0), 1.0])
    # its share: the median over the bins of error ÷ stiffness, (0 + 1/50) / 2 between the middle two
    assert wide.interpolation_share == 0.01 and wide.to_dict()["band"]["interpolation_share"] == 0.01
