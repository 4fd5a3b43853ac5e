"""Tests of the device scenarios of limbstiff.simulate.devices: ankle-coupled, ankle-platform."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.signal import csd, welch

from limbstiff.cli import main
from limbstiff.simulate import EFFECTS, SCENARIOS, simulate, simulate_with_truth
from limbstiff.simulate.devices import (coupling_mode, coupling_stiffness, one_body_equivalent,
                                        operating_point_stiffness)

NEW = ["ankle-coupled", "ankle-platform"]


def derivative(x, ts):
    """Fourth-order central difference (the two samples at each end are left 0)."""
    d = np.zeros_like(x)
    d[2:-2] = (x[:-4] - 8 * x[1:-3] + 8 * x[3:-1] - x[4:]) / (12 * ts)
    return d


def coupled(**extra):
    params = {"duration": 5.0, "torque_noise": 0.0, **extra}
    return simulate_with_truth("ankle-coupled", seed=2, params=params)


# --- ankle-coupled ----------------------------------------------------------------------------

def test_coupled_records_device_angle_and_sensor_torque():
    trial, truth = coupled()
    p = SCENARIOS["ankle-coupled"].defaults
    ts, inner = trial.sample_period, slice(2, -2)
    np.testing.assert_array_equal(trial.angle, truth.angle)
    np.testing.assert_array_equal(trial.torque, truth.external_torque)
    np.testing.assert_array_equal(trial.stiffness_true, p["stiffness"])
    # The limb's motion integrates its equation: finite differences of the RK4 solution.
    yl, vl = truth.limb.angle, truth.limb.velocity
    acc = derivative(vl, ts)
    np.testing.assert_allclose(derivative(yl, ts)[inner], vl[inner],
                               atol=1e-4 * np.max(np.abs(vl)))
    limb = (p["limb_inertia"] * acc + p["limb_damping"] * vl + p["stiffness"] * yl
            - truth.limb.coupling_torque)
    scale = np.std(truth.external_torque)
    assert np.max(np.abs(limb[inner])) < 1e-3 * scale
    # The sensor torque moves both bodies: f = I_d·θ̈_d + I_l·θ̈_l + B_l·θ̇_l + K·θ_l.
    both = (p["device_inertia"] * derivative(truth.velocity, ts) + p["limb_inertia"] * acc
            + p["limb_damping"] * vl + p["stiffness"] * yl)
    assert np.max(np.abs(both - truth.external_torque)[inner]) < 1e-3 * scale
    kc = coupling_stiffness(p["limb_inertia"], p["stiffness"], p["coupling_frequency"])
    coupling = kc * (truth.angle - yl) + p["coupling_damping"] * (truth.velocity - vl)
    np.testing.assert_allclose(truth.limb.coupling_torque, coupling, rtol=1e-5, atol=1e-9)


@pytest.mark.parametrize("fc", [20.0, 35.0, 60.0])
def test_coupling_resonance_is_the_parameter(fc):
    trial, truth = coupled(coupling_frequency=fc, duration=1.0)
    p = SCENARIOS["ankle-coupled"].defaults
    kc = float(trial.metadata["coupling_stiffness"])
    assert kc == pytest.approx(coupling_stiffness(p["limb_inertia"], p["stiffness"], fc), rel=1e-5)
    fn, _ = coupling_mode(p["limb_inertia"], p["limb_damping"], p["stiffness"], kc,
                          p["coupling_damping"])
    assert fn == pytest.approx(fc, rel=1e-5)
    assert float(trial.metadata["coupling_resonance_hz"]) == pytest.approx(fc, rel=1e-5)
    assert truth.internal_step <= 1.0 / (20.0 * fc)


def test_simulated_limb_resonates_at_the_parameter():
    """From the simulated signals: Re of the limb's impedance on the coupling crosses 0 at f_c."""
    fc, fs = 35.0, 1000.0
    trial, truth = coupled(duration=20.0, cutoff=60.0, hold_min=0.05, hold_max=0.1)
    kc, bc = float(trial.metadata["coupling_stiffness"]), 0.3
    f, pxy = csd(truth.angle, truth.limb.angle, fs=fs, nperseg=2000)
    _, pxx = welch(truth.angle, fs=fs, nperseg=2000)
    h = pxy / pxx                                           # θ_l/θ_d
    band = (f > 10) & (f < 80)
    real = ((kc + 1j * bc * 2 * np.pi * f) / h).real[band]  # K + k_c − I_l·ω²
    k = np.nonzero(np.diff(np.sign(real)))[0][0]
    fb = f[band]
    crossing = fb[k] - real[k] * (fb[k + 1] - fb[k]) / (real[k + 1] - real[k])
    assert crossing == pytest.approx(fc, rel=0.03)


