"""The layering of docs/architecture.md holds: no module imports from a layer above its own.

The layers are read from the table under "## Layering" in docs/architecture.md, so the document
and the test cannot drift apart. Every import of the package is checked — at load time and inside
functions (an import placed in a function to dodge a cycle is still a dependency) — except those
under ``if TYPE_CHECKING:``, which annotations need and which never run. The root ``limbstiff``
(``__version__`` and the lazy public API, whose ``__getattr__`` imports by name) sits at layer 0.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "limbstiff"
DOC = ROOT / "docs" / "architecture.md"
#: The pure-maths units: they import numpy and scipy, never files, drawing or the command line
#: (a result's ``to_frame`` may import pandas when called).
MATHS = ("limbstiff.signals", "limbstiff.filtered", "limbstiff.statespace", "limbstiff.estimate",
         "limbstiff.mechanics", "limbstiff.checks", "limbstiff.coupling", "limbstiff.unmodelled",
         "limbstiff.simulate", "limbstiff.bandwidth", "limbstiff.trial_level", "limbstiff.heldout",
         "limbstiff.effects", "limbstiff.cycles", "limbstiff.scheduled")
FORBIDDEN_IN_MATHS = ("limbstiff.files", "limbstiff.report", "limbstiff.cli", "limbstiff.batch", "matplotlib",
                      "click")


def layers() -> dict[str, int]:
    """Unit (a module or package) → its layer, from the table in docs/architecture.md."""
    section = DOC.read_text(encoding="utf-8").split("## Layering", 1)[1].split("\n## ", 1)[0]
    out = {}
    for number, cells in re.findall(r"^\| (\d+) \|([^|]*)\|", section, flags=re.M):
        for unit in re.findall(r"`(limbstiff[a-z_.]*)`", cells):
            out[unit] = int(number)
    assert len(out) > 10, "no layering table found in docs/architecture.md"
    return out


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def unit_of(module: str, units: dict[str, int]) -> str | None:
    """The longest unit that is ``module`` or contains it."""
    candidates = [u for u in units if module == u or module.startswith(u + ".")]
    return max(candidates, key=len) if candidates else None


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    skipped = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skipped |= {id(n) for child in node.body for n in ast.walk(child)}
    return skipped


def imports_of(path: Path) -> list[tuple[str, int]]:
    """Every module ``path`` imports (absolute names, with line numbers), outside TYPE_CHECKING."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skipped, here = _type_checking_nodes(tree), module_name(path)
    package = here if path.name == "__init__.py" else here.rpartition(".")[0]
    out = []
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            out += [(a.name, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.split(".")[:len(package.split(".")) - (node.level - 1)]
                base = ".".join(parent + ([node.module] if node.module else []))
            out += [(base, node.lineno)] + [(f"{base}.{a.name}", node.lineno) for a in node.names]
    return out


def _is_module(name: str) -> bool:
    path = ROOT / Path(*name.split("."))
    return path.with_suffix(".py").exists() or (path / "__init__.py").exists()


def violations(units: dict[str, int]) -> list[str]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        here = module_name(path)
        own = unit_of(here, units)
        assert own is not None, f"{here} is in no layer of docs/architecture.md"
        for target, line in imports_of(path):
            if not target.startswith("limbstiff") or not _is_module(target):
                continue
            other = unit_of(target, units)
            if other != own and units[other] >= units[own]:
                found.append(f"{path.relative_to(ROOT)}:{line} {own} (layer {units[own]}) imports "
                             f"{target} (layer {units[other]})")
    return found


def test_no_module_imports_from_its_own_layer_or_above():
    assert violations(layers()) == []


def test_the_check_sees_an_upward_import(tmp_path, monkeypatch):
    # the test can fail: with result put below report, result.plot's import of report.plots is caught
    units = layers()
    units["limbstiff.result"] = units["limbstiff.report"] - 1
    assert any("limbstiff/result.py" in v and "limbstiff.report" in v for v in violations(units))


@pytest.mark.parametrize("unit", MATHS)
def test_the_maths_imports_no_files_drawing_or_command_line(unit):
    paths = [p for p in PACKAGE.rglob("*.py") if unit_of(module_name(p), {unit: 0}) == unit]
    assert paths, f"{unit} has no modules"
    bad = [f"{p.relative_to(ROOT)}:{line} imports {name}" for p in paths for name, line in imports_of(p)
           if any(name == f or name.startswith(f + ".") for f in FORBIDDEN_IN_MATHS)]
    assert bad == []
