"""The noise levels of the state-space model: what they are, their bounds, and the one fit of them
(:func:`fit_levels`: Nelder–Mead over their logarithms from one set of starts).

The likelihood is given as a function of the log levels, so the same fit serves the analysis's
(:func:`limbstiff.estimate.kalman.fit_noise_levels`, which the live model calls too), the
identification's marginal likelihood (:mod:`limbstiff.mechanics.likelihood`) and the diagnosis's
models (:mod:`limbstiff.diagnosis.nominal`).
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


#: Levels of the grid :func:`fit_levels` starts from, over the measurement noise and over the
#: stiffness walks (both kinds at one level), each spanning its bounds.
GRID_LEVELS = 5
#: Decades by which :func:`fit_levels` also moves both stiffness walks of the first guess, down and up.
WALK_SHIFT_DECADES = 3.0


def _nelder_mead(negative, x0: np.ndarray, bounds: list, max_evaluations: int):
    """One bounded Nelder–Mead run from ``x0`` (initial simplex two log units along each level)."""
    from scipy.optimize import minimize

    lo, hi = np.array(bounds).T
    simplex = np.clip(x0 + np.vstack([np.zeros(len(x0)), 2.0 * np.eye(len(x0))]), lo, hi)
    return minimize(negative, x0, method="Nelder-Mead", bounds=bounds,
                    options={"xatol": 0.02, "fatol": 0.01, "maxfev": max_evaluations, "initial_simplex": simplex})


def starts(loglik, guess, bounds: list) -> list[np.ndarray]:
    """Where :func:`fit_levels` starts, log levels (4,) each, within ``bounds``:

    1. ``guess`` (the caller's first guess: the data's sizes, or the levels of a related model);
    2. and 3. ``guess`` with both stiffness walks :data:`WALK_SHIFT_DECADES` decades smaller and larger:
       the likelihood can have a second, poorer optimum where the stiffness walks fast and explains
       the torque sample by sample, and a search started on the wrong side of it stays there;
    4. the best point of a :data:`GRID_LEVELS` × :data:`GRID_LEVELS` grid over the measurement noise
       and the stiffness walks (the torque walk at the guess's): the likelihood has two kinds of
       optimum — a stiffness that walks and tracks the torque, and a constant one with the rest as
       measurement noise — and an unmodelled effect can make the second the better; once the effect
       is in the model the first must still be found from where the model without it ended, which
       shifting the walks alone does not do (measured: a friction trial of a gait-like ankle, 60 ↔ 110
       N·m/rad every 1.2 s, stayed at the constant stiffness from the guess and from the walks moved
       by 10³), and two models compared at different optima would differ by the optimiser, not by
       the effect.

    Starts that coincide after clipping to the bounds are given once.
    """
    lo, hi = np.array(bounds).T
    x0 = np.clip(np.asarray(guess, dtype=float), lo, hi)
    shift = WALK_SHIFT_DECADES * np.log(10)
    out = [np.clip(x0 + np.array([0.0, 0.0, s, s]), lo, hi) for s in (0.0, -shift, shift)]
    grid = [np.array([r, x0[1], k, k]) for r in np.linspace(lo[0], hi[0], GRID_LEVELS)
            for k in np.linspace(lo[2], hi[2], GRID_LEVELS)]
    values = [loglik(x) for x in grid]
    finite = [v if np.isfinite(v) else -np.inf for v in values]
    out.append(grid[int(np.argmax(finite))])
    unique = []
    for x in out:
        if not any(np.array_equal(x, u) for u in unique):
            unique.append(x)
    return unique


def fit_levels(loglik, guess, bounds: list, max_evaluations: int = 400) -> tuple[np.ndarray, float]:
    """The noise levels of the state-space model by maximum likelihood: the one noise fit.

    Nelder–Mead over the log levels within ``bounds`` (:func:`noise_bounds`) from each of
    :func:`starts`, the best kept. Every noise fit of the package is this one — the analysis's
    (:func:`limbstiff.estimate.kalman.fit_noise_levels`), the identification's marginal likelihood
    (:func:`limbstiff.mechanics.likelihood.kalman_mechanics`), the diagnosis's models
    (:func:`limbstiff.diagnosis.nominal.fit_noise`) and the live model's — so that one likelihood
    has one optimum whichever part asks.

    Parameters
    ----------
    loglik : callable
        Log-likelihood of the log levels (4,): ln (R, Q_s, Q_σ, Q_c); a non-finite value counts as
        the worst.
    guess : array, shape (4,)
        The first guess, log levels.
    bounds : list of (float, float)
        Bounds of the log levels.
    max_evaluations : int
        Likelihood evaluations allowed per start.

    Returns
    -------
    logs : ndarray, shape (4,)
        The best log levels.
    loglik : float
        The log-likelihood there.
    """
    def negative(x):
        value = loglik(x)
        return -value if np.isfinite(value) else 1e300

    best = None
    for x0 in starts(loglik, guess, bounds):
        res = _nelder_mead(negative, x0, bounds, max_evaluations)
        if best is None or res.fun < best.fun:
            best = res
    return best.x, -float(best.fun)
