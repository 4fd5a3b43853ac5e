"""Simulated trials with known stiffness: the paper's examples, human limbs, unmodelled effects.

>>> from limbstiff.simulate import simulate
>>> trial = simulate("elbow", seed=1, params={"duration": 5}, effect="reflex")

``simulate`` returns a :class:`~limbstiff.trial.Trial` whose ``stiffness_true`` is the
stiffness σ = ∂s/∂y of the elastic element along the true motion; ``simulate_with_truth``
also returns the exact signals (:class:`TrueSignals`: velocity, acceleration, jerk,
generalized damping…).
Every random draw comes from ``numpy.random.default_rng(seed)``.
"""

from __future__ import annotations

import math
from typing import Mapping

import numpy as np

from ..trial import Trial
from ..effects.registry import EFFECTS, Effect
from ..effects.simulated import NO_EFFECT, DynamicsTerm, Measurement
from .plants import run
from .truth import CoupledLimb, TrueSignals
from .scenarios import SCENARIOS, Scenario, check_common, lookup, merge_params

__all__ = ["simulate", "simulate_with_truth", "SCENARIOS", "EFFECTS", "Scenario", "Effect",
           "TrueSignals", "CoupledLimb", "describe_scenarios", "effect_defaults", "trial_scales"]


def _fmt(x: float) -> str:
    return f"{float(x):.12g}"


def _lookup_effect(name: str) -> Effect:
    try:
        return EFFECTS[name]
    except KeyError:
        raise ValueError(f"unknown effect {name!r}; available: " + ", ".join(EFFECTS)) from None


def trial_scales(truth: TrueSignals) -> dict[str, float]:
    """Typical sizes of a (nominal) simulated trial, which set the default effect sizes.

    Returns
    -------
    dict
        ``torque``: sd of the external torque (N·m or N); ``velocity``: RMS velocity (rad/s
        or m/s); ``quartic_velocity``: (mean ẏ⁴)^(1/4), which sizes a torque ∝ ẏ|ẏ|;
        ``angle``: sd of the recorded angle (rad or m; without the ``unrecorded_angle`` of a
        moving operating point); ``stiffness``: smallest positive stiffness (N·m/rad or N/m).
    """
    sigma = truth.stiffness
    positive = sigma[sigma > 0]
    v = truth.velocity
    scales = {
        "torque": float(np.std(truth.external_torque)),
        "velocity": float(np.sqrt(np.mean(v**2))),
        "quartic_velocity": float(np.mean(v**4) ** 0.25),
        "angle": float(np.std(truth.angle - truth.unrecorded_angle)),
        "stiffness": float(positive.min()) if positive.size else 0.0,
    }
    for key, value in scales.items():
        if not value > 0:
            raise ValueError(f"the nominal trial has no {key} to size the effect on; "
                             "give every effect parameter explicitly")
    return scales


def effect_defaults(effect: str, scenario: str, *, seed: int = 0,
                    params: Mapping[str, float] | None = None) -> dict[str, float]:
    """Default parameters of ``effect`` for a scenario (sized on its nominal trial)."""
    eff = _lookup_effect(effect)
    sc = lookup(scenario)
    p = merge_params(f"scenario '{scenario}'", sc.defaults, params)
    setup = sc.build(p, np.random.default_rng(seed))
    return eff.defaults_for(trial_scales(run(setup, NO_EFFECT, p["fs"], p["duration"])))


def simulate_with_truth(scenario: str, *, seed: int = 0,
                        params: Mapping[str, float] | None = None, effect: str | None = None,
                        effect_params: Mapping[str, float] | None = None
                        ) -> tuple[Trial, TrueSignals]:
    """Simulate a scenario; return the trial and the true signals.

    Parameters are those of :func:`simulate`.

    Returns
    -------
    trial : Trial
    truth : TrueSignals
        Noise-free true signals on ``trial.time`` (``unrecorded_angle``: zeros but for
        ``ankle-platform``; ``limb``: the limb's motion and the coupling torque of
        ``ankle-coupled``, whose ``angle`` is the device's).
    """
    sc = lookup(scenario)
    what = f"scenario '{sc.name}'"
    p = merge_params(what, sc.defaults, params)
    check_common(what, p)
    rng = np.random.default_rng(seed)
    setup = sc.build(p, rng)
    eff, ep, built = _effect_for(setup, p, effect, effect_params)
    term = built if isinstance(built, DynamicsTerm) else NO_EFFECT
    truth = run(setup, term, p["fs"], p["duration"])
    if term.delay:
        ep["delay"] = truth.delay
    measurement = built if isinstance(built, Measurement) else None
    angle, channels = _recorded(sc, p, setup, truth, measurement, rng)
    metadata = _metadata(sc, seed, p, eff, ep, setup, term, truth)
    name = sc.name if eff is None else f"{sc.name}-{eff.name}"
    trial = Trial(name=name, time=truth.time, angle=angle, torque=channels["torque"],
                  elastic_torque=channels.get("elastic_torque"),
                  stiffness_true=truth.stiffness, kind=sc.kind, metadata=metadata)
    return trial, truth


