"""Quantities read by dimension (issue 23) and plain numbers that would be ambiguous (issue 17, item 4).

Every expected value below is computed here from the unit definitions (1 in = 25.4 mm exactly,
1 lbf = 4.4482216152605 N, 1 slug = 1 lbf·s²/ft, 1 blob = 1 lbf·s²/in, 1 kgf = 9.80665 N,
1 lb = 0.45359237 kg, 1° = π/180 rad, 1 rev = 2π rad), never from the code's own tables.
"""

from __future__ import annotations

import math
import os
import re
import subprocess
import sys
import tomllib

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.errors import ModelError
from loopsolve.model.units import Kind, UnitError, parse_quantity

IN = 0.0254  # m
FT = 0.3048  # m
LBF = 4.4482216152605  # N
LB = 0.45359237  # kg
G0 = 9.80665  # m/s²
SLUG = LBF / FT  # kg (lbf·s²/ft ≈ 14.593902937206)
BLOB = LBF / IN  # kg (lbf·s²/in, the "slinch")
KGF = G0  # N
DEG = math.pi / 180
REV = 2 * math.pi

# (value, kind, expected in internal units: model length unit mm for lengths, radians, SI)
SPELLINGS = [
    ("1in", Kind.LENGTH, 25.4),
    ("1 inch", Kind.LENGTH, 25.4),
    ("2 ft", Kind.LENGTH, 2 * 304.8),
    ("3µm", Kind.LENGTH, 3e-3),
    ("3 μm", Kind.LENGTH, 3e-3),  # the Greek mu as well as the micro sign
    ("5 cm", Kind.LENGTH, 50.0),
    ("0.1m", Kind.LENGTH, 100.0),
    ("2 in/s", Kind.LENGTH_RATE, 2 * 25.4),
    ("60 mm/min", Kind.LENGTH_RATE, 1.0),
    ("3cm/s^2", Kind.LENGTH_ACCEL, 30.0),
    ("3cm/s²", Kind.LENGTH_ACCEL, 30.0),
    ("3 cm/s2", Kind.LENGTH_ACCEL, 30.0),
    ("1 ft/s^2", Kind.LENGTH_ACCEL, 304.8),
    ("1 m/s^3", Kind.LENGTH_JERK, 1000.0),
    ("2 in/s³", Kind.LENGTH_JERK, 2 * 25.4),
    ("90°", Kind.ANGLE, math.pi / 2),
    ("90 deg", Kind.ANGLE, math.pi / 2),
    ("0.25 rev", Kind.ANGLE, math.pi / 2),
    ("1 turn", Kind.ANGLE, REV),
    ("30 arcmin", Kind.ANGLE, 0.5 * DEG),
    ("0.5 rad", Kind.ANGLE, 0.5),
    ("120 rev/min", Kind.ANGULAR_RATE, 120 * REV / 60),
    ("120 rpm", Kind.ANGULAR_RATE, 120 * REV / 60),
    ("90 °/s", Kind.ANGULAR_RATE, math.pi / 2),
    ("90 deg/s", Kind.ANGULAR_RATE, math.pi / 2),
    ("1 rev/s", Kind.ANGULAR_RATE, REV),
    ("30 deg/min", Kind.ANGULAR_RATE, 30 * DEG / 60),
    ("2 rad/s", Kind.ANGULAR_RATE, 2.0),
    ("60 rpm/s", Kind.ANGULAR_ACCEL, REV),
    ("2 rad/s²", Kind.ANGULAR_ACCEL, 2.0),
    ("1 rev/s^3", Kind.ANGULAR_JERK, REV),
    ("2 slug", Kind.MASS, 2 * SLUG),
    ("1 blob", Kind.MASS, BLOB),
    ("1 slinch", Kind.MASS, BLOB),
    ("3 lb", Kind.MASS, 3 * LB),
    ("500 g", Kind.MASS, 0.5),
    ("1 t", Kind.MASS, 1000.0),
    ("0.5 slug*ft^2", Kind.INERTIA, 0.5 * SLUG * FT**2),
    ("0.5 slug*ft**2", Kind.INERTIA, 0.5 * SLUG * FT**2),
    ("2 blob*in^2", Kind.INERTIA, 2 * BLOB * IN**2),
    ("1200 kg*mm^2", Kind.INERTIA, 1.2e-3),
    ("3e5g*mm^2", Kind.INERTIA, 3e-4),
    ("3 lb*in^2", Kind.INERTIA, 3 * LB * IN**2),
    ("2 kg·m²", Kind.INERTIA, 2.0),
    ("5 kgf", Kind.FORCE, 5 * KGF),
    ("1.2 lbf", Kind.FORCE, 1.2 * LBF),
    ("2 kN", Kind.FORCE, 2000.0),
    ("12 in*lbf", Kind.TORQUE, 12 * LBF * IN),
    ("12 lbf*in", Kind.TORQUE, 12 * LBF * IN),
    ("1 ft*lbf", Kind.TORQUE, LBF * FT),
    ("3 kN*mm", Kind.TORQUE, 3.0),
    ("2 N*m", Kind.TORQUE, 2.0),
    ("2 Nm", Kind.TORQUE, 2.0),
    ("2 N·m", Kind.TORQUE, 2.0),
    ("2 N m", Kind.TORQUE, 2.0),
    ("500 N*mm", Kind.TORQUE, 0.5),
    ("20 lbf/in", Kind.STIFFNESS, 20 * LBF / IN),
    ("3 N/mm", Kind.STIFFNESS, 3000.0),
    ("20 lbf*s/in", Kind.DAMPING, 20 * LBF / IN),
    ("2 N*s/mm", Kind.DAMPING, 2000.0),
    ("2 Ns/m", Kind.DAMPING, 2.0),
    ("2 N*m/deg", Kind.TORSIONAL_STIFFNESS, 2 / DEG),
    ("5 in*lbf/rad", Kind.TORSIONAL_STIFFNESS, 5 * LBF * IN),
    ("0.1 N*m*s/rad", Kind.TORSIONAL_DAMPING, 0.1),
    ("1 in*lbf*s/rad", Kind.TORSIONAL_DAMPING, LBF * IN),
    ("-32.174 ft/s^2", Kind.ACCELERATION, -32.174 * FT),
    ("-9.81 m/s²", Kind.ACCELERATION, -9.81),
    ("-9810 mm/s^2", Kind.ACCELERATION, -9.81),
    ("7.85 g/cm^3", Kind.DENSITY, 7850.0),
    ("0.283 lb/in^3", Kind.DENSITY, 0.283 * LB / IN**3),
    ("500 ms", Kind.TIME, 0.5),
    ("2 min", Kind.TIME, 120.0),
]


