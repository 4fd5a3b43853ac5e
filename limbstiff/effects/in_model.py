"""Named torque effects in the analysis's model: shape profiled, amplitude identified with m and b.

``limbstiff analyze --effect reflex`` (or the protocol's ``effects``) puts an effect of the library
(:data:`~limbstiff.effects.registry.CANDIDATES`) in the model the stiffness is estimated with:
f = m·ÿ + b·ẏ + a·φ(shape) + s. Its shape (a reflex's delay, direction and activation) is
chosen on the effect's own grid by the Kalman model's marginal likelihood at the noise levels of
the model without it (:func:`profile_effect`); its amplitude a is then a linear coefficient
identified with m and b, its posterior drawn with theirs
(:func:`~limbstiff.mechanics.identification.identify_mechanics`) and carried into the stiffness's
band. Only torque effects can be put in the model: a corrected channel or an offset of m or b
changes what the model is fitted to, not what it contains.

The same profile, run on every analysis without effects, is the probe behind the ``reflex``
check (:func:`probe_effect`): how far m, b and the stiffness would move with the effect in the
model. Pure numpy/scipy: no I/O.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Mapping, Sequence

import numpy as np

from ..checks.model import MIN_STEPS
from ..checks.reflex import MechanicsMove, ReflexShift
from ..checks.shape import ShapeMiss, shape_miss
from ..errors import LimbstiffError, TrialError
from ..filtered import Filtered
from ..mechanics.effect_terms import EffectTerms, without_effects
from ..mechanics.identification import Identification, mechanics_problem
from ..mechanics.likelihood import MechanicsProblem, kalman_mechanics, robust_covariance
from ..protocol import Protocol
from ..statespace.noise import NoiseLevels
from ..statespace.steps import ModelSteps
from ..trial import Trial
from ..unmodelled import delay_signal
from .candidates import ACTIVATION_HZ, activation
from .registry import CANDIDATES, IN_MODEL
from .channels import Channels
from .kinds import Scales, TorqueEffect, filtered_torque

#: The shapes of an effect are screened on the signals at a lower rate, at least this many times
#: the low-pass corner (:func:`_screened`).
SCREEN_RATE = 8.0
#: Shapes whose screened log-likelihood is within this share of the best one's lead over the median
#: shape are evaluated at the full rate, the best of those kept. Measured on seven simulated elbows
#: and wrists (with and without a reflex, friction, hysteresis; rates of 8–9 corners): the screen's
#: log-likelihoods off by at most 3 % of that lead (beyond a common offset), the best shape always
#: the screen's best, 1–13 of the 130 reflex shapes evaluated at the full rate.
SCREEN_SHARE = 0.2
#: A long trial's shapes are screened on the samples this close to the model's blocks, s: longer
#: than the reflex's delays (≤ 80 ms), its activation's time constants (≤ 0.12 s) and the low-pass
#: filters' transients at the joins.
SCREEN_MARGIN_S = 2.0
#: Other shapes whose log marginal likelihood lies within this of the chosen one's (weight e⁻⁷ ≈ 10⁻³
#: of it, where their draws stop mattering to a 90 % band) are kept as its alternatives, whose spread
#: the band carries (:mod:`limbstiff.effects.model_form`) …
EVIDENCE_SPAN = 7.0
#: … at most this many of them (each costs one smoother pass and a course's memory).
ALTERNATIVES_MAX = 3
#: The shapes' torques are filtered together, at most about this many samples at a time (a few
#: tens of MB: one call per block, not per shape).
COLUMNS_SAMPLES = 2 ** 21


@dataclass(frozen=True)
class ShapeProfile:
    """One effect at the shape that raises the model's marginal likelihood most.

    Parameters
    ----------
    name : str
    shape : Mapping
        The chosen shape parameters.
    column : ndarray, shape (n,)
        Its torque per unit amplitude, low-passed like the torque, N·m per unit.
    loglik_gain : float
        Log marginal likelihood gained over the model without it, at fixed noise levels.
    coefficients : ndarray, shape (p,)
        Posterior mean of the model's coefficients with it: (m, b, amplitude), or the amplitude
        alone when m and b are given.
    covariance : ndarray, shape (p, p)
        Their sandwich covariance (robust to residuals that are not white).
    shapes_tried : int
    without : ndarray, shape (p − 1,)
        The coefficients of the same model without it, at the same noise levels: the baseline its
        change of m and b is measured from.
    alternatives : tuple of (float, ndarray)
        The other shapes of comparable evidence (:data:`EVIDENCE_SPAN`, at most
        :data:`ALTERNATIVES_MAX`, the most likely first): each one's log marginal likelihood less
        the chosen one's (≤ 0) and its column (n,).
    """

    name: str
    shape: Mapping
    column: np.ndarray
    loglik_gain: float
    coefficients: np.ndarray
    covariance: np.ndarray
    shapes_tried: int
    without: np.ndarray = field(default_factory=lambda: np.zeros(0))
    alternatives: tuple = ()

    @property
    def amplitude_z(self) -> float:
        """The amplitude over its (sandwich) standard error."""
        sd = float(np.sqrt(max(self.covariance[-1, -1], 0.0)))
        return float(self.coefficients[-1] / sd) if sd > 0 else float("inf")


def _shape_loglik(problem: MechanicsProblem, logs: np.ndarray, column: np.ndarray) -> float | None:
    """The marginal likelihood of ``problem`` with ``column`` (at its steps) at unit RMS added (None
    when it is zero or the likelihood not finite)."""
    size = float(np.sqrt(np.mean(column ** 2)))
    if not size > 0:
        return None
    loglik = dataclasses.replace(problem, steps=problem.steps.with_channels(column / size)).conditional(logs)[0]
    return loglik if np.isfinite(loglik) else None


def _screened(ch: Channels, effect: TorqueEffect, shapes: list, problem: MechanicsProblem,
              logs: np.ndarray) -> list:
    """The shapes worth evaluating at the full rate: those whose likelihood, with the torque
    evaluated on every q-th sample only (:meth:`Channels.every`) or, on a long trial, around the
    model's blocks only (:func:`_around_blocks`, when fewer samples), is within :data:`SCREEN_SHARE`
    of the best one's lead over the median shape. q divides the model's step and keeps the rate at
    least :data:`SCREEN_RATE` times the low-pass corner; all shapes when neither screen applies."""
    idx = problem.steps.index
    spacing = int(idx[1] - idx[0]) if len(idx) > 1 else 1
    q = max((k for k in range(1, spacing + 1) if spacing % k == 0 and ch.cutoff_hz is not None
             and ch.fs / k >= SCREEN_RATE * ch.cutoff_hz), default=1)
    blocks = _around_blocks(problem, ch)
    if blocks is not None and q * len(blocks) >= ch.n:
        blocks = None                   # every q-th sample is the cheaper screen
    if q == 1 and blocks is None:
        return list(shapes)
    if blocks is not None:
        coarse, at = ch.rows(blocks), np.searchsorted(blocks, idx)
    else:
        offset = int(idx[0] % q)
        coarse, at = ch.every(q, offset), (idx - offset) // q
    logliks = [_shape_loglik(problem, logs, column[at]) for column in _columns(effect, coarse, shapes)]
    valid = [v for v in logliks if v is not None]
    if not valid:
        return list(shapes)
    top = max(valid)
    margin = SCREEN_SHARE * (top - float(np.median(valid)))
    return [shape for shape, v in zip(shapes, logliks) if v is not None and v >= top - margin]


def _columns(effect: TorqueEffect, ch: Channels, shapes: list):
    """Each shape's torque per unit amplitude on ``ch`` (n,), in turn: filtered
    :data:`COLUMNS_SAMPLES` samples at a time (:meth:`TorqueEffect.columns`)."""
    per = max(1, COLUMNS_SAMPLES // max(ch.n, 1))
    for first in range(0, len(shapes), per):
        yield from effect.columns(ch, shapes[first:first + per])


def _around_blocks(problem: MechanicsProblem, ch: Channels) -> np.ndarray | None:
    """The samples within :data:`SCREEN_MARGIN_S` of the model's blocks (a long trial is identified
    on a few blocks spread over it), when they are less than half the trial: there the shapes are
    screened on them alone (the joins' transients die out within the margin); None otherwise."""
    idx, restart = problem.steps.index, problem.steps.restart
    firsts = np.flatnonzero(restart | (np.arange(len(idx)) == 0))
    lasts = np.append(firsts[1:] - 1, len(idx) - 1)
    margin = int(SCREEN_MARGIN_S * ch.fs)
    near = np.zeros(ch.n, dtype=bool)
    for a, b in zip(firsts, lasts):
        near[max(idx[a] - margin, 0):min(idx[b] + margin + 1, ch.n)] = True
    rows = np.flatnonzero(near)
    return rows if 2 * len(rows) < ch.n else None


def profile_effect(ch: Channels, name: str, problem: MechanicsProblem, noise: NoiseLevels) -> ShapeProfile:
    """The shape of effect ``name`` on its grid that raises the marginal likelihood of ``problem``
    most at the noise levels ``noise`` (the coefficients of ``problem`` integrated out).

    Each shape's torque is compared at unit RMS: under the flat prior the marginal likelihood
    carries −½·ln det of the coefficients' information, which grows with the column's size, so
    unscaled a smaller torque (a lower activation corner) would gain ln(1/size) for nothing.

    Parameters
    ----------
    ch : Channels
        The trial's filtered signals (:meth:`Channels.before_analysis`).
    name : str
        One of :data:`IN_MODEL`.
    problem : MechanicsProblem
        The model without it (with the effects chosen before it).
    noise : NoiseLevels
        The noise levels the shapes are compared at.

    Returns
    -------
    ShapeProfile
    """
    effect = CANDIDATES[name]
    logs = noise.logs()
    base, without, _ = problem.conditional(logs)
    idx = problem.steps.index
    shapes = effect.grid(Scales.of([ch]))
    tried = []
    screened = _screened(ch, effect, shapes, problem, logs)
    for shape, column in zip(screened, _columns(effect, ch, screened)):
        loglik = _shape_loglik(problem, logs, column[idx])
        if loglik is not None:
            tried.append((loglik, shape, np.array(column)))
    if not tried:
        raise LimbstiffError(f"the {name} could not be fitted at any shape of its grid")
    tried.sort(key=lambda t: -t[0])
    loglik, shape, column = tried[0]
    alternatives = tuple((float(ll - loglik), col) for ll, _, col in tried[1:1 + ALTERNATIVES_MAX]
                         if ll >= loglik - EVIDENCE_SPAN)
    with_it = dataclasses.replace(problem, steps=problem.steps.with_channels(column[idx]))
    mean = with_it.conditional(logs)[1]
    robust = robust_covariance(with_it, logs, mean, motion_frequency=ch.motion_hz)
    return ShapeProfile(name, dict(shape), column, float(loglik - base), mean, robust.sandwich, len(shapes),
                        without=np.asarray(without, dtype=float), alternatives=alternatives)


def effect_terms(trial: Trial, filtered: Filtered, names: Sequence[str], *,
                 given: tuple[float, float] | None = None) -> EffectTerms:
    """The effects ``names`` at their profiled shapes, one after the other (each profiled with
    those before it in the model), at the maximum-likelihood noise levels of the model without them.

    Parameters
    ----------
    trial : Trial
        External-torque trial (the raw channels).
    filtered : Filtered
        Its filtered signals.
    names : sequence of str
        Effects of :data:`IN_MODEL`.
    given : (float, float), optional
        m (kg·m²) and b (N·m·s/rad) when they are given.

    Returns
    -------
    EffectTerms
    """
    ch = Channels.before_analysis(trial, filtered)
    problem, guess = mechanics_problem(filtered, given=given)
    noise = kalman_mechanics(problem, guess=guess).noise
    chosen = []
    for name in names:
        found = profile_effect(ch, name, problem, noise)
        chosen.append(found)
        problem = dataclasses.replace(problem, steps=problem.steps.with_channels(found.column[problem.steps.index]))
    return EffectTerms(names=tuple(p.name for p in chosen), shapes=tuple(p.shape for p in chosen),
                       amplitude_names=tuple(CANDIDATES[p.name].amplitudes[0] for p in chosen),
                       units=tuple(CANDIDATES[p.name].units.get(CANDIDATES[p.name].amplitudes[0], "1")
                                   for p in chosen),
                       columns=np.vstack([p.column for p in chosen]),
                       loglik_gains=tuple(p.loglik_gain for p in chosen),
                       alternatives=tuple(p.alternatives for p in chosen),
                       shapes_tried=tuple(p.shapes_tried for p in chosen))


def probe_effect(trial: Trial, filtered: Filtered, name: str, *, noise: NoiseLevels,
                 given: tuple[float, float] | None = None) -> ShapeProfile:
    """Effect ``name`` profiled against the model an analysis fitted without it (its noise levels
    ``noise``; ``given`` m and b when they were given): what the ``reflex`` check reads."""
    problem, _ = mechanics_problem(filtered, given=given)
    return profile_effect(Channels.before_analysis(trial, filtered), name, problem, noise)


def probe_delta(probe: ShapeProfile, intervals) -> np.ndarray:
    """How far m, b and the probed effect's amplitude (from 0) move with it in the model, shape (3,):
    m and b with the effect against m and b without it, both at the probe's noise levels (the
    analysis's medians carry the priors, the sandwich and the angle error's shift as well); zero
    for m or b given (``intervals`` None, or a fixed interval)."""
    coef = np.asarray(probe.coefficients, dtype=float)
    delta = np.concatenate([coef[:2] - probe.without[:2] if intervals is not None else np.zeros(2), coef[-1:]])
    if intervals is not None:
        delta[:2] = [0.0 if iv.is_fixed else d for iv, d in zip(intervals, delta[:2])]
    return delta


def reflex_shift(probe: ShapeProfile, *, sensitivity, intervals,
                 stiffness: np.ndarray, half_width: np.ndarray, informed: np.ndarray) -> ReflexShift:
    """What the probed effect would change, for the ``reflex`` check.

    Parameters
    ----------
    probe : ShapeProfile
        :func:`probe_effect`'s outcome.
    sensitivity : sequence of three ndarray, shape (n,)
        ∂σ̂/∂m, ∂σ̂/∂b and ∂σ̂/∂a for the probe's column (the estimate is affine in them).
    intervals : (Interval, Interval) or None
        Their intervals when identified (None when given: they do not move).
    stiffness, half_width : ndarray, shape (n,)
        The analysis's stiffness and its band's half-width, N·m/rad.
    informed : ndarray of bool, shape (n,)

    Returns
    -------
    ReflexShift
    """
    coef = np.asarray(probe.coefficients, dtype=float)
    delta = probe_delta(probe, intervals)
    where = informed if np.any(informed) else slice(None)
    change = delta[0] * sensitivity[0][where]
    for d, row in zip(delta[1:], sensitivity[1:3]):
        change += d * row[where]
    centre = float(np.median(stiffness[where]))
    relative = float(np.median(change)) / centre if centre else float("nan")
    band = float(np.median(half_width[where])) / abs(centre) if centre else float("nan")
    moved = []
    if intervals is not None:
        moved = [MechanicsMove(name, iv.median, float(iv.median + d), not iv.lo <= iv.median + d <= iv.hi)
                 for name, d, iv in zip(("inertia", "damping"), delta[:2], intervals) if not iv.is_fixed]
    sh = probe.shape
    fa = sh.get("activation_hz")
    words = (f"delay {1000 * sh['delay']:.0f} ms, stretch towards {'positive' if sh['direction'] > 0 else 'negative'} "
             f"angles, gain {coef[-1]:.3g}" + ("" if fa is None else f", activation corner {fa:.2g} Hz"))
    return ReflexShift(amplitude_z=probe.amplitude_z, shapes_tried=probe.shapes_tried, stiffness=relative,
                       band=band, mechanics=tuple(moved), description=words)


def terms_for(trial: Trial, filtered: Filtered, protocol: Protocol, *, where: str) -> EffectTerms | None:
    """The protocol's effects at the shapes the data choose (None without effects)."""
    if not protocol.effects:
        return None
    if filtered.variant != "external":
        raise TrialError(where, "effects in the model (--effect) are identified with inertia and damping, from the "
                                "external torque; this trial has only the elastic torque (direct variant)")
    if protocol.estimator != "kalman":
        raise TrialError(where, "effects in the model (--effect) are estimated by the kalman estimator only: run "
                                f"with --estimator kalman instead of {protocol.estimator}")
    given = (protocol.inertia, protocol.damping) if None not in (protocol.inertia, protocol.damping) else None
    return effect_terms(trial, filtered, protocol.effects, given=given)


def filtered_without(filtered: Filtered, terms: EffectTerms, amplitudes: np.ndarray) -> Filtered:
    """The filtered signals with the effects' torques at ``amplitudes`` (k,) taken off the torque
    (and its rate): what m, b and the spring are left to explain (an analysis's ``filtered`` then)."""
    rate = amplitudes @ np.gradient(terms.columns, filtered.sample_period, axis=1)
    return dataclasses.replace(filtered, torque=without_effects(filtered.torque, terms, amplitudes),
                               torque_rate=filtered.torque_rate - rate)


def reflex_probe(trial: Trial, filtered: Filtered, protocol: Protocol, ident: Identification | None,
                 noise: NoiseLevels | None) -> ShapeProfile | None:
    """The library's reflex profiled against the analysis's model (:func:`probe_effect`), for the
    ``reflex`` check: external variant, Kalman estimator, no effects in the model."""
    if ident is None or protocol.effects or protocol.estimator != "kalman" or noise is None:
        return None
    given = (ident.inertia.median, ident.damping.median) if ident.given else None
    try:
        return probe_effect(trial, filtered, "reflex", noise=noise, given=given)
    except (LimbstiffError, np.linalg.LinAlgError, ValueError, FloatingPointError):
        return None             # a check that cannot be computed is skipped, the analysis kept


#: The velocity-driven torques the ``velocity_shape`` check fits beside the model
#: (:mod:`limbstiff.checks.shape`): loop delays, s, within the reflex grid's 20–80 ms …
SHAPE_DELAYS_S = (0.03, 0.06)
#: … thresholds, as percentiles of the trial's |ẏ| (a reflex that starts only above some velocity) …
SHAPE_PERCENTILES = (50.0, 80.0)
#: … and one activation corner, Hz: the middle of the reflex grid's (:data:`candidates.ACTIVATION_HZ`).
SHAPE_ACTIVATION_HZ = ACTIVATION_HZ[len(ACTIVATION_HZ) // 2]


def velocity_shapes(trial: Trial, filtered: Filtered) -> np.ndarray:
    """Torques that follow the velocity through a threshold: ±[±ẏ(t − δ) − v₀]₊ through the
    activation, for δ in :data:`SHAPE_DELAYS_S`, v₀ at :data:`SHAPE_PERCENTILES` of |ẏ| and both
    directions, filtered as the torque (:func:`filtered_torque`); rad/s, shape (k, n)."""
    ch = Channels.before_analysis(trial, filtered)
    speed = np.abs(ch.velocity)
    rows = []
    for delay in SHAPE_DELAYS_S:
        late = delay_signal(ch.time, ch.velocity, delay, before=0.0)
        for threshold in np.percentile(speed, SHAPE_PERCENTILES):
            for s in (1.0, -1.0):
                rows.append(activation(s * np.maximum(s * late - threshold, 0.0), ch.fs, SHAPE_ACTIVATION_HZ))
    return filtered_torque(ch, np.vstack(rows))


def velocity_shape_miss(trial: Trial, filtered: Filtered, steps: ModelSteps, noise: NoiseLevels, *,
                        identified: bool, observable: np.ndarray) -> ShapeMiss | None:
    """:func:`velocity_shapes` of ``trial`` and its ``filtered`` signals fitted beside the Kalman
    model at ``steps`` and ``noise`` (:func:`~limbstiff.checks.shape.shape_miss`), with ÿ and ẏ
    when m and b are ``identified``; the analysis's and the diagnosis's one computation. None for
    the direct variant, too few steps, or a fit that cannot be made."""
    if filtered.variant != "external" or len(steps.index) < MIN_STEPS:
        return None
    nuisance = np.vstack([filtered.acceleration[steps.index], filtered.velocity[steps.index]]) if identified else None
    try:
        return shape_miss(steps, noise, velocity_shapes(trial, filtered)[:, steps.index], nuisance=nuisance,
                          informed=observable[steps.index], motion_frequency=filtered.motion_hz)
    except (np.linalg.LinAlgError, ValueError, FloatingPointError):
        return None             # a check that cannot be computed is skipped, the analysis kept


def rival_columns(miss: ShapeMiss | None) -> np.ndarray | None:
    """The torques the angle terms are fitted beside: :func:`velocity_shape_miss`'s when significant."""
    return miss.columns if miss is not None and miss.significant else None
