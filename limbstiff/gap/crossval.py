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
from .kinds import Effect

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
                      if e.corrects_channel)
    for ch0, lay in zip(problem.channels, problem.layouts):
        ch, regs, local = compose(ch0, components)
        rows = lay.rows
        loc = _rows_matrix(local, rows) if local else None
        proj = nominal.projector(ch.angle[rows], ch.time[rows], lay, loc)
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
            y = None if term.angle is None else ch.angle[rows]
        regs = None if term.regressors is None else term.regressors[:, rows].T.copy()
        hit = problem.cache[key] = (y, z, regs)
    return hit


def _design(problem, bases, effect: Effect | None, shape, share: list | None = None):
    """Projected target (R,) and regressors (R, p_base + p_effect) of base + effect at shape.

    ``share``, when given, receives per trial the norm of the effect's projected regressors over
    that of its centred raw ones: the part of its torque the elastic nuisance cannot take up."""
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
            projected = proj.project(regs)
            if share is not None:
                raw = np.linalg.norm(regs - regs.mean(0))
                share.append(float(np.linalg.norm(projected) / raw) if raw > 0 else 0.0)
            X = np.column_stack([X, projected])
        zs.append(z)
        Xs.append(X)
    return np.concatenate(zs), np.vstack(Xs)


def _fold_fits(z: np.ndarray, X: np.ndarray, weights: np.ndarray):
    """Least squares on several row subsets at once, by the normal equations.

    Parameters
    ----------
    z : ndarray, shape (R,)
    X : ndarray, shape (R, p)
    weights : ndarray of bool, shape (K, R)
        Rows of each fit.

    Returns
    -------
    coef : ndarray, shape (K, p)
    rss : ndarray, shape (K,)
        Residual sums of squares on the rows of each fit.
    """
    w = weights.astype(float)
    zz = w @ (z * z)
    p = X.shape[1]
    if p == 0:
        return np.zeros((len(w), 0)), zz
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    Xs = X / scale
    gram = np.einsum("kr,rp,rq->kpq", w, Xs, Xs, optimize=True)
    rhs = (w * z) @ Xs
    coef_s = np.einsum("kpq,kq->kp", np.linalg.pinv(gram, rcond=1e-10, hermitian=True), rhs)
    rss = zz - np.einsum("kp,kp->k", coef_s, rhs)
    return coef_s / scale, np.maximum(rss, 0.0)


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
    absorbed : bool
        The effect's torque lies (to :data:`ABSORBED_SHARE`) within the elastic nuisance: not fitted.
    share : float or None
        Largest share of the effect's torque the nuisance cannot take up, over its shapes.
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
    absorbed: bool = False
    share: float | None = None


#: Share of an effect's torque (norm of its part the elastic nuisance cannot take up, over its
#: own) below which the effect is *absorbed*: indistinguishable from the elastic torque in these
#: data (a torque that depends on the angle alone, such as gravity over a small range). Its
#: amplitude would be fitted on the 1 % residue — numerical and noise remnants — so it is not
#: fitted (−40 dB).
ABSORBED_SHARE = 0.01


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
    masks = problem.cache.get("fold_masks")
    if masks is None:
        masks = problem.cache["fold_masks"] = (np.vstack([problem.training, np.ones((1, len(problem.fold)), bool)]),
                                               [problem.fold == j for j in range(k)])
    weights, tests = masks
    best_train = np.full(k, np.inf)
    held = np.zeros(len(problem.fold))
    fold_shapes = [None] * k
    best_all = (np.inf, None, None)
    best_share = 0.0
    for shape in (shapes if effect is not None else [{}]):
        share = []
        z, X = _design(problem, bases, effect, shape, share)
        best_share = max([best_share] + share)
        coefs, rss = _fold_fits(z, X, weights)
        for j in np.flatnonzero(rss[:k] < best_train):
            best_train[j] = rss[j]
            te = tests[j]
            held[te] = z[te] - X[te] @ coefs[j]
            fold_shapes[j] = shape
        if rss[k] < best_all[0]:
            best_all = (rss[k], shape, coefs[k])
    rss, shape, coef = best_all
    z, X = _design(problem, bases, effect, shape)
    resid = z - X @ coef
    absorbed = effect is not None and X.shape[1] > p_base and best_share < ABSORBED_SHARE
    if absorbed:            # not fitted: score it as the base model
        base = evaluate(problem, base_components, bases=bases)
        return Evaluation(effect=effect.name, unit_rss=base.unit_rss, shape=dict(shape),
                          coef=np.full(X.shape[1] - p_base, np.nan), base_coef=base.base_coef,
                          rss_train=base.rss_train, fitted=np.zeros(len(z)), residual=base.residual,
                          fold_shapes=[], absorbed=True, share=best_share)
    return Evaluation(effect=None if effect is None else effect.name, unit_rss=problem.unit_sum(held ** 2),
                      shape=dict(shape), coef=coef[p_base:], base_coef=coef[:p_base], rss_train=float(rss),
                      fitted=X[:, p_base:] @ coef[p_base:], residual=resid, fold_shapes=fold_shapes,
                      share=best_share)


def interleaved(problem: Problem) -> Problem:
    """The same rows dealt into :data:`LOCAL_FOLDS` interleaved folds of whole units (unit i of a
    trial in fold i mod 5), with the guard kept out of training around every held-out unit."""
    hit = problem.cache.get("interleaved")
    if hit is not None:
        return hit
    fold = np.concatenate([lay.unit % LOCAL_FOLDS for lay in problem.layouts])
    times = np.concatenate([c.time[lay.rows] for c, lay in zip(problem.channels, problem.layouts)])
    training = np.ones((LOCAL_FOLDS, len(fold)), dtype=bool)
    for j in range(LOCAL_FOLDS):
        training[j] = fold != j
        for i in range(len(problem.layouts)):
            sel = problem.trial == i
            t, held = times[sel], times[sel & (fold == j)]
            if held.size == 0:
                continue
            pos = np.searchsorted(held, t)
            near = np.zeros(len(t), dtype=bool)
            for cand in (np.clip(pos - 1, 0, held.size - 1), np.clip(pos, 0, held.size - 1)):
                near |= np.abs(held[cand] - t) <= problem.guard_s
            training[j, sel] &= ~near
    out = Problem(channels=problem.channels, layouts=problem.layouts, scheme="interleaved", guard_s=problem.guard_s,
                  fold=fold, unit=problem.unit, trial=problem.trial, deviation=problem.deviation,
                  training=training, cache={k: v for k, v in problem.cache.items() if k != "fold_masks"})
    problem.cache["interleaved"] = out
    return out


def evaluate_local(problem: Problem, base_components, effect: Effect, *, shapes, bases=None) -> Evaluation:
    """Score a local term (no parameter carries over: a drift spline) by predicting held-out units.

    The elastic nuisance is refitted on all the data, as for every model; the term's
    coefficients (and the base's amplitudes) are fitted on four units in five and predict the
    fifth (:func:`interleaved`). The base model is scored the same way, and both are returned.
    """
    inter = interleaved(problem)
    bases = bases if bases is not None else _base(problem, base_components)
    base = evaluate(inter, base_components, bases=bases)
    ev = evaluate(inter, base_components, effect, shapes=shapes, bases=bases)
    ev.scheme = "interleaved"
    ev.base_unit_rss = base.unit_rss
    return ev
