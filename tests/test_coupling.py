"""A compliant coupling between limb and device, and a platform that moves the operating point:
the two recordings unlike the simulator's own limbs (issue: know when the model fails).

Targets from the issue: median stiffness error ≤ 10 % on both with default settings, following
the stiffness's dependence on the operating point.
"""

from __future__ import annotations

import numpy as np
import pytest

import limbstiff
from limbstiff.coupling import ADEQUATE_CHI2, CouplingFit
from limbstiff.simulate import simulate

pytestmark = pytest.mark.slow        # end to end: `pytest -m "not slow"` is the inner loop


@pytest.fixture(scope="module")
def coupled():
    # default coupling: 35 Hz, which puts a one-body analysis 12 % low (springs in series)
    trial = simulate("ankle-coupled", seed=7)
    return trial, limbstiff.analyze(trial, seed=0)


def test_the_coupling_is_found_and_undone(coupled):
    trial, result = coupled
    assert result.coupling.found
    # the fitted resonance is the simulated one (the scenario's coupling_frequency)
    assert result.coupling.resonance_hz == pytest.approx(35.0, rel=0.05)
    assert result.coupling.two_body_chi2 <= ADEQUATE_CHI2 < result.coupling.one_body_chi2
    # filtered below the resonance, where the one-body model sees the springs in series
    assert result.filtered.cutoff_hz <= 0.5 * result.coupling.resonance_hz + 1e-9
    assert result.reference_error()["median"] <= 0.10
    assert result.checks["device_coupling"].passed


def test_the_coupled_ankle_is_ok(coupled):
    """velocity_shape is not judged on a coupled trial: the residual holds the second body's motion
    (it fired on every clean coupled ankle of benchmarks/checks.py, the estimate within 0.2 %)."""
    result = coupled[1]
    assert result.verdict == "ok"
    assert result.checks["velocity_shape"].passed and "not judged" in result.checks["velocity_shape"].message


@pytest.mark.parametrize("frequency", [20.0, 60.0])
def test_other_coupling_resonances_stay_within_ten_percent(frequency):
    # at 20 Hz the series bias is -38 %; at 60 Hz (-4 %) the resonance lies above the band fitted
    result = limbstiff.analyze(simulate("ankle-coupled", seed=8, params={"coupling_frequency": frequency,
                                                                         "duration": 30.0}), seed=0)
    assert result.reference_error()["median"] <= 0.10


def test_no_coupling_is_claimed_without_one():
    result = limbstiff.analyze(simulate("ankle", seed=9, params={"duration": 20.0}), seed=0)
    assert not result.coupling.found and result.coupling.one_body_chi2 <= ADEQUATE_CHI2
    assert "device_coupling" not in {c.name for c in result.checks.checks}
    # one body describes it, so the two-body fit is not made (its starts ran out of evaluations
    # here, stopping where the last digits of the arithmetic took them: issue 38's CI failure)
    assert np.isnan(result.coupling.two_body_chi2) and np.isnan(result.coupling.resonance_hz)


def test_a_two_body_start_that_does_not_converge_is_no_fit(monkeypatch):
    from limbstiff import coupling
    w = 2 * np.pi * np.linspace(3.0, 40.0, 30)
    h = coupling._two_body(np.array([1e-4, 400.0, 0.3, 60.0, 0.5, 0.06]), w)
    one = np.array([50.0, 0.05, 0.5])
    params, chi2 = coupling._fit_two_body(w, h, np.ones_like(w), one)
    assert params[1] == pytest.approx(400.0, rel=1e-4) and chi2 < 1e-6     # noise-free: exact
    monkeypatch.setattr(coupling, "MAX_EVALUATIONS", 2)       # no start converges in two evaluations
    params, chi2 = coupling._fit_two_body(w, h, np.ones_like(w), one)
    assert np.isnan(chi2) and np.isnan(params).all()


def test_series_springs_are_undone_exactly():
    fit = CouplingFit(one_body_chi2=100.0, two_body_chi2=2.0, coupling_stiffness=400.0, resonance_hz=35.0,
                      limb_stiffness_fit=60.0, band_hz=(3.0, 40.0))
    limb = np.array([10.0, 60.0, 150.0])
    series = limb * 400.0 / (limb + 400.0)
    np.testing.assert_allclose(fit.limb_stiffness(series), limb)
    assert np.isnan(fit.limb_stiffness(np.array([400.0]))[0])      # no limb stiffness gives k_c


def test_platform_follows_the_operating_point():
    # the slow movement is in the torque, not in the angle; the stiffness rises 15 -> 85 with it
    trial, truth = limbstiff.simulate.simulate_with_truth("ankle-platform", seed=5)
    result = limbstiff.analyze(trial, seed=0)
    assert result.reference_error()["median"] <= 0.10
    use = result.observable & (trial.time - trial.time[0] >= 2.0)
    true = trial.stiffness_true
    for lo, hi in ((15, 35), (35, 60), (60, 85)):                   # thirds of the stiffness range
        part = use & (true >= lo) & (true < hi)
        assert part.sum() > 1000
        assert np.median(np.abs(result.stiffness[part] - true[part]) / true[part]) <= 0.10
    assert result.verdict == "ok"


def test_friction_is_not_taken_for_a_coupling():
    # Coulomb friction bends the dynamic stiffness (one-body chi2 6-7) so that a two-body model
    # fits it within the noise; a first version "corrected" such trials to errors of 38-4800 %
    result = limbstiff.analyze(simulate("ankle", seed=2, params={"duration": 20.0}, effect="coulomb_friction"),
                               seed=2)
    assert not result.coupling.found
    assert result.reference_error()["median"] < 0.05


def test_two_body_gradient_is_the_derivative_of_the_response():
    # the fit's exact Jacobian against central differences of the response itself, at a limb of
    # 60 N·m/rad on a 400 N·m/rad coupling (step 1e-6 in ln p: truncation error ~1e-12 relative)
    from limbstiff.coupling import _two_body, _two_body_gradient
    w = 2 * np.pi * np.linspace(3.0, 60.0, 40)
    x = np.log([0.002, 400.0, 0.5, 60.0, 1.0, 0.015])
    numeric = np.column_stack([(_two_body(np.exp(x + d), w) - _two_body(np.exp(x - d), w)) / 2e-6
                               for d in 1e-6 * np.eye(6)])
    exact = _two_body_gradient(np.exp(x), w)
    assert np.max(np.abs(numeric - exact)) <= 1e-6 * np.max(np.abs(exact))
