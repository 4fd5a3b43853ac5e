"""Which files a batch analyses, and the output folder name of each.

Folders are searched recursively for the file types the reader marks for folders
(:data:`limbstiff.files.read.FOLDER_EXTENSIONS`); files and globs are taken as named.
"""

from __future__ import annotations

import glob
import os
from pathlib import Path
from typing import Iterable, Sequence

from ..errors import LimbstiffError
from ..files.read import FOLDER_EXTENSIONS


class NothingToDo(LimbstiffError):
    """No trial file was found in the paths given."""


def discover(paths: Iterable[str | os.PathLike], *, extensions: tuple[str, ...] = FOLDER_EXTENSIONS,
             missing: list[tuple[str, str]] | None = None, searched: set[Path] | None = None) -> list[Path]:
    """Trial files named by ``paths``: files, folders (searched recursively) or globs.

    Folders are searched for files whose extension is in ``extensions`` (case-insensitive);
    files named explicitly or matched by a glob are taken whatever their extension (the reader
    says if it cannot read one).

    Parameters
    ----------
    missing : list, optional
        When given, a path that matches nothing is appended to it as (path, one-line reason)
        instead of stopping the batch: the other trials still run and the missing one is a
        failed row of ``summary.csv``.
    searched : set, optional
        When given, the files found by searching a folder (not named or globbed) are added to it,
        resolved: a batch skips those that are no trial.

    Raises
    ------
    NothingToDo
        When a path matches nothing (and ``missing`` is not given), or nothing at all is found.
    """
    found: list[Path] = []
    for raw in paths:
        text = str(raw)
        p = Path(text)
        if p.is_dir():
            inside = sorted(q for q in p.rglob("*") if q.is_file() and q.suffix.lower() in extensions
                            and not q.name.startswith("."))
            found += inside
            if searched is not None:
                searched.update(q.resolve() for q in inside)
            continue
        if p.is_file():
            found.append(p)
            continue
        why = None
        if glob.has_magic(text):
            matches = sorted(Path(q) for q in glob.glob(text, recursive=True) if Path(q).is_file())
            found += matches
            why = None if matches else f"{text}: no file matches this pattern"
        else:
            why = f"{text}: no such file or folder"
        if why and missing is None:
            raise NothingToDo(why)
        if why:
            missing.append((text, why))
    unique = list(dict.fromkeys(q.resolve() for q in found))
    if not unique and not missing:
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


class OutputFolderError(LimbstiffError):
    """The output folder cannot be made or written (a usage error: exit status 2)."""


def writable_folder(out: str | os.PathLike) -> Path:
    """``out``, made if needed, once a file has been written in it and removed; checked before any
    trial runs, so that a batch never analyses for nothing.

    Raises
    ------
    OutputFolderError
        One line naming the folder, the reason and what to do.
    """
    import tempfile

    path = Path(out)
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=path, prefix=".limbstiff-probe-"):
            pass
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        if isinstance(exc, FileExistsError) or (path.exists() and not path.is_dir()):
            reason = "it is a file, not a folder"
        raise OutputFolderError(f"{path}: cannot write the output folder ({reason}); choose another --out") from None
    return path
