"""Units of trial columns: the unit table, standard headers, SI conversion.

Pure functions, no I/O. A standard header is ``<quantity>_<unit>`` (``time_ms``,
``angle_deg``, ``stiffness_true_Nm_per_rad``); :func:`parse_standard_header` splits it,
:func:`to_si` converts a column to SI units. Only the units listed in :data:`UNITS` are
accepted: there is no guessing, so a misspelt unit is an error rather than a wrong number.
Which column of a file fills which quantity is decided in :mod:`limbstiff.files.columns`.
"""

from __future__ import annotations

import math
import re
from types import MappingProxyType
from typing import Mapping, NamedTuple

import numpy as np



class Unit(NamedTuple):
    """One accepted unit.

    Parameters
    ----------
    dimension : str
        ``time``, ``angle``, ``length``, ``torque``, ``force``, ``rotational_stiffness`` or
        ``translational_stiffness``.
    factor : float
        Multiply a value in this unit by ``factor`` to get SI units.
    """

    dimension: str
    factor: float


_DEG = math.pi / 180.0

#: Every accepted unit, by the spelling used in headers and protocols (case-sensitive:
#: ``mN`` and ``MN`` differ). The first spelling of each dimension is its SI unit.
UNITS: Mapping[str, Unit] = MappingProxyType({
    # time
    "s": Unit("time", 1.0), "ms": Unit("time", 1e-3), "us": Unit("time", 1e-6),
    "sec": Unit("time", 1.0), "µs": Unit("time", 1e-6), "μs": Unit("time", 1e-6),
    # angle
    "rad": Unit("angle", 1.0), "deg": Unit("angle", _DEG), "degree": Unit("angle", _DEG),
    "degrees": Unit("angle", _DEG), "mrad": Unit("angle", 1e-3), "°": Unit("angle", _DEG),
    # length
    "m": Unit("length", 1.0), "mm": Unit("length", 1e-3), "cm": Unit("length", 1e-2),
    # torque
    "Nm": Unit("torque", 1.0), "N.m": Unit("torque", 1.0), "N·m": Unit("torque", 1.0),
    "N*m": Unit("torque", 1.0), "Nmm": Unit("torque", 1e-3), "N.mm": Unit("torque", 1e-3),
    "N·mm": Unit("torque", 1e-3), "mNm": Unit("torque", 1e-3), "N m": Unit("torque", 1.0),
    "N-m": Unit("torque", 1.0), "mN·m": Unit("torque", 1e-3), "mN.m": Unit("torque", 1e-3),
    "Ncm": Unit("torque", 1e-2), "N·cm": Unit("torque", 1e-2), "N.cm": Unit("torque", 1e-2),
    "kNm": Unit("torque", 1e3),
    # force
    "N": Unit("force", 1.0), "mN": Unit("force", 1e-3), "kN": Unit("force", 1e3),
    # stiffness
    "Nm_per_rad": Unit("rotational_stiffness", 1.0), "Nm/rad": Unit("rotational_stiffness", 1.0),
    "N·m/rad": Unit("rotational_stiffness", 1.0), "N.m/rad": Unit("rotational_stiffness", 1.0),
    "Nm_per_deg": Unit("rotational_stiffness", 1.0 / _DEG),
    "Nm/deg": Unit("rotational_stiffness", 1.0 / _DEG),
    "N_per_m": Unit("translational_stiffness", 1.0), "N/m": Unit("translational_stiffness", 1.0),
    "N_per_mm": Unit("translational_stiffness", 1e3), "N/mm": Unit("translational_stiffness", 1e3),
})

#: Kind of joint implied by a dimension (None: either kind).
DIMENSION_KIND: Mapping[str, str | None] = MappingProxyType({
    "time": None, "angle": "rotational", "length": "translational",
    "torque": "rotational", "force": "translational",
    "rotational_stiffness": "rotational", "translational_stiffness": "translational",
})

#: Trial field each dimension may fill.
FIELD_DIMENSIONS: Mapping[str, tuple[str, ...]] = MappingProxyType({
    "time": ("time",),
    "angle": ("angle", "length"),
    "torque": ("torque", "force"),
    "elastic_torque": ("torque", "force"),
    "stiffness_true": ("rotational_stiffness", "translational_stiffness"),
})


