"""The library calls behind ``limbstiff diagnose``: trials in, :class:`Diagnosis` out.

:func:`diagnose` analyses each trial (the nominal model: m and b given or identified, the
stiffness course), fits and judges every candidate effect held out, selects the ones
responsible and measures how much each biases the stiffness. :func:`diagnose_files` reads the
trial files and writes ``diagnosis.json`` and ``diagnosis.pdf`` (:mod:`.from_files`).
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..blas_threads import one_blas_thread
from ..analysis import analyze
from ..settings import range_of_motion
from ..errors import TrialError
from ..protocol import MODEL_EFFECTS, Protocol
from ..trial import Trial
from . import crossval, nominal, residual, selection
from .bias import analysis_stiffness, stiffness_change
from ..effects.channels import channels_from
from ..effects.registry import CANDIDATES, EFFECTS
from ..effects.kinds import MechanicsOffset
from .per_trial import chosen_fits, disagreements, trial_selections
from .parts import (After, Evidence, HeldOut, Mechanics, NotTried, Settings, Step, StepScore, StiffnessBias,
                    StiffnessWalks, TrialInfo, TrialStiffness)
from .result import Candidate, Diagnosis

#: Held-out blocks of a single trial.
BLOCKS = 5


def candidate_library(channels, effects: dict | None = None) -> tuple[dict, list[str]]:
    """The effects to try on these trials, and notes on those left out.

    When m and b are identified they are fitted together with every effect, so an error of
    either is not a separate effect: ``inertia_error`` and ``damping_error`` are left out.
    """
    effects = dict(CANDIDATES if effects is None else effects)
    notes = []
    if any(c.identified for c in channels):
        dropped = [n for n, e in effects.items() if isinstance(e, MechanicsOffset)]
        effects = {n: e for n, e in effects.items() if n not in dropped}
        if dropped:
            notes.append("inertia and damping were identified from the trial(s) and are fitted together with every "
                         f"effect, so {' and '.join(dropped)} are not separate effects and were not tried; give the "
                         "values the set-up assumes (protocol [mechanics], --inertia/--damping) to test them")
    return effects, notes


@one_blas_thread
def diagnose(trials: Sequence[Trial], protocol: Protocol | None = None, *, seed: int = 0,
             inertia: float | None = None, damping: float | None = None, blocks: int = BLOCKS,
             effects: dict | None = None, results: Sequence | None = None) -> Diagnosis:
    """Diagnose the gap between the nominal model and one or several recordings.

    Parameters
    ----------
    trials : sequence of Trial
        Trials of one set-up: the effects' amplitudes are shared, each trial is cut into
        ``blocks`` contiguous held-out blocks. With several, each trial's own selection is made
        too (``Diagnosis.per_trial``, :mod:`.per_trial`) and a disagreement is a warning.
    protocol : Protocol, optional
    seed : int
        Seed of the analysis and of every random draw of the tests and intervals.
    inertia, damping : float, optional
        The nominal m (kg·m²) and b (N·m·s/rad) a lab assumes; otherwise they are identified
        (and fitted again together with each effect).
    blocks : int
    effects : dict of str to ModelEffect, optional
        The candidate library (default :data:`candidates.CANDIDATES`).
    results : sequence of StiffnessResult, optional
        The trials' analyses with ``protocol`` (and the overrides), when already done, without
        effects in the model (the protocol's ``effects`` are not the nominal model's).

    Returns
    -------
    Diagnosis

    Raises
    ------
    TrialError
        A trial that cannot be analysed or is too short to diagnose.
    """
    # the nominal model holds no effect: those the protocol puts in the model are candidates like any other
    protocol = (protocol or Protocol()).override(inertia=inertia, damping=damping, effects=())
    originals, trials, results, channels = _analysed(trials, protocol, seed, results)
    effects, library_notes = candidate_library(channels, effects)
    problem = _problem(channels, blocks)
    rng = np.random.default_rng(seed)
    run = _Run(trials, results, channels, protocol, seed, problem, selection.select(problem, effects, rng=rng),
               originals)
    candidates = sorted((_candidate(run, name, scored, effects[name], rng) for name, scored in run.sel.first.items()),
                        key=lambda c: -c.shrink_heldout)
    candidates += _untried(run, {c.effect for c in candidates})
    after = _after(run, rng)
    series = residual.series(problem, run.sel.nominal, run.sel.final if run.chosen else None)
    trials_info = _trials_info(run)
    alone = trial_selections(trials, channels, effects, pooled=tuple(run.chosen), seed=seed, blocks=blocks,
                             cache=problem.cache)
    return Diagnosis(trials=tuple(trials_info), metric=nominal.METRIC,
                     gap_train=float(run.sel.nominal.rss_train) / run.den, gap_heldout=run.nominal_heldout / run.den,
                     noise_floor=_noise_floor(problem, trials_info), heldout=_heldout(problem),
                     where={n: s.where for n, s in series.items()}, candidates=tuple(candidates),
                     diagnosis=tuple(run.chosen), steps=tuple(_steps(run)), ambiguities=tuple(run.sel.ambiguities),
                     after=after, settings=_settings(protocol.ci_level), notes=tuple(library_notes + _notes(run)),
                     warnings=tuple(w for r in results for w in r.warnings), seed=seed, series=series,
                     per_trial=alone, disagreements=disagreements(tuple(run.chosen), alone),
                     stiffness=_stiffness_with_effects(run))


def _analysed(trials: Sequence[Trial], protocol: Protocol, seed: int, results: Sequence | None
              ) -> tuple[list, list, list, list]:
    """The trials given, those their analyses ran on, the analyses (made when not given) and each
    trial's channels. An ensemble's analysis runs on its whole cycles less their ensemble mean, the
    curve's torque taken off: the gap diagnosed is the one its model leaves (``result.trial``)."""
    originals = list(trials)
    results = list(results) if results is not None else [analyze(t, protocol, seed=seed) for t in originals]
    trials = [r.trial if r.curve is not None else t for t, r in zip(originals, results)]
    return originals, trials, results, [channels_from(t, r) for t, r in zip(trials, results)]


