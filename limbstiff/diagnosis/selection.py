"""Which effects: greedy selection on held-out gains, significance, intervals, ambiguities.

Every candidate is fitted on training folds and scored held out (:mod:`.crossval`); its
*gain* in each scoring unit (one motion period) is the drop of the held-out squared residual
against the current model. Selection is greedy: the candidate with the largest held-out
shrinkage among those that are both

* **significant** — a one-sided sign-flip (randomisation) test of the mean unit gain: under
  the null hypothesis that the effect carries no information about held-out data, a unit gain
  is a symmetric term (the cross product of the held-out residual with a torque fitted
  elsewhere) minus a non-negative one (the fitted torque squared), so flipping signs at random
  can only make the observed sum look larger; Holm's correction over the candidates of a step
  keeps the family-wise error at :data:`ALPHA`; and
* **relevant** — it removes at least :data:`RELEVANCE` of the nominal model's held-out gap;

is added, the others are refitted on top of it, and the search stops when none qualifies. A
clean recording therefore gets an empty diagnosis. Each model compared has its own noise levels
(:mod:`.crossval`), so a unit's gain also holds the change of the filter's gains; the null
argument above holds for the effect's term, and measured on clean trials of an independent
simulator (four with a stiffness changing within the trial) the test stayed quiet on 11 of 12.
An effect fitted at the lower edge of its grid is named as the effect it becomes there
(:func:`_at_limit`). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import product

import numpy as np

from . import crossval
from ..effects.kinds import ModelEffect, Scales

#: Family-wise error rate of a selection step (Holm over the candidates).
ALPHA = 0.05
#: Smallest share of the nominal model's held-out gap an effect must remove to be named (at
#: any step of the selection: what it adds to the effects chosen before it). A term that removes
#: less than 5 % of the residual power is under a fifth (√0.05) of the residual's RMS — the
#: level of the structure the nominal model's own approximations leave on clean simulated
#: trials (filter edges, encoder quantisation, the window-wise linear spring: ≤ 1 % measured) —
#: and too small to change a physical conclusion; it is a statement of practical relevance,
#: not a statistical threshold.
RELEVANCE = 0.05
#: Random sign flips of the test (exact enumeration up to 2¹⁴ units).
PERMUTATIONS = 9999
#: Bootstrap resamples of the units for the intervals.
BOOTSTRAP = 2000
#: |correlation| of two fitted torques above which the data cannot tell them apart.
COLLINEAR = 0.9
#: Experiments that separate pairs that the data may not tell apart.
SEPARATE_BY = {
    frozenset({"time_delay", "inertia_error"}): "a trial with different excitation frequency content (a "
        "delay's torque grows with frequency like ω·f, an inertia error's like ω²), or adding a known mass",
    frozenset({"time_delay", "damping_error"}): "a trial at a different stiffness or excitation frequency (a "
        "delay looks like a damping error of −delay×stiffness, which changes with them), or timing both "
        "channels against a common reference signal",
    frozenset({"coulomb_friction", "backlash"}): "a slow ramp through reversals (backlash: a dead band where "
        "the torque changes while the angle stays; friction: a torque step at zero speed), or an encoder on "
        "the joint side of the transmission",
    frozenset({"coulomb_friction", "hysteresis"}): "small-amplitude oscillations below the characteristic "
        "angle (Dahl hysteresis then acts as a spring, Coulomb friction as a step)",
    frozenset({"hysteresis", "backlash"}): "a slow ramp through reversals with an encoder on the joint side",
    frozenset({"quadratic_damping", "damping_error"}): "trials at several perturbation speeds (a quadratic "
        "damping's apparent viscosity grows with speed)",
    frozenset({"coulomb_friction", "damping_error"}): "trials at several perturbation speeds (friction is "
        "independent of speed, viscous damping proportional to it)",
    frozenset({"reflex", "damping_error"}): "a trial with the reflex suppressed (muscle relaxed, or "
        "perturbations faster than the loop delay): a reflex lags by 20–80 ms, damping does not",
    frozenset({"reflex", "time_delay"}): "a trial with the muscle relaxed: a reflex disappears, a channel "
        "delay does not",
    frozenset({"inertia_error", "damping_error"}): "adding a known mass, or a trial with different frequency "
        "content",
}
GENERIC_SEPARATION = ("a trial with a different excitation (amplitude, speed, frequency content): the two "
                      "terms scale differently with it")


def sign_flip_pvalue(gains: np.ndarray, rng: np.random.Generator, *, alternative: str = "greater",
                     permutations: int = PERMUTATIONS) -> float:
    """Randomisation p-value of the sum of ``gains`` (one per unit) against random signs.

    Parameters
    ----------
    gains : ndarray, shape (U,)
    rng : numpy.random.Generator
    alternative : {"greater", "two-sided"}
    permutations : int
        Random draws when 2^U exceeds 2¹⁴ (otherwise every sign pattern is enumerated).

    Returns
    -------
    float
    """
    g = np.asarray(gains, float)
    g = g[g != 0]
    if g.size == 0:
        return 1.0
    stat = g.sum() if alternative == "greater" else abs(g.sum())
    if g.size <= 14:
        signs = np.array(list(product((1.0, -1.0), repeat=g.size)))
        null = signs @ g
        null = null if alternative == "greater" else np.abs(null)
        return float(np.mean(null >= stat - 1e-12 * np.abs(stat)))
    signs = rng.choice((-1.0, 1.0), size=(permutations, g.size))
    null = signs @ g
    null = null if alternative == "greater" else np.abs(null)
    return float((1 + np.sum(null >= stat - 1e-12 * np.abs(stat))) / (permutations + 1))


def holm(pvalues: dict) -> dict:
    """Holm-adjusted p-values (step-down, monotone), same keys."""
    names = sorted(pvalues, key=pvalues.get)
    m, out, running = len(names), {}, 0.0
    for i, name in enumerate(names):
        running = max(running, min(1.0, (m - i) * pvalues[name]))
        out[name] = running
    return out


def shrink_interval(reference: np.ndarray, candidate: np.ndarray, rng: np.random.Generator, *,
                    level: float, resamples: int = BOOTSTRAP) -> tuple[float, float]:
    """Percentile bootstrap interval of 1 − Σ candidate / Σ reference over resampled units."""
    u = len(reference)
    idx = rng.integers(0, u, size=(resamples, u))
    with np.errstate(divide="ignore", invalid="ignore"):
        values = 1.0 - candidate[idx].sum(1) / reference[idx].sum(1)
    values = values[np.isfinite(values)]
    lo, hi = np.quantile(values, [0.5 - level / 2, 0.5 + level / 2])
    return float(lo), float(hi)


@dataclass
class Scored:
    """One candidate at one selection step.

    ``shrink`` is the share of the current model's held-out gap it removes; ``share_of_nominal``
    the same gain as a share of the nominal model's held-out gap, which decides relevance (an
    effect is named for what it explains of the sim-to-real gap, not of what is left of it).
    """

    evaluation: crossval.Evaluation
    reference: np.ndarray          # the current model's held-out RSS per unit (same scheme)
    gains: np.ndarray
    shrink: float
    p_value: float
    share_of_nominal: float = 0.0
    p_adjusted: float = 1.0

    @property
    def significant(self) -> bool:
        return self.p_adjusted <= ALPHA

    @property
    def relevant(self) -> bool:
        return self.share_of_nominal >= RELEVANCE


@dataclass(frozen=True)
class Ambiguity:
    """Two qualifying effects the data cannot tell apart.

    Parameters
    ----------
    effects : tuple of str
        The chosen effect, then the other.
    correlation : float
        |r| of their fitted torques (dimensionless).
    p_difference : float
        Two-sided sign-flip p-value of the difference of their unit gains.
    reason : str
    separate_by : str
        The experiment that would tell them apart.
    """

    effects: tuple[str, str]
    correlation: float
    p_difference: float
    reason: str
    separate_by: str


@dataclass
class Selection:
    """Outcome of the greedy selection.

    Attributes
    ----------
    nominal : crossval.Evaluation
        The nominal model scored held out.
    first : dict of str to Scored
        Every candidate against the nominal model (step 1).
    steps : list of dict of str to Scored
        Every step's candidates against the model chosen so far.
    chosen : list of (ModelEffect, dict)
        The effects judged responsible, in order, with their shapes.
    final : crossval.Evaluation
        The model with every chosen effect.
    ambiguities : list of Ambiguity
    named_as : dict of str to str
        Effects fitted at the lower edge of their grid and named as the effect they become there
        (:func:`_at_limit`); they are not tried again.
    """

    nominal: crossval.Evaluation
    first: dict
    steps: list
    chosen: list
    final: crossval.Evaluation
    ambiguities: list = field(default_factory=list)
    named_as: dict = field(default_factory=dict)


def _score(problem, base, base_eval, effect: ModelEffect, rng, nominal_total: float) -> Scored:
    ev = crossval.evaluate(problem, base, effect, shapes=effect.grid(problem_scales(problem)))
    ref = base_eval.unit_rss
    gains = ref - ev.unit_rss
    total = float(ref.sum())
    shrink = float(gains.sum() / total) if total > 0 else 0.0
    share = float(gains.sum() / nominal_total) if nominal_total > 0 else 0.0
    return Scored(ev, ref, gains, shrink, sign_flip_pvalue(gains, rng), share)


def problem_scales(problem) -> Scales:
    """The scales of the problem's trials that set the effects' grids (cached on the problem)."""
    key = ("scales",)
    if key not in problem.cache:
        problem.cache[key] = Scales.of(problem.channels)
    return problem.cache[key]


def select(problem: crossval.Problem, effects: dict, *, rng: np.random.Generator) -> Selection:
    """Greedy selection of effects (see the module docstring).

    Parameters
    ----------
    problem : crossval.Problem
    effects : dict of str to ModelEffect
        The candidate library.
    rng : numpy.random.Generator
        Source of the sign flips.

    Returns
    -------
    Selection
    """
    base: list = []
    base_eval = nominal_eval = crossval.evaluate(problem, base)
    remaining = dict(effects)
    steps, first, named_as = [], None, {}
    while remaining:
        total = float(nominal_eval.unit_rss.sum())
        scored = {name: _score(problem, base, base_eval, eff, rng, total) for name, eff in remaining.items()}
        for name, p in holm({n: s.p_value for n, s in scored.items()}).items():
            scored[name].p_adjusted = p
        steps.append(scored)
        first = first or scored
        eligible = [n for n, s in scored.items() if s.significant and s.relevant]
        if not eligible:
            break
        top = max(eligible, key=lambda n: scored[n].shrink)
        best = _at_limit(top, scored, eligible, effects, problem)
        if best != top:
            remaining.pop(top)
            named_as[top] = best
        base = base + [(remaining.pop(best), scored[best].evaluation.shape)]
        base_eval = crossval.evaluate(problem, base)
    sel = Selection(nominal=nominal_eval, first=first or {}, steps=steps, chosen=base, final=base_eval,
                    named_as=named_as)
    sel.ambiguities = ambiguities(sel, rng)
    return sel


def _at_limit(best: str, scored: dict, eligible: list, effects: dict, problem) -> str:
    """The effect ``best`` becomes at the lower edge of its grid (:attr:`ModelEffect.lower_limit`),
    when it was fitted there and that effect qualifies too; otherwise ``best``.

    A Dahl loop whose characteristic angle is as narrow as the grid resolves is a friction whose
    presliding compliance shows (Dahl's model is one of friction; a LuGre friction's bristles fit
    as such a loop, measured: y_c at the grid's lowest value, amplitude within 5 % of the
    friction torque), so it is named friction — whose grid ends in the same loop, so the same
    torque enters the model; loops of simulated Dahl hysteresis fit at 3–6 times the lowest value.
    """
    limit = effects[best].lower_limit
    if limit is None or limit not in eligible:
        return best
    shape = scored[best].evaluation.shape
    grid = effects[best].grid(problem_scales(problem))
    return limit if shape and all(shape.get(k) == min(g[k] for g in grid) for k in shape) else best


def ambiguities(sel: Selection, rng: np.random.Generator) -> list[Ambiguity]:
    """Pairs the data cannot tell apart: for each chosen effect, the other qualifying candidates of
    its step whose fitted torque is nearly collinear with it (|r| ≥ :data:`COLLINEAR`) or whose
    unit gains do not differ significantly (two-sided sign-flip test at :data:`ALPHA`)."""
    out = []
    for (effect, _), scored in zip(sel.chosen, sel.steps):
        a = scored[effect.name]
        for name, b in scored.items():
            if name == effect.name or not (b.significant and b.relevant):
                continue
            fa, fb = a.evaluation.fitted, b.evaluation.fitted
            denom = np.sqrt(float(fa @ fa) * float(fb @ fb))
            corr = float(abs(fa @ fb) / denom) if denom > 0 else 0.0
            p_diff = sign_flip_pvalue(a.gains - b.gains, rng, alternative="two-sided")
            if corr >= COLLINEAR or p_diff > ALPHA:
                reason = []
                if corr >= COLLINEAR:
                    reason.append(f"their fitted torques are collinear (|r| = {corr:.2f})")
                if p_diff > ALPHA:
                    reason.append(f"their held-out gains do not differ significantly (p = {p_diff:.2g}; "
                                  f"shrink {a.shrink:.1%} against {b.shrink:.1%})")
                out.append(Ambiguity(effects=(effect.name, name), correlation=corr, p_difference=p_diff,
                                     reason="; ".join(reason),
                                     separate_by=SEPARATE_BY.get(frozenset({effect.name, name}), GENERIC_SEPARATION)))
    return out
