"""Writing the outputs of ``limbstiff analyze`` (docs/interface.md section 4), atomically.

Each file is written to a temporary name and renamed, so a reader never sees half a file and
an interrupted run leaves the previous complete file (or none). ``summary.json`` is written
last: its presence marks a trial whose outputs are complete.
"""

from __future__ import annotations

import json
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Mapping

import numpy as np

from .atomic import atomic_write_text

#: Significant digits of the stiffness columns of ``stiffness.csv``: the band is rarely narrower
#: than 0.1 % of the stiffness, so a fifth digit is already below the estimate's uncertainty.
STIFFNESS_DIGITS = 5

STIFFNESS_CSV = "stiffness.csv"
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
    """Write ``stiffness.csv`` and ``summary.json`` of one result into ``directory``.

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
    frame = result.to_frame()
    for column in ("stiffness", "stiffness_lo", "stiffness_hi"):
        frame[column] = round_significant(frame[column].to_numpy(), digits=STIFFNESS_DIGITS)
    # time keeps ten digits: a microsecond an hour into a trial
    atomic_write_text(directory / STIFFNESS_CSV, frame.to_csv(index=False, float_format="%.10g"))
    summary = result.summary()
    if extra:
        summary.update(extra)
    write_json(directory / SUMMARY_JSON, summary)
    return summary
