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
from . import crossval, nominal, selection, where
from .channels import Channels, channels_from
from .effects import EFFECTS, remove
from .result import Candidate, Diagnosis

#: Held-out blocks of a single trial.
BLOCKS = 5
#: Confidence level of the "where" bounds.
WHERE_LEVEL = 0.95
#: Cross-correlation lags, s: beyond the longest reflex loop (80 ms) and channel shift (50 ms).
XCORR_LAG_S = 0.2


def _median_stiffness(result) -> float:
    obs = result.observable if np.any(result.observable) else np.ones_like(result.observable)
    return float(np.median(result.stiffness[obs]))


def _corrected_trial(trial: Trial, ch: Channels, corr) -> Trial:
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


def _full_residual(ch: Channels, components, coef: np.ndarray):
    """Full-rate residual of a model (nuisance refitted at full rate), with its layout."""
    lay = nominal.layout(ch, decimation=1)
    chc, regs, local = crossval.compose(ch, components)
    rows = lay.rows
    z = chc.elastic_target()[rows]
    if regs:
        z = z - coef @ np.vstack(regs)[:, rows]
    loc = np.vstack(local)[:, rows].T if local else None
    proj = nominal.projector(chc.angle[rows], chc.time[rows], lay, loc)
    return lay, proj.project(z)


