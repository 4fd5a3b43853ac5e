"""Writing a trial as the standard CSV file of docs/interface.md section 1.

Reading is :func:`limbstiff.files.read_trial` (:mod:`limbstiff.files.text` for CSV and other
delimited text); what :func:`write_trial` writes, it reads back to the same arrays.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..trial import Trial
from ..units import FIELDS, UNITS, canonical_unit
from .csv_writer import write_csv

_HEADERS = {
    "rotational": ("time_s", "angle_rad", "torque_Nm", "elastic_torque_Nm", "stiffness_true_Nm_per_rad"),
    "translational": ("time_s", "position_m", "force_N", "elastic_force_N", "stiffness_true_N_per_m"),
}


def write_trial(trial: Trial, path) -> Path:
    """Write a trial as a standard CSV file, atomically.

    Metadata become ``# key: value`` lines; the header is ``time_s,angle_rad,torque_Nm``
    (``time_s,position_m,force_N`` for translational trials), then ``elastic_torque_Nm`` /
    ``elastic_force_N`` and ``stiffness_true_Nm_per_rad`` / ``stiffness_true_N_per_m`` when
    present; then ``schedule_<unit>`` when the trial has a scheduling variable (its SI unit in
    the table's ASCII spelling: ``schedule_rad``, ``schedule_Nm``; a free unit as it is:
    ``schedule_%MVC``) and ``marker`` when it has a cycle marker. Floats are written at full
    precision (the shortest text that reads back to the bit), so :func:`read_trial` gives the same arrays (the marker is read back with a
    protocol whose ``[cycles]`` says ``marker = "marker"``; without one it is an ignored column).

    Parameters
    ----------
    trial : Trial
    path : str or path-like
        Destination; parent directories are created, an existing file is replaced.

    Returns
    -------
    Path
        ``path``.
    """
    data = {}
    for field, header in zip(FIELDS, _HEADERS[trial.kind]):
        array = getattr(trial, field)
        if array is not None:
            data[header] = np.asarray(array, dtype=float)
    if trial.schedule is not None:
        data[schedule_header(trial.schedule_unit)] = np.asarray(trial.schedule, dtype=float)
    if trial.marker is not None:
        data["marker"] = np.asarray(trial.marker, dtype=float)
    write_csv(path, data, digits=None, metadata=trial.metadata)
    return Path(path)


def schedule_header(unit: str) -> str:
    """The standard header of a scheduling variable in ``unit``: ``schedule_<unit>``, a unit of the
    table in its first (ASCII) spelling (``N·m`` → ``schedule_Nm``), a free unit as it is
    (``schedule_%MVC``), which the readers keep unconverted.

    Raises
    ------
    ValueError
        A unit that cannot stand in a CSV header (a comma, a quote, a line break).
    """
    if unit in UNITS:
        return f"schedule_{canonical_unit(unit)}"
    if any(c in unit for c in ',;\t"\n\r') or unit != unit.strip():
        raise ValueError(f"schedule unit {unit!r} cannot be written in a CSV header")
    return f"schedule_{unit}"
