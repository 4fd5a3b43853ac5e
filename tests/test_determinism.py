"""The same trials give the same outputs to the bit, whatever runs them.

``--jobs 1``, ``--jobs 2``, a two-worker dask LocalCluster and ``OPENBLAS_NUM_THREADS=1`` against
``=2`` must write byte-identical ``stiffness.csv`` and ``summary.json`` files with equal numbers.
Before BLAS was held to one thread inside the analysis (:mod:`limbstiff.blas_threads`), a real
ankle trial's inertia moved in the sixth digit between one and two OpenBLAS threads (issue 33).
Each run is its own process (the CLI), as a BLAS library reads its thread count when it loads.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow        # end to end: `pytest -m "not slow"` is the inner loop

ROOT = Path(__file__).resolve().parents[1]
REAL = ROOT / "data" / "reklab-ankle"
#: summary.json keys that name where or when the outputs were written, not what they hold.
CONTEXT_KEYS = {"output"}


def _trials(folder: Path) -> Path:
    """The first 15 s of two real ankle trials, z_df3 and z_pf (with a reflex). Without the one-thread
    limit, z_df3's stiffness.csv differed between one and two OpenBLAS threads (checked when written)."""
    folder.mkdir()
    for name in ("z_df3", "z_pf"):
        lines = (REAL / f"{name}.csv").read_text().splitlines(keepends=True)
        (folder / f"{name}.csv").write_text("".join(lines[:15_001]))
    return folder


def _analyze(folder: Path, out: Path, *args: str, threads: int | None = None) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
    if threads is not None:
        env["OPENBLAS_NUM_THREADS"] = str(threads)
    cmd = [sys.executable, "-m", "limbstiff", "analyze", str(folder), "--out", str(out), "--no-pdf", "--seed", "3",
           "--protocol", str(ROOT / "protocols" / "reklab-ankle.toml"), *args]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr


def _outputs(out: Path) -> dict:
    found = {}
    for name in ("z_df3", "z_pf"):
        summary = json.loads((out / name / "summary.json").read_text())
        found[name] = ((out / name / "stiffness.csv").read_bytes(),
                       {k: v for k, v in summary.items() if k not in CONTEXT_KEYS})
    return found


def test_outputs_do_not_depend_on_threads_processes_or_executor(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    folder = _trials(tmp_path / "trials")
    runs = {"jobs 1, 1 BLAS thread": ("--jobs", "1"), "jobs 1, 2 BLAS threads": ("--jobs", "1"),
            "jobs 2": ("--jobs", "2")}
    threads = {"jobs 1, 1 BLAS thread": 1, "jobs 1, 2 BLAS threads": 2}
    for i, (label, args) in enumerate(runs.items()):
        _analyze(folder, tmp_path / f"out{i}", *args, threads=threads.get(label))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as local:
        _analyze(folder, tmp_path / "out-dask", "--scheduler", local.scheduler_address)
    reference = _outputs(tmp_path / "out0")
    assert reference["z_df3"][1]["inertia"]["median"] > 0     # a real analysis, not an empty one
    for label, out in [(label, tmp_path / f"out{i}") for i, label in enumerate(runs)][1:] + [
            ("dask LocalCluster", tmp_path / "out-dask")]:
        got = _outputs(out)
        for name in reference:
            assert got[name][0] == reference[name][0], f"{name}: stiffness.csv differs with {label}"
            assert got[name][1] == reference[name][1], f"{name}: summary.json differs with {label}"