def _where(ch: Channels, lay, residual: np.ndarray, decimation: int) -> dict:
    rows = lay.rows
    f = ch.torque[rows]
    dev_power = float(np.mean((f - f.mean()) ** 2))
    y, v = ch.angle[rows], ch.velocity[rows]
    t = ch.time[rows]
    # time: gap per window, change points of its logarithm
    wins = np.unique(lay.window)
    win_gap = np.array([np.mean(residual[lay.window == w] ** 2) / dev_power for w in wins])
    starts = [float(t[lay.window == w][0]) for w in wins]
    cps = where.change_points(np.log(np.maximum(win_gap, 1e-300)))
    time = {"window_s": lay.window_s, "start_s": starts, "end_s": float(t[-1]), "gap": win_gap.tolist(),
            "change_points_s": [starts[i] for i in cps]}
    freq = where.spectrum(residual, f, y, ch.fs, max_hz=min(0.5 * ch.fs, 2 * nominal.effective_cutoff(ch)),
                          level=WHERE_LEVEL)
    # regimes
    eff = where.effective_fraction(residual[::decimation] ** 2)
    # "near zero": below three velocity-noise levels, or 1 % of the RMS speed on noise-free data
    still = max(3.0 * ch.velocity_noise, 0.01 * float(np.sqrt(np.mean(v ** 2))))
    regime = {}
    lab, names, rng = where.speed_bins(v, still)
    regime["speed"] = where.binned_gap(residual, dev_power, lab, names, level=WHERE_LEVEL, effective=eff / decimation,
                                       edges=rng)
    near = where.reversal_mask(v, int(round(0.125 * ch.fs / ch.motion_hz)), still)
    regime["reversal"] = where.binned_gap(residual, dev_power, near.astype(int),
                                          ["away from reversals", "within 1/8 period of a reversal"],
                                          level=WHERE_LEVEL, effective=eff / decimation)
    for key, x in (("angle", y), ("torque", f), ("stiffness", ch.stiffness[rows])):
        lab, rng = where.quantile_bins(x, 5)
        regime[key] = where.binned_gap(residual, dev_power, lab, [f"{lo:.4g}–{hi:.4g}" for lo, hi in rng],
                                       level=WHERE_LEVEL, effective=eff / decimation, edges=rng)
    # whiteness at the rows' rate, against what filtered white noise would show
    dec = residual[::decimation]
    max_lag = int(min(20, len(dec) // 5))
    grid = np.linspace(0.0, 0.5 * ch.fs, 4097)
    ref = where.filtered_noise_acf(nominal.filter_power(grid, ch), grid, np.arange(max_lag + 1) * decimation / ch.fs)
    white = where.whiteness(dec, max_lag=max_lag, level=WHERE_LEVEL, reference=ref)
    white["sample_period_s"] = decimation / ch.fs
    white["note"] = ("reference: autocorrelation of white noise through the analysis's low-pass; the test is on "
                     "the departure from it")
    xcorr = {"velocity": where.cross_correlation(residual, v, max_lag=int(XCORR_LAG_S * ch.fs),
                                                 sample_period=1.0 / ch.fs, level=WHERE_LEVEL),
             "angle": where.cross_correlation(residual, y, max_lag=int(XCORR_LAG_S * ch.fs),
                                              sample_period=1.0 / ch.fs, level=WHERE_LEVEL)}
    return {"time": time, "frequency": freq, "regime": regime, "whiteness": white, "cross_correlation": xcorr}


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
    sel = selection.select(problem, effects, rng=rng)
    level = protocol.ci_level
    den = float(np.sum(problem.deviation ** 2))
    nominal_held = float(sel.nominal.unit_rss.sum())
    nominal_train = float(sel.nominal.rss_train)
    chosen = [e.name for e, _ in sel.chosen]
    mech = SimpleNamespace(inertia=float(np.median([c.inertia for c in channels])),
                           damping=float(np.median([c.damping for c in channels])))

    candidates = []
    for name, sc in sel.first.items():
        ev, eff = sc.evaluation, effects[name]
        params = eff.params(ev.shape, ev.coef, mech)
        if eff.local:
            params["rms"] = float(np.sqrt(np.mean(ev.fitted ** 2)))
        later = [s[name] for s in sel.steps[1:] if name in s]
        evidence = {"absorbed": ev.absorbed, "identifiable_share": ev.share,
                    "p_value": sc.p_value, "p_adjusted": sc.p_adjusted, "significant": sc.significant,
                    "relevant": sc.relevant, "units": int(len(sc.gains)),
                    "units_improved": float(np.mean(sc.gains > 0)), "scheme": ev.scheme,
                    "fold_params": [eff.params(s, np.zeros(len(ev.coef)), None) for s in ev.fold_shapes
                                    if s is not None] if eff.grid(selection.problem_scales(problem)) != [{}] else None,
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
        fitted = [[(eff, ev.shape, ev.coef)] for _ in trials]
        bias = stiffness_change(trials, results, channels, protocol, fitted, seed)
        candidates.append(Candidate(
            effect=name, description=eff.description, params=params, gap_train=ev.rss_train / den,
            gap_heldout=float(ev.unit_rss.sum()) / den, shrink_heldout=sc.shrink,
            shrink_interval=selection.shrink_interval(sc.reference, ev.unit_rss, rng, level=level),
            evidence=evidence, stiffness_bias=bias))
    candidates.sort(key=lambda c: -c.shrink_heldout)

    # the model with every chosen effect
    final = sel.final
    fitted_all = []
    k = 0
    for step, (eff, shape) in enumerate(sel.chosen):
        if eff.local:          # refitted as nuisance in the model: take its fit when it was chosen
            coef = sel.steps[step][eff.name].evaluation.coef
        else:
            n_coef = 0 if eff.kind == "measurement" else 1
            coef = final.base_coef[k:k + n_coef]
            k += n_coef
        fitted_all.append((eff, shape, coef))
    after = {"effects": chosen, "gap_train": final.rss_train / den,
             "gap_heldout": float(final.unit_rss.sum()) / den,
             "shrink_heldout": 1.0 - float(final.unit_rss.sum()) / nominal_held if nominal_held > 0 else None,
             "shrink_heldout_interval": list(selection.shrink_interval(sel.nominal.unit_rss, final.unit_rss, rng,
                                                                    level=level)),
             "params": {eff.name: eff.params(shape, coef, mech) for eff, shape, coef in fitted_all}}
    if any(e.local for e, _ in sel.chosen):
        after["note"] = ("sensor drift, once chosen, is refitted on every scored block like the elastic terms; "
                         "the held-out gap above scores the other effects only")
    after["stiffness_bias"] = stiffness_change(trials, results, channels, protocol,
                                               [fitted_all] * len(trials), seed) if fitted_all else None

    where_out, series = {}, {}
    for i, (ch, lay) in enumerate(zip(channels, problem.layouts)):
        full_lay, res0 = _full_residual(ch, [], np.zeros(0))
        w = _where(ch, full_lay, res0, lay.decimation)
        where_out[ch.name] = w
        s = {"time": ch.time[full_lay.rows], "residual": res0, "torque": ch.torque[full_lay.rows],
             "where": w}
        if sel.chosen:
            _, res1 = _full_residual(ch, sel.chosen, final.base_coef)
            s["residual_after"] = res1
            s["where_after"] = _where(ch, full_lay, res1, lay.decimation)
        series[ch.name] = s

    trials_info = []
    for i, (t, r, ch, lay) in enumerate(zip(trials, results, channels, problem.layouts)):
        sel_i = problem.trial == i
        trials_info.append({"trial": t.name, "source": t.source, "source_sha256": t.source_sha256,
                            "fs_hz": t.fs, "duration_s": t.duration, "variant": r.variant,
                            "inertia": ch.inertia, "damping": ch.damping, "mechanics": ch.mechanics,
                            "cutoff_hz": ch.cutoff_hz, "motion_hz": ch.motion_hz, "rows": int(len(lay.rows)),
                            "decimation": lay.decimation, "windows": int(lay.window.max()) + 1,
                            "stiffness_median": _median_stiffness(r),
                            "noise_floor": nominal.noise_floor(ch, lay),
                            "gap_train": float(np.sum(sel.nominal.residual[sel_i] ** 2)
                                               / np.sum(problem.deviation[sel_i] ** 2))})
    floor = float(np.average([t["noise_floor"] for t in trials_info],
                             weights=[np.sum(problem.deviation[problem.trial == i] ** 2) for i in range(len(trials))]))

    steps = [{"step": i + 1, "added": chosen[i] if i < len(chosen) else None,
              "candidates": {n: {"shrink_heldout": s.shrink, "share_of_nominal_gap": s.share_of_nominal,
                                 "p_value": s.p_value, "p_adjusted": s.p_adjusted,
                                 "significant": s.significant, "relevant": s.relevant}
                             for n, s in step.items()}} for i, step in enumerate(sel.steps)]
    notes = _notes(channels, problem, chosen)
    heldout = {"scheme": "leave-one-trial-out" if problem.scheme == "trials" else f"{problem.n_folds} contiguous blocks",
               "folds": problem.n_folds, "guard_s": problem.guard_s if problem.scheme == "blocks" else 0.0,
               "units": problem.n_units, "unit_s": [lay.unit_s for lay in problem.layouts],
               "window_s": [lay.window_s for lay in problem.layouts]}
    settings = {"alpha": selection.ALPHA, "relevance": selection.RELEVANCE, "permutations": selection.PERMUTATIONS,
                "bootstrap": selection.BOOTSTRAP, "collinear": selection.COLLINEAR, "ci_level": level,
                "window_periods": nominal.WINDOW_PERIODS, "units_per_window": nominal.UNITS_PER_WINDOW,
                "nuisance": list(nominal.NUISANCE), "test": "one-sided sign-flip test of the summed held-out gains "
                "over units, Holm-corrected over the candidates of each step",
                "relevance_reason": "an effect must remove at least this share of the nominal model's held-out "
                                    "gap, at the step it is added (see limbstiff.diagnose.selection.RELEVANCE)"}
    warnings = [w for r in results for w in r.warnings]
    notes.insert(0, "gap: the nominal model fits nothing of its own but the elastic terms, which are refitted on "
                    "whatever is scored, so its held-out gap equals its in-sample gap"
                 + ("; its m and b were identified from these same data" if any(c.mechanics == "identified"
                                                                              for c in channels) else ""))
    return Diagnosis(trials=tuple(trials_info), metric=nominal.METRIC, gap_train=nominal_train / den,
                     gap_heldout=nominal_held / den, noise_floor=floor, heldout=heldout, where=where_out,
                     candidates=tuple(candidates), diagnosis=tuple(chosen), steps=tuple(steps),
                     ambiguities=tuple(sel.ambiguities), after=after, settings=settings, notes=tuple(notes),
                     warnings=tuple(warnings), seed=seed, series=series)


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
