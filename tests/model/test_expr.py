"""Tests of the safe expression parser :mod:`loopsolve.model.expr`."""

from __future__ import annotations

import math

import pytest

from loopsolve.errors import ModelError
from loopsolve.model.expr import (
    Binary,
    Call,
    Const,
    ExpressionError,
    Name,
    Num,
    Unary,
    evaluate,
    names,
    parse,
    to_text,
    walk,
)


@pytest.mark.parametrize(
    "text, expected",
    [
        ("2**3**2", 512.0),
        ("-2**2", -4.0),
        ("(-2)**2", 4.0),
        ("1-2-3", -4.0),
        ("8/4/2", 1.0),
        ("2+3*4", 14.0),
        ("(2+3)*4", 20.0),
        ("2*3**2", 18.0),
        ("-3*-2", 6.0),
        ("+-+2", -2.0),
        ("2**-1", 0.5),
        ("-2**-2", -0.25),
        ("12", 12.0),
        ("1.5", 1.5),
        (".5", 0.5),
        ("1e-3", 0.001),
        ("2.5E+2", 250.0),
        ("1.e2", 100.0),
        ("  7 \t", 7.0),
        ("a*b - c/d", 2 * 3 - 4 / 8),
        ("pi", math.pi),
        ("2*pi*a", 4 * math.pi),
    ],
)
def test_precedence_and_associativity(text, expected):
    assert evaluate(parse(text), {"a": 2.0, "b": 3.0, "c": 4.0, "d": 8.0}) == pytest.approx(
        expected
    )


def test_power_binds_tighter_than_unary_minus():
    assert parse("-x**2") == Unary("-", Binary("**", Name("x"), Num(2.0)))
    assert parse("2**3**2") == Binary("**", Num(2.0), Binary("**", Num(3.0), Num(2.0)))
    assert parse("1-2-3") == Binary("-", Binary("-", Num(1.0), Num(2.0)), Num(3.0))


@pytest.mark.parametrize(
    "text, expected",
    [
        ("sin(0.5)", math.sin(0.5)),
        ("cos(0.5)", math.cos(0.5)),
        ("tan(0.5)", math.tan(0.5)),
        ("sqrt(2)", math.sqrt(2)),
        ("asin(0.5)", math.asin(0.5)),
        ("acos(0.5)", math.acos(0.5)),
        ("atan(0.5)", math.atan(0.5)),
        ("atan2(1, -1)", math.atan2(1, -1)),
        ("abs(-3)", 3.0),
        ("sqrt(a**2 + b**2)", 5.0),
        ("sin(pi/2)**2", 1.0),
    ],
)
def test_every_allowed_function(text, expected):
    assert evaluate(parse(text), {"a": 3.0, "b": 4.0}) == pytest.approx(expected)


def test_call_tree():
    assert parse("atan2(y, x)") == Call("atan2", (Name("y"), Name("x")))
    assert parse("pi") == Const("pi")


@pytest.mark.parametrize(
    "text, value, unit",
    [
        ("30deg", 30.0, "deg"),
        ("30 deg", 30.0, "deg"),
        ("30°", 30.0, "°"),
        ("0.5rad", 0.5, "rad"),
        ("10rpm", 10.0, "rpm"),
        ("2rad/s", 2.0, "rad/s"),
        ("2rad/s^2", 2.0, "rad/s^2"),
        ("2 rad/s²", 2.0, "rad/s²"),
        ("25mm", 25.0, "mm"),
        ("3m", 3.0, "m"),
        ("1.5e3mm/s", 1500.0, "mm/s"),
        ("1rev", 1.0, "rev"),
    ],
)
def test_unit_suffix(text, value, unit):
    assert parse(text) == Num(value, unit)


def test_unit_suffix_inside_expression():
    tree = parse("theta4 + 30deg")
    assert tree == Binary("+", Name("theta4"), Num(30.0, "deg"))
    assert evaluate(tree, {"theta4": 1.0}) == pytest.approx(1.0 + math.pi / 6)
    # in degrees
    assert evaluate(tree, {"theta4": 10.0}, angle_unit_factor=math.pi / 180) == pytest.approx(
        40.0
    )


