"""A study that varies an angle parameter given in degrees (issue 18, rows 5 and 6).

A four-bar whose frame link r1 is tilted by ``beta`` (degrees): turning the whole mechanism by
β with the crank angle θ2 absolute gives θ4(θ2, β) = β + θ4₀(θ2 − β), so ∂θ4/∂β = 1 − ω4/ω2 —
an exact reference beside central differences of single sweeps. The study must put every
design on the lockstep path (``lockstep`` is True: the vectorized continuation, not the
design-by-design fallback), give each design the rows of its own single sweep, and report
∂q/∂β in degrees per degree.
"""

from __future__ import annotations

import numpy as np
import pytest

import loopsolve as ls

pytest.importorskip("xarray")

BETAS = [-10.0, -5.0, 0.0, 5.0, 12.5]


def tilted(beta: float, *, r4_angle: str = "theta4", r1_angle: str = "beta") -> str:
    return f'''name = "Four-bar with a parameter angle"
units = {{ length = "mm", angle = "deg" }}
[parameters]
r1 = 60
r2 = 25
r3 = 70
r4 = 45
beta = {beta!r}
[variables]
theta2 = {{ input = true, guess = 90, speed = "10rpm" }}
theta3 = {{ guess = 20 }}
theta4 = {{ guess = 80 }}
[vectors]
r1 = {{ length = "r1", angle = "{r1_angle}" }}
r2 = {{ length = "r2", angle = "theta2" }}
r3 = {{ length = "r3", angle = "theta3" }}
r4 = {{ length = "r4", angle = "{r4_angle}" }}
[[loops]]
equation = "r2 + r3 = r1 + r4"
[points]
B = "r2"
C = "r2 + r3"
'''


@pytest.fixture(scope="module")
def frame_study():
    mech = ls.loads(tilted(0.0))
    return ls.study(mech, {"beta": BETAS}, 0, 360, 30, sensitivity=True)


def test_frame_angle_study_stays_on_the_lockstep_path(frame_study):
    ds = frame_study
    assert ds.status.values.tolist() == ["ok"] * len(BETAS)
    assert ds.lockstep.values.tolist() == [True] * len(BETAS)  # no design fell back to the single sweep
    assert ds.mode.values.tolist() == ["-"] * len(BETAS)


def test_frame_angle_study_rows_are_the_single_sweeps(frame_study):
    ds = frame_study
    for j, beta in enumerate(BETAS):
        sw = ls.loads(tilted(beta)).sweep(0, 360, 30)
        for col in ("theta3", "theta4", "theta4_vel", "C_x", "C_y"):
            np.testing.assert_allclose(ds[col].values[j], sw[col], rtol=1e-9, atol=1e-9, err_msg=f"{col} β={beta}")


def test_frame_angle_sensitivity_is_per_degree(frame_study):
    """d_theta4_d_beta against central differences (h = 1e-3°) of single sweeps and against
    the rotation identity 1 − ω4/ω2; the values lie between 0.4 and 2.1 deg/deg (a factor
    180/π or π/180 off would be far outside)."""
    ds = frame_study
    h = 1e-3
    for j, beta in enumerate(BETAS):
        plus = ls.loads(tilted(beta + h)).sweep(0, 360, 30)
        minus = ls.loads(tilted(beta - h)).sweep(0, 360, 30)
        sw = ls.loads(tilted(beta)).sweep(0, 360, 30)
        for q in ("theta3", "theta4"):
            cd = (plus[q] - minus[q]) / (2 * h)
            np.testing.assert_allclose(ds[f"d_{q}_d_beta"].values[j], cd, rtol=0, atol=1e-6, err_msg=f"{q} β={beta}")
            exact = 1 - sw[f"{q}_vel"] / sw["theta2_vel"]
            np.testing.assert_allclose(ds[f"d_{q}_d_beta"].values[j], exact, rtol=0, atol=1e-9)
    s = ds.d_theta4_d_beta.values
    assert 0.3 < np.min(s) and np.max(s) < 2.5


def test_coupling_offset_angle_parameter():
    """``r4`` at ``theta4 + beta``: the rocker's own direction does not move, so
    ∂θ4/∂β = −1 and ∂θ3/∂β = 0 exactly, on the lockstep path."""
    mech = ls.loads(tilted(0.0, r4_angle="theta4 + beta", r1_angle="0"))
    betas = [-4.0, 0.0, 3.0]
    ds = ls.study(mech, {"beta": betas}, 0, 360, 45, sensitivity=True)
    assert ds.lockstep.values.all() and (ds.status.values == "ok").all()
    np.testing.assert_allclose(ds.d_theta4_d_beta.values, -1.0, atol=1e-9)
    np.testing.assert_allclose(ds.d_theta3_d_beta.values, 0.0, atol=1e-9)
    base = ls.loads(tilted(0.0, r1_angle="0")).sweep(0, 360, 45)
    for j, b in enumerate(betas):
        np.testing.assert_allclose(ds.theta4.values[j], base["theta4"] - b, atol=1e-9)