def _problem(channels: list, blocks: int) -> crossval.Problem:
    """The held-out problem of the pooled trials (:func:`crossval.build_problem`); a trial too short
    for it is a :class:`TrialError` naming it."""
    try:
        return crossval.build_problem(channels, blocks=blocks)
    except ValueError as exc:
        raise TrialError(str(exc).split(":")[0], str(exc).split(":", 1)[1].strip()) from None


def _noise_floor(problem: crossval.Problem, trials_info: list[TrialInfo]) -> float:
    """The gap white sensor noise alone would leave, over the pooled trials: each trial's floor
    weighted by its share of Σ (f − f̄)²."""
    return float(np.average([t.noise_floor for t in trials_info],
                            weights=[np.sum(problem.deviation[problem.trial == i] ** 2)
                                     for i in range(len(trials_info))]))


@dataclass(frozen=True)
class _Run:
    """What the steps of :func:`diagnose` share: the trials, their analyses and channels, the
    protocol and seed of the re-analyses, the held-out problem and the selection made on it.
    ``trials`` are those the analyses ran on (an ensemble's whole cycles less their mean);
    ``originals`` those given, which a re-analysis starts from."""

    trials: list
    results: list
    channels: list
    protocol: Protocol
    seed: int
    problem: crossval.Problem
    sel: selection.Selection
    originals: list

    @property
    def den(self) -> float:
        """Σ (f − f̄)² over the scored steps, the gap's denominator (N·m²)."""
        return float(np.sum(self.problem.deviation ** 2))

    @property
    def nominal_heldout(self) -> float:
        """The nominal model's held-out sum of squared prediction errors (N·m²)."""
        return float(self.sel.nominal.unit_rss.sum())

    @property
    def chosen(self) -> list[str]:
        """Names of the chosen effects, in the order they were added."""
        return [e.name for e, _ in self.sel.chosen]

    @property
    def mech(self) -> Mechanics:
        """The nominal m and b (medians over the trials), for the effects' parameters."""
        return Mechanics(inertia=float(np.median([c.inertia for c in self.channels])),
                         damping=float(np.median([c.damping for c in self.channels])))

    def fitted_mechanics(self, mechanics) -> dict[str, Mechanics] | None:
        """By trial name, the (m, b) of each trial fitted with effects (None: none fitted)."""
        if mechanics is None:
            return None
        return {ch.name: Mechanics(inertia=m[0], damping=m[1]) for ch, m in zip(self.channels, mechanics)}

    @property
    def nominal_stiffness(self) -> list[float]:
        """Each trial's median stiffness as its analysis reports it: the nominal model's is the
        analysis's (same filter, corner, coupling, m, b and noise levels)."""
        return [r.informed_stiffness()[0].median for r in self.results]

    @functools.cached_property
    def baseline(self) -> list[float]:
        """Each trial's :func:`analysis_stiffness` as recorded: what a corrected trial's is compared
        with (the nominal one but for an ensemble's curve)."""
        return [analysis_stiffness(t, r, c, self.protocol) for t, r, c in zip(self.trials, self.results, self.channels)]

    def stiffness_change(self, fitted: list, mechanics=None) -> StiffnessBias:
        """:func:`stiffness_change` of the same fitted effects removed from every trial."""
        return stiffness_change(self.trials, self.results, self.channels, self.protocol, [fitted] * len(self.trials),
                                nominal_stiffness=self.nominal_stiffness, baseline=self.baseline,
                                mechanics=mechanics, nominal_mechanics=self.sel.nominal.mechanics)


