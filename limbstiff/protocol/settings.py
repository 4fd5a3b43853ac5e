"""The frozen :class:`Protocol` and its parts (:class:`Column`, :class:`Cycles`, :class:`Prior`),
with the allowed values of each setting and the checks every protocol passes when it is made.

Every setting left out takes the default documented on :class:`Protocol`; ``None`` means "derive
it from the data". Reading the TOML file is :mod:`limbstiff.protocol.reading`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Any, Mapping

from ..errors import ProtocolError
from ..frozen import FrozenDict
from ..plausibility import LIMBS
from ..units import UNITS, free_unit_clash

QUANTITIES = ("time", "angle", "torque", "elastic_torque", "stiffness_true", "schedule")
VARIANTS = ("auto", "external", "direct")
ESTIMATORS = ("kalman", "observer-smoothed", "observer")
#: Unmodelled effects an analysis can put in its model (``[mechanics] effects``, ``--effect``): the torque
#: effects of the registry (:data:`limbstiff.effects.registry.IN_MODEL`, which checks them equal at import).
MODEL_EFFECTS = ("coulomb_friction", "quadratic_damping", "hysteresis", "reflex")
DISCRETISATIONS = ("exact", "euler")
DERIVATIVES = ("zero-phase", "paper")
PRIOR_DISTRIBUTIONS = ("lognormal", "halfnormal", "uniform")
DELIMITERS = ("auto", ",", ";", "\t")
DECIMALS = ("auto", ".", ",")


@dataclass(frozen=True)
class Column:
    """How one quantity is found in a file.

    Parameters
    ----------
    header : str or None
        Column header in the file; None keeps the standard ``<quantity>_<unit>`` name.
    unit : str or None
        Unit of that column (for example ``"deg"``); None takes it from the header.
    scale : float
        Factor applied after unit conversion; ``-1`` flips the sign.
    component : {"x", "y", "z"} or None
        Which coordinate of a C3D point channel (model outputs such as ``LAnkleAngles``);
        None for every other channel.
    """

    header: str | None = None
    unit: str | None = None
    scale: float = 1.0
    component: str | None = None


#: The marker's name in messages when each file is one cycle (``Cycles(marker=ENSEMBLE_MARKER)``,
#: ``analyze --ensemble``): the files, not a column.
ENSEMBLE_MARKER = "<files>"
#: How an ensemble's cycles were cut, in words (the curve's caption and ``how`` in summary.json),
#: formatted with the number of files.
ENSEMBLE_HOW = "one cycle per file, {} files"


@dataclass(frozen=True)
class Cycles:
    """How a trial is cut into movement cycles (the ``[cycles]`` section).

    Exactly one of ``period_s`` and ``marker`` is given: cycles of fixed length from the first
    sample (or from ``start_s``), or cycles started by the rising edges of a trigger column.

    Parameters
    ----------
    period_s : float or None, s
        Length of every cycle; None when a marker column starts them.
    start_s : float, s
        Time after the first sample at which the first fixed-length cycle starts (≥ 0).
    marker : str or None
        Header of the trigger (event) column whose rising edges start the cycles, matched like
        the headers of ``[columns]``; its raw values become :attr:`limbstiff.trial.Trial.marker`.
    """

    period_s: float | None = None
    start_s: float = 0.0
    marker: str | None = None


@dataclass(frozen=True)
class Prior:
    """Prior on a positive mechanical parameter (inertia or damping).

    Parameters
    ----------
    distribution : {"lognormal", "halfnormal", "uniform"}
        Family. ``lognormal`` takes ``median`` and ``sigma`` (sd of the log); ``halfnormal``
        takes ``scale``; ``uniform`` takes ``low`` and ``high``.
    median, sigma, scale, low, high : float or None
        Parameters of that family, in SI units.
    """

    distribution: str = "halfnormal"
    median: float | None = None
    sigma: float | None = None
    scale: float | None = None
    low: float | None = None
    high: float | None = None


@dataclass(frozen=True)
class Protocol:
    """One experimental set-up. Fields left ``None`` are derived from each trial's data.

    Parameters
    ----------
    name : str
        Short name of the set-up.
    description : str
        What the set-up is, for people.
    source : str or None
        File the protocol was read from.
    columns : Mapping[str, Column]
        How each quantity (``time``, ``angle``, ``torque``, ``elastic_torque``,
        ``stiffness_true``, ``schedule``) is found in the files; quantities not listed use the
        standard ``<quantity>_<unit>`` headers. ``schedule`` is a recorded variable the stiffness
        depends on (an operating position, an EMG envelope, a commanded torque): its unit is one
        of the unit table (converted to SI) or a free unit the table does not know (``"%MVC"``,
        ``"V"``, ``"1"``), kept as given, unconverted.
    delimiter : {"auto", ",", ";", "\\t"}
        Field separator of text files; ``auto`` detects it from the header line (``"tab"``
        is accepted for ``"\\t"``).
    decimal : {"auto", ".", ","}
        Decimal mark of text files; ``auto`` takes ``,`` for semicolon- or tab-separated files whose
        numbers are written with a comma (``1,25``), else ``.``.
    unit_row : bool or "auto"
        Whether text files have a row of units under the header (``s``, ``deg``, ``Nm``…);
        ``auto`` detects it.
    sample_rate_hz : float or None, Hz
        Sampling rate of MAT files that have no time variable (the time base is then built
        from it); None: such files must carry their own rate (a scalar ``fs`` variable).
    encoding : str
        Text encoding of text files (a Python codec name such as ``cp1252``); ``auto`` reads
        UTF-8 and, when a file is not UTF-8, Windows-1252 (Latin-1 where that fails) with a
        warning.
    max_gap_s : float or None, s
        Longest gap in the time column bridged by interpolation (marked unobservable); None:
        from the data (:func:`limbstiff.files.validate.default_max_gap`).
    sheet : str or None
        The worksheet of ``.xlsx`` files to read; None: the first.
    variant : {"auto", "external", "direct"}
        Observer variant; ``auto`` takes ``direct`` when an elastic torque is recorded.
    estimator : str
        Estimator name (see :data:`ESTIMATORS`).
    observer_gain : float or None, 1/rad (1/m)
        Gain α of update law (7); None derives it from the range of motion.
    discretisation : {"exact", "euler"}
        ``exact`` solves the update over each sample (stable for any gain); ``euler`` is the
        plain forward-Euler step, kept for comparison.
    derivatives : {"zero-phase", "paper"}
        ``zero-phase`` filters forwards and backwards then differentiates (offline);
        ``paper`` is the causal chain of Sec. V: second-order prefilter and the dirty
        derivative of eq. (11).
    bandwidth_hz : float or None, Hz
        Low-pass corner of the zero-phase chain; None derives it from the data.
    prefilter_time_constant : float, s
        Time constant of the paper chain's second-order prefilter (0.02 s in Sec. V).
    dirty_derivative_time_constant : float, s
        Time constant of the dirty derivative D(s) = s/(1 + τ s) (10⁻⁴ s in eq. 11).
    sample_period : float or None, s
        Resample every trial to this period before analysis (0.015 s on the paper's bench).
    inertia : float or None, kg·m² (kg)
        Fixed inertia m; None identifies it.
    damping : float or None, N·m·s/rad (N·s/m)
        Fixed damping b; None identifies it.
    inertia_prior, damping_prior : Prior
        Priors used when m and b are identified.
    inertia_range : tuple of float or None, kg·m² (kg)
        Range of inertia expected for the set-up (anthropometry plus attachments); an
        identified inertia outside it is reported as a warning.
    ci_level : float
        Level of the central credible interval reported as ``lo``/``hi``.
    limb : str or None
        The joint or set-up recorded (a key of :data:`limbstiff.plausibility.LIMBS`: ``ankle``,
        ``elbow``, ``vsa``…): its inertia, range of motion and torques bound the units check;
        None assumes any joint (:data:`limbstiff.plausibility.ANY_JOINT`).
    effects : tuple of str
        Unmodelled effects put in the model (names of :data:`MODEL_EFFECTS`, ``[mechanics] effects``):
        their shape chosen from the data, their amplitudes identified with m and b
        (:mod:`limbstiff.effects.in_model`). None by default.
    cycles : Cycles or None
        How trials are cut into movement cycles (``[cycles]``: ``period_s``, ``start_s``,
        ``marker``); None: the protocol does not say.
    """

    name: str = "default"
    description: str = ""
    source: str | None = None
    columns: Mapping[str, Column] = field(default_factory=dict)
    delimiter: str = "auto"
    decimal: str = "auto"
    unit_row: bool | str = "auto"
    sample_rate_hz: float | None = None
    encoding: str = "auto"
    max_gap_s: float | None = None
    sheet: str | None = None
    variant: str = "auto"
    estimator: str = "kalman"
    observer_gain: float | None = None
    discretisation: str = "exact"
    derivatives: str = "zero-phase"
    bandwidth_hz: float | None = None
    prefilter_time_constant: float = 0.02
    dirty_derivative_time_constant: float = 1e-4
    sample_period: float | None = None
    inertia: float | None = None
    damping: float | None = None
    inertia_prior: Prior = field(default_factory=Prior)
    damping_prior: Prior = field(default_factory=Prior)
    inertia_range: tuple | None = None
    ci_level: float = 0.9
    limb: str | None = None
    effects: tuple = ()
    cycles: Cycles | None = None

    def __post_init__(self):
        object.__setattr__(self, "columns", FrozenDict(self.columns))
        _check(self)

    def override(self, **changes: Any) -> "Protocol":
        """Return a copy with the given settings replaced; ``None`` values are ignored.

        This is how command-line options take precedence over the file.
        """
        changes = {k: v for k, v in changes.items() if v is not None}
        return replace(self, **changes) if changes else self

    def to_dict(self) -> dict:
        """The resolved settings as plain JSON-ready values (for provenance)."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, (Column, Prior, Cycles)):
                value = {g.name: getattr(value, g.name) for g in fields(value)}
            elif f.name == "columns":
                # a component only where one is set: the settings (and their hash) of other files unchanged
                value = {q: {g.name: getattr(c, g.name) for g in fields(c)
                             if g.name != "component" or c.component is not None} for q, c in value.items()}
            if (f.name in ("limb", "sheet", "cycles") and value is None) or (f.name == "effects" and not value):
                continue        # the settings (and their hash) of protocols without a limb, effects or cycles unchanged
            if f.name == "effects":
                value = list(value)
            out[f.name] = value
        return out


def _positive(p: Protocol, name: str, allow_none: bool = True):
    value = getattr(p, name)
    if value is None and allow_none:
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0:
        raise ProtocolError(p.source or p.name, f"'{name}' must be a positive number, not {value!r}")


def _check(p: Protocol) -> None:
    where = p.source or p.name
    for name, allowed in (("variant", VARIANTS), ("estimator", ESTIMATORS),
                          ("discretisation", DISCRETISATIONS), ("derivatives", DERIVATIVES)):
        if getattr(p, name) not in allowed:
            raise ProtocolError(where, f"'{name}' must be one of {', '.join(allowed)}, not {getattr(p, name)!r}")
    for name in ("observer_gain", "bandwidth_hz", "sample_period", "inertia", "damping", "sample_rate_hz",
                 "max_gap_s"):
        _positive(p, name)
    _check_format(p, where)
    if p.limb is not None and p.limb not in LIMBS:
        raise ProtocolError(where, f"'limb' must be one of {', '.join(LIMBS)}, not {p.limb!r}")
    effects = (p.effects,) if isinstance(p.effects, str) else p.effects
    if not isinstance(effects, (list, tuple)) or any(e not in MODEL_EFFECTS for e in effects) \
            or len(set(effects)) != len(effects):
        raise ProtocolError(where, f"'effects' must be a list of distinct effects among {', '.join(MODEL_EFFECTS)}, "
                                   f"not {p.effects!r}")
    object.__setattr__(p, "effects", tuple(effects))
    for name in ("prefilter_time_constant", "dirty_derivative_time_constant"):
        _positive(p, name, allow_none=False)
    if p.inertia_range is not None:
        r = p.inertia_range
        if not (isinstance(r, (list, tuple)) and len(r) == 2 and all(isinstance(x, (int, float)) for x in r)
                and 0 < r[0] < r[1]):
            raise ProtocolError(where, f"'expected_inertia' must be [low, high] with 0 < low < high, not {r!r}")
        object.__setattr__(p, "inertia_range", (float(r[0]), float(r[1])))
    if not (isinstance(p.ci_level, float) and 0 < p.ci_level < 1):
        raise ProtocolError(where, f"'ci_level' must be a number between 0 and 1, not {p.ci_level!r}")
    for label, prior in (("inertia", p.inertia_prior), ("damping", p.damping_prior)):
        _check_prior(where, label, prior)
    _check_cycles(p, where)
    for quantity, column in p.columns.items():
        if quantity == "schedule" and column.unit is not None:
            _check_schedule_unit(where, column.unit)
        elif column.unit is not None and column.unit not in UNITS:
            raise ProtocolError(where, f"unknown unit '{column.unit}' for {quantity} in [columns.{quantity}]")
        if column.scale == 0 or column.scale != column.scale:
            raise ProtocolError(where, f"'scale' of [columns.{quantity}] must be a non-zero number")


def _check_schedule_unit(where, unit) -> None:
    """A schedule's unit: any unit of the table, or a free one (``%MVC``, ``V``) kept unconverted —
    but not one the table knows by another case (``Deg``), which would pass unconverted by mistake."""
    clash = free_unit_clash(unit) if isinstance(unit, str) else None
    if not isinstance(unit, str) or not unit.strip():
        raise ProtocolError(where, f"'unit' of [columns.schedule] must be a unit, not {unit!r}")
    if clash:
        raise ProtocolError(where, f"unit '{unit}' of [columns.schedule] is not in the unit table, '{clash}' is: "
                                   f"write unit = \"{clash}\" (converted to SI) or a unit the table does not know")


def _check_cycles(p: Protocol, where) -> None:
    """``[cycles]``: exactly one of period_s and marker; period_s > 0, start_s ≥ 0."""
    c = p.cycles
    if c is None:
        return
    if not isinstance(c, Cycles):
        raise ProtocolError(where, f"'cycles' must be a Cycles, not {type(c).__name__}")
    if (c.period_s is None) == (c.marker is None):
        said = "both period_s and marker" if c.marker is not None else "neither period_s nor marker"
        raise ProtocolError(where, f"[cycles] gives {said}: write either period_s = <cycle length in s> "
                                   "(cycles of fixed length) or marker = \"<header of the trigger column>\"")
    number = (int, float)
    if c.period_s is not None and (isinstance(c.period_s, bool) or not isinstance(c.period_s, number)
                                   or not c.period_s > 0 or c.period_s == float("inf")):
        raise ProtocolError(where, f"'period_s' in [cycles] must be a positive number of seconds, not {c.period_s!r}")
    if isinstance(c.start_s, bool) or not isinstance(c.start_s, number) or not 0 <= c.start_s < float("inf"):
        raise ProtocolError(where, f"'start_s' in [cycles] must be a number of seconds ≥ 0, not {c.start_s!r}")
    if c.marker is not None and c.start_s:
        raise ProtocolError(where, "'start_s' in [cycles] applies to cycles of fixed length (period_s); with a "
                                   "marker the rising edges start the cycles: remove start_s")
    if c.marker is not None and not (isinstance(c.marker, str) and c.marker.strip()):
        raise ProtocolError(where, f"'marker' in [cycles] must be the header of the trigger column, not {c.marker!r}")
    object.__setattr__(p, "cycles", replace(c, period_s=None if c.period_s is None else float(c.period_s),
                                            start_s=float(c.start_s)))


def _check_format(p: Protocol, where) -> None:
    if p.delimiter == "tab":
        object.__setattr__(p, "delimiter", "\t")
    for name, allowed in (("delimiter", DELIMITERS), ("decimal", DECIMALS)):
        if getattr(p, name) not in allowed:
            shown = ", ".join(repr(a) for a in allowed)
            raise ProtocolError(where, f"'{name}' in [format] must be one of {shown}, not {getattr(p, name)!r}")
    if p.unit_row not in (True, False, "auto") or not isinstance(p.unit_row, (bool, str)):
        raise ProtocolError(where, f"'unit_row' in [format] must be true, false or \"auto\", not {p.unit_row!r}")
    if p.sheet is not None and not (isinstance(p.sheet, str) and p.sheet.strip()):
        raise ProtocolError(where, f"'sheet' in [format] must be a worksheet's name, not {p.sheet!r}")
    if p.delimiter == "," and p.decimal == ",":
        raise ProtocolError(where, "[format] delimiter and decimal cannot both be ','")
    if p.encoding != "auto":
        import codecs
        try:
            codecs.lookup(str(p.encoding))
        except (LookupError, TypeError):
            raise ProtocolError(where, f"'encoding' in [format] is not a known text encoding: {p.encoding!r} "
                                       "(for example \"utf-8\", \"cp1252\", \"latin-1\")") from None


def _check_prior(where, label, prior: Prior) -> None:
    need = {"lognormal": ("median", "sigma"), "halfnormal": (), "uniform": ("low", "high")}
    if prior.distribution not in need:
        raise ProtocolError(where, f"prior on {label}: distribution must be one of "
                                   f"{', '.join(PRIOR_DISTRIBUTIONS)}, not {prior.distribution!r}")
    for key in need[prior.distribution]:
        value = getattr(prior, key)
        if not isinstance(value, (int, float)) or isinstance(value, bool) or not value > 0:
            raise ProtocolError(where, f"prior on {label}: '{key}' must be a positive number")
    if prior.distribution == "uniform" and not prior.low < prior.high:
        raise ProtocolError(where, f"prior on {label}: 'low' must be below 'high'")
