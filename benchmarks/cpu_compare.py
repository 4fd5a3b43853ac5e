"""CPU time of one ``analyze`` of a 60 s simulated elbow, this tree against an earlier revision.

    python benchmarks/cpu_compare.py REVISION [--rounds 3] [--runs 3]

The revision is checked out into a temporary git worktree; each round runs one process per tree,
alternating (the machine is shared), each process analysing the trial once to warm up and then
``--runs`` times. Reported: the median CPU time (``time.process_time``: every thread of the
process) and wall time per analysis of each tree, and their ratio. Numbers are printed, not
written to RESULTS.md: it compares a change with what came before it (issue 33: with BLAS held
to one thread the analysis's CPU time fell and its wall time did not grow).
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
    print(f"analysis of a 60 s elbow, median of {args.rounds * args.runs} runs each:")
    for key in ("before", "after"):
        print(f"  {key:6s} ({args.revision if key == 'before' else 'this tree'}): CPU {cpu[key]:.2f} s, "
              f"wall {wall[key]:.2f} s")
    print(f"  after ÷ before: CPU {cpu['after'] / cpu['before']:.2f}, wall {wall['after'] / wall['before']:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
