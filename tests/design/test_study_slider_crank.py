"""A study of slider-cranks: solve-order blocks of one unknown on the lockstep path.

The engine slider-crank (r2 + r3 = r1) solves θ3 from the y equation and r1 from the x one:
two 1×1 blocks. Mutation testing (issue 18) found no study test with such blocks: the
vectorized solve of a 1×1 block could index the wrong unknown unnoticed. Checked here against
the closed form r1 = r2 cos θ2 + √(r3² − r2² sin² θ2), θ3 = −asin(r2 sin θ2 / r3), and
∂r1/∂r2 = cos θ2 − r2 sin² θ2 / √(r3² − r2² sin² θ2).
"""

from __future__ import annotations

import numpy as np
import pytest

import loopsolve as ls

pytest.importorskip("xarray")

R2 = [30.0, 40.0, 50.0]
R3 = 140.0


def test_slider_crank_study_is_the_closed_form():
    mech = ls.load(ls.models_dir() / "engine_slider_crank.toml")
    assert [len(b.unknowns) for b in mech.compile().blocks] == [1, 1]
    ds = ls.study(mech, {"r2": R2}, 0, 360, 15, sensitivity=True, progress=False)
    assert ds.lockstep.values.tolist() == [True] * len(R2)
    assert ds.status.values.tolist() == ["ok"] * len(R2)
    t = np.radians(ds.theta2.values)
    for j, r2 in enumerate(R2):
        root = np.sqrt(R3**2 - (r2 * np.sin(t)) ** 2)
        np.testing.assert_allclose(ds.r1.values[j], r2 * np.cos(t) + root, rtol=0, atol=1e-9)
        np.testing.assert_allclose(ds.theta3.values[j], -np.degrees(np.arcsin(r2 * np.sin(t) / R3)), rtol=0, atol=1e-9)
        np.testing.assert_allclose(ds.d_r1_d_r2.values[j], np.cos(t) - r2 * np.sin(t) ** 2 / root, rtol=0, atol=1e-9)
        # the rates: dr1/dt = −r2 ω sin θ2 (1 + r2 cos θ2 / root), ω = 3000 rpm
        w = 3000 * 2 * np.pi / 60
        np.testing.assert_allclose(ds.r1_vel.values[j], -r2 * w * np.sin(t) * (1 + r2 * np.cos(t) / root),
                                   rtol=1e-9, atol=1e-6)
