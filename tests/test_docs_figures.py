"""Figures quoted in README.md and docs/*.md agree with the committed benchmark outputs.

Every measured number the documentation quotes (errors, coverages, run times, the real ankle
trials' stiffness, inertia and damping, right-first rates…) sits in a block delimited by HTML
comments on their own lines::

    <!-- figures: benchmarks/RESULTS.md#accuracy , data/reklab-ankle/SOURCE.md -->
    … text and tables quoting the figures …
    <!-- end figures -->

Each source is a path from the repository's root; ``#name`` names the section of that file
between ``<!-- name:start -->`` and ``<!-- name:end -->`` (as in ``benchmarks/RESULTS.md``), and a
source without ``#`` is the whole file. Several sources are separated by ``,``. Every number of a
block must be found in its sources: equal, or equal once the source's number is rounded to as
many decimals as the block's (``0.0174`` in a source is quoted as ``0.0174`` or ``0.017``,
``112.7`` as ``113``, ``7.8`` as ``7.8``). A number quoted with a minus sign needs the minus in
the source; one quoted without a sign also matches the source's negative number (the text says
"low" or "off" instead of the sign). Numbers are not rescaled: a source's ``0.24`` is not a
quoted ``24 %``.

What counts as a number of a block, and what does not:

- decimals and integers; a ``-`` or Unicode minus ``−`` right before one is its sign, except
  between two numbers (``20-60``, a range) and after a letter (``1e-12``, ``trial-12``, skipped);
  a ``+`` is no sign; ``5.4–5.8`` is two numbers;
- not the digits of identifiers: a number preceded by a letter, digit, ``_`` or ``.``, or
  followed by a letter, digit or ``_`` (``z_df3``, ``C1``, ``x86_64``, ``fig6.png``, ``v7.3``) is
  skipped, and so is one followed by a superscript (``10⁶``, ``10⁻⁴``: powers of ten);
- not dates: ``2010-05-03`` and a year (1900–2099) after ``et al.`` or ``RSS``;
- not references: a number after ``§``, ``Sec.``, ``Fig.``/``Figs.``, ``eq.``, ``issue`` or
  ``issues``;
- not markdown link targets: the ``(…)`` of ``[text](…)`` and HTML comments are dropped first;
- not the small integers 0–10 used as counts and ordinals (``5 seeds``, ``two to 3``), unless
  they carry a decimal point (``5.0``) or a percent sign (``5 %``, ``5%``).

Numbers of the sources are read without these exclusions.
"""

from __future__ import annotations

import re
from decimal import ROUND_HALF_EVEN, ROUND_HALF_UP, Decimal
from pathlib import Path
from typing import NamedTuple

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]

OPEN = re.compile(r"^<!--\s*figures:\s*(.*?)\s*-->\s*$")
CLOSE = re.compile(r"^<!--\s*end figures\s*-->\s*$")
DIGITS = re.compile(r"\d+(?:\.\d+)?")
SUPERSCRIPTS = "⁰¹²³⁴⁵⁶⁷⁸⁹⁻⁺"
#: Words after which a number is a reference (a section, figure, equation or issue), not a figure.
REFERENCE = re.compile(r"(?:§|\bSecs?\.|\bFigs?\.|\beqs?\.|\bissues?)\s*\(?$", re.I)
YEAR_BEFORE = re.compile(r"(?:\bet al\.|\bRSS)\s*$")
DATE = re.compile(r"\b\d{4}-\d{2}-\d{2}\b")
LINK_TARGET = re.compile(r"\]\([^)]*\)")
COMMENT = re.compile(r"<!--.*?-->", re.S)


class Quoted(NamedTuple):
    """One number of a block: its text, value, decimals, whether it carries a minus, its line."""

    text: str
    value: Decimal
    decimals: int
    negative: bool
    line: int


class Block(NamedTuple):
    """One figures block: the file, the line of its opening comment, its sources and text."""

    path: Path
    line: int
    sources: list[str]
    text: str


def _blank(match: re.Match) -> str:
    """The match replaced by spaces (line breaks kept), so that offsets and lines stay put."""
    return re.sub(r"[^\n]", " ", match.group(0))


def quoted_numbers(text: str, first_line: int = 1) -> list[Quoted]:
    """The numbers of a block's text that must be sourced, with the exclusions of the module.

    Parameters
    ----------
    text : str
        The block's text (between its two comments).
    first_line : int
        Line number of the text's first line in its file, for messages.

    Returns
    -------
    list of Quoted
    """
    text = COMMENT.sub(_blank, LINK_TARGET.sub(lambda m: "](" + _blank(m)[2:], text))
    text = DATE.sub(_blank, text)
    out = []
    for m in DIGITS.finditer(text):
        digits, (start, end) = m.group(0), m.span()
        before, after = text[max(start - 2, 0):start].rjust(2), text[end:end + 1]
        if before[1].isalnum() or before[1] in "_." or after.isalnum() or after in "_" + SUPERSCRIPTS:
            continue  # part of an identifier, a version, a file name or a power of ten
        negative = False
        if before[1] in "-−":
            if before[0].isalpha() or before[0] == "_":
                continue  # "e-12", "trial-12": an exponent or a name
            negative = not (before[0].isdigit() or before[0] in ")]")  # "20-60" is a range
        if REFERENCE.search(text[max(start - 12, 0):start]):
            continue
        if digits.isdigit() and len(digits) == 4 and 1900 <= int(digits) <= 2099 and YEAR_BEFORE.search(text[max(start - 12, 0):start]):
            continue
        is_percent = re.match(r"[ \u00a0\u202f]?%", text[end:end + 2]) is not None
        if "." not in digits and int(digits) <= 10 and not is_percent:
            continue
        decimals = len(digits.split(".")[1]) if "." in digits else 0
        line = first_line + text.count("\n", 0, start)
        out.append(Quoted(("−" if negative else "") + digits, Decimal(digits), decimals, negative, line))
    return out


