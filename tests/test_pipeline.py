"""analyze as a straight pipeline (issue 45): each step once, coefficients read by name."""

from __future__ import annotations

import numpy as np
import pytest

from limbstiff import analysis
from limbstiff.analysis import analyze
from limbstiff.coefficients import Coefficients
from limbstiff.estimate import estimators
from limbstiff.filtered import filter_trial
from limbstiff.interval import Interval
from limbstiff.mechanics.effect_terms import EffectFit
from limbstiff.mechanics.identification import Identification
from limbstiff.protocol import Protocol
from limbstiff.simulate import simulate

from .conftest import multisine_trial


def _counting(monkeypatch, name: str) -> list:
    """Count the calls of ``estimators.<name>`` made through the analysis."""
    calls, real = [], getattr(estimators, name)

    def counted(*args, **kw):
        calls.append(kw)
        return real(*args, **kw)
    monkeypatch.setattr(analysis.estimators, name, counted)
    return calls


def test_coefficients_are_read_by_name_in_the_models_order():
    effect = EffectFit("reflex", {"delay": 0.04}, "gain", "N·m·s/rad", Interval(0.3, 0.2, 0.4))
    ident = Identification("kalman+emcee", Interval(0.06, 0.05, 0.07), Interval(0.4, 0.3, 0.5),
                           np.eye(2), effects=(effect,))
    coef = Coefficients.of(ident)
    assert coef.names == ("inertia", "damping", "reflex")
    np.testing.assert_array_equal(coef.values_of(["reflex", "inertia"]), [0.3, 0.06])
    np.testing.assert_array_equal(coef.positions(["damping"]), [1])
    with pytest.raises(ValueError):
        coef.positions(["friction"])
    sensitivity = np.arange(8.0).reshape(4, 2)          # a probe's row after the coefficients'
    np.testing.assert_array_equal(coef.rows_of(sensitivity), sensitivity[:3])


@pytest.mark.parametrize("mech", [{}, {"inertia": 0.06, "damping": 0.45}])
def test_the_noise_fit_alone_is_the_kalman_estimates_fit(mech):
    filtered = filter_trial(multisine_trial(duration=6.0), Protocol(bandwidth_hz=20.0))
    assert estimators.kalman_noise(filtered, **mech) == estimators.kalman(filtered, **mech).fit.noise


def test_given_inertia_and_damping_the_course_is_estimated_once(monkeypatch):
    """The reflex probe needs the noise levels; they are fitted once before it, so the Kalman
    smoother runs once (it ran twice: once to fit them, once with the probe's column)."""
    calls = _counting(monkeypatch, "kalman")
    result = analyze(simulate("elbow", seed=3, effect="reflex", params={"duration": 15.0}), inertia=0.06,
                     damping=0.4, seed=1)
    assert "reflex" in [c.name for c in result.checks.checks]
    assert len(calls) == 1 and calls[0]["noise"] is not None


def test_observers_fit_the_kalman_noise_for_the_checks_without_a_kalman_estimate(monkeypatch):
    """m and b given: no identification's noise levels, so the checks' are fitted, once, and no
    Kalman course is estimated beside the observer's."""
    calls, fits = _counting(monkeypatch, "kalman"), _counting(monkeypatch, "kalman_noise")
    result = analyze(multisine_trial(duration=6.0), estimator="observer-smoothed", inertia=0.06, damping=0.45,
                     seed=0)
    assert calls == [] and len(fits) == 1
    assert result.fit.noise is None and np.all(np.isfinite(result.stiffness[result.observable]))
