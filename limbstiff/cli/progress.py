"""Progress of a batch on stderr: a bar that redraws itself on a terminal, plain lines otherwise.

Lab pipelines capture stderr into logs, where a redrawn bar would be noise; there each finished
trial is one line. On a terminal the bar shows trials done, failures and the time left, and
failed trials are still printed as lines of their own above it.
"""

from __future__ import annotations

import shutil
import sys
import time

import click


class Progress:
    """``progress(outcome, done, total)`` callback for :func:`limbstiff.batch.jobs.analyze_files`.

    Parameters
    ----------
    stream : file, optional
        Where to write (stderr by default).
    bar : bool, optional
        Draw a bar; by default when ``stream`` is a terminal.
    """

    def __init__(self, stream=None, *, bar: bool | None = None):
        self.stream = stream or sys.stderr
        self.bar = self.stream.isatty() if bar is None else bar
        self.start = time.monotonic()
        self.failed = 0
        self.drawn = False

    def __call__(self, outcome, done: int, total: int) -> None:
        self.failed += outcome.status == "failed"
        if not self.bar:
            click.echo(f"[{done}/{total}] {outcome.trial}: {_mark(outcome)}", file=self.stream)
            return
        if outcome.status == "failed":
            self._clear()
            click.echo(f"{outcome.trial}: FAILED: {outcome.error}", file=self.stream)
        self._draw(done, total)
        if done == total:
            click.echo("", file=self.stream)
            self.drawn = False

    def _clear(self) -> None:
        if self.drawn:
            click.echo("\r\033[K", file=self.stream, nl=False)

    def _draw(self, done: int, total: int) -> None:
        elapsed = time.monotonic() - self.start
        left = elapsed / done * (total - done)
        tail = f" {done}/{total} trials"
        tail += f", {self.failed} failed" if self.failed else ""
        tail += f", {_clock(elapsed)} elapsed" + (f", ~{_clock(left)} left" if done < total else "")
        width = max(10, min(40, shutil.get_terminal_size((80, 20)).columns - len(tail) - 3))
        full = round(width * done / total)
        click.echo(f"\r[{'#' * full}{'.' * (width - full)}]{tail}\033[K", file=self.stream, nl=False)
        self.drawn = True


def _mark(outcome) -> str:
    if outcome.status == "skipped":
        return "skipped, not a trial"
    if outcome.status != "ok":
        return f"FAILED: {outcome.error}"
    if getattr(outcome, "resumed", False):
        return "up to date; --overwrite to redo"
    verdict, output = getattr(outcome.row, "verdict", None), getattr(outcome.row, "output", None)
    if verdict in (None, "ok"):
        return "ok"
    return f"done, verdict {verdict}" + (f" (why: {output}/summary.json, verdict_reasons)" if output else "")


def _clock(seconds: float) -> str:
    m, s = divmod(int(round(seconds)), 60)
    return f"{m // 60}:{m % 60:02d}:{s:02d}" if m >= 60 else f"{m}:{s:02d}"
