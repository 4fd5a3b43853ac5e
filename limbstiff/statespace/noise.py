"""The noise levels of the state-space model: what they are, their bounds, and a Nelder–Mead
search over their logarithms.

The likelihood is given as a function of the log levels, so the same search serves the analysis's
fit (:func:`limbstiff.estimate.kalman.fit_noise_levels`), the identification's marginal likelihood
(:mod:`limbstiff.mechanics.likelihood`) and the diagnosis's refits (:mod:`limbstiff.diagnosis.nominal`).
Pure numpy/scipy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class NoiseLevels:
    """Variances of the state-space model (:mod:`limbstiff.statespace`).

    Parameters
    ----------
    measurement : float, (N·m)²
        R: variance of the torque left to the elastic element, per (decimated) sample.
    torque_walk : float, (N·m)²/s
        Q_s: intensity of elastic-torque changes not explained by σ·dy (s_u·u̇ of the paper).
    stiffness_walk : float, (N·m/rad)²/s
        Q_σ: intensity of the stiffness walk that has no torque of its own (angle-driven).
    coupled_walk : float, (N·m/rad)²/s
        Q_c: intensity of the stiffness walk that moves the torque of the deflected spring.
    """

    measurement: float
    torque_walk: float
    stiffness_walk: float
    coupled_walk: float

    def to_dict(self) -> dict:
        return {"measurement": self.measurement, "torque_walk": self.torque_walk,
                "stiffness_walk": self.stiffness_walk, "coupled_walk": self.coupled_walk}

    @staticmethod
    def units(torque: str, stiffness: str) -> dict[str, str]:
        """Unit of each level of :meth:`to_dict`, given the trial's torque and stiffness units."""
        return {"measurement": f"({torque})²", "torque_walk": f"({torque})²/s",
                "stiffness_walk": f"({stiffness})²/s", "coupled_walk": f"({stiffness})²/s"}

    def logs(self) -> np.ndarray:
        """ln (R, Q_s, Q_σ, Q_c), shape (4,): the coordinates the noise fits and the sampler work in."""
        return np.log([self.measurement, self.torque_walk, self.stiffness_walk, self.coupled_walk])

    @classmethod
    def from_logs(cls, logs) -> "NoiseLevels":
        """The levels whose logarithms are ``logs`` (shape (4,))."""
        return cls(*np.exp(np.asarray(logs, dtype=float)))

    def per_step(self, step: float) -> tuple[float, float, float, float]:
        """(R, Q_s·Δt, Q_σ·Δt, Q_c·Δt): the variances per step the kernels take."""
        return (float(self.measurement), float(self.torque_walk * step), float(self.stiffness_walk * step),
                float(self.coupled_walk * step))


def noise_bounds(measured_variance: float, stiffness_scale: float, motion_frequency: float) -> list:
    """Bounds on the logarithms of (R, Q_s, Q_σ, Q_c) that keep the model observable.

    Upper bounds: by bound (9) of the paper a stiffness that changes faster than the motion
    reveals it cannot be tracked, so within one period of the typical motion the stiffness may
    not walk by more than its own size, nor the non-elastic torque by more than the torque's
    spread: Q_σ ≤ σ²·f_motion, Q_s ≤ var(z)·f_motion, and R ≤ var(z). Without them, data
    sampled finely compared with its residual's correlation time admit a degenerate optimum
    (R → 0, the stiffness jumping to follow every sample). Lower bounds: levels below which a
    term has no visible effect on the estimate — measurement noise of 10⁻⁶·var(z), a
    non-elastic torque walking by 0.1 % of its spread or a stiffness walking by 0.01 % of
    itself per motion period — so that a flat prior on the log scale stays proper and the
    sampler does not wander over decades the data cannot tell apart. The coupled walk Q_c is a
    stiffness walk too and has Q_σ's bounds.
    """
    v = max(measured_variance, 1e-300)
    k2 = max(stiffness_scale ** 2, 1e-300)
    f = motion_frequency
    return [(np.log(1e-6 * v), np.log(v)), (np.log(1e-6 * v * f), np.log(v * f)),
            (np.log(1e-8 * k2 * f), np.log(k2 * f)), (np.log(1e-8 * k2 * f), np.log(k2 * f))]


def nelder_mead(loglik, starts, bounds: list, max_evaluations: int = 300):
    """Nelder–Mead over the log noise levels within ``bounds`` from each of ``starts`` (clipped
    to the bounds; initial simplex two log units along each level), the best kept; returns
    (best logs, best value). A non-finite log-likelihood counts as the worst."""
    from scipy.optimize import minimize

    lo, hi = np.array(bounds).T

    def negative(x):
        value = loglik(x)
        return -value if np.isfinite(value) else 1e300

    best = None
    for start in starts:
        x0 = np.clip(np.asarray(start, dtype=float), lo, hi)
        simplex = np.clip(x0 + np.vstack([np.zeros(len(x0)), 2.0 * np.eye(len(x0))]), lo, hi)
        res = minimize(negative, x0, method="Nelder-Mead", bounds=bounds,
                       options={"xatol": 0.02, "fatol": 0.01, "maxfev": max_evaluations,
                                "initial_simplex": simplex})
        if best is None or res.fun < best.fun:
            best = res
    return best.x, -float(best.fun)


def maximise(loglik, start: np.ndarray, bounds: list, max_evaluations: int = 300):
    """Nelder–Mead over the log noise levels within ``bounds``; returns (best logs, best value).

    The likelihood can have a second, poorer optimum where the stiffness walks fast and
    explains the torque sample by sample; the search therefore also starts with both stiffness
    walks 10³ times smaller and larger, and keeps the best.
    """
    start = np.asarray(start, dtype=float)
    shifts = (0.0, -3 * np.log(10), 3 * np.log(10))
    return nelder_mead(loglik, [start + np.array([0.0, 0.0, shift, shift]) for shift in shifts], bounds, max_evaluations)
