"""The five real ankle recordings (data/reklab-ankle), against SOURCE.md.

SOURCE.md's reference values (least squares with a delayed reflex term, ±20–30 %):
z_df I 0.0166 B 1.35 K 90; z_df2 I 0.0145 B 0.79 K 54; z_df3 I 0.0138 B 1.45 K 139;
z_pf I 0.0165 B 0.65 K 69; z_pf2 I 0.0149 B 1.48 K 127.
"""

import numpy as np
import pytest

from limbstiff.analysis import analyze
from limbstiff.files import read_trial
from limbstiff.protocol import load_protocol

from .conftest import PROTOCOLS, REAL

pytestmark = pytest.mark.slow        # end to end: `pytest -m "not slow"` is the inner loop

REFERENCE = {"z_df": (0.0166, 1.35, 90.0), "z_df2": (0.0145, 0.79, 54.0), "z_df3": (0.0138, 1.45, 139.0),
             "z_pf": (0.0165, 0.65, 69.0), "z_pf2": (0.0149, 1.48, 127.0)}


@pytest.fixture(scope="module")
def results():
    protocol = load_protocol(PROTOCOLS / "reklab-ankle.toml")
    return {name: analyze(read_trial(REAL / f"{name}.csv", protocol), protocol) for name in REFERENCE}


@pytest.mark.parametrize("name", ["z_df", "z_df2", "z_df3"])
def test_dorsiflexor_stiffness_within_30_percent(results, name):
    # SOURCE.md's K is one linear stiffness fitted over the whole perturbation: an average over
    # the cycle, like the model's per-sample course (whose median is compared here, measured 112.7,
    # 63.0, 171.4), not the trial-level median, which adds the change with the angle within the
    # cycle (116.9 on z_df, where the stiffness is higher at the perturbation's centre)
    result = results[name]
    informed = result.observable
    assert float(np.median(result.stiffness[informed])) == pytest.approx(REFERENCE[name][2], rel=0.30)


@pytest.mark.parametrize("name", list(REFERENCE))
def test_inertia_and_damping_plausible(results, name):
    s = results[name].summary()
    # foot and footplate: 0.010–0.022 kg·m²; damping within a factor of two of SOURCE.md
    assert 0.010 <= s["inertia"]["median"] <= 0.022
    assert REFERENCE[name][1] / 2 <= s["damping"]["median"] <= REFERENCE[name][1] * 2


@pytest.mark.parametrize("name", list(REFERENCE))
def test_summary_says_inertia_is_in_the_expected_range(results, name):
    # protocols/reklab-ankle.toml: expected_inertia = [0.010, 0.022]
    check = results[name].summary()["details"]["identification"]["inertia_in_expected_range"]
    assert check == {"range": [0.010, 0.022], "inside": True}
    assert results[name].summary()["mcmc"]["converged"]


@pytest.mark.parametrize("name", ["z_df", "z_df2", "z_df3"])
def test_trials_the_model_fits_pass_every_check_but_the_angle_dependence(results, name):
    # the issue: a check that cries wolf is as bad as none. The dorsiflexor trials' stiffness
    # matches SOURCE.md; what the model misses there is only that the stiffness changes with the
    # angle within the perturbation (the angle_dependence check, below)
    # z_df also has the reflex SOURCE.md describes, which moves its stiffness by more than its band
    # (test_a_reflex_in_the_model_moves_z_df_towards_source below)
    # issue 46: z_df2's residual also holds a torque following the velocity through a threshold (the
    # reflex SOURCE.md describes); it moves the stiffness by 0.28 of the band's half-width, under the
    # contract's 0.33 (test_no_angle_property_… below), so velocity_shape passes
    failed = {c.name for c in results[name].checks.failed}
    allowed = {"angle_dependence"} | ({"reflex"} if name == "z_df" else set())
    assert failed <= allowed, results[name].checks.reasons
    assert results[name].verdict == ("caution" if failed else "ok")


def test_a_reflex_in_the_model_moves_z_df_towards_source(results):
    # SOURCE.md's K is a least-squares fit *with* a delayed reflex term (90 N·m/rad). Left out, the
    # reflex is named by the check (measured: the median would move by −10.6 %, beyond the band's
    # 2.8 %); put in the model it moves the median from 116.9 towards 90 (measured 104.1)
    check = results["z_df"].checks["reflex"]
    assert not check.passed and check.value > check.threshold and "--effect reflex" in check.message
    protocol = load_protocol(PROTOCOLS / "reklab-ankle.toml")
    fitted = analyze(read_trial(REAL / "z_df.csv", protocol), protocol, effects=("reflex",))
    before, after = (r.informed_stiffness()[0].median for r in (results["z_df"], fitted))
    assert abs(after - REFERENCE["z_df"][2]) < abs(before - REFERENCE["z_df"][2])
    # the check's prediction (affine in m, b and the gain at the probe's noise levels) against the
    # analysis done with the reflex in the model: within 3 points (its shape, noise levels and m, b
    # are fitted again there)
    assert after / before - 1 == pytest.approx(-check.value, abs=0.03)
    # with the reflex in the model only the change with the angle is left to say, and (issue 46) the
    # part of the reflex the library's shape lacks (a threshold: velocity_shape)
    assert {c.name for c in fitted.checks.failed} <= {"angle_dependence", "velocity_shape"}


