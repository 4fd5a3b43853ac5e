"""The offline estimators on small, seeded versions of the accuracy benchmark's scenarios.

Targets (issue: accurate stiffness from noisy, quantised recordings): median relative error
≤ 3 %, 90th percentile ≤ 10 % after the first 2 s, and band coverage ≥ 80 % for a nominal 90 %.
Seeds here (7, 8) differ from the benchmark's (100+).
"""

import numpy as np
import pytest

from limbstiff.statespace import kernels
from limbstiff.analysis import analyze
from limbstiff.protocol import Protocol
from limbstiff.simulate import simulate


def _errors(result, skip=2.0):
    t = result.trial.time
    use = result.observable & (t - t[0] >= skip)
    truth = result.trial.stiffness_true[use]
    rel = np.abs(result.stiffness[use] - truth) / truth
    inside = (result.stiffness_lo[use] <= truth) & (truth <= result.stiffness_hi[use])
    return np.median(rel), np.percentile(rel, 90), inside.mean()


@pytest.mark.parametrize("scenario, params", [
    ("elbow", {"duration": 20.0}),                      # the elbow: 8000 counts, 0.01 N·m
    ("elbow", {"duration": 12.0, "fs": 1000 / 15}),     # the paper's 66.7 Hz
    ("ankle", {"duration": 12.0, "stiffness_variation": 0.3, "variation_period": 6.0}),
    ("wrist", {"duration": 12.0}),
])
@pytest.mark.slow
def test_default_estimator_meets_the_targets(scenario, params):
    result = analyze(simulate(scenario, seed=7, params=params))
    assert result.estimator == "kalman"
    median, p90, coverage = _errors(result)
    assert median <= 0.03 and p90 <= 0.10
    assert coverage >= 0.80


def test_identified_inertia_and_damping_on_the_elbow():
    # true 0.06 kg·m² and 0.45 N·m·s/rad; the benchmark finds them within 1 %
    result = analyze(simulate("elbow", seed=8, params={"duration": 12.0}))
    assert result.inertia.median == pytest.approx(0.06, rel=0.03)
    assert result.damping.median == pytest.approx(0.45, rel=0.03)
    assert result.inertia.lo < result.inertia.median < result.inertia.hi


def test_band_widens_and_observable_drops_without_motion():
    trial = simulate("elbow", seed=7, params={"duration": 14.0, "pause_start": 6.0, "pause_duration": 4.0})
    result = analyze(trial)
    t = trial.time
    width = result.stiffness_hi - result.stiffness_lo
    pause = (t > 8.0) & (t < 9.5)                       # motion has died out after ~1–2 s
    moving = (t > 3.0) & (t < 5.5)
    assert result.observable[pause].mean() < 0.2 and result.observable[moving].mean() > 0.95
    assert np.median(width[pause]) > 2 * np.median(width[moving])


def test_uninformed_band_spans_the_trials_range():
    """Where no motion informs the estimate the band holds at least the informed band's range
    (exact on a made-up band); informed samples keep the model's band; nothing informed, or
    everything, leaves the band as it is."""
    from limbstiff.estimate.informed import uninformed_band
    lo, hi = np.array([1.0, 2.0, 9.0, 4.0]), np.array([3.0, 5.0, 9.5, 6.0])
    observable = np.array([True, True, False, True])
    new_lo, new_hi = uninformed_band(lo, hi, observable)
    np.testing.assert_array_equal(new_lo, [1.0, 2.0, 1.0, 4.0])
    np.testing.assert_array_equal(new_hi, [3.0, 5.0, 9.5, 6.0])        # 9.5 is already wider than 6
    for mask in (np.zeros(4, bool), np.ones(4, bool)):
        assert all(a is b for a, b in zip(uninformed_band(lo, hi, mask), (lo, hi)))


@pytest.mark.slow
def test_a_motion_pause_holds_the_truth():
    """Elbow with a 4 s pause (seed 2, whose model band in the pause held the truth 56 % of the
    time): the true stiffness ramps 6 → 30 N·m/rad and stays within the trial's range, so the
    widened band holds it in every uninformed sample after the first 2 s."""
    trial = simulate("elbow", seed=2, params={"duration": 20.0, "pause_start": 12.0, "pause_duration": 4.0})
    result = analyze(trial, seed=0)
    use = (trial.time - trial.time[0] >= 2.0) & ~result.observable
    inside = (result.stiffness_lo <= trial.stiffness_true) & (trial.stiffness_true <= result.stiffness_hi)
    assert use.sum() > 1000 and inside[use].mean() == 1.0