#: Trial fields, in the order they are read and written.
FIELDS = ("time", "angle", "torque", "elastic_torque", "stiffness_true")

#: The SI unit of each dimension, as a trial's ``schedule_unit`` names it.
SI_NAMES: Mapping[str, str] = MappingProxyType({
    "time": "s", "angle": "rad", "length": "m", "torque": "N·m", "force": "N",
    "rotational_stiffness": "N·m/rad", "translational_stiffness": "N/m",
})


class Standard(NamedTuple):
    """What a standard quantity of a header means.

    Parameters
    ----------
    field : str
        :class:`~limbstiff.trial.Trial` field it fills.
    dimensions : tuple of str
        Dimensions its unit may have.
    """

    field: str
    dimensions: tuple[str, ...]


#: Quantities recognised in ``<quantity>_<unit>`` headers without any protocol.
STANDARD_QUANTITIES: Mapping[str, Standard] = MappingProxyType({
    "time": Standard("time", ("time",)),
    "angle": Standard("angle", ("angle",)),
    "torque": Standard("torque", ("torque",)),
    "position": Standard("angle", ("length",)),
    "force": Standard("torque", ("force",)),
    "elastic_torque": Standard("elastic_torque", ("torque",)),
    "elastic_force": Standard("elastic_torque", ("force",)),
    "stiffness_true": Standard("stiffness_true", ("rotational_stiffness", "translational_stiffness")),
    # a scheduling variable: any unit of the table, or a free one (see schedule_si)
    "schedule": Standard("schedule", tuple(SI_NAMES)),
})

# longest first, so that "elastic_torque_Nm" is not read as quantity "elastic"
_BY_LENGTH = sorted(STANDARD_QUANTITIES, key=len, reverse=True)
_BRACKETED = re.compile(r"[(\[]\s*([^()\[\]]+?)\s*[)\]]\s*$")


def accepted_units(dimensions: tuple[str, ...] | str) -> list[str]:
    """Spellings of the units of the given dimension(s), in table order.

    Parameters
    ----------
    dimensions : str or tuple of str
        One or more dimensions (see :class:`Unit`).

    Returns
    -------
    list of str
    """
    if isinstance(dimensions, str):
        dimensions = (dimensions,)
    return [name for name, unit in UNITS.items() if unit.dimension in dimensions]


def parse_standard_header(header: str) -> tuple[str, str] | None:
    """Split a standard header: ``<quantity>_<unit>``, ``<Quantity> (<unit>)`` or
    ``<Quantity> [<unit>]`` (a Windows export's ``Time (s)``, ``Torque [Nm]``).

    The quantity is matched case-insensitively (spaces as ``_``), longest first; the unit is
    returned as written (it is not checked here). Synonyms (``Moment``, ``Displacement``) are
    not standard: a protocol maps them.

    Parameters
    ----------
    header : str
        Column header, for example ``"elastic_torque_Nm"``.

    Returns
    -------
    (quantity, unit) or None
        None when the header does not start with a standard quantity followed by ``_``.
    """
    match = _BRACKETED.search(header.strip())
    if match:           # "Time (s)", "Angle [deg]", "Elastic torque (Nm)"
        name = "_".join(header.strip()[:match.start()].lower().split())
        if name in STANDARD_QUANTITIES:
            return name, match.group(1)
    lowered = header.strip().lower()
    for quantity in _BY_LENGTH:
        prefix = quantity + "_"
        if lowered.startswith(prefix) and len(lowered) > len(prefix):
            return quantity, header.strip()[len(prefix):]
    return None


def unit_in_header(header: str) -> str | None:
    """Find a known unit written in a free-form header.

    Recognises a trailing ``(unit)`` or ``[unit]`` (``"Torque (Nm)"``) and a trailing
    ``_unit`` suffix (``"pos1_deg"``, ``"k_Nm_per_rad"``; the longest known suffix wins).

    Parameters
    ----------
    header : str

    Returns
    -------
    str or None
        The unit spelling, or None if no known unit is found.
    """
    header = header.strip()
    match = _BRACKETED.search(header)
    if match and match.group(1) in UNITS:
        return match.group(1)
    parts = header.split("_")
    for start in range(1, len(parts)):
        candidate = "_".join(parts[start:])
        if candidate in UNITS:
            return candidate
    return None


