"""Tests of quantities with units, :mod:`loopsolve.model.units`."""

from __future__ import annotations

import math

import pytest

from loopsolve.errors import ModelError
from loopsolve.model.units import (
    Kind,
    UnitError,
    angle_factor,
    length_factor,
    parse_quantity,
    to_display,
    unit_kind,
    unit_label,
    units_of_kind,
    validate_units,
)

TWO_PI = 2 * math.pi
DEG = math.pi / 180


@pytest.mark.parametrize(
    "value, kind, expected",
    [
        # angles -> radians
        ("90deg", Kind.ANGLE, math.pi / 2),
        ("90 deg", Kind.ANGLE, math.pi / 2),
        ("90degree", Kind.ANGLE, math.pi / 2),
        ("90 degrees", Kind.ANGLE, math.pi / 2),
        ("90°", Kind.ANGLE, math.pi / 2),
        ("0.5rad", Kind.ANGLE, 0.5),
        ("0.25rev", Kind.ANGLE, math.pi / 2),
        ("1 turn", Kind.ANGLE, TWO_PI),
        ("-45", Kind.ANGLE, -math.pi / 4),
        (90, Kind.ANGLE, math.pi / 2),
        (90.0, Kind.ANGLE, math.pi / 2),
        # angular rates -> rad/s
        ("10rpm", Kind.ANGULAR_RATE, 10 * TWO_PI / 60),
        ("10 rpm", Kind.ANGULAR_RATE, 10 * TWO_PI / 60),
        ("10.5rad/s", Kind.ANGULAR_RATE, 10.5),
        ("180deg/s", Kind.ANGULAR_RATE, math.pi),
        ("2rps", Kind.ANGULAR_RATE, 2 * TWO_PI),
        ("2rev/s", Kind.ANGULAR_RATE, 2 * TWO_PI),
        (3, Kind.ANGULAR_RATE, 3.0),
        ("-3.5", Kind.ANGULAR_RATE, -3.5),
        ("1e1", Kind.ANGULAR_RATE, 10.0),
        # angular accel/jerk
        ("2rad/s^2", Kind.ANGULAR_ACCEL, 2.0),
        ("2rad/s2", Kind.ANGULAR_ACCEL, 2.0),
        ("2rad/s²", Kind.ANGULAR_ACCEL, 2.0),
        ("90deg/s^2", Kind.ANGULAR_ACCEL, math.pi / 2),
        ("90deg/s²", Kind.ANGULAR_ACCEL, math.pi / 2),
        ("4 rad/s^3", Kind.ANGULAR_JERK, 4.0),
        ("4rad/s³", Kind.ANGULAR_JERK, 4.0),
        ("90deg/s^3", Kind.ANGULAR_JERK, math.pi / 2),
        (4, Kind.ANGULAR_JERK, 4.0),
        # lengths -> model length unit (mm)
        ("25mm", Kind.LENGTH, 25.0),
        ("1in", Kind.LENGTH, 25.4),
        ("1 inch", Kind.LENGTH, 25.4),
        ("0.1m", Kind.LENGTH, 100.0),
        ("2cm", Kind.LENGTH, 20.0),
        ("1ft", Kind.LENGTH, 304.8),
        (12, Kind.LENGTH, 12.0),
        ("12", Kind.LENGTH, 12.0),
        ("1.2 m/s", Kind.LENGTH_RATE, 1200.0),
        ("5mm/s", Kind.LENGTH_RATE, 5.0),
        ("2 m/s^2", Kind.LENGTH_ACCEL, 2000.0),
        ("2m/s²", Kind.LENGTH_ACCEL, 2000.0),
        ("3m/s^3", Kind.LENGTH_JERK, 3000.0),
        ("3 in/s³", Kind.LENGTH_JERK, 3 * 25.4),
        # dimensionless
        (2.5, Kind.DIMENSIONLESS, 2.5),
        ("2.5", Kind.DIMENSIONLESS, 2.5),
    ],
)
def test_parse_quantity(value, kind, expected):
    assert parse_quantity(value, kind) == pytest.approx(expected)


