"""The emcee chain over the four log noise levels, run until it is long enough.

The adaptation fits the independence proposal (:mod:`limbstiff.mechanics.proposal`) in rounds and is
discarded; the chain then runs in blocks of :data:`BLOCK_STEPS` until it is :data:`MIN_TAU_MULTIPLE`
autocorrelation times long with :data:`KEPT_STEPS` after its burn-in, or :data:`MAX_STEPS` are run,
falling back to differential evolution alone when the proposal does not fit. What the chain's
states give (the posterior of m, b and the noise levels) is :mod:`limbstiff.mechanics.posterior`.
"""

from __future__ import annotations

import warnings

import numpy as np

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


def autocorr_time(chain: np.ndarray) -> np.ndarray:
    """emcee's integrated autocorrelation time per parameter, in steps, however short the chain.

    emcee raises :class:`emcee.autocorr.AutocorrError` on a chain shorter than 50 τ and carries
    its estimate in ``.tau``; the length is judged by :func:`limbstiff.mechanics.posterior.sample`
    (and said in its warnings),
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


def burn_in(steps: int, tau: np.ndarray) -> int:
    """Steps discarded from the start of a chain of ``steps``: three autocorrelation times, at most
    half the chain (half when the times are undefined)."""
    return int(min(steps // 2, 3 * np.max(tau))) if np.all(np.isfinite(tau)) else steps // 2


def run_chain(problem, start, rng: np.random.Generator):
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

    with warnings.catch_warnings():
        # a walker at a log-probability of nan or -inf (a degenerate recording) is emcee's to
        # reject; numpy's RuntimeWarnings about it are not for the user's terminal
        warnings.simplefilter("ignore", RuntimeWarning)

        log_prob = _log_prob(problem)
        state = _start_walkers(problem.bounds, start, rng)
        # differential-evolution moves: integrated autocorrelation times of ~15 steps here against
        # ~45 with the default stretch move (the stiffness walk's posterior often rests on a bound)
        de = [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]
        random_state = np.random.RandomState(int(rng.integers(2 ** 32))).get_state()
        state, moves, random_state, share = _adapted(problem, log_prob, state, de, random_state)
        discarded = ADAPT_ROUNDS * ADAPT_STEPS
        sampler = _sampler(log_prob, problem.bounds.shape[0], moves, random_state)
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
                sampler = _sampler(log_prob, problem.bounds.shape[0], de, random_state)
                steps = 0


def _log_prob(problem):
    """The walkers' log posterior, vectorised over rows of log noise levels; −∞ outside the bounds."""
    lo, hi = problem.bounds[:, 0], problem.bounds[:, 1]

    def log_prob(thetas):
        out = np.full(len(thetas), -np.inf)
        inside = np.all((thetas >= lo) & (thetas <= hi), axis=1)
        if np.any(inside):
            out[inside] = problem.conditionals(thetas[inside])[0]
        return out
    return log_prob


def _start_walkers(bounds: np.ndarray, start, rng: np.random.Generator) -> np.ndarray:
    """:data:`N_WALKERS` starts, shape (N_WALKERS, 4), scattered about the start's log noise levels."""
    lo, hi = bounds[:, 0], bounds[:, 1]
    # inside the bounds: walkers clipped onto a bound together would coincide, and emcee's snooker
    # move divides by their distance (NaN proposals)
    centre = np.clip(start.noise.logs(),
                     lo + START_MARGIN, hi - START_MARGIN)
    return np.clip(centre + 0.05 * rng.standard_normal((N_WALKERS, len(centre))), lo, hi)


def _sampler(log_prob, ndim: int, moves, random_state):
    """An emcee ensemble of :data:`N_WALKERS` walkers over ``ndim`` parameters, continuing ``random_state``."""
    import emcee

    sampler = emcee.EnsembleSampler(N_WALKERS, ndim, log_prob, vectorize=True, moves=moves)
    sampler.random_state = random_state
    return sampler


def _adapted(problem, log_prob, state, de, random_state):
    """:data:`ADAPT_ROUNDS` rounds of :data:`ADAPT_STEPS` fitting the independence proposal.

    Returns
    -------
    state : emcee.State
        The walkers after the adaptation.
    moves : list of (emcee move, float)
        The chain's moves: the proposal's share and differential evolution, or ``de`` alone when
        the last round's proposal did not fit.
    random_state : tuple
        emcee's random state, to be continued by the chain.
    share : float
        The independence proposal's share of the moves (0 without one).
    """
    import emcee

    moves = de
    # rounds: the first proposal, fitted to walkers still spreading out, is too narrow; each next
    # one is fitted to the faster chain the one before gives
    for _ in range(ADAPT_ROUNDS):
        adapt = _sampler(log_prob, problem.bounds.shape[0], moves, random_state)
        state = adapt.run_mcmc(state, ADAPT_STEPS, progress=False)
        random_state = adapt.random_state
        proposal = StudentProposal.fit(adapt.get_chain(discard=ADAPT_STEPS // 2, flat=True), problem.bounds)
        moves = de if proposal is None else (
            [(emcee.moves.MHMove(proposal.propose), INDEPENDENCE_SHARE)]
            + [(move, (1.0 - INDEPENDENCE_SHARE) * w) for move, w in de])
    return state, moves, random_state, (0.0 if proposal is None else INDEPENDENCE_SHARE)