def _stiffness_with_effects(run: _Run) -> tuple[TrialStiffness, ...]:
    """Per trial, the stiffness ``summary.csv`` reports and the analysis's with the chosen effects
    that can be put in the model (:data:`~limbstiff.protocol.MODEL_EFFECTS`) in it."""
    in_model = tuple(n for n in run.chosen if n in MODEL_EFFECTS)
    left = [n for n in run.chosen if n not in MODEL_EFFECTS]
    note = (f"{' and '.join(left)} cannot be put in the analysis's model (a corrected channel or an offset of m "
            "or b): its corrected median, without an interval, is after.stiffness_bias") if left else None
    out = []
    for trial, result in zip(run.originals, run.results):
        reported = result.informed_stiffness()[0]
        row = TrialStiffness(trial=trial.name, reported=reported, verdict=result.verdict, effects=in_model,
                             with_effects=None, verdict_with_effects=None,
                             note=note or (None if run.chosen else "no effect chosen"))
        if in_model:
            try:
                corrected = analyze(trial, run.protocol, seed=run.seed, effects=in_model)
            except Exception as exc:        # noqa: BLE001 — one trial's re-analysis must not lose the diagnosis
                row = dataclasses.replace(row, note=f"the analysis with {', '.join(in_model)} in the model failed: "
                                                    f"{exc}")
            else:
                row = dataclasses.replace(row, with_effects=corrected.informed_stiffness()[0],
                                          verdict_with_effects=corrected.verdict, inertia_with_effects=corrected.inertia,
                                          damping_with_effects=corrected.damping)
        out.append(row)
    return tuple(out)


#: The effect names of the interface (docs/interface.md section 5) and why one is not tried as a term.
NOT_TRIED = {
    **{name: e.held_by_nominal for name, e in EFFECTS.items() if e.model is None},
    "inertia_error": "m and b were identified and are fitted together with every effect",
    "damping_error": "m and b were identified and are fitted together with every effect",
}


def _untried(run: _Run, tried: set) -> list[Candidate]:
    """An entry for each effect name of the interface that was not tried, saying why (its gaps
    are the nominal model's, its shrink 0)."""
    train, held = float(run.sel.nominal.rss_train) / run.den, run.nominal_heldout / run.den
    identified = any(c.identified for c in run.channels)
    out = []
    for name, why in NOT_TRIED.items():
        if name in tried:
            continue
        if name in ("inertia_error", "damping_error") and not identified:
            why = "not in the candidate library given"
        out.append(Candidate(effect=name, description="not tried: " + why, params={}, units={}, gap_train=train,
                             gap_heldout=held, shrink_heldout=0.0, shrink_interval=(0.0, 0.0),
                             evidence=NotTried(reason=why)))
    return out


