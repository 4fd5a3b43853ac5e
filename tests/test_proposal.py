"""The posterior's independence proposal and its batched Gaussian draws, against exact answers."""

import dataclasses
import math

import numpy as np
import pytest

from limbstiff.mechanics.posterior import gaussian_draws
from limbstiff.mechanics.proposal import StudentProposal


def _truncated_normal_mean(a: float, b: float) -> float:
    """Mean of a standard normal truncated to [a, b] (Johnson, Kotz & Balakrishnan 1994, §10.1)."""
    pdf = lambda x: math.exp(-0.5 * x * x) / math.sqrt(2 * math.pi)   # noqa: E731
    cdf = lambda x: 0.5 * (1 + math.erf(x / math.sqrt(2)))              # noqa: E731
    return (pdf(a) - pdf(b)) / (cdf(b) - cdf(a))


def test_independence_chain_samples_a_truncated_normal():
    """emcee with the proposal alone, fitted off-centre and too wide, still samples the exact
    target: a standard normal in 2-D truncated to [−1, 3] × [−3, 0.5]. The proposal is truncated to
    the box (the posterior's support), so its normalisation must cancel in the ratio; a wrong
    ratio (none: the proposal taken for the target) shifts the
    means by 0.04 and 0.08. Tolerance 0.02: three times the means' spread over 20 seeds of this
    chain (sd 0.0066), well below the shifts a wrong ratio makes."""
    import emcee
    bounds = np.array([[-1.0, 3.0], [-3.0, 0.5]])

    def log_prob(x):
        inside = np.all((x >= bounds[:, 0]) & (x <= bounds[:, 1]), axis=1)
        return np.where(inside, -0.5 * np.sum(x * x, axis=1), -np.inf)

    proposal = StudentProposal(np.array([0.3, -0.4]), np.diag([1.6, 1.3]), bounds)
    sampler = emcee.EnsembleSampler(8, 2, log_prob, vectorize=True, moves=[emcee.moves.MHMove(proposal.propose)])
    sampler.random_state = np.random.RandomState(3).get_state()
    start = 0.1 + 0.1 * np.random.default_rng(1).standard_normal((8, 2))
    sampler.run_mcmc(start, 4000, progress=False)
    chain = sampler.get_chain(discard=200, flat=True)
    assert np.all(proposal.inside(chain))
    assert np.mean(sampler.acceptance_fraction) > 0.5
    expected = [_truncated_normal_mean(-1.0, 3.0), _truncated_normal_mean(-3.0, 0.5)]
    np.testing.assert_allclose(chain.mean(axis=0), expected, atol=0.02)


def test_proposal_refuses_collapsed_walkers_and_draws_inside():
    """Walkers on a line give a singular spread: no proposal (the chain keeps differential
    evolution). A fitted one proposes inside the box only, with the log ratio of its densities."""
    line = np.column_stack([np.arange(10.0), 2 * np.arange(10.0)])
    box = np.array([[-5.0, 5.0], [-5.0, 5.0]])
    assert StudentProposal.fit(line, box) is None
    rng = np.random.default_rng(0)
    proposal = StudentProposal.fit(rng.standard_normal((400, 2)), box)
    new, ratio = proposal.propose(np.zeros((500, 2)), np.random.RandomState(0))
    assert np.all(proposal.inside(new))
    np.testing.assert_allclose(ratio, proposal.log_density(np.zeros((500, 2))) - proposal.log_density(new))


@pytest.mark.parametrize("seed", [0, 1])
def test_gaussian_draws_have_the_exact_moments(seed):
    """Batched draws (one per index) have each component's mean and covariance, a singular
    covariance included. 100 000 draws per component: the mean's standard error is ≤ 2/316 =
    0.0063 (largest sd 2), so 5 SE ≈ 0.032; the covariance's relative error is ~√(2/n) ≈ 0.0045, so
    0.03 is ~6 SE."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((2, 3, 3))
    covs = np.concatenate([a @ a.transpose(0, 2, 1), np.diag([1.0, 0.0, 4.0])[None]])
    means = rng.standard_normal((3, 3))
    which = np.repeat(np.arange(3), 100_000)
    x = gaussian_draws(means, covs, which, np.random.default_rng(seed + 10))
    for k in range(3):
        part = x[which == k]
        np.testing.assert_allclose(part.mean(axis=0), means[k], atol=0.032)
        np.testing.assert_allclose(np.cov(part.T), covs[k], atol=0.03 * np.abs(covs[k]).max())
    assert np.all(x[which == 2][:, 1] == means[2, 1])


@pytest.mark.parametrize("extra", [0, 1, 3])
def test_the_walkers_batched_likelihood_equals_each_walkers_own(extra):
    """marginal_many (one compiled pass for all walkers with 2–4 channels, a loop above) gives every
    row's likelihood, mean and covariance of :func:`marginal` to the bit, a row that does not
    determine the coefficients (−inf) included."""
    from limbstiff.simulate import simulate
    from limbstiff.filtered import filter_trial
    from limbstiff.protocol import Protocol
    from limbstiff.mechanics.identification import mechanics_problem
    from limbstiff.statespace.linear import marginal, marginal_many
    from limbstiff.statespace.noise import NoiseLevels
    f = filter_trial(simulate("elbow", seed=2, params={"duration": 8.0}), Protocol())
    columns = np.vstack([f.velocity * np.abs(f.velocity), f.angle ** 2, np.sign(f.velocity)][:extra]) if extra else None
    problem, _ = mechanics_problem(f, extra=columns)
    rng = np.random.default_rng(extra)
    logs = problem.bounds.mean(axis=1) + rng.standard_normal((6, 4))
    steps = problem.steps
    zero = dataclasses.replace(steps, channels=np.vstack([steps.channels[:1], 0 * steps.channels[1:]]))
    for st in (steps, zero):
        loglik, mean, cov = marginal_many(st, logs)
        for j, row in enumerate(logs):
            one = marginal(st, NoiseLevels.from_logs(row))
            assert loglik[j] == one.loglik or (np.isneginf(loglik[j]) and np.isneginf(one.loglik))
            np.testing.assert_array_equal(mean[j], one.coefficients)
            np.testing.assert_array_equal(cov[j], one.covariance)
    assert np.any(np.isneginf(marginal_many(zero, logs)[0]))      # the case is exercised