def test_angle_unit_rad_plain_numbers():
    assert parse_quantity(1.5, Kind.ANGLE, angle_unit="rad") == 1.5
    assert parse_quantity("90deg", Kind.ANGLE, angle_unit="rad") == pytest.approx(math.pi / 2)
    # plain angular rates are rad/s whatever the angle unit
    assert parse_quantity(2, Kind.ANGULAR_RATE, angle_unit="deg") == 2.0


@pytest.mark.parametrize(
    "value, length_unit, expected",
    [
        ("0.1m", "mm", 100.0),
        ("25.4mm", "in", 1.0),
        ("1ft", "in", 12.0),
        ("100mm", "m", 0.1),
        (7, "m", 7.0),
        ("7", "px", 7.0),
        ("7px", "px", 7.0),
        ("7px/s", "px", 7.0),
        ("7 px/s^2", "px", 7.0),
    ],
)
def test_length_unit_of_model(value, length_unit, expected):
    kind = Kind.LENGTH
    if isinstance(value, str) and "/s^2" in value:
        kind = Kind.LENGTH_ACCEL
    elif isinstance(value, str) and "/s" in value:
        kind = Kind.LENGTH_RATE
    assert parse_quantity(value, kind, length_unit=length_unit) == pytest.approx(expected)


@pytest.mark.parametrize(
    "value, kind, kwargs, fragments",
    [
        ("10rpm", Kind.ANGLE, {}, ["'rpm'", "angular rate unit", "deg, degree"]),
        ("5mm", Kind.ANGULAR_RATE, {}, ["'5mm'", "length unit", "rad/s, deg/s, rpm"]),
        ("90deg", Kind.LENGTH, {}, ["angle unit", "mm, cm, m"]),
        ("1m/s", Kind.LENGTH, {}, ["length rate unit"]),
        ("2rad/s", Kind.ANGULAR_ACCEL, {}, ["rad/s^2"]),
        ("10 blargs", Kind.LENGTH, {}, ["unknown unit 'blargs'"]),
        ("10RPM", Kind.ANGULAR_RATE, {}, ["did you mean 'rpm'"]),
        ("abc", Kind.ANGLE, {}, ["cannot read a number", "'abc'"]),
        ("", Kind.ANGLE, {}, ["cannot read a number"]),
        ("1e999", Kind.ANGLE, {}, ["not finite"]),
        ("inf", Kind.ANGLE, {}, ["cannot read a number"]),
        ("nan", Kind.ANGLE, {}, ["cannot read a number"]),
        (float("nan"), Kind.ANGLE, {}, ["not finite"]),
        (float("inf"), Kind.LENGTH, {}, ["not finite"]),
        (True, Kind.ANGLE, {}, ["bool"]),
        (None, Kind.ANGLE, {}, ["NoneType"]),
        ([1], Kind.ANGLE, {}, ["list"]),
        ("2*pi", Kind.ANGLE, {}, ["unknown unit '*pi'"]),
        ("3deg", Kind.DIMENSIONLESS, {}, ["none (give a plain number)"]),
        ("1in", Kind.LENGTH, {"length_unit": "units"}, ["custom length unit 'units'"]),
        ("5 blorps", Kind.LENGTH, {}, ["unknown unit 'blorps'"]),
        ("10Hz", Kind.ANGULAR_RATE, {}, ["'Hz'", "[time]^-1", "rpm"]),  # 1 Hz is not 1 rad/s
    ],
)
def test_parse_quantity_errors(value, kind, kwargs, fragments):
    with pytest.raises(UnitError) as info:
        parse_quantity(value, kind, where="variables.theta2.speed", **kwargs)
    message = str(info.value)
    assert message.startswith("variables.theta2.speed: ")
    for fragment in fragments:
        assert fragment in message
    assert isinstance(info.value, ModelError)
    assert info.value.where == "variables.theta2.speed"
    assert info.value.kind is kind


