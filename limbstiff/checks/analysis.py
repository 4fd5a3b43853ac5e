"""Every model check of one analysis: :func:`check_analysis`. Pure numpy: no I/O."""

from __future__ import annotations

import numpy as np

from ..coupling import ADEQUATE_CHI2, CouplingFit
from ..estimate.angle_terms import AngleTerms
from ..statespace.noise import NoiseLevels
from ..estimate.observer import informed_samples
from ..filtered import Filtered
from ..mechanics.identification import Identification
from . import model
from .verdict import (AGREEMENT_MAX, ANGLE_CHANGE_MIN, ANGLE_VARIATION_MAX, ANGLE_WALD, BAND_WIDTH_MAX,
                      BAND_ZERO_MAX, BOUND_MARGIN, CAUTION, HELDOUT_CAUTION, HELDOUT_UNRELIABLE, NEGATIVE_SHARE_MAX,
                      NEGLIGIBLE_HELDOUT, NEGLIGIBLE_RESIDUAL, UNRELIABLE, VELOCITY_CORRELATION_MAX, WHITENESS_MAX,
                      Check, ModelChecks, check_at_least, check_at_most, finite_or_none)

#: Windows of the sign test, in periods of the typical motion (as the identification's).
SIGN_WINDOW_PERIODS = 4.0
#: Share of the torque the opposite sign's elastic line must explain beyond the recorded sign's.
SIGN_MARGIN = 0.1


def sign_advice(scale: float = 1.0, column: str = "torque") -> str:
    """What to change for a torque that looks recorded with the opposite sign, from the protocol as given.

    Parameters
    ----------
    scale : float
        The ``scale`` of the torque's column in the protocol (1 when it sets none).
    column : {"torque", "elastic_torque"}
        The column it applies to.

    Returns
    -------
    str
        Remove the flip that is there (a negative ``scale``), or add one.
    """
    seen = "the torque looks recorded with the opposite sign"
    if scale < 0:
        return (f"{seen}: the protocol's [columns.{column}] already flips it (scale = {scale:g}) and this file's "
                f"torque needs no flip; remove it (scale = {-scale:g}) and analyse again")
    if scale != 1:
        return (f"{seen} (a reaction torque?): set scale = {-scale:g} in the protocol's [columns.{column}] "
                "and analyse again")
    return (f"{seen} (a reaction torque?): add scale = -1 to [columns.{column}] of a protocol (--protocol) "
            "and analyse again")


def torque_sign(filtered: Filtered, *, inertia: float, damping: float,
                scale: float = 1.0) -> Check:
    """Whether the torque looks recorded with the opposite sign.

    Window by window (:data:`SIGN_WINDOW_PERIODS` motion periods), the torque left to the
    elastic element is fitted by a line in the angle. With the right sign that line explains
    most of it; with the wrong one −f − m·ÿ − b·ẏ is the elastic torque, and its line explains
    clearly more (by :data:`SIGN_MARGIN`) and rises with the angle, or as much while the recorded
    one falls (the direct variant, where flipping only negates); ``scale`` is the protocol's for the
    torque's column (the advice: :func:`sign_advice`). Measured: right sign
    0.54–1.00 of the torque explained (simulated elbow, wrist, ankle; real z_df, z_pf, z_pf2),
    the opposite sign 0.15–0.50; the slope alone misleads where m·ÿ outweighs the stiffness.
    """
    window = max(8, int(round(SIGN_WINDOW_PERIODS / filtered.motion_hz / filtered.sample_period)))
    recorded = model.elastic_slopes(filtered.elastic_torque(inertia, damping), filtered.angle, window=window)
    flipped = model.elastic_slopes(-filtered.torque - inertia * filtered.acceleration - damping * filtered.velocity,
                                   filtered.angle, window=window)
    gain = float(np.median(flipped[1]) - np.median(recorded[1]))
    rises, rises_flipped = float(np.median(recorded[0])) > 0, float(np.median(flipped[0])) > 0
    # without m and b (direct variant) flipping only negates: the fit is the same, the slope tells
    wrong = rises_flipped and (gain > SIGN_MARGIN or (not rises and gain > -SIGN_MARGIN))
    return Check("torque_sign", gain, SIGN_MARGIN, not wrong,
                 sign_advice(scale, _torque_column(filtered)) if wrong else
                 "the torque rises with the angle as a torque applied to the joint does",
                 UNRELIABLE)


def _torque_column(filtered: Filtered) -> str:
    return "torque" if filtered.variant == "external" else "elastic_torque"


