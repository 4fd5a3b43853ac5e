"""Provenance of a result: the software block and a short hash of the settings.

:func:`software` is the one provenance block of every JSON output (``summary.json``,
``posterior.json``, ``diagnosis.json``, a live session's ``stream.json``), and the PDF footers
read theirs from it. Standard library only, and no dependency is imported to learn its version
(the installed distribution's metadata is read instead), so this module is cheap to import anywhere.
"""

from __future__ import annotations

import functools
import hashlib
import json
import platform
from importlib import metadata
from typing import Any, Mapping

from . import __version__

#: Distributions whose versions are recorded, in this order.
DEPENDENCIES = ("numpy", "scipy", "pandas", "emcee", "matplotlib", "numba")


@functools.lru_cache(maxsize=None)
def _dependency_versions() -> tuple[tuple[str, str], ...]:
    found = []
    for name in DEPENDENCIES:
        try:
            found.append((name, metadata.version(name)))
        except metadata.PackageNotFoundError:
            continue
    return tuple(found)


def dependency_versions() -> dict[str, str]:
    """Installed versions of limbstiff's dependencies (those present), read once per process.

    Returns
    -------
    dict of str to str
        Distribution name (``numpy``, ``scipy``, ``pandas``, ``emcee``, ``matplotlib``,
        ``numba``) to version string; a distribution that is not installed is left out.
        A new dict each call (the cached values cannot be changed through it).
    """
    return dict(_dependency_versions())


def software() -> dict:
    """The provenance block: limbstiff's name and version, the Python version and the dependencies'
    versions (:func:`dependency_versions`).

    Returns
    -------
    dict
        ``{"name": "limbstiff", "version", "python", "dependencies"}``, JSON-ready; a new dict each call.
    """
    return {"name": "limbstiff", "version": __version__, "python": platform.python_version(),
            "dependencies": dependency_versions()}


def dependencies_text(block: Mapping[str, Any]) -> str:
    """The dependencies of a :func:`software` block as one line, ``numpy 2.1.3, scipy 1.14.1, …``."""
    return ", ".join(f"{k} {v}" for k, v in block["dependencies"].items())


def settings_hash(settings: Mapping[str, Any], length: int = 12) -> str:
    """Short fingerprint of a result's resolved settings.

    Parameters
    ----------
    settings : Mapping
        The resolved protocol's ``to_dict()`` (JSON-ready values; anything else is hashed as its ``str``).
    length : int
        Hex digits kept.

    Returns
    -------
    str
        The first ``length`` hex digits of the SHA-256 of ``json.dumps(settings, sort_keys=True)``:
        equal settings give equal hashes across runs and machines.
    """
    text = json.dumps(dict(settings), sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:length]
