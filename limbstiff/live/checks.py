"""The checks a live estimate can make causally, one that looks back, and the verdict code it publishes.

Over the last :data:`WINDOW_PERIODS` motion periods of model steps (at least :data:`WINDOW_MIN_S`):

* motion — the share of samples the data inform (the band not 3× its typical width): below
  :data:`~limbstiff.checks.verdict.MOTION_MIN` the verdict is ``caution`` (the offline analysis warns there);
* torque explained — 1 − Σe²/Σ(z − z̄)², e the one-step prediction errors of z = f − m·ÿ − b·ẏ: the
  offline held-out thresholds (:data:`~limbstiff.checks.verdict.HELDOUT_CAUTION`,
  :data:`~limbstiff.checks.verdict.HELDOUT_UNRELIABLE`). A one-step prediction is easier than the
  offline check's whole held-out periods, so this flags only what the offline check flags too;
* noise — the standardised prediction errors are white when the model is right: their largest
  |autocorrelation| at lags 1–10 steps above :data:`~limbstiff.checks.verdict.WHITENESS_MAX` is ``caution``,
  unless they leave less than :data:`~limbstiff.checks.verdict.NEGLIGIBLE_RESIDUAL` of z's variance
  (a noise-free simulation: their structure is the integration's own error, as offline);
* tracking — a stiffness that changes faster than the live estimate follows leaves its one-step
  prediction errors proportional to the angle's increments, e ≈ (σ − σ̂)·Δy: their least-squares
  slope on Δy over the window, β, is what the estimate misses. |β| over the band's median
  half-width and over :data:`TRACKING_Z` standard errors (√(ΣS·Δy²)/ΣΔy², the errors independent
  with variance S) is ``caution``: the estimate lags and its band is too narrow there;
* changing — the estimate has moved by more than its band's half-width over its memory (two
  motion periods; now against a memory ago), or has swung by more than its band's width within it
  (its range over the memory, largest minus smallest: :data:`SWING_HALF_WIDTHS` half-widths, bands
  that far apart cannot both have held a stiffness that stayed put): the stiffness is changing,
  and a causal estimate lags a change by a good part of its memory, which its band does not hold:
  ``caution``. The swing sees a stiffness that swings back within the memory, which the ends miss
  (issue 46: where the band missed on samples said ``ok`` on the independent simulator,
  benchmarks/RESULTS.md#live).
  It cannot help where the live model itself is off;
* settling — until the estimate has run for its memory (after its start, a break, or a new
  model's other steps) whether it is changing cannot be told, and a fresh estimate is still
  converging: ``caution``, not ``ok`` on checks that judged nothing;
* hindsight — each identification and noise refit also smooths its record as the offline
  analysis does (zero-phase filtered, the identification's m, b and noise levels), which does not
  lag. Over one checks window (:func:`window_s`) ending a memory and the filter's edge before its
  record's end, the share of the informed published samples whose band missed that smoothed
  course is compared with what a calibrated band allows (:attr:`Hindsight.limit`); above it,
  ``caution`` until a later look back says otherwise: the band has been too narrow. It looks back
  (by the memory and the edge, and the refit's spacing), which no causal check can; where the
  smoother is off as well it cannot tell, and a slow motion (a long window and memory) leaves a
  short record no look back at all;
* the band — median width over |median stiffness| above :data:`~limbstiff.checks.verdict.BAND_WIDTH_MAX`
  is ``caution``, above :data:`~limbstiff.checks.verdict.BAND_ZERO_MAX` ``unreliable``; a share of
  negative stiffness above :data:`~limbstiff.checks.verdict.NEGATIVE_SHARE_MAX` is ``unreliable``.

The offline analysis run on the recording when the session ends makes every check. How often the
band holds the truth on the samples said ``ok``, with and without these checks, and where they fall
short: benchmarks/RESULTS.md#live (read in docs/benchmarks.md#live). Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks.model import WHITENESS_LAGS, largest_autocorrelation
from ..checks.verdict import (BAND_WIDTH_MAX, BAND_ZERO_MAX, CAUTION, HELDOUT_CAUTION, HELDOUT_UNRELIABLE, MOTION_MIN,
                              NEGATIVE_SHARE_MAX, NEGLIGIBLE_RESIDUAL, NO_ESTIMATE, UNRELIABLE, WHITENESS_MAX,
                              Verdict)

#: The estimate's range over its memory, in half-widths of its band now, above which it is
#: ``changing`` although its ends agree: the band's width — two bands within the memory further
#: apart than that cannot both hold a stiffness that stayed put. (One half-width, the ends' limit,
#: fired on the estimate's own noise on a third of the checks of a constant stiffness.) Chosen on
#: suite seeds 7100 and 7200 of the independent simulator, verified on 7300 and 7400
#: (docs/benchmarks.md, "Live and independent trials: coverage among ok").
SWING_HALF_WIDTHS = 2.0
#: Standard errors |β| must exceed for the tracking check (a two-sided test at 0.27 %; not fitted).
TRACKING_Z = 3.0
#: The window the checks look back over, in motion periods, and at least this many seconds.
WINDOW_PERIODS, WINDOW_MIN_S = 10.0, 5.0
#: What each failed check means for the live estimate, in plain words (the status line, ``stream.json``).
REASONS = {
    "settling": "the estimate has not yet run for its memory: whether the stiffness is changing cannot be told yet",
    "motion": "the motion informs less than half of the recent samples",
    "torque_explained": "the model explains little of the torque",
    "tracking": "the stiffness changes faster than the live estimate follows: its band is too narrow",
    "changing": "the stiffness is changing: the live estimate lags it and its band may not hold it",
    "hindsight": "looking back, the band missed the smoothed course more often than it should",
    "noise": "the prediction errors are not white: the model misses part of the torque",
    "band_width": "the band is wide against the stiffness",
    "negative_stiffness": "the estimate is negative on part of the recent samples",
}
#: Codes of the ``verdict`` channel and what they mean: no estimate yet (warming up), then each
#: :class:`~limbstiff.checks.verdict.Verdict`'s code.
VERDICT_NAMES = {NO_ESTIMATE: "no estimate yet", **{v.code: v.value for v in Verdict}}
#: Lags of the whiteness statistic, as offline; a window is judged once it holds more than twice as many steps.
LAGS = WHITENESS_LAGS
#: Binomial standard errors the hindsight share may exceed 1 − ci_level by (one-sided 2.3 %; not fitted).
HINDSIGHT_Z = 2.0
#: The fewest independent comparisons (span over two memories) the hindsight check judges.
HINDSIGHT_MIN_MEMORIES = 2.0


def window_s(motion_hz: float) -> float:
    """The checks' window, s: :data:`WINDOW_PERIODS` motion periods, at least :data:`WINDOW_MIN_S`."""
    return max(WINDOW_PERIODS / motion_hz, WINDOW_MIN_S)


