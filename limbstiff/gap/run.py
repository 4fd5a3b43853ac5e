"""The library calls behind ``limbstiff diagnose``: trials in, :class:`Diagnosis` out.

:func:`diagnose` analyses each trial (the nominal model: m and b given or identified, the
stiffness course), fits and judges every candidate effect held out, selects the ones
responsible and measures how much each biases the stiffness. :func:`diagnose_files` reads the
trial files and writes ``diagnosis.json`` and ``diagnosis.pdf``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Sequence

import numpy as np

from ..analysis import analyze, range_of_motion
from ..errors import LimbstiffError, TrialError
from ..protocol import Protocol
from ..trial import Trial
from . import crossval, nominal, residual, selection
from .channels import Channels, channels_from
from .effects import EFFECTS
from .kinds import remove
from .result import Candidate, Diagnosis

#: Held-out blocks of a single trial.
BLOCKS = 5


def _median_stiffness(result) -> float:
    """Median estimated stiffness over the observable samples (all when none is), N·m/rad."""
    return result.informed_stiffness()[0].median


def _corrected_trial(trial: Trial, ch: Channels, corr) -> Trial:
    """The trial with the recorded channels of a :class:`~.kinds.Correction` put in."""
    changes = {}
    if corr.angle is not None:
        changes["angle"] = corr.angle
    if corr.torque is not None:
        changes["torque" if trial.torque is not None and ch.mechanics != "none" else "elastic_torque"] = corr.torque
    return dataclasses.replace(trial, **changes) if changes else trial


def stiffness_change(trials, results, channels, protocol: Protocol, fitted_per_trial, seed: int) -> dict:
    """Median stiffness of each trial with the fitted effects removed, against the nominal one.

    The trial is re-analysed with the effect's torque taken off the recorded torque (or its
    recorded channel corrected, or m and b corrected), m and b fixed to the nominal values (so
    that only the effect changes), the same low-pass corner and seed.

    Returns
    -------
    dict
        ``per_trial`` {name: {nominal, corrected, relative}} with relative = nominal/corrected − 1
        (the bias the effect puts on the nominal estimate) and ``median_relative``.
    """
    per = {}
    for trial, res, ch, fitted in zip(trials, results, channels, fitted_per_trial):
        corr = remove(ch, fitted)
        try:
            proto = protocol.override(bandwidth_hz=ch.cutoff_hz)
            if ch.mechanics != "none":
                if not (corr.inertia > 0 and corr.damping > 0):
                    raise LimbstiffError(f"the corrected inertia ({corr.inertia:.3g}) or damping ({corr.damping:.3g}) "
                                         "is not positive")
                proto = proto.override(inertia=corr.inertia, damping=corr.damping)
            again = analyze(_corrected_trial(trial, ch, corr), proto, seed=seed)
        except LimbstiffError as exc:
            per[trial.name] = {"nominal": _median_stiffness(res), "corrected": None, "relative": None,
                               "error": str(exc)}
            continue
        nom, new = _median_stiffness(res), _median_stiffness(again)
        per[trial.name] = {"nominal": nom, "corrected": new, "relative": nom / new - 1.0 if new else None}
    rel = [v["relative"] for v in per.values() if v["relative"] is not None]
    return {"per_trial": per, "median_relative": float(np.median(rel)) if rel else None}


def diagnose(trials: Sequence[Trial], protocol: Protocol | None = None, *, seed: int = 0,
             inertia: float | None = None, damping: float | None = None, blocks: int = BLOCKS,
             effects: dict | None = None, results: Sequence | None = None) -> Diagnosis:
    """Diagnose the gap between the nominal model and one or several recordings.

    Parameters
    ----------
    trials : sequence of Trial
        Several trials of one set-up are scored leave-one-trial-out; one trial on ``blocks``
        contiguous held-out blocks.
    protocol : Protocol, optional
    seed : int
        Seed of the analysis and of every random draw of the tests and intervals.
    inertia, damping : float, optional
        The nominal m (kg·m²) and b (N·m·s/rad) a lab assumes; otherwise those identified.
    blocks : int
    effects : dict of str to Effect, optional
        The candidate library (default :data:`effects.EFFECTS`).
    results : sequence of StiffnessResult, optional
        The trials' analyses with ``protocol`` (and the overrides), when already done.

    Returns
    -------
    Diagnosis

    Raises
    ------
    TrialError
        A trial that cannot be analysed or is too short to diagnose.
    """
    protocol = (protocol or Protocol()).override(inertia=inertia, damping=damping)
    effects = dict(EFFECTS if effects is None else effects)
    trials = list(trials)
    results = list(results) if results is not None else [analyze(t, protocol, seed=seed) for t in trials]
    channels = [channels_from(t, r) for t, r in zip(trials, results)]
    try:
        problem = crossval.build_problem(channels, blocks=blocks)
    except ValueError as exc:
        raise TrialError(str(exc).split(":")[0], str(exc).split(":", 1)[1].strip()) from None
    rng = np.random.default_rng(seed)
    run = _Run(trials, results, channels, protocol, seed, problem, selection.select(problem, effects, rng=rng))
    candidates = sorted((_candidate(run, name, scored, effects[name], rng) for name, scored in run.sel.first.items()),
                        key=lambda c: -c.shrink_heldout)
    after = _after(run, rng)
    where_out, series = residual.series(channels, problem.layouts, run.sel.chosen, run.sel.final.base_coef)
    trials_info = _trials_info(run)
    floor = float(np.average([t["noise_floor"] for t in trials_info],
                             weights=[np.sum(problem.deviation[problem.trial == i] ** 2) for i in range(len(trials))]))
    notes = _notes(channels, problem, run.chosen)
    notes.insert(0, "gap: the nominal model fits nothing of its own but the elastic terms, which are refitted on "
                    "whatever is scored, so its held-out gap equals its in-sample gap"
                 + ("; its m and b were identified from these same data" if any(c.mechanics == "identified"
                                                                              for c in channels) else ""))
    return Diagnosis(trials=tuple(trials_info), metric=nominal.METRIC, gap_train=float(run.sel.nominal.rss_train) / run.den,
                     gap_heldout=run.nominal_heldout / run.den, noise_floor=floor, heldout=_heldout(problem),
                     where=where_out, candidates=tuple(candidates), diagnosis=tuple(run.chosen),
                     steps=tuple(_steps(run)), ambiguities=tuple(run.sel.ambiguities), after=after,
                     settings=_settings(protocol.ci_level), notes=tuple(notes),
                     warnings=tuple(w for r in results for w in r.warnings), seed=seed, series=series)


@dataclass(frozen=True)
class _Run:
    """What the steps of :func:`diagnose` share: the trials, their analyses and channels, the
    protocol and seed of the re-analyses, the held-out problem and the selection made on it."""

    trials: list
    results: list
    channels: list
    protocol: Protocol
    seed: int
    problem: crossval.Problem
    sel: selection.Selection

    @property
    def den(self) -> float:
        """Σ (f − f̄)² over the rows, the gap's denominator (N·m²)."""
        return float(np.sum(self.problem.deviation ** 2))

    @property
    def nominal_heldout(self) -> float:
        """The nominal model's held-out RSS (N·m²)."""
        return float(self.sel.nominal.unit_rss.sum())

    @property
    def chosen(self) -> list[str]:
        """Names of the chosen effects, in the order they were added."""
        return [e.name for e, _ in self.sel.chosen]

    @property
    def mech(self) -> SimpleNamespace:
        """The nominal m and b (medians over the trials), for the effects' parameters."""
        return SimpleNamespace(inertia=float(np.median([c.inertia for c in self.channels])),
                               damping=float(np.median([c.damping for c in self.channels])))

    def stiffness_change(self, fitted: list) -> dict:
        """:func:`stiffness_change` of the same fitted effects removed from every trial."""
        return stiffness_change(self.trials, self.results, self.channels, self.protocol,
                                [fitted] * len(self.trials), self.seed)


