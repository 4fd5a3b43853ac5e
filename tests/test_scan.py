"""The blocked NumPy scan equals the plain loop (the definition of the recursion) to 1e-9."""

import numpy as np
import pytest

from limbstiff.estimate import observer, scan
from limbstiff.statespace import kernels

# The loop is x[k] = a[k]·x[k−1] + c[k] itself; kernels.linear_recursion.py_func is that loop in
# CPython whether or not numba compiled the module.
LOOP = getattr(kernels.linear_recursion, "py_func", kernels.linear_recursion)


@pytest.mark.parametrize("n, mean_decay", [(1, 0.1), (63, 0.1), (5000, 1e-4), (20000, 0.3), (20000, 50.0)])
def test_scan_equals_the_loop(n, mean_decay):
    rng = np.random.default_rng(n)
    decay = rng.exponential(mean_decay, n)
    decay[rng.random(n) < 0.2] = 0.0                        # held stretches: a = 1 exactly
    a = np.exp(-decay)
    c = (1 - a) * rng.normal(30.0, 10.0, n)
    ref = LOOP(a, c, 5.0)
    # relative to the signal's size: the scan's error is rounding, ~1e-14 of it
    np.testing.assert_allclose(scan.linear_recursion(a, c, 5.0), ref, rtol=0, atol=1e-9 * np.max(np.abs(ref)))


def test_scan_on_an_observer_pass_and_a_forgotten_state():
    # a = 0 forgets the state; the scan must not produce inf/nan from ln 0. It takes a as
    # e^-36 there, so the carried state 1e6 leaks in by at most 1e6·2.3e-16 = 2.3e-10.
    a = np.array([1.0, 0.5, 0.0, 1.0, 0.25] * 40)
    c = np.arange(200.0)
    np.testing.assert_allclose(scan.linear_recursion(a, c, 1e6), LOOP(a, c, 1e6), rtol=0, atol=3e-10)
    rng = np.random.default_rng(1)
    t = np.arange(200_000) * 1e-3
    velocity = 0.3 * np.cos(2 * np.pi * 1.3 * t) + 0.01 * rng.standard_normal(t.size)
    drive = 12.0 * velocity + rng.standard_normal(t.size)
    a, c = observer.recursion_coefficients(velocity, drive, observer_gain=200.0, sample_period=1e-3)
    ref = LOOP(a, c, 0.0)
    np.testing.assert_allclose(scan.linear_recursion(a, c), ref, rtol=0, atol=1e-9 * np.max(np.abs(ref)))
    np.testing.assert_allclose(observer.linear_recursion(a, c), ref, rtol=0, atol=1e-9 * np.max(np.abs(ref)))


def test_scan_refuses_an_unstable_recursion():
    with pytest.raises(ValueError, match="0 <= a <= 1"):
        scan.linear_recursion(np.array([1.5, 0.5]), np.zeros(2))


@pytest.mark.parametrize("discretisation", ["exact", "euler"])
def test_observer_pass_equals_coefficients_and_scan(discretisation):
    # observe() (coefficients, then the compiled recursion) against the path without numba:
    # the same coefficients, then the blocked scan (exact) or the loop (Euler's a may leave [0, 1])
    rng = np.random.default_rng(2)
    velocity = 0.2 * np.sin(np.arange(50_000) * 2e-3) + 0.02 * rng.standard_normal(50_000)
    drive = 20.0 * velocity + rng.standard_normal(50_000)
    kw = dict(observer_gain=30.0, sample_period=1e-3, discretisation=discretisation, velocity_threshold=0.01)
    a, c = observer.recursion_coefficients(velocity, drive, **kw)
    ref = scan.linear_recursion(a, c, 3.0) if discretisation == "exact" else LOOP(a, c, 3.0)
    got = observer.observe(velocity, drive, initial=3.0, **kw)
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9 * np.max(np.abs(ref)))
