"""The state-space (Kalman) model of a recording, written once for every user.

One step per (decimated) sample k:

    s[k] = s[k−1] + σ[k−1]·(y[k] − y[k−1]) + g[k]·w_c + w_s    elastic torque: ds = σ·dy
    σ[k] = σ[k−1] + w_σ + w_c                                    stiffness: a random walk
    c₀[k] − Σ_j β_j·c_j[k] = s[k] + v                            measurement

with w_s ~ N(0, Q_s·Δt), w_σ ~ N(0, Q_σ·Δt), w_c ~ N(0, Q_c·Δt), v ~ N(0, R) (the levels:
:class:`~limbstiff.statespace.noise.NoiseLevels`), g the spring's deflection. The measurement is
the torque c₀ less the columns c_j whose coefficients β_j enter linearly: ÿ and ẏ with (m, b) in
the identification, an effect's torque with its amplitude in the diagnosis, nothing (z given) in
the estimator. The filter's covariance does not depend on the data, so one pass over all channels
gives the likelihood as a quadratic form in (1, −β) and the β integrate out exactly.

Modules (one idea each):

- :mod:`.noise` — the noise levels, their bounds, the search over their logarithms;
- :mod:`.steps` — :class:`~.steps.ModelSteps`, the model's data at its steps, and its builders;
- :mod:`.smoother` — log-likelihood, the causal (forward) filter, the RTS smoother, the stiffness
  state placed back on the samples;
- :mod:`.linear` — the linear coefficients: innovations, the marginal likelihood with any number
  of them integrated out, their sandwich covariance;
- :mod:`.kernels` — the loops, compiled with numba: one step of the model and one forward pass.

A stiffness that is a smooth function of a cycle's phase or of a recorded variable,
σ = Σ_j β_j·h_j(·) + walk, adds one column per basis function whose weight is a linear coefficient
like m and b (:func:`.linear.marginal`; :mod:`limbstiff.scheduled`). A live estimate is the forward
pass's step (:func:`.kernels.step`, which :mod:`limbstiff.live.kernel` calls as the data arrive), whose
moments at a step use the data up to it only.
Pure numpy and scipy: no I/O. Below estimation, identification, checks, the corner scan and the
diagnosis (docs/architecture.md, "Layering").
"""
