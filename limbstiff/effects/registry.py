"""The one registry of unmodelled effects: each effect's simulation and its place in the model, together.

Every effect a real joint or set-up adds to the nominal model f = m·ÿ + b·ẏ + s(y, t) is one
:class:`Effect` of :data:`EFFECTS`, which carries

* its **physics**, written once for both in :mod:`limbstiff.unmodelled` (play, Dahl hysteresis,
  channel delay, Coulomb friction, gravity);
* its **simulation** (:mod:`.simulated`): what it adds to the equation of motion or the record, and
  its default sizes, each a fraction of the scenario's typical scales (``torque``: RMS external
  torque, N·m; ``velocity``: RMS ẏ, rad/s; ``angle``: RMS angle about its mean, rad; ``stiffness``:
  smallest σ, N·m/rad — see :func:`limbstiff.simulate.trial_scales`), so that an effect is clearly
  visible but physiological whatever the joint; sizes are rounded to three significant figures;
* its **model** (:class:`~.kinds.ModelEffect`, shapes and grids in :mod:`.candidates`): the torque
  columns, corrected channel or offset of m or b the analysis (``--effect``) and the diagnosis fit,
  or None for the two effects the nominal model already holds (gravity, a generalized stiffness, and
  sensor drift, a walk of the elastic torque).

The simulator (:mod:`limbstiff.simulate`), the diagnosis (:data:`CANDIDATES`) and the analysis
(:data:`IN_MODEL`) read it; the protocol, which sits below it, keeps the names it accepts in
:data:`limbstiff.protocol.MODEL_EFFECTS`, checked here against :data:`IN_MODEL` at import. A new
effect is one new entry. Pure numpy/scipy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Mapping

from ..protocol import MODEL_EFFECTS
from ..unmodelled import dahl, delay_signal
from .candidates import (ACTIVATION_HZ, REFLEX_DELAYS_S, TIME_DELAYS_S, backlash_angle, friction_grid,
                         friction_torque, geom, hysteresis_low, quadratic_torque, reflex_torque)
from .kinds import ChannelCorrection, MechanicsOffset, ModelEffect, TorqueEffect
from .simulated import (REFERENCE_SCALES, backlash_record, coulomb_term, gravity_term, hysteresis_term,
                        quadratic_term, reflex_term, scale_error, sensor_drift_record, time_delay_record)


@dataclass(frozen=True)
class Effect:
    """One unmodelled effect: how the simulator draws it and how the model holds it.

    Attributes
    ----------
    name : str
    description : str
        The effect as simulated and the reasons for its default sizes, one paragraph.
    kind : {"dynamics", "measurement"}
        What it changes in a simulation: the equation of motion, or the recorded channels.
    sizes : callable (scales) -> dict
        Default parameters for a scenario with the given scales.
    build : callable (params) -> DynamicsTerm or Measurement
        What it adds to a simulation (:mod:`.simulated`).
    scaled : bool
        Whether the defaults depend on the scenario's scales (if not, no nominal run is
        needed to size them).
    model : ModelEffect or None
        How the model holds it (named like the effect); None when the nominal model already does.
    held_by_nominal : str or None
        Why the nominal model already holds it (for an effect without ``model``), one sentence.
    defaults : Mapping[str, float]
        Default parameters for the human elbow (``REFERENCE_SCALES``).
    """

    name: str
    description: str
    kind: str
    sizes: Callable = field(repr=False)
    build: Callable = field(repr=False)
    scaled: bool = True
    model: ModelEffect | None = field(default=None, repr=False)
    held_by_nominal: str | None = None
    defaults: Mapping[str, float] = field(init=False)

    def __post_init__(self):
        if self.model is not None and self.model.name != self.name:
            raise ValueError(f"effect {self.name!r} holds the model of {self.model.name!r}")
        if (self.model is None) == (self.held_by_nominal is None):
            raise ValueError(f"effect {self.name!r}: a model, or why the nominal model holds it (one of them)")
        object.__setattr__(self, "defaults", self.defaults_for(REFERENCE_SCALES))

    def defaults_for(self, scales: Mapping[str, float]) -> dict[str, float]:
        """Default parameters for a scenario with these scales."""
        return {key: float(f"{value:.3g}") for key, value in self.sizes(scales).items()}


def _effect(name: str, kind: str, sizes: Callable, build: Callable, doc: str, *, scaled: bool = True,
            model: type | None = None, held_by_nominal: str | None = None, **how) -> Effect:
    """One entry: ``model`` the :class:`~.kinds.ModelEffect` class and ``how`` its fields (its name is the
    effect's)."""
    return Effect(name=name, description=" ".join(doc.split()), kind=kind, sizes=sizes, build=build,
                  scaled=scaled, model=None if model is None else model(name=name, **how),
                  held_by_nominal=held_by_nominal)


EFFECTS: dict[str, Effect] = {e.name: e for e in (
    _effect("coulomb_friction", "dynamics",
            lambda s: {"friction_torque": 0.1 * s["torque"],
                       "smoothing_velocity": 0.05 * s["velocity"]},
            coulomb_term, """Coulomb friction F_c·tanh(ẏ/v_ε) opposing motion (bearings, cable
            guides, an apparatus's seals). F_c = 10 % of the RMS torque (≈ 5–10 % of the
            torque amplitude); v_ε = 5 % of the RMS velocity, so it acts like a sign
            function except very near reversals.""",
            model=TorqueEffect,
            description="Coulomb friction F_c opposing motion (bearings, seals, cable "
            "guides): F_c·tanh(ẏ/v_ε), or with presliding (LuGre's bristles, Dahl's friction model) F_c·z, "
            "dz/dy = (sgn(ẏ) − z)/y_p, the friction building up over the presliding angle y_p after each "
            "reversal.", amplitudes=("friction_torque",),
            units={"friction_torque": "N·m", "smoothing_velocity": "rad/s", "presliding_angle": "rad"},
            grid=friction_grid,
            grid_reason="v_ε from the velocity noise level (below it the sign of ẏ is unknown) to 0.3×RMS "
            "velocity (above it tanh is nearly linear over the motion: a viscous term); presliding angles "
            "from a tenth of the narrowest hysteresis loop to it (a wider loop is hysteresis)",
            torque=friction_torque),
    _effect("quadratic_damping", "dynamics",
            lambda s: {"coefficient": 0.15 * s["torque"] / s["quartic_velocity"] ** 2},
            quadratic_term, """Quadratic (turbulent/viscoelastic) damping c·ẏ|ẏ|, N·m·s²/rad². c is
            set so that its RMS is 15 % of the RMS torque.""",
            model=TorqueEffect,
            description="Quadratic (turbulent, viscoelastic) damping c·ẏ|ẏ|.",
            amplitudes=("coefficient",), units={"coefficient": "N·m·s²/rad²"}, grid=lambda s: [{}], grid_reason="no shape parameter",
            torque=quadratic_torque),
    _effect("hysteresis", "dynamics",
            lambda s: {"amplitude": 0.1 * s["torque"], "characteristic_angle": 0.2 * s["angle"]},
            hysteresis_term, """Dahl hysteresis: internal torque z with dz/dt = (F·ẏ − |ẏ|·z)/y_c,
            which saturates at ±F within an angle y_c after each reversal (soft-tissue and
            short-range stiffness friction). F = 10 % of the RMS torque, y_c = 20 % of the RMS
            angle: a loop that is clearly open but thin.""",
            model=TorqueEffect,
            description="Dahl hysteresis z with dz/dy = (sgn(ẏ)·F − z)/y_c: a friction "
            "torque that builds up over the angle y_c after each reversal (soft tissue, short-range "
            "stiffness).", amplitudes=("amplitude",), units={"amplitude": "N·m", "characteristic_angle": "rad"},
            grid=lambda s: [{"characteristic_angle": v} for v in geom(hysteresis_low(s), s.angle, 6)],
            grid_reason="y_c from twice the angle resolution (a narrower loop is Coulomb friction) to the RMS "
            "angle (a loop that never saturates acts as a spring)",
            torque=lambda ch, sh: dahl(ch.angle, sh["characteristic_angle"]), lower_limit="coulomb_friction"),
    _effect("backlash", "measurement",
            lambda s: {"width": 0.2 * s["angle"]},
            backlash_record, """Play of total width in the angle measurement (an encoder behind a
            gear or a loose cuff): the recorded angle stays put until the true angle has
            crossed a dead band of ±width/2. Width = 20 % of the RMS angle (0.15° for the
            elbow).""",
            model=ChannelCorrection,
            description="Play of total width w between the joint and the angle sensor (a "
            "gear, a loose cuff): the recorded angle stays put while the joint crosses the dead band.",
            grid=lambda s: [{"width": v} for v in geom(max(2 * s.angle_resolution, 0.01 * s.angle),
                                                        0.5 * s.angle, 20)],
            grid_reason="w from twice the angle resolution or 1 % of the RMS angle (a narrower play is "
            "invisible) to half the RMS angle (a wider one would hold the recorded angle still most of the "
            "time), 20 values: the fit is sharply peaked in w", channel="angle", correct=backlash_angle,
            units={"width": "rad"}),
    _effect("time_delay", "measurement",
            lambda s: {"delay": 0.01},
            time_delay_record, """The recorded torque lags the angle by `delay` s (unmatched
            anti-aliasing filters, a slow torque amplifier, a bus). 10 ms: larger than a
            sample but small against the 40 ms of a reflex.""", scaled=False,
            model=ChannelCorrection,
            description="The torque channel lags the angle channel by d (unmatched "
            "anti-aliasing filters, amplifiers, a bus); d < 0: the angle lags.",
            grid=lambda s: [{"delay": float(d)} for d in TIME_DELAYS_S],
            grid_reason="±50 ms in 1 ms steps: longer lags are a broken set-up, and beyond 20 ms a lag "
            "overlaps the reflex loop", channel="torque", units={"delay": "s"},
            # f_recorded(t) = f(t − d): the torque the joint saw at t is the one recorded at t + d
            correct=lambda ch, x, sh: delay_signal(ch.time, x, -sh["delay"])),
    _effect("reflex", "dynamics",
            lambda s: {"gain": 0.3 * s["torque"] / s["velocity"], "delay": 0.04,
                       "direction": 1.0},
            reflex_term, """Stretch reflex: torque direction·g·[direction·ẏ(t − delay)]₊ that
            resists stretch in one direction only (direction +1 stretches the muscle with
            positive velocity), after the loop delay (default 40 ms, physiological range
            20–80 ms). g = 0.3·RMS torque/RMS velocity, so the half-wave-rectified reflex
            torque is ~15–25 % of the torque, as in the ankle recordings.""",
            model=TorqueEffect,
            description="Stretch reflex: delayed, half-wave rectified velocity feedback "
            "direction·g·[direction·ẏ(t − δ)]₊ resisting stretch in one direction, optionally through "
            "muscle activation dynamics (critically damped second-order low-pass).", amplitudes=("gain",),
            units={"gain": "N·m·s/rad", "delay": "s", "direction": "1 (+1: stretch towards positive angles)",
                   "activation_hz": "Hz (none: no activation dynamics)"},
            grid=lambda s: [{"delay": float(d), "direction": sgn, "activation_hz": fa}
                            for d in REFLEX_DELAYS_S for sgn in (1.0, -1.0) for fa in ACTIVATION_HZ],
            grid_reason="loop delays 20–80 ms (spinal stretch reflexes of human limbs) in 5 ms steps; both "
            "stretch directions; activation dynamics none (torque follows the rectified velocity at once) "
            "or a critically damped low-pass whose impulse response peaks at the twitch contraction time "
            "of human muscles, 30, 60, 90 or 120 ms (fast muscles to soleus): corners 1/(2π·T_c)",
            torque=reflex_torque),
    _effect("gravity", "dynamics",
            lambda s: {"mgl": 0.2 * s["stiffness"], "angle_offset": 0.0},
            gravity_term, """Gravity on an unbalanced segment: −mgl·(sin(y + angle_offset) −
            sin(angle_offset)), the sign of the paper's link (destabilising about the upright
            position; the static weight at the operating point is taken as compensated).
            mgl = 20 % of the smallest stiffness, so the joint stays stable but looks 20 %
            softer.""",
            held_by_nominal="a torque that depends on the angle alone is a generalized stiffness, which the model "
            "holds (its static nonlinear spring and its walking stiffness); it cannot be told from stiffness in these "
            "data"),
    _effect("sensor_drift", "measurement",
            lambda s: {"slope": 0.005 * s["torque"], "random_walk": 0.02 * s["torque"],
                       "knot_interval": 1.0},
            sensor_drift_record, """Torque sensor drift (thermal strain-gauge drift): slope·t plus a
            low-frequency random walk (spline through knots `knot_interval` s apart). Slope
            0.5 %·RMS torque per second and walk intensity 2 %·RMS torque/√s: over 30 s about
            15 % and 10 % of the RMS torque.""",
            held_by_nominal="a slow drift of the torque offset is a walk of the elastic torque, which the model "
            "holds (its torque walk Q_s)"),
    _effect("inertia_error", "dynamics",
            lambda s: {"fraction": 0.2},
            scale_error("inertia_scale"), """The true inertia is the nominal one × (1 +
            fraction) (an unaccounted handle, brace or footplate); the scenario parameters
            and `nominal_inertia` keep the nominal value a user would assume, `true_inertia`
            the real one. No effect on massless scenarios.""", scaled=False,
            model=MechanicsOffset,
            description="The true inertia differs from the nominal one by Δm (a "
            "handle, brace or footplate not accounted for).", amplitudes=("delta_inertia",),
            units={"delta_inertia": "kg·m²", "fraction": "1 (of the nominal inertia)"},
            grid=lambda s: [{}], grid_reason="no shape parameter", parameter="inertia",
            signal="acceleration"),
    _effect("damping_error", "dynamics",
            lambda s: {"fraction": 0.3},
            scale_error("damping_scale"), """The true damping is the nominal one × (1 +
            fraction); `nominal_damping` keeps the value a user would assume, `true_damping`
            the real one. Damping is the least known parameter of a limb, hence 30 %.""",
            scaled=False,
            model=MechanicsOffset,
            description="The true damping differs from the nominal one by Δb.",
            amplitudes=("delta_damping",),
            units={"delta_damping": "N·m·s/rad", "fraction": "1 (of the nominal damping)"}, grid=lambda s: [{}], grid_reason="no shape parameter",
            parameter="damping", signal="velocity"),
)}

#: The candidate effects of the diagnosis: the model of each effect the model can hold, in registry order.
CANDIDATES: dict[str, ModelEffect] = {n: e.model for n, e in EFFECTS.items() if e.model is not None}
#: The effects an analysis can put in its model (``--effect``, ``[mechanics] effects``): the torque effects.
IN_MODEL = tuple(n for n, m in CANDIDATES.items() if isinstance(m, TorqueEffect))
if IN_MODEL != MODEL_EFFECTS:
    raise ImportError(f"limbstiff.protocol.MODEL_EFFECTS {MODEL_EFFECTS} is not the registry's torque effects "
                      f"{IN_MODEL}")