def test_unit_does_not_swallow_identifiers():
    assert parse("2*r") == Binary("*", Num(2.0), Name("r"))
    assert parse("2rad/s*t") == Binary("*", Num(2.0, "rad/s"), Name("t"))
    assert parse("3mm") == Num(3.0, "mm")
    with pytest.raises(ExpressionError, match="unknown unit 'radius'"):
        parse("2radius")
    # any unit with a dimension is a unit here (the field's kind is checked later, by exprcheck)
    assert parse("3min") == Num(3.0, "min")
    assert parse("2rev/min") == Num(2.0, "rev/min")
    # a /word continues the unit only while the text is still a unit
    assert parse("30deg/k") == Binary("/", Num(30.0, "deg"), Name("k"))
    assert parse("30deg/2") == Binary("/", Num(30.0, "deg"), Num(2.0))
    # dimensionless names are not units: 2pi is still implicit multiplication
    with pytest.raises(ExpressionError, match="unknown unit 'pi'"):
        parse("2pi")


def test_evaluate_units():
    assert evaluate(parse("90deg")) == pytest.approx(math.pi / 2)
    assert evaluate(parse("10rpm")) == pytest.approx(10 * 2 * math.pi / 60)
    assert evaluate(parse("1rev")) == pytest.approx(2 * math.pi)
    with pytest.raises(ExpressionError, match="length"):
        evaluate(parse("25mm"))


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("x", "unknown name 'x'"),
        ("1/0", "division by zero"),
        ("sqrt(-1)", "domain"),
        ("asin(2)", "domain"),
        ("(-8)**(1/3)", "domain"),
        ("10**400", "overflow"),
    ],
)
def test_evaluate_errors(text, fragment):
    with pytest.raises(ExpressionError, match=fragment.replace("(", r"\(")):
        evaluate(parse(text), {})


def test_evaluate_accepts_text_and_numbers():
    assert evaluate("a + 1", {"a": 1}) == 2.0
    assert evaluate(3) == 3.0


def test_parse_numbers():
    assert parse(2) == Num(2.0, None)
    assert parse(2.5) == Num(2.5, None)
    with pytest.raises(ExpressionError, match="boolean"):
        parse(True)
    with pytest.raises(ExpressionError):
        parse(float("nan"))
    with pytest.raises(ExpressionError):
        parse(None)  # type: ignore[arg-type]


LONG = "x" * 10000
DEEP = "(" * 200 + "1" + ")" * 200


@pytest.mark.parametrize(
    "text, fragment",
    [
        ("__import__('os')", "'__import__'"),
        ("os.system('ls')", "unexpected '.' at column 3"),
        ("exec('1')", "strings are not allowed"),
        ("exec(1)", "unknown function 'exec' (allowed: sin, cos"),
        ("eval(x)", "unknown function 'eval'"),
        ("lambda: 1", "'lambda' is a reserved word"),
        ("(1", "unclosed '('"),
        ("1)", "unmatched ')' at column 2"),
        ("1 +", "unexpected end of expression"),
        ("a[0]", "indexing is not allowed"),
        ('"abc"', "strings are not allowed"),
        ("1; 2", "unexpected ';' at column 2"),
        ("x if y else z", "'if' is a reserved word"),
        ("2 ^ 3", "use '**'"),
        ("_x", "names starting with '_'"),
        ("__class__", "names starting with '_'"),
        (LONG, "too long"),
        (DEEP, "nested too deeply"),
        ("-" * 500 + "1", "nested too deeply"),
        ("+".join(["1"] * 450), "nested too deeply"),
        ("", "empty expression"),
        ("   ", "empty expression"),
        ("1 2", "unexpected '2' at column 3"),
        ("2x", "implicit multiplication"),
        ("sin", "function 'sin' must be called"),
        ("sin(1, 2)", "sin() takes exactly 1 argument (got 2)"),
        ("atan2(1)", "atan2() takes exactly 2 arguments (got 1)"),
        ("1, 2", "unexpected ','"),
        ("pi(1)", "'pi' is a constant"),
        ("a.b", "attribute access"),
        ("x = 1", "unexpected '='"),
        ("1e999", "too large"),
        ("θ", "unexpected 'θ'"),
        ("1 // 2", "unexpected '/'"),
        ("*1", "unexpected '*' at column 1"),
    ],
)
def test_hostile_and_malformed_inputs(text, fragment):
    with pytest.raises(ExpressionError) as info:
        parse(text)
    message = str(info.value)
    assert fragment in message
    assert isinstance(info.value, ModelError)
    if len(text) <= 200 and text.strip():
        assert text in message  # the full text is quoted


