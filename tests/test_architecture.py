"""docs/architecture.md stays true, and the layout keeps its rules.

The module map must name every module of the package (and only importable ones); no function
may exceed 60 lines and no module 430; no module may be named like a standard-library module (``io``, ``select``…
shadow the real ones for relative imports and confuse readers); no module may be replaced at
import (a package that turns itself into a callable class is a package *and* a function).
"""

from __future__ import annotations

import ast
import importlib
import re
import sys
import types
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "limbstiff"
MAP = ROOT / "docs" / "architecture.md"
#: The guide's limit for one function, in lines (its docstring included).
MAX_FUNCTION_LINES = 60
#: A module is readable in one sitting: the guide's ~400 lines, with a little room.
MAX_MODULE_LINES = 430


def _package_modules() -> set[str]:
    out = set()
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out.add(".".join(parts))
    return out


def _mapped_modules() -> set[str]:
    rows = re.findall(r"^\| `(limbstiff(?:\.[a-z_][a-z_0-9]*)*)` \|", MAP.read_text(encoding="utf-8"), flags=re.M)
    assert rows, "no module rows found in docs/architecture.md"
    return set(rows)


def test_the_map_names_every_module_and_nothing_else():
    mapped, present = _mapped_modules(), _package_modules()
    assert sorted(present - mapped) == [], "modules missing from docs/architecture.md"
    assert sorted(mapped - present) == [], "docs/architecture.md names modules that do not exist"


@pytest.mark.parametrize("name", sorted(_mapped_modules() - {"limbstiff.__main__"}))   # that one runs the command
def test_every_mapped_module_imports_as_a_plain_module(name):
    module = importlib.import_module(name)
    assert type(module) is types.ModuleType, f"{name} replaced its module class at import"


def test_no_function_is_longer_than_the_limit():
    long = []
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                n = node.end_lineno - node.lineno + 1
                if n > MAX_FUNCTION_LINES:
                    long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({n} lines)")
    assert long == []


def test_no_module_is_longer_than_the_limit():
    long = [f"{path.relative_to(ROOT)} ({n} lines)" for path in PACKAGE.rglob("*.py")
            if (n := len(path.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES]
    assert long == []


def test_no_module_shadows_the_standard_library():
    stdlib = set(sys.stdlib_module_names)
    shadowing = [p.relative_to(ROOT) for p in PACKAGE.rglob("*")
                 if (p.stem if p.suffix == ".py" else p.name) in stdlib and p.name != "__pycache__"]
    assert shadowing == []