def test_band_informed_drops_samples_whose_band_is_three_times_wider():
    """Exact on a made-up variance: the typical variance is the median over the samples informed
    by motion (here 1); 9 = 3² is still informed, 9.5 is not; uninformed samples stay so."""
    from limbstiff.estimate.informed import band_informed
    variance = np.array([1.0, 1.0, 9.0, 9.5, 1.0, 100.0])
    observable = np.array([True, True, True, True, True, False])
    np.testing.assert_array_equal(band_informed(variance, observable), [True, True, True, False, True, False])
    few = np.array([True, True, False, False, False, False])
    assert band_informed(variance, few) is few                 # fewer than 3 usable samples: left as it is


@pytest.mark.slow
def test_a_pause_the_independent_simulator_drifts_through_is_not_informed(tmp_path):
    """The independent simulator's clean co-contraction elbow with a 3 s pause (suite seed 7200,
    ``tests/support/independent_trials.py``, written without limbstiff's code): the limb drifts at
    about 3 % of its speed in the pause, far above the velocity noise, so the motion criterion
    alone counts the pause as informed, and there the model's band held the truth in 20 % of the
    samples (the stiffness swings 27 → 13 → 24 N·m/rad across the gap). Its band is over three
    times its typical width, so the pause is not informed; the band over the informed samples
    after 2 s then holds the truth in 96 % of them (88 % before). Bounds: the 90 % band's
    coverage on one trial, between 85 % (below: too narrow) and 99 % (above: no longer a 90 % band)."""
    import json

    from limbstiff.files import read_trial

    from .support import independent_trials
    spec = next(s for s in independent_trials.suite(7200) if s.name == "clean-pause-elbow")
    independent_trials.write_trial(spec, tmp_path)
    truth = json.loads((tmp_path / f"{spec.name}.json").read_text())
    result = analyze(read_trial(tmp_path / f"{spec.name}.csv"), seed=0)
    start, end = truth["motion"]["pause_s"]
    t = result.trial.time - result.trial.time[0]
    assert result.observable[(t > start + 0.5) & (t < end - 0.5)].mean() < 0.2
    assert 0.85 <= result.reference_error()["coverage"] <= 0.99


@pytest.mark.slow
def test_smoothed_observer_beats_the_causal_one():
    trial = simulate("elbow", seed=7, params={"duration": 12.0})
    causal = _errors(analyze(trial, Protocol(estimator="observer")))
    smoothed = _errors(analyze(trial, Protocol(estimator="observer-smoothed")))
    assert smoothed[0] < causal[0]


@pytest.mark.slow
def test_observer_sensitivity_is_exact():
    # docs/architecture.md, fact 2 through the whole estimator: σ̂(m + Δm, b + Δb) = σ̂ + Δm·g0 + Δb·g1
    trial = simulate("elbow", seed=7, params={"duration": 6.0})
    for est in ("observer", "observer-smoothed", "kalman"):
        base = analyze(trial, Protocol(estimator=est, inertia=0.06, damping=0.45))
        moved = analyze(trial, Protocol(estimator=est, inertia=0.066, damping=0.40))
        from limbstiff.estimate import estimators
        filtered = base.filtered
        kw = dict(inertia=0.06, damping=0.45)
        if est == "kalman":
            noise = base.fit.noise
            e0 = estimators.kalman(filtered, noise=noise, **kw)
            e1 = estimators.kalman(filtered, noise=noise, inertia=0.066, damping=0.40)
        else:
            opts = dict(smoothed=est == "observer-smoothed", gain=base.derived.observer_gain,
                        velocity_threshold=base.derived.velocity_threshold)
            e0 = estimators.observers(filtered, **opts, **kw)
            e1 = estimators.observers(filtered, **opts, inertia=0.066, damping=0.40)
        predicted = e0.stiffness + 0.006 * e0.sensitivity[0] - 0.05 * e0.sensitivity[1]
        scale = np.max(np.abs(e1.stiffness))
        assert np.max(np.abs(predicted - e1.stiffness)) < 1e-8 * scale
        assert moved.stiffness.shape == base.stiffness.shape