def _walks(ev) -> list[float]:
    """The stiffness walk of a model, both kinds together (Q_σ + Q_c), per trial ((N·m/rad)²/s)."""
    return [float(n.stiffness_walk + n.coupled_walk) for n in ev.noise]


def _candidate(run: _Run, name: str, scored, eff, rng: np.random.Generator) -> Candidate:
    """One candidate effect as fitted and scored against the nominal model (step 1).

    ``scored``: its :class:`selection.Scored`; ``eff``: the effect; ``rng`` draws its interval.
    """
    ev = scored.evaluation
    params = eff.params(ev.shape, ev.coef, run.mech)
    bias = run.stiffness_change([(eff, ev.shape, ev.coef)], ev.mechanics)
    return Candidate(
        effect=name, description=eff.description, params=params, units=eff.units_of(params),
        gap_train=ev.rss_train / run.den, gap_heldout=float(ev.unit_rss.sum()) / run.den,
        shrink_heldout=scored.shrink,
        shrink_interval=selection.shrink_interval(scored.reference, ev.unit_rss, rng, level=run.protocol.ci_level),
        evidence=_evidence(run, name, scored, eff), stiffness_bias=bias, mechanics=run.fitted_mechanics(ev.mechanics))


def _evidence(run: _Run, name: str, scored, eff) -> Evidence:
    """How a candidate was judged: test, step, shapes per fold, noise levels, grid."""
    ev, chosen = scored.evaluation, run.chosen
    later = [s[name] for s in run.sel.steps[1:] if name in s]
    shaped = eff.grid(selection.problem_scales(run.problem)) != [{}]
    return Evidence(
        identifiable_share=ev.share, p_value=scored.p_value, p_adjusted=scored.p_adjusted,
        significant=scored.significant, relevant=scored.relevant, share_of_nominal_gap=scored.share_of_nominal,
        units=int(len(scored.gains)), units_improved=float(np.mean(scored.gains > 0)),
        fold_params=tuple(eff.params(s, np.zeros(len(ev.coef)), None) for s in ev.fold_shapes
                          if s is not None) if shaped else None,
        stiffness_walk=StiffnessWalks(nominal=tuple(_walks(run.sel.nominal)), with_effect=tuple(_walks(ev))),
        chosen=name in chosen, step=chosen.index(name) + 1 if name in chosen else None,
        shrink_after_chosen=later[-1].shrink if later and name not in chosen else None, grid=eff.grid_reason)


def _after(run: _Run, rng: np.random.Generator) -> After:
    """The model with every chosen effect: its gap, shrinkage, parameters and stiffness bias."""
    final, nominal_held, den = run.sel.final, run.nominal_heldout, run.den
    fitted = chosen_fits(run.sel)
    params = {eff.name: eff.params(shape, coef, run.mech) for eff, shape, coef in fitted}
    return After(
        effects=tuple(run.chosen), gap_train=final.rss_train / den, gap_heldout=float(final.unit_rss.sum()) / den,
        shrink_heldout=1.0 - float(final.unit_rss.sum()) / nominal_held if nominal_held > 0 else None,
        shrink_heldout_interval=tuple(selection.shrink_interval(run.sel.nominal.unit_rss, final.unit_rss, rng,
                                                                level=run.protocol.ci_level)),
        params=params, units={eff.name: eff.units_of(params[eff.name]) for eff, _, _ in fitted},
        stiffness_walk=tuple(_walks(final)), mechanics=run.fitted_mechanics(final.mechanics),
        stiffness_bias=run.stiffness_change(fitted, final.mechanics) if fitted else None)


