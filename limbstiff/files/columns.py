"""Which column (or variable) of a trial file fills which Trial field, and in which unit.

Pure functions, no I/O, shared by every reader: the delimited-text reader passes its header
row (and its unit row, if any), the MAT reader its variable names. The rules are those of
docs/interface.md section 1: standard ``<quantity>_<unit>`` names are recognised without
configuration, anything else is mapped by the protocol's ``[columns]`` table.
"""

from __future__ import annotations

from typing import NamedTuple, Sequence

from ..errors import NotATrial, TrialError
from ..units import FIELDS, STANDARD_QUANTITIES, UNITS, canonical_unit, parse_standard_header, split_header, \
    unit_in_header
from .column_units import agree, check_field_unit, check_unit

_LABELS = {"time": "time", "angle": "angle/position", "torque": "torque/force",
           "elastic_torque": "elastic torque/force", "stiffness_true": "reference stiffness",
           "schedule": "scheduling variable", "marker": "cycle marker ([cycles] marker)"}

#: Every Trial field a reader fills: :data:`~limbstiff.units.FIELDS`, then the scheduling variable
#: (``[columns.schedule]`` or a ``schedule_<unit>`` header) and the cycle marker (``[cycles] marker``).
READ_FIELDS = (*FIELDS, "schedule", "marker")


class ColumnSpec(NamedTuple):
    """Where one Trial field is read from.

    Parameters
    ----------
    field : str
        Trial field (see :data:`READ_FIELDS`).
    header : str
        Column header (or variable name, or MAT path) in the file.
    index : int
        0-based position of that header in the list given to :func:`resolve_columns`.
    unit : str
        Unit of the values in the file (a key of :data:`~limbstiff.units.UNITS`; for the
        scheduling variable also a free unit, for the marker ``""``: raw values).
    scale : float
        Factor applied after conversion to SI units.
    """

    field: str
    header: str
    index: int
    unit: str
    scale: float


def resolve_columns(where: str, headers: Sequence[str], protocol=None, *,
                    units: Sequence[str | None] | None = None, noun: str = "column",
                    need_time: bool = True) -> dict[str, ColumnSpec]:
    """Decide which column gives each :class:`~limbstiff.trial.Trial` field, in which unit.

    A quantity listed in ``protocol.columns`` with a ``header`` is read from that column (its
    unit from the protocol, else the unit row, else the header); every other quantity is
    looked for among the standard ``<quantity>_<unit>`` headers not claimed by the protocol —
    or, with a unit row, among plain quantity headers (``angle`` above ``deg``) — its unit and
    scale still overridable by the protocol. A protocol's ``header`` names a column by its
    whole header or by its name without the unit (``Zeit`` for ``Zeit (ms)``), and the unit it
    gives such a column must agree with the unit in the header and with the unit row. For a
    standard column the protocol does not name, its unit overrides the one in the header (a file
    whose ``angle_rad`` holds degrees), but must still agree with the unit row.

    Parameters
    ----------
    where : str
        File name, for error messages.
    headers : sequence of str
        Column headers (or variable names) of the file, stripped, in order.
    protocol : Protocol or None
    units : sequence of (str or None), optional
        The file's unit row, aligned with ``headers`` (None where a cell is empty).
    noun : str
        What a header names, for messages (``"column"`` or ``"variable"``).
    need_time : bool
        False when the caller builds the time base itself (from a sample rate).

    Returns
    -------
    dict of str to ColumnSpec
        By Trial field; ``time`` (if ``need_time``) and ``angle``, and ``torque`` or
        ``elastic_torque``; ``schedule`` when the protocol maps it or a ``schedule_<unit>``
        header is present (its unit may be a free one, kept unconverted); ``marker`` when the
        protocol's ``[cycles] marker`` names a column.

    Raises
    ------
    TrialError
        A missing column, an unknown or mismatched unit, two columns for one quantity.
    """
    mapped = dict(protocol.columns) if protocol is not None else {}
    file = _listing(where, headers, units, noun)
    marker = getattr(getattr(protocol, "cycles", None), "marker", None)
    located = _located(file, mapped, marker)
    # the schedule may be a column that is also a quantity (the angle itself: stiffness against
    # position), so it claims no header from the standard ones
    claimed = {headers[index] for field, index in located.items() if field != "schedule"}
    standard = _standard_headers(where, headers, file.row, claimed, noun)
    columns = _quantity_columns(file, mapped, located, standard, lenient=bool(claimed))
    if marker is not None:
        columns["marker"] = _marker_column(file, located["marker"], columns)
    _check_complete(file, columns, need_time)
    return columns


