"""The benchmark generators' physics, with exact answers (benchmarks/generators, issue 46).

The generators are written apart from limbstiff's method; these tests read nothing of the method:
they check each generator's own equations (torque balance, trough, reflex onset, amplitudes,
activation dynamics, noise level), that seeds reproduce bit for bit, and that the CSV files read
back through limbstiff's reader unchanged.
"""
from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from benchmarks.generators import bin_means, write_trial_csv
from benchmarks.generators import ensembles as en
from benchmarks.generators import gated_reflex as gr

DT_FINE = 1.0 / (gr.FS * gr.FINE)


def _motion(seed=0, duration=4.0):
    levels = gr.prbs_levels(np.random.default_rng(seed), duration)
    return levels, gr.prescribed_motion(levels, DT_FINE)


# --- gated reflex -------------------------------------------------------------------------------

def test_gated_reflex_without_reflex_or_noise_is_the_joint_equation():
    g = gr.generate(0.0, 1, np.random.default_rng(4), 3.0, noise=False)
    assert np.all(g["reflex"] == 0.0) and g["noise_sd"] == 0.0
    rest = g["torque"] - gr.I_TRUE * g["acceleration"] - gr.B_TRUE * g["velocity"] - gr.K_TRUE * g["theta"]
    assert np.max(np.abs(rest)) < 1e-13 * np.max(np.abs(g["torque"]))
    # with the reflex, what is left is the reflex torque
    g = gr.generate(8.0, -1, np.random.default_rng(4), 3.0, noise=False)
    rest = g["torque"] - gr.I_TRUE * g["acceleration"] - gr.B_TRUE * g["velocity"] - gr.K_TRUE * g["theta"]
    assert np.max(np.abs(rest - g["reflex"])) < 1e-13 * np.max(np.abs(g["torque"]))
    assert np.any(g["reflex"] != 0.0)


def test_gated_reflex_kinematics_are_exact_and_the_prbs_as_designed():
    levels, (theta, vel, acc) = _motion(1)
    assert set(np.unique(levels)) == {-gr.AMPLITUDE, gr.AMPLITUDE}          # ±0.03 rad exactly
    per = int(round(gr.SWITCH_S / DT_FINE))                                # 200 ms slots
    assert np.max(np.abs(theta[per - 1::per] - levels)) < 1e-6 * gr.AMPLITUDE   # settled by each slot's end
    inner = slice(2, -2)
    assert np.max(np.abs(np.gradient(theta, DT_FINE) - vel)[inner]) < 2e-4 * np.max(np.abs(vel))
    assert np.max(np.abs(np.gradient(vel, DT_FINE) - acc)[inner]) < 1e-3 * np.max(np.abs(acc))
    # the 30 Hz Butterworth: unit DC gain and -3 dB at 30 Hz
    a, b, c = gr.butterworth_state_space()
    h = [c @ np.linalg.solve(1j * w * np.eye(len(b)) - a, b) for w in (0.0, 2 * np.pi * 30)]
    assert abs(h[0]) == pytest.approx(1.0, abs=1e-9) and abs(h[1]) == pytest.approx(2 ** -0.5, abs=1e-9)


@pytest.mark.parametrize("direction", [1, -1])
def test_the_reflex_starts_exactly_delay_after_the_gated_velocity_crosses_threshold(direction):
    _, (_, vel, _) = _motion(2)
    r = gr.reflex_torque(vel, DT_FINE, 6.0, +1, direction)
    cross = int(np.flatnonzero(direction * vel > gr.THRESHOLD)[0])
    lag = int(round(gr.DELAY_S / DT_FINE))
    assert lag == 400
    assert np.all(r[:cross + lag] == 0.0)
    assert r[cross + lag] * direction > 0.0          # resisting: the actuator pushes along the stretch
    assert np.all(gr.reflex_torque(vel, DT_FINE, 6.0, -1, direction) == -r)   # the published sign
    # below the gate nothing at all: a velocity just under the threshold gives no reflex
    assert np.all(gr.reflex_torque(np.full(5000, gr.THRESHOLD), DT_FINE, 6.0, 1) == 0.0)


def test_the_activation_is_second_order_with_the_designed_omega_and_zeta():
    n = int(3.0 / DT_FINE)
    velocity = np.full(n, gr.THRESHOLD + 1.0)                          # 1 rad/s above the gate
    r = gr.reflex_torque(velocity, DT_FINE, 1.0, 1, delay_s=0.0)
    wd = gr.OMEGA * np.sqrt(1 - gr.ZETA ** 2)
    assert r[-1] == pytest.approx(1.0, abs=1e-9)                                   # unit DC gain
    assert r.max() == pytest.approx(1 + np.exp(-gr.ZETA * gr.OMEGA * np.pi / wd), abs=1e-6)   # overshoot
    assert np.argmax(r) * DT_FINE == pytest.approx(np.pi / wd, abs=2e-4)          # peak time


