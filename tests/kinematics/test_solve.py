"""Single-position solves: typed failures that carry their data, and the Coriolis split.

* AssemblyError outside the assemblable range (the notes' B² − 4AC < 0), with the input value
  and the residual Newton could not remove;
* SingularPositionError at real singular configurations: the change point of a parallelogram
  four-bar, the toggle of a non-Grashof double-rocker, the dead centres of a slider-crank
  driven by its slider;
* ConvergenceError carrying the partial result;
* the quick-return's block: tangential + normal + slip + Coriolis = the point's acceleration,
  and the Coriolis part equals 2 ṡ θ̇4 e_t computed by hand from the geometry.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import classic
from loopsolve.kinematics.export import to_json
from loopsolve.kinematics.newton import Newton, NewtonStatus, newton
from loopsolve.kinematics.solve import initial_z, input_value, solve_position

TRIPLE_ROCKER = (4, 3, 3.5, 5)  # non-Grashof: the input rocks between 18.57° and 341.43°


# ----------------------------------------------------------------------------- AssemblyError


@pytest.mark.parametrize("at", [0.0, 10.0, -5.0, 350.0])
def test_assembly_error_outside_the_range(at):
    mech = ls.fourbar(*TRIPLE_ROCKER, theta2=180, mode="open")
    (lo, hi), = classic.fourbar_input_range(*TRIPLE_ROCKER)
    x = math.radians(at) % (2 * math.pi)
    assert not (lo <= x <= hi)
    assert np.isnan(classic.fourbar_position(*TRIPLE_ROCKER, math.radians(at))[0])
    with pytest.raises(ls.AssemblyError) as info:
        mech.solve(at)
    exc = info.value
    assert exc.input_value == pytest.approx(at)
    assert exc.residual is not None and exc.residual > 1e-6  # a real gap, not rounding
    assert f"theta2 = {at:g}" in str(exc) and "cannot be assembled" in str(exc)
    assert exc.exit_code == 3
    assert isinstance(exc, RuntimeError)


def test_assembly_error_from_solve_position_reports_the_residual():
    """The low-level solve names the gap: the closest approach of coupler and rocker circles."""
    mech = ls.fourbar(*TRIPLE_ROCKER, theta2=180, mode="open")
    ck = mech.compile()
    z0 = initial_z(ck, warn=False)
    z0[ck.index("theta2")] = 0.0
    with pytest.raises(ls.AssemblyError) as info:
        solve_position(ck, z0, display_input=0.0)
    # at θ2 = 0 the diagonal B-O4 is 1 long but |r3 - r4| = 1.5: circles miss by 0.5
    assert info.value.residual == pytest.approx(0.5, rel=0.05)
    assert "residual" in str(info.value) and "theta2 = 0" in str(info.value)
    assert info.value.result is not None and len(info.value.result) == 3


def test_slider_crank_beyond_reach_is_an_assembly_error():
    """Offset slider-crank whose rod cannot reach the line of sliding at the top of the crank."""
    mech = ls.slider_crank(5, 8, offset=-4, theta2=-90, mode="right")
    assert np.isnan(classic.slider_crank_position(5, 8, math.radians(90), offset=-4)[0])
    with pytest.raises(ls.AssemblyError) as info:
        mech.solve(90)
    assert info.value.input_value == 90


# ----------------------------------------------------------------------------- SingularPositionError


def _singular(mech, at, **kw):
    with pytest.raises(ls.SingularPositionError) as info:
        mech.solve(at, **kw)
    exc = info.value
    assert exc.input_value == pytest.approx(at)
    assert exc.cond > 1e5
    assert exc.result is not None  # the positions found are carried
    assert exc.exit_code == 3
    msg = str(exc)
    assert "singular position" in msg and "move the input away" in msg
    return exc


def test_change_point_of_a_parallelogram():
    """r1 = r3, r2 = r4: at θ2 = 0 all links are collinear and Φ_q is exactly singular."""
    mech = ls.fourbar(60, 25, 60, 25, theta2=0)
    exc = _singular(mech, 0.0)
    assert "theta3 = 0" in str(exc) and "theta4 = 0" in str(exc)
    # reached by Newton from elsewhere, the position is only known to ~1e-6 rad: still singular
    _singular(ls.fourbar(60, 25, 60, 25, theta2=10), 0.0)
    # a millidegree away the mechanism moves normally: the parallelogram keeps θ3 = 0, ω4 = ω2
    s = ls.fourbar(60, 25, 60, 25, theta2=10).solve(5.0)
    assert s["theta3"] == pytest.approx(0.0, abs=1e-9) and s["theta4_vel"] == pytest.approx(1.0, rel=1e-9)


def test_toggle_of_a_double_rocker():
    """At the limit of the non-Grashof rocker's input range coupler and rocker fold: singular."""
    (lo, hi), = classic.fourbar_input_range(*TRIPLE_ROCKER)
    mech = ls.fourbar(*TRIPLE_ROCKER, theta2=180, mode="open")
    for limit in (lo, hi):
        exc = _singular(mech, math.degrees(limit))
        t3, t4 = (float(v) for v in np.degrees(exc.result[1:]))
        assert (t3 - t4 + 180) % 360 - 180 == pytest.approx(0, abs=1e-9)  # coupler and rocker aligned
    # slightly inside the range the rates are large but defined
    s = mech.solve(math.degrees(lo) + 0.01)
    assert abs(s["theta4_vel"]) > 10


