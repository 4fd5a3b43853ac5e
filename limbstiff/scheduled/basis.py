"""The stiffness as a smooth function of a cycle's phase or of a recorded variable: its basis.

σ(t) = Σ_j β_j·h_j(u(t)) + walk(t), u the phase (0–1, periodic) or the schedule (a recorded
variable, in its unit). The h_j are hat functions (linear B-splines) on J knots: the curve is
piecewise linear between its values at the knots, local (a step in the stiffness stays where it
is) and as fine as J makes it (J chosen by held-out prediction, :mod:`.resolution`). The first
knot's hat is left out: the constant is the walk's level, which the model's diffuse start already
holds, so the weights are each knot's stiffness less the first's.

Each weight enters the torque as one column (:meth:`StiffnessBasis.columns`): on the phase h_j(φ)·θ′,
θ′ the angle's deviation from the cycles' mean path; on a schedule Σ h_j(u)·Δy, what the elastic
torque gains along the way. Its coefficient is linear like m and b
(:mod:`limbstiff.statespace.linear`), identified with them and drawn with them by the posterior.
Pure numpy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


#: Knots tried on the phase (periodic) and on a schedule; 0 is the walk alone.
PHASE_KNOTS = (0, 4, 6, 8, 12, 16, 24)
SCHEDULE_KNOTS = (0, 3, 4, 6, 8, 12)
#: The schedule's knots span its 1st to 99th percentile: the curve is flat beyond them.
SCHEDULE_RANGE_PERCENTILES = (1.0, 99.0)


@dataclass(frozen=True)
class StiffnessBasis:
    """Hat functions on knots of the phase or of a schedule.

    Parameters
    ----------
    against : {"phase", "schedule"}
    knots : ndarray, shape (J,)
        Phase (0–1, periodic: the last hat wraps to the first) or schedule values (increasing).
    unit : str
        Of the schedule ("1" for the phase).
    """

    against: str
    knots: np.ndarray
    unit: str = "1"

    @property
    def periodic(self) -> bool:
        return self.against == "phase"

    @property
    def size(self) -> int:
        """Weights: the knots less the first (0 for the walk alone)."""
        return max(len(self.knots) - 1, 0)

    def _locate(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Where each finite ``u`` (n,) falls among the knots: the mask of finite u (n,), and for
        those its knot interval's left and right knots and the fraction of the way across it (0–1;
        a schedule's u beyond its end knots at its end knot), each (k,). At least two knots."""
        J = len(self.knots)
        ok = np.isfinite(u)
        if self.periodic:
            x = (u[ok] % 1.0) * J               # knots at j/J
            left = np.floor(x).astype(int) % J
            w = x - np.floor(x)
            right = (left + 1) % J
        else:
            k = self.knots
            x = np.clip(u[ok], k[0], k[-1])
            left = np.clip(np.searchsorted(k, x, side="right") - 1, 0, J - 2)
            w = (x - k[left]) / (k[left + 1] - k[left])
            right = left + 1
        return ok, left, right, w

    def hats(self, u: np.ndarray) -> np.ndarray:
        """Every knot's hat at ``u`` (n,), shape (J, n); rows sum to 1 where u is finite, 0 where NaN."""
        u = np.asarray(u, dtype=float)
        out = np.zeros((len(self.knots), len(u)))
        if len(self.knots) == 0:
            return out
        ok, left, right, w = self._locate(u)
        cols = np.flatnonzero(ok)
        np.add.at(out, (left, cols), 1.0 - w)
        np.add.at(out, (right, cols), w)
        return out

    def design(self, u: np.ndarray) -> np.ndarray:
        """The weights' functions at ``u`` (n,): the hats less the first knot's, shape (J − 1, n)."""
        return self.hats(u)[1:]

    def columns(self, u: np.ndarray, angle: np.ndarray, *, sample_period: float,
                motion_frequency: float) -> np.ndarray:
        """The torque per unit weight, h_j(u)·g, shape (J − 1, n), N·m per N·m/rad.

        On the phase, the column is h_j(φ)·g with g the angle itself less its mean: an ensemble's
        angle is already its deviation from what every cycle repeats
        (:func:`limbstiff.cycles.ensemble_mean`), and the stiffness at a phase acts on all of it (a
        spring whose stiffness changes over the cycle, or a nonlinear one moved along the cycle's
        path, gives the same: f(θ_ref + x) − f(θ_ref) ≈ f′(θ_ref)·x). On a schedule the operating
        point moves, and the torque changes by σ·dy along the way (σ = ∂τ/∂y, the paper's
        definition): the column is Σ_{i≤k} h_j(u_{i−1})·(y_i − y_{i−1}), what the model's elastic
        torque ds = σ·dy gains from the weight.
        """
        design = self.design(u)
        if not self.periodic:
            dy = np.diff(np.asarray(angle, dtype=float), prepend=float(angle[0]))
            shifted = np.concatenate([design[:, :1], design[:, :-1]], axis=1)
            return np.ascontiguousarray(np.cumsum(shifted * dy[None, :], axis=1))
        g = np.asarray(angle, dtype=float) - float(np.mean(angle))
        return np.ascontiguousarray(design * g[None, :])

    def interpolation_error(self, weights: np.ndarray, u: np.ndarray) -> np.ndarray:
        """How far the curve may lie from a smooth stiffness through its knot values, at ``u`` (n,),
        shape (n,), N·m/rad (N/m): a straight line over a knot interval of width h misses a function
        of second derivative f″ by ½·t·(1 − t)·h²·|f″| at the fraction t of the interval (the error
        of linear interpolation), f″ taken as the larger of the knot values' second differences at
        the interval's two ends. Zero at the knots, beyond a schedule's end knots and with fewer
        than three knots; NaN where u is."""
        J = len(self.knots)
        u = np.asarray(u, dtype=float)
        out = np.where(np.isfinite(u), 0.0, np.nan)
        if J < 3:
            return out
        c = np.concatenate([[0.0], np.asarray(weights, dtype=float)[:J - 1]])     # the first knot's is the walk's
        ends = np.append(self.knots, 1.0) if self.periodic else self.knots
        h = np.diff(ends)                                                       # each knot interval's width
        interval = np.arange(len(h))
        slope = (c[(interval + 1) % J] - c[interval]) / h
        if self.periodic:
            curvature = np.abs(2 * (slope - np.roll(slope, 1)) / (h + np.roll(h, 1)))           # at each knot
        else:
            inner = np.abs(2 * np.diff(slope) / (h[:-1] + h[1:]))
            curvature = np.concatenate([inner[:1], inner, inner[-1:]])          # an end knot takes its neighbour's
        at_ends = np.maximum(curvature, np.roll(curvature, -1))[:len(h)]
        ok, left, _, t = self._locate(u)
        out[ok] = 0.5 * t * (1 - t) * h[left] ** 2 * at_ends[left]
        return out

    def curve(self, weights: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Σ_j β_j·h_j(u) (n,) for weights (J − 1,): the curve less its first knot's value."""
        return np.asarray(weights, dtype=float) @ self.design(u) if self.size else np.zeros(len(u))


def phase_basis(knots: int) -> StiffnessBasis:
    """``knots`` equally spaced knots over the phase (none: the walk alone)."""
    return StiffnessBasis("phase", np.arange(knots) / knots if knots else np.zeros(0))


def schedule_basis(knots: int, values: np.ndarray, *, unit: str) -> StiffnessBasis:
    """``knots`` knots at equally spaced quantiles of the schedule's ``values`` between its
    :data:`SCHEDULE_RANGE_PERCENTILES` (each knot with a like share of the data)."""
    if not knots:
        return StiffnessBasis("schedule", np.zeros(0), unit)
    lo, hi = SCHEDULE_RANGE_PERCENTILES
    k = np.percentile(values[np.isfinite(values)], np.linspace(lo, hi, knots))
    k = np.maximum.accumulate(k)
    if np.any(np.diff(k) <= 0):         # ties in a schedule that dwells: equal spacing instead
        k = np.linspace(k[0], k[-1], knots)
    return StiffnessBasis("schedule", k, unit)