def _listing(where: str, headers: Sequence[str], units: Sequence[str | None] | None, noun: str) -> _Listing:
    """The file's headers with its unit row padded to their length (None where absent)."""
    found = ", ".join(h for h in headers if h) or "none"
    row = list(units or ())
    row += [None] * (len(headers) - len(row))
    return _Listing(where, noun, list(headers), row, f"{'headers' if noun == 'column' else noun + 's'} found: {found}")


def _located(file: _Listing, mapped: dict, marker: str | None) -> dict[str, int]:
    """The index of every header the protocol names (``[columns]`` and ``[cycles] marker``), by field."""
    located = {field: _locate(file, field, spec.header) for field, spec in mapped.items()
               if spec.header is not None}
    if marker is not None:
        located["marker"] = _locate(file, "marker", marker)
    return located


def _quantity_columns(file: _Listing, mapped: dict, located: dict[str, int], standard: dict[int, tuple[str, str]],
                      *, lenient: bool) -> dict[str, ColumnSpec]:
    """The column of every quantity (the Trial's fields and the schedule): the protocol's where it
    names one, else the one standard header holding it (none for a field the protocol settles)."""
    covered = _covered(mapped)
    columns: dict[str, ColumnSpec] = {}
    for field in (*FIELDS, "schedule"):
        spec = mapped.get(field)
        if spec is not None and spec.header is not None:
            columns[field] = _mapped_column(file, field, spec, located[field], columns)
            continue
        if field in covered:
            continue
        column = _standard_column(file, field, spec, standard, lenient=lenient)
        if column is not None:
            columns[field] = column
    return columns


def _marker_column(file: _Listing, index: int, columns: dict[str, ColumnSpec]) -> ColumnSpec:
    """The trigger column ``[cycles] marker`` names: raw values, no unit, no scale."""
    header = file.headers[index]
    other = [_LABELS[c.field] for c in columns.values() if c.header == header]
    if other:
        raise TrialError(file.where, f"{file.noun} '{header}' is given by the protocol for both "
                                     f"{other[0]} and {_LABELS['marker']}")
    return ColumnSpec("marker", header, index, "", 1.0)


def _covered(mapped) -> set[str]:
    """Fields a protocol's ``[columns]`` settles, so that no other column is read for them: the
    ones it names a header for, and both torques when it names either (a logger's unmapped
    ``torque_in`` beside a mapped ``torque_out`` is ignored, never read as a torque in 'in')."""
    named = {field for field, spec in mapped.items() if spec.header is not None}
    if named & {"torque", "elastic_torque"}:
        named |= {"torque", "elastic_torque"}
    return named


class _Listing(NamedTuple):
    """The headers of one file, as :func:`resolve_columns` was given them.

    Parameters
    ----------
    where : str
        File name, for error messages.
    noun : str
        What a header names (``"column"`` or ``"variable"``).
    headers : list of str
    row : list of (str or None)
        The unit row, aligned with ``headers`` (all None without one).
    found : str
        ``headers found: …``, for the messages about a missing column.
    """

    where: str
    noun: str
    headers: list
    row: list
    found: str