@dataclass(frozen=True)
class LiveChecks:
    """The live checks over the last window.

    Parameters
    ----------
    motion : float
        Share of the window's samples informed by the data (NaN for an empty window).
    explained : float
        Share of z's variance the one-step prediction explains (NaN without steps).
    tracking : float
        β over the band's median half-width (NaN without steps).
    moved : float
        How far the estimate moved over its memory (now against a memory ago), in half-widths of
        its band now (NaN before the estimate has run for its memory: then ``settling``).
    swing : float
        Its range within the memory, in the same half-widths (NaN as ``moved``).
    whiteness : float
        Largest |autocorrelation| of the standardised prediction errors, lags 1–10 steps.
    band_width : float
        Median band width over |median stiffness|.
    negative_share : float
        Share of informed samples with a negative stiffness.
    hindsight : Hindsight or None
        The last look back (an identification's or a noise refit's) that could be judged; None
        before one could.
    verdict : Verdict
        ``ok``, ``caution`` or ``unreliable`` (its :attr:`~Verdict.code` is published).
    failed : tuple of str
        The names of the failed checks.
    """

    motion: float
    explained: float
    tracking: float
    moved: float
    swing: float
    whiteness: float
    band_width: float
    negative_share: float
    hindsight: "Hindsight | None"
    verdict: Verdict
    failed: tuple[str, ...]


