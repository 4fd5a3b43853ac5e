"""Reading one trial file of any accepted format: the reader is chosen by the extension.

| extension | reader |
|---|---|
| ``.csv``, ``.tsv``, ``.txt`` | :func:`limbstiff.files.text.read_text` (comma, tab or semicolon, detected) |
| ``.mat`` | :func:`limbstiff.files.mat.read_mat` (MATLAB v4–v7; v7.3/HDF5 is refused) |
| ``.c3d`` | :func:`limbstiff.files.c3d.read_c3d` (through a protocol; the optional ``ezc3d`` extra) |

Every reader ends in :func:`limbstiff.files.validate.checked_trial`, so a trial is checked the
same way whatever its format.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import TrialError
from ..trial import Trial
from .validate import read_bytes

#: Accepted extensions (lower case) and the module whose reader handles them.
EXTENSIONS = {".csv": "text", ".tsv": "text", ".txt": "text", ".mat": "mat", ".c3d": "c3d"}


def read_trial(path, protocol=None, *, name: str | None = None) -> Trial:
    """Read one trial file into a :class:`~limbstiff.trial.Trial` in SI units.

    Parameters
    ----------
    path : str or path-like
        A ``.csv``, ``.tsv`` or ``.txt`` file (UTF-8 text: ``# key: value`` metadata lines,
        one header row, an optional unit row, one row per sample; comma, tab or semicolon
        separated), a ``.mat`` file (MATLAB v4 to v7: one variable per quantity) or a ``.c3d``
        file (analog or point channels named by the protocol).
    protocol : Protocol or None
        Maps other column or variable names, units, scales and signs (``protocol.columns``);
        ``delimiter``, ``decimal``, ``unit_row`` of text files; ``sample_rate_hz`` (Hz) of
        files without time; ``sample_period`` (s) to resample to. Quantities it does not
        list use the standard ``<quantity>_<unit>`` names.
    name : str or None
        Trial name; the file stem if None.

    Returns
    -------
    Trial
        Uniformly sampled; ``warnings`` says what was resampled or ignored.

    Raises
    ------
    TrialError
        With a one-line message naming the file and the problem (an unknown extension too).
    """
    path = Path(path)
    if path.is_dir():
        raise TrialError(str(path), "is a directory, not a trial file")
    reader = EXTENSIONS.get(path.suffix.lower())
    if reader is None:
        accepted = ", ".join(EXTENSIONS)
        raise TrialError(str(path), f"unknown file type '{path.suffix or '(no extension)'}' "
                                    f"(accepted: {accepted})")
    raw = read_bytes(path)
    if reader == "mat":
        from .mat import read_mat
        return read_mat(path, raw, protocol, name=name)
    if reader == "c3d":
        from .c3d import read_c3d
        return read_c3d(path, raw, protocol, name=name)
    from .text import read_text
    return read_text(path, raw, protocol, name=name)
