"""The corner scan's shortcuts give what the long way gives, to the bit."""

import dataclasses

import numpy as np
import pytest

from limbstiff import bandwidth
from limbstiff.estimate.estimators import kalman
from limbstiff.estimate.kalman import fit_noise
from limbstiff.filtered import filter_trial
from limbstiff.protocol import Protocol
from limbstiff.simulate import simulate
from limbstiff.statespace.steps import kalman_decimation, model_steps


@pytest.fixture(scope="module")
def trial():
    return simulate("elbow", seed=2, params={"duration": 8.0})


@pytest.mark.parametrize("corner", [7.3, 30.0, None])
def test_a_corner_refiltered_equals_filter_trial(trial, corner):
    spectral = filter_trial(trial, Protocol())
    short, long = bandwidth._at_corner(trial, spectral, corner), filter_trial(trial, Protocol(), corner_hz=corner)
    for field in dataclasses.fields(long):
        mine, theirs = getattr(short, field.name), getattr(long, field.name)
        assert np.array_equal(mine, theirs) if isinstance(theirs, np.ndarray) else mine == theirs, field.name


def test_fit_noise_is_the_estimators_fit(trial):
    f = filter_trial(trial, Protocol())
    steps = model_steps(f.angle, f.elastic_torque(0.05, 0.3), sample_period=f.sample_period,
                        decimation=kalman_decimation(f.sample_period, f.cutoff_hz), edge=f.edge,
                        motion_frequency=f.motion_hz, scale_from=f.torque)
    assert fit_noise(steps, motion_frequency=f.motion_hz) == kalman(f, inertia=0.05, damping=0.3).fit.noise
