"""Quantities with units: the unit table, parsing and display conversions.

Model files give quantities either as plain numbers (in the *display unit* of their kind)
or as strings with a unit suffix (``"10rpm"``, ``"90 deg"``, ``"1.2 m/s"``).  This module
converts both to the *internal* units used by the solver:

* angular kinds (angle, angular rate, acceleration, jerk) are radian based
  (rad, rad/s, rad/s², rad/s³);
* length kinds are expressed in the model's length unit (``length_unit``, e.g. mm) and
  its rates per second.

Plain numbers for angles are in the model's ``angle_unit`` (degrees by default); plain
numbers for angular rates, accelerations and jerks are always radian based (rad/s,
rad/s², rad/s³), following the textbook convention.

Nothing here evaluates user text as code: strings are matched against a regular
expression and a fixed unit table.
"""

from __future__ import annotations

import enum
import math
import numbers
import re
from fractions import Fraction
from types import MappingProxyType
from typing import Mapping

from loopsolve.errors import ModelError

__all__ = [
    "Kind",
    "UnitError",
    "UNITS",
    "UNIT_SUFFIXES",
    "MODEL_ANGLE_UNITS",
    "unit_kind",
    "units_of_kind",
    "parse_quantity",
    "angle_factor",
    "length_factor",
    "validate_units",
    "unit_label",
    "to_display",
    "REDUCE_TURNS",
    "MAX_MAGNITUDE",
]


class Kind(enum.Enum):
    """The physical kind of a quantity."""

    LENGTH = "length"
    LENGTH_RATE = "length rate"
    LENGTH_ACCEL = "length acceleration"
    LENGTH_JERK = "length jerk"
    ANGLE = "angle"
    ANGULAR_RATE = "angular rate"
    ANGULAR_ACCEL = "angular acceleration"
    ANGULAR_JERK = "angular jerk"
    DIMENSIONLESS = "dimensionless"

    @property
    def is_angular(self) -> bool:
        """True for the four radian-based kinds."""
        return self in _ANGULAR_KINDS

    @property
    def is_length(self) -> bool:
        """True for the four length-based kinds."""
        return self in _LENGTH_KINDS


_ANGULAR_KINDS = frozenset({Kind.ANGLE, Kind.ANGULAR_RATE, Kind.ANGULAR_ACCEL, Kind.ANGULAR_JERK})
_LENGTH_KINDS = frozenset({Kind.LENGTH, Kind.LENGTH_RATE, Kind.LENGTH_ACCEL, Kind.LENGTH_JERK})

# order of the time derivative of each kind: used to build the rate/accel/jerk suffixes
_ORDER = {
    Kind.LENGTH: 0,
    Kind.LENGTH_RATE: 1,
    Kind.LENGTH_ACCEL: 2,
    Kind.LENGTH_JERK: 3,
    Kind.ANGLE: 0,
    Kind.ANGULAR_RATE: 1,
    Kind.ANGULAR_ACCEL: 2,
    Kind.ANGULAR_JERK: 3,
}
_BY_ORDER_LENGTH = {v: k for k, v in _ORDER.items() if k.is_length}
_BY_ORDER_ANGULAR = {v: k for k, v in _ORDER.items() if k.is_angular}

# spellings of "per second", "per second squared", "per second cubed"
_PER_TIME = {1: ("/s",), 2: ("/s^2", "/s2", "/s²"), 3: ("/s^3", "/s3", "/s³")}

_TWO_PI = 2.0 * math.pi
_DEG = math.pi / 180.0

# length units: metres per unit
_LENGTHS = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "in": 0.0254, "inch": 0.0254, "ft": 0.3048}