def _candidate(run: _Run, name: str, scored, eff, rng: np.random.Generator) -> Candidate:
    """One candidate effect as fitted and scored against the nominal model (step 1).

    ``scored``: its :class:`selection.Scored`; ``eff``: the effect; ``rng`` draws its interval.
    """
    ev = scored.evaluation
    params = eff.params(ev.shape, ev.coef, run.mech)
    if eff.local:
        params["rms"] = float(np.sqrt(np.mean(ev.fitted ** 2)))
    evidence = _evidence(run, name, scored, eff)
    bias = run.stiffness_change([(eff, ev.shape, ev.coef)])
    return Candidate(
        effect=name, description=eff.description, params=params, gap_train=ev.rss_train / run.den,
        gap_heldout=float(ev.unit_rss.sum()) / run.den, shrink_heldout=scored.shrink,
        shrink_interval=selection.shrink_interval(scored.reference, ev.unit_rss, rng, level=run.protocol.ci_level),
        evidence=evidence, stiffness_bias=bias)


def _evidence(run: _Run, name: str, scored, eff) -> dict:
    """How a candidate was judged: test, scheme, step, shapes per fold, grid, notes."""
    ev, chosen = scored.evaluation, run.chosen
    later = [s[name] for s in run.sel.steps[1:] if name in s]
    shaped = eff.grid(selection.problem_scales(run.problem)) != [{}]
    evidence = {"absorbed": ev.absorbed, "identifiable_share": ev.share,
                "p_value": scored.p_value, "p_adjusted": scored.p_adjusted, "significant": scored.significant,
                "relevant": scored.relevant, "units": int(len(scored.gains)),
                "units_improved": float(np.mean(scored.gains > 0)), "scheme": ev.scheme,
                "fold_params": [eff.params(s, np.zeros(len(ev.coef)), None) for s in ev.fold_shapes
                                if s is not None] if shaped else None,
                "chosen": name in chosen, "step": chosen.index(name) + 1 if name in chosen else None,
                "shrink_after_chosen": later[-1].shrink if later and name not in chosen else None,
                "grid": eff.grid_reason}
    if ev.absorbed:
        evidence["note"] = (f"absorbed: at most {100 * (ev.share or 0):.2g} % of its torque lies outside what the "
                            "elastic term (a cubic spring per window) takes up, so it cannot be told from a "
                            "stiffness in these data and is not fitted")
    if ev.scheme == "interleaved":
        evidence["note"] = ("no parameter carries over to other data: scored by predicting every fifth "
                            "motion period from the rest of the same recording, the nominal model alike")
    return evidence


