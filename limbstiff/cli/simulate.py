"""``limbstiff simulate``: write a simulated trial with its true stiffness."""

from __future__ import annotations

import click

from .options import fail, overwrite_option, reports_errors, seed_option


def _pairs(values: tuple[str, ...], what: str) -> dict[str, float]:
    out = {}
    for text in values:
        key, sep, value = text.partition("=")
        if not sep:
            fail(f"{what} '{text}' must be KEY=VALUE")
        try:
            out[key.strip()] = float(value)
        except ValueError:
            fail(f"{what} '{text}': '{value}' is not a number")
    return out


@click.command("simulate")
@click.argument("scenario", required=False)
@click.option("--out", "out", type=click.Path(), default=None,
              help="CSV file to write (default: SCENARIO[-EFFECT].csv).")
@seed_option
@click.option("--effect", default=None, help="Unmodelled effect to add (see --list).")
@click.option("--set", "params", multiple=True, metavar="KEY=VALUE", help="Scenario parameter.")
@click.option("--effect-param", "effect_params", multiple=True, metavar="KEY=VALUE",
              help="Effect parameter.")
@click.option("--list", "list_", is_flag=True, help="List scenarios and effects with their parameters.")
@overwrite_option
@reports_errors
def command(scenario: str | None, out: str | None, seed: int, effect: str | None, params: tuple[str, ...],
            effect_params: tuple[str, ...], list_: bool, overwrite: bool) -> None:
    """Simulate SCENARIO and write it in the input format, with a stiffness_true column."""
    from ..files import write_trial
    from ..files.outputs import writable_file
    from ..simulate import SIMULATED_EFFECTS, SCENARIOS, simulate

    if list_:
        for title, table in (("scenarios", SCENARIOS), ("effects", SIMULATED_EFFECTS)):
            click.echo(f"{title}:")
            for name, item in table.items():
                click.echo(f"  {name}: {item.description.splitlines()[0]}")
                defaults = ", ".join(f"{k}={v:g}" for k, v in item.defaults.items())
                click.echo(f"      {defaults}")
        return
    if scenario is None:
        fail("give a SCENARIO (see 'limbstiff simulate --list')")
    if out is not None:
        writable_file(out, overwrite=overwrite)      # before simulating
    try:
        trial = simulate(scenario, seed=seed, params=_pairs(params, "--set"), effect=effect,
                         effect_params=_pairs(effect_params, "--effect-param"))
    except ValueError as exc:
        fail(str(exc))
    path = writable_file(out or f"{trial.name}.csv", overwrite=overwrite)
    write_trial(trial, path)
    click.echo(f"{trial.name}: {trial.n_samples} samples at {trial.fs:g} Hz -> {path}", err=True)
