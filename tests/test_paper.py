"""The paper's simulation results (Grioli & Bicchi 2010, Sec. IV), reproduced from simulated recordings.

Reference claims (paper text): Fig. 6 — "the observation error decays to less than one
percent in less than 0.3 s" and "remains under 1 % for the rest of the time"; Fig. 7 — both
muscle models tracked; Fig. 8 — with m and b 10 % off "the relative error on stiffness is of
comparable magnitude"; Fig. 9 — "the stiffness estimate is not updated" while motion stops
and "recovers quickly" when it resumes.
"""

import functools

import numpy as np
import pytest

from limbstiff import paper


@functools.cache
def _fig7(model):
    """Fig. 7's 30 s track with the exact m and b, computed once for Figs. 7 and 8 (deterministic)."""
    return paper.fig7_antagonistic_link(model, duration=30.0)


@pytest.mark.slow
@pytest.mark.parametrize("spring", [1, 2, 3])
def test_fig6_exponential_springs_settle_below_one_percent_within_0_3_s(spring):
    track = paper.fig6_exponential_spring(spring, duration=10.0)
    assert track.settling_time(0.01) < 0.3
    # and it stays there: the b/α bound of paper.FIG6_GAIN is 0.25 % for the stiffest spring
    assert track.error_stats(start=0.3)["max"] < 0.01


@pytest.mark.slow
@pytest.mark.parametrize("model", ["hogan", "feldman"])
def test_fig7_both_muscle_models_tracked(model):
    stats = _fig7(model).error_stats(start=2.0)
    # Measured: median 0.2 % (hogan) and < 0.01 % (feldman), 90th percentile 3.0 % and 2.4 %;
    # the residual comes from the s_u·u̇/ẏ term of bound (9) near velocity reversals.
    assert stats["median"] < 0.01
    assert stats["p90"] < 0.05


@pytest.mark.slow
@pytest.mark.parametrize("model", ["hogan", "feldman"])
def test_fig8_ten_percent_error_on_m_and_b_gives_comparable_stiffness_error(model):
    exact = _fig7(model).error_stats()
    off = paper.fig7_antagonistic_link(model, duration=30.0, inertia_error=0.1,
                                       damping_error=0.1).error_stats()
    # "Comparable magnitude": the median stiffness error is of the order of the 10 %
    # parameter error (measured 12.5 % hogan, 9.2 % feldman), not amplified tenfold.
    assert 0.03 < off["median"] < 0.3
    assert off["median"] > 5 * exact["median"]


def test_fig9_no_update_without_motion_and_quick_recovery():
    track = paper.fig9_exponential_vsa()
    pause = track.interior(11.0, 19.5)
    # motion dies out within ~1.5 s of 10 s: the estimate is held (changes < 3 %) while the
    # true stiffness keeps growing (by ~35 % over the pause), and is flagged unobservable.
    # (The zero-phase filter lets the restart at 20 s show a few tens of ms early: stop at 19.5 s.)
    held = track.estimate[pause]
    assert np.ptp(held) / np.mean(held) < 0.03
    assert np.ptp(track.truth[pause]) / np.mean(track.truth[pause]) > 0.3
    assert track.observable[track.interior(13.0, 20.0)].mean() < 0.05
    # recovery: within 1 s of motion resuming the error is below 5 % and stays there
    assert track.settling_time(0.05) < 21.0
    assert track.error_stats(start=2.0, stop=10.0)["median"] < 0.02


def test_exponential_spring_with_default_settings_is_within_one_percent_after_0_3_s():
    # `limbstiff simulate paper-exp-spring` as it comes, `limbstiff analyze` as it comes (the
    # Kalman estimator, nothing given): the paper's "< 1 %" after 0.3 s, at the 95th percentile.
    # Measured 1.8 % before the stiffness was placed at the middle of its filter step, 0.28 % after.
    import limbstiff
    from limbstiff.simulate import simulate

    trial = simulate("paper-exp-spring")
    result = limbstiff.analyze(trial)
    after = trial.time - trial.time[0] >= 0.3
    error = np.abs(result.stiffness - trial.stiffness_true)[after] / trial.stiffness_true[after]
    assert np.percentile(error, 95) <= 0.01
    assert result.verdict == "ok"
