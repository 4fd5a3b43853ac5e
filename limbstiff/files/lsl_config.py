"""liblsl's configuration as limbstiff hands it over: the user's own, with liblsl's log kept off the terminal.

liblsl writes INFO lines, and an ``ERR`` line whenever a sender closes its outlet (``Stream
transmission broke off … re-connecting``: a normal end of a stream), on stderr, over the terminal's
status line. Before limbstiff's first LSL call (:func:`hand_over`) liblsl is given the file it would
read itself (:func:`user_config`) with ``[log] level = -3`` added unless that file sets a level
(:func:`liblsl_config`), through ``set_config_content`` (liblsl ≥ 1.17.7; with an older one liblsl
reads the file itself and logs as it is set). I/O only: reads the file, no LSL call but that one.
"""

from __future__ import annotations

import os
from pathlib import Path

#: liblsl's log level on the terminal unless the user's configuration sets one: fatal errors only
#: (-2, errors, would still show the ERR line of every sender that closes its outlet).
LOG_LEVEL = -3


def user_config() -> Path | None:
    """The configuration file liblsl would read: ``LSLAPICFG``, else ``lsl_api.cfg`` in the working
    folder, ``~/lsl_api/lsl_api.cfg``, ``/etc/lsl_api/lsl_api.cfg`` (the first readable); None."""
    named = os.environ.get("LSLAPICFG")
    places = [Path(named)] if named else []
    places += [Path.cwd() / "lsl_api.cfg", Path.home() / "lsl_api" / "lsl_api.cfg", Path("/etc/lsl_api/lsl_api.cfg")]
    return next((path for path in places if path.is_file() and os.access(path, os.R_OK)), None)


def liblsl_config(path: Path | None = None) -> str:
    """liblsl's configuration as limbstiff gives it: the user's file (``path``, by default
    :func:`user_config`) as it is, plus ``[log] level =`` :data:`LOG_LEVEL` when it sets no level."""
    path = user_config() if path is None else path
    text = path.read_text(encoding="utf-8", errors="replace") if path is not None else ""
    section, has_level = "", False
    for line in text.splitlines():
        line = line.split(";", 1)[0].strip()
        if line.startswith("[") and line.endswith("]"):
            section = line[1:-1].strip().lower()
        elif section == "log" and line.split("=", 1)[0].strip().lower() == "level" and "=" in line:
            has_level = True
    if has_level:
        return text
    head = f"{text.rstrip()}\n\n" if text.strip() else ""
    return f"{head}; added by limbstiff: liblsl's log off the terminal\n[log]\nlevel = {LOG_LEVEL}\n"


def hand_over(pylsl) -> None:
    """Give liblsl :func:`liblsl_config` (before any other LSL call of the process, or it has no
    effect); nothing with a liblsl older than 1.17.7 (or a file that cannot be read: liblsl then
    tries it itself and says why)."""
    try:
        pylsl.set_config_content(liblsl_config())
    except (AttributeError, NotImplementedError, OSError):
        pass
