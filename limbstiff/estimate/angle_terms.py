"""A stiffness that changes with the angle within the motion cycle, fitted to the Kalman model's residual.

The model's stiffness walks slowly beside the motion (the noise bounds of
:mod:`limbstiff.statespace.noise`), so a stiffness that rises and falls with every excursion —
a spring stiffening with the deflection, muscle yielding beyond its short-range stiffness, a
reflex answering stretch one way — is averaged over the cycle. Written as

    σ(t, g) = σ₀(t) + β₁·g + β₂·(g² − mean g²),     g the deflection (:func:`~limbstiff.statespace.steps.deflection`),

the term adds to the torque left to the elastic element Σ β·h(g)·Δy over the steps
(ds = σ·dy). The filter is linear in the data, so β follows by generalised least squares of the
standardised innovations of z on those of the two regressors, all from one filter pass
(:func:`~limbstiff.statespace.linear.innovations`), with the sandwich covariance
over :data:`~limbstiff.statespace.linear.LONG_RUN_PERIODS` motion periods (as the
identification's: correlated residuals do not make β significant). Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..statespace.linear import course_response, innovations, sandwich_covariance
from ..statespace.noise import NoiseLevels
from ..statespace.steps import ModelSteps


@dataclass(frozen=True)
class AngleTerms:
    """The fitted angle terms and what the smoothed course misses of them.

    Parameters
    ----------
    coefficients : ndarray, shape (2,)
        β₁ (N·m/rad²) and β₂ (N·m/rad³).
    covariance : ndarray, shape (2, 2)
        Their sandwich covariance.
    wald : float
        β̂ᵀ·C⁻¹·β̂: χ² with 2 degrees of freedom when the stiffness does not depend on the angle.
    missed : ndarray, shape (2, m)
        Per unit β, the term h(g) = (g, g² − mean g²) less the smoothed course's own response to
        its torque, at the model's steps (aligned as the estimate, :func:`kalman.at_steps`): what
        the course lacks. A stiffness walk that follows the angle already has the term (missed ≈ 0).
    index : ndarray of int, shape (m,)
        The sample of each step.
    beside : bool
        Fitted beside other torques the model lacks (:func:`fit_angle_terms`): a rival explanation
        of the same residual was found.
    """

    coefficients: np.ndarray
    covariance: np.ndarray
    wald: float
    missed: np.ndarray
    index: np.ndarray
    beside: bool = False

    def missed_course(self) -> np.ndarray:
        """β̂·missed: what the course lacks at each step, N·m/rad (N/m), shape (m,)."""
        return self.coefficients @ self.missed

    def variation(self, informed: np.ndarray) -> float:
        """Root mean square of :meth:`missed_course` over the steps at the samples ``informed``
        (boolean, shape (n,) of the trial's samples), N·m/rad (N/m)."""
        missed = self.missed_course()[informed[self.index]]
        return float(np.sqrt(np.mean(missed ** 2))) if missed.size else 0.0


def angle_regressors(steps: ModelSteps) -> tuple[np.ndarray, np.ndarray]:
    """The torque a term β₁·g + β₂·(g² − c) adds, per unit β, and the term itself.

    With ds = σ·dy that torque is Σ β·h(g)·Δy over the steps (h at each step's middle), so that
    z − β·U obeys the model without the term (c = mean g² keeps the cycle average in σ₀).

    Returns
    -------
    U : ndarray, shape (2, m)
        Σ g·Δy and Σ (g² − c)·Δy, rad² and rad³ (m² and m³).
    H : ndarray, shape (2, m)
        g and g² − c at the steps, rad and rad² (m and m²).
    """
    g = steps.deflection
    middle = np.concatenate([g[:1], 0.5 * (g[1:] + g[:-1])])
    c = float(np.mean(g ** 2))
    d = np.concatenate([[0.0], steps.increments[1:]])
    return np.cumsum(np.vstack([middle, middle ** 2 - c]) * d, axis=1), np.vstack([g, g ** 2 - c])


#: Largest condition number of the terms' information and covariance matrices: beyond it the
#: motion does not tell β₁ from β₂ (an excursion always to one side) and no fit is claimed.
MAX_CONDITION = 1e12


def fit_angle_terms(steps: ModelSteps, noise: NoiseLevels, *, motion_frequency: float,
                    beside: np.ndarray | None = None) -> AngleTerms | None:
    """The angle terms of a trial's Kalman model (module docstring).

    Parameters
    ----------
    steps : ModelSteps
        The model's data (z at the analysis's m and b).
    noise : NoiseLevels
        The model's noise levels.
    motion_frequency : float, Hz
        Sets the lags of the long-run covariance.
    beside : ndarray, shape (k, m), optional
        Torques at the steps fitted together with the terms (a velocity-driven torque the model
        lacks, :mod:`limbstiff.checks.shape`): the terms then claim only what those do not explain
        (their innovations projected out of both sides, Frisch–Waugh–Lovell).

    Returns
    -------
    AngleTerms or None
        None when the motion cannot tell the terms apart (:data:`MAX_CONDITION`).
    """
    U, H = angle_regressors(steps)
    with_terms = steps.with_channels(U if beside is None else np.vstack([U, beside]))
    e, s = innovations(with_terms, noise)
    e = e / np.sqrt(s)
    x, eps = e[1:3].T, e[0]
    if beside is not None:
        other = e[3:].T
        x, eps = (v - other @ np.linalg.lstsq(other, v, rcond=None)[0] for v in (x, eps))
    information = x.T @ x
    if not np.all(np.isfinite(information)) or np.linalg.cond(information) > MAX_CONDITION:
        return None                     # the motion does not tell the two terms apart (or from none)
    beta = np.linalg.inv(information) @ (x.T @ eps)
    _, sandwich = sandwich_covariance(x, eps - x @ beta, motion_frequency=motion_frequency, step=steps.step)
    if np.linalg.cond(sandwich) > MAX_CONDITION:
        return None
    # the smoother is linear in z: its course from z − β·U is its course from z less β times these
    followed = course_response(steps, U, noise)
    return AngleTerms(coefficients=beta, covariance=sandwich, wald=float(beta @ np.linalg.solve(sandwich, beta)),
                      missed=H - followed, index=steps.index, beside=beside is not None)


#: Central share of the informed steps' deflections the stiffness against angle is drawn over
#: (as the range of motion's central 95 %: a spike or a drifting end does not stretch it).
COURSE_RANGE = (2.5, 97.5)


@dataclass(frozen=True)
class AngleCourse:
    """The stiffness against the angle that the angle terms give, on a grid of deflections.

    σ(g) = σ̄₀ + β₁·g + β₂·(g² − c): σ̄₀ the median over the informed steps of the course without
    the terms (the smoothed course less the part of them it follows), so that the curve is the
    stiffness at each deflection g about the operating angle, the cycle's average taken out.

    Parameters
    ----------
    deflection : ndarray, shape (k,), rad (m)
        The grid, over the central :data:`COURSE_RANGE` of the informed steps' deflections.
    operating : float, rad (m)
        The angle the deflection is taken about (median over the informed steps of the angle less
        its deflection): ``angle`` = operating + deflection.
    stiffness, lo, hi : ndarray, shape (k,), N·m/rad (N/m)
        σ(g) and its band: the terms' sandwich covariance (the shape) and ``level_half`` (the
        level's own uncertainty) added in quadrature.
    level : float
        The band's level (0.9 for 90 %).
    """

    deflection: np.ndarray
    operating: float
    stiffness: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    level: float

    @property
    def angle(self) -> np.ndarray:
        """operating + deflection, rad (m), shape (k,)."""
        return self.operating + self.deflection


def angle_course(terms: AngleTerms, steps: ModelSteps, course: np.ndarray, informed: np.ndarray, *,
                 level: float = 0.9, level_half: float = 0.0, points: int = 41) -> AngleCourse:
    """The stiffness against the angle from the fitted terms (:class:`AngleCourse`).

    Parameters
    ----------
    terms : AngleTerms
        Fitted on ``steps`` (:func:`fit_angle_terms`).
    steps : ModelSteps
        The model's steps the terms were fitted on.
    course : ndarray, shape (m,), N·m/rad (N/m)
        The smoothed course at the steps (without the terms).
    informed : ndarray of bool, shape (m,)
        The steps informed by motion (all when none is).
    level : float
        Level of the band.
    level_half : float, N·m/rad (N/m)
        Half-width of the level's own interval at ``level`` (the median stiffness's, say), added
        in quadrature to the shape's; 0 draws the shape's uncertainty alone.
    points : int
        Points of the grid.

    Returns
    -------
    AngleCourse
    """
    from scipy.stats import norm

    g = steps.deflection
    c = float(np.mean(g ** 2))                       # as angle_regressors: the terms' own centring
    informed = np.asarray(informed, dtype=bool)
    if not informed.any():
        informed = np.ones_like(informed)
    beta = terms.coefficients
    # the course without the terms: the smoothed course less what it follows of them (H − missed)
    base = course + terms.missed_course() - beta @ np.vstack([g, g ** 2 - c])
    lo_g, hi_g = np.percentile(g[informed], COURSE_RANGE)
    grid = np.linspace(lo_g, hi_g, points)
    h = np.vstack([grid, grid ** 2 - c])
    sigma = float(np.median(base[informed])) + beta @ h
    shape_sd = np.sqrt(np.maximum(np.einsum("ik,ij,jk->k", h, terms.covariance, h), 0.0))
    half = np.hypot(float(norm.ppf(0.5 + level / 2)) * shape_sd, level_half)
    return AngleCourse(deflection=grid, operating=float(np.median((steps.angle - g)[informed])),
                       stiffness=sigma, lo=sigma - half, hi=sigma + half, level=level)
