"""Page 1 of the report as images for the README and docs: a good trial and a doubtful one.

    python benchmarks/report_images.py

Writes ``docs/images/page1-elbow.png`` (the bundled example, ``examples/elbow.csv`` with
``protocols/elbow-lab.toml``: verdict ok) and ``docs/images/page1-z_pf.png`` (the real ankle
trial ``data/reklab-ankle/z_pf`` with ``protocols/reklab-ankle.toml``: verdict caution), at
110 dpi, from the same code as ``report.pdf``.
"""

from __future__ import annotations

import os
from pathlib import Path

import limbstiff
from limbstiff.report import report_figures

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"
TRIALS = {"page1-elbow.png": ("examples/elbow.csv", "protocols/elbow-lab.toml"),
          "page1-z_pf.png": ("data/reklab-ankle/z_pf.csv", "protocols/reklab-ankle.toml")}


def main() -> None:
    IMAGES.mkdir(parents=True, exist_ok=True)
    os.chdir(ROOT)                       # the page shows the source as a lab would give it: relative
    for image, (path, protocol_path) in TRIALS.items():
        protocol = limbstiff.load_protocol(protocol_path)
        result = limbstiff.analyze(limbstiff.read_trial(path, protocol), protocol, seed=0)
        report_figures(result)[0].savefig(IMAGES / image, dpi=110)
        print(f"{image}: {result.trial.name}, verdict {result.verdict}")


if __name__ == "__main__":
    main()
