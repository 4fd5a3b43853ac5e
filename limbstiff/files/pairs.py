"""Reading force–displacement calibration pairs (for ``limbstiff calibrate``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import TrialError
from ..units import DIMENSION_KIND, UNITS, parse_standard_header, to_si, unit_in_header

_DISPLACEMENT = ("position", "angle")
_FORCE = ("elastic_force", "force", "elastic_torque", "torque")


def _pick(headers, wanted, given, what, path):
    if given is not None:
        if given not in headers:
            raise TrialError(path, f"no column '{given}' (found: {', '.join(headers)})")
        return given
    for quantity in wanted:
        for h in headers:
            parsed = parse_standard_header(h)
            if parsed and parsed[0] == quantity:
                return h
    raise TrialError(path, f"no {what} column (looked for {', '.join(q + '_<unit>' for q in wanted)}; "
                           f"found: {', '.join(headers)})")


def read_pairs(path: str | Path, *, displacement: str | None = None,
               force: str | None = None) -> tuple[np.ndarray, np.ndarray, str]:
    """Force–displacement pairs from a CSV file, in SI units.

    Parameters
    ----------
    path : str or Path
        CSV with a header; ``#`` lines before it are skipped.
    displacement, force : str, optional
        Column names; by default the standard ``position_*``/``angle_*`` and
        ``elastic_force_*``/``force_*``/``torque_*`` columns.

    Returns
    -------
    displacement : ndarray, shape (n,), m (rad)
    force : ndarray, shape (n,), N (N·m)
    kind : {"rotational", "translational"}
        From the displacement's unit (an angle or a length).

    Raises
    ------
    TrialError
        Missing file or column, non-numeric values, unknown unit.
    """
    import pandas as pd

    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError:
        raise TrialError(path, "file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise TrialError(path, f"cannot read file ({exc})") from None
    lines = [ln for ln in text.splitlines() if not ln.lstrip().startswith("#")]
    if not lines:
        raise TrialError(path, "empty file: no header")
    import io as _io
    frame = pd.read_csv(_io.StringIO("\n".join(lines)), dtype=str)
    headers = [str(h).strip() for h in frame.columns]
    frame.columns = headers
    out, dimensions = [], []
    for given, wanted, what in ((displacement, _DISPLACEMENT, "displacement"), (force, _FORCE, "force")):
        col = _pick(headers, wanted, given, what, path)
        parsed = parse_standard_header(col)
        unit = parsed[1] if parsed else unit_in_header(col)
        if unit not in UNITS:
            raise TrialError(path, f"unknown unit '{unit}' in column '{col}'")
        values = pd.to_numeric(frame[col].str.strip(), errors="coerce").to_numpy(dtype=float)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise TrialError(path, f"column '{col}' has a missing or non-numeric value at data row {bad[0] + 1}")
        out.append(to_si(values, unit))
        dimensions.append(UNITS[unit].dimension)
    kind = DIMENSION_KIND[dimensions[0]]
    if dimensions[0] not in ("angle", "length") or dimensions[1] not in ("torque", "force") \
            or DIMENSION_KIND[dimensions[1]] != kind:
        raise TrialError(path, f"displacement in {dimensions[0]} units and force in {dimensions[1]} units: pairs are "
                               "an angle with a torque or a length with a force")
    return out[0], out[1], kind
