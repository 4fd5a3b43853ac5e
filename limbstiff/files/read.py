"""Reading one trial file of any accepted format: the reader is chosen by the extension.

| extension | reader |
|---|---|
| ``.csv``, ``.tsv``, ``.txt`` | :func:`limbstiff.files.text.read_text` (comma, tab or semicolon, detected) |
| ``.mat`` | :func:`limbstiff.files.mat.read_mat` (MATLAB v4–v7; v7.3/HDF5 is refused) |
| ``.c3d`` | :func:`limbstiff.files.c3d.read_c3d` (through a protocol; the optional ``ezc3d`` extra) |
| ``.xlsx`` | :func:`limbstiff.files.excel.read_xlsx` (one worksheet, read like text) |

Old binary Excel workbooks (``.xls``) and OpenDocument spreadsheets (``.ods``: pandas' reader
needs ``odfpy``, not a dependency) are refused with what to do (:data:`REFUSED`).

:data:`EXTENSIONS` is the one registry of file types: :func:`read_trial` reads what it lists,
and a batch searches folders for the types it marks ``in_folders``
(:data:`FOLDER_EXTENSIONS`). Every reader ends in
:func:`limbstiff.files.validate.checked_trial`, so a trial is checked the same way whatever
its format.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from ..errors import NotATrial, TrialError
from ..frozen import FrozenDict
from ..trial import Trial
from .dialect import ANY_CONTROL, shown
from .validate import read_bytes

if TYPE_CHECKING:
    from ..protocol import Protocol


def _read_text(path: Path, raw: bytes, protocol: Protocol | None, name: str | None) -> Trial:
    from .text import read_text
    return read_text(path, raw, protocol, name=name)


def _read_mat(path: Path, raw: bytes, protocol: Protocol | None, name: str | None) -> Trial:
    from .mat import read_mat
    return read_mat(path, raw, protocol, name=name)


def _read_xlsx(path: Path, raw: bytes, protocol: Protocol | None, name: str | None) -> Trial:
    from .excel import read_xlsx
    return read_xlsx(path, raw, protocol, name=name)


def _read_c3d(path: Path, raw: bytes, protocol: Protocol | None, name: str | None) -> Trial:
    from .c3d import read_c3d
    return read_c3d(path, raw, protocol, name=name)


@dataclass(frozen=True)
class FileType:
    """A trial-file type: how it is read and whether folders are searched for it.

    Parameters
    ----------
    read : callable (path, raw, protocol, name) -> Trial
        The reader, given the file's path (for messages and the default trial name), its
        bytes, the protocol (or None) and the trial name (None: the file stem); it returns the
        trial checked by :func:`limbstiff.files.validate.checked_trial` (SI units, a uniform
        time base) or raises :class:`~limbstiff.errors.TrialError` with one line naming the
        file and the problem. Its module is imported only when such a file is read.
    in_folders : bool
        Whether a batch searches folders for files of this type (files named explicitly are
        read whatever this says).
    """

    read: Callable[[Path, bytes, "Protocol | None", str | None], Trial]
    in_folders: bool = True


#: Accepted extensions (lower case) and their file types, in the order error messages list them.
#: ``.txt`` is read when named but not searched for: a data folder's README.txt or notes would
#: otherwise become failed trials.
EXTENSIONS = FrozenDict({".csv": FileType(_read_text), ".tsv": FileType(_read_text),
                         ".txt": FileType(_read_text, in_folders=False), ".mat": FileType(_read_mat),
                         ".c3d": FileType(_read_c3d), ".xlsx": FileType(_read_xlsx)})
#: Extensions of trial formats that are not read, and what to do instead.
REFUSED = FrozenDict({".xls": "an old binary Excel workbook (.xls) is not read: save it as .xlsx or .csv",
                      ".ods": "an OpenDocument spreadsheet (.ods) is not read: save it as .xlsx or .csv "
                              "(LibreOffice: File > Save As)"})
#: The extensions a batch searches folders for: the types it reads, and the refused ones, so that a
#: workbook kept in a trials folder is said (and skipped), not silently passed over.
FOLDER_EXTENSIONS = tuple(ext for ext, file_type in EXTENSIONS.items() if file_type.in_folders) + tuple(REFUSED)


def read_trial(path, protocol: Protocol | None = None, *, name: str | None = None) -> Trial:
    """Read one trial file into a :class:`~limbstiff.trial.Trial` in SI units.

    Parameters
    ----------
    path : str or path-like
        A ``.csv``, ``.tsv`` or ``.txt`` file (UTF-8 text: ``# key: value`` metadata lines,
        one header row, an optional unit row, one row per sample; comma, tab or semicolon
        separated), an ``.xlsx`` workbook (one worksheet laid out as the text), a ``.mat`` file
        (MATLAB v4 to v7: one variable per quantity) or a ``.c3d`` file (analog or point
        channels named by the protocol).
    protocol : Protocol or None
        Maps other column or variable names, units, scales and signs (``protocol.columns``);
        ``delimiter``, ``decimal``, ``unit_row`` of text files; ``sheet`` of workbooks;
        ``sample_rate_hz`` (Hz) of
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
    file_type = EXTENSIONS.get(path.suffix.lower())
    if path.suffix.lower() in REFUSED:           # not read: no trial here (skipped when found in a folder)
        raise NotATrial(str(path), REFUSED[path.suffix.lower()])
    if file_type is None:
        accepted = ", ".join(EXTENSIONS)
        raise TrialError(str(path), f"unknown file type '{path.suffix or '(no extension)'}' "
                                    f"(accepted: {accepted})")
    try:
        return file_type.read(path, read_bytes(path), protocol, name)
    except TrialError as exc:
        if not ANY_CONTROL.search(exc.problem):
            raise
        # a header or cell quoted from the file held a control character: one printable line still
        raise TrialError(exc.source, shown(exc.problem, len(exc.problem))) from None