@dataclass(frozen=True)
class Hindsight:
    """The published band against the smoothed stiffness of the same record.

    Parameters
    ----------
    outside : float
        Share of the informed published samples whose band misses the smoothed course.
    samples : int
        Samples compared.
    independent : float
        About how many independent comparisons they are: their span (their number, when fewer)
        over two memories (the causal estimate's errors are correlated over its memory).
    ci_level : float
        The band's level.
    """

    outside: float
    samples: int
    independent: float
    ci_level: float

    @property
    def limit(self) -> float:
        """The share outside above which the band is too narrow: a calibrated band misses the
        truth on 1 − ci_level of the samples (the smoothed course, closer to the causal one than
        the truth, on fewer), plus :data:`HINDSIGHT_Z` binomial standard errors over
        :attr:`independent` comparisons."""
        p = 1.0 - self.ci_level
        return p + HINDSIGHT_Z * float(np.sqrt(p * (1.0 - p) / max(self.independent, 1.0)))

    @property
    def too_narrow(self) -> bool:
        return self.outside > self.limit

    def to_dict(self) -> dict:
        return {"outside": self.outside, "limit": self.limit, "samples": self.samples,
                "independent": self.independent, "too_narrow": self.too_narrow}


def hindsight(smoothed: np.ndarray, lo: np.ndarray, hi: np.ndarray, *, memory_samples: int,
              ci_level: float) -> Hindsight | None:
    """How often the published band missed the smoothed course (:class:`Hindsight`).

    Parameters
    ----------
    smoothed : ndarray, shape (n,), N·m/rad (N/m)
        The smoothed stiffness at the samples compared.
    lo, hi : ndarray, shape (n,)
        The band published at the same samples; NaN where none was or the data did not inform it.
    memory_samples : int
        The live estimate's memory in samples.
    ci_level : float

    Returns
    -------
    Hindsight or None
        None with fewer than :data:`HINDSIGHT_MIN_MEMORIES` independent comparisons.
    """
    use = np.flatnonzero(np.isfinite(lo) & np.isfinite(hi) & np.isfinite(smoothed))
    if not len(use):
        return None
    # a span with gaps in it (intermittent motion) holds no more comparisons than its samples
    independent = min(use[-1] - use[0] + 1, len(use)) / (2.0 * max(memory_samples, 1))
    if independent < HINDSIGHT_MIN_MEMORIES:
        return None
    miss = (smoothed[use] < lo[use]) | (smoothed[use] > hi[use])
    return Hindsight(outside=float(miss.mean()), samples=int(len(use)), independent=float(independent),
                     ci_level=float(ci_level))


def _whiteness(standardised: np.ndarray) -> float:
    """The offline whiteness statistic (:func:`~limbstiff.checks.model.largest_autocorrelation`) of
    the window's standardised prediction errors (NaN on too few, or on a constant)."""
    sd = float(standardised.std())
    if len(standardised) <= 2 * LAGS or not sd > 0:
        return float("nan")
    return largest_autocorrelation((standardised - standardised.mean()) / sd, len(standardised))


def _tracking(innovation, innovation_variance, angle, half_width) -> tuple[float, float]:
    """β / half-width and β's z (NaN when the window has too few steps or no motion)."""
    if len(angle) <= 2 * LAGS or not half_width > 0:
        return float("nan"), float("nan")
    d = np.diff(angle)
    dd = float(d @ d)
    if dd <= 0:
        return float("nan"), float("nan")
    beta = float(innovation[1:] @ d) / dd
    se = float(np.sqrt(innovation_variance[1:] @ (d * d))) / dd
    return abs(beta) / half_width, abs(beta) / se if se > 0 else float("inf")


def _moved(recent: np.ndarray | None, half_now: float) -> tuple[float, float]:
    """How far the estimate moved over its memory, and its range within it: ``recent`` (the estimate
    published over its last memory, per sample; NaN where none was) end against start, and largest
    minus smallest, over ``half_now``, its band's half-width now. NaN when not measurable: not asked
    for, the estimate did not exist a memory ago, or the band is empty."""
    if recent is None or not len(recent) or not np.isfinite(recent[0]) or not half_now > 0:
        return float("nan"), float("nan")
    return (abs(float(recent[-1] - recent[0])) / half_now,
            float(np.nanmax(recent) - np.nanmin(recent)) / half_now)


