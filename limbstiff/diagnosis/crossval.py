"""Held-out evaluation: fit a model on some data, score its torque prediction on data it was not
fitted on.

Every trial is cut into contiguous held-out blocks of whole units (:mod:`.nominal`); fold j
leaves out block j of every trial. A model — the nominal one plus some effects — is the Kalman
model of :mod:`.nominal` with the effects' torques as extra measurement terms. Its noise levels
are refitted by maximum marginal likelihood; its coefficients (the effects' amplitudes, shared by
the trials; m and b of each trial when they are identified) are fitted by weighted least squares
on the training folds' innovations (weights 1/S); its held-out error is the one-step-ahead
prediction error of the torque on the left-out block. An effect's shape (delay, width…) is
chosen on the training folds over its grid, at the current model's noise levels; the noise is
then refitted once, at the shape chosen on all the data. Training steps within a *guard* of the
held-out block are left out: the zero-phase filter spreads the held-out torque over about two
corner periods, and a channel shift of up to 50 ms moves it further. The folds, the guard and
the fits of every fold at once are :mod:`limbstiff.heldout`'s. Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import heldout
from ..statespace.noise import NoiseLevels
from ..statespace.linear import innovations
from ..statespace.steps import ModelSteps, channel_steps, deflection
from . import nominal
from ..effects.channels import Channels
from ..effects.kinds import ModelEffect

#: Largest channel shift a candidate may apply, s (``effects.TIME_DELAYS_S``).
MAX_SHIFT_S = 0.05
#: Corner periods over which the zero-phase filter spreads a sample.
FILTER_SPREAD_PERIODS = 2.0


@dataclass(frozen=True)
class Problem:
    """The trials of one diagnosis, their steps and folds.

    Parameters
    ----------
    channels : tuple of Channels
    layouts : tuple of nominal.ScoringLayout
    guard_s : float, s
    folds : heldout.Folds
        Per step (all trials concatenated): held-out block, global unit id (−1: not scored) and
        the steps each fold trains on.
    trial : ndarray of int, shape (R,)
        Each step's trial index.
    deviation : ndarray, shape (R,), N·m
        f − f̄ per trial (zero where not scored).
    """

    channels: tuple
    layouts: tuple
    guard_s: float
    folds: heldout.Folds
    trial: np.ndarray
    deviation: np.ndarray
    cache: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def n_folds(self) -> int:
        return self.folds.n_folds

    @property
    def n_units(self) -> int:
        return self.folds.n_units

    @property
    def scored(self) -> np.ndarray:
        return self.folds.scored

    @property
    def n_rows(self) -> int:
        return len(self.trial)

    def trial_rows(self, i: int) -> slice:
        start = sum(len(lay.rows) for lay in self.layouts[:i])
        return slice(start, start + len(self.layouts[i].rows))


def guard_seconds(channels) -> float:
    """Guard around a held-out block: filter spread plus the largest channel shift, s."""
    return max(FILTER_SPREAD_PERIODS / nominal.effective_cutoff(c) for c in channels) + MAX_SHIFT_S


def build_problem(channels, *, blocks: int = heldout.FOLDS) -> Problem:
    """Steps, units and folds: ``blocks`` contiguous blocks per trial, block j of every trial in fold j.

    Raises
    ------
    ValueError
        A trial too short for its layout.
    """
    channels = tuple(channels)
    layouts = tuple(nominal.layout(c, blocks=blocks) for c in channels)
    guard = guard_seconds(channels)
    k = max(lay.n_segments for lay in layouts)
    # the guard in each trial's steps: those no further than guard_s from a held-out one
    folds = heldout.joined([heldout.folds_of(lay.unit, lay.segment, guard=guard_steps(guard, lay.step_s), n_folds=k)
                            for lay in layouts])
    dev = []
    for c, lay in zip(channels, layouts):
        f = c.torque[lay.rows]
        dev.append(np.where(lay.scored, f - f[lay.scored].mean(), 0.0))
    return Problem(channels=channels, layouts=layouts, guard_s=guard, folds=folds,
                   trial=np.concatenate([np.full(len(lay.rows), i) for i, lay in enumerate(layouts)]),
                   deviation=np.concatenate(dev))


def guard_steps(guard_s: float, step_s: float) -> int:
    """Steps within ``guard_s`` seconds of a step (those ``guard_s`` away included, to rounding)."""
    return int(np.floor(guard_s / step_s * (1 + 1e-9)))


def compose(ch: Channels, components) -> tuple[Channels, list]:
    """Apply a model's effects in order: corrected channels and the effects' regressors (p, n)."""
    regs = []
    for effect, shape in components:
        term = effect.evaluate(ch, shape)
        ch = ch.with_channels(angle=term.angle, torque=term.torque)
        if term.regressors is not None:
            regs.append(term.regressors)
    return ch, regs


def _signature(components) -> tuple:
    return tuple((e.name, tuple(sorted(s.items()))) for e, s in components)


def _composed(problem: Problem, i: int, components, keep: bool = True) -> tuple[Channels, ModelSteps]:
    """Trial ``i``'s channels corrected by the model's effects, and the model's data at its steps:
    target, m and b columns when identified, the effects' regressors (cached per model when
    ``keep``)."""
    key = ("steps", i, _signature(components))
    hit = problem.cache.get(key)
    if hit is None:
        ch0, lay = problem.channels[i], problem.layouts[i]
        ch, regs = compose(ch0, components)
        rows = lay.rows
        chans = [ch.target()[None, rows], ch.nuisance_columns(rows)] + [r[:, rows] for r in regs]
        hit = (ch, channel_steps(ch.angle[rows], np.vstack(chans), scale_from=ch0.torque[rows], step=lay.step_s,
                                 deflection=deflection(ch.angle[rows], step=lay.step_s, motion_frequency=ch.motion_hz),
                                 index=rows))
        if keep:
            problem.cache[key] = hit
    return hit


def trial_steps(problem: Problem, i: int, components, effect: ModelEffect | None = None,
                shape: dict | None = None) -> ModelSteps:
    """The model's data at trial ``i``'s steps, with the candidate ``effect`` at ``shape`` last.

    A candidate's regressors are cached per shape (their full-rate evaluation is the costly
    part); a candidate that corrects a channel gives a new model each time."""
    ch, base = _composed(problem, i, components)
    if effect is None:
        return base
    if effect.corrects_channel:
        return _composed(problem, i, list(components) + [(effect, shape)], keep=False)[1]
    corrections = _signature([(e, s) for e, s in components if e.corrects_channel])
    key = ("term", i, corrections, effect.name, tuple(sorted(shape.items())))
    regs = problem.cache.get(key)
    if regs is None:
        regs = problem.cache[key] = effect.evaluate(ch, shape).regressors[:, problem.layouts[i].rows]
    return channel_steps(base.angle, np.vstack([base.channels, regs]), step=base.step, deflection=base.deflection,
                         scale_from=problem.channels[i].torque[problem.layouts[i].rows], index=base.index)


def _noise(problem: Problem, components, effect=None, shape=None, start=None) -> list[NoiseLevels]:
    """Each trial's noise levels for the model, by maximum marginal likelihood (cached per model,
    so that a candidate once chosen keeps the levels it was judged with)."""
    model = list(components) + ([(effect, shape)] if effect is not None else [])
    key = ("noise", _signature(model))
    hit = problem.cache.get(key)
    if hit is None:
        hit = []
        for i, ch in enumerate(problem.channels):
            st = trial_steps(problem, i, components, effect, shape)
            first = start[i] if start is not None else nominal.start_noise(ch, st)
            hit.append(nominal.fit_noise(st, start=first, motion_hz=ch.motion_hz))
        problem.cache[key] = hit
    return hit


@dataclass(frozen=True)
class Design:
    """A model's innovations over all trials' steps, as a regression.

    Parameters
    ----------
    target : ndarray, shape (R,), N·m
        Innovations of the target channel.
    columns : ndarray, shape (R, P), N·m per unit coefficient
        Innovations of the fitted columns: first each trial's nuisance (m and b when identified,
        the static nonlinear spring; zero on the other trials' steps), then the effects'
        regressors (shared by the trials).
    weight : ndarray, shape (R,), 1/(N·m)
        1/√S: the innovations' standard deviation under the model.
    n_nuisance : int
        Columns that belong to one trial.
    blocks : tuple of (slice, ndarray of int)
        Each trial's steps and the columns not zero on them (its own and the shared ones).
    raw_norm : float
        Norm of the candidate's regressors before filtering (N·m per unit coefficient), 0 without one.
    """

    target: np.ndarray
    columns: np.ndarray
    weight: np.ndarray
    n_nuisance: int
    blocks: tuple = ()
    raw_norm: float = 0.0

    def fit(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Weighted least squares on several row subsets (bool (K, R)): coefficients (K, P) and
        the weighted residual sums of squares (K,)."""
        w = self.weight
        return heldout.fold_fits(self.target * w, self.columns * w[:, None], rows, self.blocks)


