"""CPU time of one ``analyze`` of a 60 s simulated elbow, this tree against an earlier revision.

    python benchmarks/cpu_compare.py REVISION [--rounds 3] [--runs 3] [--section NAME]

The revision is checked out into a temporary git worktree; each round runs one process per tree,
alternating (the machine is shared), each process analysing the trial once to warm up and then
``--runs`` times. Reported: the median CPU time (``time.process_time``: every thread of the
process) and wall time per analysis of each tree, and their ratio. Numbers are printed; with
``--section`` they are also written to that section of RESULTS.md (issue 45 asks for its
figure against 657199d as a committed result). It compares a change with what came before it
(issue 33: with BLAS held to one thread the analysis's CPU time fell and its wall time did not grow).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
from _results import machine, update_section  # noqa: E402
ONE_TREE = """
import json, sys, time
from limbstiff.analysis import analyze
from limbstiff.protocol import load_protocol
from limbstiff.simulate import simulate
protocol = load_protocol(sys.argv[1] + "/protocols/elbow-lab.toml")
trial = simulate("elbow", seed=0, params={"duration": 60.0})
analyze(trial, protocol, seed=0)
out = []
for _ in range(int(sys.argv[2])):
    cpu, wall = time.process_time(), time.perf_counter()
    analyze(trial, protocol, seed=0)
    out.append((time.process_time() - cpu, time.perf_counter() - wall))
print(json.dumps(out))
"""


def measure(tree: Path, runs: int) -> list[tuple[float, float]]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    done = subprocess.run([sys.executable, "-c", ONE_TREE, str(tree), str(runs)], env=env, check=True,
                          capture_output=True, text=True, cwd=tempfile.gettempdir())
    return [tuple(r) for r in json.loads(done.stdout)]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("revision")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--section", help="also write the figures to this section of RESULTS.md")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        before = Path(tmp) / "before"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(before), args.revision],
                       check=True, capture_output=True)
        try:
            times = {"before": [], "after": []}
            for _ in range(args.rounds):
                times["before"] += measure(before, args.runs)
                times["after"] += measure(ROOT, args.runs)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(before)], check=True)
    cpu = {k: statistics.median(c for c, _ in v) for k, v in times.items()}
    wall = {k: statistics.median(w for _, w in v) for k, v in times.items()}
    text = _text(args, cpu, wall)
    print(text)
    if args.section:
        update_section(args.section, text)
    return 0


def _text(args, cpu: dict, wall: dict) -> str:
    """The figures as a RESULTS.md section."""
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                          text=True).stdout.strip()
    lines = [f"## CPU of a 60 s analysis against {args.revision} (`benchmarks/cpu_compare.py`)", "",
             f"Machine: {machine()}. One `analyze` of a 60 s simulated elbow (`protocols/elbow-lab.toml`, seed 0), "
             f"median of {args.rounds * args.runs} runs per tree, the trees' processes alternating.", "",
             "| tree | CPU | wall |", "|---|---|---|"]
    for key, name in (("before", args.revision), ("after", f"this tree ({head})")):
        lines.append(f"| {name} | {cpu[key]:.2f} s | {wall[key]:.2f} s |")
    lines.append(f"| after ÷ before | {cpu['after'] / cpu['before']:.2f} | {wall['after'] / wall['before']:.2f} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
