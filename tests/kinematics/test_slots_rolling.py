"""[slots] and [rolling]: pins in slots and rolling contact, against closed forms written here."""

import math
import subprocess
import sys

import numpy as np
import pytest

import loopsolve as ls

from support.models import DISK, SLOTTED


def test_pin_in_the_slot_of_a_rotating_lever():
    """The lever (pivot O4 at the origin) points at the crank pin A = (r2 cos θ2, d + r2 sin θ2)."""
    mech = ls.loads(SLOTTED)
    assert mech.info()["mobility"] == 1
    sw = mech.sweep(0, 360, 10, speed=2.0)
    t = np.radians(np.asarray(sw["theta2"]))
    ax, ay = 40 * np.cos(t), 100 + 40 * np.sin(t)
    assert np.allclose(np.radians(sw["theta4"]), np.arctan2(ay, ax), atol=1e-12)
    # ω4 = d/dt atan2(ay, ax) = (ax ȧy − ay ȧx)/(ax² + ay²)
    w4 = (ax * 80 * np.cos(t) + ay * 80 * np.sin(t)) / (ax**2 + ay**2)
    assert np.allclose(sw["theta4_vel"], w4, atol=1e-12)


def test_arc_slot_is_a_rocker():
    """A coupler end P in a circular slot of the frame (centre C, radius R) moves as a four-bar's rocker tip."""
    text = """
name = "arc slot"
units = { length = "mm", angle = "deg" }
[parameters]
r2 = 25
r3 = 70
R = 45
[variables]
theta2 = { input = true, guess = 90 }
theta3 = { guess = 16 }
[vectors]
r2 = { length = "r2", angle = "theta2" }
r3 = { length = "r3", angle = "theta3" }
rc = { x = 60, y = 0 }
[points]
P = "r2 + r3"
C = "rc"
[slots]
arc = { point = "P", link = "frame", arc = { center = "C", radius = "R" } }
"""
    mech = ls.loads(text)
    four = ls.fourbar(r1=60, r2=25, r3=70, r4=45)
    for x in (60, 90, 135):
        s = mech.solve(x)
        f = four.solve(x)
        assert s["theta3"] == pytest.approx(f["theta3"], abs=1e-9)
        assert s["theta3_vel"] == pytest.approx(f["theta3_vel"], abs=1e-12)
        assert math.hypot(s["P_x"] - 60, s["P_y"]) == pytest.approx(45, abs=1e-10)


def test_rolling_disk():
    """x = −r θ; a rim point traces a cycloid and is at rest when it touches the ground."""
    mech = ls.loads(DISK.replace("SIDE", ""))
    sw = mech.sweep(-180, 540, 15, speed=3.0, accel=1.5)
    t = np.radians(np.asarray(sw["theta"]))
    assert np.allclose(sw["x"], -50 * t, atol=1e-9)
    assert np.allclose(sw["x_vel"], -50 * 3.0) and np.allclose(sw["x_acc"], -50 * 1.5)
    assert np.allclose(sw["Q_x"], -50 * t + 50 * np.cos(t), atol=1e-9)
    assert np.allclose(sw["Q_y"], 50 + 50 * np.sin(t), atol=1e-9)
    bottom = mech.solve(-90, speed=3.0)  # the rim point at the contact: the instant centre
    assert bottom["Q_x_vel"] == pytest.approx(0, abs=1e-12) and bottom["Q_y_vel"] == pytest.approx(0, abs=1e-12)
    below = ls.loads(DISK.replace("SIDE", ', side = "right"'))
    assert below.solve(30)["x"] == pytest.approx(50 * math.radians(30))


def test_rolling_on_a_circle_outside_and_inside():
    """A planet of radius r on the arm ψ about a fixed circle R: ω = (1 ± R/r) ω_arm (epicycloid, hypocycloid)."""
    for internal, sign in ((False, 1), (True, -1)):
        text = f"""
name = "planet"
units = {{ length = "mm", angle = "deg" }}
[variables]
psi = {{ input = true, guess = 0 }}
theta = {{ guess = {0 if internal else 180} }}
[vectors]
arm = {{ length = {60 + sign * 20}, angle = "psi" }}
rim = {{ length = 20, angle = "theta" }}
[points]
Q = "arm + rim"
[rolling]
planet = {{ angle = "theta", radius = 20, on = "frame", base = 60, arm = "psi", internal = {str(internal).lower()} }}
"""
        mech = ls.loads(text)
        sw = mech.sweep(0, 360, 30, speed=2.0)
        assert np.allclose(sw["theta_vel"], (1 + sign * 3) * 2.0)
        psi = np.radians(np.asarray(sw["psi"]))
        th = np.radians(np.asarray(sw["theta"]))
        assert np.allclose(th - th[0], (1 + sign * 3) * psi, atol=1e-12)
        # ... (the guesses put Q at the contact at ψ = 0) has zero velocity there: the planet's instant centre
        s = mech.solve(0, speed=2.0)
        assert math.hypot(s["Q_x"], s["Q_y"]) == pytest.approx(60)
        assert s["Q_x_vel"] == pytest.approx(0, abs=1e-9) and s["Q_y_vel"] == pytest.approx(0, abs=1e-9)
        away = mech.solve(40, speed=2.0)
        assert math.hypot(away["Q_x_vel"], away["Q_y_vel"]) > 1.0


@pytest.mark.parametrize("extra, key, words", [
    ('[slots]\ns1 = { point = "A", link = "lever", line = "r9" }', "slots.s1.line", "not a declared vector"),
    ('[slots]\ns1 = { point = "Z", link = "lever", line = "r4" }', "slots.s1.point", "not a declared point"),
    ('[slots]\ns1 = { point = "A", line = "r4" }', "slots.s1", "needs `point`, `link`"),
])
def test_bad_slots(tmp_path, extra, key, words):
    path = tmp_path / "bad.toml"
    path.write_text(SLOTTED.split("[slots]")[0] + extra)
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "info", str(path)], capture_output=True, text=True)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert key in proc.stderr and words in proc.stderr


def test_unknown_link_of_a_slot(tmp_path):
    """With [bodies] the links are known: a slot on an undeclared one is named."""
    body = ('\n[bodies]\ncrank = { mass = "0.5kg", inertia = "1e-4kg*m^2", com = "O2", angle = "theta2", '
            'joints = ["O2", "A"] }\nlever = { mass = "1kg", inertia = "4e-3kg*m^2", com = "0.5*r4", '
            'angle = "theta4", joints = ["O4"] }\n')
    path = tmp_path / "bad.toml"
    path.write_text(SLOTTED.replace('link = "lever"', 'link = "levr"') + body)
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "info", str(path)], capture_output=True, text=True)
    assert proc.returncode == 2 and "slots.s1.link" in proc.stderr and "levr" in proc.stderr
