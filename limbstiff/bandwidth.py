"""The low-pass corner chosen by how well the model predicts the torque.

The spectra (:func:`limbstiff.signals.choose_bandwidth`) say up to which frequency the angle
and torque stand above their noise; they cannot say whether the model f = m·ÿ + b·ẏ + s(y, t)
describes the torque up there. A resonance of the set-up, a compliant coupling between limb and
device, or a movement the angle channel does not hold put torque in the band that no stiffness
explains, and at a corner above them the model fits that torque with nonsense (on a real ankle
recording, a median stiffness of −1 N·m/rad at 169 Hz). :func:`scan_corners` therefore fits the
model at corners from the spectral choice down to the motion band and scores each by its
prediction of the torque on held-out whole motion periods (:mod:`limbstiff.checks.model`), all
against the same torque. The spectral corner stays unless a lower one predicts clearly better (by
more than :data:`SCORE_TOLERANCE`); then the highest corner within the tolerance of the best is
kept: the model stops improving beyond it. Pure numpy.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from . import signals
from .checks.model import heldout_explained
from .estimate.kalman import fit_noise
from .filtered import Filtered, filter_trial
from .mechanics.least_squares import least_squares
from .protocol import Protocol
from .statespace.steps import kalman_decimation, model_steps
from .trial import Trial

#: Corners tried: this many, geometrically spaced from the spectral choice down.
N_CORNERS = 7
#: Lowest corner tried: :data:`OCTAVES_DOWN` octaves below the spectral choice, and at least
#: :data:`LOWEST_CORNER_MOTIONS` times the typical motion frequency and :data:`MIN_CORNER_HZ`.
#: The scan looks for torque the model cannot follow in the upper part of the band (resonances
#: and couplings of 20–60 Hz under spectral corners of 60–150 Hz); it must not filter away the
#: excitation that identifies the inertia: on the real ankle trials 90 % of the velocity's power
#: lies below 45–50 Hz, and at a 2.6 Hz corner the identification of z_pf2 fails outright.
OCTAVES_DOWN, LOWEST_CORNER_MOTIONS, MIN_CORNER_HZ = 3.0, 3.0, 1.0
#: Scores (share of the torque's variance) closer than this to the best count as no better: the
#: scatter of the score between neighbouring corners on clean simulated trials is ~0.002–0.008.
SCORE_TOLERANCE = 0.01
#: The scan looks at most this long a stretch from the middle of the trial, s: corners do not
#: change along a recording, and an hour-long trial would cost minutes.
SCAN_SECONDS = 120.0
#: Identification windows of the least-squares m and b used in the scan, in motion periods.
WINDOW_PERIODS = 4.0


@dataclass(frozen=True)
class CornerScan:
    """The model's held-out prediction of the torque at each corner tried.

    Parameters
    ----------
    corners_hz : tuple of float or None
        The corners tried, highest first (None: no filter).
    scores : tuple of float or None
        Share of the reference torque's variance predicted on held-out motion periods (None:
        too short to score).
    chosen_hz : float or None
        The corner kept.
    spectral_hz : float or None
        The corner the spectra alone gave.
    """

    corners_hz: tuple
    scores: tuple
    chosen_hz: float | None
    spectral_hz: float | None

    @property
    def gain(self) -> float:
        """How much more of the torque the chosen corner predicts than the spectral one."""
        s = dict(zip(self.corners_hz, self.scores))
        chosen, spectral = s.get(self.chosen_hz), s.get(self.spectral_hz)
        return 0.0 if chosen is None or spectral is None else float(chosen - spectral)

    def to_dict(self) -> dict:
        return {"corners_hz": list(self.corners_hz), "scores": list(self.scores), "chosen_hz": self.chosen_hz,
                "spectral_hz": self.spectral_hz, "tolerance": SCORE_TOLERANCE}


def _middle(trial: Trial) -> Trial:
    """At most :data:`SCAN_SECONDS` from the middle of the trial."""
    n = int(SCAN_SECONDS * trial.fs)
    if trial.n_samples <= n:
        return trial
    start = (trial.n_samples - n) // 2
    return trial.segment(start, start + n)


def _score(filtered: Filtered, reference: np.ndarray) -> float | None:
    """The held-out score at ``filtered``'s corner: m and b by least squares, the noise levels by
    maximum likelihood as the analysis fits them (:func:`~limbstiff.estimate.kalman.fit_noise`;
    the smoothed course is not needed)."""
    if filtered.variant == "external":
        fit = least_squares(filtered.torque, filtered.angle, filtered.velocity, filtered.acceleration,
                            sample_period=filtered.sample_period, window=WINDOW_PERIODS / filtered.motion_hz)
        m, b = fit.inertia, fit.damping
    else:
        m = b = 0.0
    steps = model_steps(filtered.angle, filtered.elastic_torque(m, b), sample_period=filtered.sample_period,
                        decimation=kalman_decimation(filtered.sample_period, filtered.cutoff_hz), edge=filtered.edge,
                        motion_frequency=filtered.motion_hz, scale_from=filtered.torque)
    noise = fit_noise(steps, motion_frequency=filtered.motion_hz)
    return heldout_explained(filtered, inertia=m, damping=b, noise=noise, reference=reference)


def _at_corner(part: Trial, spectral: Filtered, corner_hz: float | None) -> Filtered:
    """``part`` filtered at ``corner_hz``: what :func:`~limbstiff.filtered.filter_trial` gives with
    ``corner_hz``, the spectra and noise figures that do not depend on the corner taken from
    ``spectral`` instead of computed again."""
    chain = dataclasses.replace(spectral.chain, cutoff_hz=corner_hz)
    y = chain.apply(part.angle, 3)
    f = chain.apply(part.torque if spectral.variant == "external" else part.elastic_torque, 1)
    return dataclasses.replace(
        spectral, angle=y[0], velocity=y[1], acceleration=y[2], jerk=y[3], torque=f[0], torque_rate=f[1], chain=chain,
        bandwidth=dataclasses.replace(spectral.bandwidth, cutoff_hz=corner_hz),
        motion_hz=signals.motion_frequency(y[0], part.fs),
        velocity_noise=signals.velocity_noise_level(part.angle, part.fs, corner_hz))


def corners_to_try(spectral: Filtered) -> list[float | None]:
    """The spectral choice, then geometric steps down to the motion band, highest first."""
    top = spectral.cutoff_hz if spectral.cutoff_hz is not None else 0.9 * signals.MAX_BANDWIDTH_FRACTION * spectral.fs
    low = max(top / 2 ** OCTAVES_DOWN, LOWEST_CORNER_MOTIONS * spectral.motion_hz, MIN_CORNER_HZ)
    if not low < top:
        return [spectral.cutoff_hz]
    grid = [float(c) for c in np.geomspace(top, low, N_CORNERS)]
    return [spectral.cutoff_hz] + grid[1:] if spectral.cutoff_hz is not None else [None] + grid


def scans(protocol: Protocol) -> bool:
    """Whether the corner is left to the data: zero-phase chain, no ``bandwidth_hz`` given."""
    return protocol.derivatives == "zero-phase" and protocol.bandwidth_hz is None


def scan_corners(trial: Trial, protocol: Protocol) -> tuple[CornerScan, Filtered | None]:
    """Score the model's held-out torque prediction at each corner; keep the highest within
    :data:`SCORE_TOLERANCE` of the best (the spectral corner when nothing can be scored).

    Parameters
    ----------
    trial : Trial
    protocol : Protocol
        Its ``bandwidth_hz`` must be ``auto`` and its chain zero-phase (else there is nothing to choose).

    Returns
    -------
    scan : CornerScan
    filtered : Filtered or None
        The trial filtered at the corner kept, when the scan filtered the whole trial (at most
        :data:`SCAN_SECONDS` long); None for a longer trial, of which only the middle was scanned.
    """
    part = _middle(trial)
    spectral = filter_trial(part, protocol)
    corners = corners_to_try(spectral)
    recorded = part.torque if spectral.variant == "external" else part.elastic_torque
    reference = spectral.chain.apply(recorded, 0)[0]
    scores, kept = [], {}
    for c in corners:
        filtered = spectral if c == spectral.cutoff_hz else _at_corner(part, spectral, c)
        scores.append(_score(filtered, reference))
        if part is trial:
            kept[c] = filtered
    valid = [(c, s) for c, s in zip(corners, scores) if s is not None]
    chosen = spectral.cutoff_hz
    if valid:
        best = max(s for _, s in valid)
        chosen = [c for c, s in valid if s >= best - SCORE_TOLERANCE][0]
    return CornerScan(tuple(corners), tuple(scores), chosen, spectral.cutoff_hz), kept.get(chosen)