def test_low_frequency_limb_tracks_device_and_one_body_bias():
    """Slow steps: θ_l ≈ k_c/(K + k_c)·θ_d, and a one-body fit finds the springs in series."""
    trial, truth = coupled(duration=20.0, cutoff=2.0, hold_min=0.5, hold_max=1.0)
    p = SCENARIOS["ankle-coupled"].defaults
    kc = float(trial.metadata["coupling_stiffness"])
    k = p["stiffness"]
    ratio = kc / (k + kc)
    yd, yl = truth.angle, truth.limb.angle
    assert np.max(np.abs(yl - ratio * yd)) < 0.02 * np.max(np.abs(yd))
    assert np.corrcoef(yd, yl)[0, 1] > 0.999
    x = np.column_stack([truth.acceleration, truth.velocity, yd])
    (i_fit, b, k_fit), *_ = np.linalg.lstsq(x[1000:], truth.external_torque[1000:], rcond=None)
    expected = one_body_equivalent(p["device_inertia"], p["limb_inertia"], p["limb_damping"],
                                   k, kc, p["coupling_damping"])
    assert expected["stiffness"] == pytest.approx(k * kc / (k + kc))
    assert float(trial.metadata["one_body_stiffness"]) == pytest.approx(expected["stiffness"],
                                                                        rel=1e-5)
    assert k_fit == pytest.approx(expected["stiffness"], rel=0.01)
    assert b == pytest.approx(expected["damping"], rel=0.02)
    assert i_fit == pytest.approx(expected["inertia"], rel=0.02)
    assert k_fit < 0.9 * k


def test_coupled_rejects_a_resonance_below_the_limbs_own():
    with pytest.raises(ValueError, match="coupling_frequency"):
        simulate("ankle-coupled", params={"duration": 1.0, "coupling_frequency": 10.0})


def test_coupled_effects_act_on_the_limb():
    params = {"duration": 3.0, "torque_noise": 0.0}
    _, nominal = simulate_with_truth("ankle-coupled", params=params)
    trial, truth = simulate_with_truth("ankle-coupled", params=params, effect="reflex")
    np.testing.assert_array_equal(truth.angle, nominal.angle)    # device imposed
    assert not np.allclose(truth.limb.angle, nominal.limb.angle)
    assert float(trial.metadata["effect.delay"]) == pytest.approx(0.04, abs=2.5e-4)
    assert np.max(np.abs(truth.effect_torque[truth.time < 0.04])) == 0.0
    trial = simulate("ankle-coupled", params=params, effect="inertia_error")
    assert float(trial.metadata["true_inertia"]) == pytest.approx(1.2 * 0.01)


@pytest.mark.parametrize("name", NEW)
@pytest.mark.parametrize("effect", list(EFFECTS))
def test_every_effect_applies(name, effect):
    base = simulate(name, seed=1, params={"duration": 1.0})
    trial = simulate(name, seed=1, params={"duration": 1.0}, effect=effect)
    assert trial.name == f"{name}-{effect}"
    assert not (np.array_equal(base.angle, trial.angle)
                and np.array_equal(base.torque, trial.torque))


# --- ankle-platform ---------------------------------------------------------------------------

@pytest.fixture(scope="module")
def platform():
    return simulate_with_truth("ankle-platform", seed=4,
                               params={"duration": 60.0, "torque_noise": 0.0})


def moving_average(x, n):
    return np.convolve(x, np.ones(n) / n, mode="valid")


