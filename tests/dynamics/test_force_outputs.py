"""What a user reads from ``loopsolve forces`` and ``loopsolve simulate``, checked by hand (issue 18).

- the shaking moment is taken about the model's origin: shifting the whole mechanism by ``d``
  (every point and centre of mass) leaves the shaking force as it is and adds ``d × F`` to the
  moment (M′ = M + d × F_shake), on the crank-shaper whose first joint is not at the origin;
- the ``|F|`` column of ``forces --at`` is ``hypot(F_x, F_y)`` of the JSON's components;
- every force, moment, energy and power column of every shipped dynamics model carries its SI
  unit (N, N*m, J, W) in the table and CSV headers and in the JSON ``units``;
- ``simulate`` without ``--speed0`` starts at the model's declared input speed.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
import subprocess
import sys

import numpy as np
import pytest

import loopsolve as ls

SHAPER = ls.models_dir() / "shaper_dynamics.toml"
DYNAMICS_MODELS = sorted(p for p in ls.models_dir().glob("*.toml") if "\n[bodies]" in p.read_text())


def cli(*args):
    r = subprocess.run([sys.executable, "-m", "loopsolve.cli", *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r.stdout


# ------------------------------------------------------------------------- the shaking moment
def shifted_shaper(dx_mm: float, dy_mm: float) -> str:
    """The shaper's model text with the whole mechanism moved by (dx, dy) mm: a constant vector
    ``r_shift`` is added to every point and to every centre of mass not given by a point name.
    The loops are unchanged, so the joint variables and the forces are the same."""
    out, section = [], None
    for line in SHAPER.read_text().splitlines():
        m = re.match(r"^\[+(\w+)\]+", line)
        if m:
            section = m.group(1)
        if section == "points" and "=" in line:
            key, value = line.split("=", 1)
            value = value.strip().strip('"')
            line = f'{key}= "r_shift"' if value == "0" else f'{key}= "r_shift + {value}"'
        elif section == "bodies":
            line = re.sub(r'com = "([^"]*\br_[^"]*)"', r'com = "r_shift + \1"', line)
        out.append(line)
        if line.startswith("[vectors]"):
            out.append(f"r_shift = {{ x = {dx_mm}, y = {dy_mm} }}")
    return "\n".join(out) + "\n"


def test_shaking_moment_is_about_the_origin_shift_adds_d_cross_f():
    """Moving the shaper by d = (30, −50) mm: the shaking force is unchanged and the moment about
    the origin becomes M + d × F (d_x F_y − d_y F_x), at 12 crank angles. A moment taken about the
    first joint (the crank pivot O2, which moves with the mechanism) would not change at all."""
    text = shifted_shaper(30, -50)
    assert text.count("r_shift") == 1 + 5 + 4  # the vector, five points, four com expressions
    base, moved = ls.load(SHAPER), ls.loads(text)
    f0 = ls.forces(base, 0, 330, 30)
    f1 = ls.forces(moved, 0, 330, 30)
    # the shift moved the points (the check is not vacuous) and not the joint variables
    assert np.allclose(f1.sweep["O2_x"] - f0.sweep["O2_x"], 30) and np.allclose(f1.sweep["E_y"] - f0.sweep["E_y"], -50)
    assert np.allclose(f1.sweep["theta_lever"], f0.sweep["theta_lever"], atol=1e-9)
    F = f0.shaking_force
    np.testing.assert_allclose(f1.shaking_force, F, rtol=1e-9, atol=1e-9)
    dx, dy = 0.030, -0.050  # m
    expected = f0.shaking_moment + dx * F[:, 1] - dy * F[:, 0]
    np.testing.assert_allclose(f1.shaking_moment, expected, rtol=1e-9, atol=1e-9)
    # the shift is large enough to matter: |d × F| > 2 N*m at every angle (17 N*m while cutting)
    assert np.min(np.abs(dx * F[:, 1] - dy * F[:, 0])) > 2


def test_shaper_shaking_moment_balances_the_frame_reactions():
    """Independent of the code's sums: the frame feels −(the forces the frame exerts) at the
    frame joints O2 and O4, the ram's guide reaction at the ram's centre and its couple, and the
    reaction to the driving torque; their moment about the origin, computed here from the
    printed pin forces and the points, is the shaking moment (at 30°: the issue's −96.31 N*m)."""
    fs = ls.forces(ls.load(SHAPER), 30)
    sw = fs.sweep
    mm = 1e-3

    def cross(px, py, f):
        return px * f[1] - py * f[0]

    # F_<joint> is the force on the first body carrying the joint, here from the frame at O2 and O4
    m = 0.0
    fx = fy = 0.0
    for joint in ("O2", "O4"):
        f = fs.joint_forces[f"F_{joint}"]
        m -= cross(sw[f"{joint}_x"][0] * mm, sw[f"{joint}_y"][0] * mm, f)
        fx, fy = fx - f[0], fy - f[1]
    g = fs.guide_reactions["ram_guide"]  # (F_x, F_y, couple) on the ram from the frame, at its com E
    m -= cross(sw["E_x"][0] * mm, sw["E_y"][0] * mm, g[:2]) + g[2]
    fx, fy = fx - g[0], fy - g[1]
    m -= fs.drive  # the motor's stator takes −T
    np.testing.assert_allclose(fs.shaking_force, [fx, fy], rtol=1e-12, atol=1e-9)
    assert fs.shaking_moment == pytest.approx(m, rel=1e-12, abs=1e-9)
    assert fs.shaking_moment == pytest.approx(-96.31, abs=0.005)


# ------------------------------------------------------------------------- the |F| column
def test_forces_at_table_magnitude_column_is_hypot_of_the_json_components():
    table = cli("forces", SHAPER, "--at", 30)
    doc = json.loads(cli("forces", SHAPER, "--at", 30, "--format", "json"))
    row = doc["rows"][0]
    seen = 0
    for line in table.splitlines():
        m = re.match(r"^(F_\w+)\s+(\S+)\s+(\S+)\s+(\S+)", line)
        if not m:
            continue
        name, fx, fy, mag = m.group(1), *map(float, m.group(2, 3, 4))
        jx, jy = row[f"{name}_x"], row[f"{name}_y"]
        assert fx == pytest.approx(jx, rel=1e-5, abs=1e-9) and fy == pytest.approx(jy, rel=1e-5, abs=1e-9)
        assert mag == pytest.approx(math.hypot(jx, jy), rel=1e-5), name
        seen += 1
    assert seen == 7  # five pins, two guides
    # where both components are large, |Fx| + |Fy| would be far off: F_O2 at 30°
    assert math.hypot(row["F_O2_x"], row["F_O2_y"]) < 0.95 * (abs(row["F_O2_x"]) + abs(row["F_O2_y"]))


# ------------------------------------------------------------------------- units
def expected_unit(col: str, drive: str) -> str | None:
    """The SI unit a force-analysis column must carry, from its name (DESIGN.md, forces)."""
    if col == drive:
        return "N*m" if col == "input_torque" else "N"
    if col == "shaking_moment" or col.startswith("M_"):
        return "N*m"
    if col.startswith("F_") or col.startswith("shaking_force_"):
        return "N"
    if col in ("kinetic_energy", "potential_energy"):
        return "J"
    if col == "power_residual":
        return "W"
    return None


@pytest.mark.parametrize("path", DYNAMICS_MODELS, ids=lambda p: p.stem)
def test_every_force_moment_and_energy_column_has_its_unit(path):
    assert len(DYNAMICS_MODELS) >= 4
    fs = ls.forces(ls.load(path), 0, 20, 10)  # what `loopsolve forces --format json/csv/table` prints
    doc = json.loads(fs.to_json())
    drive = "input_torque" if "input_torque" in doc["rows"][0] else "input_force"
    force_cols = [c for c in doc["rows"][0] if expected_unit(c, drive)]
    # every kind is present: the drive, pins, shaking force and moment, both energies
    assert drive in force_cols and "shaking_moment" in force_cols and "kinetic_energy" in force_cols
    assert any(c.startswith("F_") for c in force_cols)
    if any(c.endswith("_guide_x") for c in force_cols):  # a guide has its couple, in N*m
        assert any(c.startswith("M_") for c in force_cols)
    for c in force_cols:
        assert doc["units"].get(c) == expected_unit(c, drive), (path.stem, c, doc["units"].get(c))
    header = next(csv.reader(io.StringIO(fs.to_csv())))
    for c in force_cols:
        assert f"{c} [{expected_unit(c, drive)}]" in header, (path.stem, c)
    table = fs.table().splitlines()[1].split()
    for c in force_cols:
        assert f"[{expected_unit(c, drive)}]" == table[table.index(c) + 1], (path.stem, c)


def test_forces_cli_json_units():
    doc = json.loads(cli("forces", SHAPER, "--from", 0, "--to", 20, "--step", 10, "--format", "json"))
    for c in ("shaking_moment", "M_block_guide", "M_ram_guide", "input_torque"):
        assert doc["units"][c] == "N*m", c
    assert doc["units"]["F_ram_guide_y"] == "N" and doc["units"]["potential_energy"] == "J"


def test_forces_python_units_match_the_names():
    fs = ls.forces(ls.load(SHAPER), 0, 60, 30)
    units = fs.units()
    cols = [c for c in fs.columns if expected_unit(c, "input_torque")]
    assert "M_block_guide" in cols and "M_ram_guide" in cols and "shaking_moment" in cols
    for c in cols:
        assert units[c] == expected_unit(c, "input_torque"), c


# ------------------------------------------------------------------------- simulate's start
@pytest.mark.parametrize("model, rpm", [("thesis_crank_rocker_dynamics", 10),
                                        ("thesis_crank_rocker_dynamics_diagram", 10),
                                        ("shaper_dynamics", 30)])
def test_simulate_without_speed0_starts_at_the_declared_speed(model, rpm):
    path = ls.models_dir() / f"{model}.toml"
    w = rpm * 2 * math.pi / 60  # 10 rpm = 1.0471975511965976 rad/s
    rows = list(csv.DictReader(io.StringIO(cli("simulate", path, "--duration", 0.02, "--step", 0.01,
                                               "--format", "csv"))))
    vel = [k for k in rows[0] if k.endswith("_vel [rad/s]")]
    assert len(vel) == 1
    assert float(rows[0][vel[0]]) == pytest.approx(w, rel=1e-12)
    assert float(rows[0]["t [s]"]) == 0
    sim = ls.simulate(ls.load(path), 0.02, step=0.01)
    assert sim.xd[0] == pytest.approx(w, rel=1e-12)


def test_simulate_speed0_overrides_and_a_model_without_speed_starts_at_rest():
    path = ls.models_dir() / "thesis_crank_rocker_dynamics.toml"
    sim = ls.simulate(ls.load(path), 0.02, step=0.01, speed0="60rpm")
    assert sim.xd[0] == pytest.approx(2 * math.pi, rel=1e-12)
    text = path.read_text().replace(', speed = "10rpm"', "")
    assert text != path.read_text()
    assert ls.simulate(ls.loads(text), 0.02, step=0.01).xd[0] == 0