def _effect_for(setup, p: Mapping[str, float], effect: str | None,
                effect_params: Mapping[str, float] | None) -> tuple:
    """The effect, its parameters and what it adds to the simulation.

    Parameters the caller did not give are sized on the scenario's nominal trial (run once,
    only when the effect's defaults depend on it).

    Returns
    -------
    eff : Effect or None
    params : dict of str to float
    built : DynamicsTerm, Measurement or None
    """
    if effect is None:
        if effect_params:
            raise ValueError("effect parameters given without an effect")
        return None, {}, None
    eff = _lookup_effect(effect)
    given = merge_params(f"effect '{eff.name}'", eff.defaults, effect_params)
    given = {k: given[k] for k in (effect_params or {})}
    if set(given) >= set(eff.defaults):
        ep = given
    elif not eff.scaled:
        ep = {**eff.defaults, **given}
    else:
        nominal = run(setup, NO_EFFECT, p["fs"], p["duration"])
        ep = {**eff.defaults_for(trial_scales(nominal)), **given}
    return eff, ep, eff.build(ep)


def _recorded(sc: Scenario, p: Mapping[str, float], setup, truth: TrueSignals,
              measurement: Measurement | None, rng: np.random.Generator) -> tuple:
    """What the sensors record of the true signals: angle reference, torque sign, measurement
    effect, torque noise, encoder.

    Returns
    -------
    angle : ndarray, shape (n,), rad (m)
    channels : dict
        ``torque`` and, when the set-up records it, ``elastic_torque``, shape (n,), N·m (N).
    """
    t = truth.time
    angle = truth.angle.copy()
    if setup.unrecorded_angle is not None:
        angle = angle - truth.unrecorded_angle
    channels = {"torque": truth.external_torque.copy()}
    if setup.record_elastic:
        channels["elastic_torque"] = truth.elastic_torque.copy()
    if setup.torque_sign != 1.0:
        channels = {k: setup.torque_sign * x for k, x in channels.items()}
    if measurement is not None:
        angle, channels = measurement.apply(t, angle, channels, rng)
    noise = p["torque_noise"]
    if noise > 0:
        channels = {k: x + rng.normal(0.0, noise, size=x.size) for k, x in channels.items()}
    step = (p.get("position_resolution", 0.0) if sc.kind == "translational"
            else (2.0 * math.pi / p["encoder_counts"] if p.get("encoder_counts", 0) > 0 else 0.0))
    if step > 0:
        angle = np.round(angle / step) * step
    return angle, channels


def simulate(scenario: str, *, seed: int = 0, params: Mapping[str, float] | None = None,
             effect: str | None = None,
             effect_params: Mapping[str, float] | None = None) -> Trial:
    """Simulate a named scenario, optionally with one unmodelled effect.

    Parameters
    ----------
    scenario : str
        A key of ``SCENARIOS`` (see :func:`describe_scenarios`).
    seed : int
        Seed of ``numpy.random.default_rng``, the source of every random draw.
    params : Mapping[str, float], optional
        Overrides of the scenario's defaults (``fs``, ``duration``, ``torque_noise``…).
    effect : str, optional
        A key of :data:`~limbstiff.effects.registry.EFFECTS`.
    effect_params : Mapping[str, float], optional
        Overrides of the effect's defaults, which are sized on the scenario's nominal
        trial (see :func:`effect_defaults`).

    Returns
    -------
    Trial
        Named ``scenario`` or ``scenario-effect``; ``metadata`` records the scenario, seed,
        effect, every parameter used (``param.*``, ``effect.*``) and the true mechanical
        values where constant (``true_inertia``, ``true_damping``).

    Raises
    ------
    ValueError
        Unknown scenario, effect or parameter, or an invalid value (one-line message).
    """
    return simulate_with_truth(scenario, seed=seed, params=params, effect=effect,
                               effect_params=effect_params)[0]


def _metadata(sc, seed, p, eff, ep, setup, term, truth) -> dict[str, str]:
    meta = {"generator": "limbstiff.simulate", "scenario": sc.name, "seed": str(seed),
            "effect": eff.name if eff else "none", "drive":
            "position" if setup.trajectory is not None else "torque"}
    if eff is not None:
        meta["effect_kind"] = eff.kind
    meta.update({f"param.{k}": _fmt(v) for k, v in p.items()})
    meta.update({f"effect.{k}": _fmt(v) for k, v in ep.items()})
    meta.update(setup.metadata)
    m = setup.joint.inertia
    meta["nominal_inertia"] = _fmt(m)
    meta["true_inertia"] = _fmt(m * term.inertia_scale)
    law = setup.metadata.get("damping_law", "linear")
    coefficient = float(setup.metadata.get("damping_coefficient", p.get("damping", 0.0)))
    if law in ("linear", "none"):
        meta["nominal_damping"] = _fmt(coefficient)
        meta["true_damping"] = _fmt(coefficient * term.damping_scale)
    else:
        meta[f"nominal_{law}_damping"] = _fmt(coefficient)
        meta[f"true_{law}_damping"] = _fmt(coefficient * term.damping_scale)
    if truth.internal_step:
        meta["internal_step_s"] = _fmt(truth.internal_step)
    return meta


def describe_scenarios() -> str:
    """Text listing every scenario (name, kind, description, defaults) and effect."""
    lines = ["Scenarios:"]
    for sc in SCENARIOS.values():
        lines.append(f"  {sc.name} ({sc.kind}): {sc.description}")
        lines.append("      " + ", ".join(f"{k}={v:g}" for k, v in sc.defaults.items()))
    lines.append("Effects (defaults shown for the elbow; sized on each scenario's trial):")
    for e in EFFECTS.values():
        lines.append(f"  {e.name} ({e.kind}): "
                     + ", ".join(f"{k}={v:g}" for k, v in e.defaults.items()))
    return "\n".join(lines)
