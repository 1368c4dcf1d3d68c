"""Slot reactions and rolling-contact forces, against statics and the power balance written here."""

import math

import numpy as np
import pytest

import loopsolve as ls

from support.models import DISK, SLOTTED
BODIES = """
[bodies]
crank = { mass = "0.5kg", inertia = "1e-4kg*m^2", com = "O2", angle = "theta2", joints = ["O2", "A"] }
lever = { mass = "1kg", inertia = "4e-3kg*m^2", com = "0.5*r4", angle = "theta4", joints = ["O4"] }
[[loads]]
body = "lever"
torque = "-5N*m"
"""


def test_slot_reaction_is_normal_to_the_lever():
    """Slowly (no inertia): the lever's moment about O4, N |O4A| = 5 N·m; the driver's power T ω2 = 5 ω4."""
    mech = ls.loads(SLOTTED + BODIES)
    f = ls.forces(mech, 0, 360, 15, speed=1e-4)
    t = np.radians(np.asarray(f["theta2"]))
    A = np.stack([40 * np.cos(t), 100 + 40 * np.sin(t)], axis=1) / 1000
    assert np.allclose(np.abs(f["F_s1"]), 5 / np.linalg.norm(A, axis=1), rtol=1e-6)
    F = np.stack([f["F_s1_x"], f["F_s1_y"]], axis=1)
    assert np.allclose(np.sum(F * A, axis=1), 0, atol=1e-6)  # normal to the slot (along the lever: none)
    w4 = np.asarray(f["theta4_vel"])
    assert np.allclose(np.asarray(f["input_torque"]) * 1e-4, 5 * w4, rtol=1e-5, atol=1e-12)


def test_slot_reaction_at_speed_keeps_the_power_balance():
    mech = ls.loads(SLOTTED + BODIES)
    f = ls.forces(mech, 0, 360, 15, speed=20.0, accel=5.0)
    assert np.max(np.abs(f["power_residual"])) < 1e-8 * np.max(np.abs(f["input_torque"]) * 20)


def test_rolling_disk_forces():
    """A disk driven by a torque rolls on the ground: T = (I + m r²) α, traction −m r α, normal m g."""
    text = DISK.replace("SIDE", "").replace('units = { length = "mm", angle = "deg" }',
                                            'units = { length = "mm", angle = "deg" }\ngravity = [0, "-9.81m/s^2"]')
    text += '\n[bodies]\ndisk = { mass = "2kg", inertia = "2.5e-3kg*m^2", com = "C", angle = "theta", joints = [] }\n'
    mech = ls.loads(text)
    f = ls.forces(mech, 0, 360, 45, speed=2.0, accel=3.0)
    assert np.allclose(f["input_torque"], (2.5e-3 + 2 * 0.05**2) * 3.0)
    assert np.allclose(f["F_wheel"], 2 * 9.81)
    assert np.allclose(f["F_wheel_x"], -2 * 0.05 * 3.0)
    assert np.allclose(f["F_wheel_y"], 2 * 9.81)