def test_the_angle_dependence_of_z_df_is_within_its_band_and_z_df3_shows_none(results):
    # measured before issue 46: z_df's stiffness changes by ±11 % (rms) within the perturbation (Wald
    # 34, 4.3 band half-widths). Since issue 46 its band carries the reflex in or out (the probe's
    # reflex weighs nearly 1: ±18 % instead of ±2.7 %) and the terms are fitted beside the
    # velocity-driven torques: the change, 0.63 half-widths, is within the band and not flagged;
    # z_df3 shows none (Wald 1.0, 0.1 half-widths)
    assert results["z_df"].checks["angle_dependence"].passed
    assert 0.3 < results["z_df"].checks["angle_dependence"].value < 1.0
    assert results["z_df3"].checks["angle_dependence"].passed
    assert results["z_df3"].verdict == "ok"


def test_z_pf_is_flagged_with_its_reason(results):
    # SOURCE.md: plantarflexors active, a large stretch reflex; the model predicts under half of
    # the torque out of sample (measured 0.04 before the corner scan, ~0.4 after)
    z_pf = results["z_pf"]
    assert z_pf.verdict in ("caution", "unreliable")
    assert "heldout_torque_explained" in {c.name for c in z_pf.checks.failed}
    assert any("motion periods it was not fitted on" in r for r in z_pf.checks.reasons)


@pytest.mark.parametrize("name", list(REFERENCE))
def test_no_coupling_is_claimed_on_the_real_trials(results, name):
    # the two-body model does not describe them to within the noise either (a reflex, not a coupling)
    assert not results[name].coupling.found


def test_no_angle_property_is_claimed_where_a_velocity_driven_torque_is_a_rival(results):
    # issue 34 said z_df's and z_df2's change with the angle is the joint's property. Issue 46: both
    # residuals also hold a torque following the velocity through a threshold (their reflex), which
    # follows the angle's phase as well, so the change is no longer claimed as the joint's (the
    # gated reflex of benchmarks/reflex_study.py, whose stiffness is constant, was claimed so too)
    from limbstiff.digest import ANGLE_PROPERTY

    for name in ("z_df", "z_df2"):
        assert not any(r.startswith(ANGLE_PROPERTY) for r in results[name].checks.reasons)
    # z_df2's velocity-driven torques stand out of the noise (so they are the angle terms' rival) and
    # move its median by −3.8 % (±0.5 %): 0.28 of the band's half-width, a shift under which a 90 %
    # band still holds 85 % (the limit, 0.33); measured when the limit moved from half of it (issue 46)
    shape = results["z_df2"].checks["velocity_shape"]
    assert shape.passed and "is in the residual" in shape.message
    assert 0.5 * shape.threshold < shape.value < shape.threshold
    # z_df3 shows no change with the angle: the check passes and lowers nothing
    assert results["z_df3"].checks["angle_dependence"].passed
    assert "angle_dependence" not in {c.name for c in results["z_df3"].checks.failed}


def test_z_df_stiffness_against_angle(results):
    # the report's curve refits the terms on the result's own steps: the same terms as the check's
    # (its value, variation over band half-width, reproduced), highest near the operating angle and
    # lower at both ends of the perturbation (measured 121 N·m/rad at the centre, 84 and 90 at
    # −0.029 and +0.028 rad), as page 1 and page 3 say
    from limbstiff.estimate.observer import informed_samples
    from limbstiff.report.pages import angle_rows
    from limbstiff.report.plots import angle_figure

    pytest.importorskip("matplotlib")
    result = results["z_df"]
    figure = angle_figure(result)
    c = figure.course
    assert c.operating == pytest.approx(0.153, abs=0.005)
    assert c.deflection[0] == pytest.approx(-0.029, abs=0.003) and c.deflection[-1] == pytest.approx(0.028, abs=0.003)
    top = int(np.argmax(c.stiffness))
    assert 0 < top < len(c.stiffness) - 1
    half = (c.hi - c.lo) / 2
    assert c.stiffness[top] - max(c.stiffness[0], c.stiffness[-1]) > half[top] + max(half[0], half[-1])
    assert c.stiffness[top] == pytest.approx(121, rel=0.05)
    assert np.all(c.lo < c.stiffness) and np.all(c.stiffness < c.hi)
    informed = informed_samples(result.observable)
    band_half = np.median((result.stiffness_hi - result.stiffness_lo)[informed]) / 2
    # page 3 refits the terms alone; the check's are fitted beside the velocity-driven torques
    # (issue 46): measured 0.613 against 0.626 half-widths
    assert figure.terms.variation(informed) / band_half == pytest.approx(
        result.checks["angle_dependence"].value, rel=0.05)
    # the smoothed course behind it is the result's, at informed steps
    assert np.median(figure.stiffness) == pytest.approx(np.median(result.stiffness[informed]), rel=0.01)
    # page 1 has no row on it since issue 46: the change lies within z_df's band (the reflex in or out)
    assert angle_rows(result, figure) == []


@pytest.mark.parametrize("name", list(REFERENCE))
def test_page_one_and_the_diagnosis_state_the_analysis_median(results, name):
    """One answer (issue 45): page 1's headline median lies within the per-cycle course it draws, and
    the stiffness the diagnosis measures an effect's bias from (the analysis's model and summary on
    the trial as recorded) is that median."""
    from limbstiff.diagnosis.bias import analysis_stiffness
    from limbstiff.digest import cycle_course
    from limbstiff.effects.channels import channels_from
    result = results[name]
    median = result.informed_stiffness()[0].median
    course = cycle_course(result)
    drawn = course.stiffness[course.informed]
    assert drawn.min() <= median <= drawn.max()
    protocol = load_protocol(PROTOCOLS / "reklab-ankle.toml")
    assert analysis_stiffness(result.trial, result, channels_from(result.trial, result),
                              protocol) == pytest.approx(median, rel=1e-12)
