"""[constraints]: scalar equations solved with the loops, against closed forms written here."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import loopsolve as ls

from support.models import FIVEBAR, fivebar
BELT = """
name = "belt"
units = { length = "mm", angle = "deg" }
[parameters]
r2 = 20
r5 = 50
[variables]
theta2 = { input = true, guess = 0, kind = "angle" }
theta5 = { guess = 10 }
[constraints]
belt = "r5*theta5 = r2*theta2 + 10*r5"
"""


def test_belt_alone_is_a_model_and_follows_the_ratio():
    """A model of one constraint and no loop: θ5 = (r2/r5) θ2 + 10°, its rates the ratio times the input's."""
    mech = ls.loads(BELT)
    assert mech.info()["mobility"] == 1
    sw = mech.sweep(0, 720, 30, speed=3.0, accel=2.0)
    th2 = np.asarray(sw["theta2"])
    th5 = np.asarray(sw["theta5"])
    # the first row in (-180, 180], later rows continuous (the angle contract): the closed form exactly
    assert np.allclose(th5, 0.4 * th2 + 10, atol=1e-9)
    assert np.allclose(sw["theta5_vel"], 0.4 * 3.0) and np.allclose(sw["theta5_acc"], 0.4 * 2.0)
    assert np.allclose(sw["theta5_jerk"], 0.0)


def test_belt_in_radians_is_the_same_equation():
    mech = ls.loads(BELT.replace('"deg"', '"rad"').replace("10*r5", "0.5*r5"))
    s = mech.solve(2.0)
    assert s["theta5"] == pytest.approx(0.4 * 2.0 + 0.5, abs=1e-12)


def _fivebar_closed_form(t2, t5, r1=40.0, r2=20.0, r3=50.0, r4=50.0, r5=20.0):
    """Circle–circle intersection of the two arms (P above the line AB), in degrees."""
    A = np.array([r2 * math.cos(t2), r2 * math.sin(t2)])
    B = np.array([r1 + r5 * math.cos(t5), r5 * math.sin(t5)])
    d = float(np.linalg.norm(B - A))
    a = (r3**2 - r4**2 + d**2) / (2 * d)
    h = math.sqrt(r3**2 - a**2)
    u = (B - A) / d
    P = A + a * u + h * np.array([-u[1], u[0]])
    th3 = math.degrees(math.atan2(P[1] - A[1], P[0] - A[0]))
    th4 = math.degrees(math.atan2(P[1] - B[1], P[0] - B[0]))
    return th3, th4, P


def test_coupled_cranks_of_a_five_bar_against_the_dyad_in_closed_form():
    """θ5 = 180° − θ2 (mirror-coupled cranks): one input; the arms from the circle–circle intersection."""
    mech = fivebar('[constraints]\ncouple = "theta5 = 180 - theta2"')
    assert mech.unknowns() == ("theta3", "theta4", "theta5")
    sw = mech.sweep(60, 120, 5)
    for row in sw.rows:
        t2 = math.radians(row["theta2"])
        t5 = math.pi - t2
        th3, th4, P = _fivebar_closed_form(t2, t5)
        assert row["theta5"] == pytest.approx(180 - row["theta2"], abs=1e-9)
        assert row["theta3"] == pytest.approx(th3, abs=1e-8)
        assert row["theta4"] == pytest.approx(th4, abs=1e-8)
        assert row["P_x"] == pytest.approx(20.0, abs=1e-9)  # the mirror image keeps P on x = 20
        assert row["P_y"] == pytest.approx(P[1], abs=1e-8)
        assert row["theta5_vel"] == pytest.approx(-1.0, abs=1e-12)


