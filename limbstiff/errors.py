"""Exceptions that carry a one-line, user-facing message.

Every failure a user can cause (a bad file, a bad protocol, a bad option) is raised as a
:class:`LimbstiffError`; the command line prints ``str(error)`` on one line and exits non-zero,
never a traceback.
"""

from __future__ import annotations


class LimbstiffError(Exception):
    """Base class of the errors limbstiff reports to its users."""


class TrialError(LimbstiffError, ValueError):
    """A trial file that cannot be read or analysed.

    Parameters
    ----------
    source : str
        The file (or trial name) the problem is in.
    problem : str
        What is wrong, in one line.
    """

    def __init__(self, source: str, problem: str):
        self.source = str(source)
        self.problem = problem
        super().__init__(f"{self.source}: {problem}")


class NotATrial(TrialError):
    """A table without any of a trial's columns (no time, angle or torque column, and no header
    that looks like one): a list of subjects or notes kept beside the trials. A batch skips such
    a file found in a folder, with one line, and fails it when it was named."""


class ProtocolError(LimbstiffError, ValueError):
    """A protocol file (or a command-line override) that is not valid."""

    def __init__(self, source: str, problem: str):
        self.source = str(source)
        self.problem = problem
        super().__init__(f"{self.source}: {problem}")


class StreamError(LimbstiffError):
    """A live stream that cannot be found, read or published (``limbstiff stream``).

    Parameters
    ----------
    source : str
        The stream (its name or type) the problem is in.
    problem : str
        What is wrong and what to do, in one line.
    """

    def __init__(self, source: str, problem: str):
        self.source = str(source)
        self.problem = problem
        super().__init__(f"{self.source}: {problem}")
