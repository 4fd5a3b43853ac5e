"""``limbstiff simulate``: write a simulated trial with its true stiffness."""

from __future__ import annotations

import click

from .options import fail, reports_errors, seed_option


def _pairs(values, what):
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
@click.option("--out", "out", type=click.Path(dir_okay=False), default=None,
              help="CSV file to write (default: SCENARIO[-EFFECT].csv).")
@seed_option
@click.option("--effect", default=None, help="Unmodelled effect to add (see --list).")
@click.option("--set", "params", multiple=True, metavar="KEY=VALUE", help="Scenario parameter.")
@click.option("--effect-param", "effect_params", multiple=True, metavar="KEY=VALUE",
              help="Effect parameter.")
@click.option("--list", "list_", is_flag=True, help="List scenarios and effects with their parameters.")
@reports_errors
def command(scenario, out, seed, effect, params, effect_params, list_):
    """Simulate SCENARIO and write it in the input format, with a stiffness_true column."""
    from ..files import write_trial
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
    try:
        trial = simulate(scenario, seed=seed, params=_pairs(params, "--set"), effect=effect,
                         effect_params=_pairs(effect_params, "--effect-param"))
    except ValueError as exc:
        fail(str(exc))
    path = out or f"{trial.name}.csv"
    write_trial(trial, path)
    click.echo(f"{trial.name}: {trial.n_samples} samples at {trial.fs:g} Hz -> {path}", err=True)
