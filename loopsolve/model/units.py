"""Quantities with units: one parser for every quantity of a model file, the CLI and Python.

A quantity is a plain number or a number with a unit (``"10rpm"``, ``"90 deg"``, ``"1.2 m/s"``,
``"12 in*lbf"``, ``"0.5 slug*ft^2"``). Every :class:`Kind` accepts *any* unit of its dimension,
converted exactly: the units library (pint, through :mod:`loopsolve.model.unitlib`) says what a unit is
by dimensional analysis, so no spelling is listed here. A unit of another dimension is an error
naming the field, the value, the expected kind and examples of its units.

Internal units (what :func:`parse_quantity` returns):

* angular kinds (angle, angular rate, acceleration, jerk) are radian based (rad, rad/s, ...);
* length kinds are in the model's length unit (``length_unit``, e.g. mm) and its rates per second;
* the mechanical kinds (mass, inertia, force, torque, stiffness, damping, torsional stiffness and
  damping, acceleration of gravity, density, time) are SI (kg, kg·m², N, N·m, N/m, N·s/m, ...).

Plain numbers keep their documented meaning: angles are in the model's ``angle_unit`` (degrees by
default), angular rates rad/s (rad/s², rad/s³), lengths the model's length unit; masses, forces
and times SI; a kind whose SI unit is written with the metre (inertia, torque, stiffness, damping,
torsional stiffness and damping, gravity, density) is SI in a metre model and **refused** in any
other (``inertia = 1000`` in a mm model: kg·m² or kg·mm²?), naming the field and the units to
write — except 0, which is 0 in every unit.

Nothing here evaluates user text as code: a string is split into a number and a unit by a
regular expression, and the unit is read by the units library's parser.
"""

from __future__ import annotations

import enum
import math
import numbers
import re
import sys
from fractions import Fraction
from typing import Mapping

from loopsolve.errors import ModelError
from .unitlib import UnitInfo, lookup, refusal