def test_parse_quantity_without_where():
    with pytest.raises(UnitError, match=r"^unit 'rpm'"):
        parse_quantity("1rpm", Kind.ANGLE)


def test_angle_factor():
    assert angle_factor("deg") == pytest.approx(DEG)
    assert angle_factor("rad") == 1.0
    assert angle_factor("rev") == pytest.approx(TWO_PI)
    with pytest.raises(UnitError, match="unknown angle unit 'mm'"):
        angle_factor("mm")


def test_length_factor():
    assert length_factor("in", "mm") == pytest.approx(25.4)
    assert length_factor("m", "mm") == pytest.approx(1000.0)
    assert length_factor("mm", "mm") == 1.0
    assert length_factor("px", "px") == 1.0
    with pytest.raises(UnitError, match="'units'"):
        length_factor("mm", "units")
    with pytest.raises(UnitError, match="'deg'"):
        length_factor("deg", "mm")


@pytest.mark.parametrize("angle_unit, length_unit", [("deg", "mm"), ("rad", "m"),
                                                     ("deg", "in"), ("rad", "units"),
                                                     ("deg", "px")])
def test_validate_units_ok(angle_unit, length_unit):
    """Accepted display units: no error, and quantities are then read in them."""
    assert validate_units(angle_unit, length_unit) is None
    # a plain angle is in the model's angle unit, a plain length in its length unit
    expected_angle = math.pi / 2 if angle_unit == "deg" else 90.0
    assert parse_quantity(90, Kind.ANGLE, angle_unit=angle_unit, length_unit=length_unit) == \
        pytest.approx(expected_angle, rel=1e-15)
    assert parse_quantity(2.5, Kind.LENGTH, angle_unit=angle_unit, length_unit=length_unit) == 2.5
    # the model's own length unit as a suffix is the identity, also for custom units (px)
    assert parse_quantity(f"3{length_unit}", Kind.LENGTH, angle_unit=angle_unit,
                          length_unit=length_unit) == pytest.approx(3.0, rel=1e-15)
    assert parse_quantity(f"3{length_unit}/s", Kind.LENGTH_RATE, angle_unit=angle_unit,
                          length_unit=length_unit) == pytest.approx(3.0, rel=1e-15)


@pytest.mark.parametrize(
    "angle_unit, length_unit, fragment",
    [
        ("grad", "mm", "angle_unit"),
        ("rev", "mm", "angle_unit"),
        ("deg", "", "length_unit"),
        ("deg", "1mm", "length_unit"),
        ("deg", "m m", "length_unit"),
        ("deg", "rad", "not a length unit"),
        ("deg", "rpm", "not a length unit"),
        ("deg", None, "length_unit"),
    ],
)
def test_validate_units_errors(angle_unit, length_unit, fragment):
    with pytest.raises(UnitError, match=fragment):
        validate_units(angle_unit, length_unit)


def test_parse_quantity_validates_model_units():
    with pytest.raises(UnitError, match="angle_unit"):
        parse_quantity(1, Kind.ANGLE, angle_unit="grad")


@pytest.mark.parametrize(
    "kind, angle_unit, length_unit, label",
    [
        (Kind.ANGLE, "deg", "mm", "deg"),
        (Kind.ANGLE, "rad", "mm", "rad"),
        (Kind.ANGULAR_RATE, "deg", "mm", "rad/s"),
        (Kind.ANGULAR_ACCEL, "deg", "mm", "rad/s^2"),
        (Kind.ANGULAR_JERK, "deg", "mm", "rad/s^3"),
        (Kind.LENGTH, "deg", "mm", "mm"),
        (Kind.LENGTH_RATE, "deg", "mm", "mm/s"),
        (Kind.LENGTH_ACCEL, "deg", "m", "m/s^2"),
        (Kind.LENGTH_JERK, "deg", "in", "in/s^3"),
        (Kind.DIMENSIONLESS, "deg", "mm", ""),
    ],
)
def test_unit_label(kind, angle_unit, length_unit, label):
    assert unit_label(kind, angle_unit, length_unit) == label