def _locate(file: _Listing, field: str, given: str) -> int:
    """The index of the header the protocol names for ``field``: the header itself, else the one
    header whose name without its unit is ``given`` (``Zeit`` finds ``Zeit (ms)``, ``Zeit_ms``;
    the case of the letters counts only when two headers differ by it alone).

    Raises
    ------
    TrialError
        No such header, or two headers of that name.
    """
    given = given.strip()
    if given in file.headers:
        return file.headers.index(given)
    names = [split_header(h)[0] for h in file.headers]
    matches = [i for i, name in enumerate(names) if name == given]
    if not matches:
        matches = [i for i, name in enumerate(names) if name.casefold() == given.casefold()]
    if len(matches) > 1:
        both = " and ".join(f"'{file.headers[i]}'" for i in matches[:2])
        raise TrialError(file.where, f"{file.noun} '{given}' given by the protocol for {_LABELS[field]} "
                                     f"matches both {both}; give the whole header in the protocol")
    if not matches:
        raise TrialError(file.where, f"{file.noun} '{given}' given by the protocol for {_LABELS[field]} "
                                     f"is not in the file ({file.found})")
    return matches[0]


def _mapped_column(file: _Listing, field: str, spec, index: int,
                   columns: dict[str, ColumnSpec]) -> ColumnSpec:
    """The column the protocol names for ``field``, its unit checked against the file's.

    Parameters
    ----------
    file : _Listing
    field : str
        Trial field.
    spec : protocol column spec
        With a ``header``; ``unit`` and ``scale`` as the protocol gives them.
    index : int
        Where that header is (:func:`_locate`).
    columns : dict of str to ColumnSpec
        The fields resolved so far, to refuse one column mapped to two quantities.
    """
    where, noun, row, label = file.where, file.noun, file.row, _LABELS[field]
    header = file.headers[index]
    named = unit_in_header(header)
    agree(where, noun, header, ("the protocol", spec.unit), ("its name", named))
    agree(where, noun, header, ("the protocol", spec.unit), ("the unit row", row[index]))
    agree(where, noun, header, ("its name", named), ("the unit row", row[index]))
    unit = spec.unit or row[index] or named
    if unit is None:
        raise TrialError(where, f"{noun} '{header}' ({label}) has no unit in its name; "
                                f"give one in the protocol ([columns.{field}] unit)")
    check_field_unit(where, noun, header, unit, field, label)
    other = [_LABELS[c.field] for c in columns.values() if c.header == header]
    if other and field != "schedule":
        raise TrialError(where, f"{noun} '{header}' is given by the protocol for both "
                                f"{other[0]} and {label}")
    return ColumnSpec(field, header, index, unit, spec.scale)


def _standard_column(file: _Listing, field: str, spec, standard: dict[int, tuple[str, str]], *,
                     lenient: bool = False) -> ColumnSpec | None:
    """The one standard header holding ``field``, or None when there is none.

    Parameters
    ----------
    file : _Listing
    field : str
        Trial field.
    spec : protocol column spec or None
        Without a ``header``; its ``unit`` and ``scale``, if any, override the header's.
    standard : dict of int to (str, str)
        (quantity, unit) of the unclaimed standard headers, by index.
    lenient : bool
        The protocol maps columns: a header that only looks standard (its unit unknown) is
        left alone (the reader lists it as ignored) instead of being an error.
    """
    where, noun, label = file.where, file.noun, _LABELS[field]
    free = field == "schedule"          # a free unit (%MVC) is the scheduling variable's own, not a misspelling
    candidates = [(i, q, u) for i, (q, u) in standard.items()
                  if STANDARD_QUANTITIES[q].field == field and not (lenient and u not in UNITS and not free)]
    if not candidates:
        return None
    if len(candidates) > 1:
        names = " and ".join(f"'{file.headers[c[0]]}'" for c in candidates)
        if len({c[1] for c in candidates}) > 1:
            raise TrialError(where, f"mixes rotational and translational {noun}s ({names})")
        raise TrialError(where, f"more than one {label} {noun} ({names})")
    index, quantity, unit = candidates[0]
    header = file.headers[index]
    if spec is not None and spec.unit:
        agree(where, noun, header, ("the protocol", spec.unit), ("the unit row", file.row[index]))
        unit = spec.unit
        check_field_unit(where, noun, header, unit, field, label)
    elif free:
        check_field_unit(where, noun, header, unit, field, label)
    else:
        check_unit(where, noun, header, unit, quantity.replace("_", " "),
                    STANDARD_QUANTITIES[quantity].dimensions, hint=True)
    return ColumnSpec(field, header, index, unit, spec.scale if spec is not None else 1.0)