def design(problem: Problem, components, noise, effect: ModelEffect | None = None, shape: dict | None = None) -> Design:
    """The model's :class:`Design` at the trials' noise levels ``noise`` (one per trial)."""
    per = [trial_steps(problem, i, components, effect, shape) for i in range(len(problem.channels))]
    n_own = [ch.n_nuisance for ch in problem.channels]
    k_own = sum(n_own)
    n_shared = per[0].channels.shape[0] - 1 - n_own[0]
    rows = problem.n_rows
    target, weight = np.empty(rows), np.empty(rows)
    columns = np.zeros((rows, k_own + n_shared))
    raw = 0.0
    col = 0
    blocks = []
    for i, (st, k) in enumerate(zip(per, n_own)):
        sl = problem.trial_rows(i)
        blocks.append((sl, np.r_[col:col + k, k_own:k_own + n_shared]))
        e, var = innovations(st, noise[i])
        target[sl], weight[sl] = e[0], 1.0 / np.sqrt(var)
        columns[sl, col:col + k] = e[1:1 + k].T
        columns[sl, k_own:] = e[1 + k:].T
        col += k
        if effect is not None and effect.amplitudes:
            last = st.channels[-len(effect.amplitudes):]
            raw += float(np.sum((last - last.mean(axis=1, keepdims=True)) ** 2))
    return Design(target, columns, weight, k_own, tuple(blocks), float(np.sqrt(raw)))


