"""Which files a batch analyses, and the output folder name of each.

Folders are searched recursively for trial files; files and globs are taken as named.
Standard library only.
"""

from __future__ import annotations

import glob
import os
from pathlib import Path
from typing import Iterable, Sequence

from ..errors import LimbstiffError

#: What folders are searched for. ``.txt`` is read when named, but not searched for: a data
#: folder's README.txt or notes would otherwise become failed trials.
FOLDER_EXTENSIONS = (".csv", ".tsv", ".mat")

class NothingToDo(LimbstiffError):
    """No trial file was found in the paths given."""


def discover(paths: Iterable[str | os.PathLike], *, extensions: tuple[str, ...] = FOLDER_EXTENSIONS) -> list[Path]:
    """Trial files named by ``paths``: files, folders (searched recursively) or globs.

    Folders are searched for files whose extension is in ``extensions`` (case-insensitive);
    files named explicitly or matched by a glob are taken whatever their extension (the reader
    says if it cannot read one).

    Raises
    ------
    NothingToDo
        When a path matches nothing, or nothing at all is found.
    """
    found: list[Path] = []
    for raw in paths:
        text = str(raw)
        p = Path(text)
        if p.is_dir():
            found += sorted(q for q in p.rglob("*") if q.is_file() and q.suffix.lower() in extensions
                            and not q.name.startswith("."))
        elif p.is_file():
            found.append(p)
        elif glob.has_magic(text):
            matches = sorted(Path(q) for q in glob.glob(text, recursive=True) if Path(q).is_file())
            if not matches:
                raise NothingToDo(f"{text}: no file matches this pattern")
            found += matches
        else:
            raise NothingToDo(f"{text}: no such file or folder")
    unique = list(dict.fromkeys(q.resolve() for q in found))
    if not unique:
        raise NothingToDo("no trial files found (folders are searched for "
                          + ", ".join(f"*{e}" for e in extensions) + ")")
    return unique


def output_names(files: Sequence[Path]) -> tuple[list[str], list[str]]:
    """One output folder name per file: its stem, made unique when stems collide.

    Returns
    -------
    names : list of str
    notes : list of str
        One line per collision, saying which file went where.
    """
    names, notes, used = [], [], set()
    for f in files:
        name, k = f.stem, 2
        while name in used:
            name, k = f"{f.stem}-{k}", k + 1
        if name != f.stem:
            notes.append(f"{f}: another trial is also named '{f.stem}'; its outputs are in '{name}/'")
        used.add(name)
        names.append(name)
    return names, notes
