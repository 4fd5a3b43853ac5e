"""A column's unit: checked against its quantity, two statements of it agreeing, the joint kind
the units make, and the values converted to what the Trial holds.

Pure functions, no I/O, shared by every reader (:mod:`limbstiff.files.columns` finds the columns).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import TrialError
from ..units import DIMENSION_KIND, FIELD_DIMENSIONS, FIELDS, UNITS, accepted_units, free_unit_clash, same_unit, \
    schedule_si, to_si

if TYPE_CHECKING:
    from .columns import ColumnSpec


def in_si(values, column: ColumnSpec) -> np.ndarray:
    """A column's values as its Trial field holds them: in SI units times the scale; the
    scheduling variable in a free unit unconverted (times the scale); the marker raw."""
    if column.field == "marker":
        return np.asarray(values, dtype=float)
    if column.field == "schedule":
        return schedule_si(values, column.unit)[0] * column.scale
    return to_si(values, column.unit) * column.scale


def schedule_unit(columns: dict[str, ColumnSpec]) -> str | None:
    """The unit of the trial's ``schedule`` once read (``rad``, ``N·m``, or the free unit), or None."""
    column = columns.get("schedule")
    return None if column is None else schedule_si(np.zeros(0), column.unit)[1]


def units_written(columns: dict[str, ColumnSpec]) -> dict[str, str]:
    """The unit each quantity's column was written in (the Trial's ``units_written``)."""
    return {field: c.unit for field, c in columns.items() if field not in ("schedule", "marker") and c.unit}


def agree(where, noun, header, first, second) -> None:
    """Error if two statements of a column's unit (``(who, unit)``, unit may be None) differ."""
    (who1, unit1), (who2, unit2) = first, second
    if unit1 and unit2 and not same_unit(unit1, unit2):
        raise TrialError(where, f"{noun} '{header}': {who1} says unit '{unit1}', "
                                f"{who2} says '{unit2}'")


def check_field_unit(where, noun, header, unit, field, label) -> None:
    """Error unless ``unit`` suits ``field``: a unit of its dimensions; for the scheduling
    variable any unit of the table or a free one, though not one the table knows by another case."""
    if field != "schedule":
        check_unit(where, noun, header, unit, label, FIELD_DIMENSIONS[field])
        return
    clash = free_unit_clash(unit)
    if clash:
        raise TrialError(where, f"{noun} '{header}': unit '{unit}' of {label} is not in the unit table, "
                                f"'{clash}' is: write '{clash}' (converted to SI), or a unit the table does "
                                "not know (kept as given)")


def check_unit(where, noun, header, unit, label, dimensions, hint=False) -> None:
    """Error unless ``unit`` is a known unit of one of ``dimensions``."""
    accepted = ", ".join(accepted_units(dimensions))
    if unit not in UNITS:
        raise TrialError(where, f"{noun} '{header}': unknown unit '{unit}' for {label} (accepted: {accepted})")
    if UNITS[unit].dimension not in dimensions:
        more = f"; a protocol can map this {noun} to another quantity" if hint else ""
        raise TrialError(where, f"{noun} '{header}': unit '{unit}' is not a unit of {label} "
                                f"(accepted: {accepted}{more})")


def joint_kind(where: str, columns: dict[str, ColumnSpec], noun: str = "column") -> str:
    """``rotational`` or ``translational``, from the units of the columns.

    Raises
    ------
    TrialError
        If rotational and translational units are mixed.
    """
    kinds = {c.header: DIMENSION_KIND[UNITS[c.unit].dimension] for c in columns.values() if c.field in FIELDS}
    rotational = [h for h, k in kinds.items() if k == "rotational"]
    translational = [h for h, k in kinds.items() if k == "translational"]
    if rotational and translational:
        raise TrialError(where, f"mixes rotational and translational {noun}s "
                                f"('{rotational[0]}' and '{translational[0]}')")
    return "rotational" if rotational else "translational"