@pytest.mark.skipif(not kernels.COMPILED, reason="numba not installed: only the reference runs")
def test_compiled_kernels_equal_the_reference():
    rng = np.random.default_rng(0)
    n = 500
    a, c = rng.uniform(0.5, 1.0, n), rng.standard_normal(n)
    np.testing.assert_allclose(kernels.linear_recursion(a, c, 0.3),
                               kernels.linear_recursion.py_func(a, c, 0.3), rtol=1e-12)
    d, z, acc, vel, g = 0.01 * rng.standard_normal((5, n))
    args = (d, g, z, 1e-3, 1e-4, 1e-2, 3e-2, 0.0, 1.0, 1.0, 0.0, 4.0)
    obs = np.ones(n, dtype=bool)
    fast = kernels.kalman_filter(*args[:3], obs, *args[3:], True)
    ref = kernels.kalman_filter.py_func(*args[:3], obs, *args[3:], True)
    for x, y in zip(fast, ref):
        np.testing.assert_allclose(x, y, rtol=1e-9, atol=1e-12)
    assert kernels.kalman_loglik(*args, 0.0) == pytest.approx(fast[2], rel=1e-12)
    for x, y in zip(kernels.rts_smoother(d, g, *fast[:2], 1e-4, 1e-2, 3e-2),
                    kernels.rts_smoother.py_func(d, g, *ref[:2], 1e-4, 1e-2, 3e-2)):
        np.testing.assert_allclose(x, y, rtol=1e-9, atol=1e-12)
    chans, slopes = np.vstack([z, acc, vel]), np.array([0.3, 0.1, 0.2])
    args = (d, g, chans, slopes, 1e-3, 1e-4, 1e-2, 3e-2, 1.0, 4.0, np.zeros(n, dtype=bool))
    for x, y in zip(kernels.kalman_quadratic(*args), kernels.kalman_quadratic.py_func(*args)):
        np.testing.assert_allclose(x, y, rtol=1e-9)
    # the quadratic form equals the direct two-state likelihood of z = f − m·ÿ − b·ẏ
    m, b = 0.05, 0.4
    sls, a = kernels.kalman_quadratic(*args)
    w = np.array([1.0, -m, -b])
    zz = z - m * acc - b * vel
    # same initial mean as the quadratic form: first value and slope of z
    direct = kernels.kalman_loglik(d, g, zz, 1e-3, 1e-4, 1e-2, 3e-2, zz[0], slopes @ w, 1.0, 0.0, 4.0, 0.0)
    assert -0.5 * (n * np.log(2 * np.pi) + sls + w @ a @ w) == pytest.approx(direct, rel=1e-10)


