"""A folder of one-cycle files read as one ensemble (issue 36): :func:`read_ensemble`.

Labs often export each movement cycle (a gait stride, a reach) as a file of its own. The files
are read with the same protocol, checked to agree (kind, sample rate, channels, units), put in
the natural order of their names (``cycle2`` before ``cycle10``) and joined into one
:class:`~limbstiff.trial.Trial` whose ``marker`` starts a cycle at the first sample of every
file, so the trial is analysed as an ensemble with ``Cycles(marker=ENSEMBLE_MARKER)``.

The marker is also high on the very last sample, which ends the last file's cycle (a marker's
cycles run from one rising edge to the next: without it the last file would be no whole cycle).
The zero-phase filters smear the step at each join, so the first and last :data:`JOIN_S` of
every file are marked ``bridged`` (not informed by motion).
"""

from __future__ import annotations

import hashlib
import os
import re
from pathlib import Path
from typing import TYPE_CHECKING, Iterable, Sequence

import numpy as np

from ..errors import TrialError
from ..trial import Trial

if TYPE_CHECKING:
    from ..protocol import Protocol

#: Fewest files an ensemble takes: :data:`limbstiff.cycles.MIN_CYCLES` (a module of the same
#: layer as this one, so not imported; ``tests/test_ensemble_files.py`` keeps the two equal).
MIN_FILES = 5
#: Time at each end of every file marked ``bridged``, s: the filters' smear of a join's step.
JOIN_S = 0.02
#: Relative difference of sample rates the files may have.
RATE_TOLERANCE = 1e-6
#: The arrays concatenated file by file (None in every file, or in none).
CHANNELS = ("torque", "elastic_torque", "stiffness_true", "schedule")


def natural_key(path: str | os.PathLike) -> tuple:
    """Sort key of a file by its name in natural order (``cycle2`` before ``cycle10``), then by
    its whole path (files of the same name in different folders)."""
    def chunks(text: str) -> tuple:
        return tuple((0, int(c), "") if c.isdigit() else (1, 0, c.lower())
                     for c in re.split(r"(\d+)", text) if c)
    p = Path(path)
    return chunks(p.name), chunks(str(p))


def ensemble_order(paths: Iterable[str | os.PathLike]) -> list[Path]:
    """The files of an ensemble in natural order of their names.

    Raises
    ------
    TrialError
        Fewer than :data:`MIN_FILES` files (one line).
    """
    files = sorted((Path(p) for p in paths), key=natural_key)
    if len(files) < MIN_FILES:
        where = str(ensemble_folder(files)) if files else "ensemble"
        raise TrialError(where, f"{len(files)} trial file{'s' if len(files) != 1 else ''} found; an ensemble of "
                                f"one-cycle files needs at least {MIN_FILES} (one file per cycle)")
    return files


def ensemble_folder(files: Sequence[Path]) -> Path:
    """The folder the files share (their parents' common path)."""
    return Path(os.path.commonpath([str(Path(f).absolute().parent) for f in files]))


def ensemble_sha256(digests: Iterable[str]) -> str:
    """SHA-256 of an ensemble: over its files' own SHA-256s (hex), in the ensemble's order."""
    return hashlib.sha256("".join(digests).encode("ascii")).hexdigest()


def read_ensemble(paths: Iterable[str | os.PathLike], protocol: Protocol | None = None, *,
                  name: str | None = None) -> Trial:
    """Read one-cycle files as one trial, each file one cycle of the ensemble.

    Parameters
    ----------
    paths : iterable of path-like
        The files (any order: they are sorted by :func:`natural_key`), at least :data:`MIN_FILES`.
    protocol : Protocol or None
        How every file is read (its ``[cycles]`` is not used to read them: the files are the cycles).
    name : str or None
        Trial name; the name of the folder the files share if None.

    Returns
    -------
    Trial
        Time continuous on one uniform grid, the channels concatenated, ``marker`` 1 at the first
        sample of every file (and at the last sample), ``bridged`` at the joins, ``source`` the
        folder, ``source_sha256`` :func:`ensemble_sha256`, metadata the first file's plus
        ``ensemble_files``, every file's warnings prefixed with its name.

    Raises
    ------
    TrialError
        Fewer than :data:`MIN_FILES` files, a file that cannot be read, or one that does not agree
        with the first (kind, sample rate, channels, schedule unit): one line naming it.
    """
    from dataclasses import replace

    from .read import read_trial

    files = ensemble_order(paths)
    folder = ensemble_folder(files)
    reading = None if protocol is None else replace(protocol, cycles=None)
    trials = [read_trial(f, reading) for f in files]
    first = trials[0]
    for f, trial in zip(files[1:], trials[1:]):
        _check_agrees(f, trial, files[0], first)
    return _joined(files, trials, folder=folder, name=name or folder.name)


def _check_agrees(path: Path, trial: Trial, first_path: Path, first: Trial) -> None:
    """One line naming ``path`` when its trial differs from the first file's."""
    def differs(what: str) -> TrialError:
        return TrialError(str(path), f"{what}: the files of an ensemble must agree")

    if trial.kind != first.kind:
        raise differs(f"is a {trial.kind} trial, {first_path.name} a {first.kind} one")
    if abs(trial.fs - first.fs) > RATE_TOLERANCE * first.fs:
        raise differs(f"is sampled at {trial.fs:.6g} Hz, {first_path.name} at {first.fs:.6g} Hz")
    for channel in CHANNELS:
        if (getattr(trial, channel) is None) != (getattr(first, channel) is None):
            has = "has" if getattr(trial, channel) is not None else "has no"
            raise differs(f"{has} '{channel}' column, unlike {first_path.name}")
    if trial.schedule_unit != first.schedule_unit:
        raise differs(f"has its schedule in '{trial.schedule_unit}', {first_path.name} in '{first.schedule_unit}'")


def _joined(files: Sequence[Path], trials: Sequence[Trial], *, folder: Path, name: str) -> Trial:
    """The trials one after another on one time grid, with the marker and the joins' bridges."""
    first = trials[0]
    lengths = [t.n_samples for t in trials]
    n = int(sum(lengths))
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(int)
    ts = first.sample_period
    marker = np.zeros(n)
    marker[starts] = 1.0
    marker[-1] = 1.0                      # the end of the last cycle
    edge = max(1, int(round(JOIN_S / ts)))
    bridged = np.concatenate([np.zeros(t.n_samples, bool) if t.bridged is None else np.asarray(t.bridged, bool)
                              for t in trials])
    for start, length in zip(starts, lengths):
        bridged[start:start + min(edge, length)] = True
        bridged[max(start, start + length - edge):start + length] = True
    channels = {c: None if getattr(first, c) is None else np.concatenate([getattr(t, c) for t in trials])
                for c in CHANNELS}
    metadata = dict(first.metadata, ensemble_files=str(len(files)))
    warnings = [f"{f.name}: {w}" for f, t in zip(files, trials) for w in t.warnings]
    if any(t.marker is not None for t in trials):
        warnings.append("the files' own marker columns are not used: each file is one cycle of the ensemble")
    return Trial(name=name, time=first.time[0] + ts * np.arange(n), angle=np.concatenate([t.angle for t in trials]),
                 kind=first.kind, metadata=metadata, source=str(folder),
                 source_sha256=ensemble_sha256(t.source_sha256 or "" for t in trials), warnings=tuple(warnings),
                 bridged=bridged, schedule_unit=first.schedule_unit, marker=marker, **channels)