@pytest.mark.parametrize("value, kind, expected", SPELLINGS, ids=[v for v, _, _ in SPELLINGS])
def test_spellings_designers_write(value, kind, expected):
    got = parse_quantity(value, kind, length_unit="mm", where="x")
    assert got == pytest.approx(expected, rel=1e-14)


def test_every_kind_has_spellings_in_the_table():
    assert {k for _, k, _ in SPELLINGS} == set(Kind) - {Kind.DIMENSIONLESS}


def test_exact_factors():
    """Exactly converted (correctly rounded), not through a chain of rounded factors."""
    assert parse_quantity("1ft", Kind.LENGTH, length_unit="m") == 0.3048
    assert parse_quantity("1 in*lbf", Kind.TORQUE) == 0.1129848290276167  # 4.4482216152605 * 0.0254 exactly
    assert parse_quantity("1 slug", Kind.MASS) == float(__import__("fractions").Fraction("4.4482216152605")
                                                         / __import__("fractions").Fraction("0.3048"))
    # angles: the factor numeric codes use (bit-identical to math.pi / 180 and 2π/60)
    assert parse_quantity("1deg", Kind.ANGLE) == math.pi / 180
    assert parse_quantity("10rpm", Kind.ANGULAR_RATE) == 10 * (2 * math.pi / 60)


