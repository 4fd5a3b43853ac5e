"""The public API: ``limbstiff.analyze`` takes files, ``dir(limbstiff)`` lists the API, and every
``limbstiff.<name>`` the README and docs/ mention exists."""

from __future__ import annotations

import importlib
import importlib.util
import re
from pathlib import Path

import pytest

import limbstiff

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: ``limbstiff.<name>`` and ``limbstiff.<pkg>.<name>``…, not inside a path or a longer name.
MENTION = re.compile(r"(?<![\w/.\-])limbstiff(?:\.[A-Za-z_]\w*)+")


def mentions() -> dict[str, str]:
    """Every dotted name under ``limbstiff`` the docs mention, with the first file naming it."""
    found: dict[str, str] = {}
    for path in DOCS:
        for name in MENTION.findall(path.read_text(encoding="utf-8")):
            found.setdefault(name.rstrip("."), path.name)
    return found


def resolve(dotted: str):
    """The object a dotted name denotes: the longest importable module, then attributes
    (``__main__`` found, not run)."""
    if dotted.endswith(".__main__"):
        spec = importlib.util.find_spec(dotted)
        if spec is None:
            raise ModuleNotFoundError(dotted)
        return spec
    parts = dotted.split(".")
    for k in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:k]))
        except ModuleNotFoundError:
            continue
        for attr in parts[k:]:
            obj = getattr(obj, attr)
        return obj
    raise ModuleNotFoundError(dotted)


def test_docs_mention_names():
    found = mentions()
    assert {"limbstiff.analyze", "limbstiff.diagnose_files", "limbstiff.write_report"} <= set(found)


@pytest.mark.parametrize("dotted", sorted(mentions()))
def test_every_name_the_docs_mention_exists(dotted):
    try:
        resolve(dotted)
    except (ImportError, AttributeError) as exc:
        pytest.fail(f"{mentions()[dotted]} names {dotted}, which does not exist: {exc}")


def test_dir_lists_the_public_api():
    names = dir(limbstiff)
    assert names == sorted(limbstiff.__all__)
    assert {"analyze", "read_trial", "load_protocol", "write_report", "analyze_files", "diagnose",
            "diagnose_files", "StiffnessResult", "Trial", "Protocol", "__version__"} <= set(names)
    for name in limbstiff.__all__:
        assert getattr(limbstiff, name) is not None
    with pytest.raises(AttributeError, match="no attribute 'nonesuch'"):
        limbstiff.nonesuch  # noqa: B018


def test_analyze_takes_a_path_and_a_protocol_path(monkeypatch):
    """A trial file and a protocol file give the same result as the objects read from them."""
    monkeypatch.chdir(ROOT)
    protocol = limbstiff.load_protocol("protocols/elbow-lab.toml")
    trial = limbstiff.read_trial("examples/elbow.csv", protocol)
    from limbstiff.analysis import trial_and_protocol
    read, given = trial_and_protocol(Path("examples/elbow.csv"), "protocols/elbow-lab.toml")
    assert given == protocol and read.name == trial.name
    assert (read.angle == trial.angle).all() and read.source_sha256 == trial.source_sha256
    same, kept = trial_and_protocol(trial, protocol)
    assert same is trial and kept is protocol
    bare, default = trial_and_protocol("examples/elbow.csv", None)
    assert default == limbstiff.Protocol() and bare.n_samples == trial.n_samples


@pytest.mark.slow
def test_analyze_a_bundled_file_by_its_name(monkeypatch):
    monkeypatch.chdir(ROOT)
    result = limbstiff.analyze("examples/elbow.csv", seed=0)
    assert result.trial.name == "elbow" and result.verdict in ("ok", "caution", "unreliable")
    assert len(result.to_frame()) == result.trial.n_samples


def test_analyze_reports_a_missing_file(tmp_path):
    with pytest.raises(limbstiff.LimbstiffError):
        limbstiff.analyze(tmp_path / "nonesuch.csv")
