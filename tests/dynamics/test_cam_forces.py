"""The cam–follower contact force along the common normal, against Newton's law on the follower and the
power balance written here."""

import math

import numpy as np
import pytest

import loopsolve as ls

MODEL = """
name = "cam and follower"
units = { length = "mm", angle = "deg" }
[variables]
theta2 = { input = true, guess = 0 }
s = { guess = 0 }
[vectors]
re = { length = "e", angle = 0 }
rf = { length = "sqrt(48**2 - e**2) + s", angle = 90 }
[parameters]
e = 5
[points]
O = "0"
C = "re + rf"
[cams.c1]
cam = "theta2"
follower = "s"
kind = "translating"
contact = "roller"
roller = "8mm"
base = "40mm"
offset = "e"
law = [ { to = 90, rise = "25mm", curve = "cycloidal" }, { to = 150, dwell = true },
        { to = 270, rise = "-25mm", curve = "3-4-5" }, { to = 360, dwell = true } ]
[bodies]
cam = { mass = "1kg", inertia = "1e-3kg*m^2", com = "O", angle = "theta2", joints = ["O"] }
follower = { mass = "0.5kg", com = "C", guide = "rf", joints = [] }
[[loads]]
at = "C"
body = "follower"
force = [0, "-100N"]
"""


def test_contact_force_along_the_normal_and_the_driving_torque():
    """Along the follower's axis: F cos φ − 100 N = m s̈ (the guide takes the rest); the driving torque from
    the power balance T ω = (m s̈ + 100 N) ṡ + I ω α, with tan φ = (s′ − ε)/(s + √(R_p² − ε²))."""
    mech = ls.loads(MODEL)
    w, al = 20.0, 4.0
    f = ls.forces(mech, 0, 355, 5, speed=w, accel=al)
    s = np.asarray(f["s"]) / 1000
    sd = np.asarray(f["s_vel"]) / 1000
    sdd = np.asarray(f["s_acc"]) / 1000
    s1 = sd / w  # ds/dθ (m/rad)
    phi = np.arctan((s1 - 0.005) / (s + math.sqrt(0.048**2 - 0.005**2)))
    F = (0.5 * sdd + 100.0) / np.cos(phi)
    assert np.allclose(f["F_c1"], F, rtol=1e-9)
    # its direction: the common normal, at φ from the follower's axis
    fx, fy = np.asarray(f["F_c1_x"]), np.asarray(f["F_c1_y"])
    assert np.allclose(np.arctan2(-fx, fy), phi, atol=1e-9)
    T = ((0.5 * sdd + 100.0) * sd + 1e-3 * w * al) / w
    assert np.allclose(f["input_torque"], T, rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(f["power_residual"])) < 1e-9


def test_a_follower_that_would_leave_the_cam_pulls():
    """Without a load the decelerating rise needs a pull on the follower: the normal force turns negative
    (the contact would open; a spring must hold the follower)."""
    mech = ls.loads(MODEL.replace('force = [0, "-100N"]', 'force = [0, "0N"]'))
    f = ls.forces(mech, 60, speed=30.0)
    assert f["F_c1"] < 0
