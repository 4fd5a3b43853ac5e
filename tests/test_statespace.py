"""The state-space model's one marginal likelihood, against exact answers.

With the coefficients β of channels 1… in z = c₀ − Σ β_j·c_j, the log-likelihood is a quadratic
form in (1, −β), so its integral over β under a flat prior is exactly
L(β̂) + (p/2)·ln 2π − ½·ln det A_pp, with L(β̂) the ordinary one-channel likelihood of z at the
posterior mean — computed here by the forward pass's one-channel log-likelihood on z itself
(``kalman_loglik``), not through the quadratic form.
"""

from __future__ import annotations

import numpy as np
import pytest

from limbstiff.statespace.linear import innovations, integrate_out, marginal
from limbstiff.statespace.noise import NoiseLevels
from limbstiff.statespace.smoother import kalman_filter, kalman_loglik, kalman_smoother
from limbstiff.statespace.steps import channel_steps, initial_slopes

NOISE = NoiseLevels(0.05, 0.01, 30.0, 10.0)


def _steps(channels: int, seed: int = 4, n: int = 600):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.02
    y = 0.1 * np.sin(2 * np.pi * 0.9 * t) + 0.05 * np.sin(2 * np.pi * 2.3 * t)
    columns = [rng.normal(0, 1, n) for _ in range(channels - 1)]
    torque = 40 * y + sum(0.3 * (j + 1) * c for j, c in enumerate(columns)) + rng.normal(0, 0.2, n)
    return channel_steps(y, np.vstack([torque, *columns]), scale_from=torque, step=0.02, deflection=y - y.mean())


@pytest.mark.parametrize("p", [0, 1, 2, 3])
def test_marginal_likelihood_is_the_gaussian_integral_over_the_coefficients(p):
    steps = _steps(p + 1)
    out = marginal(steps, NOISE)
    w = np.concatenate([[1.0], -out.coefficients])
    z = w @ steps.channels
    at_mean = kalman_loglik(steps.increments, z, NOISE, step=steps.step, deflection=steps.deflection,
                            initial_mean=(z[0], float(w @ steps.slopes)), initial_cov=steps.initial_cov)
    logdet = np.linalg.slogdet(np.linalg.inv(out.covariance))[1] if p else 0.0
    expected = at_mean + 0.5 * p * np.log(2 * np.pi) - 0.5 * logdet
    # both sides sum 600 terms of size ~1: agreement to 1e-9 relative is rounding, not the model
    assert out.loglik == pytest.approx(expected, rel=1e-9)
    if p:   # the coefficients the torque was made with (0.3, 0.6, 0.9), within 5 posterior sd
        truth = 0.3 * np.arange(1, p + 1)
        assert np.all(np.abs(out.coefficients - truth) < 5 * np.sqrt(np.diag(out.covariance)))


def test_the_closed_form_for_two_coefficients_equals_the_general_solve():
    steps = _steps(3)
    e, var = innovations(steps, NOISE)
    sum_log_s = float(np.sum(np.log(var)))
    a = (e / var) @ e.T
    closed = integrate_out(sum_log_s, a, steps.channels.shape[1])
    beta = np.linalg.solve(a[1:, 1:], a[1:, 0])
    general = (-0.5 * (600 * np.log(2 * np.pi) + sum_log_s + a[0, 0] - a[1:, 0] @ beta) + np.log(2 * np.pi)
               - 0.5 * np.linalg.slogdet(a[1:, 1:])[1])
    assert closed.loglik == pytest.approx(general, rel=1e-12)
    np.testing.assert_allclose(closed.coefficients, beta, rtol=1e-10)
    np.testing.assert_allclose(closed.covariance, np.linalg.inv(a[1:, 1:]), rtol=1e-10)


def test_undetermined_coefficients_have_no_likelihood():
    # a column that is zero tells nothing of its coefficient: −inf, not a number from a singular matrix
    steps = _steps(3)
    flat = channel_steps(steps.angle, np.vstack([steps.channels[:2], np.zeros(steps.channels.shape[1])]),
                         scale_from=steps.channels[0], step=steps.step, deflection=steps.deflection)
    assert marginal(flat, NOISE).loglik == -np.inf


