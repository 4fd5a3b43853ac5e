"""Held-out evaluation: fit an effect on some data, score it on data it was not fitted on.

Folds are whole trials when several are diagnosed together (leave one trial out), otherwise
contiguous blocks of whole windows of the one trial. An effect's shape and amplitudes are
fitted on the training folds; the elastic nuisance (per window, :mod:`.nominal`) is refitted on
whatever is scored, for the nominal and the augmented model alike. Training rows within a
*guard* of the held-out block are left out: the zero-phase filter spreads the held-out torque
over about two corner periods, and a channel shift of up to 50 ms moves it further.

A term without a parameter that carries over (sensor drift: a spline in time) cannot be scored
on another trial or block; it is scored by predicting held-out *units* (one motion period each,
every fifth) from the rest of the same recording, base and augmented model alike
(:func:`evaluate_local`). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import nominal
from .channels import Channels
from .effects import Effect

#: Largest channel shift a candidate may apply, s (``effects.TIME_DELAYS_S``).
MAX_SHIFT_S = 0.05
#: Corner periods over which the zero-phase filter spreads a sample.
FILTER_SPREAD_PERIODS = 2.0
#: Interleaved folds of the local (drift) scoring.
LOCAL_FOLDS = 5


@dataclass(frozen=True)
class Problem:
    """The trials of one diagnosis, their rows and folds.

    Parameters
    ----------
    channels : tuple of Channels
    layouts : tuple of nominal.Layout
    scheme : {"trials", "blocks"}
    guard_s : float, s
    fold, unit, trial, deviation : ndarray, shape (R,)
        Per row (all trials concatenated): fold, global unit id, trial index, f − f̄ (N·m).
    training : ndarray of bool, shape (K, R)
        Rows usable for training when fold k is held out.
    """

    channels: tuple
    layouts: tuple
    scheme: str
    guard_s: float
    fold: np.ndarray
    unit: np.ndarray
    trial: np.ndarray
    deviation: np.ndarray
    training: np.ndarray
    cache: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def n_folds(self) -> int:
        return self.training.shape[0]

    @property
    def n_units(self) -> int:
        return int(self.unit.max()) + 1

    def unit_sum(self, values: np.ndarray) -> np.ndarray:
        """Sum of per-row ``values`` within each unit, shape (U,)."""
        return np.bincount(self.unit, weights=values, minlength=self.n_units)


def guard_seconds(channels) -> float:
    """Guard around a held-out block: filter spread plus the largest channel shift, s."""
    return max(FILTER_SPREAD_PERIODS / nominal.effective_cutoff(c) for c in channels) + MAX_SHIFT_S


def build_problem(channels, *, blocks: int = 5) -> Problem:
    """Rows, units and folds: leave-one-trial-out for several trials, else ``blocks`` blocks.

    Raises
    ------
    ValueError
        A trial too short for its layout.
    """
    channels = tuple(channels)
    several = len(channels) > 1
    layouts = tuple(nominal.layout(c, blocks=1 if several else blocks) for c in channels)
    guard = guard_seconds(channels)
    fold, unit, trial, dev, times = [], [], [], [], []
    offset = 0
    for i, (c, lay) in enumerate(zip(channels, layouts)):
        fold.append(np.full(len(lay.rows), i) if several else lay.segment)
        unit.append(lay.unit + offset)
        offset += lay.n_units
        trial.append(np.full(len(lay.rows), i))
        dev.append(nominal.torque_deviation(c, lay))
        times.append(c.time[lay.rows])
    fold, unit, trial, times = map(np.concatenate, (fold, unit, trial, times))
    k = int(fold.max()) + 1
    training = np.ones((k, len(fold)), dtype=bool)
    for j in range(k):
        held = fold == j
        training[j] &= ~held
        if not several:
            lo, hi = times[held].min() - guard, times[held].max() + guard
            training[j] &= ~((times >= lo) & (times <= hi))
    return Problem(channels=channels, layouts=layouts, scheme="trials" if several else "blocks",
                   guard_s=guard, fold=fold, unit=unit, trial=trial, deviation=np.concatenate(dev),
                   training=training)


def compose(ch: Channels, components) -> tuple[Channels, list, list]:
    """Apply a model's effects in order: corrected channels, regressors (p, n) and local columns."""
    regs, local = [], []
    for effect, shape in components:
        term = effect.evaluate(ch, shape)
        ch = ch.with_channels(angle=term.angle, torque=term.torque)
        if term.regressors is not None:
            (local if effect.local else regs).append(term.regressors)
    return ch, regs, local


@dataclass
class _TrialBase:
    signature: tuple          # the base's channel corrections (for the cache)
    ch: Channels
    regs: np.ndarray          # (r, p) at rows, unprojected
    local: np.ndarray | None  # (r, k) at rows
    proj: nominal.Projector
    z: np.ndarray             # projected target (r,)
    X: np.ndarray             # projected base regressors (r, p)