def test_gated_reflex_noise_is_15_db_and_seeds_reproduce():
    a = gr.generate(6.0, 1, np.random.default_rng(7), 20.0)
    b = gr.generate(6.0, 1, np.random.default_rng(7), 20.0)
    assert all(np.array_equal(a[k], b[k]) for k in ("angle", "torque", "theta", "reflex"))
    clean = gr.I_TRUE * a["acceleration"] + gr.B_TRUE * a["velocity"] + gr.K_TRUE * a["theta"] + a["reflex"]
    rms = np.sqrt(np.mean(clean ** 2))
    assert a["noise_sd"] == pytest.approx(rms / 10 ** (15 / 20), rel=1e-12)
    assert np.std(a["torque"] - clean) / a["noise_sd"] == pytest.approx(1.0, abs=0.03)
    assert np.max(np.abs(a["angle"] - a["theta"])) <= np.pi / 2 ** 16 * (1 + 1e-9)   # half a count
    # common random numbers: another gain and sign moves the same joint
    c = gr.generate(2.0, -1, np.random.default_rng(7), 20.0)
    assert np.array_equal(a["theta"], c["theta"]) and not np.array_equal(a["torque"], c["torque"])
    assert not np.array_equal(a["theta"], gr.generate(6.0, 1, np.random.default_rng(8), 20.0)["theta"])


def test_reflex_study_uses_the_module_unchanged():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    try:
        import reflex_study
    finally:
        sys.path.pop(0)
    a = reflex_study.generate(4.0, -1, 11, 5.0, 1)
    b = gr.generate(4.0, -1, np.random.default_rng(11), 5.0, 1)
    assert all(np.array_equal(a[k], b[k]) for k in ("angle", "torque", "theta", "velocity", "acceleration", "reflex"))


# --- ensembles ----------------------------------------------------------------------------------

def _settings(**kw):
    base = en.Settings(n_cycles=6, trough=en.Trough(centre=0.3, width_s=0.075, k_min=25.0))
    return replace(base, **kw)


def test_ensemble_torque_is_its_equation_exactly():
    s = _settings(reflex_gain=0.0)
    tr = en.simulate(s, np.random.default_rng(1), noise=False)
    t = tr.truth
    rest = (tr.torque - t["background"] - s.inertia * t["acceleration"] - s.damping * t["velocity"]
            - tr.stiffness_true * (t["theta"] - t["reference"]))
    assert np.max(np.abs(rest)) < 1e-13 * np.max(np.abs(tr.torque))
    assert np.array_equal(tr.angle, t["theta"])
    phi = np.where(np.isnan(tr.phase), np.nan, tr.phase)
    ok = ~np.isnan(phi)
    assert np.array_equal(tr.stiffness_true[ok], en.stiffness(phi[ok], s))
    assert np.array_equal(t["background"][ok], en.background_torque(phi[ok], s))
    # the angle's derivatives are its velocity and acceleration
    inner = slice(2, -2)
    assert np.max(np.abs(np.gradient(t["theta"], 1e-3) - t["velocity"])[inner]) < 0.03 * np.max(np.abs(t["velocity"]))
    # with a reflex, what is left is the reflex
    s = replace(s, reflex_gain=3.0)
    tr = en.simulate(s, np.random.default_rng(1), noise=False)
    t = tr.truth
    rest = (tr.torque - t["background"] - s.inertia * t["acceleration"] - s.damping * t["velocity"]
            - tr.stiffness_true * t["perturbation"])
    assert np.max(np.abs(rest - t["reflex"])) < 1e-13 * np.max(np.abs(tr.torque)) and np.any(t["reflex"] > 0)


def test_the_trough_minimum_width_and_edges_are_as_configured():
    s = _settings()
    w = s.trough.width_s / s.period_s
    k0 = en.stiffness(np.array([0.3, 0.3 - w / 2, 0.3 + w / 2]), replace(s, trough=None))
    assert en.stiffness(0.3, s) == pytest.approx(25.0, abs=1e-12)                  # the minimum's value
    half = en.stiffness(np.array([0.3 - w / 2, 0.3 + w / 2]), s)
    assert half == pytest.approx(0.5 * (k0[1:] + 25.0), abs=1e-12)                # full width at half depth
    grid = np.linspace(0, 1, 100001)
    k = en.stiffness(grid, s)
    outside = np.abs(en.wrapped(grid, 0.3)) >= w
    assert k[~outside].min() >= 25.0 - 1e-12 and k[~outside].min() == pytest.approx(25.0, abs=1e-6)
    assert np.array_equal(k[outside], en.stiffness(grid, replace(s, trough=None))[outside])
    assert np.max(en.stiffness(grid, replace(s, trough=None))) == pytest.approx(s.k_high, abs=1e-9)
    assert np.min(en.stiffness(grid, replace(s, trough=None))) >= s.k_low - 1e-12
    with pytest.raises(ValueError):
        en.stiffness(0.8, replace(s, trough=en.Trough(0.8, 0.075, 40.0)))      # above K_0 there: refused