def split_header(header: str) -> tuple[str, str | None]:
    """A header's name and the known unit written in it: ``"Zeit (ms)"`` → ``("Zeit", "ms")``,
    ``"angle [deg]"`` → ``("angle", "deg")``, ``"torque_Nm"`` → ``("torque", "Nm")``,
    ``"Moment"`` → ``("Moment", None)``.

    The unit is found as :func:`unit_in_header` finds it (a trailing ``(unit)``, ``[unit]`` or
    ``_unit`` of :data:`UNITS`); without one the name is the whole header, stripped.

    Parameters
    ----------
    header : str

    Returns
    -------
    (str, str or None)
    """
    header = header.strip()
    match = _BRACKETED.search(header)
    if match and match.group(1) in UNITS and header[:match.start()].strip():
        return header[:match.start()].strip(), match.group(1)
    parts = header.split("_")
    for start in range(1, len(parts)):
        candidate = "_".join(parts[start:])
        if candidate in UNITS and "_".join(parts[:start]).strip():
            return "_".join(parts[:start]).strip(), candidate
    return header, None


def to_si(values: np.ndarray, unit: str) -> np.ndarray:
    """Convert values from ``unit`` to SI units.

    Parameters
    ----------
    values : array_like, shape (n,)
        Values in ``unit``.
    unit : str
        A key of :data:`UNITS`.

    Returns
    -------
    ndarray, shape (n,), float
        Values in SI units (s, rad, m, N·m, N, N·m/rad, N/m).

    Raises
    ------
    KeyError
        If the unit is not in :data:`UNITS`.
    """
    factor = UNITS[unit].factor
    values = np.asarray(values, dtype=float)
    return values if factor == 1.0 else values * factor


def canonical_unit(unit: str) -> str:
    """The table's first spelling of a unit (``"°"`` → ``"deg"``, ``"N·m"`` → ``"Nm"``).

    Parameters
    ----------
    unit : str
        A key of :data:`UNITS`.

    Returns
    -------
    str
    """
    return next(name for name in UNITS if same_unit(name, unit))


def same_unit(a: str, b: str) -> bool:
    """Whether two unit spellings mean the same unit (``"Nm"`` and ``"N·m"`` do).

    Parameters
    ----------
    a, b : str
        Unit spellings; spellings not in :data:`UNITS` are the same only if identical.

    Returns
    -------
    bool
    """
    if a == b:
        return True
    ua, ub = UNITS.get(a), UNITS.get(b)
    return (ua is not None and ub is not None and ua.dimension == ub.dimension
            and math.isclose(ua.factor, ub.factor, rel_tol=1e-12))


def free_unit_clash(unit: str) -> str | None:
    """The table's spelling of a unit written in another case (``"Deg"`` → ``"deg"``), or None
    when ``unit`` is in the table or is a free unit it does not know at all (``"%MVC"``, ``"V"``).

    A scheduling variable may be in a free unit, kept unconverted; a unit the table knows by
    another case is refused rather than kept unconverted by mistake.
    """
    if unit in UNITS:
        return None
    folded = unit.strip().casefold()
    return next((name for name in UNITS if name.casefold() == folded), None)


def schedule_si(values: np.ndarray, unit: str) -> tuple[np.ndarray, str]:
    """A scheduling variable in SI units and the unit it is then in.

    Parameters
    ----------
    values : array_like, shape (n,)
        Values in ``unit``.
    unit : str
        A key of :data:`UNITS` (converted: ``deg`` → ``rad``, ``mm`` → ``m``, ``Nmm`` → ``N·m``)
        or a free unit the table does not know (``%MVC``, ``V``, ``1``), kept as given.

    Returns
    -------
    values : ndarray, shape (n,), float
    unit : str
        The SI unit (:data:`SI_NAMES`) or the free unit.
    """
    if unit in UNITS:
        return to_si(values, unit), SI_NAMES[UNITS[unit].dimension]
    return np.asarray(values, dtype=float), unit
