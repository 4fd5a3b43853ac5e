"""What a batch run returns: :class:`BatchReport`, with the result protocol of the package.

``to_dict()`` (JSON-ready), ``to_frame()`` (the ``summary.csv`` table of the run's trials),
``plot(ax=…)`` (each trial's median stiffness with its interval,
:func:`limbstiff.report.axes_batch.plot_trials`) and ``report()`` (how the run went, in words).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .runner import TrialOutcome
from .table import TrialRow, summary_row, summary_table


@dataclass(frozen=True)
class BatchReport:
    """Outcome of a batch run.

    Parameters
    ----------
    outcomes : tuple of TrialOutcome of TrialRow
        One per trial, in input order.
    out : Path
        Output folder.
    notes : tuple of str
        Run-level remarks (stem collisions…).
    missing : tuple of str
        One line per path that matched nothing, with why (also a failed row of ``summary.csv``).
    warnings : tuple of str
        Run-level warnings (a table mixing rotational and translational trials).
    """

    outcomes: tuple[TrialOutcome[TrialRow], ...]
    out: Path
    notes: tuple[str, ...] = ()
    missing: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()

    @property
    def n_failed(self) -> int:
        return sum(o.status != "ok" for o in self.outcomes)

    @property
    def exit_status(self) -> int:
        """0 when every trial is done, 1 when some failed (docs/interface.md section 2)."""
        return 1 if self.n_failed else 0

    @property
    def tally(self) -> str:
        """How many trials are done, of how many, and where (what ``limbstiff analyze`` prints last)."""
        n = len(self.outcomes)
        resumed = sum(getattr(o, "resumed", False) for o in self.outcomes)
        skipped = f" ({resumed} up to date, skipped; --overwrite to redo)" if resumed else ""
        return f"{n - self.n_failed} of {n} trials done{skipped}; outputs in {self.out}"

    def to_dict(self) -> dict:
        """JSON-ready: the output folder, the exit status, each trial's ``summary.csv`` row (None
        a blank cell), the notes, paths that matched nothing and warnings."""
        from ..files.outputs import jsonable
        return jsonable({"out": str(self.out), "exit_status": self.exit_status, "n_failed": self.n_failed,
                         "trials": [summary_row(o) for o in self.outcomes], "notes": list(self.notes),
                         "missing": list(self.missing), "warnings": list(self.warnings)})

    def to_frame(self):
        """The ``summary.csv`` table of this run's trials as a :class:`pandas.DataFrame`: its
        columns (:data:`~limbstiff.batch.table.SUMMARY_COLUMNS`, then ``meta.<key>``), one row per
        outcome (``summary.csv`` on disk may keep rows of an earlier run's trials too)."""
        import pandas as pd
        return pd.DataFrame(summary_table(self.outcomes))

    def plot(self, ax=None):
        """Draw each trial's median stiffness with its interval, a row per trial (nothing for a
        failed one), into a matplotlib axes (:func:`limbstiff.report.axes_batch.plot_trials`).

        Returns
        -------
        matplotlib.axes.Axes
        """
        from ..report.axes_batch import plot_trials
        rows = [o.row or TrialRow() for o in self.outcomes]
        units = sorted({r.units.get("stiffness") for r in rows} - {None})
        nan = float("nan")
        values = [[nan if v is None else v for v in (r.stiffness.median, r.stiffness.lo, r.stiffness.hi)]
                  for r in rows]
        median, lo, hi = zip(*values) if values else ((), (), ())
        return plot_trials([o.trial for o in self.outcomes], median, lo, hi, ax=ax,
                           label=f"median stiffness ({' or '.join(units) or 'SI'})")

    def report(self) -> str:
        """How the run went, in words: the tally, each failed trial with why, the paths that
        matched nothing, warnings and notes."""
        lines = [self.tally + "."]
        lines += [f"{o.trial} failed: {o.error}" for o in self.outcomes if o.status != "ok"]
        lines += [f"warning: {w}" for w in self.warnings] + [f"note: {n}" for n in self.notes]
        return "\n".join(lines)
