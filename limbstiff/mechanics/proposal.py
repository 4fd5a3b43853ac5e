"""An independence proposal for the noise levels' chain: a multivariate Student t fitted to the
walkers after a short adaptation.

The log noise levels' posterior is close to Gaussian on most trials. The ensemble's
differential-evolution moves explore it with integrated autocorrelation times of 15–35 steps,
and the chain must be 50 of them long; proposals drawn independently from a distribution close
to the posterior decorrelate in a few steps. The proposal is fixed once the adaptation ends, so
the chain after it is an ordinary Metropolis–Hastings chain on the exact posterior (Tierney 1994,
Ann. Statist. 22:1701, independence chains); heavy tails (ν = :data:`DEGREES_OF_FREEDOM`) and a
scale wider than the walkers' spread keep the importance ratio bounded where the posterior's
tails are wider than a Gaussian's. Pure numpy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Degrees of freedom of the Student t proposal: tails wide enough for a posterior cut by a bound
#: or skewed in a log noise level.
DEGREES_OF_FREEDOM = 4.0
#: The proposal's scale over the walkers' spread (1 would match a Gaussian posterior exactly;
#: wider loses a little acceptance and guards the tails).
SCALE = 1.5
#: Draws tried per walker for one inside the box; a walker still outside is proposed there and
#: rejected (the posterior is zero outside).
MAX_REDRAWS = 50


@dataclass(frozen=True)
class StudentProposal:
    """A multivariate Student t over the log noise levels.

    Parameters
    ----------
    centre : ndarray, shape (p,)
    cholesky : ndarray, shape (p, p)
        Lower Cholesky factor of the scale matrix.
    bounds : ndarray, shape (p, 2)
        The box the posterior lives in: the proposal is the t truncated to it.
    dof : float
    """

    centre: np.ndarray
    cholesky: np.ndarray
    bounds: np.ndarray
    dof: float = DEGREES_OF_FREEDOM

    @classmethod
    def fit(cls, samples: np.ndarray, bounds: np.ndarray) -> "StudentProposal | None":
        """The proposal for walkers' positions ``samples`` (n, p) in the box ``bounds`` (p, 2): their
        mean, and their covariance widened by :data:`SCALE`; None when that covariance is singular
        (walkers collapsed)."""
        cov = np.atleast_2d(np.cov(samples.T)) * SCALE ** 2
        try:
            chol = np.linalg.cholesky(cov)
        except np.linalg.LinAlgError:
            return None
        return cls(np.mean(samples, axis=0), chol, np.asarray(bounds, dtype=float))

    def log_density(self, x: np.ndarray) -> np.ndarray:
        """Log density up to a constant at each row of ``x`` (K, p)."""
        z = np.linalg.solve(self.cholesky, (x - self.centre).T)
        return -0.5 * (self.dof + len(self.centre)) * np.log1p(np.sum(z * z, axis=0) / self.dof)

    def propose(self, coords: np.ndarray, random) -> tuple[np.ndarray, np.ndarray]:
        """emcee's ``MHMove`` proposal: new positions drawn independently of ``coords`` (K, p), and
        ln q(x) − ln q(x′) per walker. ``random`` is emcee's ``numpy.random.RandomState``."""
        new = self._draw(len(coords), random)
        # the truncated t's normalisation is the same at both ends: it cancels in the ratio
        for _ in range(MAX_REDRAWS):
            outside = ~self.inside(new)
            if not np.any(outside):
                break
            new[outside] = self._draw(int(np.sum(outside)), random)
        return new, self.log_density(coords) - self.log_density(new)

    def inside(self, x: np.ndarray) -> np.ndarray:
        """Whether each row of ``x`` (K, p) lies in the box, shape (K,)."""
        return np.all((x >= self.bounds[:, 0]) & (x <= self.bounds[:, 1]), axis=1)

    def _draw(self, k: int, random) -> np.ndarray:
        z = random.standard_normal((k, len(self.centre))) @ self.cholesky.T
        w = np.sqrt(self.dof / random.chisquare(self.dof, size=k))
        return self.centre + z * w[:, None]
