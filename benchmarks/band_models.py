"""Which state-space model calibrates the stiffness band? An experiment for issue 14.

    python benchmarks/band_models.py [--seeds 2] [--scenarios elbow ankle ...]

The shipped Kalman model (:mod:`limbstiff.estimate.kalman`) has the stiffness as a random walk
and white measurement noise R. Its 90 % band holds the truth at 100 % of the samples on the
accuracy benchmark's stiffness ramps: the band is 3–4× the error there. Two suspects:

* the prior: a random walk fitted to a smooth course allows wiggles the course does not have;
  an integrated random walk (the stiffness's rate of change τ as a state) does not;
* the noise: z = f − m·ÿ − b·ẏ carries the angle's quantisation through m·ÿ, whose spectrum
  rises as f⁴ up to the filter's corner, so a white R fitted to its total power overstates the
  noise at the motion's frequencies, where the stiffness is measured.

For every scenario of ``benchmarks/accuracy.py`` (m and b identified by ``analyze``), this fits
four models by maximum likelihood at the Kalman steps and compares their smoothed stiffness and
90 % band with the truth (informed samples after the first 2 s; the band adds the m, b part of
the shipped analysis to each):

* ``rw``: the shipped model (its own fit);
* ``irw``: s, σ and τ = dσ/dt as states, dσ = τ·dt + w_σ + w_c, the change τ·dt moving the
  deflected spring's torque as w_c does; noise levels R, Q_s, Q_σ, Q_c, Q_τ;
* ``irw+ma2``: the same with measurement noise a + r, a an MA(2) process u[k] + θ₁·u[k−1] +
  θ₂·u[k−2] (its variance Q_u, θ fitted; θ = (−2, 1) is a second difference, the shape of
  quantisation through ÿ) and r white;
* ``irw+ma2+angle``: the same with a stiffness that depends on the deflection g (the angle less its
  moving average): σ₀ + σ₁·g + σ₂·g², σ₁ and σ₂ walking slowly (Q₁, Q₂), the torque following
  ds = σ(g)·dy. A second-order expansion of any smooth spring about the working point.

The models here are a generic Kalman filter and RTS smoother (numba, dense matrices), written
for this experiment only: the package's kernels are specialised to the two-state model. Writes
``benchmarks/RESULTS.md`` (section ``band_models``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba
import numpy as np
from scipy import optimize

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import machine, update_section  # noqa: E402
from accuracy import SCENARIOS  # noqa: E402

from limbstiff.analysis import analyze  # noqa: E402
from limbstiff.estimate import estimators  # noqa: E402
from limbstiff.estimate.kalman import at_steps  # noqa: E402
from limbstiff.simulate import simulate  # noqa: E402

Z90 = 1.6448536269514722
MODELS = ("rw", "irw", "irw+ma2", "irw+ma2+angle")


@numba.njit(cache=True)
def _transition(F, dy, g, g_prev, dt, angle, noise_at):
    F[:, :] = 0.0
    F[0, 0] = 1.0
    F[0, 1] = dy
    F[0, 2] = g * dt
    F[1, 1] = 1.0
    F[1, 2] = dt
    F[2, 2] = 1.0
    if angle:
        mid = 0.5 * (g + g_prev)
        F[0, 3] = mid * dy
        F[0, 4] = mid * mid * dy
        F[3, 3] = 1.0
        F[4, 4] = 1.0
    if noise_at > 0:
        F[noise_at + 1, noise_at] = 1.0
        F[noise_at + 2, noise_at + 1] = 1.0


@numba.njit(cache=True)
def kalman_irw(dy, g, z, dt, levels, theta, x0, P0, angle, ma2, smooth):
    """Filter (and RTS smoother) of the IRW model: states s, σ₀, τ; with ``angle`` also σ₁, σ₂ (the
    stiffness σ₀ + σ₁·g + σ₂·g² at deflection g); with ``ma2`` the MA(2) noise states last.

    levels = (R, Q_s, Q_σ, Q_c, Q_τ, Q_u, Q₁, Q₂); theta = (θ₁, θ₂). Returns the smoothed means
    (n, d), covariances (n, d, d) and the log-likelihood.
    """
    n, d = len(z), len(x0)
    R, Qs, Qsig, Qc, Qtau, Qu, Q1, Q2 = levels
    noise_at = d - 3 if ma2 else 0
    xf, Pf = np.zeros((n, d)), np.zeros((n, d, d))
    xp, Pp = np.zeros((n, d)), np.zeros((n, d, d))
    F, Q = np.zeros((d, d)), np.zeros((d, d))
    H = np.zeros(d)
    H[0] = 1.0
    if ma2:
        H[noise_at], H[noise_at + 1], H[noise_at + 2] = 1.0, theta[0], theta[1]
    x, P, ll = x0.copy(), P0.copy(), 0.0
    for k in range(n):
        if k > 0:
            _transition(F, dy[k], g[k], g[k - 1], dt, angle, noise_at)
            Q[:, :] = 0.0
            Q[0, 0] = (Qs + g[k] * g[k] * Qc) * dt
            Q[0, 1] = Q[1, 0] = g[k] * Qc * dt
            Q[1, 1] = (Qsig + Qc) * dt
            Q[2, 2] = Qtau * dt
            if angle:
                Q[3, 3] = Q1 * dt
                Q[4, 4] = Q2 * dt
            if ma2:
                Q[noise_at, noise_at] = Qu
            x = F @ x
            P = F @ P @ F.T + Q
        xp[k], Pp[k] = x, P
        PH = P @ H
        S = H @ PH + R
        e = z[k] - H @ x
        ll += -0.5 * (np.log(2 * np.pi * S) + e * e / S)
        K = PH / S
        x = x + K * e
        P = P - np.outer(K, PH)
        xf[k], Pf[k] = x, P
    xs, Ps = xf.copy(), Pf.copy()
    if smooth:
        for k in range(n - 2, -1, -1):
            _transition(F, dy[k + 1], g[k + 1], g[k], dt, angle, noise_at)
            J = Pf[k] @ F.T @ np.linalg.pinv(Pp[k + 1])
            xs[k] = xf[k] + J @ (xs[k + 1] - xp[k + 1])
            Ps[k] = Pf[k] + J @ (Ps[k + 1] - Pp[k + 1]) @ J.T
    return xs, Ps, ll


def _model(steps, noise, ma2: bool, angle: bool = False):
    """Log-likelihood and smoother of the IRW model as functions of its free parameters q — ln R,
    ln Q_s, ln Q_σ, ln Q_c, ln Q_τ, then θ₁, θ₂, ln Q_u (``ma2``), then ln Q₁, ln Q₂ (``angle``); the
    smoother gives the stiffness at each step and its variance."""
    n = len(steps.measured)
    duration = n * steps.step
    p11, _, p22 = steps.initial_cov
    d = 3 + 2 * angle + 3 * ma2
    g = steps.deflection
    spread = max(float(np.std(g)), 1e-12)

    def run(q, smooth=False):
        k = 5
        theta, qu = np.zeros(2), -np.inf
        if ma2:
            theta, qu, k = np.array([q[5], q[6]]), q[7], 8
        q12 = q[k:k + 2] if angle else [-np.inf, -np.inf]
        levels = np.exp(np.r_[q[:5], qu, q12])
        x0 = np.zeros(d)
        x0[:2] = steps.initial_mean
        diag = [p11, p22, 100 * p22 / duration ** 2] + ([100 * p22 / spread ** 2, 100 * p22 / spread ** 4]
                                                        if angle else []) + [levels[5]] * (3 * ma2)
        xs, Ps, ll = kalman_irw(steps.increments, g, steps.measured, steps.step, levels, theta, x0, np.diag(diag),
                                angle, ma2, smooth)
        if not smooth:
            return None, None, ll
        h = np.zeros((n, d))
        h[:, 1] = 1.0
        if angle:
            h[:, 3], h[:, 4] = g, g * g
        return np.sum(h * xs, axis=1), np.einsum("ki,kij,kj->k", h, Ps, h), ll
    return run


def _fit(run, starts):
    """Maximum likelihood by Nelder–Mead from each start, restarted once from its optimum."""
    best = None
    for s0 in starts:
        res = None
        for _ in range(2):
            res = optimize.minimize(lambda q: -run(q)[2], s0 if res is None else res.x, method="Nelder-Mead",
                                    options={"maxiter": 4000, "xatol": 1e-3, "fatol": 1e-3})
        if best is None or res.fun < best.fun:
            best = res
    return best.x


def compare(name: str, seed: int) -> list[dict]:
    """The three models' fit, error and band on one trial of scenario ``name``."""
    scenario, params, _ = SCENARIOS[name]
    trial = simulate(scenario, seed=seed, params=params)
    result = analyze(trial, seed=seed)
    estimate = estimators.kalman(result.filtered, inertia=result.inertia.median, damping=result.damping.median,
                                 noise=result.fit.noise)
    steps, noise = estimate.steps, result.fit.noise
    idx = steps.index
    use = (result.observable & (trial.time - trial.time[0] >= 2.0))[idx]
    truth = trial.stiffness_true[idx][use]
    mech = (estimate.variance_with(result.identification.covariance) - estimate.variance)[idx][use]
    duration = len(steps.measured) * steps.step
    tau0 = np.log(steps.initial_cov[2] / duration ** 3)
    rows = [_row("rw", estimate.stiffness[idx][use], estimate.variance[idx][use] + mech, truth, result.fit.loglik,
                 result.fit.loglik, 0.0)]
    t0 = time.perf_counter()
    irw = _model(steps, noise, ma2=False)
    q_irw = _fit(irw, [np.r_[noise.logs(), tau0 + shift] for shift in (0.0, -8.0)])
    rows.append(_evaluate("irw", irw, q_irw, use, truth, mech, result.fit.loglik, time.perf_counter() - t0))
    t0 = time.perf_counter()
    ma2 = _model(steps, noise, ma2=True)
    starts = [np.r_[q_irw[:5] - [2, 0, 0, 0, 0], theta, noise.logs()[0] - 2]
              for theta in ((-2.0, 1.0), (-1.0, 0.0), (0.0, 0.0))]
    q_ma2 = _fit(ma2, starts)
    rows.append(_evaluate("irw+ma2", ma2, q_ma2, use, truth, mech, result.fit.loglik, time.perf_counter() - t0))
    t0 = time.perf_counter()
    both = _model(steps, noise, ma2=True, angle=True)
    walk = np.log(steps.initial_cov[2] / duration) - 2 * np.log(max(float(np.std(steps.deflection)), 1e-12))
    starts = [np.r_[q_ma2, walk + shift, walk + shift - 2 * np.log(max(float(np.std(steps.deflection)), 1e-12))]
              for shift in (-4.0, -12.0)]
    rows.append(_evaluate("irw+ma2+angle", both, _fit(both, starts), use, truth, mech, result.fit.loglik,
                          time.perf_counter() - t0))
    return rows