@pytest.mark.parametrize("x, theta2_guess", [(13.0, -30.0), (3.0, -150.0)], ids=["outer", "inner"])
def test_dead_centres_of_a_slider_driven_slider_crank(x, theta2_guess):
    """Driven by the slider (input x), the crank cannot be moved through its dead centres."""
    mech = ls.slider_crank(5, 8, theta2=theta2_guess)
    exc = _singular(mech, x, input="x")
    assert "x = " in str(exc)


def test_crank_driven_slider_crank_is_regular_at_dead_centre():
    """The same configuration is harmless when the crank drives (Φ_q depends on the input choice)."""
    s = ls.slider_crank(5, 8, theta2=0).solve(0.0)
    assert s["x"] == pytest.approx(13.0) and s["x_vel"] == pytest.approx(0.0, abs=1e-12)
    assert s.cond < 100


# ----------------------------------------------------------------------------- ConvergenceError


def test_convergence_error_carries_the_partial_result():
    from loopsolve.kinematics.solve import solve_position

    mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    ck = mech.compile()
    with pytest.raises(ls.ConvergenceError) as info:
        solve_position(ck, np.array([math.radians(90), 3.0, -2.0]), settings=Newton(max_iter=2), display_input=90)
    exc = info.value
    assert exc.input_value == 90
    assert isinstance(exc.result, np.ndarray) and exc.result.shape == (3,)
    assert exc.result[0] == pytest.approx(math.radians(90))  # the input stays where it was asked
    assert not np.allclose(exc.result[1:], [3.0, -2.0])  # two iterations were made
    assert "did not converge" in str(exc) and "theta2 = 90" in str(exc)
    # the partial result is a good restart: the solve then converges to the open mode
    s = mech.solve(90, guess={"theta3": exc.result[1], "theta4": exc.result[2]})
    assert np.isfinite(s["theta4"])
    # a solve does not stop where Newton gave up: the guesses name the mode (sin(θ3 − θ4) < 0: open)
    s = mech.solve(90, guess={"theta3": 3.0, "theta4": -2.0}, settings=Newton(max_iter=2))
    assert s.mode == "-" and s["theta4"] == pytest.approx(80.7225, abs=1e-4)


