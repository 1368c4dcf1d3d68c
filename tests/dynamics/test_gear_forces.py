"""Tooth forces of gear pairs in the force analysis, against power and moment balances written here."""

import math

import numpy as np
import pytest

import loopsolve as ls

from support.models import FIVEBAR, GEAR_TRAIN


@pytest.mark.parametrize("internal", [False, True])
@pytest.mark.parametrize("pa", [20, 14.5])
@pytest.mark.parametrize("load", [2.0, -3.0])
def test_tooth_force_from_the_power_and_moment_balance(internal, pa, load):
    """Two gears on fixed axes, an accelerating input and a load torque on the output.

    Power: T ω2 = I2 ω2 α2 + I5 ω5 α5 − T_L ω5; gear 5 about its pivot: W_t r5 = ±(I5 α5 − T_L); the
    force along the line of action |W_t| / cos φ; its radial part |W_t| tan φ pushes the gears apart.
    """
    rg, rm = (12, 36) if internal else (12, 18)
    d = rm - rg if internal else rg + rm
    mech = ls.loads(GEAR_TRAIN.format(d=d, rg=rg, rm=rm, load=load,
                                 extra=f"pressure_angle = {pa}" + (", internal = true" if internal else "")))
    w2, a2 = 10.0, 5.0
    ratio = rg / rm if internal else -rg / rm
    w5, a5 = ratio * w2, ratio * a2
    f = ls.forces(mech, 30, speed=w2, accel=a2)
    T = (2e-4 * w2 * a2 + 6e-4 * w5 * a5 - load * w5) / w2
    assert f["input_torque"] == pytest.approx(T, rel=1e-10)
    Wt = abs(6e-4 * a5 - load) / (rm / 1000)
    assert f["F_g"] == pytest.approx(Wt / math.cos(math.radians(pa)), rel=1e-10)
    # the force on gear 2: its tangential part is W_t, its radial part W_t tan φ towards gear 2's centre
    P = np.array([(-rg if internal else rg) / 1000, 0.0])  # the pitch point (the ring's centre is at +x)
    F = np.array([f["F_g_x"], f["F_g_y"]])
    radial = F @ (-P / np.linalg.norm(P))
    assert radial == pytest.approx(Wt * math.tan(math.radians(pa)), rel=1e-9)
    assert abs(F @ np.array([0.0, 1.0])) == pytest.approx(Wt, rel=1e-9)
    # the moment of the tooth force about gear 2's pivot is what drives it: T − I2 α2
    assert P[0] * F[1] - P[1] * F[0] == pytest.approx(-(T - 2e-4 * a2), rel=1e-9)
    assert f["power_residual"] == pytest.approx(0.0, abs=1e-9)


def test_tooth_force_along_a_sweep_and_on_the_pins():
    mech = ls.loads(GEAR_TRAIN.format(d=30, rg=12, rm=18, load=2.0, extra="pressure_angle = 20"))
    f = ls.forces(mech, 0, 360, 30, speed=10.0)
    Wt = 2.0 / 0.018
    assert np.allclose(f["F_g"], Wt / math.cos(math.radians(20)))
    # gear 2's pin carries the tooth force (its centre of mass is on the axis and it does not accelerate)
    assert np.allclose(np.asarray(f["F_O2_x"]), -np.asarray(f["F_g_x"]))
    assert np.allclose(np.asarray(f["F_O2_y"]), -np.asarray(f["F_g_y"]))


RACK = """
name = "rack and pinion"
units = { length = "mm", angle = "deg" }
[variables]
theta = { input = true, guess = 0 }
x = { guess = 0 }
[vectors]
r2 = { length = 10, angle = "theta" }
rack = { length = "x", angle = 0 }
drop = { length = 20, angle = -90 }
[points]
O = "0"
A = "r2"
R = "drop + rack"
[gears]
drive = { gear = "theta", rack = "x", radius = "20mm" }
[bodies]
pinion = { mass = "0.2kg", inertia = "1e-4kg*m^2", com = "O", angle = "theta", joints = ["O"] }
slide = { mass = "1.5kg", com = "R", guide = "rack", joints = [] }
[[loads]]
at = "R"
body = "slide"
force = ["-50N", 0]
"""


def test_rack_force_against_newton_on_the_rack():
    """The rack: m a = W − 50 N along x (W the tangential tooth force on the rack), T ω = (W) ẋ + I α ω."""
    mech = ls.loads(RACK)
    w, a = 4.0, 2.0
    f = ls.forces(mech, 15, speed=w, accel=a)
    xdd = 0.020 * a
    W = 1.5 * xdd + 50.0  # on the rack, along +x
    assert f["F_drive"] == pytest.approx(W / math.cos(math.radians(20)), rel=1e-10)
    assert f["input_torque"] == pytest.approx(1e-4 * a + W * 0.020, rel=1e-10)
    # on the pinion (the pair's first member): −W along x, and W tan φ towards its centre (+y)
    assert f["F_drive_x"] == pytest.approx(-W, rel=1e-10)
    assert f["F_drive_y"] == pytest.approx(W * math.tan(math.radians(20)), rel=1e-10)


GEARED_FIVEBAR_BODIES = """
[bodies]
crank2 = { mass = "0.1kg", inertia = "2e-5kg*m^2", com = "0.5*r2", angle = "theta2", joints = ["O1", "A"] }
arm3 = { mass = "0.2kg", inertia = "5e-5kg*m^2", com = "r2 + 0.5*r3", angle = "theta3", joints = ["A", "P"] }
arm4 = { mass = "0.2kg", inertia = "5e-5kg*m^2", com = "r1 + r5 + 0.5*r4", angle = "theta4", joints = ["B", "P"] }
crank5 = { mass = "0.1kg", inertia = "3e-5kg*m^2", com = "r1 + 0.5*r5", angle = "theta5", joints = ["O5", "B"] }

[[loads]]
at = "P"
body = "arm3"
force = [0, "-20N"]
"""


def _geared_fivebar():
    text = FIVEBAR.format(extra='[gears]\ng = { gear = "theta2", mate = "theta5", radii = [12, 18] }'
                          + GEARED_FIVEBAR_BODIES)
    text = text.replace("r1 = 40", "r1 = 30").replace('P = "r2 + r3"', 'P = "r2 + r3"\nO1 = "0"\nO5 = "r1"')
    return ls.loads(text)


def test_geared_five_bar_forces_agree_with_the_equation_of_motion():
    """Newton–Euler with the tooth force gives the driving torque of the virtual-work equation of motion."""
    from loopsolve.dynamics.dynamics_model import compile_dynamics
    from loopsolve.dynamics.kinetostatics import virtual_work_drive

    mech = _geared_fivebar()
    f = ls.forces(mech, 50, 130, 10, speed=6.0, accel=-3.0)
    dm = compile_dynamics(mech)
    T = virtual_work_drive(dm, f.sweep.z, 6.0, -3.0)
    assert np.allclose(f["input_torque"], T, rtol=1e-9, atol=1e-12)
    assert np.all(np.asarray(f["F_g"]) > 0)
    assert np.max(np.abs(f["power_residual"])) < 1e-9


def test_simulation_of_a_geared_five_bar_keeps_its_energy():
    """No loads, no gravity: the tooth force does no work, so the kinetic energy is constant."""
    mech = _geared_fivebar()
    spec = dict(mech.spec)
    spec.pop("loads")
    free = ls.build_mechanism(spec)
    sim = ls.simulate(free, 0.2, step=0.01, speed0=5.0, at=90)
    ke = np.asarray(sim.kinetic_energy)
    assert np.ptp(ke) < 1e-6 * ke[0]
