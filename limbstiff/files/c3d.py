"""Reading C3D files (motion labs' format) through the optional ``ezc3d`` extra.

A protocol's ``[columns]`` names the channels: ``header`` is the channel's label, an analog
channel (``Torque``, a dynamometer's ``Angle``) or a point channel with its ``component``
(``x``, ``y`` or ``z``; model outputs such as ``LAnkleAngles`` or ``LAnkleMoment``). Units come
from the protocol's ``unit`` or, when it has none, from the file (``ANALOG:UNITS`` for analog
channels; ``POINT:ANGLE_UNITS`` or ``POINT:FORCE_UNITS`` for the labels the file lists as angles
or forces, else ``POINT:UNITS``), and must be one of the quantity's (a torque in ``mm`` is an
error). Model moments and powers need the protocol's ``unit``: they are often normalised by body
mass whatever ``POINT:MOMENT_UNITS`` says. Time is built from the
channels' rate (analog or point) and the file's first frame. All mapped channels must be analog
or all points: mixing rates would mean resampling one of them, which the file's owner should
decide. ``SUBJECTS:NAMES`` becomes the metadata's ``subject``.

ezc3d reads the file itself (it needs a path); the bytes read before are hashed for the trial's
``source_sha256``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import TrialError
from ..trial import Trial
from .column_units import check_unit, in_si, joint_kind, schedule_unit, units_written
from .columns import READ_FIELDS, ColumnSpec
from ..units import FIELD_DIMENSIONS, UNITS, free_unit_clash
from .validate import checked_trial

INSTALL_HINT = "pip install 'limbstiff[c3d]'"
COMPONENTS = {"x": 0, "y": 1, "z": 2}
#: POINT parameters listing labels of a kind, and the parameter giving that kind's unit.
POINT_KINDS = (("ANGLES", "ANGLE_UNITS"), ("MOMENTS", "MOMENT_UNITS"), ("FORCES", "FORCE_UNITS"),
               ("POWERS", "POWER_UNITS"))


def read_c3d(path: Path, raw: bytes, protocol=None, *, name: str | None = None) -> Trial:
    """Read one C3D trial into a checked Trial.

    Parameters
    ----------
    path : Path
    raw : bytes
        The file's content (hashed; ezc3d reads the path).
    protocol : Protocol
        ``columns`` must name at least the angle and a torque channel (``header``: label;
        ``component`` for point channels; ``unit`` when the file's is absent or wrong).
    name : str or None

    Raises
    ------
    TrialError
        One line naming the file: the extra missing, an unreadable file, no protocol, a label
        not in the file, a point channel without (or with a wrong) component, a unit unknown,
        analog and point channels mixed.
    """
    where = str(path)
    try:
        import ezc3d
    except ImportError:
        raise TrialError(where, f"reading C3D files needs the optional extra: {INSTALL_HINT}") from None
    columns = _mapped_columns(where, protocol)
    try:
        c3d = ezc3d.c3d(str(path))
    except Exception as exc:  # noqa: BLE001 - ezc3d raises plain RuntimeErrors on bad files
        raise TrialError(where, f"not a readable C3D file ({' '.join(str(exc).split())})") from None
    channels = {field: _channel(where, c3d, column, free=field == "schedule")
                for field, column in columns.items() if field != "time"}
    kind = _one_kind(where, channels)
    rate = float(c3d["header"]["analogs" if kind == "analog" else "points"]["frame_rate"])
    first = int(c3d["header"]["points"]["first_frame"])
    values: dict[str, np.ndarray | None] = dict.fromkeys(READ_FIELDS)
    values["time"] = _time(where, c3d, channels, columns, kind=kind, rate=rate, first=first)
    specs = {}
    for k, (field, (_, data, unit)) in enumerate(channels.items()):
        specs[field] = _spec(where, field, columns[field], k, unit)
        values[field] = in_si(data, specs[field])
    joint = joint_kind(where, specs, noun="channel")
    metadata = _metadata(c3d, columns, kind=kind, rate=rate, first=first)
    return checked_trial(path, raw, values, kind=joint,
                         protocol=protocol, name=name, metadata=metadata, warnings=[],
                         locate=lambda k: f"{kind} frame {k + 1}", schedule_unit=schedule_unit(specs),
                         units=units_written(specs))


def _mapped_columns(where: str, protocol) -> dict:
    """The protocol's columns that name a channel; an error when the angle or a torque is not
    among them, or when the protocol asks for a cycle marker (not read from C3D files)."""
    columns = {} if protocol is None else {f: c for f, c in protocol.columns.items() if c.header}
    if getattr(getattr(protocol, "cycles", None), "marker", None) is not None:
        raise TrialError(where, "a cycle marker ([cycles] marker) is not read from C3D files: give the cycles' "
                                "length instead ([cycles] period_s), or export the trial as CSV with its trigger column")
    if "angle" not in columns or not ({"torque", "elastic_torque"} & set(columns)):
        raise TrialError(where, "a C3D file is read through a protocol whose [columns] name the angle and torque "
                                "channels, e.g. angle = { header = \"LAnkleAngles\", component = \"x\" }")
    return columns


def _one_kind(where: str, channels: dict) -> str:
    """``analog`` or ``point``: the kind all mapped channels share (an error when they mix)."""
    kinds = {kind for kind, _, _ in channels.values()}
    if len(kinds) > 1:
        listing = ", ".join(f"{f}: {kind}" for f, (kind, _, _) in channels.items())
        raise TrialError(where, f"the protocol maps analog and point channels ({listing}); they have different "
                                "rates: map all quantities to analog channels or all to point channels")
    return kinds.pop()


def _time(where: str, c3d, channels: dict, columns: dict, *, kind: str, rate: float, first: int) -> np.ndarray:
    """The time base, s, shape (n,): from the file's first frame at the channels' ``rate`` (Hz); an
    error when a channel has another number of frames or a gap (a non-finite value)."""
    n = next(iter(channels.values()))[1].size
    start = first / float(c3d["header"]["points"]["frame_rate"])
    time = start + np.arange(n) / rate
    for field, (_, data, _) in channels.items():
        if data.size != n:
            raise TrialError(where, f"channel '{columns[field].header}' has {data.size} frames, the others {n}")
        bad = np.flatnonzero(~np.isfinite(data))
        if bad.size:
            raise TrialError(where, f"channel '{columns[field].header}' has no value at {kind} frame {bad[0] + 1} "
                                    f"(t = {time[bad[0]]:g} s; an occluded marker or a gap in the model "
                                    "output): fill or cut the gap before analysing")
    return time


def _spec(where: str, field: str, column, k: int, unit: str) -> ColumnSpec:
    """The channel of ``field`` as a :class:`ColumnSpec`, its unit checked against the quantity's."""
    if field == "schedule":
        _schedule_unit(where, column.header, unit)
    else:
        check_unit(where, "channel", column.header, unit, field.replace("_", " "), FIELD_DIMENSIONS[field])
    return ColumnSpec(field, column.header, k, unit, column.scale)


def _schedule_unit(where: str, label: str, unit: str) -> None:
    """Error if the scheduling variable's unit is one the table knows by another case (``Deg``)."""
    clash = free_unit_clash(unit)
    if clash:
        raise TrialError(where, f"channel '{label}': unit '{unit}' of the scheduling variable is not in the unit "
                                f"table, '{clash}' is: give unit = \"{clash}\" in [columns.schedule]")


def _strings(c3d, group: str, name: str) -> list[str]:
    """A parameter's values as stripped strings (empty when the file lacks it)."""
    return [str(x).strip() for x in _parameter(c3d, group, name) or []]


def _parameter(c3d, group: str, name: str):
    try:
        return c3d["parameters"][group][name]["value"]
    except KeyError:
        return None


def _channel(where: str, c3d, column, free: bool = False) -> tuple[str, np.ndarray, str]:
    """(``analog`` or ``point``, values in the file's or the protocol's unit, that unit) of one
    mapped channel; ``free``: the file's unit may be one the table does not know (the scheduling
    variable's ``V``, ``%MVC``), kept unconverted."""
    label = column.header.strip()
    analog, points = _strings(c3d, "ANALOG", "LABELS"), _strings(c3d, "POINT", "LABELS")
    if label in analog:
        if column.component is not None:
            raise TrialError(where, f"'{label}' is an analog channel: it has no component (remove component)")
        k = analog.index(label)
        data = np.asarray(c3d["data"]["analogs"][0, k, :], dtype=float)
        units = _strings(c3d, "ANALOG", "UNITS")
        return "analog", data, _unit(where, label, column.unit, units[k] if k < len(units) else "", free)
    if label in points:
        if column.component is None:
            raise TrialError(where, f"'{label}' is a point channel with components x, y, z: give component = "
                                    f"\"x\", \"y\" or \"z\" in its [columns] entry")
        k = points.index(label)
        data = np.asarray(c3d["data"]["points"][COMPONENTS[column.component], k, :], dtype=float)
        if not column.unit and _listed(c3d, label, ("MOMENTS", "POWERS")):
            raise TrialError(where, f"'{label}' is a model output whose unit the file cannot settle (moments are "
                                    "often normalised by body mass, N·mm/kg, whatever POINT:MOMENT_UNITS says): give "
                                    "unit = \"Nmm\" (and scale = the body mass in kg if normalised) in its [columns] "
                                    "entry")
        return "point", data, _unit(where, label, column.unit, _point_unit(c3d, label), free)
    known = ", ".join(analog + points) or "none"
    raise TrialError(where, f"no channel labelled '{label}' (analog and point labels: {_shorten(known)}); "
                            "check the header of this quantity in the protocol's [columns]")


def _listed(c3d, label: str, listings: tuple[str, ...]) -> bool:
    """Whether the file lists ``label`` under one of the POINT parameters ``listings``."""
    return any(label in _strings(c3d, "POINT", name) for name in listings)


def _point_unit(c3d, label: str) -> str:
    """The file's unit of a point channel: that of its kind (angles, moments…) or POINT:UNITS."""
    unit = next((unit for listing, unit in POINT_KINDS if _listed(c3d, label, (listing,))), "UNITS")
    return (_strings(c3d, "POINT", unit) or [""])[0]


def _unit(where: str, label: str, given: str | None, in_file: str, free: bool = False) -> str:
    """The protocol's unit, else the file's (known to limbstiff, or any with ``free``), else a
    one-line error."""
    if given:
        return given
    if in_file in UNITS or (free and in_file.strip()):
        return in_file.strip() if free else in_file
    said = f"unit '{in_file}'" if in_file else "no unit"
    raise TrialError(where, f"channel '{label}' has {said} in the file: give its unit in the protocol's [columns] "
                            f"entry (unit = \"deg\", \"Nm\", …)")


def _metadata(c3d, columns, *, kind: str, rate: float, first: int) -> dict[str, str]:
    meta = {}
    subjects = _parameter(c3d, "SUBJECTS", "NAMES")
    if subjects:
        meta["subject"] = ", ".join(str(s).strip() for s in subjects if str(s).strip())
    meta["c3d_channels"] = kind
    meta["c3d_rate_hz"] = f"{rate:g}"
    meta["c3d_first_frame"] = str(first)
    for field, column in columns.items():
        part = f" ({column.component})" if column.component is not None else ""
        meta[f"channel_{field}"] = column.header.strip() + part
    return meta


def _shorten(text: str, limit: int = 160) -> str:
    return text if len(text) <= limit else text[:limit - 1] + "…"
