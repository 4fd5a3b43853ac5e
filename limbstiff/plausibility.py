"""Is a trial plausible for the limb it records? Units and ranges checked before any fit.

A lab's commonest mistake is a unit slip: degrees under ``angle_rad``, milliseconds read as
seconds, N·mm read as N·m, encoder counts read as an angle. The fit cannot see it — the model
scales with the data and comes out ``ok`` with a stiffness off by 57 or 1000 — so the sizes of
the signals are checked against what the limb allows, and the finding names the likely unit
and the protocol line that fixes it.

Pure functions over numpy arrays and frozen dataclasses; nothing of the package imported (the
protocol validates its ``limb`` key against :data:`LIMBS`). A :class:`Finding` is ``fatal``
when the value is impossible (the analysis stops with a one-line error) and not fatal when it
is only implausible (the verdict is ``unreliable`` with the finding as its reason).

Where the numbers come from
---------------------------
Inertias about the joint axis, from Winter's anthropometric tables (D. A. Winter,
*Biomechanics and Motor Control of Human Movement*, 4th ed., 2009, Table 4.1: segment mass
fractions, lengths as fractions of height, radii of gyration about the proximal end) for
adults of 40–120 kg and 1.5–2.0 m, widened for what a device attaches (handle, footplate,
splint). Ranges of motion: the normal active ranges of the AAOS (*Joint Motion: Method of
Measuring and Recording*, 1965; Norkin & White, *Measurement of Joint Motion*). Largest
torques: about 1.5× the maximal voluntary torques reported for healthy adults (e.g. knee
extension 250–300 N·m, ankle plantarflexion 150–250 N·m, elbow flexion 70–90 N·m, wrist 10–15
N·m, finger MCP ~5 N·m). Smallest test torque: the joint's smallest passive stiffness
(relaxed) times the smallest motion a stiffness test applies, :data:`SMALLEST_TEST_MOTION`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Mapping

import numpy as np

#: Lowest sample rate that can hold a stiffness test, Hz: perturbations are 0.5–10 Hz and the
#: model needs the angle's second derivative, so a rate below 10 Hz holds no test. Milliseconds
#: read as seconds turn any rate of 10 Hz–10 kHz into 0.01–10 Hz.
MIN_SAMPLE_RATE_HZ = 10.0
#: Highest sample rate of a limb or actuator recording, Hz: their signals carry nothing above
#: ~1 kHz and their acquisition runs at 0.1–10 kHz. Seconds read as milliseconds turn any rate of
#: 50 Hz or more (the paper's bench samples at 66.7 Hz) into 50 kHz or more.
MAX_SAMPLE_RATE_HZ = 5.0e4
#: No joint angle exceeds a full turn (rad): values beyond it are in another unit.
MAX_ANGLE_RAD = 2 * math.pi
#: Smallest motion of a stiffness test, rad: the smallest perturbations in use are about
#: ±0.01 rad (0.57°); a 95 % range below 0.003 rad (0.17°) is about one count of a 2000-count
#: encoder. Radians read as degrees turn the ±0.01–0.1 rad of every test into 0.0003–0.003 rad.
SMALLEST_TEST_MOTION = 0.003
#: Largest motion of a stiffness test, rad (95 % range): perturbations are rarely more than about
#: 1 rad (57°); beyond it the trial is most likely in degrees (±0.02 rad in degrees spans 2.3).
LARGEST_TEST_MOTION = 1.0
#: A protocol's ``expected_inertia`` is widened by this factor each way to bound the inertia when it
#: names no limb: that range is already checked (a miss gives ``caution``: the set-up may differ),
#: while a unit slip moves the inertia by a factor of 57 or 1000; with :data:`INERTIA_MARGIN` a
#: miss by up to 20× stays a ``caution``.
EXPECTED_WIDENING = 10.0
#: A lognormal inertia prior bounds the inertia to its median·exp(±PRIOR_SIGMAS·σ), and at least
#: ±:data:`EXPECTED_WIDENING`, when the protocol names no limb (elbow-lab.toml: 0.006–0.6 kg·m²).
PRIOR_SIGMAS = 3.0
#: A finding's inertia must be this far outside the limb's range to call the units into question
#: (the range already holds every adult and attachment; slips are factors of 57 and 1000).
INERTIA_MARGIN = 1.0


@dataclass(frozen=True)
class Limb:
    """What a joint or an actuator allows.

    Parameters
    ----------
    name : str
    inertia : (float, float), kg·m²
        Range of the inertia about the axis, attachments included.
    span : float, rad
        Largest span of the angle in a trial (the joint's range of motion).
    torque_max : float, N·m
        Largest torque a test can record.
    torque_min_range : float, N·m
        Smallest range (2.5–97.5 %) of the torque of a stiffness test.
    source : str
        Where the numbers come from.
    """

    name: str
    inertia: tuple[float, float]
    span: float
    torque_max: float
    torque_min_range: float
    source: str


_W = "Winter 2009, Table 4.1"
#: The joints and set-ups a protocol's ``limb`` names (see the module's docstring for sources).
LIMBS: Mapping[str, Limb] = MappingProxyType({
    # index finger ~0.03 kg, gyration ~0.04 m about MCP: 5e-5; MCP 0–90° flexion, 45° extension
    "finger": Limb("finger", (5e-6, 1e-3), 2.4, 10.0, 1e-3, f"{_W} scaled to a finger; AAOS ROM"),
    # hand 0.006 M, length 0.108 H, gyration 0.587 L about the wrist: 0.005 at 70 kg; ROM 150°
    "wrist": Limb("wrist", (1e-3, 0.05), 2.7, 30.0, 5e-3, f"{_W}; AAOS ROM; MVC 10–15 N·m"),
    # forearm and hand 0.022 M, gyration 0.827 of the forearm (0.146 H): 0.07 at 70 kg; ROM 150°
    "elbow": Limb("elbow", (0.02, 0.4), 2.7, 150.0, 0.02, f"{_W}; AAOS ROM; MVC 70–90 N·m"),
    # whole arm 0.050 M, gyration 0.645 of its length: 0.5 at 70 kg
    "shoulder": Limb("shoulder", (0.1, 3.0), math.pi, 200.0, 0.05, f"{_W}; AAOS ROM; MVC ~100 N·m"),
    # foot about the ankle 0.01–0.02 (+ footplate); ROM 20° dorsi + 50° plantar
    "ankle": Limb("ankle", (0.005, 0.1), 1.3, 400.0, 0.1, f"{_W}; AAOS ROM; MVC 150–250 N·m"),
    # leg and foot 0.061 M, gyration 0.735 of the leg (0.246 H): 0.4 at 70 kg; ROM 135°
    "knee": Limb("knee", (0.1, 2.0), 2.5, 500.0, 0.2, f"{_W}; AAOS ROM; MVC 250–300 N·m"),
    # whole leg 0.161 M, gyration 0.560 of its length (0.530 H): 3 at 70 kg
    "hip": Limb("hip", (0.5, 8.0), 2.7, 500.0, 0.3, f"{_W}; AAOS ROM; MVC ~300 N·m"),
    # variable-stiffness actuators and links on a bench (the paper's link: 0.05)
    "vsa": Limb("vsa", (1e-5, 0.5), math.pi, 50.0, 1e-3, "Grioli & Bicchi 2010 bench; VSA literature"),
    # any other rotational test bench
    "bench": Limb("bench", (1e-6, 10.0), MAX_ANGLE_RAD, 1000.0, 1e-4, "wide: any bench"),
})

#: What is assumed with no limb named: bounds wide enough for every joint and bench above, that
#: still catch the factor-57 and factor-1000 slips of angle and time. Inertia from a finger's
#: distal phalanx (1e-6) to a whole leg with an exoskeleton about the hip; span π (no joint turns
#: further in a trial); torque up to 500 N·m (1.5× the strongest joint's maximal voluntary torque)
#: and down to 1 mN·m over the trial (the resolution of the finest torque sensors on limbs).
ANY_JOINT = Limb("any joint", (1e-6, 10.0), math.pi, 500.0, 1e-3, "the table's widest bounds")


@dataclass(frozen=True)
class Finding:
    """One implausible value.

    Parameters
    ----------
    name : str
        Which check (``sample_rate``, ``angle_span``, ``angle_range``, ``torque_size``,
        ``torque_range``, ``inertia``).
    fatal : bool
        True: impossible, the analysis stops. False: implausible, the verdict is ``unreliable``.
    message : str
        One line: what was found, the likely unit and the protocol line that fixes it.
    """

    name: str
    fatal: bool
    message: str


def limb_named(name: str | None) -> Limb:
    """The :class:`Limb` of a protocol's ``limb`` key; :data:`ANY_JOINT` for None.

    Raises
    ------
    KeyError
        If the name is not in :data:`LIMBS`.
    """
    return ANY_JOINT if name is None else LIMBS[name]


def limb_of(name: str | None, *, expected_inertia: tuple[float, float] | None = None,
            prior: tuple[float, float] | None = None) -> Limb:
    """The bounds of a protocol: its ``limb``, else :data:`ANY_JOINT` with the inertia bounded by
    its ``expected_inertia`` (widened by :data:`EXPECTED_WIDENING`) or its lognormal prior.

    Parameters
    ----------
    name : str or None
        The protocol's ``limb``.
    expected_inertia : (float, float), optional, kg·m²
    prior : (float, float), optional
        Median (kg·m²) and σ of a lognormal prior on the inertia.

    Returns
    -------
    Limb
    """
    if name is not None:
        return LIMBS[name]
    if expected_inertia is not None:
        lo, hi = expected_inertia
        return replace(ANY_JOINT, name="set-up", inertia=(lo / EXPECTED_WIDENING, hi * EXPECTED_WIDENING))
    if prior is not None:
        median, sigma = prior
        spread = max(math.exp(PRIOR_SIGMAS * sigma), EXPECTED_WIDENING)
        return replace(ANY_JOINT, name="set-up", inertia=(median / spread, median * spread))
    return ANY_JOINT


def _range(values: np.ndarray) -> float:
    return float(np.subtract(*np.percentile(values, [97.5, 2.5])))


def check_time(time: np.ndarray) -> tuple[Finding, ...]:
    """A sample rate no limb recording has: the time column in another unit.

    Parameters
    ----------
    time : ndarray, shape (n,), s
        Uniform sample times (at least two).

    Returns
    -------
    tuple of Finding
    """
    rate = 1.0 / float(np.median(np.diff(time)))
    duration = float(time[-1] - time[0])
    if rate < MIN_SAMPLE_RATE_HZ:
        return (Finding("sample_rate", True,
                        f"the time column gives a sample rate of {rate:.3g} Hz and a trial of {duration:.4g} s: "
                        f"it is probably in milliseconds read as seconds; say so in its header (time_ms) or "
                        f"the protocol: [columns.time] unit = \"ms\""),)
    if rate > MAX_SAMPLE_RATE_HZ:
        return (Finding("sample_rate", True,
                        f"the time column gives a sample rate of {rate:.3g} Hz and a trial of {duration:.3g} s: "
                        f"it is probably in seconds read as milliseconds; say so in its header (time_s) or "
                        f"the protocol: [columns.time] unit = \"s\""),)
    return ()


def check_angle(angle: np.ndarray, *, limb: Limb = ANY_JOINT, written: str | None = None) -> tuple[Finding, ...]:
    """An angle too large or too small for a joint: degrees, radians or encoder counts misread.

    Parameters
    ----------
    angle : ndarray, shape (n,), rad
        The angle as read (in rad if its unit is right).
    limb : Limb
        What the joint allows (:data:`ANY_JOINT` when none is named).
    written : str or None
        The unit the protocol states for the angle, if any: the advice never names it as the fix.

    Returns
    -------
    tuple of Finding
        Fatal when the angle is constant or its span exceeds the joint's range of motion or a full turn.
    """
    span, peak, task = float(np.ptp(angle)), float(np.max(np.abs(angle))), _range(angle)
    if span == 0:
        return (Finding("angle_constant", True, f"the angle is {angle[0]:g} rad throughout: the joint did not move"),)
    counts = bool(np.all(angle == np.round(angle))) and span >= 2
    fix = ("probably encoder counts; convert them in the protocol: [columns.angle] unit = \"rad\" with "
           "scale = 2π/(counts per turn), e.g. 0.001534 for 4096" if counts else
           "not in the degrees written (encoder counts, hundredths of a degree?); convert it with "
           "[columns.angle] scale in the protocol" if _stated(written, "deg") else
           "probably in degrees; say so in its header (angle_deg) or the protocol: [columns.angle] unit = \"deg\"")
    if span > limb.span or peak > MAX_ANGLE_RAD:
        return (Finding("angle_span", True, f"the angle spans {span:.3g} rad and reaches {peak:.3g} rad, more than "
                                            f"{_of(limb)} can turn ({limb.span:.2g} rad): it is {fix}"),)
    if task > LARGEST_TEST_MOTION:
        return (Finding("angle_range", False, f"the angle's range is {task:.3g} rad ({math.degrees(task):.0f}°), "
                                              f"more than a stiffness test moves a joint ({LARGEST_TEST_MOTION:g} "
                                              f"rad): it is {fix}"),)
    if task < SMALLEST_TEST_MOTION:
        return (Finding("angle_range", False, f"the angle's range is only {task:.3g} rad ({math.degrees(task):.3g}°), "
                                              f"less than any stiffness test moves a joint ({SMALLEST_TEST_MOTION:g} "
                                              f"rad): {_small_angle(task, written)}"),)
    return ()


def _stated(written: str | None, unit: str) -> bool:
    """Whether the protocol states ``unit`` (spelt ``Nm``, ``N·m``, ``N m``…)."""
    bare = (written or "").replace("·", "").replace("*", "").replace(" ", "").replace(".", "").lower()
    return {"°": "deg", "degree": "deg", "degrees": "deg", "radian": "rad", "radians": "rad"}.get(bare, bare) == \
        unit.lower()


def _small_angle(task: float, written: str | None) -> str:
    """Why an angle's 95 % range ``task`` (rad) is so small: radians read as degrees only where that
    makes a test's motion and the degrees were not stated; else the joint barely moves."""
    if math.degrees(task) >= SMALLEST_TEST_MOTION and not _stated(written, "rad"):
        return ("it is probably in radians read as degrees; say so in its header (angle_rad) or the protocol: "
                "[columns.angle] unit = \"rad\"")
    return ("the joint barely moves, or the numbers are not radians (micro-radians, a gauge's volts?): "
            "check the angle channel, and convert it with [columns.angle] scale in the protocol")


def check_torque(torque: np.ndarray, *, limb: Limb = ANY_JOINT, written: str | None = None) -> tuple[Finding, ...]:
    """A torque too large or too small for the limb: N·mm and N·m misread; none recorded.

    Parameters
    ----------
    torque : ndarray, shape (n,), N·m
        The torque as read (external or elastic).
    limb : Limb
    written : str or None
        The unit the protocol states for the torque, if any: the advice never names it as the fix.

    Returns
    -------
    tuple of Finding
        Fatal when the torque is constant (none was recorded) or exceeds what the limb can bear.
    """
    peak, task = float(np.max(np.abs(torque))), _range(torque)
    if np.ptp(torque) == 0:
        recorded = "no torque was recorded" if torque[0] == 0 else "no torque was recorded (only an offset)"
        return (Finding("torque_constant", True, f"the torque is {torque[0]:g} N·m throughout: {recorded}; "
                                                 "check the torque channel and its column"),)
    if peak > limb.torque_max:
        why = ("not in the N·mm written (a gauge's raw counts?); convert it with [columns.torque] scale in the "
               "protocol" if _stated(written, "Nmm") else "probably in N·mm read as N·m; say so in its header "
               "(torque_Nmm) or the protocol: [columns.torque] unit = \"Nmm\"")
        return (Finding("torque_size", True, f"the torque reaches {peak:.3g} N·m, more than {_of(limb)} can bear "
                                             f"({limb.torque_max:g} N·m): it is {why}"),)
    if task < limb.torque_min_range:
        slip = 1000 * task >= limb.torque_min_range and not _stated(written, "Nm")
        why = ("probably in N·m read as N·mm (or mN·m); say so in its header (torque_Nm) or the protocol: "
               "[columns.torque] unit = \"Nm\"" if slip else
               "the torque barely changes, or the numbers are not N·m (a gauge's volts?): check the torque "
               "channel, and convert it with [columns.torque] scale in the protocol")
        return (Finding("torque_range", False, f"the torque's range is only {task:.3g} N·m, less than any stiffness "
                                               f"test of {_of(limb)} applies ({limb.torque_min_range:g} N·m): "
                                               f"{'it is ' if slip else ''}{why}"),)
    return ()


def check_recording(time: np.ndarray, angle: np.ndarray, torque: np.ndarray | None, *, rotational: bool = True,
                    limb: Limb = ANY_JOINT, written: Mapping[str, str] | None = None) -> tuple[Finding, ...]:
    """Every check before the fit: time, and for a rotational joint the angle and the torque.

    Parameters
    ----------
    time : ndarray, shape (n,), s
    angle : ndarray, shape (n,), rad (m)
    torque : ndarray, shape (n,), N·m (N), or None
    rotational : bool
        False for a translational spring (position and force): only the time is checked.
    limb : Limb
    written : mapping of str to str, optional
        The units the protocol states, by quantity (``angle``, ``torque``).

    Returns
    -------
    tuple of Finding
        The fatal ones first.
    """
    written = written or {}
    found = list(check_time(time))
    if rotational:
        found += check_angle(angle, limb=limb, written=written.get("angle"))
        if torque is not None:
            found += check_torque(torque, limb=limb, written=written.get("torque"))
    return tuple(sorted(found, key=lambda f: not f.fatal))


def check_inertia(inertia: float, *, limb: Limb = ANY_JOINT,
                  written: Mapping[str, str] | None = None) -> Finding | None:
    """An identified inertia far outside what the limb allows: a unit of torque or angle misread.

    Parameters
    ----------
    inertia : float, kg·m²
    limb : Limb
    written : mapping of str to str, optional
        The units the torque and the angle were written in: a cause naming one is left out.

    Returns
    -------
    Finding or None
        Not fatal: the verdict is ``unreliable``.
    """
    lo, hi = limb.inertia
    if lo / (1 + INERTIA_MARGIN) <= inertia <= hi * (1 + INERTIA_MARGIN):
        return None
    written = written or {}
    causes = ((("torque", "Nmm"), "the torque in N·mm read as N·m ([columns.torque] unit = \"Nmm\")"),
              (("angle", "rad"), "the angle in radians read as degrees ([columns.angle] unit = \"rad\")"))
    if inertia < lo:
        causes = ((("torque", "Nm"), "the torque in N·m read as N·mm ([columns.torque] unit = \"Nm\")"),
                  (("angle", "deg"), "the angle in degrees read as radians ([columns.angle] unit = \"deg\")"))
    cause = " or ".join(text for (q, unit), text in causes if not _stated(written.get(q), unit)) or \
        "check the scale of the torque and of the angle"
    return Finding("inertia", False, f"the identified inertia {inertia:.3g} kg·m² is far outside {_of(limb)}'s "
                                     f"({lo:g}–{hi:g} kg·m²): a unit is probably wrong, {cause}")


def _of(limb: Limb) -> str:
    if limb.name == ANY_JOINT.name:
        return "a joint"
    return f"a {limb.name}" if limb.name in ("vsa", "bench") else f"the {limb.name}"
