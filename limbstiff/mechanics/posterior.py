"""Posterior of inertia, damping and the noise levels by emcee, with its quality checked.

The likelihood is the Kalman model's exact one (:mod:`limbstiff.statespace`). Parameters
θ = (m, b, ln R, ln Q_s, ln Q_σ, ln Q_c): m and b carry the protocol's priors (default: flat on
m, b > 0) and are integrated exactly given the noise levels; the log noise levels are flat
within :func:`limbstiff.statespace.noise.noise_bounds` and sampled by emcee. The chain runs in blocks until it is at least
:data:`~limbstiff.mechanics.chain.MIN_TAU_MULTIPLE` integrated autocorrelation times long (emcee's own
estimator) or :data:`~limbstiff.mechanics.chain.MAX_STEPS` is reached, in which case a warning says so
(:mod:`limbstiff.mechanics.chain`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..statespace.noise import NoiseLevels
from ..protocol import Prior
from .chain import MIN_TAU_MULTIPLE, N_DRAWS, N_WALKERS, burn_in, run_chain

PARAMETERS = ("inertia", "damping", "log_measurement", "log_torque_walk", "log_stiffness_walk", "log_coupled_walk")


@dataclass(frozen=True)
class McmcDiagnostics:
    """How the chain went.

    Parameters
    ----------
    n_walkers, n_steps, burn_in, thin : int
    autocorr_time : dict of str to float
        Integrated autocorrelation time of each parameter, in steps (emcee's estimator).
    acceptance_fraction : float
        Mean over walkers.
    converged : bool
        The chain is at least :data:`MIN_TAU_MULTIPLE` autocorrelation times long.
    seed : int
    adaptation_steps : int
        Steps run and discarded before the chain: the adaptation that fits the independence
        proposal, and the proposal's own when the chain fell back to differential evolution.
    independence_share : float
        Share of the chain's steps drawn from it (0: differential evolution only).
    """

    n_walkers: int
    n_steps: int
    burn_in: int
    thin: int
    autocorr_time: dict
    acceptance_fraction: float
    converged: bool
    seed: int
    adaptation_steps: int = 0
    independence_share: float = 0.0

    @property
    def chain_in_autocorr_times(self) -> float:
        """Chain length over the longest autocorrelation time (≥ :data:`MIN_TAU_MULTIPLE` wanted)."""
        longest = np.max(list(self.autocorr_time.values()))      # NaN when a time is undefined
        return float(self.n_steps / longest)

    def to_dict(self) -> dict:
        return {"sampler": "emcee", "n_walkers": self.n_walkers, "n_steps": self.n_steps,
                "burn_in": self.burn_in, "thin": self.thin, "autocorr_time": self.autocorr_time,
                "chain_in_autocorr_times": self.chain_in_autocorr_times,
                "acceptance_fraction": self.acceptance_fraction, "converged": self.converged,
                "seed": self.seed, "adaptation_steps": self.adaptation_steps,
                "independence_share": self.independence_share}


@dataclass(frozen=True)
class Posterior:
    """Posterior draws of θ = (m, b, ln R, ln Q_s, ln Q_σ, ln Q_c), and of the amplitudes of the
    effects in the model.

    Parameters
    ----------
    draws : ndarray, shape (n_draws, 6)
        m and b are the given values in every draw when they were given.
    diagnostics : McmcDiagnostics
    warnings : tuple of str
    amplitudes : ndarray, shape (n_draws, k)
        The effects' amplitudes, drawn with m and b (k = 0 without effects).
    """

    draws: np.ndarray
    diagnostics: McmcDiagnostics
    warnings: tuple[str, ...] = field(default=())
    amplitudes: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))

    @property
    def coefficients(self) -> np.ndarray:
        """Draws of (m, b, amplitudes…), shape (n_draws, 2 + k): the model's linear coefficients."""
        amps = self.amplitudes if len(self.amplitudes) == len(self.draws) else np.zeros((len(self.draws), 0))
        return np.hstack([self.draws[:, :2], amps])

    @property
    def mechanics(self) -> np.ndarray:
        """Draws of (m, b), shape (n_draws, 2)."""
        return self.draws[:, :2]

    def interval(self, j: int, level: float) -> tuple[float, float, float]:
        """Median and central interval of parameter ``j``."""
        lo, med, hi = np.quantile(self.draws[:, j], [0.5 - level / 2, 0.5, 0.5 + level / 2])
        return float(med), float(lo), float(hi)

    def noise_levels(self) -> NoiseLevels:
        """Posterior median of the noise levels."""
        return NoiseLevels(*np.exp(np.median(self.draws[:, 2:], axis=0)))

    def to_frame(self):
        """The draws as a :class:`pandas.DataFrame` (one column per parameter)."""
        import pandas as pd
        return pd.DataFrame(self.draws, columns=PARAMETERS)


def log_prior(values: np.ndarray, prior: Prior) -> np.ndarray:
    """Log density (up to a constant) of a positive parameter under ``prior``; −inf if ≤ 0.

    ``halfnormal`` without a scale is the default: flat on the positive half-line.
    """
    x = np.asarray(values, dtype=float)
    out = np.full(x.shape, -np.inf)
    ok = x > 0
    if prior.distribution == "lognormal":
        out[ok] = -0.5 * (np.log(x[ok] / prior.median) / prior.sigma) ** 2 - np.log(x[ok])
    elif prior.distribution == "uniform":
        ok &= (x >= prior.low) & (x <= prior.high)
        out[ok] = 0.0
    elif prior.scale is None:
        out[ok] = 0.0
    else:
        out[ok] = -0.5 * (x[ok] / prior.scale) ** 2
    return out


def prior_density(values: np.ndarray, prior: Prior) -> np.ndarray | None:
    """Normalised density of a prior on a positive parameter.

    Parameters
    ----------
    values : ndarray, shape (n,)
        Inertia (kg·m², kg) or damping (N·m·s/rad, N·s/m).
    prior : Prior

    Returns
    -------
    ndarray, shape (n,), or None
        The density, 1/(unit of ``values``), 0 outside the support; None for the flat default,
        which has no density.
    """
    x = np.asarray(values, dtype=float)
    out = np.zeros(x.shape)
    ok = x > 0
    if prior.distribution == "lognormal":
        z = np.log(x[ok] / prior.median) / prior.sigma
        out[ok] = np.exp(-0.5 * z ** 2) / (x[ok] * prior.sigma * np.sqrt(2 * np.pi))
    elif prior.distribution == "uniform":
        out[ok & (x >= prior.low) & (x <= prior.high)] = 1.0 / (prior.high - prior.low)
    elif prior.scale is None:
        return None
    else:
        out[ok] = 2.0 * np.exp(-0.5 * (x[ok] / prior.scale) ** 2) / (prior.scale * np.sqrt(2 * np.pi))
    return out


def sample(problem, *, start, inertia_prior: Prior, damping_prior: Prior, rng: np.random.Generator,
           seed: int, given: tuple[float, float] | None = None) -> Posterior:
    """Posterior of (m, b) and the noise levels: emcee on the noise levels, m and b exactly.

    For given noise levels the likelihood is Gaussian in (m, b) (see
    :class:`identify.MechanicsProblem`), so the chain runs over the four log noise levels on
    their marginal likelihood, and each kept state contributes one draw of (m, b) from its
    Gaussian conditional. The protocol's priors on m and b (and their positivity) enter by
    importance resampling of those draws.

    Parameters
    ----------
    problem : identify.MechanicsProblem
    start : identify.MechanicsFit
        The maximum-likelihood fit the walkers start around.
    inertia_prior, damping_prior : Prior
    rng : numpy.random.Generator
        Source of every random draw (walkers' start, emcee's generator, conditional draws).
    seed : int
        Recorded in the diagnostics.
    given : (float, float), optional
        m and b when they are given (the problem then fits the effects' amplitudes only).

    Returns
    -------
    Posterior
    """
    sampler, steps, tau, share, discarded = run_chain(problem, start, rng)
    warnings = []
    converged = bool(steps >= MIN_TAU_MULTIPLE * np.max(tau))
    if not converged:
        length = ("an undefined number of" if not np.all(np.isfinite(tau))
                  else f"only {steps / np.max(tau):.0f}")
        warnings.append(f"MCMC chain is {length} autocorrelation times long "
                        f"(fewer than {MIN_TAU_MULTIPLE}); the posterior may be rough")
    burn = burn_in(steps, tau)
    flat = sampler.get_chain(discard=burn, flat=True)
    thin = max(1, len(flat) // N_DRAWS)
    # the chain holds N_DRAWS states after its burn-in (:func:`run_chain`); were it shorter, its
    # states would be repeated, each with a draw of its own of the coefficients
    noise = np.resize(flat[::thin][-N_DRAWS:], (N_DRAWS, flat.shape[1]))
    draws, amplitudes, why = _with_mechanics(problem, noise, inertia_prior, damping_prior, rng, given)
    warnings += why
    acceptance = float(np.mean(sampler.acceptance_fraction))
    # high acceptance is unusual for differential evolution only (steps too small); an independence
    # proposal close to the posterior is accepted often
    high = 1.0 if share else 0.7
    if not 0.15 <= acceptance <= high:
        warnings.append(f"MCMC acceptance fraction {acceptance:.2f} is unusual (0.15–{high:.2g} expected)")
    diag = McmcDiagnostics(n_walkers=N_WALKERS, n_steps=steps, burn_in=burn, thin=thin,
                           autocorr_time=dict(zip(PARAMETERS[2:], map(float, tau))),
                           acceptance_fraction=acceptance, converged=converged, seed=seed,
                           adaptation_steps=discarded, independence_share=share)
    return Posterior(draws=draws, diagnostics=diag, warnings=tuple(warnings), amplitudes=amplitudes)


def gaussian_draws(means: np.ndarray, covs: np.ndarray, which: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One draw from the Gaussian N(means[k], covs[k]) for each k in ``which``, all at once.

    Parameters
    ----------
    means : ndarray, shape (K, p)
    covs : ndarray, shape (K, p, p)
        Symmetric, positive semi-definite (negative eigenvalues of rounding are taken as 0).
    which : ndarray of int, shape (n,)
    rng : numpy.random.Generator

    Returns
    -------
    ndarray, shape (n, p)
    """
    values, vectors = np.linalg.eigh(covs)
    roots = vectors * np.sqrt(np.clip(values, 0.0, None))[:, None, :]
    z = rng.standard_normal((len(which), means.shape[1]))
    return means[which] + np.einsum("nij,nj->ni", roots[which], z)


def _with_mechanics(problem, noise: np.ndarray, inertia_prior: Prior, damping_prior: Prior,
                    rng: np.random.Generator, given=None) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """One draw of the coefficients (m, b, amplitudes) from their Gaussian conditional per kept
    noise state, resampled by the priors' weights on m and b (m and b the ``given`` ones in every
    draw when given; the amplitudes' prior is flat).

    Returns
    -------
    draws : ndarray, shape (n, 6)
        (m, b, ln R, ln Q_s, ln Q_σ, ln Q_c).
    amplitudes : ndarray, shape (n, k)
    warnings : list of str
    """
    # a walker that stays put repeats its state: one pass for each distinct state
    distinct, which = np.unique(noise, axis=0, return_inverse=True)
    _, means, covs = problem.conditionals(distinct)
    coef = gaussian_draws(means, covs, which.ravel(), rng)
    if given is not None:
        mech, amps = np.tile(np.asarray(given, dtype=float), (len(noise), 1)), coef
        return np.hstack([mech, noise]), amps, []
    mech, amps = coef[:, :2], coef[:, 2:]
    logw = log_prior(mech[:, 0], inertia_prior) + log_prior(mech[:, 1], damping_prior)
    if not np.any(np.isfinite(logw)):
        return (np.hstack([mech, noise]), amps,
                ["no posterior draw of inertia and damping satisfies their priors (all ≤ 0?)"])
    w = np.exp(logw - np.max(logw))
    keep = rng.choice(len(mech), size=len(mech), p=w / w.sum())
    return np.hstack([mech, noise])[keep], amps[keep], []
