"""Example #1 of the lecture notes (seed 000_9c80aae809135345.txt), solved by hand and by loopsolve.

In-line slider-crank: r2 = 5 in, r3 = 8 in, θ2 = 45°, θ̇2 = 10 rad/s, θ̈2 = 0; the slider C moves
on the line through the crank pivot (θ1 = 0, r4 = 0). The notes start it with

    (3)  8 cos θ3 = r1 − 5/√2          (4)  8 sin θ3 = −5/√2

and stop there. The hand solution below continues with the notes' own formulas:

* position: θ3 = asin(−5/(8√2)) in the quadrant with cos θ3 > 0 (slider to the right of the
  crank pin, the configuration of the figure); r1 = 5/√2 + 8 cos θ3 from (3);
* velocity (notes' component equations with θ1 = 0, θ̇1 = 0):
  −r2 θ̇2 sin θ2 − r3 θ̇3 sin θ3 = ṙ1,   r2 θ̇2 cos θ2 + r3 θ̇3 cos θ3 = 0;
* acceleration (notes' component equations):
  −r2 θ̈2 sin θ2 − r2 θ̇2² cos θ2 − r3 θ̈3 sin θ3 − r3 θ̇3² cos θ3 = r̈1,
   r2 θ̈2 cos θ2 − r2 θ̇2² sin θ2 + r3 θ̈3 cos θ3 − r3 θ̇3² sin θ3 = 0.
  (The notes' matrix form prints +cos θ1 in the top-left entry of the acceleration matrix; the
  component equations, which are what differentiating the loop gives, have −cos θ1. With
  θ1 = 0 the printed matrix would flip the sign of r̈1: the test below shows which is right.)
"""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

import loopsolve as ls

R2, R3 = 5.0, 8.0
TH2 = math.radians(45.0)
W2, A2 = 10.0, 0.0

# ---- the hand solution, straight from the notes' formulas
SQ2 = math.sqrt(2.0)
TH3 = math.asin(-5.0 / (8.0 * SQ2))  # eq. (4); cos θ3 > 0 branch
R1 = 5.0 / SQ2 + 8.0 * math.cos(TH3)  # eq. (3)
W3 = -R2 * W2 * math.cos(TH2) / (R3 * math.cos(TH3))  # y-component of the velocity equation
R1_DOT = -R2 * W2 * math.sin(TH2) - R3 * W3 * math.sin(TH3)  # x-component
A3 = (-R2 * A2 * math.cos(TH2) + R2 * W2**2 * math.sin(TH2) + R3 * W3**2 * math.sin(TH3)) / (R3 * math.cos(TH3))
R1_DDOT = -R2 * A2 * math.sin(TH2) - R2 * W2**2 * math.cos(TH2) - R3 * A3 * math.sin(TH3) - R3 * W3**2 * math.cos(TH3)


@pytest.fixture(scope="module")
def state():
    mech = ls.load(ls.models_dir() / "example1_slider_crank.toml")
    return mech.solve()  # the model declares θ2 = 45°, 10 rad/s, 0 rad/s²


def test_hand_solution_numbers(state):
    """The hand solution (rounded as a student would write it down), and loopsolve's, rounded alike."""
    assert round(math.degrees(TH3), 4) == -26.2278
    assert round(R1, 4) == 10.7119
    assert (round(W3, 4), round(R1_DOT, 4)) == (-4.9266, -52.7737)
    assert (round(A3, 3), round(R1_DDOT, 3)) == (37.309, -395.831)
    assert (round(state["theta3"], 4), round(state["r1"], 4)) == (-26.2278, 10.7119)
    assert (round(state["theta3_vel"], 4), round(state["r1_vel"], 4)) == (-4.9266, -52.7737)
    assert (round(state["theta3_acc"], 3), round(state["r1_acc"], 3)) == (37.309, -395.831)


def test_model_is_at_the_example_input(state):
    assert state["theta2"] == 45.0
    assert state["theta2_vel"] == 10.0 and state["theta2_acc"] == 0.0


def test_notes_starting_equations_hold(state):
    th3 = math.radians(state["theta3"])
    r1 = state["r1"]
    assert 8 * math.sin(th3) == pytest.approx(-5 / SQ2, abs=1e-12)  # eq. (4)
    assert 8 * math.cos(th3) == pytest.approx(r1 - 5 / SQ2, abs=1e-12)  # eq. (3)


