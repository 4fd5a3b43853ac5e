"""Calibrated uncertainty: exact answers for the pieces, a small simulation-based calibration for the whole.

The large study (200 trials per run, rank statistics per joint) is ``benchmarks/identify.py``.
"""

from __future__ import annotations

import numpy as np
import pytest

from limbstiff.statespace.noise import NoiseLevels
from limbstiff.statespace.smoother import kalman_smoother
from limbstiff.statespace.steps import model_steps
from limbstiff.estimate.course_draws import course_deviations
from limbstiff.mechanics.fixed_b import bartlett_fixed_b
from limbstiff.statespace.linear import long_run_covariance
from limbstiff.trial_level import trial_level


def test_course_draws_have_the_smoothers_posterior_variance():
    # Durbin & Koopman's simulation smoother draws from the smoothed posterior: the variance over
    # draws at each step must be the smoother's own (the states themselves, not aligned). 2000 draws: a variance's relative standard error is √(2/2000) = 3 %; the median over steps
    # is within ±10 % unless the draws are wrong (too tight without the walk, too wide without the data).
    rng = np.random.default_rng(11)
    n, step = 400, 0.02
    t = np.arange(n) * step
    y = 0.1 * np.sin(2 * np.pi * 0.9 * t) + 0.04 * np.sin(2 * np.pi * 2.3 * t)
    z = np.cumsum(np.r_[0, 30 * np.diff(y)]) + rng.normal(0, 0.05, n)
    st = model_steps(y, z, sample_period=step, decimation=1, edge=0, motion_frequency=0.9)
    noise = NoiseLevels(0.05 ** 2, 1e-4, 20.0, 10.0)        # both kinds of stiffness walk
    smoothed = kalman_smoother(st.increments, st.measured, noise, step=step, deflection=st.deflection,
                                      initial_mean=st.initial_mean, initial_cov=st.initial_cov)
    dev = course_deviations(st, noise, draws=2000, rng=np.random.default_rng(3), aligned=False)
    ratio = dev.var(axis=0) / smoothed.cov[:, 2]
    assert 0.9 < np.median(ratio) < 1.1
    assert abs(np.median(dev.mean(axis=0) / np.sqrt(dev.var(axis=0)))) < 0.1     # centred on the estimate
    # the kept columns are those of the full draws (same generator, same blocks)
    from limbstiff.estimate import course_draws
    columns = np.array([0, 7, 199, 399])
    full = course_deviations(st, noise, draws=30, rng=np.random.default_rng(5))
    kept = course_deviations(st, noise, draws=30, rng=np.random.default_rng(5), columns=columns)
    np.testing.assert_array_equal(kept, full[:, columns])
    # drawn in blocks of 3 (as a long trial is), the draws have the same variance (±10 %, as above)
    course_draws.BLOCK_VALUES, saved = 400 * 3, course_draws.BLOCK_VALUES
    try:
        small = course_deviations(st, noise, draws=2000, rng=np.random.default_rng(4), aligned=False)
    finally:
        course_draws.BLOCK_VALUES = saved
    assert 0.9 < np.median(small.var(axis=0) / smoothed.cov[:, 2]) < 1.1


def test_long_run_covariance_of_an_ma1_series():
    # scores x_k = e_k + e_{k−1} (MA(1), e white of unit variance): the variance of their sum is
    # n·(1 + 1 + 2·1) = 4n exactly in the limit; with Bartlett weights at 20 lags the lag-1 term is
    # weighted by 1 − 1/21, so the expectation is n·(2 + 2·20/21). 20 000 terms: ±3 % holds it.
    e = np.random.default_rng(2).standard_normal(20_001)
    x = (e[1:] + e[:-1])[:, None]
    expected = len(x) * (2 + 2 * 20 / 21)
    assert long_run_covariance(x, 20)[0, 0] == pytest.approx(expected, rel=0.03)
    assert long_run_covariance(x, 0)[0, 0] == pytest.approx(2 * len(x), rel=0.03)   # no lags: the white formula


def _bartlett_limit(b, paths=8000, grid=500, seed=3):
    """|W(1)|/√Q(b) on simulated Brownian paths (Kiefer & Vogelsang 2005), and the Q(b)."""
    rng = np.random.default_rng(seed)
    r = np.arange(1, grid + 1) / grid
    w = np.cumsum(rng.standard_normal((paths, grid)), axis=1) / np.sqrt(grid)
    bridge = w - r * w[:, -1:]
    lag = int(round(b * grid))
    q = (2 / b) * (np.mean(bridge ** 2, axis=1) - np.sum(bridge[:, lag:] * bridge[:, :-lag], axis=1) / grid)
    return np.abs(w[:, -1]) / np.sqrt(q), q


