"""A linear spring's share of the driving torque, by hand (mutation survivor of issue 18).

A spring (200 N/m, free length 40 mm) from the crank pin B to the rocker pivot O4 of the
thesis crank-rocker: at rest (speed 0) the torque it adds is dV/dθ2 = k (L − L0) dL/dθ2 with
L = |B − O4|, B = r2 (cos θ2, sin θ2), O4 = (60, 0) mm. A survivor dropped the stiffness of
every linear spring: the Newton–Euler and virtual-work forms agreed with each other (both
without the spring), so only a reference written outside the code catches it.
"""

from __future__ import annotations

import numpy as np

import loopsolve as ls

SPRING = '[[loads]]\nname = "s"\nspring = ["B", "O4"]\nbodies = ["crank", "frame"]\nstiffness = "200N/m"\nfree_length = 40\n\n'


def test_spring_adds_k_stretch_dl_dtheta():
    text = (ls.models_dir() / "thesis_crank_rocker_dynamics.toml").read_text(encoding="utf-8")
    with_spring = text.replace("[modes]", SPRING + "[modes]")
    assert with_spring != text
    f0 = ls.forces(ls.loads(text), 0, 360, 15, speed=0)
    f1 = ls.forces(ls.loads(with_spring), 0, 360, 15, speed=0)
    th = np.radians(f0.sweep["theta2"])
    r2 = 25e-3
    P = np.stack([r2 * np.cos(th) - 60e-3, r2 * np.sin(th)])
    L = np.hypot(*P)
    dL = (P * np.stack([-r2 * np.sin(th), r2 * np.cos(th)])).sum(axis=0) / L
    expected = 200.0 * (L - 0.040) * dL
    assert np.max(np.abs(expected)) > 0.1  # N*m: the spring matters (the bare linkage needs < 0.06)
    np.testing.assert_allclose(f1.drive - f0.drive, expected, rtol=0, atol=1e-9)
    # its potential energy is ½ k (L − L0)²
    np.testing.assert_allclose(f1.potential_energy - f0.potential_energy, 0.5 * 200.0 * (L - 0.040) ** 2,
                               rtol=0, atol=1e-12)
