"""How fine the stiffness's curve is: the knots chosen by held-out prediction of whole units.

For each candidate number of knots (:data:`~.basis.PHASE_KNOTS`, :data:`~.basis.SCHEDULE_KNOTS`)
the model — m, b, the effects in the model and the curve's weights as linear coefficients, the
walk for the rest — has its noise levels fitted by maximum marginal likelihood. Its innovations
are then linear in the coefficients (:func:`~limbstiff.statespace.linear.innovations`): the
coefficients are fitted by weighted least squares (weights 1/S) on the training folds, and the
one-step prediction of the torque is scored, as a Gaussian log density, on the units left out
(:mod:`limbstiff.heldout`). Units are whole cycles for an ensemble, stretches of the record for a
schedule, dealt to :data:`~limbstiff.heldout.FOLDS` folds in turn. Training steps within
:data:`GUARD_CORNER_PERIODS` of a left-out unit are dropped: the zero-phase filter spreads its
torque that far. Pure numpy: no I/O.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from .. import heldout
from ..filtered import Filtered
from ..mechanics.identification import mechanics_problem
from ..mechanics.likelihood import MechanicsFit, kalman_mechanics
from ..statespace.linear import innovations
from .basis import StiffnessBasis

#: Corner periods of training data dropped on each side of a left-out unit.
GUARD_CORNER_PERIODS = 2.0


@dataclass(frozen=True)
class ResolutionScore:
    """The held-out score of one resolution.

    Parameters
    ----------
    knots : int
    score : float
        Held-out log predictive density of the torque, summed over the steps scored.
    per_unit : ndarray, shape (U,)
        Its sum within each unit.
    explained : float
        Share of the held-out innovations' variance (about their mean) the fitted columns explain.
    unit_error : ndarray, shape (U,)
        Each unit's mean squared held-out error in units of the model's own variance S (about 1
        when the unit is like the others).
    model_error : float
        The same over all steps, the coefficients fitted on all of them: what the model expects
        of itself.
    fit : MechanicsFit or None
        The model's maximum-likelihood fit on the identification's problem (its noise levels):
        the identification of the resolution chosen starts from it instead of fitting it again.
    """

    knots: int
    score: float
    per_unit: np.ndarray
    explained: float
    unit_error: np.ndarray
    model_error: float
    fit: MechanicsFit | None = field(default=None, compare=False, repr=False)

    @property
    def heldout_error(self) -> float:
        """Mean squared held-out error over all units, in units of S."""
        return float(np.mean(self.unit_error[np.isfinite(self.unit_error)]))

    def to_dict(self) -> dict:
        return {"knots": self.knots, "heldout_log_density": self.score, "heldout_explained": self.explained,
                "heldout_error": self.heldout_error, "model_error": self.model_error}


@dataclass(frozen=True)
class Resolution:
    """The resolutions tried and the one chosen.

    Parameters
    ----------
    scores : tuple of ResolutionScore
    chosen : int
        The fewest knots within one standard error of the best held-out score
        (:func:`one_standard_error`).
    n_units : int
        Units (cycles or stretches) scored.
    """

    scores: tuple[ResolutionScore, ...]
    chosen: int
    n_units: int

    def score_of(self, knots: int) -> ResolutionScore:
        return next(s for s in self.scores if s.knots == knots)

    def to_dict(self) -> dict:
        return {"chosen_knots": self.chosen, "held_out_units": self.n_units, "folds": heldout.FOLDS,
                "tried": [s.to_dict() for s in self.scores]}


def _settled(unit: np.ndarray, restart: np.ndarray, guard: int) -> np.ndarray:
    """Each step's unit, −1 within ``guard`` steps of the start of a block of the identification's
    steps (the filter restarts there from its diffuse state: its first predictions are not the
    model's)."""
    starts = np.flatnonzero(restart)
    starts = np.concatenate([[0], starts]) if not len(starts) or starts[0] != 0 else starts
    out = unit.copy()
    for s0 in starts:
        out[s0:s0 + max(guard, 1)] = -1
    return out


#: A unit with fewer scored steps than this share of the median unit's (cut by the edges of the
#: identification's blocks) has no error of its own: too few steps to compare with the others.
MIN_UNIT_SHARE = 0.5


def heldout_score(e: np.ndarray, var: np.ndarray, unit: np.ndarray, *, guard: int,
                  folds: int = heldout.FOLDS) -> ResolutionScore:
    """Held-out log density of channel 0 given the others, fitted on the training folds
    (:func:`limbstiff.heldout.regression`).

    Parameters
    ----------
    e : ndarray, shape (c, m)
        Each channel's innovations (channel 0 the torque, the others its linear columns).
    var : ndarray, shape (m,)
        Their common variance S.
    unit : ndarray of int, shape (m,)
        Each step's unit (−1: not scored, not trained on).
    guard : int
        Steps dropped from training on each side of a held-out one.

    Returns
    -------
    ResolutionScore
        Its ``knots`` is 0: the caller's to set.
    """
    folds = heldout.folds_of(unit, heldout.interleaved(unit, folds), guard=guard, n_folds=folds)
    weight = 1.0 / np.sqrt(var)
    scores = heldout.regression(folds, e[0], e[1:].T, weight)
    error = scores.error ** 2 / var
    per_unit = folds.unit_sum(-0.5 * (np.log(2 * np.pi * var) + error))
    steps = folds.unit_sum(np.ones(len(var)))
    with np.errstate(invalid="ignore", divide="ignore"):
        unit_error = folds.unit_sum(error) / steps
    unit_error[steps < MIN_UNIT_SHARE * np.median(steps[steps > 0])] = np.nan
    # what the model expects of itself: the coefficients fitted on every scored step
    _, rss = heldout.fold_fits(e[0] * weight, e[1:].T * weight[:, None], folds.scored[None])
    return ResolutionScore(0, float(per_unit.sum()), per_unit, scores.explained, unit_error,
                           float(rss[0]) / int(folds.scored.sum()))


def choose_resolution(filtered: Filtered, bases: dict[int, StiffnessBasis], columns, unit: np.ndarray, *,
                      given: tuple[float, float] | None = None,
                      effect_columns: np.ndarray | None = None) -> Resolution:
    """The knots whose model predicts held-out units best (module docstring).

    Parameters
    ----------
    filtered : Filtered
        The trial's filtered signals (external variant).
    bases : dict of int to StiffnessBasis
        The candidates, by number of knots.
    columns : callable
        A basis → the torques of its weights per unit weight (k, n), or None for the walk alone.
    unit : ndarray of int, shape (n,)
        The held-out unit of every sample (−1 outside).
    given : (m, b), optional
        When the protocol gives them.
    effect_columns : ndarray, shape (k, n), optional
        The torques of the effects in the model, per unit amplitude.
    """
    scores = []
    corner = filtered.cutoff_hz or filtered.fs / 2
    for knots, basis in sorted(bases.items()):
        extra = [c for c in (effect_columns, columns(basis)) if c is not None and len(c)]
        problem, guess = mechanics_problem(filtered, given=given, extra=np.vstack(extra) if extra else None)
        fit = kalman_mechanics(problem, guess=guess)
        e, var = innovations(problem.steps, fit.noise)
        guard = int(np.ceil(GUARD_CORNER_PERIODS / (corner * problem.steps.step)))
        scored = heldout_score(e, var, _settled(unit[problem.steps.index], problem.steps.restart, guard), guard=guard)
        scores.append(dataclasses.replace(scored, knots=knots, fit=fit))
    return Resolution(tuple(scores), one_standard_error(scores), int(unit.max()) + 1)


def one_standard_error(scores: list[ResolutionScore]) -> int:
    """The fewest knots whose held-out score is within one standard error of the best's (the
    one-standard-error rule of cross-validation: Breiman et al. 1984, Hastie, Tibshirani &
    Friedman 2009, §7.10): differences smaller than the units' own scatter are not evidence of a
    finer curve, and a steady task's cycles must not get one. The standard error is that of the
    sum of the per-unit differences from the best, over the units scored."""
    best = max(scores, key=lambda s: s.score)
    scored = best.per_unit != 0
    for s in sorted(scores, key=lambda s: s.knots):
        diff = (s.per_unit - best.per_unit)[scored]
        se = float(np.std(diff, ddof=1) * np.sqrt(len(diff))) if len(diff) > 1 else 0.0
        if s.score >= best.score - se:
            return s.knots
    return best.knots
