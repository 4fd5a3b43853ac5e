"""Writing the outputs of ``limbstiff analyze`` (docs/interface.md section 4), atomically.

Each file is written to a temporary name and renamed, so a reader never sees half a file and
an interrupted run leaves the previous complete file (or none). ``summary.json`` is written
last: its presence marks a trial whose outputs are complete.

The per-sample CSVs go through the one CSV writer (:func:`~.csv_writer.write_csv`, ten digits).
"""

from __future__ import annotations

import json
import os
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

from ..errors import LimbstiffError
from .atomic import atomic_write_text
from .csv_writer import write_csv

#: Significant digits of the stiffness columns of ``stiffness.csv``: the band is rarely narrower
#: than 0.1 % of the stiffness, so a fifth digit is already below the estimate's uncertainty.
STIFFNESS_DIGITS = 5

STIFFNESS_CSV = "stiffness.csv"
#: The stiffness against the cycle's phase or the schedule (an ensemble or schedule analysis).
CURVE_CSV = {"phase": "stiffness_by_phase.csv", "schedule": "stiffness_by_schedule.csv"}
SUMMARY_JSON = "summary.json"
REPORT_PDF = "report.pdf"

#: Field metadata: the JSON leaves the key out when the value is None.
OMIT_NONE = {"omit_none": True}


def jsonable(value):
    """Plain JSON values: a dataclass as its fields (in order, named as its keys; a field with
    :data:`OMIT_NONE` left out when None), an object with ``to_dict`` as that, numpy scalars and
    arrays converted, non-finite floats as None."""
    if hasattr(value, "to_dict"):
        return jsonable(value.to_dict())
    if is_dataclass(value) and not isinstance(value, type):
        return {f.name: jsonable(getattr(value, f.name)) for f in fields(value)
                if not (f.metadata.get("omit_none") and getattr(value, f.name) is None)}
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return jsonable(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def write_json(path: str | Path, data: dict) -> None:
    """Write ``data`` as indented UTF-8 JSON, atomically."""
    atomic_write_text(path, json.dumps(data, indent=2, ensure_ascii=False, allow_nan=False) + "\n")


def round_significant(x: np.ndarray, *, digits: int) -> np.ndarray:
    """Values rounded to a number of significant digits.

    Parameters
    ----------
    x : ndarray, shape (n,)
    digits : int

    Returns
    -------
    ndarray, shape (n,)
        ``x`` to ``digits`` significant digits; NaN and ±inf kept, 0 stays 0.
    """
    x = np.asarray(x, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        exponent = np.floor(np.log10(np.abs(x)))
        scale = np.where(np.isfinite(exponent), 10.0 ** (digits - 1 - exponent), 1.0)
        return np.where(np.isfinite(x) & (x != 0), np.round(x * scale) / scale, x)


def write_result(result, directory: str | Path, *, extra: dict | None = None) -> dict:
    """Write ``stiffness.csv`` and ``summary.json`` of one result into ``directory``, and
    ``stiffness_by_phase.csv`` or ``stiffness_by_schedule.csv`` for an ensemble or schedule analysis.

    Parameters
    ----------
    result : StiffnessResult
    directory : str or Path
        Created if needed.
    extra : dict, optional
        More keys for ``summary.json`` (for example the outputs written alongside).

    Returns
    -------
    dict
        The summary that was written.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    # time keeps ten digits: a microsecond an hour into a trial
    write_csv(directory / STIFFNESS_CSV, _rounded(result.columns()))
    if getattr(result, "curve", None) is not None:
        frame = result.curve.to_frame()
        write_csv(directory / CURVE_CSV[result.curve.against], _rounded({c: frame[c].to_numpy() for c in frame}))
    summary = result.to_dict()
    if extra:
        summary.update(extra)
    write_json(directory / SUMMARY_JSON, summary)
    return summary


def _rounded(columns: dict) -> dict:
    """``columns`` with the stiffness and its band to :data:`STIFFNESS_DIGITS` significant digits."""
    return {name: round_significant(values, digits=STIFFNESS_DIGITS)
            if name in ("stiffness", "stiffness_lo", "stiffness_hi") else values
            for name, values in columns.items()}


class OutputExists(LimbstiffError):
    """A file a command would write is there already and ``--overwrite`` was not given (exit 2)."""


class OutputPathError(LimbstiffError):
    """A file a command would write cannot be written there (exit 2)."""


def writable_file(path: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """``path``, once checked that a command may write it as a file, before anything is computed
    or written.

    Parameters
    ----------
    path : str or path-like
        The file to write (its folder must exist).
    overwrite : bool
        Whether an existing file may be replaced (``--overwrite``).

    Returns
    -------
    Path

    Raises
    ------
    OutputExists
        ``path`` exists and ``overwrite`` is false.
    OutputPathError
        ``path`` is a folder, its folder is missing, is a file or cannot be written in.
    """
    import tempfile

    path = Path(path)
    if path.is_dir():
        raise OutputPathError(f"{path}: is a folder, not a file; give a file path")
    if path.exists() and not overwrite:
        raise OutputExists(f"{path} exists: use --overwrite to replace it, or another path")
    parent = path.parent
    if not parent.is_dir():
        through = next((a for a in (parent, *parent.parents) if a.exists() and not a.is_dir()), None)
        why = f"{through} is a file, not a folder" if through else f"its folder {parent} does not exist"
        raise OutputPathError(f"{path}: cannot write it ({why}); choose another path")
    try:
        with tempfile.NamedTemporaryFile(dir=parent, prefix=".limbstiff-probe-"):
            pass
    except OSError as exc:
        raise OutputPathError(f"{path}: cannot write in {parent} ({exc.strerror or type(exc).__name__}); "
                              "choose another path") from None
    return path


def refuse_existing(directory: str | os.PathLike, names: Iterable[str], *, overwrite: bool = False) -> None:
    """Refuse, before anything runs, to replace the outputs ``names`` in ``directory`` without
    ``overwrite`` (``limbstiff diagnose``).

    Raises
    ------
    OutputExists
        One line naming the folder and the files there.
    """
    there = [n for n in names if (Path(directory) / n).exists()]
    if there and not overwrite:
        raise OutputExists(f"outputs in {directory} exist ({', '.join(there)}): use --overwrite to replace them, "
                           "or another --out")
