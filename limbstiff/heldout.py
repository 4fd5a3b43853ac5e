"""Held-out evaluation, written once: whole units dealt to folds, a guard around what a fold
leaves out, and each fold's prediction scored on the steps it did not see.

A *unit* is a stretch of steps left out whole — a motion cycle, a stretch of a schedule, a block
of motion periods — so that a fold holds the excursions that reveal the stiffness, not a fragment
its neighbours explain. Units are dealt to the folds in turn (:func:`interleaved`, every fold
spans the record) or in contiguous blocks (:func:`contiguous`). Training steps within a *guard*
of a left-out step are not trained on: a zero-phase filter spreads a sample's torque over about
two corner periods, and training beside a left-out step would see it. The guard is the caller's,
in steps: each user knows its filter. A model is fitted on each fold's training steps and
predicts its left-out steps (:func:`score`); when it is a linear regression on the model's
innovations, weighted by 1/S, :func:`regression` fits every fold at once. Pure numpy: no I/O.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

#: Folds of a held-out evaluation: each leaves out a fifth of the units and trains on the rest.
FOLDS = 5


@dataclass(frozen=True)
class Folds:
    """Which steps each fold leaves out and which it trains on.

    Parameters
    ----------
    unit : ndarray of int, shape (m,)
        Each step's unit (−1: neither scored nor trained on).
    fold : ndarray of int, shape (m,)
        Each step's fold (−1 where ``unit`` is).
    training : ndarray of bool, shape (K, m)
        The steps fold k trains on: every scored step but its own and those within the guard.
    """

    unit: np.ndarray
    fold: np.ndarray
    training: np.ndarray

    @property
    def n_folds(self) -> int:
        return self.training.shape[0]

    @property
    def n_units(self) -> int:
        return int(self.unit.max()) + 1

    @property
    def scored(self) -> np.ndarray:
        return self.unit >= 0

    def held(self, k: int) -> np.ndarray:
        """The steps fold ``k`` leaves out, bool (m,)."""
        return self.fold == k

    def unit_sum(self, values: np.ndarray) -> np.ndarray:
        """Sum of per-step ``values`` (m,) within each unit, shape (U,)."""
        s = self.scored
        return np.bincount(self.unit[s], weights=values[s], minlength=self.n_units)


def interleaved(unit: np.ndarray, n_folds: int) -> np.ndarray:
    """Each step's fold, units dealt to ``n_folds`` folds in turn (unit u to fold u mod K); −1
    where ``unit`` is −1."""
    return np.where(unit >= 0, unit % n_folds, -1)


def contiguous(unit: np.ndarray, n_folds: int) -> np.ndarray:
    """Each step's fold, the units (0…U−1) in min(``n_folds``, U) contiguous blocks of whole units
    as equal as they can be (the first blocks one unit longer); −1 where ``unit`` is −1."""
    n_units = int(unit.max()) + 1
    block = np.zeros(max(n_units, 0), dtype=int)
    for k, units in enumerate(np.array_split(np.arange(n_units), min(n_folds, n_units))):
        block[units] = k
    return np.where(unit >= 0, block[np.maximum(unit, 0)], -1)


def near(mask: np.ndarray, guard: int) -> np.ndarray:
    """Steps within ``guard`` steps of a True step of ``mask`` (those included), bool (m,)."""
    if guard <= 0:
        return mask
    count = np.concatenate([[0], np.cumsum(mask, dtype=np.int64)])
    i = np.arange(len(mask))
    return count[np.minimum(i + guard + 1, len(mask))] - count[np.maximum(i - guard, 0)] > 0


def folds_of(unit: np.ndarray, fold: np.ndarray, *, guard: int, n_folds: int | None = None) -> Folds:
    """The :class:`Folds` of steps whose units and folds are given.

    Parameters
    ----------
    unit, fold : ndarray of int, shape (m,)
        Each step's unit and fold (:func:`interleaved`, :func:`contiguous`); −1: not scored.
    guard : int
        Steps on each side of a left-out step that its fold does not train on.
    n_folds : int, optional
        Folds (default: the largest fold + 1); a fold that leaves nothing out trains on every
        scored step.
    """
    n_folds = int(fold.max()) + 1 if n_folds is None else n_folds
    scored = unit >= 0
    training = np.stack([scored & ~near(fold == k, guard) for k in range(n_folds)]) if n_folds else \
        np.zeros((0, len(unit)), dtype=bool)
    return Folds(unit=unit, fold=fold, training=training)


def joined(parts: Sequence[Folds]) -> Folds:
    """Several records' folds side by side (trials pooled): fold k leaves out fold k of each, their
    units numbered on; the guard stays within each record."""
    offsets = np.cumsum([0] + [p.n_units for p in parts[:-1]])
    return Folds(unit=np.concatenate([np.where(p.scored, p.unit + o, -1) for p, o in zip(parts, offsets)]),
                 fold=np.concatenate([p.fold for p in parts]),
                 training=np.hstack([p.training for p in parts]))


@dataclass(frozen=True)
class Scores:
    """A model's held-out prediction errors, fold by fold.

    Parameters
    ----------
    error : ndarray, shape (m,)
        Each left-out step's error, target less prediction (the target's unit); 0 on steps no
        fold scored.
    rss : ndarray, shape (K,)
        Sum of squared errors over each fold's left-out steps.
    spread : ndarray, shape (K,)
        Sum of squared deviations of the target from its mean over each fold's left-out steps.
    """

    error: np.ndarray
    rss: np.ndarray
    spread: np.ndarray

    @property
    def explained(self) -> float:
        """Share of the left-out target's variance (about each fold's mean) the predictions explain."""
        return 1.0 - float(np.sum(self.rss)) / max(float(np.sum(self.spread)), 1e-300)


def score(folds: Folds, target: np.ndarray, predict: Callable[[int], np.ndarray], *,
          which: Sequence[int] | None = None) -> Scores:
    """Each fold's prediction of its left-out steps, scored.

    Parameters
    ----------
    folds : Folds
    target : ndarray, shape (m,)
        What is predicted.
    predict : callable
        Fold k → the prediction (h,) on its left-out steps (``folds.held(k)``), made from its
        training steps (``folds.training[k]``) alone.
    which : sequence of int, optional
        The folds scored (default all); the others' steps keep error 0.
    """
    error = np.zeros(len(target))
    rss, spread = np.zeros(folds.n_folds), np.zeros(folds.n_folds)
    for k in range(folds.n_folds) if which is None else which:
        held = folds.held(k)
        if not held.any():
            continue
        error[held] = target[held] - predict(k)
        rss[k] = float(error[held] @ error[held])
        spread[k] = float(np.sum((target[held] - target[held].mean()) ** 2))
    return Scores(error, rss, spread)


def regression(folds: Folds, target: np.ndarray, columns: np.ndarray, weight: np.ndarray, *,
               which: Sequence[int] | None = None, blocks=()) -> Scores:
    """:func:`score` of a linear regression fitted by weighted least squares on each fold's
    training steps (:func:`fold_fits`).

    Parameters
    ----------
    target : ndarray, shape (m,)
    columns : ndarray, shape (m, p)
    weight : ndarray, shape (m,)
        Each step's weight on its residual, 1/√S for innovations of variance S.
    which : sequence of int, optional
        The folds fitted and scored (default all).
    blocks : sequence of (slice, ndarray of int), optional
        As :func:`fold_fits`.
    """
    which = list(range(folds.n_folds)) if which is None else list(which)
    coef, _ = fold_fits(target * weight, columns * weight[:, None], folds.training[which], blocks)
    fitted = dict(zip(which, coef))
    return score(folds, target, lambda k: columns[folds.held(k)] @ fitted[k], which=which)


def fold_fits(z: np.ndarray, X: np.ndarray, rows: np.ndarray, blocks=()) -> tuple[np.ndarray, np.ndarray]:
    """Least squares on several row subsets at once, by the normal equations.

    Parameters
    ----------
    z : ndarray, shape (R,)
    X : ndarray, shape (R, p)
    rows : ndarray of bool, shape (K, R)
        Rows of each fit.
    blocks : sequence of (slice, ndarray of int), optional
        Row blocks and the only columns not zero on them (each trial's own and the shared ones):
        the normal equations are summed block by block, which with several trials costs a small
        fraction of the dense product.

    Returns
    -------
    coef : ndarray, shape (K, p)
    rss : ndarray, shape (K,)
        Residual sums of squares on the rows of each fit.
    """
    w = rows.astype(float)
    zz = w @ (z * z)
    p = X.shape[1]
    if p == 0:
        return np.zeros((len(w), 0)), zz
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    Xs = X / scale
    gram = _gram(Xs, w, blocks or ((slice(None), np.arange(p)),))
    rhs = (w * z) @ Xs
    coef_s = np.einsum("kpq,kq->kp", np.linalg.pinv(gram, rcond=1e-10, hermitian=True), rhs)
    rss = zz - np.einsum("kp,kp->k", coef_s, rhs)
    return coef_s / scale, np.maximum(rss, 0.0)


def _gram(X: np.ndarray, w: np.ndarray, blocks) -> np.ndarray:
    """Σ_r w_kr·x_r·x_rᵀ for each row subset k (K, p, p), block by block; one BLAS product per
    subset and block (several times faster than one einsum over all of them)."""
    gram = np.zeros((len(w), X.shape[1], X.shape[1]))
    for rows, cols in blocks:
        xb = X[rows][:, cols]
        idx = np.ix_(cols, cols)
        for k, wk in enumerate(w[:, rows]):
            gram[k][idx] += xb.T @ (wk[:, None] * xb)
    return gram
