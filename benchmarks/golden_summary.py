"""What a change moved in the golden snapshot, in a table: per analysis the median stiffness, m and
the verdict before and after, and how many values differ in each part of the snapshot.

    python benchmarks/golden_summary.py BEFORE.json AFTER.json [--section NAME]

``golden.py --compare`` lists every value that differs; this says how much the answers moved. With
``--section`` the table is written to that section of RESULTS.md as well as printed.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _results import update_section  # noqa: E402


def _leaves(x, path=""):
    if isinstance(x, dict):
        for k, v in x.items():
            yield from _leaves(v, f"{path}/{k}")
    elif isinstance(x, list):
        for i, v in enumerate(x):
            yield from _leaves(v, f"{path}[{i}]")
    else:
        yield path, x


def differing(before: dict, after: dict) -> Counter:
    """Count of differing leaves per part: the snapshot's first key and, for analyses, the estimator."""
    a, b = dict(_leaves(before)), dict(_leaves(after))
    parts = Counter()
    for path in set(a) | set(b):
        if a.get(path, object()) != b.get(path, object()):
            top = path.strip("/").split("/")
            parts[top[0] if top[0] != "analysis" else f"analysis ({top[2]})"] += 1
    return parts


def _change(x, y) -> str:
    return "—" if x is None or y is None else f"{100 * (y / x - 1):+.4f} %"


def table(before: dict, after: dict) -> str:
    lines = ["| analysis | median stiffness before → after | change | inertia change | verdict before → after |",
             "|---|---|---|---|---|"]
    for key, entry in before["analysis"].items():
        sa, sb = entry["summary"], after["analysis"][key]["summary"]
        ma, mb = sa["stiffness"]["median"], sb["stiffness"]["median"]
        ia, ib = ((s.get("inertia") or {}).get("median") for s in (sa, sb))
        lines.append(f"| {key} | {ma:.6g} → {mb:.6g} | {_change(ma, mb)} | {_change(ia, ib)} | "
                     f"{sa.get('verdict')} → {sb.get('verdict')} |")
    counts = differing(before, after)
    lines += ["", "Values that differ, per part of the snapshot: "
              + (", ".join(f"{part} {n}" for part, n in sorted(counts.items())) or "none") + "."]
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("before")
    parser.add_argument("after")
    parser.add_argument("--section")
    parser.add_argument("--title", default="Golden snapshot: before → after")
    args = parser.parse_args(argv)
    before, after = (json.loads(Path(p).read_text(encoding="utf-8")) for p in (args.before, args.after))
    text = f"## {args.title}\n\n" + table(before, after) + "\n"
    print(text)
    if args.section:
        update_section(args.section, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
