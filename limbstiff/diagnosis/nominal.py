"""The nominal model of the diagnosis: the analysis's own time-varying Kalman model.

The stiffness analysis models the torque left to the elastic element as a state that follows
the angle with a stiffness walking in time (:mod:`limbstiff.statespace`):

    s[k] = s[k−1] + σ[k−1]·(y[k] − y[k−1]) + w_s,   σ[k] = σ[k−1] + w_σ,
    z[k] = f[k] − m·ÿ[k] − b·ẏ[k] − Σ_j a_j·φ_j[k] = s[k] + v,

and the diagnosis uses exactly that model, with the candidate effects' torques φ_j as extra
terms of the measurement equation. The filter's gains and innovation variance S[k] do not depend
on the data, so the one-step prediction errors (innovations) of z are Σ_c w_c·e_c[k], the
innovations e_c of each channel (f, ÿ, ẏ, φ_j) filtered alone, with w = (1, −m, −b, −a): every
coefficient that enters linearly — m and b when they are identified, an inertia or damping
error when they are given, a friction torque, a reflex gain — is fitted by weighted least squares
on those innovations and integrated out of the likelihood exactly, as the identification does for
m and b. The noise levels (R, Q_s, Q_σ, Q_c) are refitted by maximum marginal likelihood for every
model compared, so that a stiffness walk that took up an unmodelled effect is allowed to shrink
once the effect is in the model.

The gap is the one-step-ahead prediction error of the torque on held-out data, as a share of
the torque's variance. Any torque that depends on the angle alone is a (generalized) stiffness,
and a drift of the torque offset is a walk of the elastic torque (Q_s): the model holds both.

Rows are the Kalman model's steps (the analysis's decimation: 1.25 steps per low-pass corner
period), grouped into *units* of about one motion period, the pieces whose held-out gains the
significance test compares, and into held-out *segments* of whole units. The first motion period
of each trial is the filter's settling time (its diffuse start) and is not scored. Pure numpy:
no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import heldout
from ..estimate.observer import informed_samples
from ..statespace.linear import marginal
from ..statespace.noise import NoiseLevels, fit_levels, noise_bounds
from ..statespace.steps import ModelSteps, kalman_decimation
from ..effects.channels import Channels

#: Scoring units per time window of the "where" analysis.
UNITS_PER_WINDOW = 4
#: Fewest steps in a unit: the innovations are nearly white at the model's steps, so a few steps
#: already carry nearly independent gains.
MIN_UNIT_ROWS = 8
#: A unit is one motion period, or shorter when that leaves fewer than this many units: the
#: sign-flip test over U units cannot give p below 2^−U, and Holm's correction multiplies it by
#: the number of candidates (measured: a slow elbow trial, 0.24 Hz motion, held 6 units and no
#: effect could reach significance).
TARGET_UNITS = 40
#: Samples at each end kept out besides the filter edge: the longest look-back of a candidate
#: (reflex delays up to 80 ms) and the largest channel shift (50 ms).
LOOKBACK_S = 0.08
#: Motion periods at the start of each trial left unscored while the filter settles.
SETTLING_PERIODS = 1.0
#: Fewest held-out blocks a single trial must hold.
MIN_BLOCKS = 3
#: Likelihood evaluations allowed to refit the noise levels of one model.
NOISE_EVALUATIONS = 200

METRIC = ("one-step-ahead prediction error of the time-varying (Kalman) model on held-out data: the sum "
          "of squared innovations of the torque over the sum of squared deviations of the measured torque "
          "from its mean, both low-passed like the analysis (a fraction)")


def effective_cutoff(ch: Channels) -> float:
    """Corner of the filter chain, Hz (the paper chain's prefilter 1/(2πτ); Nyquist when unfiltered)."""
    if ch.chain.kind == "paper":
        return 1.0 / (2 * np.pi * ch.chain.prefilter_time_constant)
    return ch.cutoff_hz if ch.cutoff_hz is not None else 0.5 * ch.fs


@dataclass(frozen=True)
class ScoringLayout:
    """Which samples of one trial are the model's steps and how they are grouped.

    Parameters
    ----------
    trial : str
    rows : ndarray of int, shape (r,)
        Full-rate sample index of each step.
    scored : ndarray of bool, shape (r,)
        False during the filter's settling time.
    unit, window, segment : ndarray of int, shape (r,)
        Unit (numbered within the trial, −1 when not scored), time window of
        :data:`UNITS_PER_WINDOW` units, and held-out block of each step (−1 when not scored).
    decimation : int
        Samples per step.
    unit_s, window_s, step_s : float
        Lengths in seconds.
    """

    trial: str
    rows: np.ndarray
    scored: np.ndarray
    unit: np.ndarray
    window: np.ndarray
    segment: np.ndarray
    decimation: int
    unit_s: float
    window_s: float
    step_s: float

    @property
    def n_units(self) -> int:
        return int(self.unit.max()) + 1

    @property
    def n_segments(self) -> int:
        return int(self.segment.max()) + 1


def layout(ch: Channels, *, blocks: int) -> ScoringLayout:
    """Steps, units and held-out blocks of one trial.

    Parameters
    ----------
    ch : Channels
    blocks : int
        Contiguous held-out blocks of whole units (at least :data:`MIN_BLOCKS`).

    Raises
    ------
    ValueError
        When the trial holds fewer units than :data:`MIN_BLOCKS` (too short to diagnose).
    """
    decimation = kalman_decimation(1.0 / ch.fs, ch.cutoff_hz)
    margin = ch.edge + int(np.ceil(LOOKBACK_S * ch.fs))
    rows = np.arange(margin, ch.n - margin, decimation)
    step_s = decimation / ch.fs
    settle = min(len(rows), int(np.ceil(SETTLING_PERIODS / (ch.motion_hz * step_s))))
    period_rows = int(round(1.0 / (ch.motion_hz * step_s)))
    unit_rows = max(MIN_UNIT_ROWS, min(period_rows, (len(rows) - settle) // TARGET_UNITS))
    n_units = (len(rows) - settle) // unit_rows
    if n_units < MIN_BLOCKS:
        raise ValueError(f"{ch.name}: too short to diagnose: {len(rows) * step_s:.1f} s hold {max(n_units, 0)} "
                         f"scoring unit(s) of {unit_rows * step_s:.2f} s after the filter settles, at least "
                         f"{MIN_BLOCKS} are needed")
    unit = np.full(len(rows), -1)
    for u, part in enumerate(np.array_split(np.arange(settle, len(rows)), n_units)):
        unit[part] = u
    segment = heldout.contiguous(unit, blocks)
    window = np.maximum(unit, 0) // UNITS_PER_WINDOW
    return ScoringLayout(trial=ch.name, rows=rows, scored=unit >= 0, unit=unit, window=window, segment=segment,
                  decimation=decimation, unit_s=unit_rows * step_s, window_s=UNITS_PER_WINDOW * unit_rows * step_s,
                  step_s=step_s)


def fit_noise(steps: ModelSteps, *, start: NoiseLevels, motion_hz: float) -> NoiseLevels:
    """Noise levels of the model by maximum marginal likelihood: the one noise fit
    (:func:`~limbstiff.statespace.noise.fit_levels`, which says why it starts where it does) from
    ``start``, within the analysis's bounds (:func:`~limbstiff.statespace.noise.noise_bounds`).
    """
    z = steps.channels[0]
    bounds = noise_bounds(float(np.var(z - z.mean())), float(np.sqrt(steps.initial_cov[2])), motion_hz)

    def loglik(x):
        return marginal(steps, NoiseLevels(*np.exp(x))).loglik

    best, _ = fit_levels(loglik, start.logs(), bounds, NOISE_EVALUATIONS)
    return NoiseLevels(*np.exp(best))


def start_noise(ch: Channels, steps: ModelSteps) -> NoiseLevels:
    """Where the noise fit starts: the analysis's levels, or sizes of the target when the
    analysis did not fit any (an observer estimator)."""
    if ch.noise is not None:
        return ch.noise
    z = steps.channels[0]
    v = float(np.var(z - z.mean())) + 1e-300
    duration = steps.step * len(z)
    k = float(np.median(ch.stiffness))
    walk = (0.1 * abs(k) + 1e-12) ** 2 * ch.motion_hz
    return NoiseLevels(measurement=0.01 * v, torque_walk=0.01 * v / duration, stiffness_walk=walk, coupled_walk=walk)


def filter_power(freq: np.ndarray, ch: Channels) -> np.ndarray:
    """|H(f)|² of the chain the channels went through (zero-phase Butterworth of order 4 run
    twice, or the paper's prefilter 1/(τs + 1)²)."""
    if ch.chain.kind == "paper":
        w = 2 * np.pi * freq * ch.chain.prefilter_time_constant
        return 1.0 / (1.0 + w ** 2) ** 2
    if ch.cutoff_hz is None:
        return np.ones_like(freq)
    return 1.0 / (1.0 + (freq / ch.cutoff_hz) ** 8) ** 2


def noise_floor(ch: Channels, lay: ScoringLayout) -> float:
    """Gap that white sensor noise alone would leave, as a fraction of the torque variance.

    The recorded spectral floors of torque (N_f) and angle (N_y) are taken as white and carried
    through the filter and the model, f − m·ÿ − b·ẏ − k·y, with k the median estimated
    stiffness: floor = ∫|H|²·(N_f + |k − m·ω² + i·b·ω|²·N_y) df. A one-step prediction cannot
    do better than this measurement noise; quantisation of a slowly moving angle is not white
    (its in-band level exceeds the floor), so this is a lower bound.
    """
    freq = np.linspace(0.0, 0.5 * ch.fs, 4097)
    k = float(np.median(ch.stiffness[informed_samples(ch.observable)]))
    w = 2 * np.pi * freq
    z2 = (k - ch.inertia * w ** 2) ** 2 + (ch.damping * w) ** 2
    power = np.trapezoid(filter_power(freq, ch) * (ch.torque_floor + z2 * ch.angle_floor), freq)
    f = ch.torque[lay.rows[lay.scored]]
    var = float(np.mean((f - f.mean()) ** 2))
    return float(power / var) if var > 0 else float("nan")
