"""Input and output: trial CSV files, units, atomic writes and file hashes.

Scope: everything that touches trial files on disk (:func:`read_trial`, :func:`write_trial`),
the explicit unit table (:data:`UNITS`) and the atomic-write helpers every output goes through.
"""

from __future__ import annotations

from .atomic import atomic_output, atomic_write_bytes, atomic_write_text, sha256_file
from .csv import read_trial, write_trial
from .units import UNITS

__all__ = ["read_trial", "write_trial", "UNITS", "atomic_write_text", "atomic_write_bytes",
           "atomic_output", "sha256_file"]