def _build_table() -> dict[str, tuple[Kind, float]]:
    table: dict[str, tuple[Kind, float]] = {}
    # angles (factor: radians per unit)
    for name, f in (
        ("deg", _DEG),
        ("degree", _DEG),
        ("degrees", _DEG),
        ("°", _DEG),
        ("rad", 1.0),
        ("rev", _TWO_PI),
        ("turn", _TWO_PI),
    ):
        table[name] = (Kind.ANGLE, f)
    # angular rates (rad/s per unit)
    for name, f in (
        ("rad/s", 1.0),
        ("deg/s", _DEG),
        ("rpm", _TWO_PI / 60.0),
        ("rps", _TWO_PI),
        ("rev/s", _TWO_PI),
    ):
        table[name] = (Kind.ANGULAR_RATE, f)
    for order in (2, 3):
        for base, f in (("rad", 1.0), ("deg", _DEG)):
            for per in _PER_TIME[order]:
                table[base + per] = (_BY_ORDER_ANGULAR[order], f)
    # lengths (factor: metres per unit) and their time derivatives
    for base, f in _LENGTHS.items():
        table[base] = (Kind.LENGTH, f)
        for order in (1, 2, 3):
            for per in _PER_TIME[order]:
                table[base + per] = (_BY_ORDER_LENGTH[order], f)
    return table


#: every known unit spelling -> (kind, factor to the SI base: radians or metres based)
UNITS: Mapping[str, tuple[Kind, float]] = MappingProxyType(_build_table())

#: every unit spelling, longest first (so a tokenizer trying them in order finds the
#: longest match: ``rad/s^2`` before ``rad/s`` before ``rad``)
UNIT_SUFFIXES: tuple[str, ...] = tuple(sorted(UNITS, key=lambda u: (-len(u), u)))

#: angle units a model may declare as its display angle unit
MODEL_ANGLE_UNITS: tuple[str, ...] = ("deg", "rad")

_IDENT_RE = re.compile(r"[A-Za-z][A-Za-z0-9_]*\Z")
_QUANTITY_RE = re.compile(
    r"\s*(?P<num>[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)\s*(?P<unit>.*?)\s*\Z",
    re.DOTALL,
)


class UnitError(ModelError):
    """A quantity has an unknown unit, a unit of the wrong kind, or is not a number.

    ``where`` names the model field (e.g. ``'variables.theta2.speed'``), ``text`` the
    offending value and ``kind`` the expected :class:`Kind` (when known).
    """

    def __init__(
        self,
        message: str,
        *,
        where: str = "",
        text: str | None = None,
        kind: Kind | None = None,
    ):
        super().__init__(message)
        self.where = where
        self.text = text
        self.kind = kind


def _a(noun: str) -> str:
    return ("an " if noun[0] in "aeiou" else "a ") + noun


def _prefix(where: str) -> str:
    return f"{where}: " if where else ""


def unit_kind(unit: str) -> Kind:
    """Return the :class:`Kind` of a known unit spelling.

    Examples
    --------
    >>> unit_kind("rpm")
    <Kind.ANGULAR_RATE: 'angular rate'>
    >>> unit_kind("mm/s^2").name
    'LENGTH_ACCEL'
    """
    try:
        return UNITS[unit][0]
    except (KeyError, TypeError):
        raise UnitError(f"unknown unit {unit!r}", text=str(unit)) from None


def units_of_kind(kind: Kind, length_unit: str | None = None) -> tuple[str, ...]:
    """List the unit spellings accepted for ``kind`` (table order).

    A custom ``length_unit`` (one not in the table, e.g. ``"px"``) is added to the
    length kinds with its ``/s``, ``/s^2``, ``/s^3`` forms.

    Examples
    --------
    >>> units_of_kind(Kind.ANGULAR_RATE)
    ('rad/s', 'deg/s', 'rpm', 'rps', 'rev/s')
    >>> units_of_kind(Kind.LENGTH, "px")[-1]
    'px'
    """
    found = [u for u, (k, _) in UNITS.items() if k is kind]
    if kind.is_length and length_unit and length_unit not in UNITS:
        order = _ORDER[kind]
        if order == 0:
            found.append(length_unit)
        else:
            found.extend(length_unit + per for per in _PER_TIME[order])
    return tuple(found)


def angle_factor(angle_unit: str) -> float:
    """Radians per ``angle_unit`` (``'deg'`` -> pi/180, ``'rad'`` -> 1).

    Examples
    --------
    >>> round(angle_factor("deg"), 6)
    0.017453
    >>> angle_factor("rad")
    1.0
    """
    entry = UNITS.get(angle_unit) if isinstance(angle_unit, str) else None
    if entry is None or entry[0] is not Kind.ANGLE:
        accepted = ", ".join(units_of_kind(Kind.ANGLE))
        raise UnitError(
            f"unknown angle unit {angle_unit!r} (accepted: {accepted})",
            text=str(angle_unit),
            kind=Kind.ANGLE,
        )
    return entry[1]