def _check_complete(file: _Listing, columns: dict[str, ColumnSpec], need_time: bool) -> None:
    """Error unless time (if needed), angle, and torque or elastic torque were all found."""
    where, noun, found = file.where, file.noun, file.found
    hint = _protocol_hint(file, columns)
    if not hint and not {"time", "angle", "torque", "elastic_torque"} & set(columns):
        raise NotATrial(where, f"not a trial: no time, angle or torque {noun} (expected time_s, angle_deg, "
                               f"torque_Nm or the like; {found})")
    if need_time and "time" not in columns:
        raise TrialError(where, f"no time {noun} (expected time_s, time_ms or 'Time (s)'; {found}){hint}")
    if "angle" not in columns:
        raise TrialError(where, f"no angle or position {noun} (expected angle_rad, angle_deg, "
                                f"position_m, position_mm or 'Angle (deg)'; {found}){hint}")
    if "torque" not in columns and "elastic_torque" not in columns:
        raise TrialError(where, f"no torque or force {noun} (expected torque_Nm, force_N, "
                                f"elastic_torque_Nm, elastic_force_N or 'Torque (Nm)'; {found}){hint}")


#: Words that suggest which quantity a free-form header holds, for the protocol hint only
#: (never used to read a file: a protocol must say it).
_GUESS = {"time": ("time", "zeit", "temps", "tiempo", "t", "sec", "seconds"),
          "angle": ("angle", "position", "pos", "displacement", "disp", "theta", "winkel", "q"),
          "torque": ("torque", "moment", "force", "tau", "load", "drehmoment")}


def _protocol_hint(file: _Listing, columns: dict[str, ColumnSpec]) -> str:
    """A ready-to-paste protocol line (TOML) mapping the file's likely columns, after
    '; a protocol can map them: '; empty when the file has no headers to map."""
    entries = []
    for field, words in _GUESS.items():
        if field in columns:
            continue
        index = next((i for i, h in enumerate(file.headers)
                      if h and (h.strip().lower().replace("_", " ").split() or [""])[0].strip("([") in words), None)
        if index is None:
            continue
        name, named = split_header(file.headers[index])
        unit = file.row[index] or named
        unit = canonical_unit(unit) if unit in UNITS else (unit or "?")
        if sum(split_header(h)[0] == name for h in file.headers) > 1:
            name = file.headers[index].strip()       # two headers of that name: the whole one
        header = name.replace("\\", "\\\\").replace('"', '\\"')
        entries.append(f'{field} = {{ header = "{header}", unit = "{unit}" }}')
    if not entries:
        return ""
    return ("; a protocol can map them (--protocol FILE with, for example, the line: columns = { "
            + ", ".join(entries) + " }; check each unit)")


def _standard_headers(where, headers, row, claimed, noun) -> dict[int, tuple[str, str]]:
    """(quantity, unit) of every unclaimed standard header, by index.

    A standard name (``angle_deg``) gives both; a plain quantity name (``angle``, any case)
    is standard when the unit row gives its unit.
    """
    out = {}
    for index, header in enumerate(headers):
        if header in claimed:
            continue
        parsed = parse_standard_header(header)
        plain = header.strip().lower()
        if parsed is None and row[index] and plain in STANDARD_QUANTITIES:
            parsed = (plain, row[index])
        elif parsed is not None:
            agree(where, noun, header, ("its name", parsed[1]), ("the unit row", row[index]))
        if parsed is not None:
            out[index] = parsed
    return out
