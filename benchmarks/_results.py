"""Keep ``benchmarks/RESULTS.md`` as one file with one section per benchmark script."""

from __future__ import annotations

import platform
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "RESULTS.md"


def machine() -> str:
    """One line describing the machine a benchmark ran on."""
    import os
    try:
        import numba
        jit = f"numba {numba.__version__}"
    except ImportError:
        jit = "no numba"
    return (f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
            f"{platform.python_version()}, numpy {np.__version__}, {jit}")


def update_section(name: str, text: str) -> None:
    """Replace (or append) the section of RESULTS.md delimited by markers for ``name``."""
    start, end = f"<!-- {name}:start -->", f"<!-- {name}:end -->"
    body = RESULTS.read_text(encoding="utf-8") if RESULTS.exists() else "# Benchmark results\n"
    block = f"{start}\n{text.rstrip()}\n{end}"
    if start in body and end in body:
        before, rest = body.split(start, 1)
        after = rest.split(end, 1)[1]
        body = before + block + after
    else:
        body = body.rstrip() + "\n\n" + block + "\n"
    RESULTS.write_text(body, encoding="utf-8")
