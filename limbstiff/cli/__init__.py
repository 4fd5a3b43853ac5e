"""The ``limbstiff`` command: a click group whose commands are loaded only when called.

Each command lives in its own module (``limbstiff/cli/<command>.py``), parses its options and
calls one library function. Nothing heavy is imported at start, so ``limbstiff --help``
answers at once.
"""

from __future__ import annotations

import importlib

import click

from .. import __version__

COMMANDS = {
    "analyze": "Estimate stiffness of trial files and write the outputs.",
    "identify": "Identify inertia and damping (posterior by emcee) without the stiffness.",
    "simulate": "Write a simulated trial (paper scenarios, human limbs, effects).",
    "calibrate": "Fit an exponential spring to force–displacement pairs (paper Sec. V).",
    "diagnose": "Find where the model misses the data, which unmodelled effect causes it, how far it shrinks.",
    "stream": "Live stiffness of a Lab Streaming Layer stream; the recording analysed at the end.",
}


class LazyGroup(click.Group):
    """A group that imports a command's module only when that command runs or is listed."""

    def list_commands(self, ctx):
        return list(COMMANDS)

    def get_command(self, ctx, name):
        if name not in COMMANDS:
            return None
        return importlib.import_module(f"limbstiff.cli.{name}").command

    def format_commands(self, ctx, formatter):
        with formatter.section("Commands"):
            formatter.write_dl(list(COMMANDS.items()))


@click.group(cls=LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="limbstiff")
def main():
    """Measure joint stiffness from torque and angle recordings (Grioli & Bicchi observer)."""
