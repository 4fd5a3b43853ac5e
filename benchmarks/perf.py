"""Speed and memory of the estimator passes and of ``analyze``, as ratios measured in one run.

    python benchmarks/perf.py [--quick]

1. One estimator pass on 10⁶ samples ÷ one ``numpy.cumsum`` over 10⁶ float64 (target ≤ 10):
   the observer (exact and Euler discretisations, forwards and backwards, as the estimators run
   it; and the pure-NumPy blocked scan used without numba) and the Kalman filter + RTS smoother.
2. Bands from 2000 posterior draws ÷ one estimator pass (target ≤ 3).
3. Full ``analyze`` of a 60 s, 1 kHz trial with identification, bands and the PDF report (target
   ≤ 5 s on 2 cores), and the report's time ÷ the analysis's (target ≤ 0.4; median of 5 runs,
   in one process with matplotlib already imported).
4. ``analyze`` time against trial length, 10 s to 1 hour, and the fitted exponent (linear: 1).
5. Peak memory of reading and analysing a one-hour 1 kHz trial (3.6 million samples) with
   identification and bands and writing its PDF report, in a fresh process (target < 1 GB), and
   there the report's time ÷ the analysis's (target ≤ 0.4).
Times are the best of several repetitions (the least disturbed by other processes). Writes
section ``perf`` of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import machine, update_section  # noqa: E402

from limbstiff.analysis import analyze  # noqa: E402
from limbstiff.estimate import estimators, observer, scan  # noqa: E402
from limbstiff.statespace import kernels  # noqa: E402
from limbstiff.statespace.noise import NoiseLevels  # noqa: E402
from limbstiff.statespace.smoother import kalman_smoother  # noqa: E402
from limbstiff.statespace.steps import deflection  # noqa: E402
from limbstiff.filtered import filter_trial  # noqa: E402
from limbstiff.protocol import Protocol  # noqa: E402
from limbstiff.simulate import simulate  # noqa: E402

N = 1_000_000


def best(func, repeats: int = 7) -> float:
    """Shortest wall time of ``repeats`` calls, s."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        func()
        times.append(time.perf_counter() - t0)
    return min(times)


def signals_of(trial):
    return filter_trial(trial, Protocol())


def passes() -> tuple[list[tuple[str, float]], float, dict]:
    """Seconds of one pass of each estimator over 10⁶ samples, and of one cumsum."""
    trial = simulate("ankle", seed=0, params={"duration": N / 1000.0 - 0.001})
    sig = signals_of(trial)
    m, b, ts = 0.015, 1.0, sig.sample_period
    drive = observer.external_drive(sig.torque_rate, sig.acceleration, sig.jerk, inertia=m, damping=b)
    x = np.random.default_rng(0).standard_normal(N)
    t_cumsum = best(lambda: np.cumsum(x), 21)
    out = []
    for disc in ("exact", "euler"):
        gain = 0.5 if disc == "euler" else 300.0       # Euler needs α·|ẏ|·Ts < 2 to stay stable
        for direction, sl in (("forwards", slice(None)), ("backwards", slice(None, None, -1))):
            vel, drv = np.ascontiguousarray(sig.velocity[sl]), np.ascontiguousarray(drive[sl])
            out.append((f"observer, {disc}, {direction} (coefficients in NumPy, compiled recursion: as the estimators run it)",
                        best(lambda disc=disc, gain=gain, vel=vel, drv=drv: observer.observe(
                            vel, drv, observer_gain=gain, sample_period=ts, discretisation=disc))))

    def numpy_pass():
        a, c = observer.recursion_coefficients(sig.velocity, drive, observer_gain=300.0, sample_period=ts)
        return scan.linear_recursion(a, c)
    out.append(("observer, exact, pure NumPy (coefficients + blocked scan; the reference path)", best(numpy_pass)))
    a, c = observer.recursion_coefficients(sig.velocity, drive, observer_gain=300.0, sample_period=ts)
    out.append(("  the recursion alone, compiled", best(lambda: kernels.linear_recursion(a, c, 0.0))))
    out.append(("  the recursion alone, NumPy blocked scan", best(lambda: scan.linear_recursion(a, c))))
    z = sig.elastic_torque(m, b)
    d = np.diff(sig.angle, prepend=sig.angle[0])
    noise = NoiseLevels(1e-2, 1e-1, 1.0, 1.0)
    kw = dict(step=ts, deflection=deflection(sig.angle, step=ts, motion_frequency=sig.motion_hz), initial_mean=np.array([z[0], 60.0]), initial_cov=np.array([1.0, 0.0, 1e4]))

    def kalman(loglik):
        return kalman_smoother(d, z, noise, loglik=loglik, **kw)
    out.append(("Kalman filter + RTS smoother, every sample, with the log-likelihood", best(lambda: kalman(True), 5)))
    out.append(("Kalman filter + RTS smoother, every sample (the responses to ÿ and ẏ: no log-likelihood)",
                best(lambda: kalman(False), 5)))
    out.append(("Kalman estimator as analyze runs it: steps at 2.5× the corner, σ̂ and its two "
                "sensitivities, back to every sample",
                best(lambda: estimators.kalman(sig, inertia=m, damping=b,
                                               noise=noise), 3)))
    return out, t_cumsum, {"sig": sig}