def _rows_matrix(arrays, rows):
    return np.vstack(arrays)[:, rows].T if arrays else np.zeros((len(rows), 0))


def _base(problem: Problem, components) -> list[_TrialBase]:
    out = []
    signature = tuple((e.name, tuple(sorted(s.items()))) for e, s in components
                      if e.kind == "measurement" and not e.local)
    for ch0, lay in zip(problem.channels, problem.layouts):
        ch, regs, local = compose(ch0, components)
        rows = lay.rows
        loc = _rows_matrix(local, rows) if local else None
        proj = nominal.projector(ch.angle[0][rows], ch.time[rows], lay, loc)
        R = _rows_matrix(regs, rows)
        out.append(_TrialBase(signature, ch, R, loc, proj, proj.project(ch.elastic_target()[rows]),
                              proj.project(R)))
    return out


def _term_rows(problem, i, b, effect, shape):
    """An effect's term at the rows of trial ``i``: (angle rows (r,) or None, target rows (r,) or
    None, regressors (r, p) or None), cached while the base's channels stay the same."""
    key = (i, b.signature, effect.name, tuple(sorted(shape.items())))
    hit = problem.cache.get(key)
    if hit is None:
        rows = problem.layouts[i].rows
        term = effect.evaluate(b.ch, shape)
        y = z = None
        if term.angle is not None or term.torque is not None:
            ch = b.ch.with_channels(angle=term.angle, torque=term.torque)
            z = ch.elastic_target()[rows]
            y = None if term.angle is None else ch.angle[0][rows]
        regs = None if term.regressors is None else term.regressors[:, rows].T.copy()
        hit = problem.cache[key] = (y, z, regs)
    return hit


def _design(problem, bases, effect: Effect | None, shape):
    """Projected target (R,) and regressors (R, p_base + p_effect) of base + effect at shape."""
    zs, Xs = [], []
    for i, (b, lay) in enumerate(zip(bases, problem.layouts)):
        rows = lay.rows
        if effect is None:
            zs.append(b.z)
            Xs.append(b.X)
            continue
        y, z_raw, regs = _term_rows(problem, i, b, effect, shape)
        proj, z = b.proj, b.z
        if y is not None:
            proj = nominal.projector(y, b.ch.time[rows], lay, b.local)
        if z_raw is not None:
            z = proj.project(z_raw)
        X = b.X if proj is b.proj else proj.project(b.regs)
        if regs is not None:
            X = np.column_stack([X, proj.project(regs)])
        zs.append(z)
        Xs.append(X)
    return np.concatenate(zs), np.vstack(Xs)


def _lstsq(X, z):
    if X.shape[1] == 0:
        return np.zeros(0)
    return np.linalg.lstsq(X, z, rcond=None)[0]


@dataclass
class Evaluation:
    """An effect (or the base alone) fitted and scored.

    Attributes
    ----------
    effect : str or None
    unit_rss : ndarray, shape (U,)
        Held-out sum of squared residuals per unit (N·m²).
    shape : dict
        Shape fitted on all the data; ``fold_shapes`` those fitted on each fold's training data.
    coef : ndarray
        Amplitudes of the effect fitted on all the data (after the base's).
    base_coef : ndarray
    rss_train : float
        In-sample sum of squared residuals with everything fitted on all the data.
    fitted : ndarray, shape (R,)
        In-sample projected torque of the effect (for collinearity between candidates).
    residual : ndarray, shape (R,)
        In-sample projected residual.
    scheme : str
        ``"folds"`` or ``"interleaved"`` (local terms).
    base_unit_rss : ndarray or None
        The base's held-out RSS under the same scheme (given for interleaved scoring).
    """

    effect: str | None
    unit_rss: np.ndarray
    shape: dict
    coef: np.ndarray
    base_coef: np.ndarray
    rss_train: float
    fitted: np.ndarray
    residual: np.ndarray
    fold_shapes: list = field(default_factory=list)
    scheme: str = "folds"
    base_unit_rss: np.ndarray | None = None


