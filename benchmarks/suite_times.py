"""Wall time of the test suite: in full (the README's command) and the inner loop (``-m "not slow"``),
on an otherwise idle machine and beside a CPU-bound process, each from an empty numba cache (as CI,
which starts from a clean clone: compiling the kernels costs each process that finds none cached
about 10 s of CPU).

    python benchmarks/suite_times.py [--only full,fast] [--load-only | --idle-only]

Each run is the command as a developer types it (``python -m pytest -q``, the project's addopts:
two xdist processes, a file to each), from the repository's root; a run of one mode keeps the
section's rows of the other. "Loaded" runs start one process
that spins on the CPU for as long as the suite runs (a second user on the 2-core machine); the
suite must pass under it. Writes section ``test-suite`` of RESULTS.md: per run the wall time, the
counts pytest printed, and whether it passed.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import re
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _results import machine, update_section  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
COMMANDS = {"full": [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider"],
            "fast": [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-m", "not slow"]}


def _spin(stop) -> None:
    x = 0
    while not stop.is_set():
        for _ in range(100_000):
            x = (x * 1103515245 + 12345) & 0xFFFFFFFF


def _clear_numba_cache() -> None:
    """Remove numba's cached kernels of the tree (``__pycache__/*.nbi``, ``*.nbc``)."""
    for path in (ROOT / "limbstiff").rglob("__pycache__/*.nb[ic]"):
        path.unlink()


def run(name: str, loaded: bool) -> dict:
    _clear_numba_cache()
    stop = multiprocessing.Event()
    hog = multiprocessing.Process(target=_spin, args=(stop,)) if loaded else None
    if hog is not None:
        hog.start()
    began, cpu = time.perf_counter(), os.times()
    try:
        done = subprocess.run(COMMANDS[name], cwd=ROOT, capture_output=True, text=True)
    finally:
        wall = time.perf_counter() - began
        after = os.times()
        used = (after.children_user - cpu.children_user) + (after.children_system - cpu.children_system)
        if hog is not None:
            stop.set()
            hog.join()
    last = [ln for ln in done.stdout.splitlines() if re.search(r"\d+ (passed|failed)", ln)]
    failed = [ln for ln in done.stdout.splitlines() if ln.startswith("FAILED")]
    if failed:
        print("\n".join(failed), flush=True)
    return {"suite": name, "loaded": loaded, "wall_s": wall, "cpu_s": used, "passed": done.returncode == 0,
            "counts": last[-1].strip("= ") if last else done.stdout[-200:]}


def _previous_rows() -> list[str]:
    """The table rows of the section as it stands (a run of one mode keeps the other's rows)."""
    from _results import RESULTS
    text = RESULTS.read_text(encoding="utf-8") if RESULTS.exists() else ""
    if "<!-- test-suite:start -->" not in text:
        return []
    section = text.split("<!-- test-suite:start -->", 1)[1].split("<!-- test-suite:end -->", 1)[0]
    return [ln for ln in section.splitlines() if ln.startswith("| full |") or ln.startswith("| fast |")]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="full,fast")
    parser.add_argument("--load-only", action="store_true")
    parser.add_argument("--idle-only", action="store_true")
    args = parser.parse_args(argv)
    loads = [False, True] if not (args.load_only or args.idle_only) else [args.load_only]
    rows = []
    for loaded in loads:
        for name in args.only.split(","):
            rows.append(run(name, loaded))
            print(rows[-1], flush=True)
    measured = [(r["suite"], "loaded" if r["loaded"] else "idle") for r in rows]
    kept = [row for row in _previous_rows() if tuple(c.strip() for c in row.split("|")[1:3]) not in measured]
    lines = [f"## Test suite (`benchmarks/suite_times.py`)", "",
             f"Machine: {machine()}. `full` is the README's `python -m pytest -q` (which `.ci/run` runs); `fast` "
             f"is the inner loop `python -m pytest -q -m \"not slow\"`. Loaded: beside one process spinning on "
             f"the CPU for the whole run. Targets: full ≤ 5 min idle, fast ≤ 90 s; both pass loaded.", "",
             "CPU: user + system time of the suite's processes (the spinning process not counted).", "",
             "| suite | machine | wall | CPU | passed | pytest's count |", "|---|---|---|---|---|---|"]
    lines += kept
    for r in rows:
        lines.append(f"| {r['suite']} | {'loaded' if r['loaded'] else 'idle'} | {r['wall_s'] / 60:.1f} min "
                     f"({r['wall_s']:.0f} s) | {r['cpu_s']:.0f} s | {'yes' if r['passed'] else '**no**'} | {r['counts']} |")
    update_section("test-suite", "\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0 if all(r["passed"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
