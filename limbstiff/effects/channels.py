"""The signals of one trial as the effects see them: the analysis's own filtered signals.

A :class:`Channels` holds the trial's :class:`~limbstiff.filtered.Filtered` signals (the same
object the stiffness analysis estimated from: no second filtering), the angle, its first two
derivatives and the torque (replaced by corrected ones when an effect corrects a recorded
channel), the inertia and damping the analysis used and its stiffness course. Every unmodelled
torque a candidate effect adds is passed through the same filter chain
(:meth:`Channels.lowpass`) so that it is compared with the recorded torque on equal terms. Pure
numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..statespace.noise import NoiseLevels
from ..filtered import FilterChain, Filtered
from ..trial import Trial


#: Samples per block of :meth:`Channels.linear_part`'s sums (a few MB of temporaries).
LINEAR_BLOCK = 65_536


@dataclass(frozen=True)
class Channels:
    """Filtered signals of one trial and the nominal model the stiffness analysis used.

    Parameters
    ----------
    name : str
        Trial name.
    time : ndarray, shape (n,), s
    filtered : Filtered
        The analysis's filtered signals and what was chosen from the data (chain, noise levels).
    angle, velocity, acceleration : ndarray, shape (n,)
        y, ẏ, ÿ (rad, rad/s, rad/s²; m… for translational): the filtered ones, or corrected ones.
    torque : ndarray, shape (n,), N·m (N)
        The torque the model predicts (external, or elastic for the direct variant), filtered.
    raw_angle, raw_torque : ndarray, shape (n,)
        As recorded (SI units).
    inertia, damping : float
        m (kg·m²) and b (N·m·s/rad) of the nominal model (0 for the direct variant).
    mechanics : str
        ``"given"`` (protocol or command line), ``"identified"`` (from this trial) or
        ``"none"`` (direct variant).
    stiffness : ndarray, shape (n,), N·m/rad, or None
        The stiffness course the analysis estimated (None before it: :meth:`before_analysis`).
    observable : ndarray of bool, shape (n,), or None
    noise : NoiseLevels or None
        The Kalman model's noise levels the analysis fitted (None for an observer estimator).
    """

    name: str
    time: np.ndarray
    filtered: Filtered
    angle: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    torque: np.ndarray
    raw_angle: np.ndarray
    raw_torque: np.ndarray
    inertia: float
    damping: float
    mechanics: str
    stiffness: np.ndarray | None = None
    observable: np.ndarray | None = None
    noise: NoiseLevels | None = None

    @property
    def chain(self) -> FilterChain:
        return self.filtered.chain

    @property
    def fs(self) -> float:
        return self.filtered.fs

    @property
    def cutoff_hz(self) -> float | None:
        return self.filtered.cutoff_hz

    @property
    def edge(self) -> int:
        return self.filtered.edge

    @property
    def motion_hz(self) -> float:
        return self.filtered.motion_hz

    @property
    def velocity_noise(self) -> float:
        return self.filtered.velocity_noise

    @property
    def quantisation_step(self) -> float:
        """Encoder step of the recorded angle, rad (0 when continuous)."""
        return self.filtered.bandwidth.quantisation_step

    @property
    def angle_noise(self) -> float:
        """Standard deviation of the white noise on the recorded angle, rad."""
        return self.filtered.angle_noise

    @property
    def angle_resolution(self) -> float:
        return self.filtered.angle_resolution

    @property
    def torque_floor(self) -> float:
        """One-sided spectral floor of the recorded torque, (N·m)²/Hz."""
        return self.filtered.torque_noise_floor

    @property
    def angle_floor(self) -> float:
        """One-sided spectral floor of the recorded angle, rad²/Hz."""
        return self.filtered.bandwidth.noise_floor

    @property
    def n(self) -> int:
        return len(self.time)

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0])

    def lowpass(self, x: np.ndarray) -> np.ndarray:
        """``x`` through the same low-pass as the recorded channels (shape (n,), or (k, n) on a
        zero-phase chain: each row)."""
        return self.filtered.lowpass(x)

    def linear_part(self, x: np.ndarray) -> np.ndarray:
        """Least-squares fit of ``x`` (n,) on 1, y, ẏ, ÿ; of each row of ``x`` (k, n) when stacked
        (each as alone, the centred columns formed once for all of them).

        On y, ẏ, ÿ less their means (the same fit; centred, the constant is orthogonal to them and
        an angle's offset costs no accuracy), through their 3 × 3 normal equations scaled to unit
        norm, block by block: no n × 4 basis is formed (its QR took 330 MB on an hour at 1 kHz).
        """
        key = "_linear_gram"
        kept = self.__dict__.get(key)
        columns = (self.angle, self.velocity, self.acceleration)
        if kept is None:
            means = np.array([np.mean(c) for c in columns])
            gram = sum(d @ d.T for d in self._centred_blocks(columns, means))
            norms = np.maximum(np.sqrt(np.diag(gram)), 1e-300)
            kept = (means, norms, np.linalg.pinv(gram / np.outer(norms, norms)))
            object.__setattr__(self, key, kept)
        means, norms, inverse = kept
        x = np.asarray(x, float)
        stacked = np.atleast_2d(x)
        levels = [float(np.mean(row)) for row in stacked]
        projections = [0] * len(stacked)
        for rows, d in zip(self._blocks(), self._centred_blocks(columns, means)):
            projections = [p + d @ (row[rows] - level) for p, row, level in zip(projections, stacked, levels)]
        coefs = [inverse @ (p / norms) / norms for p in projections]
        out = np.empty(stacked.shape)
        for rows, d in zip(self._blocks(), self._centred_blocks(columns, means)):
            for k, (level, coef) in enumerate(zip(levels, coefs)):
                out[k, rows] = level + coef @ d
        return out.reshape(x.shape)

    def _blocks(self):
        return (slice(i, i + LINEAR_BLOCK) for i in range(0, self.n, LINEAR_BLOCK))

    def _centred_blocks(self, columns, means):
        """The columns less ``means``, (3, block) at a time."""
        for rows in self._blocks():
            yield np.vstack([c[rows] for c in columns]) - means[:, None]

    def differentiate(self, x: np.ndarray, order: int = 2) -> np.ndarray:
        """``x`` filtered and differentiated like the angle: shape (order + 1, n)."""
        return self.filtered.differentiate(x, order)

    def with_channels(self, *, angle: np.ndarray | None = None, torque: np.ndarray | None = None) -> "Channels":
        """A copy with corrected channels: ``angle`` the filtered y, ẏ, ÿ stacked (3, n), as
        :meth:`differentiate` returns them; ``torque`` the filtered torque (n,)."""
        changes = {}
        if angle is not None:
            changes.update(angle=angle[0], velocity=angle[1], acceleration=angle[2])
        if torque is not None:
            changes["torque"] = torque
        return replace(self, **changes) if changes else self

    def elastic_target(self) -> np.ndarray:
        """z = f − m·ÿ − b·ẏ: the torque the nominal model leaves to the elastic element (n,)."""
        return self.torque - self.inertia * self.acceleration - self.damping * self.velocity

    @property
    def identified(self) -> bool:
        """m and b were identified from the trial: the diagnosis fits them with the effects."""
        return self.mechanics == "identified"

    def target(self) -> np.ndarray:
        """The measurement of the diagnosis's model (n,), N·m: f when m and b are fitted with the
        effects (:attr:`identified`), else f − m·ÿ − b·ẏ."""
        return self.torque if self.identified else self.elastic_target()

    def mechanics_columns(self, rows=slice(None)) -> np.ndarray:
        """ÿ and ẏ (2, r) at ``rows`` when m and b are fitted with the effects, else none (0, r)."""
        if self.identified:
            return np.vstack([self.acceleration[rows], self.velocity[rows]])
        return np.zeros((0, len(self.time[rows])))

    def spring_columns(self, rows=slice(None)) -> np.ndarray:
        """u² and u³ (2, r) at ``rows``, u = (y − ȳ)/sd(y) (dimensionless): the static nonlinear part
        of the spring, a stiffness that depends on the angle (N·m per unit coefficient once fitted)."""
        u = (self.angle[rows] - self.angle.mean()) / max(float(np.std(self.angle)), 1e-300)
        return np.vstack([u * u, u ** 3])

    def nuisance_columns(self, rows=slice(None)) -> np.ndarray:
        """Columns fitted per trial in every model, at ``rows``: :meth:`mechanics_columns` then
        :meth:`spring_columns`, shape (:attr:`n_nuisance`, r)."""
        return np.vstack([self.mechanics_columns(rows), self.spring_columns(rows)])

    @property
    def n_nuisance(self) -> int:
        return 4 if self.identified else 2


    def every(self, step: int, offset: int = 0) -> "Channels":
        """The channels at every ``step``-th sample from ``offset``, filtered signals and chain at the
        lower rate: a cheap, approximate look at an effect's torque (a screen of its shapes)."""
        return self.rows(slice(offset, None, step), step)

    def rows(self, rows, step: int = 1) -> "Channels":
        """The channels at ``rows`` (a slice, or sample indices (k,)), sampled ``step`` times more
        coarsely: a cheap, approximate look at an effect's torque (a screen of its shapes)."""
        f = self.filtered
        arrays = ("angle", "velocity", "acceleration", "jerk", "torque", "torque_rate")
        filtered = replace(f, sample_period=f.sample_period * step, chain=replace(f.chain, fs=f.chain.fs / step),
                           **{name: getattr(f, name)[rows] for name in arrays})
        own = ("time", "angle", "velocity", "acceleration", "torque", "raw_angle", "raw_torque", "stiffness",
               "observable")
        return replace(self, filtered=filtered,
                       **{name: getattr(self, name)[rows] for name in own if getattr(self, name) is not None})

    @classmethod
    def before_analysis(cls, trial: Trial, filtered: Filtered) -> "Channels":
        """The channels an analysis puts effects in its model from: the filtered signals of an
        external-torque trial, m and b fitted with the effects (no course yet)."""
        return cls(name=trial.name, time=np.asarray(trial.time, float), filtered=filtered, angle=filtered.angle,
                   velocity=filtered.velocity, acceleration=filtered.acceleration, torque=filtered.torque,
                   raw_angle=np.asarray(trial.angle, float), raw_torque=np.asarray(trial.torque, float),
                   inertia=0.0, damping=0.0, mechanics="identified")


def channels_from(trial: Trial, result) -> Channels:
    """Build the :class:`Channels` of a trial from its stiffness analysis.

    The signals are the analysis's own filtered ones, at the corner it chose — also when its
    corner scan lowered the corner below the spectra's (:mod:`limbstiff.bandwidth`), which an
    unmodelled effect can cause. Measured both ways: at the spectra's corner (148 Hz instead of
    74 Hz) the real z_pf trial's m and b fitted on the innovations fell to 0.011 kg·m² and a
    negative damping, and its nominal stiffness to 18 N·m/rad (74 Hz: 0.016, 0.96, 64; reference
    0.0165, 0.65, 69); at the chosen corner, a simulated slow elbow trial with LuGre friction,
    which had led the scan from 4.4 to 1.4 Hz, is diagnosed as backlash instead of friction.

    Parameters
    ----------
    trial : Trial
    result : StiffnessResult
        The analysis of ``trial`` (gives the filtered signals, m, b and σ̂).

    Returns
    -------
    Channels
    """
    f = result.filtered
    external = result.variant == "external"
    raw_torque = trial.torque if external else trial.elastic_torque
    if external:
        m, b = result.inertia.median, result.damping.median
        mechanics = "given" if result.identification.given else "identified"
    else:
        m = b = 0.0
        mechanics = "none"
    return Channels(
        name=trial.name, time=np.asarray(trial.time, float), filtered=f, angle=f.angle, velocity=f.velocity,
        acceleration=f.acceleration, torque=f.torque, raw_angle=np.asarray(trial.angle, float),
        raw_torque=np.asarray(raw_torque, float), inertia=float(m), damping=float(b), mechanics=mechanics,
        stiffness=np.asarray(result.stiffness, float), observable=np.asarray(result.observable, bool),
        noise=result.fit.noise if result.fit is not None else None)