def _trials_info(run: _Run) -> list[TrialInfo]:
    """One summary per trial: source, sampling, nominal model, layout, stiffness, noise floor, gap."""
    problem, out = run.problem, []
    for i, (t, r, ch, lay) in enumerate(zip(run.trials, run.results, run.channels, problem.layouts)):
        sl = problem.trial_rows(i)
        out.append(TrialInfo(
            trial=t.name, source=t.source, source_sha256=t.source_sha256, fs_hz=t.fs, duration_s=t.duration,
            variant=r.variant, inertia=ch.inertia, damping=ch.damping, mechanics=ch.mechanics,
            cutoff_hz=ch.cutoff_hz, motion_hz=ch.motion_hz, steps=int(lay.scored.sum()), step_s=lay.step_s,
            units=lay.n_units, stiffness_median=r.informed_stiffness()[0].median,
            noise_levels=run.sel.nominal.noise[i], noise_floor=nominal.noise_floor(ch, lay),
            gap_train=float(np.sum(run.sel.nominal.residual[sl] ** 2) / np.sum(problem.deviation[sl] ** 2))))
    return out


def _steps(run: _Run) -> list[Step]:
    """Every selection step: the effect added and every candidate's score and test."""
    chosen = run.chosen
    return [Step(step=i + 1, added=chosen[i] if i < len(chosen) else None,
                 candidates={n: StepScore(shrink_heldout=s.shrink, share_of_nominal_gap=s.share_of_nominal,
                                          p_value=s.p_value, p_adjusted=s.p_adjusted, significant=s.significant,
                                          relevant=s.relevant) for n, s in step.items()})
            for i, step in enumerate(run.sel.steps)]


def _heldout(problem: crossval.Problem) -> HeldOut:
    """The held-out scheme: folds, guard (s), units, unit length and step (s)."""
    return HeldOut(scheme=f"{problem.n_folds} contiguous blocks per trial", folds=problem.n_folds,
                   guard_s=problem.guard_s, units=problem.n_units, unit_s=tuple(lay.unit_s for lay in problem.layouts),
                   step_s=tuple(lay.step_s for lay in problem.layouts))


def _settings(level: float) -> Settings:
    """The settings of the selection, the nominal model and the test (confidence ``level``)."""
    return Settings(
        alpha=selection.ALPHA, relevance=selection.RELEVANCE, permutations=selection.PERMUTATIONS,
        bootstrap=selection.BOOTSTRAP, collinear=selection.COLLINEAR, ci_level=level,
        model="the analysis's Kalman model (stiffness a random walk) with the effects as measurement terms; noise "
              "levels refitted per model by maximum marginal likelihood",
        settling_periods=nominal.SETTLING_PERIODS,
        test="one-sided sign-flip test of the summed held-out gains over units, Holm-corrected over the candidates "
             "of each step",
        relevance_reason="an effect must remove at least this share of the nominal model's held-out gap, at the "
                         "step it is added (see limbstiff.diagnosis.selection.RELEVANCE)")


def _notes(run: _Run) -> list[str]:
    """What the diagnosis says besides its findings: an effect renamed at its grid's limit, and why
    gravity and sensor drift are held by the nominal model."""
    renamed = [f"{orig} was fitted at the narrowest loop its grid allows and is named {name}: a friction whose "
               "presliding compliance shows (see selection._at_limit); not tried again"
               for orig, name in run.sel.named_as.items()]
    rom = max(range_of_motion(c.angle) for c in run.channels)
    half = 0.5 * rom
    curv = abs(1.0 - np.sin(half) / half) if half > 0 else 0.0
    return renamed + [f"gravity: over the range of motion (±{half:.3g} rad) sin(y) departs from a straight line by "
            f"{100 * curv:.2g} % at most; a torque that depends on the angle alone is a stiffness (the paper's "
            "generalized stiffness includes −mgl·cos θ) and the time-varying stiffness takes it up, so gravity can "
            "hardly be told from stiffness in these data; separate them by repeating the trial at another operating "
            "angle (gravity changes the stiffness by mgl·cos θ) or with the segment's weight supported",
            "sensor drift: a slow drift of the torque offset is a walk of the elastic torque, which the model holds "
            "(its torque walk Q_s), so it is not a separate effect; separate them with zero-load recordings before "
            "and after the trial"]