@dataclass
class Evaluation:
    """A model (the base, or the base with one more effect) fitted and scored.

    Attributes
    ----------
    effect : str or None
    unit_rss : ndarray, shape (U,)
        Held-out sum of squared one-step prediction errors per unit (N·m²).
    shape : dict
        Shape fitted on all the data; ``fold_shapes`` those chosen on each fold's training data.
    coef : ndarray
        The effect's amplitudes fitted on all the data (with the base's).
    base_coef : ndarray
        The base effects' amplitudes, in the order of the base's regressors.
    mechanics : list of (float, float) or None
        Each trial's m and b fitted with the effects (None when they are given).
    rss_train : float
        In-sample sum of squared innovations with everything fitted on all the data (N·m²).
    fitted : ndarray, shape (R,)
        The effect's part of the in-sample one-step prediction (for collinearity between candidates).
    residual : ndarray, shape (R,)
        In-sample innovations of the torque (N·m).
    noise : list of NoiseLevels
        The model's noise levels, per trial.
    share : float or None
        Norm of the effect's innovations over that of its centred torque: the part of its torque
        the time-varying model cannot take up by itself.
    """

    effect: str | None
    unit_rss: np.ndarray
    shape: dict
    coef: np.ndarray
    base_coef: np.ndarray
    mechanics: list | None
    rss_train: float
    fitted: np.ndarray
    residual: np.ndarray
    noise: list
    fold_shapes: list = field(default_factory=list)
    share: float | None = None


