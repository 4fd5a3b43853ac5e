"""The ``reflex`` check: a delayed torque that follows the velocity, left out of the model.

A stretch reflex adds a torque that follows the joint's velocity some 20–80 ms late. Left out,
least squares and the Kalman model take what they can of it into m and b (a reflex resisting
stretch reads as extra damping, one lagging by a quarter cycle as inertia), and the rest into
the stiffness — with intervals that do not know it. The analysis profiles the library's reflex
over its grid against its own model (:func:`limbstiff.effects.in_model.probe_effect`) and this
check reads the outcome: whether the reflex's amplitude is clearly not zero, and if so how far
the stiffness, m and b would move with it in the model. Pure numpy/scipy: no I/O.
"""

from __future__ import annotations

from dataclasses import dataclass

from scipy import stats

from .verdict import CAUTION, UNRELIABLE, Check

#: False-alarm rate of the amplitude's test over the whole grid of shapes (Bonferroni: each
#: shape is tested at this rate over the number of shapes, two-sided).
FALSE_ALARM_RATE = 0.05
#: A stiffness moved by more than this share is wrong, not uncertain: the error at which the
#: project counts an estimate wrong (benchmarks/checks.py, WRONG).
WRONG_SHIFT = 0.2
#: m or b moved by more than this share (and outside its interval) is a material change: the
#: accuracy asked of identified m and b (issue 34). Their intervals alone are too narrow a yardstick
#: on long recordings: on the real ankle z_df3 a 3.6 % change of b lies outside its interval.
MECHANICS_SHIFT = 0.1


@dataclass(frozen=True)
class MechanicsMove:
    """m or b with the effect in the model.

    Parameters
    ----------
    name : {"inertia", "damping"}
    before, after : float
        Without and with it, kg·m² or N·m·s/rad.
    outside : bool
        ``after`` lies outside the interval of ``before``.
    """

    name: str
    before: float
    after: float
    outside: bool

    @property
    def material(self) -> bool:
        """Outside the interval and by more than :data:`MECHANICS_SHIFT`."""
        return self.outside and abs(self.after - self.before) > MECHANICS_SHIFT * abs(self.before)

    def words(self) -> str:
        return f"{self.name} {self.after:.3g} instead of {self.before:.3g}"


def amplitude_threshold(shapes_tried: int) -> float:
    """The |z| an amplitude must exceed, over ``shapes_tried`` shapes (:data:`FALSE_ALARM_RATE`)."""
    return float(stats.norm.isf(FALSE_ALARM_RATE / (2 * max(shapes_tried, 1))))


@dataclass(frozen=True)
class ReflexShift:
    """What a reflex in the model would change.

    Parameters
    ----------
    amplitude_z : float
        Its amplitude over its (sandwich) standard error.
    shapes_tried : int
        Shapes of the grid it was chosen from.
    stiffness : float
        Relative change of the median stiffness with it in the model.
    band : float
        Half-width of the stiffness's band at the median, relative to it.
    mechanics : tuple of MechanicsMove
        m and b with it in the model (none when they are given).
    description : str
        The reflex found (delay, direction, gain), in words.
    """

    amplitude_z: float
    shapes_tried: int
    stiffness: float
    band: float
    mechanics: tuple[MechanicsMove, ...]
    description: str


def reflex_check(shift: ReflexShift | None) -> Check | None:
    """Fails (``caution``) when a reflex is clearly in the torque and would move the stiffness by
    more than its band's half-width, or m or b materially (:attr:`MechanicsMove.material`);
    ``unreliable`` when it would move the stiffness by more than :data:`WRONG_SHIFT`. None when
    no probe was run."""
    if shift is None:
        return None
    threshold = amplitude_threshold(shift.shapes_tried)
    value = abs(shift.stiffness)
    if not abs(shift.amplitude_z) > threshold:
        return Check("reflex", value, shift.band, True,
                     "no delayed torque that follows the velocity (a stretch reflex) stands out of the noise "
                     f"(amplitude {abs(shift.amplitude_z):.1f} standard errors, {threshold:.1f} needed)")
    moved = [m for m in shift.mechanics if m.material]
    moves = value > shift.band or bool(moved)
    limits = [f"the median stiffness would change by {100 * shift.stiffness:+.1f} %"] + [m.words() for m in moved]
    message = (f"a delayed torque that follows the velocity (a stretch reflex? {shift.description}) is in the "
               f"torque and the model leaves it out: with it in the model {', '.join(limits)}. If the joint has "
               "a stretch reflex, analyse again with "
               "--effect reflex (or [mechanics] effects = [\"reflex\"] in the protocol); on a device, friction "
               "that follows the velocity does this too (limbstiff diagnose tells them apart)")
    if not moves:
        return Check("reflex", value, shift.band, True,
                     f"a delayed torque that follows the velocity ({shift.description}) is in the torque, but it moves "
                     "neither the stiffness beyond its band nor m and b beyond their intervals")
    return Check("reflex", value, shift.band, False, message, UNRELIABLE if value > WRONG_SHIFT else CAUTION)