def _chosen_fits(sel: selection.Selection) -> list:
    """The chosen effects as (Effect, shape, amplitudes) of the model with all of them.

    The final model's amplitude vector holds each effect's amplitudes in the order chosen; a
    local effect is refitted as nuisance in that model, so its fit when it was chosen is taken.
    """
    fitted, k = [], 0
    for step, (eff, shape) in enumerate(sel.chosen):
        if eff.local:
            coef = sel.steps[step][eff.name].evaluation.coef
        else:
            coef = sel.final.base_coef[k:k + len(eff.amplitudes)]
            k += len(eff.amplitudes)
        fitted.append((eff, shape, coef))
    return fitted


def _after(run: _Run, rng: np.random.Generator) -> dict:
    """The model with every chosen effect: its gap, shrinkage, parameters and stiffness bias."""
    final, nominal_held, den = run.sel.final, run.nominal_heldout, run.den
    fitted = _chosen_fits(run.sel)
    after = {"effects": run.chosen, "gap_train": final.rss_train / den,
             "gap_heldout": float(final.unit_rss.sum()) / den,
             "shrink_heldout": 1.0 - float(final.unit_rss.sum()) / nominal_held if nominal_held > 0 else None,
             "shrink_heldout_interval": list(selection.shrink_interval(run.sel.nominal.unit_rss, final.unit_rss, rng,
                                                                    level=run.protocol.ci_level)),
             "params": {eff.name: eff.params(shape, coef, run.mech) for eff, shape, coef in fitted}}
    if any(e.local for e, _ in run.sel.chosen):
        after["note"] = ("sensor drift, once chosen, is refitted on every scored block like the elastic terms; "
                         "the held-out gap above scores the other effects only")
    after["stiffness_bias"] = run.stiffness_change(fitted) if fitted else None
    return after