def _severity(*, motion: float, explained: float, tracking: float, z: float, moved: float, swing: float,
              judged: bool,
              looked_back: Hindsight | None, white: float, width: float, negative: float) -> dict[str, Verdict]:
    """The failed checks' severities, by name, in the order :attr:`LiveChecks.failed` lists them
    (the figures as :func:`live_checks` measures them; a NaN fails nothing but ``settling``:
    ``judged`` False when the ``changing`` check was asked for and could not be made)."""
    severity = {}
    if not judged:
        severity["settling"] = CAUTION
    if motion < MOTION_MIN:
        severity["motion"] = CAUTION
    if explained < HELDOUT_UNRELIABLE:
        severity["torque_explained"] = UNRELIABLE
    elif explained < HELDOUT_CAUTION:
        severity["torque_explained"] = CAUTION
    if tracking > 1.0 and z > TRACKING_Z:
        severity["tracking"] = CAUTION
    if moved > 1.0 or swing > SWING_HALF_WIDTHS:
        severity["changing"] = CAUTION
    if looked_back is not None and looked_back.too_narrow:
        severity["hindsight"] = CAUTION
    if white > WHITENESS_MAX and not explained > 1.0 - NEGLIGIBLE_RESIDUAL:
        severity["noise"] = CAUTION
    if width > BAND_ZERO_MAX:
        severity["band_width"] = UNRELIABLE
    elif width > BAND_WIDTH_MAX:
        severity["band_width"] = CAUTION
    if negative > NEGATIVE_SHARE_MAX:
        severity["negative_stiffness"] = UNRELIABLE
    return severity


def live_checks(stiffness: np.ndarray, lo: np.ndarray, hi: np.ndarray, observable: np.ndarray,
                innovation: np.ndarray, innovation_variance: np.ndarray, measured: np.ndarray,
                angle: np.ndarray, *, recent: np.ndarray | None = None,
                looked_back: Hindsight | None = None) -> LiveChecks:
    """The checks over one window.

    Parameters
    ----------
    stiffness, lo, hi : ndarray, shape (n,), N·m/rad (N/m)
        The live estimate at the window's samples.
    observable : ndarray of bool, shape (n,)
    innovation, innovation_variance, measured, angle : ndarray, shape (k,)
        At the window's model steps, in order: e, S, z and y (N·m, (N·m)², N·m, rad).
    recent : ndarray, shape (k,), N·m/rad (N/m), optional
        The estimate published at every sample of its last memory, across a new model's take-over
        (NaN where none was: before the estimate, a bridged gap): the ``changing`` and ``settling``
        checks, not made without it.
    looked_back : Hindsight, optional
        The last look back that could be judged, an identification's or a noise refit's (the
        ``hindsight`` check; not made without it).

    Returns
    -------
    LiveChecks
    """
    ok = np.isfinite(stiffness)
    motion = float(np.mean(observable & ok)) if len(ok) else float("nan")      # nothing to judge yet
    informed = observable & ok
    pick = informed if informed.any() else ok
    median = float(np.median(stiffness[pick])) if pick.any() else float("nan")
    width = float(np.median(hi[pick] - lo[pick])) / abs(median) if pick.any() and median != 0 else float("nan")
    negative = float(np.mean(stiffness[informed] < 0)) if informed.any() else 0.0
    # the prediction is judged once the window holds more than 2·LAGS steps (a fresh estimate's
    # first steps are still converging from the diffuse start)
    spread = float(np.sum((measured - measured.mean()) ** 2)) if len(measured) > 2 * LAGS else 0.0
    explained = 1.0 - float(innovation @ innovation) / spread if spread > 0 else float("nan")
    white = _whiteness(innovation / np.sqrt(innovation_variance)) if len(innovation) else float("nan")
    tracking, z = _tracking(innovation, innovation_variance, angle, 0.5 * width * abs(median))
    moved, swing = _moved(recent, 0.5 * float(hi[-1] - lo[-1]) if len(hi) else float("nan"))
    severity = _severity(motion=motion, explained=explained, tracking=tracking, z=z, moved=moved, swing=swing,
                         judged=recent is None or bool(np.isfinite(moved)),
                         looked_back=looked_back, white=white, width=width, negative=negative)
    verdict = Verdict.worst(severity.values())
    return LiveChecks(motion=motion, explained=explained, tracking=tracking, moved=moved, swing=swing,
                      whiteness=white, band_width=width,
                      negative_share=negative, hindsight=looked_back, verdict=verdict, failed=tuple(severity))
