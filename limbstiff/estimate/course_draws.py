"""Joint posterior draws of the stiffness course: the simulation smoother of the Kalman model.

The smoother gives each sample's posterior mean and variance, but a figure of the whole trial —
the median stiffness, its slope against torque — needs the course's joint posterior, whose
neighbouring samples share their errors. Durbin & Koopman's (2002, Biometrika 89:603) simulation
smoother draws from it with the smoother itself: simulate states x⁺ and measurements z⁺ from the
model, smooth z⁺, and x̂ + (x⁺ − x̂⁺) is a draw of the states given the data. The gains do not
depend on the data, so each draw is one filter and smoother pass. Pure numpy: no I/O.
"""

from __future__ import annotations

import numpy as np

from ..statespace.noise import NoiseLevels
from ..statespace.smoother import at_steps, kalman_smoother
from ..statespace.steps import ModelSteps

#: Most numbers per simulated array of a block of draws (2·10⁶ float64: 16 MB each).
BLOCK_VALUES = 2_000_000


def course_deviations(steps: ModelSteps, noise: NoiseLevels, *, draws: int, rng: np.random.Generator,
                      aligned: bool = True, columns: np.ndarray | None = None) -> np.ndarray:
    """Draws of the stiffness course's posterior error, at the model's steps.

    The courses are simulated in blocks of at most :data:`BLOCK_VALUES` numbers, so that memory
    stays that of a few passes however long the trial; only ``columns`` are kept.

    Parameters
    ----------
    steps : ModelSteps
        The data the estimate was smoothed from (its initial mean and covariance).
    noise : NoiseLevels
        The noise levels it was smoothed with.
    draws : int
    rng : numpy.random.Generator
    aligned : bool
        Aligned like the estimate (:func:`~limbstiff.statespace.smoother.at_steps`), or the state σ[k] itself.
    columns : ndarray of int, shape (c,), optional
        The steps to keep (default all).

    Returns
    -------
    ndarray, shape (draws, c), N·m/rad (N/m)
        x⁺ − x̂⁺ of the stiffness: the estimate plus a row is a draw of the course from its
        posterior; unaligned, each column's variance is the smoother's posterior variance there.
    """
    n, dt = len(steps.measured), steps.step
    keep = np.arange(n) if columns is None else np.asarray(columns)
    p11, p12, p22 = steps.initial_cov
    chol = np.linalg.cholesky(np.array([[p11, p12], [p12, p22]]) + 1e-300 * np.eye(2))
    sd = np.sqrt([noise.stiffness_walk * dt, noise.coupled_walk * dt, noise.torque_walk * dt, noise.measurement])
    out = np.empty((draws, keep.size))
    block = max(1, BLOCK_VALUES // max(n, 1))
    for first in range(0, draws, block):
        k = min(block, draws - first)
        start = np.asarray(steps.initial_mean) + rng.standard_normal((k, 2)) @ chol.T
        # the four noises drawn one after the other (the same numbers as one (4, k, n) draw), each
        # summed in place and let go as soon as it is used: a long trial's n is large
        w_k, w_c = rng.standard_normal((k, n)) * sd[0], rng.standard_normal((k, n)) * sd[1]
        w_k[:, 0] = w_c[:, 0] = 0.0
        stiffness = np.add(w_k, w_c, out=w_k)
        np.cumsum(stiffness, axis=1, out=stiffness)
        stiffness += start[:, 1:]
        change = rng.standard_normal((k, n)) * sd[2]     # w_s; then σ[i−1]·Δy[i] + g[i]·w_c[i] + w_s[i]
        change[:, 0] = 0.0
        change[:, 1:] += stiffness[:, :-1] * steps.increments[1:]
        change[:, 1:] += steps.deflection[1:] * w_c[:, 1:]
        del w_c
        measured = np.cumsum(change, axis=1, out=change)
        measured += start[:, :1]
        measured += rng.standard_normal((k, n)) * sd[3]
        for j in range(k):
            smoothed = kalman_smoother(steps.increments, measured[j], noise, step=dt, deflection=steps.deflection,
                                       initial_mean=steps.initial_mean, initial_cov=steps.initial_cov,
                                       loglik=False)
            error = np.subtract(stiffness[j], smoothed.mean[:, 1], out=stiffness[j])
            del smoothed
            out[first + j] = (at_steps(error) if aligned else error)[keep]
    return out