@pytest.mark.parametrize("b", [0.05, 0.15, 0.25])
def test_fixed_b_limit_of_the_bartlett_long_run_variance(b):
    # E[Q(b)] = 1 − b + b²/3 exactly (∫(r − r²) = 1/6 and ∫₀^{1−b} r·(1 − b − r) = (1 − b)³/6); on
    # 8000 paths the simulated mean is within 2 % (sd of Q ≤ 0.5, so its mean's sd ≤ 0.6 %) and
    # the variance within 10 % (a χ²-like variance over 8000 draws: sd ~3 %)
    from scipy import stats
    fb = bartlett_fixed_b(b)
    t, q = _bartlett_limit(b)
    assert fb.mean == pytest.approx(1 - b + b * b / 3, rel=1e-12)
    assert np.mean(q) == pytest.approx(fb.mean, rel=0.02)
    assert np.var(q) == pytest.approx(2 * fb.mean ** 2 / fb.dof, rel=0.10)
    # the 90 % critical value of t_ν/√mean against the limit's: its 90 % quantile from 8000 draws
    # has sd ~1.5 %, so ±4 % holds it; 1.645 (the sandwich taken as exact) is outside by b = 0.05
    critical = stats.t.ppf(0.95, fb.dof) / np.sqrt(fb.mean)
    assert critical == pytest.approx(np.quantile(t, 0.9), rel=0.04)
    assert not 1.645 == pytest.approx(np.quantile(t, 0.9), rel=0.04)
    # draws scaled by spread_factors have that t distribution (40 000 draws: within ±4 % as above)
    z = np.random.default_rng(5).standard_normal(40_000)
    scaled = z * fb.spread_factors(len(z), np.random.default_rng(6))
    assert np.quantile(np.abs(scaled), 0.9) == pytest.approx(critical, rel=0.04)


def test_no_lags_is_the_gaussian_limit():
    fb = bartlett_fixed_b(0.0)
    assert (fb.mean, fb.dof) == (1.0, np.inf)
    assert np.all(fb.spread_factors(5, np.random.default_rng(0)) == 1.0)


def test_trial_level_intervals_cover_the_median_of_known_draws():
    # draws of a constant course 10 + a shared offset N(0, 1): the median's 90 % interval is
    # 10 ± 1.645 (to sampling error of the 5 %/95 % quantiles of 4000 draws, ±0.1); the slope
    # against a torque that carries no information about the offset is 0 with a zero-width interval
    rng = np.random.default_rng(0)
    m = 50
    draws = 10 + rng.standard_normal((4000, 1)) + np.zeros((1, m))
    torque = np.linspace(0, 5, m)
    level = trial_level(np.full(m, 10.0), draws, torque, level=0.9, sources=("course",))
    assert level.median_stiffness.lo == pytest.approx(10 - 1.645, abs=0.1)
    assert level.median_stiffness.hi == pytest.approx(10 + 1.645, abs=0.1)
    assert level.stiffness_torque_slope.median == pytest.approx(0.0, abs=1e-12)
    assert level.stiffness_torque_slope.hi - level.stiffness_torque_slope.lo == pytest.approx(0.0, abs=1e-9)


@pytest.mark.slow
def test_simulation_based_calibration_of_inertia_and_damping():
    # SBC in small (Talts et al. 2018, arXiv:1804.06788): m, b, the stiffness course, noise and encoder
    # drawn at random as in benchmarks/identify.py (support/recovery_trials.py, 10 s instead of 20), simulated by
    # the physical simulator (not the Kalman model), identified. The truth's rank among the posterior
    # draws is uniform when the posterior is calibrated: over 18 trials × 2 parameters the share inside
    # the 90 % interval must lie in 0.72–0.99 (binomial: 36 intervals at 0.9 fall outside with
    # probability < 2 %; before this work the share was about 0.6) and the mean rank in 0.35–0.65
    # (a bias shows as ranks piled at one end: before, b's ranks sat near 0).
    from limbstiff.analysis import identify_trial
    from limbstiff.protocol import Protocol
    from limbstiff.simulate import simulate

    from .support.recovery_trials import draw_trial
    ranks, inside = [], []
    for i in range(18):
        joint, params, seed = draw_trial(i)
        params = dict(params, duration=10.0)
        ident = identify_trial(simulate(joint, seed=seed, params=params), Protocol(), seed=seed)
        for j, name in enumerate(("inertia", "damping")):
            draws, truth = ident.posterior.mechanics[:, j], params[name]
            ranks.append(float(np.mean(draws < truth)))
            iv = getattr(ident, name)
            inside.append(iv.lo <= truth <= iv.hi)
    assert 0.72 <= np.mean(inside) <= 0.99
    assert 0.35 <= np.mean(ranks) <= 0.65


