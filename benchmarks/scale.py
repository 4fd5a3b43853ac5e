"""Scaling of a batch on a dask.distributed cluster: 1, 2 and 4 worker processes on 200 trials.

    python benchmarks/scale.py [--trials 200] [--duration 5] [--workers 1 2 4]

Simulated elbow, wrist and ankle trials (seeds 0…N−1, one scenario after another) are written to
a temporary folder and analysed with reports by :func:`limbstiff.analyze_files` on a
``LocalCluster`` of W single-threaded worker processes (``executor=client.get_executor()``, what
``limbstiff analyze --scheduler`` does), for each W in one run on the same files. Measured:

- trials per second and the efficiency (rate with W workers ÷ W × rate with one worker); W
  beyond the machine's cores cannot scale, and the table says how many cores there are;
- where a worker's time goes, from dask's task stream: computing the trial vs. the rest of the
  wall time × W (scheduling, serialisation, idle workers at the end);
- within a trial's compute (measured in this process on every 10th trial): reading the file,
  the analysis, the PDF report, writing the outputs;
- from these, what a 10 000-trial study of 1–10-minute trials costs on a 16-node cluster.

Writes section ``scale`` of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import machine, update_section  # noqa: E402

import limbstiff  # noqa: E402
from limbstiff.files import write_trial  # noqa: E402
from limbstiff.simulate import simulate  # noqa: E402

SCENARIOS = ("elbow", "wrist", "ankle")


def make_trials(folder: Path, n: int, duration: float) -> list[Path]:
    """``n`` simulated trials of ``duration`` s, written as CSV."""
    paths = []
    for k in range(n):
        trial = simulate(SCENARIOS[k % 3], seed=k, params={"duration": duration})
        path = folder / f"{SCENARIOS[k % 3]}-{k:03d}.csv"
        write_trial(trial, path)
        paths.append(path)
    return paths


def warm() -> None:
    """On each worker before timing: what the first trial of a fresh process pays once."""
    from limbstiff.report import report_figures
    report_figures(limbstiff.analyze(simulate("elbow", seed=0, params={"duration": 2.0}), seed=0))


def on_cluster(folder: Path, out: Path, workers: int) -> dict:
    """Analyse the folder on a LocalCluster of ``workers`` processes; wall time and task stream."""
    from dask.distributed import LocalCluster, get_task_stream

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with cluster.get_client() as client:
            client.run(warm)                      # imports, compiled kernels, fonts: not part of a trial
            with get_task_stream(client) as stream:
                t0 = time.perf_counter()
                report = limbstiff.analyze_files([folder], out=out, executor=client.get_executor(pure=False))
                wall = time.perf_counter() - t0
    compute = sum(s["stop"] - s["start"] for task in stream.data for s in task["startstops"]
                  if s["action"] == "compute")
    moved = sum(s["stop"] - s["start"] for task in stream.data for s in task["startstops"]
                if s["action"] in ("transfer", "deserialize", "disk-read"))
    return {"wall": wall, "compute": compute, "moved": moved, "failed": report.n_failed,
            "trials": len(report.outcomes)}


def phases(paths: list[Path], out: Path) -> dict:
    """Seconds per trial reading, analysing, reporting and writing (this process, every path)."""
    from limbstiff.files.outputs import write_result
    from limbstiff.report import write_report
    times = {"reading": [], "analysis": [], "report": [], "writing": []}
    for path in paths:
        t0 = time.perf_counter()
        trial = limbstiff.read_trial(path)
        t1 = time.perf_counter()
        result = limbstiff.analyze(trial, seed=0)
        t2 = time.perf_counter()
        write_report(result, out / f"{path.stem}.pdf")
        t3 = time.perf_counter()
        write_result(result, out / path.stem)
        t4 = time.perf_counter()
        for key, dt in zip(times, (t1 - t0, t2 - t1, t3 - t2, t4 - t3)):
            times[key].append(dt)
    return {k: float(np.mean(v)) for k, v in times.items()}


def length_exponent() -> float:
    """The exponent of analysis time against trial length that ``benchmarks/perf.py`` measured
    (its section of RESULTS.md); 1 (linear, the pessimistic case) when it has not been run."""
    import re
    from _results import RESULTS
    text = RESULTS.read_text(encoding="utf-8") if RESULTS.exists() else ""
    found = re.search(r"Fitted exponent of time against length: \*\*([0-9.]+)\*\*", text)
    return float(found.group(1)) if found else 1.0


def study_estimate(per_trial: dict, efficiency: float) -> list[str]:
    """What 10 000 trials of 1–10 minutes cost on 16 nodes, from the measured figures."""
    # analysis time grows as length^exponent (benchmarks/perf.py); reading and writing linearly;
    # the report barely (thinned for drawing)
    exponent = length_exponent()
    lines = ["| trial length | per trial, one worker | 10 000 trials on 16 nodes × 8 workers |", "|---|---|---|"]
    for minutes in (1, 10):
        factor = (60 * minutes / ARGS.duration)
        seconds = (per_trial["analysis"] * factor ** exponent + per_trial["report"]
                   + (per_trial["reading"] + per_trial["writing"]) * factor)
        total = 10_000 * seconds / (16 * 8 * efficiency)
        lines.append(f"| {minutes} min | {seconds:.1f} s | {total / 60:.0f} min (at efficiency {efficiency:.2f}) |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=200)
    parser.add_argument("--duration", type=float, default=5.0)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4])
    global ARGS
    ARGS = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        (tmp / "trials").mkdir()
        paths = make_trials(tmp / "trials", ARGS.trials, ARGS.duration)
        limbstiff.analyze(limbstiff.read_trial(paths[0]), seed=0)           # compile the kernels once
        runs = {w: on_cluster(tmp / "trials", tmp / f"out{w}", w) for w in ARGS.workers}
        (tmp / "phases").mkdir()
        per_trial = phases(paths[::10], tmp / "phases")
    base = ARGS.trials / runs[ARGS.workers[0]]["wall"] / ARGS.workers[0]
    lines = ["## Scaling on a dask cluster (`benchmarks/scale.py`)", "",
             f"Machine: {machine()} — **{os.cpu_count()} cores**, so only up to {os.cpu_count()} workers can "
             f"scale. {ARGS.trials} simulated trials of {ARGS.duration:g} s at 1 kHz (elbow, wrist, ankle), "
             "analysed with reports by `analyze_files(executor=…)` on a `LocalCluster` of single-threaded "
             "worker processes.", "",
             "| workers | wall time | trials/s | efficiency | compute share of workers' time | transfer + "
             "deserialisation | failed |", "|---|---|---|---|---|---|---|"]
    for w, r in runs.items():
        rate = r["trials"] / r["wall"]
        lines.append(f"| {w} | {r['wall']:.1f} s | {rate:.2f} | **{rate / (w * base):.2f}** | "
                     f"{100 * r['compute'] / (w * r['wall']):.0f} % | {r['moved']:.2f} s | {r['failed']} |")
    total = sum(per_trial.values())
    lines += ["", "Efficiency: trials/s with W workers ÷ (W × trials/s with one). The rest of the workers' time "
              "(100 % − compute share) is scheduling, serialisation and workers idle while the last trials "
              "finish.", "",
              f"Within a trial's compute (mean over {len(paths[::10])} trials, one process): "
              + ", ".join(f"{k} {v:.2f} s ({100 * v / total:.0f} %)" for k, v in per_trial.items()) + ".", "",
              "What a 10 000-trial study costs on a 16-node cluster (8 single-threaded workers a node, the "
              f"efficiency measured with 2 workers on this machine; analysis time ∝ length^{length_exponent():.2f} "
              "from `benchmarks/perf.py`, reading and writing ∝ length):", ""]
    two = runs.get(2) or runs[ARGS.workers[-1]]
    eff = (two["trials"] / two["wall"]) / (2 * base) if 2 in runs else 1.0
    lines += study_estimate(per_trial, eff)
    text = "\n".join(lines) + "\n"
    print(text)
    update_section("scale", text)


if __name__ == "__main__":
    main()
