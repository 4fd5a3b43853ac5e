"""``limbstiff calibrate``: exponential spring from force–displacement pairs (paper Sec. V)."""

from __future__ import annotations

import click

from .options import fail, overwrite_option, reports_errors


@click.command("calibrate")
@click.argument("pairs", type=click.Path(dir_okay=False))
@click.option("--displacement", "x_col", default=None,
              help="Column of displacement (default: the position_*/angle_* column).")
@click.option("--force", "f_col", default=None,
              help="Column of force (default: the elastic_force_*/force_*/torque_* column).")
@click.option("--out", "out", type=click.Path(), default="calibration.json",
              show_default=True, help="Calibration JSON to write (give it to 'analyze --reference').")
@overwrite_option
@reports_errors
def command(pairs: str, x_col: str | None, f_col: str | None, out: str, overwrite: bool) -> None:
    """Fit f = a·e^(b·x) to the force–displacement PAIRS (CSV) and write the calibration."""
    from ..calibrate import fit_exponential_spring
    from ..files.pairs import read_pairs
    from ..files.outputs import writable_file, write_json

    writable_file(out, overwrite=overwrite)          # before the pairs are even read
    x, f, kind = read_pairs(pairs, displacement=x_col, force=f_col)
    try:
        cal = fit_exponential_spring(x, f, kind=kind)
    except ValueError as exc:
        fail(f"{pairs}: {exc}")
    write_json(out, cal.to_dict())
    click.echo(f"a = {cal.a:.6g}, b = {cal.b:.6g}, error margin {100 * cal.error_margin:.1f} % "
               f"({cal.n_pairs} pairs) -> {out}", err=True)