def sign_hint(filtered: Filtered, *, scale: float = 1.0) -> str | None:
    """:func:`sign_advice` (``scale``: the protocol's for the torque) when least squares finds a
    negative inertia and, with it, an elastic torque falling with the angle — what a torque
    recorded with the opposite sign gives (both change sign with the torque); None otherwise (a
    negative inertia alone can have other causes, a delay between the channels for one)."""
    from ..mechanics.least_squares import least_squares
    window = SIGN_WINDOW_PERIODS / filtered.motion_hz
    fit = least_squares(filtered.torque, filtered.angle, filtered.velocity, filtered.acceleration,
                        sample_period=filtered.sample_period, window=window)
    if not (fit.inertia < 0 and fit.damping < 0):
        return None
    check = torque_sign(filtered, inertia=-fit.inertia, damping=-fit.damping, scale=scale)
    slopes = model.elastic_slopes(filtered.elastic_torque(fit.inertia, fit.damping), filtered.angle,
                                  window=max(8, int(round(window / filtered.sample_period))))[0]
    return sign_advice(scale, _torque_column(filtered)) if (not check.passed or np.median(slopes) < 0) else None


def _heldout(value: float | None) -> Check:
    if value is None:
        return Check("heldout_torque_explained", None, HELDOUT_CAUTION, True,
                     "too short to leave whole motion periods out (fewer than three blocks of two periods, "
                     "or too few model steps)")
    text = f"the model predicts {100 * max(value, 0):.0f} % of the torque on motion periods it was not fitted on"
    if value < HELDOUT_UNRELIABLE:
        return Check("heldout_torque_explained", value, HELDOUT_UNRELIABLE, False,
                     text + ": it does not describe this recording (an unmodelled reflex, movement or coupling?); "
                           "do not use the stiffness; `limbstiff diagnose` says what is missing", UNRELIABLE)
    return check_at_least("heldout_torque_explained", value, HELDOUT_CAUTION, severity=CAUTION, good=text,
                          bad=text + ": a large part of the torque is not described by inertia, damping and "
                                     "stiffness; `limbstiff diagnose` says what is missing")


def _negligible(name: str, value: float | None, threshold: float, share: float) -> Check:
    return Check(name, value, threshold, True, f"the torque residual is negligible ({100 * share ** 0.5:.2g} % of the "
                                               "torque's spread): its structure does not matter")


def _innovations(stats: model.InnovationStatistics | None, negligible: bool, share: float) -> list[Check]:
    if stats is None:
        return [Check(name, None, limit, True, "too few model steps to judge the residual")
                for name, limit in (("residual_whiteness", WHITENESS_MAX),
                                    ("residual_velocity_correlation", VELOCITY_CORRELATION_MAX))]
    if negligible:
        return [_negligible("residual_whiteness", stats.autocorrelation, WHITENESS_MAX, share),
                _negligible("residual_velocity_correlation", stats.velocity_correlation, VELOCITY_CORRELATION_MAX,
                            share)]
    return [
        check_at_most("residual_whiteness", stats.autocorrelation, WHITENESS_MAX, severity=CAUTION,
                      good="the torque residual has no structure the model should have explained",
                      bad="the torque residual is strongly correlated in time: the model misses a dynamic of the "
                          "recording (a resonance of the set-up, a delay between channels?); try a lower "
                          "bandwidth_hz or `limbstiff diagnose`"),
        check_at_most("residual_velocity_correlation", stats.velocity_correlation, VELOCITY_CORRELATION_MAX,
                      severity=CAUTION,
                      good="the torque residual is not driven by the velocity",
                      bad="the torque residual follows the velocity (a stretch reflex, friction, a damping the "
                          "model lacks): the stiffness may carry part of it; `limbstiff diagnose` separates them"),
    ]


#: Share of the band's variance (median over the informed samples) above which its width is said
#: to come from the alternatives to the chosen model (:class:`limbstiff.band.ModelForm`): more
#: than half of it is then the models' spread, not the recording's noise.
MODEL_FORM_SHARE = 0.5

#: Said instead of the recording's causes when the band's width is the alternatives' spread.
MODEL_FORM_WIDE = ("most of the band's width is the spread between models the data hardly tell apart (the "
                   "chosen one and an alternative of comparable evidence, such as the stretch reflex the `reflex` "
                   "check probes put in or left out): their stiffness differs; decide which holds (--effect "
                   "reflex, or a protocol's effects) and analyse again")


