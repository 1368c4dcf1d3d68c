"""Hostile numbers, units and expressions (issue 9): every reproducer as written, through
``loads`` and through the CLI (exit 2, one stderr line naming the key); huge angles reduced
exactly; vectors given by components that depend on a variable, against a closed form and
finite differences written here."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.cli import main
from loopsolve.errors import ModelError, ModelFileError

BASE = """
name = "fb"
units = {{ length = "mm", angle = "deg" }}
[parameters]
r1 = 60
r2 = 25
r3 = {r3}
r4 = 45
[variables]
theta2 = {{ input = true, guess = 90 }}
theta3 = {{ guess = 20 }}
theta4 = {{ guess = 80 }}
[vectors]
r1 = {{ length = "r1", angle = {a1} }}
r2 = {{ length = "r2", angle = "theta2" }}
r3 = {{ length = "r3", angle = "theta3" }}
r4 = {{ length = {l4}, angle = "theta4" }}
[[loops]]
equation = {eq}
{extra}
"""


def model(a1="0", l4='"r4"', r3="70", eq='"r2 + r3 = r1 + r4"', extra=""):
    return BASE.format(a1=a1, l4=l4, r3=r3, eq=eq, extra=extra)


def cli(tmp_path, capsys, text, *args):
    path = tmp_path / "m.toml"
    path.write_text(text)
    capsys.readouterr()
    status = main(["solve", str(path), "--at", "90", *args])
    err = capsys.readouterr().err.strip().splitlines()
    return status, err


# (model text, key the error must name, fragments of the message)
REFUSED = {
    "angle 30 m": (model(a1='"30 m"'), "vectors.r1.angle", ["'m'", "expected an angle"]),
    "angle 30mm": (model(a1='"30mm"'), "vectors.r1.angle", ["'mm'", "expected an angle"]),
    "angle 30rpm": (model(a1='"30rpm"'), "vectors.r1.angle", ["angular rate", "expected an angle"]),
    "length 25deg": (model(l4='"25deg"'), "vectors.r4.length", ["'deg'", "expected a length"]),
    "unit inside sin": (model(a1='"5 + 0*sin(30mm)"'), "vectors.r1.angle", ["'mm'", "expected an angle"]),
    "unit in exponent": (model(l4='"r4*1**2deg"'), "vectors.r4.length", ["exponent"]),
    "division by zero": (model(l4='"r4 + 1/0"'), "vectors.r4.length", ["division by zero"]),
    "sqrt(-1)": (model(l4='"sqrt(-1)"'), "vectors.r4.length", ["sqrt(-1)", "not a real number"]),
    "acos(2)": (model(l4='"r4*acos(2)"'), "vectors.r4.length", ["acos(2)", "not a real number"]),
    "tan(90) in degrees": (model(l4='"r4 + tan(90)"'), "vectors.r4.length", ["not a finite real"]),
    "angle 1e308 m": (model(a1='"1e308 m"'), "vectors.r1.angle", ["'m'", "expected an angle"]),
    "length 1e308 m": (model(l4='"1e308 m"'), "vectors.r4.length", ["overflows"]),
    "nested powers": (model(a1='"((theta3**64)**64)**64"'), "vectors.r1.angle", ["degree"]),
    "huge integer": (model(l4="1" + "0" * 400), "vectors.r4.length", ["too large"]),
    "huge integer in a string": (model(l4='"1' + "0" * 400 + '"'), "vectors.r4.length", ["too large"]),
    "length 1e308": (model(l4="1e308"), "vectors.r4.length", ["1e+100"]),
    "nested sines": (model(a1='"' + "sin(" * 40 + "theta4" + ")" * 40 + '"'), "vectors.r1.angle",
                     ["nested more than"]),
    "product of sines": (model(a1='"' + "*".join(f"sin(theta4 + {i})" for i in range(20)) + '"'),
                         "vectors.r1.angle", ["terms"]),
    "guess of the wrong kind": (model().replace("theta3 = { guess = 20 }", 'theta3 = { guess = "20mm" }'),
                                "variables.theta3.guess", ["expected an angle"]),
    "speed of the wrong kind": (model().replace("guess = 90 }", 'guess = 90, speed = "5mm/s" }'),
                                "variables.theta2.speed", ["expected an angular rate"]),
    "offset of the wrong kind": (model(a1='0, offset = "10mm"'), "vectors.r1.offset", ["expected an angle"]),
    "component of the wrong kind": (model().replace('r1 = { length = "r1", angle = 0 }',
                                                    'r1 = { x = "30deg", y = 0 }'), "vectors.r1.x",
                                    ["expected a length"]),
    "zero link": (model(r3="0"), "vectors.r3.length", ["must be positive"]),
    "negative link": (model(r3="-70"), "vectors.r3.length", ["must be positive"]),
    "input in no loop": (model(eq='"r3 = r1 + r4"'), "variables.theta2", ["appears in no loop", "drives nothing"]),
    "parameter 30rpm": (model(r3='"30rpm"'), "parameters.r3", ["angular rate", "length"]),
    "parameter beyond float range": (model(r3="1" + "0" * 400), "parameters.r3", ["too large"]),
    "loop name with ESC": (model(extra="") .replace('equation = "r2', 'name = "a\\u001b[31m"\nequation = "r2'),
                           "loops.0.name", ["control character"]),  # refused when the file is read
    "mode alias longer than signature": (model(extra='[modes]\nopen = "-"\nwide = "+-+"'), "modes.wide",
                                         ["signs"]),
    "mode name with newline": (model(extra='[modes]\n"a\\nb" = "-"'), "'a\\nb'", ["control character"]),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_refused_through_loads(case):
    text, key, fragments = REFUSED[case]
    with pytest.raises(ModelError) as info:
        ls.loads(text).compile()
    msg = str(info.value)
    assert key in msg
    for f in fragments:
        assert f in msg


@pytest.mark.parametrize("case", ["angle 30 m", "angle 30mm", "angle 30rpm", "length 25deg", "division by zero",
                                  "sqrt(-1)", "acos(2)", "angle 1e308 m", "nested powers", "huge integer",
                                  "nested sines", "zero link", "input in no loop", "tan(90) in degrees"])
def test_refused_through_the_cli(tmp_path, capsys, case):
    text, key, fragments = REFUSED[case]
    status, err = cli(tmp_path, capsys, text)
    assert status == 2
    assert len(err) == 1 and key in err[0] and "Traceback" not in err[0]


def test_wrong_kind_units_were_read_silently_before():
    """The three silent readings of the issue: 30 m as 30000 deg, 30mm as 30 deg, 25deg as 25 mm."""
    for text in (model(a1='"30 m"'), model(a1='"30mm"'), model(l4='"25deg"')):
        with pytest.raises(ModelFileError):
            ls.loads(text)
    # the right kinds are still read: 30deg as an angle, 25mm as a length
    ok = ls.loads(model(a1='"0deg"', l4='"45mm"'))
    assert ok.solve(90)["theta4"] == pytest.approx(ls.loads(model()).solve(90)["theta4"], abs=1e-9)


@pytest.mark.parametrize("flag, value, fragment", [
    ("--at", "30mm", "expected an angle"),
    ("--speed", "5mm/s", "expected an angular rate"),
    ("--accel", "1rpm", "expected an angular acceleration"),
    ("--jerk", "2deg", "expected an angular jerk"),
    ("--speed", "1e308", "1e+100"),
    ("--speed", "1e150rpm", "1e+100"),
])
def test_cli_quantities_of_the_wrong_kind_or_size(tmp_path, capsys, flag, value, fragment):
    status, err = cli(tmp_path, capsys, model(), flag, value)
    assert status == 2
    assert len(err) == 1 and fragment in err[0]
    assert ("theta2" if flag == "--at" else flag.lstrip("-")) in err[0]


def test_sweep_bounds_of_the_wrong_kind(tmp_path, capsys):
    path = tmp_path / "m.toml"
    path.write_text(model())
    for args in (["--from", "0mm", "--to", "90", "--step", "10"], ["--from", "0", "--to", "90mm", "--step", "10"],
                 ["--from", "0", "--to", "90", "--step", "1rpm"]):
        capsys.readouterr()
        assert main(["sweep", str(path), *args]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "expected an angle" in err[0]


# ----------------------------------------------------------------------- huge angles


def fourbar_theta(t2_deg, r1=60.0, r2=25.0, r3=70.0, r4=45.0):
    """Closed form of the open four-bar (the mode the guesses pick at 90 deg): θ3, θ4 in degrees."""
    t2 = math.radians(t2_deg)
    bx, by = r2 * math.cos(t2), r2 * math.sin(t2)
    dx, dy = r1 - bx, -by
    d = math.hypot(dx, dy)
    t3 = math.atan2(dy, dx) + math.acos((r3 * r3 + d * d - r4 * r4) / (2 * r3 * d))
    cx, cy = bx + r3 * math.cos(t3), by + r3 * math.sin(t3)
    return math.degrees(t3), math.degrees(math.atan2(cy, cx - r1))


@pytest.mark.parametrize("at", ["1e17", 1e17, 10**17, "1e17deg", "1e300", "-1e17"])
def test_huge_angles_are_reduced_exactly(at):
    """1e17 deg is exactly 280 deg modulo 360 (as is 10**300); -1e17 is -280."""
    mech = ls.loads(model())
    s = mech.solve(at)
    expected = -280.0 if str(at).startswith("-") else 280.0
    t3, t4 = fourbar_theta(expected)
    assert s["theta4"] == pytest.approx(t4, abs=1e-7)
    assert s["theta3"] == pytest.approx(t3, abs=1e-7)


def test_huge_angles_through_the_cli(tmp_path, capsys):
    path = tmp_path / "m.toml"
    path.write_text(model())
    capsys.readouterr()
    assert main(["solve", str(path), "--at", "1e17", "--format", "json"]) == 0
    import json

    row = json.loads(capsys.readouterr().out)
    row = row[0] if isinstance(row, list) else row.get("rows", [row])[0] if "rows" in row else row
    theta4 = next(v for k, v in _flatten(row) if k.endswith("theta4"))
    assert theta4 == pytest.approx(fourbar_theta(280.0)[1], abs=1e-7)


def _flatten(obj, prefix=""):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _flatten(v, f"{prefix}.{k}" if prefix else str(k))
    else:
        yield prefix, obj


def test_unit_conversion_that_overflows_is_an_error():
    with pytest.raises(ls.units.UnitError, match="overflows"):
        ls.units.parse_quantity("1e308 m", ls.units.Kind.LENGTH, length_unit="mm")
    with pytest.raises(ls.units.UnitError, match="not finite"):
        ls.units.parse_quantity(10**400, ls.units.Kind.LENGTH)
    # radians are reduced through the exact argument reduction of sin/cos
    x = ls.units.parse_quantity("1e17rad", ls.units.Kind.ANGLE)
    assert math.cos(x) == pytest.approx(math.cos(1e17), abs=1e-15)
    assert math.sin(x) == pytest.approx(math.sin(1e17), abs=1e-15)


def test_overflowing_rates_name_the_speed(tmp_path, capsys):
    text = model().replace("r1 = 60", "r1 = 60e90").replace("r2 = 25", "r2 = 25e90") \
        .replace("r3 = 70", "r3 = 70e90").replace("r4 = 45", "r4 = 45e90") + '\n[points]\nC = "r2 + r3"\n'
    with pytest.raises(ModelError, match="speed"):
        ls.loads(text).solve(90, speed=1e100)
    status, err = cli(tmp_path, capsys, text, "--speed", "1e100")
    assert status == 2 and len(err) == 1 and "speed" in err[0]


def test_newton_does_not_overflow_on_huge_values():
    from loopsolve.kinematics.newton import NewtonStatus, newton

    big = 1e300
    res = newton(lambda x: np.array([x[0] * x[0] - big * big * 4.0 * 1e-300 * 1e-300 * 1e300 * 1e300]),
                 lambda x: np.array([[2 * x[0]]]), np.array([big]))
    assert res.status in (NewtonStatus.CONVERGED, NewtonStatus.NOT_FINITE, NewtonStatus.STALLED)
    # residuals near 1e300: f·f would overflow; compared as norms they do not
    res = newton(lambda x: np.array([1e300 * (x[0] - 2.0)]), lambda x: np.array([[1e300]]), np.array([0.0]))
    assert res.status is NewtonStatus.CONVERGED and res.x[0] == pytest.approx(2.0)


def test_rank_of_a_huge_jacobian():
    from loopsolve.model.topology import jacobian_rank

    assert jacobian_rank([[1e308, 1e308], [1e308, -1e308]]) == 2
    assert jacobian_rank([[1e308, 2e307], [1e308, 2e307]]) == 1
    with pytest.raises(ModelError, match="infinite or NaN"):
        jacobian_rank([[math.inf, 0.0], [0.0, 1.0]])


def test_diagram_coordinates_near_the_float_limit(tmp_path, capsys):
    text = (ls.models_dir() / "thesis_crank_rocker_diagram.toml").read_text().replace(
        "C  = { at = [67.255, 44.411] }", "C  = { at = [1e308, 1e308] }")
    with pytest.raises(ModelError, match="joints.C.at"):
        ls.loads(text)
    path = tmp_path / "d.toml"
    path.write_text(text)
    capsys.readouterr()
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "joints.C.at" in err[0]


# ------------------------------------------------- vectors by components that move


COMPONENTS = """
name = "four-bar by components"
units = { length = "mm", angle = "deg" }
[parameters]
r1 = 60
r2 = 25
r3 = 70
r4 = 45
[variables]
theta2 = { input = true, guess = 90, speed = 1 }
theta3 = { guess = 20 }
theta4 = { guess = 80 }
[vectors]
r1 = { x = "r1", y = 0 }
r2 = { length = "r2", angle = "theta2" }
r3 = { x = "r3*cos(theta3)", y = "r3*sin(theta3)" }
r4 = { length = "r4", angle = "theta4" }
[[loops]]
equation = "r2 + r3 = r1 + r4"
[points]
C = "r2 + r3"
"""


def _fd(f, x, h):
    """First, second and third central differences of f at x."""
    f1 = (f(x + h) - f(x - h)) / (2 * h)
    f2 = (f(x + h) - 2 * f(x) + f(x - h)) / h**2
    f3 = (f(x + 2 * h) - 2 * f(x + h) + 2 * f(x - h) - f(x - 2 * h)) / (2 * h**3)
    return f1, f2, f3


@pytest.mark.parametrize("t2", [30.0, 90.0, 200.0, 300.0])
def test_components_depending_on_a_variable_against_the_closed_form(t2):
    mech = ls.loads(COMPONENTS)
    s = mech.solve(t2, speed=1.0, accel=0.0, jerk=0.0)
    t3, t4 = fourbar_theta(t2)
    assert s["theta3"] == pytest.approx(t3, abs=1e-8)
    assert s["theta4"] == pytest.approx(t4, abs=1e-8)
    # rates: derivatives of the closed form with respect to θ2 in radians (speed 1 rad/s)
    for name, idx in (("theta3", 0), ("theta4", 1)):
        f = lambda x: math.radians(fourbar_theta(math.degrees(x))[idx])  # noqa: E731
        d1, d2, d3 = _fd(f, math.radians(t2), 1e-3)
        assert s[f"{name}_vel"] == pytest.approx(d1, rel=1e-5, abs=1e-7)
        assert s[f"{name}_acc"] == pytest.approx(d2, rel=1e-4, abs=1e-6)
        assert s[f"{name}_jerk"] == pytest.approx(d3, rel=1e-3, abs=1e-5)
    # the point C = B + r3 e(θ3) and its velocity
    cx = lambda x: 25 * math.cos(x) + 70 * math.cos(math.radians(fourbar_theta(math.degrees(x))[0]))  # noqa: E731
    assert s["C_x"] == pytest.approx(cx(math.radians(t2)), abs=1e-8)
    assert s["C_x_vel"] == pytest.approx(_fd(cx, math.radians(t2), 1e-4)[0], rel=1e-6, abs=1e-6)


def test_components_vector_length_and_angle_outputs():
    """The length and angle derived from the components, and their rates, for the moving r3."""
    mech = ls.loads(COMPONENTS)
    ck = mech.compile()
    s = mech.solve(90, speed=1.0)
    i = list(ck.vectors).index("r3")
    v0 = ck.vector_values(0, s.z)
    v1 = ck.vector_values(1, s.z, s.z1)
    v2 = ck.vector_values(2, s.z, s.z1, s.z2)
    assert v0[i, 0] == pytest.approx(70.0, abs=1e-9)
    assert math.degrees(v0[i, 1]) == pytest.approx(fourbar_theta(90.0)[0], abs=1e-8)
    assert v1[i, 0] == pytest.approx(0.0, abs=1e-9)
    assert v1[i, 1] == pytest.approx(s["theta3_vel"], abs=1e-9)
    assert v2[i, 1] == pytest.approx(s["theta3_acc"], abs=1e-9)


def test_the_issue_vector_by_components_r1_cos_theta3():
    """``r1 = { x = "r1*cos(theta3)", y = 0 }`` compiles; rates match finite differences of the
    positions, and the loop closes under equations written here."""
    text = model().replace('r1 = { length = "r1", angle = 0 }', 'r1 = { x = "r1*cos(theta3)", y = 0 }')
    mech = ls.loads(text)
    s = mech.solve(90, speed=1.0, accel=0.0, jerk=0.0)
    t2, t3, t4 = (math.radians(s[n]) for n in ("theta2", "theta3", "theta4"))
    assert 25 * math.cos(t2) + 70 * math.cos(t3) - 60 * math.cos(t3) - 45 * math.cos(t4) == pytest.approx(0, abs=1e-9)
    assert 25 * math.sin(t2) + 70 * math.sin(t3) - 45 * math.sin(t4) == pytest.approx(0, abs=1e-9)
    assert s["theta3"] == pytest.approx(15.71386105, abs=1e-6)
    h = 1e-3

    def pos(x_rad):
        return np.radians([mech.solve(math.degrees(x_rad))[n] for n in ("theta3", "theta4")])

    x = math.radians(90)
    d1, d2, d3 = _fd(pos, x, h)
    assert [s["theta3_vel"], s["theta4_vel"]] == pytest.approx(d1, rel=1e-5, abs=1e-7)
    assert [s["theta3_acc"], s["theta4_acc"]] == pytest.approx(d2, rel=1e-4, abs=1e-6)
    assert [s["theta3_jerk"], s["theta4_jerk"]] == pytest.approx(d3, rel=1e-3, abs=1e-5)
    tex = mech.to_latex()
    assert r"x = r_{1} \cos\theta_{3},\ y = 0" in tex


def test_abs_of_a_variable_differentiates_without_dirac_delta():
    """``abs()`` of a variable: its second derivative (sign') is 0 wherever it is defined."""
    text = model(l4='"abs(r4 + 0*theta4)"')
    s = ls.loads(text).solve(90)
    assert s["theta4"] == pytest.approx(fourbar_theta(90.0)[1], abs=1e-8)


def test_mode_alias_checked_also_when_the_code_is_cached():
    """A good model compiles first (its code is then cached); the same structure with an alias
    longer than the signature is still refused, naming the alias."""
    ls.loads(model(extra='[modes]\nopen = "-"')).compile()
    with pytest.raises(ModelError, match="modes.wide"):
        ls.loads(model(extra='[modes]\nopen = "-"\nwide = "+-"')).solve(90)


@pytest.mark.parametrize("scale", [1e90, 2e99])
def test_links_near_the_magnitude_cap_never_raise_bare_errors(scale):
    """Links of 1e90 model units (below the 1e100 cap) overflowed the tracker's squares (kernel.rho):
    a bare OverflowError. Now the sweep and the solve either answer or raise a LoopsolveError."""
    mech = ls.slider_crank(scale, 3 * scale, theta2=30)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for call in (lambda: mech.solve(30), lambda: mech.sweep(0, 360, 30)):
            try:
                call()
            except ls.LoopsolveError:
                pass
