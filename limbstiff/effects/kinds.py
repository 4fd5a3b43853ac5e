"""How a candidate effect enters the nominal model: the kinds of effect, and their removal.

The nominal model is f = m·ÿ + b·ẏ + s(y, t). A candidate effect (the library is
:data:`.registry.CANDIDATES`) is one object of a subclass of :class:`ModelEffect`, which says how it
enters:

* :class:`TorqueEffect` — a torque e = a·φ(y, ẏ, ÿ; shape) on the joint, linear in its
  amplitude a once its shape is fixed; removed by subtracting it from the recorded torque;
* :class:`ChannelCorrection` — a correction of a recorded channel (the torque shifted in time,
  the angle seen through a gear's play), profiled over its one parameter;
* :class:`MechanicsOffset` — an error of the nominal m or b; removed by correcting them.

Each knows its parameters, its grid (from the trials' :class:`Scales`), how to evaluate itself on
a :class:`~.channels.Channels` (:class:`Term`) and how to remove itself from the recorded
channels (:meth:`ModelEffect.remove_from`, :func:`remove`). Pure numpy/scipy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable, ClassVar, Mapping

import numpy as np

from .channels import Channels


@dataclass(frozen=True)
class Scales:
    """Sizes that set the grids, pooled (medians) over the trials diagnosed together.

    Parameters
    ----------
    velocity : float, rad/s
        RMS of ẏ.
    angle : float, rad
        Standard deviation of y.
    velocity_noise : float, rad/s
    angle_resolution : float, rad
    motion_hz : float, Hz
    """

    velocity: float
    angle: float
    velocity_noise: float
    angle_resolution: float
    motion_hz: float

    @classmethod
    def of(cls, channels) -> "Scales":
        def med(f):
            return float(np.median([f(c) for c in channels]))
        return cls(velocity=med(lambda c: np.sqrt(np.mean(c.velocity ** 2))), angle=med(lambda c: np.std(c.angle)),
                   velocity_noise=med(lambda c: c.velocity_noise), angle_resolution=med(lambda c: c.angle_resolution),
                   motion_hz=med(lambda c: c.motion_hz))


@dataclass(frozen=True)
class Term:
    """One effect at one shape, evaluated on one trial (full rate).

    Parameters
    ----------
    regressors : ndarray, shape (p, n), or None
        Torques per unit amplitude, low-passed like the torque (N·m per amplitude unit).
    angle : ndarray, shape (3, n), or None
        Corrected filtered y, ẏ, ÿ.
    torque : ndarray, shape (n,), or None
        Corrected filtered torque.
    """

    regressors: np.ndarray | None = None
    angle: np.ndarray | None = None
    torque: np.ndarray | None = None


@dataclass(frozen=True)
class Correction:
    """The recorded channels with an effect removed, for the stiffness re-estimate.

    ``angle``/``torque``: corrected raw channels (n,), or None when unchanged (what
    :func:`remove` returns); ``inertia``/``damping``: the corrected m (kg·m²) and b (N·m·s/rad).
    """

    angle: np.ndarray | None = None
    torque: np.ndarray | None = None
    inertia: float | None = None
    damping: float | None = None


@dataclass(frozen=True, kw_only=True)
class ModelEffect:
    """A candidate unmodelled effect; its subclass says how it enters the model.

    Attributes
    ----------
    name : str
    description : str
        The physics and the parametrisation, one paragraph.
    grid : callable (Scales) -> list of dict
        Shape parameters to profile over.
    grid_reason : str
        Why the grid spans what it spans.
    amplitudes : tuple of str
        Names (with SI units) of the amplitudes fitted by least squares, one per regressor of
        the model's amplitude vector (none for a channel correction).
    kind : {"dynamics", "measurement", "mechanics"}
    lower_limit : str or None
        The effect this one becomes at the lower edge of its grid (a Dahl loop as narrow as the
        grid resolves is a friction): named instead when it qualifies too.
    units : Mapping of str to str
        Unit of each parameter (rotational joints; read N for N·m and m for rad on a
        translational one); dimensionless ones are "1".
    corrects_channel : bool (class attribute)
        The effect corrects a recorded channel (changes the base model's channels).
    """

    name: str
    description: str
    grid: Callable
    grid_reason: str
    amplitudes: tuple = ()
    kind: str
    units: Mapping = field(default_factory=dict)
    lower_limit: str | None = None

    corrects_channel: ClassVar[bool] = False

    def evaluate(self, ch: Channels, shape: Mapping) -> Term:
        """The effect at ``shape`` on one trial (full rate)."""
        raise NotImplementedError

    def remove_from(self, recorded: Correction, ch: Channels, shape: Mapping, coef: np.ndarray,
                    term: Term) -> Correction:
        """The recorded channels (and m, b) with the fitted effect removed.

        Parameters
        ----------
        recorded : Correction
            Raw angle and torque (n,), m and b, with the effects before this one removed.
        ch : Channels
            The channels the effect was fitted on; ``term`` its evaluation there.
        coef : ndarray, shape (p,)
            Its amplitudes.

        Returns
        -------
        Correction
        """
        if term.regressors is None:
            return recorded
        return replace(recorded, torque=recorded.torque - coef @ term.regressors)

    def params(self, shape: Mapping, coef, mech=None) -> dict:
        """Physical parameters: the shape and the named amplitudes.

        ``mech`` (with ``inertia`` and ``damping``, the nominal m and b) lets an error of m or
        b be stated as a fraction of it.
        """
        out = {k: (None if v is None else float(v)) for k, v in shape.items()}
        coef = np.atleast_1d(np.asarray(coef, float))
        for name, value in zip(self.amplitudes, coef):
            out[name] = float(value)
        return out

    def units_of(self, params: Mapping) -> dict:
        """The unit of each of ``params`` (those of :meth:`params`; nested entries are skipped)."""
        return {k: self.units.get(k, "1") for k, v in params.items() if not isinstance(v, Mapping)}

    def correction(self, ch: Channels, shape: Mapping, coef) -> Correction:
        """Remove the fitted effect from the recorded channels (see :func:`remove`)."""
        return remove(ch, [(self, shape, coef)])


@dataclass(frozen=True, kw_only=True)
class TorqueEffect(ModelEffect):
    """A torque on the joint, amplitude × φ(y, ẏ, ÿ; shape), removed from the recorded torque.

    ``torque`` : callable (Channels, shape) -> φ, shape (n,), per unit amplitude, from the
    filtered signals; passed through :func:`filtered_torque` unless ``smooth``.
    """

    kind: str = "dynamics"
    torque: Callable
    smooth: bool = False

    def evaluate(self, ch: Channels, shape: Mapping) -> Term:
        return Term(regressors=self.columns(ch, [shape]))

    def columns(self, ch: Channels, shapes: list) -> np.ndarray:
        """The torque per unit amplitude at each of ``shapes``, shape (len(shapes), n): the shapes
        filtered together (:func:`filtered_torque` of their stack; each row as it would be alone)."""
        phi = np.vstack([self.torque(ch, shape) for shape in shapes])
        return phi if self.smooth else filtered_torque(ch, phi)


@dataclass(frozen=True, kw_only=True)
class ChannelCorrection(ModelEffect):
    """A correction of one recorded channel, profiled over its shape.

    ``channel`` : ``"angle"`` or ``"torque"``; ``correct`` : callable (Channels, x, shape) -> x,
    the channel x (n,) corrected. The angle's derivatives are recomputed from the corrected
    raw angle; a torque correction is applied to the filtered torque as well as to the raw one,
    so it must commute with the low-pass (a shift in time does).
    """

    kind: str = "measurement"
    channel: str
    correct: Callable
    corrects_channel: ClassVar[bool] = True

    def evaluate(self, ch: Channels, shape: Mapping) -> Term:
        if self.channel == "angle":
            return Term(angle=ch.differentiate(self.correct(ch, ch.raw_angle, shape), 2))
        return Term(torque=self.correct(ch, ch.torque, shape))

    def remove_from(self, recorded: Correction, ch: Channels, shape: Mapping, coef: np.ndarray,
                    term: Term) -> Correction:
        corrected = self.correct(ch, getattr(recorded, self.channel), shape)
        return replace(recorded, **{self.channel: corrected})


@dataclass(frozen=True, kw_only=True)
class MechanicsOffset(ModelEffect):
    """An error Δ of the nominal ``parameter`` (``"inertia"`` or ``"damping"``): torque Δ × the
    filtered ``signal`` (``"acceleration"`` or ``"velocity"``), removed by correcting m or b."""

    kind: str = "mechanics"
    parameter: str
    signal: str

    def evaluate(self, ch: Channels, shape: Mapping) -> Term:
        return Term(regressors=getattr(ch, self.signal)[None])

    def remove_from(self, recorded: Correction, ch: Channels, shape: Mapping, coef: np.ndarray,
                    term: Term) -> Correction:
        return replace(recorded, **{self.parameter: getattr(recorded, self.parameter) + float(coef[0])})

    def params(self, shape: Mapping, coef, mech=None) -> dict:
        out = super().params(shape, coef)
        if mech is not None:
            nominal = getattr(mech, self.parameter)
            out["fraction"] = float(np.atleast_1d(np.asarray(coef, float))[0] / nominal) if nominal > 0 else None
        return out


def filtered_torque(ch: Channels, x: np.ndarray) -> np.ndarray:
    """A torque with sharp features computed from the filtered signals, made comparable with the
    filtered record: ``x`` shape (n,), or (k, n) for k torques at once (one low-pass call; each row
    the same as alone).

    The recorded torque went through the low-pass once, so an effect torque with content above
    the band (a kink at reversals: friction, rectification, hysteresis) must too — but only its
    part that is not a linear function of the filtered y, ẏ, ÿ: those carry the angle's in-band
    noise exactly as the nominal model's own terms do, and filtering them a second time would
    leave (H² − H)·noise, which correlates with the m·ÿ noise of the residual. So
    φ = L + H(φ − L), L its least-squares fit on 1, y, ẏ, ÿ. Smooth torques (gravity, inertia,
    damping) are not filtered again at all: measured on the clean simulated elbow (8000-count
    encoder), a −mgl·sin y term filtered whole "explained" 21 % of the gap with mgl = 270 N·m
    and split as above still 11 %, both by fitting the filtered angle noise; unfiltered, 0 %.
    """
    x = np.asarray(x, float)
    if ch.chain.kind == "paper":
        # a causal chain lags: the filtered signals already carry the prefilter's lag, and a second
        # pass would lag the torque twice (measured on the elbow with a reflex at 66.7 Hz)
        return x
    linear = ch.linear_part(x)
    return linear + ch.lowpass(x - linear)


def remove(ch: Channels, fitted) -> Correction:
    """Remove several fitted effects, in the order given, from the recorded channels.

    Parameters
    ----------
    ch : Channels
    fitted : sequence of (ModelEffect, dict, ndarray)
        ModelEffect, shape and amplitudes; each torque is computed on the channels corrected by the
        effects before it (as they were fitted).

    Returns
    -------
    Correction
        Raw angle and torque with every effect removed (None when unchanged), m and b.
    """
    recorded = Correction(angle=ch.raw_angle, torque=ch.raw_torque, inertia=ch.inertia,
                          damping=ch.damping)
    for effect, shape, coef in fitted:
        term = effect.evaluate(ch, shape)
        recorded = effect.remove_from(recorded, ch, shape, np.atleast_1d(np.asarray(coef, float)),
                                      term)
        ch = ch.with_channels(angle=term.angle, torque=term.torque)
    return replace(recorded, angle=None if recorded.angle is ch.raw_angle else recorded.angle,
                   torque=None if recorded.torque is ch.raw_torque else recorded.torque)