def source_numbers(text: str) -> set[tuple[Decimal, bool]]:
    """Every number of a source, as (absolute value, negative), with no exclusion."""
    found = set()
    for m in re.finditer(r"(?<![\d.])([-−]?)(\d+(?:\.\d+)?)", text):
        found.add((Decimal(m.group(2)), m.group(1) != ""))
    return found


def matches(number: Quoted, sources: set[tuple[Decimal, bool]]) -> bool:
    """Whether a quoted number is one of the sources' numbers, or one rounded to its decimals."""
    step = Decimal(1).scaleb(-number.decimals)
    for value, negative in sources:
        if number.negative and not negative:
            continue
        if value == number.value:
            return True
        if any(value.quantize(step, rounding=mode) == number.value for mode in (ROUND_HALF_EVEN, ROUND_HALF_UP)):
            return True
    return False


def find_blocks(path: Path) -> list[Block]:
    """The figures blocks of one markdown file.

    Raises
    ------
    AssertionError
        On a block left open, a closing comment without its opening one, or a block in a block.
    """
    blocks, current = [], None
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        if OPEN.match(line):
            assert current is None, f"{path.name}:{number}: a figures block opened inside another"
            sources = [s.strip() for s in OPEN.match(line).group(1).split(",") if s.strip()]
            current = Block(path, number, sources, "")
        elif CLOSE.match(line):
            assert current is not None, f"{path.name}:{number}: 'end figures' without its opening comment"
            blocks.append(current)
            current = None
        elif current is not None:
            current = current._replace(text=current.text + line + "\n")
    assert current is None, f"{path.name}:{current.line}: figures block never closed"
    return blocks


def source_text(source: str) -> str:
    """The text a source names: a whole file, or the section ``#name`` of it.

    Raises
    ------
    FileNotFoundError, KeyError
        When the file or the section does not exist.
    """
    file, _, section = source.partition("#")
    path = ROOT / file
    if not path.is_file():
        raise FileNotFoundError(f"no file {file}")
    text = path.read_text(encoding="utf-8")
    if not section:
        return text
    m = re.search(rf"<!--\s*{re.escape(section)}:start\s*-->(.*?)<!--\s*{re.escape(section)}:end\s*-->", text, re.S)
    if m is None:
        raise KeyError(f"no section '{section}' (<!-- {section}:start --> … <!-- {section}:end -->) in {file}")
    return m.group(1)


ALL_BLOCKS = [b for path in DOCS for b in find_blocks(path)]


def _block_id(block: Block) -> str:
    return f"{block.path.relative_to(ROOT)}:{block.line}"


def test_there_are_figures_blocks():
    """At least one block exists, so the figures test cannot silently check nothing."""
    assert ALL_BLOCKS, "no <!-- figures: … --> block in README.md or docs/*.md"


@pytest.mark.parametrize("block", ALL_BLOCKS, ids=_block_id)
def test_block_sources_exist(block):
    """Every block names at least one source, and every source file and section exists."""
    assert block.sources, f"{_block_id(block)}: the figures block names no source"
    for source in block.sources:
        try:
            source_text(source)
        except (FileNotFoundError, KeyError) as error:
            pytest.fail(f"{_block_id(block)}: source '{source}': {error}")


@pytest.mark.parametrize("block", ALL_BLOCKS, ids=_block_id)
def test_quoted_figures_match_their_sources(block):
    """Every number of a block is one of its sources' numbers, possibly rounded."""
    known: set = set()
    for source in block.sources:
        known |= source_numbers(source_text(source))
    start = block.line + 1
    stale = [q for q in quoted_numbers(block.text, start) if not matches(q, known)]
    assert not stale, "\n".join(
        f"{block.path.relative_to(ROOT)}: block of line {block.line}, line {q.line}: {q.text} "
        f"is not in {' , '.join(block.sources)}" for q in stale)


def test_matcher_on_a_made_up_text(tmp_path):
    """The matcher accepts a rounded figure and rejects an unsourced one; exclusions hold."""
    source = source_numbers("| z_df | 112.7 [110.0, 115.2] | 0.0174 | -5.1 % |")
    text = ("z_df3 at 2.5× the corner: 112.7 and 0.017 match, 133.8 does not, nor −5.3; "
            "−5.1 and 5.1 do. 10⁶ samples, 5 seeds, issue 14, §5, Talts et al. 2018, "
            "[results](benchmarks/RESULTS.md#accuracy)\n")
    got = {q.text: matches(q, source) for q in quoted_numbers(text)}
    assert got == {"2.5": False, "112.7": True, "0.017": True, "133.8": False, "−5.3": False,
                   "−5.1": True, "5.1": True}
    assert not matches(quoted_numbers("-112.7 %")[0], source)  # the source's 112.7 has no minus
    assert [q.text for q in quoted_numbers("5 % and 5 trials and 5.0 s")] == ["5", "5.0"]
    doc = tmp_path / "page.md"
    doc.write_text("a\n<!-- figures: benchmarks/RESULTS.md#perf , x.md -->\n892 MB\n<!-- end figures -->\n",
                   encoding="utf-8")
    (block,) = find_blocks(doc)
    assert (block.line, block.sources, block.text) == (2, ["benchmarks/RESULTS.md#perf", "x.md"], "892 MB\n")
