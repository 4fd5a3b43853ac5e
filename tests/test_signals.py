"""Filters and derivatives: accuracy against analytic derivatives, phase, bandwidth choice."""

import numpy as np

from limbstiff import signals

FS = 1000.0


def test_central_derivatives_of_a_sine():
    t = np.arange(0, 2, 1 / FS)
    w = 2 * np.pi * 3
    d = signals.central_derivatives(np.sin(w * t), FS, 3)
    inner = slice(10, -10)
    # second-order differences: relative error about (w·Ts)²/6 per derivative ≈ 6e-5
    np.testing.assert_allclose(d[1][inner], w * np.cos(w * t)[inner], atol=5e-4 * w)
    np.testing.assert_allclose(d[3][inner], -w ** 3 * np.cos(w * t)[inner], atol=5e-4 * w ** 3)


def test_zero_phase_lowpass_has_no_lag():
    rng = np.random.default_rng(0)
    x = np.cumsum(rng.standard_normal(5000))
    y = signals.zero_phase_lowpass(x, FS, 20.0)
    xc = np.correlate(np.diff(y), np.diff(x), "full")
    assert np.argmax(xc) == len(x) - 2          # peak at zero lag


def test_paper_chain_gains():
    # Slow sine (0.5 Hz) through 1/(0.02s+1)² and s/(1+1e-4 s) at Ts = 0.015 s:
    # prefilter gain ≈ 1, derivative ≈ ω, within the prefilter's roll-off (|H(jω)| ≈ 0.998).
    fs = 1 / 0.015
    t = np.arange(0, 40, 1 / fs)
    w = 2 * np.pi * 0.5
    d = signals.paper_derivatives(np.sin(w * t), fs, 2, prefilter_time_constant=0.02,
                                  dirty_derivative_time_constant=1e-4)
    tail = t > 10
    assert abs(np.max(d[0][tail]) - 1) < 0.01
    assert abs(np.max(d[1][tail]) / w - 1) < 0.02
    assert abs(np.max(d[2][tail]) / w ** 2 - 1) < 0.03


def test_quantisation_step_is_found():
    t = np.arange(0, 5, 1 / FS)
    q = 2 * np.pi / 8000
    x = np.round(0.04 * np.sin(2 * np.pi * t) / q) * q
    assert abs(signals.quantisation_step(x) - q) < 1e-9 * q
    assert signals.quantisation_step(np.sin(2 * np.pi * t)) == 0.0


def test_bandwidth_covers_excitation_and_rejects_noise():
    rng = np.random.default_rng(3)
    t = np.arange(0, 30, 1 / FS)
    freqs = np.linspace(0.5, 8, 16)
    x = sum(0.003 * np.sin(2 * np.pi * f * t + rng.uniform(0, 6.3)) for f in freqs)
    q = 2 * np.pi / 8000
    x = np.round(x / q) * q
    bw = signals.choose_bandwidth(x, FS)
    assert 8 <= bw.signal_edge_hz <= 40
    assert bw.cutoff_hz is not None and bw.cutoff_hz < 100
    assert abs(bw.quantisation_step - q) < 1e-9


def test_motion_frequency_of_a_sine():
    t = np.arange(0, 20, 1 / FS)
    assert abs(signals.motion_frequency(np.sin(2 * np.pi * 2 * t), FS) - 2) < 0.2
