"""Input and output: trial files (CSV, TSV, XLSX, MAT), units, atomic writes and file hashes.

Scope: everything that touches trial files on disk or a live stream (:func:`read_trial` for every accepted
format, :func:`write_trial` for the standard CSV), the explicit unit table (:data:`UNITS`)
and the atomic-write helpers every output goes through.

| module | job |
|---|---|
| ``read.py`` | :func:`read_trial`: the reader chosen by extension |
| ``ensemble.py`` | :func:`read_ensemble`: one-cycle files read as one ensemble |
| ``text.py`` | CSV, TSV, semicolon-separated text (decimal comma, unit row) |
| ``mat.py`` | MATLAB ``.mat`` files (v4–v7) |
| ``excel.py`` | Excel ``.xlsx`` workbooks (one worksheet, read like text) |
| ``columns.py`` | which column or variable fills which quantity, in which unit |
| ``column_units.py`` | a column's unit checked, the joint kind the units make, the values in SI |
| ``validate.py`` | the common checks: time, gaps, length, motion, resampling, SHA-256 |
| ``units.py`` | the unit table and standard ``<quantity>_<unit>`` names |
| ``csv_writer.py`` | :func:`~.csv_writer.write_csv`: the one CSV writer every CSV goes through |
| ``trial_csv.py`` | :func:`write_trial` (the standard CSV) |
| ``recording.py`` | a CSV written as rows arrive (a live session's recording and estimate) |
| ``lsl.py`` | Lab Streaming Layer streams in: finding, reading clock-corrected (``[stream]`` extra) |
| ``lsl_outlet.py`` | Lab Streaming Layer streams out: the stiffness outlet, a trial published in real time |
"""

from __future__ import annotations

from .atomic import atomic_output, atomic_write_bytes, atomic_write_text, sha256_file
from .trial_csv import write_trial
from .read import EXTENSIONS, read_trial
from .ensemble import read_ensemble
from ..units import UNITS

__all__ = ["read_trial", "read_ensemble", "write_trial", "EXTENSIONS", "UNITS", "atomic_write_text",
           "atomic_write_bytes", "atomic_output", "sha256_file"]