def _evaluate(model, run, q, use, truth, mech, rw_loglik, seconds):
    stiffness, var, ll = run(q, smooth=True)
    return _row(model, at_steps(stiffness)[use], at_steps(np.maximum(var, 0.0))[use] + mech, truth, ll, rw_loglik,
                seconds)


def _row(model, estimate, variance, truth, loglik, rw_loglik, seconds) -> dict:
    z = (estimate - truth) / np.sqrt(variance)
    return {"model": model, "coverage": float(np.mean(np.abs(z) <= Z90)), "rms_z": float(np.sqrt(np.mean(z ** 2))),
            "median_error": float(np.median(np.abs(estimate - truth) / np.abs(truth))),
            "loglik_gain": float(loglik - rw_loglik), "seconds": seconds}


def main(seeds: int, names: list[str]) -> str:
    lines = ["| scenario | model | coverage of 90 % band (seeds) | rms of error ÷ band sd | median error "
             "| log-likelihood − rw's | fit time |", "|---|---|---|---|---|---|---|"]
    for name in names:
        per = [compare(name, seed) for seed in range(seeds)]
        for k, model in enumerate(MODELS):
            rows = [p[k] for p in per]
            cov = ", ".join(f"{100 * r['coverage']:.0f} %" for r in rows)
            rms = ", ".join(f"{r['rms_z']:.2f}" for r in rows)
            gain = ", ".join(f"{r['loglik_gain']:+.0f}" for r in rows)
            error = 100 * np.median([r["median_error"] for r in rows])
            lines.append(f"| {name} | {model} | {cov} | {rms} | {error:.2f} % | {gain} "
                         f"| {np.median([r['seconds'] for r in rows]):.0f} s |")
            print(lines[-1], flush=True)
    return "\n".join(lines)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--scenarios", nargs="*", default=list(SCENARIOS))
    args = parser.parse_args()
    table = main(args.seeds, args.scenarios)
    update_section("band_models", "\n".join([
        "## Which model calibrates the stiffness band (`benchmarks/band_models.py`, issue 14)", "",
        f"{args.seeds} seeds per scenario of the accuracy benchmark, m and b identified by `analyze`; informed "
        f"samples after the first 2 s, at the Kalman steps. Machine: {machine()}.", "",
        "`rw`: the shipped model; `irw`: the stiffness's rate of change as a state; `irw+ma2`: that, with "
        "MA(2) measurement noise besides the white; `irw+ma2+angle`: that, with a stiffness quadratic in the "
        "deflection. A calibrated band has coverage near 90 % and an rms of "
        "error ÷ band sd near 1 (below 1: the band is too wide).", "", table]))