def test_smoother_in_place_equals_the_textbook_pass():
    # The RTS pass recomputes the predicted moments instead of storing them; a textbook pass
    # with explicit matrices and stored predictions (written here independently) must agree.
    rng = np.random.default_rng(5)
    # The process noise has both stiffness walks: Q = diag(qs, qk) + qc·[[g², g], [g, 1]].
    n, r, qs, qk, qc = 300, 1e-3, 1e-4, 1e-2, 3e-2
    d, z, g = 0.01 * rng.standard_normal((3, n))
    mean, cov, _ = kernels.kalman_filter(d, g, z, np.ones(n, dtype=bool), r, qs, qk, qc, 0.0, 1.0, 1.0, 0.0, 4.0,
                                         False)
    filt_m = [np.array(m) for m in mean]
    filt_p = [np.array([[c[0], c[1]], [c[1], c[2]]]) for c in cov]
    sm, sc = kernels.rts_smoother(d, g, mean.copy(), cov.copy(), qs, qk, qc)
    xs, ps = filt_m[-1], filt_p[-1]
    for i in range(n - 2, -1, -1):
        f = np.array([[1.0, d[i + 1]], [0.0, 1.0]])
        q = np.diag([qs, qk]) + qc * np.outer([g[i + 1], 1.0], [g[i + 1], 1.0])
        xp, pp = f @ filt_m[i], f @ filt_p[i] @ f.T + q
        c = filt_p[i] @ f.T @ np.linalg.inv(pp)
        xs, ps = filt_m[i] + c @ (xs - xp), filt_p[i] + c @ (ps - pp) @ c.T
        # matrix products in another order than the kernel's: agreement to rounding, not bits
        np.testing.assert_allclose(sm[i], xs, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(sc[i], [ps[0, 0], ps[0, 1], ps[1, 1]], rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("joint, params", [
    ("elbow", {"inertia": 0.07, "damping": 0.35, "duration": 10.0}),
    ("ankle", {"inertia": 0.012, "damping": 1.2, "duration": 10.0}),
])
@pytest.mark.slow
def test_posterior_recovers_inertia_and_damping(joint, params):
    # seeds and sizes differ from benchmarks/identify.py; its 200-trial study finds median
    # errors of a fraction of a percent, so 5 % (m) and 10 % (b) are the targets
    from limbstiff.analysis import identify_trial
    ident = identify_trial(simulate(joint, seed=77, params=params), Protocol(), seed=3)
    assert ident.inertia.median == pytest.approx(params["inertia"], rel=0.05)
    assert ident.damping.median == pytest.approx(params["damping"], rel=0.10)
    mcmc = ident.posterior.diagnostics
    assert mcmc.converged and mcmc.chain_in_autocorr_times >= 50
    assert ident.inertia.lo < ident.inertia.median < ident.inertia.hi


def test_angle_terms_recover_a_known_angle_dependence():
    """Torque of a spring σ = 20 + β₁·g + β₂·(g² − mean g²) through ds = σ·dy (generated by the
    regressors' own definition), white noise 0.002 N·m, noise levels given: GLS on the
    innovations recovers β within 4 of its standard errors (seeded; the errors measured were 2.6
    and 0.7), the Wald statistic is huge, and what the course misses is the whole term (the walks
    are too slow to follow it: within 10 %). Without the term the Wald statistic stays below χ²₂'s
    0.1 % point (measured 5.2)."""
    from limbstiff.estimate.angle_terms import angle_regressors, fit_angle_terms
    from limbstiff.statespace.noise import NoiseLevels
    from limbstiff.statespace.steps import model_steps
    rng = np.random.default_rng(3)
    fs = 100.0
    t = np.arange(0, 60.0, 1 / fs)
    y = 0.1 * np.sin(2 * np.pi * t) + 0.05 * np.sin(2 * np.pi * 1.7 * t + 1)
    noise = NoiseLevels(0.002 ** 2, 1e-8, 1e-6, 1e-6)
    U, H = angle_regressors(model_steps(y, np.zeros_like(y), sample_period=1 / fs, decimation=1, edge=0,
                                        motion_frequency=1.0))
    for beta in (np.zeros(2), np.array([30.0, 400.0])):
        z = 20.0 * y + beta @ U + 0.002 * rng.standard_normal(len(y))
        steps = model_steps(y, z, sample_period=1 / fs, decimation=1, edge=0, motion_frequency=1.0)
        fit = fit_angle_terms(steps, noise, motion_frequency=1.0)
        se = np.sqrt(np.diag(fit.covariance))
        assert np.all(np.abs(fit.coefficients - beta) < 4 * se)
        if beta.any():
            assert fit.wald > 1e4
            assert fit.variation(np.ones(len(y), bool)) == pytest.approx(np.sqrt(np.mean((beta @ H) ** 2)), rel=0.1)
        else:
            assert fit.wald < 13.8155


def test_angle_terms_are_not_claimed_where_the_motion_cannot_tell_them_apart():
    """A joint held still: the terms add no torque (their regressors are zero), so their
    information matrix is singular — no fit (None), rather than a number from a singular matrix."""
    from limbstiff.estimate.angle_terms import fit_angle_terms
    from limbstiff.statespace.noise import NoiseLevels
    from limbstiff.statespace.steps import model_steps
    y = np.full(3000, 0.2)
    torque = 1.0 + 1e-3 * np.random.default_rng(0).standard_normal(3000)
    steps = model_steps(y, torque, sample_period=0.01, decimation=1, edge=0, motion_frequency=1.0)
    assert fit_angle_terms(steps, NoiseLevels(1e-6, 1e-8, 1e-6, 1e-6), motion_frequency=1.0) is None