def bands(sig) -> dict:
    """Bands from 2000 draws of (m, b) against one observer pass."""
    kw = dict(smoothed=False, gain=300.0, velocity_threshold=0.0)
    est = estimators.observers(sig, inertia=0.015, damping=1.0, **kw)
    t_three = best(lambda: estimators.observers(sig, inertia=0.015, damping=1.0, **kw), 5)
    draws = np.random.default_rng(0).multivariate_normal([0.015, 1.0], [[1e-8, 0], [0, 1e-4]], 2000)
    t_cov = best(lambda: est.variance_with(np.cov(draws.T)), 7)
    t_pass = t_three / 3                          # σ̂, ∂σ̂/∂m, ∂σ̂/∂b: three passes
    return {"pass": t_pass, "given_sensitivities": t_cov, "with_sensitivities": t_cov + 2 * t_pass,
            "naive": 2000 * t_pass}


def full_analyze(trial, pdf: bool, folder: Path) -> float:
    """Seconds to analyse ``trial`` (and write its report when ``pdf``)."""
    analysis, report = analyze_and_report(trial, pdf, folder)
    return analysis + report


def analyze_and_report(trial, pdf: bool, folder: Path) -> tuple[float, float]:
    """Seconds of the analysis and of the PDF report (0 without ``pdf``)."""
    from limbstiff.report import write_report
    t0 = time.perf_counter()
    result = analyze(trial, seed=0)
    t1 = time.perf_counter()
    if pdf:
        write_report(result, folder / f"{trial.name}.pdf")
    return t1 - t0, time.perf_counter() - t1


def report_ratio(trial, folder: Path, repeats: int = 5) -> dict:
    """Median seconds of analysis and report over ``repeats`` runs, and their ratio."""
    runs = np.array([analyze_and_report(trial, True, folder) for _ in range(repeats)])
    analysis, report = np.median(runs, axis=0)
    return {"analysis": float(analysis), "report": float(report), "ratio": float(report / analysis)}


MEMORY_SCRIPT = """
import sys, time
from limbstiff.files import read_trial
from limbstiff.analysis import analyze

def peak_mb():
    # VmHWM: this process's own peak resident set (ru_maxrss would carry over the parent's
    # peak through fork and exec)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024

base = peak_mb()
t0 = time.perf_counter()
trial = read_trial(sys.argv[1])
result = analyze(trial, seed=0)
t1 = time.perf_counter()
from limbstiff.report import write_report
write_report(result, sys.argv[1] + ".pdf")
print(t1 - t0, base, peak_mb(), trial.n_samples, time.perf_counter() - t1)
"""