def _custom_length_base(unit: str, length_unit: str) -> int | None:
    """Derivative order of ``unit`` when it is the custom ``length_unit`` (+ /s...)."""
    if unit == length_unit:
        return 0
    for order, pers in _PER_TIME.items():
        if any(unit == length_unit + per for per in pers):
            return order
    return None


def length_factor(from_unit: str, to_unit: str) -> float:
    """Factor ``f`` such that a length ``x`` in ``from_unit`` is ``x * f`` in ``to_unit``.

    Identical units give 1 (even custom ones such as ``"px"``); converting between a
    custom unit and another unit raises :class:`UnitError`.

    Examples
    --------
    >>> round(length_factor("in", "mm"), 6)
    25.4
    >>> round(length_factor("mm", "m"), 6)
    0.001
    >>> length_factor("px", "px")
    1.0
    """
    if from_unit == to_unit:
        return 1.0
    factors = []
    for unit in (from_unit, to_unit):
        entry = UNITS.get(unit) if isinstance(unit, str) else None
        if entry is None or entry[0] is not Kind.LENGTH:
            raise UnitError(
                f"cannot convert length from {from_unit!r} to {to_unit!r}: {unit!r} is not a "
                f"known length unit (known: {', '.join(_LENGTHS)})",
                text=str(unit),
                kind=Kind.LENGTH,
            )
        factors.append(entry[1])
    return factors[0] / factors[1]


def validate_units(angle_unit: str, length_unit: str) -> None:
    """Check a model's display units; raise :class:`UnitError` when invalid.

    ``angle_unit`` must be ``'deg'`` or ``'rad'``.  ``length_unit`` may be a known length
    unit (mm, cm, m, in, inch, ft) or any identifier-like name (``"px"``, ``"units"``)
    used only for display; it must not be a unit of another kind.

    Examples
    --------
    >>> validate_units("deg", "mm")
    >>> validate_units("rad", "px")
    >>> try:
    ...     validate_units("grad", "mm")
    ... except UnitError as exc:
    ...     print(exc)
    angle_unit must be one of deg, rad (got 'grad')
    """
    if angle_unit not in MODEL_ANGLE_UNITS:
        raise UnitError(
            f"angle_unit must be one of {', '.join(MODEL_ANGLE_UNITS)} (got {angle_unit!r})",
            where="angle_unit",
            text=str(angle_unit),
            kind=Kind.ANGLE,
        )
    if not isinstance(length_unit, str) or not _IDENT_RE.match(length_unit):
        raise UnitError(
            f"length_unit must be a unit name such as mm, cm, m, in, ft (got {length_unit!r})",
            where="length_unit",
            text=str(length_unit),
            kind=Kind.LENGTH,
        )
    entry = UNITS.get(length_unit)
    if entry is not None and entry[0] is not Kind.LENGTH:
        raise UnitError(
            f"length_unit {length_unit!r} is {_a(entry[0].value)} unit, not a length unit",
            where="length_unit",
            text=length_unit,
            kind=Kind.LENGTH,
        )


def _kind_error(kind: Kind, text: str, where: str, length_unit: str, detail: str) -> UnitError:
    accepted = units_of_kind(kind, length_unit) if kind is not Kind.DIMENSIONLESS else ()
    accepted_text = ", ".join(accepted) if accepted else "none (give a plain number)"
    return UnitError(
        f"{_prefix(where)}{detail} in {text!r}; expected {_a(kind.value)}, "
        f"accepted units: {accepted_text}",
        where=where,
        text=text,
        kind=kind,
    )


#: an angle of at least this many turns is reduced modulo a turn, exactly in its own unit,
#: before it is converted to radians (below it the conversion keeps ~1e-10 rad; above it the
#: number of whole turns would swamp the digits of the angle within the turn)
REDUCE_TURNS = 2**16

#: turns per unit for the angle units whose turn is a rational number of units
_TURN = {"deg": 360, "degree": 360, "degrees": 360, "°": 360, "rev": 1, "turn": 1}


