"""Each trial's own selection beside the pooled one.

A pooled diagnosis shares each effect's amplitude over the trials: an effect of one trial can be
diluted below significance by the others (an elbow with a reflex pooled with a clean wrist and
ankle: no effect), or imposed on trials without it. :func:`trial_selections` runs the same
greedy selection (:func:`selection.select`) on each trial alone — the same candidate library,
the same seed for its own random draws, the trial's own held-out blocks and grids, so each
answer is the diagnosis of that trial alone — and :func:`disagreements` says in words where
they differ from the pooled one and what to do. The channels come from the analyses already
made, and the pooled problem's cache (each trial's model steps, effect regressors and noise
levels) is reused where the models coincide. Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping, Sequence

import numpy as np

from . import crossval, selection
from .parts import Mechanics


@dataclass(frozen=True)
class TrialEffect:
    """One effect a trial's own selection chose (:mod:`limbstiff.diagnosis.per_trial`).

    Parameters
    ----------
    effect : str
    step : int
        The step of the trial's own selection that added it (from 1).
    shrink_heldout : float
        Share of the trial's held-out gap, with the effects chosen before it, that it removes.
    share_of_nominal_gap : float
        The same gain as a share of the trial's nominal held-out gap.
    params : Mapping of str to float or None
        Its parameters fitted on the trial with every effect chosen for it (SI units).
    units : Mapping of str to str
        The unit of each parameter.
    """

    effect: str
    step: int
    shrink_heldout: float
    share_of_nominal_gap: float
    params: Mapping[str, float | None]
    units: Mapping[str, str]


@dataclass(frozen=True)
class TrialSelection:
    """One trial's own selection, made on it alone beside the pooled one.

    Parameters
    ----------
    trial : str
    diagnosis : tuple of str
        The effects the trial's own selection chose, in the order added.
    agrees : bool
        The same effects as the pooled diagnosis (the order is not compared).
    effects : tuple of TrialEffect
        Each of them with its held-out shrink and parameters.
    gap_heldout : float
        The nominal model's held-out gap on the trial alone (its own blocks).
    shrink_heldout : float or None
        1 − the held-out gap with all its effects over the nominal one (None when that is 0).
    """

    trial: str
    diagnosis: tuple[str, ...]
    agrees: bool
    effects: tuple[TrialEffect, ...]
    gap_heldout: float
    shrink_heldout: float | None


def chosen_fits(sel: selection.Selection) -> list:
    """The chosen effects as (ModelEffect, shape, amplitudes) of the model with all of them: the final
    model's amplitude vector holds each effect's amplitudes in the order chosen."""
    fitted, k = [], 0
    for eff, shape in sel.chosen:
        coef = sel.final.base_coef[k:k + len(eff.amplitudes)]
        k += len(eff.amplitudes)
        fitted.append((eff, shape, coef))
    return fitted


def _reused(cache: dict, i: int) -> dict:
    """The entries of a pooled problem's cache that hold for trial ``i`` alone, keyed as a problem
    of that trial only: its model steps and effect regressors, and its noise levels of each model
    (fitted trial by trial, from the same start). The grids' scales are the trial's own: not kept."""
    out = {}
    for key, value in cache.items():
        if key[0] in ("steps", "term") and key[1] == i:
            out[(key[0], 0) + key[2:]] = value
        elif key[0] == "noise":
            out[key] = [value[i]]
    return out


def _selection_of(name: str, ch, problem: crossval.Problem, sel: selection.Selection,
                  pooled: tuple[str, ...]) -> TrialSelection:
    """A trial's :class:`TrialSelection` from its own :class:`selection.Selection` made on ``problem``."""
    mech = Mechanics(inertia=ch.inertia, damping=ch.damping)
    effects = []
    for step, (eff, shape, coef) in enumerate(chosen_fits(sel)):
        scored = sel.steps[step][eff.name]
        params = eff.params(shape, coef, mech)
        effects.append(TrialEffect(effect=eff.name, step=step + 1, shrink_heldout=scored.shrink,
                                   share_of_nominal_gap=scored.share_of_nominal, params=params,
                                   units=eff.units_of(params)))
    chosen = tuple(e.effect for e in effects)
    nominal, final = float(sel.nominal.unit_rss.sum()), float(sel.final.unit_rss.sum())
    den = float(np.sum(problem.deviation ** 2))
    return TrialSelection(trial=name, diagnosis=chosen, agrees=set(chosen) == set(pooled), effects=tuple(effects),
                          gap_heldout=nominal / den if den > 0 else float("nan"),
                          shrink_heldout=1.0 - final / nominal if nominal > 0 else None)


def trial_selections(trials: Sequence, channels: Sequence, effects: dict, *, pooled: tuple[str, ...], seed: int,
                     blocks: int, cache: dict | None = None) -> tuple[TrialSelection, ...]:
    """Each trial's own selection, when there are several trials (none for one: its own selection
    is the diagnosis).

    Parameters
    ----------
    trials : sequence of Trial
        For their names.
    channels : sequence of Channels
        The trials' channels, from their analyses.
    effects : dict of str to ModelEffect
        The pooled diagnosis's candidate library.
    pooled : tuple of str
        The pooled diagnosis.
    seed : int
        Seed of each trial's random draws (``numpy.random.default_rng(seed)``, as alone).
    blocks : int
        Held-out blocks per trial.
    cache : dict, optional
        The pooled problem's cache, reused where it holds for a trial alone.

    Returns
    -------
    tuple of TrialSelection
    """
    if len(channels) < 2:
        return ()
    out = []
    for i, (trial, ch) in enumerate(zip(trials, channels)):
        problem = crossval.build_problem([ch], blocks=blocks)
        problem.cache.update(_reused(cache or {}, i))
        sel = selection.select(problem, effects, rng=np.random.default_rng(seed))
        out.append(_selection_of(trial.name, ch, problem, sel, pooled))
    return tuple(out)


def disagreements(pooled: tuple[str, ...], per_trial: Sequence[TrialSelection]) -> tuple[str, ...]:
    """One warning naming the trials whose own selection differs from the pooled diagnosis and their
    effects, and saying what to do; none when every trial agrees."""
    differ = [s for s in per_trial if not s.agrees]
    if not differ:
        return ()
    alone = "; ".join(f"{s.trial} alone: {', '.join(s.diagnosis) or 'none'}" for s in differ)
    return (f"the trials' own selections differ from the pooled diagnosis ({', '.join(pooled) or 'none'}) — {alone}. "
            "A pooled diagnosis shares each effect's amplitude over the trials, so an effect of one trial can be "
            "diluted below significance by the others, or given to trials without it: diagnose these trials "
            "separately, or pool only trials of one set-up (same joint, device and condition).",)