def memory(duration: float, folder: Path) -> dict:
    """Peak resident memory of a fresh process reading and analysing one long trial, MB."""
    from limbstiff.files import write_trial
    path = folder / "long.csv"
    write_trial(simulate("ankle", seed=5, params={"duration": duration}), path)
    warm = "import limbstiff.analysis, limbstiff.files, numpy, limbstiff.report; import limbstiff.statespace.kernels"
    subprocess.run([sys.executable, "-c", warm], check=True)
    out = subprocess.run([sys.executable, "-c", MEMORY_SCRIPT, str(path)], check=True, capture_output=True,
                         text=True).stdout.split()
    return {"seconds": float(out[0]), "imports_mb": float(out[1]), "peak_mb": float(out[2]),
            "samples": int(out[3]), "file_mb": path.stat().st_size / 2 ** 20, "report": float(out[4])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="stop the length study at 10 minutes")
    args = parser.parse_args()
    analyze(simulate("ankle", seed=1, params={"duration": 5.0}))          # compile the kernels first
    rows, t_cumsum, ctx = passes()
    bnd = bands(ctx["sig"])
    lengths = [10.0, 30.0, 100.0, 300.0, 600.0] + ([] if args.quick else [1800.0, 3600.0])
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        ratios = {s: report_ratio(simulate(s, seed=3, params={"duration": 60.0}), folder)
                  for s in ("elbow", "wrist", "ankle")}
        # the medians of the same runs: one run varies by ±20 % on a shared 2-core machine
        t60_all = {s: r["analysis"] + r["report"] for s, r in ratios.items()}
        scaling = [(d, full_analyze(simulate("ankle", seed=4, params={"duration": d}), False, folder))
                   for d in lengths]
        mem = memory(3600.0 if not args.quick else 600.0, folder)
    slope = float(np.polyfit(np.log([d for d, _ in scaling]), np.log([t for _, t in scaling]), 1)[0])
    upper = float(np.polyfit(np.log([d for d, _ in scaling[2:]]), np.log([t for _, t in scaling[2:]]), 1)[0])

    lines = ["## Performance (`benchmarks/perf.py`)", "", f"Machine: {machine()}.", "",
             f"One `numpy.cumsum` over 10⁶ float64: {1e3 * t_cumsum:.2f} ms "
             f"({1e9 * t_cumsum / N:.2f} ns per sample). Best of several runs.", "",
             "| estimator pass over 10⁶ samples | time | ÷ cumsum |", "|---|---|---|"]
    for name, t in rows:
        lines.append(f"| {name} | {1e3 * t:.1f} ms | {t / t_cumsum:.1f} |")
    lines += ["", "Target ≤ 10 × cumsum per pass.", "",
              "| bands from 2000 posterior draws of (m, b) | time | ÷ one observer pass |", "|---|---|---|",
              f"| covariance of the draws through the sensitivities ∂σ̂/∂(m, b) | "
              f"{1e3 * bnd['given_sensitivities']:.1f} ms | {bnd['given_sensitivities'] / bnd['pass']:.2f} |",
              f"| the same, counting the two sensitivity passes | {1e3 * bnd['with_sensitivities']:.1f} ms | "
              f"{bnd['with_sensitivities'] / bnd['pass']:.2f} |",
              f"| (re-running the estimator per draw, for comparison) | {bnd['naive']:.1f} s | 2000 |",
              "", "Target ≤ 3.", "",
              "Full `analyze` of a 60 s, 1 kHz trial (identification with emcee, bands, PDF report; median "
              "analysis + median report of the 5 runs below): " +
              ", ".join(f"{s} {t:.2f} s" for s, t in t60_all.items()) + " (target ≤ 5 s).", "",
              "| 60 s, 1 kHz trial | analysis | PDF report | report ÷ analysis |", "|---|---|---|---|"]
    for s, r in ratios.items():
        lines.append(f"| {s} | {r['analysis']:.2f} s | {r['report']:.2f} s | **{r['ratio']:.2f}** |")
    hour = mem["report"] / mem["seconds"]
    lines += [f"| {mem['samples'] / 1000 / 60:.0f} minutes (ankle, fresh process; analysis includes reading) | "
              f"{mem['seconds']:.2f} s | {mem['report']:.2f} s | **{hour:.2f}** |", "",
              "Target: report ≤ 0.4 × analysis (median of 5 runs in one process, matplotlib imported; "
              "the one-hour trial once, its report's time includes importing matplotlib).", "",
              "| trial length (ankle, 1 kHz) | `analyze` (identification + bands, no PDF) | per minute of data |",
              "|---|---|---|"]
    for d, t in scaling:
        lines.append(f"| {d:g} s | {t:.2f} s | {60 * t / d:.2f} s |")
    lines += ["", f"Fitted exponent of time against length: **{slope:.2f}** over 10 s–{lengths[-1]:g} s "
                  f"({upper:.2f} from 100 s up; 1 = linear).", "",
              f"Peak memory, fresh process reading ({mem['file_mb']:.0f} MB CSV) and analysing a "
              f"{mem['samples'] / 1000 / 60:.0f}-minute 1 kHz trial ({mem['samples']} samples) with "
              f"identification and bands, then writing its PDF report: **{mem['peak_mb']:.0f} MB** (after imports "
              f"{mem['imports_mb']:.0f} MB; {mem['seconds']:.1f} s + {mem['report']:.1f} s). Target < 1 GB."]
    text = "\n".join(lines) + "\n"
    print(text)
    update_section("perf", text)


if __name__ == "__main__":
    main()