def _trials_info(run: _Run) -> list[dict]:
    """One summary per trial: source, sampling, nominal model, layout, stiffness, noise floor, gap."""
    problem, out = run.problem, []
    for i, (t, r, ch, lay) in enumerate(zip(run.trials, run.results, run.channels, problem.layouts)):
        sel_i = problem.trial == i
        out.append({"trial": t.name, "source": t.source, "source_sha256": t.source_sha256,
                    "fs_hz": t.fs, "duration_s": t.duration, "variant": r.variant,
                    "inertia": ch.inertia, "damping": ch.damping, "mechanics": ch.mechanics,
                    "cutoff_hz": ch.cutoff_hz, "motion_hz": ch.motion_hz, "rows": int(len(lay.rows)),
                    "decimation": lay.decimation, "windows": int(lay.window.max()) + 1,
                    "stiffness_median": _median_stiffness(r),
                    "noise_floor": nominal.noise_floor(ch, lay),
                    "gap_train": float(np.sum(run.sel.nominal.residual[sel_i] ** 2)
                                       / np.sum(problem.deviation[sel_i] ** 2))})
    return out


def _steps(run: _Run) -> list[dict]:
    """Every selection step: the effect added and every candidate's score and test."""
    chosen = run.chosen
    return [{"step": i + 1, "added": chosen[i] if i < len(chosen) else None,
             "candidates": {n: {"shrink_heldout": s.shrink, "share_of_nominal_gap": s.share_of_nominal,
                                "p_value": s.p_value, "p_adjusted": s.p_adjusted,
                                "significant": s.significant, "relevant": s.relevant}
                            for n, s in step.items()}} for i, step in enumerate(run.sel.steps)]


def _heldout(problem: crossval.Problem) -> dict:
    """The held-out scheme: folds, guard (s), units, unit and window lengths (s)."""
    return {"scheme": "leave-one-trial-out" if problem.scheme == "trials" else f"{problem.n_folds} contiguous blocks",
            "folds": problem.n_folds, "guard_s": problem.guard_s if problem.scheme == "blocks" else 0.0,
            "units": problem.n_units, "unit_s": [lay.unit_s for lay in problem.layouts],
            "window_s": [lay.window_s for lay in problem.layouts]}


def _settings(level: float) -> dict:
    """The settings of the selection, the nominal model and the test (confidence ``level``)."""
    return {"alpha": selection.ALPHA, "relevance": selection.RELEVANCE, "permutations": selection.PERMUTATIONS,
            "bootstrap": selection.BOOTSTRAP, "collinear": selection.COLLINEAR, "ci_level": level,
            "window_periods": nominal.WINDOW_PERIODS, "units_per_window": nominal.UNITS_PER_WINDOW,
            "nuisance": list(nominal.NUISANCE), "test": "one-sided sign-flip test of the summed held-out gains "
            "over units, Holm-corrected over the candidates of each step",
            "relevance_reason": "an effect must remove at least this share of the nominal model's held-out "
                                "gap, at the step it is added (see limbstiff.gap.selection.RELEVANCE)"}


