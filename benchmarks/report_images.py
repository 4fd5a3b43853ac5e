"""The report's images for the README and docs, from the same code as ``report.pdf``.

    python benchmarks/report_images.py

Writes, at :data:`DPI` dpi (small files, legible on a screen):

- ``docs/images/page1-elbow.png``: page 1 of the bundled example (``examples/elbow.csv`` with
  ``protocols/elbow-lab.toml``: verdict ok);
- ``docs/images/page1-z_pf.png``: page 1 of the real ankle trial ``data/reklab-ankle/z_pf.csv``
  with ``protocols/reklab-ankle.toml`` (verdict caution);
- ``docs/images/elbow-stiffness.png``: the README's two-panel figure, drawn by the README's own
  lines (:func:`readme_figure`).
"""

from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import limbstiff  # noqa: E402
from limbstiff.report import report_figures  # noqa: E402
from limbstiff.report.common import style  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
IMAGES = ROOT / "docs" / "images"
#: Resolution of the images: an A4 page is 500 × 700 pixels at 60 dpi.
DPI = {"page": 70, "figure": 80}
TRIALS = {"page1-elbow.png": ("examples/elbow.csv", "protocols/elbow-lab.toml"),
          "page1-z_pf.png": ("data/reklab-ankle/z_pf.csv", "protocols/reklab-ankle.toml")}


def readme_figure(result):
    """The README's figure (section "From Python"), as written there."""
    import matplotlib.pyplot as plt
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    result.plot(ax=left)
    result.plot(ax=right, against="angle")
    return fig


def main() -> None:
    IMAGES.mkdir(parents=True, exist_ok=True)
    os.chdir(ROOT)                       # the page shows the source as a lab would give it: relative
    for image, (path, protocol) in TRIALS.items():
        result = limbstiff.analyze(path, protocol, seed=0)
        with style():                    # the fonts of report.pdf
            report_figures(result)[0].savefig(IMAGES / image, dpi=DPI["page"])
        print(f"{image}: {result.trial.name}, verdict {result.verdict}")
        if result.trial.name == "elbow":
            readme_figure(result).savefig(IMAGES / "elbow-stiffness.png", dpi=DPI["figure"])
            print("elbow-stiffness.png: the README's figure")


if __name__ == "__main__":
    main()