# one example unit of each distinct dimension
_ONE_UNIT = {Kind.LENGTH: "mm", Kind.LENGTH_RATE: "mm/s", Kind.LENGTH_ACCEL: "mm/s^2", Kind.LENGTH_JERK: "mm/s^3",
             Kind.ANGLE: "deg", Kind.ANGULAR_RATE: "rpm", Kind.ANGULAR_ACCEL: "rad/s^2", Kind.ANGULAR_JERK: "rad/s^3",
             Kind.MASS: "slug", Kind.INERTIA: "slug*ft^2", Kind.FORCE: "lbf", Kind.TORQUE: "in*lbf",
             Kind.STIFFNESS: "lbf/in", Kind.DAMPING: "lbf*s/in", Kind.TORSIONAL_STIFFNESS: "N*m/rad",
             Kind.TORSIONAL_DAMPING: "N*m*s/rad", Kind.DENSITY: "g/cm^3", Kind.TIME: "ms"}
_WRONG = [(kind, unit) for kind in Kind for other, unit in _ONE_UNIT.items()
          if kind is not Kind.DIMENSIONLESS and other.dimension != kind.dimension]


@pytest.mark.parametrize("kind, unit", _WRONG, ids=[f"{k.name}-{u}" for k, u in _WRONG])
def test_wrong_dimension_is_refused_naming_key_value_kind_and_examples(kind, unit):
    with pytest.raises(UnitError) as info:
        parse_quantity(f"2 {unit}", kind, length_unit="mm", where="bodies.crank.field")
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith("bodies.crank.field: ")
    assert f"'2 {unit}'" in msg and f"not {'an' if kind.value[0] in 'aeiou' else 'a'} {kind.value}" in msg
    assert "e.g." in msg
    assert info.value.kind is kind and info.value.where == "bodies.crank.field"


def test_a_frequency_is_not_an_angular_rate():
    """pint makes the radian dimensionless (1 Hz = 1 rad/s); here the angle is a dimension."""
    with pytest.raises(UnitError, match="'Hz'"):
        parse_quantity("10 Hz", Kind.ANGULAR_RATE)
    with pytest.raises(UnitError, match="not a torsional stiffness"):
        parse_quantity("2 N*m", Kind.TORSIONAL_STIFFNESS)


# ---------------------------------------------------------------- the model file, the CLI and Python

THESIS_DYN = ls.models_dir() / "thesis_crank_rocker_dynamics.toml"


def _with(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new, 1)


@pytest.mark.parametrize("old, new, key", [
    ('gravity = [0, "-9.81m/s^2"]', 'gravity = [0, "-9.81 rpm"]', "gravity[1]"),
    ('torque = "-0.05N*m"', 'torque = "-0.05 lbf"', "loads[0].torque"),
    ('density = "7850kg/m^3" }, com = "0.5*r2"', 'density = "7850kg/m^2" }, com = "0.5*r2"',
     "bodies.crank.bar.density"),
    ('bar = { length = 25,', 'bar = { length = "25 rad",', "bodies.crank.bar.length"),
])
def test_model_file_wrong_dimension_names_the_key(old, new, key):
    text = _with(THESIS_DYN.read_text(encoding="utf-8"), old, new)
    with pytest.raises(ModelError) as info:
        ls.loads(text, source="us.toml")
    assert key in str(info.value) and "e.g." in str(info.value)