def _stiffness_course(stiffness, lo, hi, observable, form_share: float = 0.0) -> list[Check]:
    informed = informed_samples(observable)
    negative = float(np.mean(stiffness[informed] < 0))
    median = float(np.median(stiffness[informed]))
    width = float(np.median((hi - lo)[informed])) / abs(median) if median != 0 else np.inf
    return [
        check_at_most("negative_stiffness_share", negative, NEGATIVE_SHARE_MAX, severity=UNRELIABLE,
                      good="the stiffness is positive where the motion informs it",
                      bad=f"the stiffness is negative in {100 * negative:.0f} % of the informed samples: the model "
                          "does not fit (check the torque's sign and units, or run `limbstiff diagnose`)"),
        check_at_most("band_width_relative", finite_or_none(width), BAND_WIDTH_MAX, severity=CAUTION,
                      good="the band is narrower than the stiffness itself",
                      bad="the band is wider than the stiffness itself: " + (
                          MODEL_FORM_WIDE if form_share > MODEL_FORM_SHARE else
                          "the recording does not pin the stiffness down (too little motion, or torque the model "
                          "takes for stiffness changes)")),
        check_at_most("band_excludes_zero", finite_or_none(width), BAND_ZERO_MAX, severity=UNRELIABLE,
                      good="the band does not reach zero: the recording tells a stiffness from none",
                      bad="the band is more than twice as wide as the stiffness and reaches zero: " + (
                          MODEL_FORM_WIDE if form_share > MODEL_FORM_SHARE else
                          "the recording does not determine the stiffness (torque noise, too little motion, or "
                          "torque the model cannot explain)")),
    ]


#: Largest standard error of the within-cycle change (its rms, by the delta method through the terms'
#: sandwich covariance) relative to the change, for the change to count as well determined and
#: be reported as the joint's property: the change is then at least three of its standard errors,
#: its size known to a third. Measured: z_df 0.22, z_df2 0.10 (both reported as the joint's
#: property); z_df3 and the simulated elbow, which show no change, 1.0.
ANGLE_DETERMINED_MAX = 1 / 3


def _angle_dependence(found: AngleTerms | None, stiffness, lo, hi, observable) -> Check:
    """Caution when the stiffness changes with the angle within the cycle, significantly (the Wald
    statistic beyond :data:`ANGLE_WALD`), by more than the band's half-width and by at least
    :data:`ANGLE_CHANGE_MIN` of the stiffness: the course's band, an average over the cycle, does
    not hold the stiffness at the cycle's extremes, and that stays flagged.

    With two terms the stiffness against the angle is a parabola, smooth by construction; where
    its change is well determined (:data:`ANGLE_DETERMINED_MAX`) the message says it as what it
    is, the joint's stiffness depending on its angle (``digest.ANGLE_PROPERTY``: the verdict's
    words follow it), not a misfit — unless the terms were fitted beside a velocity-driven torque
    the model lacks (:attr:`AngleTerms.beside`, issue 46): a rival explanation, so no property is
    claimed; otherwise it lists what can cause it."""
    from ..digest import ANGLE_PROPERTY

    if found is None:
        return Check("angle_dependence", None, ANGLE_VARIATION_MAX, True,
                     "too few model steps, or too little motion to either side, to judge")
    informed = informed_samples(observable)
    half = float(np.median((hi - lo)[informed])) / 2
    variation = found.variation(informed)
    ratio = variation / half if half > 0 else np.inf
    percent = 100 * variation / max(abs(float(np.median(stiffness[informed]))), 1e-300)
    if found.wald <= ANGLE_WALD:
        return Check("angle_dependence", finite_or_none(ratio), ANGLE_VARIATION_MAX, True,
                     f"no change of the stiffness with the angle within the motion cycle that the data tell from "
                     f"noise (χ² = {found.wald:.1f}, 2 degrees of freedom)")
    if ratio <= ANGLE_VARIATION_MAX or percent < 100 * ANGLE_CHANGE_MIN:
        return Check("angle_dependence", finite_or_none(ratio), ANGLE_VARIATION_MAX, True,
                     f"the stiffness changes with the angle within the motion cycle by about ±{percent:.2g} %, "
                     + ("less than its band's half-width" if ratio <= ANGLE_VARIATION_MAX else
                        f"under {100 * ANGLE_CHANGE_MIN:.0f} % of the stiffness"))
    # the rms change's standard error, by the delta method: ∂v/∂β = M·(Mᵀβ)/(n·v)
    missed = found.missed[:, informed[found.index]]
    course = found.coefficients @ missed
    grad = missed @ course / max(course.size * variation, 1e-300)
    relative = float(np.sqrt(max(grad @ found.covariance @ grad, 0.0))) / max(variation, 1e-300)
    tail = (f"the course over time is its average over the cycle, so its band does not hold the stiffness at the "
            f"cycle's extremes (the change is {ratio:.1f} times the band's half-width); the median stiffness and "
            "the other trial-level figures include the change")
    if found.beside:
        return Check("angle_dependence", finite_or_none(ratio), ANGLE_VARIATION_MAX, False,
                     f"the stiffness appears to change with the angle within each motion cycle, by about "
                     f"±{percent:.0f} %, but the residual also holds a torque following the velocity through a "
                     "threshold or a shape the model lacks (see the velocity_shape check), which follows the angle's "
                     f"phase too: the change need not be the joint's (a reflex gated by velocity does this); {tail}",
                     CAUTION)
    if relative <= ANGLE_DETERMINED_MAX:
        return Check("angle_dependence", finite_or_none(ratio), ANGLE_VARIATION_MAX, False,
                     f"{ANGLE_PROPERTY}: it changes by about ±{percent:.0f} % within each motion cycle, a property "
                     "of the joint (muscle and tissue stiffen or yield with the stretch), not a misfit; the report "
                     f"shows it against the angle (page 3). {tail[0].upper()}{tail[1:]}", CAUTION)
    return Check("angle_dependence", finite_or_none(ratio), ANGLE_VARIATION_MAX, False,
                 f"the stiffness changes with the angle within each motion cycle, by about ±{percent:.0f} %, known "
                 f"only to ±{100 * relative:.0f} % of itself (a spring stiffening with the deflection, muscle "
                 "yielding at larger stretches, or torque answering stretch in one direction only, as a reflex "
                 f"does): {tail}", CAUTION)


