"""The batch's table, ``summary.csv``, and the test of whether a trial's outputs are current.

A finished trial's row is a :class:`TrialRow`, read from the ``summary.json`` (or
``posterior.json``) it wrote or kept; the table's cells are made from it only when
``summary.csv`` is written (by the one CSV writer, cell by cell).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from ..files.csv_writer import write_csv
from ..files.outputs import SUMMARY_JSON
from ..frozen import FrozenDict
from .runner import TrialOutcome

SUMMARY_COLUMNS = ("trial", "status", "verdict", "error", "source", "variant", "stiffness_median", "stiffness_lo",
                   "stiffness_hi", "inertia_median", "damping_median", "observable_fraction", "resumed",
                   "output", "inertia_lo", "inertia_hi", "damping_lo", "damping_hi", "stiffness_at_mean_torque",
                   "stiffness_at_mean_torque_lo", "stiffness_at_mean_torque_hi", "stiffness_torque_slope",
                   "stiffness_torque_slope_lo", "stiffness_torque_slope_hi", "kind", "stiffness_unit", "inertia_unit",
                   "damping_unit", "curve_verdict")
#: Prefix of the ``summary.csv`` columns that carry each trial's metadata (``# key: value`` lines).
METADATA_PREFIX = "meta."
#: The run's table, in the output folder.
SUMMARY_CSV = "summary.csv"


@dataclass(frozen=True)
class RowInterval:
    """A value with its interval as a trial's JSON output gives it; None where it gives none (a
    blank cell). Values are kept as written, so that the table shows them digit for digit.

    Parameters
    ----------
    median, lo, hi : float or None
        In the quantity's SI unit.
    """

    median: float | None = None
    lo: float | None = None
    hi: float | None = None

    @classmethod
    def of(cls, value: Any) -> "RowInterval":
        """The interval of a JSON ``{median, lo, hi}`` object (blank when ``value`` is none)."""
        value = _mapping(value)
        return cls(value.get("median"), value.get("lo"), value.get("hi"))


@dataclass(frozen=True, kw_only=True)
class TrialRow:
    """What ``summary.csv`` shows of one finished trial.

    Parameters
    ----------
    variant : str or None
        ``external`` or ``direct`` (None for ``identify``).
    verdict : str or None
        ``ok``, ``caution`` or ``unreliable`` (None when there are no checks).
    stiffness : RowInterval
        The trial's median stiffness, N·m/rad (N/m).
    inertia, damping : RowInterval
        kg·m², N·m·s/rad (kg, N·s/m); blank for the direct variant.
    stiffness_at_mean_torque : RowInterval
        N·m/rad (N/m).
    stiffness_torque_slope : RowInterval
        1/rad (1/m): how much stiffer per N·m (N) of background torque.
    observable_fraction : float or None
        Share of samples informed by motion.
    output : str or None
        The trial's output folder, as given.
    metadata : Mapping[str, str]
        The trial's ``# key: value`` metadata.
    resumed : bool
        Its outputs were current and kept (``--resume``), not made again.
    kind : str or None
        ``rotational`` or ``translational``: which units its figures are in.
    units : Mapping[str, str]
        The SI units of its figures (``stiffness``, ``inertia``, ``damping``…), as its JSON gives them.
    curve_verdict : str or None
        The verdict of its stiffness by phase or by schedule (None: the trial has no curve).
    """

    variant: str | None = None
    verdict: str | None = None
    stiffness: RowInterval = RowInterval()
    inertia: RowInterval = RowInterval()
    damping: RowInterval = RowInterval()
    stiffness_at_mean_torque: RowInterval = RowInterval()
    stiffness_torque_slope: RowInterval = RowInterval()
    observable_fraction: float | None = None
    output: str | None = None
    metadata: Mapping[str, str] = field(default_factory=FrozenDict)
    resumed: bool = False
    kind: str | None = None
    units: Mapping[str, str] = field(default_factory=FrozenDict)
    curve_verdict: str | None = None

    @classmethod
    def from_summary(cls, summary: Mapping[str, Any], *, resumed: bool = False) -> "TrialRow":
        """The row of a trial's ``summary.json`` or ``posterior.json`` content (a key it lacks
        is a blank cell)."""
        level = _mapping(summary.get("trial_level"))
        units = {str(k): str(v) for k, v in _mapping(summary.get("units")).items()}
        return cls(variant=summary.get("variant"), verdict=summary.get("verdict"),
                   stiffness=RowInterval.of(summary.get("stiffness")), inertia=RowInterval.of(summary.get("inertia")),
                   damping=RowInterval.of(summary.get("damping")),
                   stiffness_at_mean_torque=RowInterval.of(level.get("stiffness_at_mean_torque")),
                   stiffness_torque_slope=RowInterval.of(level.get("stiffness_torque_slope")),
                   observable_fraction=summary.get("observable_fraction"), output=summary.get("output"),
                   metadata=FrozenDict(_mapping(summary.get("metadata"))), resumed=resumed,
                   kind=summary.get("kind") or _kind_of(units), units=FrozenDict(units),
                   curve_verdict=(_mapping(summary.get("by_phase")) or _mapping(summary.get("by_schedule"))).get("verdict"))


#: The length unit of each kind's displacement (``units.angle`` of the JSON outputs), to tell a
#: ``posterior.json``'s kind, which it does not name.
_KIND_BY_DISPLACEMENT = {"rad": "rotational", "m": "translational"}


def _kind_of(units: Mapping[str, str]) -> str | None:
    return _KIND_BY_DISPLACEMENT.get(units.get("angle", ""))


def _mapping(value: Any) -> Mapping:
    return value if isinstance(value, Mapping) else {}


def summary_row(outcome: TrialOutcome[TrialRow]) -> dict:
    """The ``summary.csv`` row of one outcome (None is a blank cell)."""
    row = outcome.row or TrialRow()
    return {
        "trial": outcome.trial, "status": outcome.status, "verdict": row.verdict or "", "error": outcome.error,
        "source": outcome.source, "variant": row.variant,
        "stiffness_median": row.stiffness.median, "stiffness_lo": row.stiffness.lo, "stiffness_hi": row.stiffness.hi,
        "inertia_median": row.inertia.median, "damping_median": row.damping.median,
        "observable_fraction": row.observable_fraction,
        "resumed": int(outcome.resumed) if outcome.status == "ok" else "",
        "output": row.output,
        **_interval_columns(row),
        "kind": row.kind, **{f"{q}_unit": row.units.get(q) for q in ("stiffness", "inertia", "damping")},
        "curve_verdict": row.curve_verdict,
        **{METADATA_PREFIX + str(k): v for k, v in row.metadata.items()},
    }


def _interval_columns(row: TrialRow) -> dict:
    """The ``_lo``/``_hi`` columns: inertia and damping, the trial-level figures."""
    out = {}
    for name in ("inertia", "damping"):
        iv = getattr(row, name)
        out.update({f"{name}_lo": iv.lo, f"{name}_hi": iv.hi})
    for name in ("stiffness_at_mean_torque", "stiffness_torque_slope"):
        iv = getattr(row, name)
        out.update({name: iv.median, f"{name}_lo": iv.lo, f"{name}_hi": iv.hi})
    return out


def summary_table(outcomes: Sequence[TrialOutcome[TrialRow]]) -> dict[str, np.ndarray]:
    """The columns of ``summary.csv``, one row per outcome (object arrays; None a blank cell).

    The fixed columns (:data:`SUMMARY_COLUMNS`) come first, then one ``meta.<key>`` column per
    metadata key found in any trial (None where a trial lacks it), so a spreadsheet can sort
    and group the trials by subject, condition….
    """
    rows = [summary_row(o) for o in outcomes]
    meta = sorted({k for r in rows for k in r if k.startswith(METADATA_PREFIX)})
    return {name: np.array([r.get(name) for r in rows], dtype=object) for name in [*SUMMARY_COLUMNS, *meta]}


def write_summary_csv(path: Path, outcomes: Sequence[TrialOutcome[TrialRow]]) -> None:
    """Write ``summary.csv`` (:func:`summary_table`), one row per trial, atomically."""
    write_csv(path, summary_table(outcomes))


def up_to_date(directory: Path, *, source_sha256: str, run_sha256: str, files: Iterable[str],
               marker: str = SUMMARY_JSON) -> TrialRow | None:
    """The row of a trial whose outputs need not be made again (``resumed``), or None.

    They need not when ``marker`` (``summary.json`` or ``posterior.json``, written last, so
    present only for a complete trial) records the same input SHA-256 and the same run
    fingerprint (settings, seed, reference, version), and every file in ``files`` is there.
    """
    summary = read_marker(directory / marker)
    if summary is None:
        return None
    if summary.get("source_sha256") != source_sha256 or summary.get("run_sha256") != run_sha256:
        return None
    written = summary.get("files") if isinstance(summary.get("files"), list) else []
    if not all((directory / f).is_file() for f in [*files, *written]):      # a curve's file too
        return None
    return TrialRow.from_summary(summary, resumed=True)


def outputs_state(directory: Path, *, source: Path, run_sha256: str, files: Iterable[str],
                  marker: str = SUMMARY_JSON, input_sha256: Callable[[], str] | None = None) -> str:
    """What a trial's outputs in ``directory`` are to a run about to make them, read before it does.

    Returns
    -------
    str
        ``absent`` (no complete outputs: ``marker`` missing or unreadable), ``current`` (made from
        ``source`` as it is, with ``run_sha256``, every file in ``files`` there), ``settings`` (made
        with another run fingerprint: settings, seed, reference or version), ``input`` (from
        another content of ``source``) or ``files`` (lacking a file of ``files``). ``input_sha256``
        computes the input's SHA-256 when it is not ``source``'s alone (an ensemble's files).
    """
    from ..files.atomic import sha256_file

    summary = read_marker(Path(directory) / marker)
    if summary is None:
        return "absent"
    if summary.get("run_sha256") != run_sha256:
        return "settings"
    try:
        if summary.get("source_sha256") != (sha256_file(source) if input_sha256 is None else input_sha256()):
            return "input"
    except OSError:
        return "input"
    return "current" if all((Path(directory) / f).is_file() for f in files) else "files"


#: The lock file beside ``summary.csv`` (:func:`~limbstiff.files.atomic.locked`): held while the
#: table is rebuilt from the folder and written, so that runs into one folder lose no update.
TABLE_LOCK = ".summary.csv.lock"


def _signature(path: Path) -> tuple[int, int, int] | None:
    """What tells one writing of a file from another (its inode, size and modification time), or
    None when it is not there."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_ino, st.st_size, st.st_mtime_ns


@dataclass
class FolderTable:
    """``summary.csv`` of one output folder, rebuilt from the folder each time it is written.

    The trial folders are the record: a trial is in the table as done when its ``marker``
    (``summary.json`` or ``posterior.json``, written last) is there and readable, and never
    otherwise. Besides this run's trials (in input order; a failed one keeps the row of its
    earlier complete outputs when they are still there), the table holds every other complete
    trial folder, by name: earlier runs', and those of runs writing into the folder at the same
    time. Each writing reads the folder and writes the table under :data:`TABLE_LOCK`.

    Parameters
    ----------
    out : Path
        The output folder.
    marker : str
        The file a complete trial folder holds.
    names : sequence of str
        This run's trials, in input order.
    lost : sequence of TrialOutcome
        Failed rows of this run that are no trial (paths that matched nothing).
    """

    out: Path
    marker: str
    names: Sequence[str]
    lost: Sequence[TrialOutcome] = ()
    _started: dict = field(default_factory=dict, repr=False)
    _read: dict = field(default_factory=dict, repr=False)

    def __post_init__(self):
        # which of this run's trials had complete outputs when it began, and which writing of them
        self._started = {n: _signature(self.out / n / self.marker) for n in self.names}

    def write(self, finished: Mapping[str, TrialOutcome[TrialRow]], *,
              then: Callable[[list[TrialOutcome[TrialRow]]], Any] | None = None) -> tuple[list, Any]:
        """Rebuild the table from the folder and ``finished`` (this run's outcomes so far, by
        trial) and write it atomically, under the folder's lock; ``then(rows)``, if given, runs
        under the same lock (the overview). Returns the rows and what ``then`` returned."""
        from ..files.atomic import locked

        with locked(self.out / TABLE_LOCK):
            rows = self.rows(finished)
            write_summary_csv(self.out / SUMMARY_CSV, rows)
            return rows, (then(rows) if then is not None else None)

    def rows(self, finished: Mapping[str, TrialOutcome[TrialRow]]) -> list[TrialOutcome[TrialRow]]:
        """The table's rows: this run's finished trials, its lost paths, then the other complete
        trial folders by name (``resumed`` unless this run wrote them)."""
        disk = self._complete()
        current = []
        for name in self.names:
            o = finished.get(name)
            if o is not None:
                # the table never says less than what is on disk: a failed trial's earlier outputs
                current.append(disk[name] if o.status != "ok" and name in disk else o)
        kept = [dataclasses.replace(o, resumed=False, row=dataclasses.replace(o.row, resumed=False))
                if o.trial in self._started and self._started[o.trial] != _signature(self.out / o.trial / self.marker)
                else o for name, o in disk.items() if name not in finished]
        return current + list(self.lost) + kept

    def _complete(self) -> dict[str, TrialOutcome[TrialRow]]:
        """Every complete trial folder's row, by name (a marker read again only when rewritten)."""
        lost = {o.trial for o in self.lost}
        rows = {}
        for path in sorted(self.out.glob(f"*/{self.marker}")):
            name, sig = path.parent.name, _signature(path)
            if name in lost or sig is None:
                continue
            if self._read.get(name, (None,))[0] != sig:
                self._read[name] = (sig, _folder_row(path))
            if self._read[name][1] is not None:
                rows[name] = self._read[name][1]
        return rows


def read_marker(path: Path) -> dict | None:
    """A trial folder's ``summary.json`` or ``posterior.json`` (written last: there only when the
    folder is complete), or None when it is missing or not a JSON object."""
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return summary if isinstance(summary, dict) else None


def _folder_row(path: Path) -> TrialOutcome[TrialRow] | None:
    """The row of a complete trial folder, read back from its marker ``path`` (``resumed``: a run
    that reads it did not make it), or None when it cannot be read."""
    summary = read_marker(path)
    if summary is None:
        return None
    return TrialOutcome(path.parent.name, str(summary.get("source", "")), "ok", "",
                        TrialRow.from_summary(summary, resumed=True), resumed=True)


def mixed_kinds(outcomes: Iterable[TrialOutcome[TrialRow]]) -> str | None:
    """A one-line warning when the table holds trials of both kinds (their figures are in N·m/rad
    and N/m: not to be averaged together), else None."""
    outcomes = list(outcomes)
    kinds: dict[str, list[str]] = {}
    for o in outcomes:
        if o.row is not None and o.row.kind:
            kinds.setdefault(o.row.kind, []).append(o.trial)
    if len(kinds) < 2:
        return None
    parts = []
    for kind, trials in sorted(kinds.items()):
        unit = next((o.row.units.get("stiffness") for o in outcomes if o.trial in trials and o.row is not None
                     and o.row.units.get("stiffness")), "")
        shown = ", ".join(trials[:3]) + (f" and {len(trials) - 3} more" if len(trials) > 3 else "")
        parts.append(f"{len(trials)} {kind} ({shown}{'; ' + unit if unit else ''})")
    return ("the batch mixes kinds of trial: " + " and ".join(parts)
            + "; their figures are in different units, do not average them (summary.csv: kind, stiffness_unit)")
