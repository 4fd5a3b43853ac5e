"""Posterior of inertia, damping and the noise levels by emcee, with its quality checked.

The likelihood is the Kalman model's exact one (:mod:`limbstiff.statespace`). Parameters
θ = (m, b, ln R, ln Q_s, ln Q_σ, ln Q_c): m and b carry the protocol's priors (default: flat on
m, b > 0) and are integrated exactly given the noise levels; the log noise levels are flat
within :func:`limbstiff.statespace.noise.noise_bounds` and sampled by emcee. The chain runs in blocks until it is at least
:data:`MIN_TAU_MULTIPLE` integrated autocorrelation times long (emcee's own estimator) or
:data:`MAX_STEPS` is reached, in which case a warning says so.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..statespace.noise import NoiseLevels
from ..protocol import Prior
from .proposal import StudentProposal

#: The chain must be this many autocorrelation times long (emcee's recommendation: ≥ 50).
MIN_TAU_MULTIPLE = 50
#: Steps of the adaptation that fits the independence proposal (differential evolution only,
#: discarded), steps per block between convergence checks, and the most steps run after it.
ADAPT_STEPS, BLOCK_STEPS, MAX_STEPS = 100, 50, 10_000
#: Rounds of adaptation, each :data:`ADAPT_STEPS` long.
ADAPT_ROUNDS = 3
#: After this many steps with the independence proposal, a chain whose autocorrelation time is
#: still above :data:`FALLBACK_TAU` steps (differential evolution alone: 15–35 on simulated trials,
#: 40–100 on the real ankle ones) starts again without it.
FALLBACK_STEPS, FALLBACK_TAU = 1000, 25.0
#: Share of the chain's steps that draw from the independence proposal; the rest are differential
#: evolution, which still moves the walkers where the proposal is poor.
INDEPENDENCE_SHARE = 0.8
#: Walkers: emcee's stretch move wants at least twice the dimension (4 noise levels).
N_WALKERS = 8
#: The walkers start at least this far inside the noise levels' bounds (natural-log units).
START_MARGIN = 0.1
#: Posterior draws kept for the bands and the draws file.
N_DRAWS = 2000
#: Steps the chain keeps after its burn-in, at least: every one of the :data:`N_DRAWS` draws from
#: a state of its own (the walkers' states of these steps).
KEPT_STEPS = -(-N_DRAWS // N_WALKERS)
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


def autocorr_time(chain: np.ndarray) -> np.ndarray:
    """emcee's integrated autocorrelation time per parameter, in steps, however short the chain.

    emcee raises :class:`emcee.autocorr.AutocorrError` on a chain shorter than 50 τ and carries
    its estimate in ``.tau``; the length is judged by :func:`sample` (and said in its warnings),
    so the estimate is taken either way.

    Parameters
    ----------
    chain : ndarray, shape (n_steps, n_walkers, n_parameters)
    """
    from emcee.autocorr import AutocorrError, integrated_time
    # a walker that has not moved yet has no autocorrelation (0/0): NaN, read as "not converged"
    with np.errstate(invalid="ignore", divide="ignore"):
        try:
            return integrated_time(chain)
        except AutocorrError as err:
            return err.tau


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
    sampler, steps, tau, share, discarded = _run_chain(problem, start, rng)
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
    # the chain holds N_DRAWS states after its burn-in (:func:`_run_chain`); were it shorter, its
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


def burn_in(steps: int, tau: np.ndarray) -> int:
    """Steps discarded from the start of a chain of ``steps``: three autocorrelation times, at most
    half the chain (half when the times are undefined)."""
    return int(min(steps // 2, 3 * np.max(tau))) if np.all(np.isfinite(tau)) else steps // 2


def _run_chain(problem, start, rng: np.random.Generator):
    """emcee over the four log noise levels: :data:`ADAPT_ROUNDS` rounds of :data:`ADAPT_STEPS`
    (differential evolution, then with the proposal fitted to the round before) to fit the
    independence proposal (:mod:`limbstiff.mechanics.proposal`; discarded), then the chain with
    both moves, in blocks of :data:`BLOCK_STEPS` until it is :data:`MIN_TAU_MULTIPLE`
    autocorrelation times long with :data:`KEPT_STEPS` after its burn-in, or :data:`MAX_STEPS` are
    run; with differential evolution alone when the proposal does not fit (:data:`FALLBACK_TAU`).

    Returns
    -------
    sampler : emcee.EnsembleSampler
        The chain after the adaptation.
    steps : int
    tau : ndarray, shape (4,)
        Integrated autocorrelation times, steps.
    independence_share : float
        Share of the steps the independence proposal made (0 when the walkers collapsed or the
        chain fell back to differential evolution).
    discarded : int
        Steps run before the chain: the adaptation's, and the proposal's when it fell back.
    """
    import emcee

    lo, hi = problem.bounds[:, 0], problem.bounds[:, 1]

    def log_prob(thetas):
        out = np.full(len(thetas), -np.inf)
        inside = np.all((thetas >= lo) & (thetas <= hi), axis=1)
        if np.any(inside):
            out[inside] = problem.conditionals(thetas[inside])[0]
        return out

    # inside the bounds: walkers clipped onto a bound together would coincide, and emcee's snooker
    # move divides by their distance (NaN proposals)
    centre = np.clip(start.noise.logs(),
                     lo + START_MARGIN, hi - START_MARGIN)
    p0 = np.clip(centre + 0.05 * rng.standard_normal((N_WALKERS, len(centre))), lo, hi)
    # differential-evolution moves: integrated autocorrelation times of ~15 steps here against
    # ~45 with the default stretch move (the stiffness walk's posterior often rests on a bound)
    de = [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]
    state, moves = p0, de
    random_state = np.random.RandomState(int(rng.integers(2 ** 32))).get_state()
    # rounds: the first proposal, fitted to walkers still spreading out, is too narrow; each next
    # one is fitted to the faster chain the one before gives
    for _ in range(ADAPT_ROUNDS):
        adapt = emcee.EnsembleSampler(N_WALKERS, len(centre), log_prob, vectorize=True, moves=moves)
        adapt.random_state = random_state
        state = adapt.run_mcmc(state, ADAPT_STEPS, progress=False)
        random_state = adapt.random_state
        proposal = StudentProposal.fit(adapt.get_chain(discard=ADAPT_STEPS // 2, flat=True), problem.bounds)
        moves = de if proposal is None else (
            [(emcee.moves.MHMove(proposal.propose), INDEPENDENCE_SHARE)]
            + [(move, (1.0 - INDEPENDENCE_SHARE) * w) for move, w in de])
    share, discarded = (0.0 if proposal is None else INDEPENDENCE_SHARE), ADAPT_ROUNDS * ADAPT_STEPS
    sampler = emcee.EnsembleSampler(N_WALKERS, len(centre), log_prob, vectorize=True, moves=moves)
    sampler.random_state = random_state
    steps = 0
    while True:
        state = sampler.run_mcmc(state, BLOCK_STEPS, progress=False)
        steps += BLOCK_STEPS
        tau = autocorr_time(sampler.get_chain())
        # NaN: a walker has not moved yet, and the chain is not long enough either
        long_enough = steps >= MIN_TAU_MULTIPLE * np.max(tau) and steps - burn_in(steps, tau) >= KEPT_STEPS
        if long_enough or steps >= MAX_STEPS:
            return sampler, steps, tau, share, discarded
        if share and steps == FALLBACK_STEPS and not np.max(tau) <= FALLBACK_TAU:
            # the proposal does not fit this posterior (a plateau, an L-shaped ridge): the chain
            # starts again from here with differential evolution alone
            random_state, share, discarded = sampler.random_state, 0.0, discarded + steps
            sampler = emcee.EnsembleSampler(N_WALKERS, len(centre), log_prob, vectorize=True, moves=de)
            sampler.random_state = random_state
            steps = 0


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