def median_sign(median) -> Check:
    """``unreliable`` when the median stiffness's interval (an :class:`~limbstiff.interval.Interval`,
    N·m/rad) lies wholly below zero: a limb or a spring is not negatively stiff, the model does not
    fit whatever the course's share of negative samples. Passes when the interval is not finite."""
    hi = finite_or_none(median.hi)
    if hi is None or hi >= 0:
        return Check("median_stiffness_sign", hi, 0.0, True,
                     "the median stiffness's interval reaches above zero" if hi is not None else
                     "the median stiffness has no interval to judge")
    return Check("median_stiffness_sign", hi, 0.0, False,
                 f"the median stiffness's interval lies wholly below zero ({median.lo:.3g} to {median.hi:.3g}): a "
                 "limb is not negatively stiff, so the model does not fit (check the torque's sign and units, or "
                 "run `limbstiff diagnose`); do not use the stiffness", UNRELIABLE)


def _noise_levels(margins: np.ndarray, negligible: bool, share: float) -> Check:
    if negligible:
        return _negligible("noise_levels_at_bounds", float(min(margins[0], *margins[2:])), BOUND_MARGIN, share)
    names = ("measurement noise", "torque walk", "stiffness walk", "stiffness walk")    # Q_σ and Q_c alike
    at_bound = list(dict.fromkeys(name for name, m in zip(names, margins) if m < BOUND_MARGIN))
    failing = [n for n in at_bound if n != "torque walk"]
    value = float(min(margins[0], *margins[2:]))
    note = (" (the torque walk is at its bound: torque not explained by the angle, such as a reflex, is large)"
            if "torque walk" in at_bound else "")
    if failing:
        return Check("noise_levels_at_bounds", value, BOUND_MARGIN, False,
                     f"the {' and '.join(failing)} reached the largest value the model allows: the model takes up "
                     "torque it does not explain as " + ("stiffness changes" if "stiffness walk" in failing else
                                                         "noise") + note, CAUTION)
    return Check("noise_levels_at_bounds", value, BOUND_MARGIN, True,
                 "the noise levels were fitted inside their bounds" + note)


def _agreement(ident: Identification, filtered: Filtered, stiffness, observable) -> Check | None:
    if ident is None or ident.given or ident.least_squares is None or ident.maximum_likelihood is None:
        return None
    m, b = ident.inertia.median, ident.damping.median
    informed = informed_samples(observable)
    shifts = {name: model.stiffness_shift(filtered, inertia=m, damping=b, other=(fit.inertia, fit.damping),
                                          stiffness=stiffness, informed=informed)
              for name, fit in (("least squares", ident.least_squares),
                                ("maximum likelihood", ident.maximum_likelihood))}
    shifts = {k: v for k, v in shifts.items() if v is not None}
    if not shifts:
        return None
    name = max(shifts, key=lambda k: abs(shifts[k]))
    worst = abs(shifts[name])
    ls = ident.least_squares
    apart = max(abs(ls.inertia - m) / (abs(m) or 1e-300), abs(ls.damping - b) / (abs(b) or 1e-300))
    return check_at_most("mechanics_agreement", worst, AGREEMENT_MAX, severity=CAUTION,
                         good=f"least squares, maximum likelihood and the posterior agree on inertia and damping as "
                              f"far as the stiffness is concerned (with {name}'s m and b it would differ by "
                              f"{100 * worst:.0f} %)",
                         bad=f"least squares, maximum likelihood and the posterior disagree on inertia or damping "
                             f"(least squares by {100 * apart:.0f} %), and with {name}'s m and b the stiffness would "
                             f"differ by {100 * worst:.0f} %: they rest on the model, not the data; give m and b if "
                             "they are known, or treat the stiffness with caution")


