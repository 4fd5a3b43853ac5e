"""The observer's update law (7) and its two discretisations, against exact answers."""

import numpy as np
import pytest

from limbstiff.estimate import observer

FS = 1000.0
TS = 1 / FS


def _sine(duration=4.0, amplitude=0.02, freq=1.0):
    t = np.arange(0, duration, TS)
    w = 2 * np.pi * freq
    return t, amplitude * np.sin(w * t), amplitude * w * np.cos(w * t)


def test_exact_error_decays_as_exp_of_gain_times_path():
    # Linear spring, direct variant: r = ḟ = k·ẏ, so every exact step gives
    # σ̂[k] − K = a[k]·(σ̂[k−1] − K) and the error after the path P is exactly e^{−αP}·(σ̂0 − K).
    t, y, v = _sine()
    stiffness, gain, initial = 40.0, 30.0, 5.0
    est = observer.observe(v, stiffness * v, observer_gain=gain, sample_period=TS, initial=initial)
    path = np.cumsum(np.abs(v) * TS)
    expected = stiffness + (initial - stiffness) * np.exp(-gain * path)
    np.testing.assert_allclose(est, expected, rtol=1e-12)


def test_exact_stays_bounded_where_euler_diverges():
    # α·|ẏ|·Ts reaches 0.02·2π·1e5·1e-3 ≈ 12.6 ≫ 2: forward Euler's factor 1 − α|ẏ|Ts < −1.
    t, y, v = _sine()
    stiffness, gain = 40.0, 1e5
    assert np.max(gain * np.abs(v) * TS) > 2
    exact = observer.observe(v, stiffness * v, observer_gain=gain, sample_period=TS)
    with np.errstate(over="ignore", invalid="ignore"):
        euler = observer.observe(v, stiffness * v, observer_gain=gain, sample_period=TS,
                                 discretisation="euler")
    assert np.all(np.isfinite(exact))
    # the exact step is a convex combination of σ̂ and r/ẏ = K: never leaves [0, K]
    assert np.all((exact >= -1e-9) & (exact <= stiffness + 1e-9))
    assert np.abs(exact[-1] - stiffness) < 1e-9
    assert not np.all(np.isfinite(euler)) or np.max(np.abs(euler)) > 1e6


def test_euler_agrees_with_exact_at_small_gain():
    # For α|ẏ|Ts ≪ 1 both are first-order accurate: they differ by O((α|ẏ|Ts)²) per step.
    t, y, v = _sine()
    a = observer.observe(v, 40 * v, observer_gain=2.0, sample_period=TS)
    b = observer.observe(v, 40 * v, observer_gain=2.0, sample_period=TS, discretisation="euler")
    assert np.max(np.abs(a - b)) < 1e-3 * 40


def test_estimate_held_without_motion():
    t, y, v = _sine()
    v = v.copy()
    v[1000:2000] = 0.0
    drive = 40 * v + np.random.default_rng(0).standard_normal(v.size)   # noise where v = 0 too
    est = observer.observe(v, drive, observer_gain=30.0, sample_period=TS)
    assert np.all(est[1000:2000] == est[999])
    ok = observer.informed(v, observer_gain=300.0, sample_period=TS, window=0.5)
    assert not ok[1600:2000].any() and ok[900:1000].all()


def test_velocity_threshold_counts_as_rest():
    t, y, v = _sine()
    est = observer.observe(v, 40 * v, observer_gain=30.0, sample_period=TS,
                           velocity_threshold=np.max(np.abs(v)))
    assert np.all(est == 0.0)


def test_external_variant_converges_with_known_inertia_and_damping():
    t = np.arange(0, 6, TS)
    w1, w2 = 2 * np.pi * 1.3, 2 * np.pi * 3.1
    v = 0.01 * w1 * np.cos(w1 * t) + 0.005 * w2 * np.cos(w2 * t + 1)
    acc = -0.01 * w1 ** 2 * np.sin(w1 * t) - 0.005 * w2 ** 2 * np.sin(w2 * t + 1)
    jerk = -0.01 * w1 ** 3 * np.cos(w1 * t) - 0.005 * w2 ** 3 * np.cos(w2 * t + 1)
    m, b, k = 0.06, 0.45, 20.0
    torque_rate = m * jerk + b * acc + k * v
    drive = observer.external_drive(torque_rate, acc, jerk, inertia=m, damping=b)
    est = observer.observe(v, drive, observer_gain=200.0, sample_period=TS)
    assert np.max(np.abs(est[2000:] - k)) < 1e-9


def test_estimate_is_affine_in_inertia_and_damping():
    # docs/architecture.md, fact 2: σ̂(m, b) = S0 − m·S1 − b·S2 for fixed gain.
    rng = np.random.default_rng(1)
    n = 3000
    v, fdot, acc, jerk = rng.standard_normal((4, n))
    kw = dict(observer_gain=5.0, sample_period=TS)
    s0 = observer.observe(v, fdot, **kw)
    s1 = observer.observe(v, jerk, **kw, initial=0.0)
    s2 = observer.observe(v, acc, **kw, initial=0.0)
    for m, b in ((0.05, 0.3), (0.5, 2.0)):
        direct = observer.observe(v, observer.external_drive(fdot, acc, jerk, inertia=m, damping=b), **kw)
        np.testing.assert_allclose(direct, s0 - m * s1 - b * s2, rtol=1e-9, atol=1e-9)


def test_unknown_discretisation_is_rejected():
    with pytest.raises(ValueError, match="discretisation"):
        observer.observe(np.ones(5), np.ones(5), observer_gain=1.0, sample_period=TS, discretisation="rk4")
