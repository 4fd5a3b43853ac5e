"""The band scaled by how the recording's own noise passes through the smoother (issue 14).

    python benchmarks/band_scale.py [--seeds 2] [--jobs 2]

The Kalman smoother's gains depend only on the ratios of its noise levels: the model with R and
every Q times c gives the same stiffness (the accuracy unchanged) and c times the posterior
variance. If the torque left to the elastic element is not white (on encoders, the quantisation
through m·ÿ is blue), c could be measured from the recording: the variance of the smoothed
stiffness when the fixed smoother is fed the recording's own noise, over its variance when fed
white noise of variance R. The recording's noise is its residual, its correlation and changing
level kept by Shao's dependent wild bootstrap (JASA 105:218, 2010: residual × a moving average of
white draws over ⌈n^⅓⌉ steps). Measured before building it, on the accuracy scenarios as
simulated and, for four of them, with the same trial's angle exact (white-ish noise, where c
should be near 1):

* ``shipped``: the model's posterior variance;
* ``data's noise alone``: the variance of the fixed smoother's response to the bootstrapped
  residual, per sample (the noise's part of the error, without the prior's);
* ``× c (white noise)``: the shipped variance times c = that variance ÷ the response's to white
  noise of variance R (averaged over the informed steps);
* ``× c (white residual)``: the same, the white noise's residual bootstrapped like the data's
  (the residual lacks what the smoother takes into the state, for both).

The m, b part of the band is added as shipped. Per trial: c, the band's coverage and the rms of
error ÷ band sd over the informed samples after the first 2 s. Writes the section
``band_scale`` of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import band_cells, machine, update_section  # noqa: E402
from accuracy import SCENARIOS  # noqa: E402

Z90 = 1.6448536269514722
DRAWS = 64
EXACT = ("elbow", "elbow-66Hz", "elbow-coarse", "wrist")
METHODS = ("shipped", "data's noise alone", "× c (white noise)", "× c (white residual)")


def _response(steps, noise, measured):
    """The smoothed stiffness (aligned) when the model is fed ``measured`` alone."""
    from limbstiff.estimate.kalman import at_steps, kalman_smoother
    out = kalman_smoother(steps.increments, measured, noise, step=steps.step, deflection=steps.deflection,
                          initial_mean=(0.0, 0.0), initial_cov=steps.initial_cov, loglik=False)
    return out.mean[:, 0], at_steps(out.mean[:, 1])


def _variances(steps, noise, rng):
    """Per-step variances of the smoother's response to the data's residual, to white noise and to
    white noise's residual, each bootstrapped (multiplier over ⌈n^⅓⌉ steps)."""
    from limbstiff.estimate.kalman import kalman_smoother
    n = len(steps.measured)
    smoothed = kalman_smoother(steps.increments, steps.measured, noise, step=steps.step,
                               deflection=steps.deflection, initial_mean=steps.initial_mean,
                               initial_cov=steps.initial_cov, loglik=False)
    residual = steps.measured - smoothed.mean[:, 0]
    block = int(np.ceil(n ** (1 / 3)))
    box = np.ones(block) / np.sqrt(block)
    out = np.zeros((3, n))
    for _ in range(DRAWS):
        xi = np.convolve(rng.standard_normal(n + block - 1), box, "valid")
        out[0] += _response(steps, noise, residual * xi)[1] ** 2
        white = rng.standard_normal(n) * np.sqrt(noise.measurement)
        torque, stiffness = _response(steps, noise, white)
        out[1] += stiffness ** 2
        xi = np.convolve(rng.standard_normal(n + block - 1), box, "valid")
        out[2] += _response(steps, noise, (white - torque) * xi)[1] ** 2
    return out / DRAWS


def _one(job) -> list[dict]:
    from limbstiff.analysis import analyze
    from limbstiff.estimate import estimators
    from limbstiff.estimate.kalman import _regular_grid
    from limbstiff.simulate import simulate
    name, angle, seed = job
    scenario, params, _ = SCENARIOS[name]
    params = {**params, **({"encoder_counts": 0} if angle == "exact" else {})}
    result = analyze(simulate(scenario, seed=seed, params=params), seed=0)
    f, t = result.filtered, result.trial.time
    use = result.observable & (t - t[0] >= 2.0)
    truth = result.trial.stiffness_true[use]
    est = estimators.kalman(f, inertia=result.inertia.median, damping=result.damping.median,
                            noise=result.fit.noise)
    mechanics = est.variance_with(result.identification.covariance) - est.variance
    steps = est.steps
    back = _regular_grid(len(t), f.edge, est.fit.decimation, len(steps.index))
    data, white, white_residual = (back(v) for v in _variances(steps, est.fit.noise, np.random.default_rng([seed, 15])))
    scale_white = float(np.mean(data[use]) / np.mean(white[use]))
    scale_residual = float(np.mean(data[use]) / np.mean(white_residual[use]))
    variances = {"shipped": est.variance, "data's noise alone": data, "× c (white noise)": scale_white * est.variance,
                 "× c (white residual)": scale_residual * est.variance}
    error = est.stiffness[use] - truth
    rows = []
    for method, variance in variances.items():
        sd = np.sqrt(variance[use] + mechanics[use])
        rows.append({"name": name, "angle": angle, "seed": seed, "method": method,
                     "c": {"× c (white noise)": scale_white, "× c (white residual)": scale_residual}.get(method),
                     "coverage": float(np.mean(np.abs(error) <= Z90 * sd)),
                     "ratio": float(np.sqrt(np.mean((error / sd) ** 2)))})
    return rows


def table(rows: list[dict]) -> list[str]:
    lines = ["| scenario | angle | band | c (seeds) | coverage of 90 % band (seeds) "
             "| rms of error ÷ band sd (seeds) |", "|---|---|---|---|---|---|"]
    for name, angle in dict.fromkeys((r["name"], r["angle"]) for r in rows):
        for method in METHODS:
            sel = [r for r in rows if r["name"] == name and r["angle"] == angle and r["method"] == method]
            c = ", ".join("%.2f" % r["c"] for r in sel) if sel[0]["c"] is not None else "–"
            lines.append(f"| {name} | {angle} | {method} | {c} | {band_cells(sel)} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    seeds = [100 + s for s in range(args.seeds)]
    jobs = ([(name, "as recorded", s) for name in SCENARIOS for s in seeds]
            + [(name, "exact", s) for name in EXACT for s in seeds])
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.jobs) as pool:
        rows = [r for part in pool.map(_one, jobs) for r in part]
    wall = time.perf_counter() - t0
    text = "\n".join([
        "## The band scaled by how the recording's noise passes through the smoother "
        "(`benchmarks/band_scale.py`, issue 14)", "",
        f"The accuracy benchmark's scenarios, seeds {seeds[0]}–{seeds[-1]}, as simulated and (four of them) with the "
        "angle exact; m and b identified (their part of the band as shipped); informed samples after the first 2 s. "
        f"{DRAWS} bootstrap draws of each kind. `data's noise alone`: the fixed smoother's response to the residual "
        "(dependent wild bootstrap), no prior part; `× c`: the shipped variance times c, the response's variance to "
        "the residual over that to white noise of variance R (or to white noise's residual, bootstrapped alike). "
        f"Calibrated: coverage near 90 %, rms of error ÷ band sd near 1. {wall:.0f} s on {args.jobs} processes. "
        f"Machine: {machine()}.", "", *table(rows)])
    update_section("band_scale", text)
    print(text)


if __name__ == "__main__":
    main()