def test_error_reports_column():
    with pytest.raises(ExpressionError) as info:
        parse("os.system('x')")
    assert info.value.column == 3
    assert info.value.text == "os.system('x')"
    assert str(info.value).startswith("unexpected '.' at column 3 in \"os.system('x')\"")


def test_names_and_walk():
    tree = parse("atan2(b*sin(t), a) + pi*r - 30deg")
    assert names(tree) == frozenset({"a", "b", "r", "t"})
    kinds = [type(n).__name__ for n in walk(parse("-(a+1)"))]
    assert kinds == ["Unary", "Binary", "Name", "Num"]


def test_nodes_are_frozen_and_hashable():
    node = parse("a + 1")
    with pytest.raises(AttributeError):
        node.op = "-"  # type: ignore[misc]
    assert hash(node) == hash(parse("a+1"))


@pytest.mark.parametrize(
    "text",
    [
        "a + b * c",
        "(a + b) * c",
        "a - (b - c)",
        "a - b - c",
        "a / (b * c)",
        "a / b * c",
        "-x ** 2",
        "(-x) ** 2",
        "2 ** 3 ** 2",
        "(2 ** 3) ** 2",
        "2 ** -x",
        "- -x",
        "-(a + b)",
        "a * -b",
        "sin(x) ** 2 + cos(x) ** 2",
        "atan2(y - 1, x * 2)",
        "theta4 + 30deg",
        "2rad/s * t",
        "10 rpm",
        "1e-3 + 2.5E+2 + .5 + 1.25",
        "1e300 * 1e-300",
        "(a)",
        "pi / 2",
        "abs(-(-3)) + sqrt(2) ** 0.5",
        "+a",
    ],
)
def test_to_text_round_trip(text):
    tree = parse(text)
    printed = to_text(tree)
    assert parse(printed) == tree
    assert to_text(parse(printed)) == printed


def test_to_text_canonical():
    assert to_text(parse("(a+b)*c-d")) == "(a + b) * c - d"
    assert to_text(parse("30 deg")) == "30deg"
    assert to_text(parse("sin( x )")) == "sin(x)"


@pytest.mark.parametrize("module", ["loopsolve.model.expr", "loopsolve.model.units"])
def test_no_dangerous_builtins_used(module):
    import importlib
    import inspect
    import re

    source = inspect.getsource(importlib.import_module(module))
    assert not re.search(r"(?<![.\w])(eval|exec|compile|__import__)\(", source)
    assert not re.search(r"^\s*(import|from)\s+(ast|sympy)\b", source, re.M)


@pytest.mark.parametrize("value", [10**400, -(10**400), "1" + "0" * 400, "1" + "0" * 400 + " + a"])
def test_integers_beyond_float_range_are_an_expression_error(value):
    """An int from TOML (or digits in a string) too large for a float: ExpressionError, no OverflowError."""
    with pytest.raises(ExpressionError, match="too large") as info:
        parse(value)
    assert "1" + "0" * 40 not in str(info.value).split(" in ")[0]  # the number itself is shortened


def test_no_dangerous_builtins_in_the_expression_checks():
    import inspect
    import re

    import loopsolve.model.exprcheck as mod

    source = inspect.getsource(mod)
    assert not re.search(r"(?<![.\w])(eval|exec|compile|__import__)\(", source)
    assert not re.search(r"^\s*(import|from)\s+(ast|sympy)\b", source, re.M)
