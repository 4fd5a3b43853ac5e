"""Reading a protocol TOML file: its sections and keys into a :class:`Protocol`, unknown keys an error."""

from __future__ import annotations

import tomllib
from dataclasses import fields
from pathlib import Path
from typing import Any, Mapping

from ..errors import ProtocolError
from .settings import QUANTITIES, Column, Cycles, Prior, Protocol

# TOML layout: section -> {key in file: Protocol field}
_SECTIONS = {
    "format": {"delimiter": "delimiter", "decimal": "decimal", "unit_row": "unit_row",
               "sample_rate_hz": "sample_rate_hz", "encoding": "encoding", "max_gap_s": "max_gap_s",
               "sheet": "sheet"},
    "observer": {"variant": "variant", "estimator": "estimator", "gain": "observer_gain",
                 "discretisation": "discretisation"},
    "signals": {"derivatives": "derivatives", "bandwidth_hz": "bandwidth_hz",
                "prefilter_time_constant": "prefilter_time_constant",
                "dirty_derivative_time_constant": "dirty_derivative_time_constant",
                "sample_period": "sample_period"},
    "mechanics": {"inertia": "inertia", "damping": "damping", "expected_inertia": "inertia_range",
                  "effects": "effects"},
    "report": {"ci_level": "ci_level"},
}
# Settings for which "auto" (None) means: derive from each trial's data.
_AUTO = {"observer_gain", "bandwidth_hz", "sample_period", "inertia", "damping", "sample_rate_hz", "max_gap_s"}
_TOP = {"name", "description", "limb", "columns", "priors", "cycles", *_SECTIONS}


def load_protocol(path: str | Path) -> Protocol:
    """Read a protocol TOML file.

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file.

    Returns
    -------
    Protocol

    Raises
    ------
    ProtocolError
        If the file cannot be read, is not TOML, has unknown keys or invalid values.
    """
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text(encoding="utf-8-sig"))
    except FileNotFoundError:
        raise ProtocolError(path, "protocol file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ProtocolError(path, f"cannot read protocol file ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ProtocolError(path, f"not valid TOML ({exc})") from None
    return protocol_from_dict(raw, source=str(path))


def protocol_from_dict(raw: Mapping[str, Any], *, source: str = "<protocol>") -> Protocol:
    """Build a :class:`Protocol` from the nested mapping of a TOML file (see :func:`load_protocol`)."""
    unknown = set(raw) - _TOP
    if unknown:
        raise ProtocolError(source, f"unknown key(s) {', '.join(sorted(unknown))}")
    kwargs: dict[str, Any] = {"source": source}
    for key in ("name", "description", "limb"):
        if key in raw:
            kwargs[key] = _typed(source, key, raw[key], str)
    for section, keys in _SECTIONS.items():
        table = _table(source, section, raw.get(section, {}))
        _known(source, section, table, keys)
        for key, value in table.items():
            kwargs[keys[key]] = None if (value == "auto" and keys[key] in _AUTO) else value
    kwargs["columns"] = {quantity: _column(source, quantity, spec)
                         for quantity, spec in _table(source, "columns", raw.get("columns", {})).items()}
    for name, spec in _table(source, "priors", raw.get("priors", {})).items():
        kwargs[f"{name}_prior"] = _prior(source, name, spec)
    if "cycles" in raw:
        kwargs["cycles"] = _cycles(source, _table(source, "cycles", raw["cycles"]))
    try:
        return Protocol(**kwargs)
    except ProtocolError as exc:
        raise ProtocolError(source, exc.problem) from None
    except TypeError as exc:
        raise ProtocolError(source, f"invalid value ({exc})") from None


def _column(source, quantity: str, spec) -> Column:
    """The ``[columns.<quantity>]`` table as :class:`Column` (its values checked by the Protocol)."""
    if quantity not in QUANTITIES:
        raise ProtocolError(source, f"unknown quantity '{quantity}' in [columns] "
                                    f"(one of {', '.join(QUANTITIES)})")
    spec = _table(source, f"columns.{quantity}", spec)
    _known(source, f"columns.{quantity}", spec, ("header", "unit", "scale", "component"))
    component = _typed(source, "component", spec.get("component"), str)
    if component is not None and component.lower() not in ("x", "y", "z"):
        raise ProtocolError(source, f"'component' of [columns.{quantity}] must be \"x\", \"y\" or \"z\" "
                                    f"(a C3D point channel's coordinate), not {component!r}")
    return Column(header=_typed(source, "header", spec.get("header"), str),
                  unit=_typed(source, "unit", spec.get("unit"), str),
                  scale=float(_typed(source, "scale", spec.get("scale", 1.0), (int, float))),
                  component=None if component is None else component.lower())


def _prior(source, name: str, spec) -> Prior:
    """The ``[priors.<name>]`` table (``inertia`` or ``damping``) as :class:`Prior`."""
    if name not in ("inertia", "damping"):
        raise ProtocolError(source, f"unknown prior '{name}' (inertia or damping)")
    spec = _table(source, f"priors.{name}", spec)
    _known(source, f"priors.{name}", spec, [f.name for f in fields(Prior)])
    return Prior(**spec)


def _cycles(source, table: Mapping[str, Any]) -> Cycles:
    """The ``[cycles]`` section as :class:`Cycles` (checked by the Protocol)."""
    _known(source, "cycles", table, [f.name for f in fields(Cycles)], hint=" (period_s, start_s, marker)")
    return Cycles(period_s=table.get("period_s"), start_s=table.get("start_s", 0.0), marker=table.get("marker"))


def _known(source, section: str, table: Mapping[str, Any], keys, hint: str = "") -> None:
    """Error if the table ``[section]`` has a key not among ``keys``."""
    unknown = set(table) - set(keys)
    if unknown:
        raise ProtocolError(source, f"unknown key(s) in [{section}]: {', '.join(sorted(unknown))}{hint}")


def _table(source, name, value) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ProtocolError(source, f"'{name}' must be a table")
    return value


def _typed(source, key, value, types):
    if value is not None and (not isinstance(value, types) or isinstance(value, bool)):
        raise ProtocolError(source, f"'{key}' has the wrong type ({type(value).__name__})")
    return value