def test_rates_of_a_trigonometric_constraint_against_finite_differences():
    """θ5 = 90 + 20 sin θ2 (a cam-like coupling in the Jacobian and b1..b3): rates by central differences."""
    mech = fivebar('[constraints]\ncouple = "theta5 = 90 + 20*sin(2*theta2)"')
    x0, h = 85.0, 1e-3

    def pos(x):
        s = mech.solve(x)
        return np.array([s["theta3"], s["theta4"], s["theta5"]])

    s = mech.solve(x0, speed=1.0)
    d1 = (pos(x0 + h) - pos(x0 - h)) / (2 * math.radians(h))           # deg per rad of input
    d2 = (pos(x0 + h) - 2 * pos(x0) + pos(x0 - h)) / math.radians(h) ** 2
    vel = np.array([s["theta3_vel"], s["theta4_vel"], s["theta5_vel"]])
    acc = np.array([s["theta3_acc"], s["theta4_acc"], s["theta5_acc"]])
    assert np.allclose(np.radians(d1), vel, rtol=1e-6, atol=1e-9)
    assert np.allclose(np.radians(d2), acc, rtol=1e-4, atol=1e-6)
    assert s["theta5_vel"] == pytest.approx(math.radians(40 * math.cos(2 * math.radians(x0))), rel=1e-12)
    sj = mech.solve(x0 + h, speed=1.0)
    sm = mech.solve(x0 - h, speed=1.0)
    jerk_fd = (sj["theta5_acc"] - sm["theta5_acc"]) / (2 * math.radians(h))
    assert s["theta5_jerk"] == pytest.approx(jerk_fd, rel=1e-5)


def test_jacobian_row_of_the_constraint():
    mech = fivebar('[constraints]\ncouple = "theta5 = 180 - theta2"')
    kin = mech.derive()
    assert kin.equation_names[-1] == "constraints.couple"
    ck = mech.compile()
    z = mech.solve(80).z
    J = ck.jac(z)
    h = 1e-7
    fd = np.empty_like(J)
    for j, i in enumerate(ck.unknown_idx):
        zp, zm = z.copy(), z.copy()
        zp[i] += h
        zm[i] -= h
        fd[:, j] = (ck.phi(zp) - ck.phi(zm)) / (2 * h)
    assert np.allclose(J, fd, atol=1e-6)
    assert np.allclose(J[-1], [0, 0, 1])  # d(θ5 − π + θ2)/dq in radians


def test_parallel_cranks_turn_fully_modes_and_mobility():
    """θ5 = θ2: A and B stay 40 mm apart, P above their midpoint at the height of a 20-50 right triangle."""
    mech = fivebar('[constraints]\ncouple = "theta5 = theta2"')
    data = mech.info()
    assert data["mobility"] == 1 and data["pairs"] == [{"name": "constraints.couple", "equation": "theta5 = theta2"}]
    assert data["reachable_input_ranges"] == [[-180.0, 180.0]]  # turns fully
    modes = mech.modes(90)
    assert len(modes) == 2  # P above or below AB
    sw = mech.sweep(0, 360, 15)
    assert len(sw) == 25 and len(set(sw.modes)) == 1
    t = np.radians(np.asarray(sw["theta2"]))
    assert np.allclose(sw["P_x"], 20 + 20 * np.cos(t), atol=1e-9)
    assert np.allclose(sw["P_y"], 20 * np.sin(t) + math.sqrt(50**2 - 20**2), atol=1e-9)


def test_latex_prints_the_constraint_row():
    mech = fivebar('[constraints]\ncouple = "theta5 = 180 - theta2"')
    tex = mech.to_latex()
    assert "constraints.couple" in tex and r"\theta_{5}" in tex


@pytest.mark.parametrize("text, key, words", [
    ('couple = "theta5 = 180 - theta7"', "constraints.couple", "theta7"),
    ('couple = "theta5 = 1 = 2"', "constraints.couple", "more than one '='"),
    ('couple = "r1 = 40"', "constraints.couple", "names no variable"),
])
def test_bad_constraints_name_the_key(text, key, words):
    with pytest.raises(ls.ModelError) as err:
        fivebar("[constraints]\n" + text)
    assert key in str(err.value) and words in str(err.value)


def test_a_constraint_counts_in_the_mobility(tmp_path):
    """Two constraints on a one-input five-bar leave no motion: the count names them; exit 2, one line."""
    path = tmp_path / "over.toml"
    path.write_text(FIVEBAR.format(extra='[constraints]\na = "theta5 = 180 - theta2"\nb = "theta3 = 60"'))
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "info", str(path), "--format", "json"],
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1
    assert "constraints.a" in proc.stderr and "constraints.b" in proc.stderr


def test_cli_json_of_a_constrained_sweep(tmp_path):
    path = tmp_path / "belt.toml"
    path.write_text(BELT)
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "sweep", str(path), "--from", "0", "--to", "90",
                           "--step", "45", "--format", "json"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    rows = json.loads(proc.stdout)["rows"]
    assert [r["theta5"] for r in rows] == pytest.approx([10, 28, 46])