def _inertia_range(ident: Identification) -> Check | None:
    if ident is None or ident.expected_inertia is None:
        return None
    lo, hi = ident.expected_inertia
    inside = ident.inertia_in_expected_range
    return Check("inertia_in_expected_range", ident.inertia.median, None, bool(inside),
                 f"the inertia is {'within' if inside else 'OUTSIDE'} the range expected for this set-up "
                 f"({lo:g}–{hi:g})" + ("" if inside else ": check the protocol's expected_inertia, the units, "
                                                         "and the torque's sign"), CAUTION)


def _coupling(coupling: CouplingFit | None, corrected: bool) -> Check | None:
    if coupling is None or not coupling.found:
        return None
    text = (f"the angle is measured at the device, joined to the limb by a compliant coupling (resonance "
            f"{coupling.resonance_hz:.0f} Hz, {coupling.coupling_stiffness:.0f} N·m/rad)")
    if corrected:
        return Check("device_coupling", coupling.two_body_chi2, ADEQUATE_CHI2, True,
                     text + ": the stiffness shown is the limb's, the springs in series undone")
    return Check("device_coupling", coupling.two_body_chi2, ADEQUATE_CHI2, False,
                 text + ", as soft as the limb or softer: the limb's stiffness cannot be told apart from it "
                        "(the stiffness shown is that of both in series); stiffen the attachment", UNRELIABLE)


def check_analysis(filtered: Filtered, *, stiffness: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                   observable: np.ndarray, ident: Identification | None, noise: NoiseLevels,
                   coupling: CouplingFit | None = None, corrected: bool = False,
                   angle_terms: AngleTerms | None = None, torque_scale: float = 1.0,
                   form_share: float = 0.0) -> ModelChecks:
    """Every check of one analysis.

    Parameters
    ----------
    filtered : Filtered
    stiffness, lo, hi : ndarray, shape (n,), N·m/rad
        The stiffness and its band.
    observable : ndarray of bool, shape (n,)
    ident : Identification or None
        None for the direct variant.
    noise : NoiseLevels
        The Kalman model's noise levels.
    coupling : CouplingFit or None
        A coupling between limb and device, when one was looked for.
    corrected : bool
        Whether ``stiffness`` is the limb's with the coupling's series springs undone.
    angle_terms : AngleTerms, optional
        The angle terms already fitted on the same model (:mod:`limbstiff.estimate.angle_terms`);
        fitted here when not given.
    torque_scale : float
        The protocol's ``scale`` for the torque's column (what the sign check's advice starts from).
    form_share : float
        Share of the band's variance that is the spread of the alternatives to the chosen model
        (median over the informed samples; 0 without alternatives): the band-width checks then
        say so (:data:`MODEL_FORM_SHARE`).

    Returns
    -------
    ModelChecks
    """
    m = 0.0 if ident is None else ident.inertia.median
    b = 0.0 if ident is None else ident.damping.median
    kw = dict(inertia=m, damping=b, noise=noise)
    heldout = model.heldout_explained(filtered, **kw)
    share = float(noise.measurement) / max(model.dynamic_variance(filtered), 1e-300)
    # the residual's structure is not judged where it is tiny and the model is shown to predict
    # the torque out of sample (noise-free recordings)
    negligible = share < NEGLIGIBLE_RESIDUAL and heldout is not None and heldout >= NEGLIGIBLE_HELDOUT
    informed = informed_samples(observable)
    checks = [_heldout(heldout),
              *_innovations(model.innovation_statistics(filtered, **kw, informed=informed), negligible, share),
              *_stiffness_course(stiffness, lo, hi, observable, form_share),
              _angle_dependence(angle_terms or model.angle_terms(filtered, **kw), stiffness, lo, hi, observable),
              _noise_levels(model.bound_margins(filtered, **kw), negligible, share),
              _agreement(ident, filtered, stiffness, observable),
              _inertia_range(ident),
              torque_sign(filtered, inertia=m, damping=b, scale=torque_scale), _coupling(coupling, corrected)]
    return ModelChecks(tuple(c for c in checks if c is not None))