def test_the_filter_is_causal_and_the_smoother_is_not():
    # the filtered moments at step k use data up to k only: changing the data after k leaves them
    # unchanged to the bit, while the smoothed ones move
    steps = _steps(1)
    z = steps.channels[0].copy()
    kw = dict(step=steps.step, deflection=steps.deflection, initial_mean=steps.initial_mean,
              initial_cov=steps.initial_cov)
    changed = z.copy()
    changed[400:] += 5.0
    f0, f1 = (kalman_filter(steps.increments, x, NOISE, **kw) for x in (z, changed))
    s0, s1 = (kalman_smoother(steps.increments, x, NOISE, **kw) for x in (z, changed))
    assert np.array_equal(f0.mean[:400], f1.mean[:400])
    assert not np.allclose(s0.mean[300:400], s1.mean[300:400])


def test_initial_slopes_are_linear_in_the_channels():
    # what keeps the smoother's mean exactly affine in m and b
    rng = np.random.default_rng(1)
    y, c = rng.normal(size=200), rng.normal(size=(2, 200))
    np.testing.assert_allclose(initial_slopes(y, c[0] - 0.4 * c[1]),
                               initial_slopes(y, c[0]) - 0.4 * initial_slopes(y, c[1]), atol=1e-12)


def test_the_variants_of_the_one_forward_pass_agree_to_the_bit():
    """kernels._forward's outputs chosen by flags: the log-likelihood, the filtered moments, the
    innovations (one channel, several, either layout) and the quadratic form must be the same
    numbers however they are asked for — each recomputed here from another variant's output in
    the kernel's own order of operations, so that any difference is a fault, not rounding."""
    import math

    from limbstiff.statespace import kernels

    steps = _steps(3, n=300)
    d, g, chans, slopes = steps.increments, steps.deflection, steps.channels, steps.slopes
    r, qs, qk, qc = NOISE.per_step(steps.step)
    p11, _, p22 = steps.initial_cov
    restart = np.zeros(300, dtype=bool)
    restart[150] = True
    e, var = kernels.kalman_channel_innovations(d, g, chans, slopes, r, qs, qk, qc, p11, p22, restart)
    rows, var_rows = kernels.kalman_channel_innovations(d, g, np.ascontiguousarray(chans.T).T, slopes, r, qs, qk, qc,
                                                        p11, p22, restart)
    np.testing.assert_array_equal(rows, e)
    np.testing.assert_array_equal(var_rows, var)
    sum_log_s, a = kernels.kalman_quadratic(d, g, chans, slopes, r, qs, qk, qc, p11, p22, restart)
    expected_a, expected_sum = np.zeros((3, 3)), 0.0
    for k in range(300):
        w = 1.0 / var[k]
        expected_a += np.outer(e[:, k], e[:, k]) * w
        expected_sum += math.log(var[k])
    np.testing.assert_array_equal(a, expected_a)
    assert sum_log_s == expected_sum
    # one channel from a prior of its own: the innovations, the likelihood and the filter's moments
    z = chans[0]
    args = (d, g, z, r, qs, qk, qc, z[0] + 0.3, slopes[0], p11, 0.1, p22)
    e1, var1 = kernels.kalman_innovations(*args)
    loglik = 0.0
    for k in range(300):
        loglik -= 0.5 * (math.log(2.0 * math.pi) + math.log(var1[k]) + e1[k] * e1[k] / var1[k])
    assert kernels.kalman_loglik(*args, 0.0) == loglik
    mean, cov, filtered = kernels.kalman_filter(*args[:3], np.ones(300, dtype=bool), *args[3:], True)
    assert filtered == loglik
    # the filter's mean moves by its gain times the innovation: e = z − (s + σ·d) before the update
    np.testing.assert_array_equal(e1[1:], z[1:] - (mean[:-1, 0] + mean[:-1, 1] * d[1:]))
    # one channel from its first value, no restart: the multi-channel pass's channel 0
    e0, var0 = kernels.kalman_innovations(d, g, z, r, qs, qk, qc, z[0], slopes[0], p11, 0.0, p22)
    e_all, var_all = kernels.kalman_channel_innovations(d, g, chans, slopes, r, qs, qk, qc, p11, p22,
                                                        np.zeros(300, dtype=bool))
    np.testing.assert_array_equal(e0, e_all[0])
    np.testing.assert_array_equal(var0, var_all)