def test_the_perturbation_and_movement_amplitudes_are_what_was_asked():
    s = _settings(perturbation_amp=0.012, movement_amp=0.27, n_cycles=10)
    tr = en.simulate(s, np.random.default_rng(5), noise=False)
    u, x = tr.truth["command"], tr.truth["perturbation"]
    assert set(np.unique(u)) == {-0.012, 0.012}
    held = np.zeros(u.size, int)                        # samples since the command last changed
    for i in range(1, u.size):
        held[i] = held[i - 1] + 1 if u[i] == u[i - 1] else 0
    settled = held >= 200
    assert settled.sum() > 100
    assert np.max(np.abs(x - u)[settled]) < 1e-6 * 0.012            # the device reaches the command
    a0, coef = en.reference_coefficients(0.27, 0.1)
    ref = en.es._ref_eval(np.linspace(0, 1, 200001), 1.0, a0, coef)[0]
    assert ref.max() - ref.min() == pytest.approx(2 * 0.27, abs=1e-9)
    assert 0.5 * (ref.max() + ref.min()) == pytest.approx(0.1, abs=1e-9)


def test_the_ensemble_reflex_starts_exactly_its_delay_after_the_threshold():
    s = _settings(reflex_gain=2.0, reflex_delay_s=0.033)
    tr = en.simulate(s, np.random.default_rng(9), noise=False)
    xv, r = tr.truth["perturbation_velocity"], tr.truth["reflex"]
    cross = int(np.flatnonzero(xv > en.V_TH)[0])
    # the input held from the sample 33 ms after the crossing: torque from the next sample on
    assert np.all(r[:cross + 33 + 1] == 0.0) and r[cross + 33 + 1] > 0.0


def test_truth_by_phase_and_the_scenarios():
    grid = np.linspace(0, 1, 4001)
    assert bin_means(grid, 3.0 + 2.0 * grid, 50) == pytest.approx(3.0 + 2.0 * (np.arange(50) + 0.5) / 50, abs=1e-12)
    for name in en.SCENARIOS:
        tr = en.scenario_trial(name, 3, n_cycles=4)
        st = tr.params["settings"]
        assert 10.0 <= np.min(tr.truth_curve) and np.max(tr.truth_curve) <= 130.0
        assert (st["trough"] is not None) == ("trough" in name) and (st["reflex_gain"] > 0) == ("reflex" in name)
        assert 0.025 <= st["reflex_delay_s"] <= 0.045 and 0.01 <= st["perturbation_amp"] <= 0.02
        if st["trough"]:
            assert np.min(tr.truth_curve) <= st["trough"]["k_min"] + 1e-9
    a, b = en.scenario_trial("trough_reflex", 5, n_cycles=4), en.scenario_trial("trough_reflex", 5, n_cycles=4)
    assert np.array_equal(a.torque, b.torque) and np.array_equal(a.angle, b.angle)      # bit for bit
    assert not np.array_equal(a.torque, en.scenario_trial("trough_reflex", 6, n_cycles=4).torque)


# --- files --------------------------------------------------------------------------------------

def test_files_read_back_through_limbstiff_bit_for_bit(tmp_path):
    from limbstiff.files import read_trial
    g = gr.trial(4.0, "published", np.random.default_rng(3), duration=2.0, seed_label="3")
    e = en.scenario_trial("trough", 2, n_cycles=3)
    for tr in (g, e):
        path = write_trial_csv(tr, tmp_path)
        back = read_trial(path)
        for field in ("angle", "torque", "stiffness_true"):
            assert np.array_equal(getattr(back, field), getattr(tr, field)), field
        assert np.max(np.abs(back.time - tr.time)) < 1e-12
        assert back.warnings == (() if tr.marker is None else ("ignored column(s): 'marker'",))  # no protocol
        assert back.metadata["generator"] == tr.metadata["generator"]
        truth = json.loads(path.with_suffix(".truth.json").read_text())
        assert truth["name"] == tr.name
    lines = [ln for ln in (tmp_path / f"{e.name}.csv").read_text().splitlines() if not ln.startswith("#")]
    assert lines[0] == "time_s,angle_rad,torque_Nm,stiffness_true_Nm_per_rad,marker"
    assert np.array_equal([float(ln.split(",")[4]) for ln in lines[1:]], e.marker)
    by_phase = json.loads((tmp_path / f"{e.name}.truth.json").read_text())["truth_by_phase"]
    assert by_phase["stiffness_Nm_per_rad"] == pytest.approx(bin_means(e.truth_grid, e.truth_curve, 50), abs=1e-12)
    assert np.array_equal(e.truth_by_phase(), bin_means(e.truth_grid, e.truth_curve, 50)) and g.truth_by_phase() is None


def test_command_lines_write_the_files(tmp_path):
    assert len(gr.main([str(tmp_path / "g"), "--seeds", "1", "--gains", "2", "--duration", "1"])) == 3
    paths = en.main([str(tmp_path / "e"), "--seeds", "2", "--scenarios", "smooth", "--cycles", "3"])
    assert [p.name for p in paths] == ["ens-smooth-s0.csv", "ens-smooth-s1.csv"]
    again = en.main([str(tmp_path / "f"), "--seeds", "2", "--scenarios", "smooth", "--cycles", "3"])
    assert [p.read_bytes() for p in paths] == [p.read_bytes() for p in again]