def test_newton_statuses():
    r = newton(lambda x: np.array([x[0] ** 2 - 2]), lambda x: np.array([[2 * x[0]]]), np.array([1.0]))
    assert r.status is NewtonStatus.CONVERGED and r.x[0] == pytest.approx(math.sqrt(2), rel=1e-15)
    # x² + 1 = 0 has no real root: Newton stalls at the residual minimum (1 at x = 0)
    r = newton(lambda x: np.array([x[0] ** 2 + 1]), lambda x: np.array([[2 * x[0]]]), np.array([0.7]))
    assert r.status is NewtonStatus.STALLED and r.residual == pytest.approx(1.0, abs=1e-3)
    # x³ = 0: a triple root, Newton converges only linearly (x → 2x/3)
    r = newton(lambda x: np.array([x[0] ** 3]), lambda x: np.array([[3 * x[0] ** 2]]), np.array([1.0]),
               settings=Newton(max_iter=3))
    assert r.status is NewtonStatus.MAX_ITER and r.x[0] == pytest.approx((2 / 3) ** 3)
    # math errors (sqrt of a negative) are a non-finite residual, not an exception
    r = newton(lambda x: np.array([math.sqrt(x[0]) - 1]), lambda x: np.array([[0.5 / math.sqrt(x[0])]]),
               np.array([-1.0]))
    assert r.status is NewtonStatus.NOT_FINITE


def test_input_values_with_units():
    mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    ck = mech.compile()
    assert input_value(ck, 90) == pytest.approx(math.pi / 2)
    assert input_value(ck, "1.2rad") == pytest.approx(1.2)
    assert input_value(ck, "0.25rev") == pytest.approx(math.pi / 2)
    with pytest.raises(ls.ModelError, match="10mm"):
        input_value(ck, "10mm")
    with pytest.raises(ls.ModelError, match="nope"):
        mech.solve(90, input="nope")


# ----------------------------------------------------------------------------- Coriolis


