"""Batch throughput: 40 trials of 60 s at 1 kHz with reports, one process against two.

    python benchmarks/batch.py [--trials 40] [--duration 60]

Simulated elbow, wrist and ankle trials (seeds 0…N−1, one scenario after another) are written
to a temporary folder and analysed twice by the command a lab would run,
``limbstiff analyze FOLDER --jobs J`` with per-trial reports and the batch overview, first with
``--jobs 1`` and then ``--jobs 2``, in one run on the same files. Also timed: ``limbstiff --help``
(median of 7 starts; the command must not import the heavy modules at start).
Target: wall time with ``--jobs 2`` ≤ 0.6 × with ``--jobs 1``; ``--help`` < 0.5 s.
Writes section ``batch`` of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import machine, update_section  # noqa: E402

from limbstiff.files import write_trial
from limbstiff.simulate import simulate  # noqa: E402

SCENARIOS = ("elbow", "wrist", "ankle")
LIMBSTIFF = [sys.executable, "-m", "limbstiff"]


def wall(cmd: list[str]) -> float:
    """Wall time of a command, s (it must succeed)."""
    start = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=40)
    parser.add_argument("--duration", type=float, default=60.0)
    args = parser.parse_args()

    help_times = [wall([*LIMBSTIFF, "--help"]) for _ in range(7)]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "trials"
        folder.mkdir()
        for i in range(args.trials):
            scenario = SCENARIOS[i % len(SCENARIOS)]
            trial = simulate(scenario, seed=i, params={"duration": args.duration})
            write_trial(trial, folder / f"{scenario}-{i:03d}.csv")
        # compile the numba kernels into the on-disk cache first, so neither run pays for it
        wall([*LIMBSTIFF, "analyze", str(next(folder.glob("*.csv"))), "--out", f"{tmp}/warm", "--jobs", "1"])
        times = {}
        for jobs in (1, 2):
            times[jobs] = wall([*LIMBSTIFF, "analyze", str(folder), "--out", f"{tmp}/out{jobs}", "--jobs", str(jobs)])
            n_pdf = len(list(Path(f"{tmp}/out{jobs}").glob("*/report.pdf")))
            assert n_pdf == args.trials, f"--jobs {jobs}: {n_pdf} reports for {args.trials} trials"
            assert Path(f"{tmp}/out{jobs}/overview.pdf").exists()

    ratio = times[2] / times[1]
    help_s = statistics.median(help_times)
    text = f"""## Batch throughput (`benchmarks/batch.py`)

{args.trials} simulated trials ({', '.join(SCENARIOS)} in turn) of {args.duration:g} s at 1 kHz,
`limbstiff analyze FOLDER` with a PDF report per trial and the batch overview; numba kernels
compiled beforehand. Machine: {machine()}.

| run | wall time | per trial |
|---|---|---|
| `--jobs 1` | {times[1]:.1f} s | {times[1] / args.trials:.2f} s |
| `--jobs 2` | {times[2]:.1f} s | {times[2] / args.trials:.2f} s |

- `--jobs 2` ÷ `--jobs 1`: **{ratio:.2f}** (target ≤ 0.60: {'met' if ratio <= 0.6 else 'missed'}).
- `limbstiff --help`: **{help_s:.2f} s** median of 7 starts (target < 0.5 s:
  {'met' if help_s < 0.5 else 'missed'}; range {min(help_times):.2f}–{max(help_times):.2f} s).
"""
    print(text)
    update_section("batch", text)


if __name__ == "__main__":
    main()
