"""``limbstiff simulate``: write a simulated trial with its true stiffness, or publish it live on LSL."""

from __future__ import annotations

import sys

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
@click.option("--duration", type=click.FloatRange(min=0, min_open=True), default=None, metavar="S",
              help="Keep only the first S seconds of the simulated trial.")
@click.option("--stream", is_flag=True,
              help="Publish the trial on LSL in real time (instead of writing it; besides, with --out). "
                   "Needs pip install 'limbstiff[stream]'.")
@click.option("--stream-name", default="limbstiff-sim", show_default=True, help="LSL stream name.")
@click.option("--stream-type", default="Motion", show_default=True, help="LSL stream type.")
@click.option("--wait-consumer", type=click.FloatRange(min=0), default=10.0, show_default=True, metavar="S",
              help="With --stream: wait up to S seconds for a consumer, then publish anyway.")
@overwrite_option
@reports_errors
def command(scenario: str | None, out: str | None, seed: int, effect: str | None, params: tuple[str, ...],
            effect_params: tuple[str, ...], list_: bool, duration: float | None, stream: bool,
            stream_name: str, stream_type: str, wait_consumer: float, overwrite: bool) -> None:
    """Simulate SCENARIO and write it in the input format, with a stiffness_true column.

    With --stream the trial is published on the Lab Streaming Layer in real time, one channel per
    CSV column but time (the same names: angle_rad, torque_Nm, ..., stiffness_true_Nm_per_rad),
    each sample stamped with this computer's LSL clock; Ctrl-C stops it."""
    from ..files import write_trial
    from ..files.outputs import writable_file
    from ..simulate import EFFECTS, SCENARIOS, simulate

    if list_:
        for title, table in (("scenarios", SCENARIOS), ("effects", EFFECTS)):
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
    if duration is not None:
        trial = _first_seconds(trial, duration, scenario)
    if out is not None or not stream:
        path = writable_file(out or f"{trial.name}.csv", overwrite=overwrite)
        write_trial(trial, path)
        click.echo(f"{trial.name}: {trial.n_samples} samples at {trial.fs:g} Hz -> {path}", err=True)
    if stream:
        _stream(trial, name=stream_name, type=stream_type, wait_consumer=wait_consumer)


def _first_seconds(trial, duration: float, scenario: str):
    """The first ``duration`` s of the trial (round(duration·fs) samples); a one-line error when
    the simulation is shorter."""
    from ..simulate import SCENARIOS

    n = int(round(duration * trial.fs))
    if n > trial.n_samples:
        defaults = getattr(SCENARIOS.get(trial.metadata.get("scenario", scenario)), "defaults", {})
        hint = f"; simulate longer with --set duration={duration:g}" if "duration" in defaults else ""
        fail(f"--duration {duration:g}: scenario '{scenario}' is only {trial.duration:g} s"
             f"{hint}")
    return trial.segment(0, max(n, 2))


def _stream(trial, *, name: str, type: str, wait_consumer: float) -> None:
    """Publish the trial on LSL in real time, with a line on stderr when it starts and ends."""
    from ..files.lsl_outlet import desc_metadata, publish, trial_channels

    values, labels, units = trial_channels(trial)
    fs = trial.fs
    click.echo(f"{trial.name}: publishing {values.shape[0]} samples ({values.shape[0] / fs:g} s at {fs:g} Hz) "
               f"as LSL stream '{name}' of type '{type}' ({', '.join(labels)}), once a consumer connects "
               f"(at most {wait_consumer:g} s); Ctrl-C stops", err=True)
    began = []
    try:
        sent = publish(values, fs=fs, labels=labels, units=units, name=name, type=type,
                       source_id=f"limbstiff-simulate:{name}", wait_consumer_s=wait_consumer,
                       metadata=desc_metadata(trial.metadata),
                       on_start=lambda t0, connected: began.append(connected))
    except KeyboardInterrupt:      # the outlet is closed by publish
        click.echo(f"{trial.name}: stopped (Ctrl-C); LSL stream '{name}' withdrawn", err=True)
        sys.exit(130)
    who = "a consumer connected" if began and began[0] else "no consumer connected"
    click.echo(f"{trial.name}: sent {sent} samples at {fs:g} Hz on LSL stream '{name}' ({who} at the start)",
               err=True)