def test_angle_error_effect_reports_the_fits_mean_change_spread_and_sandwich_increase():
    # The contract of angle_error_effect, exact: shift = mean refit − exact-angle fit, covariance =
    # their sample covariance × (1 + 1/draws), in_residual = the mean increase of the refits'
    # sandwiches over the exact-angle fit's; the exact-angle channels are passed first, and every
    # later call gets an angle rounded to the quantisation grid, through the same chain (the
    # rounding error is at most half a step; the low-pass chain's overshoot keeps y within 1.5).
    from limbstiff.filtered import filter_trial
    from limbstiff.mechanics.angle_error import angle_error_effect
    from limbstiff.protocol import Protocol
    from limbstiff.simulate import simulate
    f = filter_trial(simulate("elbow", seed=2, params={"duration": 5.0}), Protocol())
    step = float(f.bandwidth.quantisation_step)
    assert step == pytest.approx(2 * np.pi / 8000, rel=0.01)          # the simulated encoder's counts
    smooth = f.chain.apply(f.angle, 2)
    calls, draws = [], 6
    estimates = np.array([[1.0, 2.0]] + [[1.0 + 0.1 * j, 2.0 - 0.05 * j * j] for j in range(1, draws + 1)])
    increases = [np.diag([0.2 * j, 0.1]) for j in range(1, draws + 1)]

    def fit(channels):
        calls.append(channels)
        j = len(calls) - 1
        return estimates[j], np.eye(2) + (increases[j - 1] if j else 0.0)

    effect = angle_error_effect(f, fit, rng=np.random.default_rng(0), draws=draws)
    np.testing.assert_array_equal(calls[0], smooth)
    assert all(np.max(np.abs(c[0] - smooth[0])) < 1.5 * step for c in calls[1:])
    assert all(np.any(c[0] != smooth[0]) for c in calls[1:])
    np.testing.assert_allclose(effect.shift, estimates[1:].mean(axis=0) - estimates[0])
    np.testing.assert_allclose(effect.covariance, np.cov(estimates[1:].T) * (1 + 1 / draws))
    np.testing.assert_allclose(effect.in_residual, np.mean(increases, axis=0))
    no_sandwich = angle_error_effect(f, lambda c: (np.zeros(2), None), rng=np.random.default_rng(0), draws=3)
    np.testing.assert_array_equal(no_sandwich.in_residual, np.zeros((2, 2)))


@pytest.mark.slow
def test_the_angle_errors_part_of_the_sandwich_is_not_counted_twice():
    # The sandwich is built from the torque residual, which holds the recording's quantisation;
    # the angle error's simulated spread holds it too, so its part (the sandwich's mean increase
    # when a simulated error is added) is taken off. Over 80 of benchmarks/identify.py's elbows
    # that part was 0.62 of m's sandwich (median), 0.08–1.82 (2nd–98th percentiles; above 1 the
    # sandwich's own noise: the difference is then set to 0), so 0.05–2.5 here. The posterior's
    # spread of m then lies between the angle error's variance and that plus the whole sandwich.
    from limbstiff.analysis import identify_trial
    from limbstiff.statespace.steps import kalman_decimation
    from limbstiff.filtered import filter_trial
    from limbstiff.mechanics.likelihood import MechanicsProblem, robust_covariance
    from limbstiff.protocol import Protocol
    from limbstiff.simulate import simulate
    trial = simulate("elbow", seed=4, params={"duration": 10.0})
    ident = identify_trial(trial, Protocol(), seed=4)
    fit = ident.maximum_likelihood
    f = filter_trial(trial, Protocol())
    problem = MechanicsProblem.build(f.angle, f.velocity, f.acceleration, f.torque, sample_period=f.sample_period,
                                     decimation=kalman_decimation(f.sample_period, f.cutoff_hz),
                                     motion_frequency=f.motion_hz, guess=ident.least_squares, edge=f.edge)
    robust = robust_covariance(problem, fit.noise.logs(), np.array([fit.inertia, fit.damping]),
                               motion_frequency=f.motion_hz)
    share = ident.angle_error.in_residual[0, 0] / robust.sandwich[0, 0]
    assert 0.05 < share < 2.5
    assert 0.0 < robust.lag_share < 0.3
    # fixed-b factors widen the sandwich's part by at most ~1.5× in sd at these lag shares
    spread = np.var(ident.posterior.mechanics[:, 0])
    angle = ident.angle_error.covariance[0, 0]
    assert 0.8 * angle < spread < 1.2 * (angle + 2.3 * robust.sandwich[0, 0])
    ankle = identify_trial(simulate("ankle", seed=4, params={"duration": 10.0}), Protocol(), seed=4)
    assert np.all(ankle.angle_error.in_residual == 0.0)               # an exact angle: nothing simulated