def _reduce_angle(number: float, text: str | None, unit: str) -> float:
    """``number`` (an angle in ``unit``) reduced modulo a turn when it is huge, still in ``unit``.

    Degrees and turns are reduced exactly: from the decimal ``text`` when given (``"1e17"`` is
    exactly 280 degrees modulo 360), else with :func:`math.fmod` (exact for floats). Radians
    are reduced through ``atan2(sin x, cos x)``, which uses the platform's exact argument
    reduction of the float ``x``.
    """
    turn = _TURN.get(unit)
    if turn is None:  # radians
        if abs(number) < REDUCE_TURNS * _TWO_PI:
            return number
        return math.atan2(math.sin(number), math.cos(number))
    if abs(number) < REDUCE_TURNS * turn:
        return number
    if text is not None:
        try:
            exact = Fraction(text)
        except (ValueError, ZeroDivisionError):
            return math.fmod(number, turn)
        return math.copysign(float(abs(exact) % turn), exact)
    return math.fmod(number, turn)


#: largest magnitude of a length, a rate or a plain number (angles are reduced modulo a turn
#: instead): beyond it the squares and products the solver forms overflow floating point
MAX_MAGNITUDE = 1e100


def _finite(value: float, kind: Kind, text: str, where: str, length_unit: str) -> float:
    if not math.isfinite(value):
        raise _kind_error(kind, text, where, length_unit,
                          "value overflows (not finite) after conversion to internal units")
    if kind is not Kind.ANGLE and abs(value) > MAX_MAGNITUDE:
        raise _kind_error(kind, text, where, length_unit,
                          f"value {value:.3g} is beyond ±{MAX_MAGNITUDE:g} (the solver's squares and "
                          "products would overflow; use a larger unit)")
    return value


def _plain(value: float, kind: Kind, angle_unit: str, text: str | None = None, where: str = "",
           length_unit: str = "mm", reduce: bool = True) -> float:
    """Convert a plain number in the display unit of ``kind`` to internal units."""
    if kind is Kind.ANGLE:
        if reduce:
            value = _reduce_angle(value, text, angle_unit)
        return _finite(value * angle_factor(angle_unit), kind, text or repr(value), where, length_unit)
    return _finite(value, kind, text if text is not None else repr(value), where, length_unit)