def test_to_display():
    assert to_display(math.pi / 2, Kind.ANGLE, "deg", "mm") == pytest.approx(90.0)
    assert to_display(1.25, Kind.ANGLE, "rad", "mm") == 1.25
    assert to_display(2.0, Kind.ANGULAR_RATE, "deg", "mm") == 2.0
    assert to_display(12.0, Kind.LENGTH, "deg", "mm") == 12.0


@pytest.mark.parametrize("angle_unit", ["deg", "rad"])
@pytest.mark.parametrize("value", [0, 1.5, -270, 1e-9])
def test_display_round_trip(angle_unit, value):
    internal = parse_quantity(value, Kind.ANGLE, angle_unit=angle_unit)
    assert to_display(internal, Kind.ANGLE, angle_unit, "mm") == pytest.approx(value)


def test_unit_kinds():
    """Kinds come from dimensions, not from a list of spellings."""
    assert unit_kind("rpm") is Kind.ANGULAR_RATE
    assert unit_kind("°") is Kind.ANGLE
    assert unit_kind("mm/s³") is Kind.LENGTH_JERK
    assert unit_kind("rev/min") is Kind.ANGULAR_RATE
    assert unit_kind("in*lbf") is Kind.TORQUE
    assert unit_kind("slug*ft^2") is Kind.INERTIA
    assert unit_kind("min") is Kind.TIME
    with pytest.raises(UnitError):
        unit_kind("Hz")  # a frequency is not an angular rate (1 Hz would be 1 rad/s, not 2π)
    with pytest.raises(UnitError, match="unknown unit 'blarg'"):
        unit_kind("blarg")
    assert units_of_kind(Kind.DIMENSIONLESS) == ()
    assert units_of_kind(Kind.LENGTH_RATE, "units")[-1] == "units/s"
    for kind in Kind:
        if kind is not Kind.DIMENSIONLESS:
            assert units_of_kind(kind)
            for example in units_of_kind(kind):  # every example of a kind is read as that kind
                assert parse_quantity(f"1{example}", kind, length_unit="m") > 0
    assert Kind.ANGULAR_ACCEL.is_angular and not Kind.ANGULAR_ACCEL.is_length
    assert Kind.LENGTH_JERK.is_length and not Kind.DIMENSIONLESS.is_angular


@pytest.mark.parametrize("value, expected_deg", [
    ("1e17", 280.0),            # 10**17 = 280 (mod 360), exactly
    (10**17, 280.0),
    (1e17, 280.0),              # the float 1e17 is the integer 10**17
    ("1e17 deg", 280.0),
    ("-1e17", -280.0),
    ("1e300", 280.0),           # 10**300 = 280 (mod 360) for every exponent >= 3
    ("100000000000000000000000361", float((10**26 + 361) % 360)),  # decimal digits beyond a double's
    ("1e17 rev", 0.0),
    ("720", 720.0),             # below the threshold nothing is reduced: multi-turn sweeps keep their turns
])
def test_huge_angles_reduced_modulo_a_turn_exactly(value, expected_deg):
    got = math.degrees(parse_quantity(value, Kind.ANGLE))
    assert got == pytest.approx(expected_deg, abs=1e-9)


@pytest.mark.parametrize("value, kind", [("1e308 m", Kind.LENGTH), ("1e101", Kind.LENGTH),
                                         ("1e200 rad/s", Kind.ANGULAR_RATE), (1e300, Kind.LENGTH_RATE)])
def test_lengths_and_rates_beyond_the_limit(value, kind):
    with pytest.raises(UnitError, match="1e\\+100|overflows"):
        parse_quantity(value, kind, where="x")