def _notes(channels, problem, chosen) -> list[str]:
    notes = []
    if any(c.mechanics == "identified" for c in channels):
        notes.append("inertia and damping were identified from the trial(s): inertia_error and damping_error are "
                     "relative to the identified values, which absorb any such error; give the values the set-up "
                     "assumes (protocol [mechanics], --inertia/--damping) to test them")
    rom = max(range_of_motion(c.angle) for c in channels)
    half = 0.5 * rom
    curv = abs(1.0 - np.sin(half) / half) if half > 0 else 0.0
    notes.append(f"gravity: over the range of motion (±{half:.3g} rad) sin(y) departs from a straight line by "
                 f"{100 * curv:.2g} % at most; a torque that depends on the angle alone is a stiffness (the paper's "
                 "generalized stiffness includes −mgl·cos θ) and the elastic term absorbs it, so gravity cannot be told "
                 "from stiffness in these data; separate them by repeating the trial at another operating angle "
                 "(gravity changes the stiffness by mgl·cos θ) or with the segment's weight supported")
    notes.append(f"sensor drift slower than the elastic windows ({problem.layouts[0].window_s:.2g} s) is "
                 "indistinguishable from a slow change of the elastic equilibrium (tonic torque), which the model "
                 "allows; separate them with zero-load recordings before and after the trial")
    return notes


@dataclass(frozen=True)
class DiagnoseReport:
    """Outcome of :func:`diagnose_files`.

    Parameters
    ----------
    diagnosis : Diagnosis or None
        None when no trial could be diagnosed.
    out : Path
    failed : tuple of str
        One line per trial that could not be read or analysed.
    files : tuple of str
        Files written.
    """

    diagnosis: Diagnosis | None
    out: Path
    failed: tuple = ()
    files: tuple = ()

    @property
    def exit_status(self) -> int:
        """0 when every trial is done, 1 when some (or all) failed (INTERFACE.md section 2)."""
        return 1 if self.failed or self.diagnosis is None else 0


def diagnose_files(paths: Sequence[str], *, protocol: Protocol | None = None, out: str | Path = "limbstiff-diagnose",
                   seed: int = 0, inertia: float | None = None, damping: float | None = None,
                   progress=None) -> DiagnoseReport:
    """Read the trials named by ``paths``, diagnose them together, write the outputs.

    Writes ``OUT/diagnosis.json`` and ``OUT/diagnosis.pdf`` (INTERFACE.md section 5), atomically.
    A trial that cannot be read or analysed is left out with a one-line reason (``failed``);
    the others are still diagnosed.

    Raises
    ------
    batch.NothingToDo
        When no trial file is found.
    """
    from ..batch.discovery import discover, output_names
    from ..files import read_trial
    from ..files.outputs import write_json

    protocol = (protocol or Protocol()).override(inertia=inertia, damping=damping)
    files = discover(paths)
    names, _ = output_names(files)
    trials, results, failed = [], [], []
    for path, name in zip(files, names):
        error = None
        try:
            trial = read_trial(path, protocol, name=name)
            results.append(analyze(trial, protocol, seed=seed))
            trials.append(trial)
        except LimbstiffError as exc:
            error = " ".join(str(exc).split())
            failed.append(error)
        if progress:
            progress(name, error)
    out = Path(out)
    if not trials:
        return DiagnoseReport(None, out, tuple(failed))
    try:
        diag = diagnose(trials, protocol, seed=seed, results=results)
    except LimbstiffError as exc:
        return DiagnoseReport(None, out, tuple(failed) + (" ".join(str(exc).split()),))
    out.mkdir(parents=True, exist_ok=True)
    data = diag.to_dict()
    data["failed"] = list(failed)
    write_json(out / "diagnosis.json", data)
    diag.plot(out / "diagnosis.pdf")
    return DiagnoseReport(diag, out, tuple(failed), (str(out / "diagnosis.json"), str(out / "diagnosis.pdf")))
