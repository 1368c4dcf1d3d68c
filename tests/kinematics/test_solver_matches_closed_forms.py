"""The general solver (Newton on the derived loop equations) equals the textbook closed forms.

The closed forms live in :mod:`loopsolve.kinematics.classic` (half-angle solution, Freudenstein, the
slider-crank quadratic, case i and case ii); the solver never uses them. Assembly modes are
chosen the way a user chooses them: through the guesses the factories write for
``mode="open"/"crossed"`` (four-bar) or ``"right"/"left"`` (slider-crank). From there the input
is stepped all around its range, each solve warm-started from the previous one, and every
position, velocity and acceleration is compared with the closed form of the same mode.

Mode conventions (classic.py docstrings): four-bar ``+1`` ⇔ sin(θ4 − θ3) > 0 ⇔ factory
"open" ⇔ signature "-"; slider-crank case i ``+1`` ⇔ the larger slider position ⇔ factory
"right"; case ii ``+1`` ⇔ sin(θ3 − θ2) > 0.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import classic

OMEGA2, ALPHA2 = 1.7, -0.9  # rad/s, rad/s²: a nonzero input acceleration exercises every term


def _circ(a_deg, b_rad):
    """Difference of two angles on the circle, in radians (a in degrees, b in radians)."""
    return (math.radians(a_deg) - float(b_rad) + math.pi) % (2 * math.pi) - math.pi


def _guess(state, names):
    """The solved unknowns of a state as a guess dict (internal units) for the next solve."""
    ck = state.compiled
    return {n: float(state.z[ck.index(n)]) for n in names}


# ============================================================================ four-bar

FOURBARS = {
    "thesis crank-rocker": (60, 25, 70, 45),
    "Prob 1 crank-rocker": (80, 20, 66, 56),
    "drag link": (20, 60, 55, 50),
    "triple rocker": (4, 3, 3.5, 5),
}
FOURBAR_MODES = {"open": +1, "crossed": -1}


def _fourbar_inputs(r1, r2, r3, r4, n=36):
    """Inputs (degrees) all around the cycle, kept 1.5 deg clear of the limit positions."""
    ranges = classic.fourbar_input_range(r1, r2, r3, r4)
    lo, hi = ranges[0]
    if hi - lo >= 2 * math.pi - 1e-12:
        return np.linspace(0.0, 360.0, n, endpoint=False)
    margin = math.radians(1.5)
    return np.degrees(np.linspace(lo + margin, hi - margin, n))


@pytest.mark.parametrize("mode", FOURBAR_MODES)
@pytest.mark.parametrize("lengths", FOURBARS.values(), ids=FOURBARS.keys())
def test_fourbar_matches_half_angle_solution_all_around(lengths, mode):
    r1, r2, r3, r4 = lengths
    sign = FOURBAR_MODES[mode]
    inputs = _fourbar_inputs(*lengths)
    mech = ls.fourbar(r1, r2, r3, r4, theta2=float(inputs[0]), mode=mode)
    ck = mech.compile()
    guess = None
    for t2 in inputs:
        s = mech.solve(float(t2), speed=OMEGA2, accel=ALPHA2, guess=guess, compiled=ck)
        guess = _guess(s, ("theta3", "theta4"))
        th2 = math.radians(t2)
        t3, t4 = classic.fourbar_position(r1, r2, r3, r4, th2, mode=sign)
        assert abs(_circ(s["theta3"], t3)) < 1e-10, (t2, s["theta3"], math.degrees(t3))
        assert abs(_circ(s["theta4"], t4)) < 1e-10, (t2, s["theta4"], math.degrees(t4))
        assert s.mode == ("-" if sign > 0 else "+")
        assert abs(float(classic.freudenstein_residual(r1, r2, r3, r4, th2, math.radians(s["theta4"])))) < 1e-12
        w3, w4 = classic.fourbar_velocity(r2, r3, r4, th2, t3, t4, OMEGA2)
        a3, a4 = classic.fourbar_acceleration(r2, r3, r4, th2, t3, t4, OMEGA2, w3, w4, ALPHA2)
        for got, want in ((s["theta3_vel"], w3), (s["theta4_vel"], w4), (s["theta3_acc"], a3), (s["theta4_acc"], a4)):
            assert got == pytest.approx(float(want), rel=1e-8, abs=1e-9 * (1 + abs(OMEGA2) ** 2))


@pytest.mark.parametrize("mode", FOURBAR_MODES)
def test_fourbar_modes_are_distinct_solutions(mode):
    """Open and crossed are really different configurations (the comparison above is not trivial)."""
    s_open = ls.fourbar(60, 25, 70, 45, theta2=40, mode="open").solve(40)
    s_crossed = ls.fourbar(60, 25, 70, 45, theta2=40, mode="crossed").solve(40)
    assert abs(s_open["theta4"] - s_crossed["theta4"]) > 10
    assert {s_open.mode, s_crossed.mode} == {"-", "+"}


def test_triple_rocker_outside_its_range_is_not_assemblable():
    """Where the half-angle discriminant is negative (closed form NaN) the solver raises AssemblyError."""
    r = (4, 3, 3.5, 5)
    (lo, hi), = classic.fourbar_input_range(*r)
    mech = ls.fourbar(*r, theta2=180, mode="open")
    for t2 in (0.0, math.degrees(lo) - 3, math.degrees(hi) + 3):
        assert np.isnan(classic.fourbar_position(*r, math.radians(t2))[0])
        with pytest.raises(ls.AssemblyError) as info:
            mech.solve(t2)
        assert info.value.input_value == pytest.approx(t2)


# ============================================================================ slider-crank, case i

SLIDERS = {
    "Example 1 (in-line)": (5, 8, 0.0),
    "Prob 2 (offset 100)": (480, 1600, 100.0),
    "negative offset": (30, 75, -20.0),
}
SLIDER_MODES = {"right": +1, "left": -1}


@pytest.mark.parametrize("mode", SLIDER_MODES)
@pytest.mark.parametrize("dims", SLIDERS.values(), ids=SLIDERS.keys())
def test_slider_crank_matches_quadratic_all_around(dims, mode):
    r2, r3, e = dims
    sign = SLIDER_MODES[mode]
    mech = ls.slider_crank(r2, r3, offset=e, theta2=0.0, mode=mode)
    ck = mech.compile()
    guess = None
    for t2 in np.linspace(0.0, 360.0, 40, endpoint=False):
        s = mech.solve(float(t2), speed=OMEGA2, accel=ALPHA2, guess=guess, compiled=ck)
        guess = _guess(s, ("theta3", "x"))
        th2 = math.radians(t2)
        r1, t3 = classic.slider_crank_position(r2, r3, th2, offset=e, mode=sign)
        assert s["x"] == pytest.approx(float(r1), rel=1e-12, abs=1e-12 * r3)
        assert abs(_circ(s["theta3"], t3)) < 1e-10
        v, w3 = classic.slider_crank_velocity(r2, r3, th2, t3, OMEGA2)
        a, a3 = classic.slider_crank_acceleration(r2, r3, th2, t3, OMEGA2, float(w3), ALPHA2)
        assert s["x_vel"] == pytest.approx(float(v), rel=1e-9, abs=1e-9 * r3)
        assert s["theta3_vel"] == pytest.approx(float(w3), rel=1e-9, abs=1e-12)
        assert s["x_acc"] == pytest.approx(float(a), rel=1e-9, abs=1e-9 * r3)
        assert s["theta3_acc"] == pytest.approx(float(a3), rel=1e-9, abs=1e-12)
        # the slider point C = r1 + r4 moves along the line y = e
        assert s["C_x"] == pytest.approx(float(r1), rel=1e-12) and s["C_y"] == pytest.approx(e, abs=1e-12 * r3)
        assert s["C_y_vel"] == pytest.approx(0.0, abs=1e-9 * r3)


# ============================================================================ slider-crank inversion (case ii)


def _inversion_inputs(r2, r3, e, n=25):
    """Slider positions x > 0 strictly inside the assemblable range |(x, e)| ∈ (|r3 − r2|, r3 + r2)."""
    lo = math.sqrt(max((r3 - r2) ** 2 - e * e, 0.0))
    hi = math.sqrt((r3 + r2) ** 2 - e * e)
    pad = 0.02 * (hi - lo)
    return np.linspace(lo + pad, hi - pad, n)


@pytest.mark.parametrize("start_theta2", [-60.0, 60.0], ids=["crank below", "crank above"])
@pytest.mark.parametrize("dims", SLIDERS.values(), ids=SLIDERS.keys())
def test_inversion_with_slider_input_matches_case_ii(dims, start_theta2):
    """`input="x"`: θ2 and θ3 unknown, both modes of the notes' case ii, rates checked through case i."""
    r2, r3, e = dims
    mech = ls.slider_crank(r2, r3, offset=e, theta2=start_theta2, mode="right")
    ck = mech.compile(input="x")
    assert ck.inputs == ("x",) and set(ck.unknowns) == {"theta2", "theta3"}
    xs = _inversion_inputs(r2, r3, e)
    # start at the x nearest the factory's pose so the guesses select that mode
    x_start = mech.variable("x").guess
    order = np.argsort(np.abs(xs - x_start))
    first = mech.solve(float(xs[order[0]]), input="x", compiled=ck)
    sign = 1 if math.sin(math.radians(first["theta3"] - first["theta2"])) > 0 else -1
    assert sign == (1 if start_theta2 < 0 else -1)
    seen_modes = set()
    speed, accel = 3.0, -2.0  # length unit/s, length unit/s²
    # march outwards from the start in both directions
    i0 = int(np.argmin(np.abs(xs - xs[order[0]])))
    for direction in (range(i0, len(xs)), range(i0, -1, -1)):
        guess = _guess(first, ("theta2", "theta3"))
        for j in direction:
            x = float(xs[j])
            s = mech.solve(x, input="x", speed=speed, accel=accel, guess=guess, compiled=ck)
            guess = _guess(s, ("theta2", "theta3"))
            seen_modes.add(s.mode)
            t2, t3 = classic.slider_crank_inversion_position(x, r2, r3, offset=e, mode=sign)
            assert abs(_circ(s["theta2"], t2)) < 1e-9, (x, s["theta2"], math.degrees(t2))
            assert abs(_circ(s["theta3"], t3)) < 1e-9
            # rates: with the solved ω2, α2 the case-i formulas must give back the slider's speed/accel
            w2, a2 = s["theta2_vel"], s["theta2_acc"]
            v, w3 = classic.slider_crank_velocity(r2, r3, t2, t3, w2)
            a, a3 = classic.slider_crank_acceleration(r2, r3, t2, t3, w2, float(w3), a2)
            assert float(v) == pytest.approx(speed, rel=1e-9)
            assert s["theta3_vel"] == pytest.approx(float(w3), rel=1e-9, abs=1e-12)
            assert float(a) == pytest.approx(accel, rel=1e-8, abs=1e-8 * abs(accel))
            assert s["theta3_acc"] == pytest.approx(float(a3), rel=1e-8, abs=1e-10)
    assert len(seen_modes) == 1


def test_inversion_dead_centres_are_not_assemblable_beyond_the_range():
    """Beyond |x| = r2 + r3 the case-ii discriminant is negative: AssemblyError, naming the input."""
    mech = ls.slider_crank(5, 8, theta2=-60)
    assert np.isnan(classic.slider_crank_inversion_position(13.5, 5, 8)[0])
    with pytest.raises(ls.AssemblyError) as info:
        mech.solve(13.5, input="x")
    assert info.value.input_value == pytest.approx(13.5)
    assert "x = 13.5" in str(info.value)