@pytest.mark.parametrize("theta2", [0.0, 37.0, 90.0, 200.0, 300.0])
def test_quick_return_coriolis_components(theta2):
    mech = ls.load(ls.models_dir() / "quick_return.toml")
    speed, accel = 2 * math.pi, 3.0  # 60 rpm with a crank angular acceleration, rad/s²
    s = mech.solve(theta2, accel=accel)
    assert s["theta2_vel"] == pytest.approx(speed)
    c = s.acceleration_components("r4")
    total = c.tangential + c.normal + c.slip + c.coriolis
    np.testing.assert_allclose(total, [s["A_x_acc"], s["A_y_acc"]], rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(c.total, total)

    # by hand, from the geometry: A = (r2 cos θ2, d + r2 sin θ2) is the block on the lever O4A
    r2, d = 100.0, 200.0
    t2 = math.radians(theta2)
    a = np.array([r2 * math.cos(t2), d + r2 * math.sin(t2)])
    v = r2 * speed * np.array([-math.sin(t2), math.cos(t2)])
    s_len = float(np.hypot(*a))
    s_dot = float(a @ v) / s_len  # slip speed along the slot
    th4 = math.atan2(a[1], a[0])
    th4_dot = float(a[0] * v[1] - a[1] * v[0]) / s_len**2  # lever angular velocity
    e_r = np.array([math.cos(th4), math.sin(th4)])
    e_t = np.array([-math.sin(th4), math.cos(th4)])
    assert s["s"] == pytest.approx(s_len, rel=1e-12)
    assert s["s_vel"] == pytest.approx(s_dot, rel=1e-10, abs=1e-9)
    assert s["theta4_vel"] == pytest.approx(th4_dot, rel=1e-10)
    np.testing.assert_allclose(c.coriolis, 2 * s_dot * th4_dot * e_t, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(c.normal, -s_len * th4_dot**2 * e_r, rtol=1e-10)
    np.testing.assert_allclose(c.tangential, s_len * s["theta4_acc"] * e_t, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(c.slip, s["s_acc"] * e_r, rtol=1e-10, atol=1e-9)
    # the block's acceleration is the crank pin's: r2 α2 e_t2 − r2 ω2² e_r2
    a_pin = r2 * accel * np.array([-math.sin(t2), math.cos(t2)]) - r2 * speed**2 * np.array([math.cos(t2), math.sin(t2)])
    np.testing.assert_allclose(total, a_pin, rtol=1e-10, atol=1e-8)


def test_coriolis_is_absent_without_sliding():
    s = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").solve(60)
    c = s.acceleration_components("r3")
    assert np.all(c.coriolis == 0) and np.all(c.slip == 0)
    with pytest.raises(ls.ModelError, match="unknown vector"):
        s.acceleration_components("r9")


def test_coriolis_in_json_output():
    s = ls.load(ls.models_dir() / "quick_return.toml").solve(37)
    doc = json.loads(to_json(s))
    parts = doc["acceleration_components"]["r4"]
    np.testing.assert_allclose(parts["total"], [s["A_x_acc"], s["A_y_acc"]], rtol=1e-12, atol=1e-9)


# ----------------------------------------------------------------------------- at and beyond limits (issue 9)

INCLINED = """
name = "inclined short-rod slider-crank"
units = { length = "mm", angle = "deg" }
[parameters]
r2 = 30
r3 = 25
e = 10
[variables]
theta2 = { input = true, guess = 0 }
theta3 = { guess = 10 }
s = { guess = 100 }
[vectors]
r2 = { length = "r2", angle = "theta2" }
r3 = { length = "r3", angle = "theta3" }
rs = { length = "s", angle = 30 }
re = { length = "e", angle = 120 }
[[loops]]
equation = "r2 + r3 = rs + re"
"""


def test_inclined_slider_crank_at_its_limit_is_singular_whatever_the_guesses(tmp_path, capsys):
    # the crank pin is r3 away from the line of sliding at theta2 = 0: 30 cos(0 - 120) - 10 = -25
    path = tmp_path / "inclined.toml"
    path.write_text(INCLINED)
    from loopsolve.cli import main

    assert main(["solve", str(path), "--at", "0"]) == 3
    captured = capsys.readouterr()
    assert captured.out == "" and "SingularPositionError" in captured.err and "theta3 = 120" in captured.err
    mech = ls.load(path)
    for t3 in (10, -60, 120, 170, 300):
        for s in (100, 26, 0, -40):
            with pytest.raises(ls.SingularPositionError) as info:
                mech.solve(0, guess={"theta3": math.radians(t3), "s": s})
            off = (info.value.result[1] - math.radians(120) + math.pi) % (2 * math.pi) - math.pi
            assert off == pytest.approx(0, abs=1e-9)  # the rod normal to the slide, from every guess
            assert info.value.result[2] == pytest.approx(15 * math.sqrt(3), abs=1e-9)


def test_rates_refused_at_a_limit_even_with_a_zero_residual():
    from loopsolve.kinematics.solve import solve_rates

    ck = ls.slider_crank(30, 25, offset=5, theta2=60).compile()  # limit at theta2 = 90: 30 - 5 = 25
    z = np.array([math.pi / 2, -math.pi / 2, 0.0])
    z[2] = float(ck.phi(np.array([math.pi / 2, -math.pi / 2, 0.0]))[0])  # the slider where the x sum is 0
    for _ in range(8):
        if not np.any(ck.phi(z)):
            break
        z[2] = np.nextafter(z[2], np.inf if ck.phi(z)[0] > 0 else -np.inf)
    assert not np.any(ck.phi(z))  # exactly on the loop
    with pytest.raises(ls.SingularPositionError):
        solve_rates(ck, z, (1.0, 0.0, 0.0))


def test_just_beyond_a_limit_is_an_assembly_error():
    (lo, hi), = classic.fourbar_input_range(*TRIPLE_ROCKER)
    mech = ls.fourbar(*TRIPLE_ROCKER, theta2=180)
    for at, out in ((math.degrees(lo), -1e-7), (math.degrees(hi), 1e-7)):
        with pytest.raises(ls.AssemblyError) as info:
            mech.solve(at + out)
        assert info.value.nearest == pytest.approx((math.degrees(hi) - 360, math.degrees(lo)) if out < 0 else
                                                   (math.degrees(hi), math.degrees(lo) + 360), abs=1e-9)
        with pytest.raises(ls.SingularPositionError):
            mech.solve(at)


def test_running_out_of_iterations_where_nothing_exists_is_an_assembly_error():
    mech = ls.fourbar(*TRIPLE_ROCKER, theta2=180)
    for at in (0.0, -360.0, 5.0):
        with pytest.raises(ls.AssemblyError, match="cannot be assembled"):
            mech.solve(at, settings=Newton(max_iter=2))


def test_state_repr_is_in_display_units():
    # `mech.solve(90)` at a prompt showed the internal arrays (radians in a degree model); the
    # repr gives the positions as indexing and the tables do. A square four-bar at 90°:
    # the coupler is horizontal and the rocker vertical (θ3 = 0°, θ4 = 90°) by construction.
    text = repr(ls.fourbar(10, 10, 10, 10, theta2=80).solve(90))
    assert text.startswith("State('four-bar', theta2=90 deg, theta3=")
    vals = dict(part.split("=") for part in text[len("State('four-bar', "):].split(", ")[:3])
    assert float(vals["theta3"].split()[0]) == pytest.approx(0, abs=1e-9)
    assert vals["theta4"] == "90 deg"
    assert "array" not in text and "mode='-'" in text


def _fourbar_theta4(t2_deg, sign, r1=60, r2=25, r3=70, r4=45):
    """theta4 [deg] of a four-bar by the law of cosines; sign picks the assembly (+1 / -1)."""
    t2 = math.radians(t2_deg)
    bx, by = r2 * math.cos(t2), r2 * math.sin(t2)
    d = math.hypot(r1 - bx, by)
    beta = math.atan2(-by, r1 - bx)
    gamma = math.acos((r4 * r4 + d * d - r3 * r3) / (2 * r4 * d))
    return math.degrees(beta + math.pi - sign * gamma) % 360



def test_the_guesses_mode_holds_far_from_the_guessed_input():
    """A solve keeps the mode the guesses describe (at the input's guess) wherever it is asked for.

    Written for loopsolve.kinematics.solve.x__guessed_mode__mutmut_1 (that rule dropped), which it does not
    kill: on four-bars Newton from the guesses stays on their branch anyway (see issue 13's note)."""
    for mode, sign in (("open", 1), ("crossed", -1)):
        mech = ls.fourbar(60, 25, 70, 45, theta2=90, mode=mode)
        for at in range(0, 360, 15):
            got = mech.solve(float(at))["theta4"] % 360
            assert abs(math.remainder(got - _fourbar_theta4(at, sign), 360)) < 1e-9, (mode, at)



def test_a_nan_residual_at_the_start_is_a_solve_error():
    """loopsolve.kinematics.newton.x_newton__mutmut_59 broke the NOT_FINITE result (a bare TypeError escaped).
    The vector r1 is r1 + sqrt(r1 - 9) long: from the guess r1 = 5 the residual is NaN at once."""
    text = (ls.models_dir() / "example1_slider_crank.toml").read_text()
    text = text.replace('r1 = { length = "r1", angle = 0 }', 'r1 = { length = "r1 + 0.001*sqrt(r1 - 9)", angle = 0 }')
    text = text.replace("r1 = { guess = 10.7 }", 'r1 = { guess = 5, kind = "length" }')
    mech = ls.loads(text, source="nan_start.toml")
    with pytest.raises(ls.SolveError) as info:
        mech.solve(45)
    # the loop cannot close where the length is NaN: an assembly error naming the input value, not a bare TypeError
    assert isinstance(info.value, ls.AssemblyError) and "theta2 = 45" in str(info.value)