def test_position_of_c_and_link3(state):
    assert math.radians(state["theta3"]) == pytest.approx(TH3, abs=1e-13)
    assert state["r1"] == pytest.approx(R1, rel=1e-14)
    assert (state["C_x"], state["C_y"]) == (pytest.approx(R1, rel=1e-14), pytest.approx(0.0, abs=1e-13))
    assert state["B_x"] == pytest.approx(5 / SQ2, rel=1e-14) and state["B_y"] == pytest.approx(5 / SQ2, rel=1e-14)


def test_velocity_of_c_and_omega3(state):
    assert state["theta3_vel"] == pytest.approx(W3, rel=1e-12)
    assert state["r1_vel"] == pytest.approx(R1_DOT, rel=1e-12)
    assert state["C_x_vel"] == pytest.approx(R1_DOT, rel=1e-12)
    assert state["C_y_vel"] == pytest.approx(0.0, abs=1e-12)


def test_acceleration_of_c_and_alpha3(state):
    assert state["theta3_acc"] == pytest.approx(A3, rel=1e-12)
    assert state["r1_acc"] == pytest.approx(R1_DDOT, rel=1e-12)
    assert state["C_x_acc"] == pytest.approx(R1_DDOT, rel=1e-12)
    assert state["C_y_acc"] == pytest.approx(0.0, abs=1e-10)


def test_printed_acceleration_matrix_sign_is_a_typo(state):
    """Solving the notes' printed matrix [[+cos θ1, −r3 sin θ3], [−sin θ1, r3 cos θ3]] flips r̈1.

    The component equations (and loopsolve) give r̈1 = R1_DDOT; the matrix as printed gives −R1_DDOT.
    loopsolve's own coefficient matrix Φ_q (columns r1, θ3) at the solution is the corrected one.
    """
    rhs = np.array([R2 * A2 * math.sin(TH2) + R2 * W2**2 * math.cos(TH2) + R3 * W3**2 * math.cos(TH3),
                    -R2 * A2 * math.cos(TH2) + R2 * W2**2 * math.sin(TH2) + R3 * W3**2 * math.sin(TH3)])
    printed = np.array([[math.cos(0.0), -R3 * math.sin(TH3)], [-math.sin(0.0), R3 * math.cos(TH3)]])
    correct = np.array([[-math.cos(0.0), -R3 * math.sin(TH3)], [-math.sin(0.0), R3 * math.cos(TH3)]])
    r_printed, a3_printed = np.linalg.solve(printed, rhs)
    r_correct, a3_correct = np.linalg.solve(correct, rhs)
    assert r_correct == pytest.approx(R1_DDOT, rel=1e-12) and a3_correct == pytest.approx(A3, rel=1e-12)
    assert r_printed == pytest.approx(-R1_DDOT, rel=1e-12) and a3_printed == pytest.approx(A3, rel=1e-12)
    # loopsolve: its r̈1 is the corrected one, and so is its matrix (Φ_q columns in the order r1, θ3)
    assert state["r1_acc"] == pytest.approx(r_correct, rel=1e-12)
    assert abs(state["r1_acc"] - r_printed) > 700
    ck = state.compiled
    cols = [ck.unknowns.index("r1"), ck.unknowns.index("theta3")]
    jac = ck.jac(state.z)[:, cols]
    np.testing.assert_allclose(jac, correct, rtol=1e-13, atol=1e-13)
    assert np.max(np.abs(jac - printed)) == pytest.approx(2.0)  # differs in the top-left entry


def test_inversion_gives_back_the_crank_angle():
    """Case ii: with the slider at r1 = R1 as the input, θ2 = 45° is one of the two modes."""
    mech = ls.load(ls.models_dir() / "example1_slider_crank.toml")
    s = mech.solve(R1, input="r1", speed=R1_DOT)
    assert s["theta2"] == pytest.approx(45.0, abs=1e-10)
    assert s["theta3"] == pytest.approx(math.degrees(TH3), abs=1e-10)
    assert s["theta2_vel"] == pytest.approx(W2, rel=1e-10)
    assert s["theta3_vel"] == pytest.approx(W3, rel=1e-10)


def test_cli_prints_the_example():
    out = subprocess.run([sys.executable, "-m", "loopsolve.cli", "solve", str(ls.models_dir() / "example1_slider_crank.toml"),
                          "--format", "json"], capture_output=True, text=True, check=True).stdout
    import json

    row = json.loads(out)["rows"][0]
    assert row["r1"] == pytest.approx(R1, rel=1e-12)
    assert row["r1_vel"] == pytest.approx(R1_DOT, rel=1e-12)
    assert row["r1_acc"] == pytest.approx(R1_DDOT, rel=1e-12)
    assert row["theta3_vel"] == pytest.approx(W3, rel=1e-12) and row["theta3_acc"] == pytest.approx(A3, rel=1e-12)