def _choose_shapes(problem: Problem, base_components, effect, shapes, noise):
    """Each fold's shape (best weighted fit on its training steps) and the shape best on all."""
    k = problem.n_folds
    rows = np.vstack([problem.folds.training, problem.scored[None]])
    best = np.full(k + 1, np.inf)
    chosen = [None] * (k + 1)
    for shape in shapes:
        _, rss = design(problem, base_components, noise, effect, shape).fit(rows)
        for j in np.flatnonzero(rss < best):
            best[j], chosen[j] = rss[j], shape
    return chosen[:k], chosen[k]


def _heldout_errors(problem: Problem, base_components, noise, effect, fold_shapes) -> np.ndarray:
    """One-step prediction errors (R,) of each fold's held-out steps, the coefficients fitted on
    its training steps at its shape (zero where not scored), N·m."""
    held = np.zeros(problem.n_rows)
    for sh in {tuple(sorted(s.items())) for s in fold_shapes}:
        folds = [j for j, s in enumerate(fold_shapes) if tuple(sorted(s.items())) == sh]
        d = design(problem, base_components, noise, effect, dict(sh))
        held += heldout.regression(problem.folds, d.target, d.columns, d.weight, which=folds, blocks=d.blocks).error
    return held


def evaluate(problem: Problem, base_components, effect: ModelEffect | None = None, *,
             shapes: list | None = None) -> Evaluation:
    """Fit the base model (with ``effect`` profiled over ``shapes``) and score it held out.

    Parameters
    ----------
    problem : Problem
    base_components : sequence of (ModelEffect, dict)
        Effects already in the model (shapes fixed, amplitudes refitted with the new one).
    effect : ModelEffect or None
        None scores the base model itself.
    shapes : list of dict, optional
        Shape grid (default ``[{}]``).

    Returns
    -------
    Evaluation
    """
    base_noise = _noise(problem, base_components)
    if effect is None:
        fold_shapes, shape, noise = [{}] * problem.n_folds, {}, base_noise
    else:
        fold_shapes, shape = _choose_shapes(problem, base_components, effect, shapes or [{}], base_noise)
        noise = _noise(problem, base_components, effect, shape, start=base_noise)
    held = _heldout_errors(problem, base_components, noise, effect, fold_shapes)
    d = design(problem, base_components, noise, effect, shape)
    coef = d.fit(problem.scored[None])[0][0]
    resid = np.where(problem.scored, d.target - d.columns @ coef, 0.0)
    p_new = len(effect.amplitudes) if effect is not None and effect.amplitudes else 0
    p_shared = d.columns.shape[1] - d.n_nuisance
    shared = coef[d.n_nuisance:]
    fitted = d.columns[:, d.columns.shape[1] - p_new:] @ shared[p_shared - p_new:] if p_new else np.zeros(len(held))
    share = None
    if p_new and d.raw_norm > 0:
        share = float(np.linalg.norm(d.columns[problem.scored, -p_new:]) / d.raw_norm)
    mech = None
    if any(ch.identified for ch in problem.channels):
        mech, k = [], 0
        for ch in problem.channels:
            mech.append(tuple(float(v) for v in coef[k:k + 2]) if ch.identified else None)
            k += ch.n_nuisance
    return Evaluation(effect=None if effect is None else effect.name, unit_rss=problem.folds.unit_sum(held ** 2),
                      shape=dict(shape), coef=shared[p_shared - p_new:], base_coef=shared[:p_shared - p_new],
                      mechanics=mech, rss_train=float(np.sum(resid ** 2)), fitted=np.where(problem.scored, fitted, 0.0),
                      residual=resid, noise=list(noise), fold_shapes=list(fold_shapes), share=share)
