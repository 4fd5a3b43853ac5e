"""The README's Python example runs as written (in a scratch folder, on the bundled files)."""

import re
from pathlib import Path

import matplotlib
import pytest

pytestmark = pytest.mark.slow        # end to end: `pytest -m "not slow"` is the inner loop

ROOT = Path(__file__).resolve().parents[1]


def test_readme_python_example_runs(tmp_path, monkeypatch):
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    for name in ("examples", "protocols"):
        (tmp_path / name).symlink_to(ROOT / name)
    monkeypatch.chdir(tmp_path)
    # the example draws with pyplot: never open a window, whatever the machine has
    monkeypatch.setenv("MPLBACKEND", "Agg")
    matplotlib.use("Agg")
    scope: dict = {}
    try:
        exec(compile(block, "README.md", "exec"), scope)
    finally:
        import matplotlib.pyplot as plt
        plt.close("all")
    result, batch = scope["result"], scope["batch"]
    out = tmp_path / "limbstiff-out"
    assert (out / "elbow-report.pdf").read_bytes().startswith(b"%PDF")
    assert (out / "elbow-stiffness.png").read_bytes().startswith(b"\x89PNG")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["examples", "limbstiff-out", "protocols"], \
        "the example leaves files outside limbstiff-out/"
    assert "Verdict" in result.report()
    assert len(result.to_frame()) == result.trial.n_samples
    assert batch.exit_status == 0 and {o.trial for o in batch.outcomes} >= {"elbow"}
    assert (tmp_path / "limbstiff-out" / "elbow" / "summary.json").exists()


def test_readme_names_only_files_that_exist():
    """Paths the README's commands and links name (outputs aside) are in the repository."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    named = set(re.findall(r"(?<![\w/.-])((?:examples|data|protocols|docs|benchmarks)/[\w./-]*\w)", text))
    assert {"examples/elbow.csv", "examples/exp-spring.csv", "data/reklab-ankle"} <= named
    missing = sorted(p for p in named if not (ROOT / p).exists() and "my-lab" not in p)
    assert not missing, f"README.md names files that do not exist: {missing}"
    commands = text[text.index("## The commands"):text.index("Exit status 0")]
    assert "pairs.csv" not in commands and " trials/ --protocol protocols/my-lab.toml --out results/   #" not in commands