def parse_quantity(
    value: object,
    kind: Kind,
    *,
    angle_unit: str = "deg",
    length_unit: str = "mm",
    where: str = "",
    reduce: bool = True,
) -> float:
    """Parse a quantity and return it in internal units.

    Parameters
    ----------
    value : int, float or str
        A plain number (in the display unit of ``kind``: ``angle_unit`` for angles,
        rad/s, rad/s², rad/s³ for angular rates, ``length_unit`` based for lengths) or a
        string such as ``"10rpm"``, ``"10 rpm"``, ``"90deg"``, ``"-3.5"``, ``"1.2 m/s"``.
    kind : Kind
        The expected kind.
    angle_unit, length_unit : str
        The model's display units.
    where : str
        Name of the field, used in error messages (e.g. ``'variables.theta2.speed'``).
    reduce : bool
        Reduce an angle of :data:`REDUCE_TURNS` turns or more modulo a turn, exactly in its
        own unit, before converting it (``"1e17"`` degrees is 280°). Pass ``False`` for an
        angle *increment* such as a sweep step.

    Returns
    -------
    float
        Radians (rad/s, ...) for angular kinds; ``length_unit`` (per s, ...) for lengths.

    Raises
    ------
    UnitError
        Unknown unit, unit of the wrong kind, non-finite number, bool or garbage.

    Examples
    --------
    >>> round(parse_quantity("10rpm", Kind.ANGULAR_RATE), 6)
    1.047198
    >>> round(parse_quantity(90, Kind.ANGLE), 6)
    1.570796
    >>> parse_quantity("0.1m", Kind.LENGTH)
    100.0
    >>> round(parse_quantity("1.2 m/s", Kind.LENGTH_RATE), 6)
    1200.0
    >>> try:
    ...     parse_quantity("5mm", Kind.ANGULAR_RATE, where="speed")
    ... except UnitError as exc:
    ...     print(exc)
    speed: unit 'mm' is a length unit, not an angular rate in '5mm'; expected an angular rate, accepted units: rad/s, deg/s, rpm, rps, rev/s
    """
    if not isinstance(kind, Kind):
        raise TypeError(f"kind must be a Kind, got {kind!r}")
    validate_units(angle_unit, length_unit)
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, str)):
        raise _kind_error(
            kind, repr(value), where, length_unit,
            f"expected a number or a string with a unit, got {type(value).__name__} {value!r}",
        )
    if isinstance(value, numbers.Real):
        try:
            number = float(value)
        except OverflowError:
            number = math.inf
        if not math.isfinite(number):
            raise _kind_error(kind, _short(value), where, length_unit, "value is not finite")
        exact = str(value) if isinstance(value, numbers.Integral) else None
        return _plain(number, kind, angle_unit, exact, where, length_unit, reduce)

    text = value
    m = _QUANTITY_RE.match(text)
    if m is None:
        raise _kind_error(kind, text, where, length_unit, "cannot read a number")
    number = float(m.group("num"))
    if not math.isfinite(number):
        raise _kind_error(kind, text, where, length_unit, "value is not finite")
    unit = m.group("unit")
    if not unit:
        return _plain(number, kind, angle_unit, m.group("num"), where, length_unit, reduce)

    entry = UNITS.get(unit)
    if entry is None:
        order = _custom_length_base(unit, length_unit) if length_unit not in UNITS else None
        if order is not None:
            custom_kind = _BY_ORDER_LENGTH[order]
            if custom_kind is kind:
                return _finite(number, kind, text, where, length_unit)
            raise _kind_error(
                kind, text, where, length_unit,
                f"unit {unit!r} is {_a(custom_kind.value)} unit, not {_a(kind.value)}",
            )
        hint = ""
        lowered = {u.lower(): u for u in UNITS}
        if unit.lower() in lowered:
            hint = f" (did you mean {lowered[unit.lower()]!r}?)"
        raise _kind_error(kind, text, where, length_unit, f"unknown unit {unit!r}{hint}")

    got_kind, factor = entry
    if got_kind is not kind:
        raise _kind_error(
            kind, text, where, length_unit,
            f"unit {unit!r} is {_a(got_kind.value)} unit, not {_a(kind.value)}",
        )
    if kind is Kind.ANGLE and reduce:
        number = _reduce_angle(number, m.group("num"), unit)
    if kind.is_angular:
        return _finite(number * factor, kind, text, where, length_unit)
    # a length kind: the table factor is metres based; convert to the model's length unit
    if length_unit not in UNITS:
        raise UnitError(
            f"{_prefix(where)}cannot convert {unit!r} in {text!r} to the custom length unit "
            f"{length_unit!r}; give the value in {length_unit} (a plain number)",
            where=where,
            text=text,
            kind=kind,
        )
    return _finite(number * factor / UNITS[length_unit][1], kind, text, where, length_unit)


def _short(value: object, limit: int = 40) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def unit_label(kind: Kind, angle_unit: str = "deg", length_unit: str = "mm") -> str:
    """Unit label for table headers, e.g. ``'deg'``, ``'rad/s^2'``, ``'mm/s'``.

    Examples
    --------
    >>> unit_label(Kind.ANGLE, "deg", "mm")
    'deg'
    >>> unit_label(Kind.ANGULAR_ACCEL, "deg", "mm")
    'rad/s^2'
    >>> unit_label(Kind.LENGTH_RATE, "deg", "mm")
    'mm/s'
    """
    if kind is Kind.ANGLE:
        return angle_unit
    if kind is Kind.DIMENSIONLESS:
        return ""
    order = _ORDER[kind]
    base = "rad" if kind.is_angular else length_unit
    return base + ("/s", "/s^2", "/s^3")[order - 1] if order else base


def to_display(value_internal, kind: Kind, angle_unit: str = "deg", length_unit: str = "mm"):
    """Convert an internal value to its display unit (the inverse of a plain number).

    Angles go from radians to ``angle_unit``; rates stay radian based; lengths are
    already in ``length_unit``.  Works element-wise on numpy arrays too.

    Examples
    --------
    >>> round(to_display(math.pi / 2, Kind.ANGLE), 6)
    90.0
    >>> to_display(2.5, Kind.ANGULAR_RATE)
    2.5
    """
    if kind is Kind.ANGLE:
        return value_internal / angle_factor(angle_unit)
    return value_internal
