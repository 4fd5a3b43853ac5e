"""The package leaves the process as it found it: no backend chosen for the user, no garbage
collector switched, no cache keyed by ``id()`` (an address, reused once the object is freed, and
blind to every other input).

The source is read with ``ast``: a call is found whatever its spacing or import alias.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "limbstiff"
#: Calls that change the whole process: choosing matplotlib's backend, switching the collector.
FORBIDDEN_CALLS = {"matplotlib.use", "matplotlib.pyplot.switch_backend", "gc.disable", "gc.enable"}
#: Methods whose first argument is a mapping's key.
KEY_METHODS = {"get", "setdefault", "pop", "__getitem__", "__setitem__", "__contains__"}


def _aliases(tree: ast.AST) -> dict[str, str]:
    """Local name → what it stands for, from the module's imports (``import matplotlib as mpl``,
    ``from gc import disable``)."""
    out = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                out[a.asname or a.name.split(".")[0]] = a.name if a.asname else a.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            for a in node.names:
                out[a.asname or a.name] = f"{node.module}.{a.name}"
    return out


def _dotted(node: ast.AST, aliases: dict[str, str]) -> str | None:
    """``a.b.c`` of a name or attribute chain, its first part resolved through the imports."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return ".".join([aliases.get(node.id, node.id)] + parts[::-1])


def _used_as_key(call: ast.Call, parents: dict) -> bool:
    """The value of ``call`` (or a tuple holding it) indexes a mapping: ``m[id(x)]``,
    ``{id(x): …}``, ``id(x) in m``, ``m.get(id(x))``…"""
    node, parent = call, parents.get(call)
    while isinstance(parent, ast.Tuple):
        node, parent = parent, parents.get(parent)
    if isinstance(parent, ast.Subscript):
        return parent.slice is node
    if isinstance(parent, ast.Dict):
        return any(k is node for k in parent.keys)
    if isinstance(parent, ast.Compare):
        return parent.left is node and any(isinstance(op, (ast.In, ast.NotIn)) for op in parent.ops)
    if isinstance(parent, ast.Call) and isinstance(parent.func, ast.Attribute):
        return parent.func.attr in KEY_METHODS and bool(parent.args) and parent.args[0] is node
    return False


def violations(source: str) -> list[str]:
    """Each process-global side effect or ``id()``-keyed lookup in ``source``, as ``line: what``."""
    tree = ast.parse(source)
    aliases = _aliases(tree)
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        name = _dotted(node.func, aliases)
        if name in FORBIDDEN_CALLS:
            found.append(f"{node.lineno}: {name}()")
        elif name == "id" and _used_as_key(node, parents):
            found.append(f"{node.lineno}: id() as a key")
    return found


def test_the_scan_finds_what_it_looks_for():
    bad = textwrap.dedent("""
        import gc
        import matplotlib as mpl
        from gc import disable as off
        cache = {}
        def f(a, n):
            mpl.use("Agg")
            gc.disable(); off(); gc.enable()
            if id(a) in cache:
                return cache[id(a), n]
            return cache.get(id(a)) or {id(a): n}
    """)
    assert len(violations(bad)) == 8, violations(bad)
    fine = "import gc, matplotlib\nx = matplotlib.get_backend()\ngc.collect()\nprint(id(x))\nif a is b: pass\n"
    assert violations(fine) == []


def test_the_package_has_no_process_global_side_effects():
    found = {str(path.relative_to(ROOT)): v for path in sorted(PACKAGE.rglob("*.py"))
             if (v := violations(path.read_text(encoding="utf-8")))}
    assert found == {}


@pytest.mark.slow
def test_the_diagnosis_report_leaves_the_users_matplotlib_alone(tmp_path):
    pytest.importorskip("matplotlib")
    # a fresh process: the user chose a backend (svg, not the Agg the report used to force) and has
    # a figure open in pyplot; after the report both are as they were, and the collector is on
    code = textwrap.dedent(f"""
        import gc, matplotlib
        matplotlib.use("svg")
        import matplotlib.pyplot as plt
        plt.figure(); plt.plot([0, 1])
        before = dict(matplotlib.rcParams)
        import limbstiff
        from limbstiff.simulate import simulate
        trial = simulate("ankle", seed=5, params={{"duration": 8.0}})
        result = limbstiff.analyze(trial, seed=0)      # the analysis the diagnosis would make again
        d = limbstiff.diagnose([trial], seed=0, results=[result])
        d.write_pdf({str(tmp_path / "diagnosis.pdf")!r})
        limbstiff.write_report(result, {str(tmp_path / "report.pdf")!r})
        assert matplotlib.get_backend() == "svg", matplotlib.get_backend()
        assert plt.get_fignums() == [1] and len(plt.gcf().axes[0].lines) == 1
        assert dict(matplotlib.rcParams) == before
        assert gc.isenabled()
    """)
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 0, res.stderr[-3000:]
    assert (tmp_path / "diagnosis.pdf").read_bytes()[:4] == b"%PDF"