def test_platform_angle_has_no_slow_component_but_torque_has(platform):
    trial, truth = platform
    p = SCENARIOS["ankle-platform"].defaults
    swing = p["operating_angle_max"] - p["operating_angle_min"]
    np.testing.assert_allclose(truth.angle - truth.unrecorded_angle, trial.angle)
    np.testing.assert_allclose(truth.unrecorded_angle, truth.control)
    assert np.ptp(truth.control) == pytest.approx(swing, rel=1e-6)
    slow_angle = moving_average(trial.angle, 5000)
    assert np.max(np.abs(slow_angle)) < 0.03 * swing
    _, s0 = operating_point_stiffness(p)
    slow_torque = moving_average(trial.torque, 5000)
    assert np.ptp(slow_torque) > 0.8 * (s0(0.2) - s0(-0.4)) > 15.0
    # The torque's slow part is the elastic torque of the operating point.
    expected = moving_average(s0(truth.control), 5000)
    assert np.max(np.abs(slow_torque - expected)) < 0.1 * np.ptp(expected)


def test_platform_stiffness_follows_the_operating_point(platform):
    trial, truth = platform
    phi, sigma = truth.control, trial.stiffness_true
    order = np.argsort(phi)
    assert np.all(np.diff(sigma[order]) >= -1e-9)
    assert sigma[np.argmin(phi)] == pytest.approx(15.0, abs=0.1)
    assert sigma[np.argmax(phi)] == pytest.approx(85.0, abs=0.1)
    stiffness, _ = operating_point_stiffness(SCENARIOS["ankle-platform"].defaults)
    np.testing.assert_allclose(sigma, stiffness(phi))
    k_mid = stiffness(np.linspace(-0.4, 0.2, 7))
    assert np.all(np.diff(k_mid) > 0) and 15.0 < k_mid[3] < 50.0


def test_platform_steps_size_and_timing(platform):
    trial, _ = platform
    q = trial.angle
    t = trial.time
    assert np.max(np.abs(q)) == pytest.approx(0.06, rel=1e-3)
    crossings = t[np.nonzero(np.diff(np.sign(q)))[0]]
    holds = np.diff(crossings)
    # Mid-hold the angle sits on ±0.06 rad, alternating: every jump is 0.12 rad.
    mid = q[np.round((crossings[:-1] + 0.5 * holds) * trial.fs).astype(int)]
    np.testing.assert_allclose(np.abs(mid), 0.06, atol=1e-3)   # 50 ms holds: 0.6 mrad short
    np.testing.assert_allclose(np.abs(np.diff(mid)), 0.12, atol=2e-3)
    assert holds.min() > 0.05 - 0.003 and holds.max() < 0.2 + 0.003
    assert np.mean(holds) == pytest.approx(0.125, rel=0.05)
    assert 0.01 < np.std(holds) < 0.06                       # uniform: 0.043 s


def test_platform_reaction_torque_sign():
    params = {"duration": 2.0, "torque_noise": 0.0, "reaction_torque": 1.0}
    trial, truth = simulate_with_truth("ankle-platform", seed=1, params=params)
    np.testing.assert_array_equal(trial.torque, -truth.external_torque)
    assert trial.metadata["torque_recorded"].startswith("reaction")
    with pytest.raises(ValueError, match="reaction_torque"):
        simulate("ankle-platform", params={"duration": 1.0, "reaction_torque": 0.5})
    with pytest.raises(ValueError, match="operating_angle"):
        simulate("ankle-platform", params={"duration": 1.0, "operating_angle_max": -0.5})


# --- both -------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", NEW)
def test_seeded(name):
    a = simulate(name, seed=5, params={"duration": 2.0})
    b = simulate(name, seed=5, params={"duration": 2.0})
    c = simulate(name, seed=6, params={"duration": 2.0})
    for field in ("angle", "torque", "stiffness_true"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert not np.allclose(a.angle, c.angle) and not np.allclose(a.torque, c.torque)


def test_listed_by_the_cli():
    res = CliRunner().invoke(main, ["simulate", "--list"])
    assert res.exit_code == 0
    assert all(f"  {name}:" in res.output for name in NEW)
    for name in NEW:
        doc = SCENARIOS[name].doc
        assert "Expected bias of a one-body analysis" in doc
    assert math.isfinite(SCENARIOS["ankle-coupled"].defaults["coupling_frequency"])