def test_python_and_cli_take_any_rate_unit(tmp_path):
    mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    a = mech.solve(90, speed="120 rev/min")
    b = mech.solve(90, speed=120 * REV / 60)
    assert a["theta4_vel"] == pytest.approx(b["theta4_vel"], rel=1e-14)
    r = subprocess.run([sys.executable, "-m", "loopsolve.cli", "solve", str(ls.models_dir() / "thesis_crank_rocker.toml"),
                        "--at", "90", "--speed", "120 rev/min", "--format", "json"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    import json
    row = json.loads(r.stdout)["rows"][0]
    assert row["theta4_vel"] == pytest.approx(b["theta4_vel"], rel=1e-15)


def test_cli_torque_with_a_unit():
    mech = ls.load(THESIS_DYN)
    a = ls.simulate(mech, 0.02, step=0.01, torque="0.4 in*lbf", speed0="60 rpm")
    b = ls.simulate(mech, 0.02, step=0.01, torque=repr(0.4 * LBF * IN), speed0="60 rpm")
    np.testing.assert_allclose(np.asarray(a.x), np.asarray(b.x), rtol=1e-13)
    with pytest.raises(UnitError, match="--torque.*not a torque"):
        ls.simulate(mech, 0.02, step=0.01, torque="20 N")


# ---------------------------------------------------------------- a US-units model

def _bar(length, width, thickness, rho=7850.0):
    """Mass and centroidal inertia of a uniform bar, SI, by hand: m = ρLwt, I = m(L² + w²)/12."""
    m = rho * length * width * thickness
    return m, m * (length**2 + width**2) / 12


def _us_model(inertia_unit: str) -> str:
    """The thesis crank-rocker with dynamics, written in inches, pounds-force, slugs and blobs."""
    lengths = {"r1": 60, "r2": 25, "r3": 70, "r4": 45}  # mm
    par = "\n".join(f"{k} = {v / 25.4!r}" for k, v in lengths.items())
    bodies = []
    for name, link, com, angle, joints in (("crank", "r2", "0.5*r2", "theta2", '["O2", "B"]'),
                                           ("coupler", "r3", "r2 + 0.5*r3", "theta3", '["B", "C"]'),
                                           ("rocker", "r4", "r1 + 0.5*r4", "theta4", '["C", "O4"]')):
        m, i = _bar(lengths[link] * 1e-3, 8e-3, 4e-3)
        if inertia_unit == "slug*ft^2":
            mass, inertia = f"{m / SLUG!r} slug", f"{i / (SLUG * FT**2)!r} slug*ft^2"
        else:
            mass, inertia = f"{m / BLOB!r} blob", f"{i / (BLOB * IN**2)!r} blob*in^2"
        bodies.append(f'{name} = {{ mass = "{mass}", inertia = "{inertia}", com = "{com}", angle = "{angle}", '
                      f'joints = {joints} }}')
    body_text = "\n".join(bodies)
    return f'''name = "Crank-rocker four-bar (US units)"
units = {{ length = "in", angle = "deg" }}
gravity = [0, "{-9.81 / FT!r} ft/s^2"]

[parameters]
{par}

[variables]
theta2 = {{ input = true, guess = 90, speed = "10 rev/min" }}
theta3 = {{ guess = 20 }}
theta4 = {{ guess = 80 }}

[vectors]
r1 = {{ length = "r1", angle = 0 }}
r2 = {{ length = "r2", angle = "theta2" }}
r3 = {{ length = "r3", angle = "theta3" }}
r4 = {{ length = "r4", angle = "theta4" }}

[[loops]]
equation = "r2 + r3 = r1 + r4"

[points]
O2 = "0"
B = "r2"
C = "r2 + r3"
O4 = "r1"

[bodies]
{body_text}

[[loads]]
body = "rocker"
torque = "{-0.05 / (LBF * IN)!r} in*lbf"
'''


@pytest.mark.parametrize("inertia_unit", ["slug*ft^2", "blob*in^2"])
def test_us_units_model_gives_the_si_driving_torque(inertia_unit):
    si = ls.load(THESIS_DYN)
    us = ls.loads(_us_model(inertia_unit), source="us.toml")
    for at in (0.0, 37.0, 90.0, 200.0, 311.0):
        t_si = float(np.ravel(ls.forces(si, at).drive)[0])
        t_us = float(np.ravel(ls.forces(us, at).drive)[0])
        assert t_us == pytest.approx(t_si, rel=1e-12, abs=0)
        assert abs(t_si) > 1e-3


# ---------------------------------------------------------------- issue 17, item 4: ambiguous plain numbers

def test_issue17_item4_inertia_1000_in_a_mm_model():
    """``inertia = 1000`` in a mm model was read as 1000 kg·m² (T = −9896 N·m instead of −7.54)."""
    text = THESIS_DYN.read_text(encoding="utf-8")
    text = _with(text, 'crank   = { bar = { length = 25, width = 8, thickness = 4, density = "7850kg/m^3" }, ',
                 'crank   = { mass = "1kg", inertia = 1000, ')
    with pytest.raises(ModelError) as info:
        ls.loads(text, source="mm.toml")
    msg = str(info.value)
    assert "bodies.crank.inertia" in msg and "ambiguous" in msg
    assert '"1000kg*m^2"' in msg and '"1000kg*mm^2"' in msg  # the units to write
    # with the unit the designer meant, it loads
    ls.loads(text.replace("inertia = 1000,", 'inertia = "1000kg*mm^2",'), source="mm.toml")


def test_issue17_item4_cli_one_line_exit_2(tmp_path):
    path = tmp_path / "mm.toml"
    path.write_text(_with(THESIS_DYN.read_text(encoding="utf-8"), 'torque = "-0.05N*m"', "torque = -0.05"),
                    encoding="utf-8")
    r = subprocess.run([sys.executable, "-m", "loopsolve.cli", "forces", str(path), "--at", "30"],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1
    assert "loads[0].torque" in r.stderr and "N*mm" in r.stderr and "mm.toml" in r.stderr


def test_plain_numbers_stay_si_in_a_metre_model_and_zero_is_zero():
    assert parse_quantity(1e-3, Kind.INERTIA, length_unit="m") == 1e-3
    assert parse_quantity(-9.81, Kind.ACCELERATION, length_unit="m") == -9.81
    assert parse_quantity(0, Kind.TORQUE, length_unit="mm") == 0.0  # 0 is 0 in every unit
    assert parse_quantity(2.5, Kind.MASS, length_unit="mm") == 2.5  # masses and forces: plain SI
    assert parse_quantity(-50, Kind.FORCE, length_unit="in") == -50.0
    assert parse_quantity("3", Kind.TIME, length_unit="mm") == 3.0
    with pytest.raises(UnitError, match="ambiguous"):
        parse_quantity("2e-4", Kind.INERTIA, length_unit="in")


_QUOTED = re.compile(r'"([+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z][A-Za-z0-9*/^ ]*)"')
_LENGTHY = {Kind.INERTIA, Kind.TORQUE, Kind.STIFFNESS, Kind.DAMPING, Kind.TORSIONAL_STIFFNESS,
            Kind.TORSIONAL_DAMPING, Kind.LENGTH_ACCEL, Kind.ACCELERATION, Kind.DENSITY}


def _substitutions():
    """Every quantity of every shipped model with dynamics, replaced (one at a time) by its bare number."""
    out = []
    for path in sorted(ls.models_dir().glob("*.toml")):
        text = path.read_text(encoding="utf-8")
        data = tomllib.loads(text)
        if "bodies" not in data:
            continue
        start = min(i for i in (text.find("\ngravity"), text.find("[bodies]")) if i >= 0)
        for m in _QUOTED.finditer(text, start):
            if ls.units.unit_kind(m.group(2)).is_angular:
                continue  # a speed: kinematics, not a mass property or a load
            field = re.findall(r"([A-Za-z_]+)\s*=\s*\[?[^=]*$", text[:m.start()])[-1]
            out.append(pytest.param(path, m.start(), m.end(), m.group(1), m.group(2), field,
                                    id=f"{path.stem}-{field}-{m.group(0)}"))
    return out


@pytest.mark.parametrize("path, start, end, number, unit, field", _substitutions())
def test_bare_number_substitution_corpus(path, start, end, number, unit, field):
    """A plain number in place of a quantity is refused naming the field where it would be ambiguous;
    elsewhere (kg, N in any model; anything in a metre model) it is SI, the very same number."""
    text = path.read_text(encoding="utf-8")
    bare = text[:start] + number + text[end:]
    kind = ls.units.unit_kind(unit)
    length_unit = tomllib.loads(text)["units"]["length"]
    ambiguous = kind in _LENGTHY and length_unit != "m" and float(number) != 0
    if ambiguous:
        with pytest.raises(ModelError) as info:
            ls.loads(bare, source=path.name)
        msg = str(info.value)
        assert field in msg and "ambiguous" in msg and repr(tomllib.loads(f"x = {number}")["x"]) in msg
        return
    original, changed = ls.loads(text, source=path.name), ls.loads(bare, source=path.name)
    si_value = parse_quantity(f"{number}{unit}", kind, length_unit="m")
    assert si_value == float(number)  # SI unit: unambiguous, and the same number
    a = ls.forces(original, 33.0)
    b = ls.forces(changed, 33.0)
    assert np.array_equal(np.ravel(a.drive), np.ravel(b.drive))


def test_corpus_covers_every_dynamics_model():
    stems = {p.values[0].stem for p in _substitutions()}
    assert stems == {p.stem for p in ls.models_dir().glob("*.toml") if "bodies" in tomllib.loads(p.read_text())}
    assert len(_substitutions()) >= 20


# ---------------------------------------------------------------- speed: pint stays off the cached path

def test_second_process_does_not_import_pint(tmp_path):
    """The units a run needs are remembered next to the compiled models: a cached run never imports pint."""
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    code = ("import sys, loopsolve as ls; m = ls.load(sys.argv[1]); "
            "print(round(float(ls.forces(m, 30, speed='10rpm').drive), 9), 'pint' in sys.modules)")
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join(sys.path))
    first = subprocess.run([sys.executable, "-c", code, str(THESIS_DYN)], capture_output=True, text=True, env=env)
    second = subprocess.run([sys.executable, "-c", code, str(THESIS_DYN)], capture_output=True, text=True, env=env)
    assert first.returncode == 0 and second.returncode == 0, first.stderr + second.stderr
    t1, pint1 = first.stdout.split()
    t2, pint2 = second.stdout.split()
    assert t1 == t2 and pint1 == "True" and pint2 == "False"
    memo = [p for p in cache.iterdir() if p.name.startswith("units-")]
    assert len(memo) == 1 and (memo[0].stat().st_mode & 0o077) == 0


def test_a_memo_writable_by_others_is_ignored(tmp_path):
    cache = tmp_path / "cache"
    cache.mkdir(mode=0o700)
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join(sys.path))
    code = "import sys; from loopsolve.model.units import *; print(parse_quantity('1 in', Kind.LENGTH), 'pint' in sys.modules)"
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, env=env)
    (memo,) = [p for p in cache.iterdir() if p.name.startswith("units-")]
    memo.write_text(memo.read_text().replace('"127/5000"', '"1/1"'))  # a forged factor: 1 in = 1 m
    memo.chmod(0o666)
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, env=env).stdout
    assert out.split() == ["25.4", "True"]  # not trusted: pint answered again


def test_cli_simulate_takes_units_for_torque_and_speed0():
    """Issue 17: ``--torque "0.05N*m"`` advised writing ``0.05*N``; ``--speed0 "120 rev/min"`` was refused."""
    r = subprocess.run([sys.executable, "-m", "loopsolve.cli", "simulate", str(THESIS_DYN), "--duration", "0.02",
                        "--step", "0.01", "--torque", "0.4 in*lbf", "--speed0", "120 rev/min", "--format", "json"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    import json
    rows = json.loads(r.stdout)["rows"]
    assert rows[0]["theta2_vel"] == pytest.approx(4 * math.pi, rel=1e-12)