def evaluate(problem: Problem, base_components, effect: Effect | None = None, *,
             shapes: list | None = None, bases=None) -> Evaluation:
    """Fit ``effect`` (profiled over ``shapes``) on top of the base model; score it held out.

    Parameters
    ----------
    problem : Problem
    base_components : sequence of (Effect, dict)
        Effects already in the model (shapes fixed, amplitudes refitted with the new one).
    effect : Effect or None
        None scores the base model itself.
    shapes : list of dict, optional
        Shape grid (default: ``[{}]``).
    bases : list, optional
        Precomputed ``_base(problem, base_components)``.

    Returns
    -------
    Evaluation
    """
    bases = bases if bases is not None else _base(problem, base_components)
    shapes = shapes if shapes is not None else [{}]
    k = problem.n_folds
    p_base = bases[0].X.shape[1]
    best_train = np.full(k, np.inf)
    held = np.zeros(len(problem.fold))
    fold_shapes = [None] * k
    best_all = (np.inf, None, None, None)
    for shape in (shapes if effect is not None else [{}]):
        z, X = _design(problem, bases, effect, shape)
        for j in range(k):
            tr, te = problem.training[j], problem.fold == j
            coef = _lstsq(X[tr], z[tr])
            rss = float(np.sum((z[tr] - X[tr] @ coef) ** 2))
            if rss < best_train[j]:
                best_train[j] = rss
                held[te] = z[te] - X[te] @ coef
                fold_shapes[j] = shape
        coef = _lstsq(X, z)
        resid = z - X @ coef
        rss = float(resid @ resid)
        if rss < best_all[0]:
            best_all = (rss, shape, coef, X[:, p_base:] @ coef[p_base:], resid)
    rss, shape, coef, fitted, resid = best_all
    return Evaluation(effect=None if effect is None else effect.name, unit_rss=problem.unit_sum(held ** 2),
                      shape=dict(shape), coef=coef[p_base:], base_coef=coef[:p_base], rss_train=rss,
                      fitted=fitted, residual=resid, fold_shapes=fold_shapes)


def _window_columns(lay, y, t):
    blocks = nominal.nuisance_columns(y, t, lay.window)
    p = len(nominal.NUISANCE)
    out = np.zeros((len(lay.rows), p * len(blocks)))
    for j, block in enumerate(blocks):
        out[lay.window == j, p * j:p * j + p] = block
    return out


def evaluate_local(problem: Problem, base_components, effect: Effect, *, shapes, bases=None) -> Evaluation:
    """Score a local term (no parameter carries over) by predicting held-out units.

    Within each trial, units are dealt into :data:`LOCAL_FOLDS` interleaved folds; for each,
    the window nuisance, the base's amplitudes and the term's coefficients are fitted on the
    other units (less a guard around the held-out ones) and predict the held-out units. The base
    is scored the same way, and both scores are returned.
    """
    bases = bases if bases is not None else _base(problem, base_components)
    n_rows = len(problem.fold)
    base_held = np.zeros(n_rows)
    best = {"held": None, "train": np.inf}
    per_shape = {}
    offset = 0
    for i_trial, (b, lay) in enumerate(zip(bases, problem.layouts)):
        rows = lay.rows
        sl = slice(offset, offset + len(rows))
        offset += len(rows)
        t = b.ch.time[rows]
        W = _window_columns(lay, b.ch.angle[0][rows], t)
        base_cols = [W, b.regs] + ([b.local] if b.local is not None else [])
        z = b.ch.elastic_target()[rows]
        fold = lay.unit % LOCAL_FOLDS
        train_masks = []
        for j in range(LOCAL_FOLDS):
            held_t = t[fold == j]
            near = np.zeros(len(rows), dtype=bool)
            if held_t.size:
                pos = np.searchsorted(held_t, t)
                for cand in (np.clip(pos - 1, 0, held_t.size - 1), np.clip(pos, 0, held_t.size - 1)):
                    near |= np.abs(held_t[cand] - t) <= problem.guard_s
            train_masks.append(~near & (fold != j))

        def score(cols):
            X = np.column_stack(cols)
            out = np.zeros(len(rows))
            for j in range(LOCAL_FOLDS):
                tr, te = train_masks[j], fold == j
                coef = _lstsq(X[tr], z[tr])
                out[te] = z[te] - X[te] @ coef
            return out

        base_held[sl] = score(base_cols)
        for i, shape in enumerate(shapes):
            L = _term_rows(problem, i_trial, b, effect, shape)[2]
            L = L[:, np.any(np.abs(L) > 0, axis=0)]
            per_shape.setdefault(i, np.zeros(n_rows))[sl] = score(base_cols + [L])
    # with several shapes the one predicting best is kept (a selection on held-out data: the
    # library gives one)
    scores = {i: float(np.sum(h ** 2)) for i, h in per_shape.items()}
    i_best = min(scores, key=scores.get)
    held = per_shape[i_best]
    shape = shapes[i_best]
    # in-sample fit with the chosen knots (projected space, like the other candidates)
    z, X = _design(problem, bases, effect, shape)
    coef = _lstsq(X, z)
    resid = z - X @ coef
    p_base = bases[0].X.shape[1]
    return Evaluation(effect=effect.name, unit_rss=problem.unit_sum(held ** 2), shape=dict(shape),
                      coef=coef[p_base:], base_coef=coef[:p_base], rss_train=float(resid @ resid),
                      fitted=X[:, p_base:] @ coef[p_base:], residual=resid, fold_shapes=[shape],
                      scheme="interleaved", base_unit_rss=problem.unit_sum(base_held ** 2))
