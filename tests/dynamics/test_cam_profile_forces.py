"""The contact force of a cam declared by its pitch curve (``profile``), against Newton's law on the
follower written here: the same closed form as for a law-declared cam (tests/dynamics/test_cam_forces.py)."""

import math

import numpy as np

import loopsolve as ls

from support.models import write_pitch_cam


def test_contact_force_of_a_profile_cam(tmp_path):
    """A pitch curve of 360 points: a harmonic rise of 20 mm over 180° and a harmonic return,
    s = 10(1 − cos θ), a single smooth curve (no joins). Along the follower's axis F cos φ − 100 N = m s̈,
    tan φ = (s′ − ε)/(s + √(R_p² − ε²)), with s, s′, s″ of the closed form (R_p = 48, ε = 5)."""
    mech = ls.load(write_pitch_cam(tmp_path, np.arange(360.0)))
    w = 20.0
    f = ls.forces(mech, 0, 355, 5, speed=w, accel=0.0)
    t = np.radians(np.asarray(f["theta2"]))
    s, s1, s2 = 0.010 * (1 - np.cos(t)), 0.010 * np.sin(t), 0.010 * np.cos(t)  # m, per radian
    assert np.allclose(np.asarray(f["s"]) / 1000, s, atol=1e-9)
    phi = np.arctan((s1 - 0.005) / (s + math.sqrt(0.048**2 - 0.005**2)))
    F = (0.5 * s2 * w**2 + 100.0) / np.cos(phi)
    # the curve through 360 points reproduces s″ to about 1e-6 of its size (a smooth law: the spline's
    # error is of the order of the spacing to the sixth power)
    assert np.allclose(f["F_c1"], F, rtol=1e-6)