__all__ = [
    "Kind",
    "UnitError",
    "MODEL_ANGLE_UNITS",
    "unit_kind",
    "unit_info",
    "units_of_kind",
    "parse_quantity",
    "angle_factor",
    "length_factor",
    "is_physical_length",
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
    MASS = "mass"
    INERTIA = "inertia"
    FORCE = "force"
    TORQUE = "torque"
    STIFFNESS = "stiffness"
    DAMPING = "damping"
    TORSIONAL_STIFFNESS = "torsional stiffness"
    TORSIONAL_DAMPING = "torsional damping"
    ACCELERATION = "acceleration"
    DENSITY = "density"
    TIME = "time"

    @property
    def is_angular(self) -> bool:
        """True for the four radian-based kinds."""
        return self in _ANGULAR_KINDS

    @property
    def is_length(self) -> bool:
        """True for the four length-based kinds (in the model's length unit)."""
        return self in _LENGTH_KINDS

    @property
    def is_mechanical(self) -> bool:
        """True for the SI kinds of mass properties and loads."""
        return self in _SI_LABEL

    @property
    def dimension(self) -> tuple[tuple[str, Fraction], ...]:
        """Powers of the base dimensions, as :class:`loopsolve.model.unitlib.UnitInfo` gives them."""
        return _DIMS[self]


_ANGULAR_KINDS = frozenset({Kind.ANGLE, Kind.ANGULAR_RATE, Kind.ANGULAR_ACCEL, Kind.ANGULAR_JERK})
_LENGTH_KINDS = frozenset({Kind.LENGTH, Kind.LENGTH_RATE, Kind.LENGTH_ACCEL, Kind.LENGTH_JERK})

# order of the time derivative of each kinematic kind
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


def _dims(**powers: int) -> tuple[tuple[str, Fraction], ...]:
    return tuple(sorted((d, Fraction(p)) for d, p in powers.items() if p))


_DIMS = {
    **{k: _dims(length=1, time=-o) for k, o in _ORDER.items() if k in _LENGTH_KINDS},
    **{k: _dims(angle=1, time=-o) for k, o in _ORDER.items() if k in _ANGULAR_KINDS},
    Kind.DIMENSIONLESS: (),
    Kind.MASS: _dims(mass=1),
    Kind.INERTIA: _dims(mass=1, length=2),
    Kind.FORCE: _dims(mass=1, length=1, time=-2),
    Kind.TORQUE: _dims(mass=1, length=2, time=-2),
    Kind.STIFFNESS: _dims(mass=1, time=-2),
    Kind.DAMPING: _dims(mass=1, time=-1),
    Kind.TORSIONAL_STIFFNESS: _dims(mass=1, length=2, time=-2, angle=-1),
    Kind.TORSIONAL_DAMPING: _dims(mass=1, length=2, time=-1, angle=-1),
    Kind.ACCELERATION: _dims(length=1, time=-2),
    Kind.DENSITY: _dims(mass=1, length=-3),
    Kind.TIME: _dims(time=1),
}

#: the SI unit of each mechanical kind (what a plain number means, where it is not ambiguous)
_SI_LABEL = {
    Kind.MASS: "kg", Kind.INERTIA: "kg*m^2", Kind.FORCE: "N", Kind.TORQUE: "N*m", Kind.STIFFNESS: "N/m",
    Kind.DAMPING: "N*s/m", Kind.TORSIONAL_STIFFNESS: "N*m/rad", Kind.TORSIONAL_DAMPING: "N*m*s/rad",
    Kind.ACCELERATION: "m/s^2", Kind.DENSITY: "kg/m^3", Kind.TIME: "s",
}
#: the same unit with the metre replaced by the model's length unit (``{L}``), for suggestions
_SI_WITH_LENGTH = {
    Kind.INERTIA: "kg*{L}^2", Kind.TORQUE: "N*{L}", Kind.STIFFNESS: "N/{L}", Kind.DAMPING: "N*s/{L}",
    Kind.TORSIONAL_STIFFNESS: "N*{L}/rad", Kind.TORSIONAL_DAMPING: "N*{L}*s/rad",
    Kind.ACCELERATION: "{L}/s^2", Kind.DENSITY: "kg/{L}^3",
}

#: examples of units of each kind, for messages and documentation (any unit of the dimension is
#: accepted: these are not a list of what is)
_EXAMPLES: Mapping[Kind, tuple[str, ...]] = {
    Kind.LENGTH: ("mm", "cm", "m", "in", "ft", "µm"),
    Kind.LENGTH_RATE: ("mm/s", "m/s", "in/s", "ft/min"),
    Kind.LENGTH_ACCEL: ("mm/s^2", "m/s^2", "in/s^2", "cm/s²"),
    Kind.LENGTH_JERK: ("mm/s^3", "m/s^3", "in/s^3"),
    Kind.ANGLE: ("deg", "degree", "°", "rad", "rev", "turn", "arcmin"),
    Kind.ANGULAR_RATE: ("rad/s", "deg/s", "rpm", "rev/min", "rev/s", "°/s"),
    Kind.ANGULAR_ACCEL: ("rad/s^2", "deg/s^2", "rpm/s"),
    Kind.ANGULAR_JERK: ("rad/s^3", "deg/s^3"),
    Kind.DIMENSIONLESS: (),
    Kind.MASS: ("kg", "g", "t", "lb", "slug", "blob"),
    Kind.INERTIA: ("kg*m^2", "kg*mm^2", "g*cm^2", "lb*in^2", "slug*ft^2", "blob*in^2"),
    Kind.FORCE: ("N", "kN", "lbf", "kgf"),
    Kind.TORQUE: ("N*m", "N*mm", "kN*m", "in*lbf", "ft*lbf"),
    Kind.STIFFNESS: ("N/m", "N/mm", "kN/m", "lbf/in"),
    Kind.DAMPING: ("N*s/m", "N*s/mm", "lbf*s/in"),
    Kind.TORSIONAL_STIFFNESS: ("N*m/rad", "N*mm/deg", "in*lbf/rad"),
    Kind.TORSIONAL_DAMPING: ("N*m*s/rad", "N*mm*s/rad", "in*lbf*s/rad"),
    Kind.ACCELERATION: ("m/s^2", "mm/s^2", "ft/s^2", "in/s^2"),
    Kind.DENSITY: ("kg/m^3", "g/cm^3", "lb/in^3"),
    Kind.TIME: ("s", "ms", "min"),
}

_PER_TIME = {1: "/s", 2: "/s^2", 3: "/s^3"}
_BY_ORDER_LENGTH = {v: k for k, v in _ORDER.items() if k.is_length}

#: angle units a model may declare as its display angle unit
MODEL_ANGLE_UNITS: tuple[str, ...] = ("deg", "rad")

_IDENT_RE = re.compile(r"[A-Za-zµμ][A-Za-z0-9_]*\Z")
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


def unit_info(unit: str) -> UnitInfo | None:
    """What the units library knows of ``unit`` (dimension, exact SI size), ``None`` if not a unit."""
    return lookup(unit)


def _kind_of_dims(info: UnitInfo) -> Kind | None:
    for kind, dims in _DIMS.items():  # kinematic kinds first: m/s^2 is a length acceleration
        if dims == info.dims and kind is not Kind.DIMENSIONLESS:
            return kind
    return None


def unit_kind(unit: str) -> Kind:
    """Return the :class:`Kind` of a unit (the first kind of its dimension).

    Examples
    --------
    >>> unit_kind("rpm")
    <Kind.ANGULAR_RATE: 'angular rate'>
    >>> unit_kind("mm/s^2").name
    'LENGTH_ACCEL'
    >>> unit_kind("in*lbf").name
    'TORQUE'
    """
    info = lookup(unit) if isinstance(unit, str) else None
    kind = _kind_of_dims(info) if info is not None else None
    if kind is None:
        raise UnitError(f"unknown unit {unit!r}" if info is None else
                        f"unit {unit!r} ({info.dimension_text()}) is not a unit of any quantity loopsolve reads",
                        text=str(unit))
    return kind


def units_of_kind(kind: Kind, length_unit: str | None = None) -> tuple[str, ...]:
    """Examples of units of ``kind`` (every unit of the same dimension is accepted).

    A custom ``length_unit`` (one the units library does not know as a length, e.g.
    ``"units"``) is added to the length kinds with its ``/s``, ``/s^2``, ``/s^3`` forms.

    Examples
    --------
    >>> units_of_kind(Kind.ANGULAR_RATE)
    ('rad/s', 'deg/s', 'rpm', 'rev/min', 'rev/s', '°/s')
    >>> units_of_kind(Kind.LENGTH, "units")[-1]
    'units'
    """
    found = list(_EXAMPLES[kind])
    if kind.is_length and length_unit and not is_physical_length(length_unit):
        order = _ORDER[kind]
        found.append(length_unit + _PER_TIME[order] if order else length_unit)
    return tuple(found)


def is_physical_length(unit: str) -> bool:
    """Whether ``unit`` is a length the units library converts (mm, in, ...), not a display-only name.

    Examples
    --------
    >>> is_physical_length("in"), is_physical_length("units")
    (True, False)
    """
    info = lookup(unit) if isinstance(unit, str) else None
    return info is not None and info.dims == _DIMS[Kind.LENGTH]


def angle_factor(angle_unit: str) -> float:
    """Radians per ``angle_unit`` (``'deg'`` -> pi/180, ``'rad'`` -> 1).

    Examples
    --------
    >>> round(angle_factor("deg"), 6)
    0.017453
    >>> angle_factor("rad")
    1.0
    """
    info = lookup(angle_unit) if isinstance(angle_unit, str) else None
    if info is None or info.dims != _DIMS[Kind.ANGLE]:
        raise UnitError(
            f"unknown angle unit {angle_unit!r} (e.g. {', '.join(units_of_kind(Kind.ANGLE))})",
            text=str(angle_unit),
            kind=Kind.ANGLE,
        )
    return info.si_factor


def length_factor(from_unit: str, to_unit: str) -> float:
    """Factor ``f`` such that a length ``x`` in ``from_unit`` is ``x * f`` in ``to_unit``.

    Identical units give 1 (even custom ones such as ``"units"``); converting between a
    custom unit and another unit raises :class:`UnitError`.

    Examples
    --------
    >>> length_factor("in", "mm")
    25.4
    >>> length_factor("mm", "m")
    0.001
    >>> length_factor("units", "units")
    1.0
    """
    if from_unit == to_unit:
        return 1.0
    infos = []
    for unit in (from_unit, to_unit):
        if not is_physical_length(unit):
            raise UnitError(
                f"cannot convert length from {from_unit!r} to {to_unit!r}: {unit!r} is not a "
                f"length unit (e.g. {', '.join(_EXAMPLES[Kind.LENGTH])})",
                text=str(unit),
                kind=Kind.LENGTH,
            )
        infos.append(lookup(unit))
    return infos[0].factor_to(infos[1])


def validate_units(angle_unit: str, length_unit: str) -> None:
    """Check a model's display units; raise :class:`UnitError` when invalid.

    ``angle_unit`` must be ``'deg'`` or ``'rad'``.  ``length_unit`` may be any length unit
    (mm, cm, m, in, ft, µm, ...) or any identifier-like name (``"units"``) used only for
    display; it must not be a unit of another kind loopsolve reads (an angle, a rate, a mass...).

    Examples
    --------
    >>> validate_units("deg", "mm")
    >>> validate_units("rad", "units")
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
    info = lookup(length_unit)
    other = _kind_of_dims(info) if info is not None else None
    if other is not None and other is not Kind.LENGTH:
        raise UnitError(
            f"length_unit {length_unit!r} is {_a(other.value)} unit, not a length unit",
            where="length_unit",
            text=length_unit,
            kind=Kind.LENGTH,
        )


def _kind_error(kind: Kind, text: str, where: str, length_unit: str, detail: str) -> UnitError:
    accepted = units_of_kind(kind, length_unit) if kind is not Kind.DIMENSIONLESS else ()
    accepted_text = ("any " + kind.value + " unit, e.g. " + ", ".join(accepted)) if accepted \
        else "none (give a plain number)"
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


def _turn_in(info: UnitInfo | None) -> Fraction | None:
    """How many of the angle unit ``info`` make a turn, when that is rational (360 for deg)."""
    turn = lookup("turn")
    if info is None or turn is None or info.pi_power != turn.pi_power:
        return None  # radians: a turn is 2π of them
    return turn.ratio / info.ratio


def _reduce_angle(number: float, text: str | None, unit_turn: Fraction | None) -> float:
    """``number`` (an angle in a unit of which ``unit_turn`` make a turn, ``None`` for the radian)
    reduced modulo a turn when it is huge, still in its unit.

    Units with a rational turn (degrees, turns) are reduced exactly: from the decimal ``text``
    when given (``"1e17"`` is exactly 280 degrees modulo 360), else with :func:`math.fmod` (exact
    for floats). Radians are reduced through ``atan2(sin x, cos x)``, which uses the platform's
    exact argument reduction of the float ``x``.
    """
    if unit_turn is None:  # radians
        if abs(number) < REDUCE_TURNS * 2.0 * math.pi:
            return number
        return math.atan2(math.sin(number), math.cos(number))
    if abs(number) < REDUCE_TURNS * unit_turn:
        return number
    if text is not None:
        try:
            exact = Fraction(text)
        except (ValueError, ZeroDivisionError):
            return math.fmod(number, unit_turn)
        return math.copysign(float(abs(exact) % unit_turn), exact)
    return math.fmod(number, unit_turn) if unit_turn.denominator == 1 else math.fmod(number, float(unit_turn))


#: largest magnitude of a length, a rate or a plain number (angles are reduced modulo a turn
#: instead): beyond it the squares and products the solver forms overflow floating point
MAX_MAGNITUDE = 1e100


def _finite(value: float, kind: Kind, text: str, where: str, length_unit: str, given: float = 0.0) -> float:
    """``value`` (converted from the number ``given`` with a unit's factor) checked: finite, within
    ±MAX_MAGNITUDE, and not flushed from a normal float to zero or below the normal floats by the
    conversion (a plain number in a display unit, whose factor is ordinary, is not checked for that:
    a tiny angle is a tiny angle)."""
    if not math.isfinite(value):
        raise _kind_error(kind, text, where, length_unit,
                          "value overflows (not finite) after conversion to internal units")
    if abs(given) >= sys.float_info.min and abs(value) < sys.float_info.min:
        raise _kind_error(kind, text, where, length_unit,
                          "value underflows (becomes 0 or subnormal) after conversion to internal units; "
                          "use a smaller unit")
    if kind is not Kind.ANGLE and abs(value) > MAX_MAGNITUDE:
        raise _kind_error(kind, text, where, length_unit,
                          f"value {value:.3g} is beyond ±{MAX_MAGNITUDE:g} (the solver's squares and "
                          "products would overflow; use a larger unit)")
    return value


def _metre_model(length_unit: str) -> bool:
    info = lookup(length_unit)
    return info is not None and info.dims == _DIMS[Kind.LENGTH] and info.ratio == 1 and info.pi_power == 0


def _plain(value: float, kind: Kind, angle_unit: str, text: str | None = None, where: str = "",
           length_unit: str = "mm", reduce: bool = True) -> float:
    """Convert a plain number in the display unit of ``kind`` to internal units."""
    shown = text if text is not None else repr(value)
    if kind is Kind.ANGLE:
        if reduce:
            value = _reduce_angle(value, text, _turn_in(lookup(angle_unit)))
        return _finite(value * angle_factor(angle_unit), kind, shown, where, length_unit)
    if kind in _SI_WITH_LENGTH and value != 0 and not _metre_model(length_unit):
        si = _SI_LABEL[kind]
        model = _SI_WITH_LENGTH[kind].format(L=length_unit)
        raise UnitError(
            f"{_prefix(where)}the plain number {shown} is ambiguous in a model whose length unit is "
            f"{length_unit} ({si}? {model}?): write the unit, e.g. \"{shown}{si}\" or \"{shown}{model}\"",
            where=where, text=shown, kind=kind)
    return _finite(value, kind, shown, where, length_unit)


def _custom_length_order(unit: str, length_unit: str) -> int | None:
    """Derivative order of ``unit`` when it is the custom ``length_unit`` (+ /s, /s^2 ...)."""
    if unit == length_unit:
        return 0
    if not unit.startswith(length_unit + "/"):
        return None
    same = lookup("m" + unit[len(length_unit):])  # the metre in its place: m/s, m/s^2 ...
    for order in (1, 2, 3):
        if same is not None and same.dims == _DIMS[_BY_ORDER_LENGTH[order]] and same.ratio == 1:
            return order
    return None


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
        A plain number (see the module's notes for its meaning per kind) or a string such as
        ``"10rpm"``, ``"10 rpm"``, ``"90deg"``, ``"-3.5"``, ``"1.2 m/s"``, ``"12 in*lbf"``.
    kind : Kind
        The expected kind; any unit of its dimension is accepted.
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
        Radians (rad/s, ...) for angular kinds; ``length_unit`` (per s, ...) for lengths; SI for
        the mechanical kinds.

    Raises
    ------
    UnitError
        Unknown unit, unit of another dimension, ambiguous plain number, non-finite number,
        bool or garbage.

    Examples
    --------
    >>> round(parse_quantity("10rpm", Kind.ANGULAR_RATE), 6)
    1.047198
    >>> round(parse_quantity(90, Kind.ANGLE), 6)
    1.570796
    >>> parse_quantity("0.1m", Kind.LENGTH)
    100.0
    >>> round(parse_quantity("12 in*lbf", Kind.TORQUE), 6)
    1.355818
    >>> try:
    ...     parse_quantity("5mm", Kind.ANGULAR_RATE, where="speed")
    ... except UnitError as exc:
    ...     print(exc)
    speed: unit 'mm' is a length unit, not an angular rate in '5mm'; expected an angular rate, accepted units: any angular rate unit, e.g. rad/s, deg/s, rpm, rev/min, rev/s, °/s
    >>> try:
    ...     parse_quantity(1000, Kind.INERTIA, length_unit="mm", where="bodies.crank.inertia")
    ... except UnitError as exc:
    ...     print(exc)
    bodies.crank.inertia: the plain number 1000 is ambiguous in a model whose length unit is mm (kg*m^2? kg*mm^2?): write the unit, e.g. "1000kg*m^2" or "1000kg*mm^2"
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

    if kind.is_length and not is_physical_length(length_unit):
        order = _custom_length_order(unit, length_unit)
        if order is not None:
            custom_kind = _BY_ORDER_LENGTH[order]
            if custom_kind is kind:
                return _finite(number, kind, text, where, length_unit)
            raise _kind_error(
                kind, text, where, length_unit,
                f"unit {unit!r} is {_a(custom_kind.value)} unit, not {_a(kind.value)}",
            )
    info = lookup(unit)
    if info is None:
        why = refusal(unit)
        if why is not None:
            raise _kind_error(kind, text, where, length_unit, f"unit {unit!r} is refused: {why}")
        hint = ""
        for guess in (unit.lower(), unit.strip().replace(" ", "")):
            if guess != unit and lookup(guess) is not None:
                hint = f" (did you mean {guess!r}?)"
                break
        raise _kind_error(kind, text, where, length_unit, f"unknown unit {unit!r}{hint}")
    if info.dims != _DIMS[kind]:
        got = _kind_of_dims(info)
        what = f"{_a(got.value)} unit" if got is not None else f"a unit of {info.dimension_text()}"
        raise _kind_error(kind, text, where, length_unit, f"unit {unit!r} is {what}, not {_a(kind.value)}")
    if kind is Kind.ANGLE and reduce:
        number = _reduce_angle(number, m.group("num"), _turn_in(info))
    if not kind.is_length:
        return _finite(number * info.si_factor, kind, text, where, length_unit, number)
    # a length kind: converted to the model's length unit
    if not is_physical_length(length_unit):
        raise UnitError(
            f"{_prefix(where)}cannot convert {unit!r} in {text!r} to the custom length unit "
            f"{length_unit!r}; give the value in {length_unit} (a plain number)",
            where=where,
            text=text,
            kind=kind,
        )
    return _finite(number * info.factor_to(lookup(length_unit)), kind, text, where, length_unit, number)


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
    if kind in _SI_LABEL:
        return _SI_LABEL[kind]
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
