"""Trial-level figures of the stiffness with their intervals: what studies compare across conditions.

* ``median_stiffness``: the median of the stiffness course over the informed samples;
* ``stiffness_at_mean_torque``: the straight line of stiffness against background torque (the
  torque's moving average over a few motion periods, as in the stiffness–torque relations of
  Hunter & Kearney 1982, J. Biomech. 15:747), at the trial's mean background torque;
* ``stiffness_torque_slope``: that line's slope, 1/rad (1/m): how much stiffer per N·m.

Each interval is the central interval of the figure over joint draws of the course (the
Kalman smoother's joint posterior, :mod:`limbstiff.estimate.course_draws`, plus draws of inertia
and damping carried through the estimate's sensitivity): not the median of the per-sample band's
limits, which is no interval of anything. With the Kalman estimator the course is the stiffness
with its change with the angle within the motion cycle, which the smoothed course averages away
(:mod:`limbstiff.estimate.angle_terms`), its coefficients drawn too. Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import uniform_filter1d

from .interval import Interval

#: Seconds at the start of a trial left out of the error against a reference (the estimators'
#: start-up transient).
REFERENCE_SKIP_S = 2.0

#: Background torque: the torque's moving average over this many motion periods.
BACKGROUND_PERIODS = 4.0
#: Course draws for the trial-level intervals: the 5 % and 95 % quantiles of 400 draws have a
#: standard error of about 0.11 standard deviations of the figure (binomial, √(0.05·0.95/400)/φ(1.645)).
COURSE_DRAWS = 400
#: Long trials get fewer draws, so that the draws cost at most this many step-passes (400 draws up to
#: 50 000 filter steps, a few minutes of data), but never fewer than :data:`MIN_COURSE_DRAWS`: with
#: 100 the quantiles' standard error is 0.22 standard deviations of the figure. A figure of a long
#: trial averages over many samples, so its interval is set by m and b more than by the course.
COURSE_WORK, MIN_COURSE_DRAWS = 20_000_000, 100
#: The figures are taken on at most this many evenly spaced filter steps (their medians and slopes
#: do not change beyond their intervals' precision; the draws keep memory at one pass).
FIGURE_STEPS = 5000


def course_draws_for(steps: int) -> int:
    """How many course draws a trial of ``steps`` filter steps gets (:data:`COURSE_WORK`)."""
    return int(min(COURSE_DRAWS, max(MIN_COURSE_DRAWS, COURSE_WORK // max(steps, 1))))


def figure_columns(steps: int) -> np.ndarray:
    """Indices of the (at most :data:`FIGURE_STEPS`) evenly spaced steps the figures use."""
    return np.unique(np.linspace(0, steps - 1, min(steps, FIGURE_STEPS)).astype(int))

FIGURES = ("median_stiffness", "stiffness_at_mean_torque", "stiffness_torque_slope")
#: What each figure is, in words for the report and the JSON.
WORDS = {
    "median_stiffness": "median of the stiffness over the samples informed by motion",
    "stiffness_at_mean_torque": "stiffness on the straight line of stiffness against background torque, at the "
                                "trial's mean background torque",
    "stiffness_torque_slope": "slope of that line: change of stiffness per unit of background torque",
}
#: Added to each meaning when the course includes the change with the angle (source ``"angle"``).
ANGLE_WORDS = "; the stiffness with its change with the angle within the motion cycle"


@dataclass(frozen=True)
class TrialLevel:
    """Trial-level figures, each an :class:`Interval` at ``level``.

    Parameters
    ----------
    median_stiffness : Interval, N·m/rad (N/m)
    stiffness_at_mean_torque : Interval, N·m/rad (N/m)
    stiffness_torque_slope : Interval, 1/rad (1/m)
        NaN when the background torque does not vary over the informed samples.
    level : float
    draws : int
        Course draws the intervals come from.
    sources : tuple of str
        What the draws vary: ``"course"`` (the smoother's joint posterior), ``"angle"`` (the
        stiffness's change with the angle within the cycle, :mod:`limbstiff.estimate.angle_terms`),
        ``"mechanics"`` (m, b).
    course : ndarray, shape (c,), N·m/rad (N/m), optional
        The course the figures are taken over, at the samples ``index`` (c,) (the model's steps,
        thinned), ``informed`` (c,) marking those the figures use: what page 1 draws per motion
        cycle (:func:`limbstiff.digest.cycle_course`), so that its median lies within the drawing.
    """

    median_stiffness: Interval
    stiffness_at_mean_torque: Interval
    stiffness_torque_slope: Interval
    level: float
    draws: int
    sources: tuple[str, ...]
    course: np.ndarray | None = field(default=None, compare=False, repr=False)
    index: np.ndarray | None = field(default=None, compare=False, repr=False)
    informed: np.ndarray | None = field(default=None, compare=False, repr=False)

    def to_dict(self) -> dict:
        extra = ANGLE_WORDS if "angle" in self.sources else ""
        out = {name: dict(getattr(self, name).to_dict(), meaning=WORDS[name] + extra) for name in FIGURES}
        out.update(ci_level=self.level, draws=self.draws, uncertainty_from=list(self.sources))
        return out


def background_torque(torque: np.ndarray, *, step: float, motion_frequency: float) -> np.ndarray:
    """The torque's moving average over :data:`BACKGROUND_PERIODS` motion periods, N·m (N).

    Parameters
    ----------
    torque : ndarray, shape (m,), at steps ``step`` s apart
    step : float, s
    motion_frequency : float, Hz
    """
    width = int(round(BACKGROUND_PERIODS / (motion_frequency * step))) if motion_frequency > 0 else len(torque)
    return uniform_filter1d(np.asarray(torque, dtype=float), max(1, min(width, len(torque))), mode="nearest")


@dataclass(frozen=True)
class FigureSamples:
    """The samples the trial-level figures are computed over.

    Parameters
    ----------
    columns : ndarray of int, shape (c,)
        Which of the model's steps are kept (:func:`figure_columns`).
    index : ndarray of int, shape (c,)
        The sample of each kept step.
    torque : ndarray, shape (c,), N·m (N)
        Background torque there (:func:`background_torque`).
    informed : ndarray of bool, shape (c,)
        Informed by motion; all True when fewer than 3 are (the figures then use every sample).
    """

    columns: np.ndarray
    index: np.ndarray
    torque: np.ndarray
    informed: np.ndarray


def figure_samples(steps: np.ndarray, torque: np.ndarray, observable: np.ndarray, *, step: float,
                   motion_frequency: float) -> FigureSamples:
    """The samples of the figures: the model's steps thinned, with their background torque.

    Parameters
    ----------
    steps : ndarray of int, shape (m,)
        Sample of each model step (:func:`~limbstiff.statespace.steps.step_index`).
    torque : ndarray, shape (n,), N·m (N)
        The recorded (filtered) torque at every sample.
    observable : ndarray of bool, shape (n,)
    step : float, s
        Time between model steps.
    motion_frequency : float, Hz

    Returns
    -------
    FigureSamples
    """
    columns = figure_columns(len(steps))
    background = background_torque(np.asarray(torque)[steps], step=step, motion_frequency=motion_frequency)
    index = steps[columns]
    informed = observable[index]
    if np.count_nonzero(informed) < 3:
        informed = np.ones(len(index), dtype=bool)
    return FigureSamples(columns, index, background[columns], informed)


def figures_of(course: np.ndarray, torque: np.ndarray) -> np.ndarray:
    """(median, at mean torque, slope) of each course (k, m) over samples with torque (m,): (k, 3)."""
    tc = torque - torque.mean()
    spread = float(tc @ tc)
    mean = course.mean(axis=1)
    slope = (course - mean[:, None]) @ tc / spread if spread > 0 else np.full(len(course), np.nan)
    return np.column_stack([np.median(course, axis=1), mean, slope])


def trial_level(estimate: np.ndarray, draws: np.ndarray, torque: np.ndarray, *, level: float,
                sources: tuple[str, ...]) -> TrialLevel:
    """The trial-level figures of an estimate and their intervals over draws of the course.

    Parameters
    ----------
    estimate : ndarray, shape (m,), N·m/rad (N/m)
        The stiffness at the informed samples used (for example the model's steps).
    draws : ndarray, shape (k, m)
        Joint draws of the course at the same samples.
    torque : ndarray, shape (m,), N·m (N)
        Background torque there (:func:`background_torque`).
    level : float
    sources : tuple of str

    Returns
    -------
    TrialLevel
    """
    point = figures_of(estimate[None, :], torque)[0]
    spread = figures_of(draws, torque)
    lo, hi = np.quantile(spread, [0.5 - level / 2, 0.5 + level / 2], axis=0)
    # the figure's own bias (draws centred on the estimate, not on the figure): intervals about
    # the point estimate, widths from the draws
    centre = np.median(spread, axis=0)
    ivs = [Interval(float(p), float(p - (c - a)), float(p + (b - c))) for p, a, b, c in zip(point, lo, hi, centre)]
    return TrialLevel(*ivs, level=level, draws=len(draws), sources=sources)
