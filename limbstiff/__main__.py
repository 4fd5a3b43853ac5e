"""``python -m limbstiff``: the same command as ``limbstiff``."""

from limbstiff.cli import main

main(prog_name="limbstiff")
