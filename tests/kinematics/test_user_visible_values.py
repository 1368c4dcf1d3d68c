"""Tests written for mutants that survived ``tools/mutation.sh`` (mutmut) and change what a user sees.

Each test names the mutant it kills (``mutmut show NAME`` prints the diff). Surviving mutants that
cannot change a user-visible result are listed, with the reason, in the closing note of issue 13.
"""

from __future__ import annotations

import math

import pytest

import loopsolve as ls
from loopsolve.kinematics import export
from loopsolve.cli import main


def test_state_table_ends_with_its_last_section(capsys):
    """loopsolve.kinematics.export.x_state_table__mutmut_136 appended text after the last section."""
    mech = ls.slider_crank(5, 8, theta2=45)
    out = export.to_table(mech.solve(45))
    assert out.endswith("\n") and not out.endswith("\n\n")
    last = out.rstrip("\n").splitlines()[-1].split()
    # the last section is the points table: its last row is the slider C, with 8 numbers
    assert last[0] == "C" and len(last) == 9
    assert last[1] == f"{5 * math.cos(math.pi / 4) + math.sqrt(64 - 12.5):g}"  # x of C, 6 digits
    assert main(["solve", str(ls.models_dir() / "example1_slider_crank.toml")]) == 0
    printed = capsys.readouterr().out
    assert printed.endswith("\n") and printed.rstrip("\n").splitlines()[-1].split()[0] == "C"


def _cos_angle(a, b, opposite):
    """Angle [deg] between sides a and b of a triangle, from the side opposite it (law of cosines)."""
    return math.degrees(math.acos((a * a + b * b - opposite * opposite) / (2 * a * b)))


def test_info_fourbar_values_by_hand():
    """loopsolve.kinematics.info.x_info__mutmut_39/189/239 renamed the variables' key, dropped the crank length
    from the input range and reported the transmission angle's maximum twice."""
    data = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").info()
    assert [(v["name"], v["kind"], v["input"]) for v in data["variables"]] == [
        ("theta2", "angle", True), ("theta3", "angle", False), ("theta4", "angle", False)]
    (fb,) = data["fourbars"]
    assert fb["links"] == {"ground": "r1", "input": "r2", "coupler": "r3", "output": "r4"}
    assert (fb["grashof"], fb["input_motion"]) == ("crank-rocker", "turns fully")
    # transmission angle (coupler r3 = 70 to rocker r4 = 45) is extreme with the crank along the ground:
    # the diagonal B-O4 is then r1 - r2 = 35 or r1 + r2 = 85
    lo, hi = fb["transmission_angle_range"]
    assert lo == _approx(_cos_angle(70, 45, 35)) and hi == _approx(_cos_angle(70, 45, 85))
    data = ls.load(ls.models_dir() / "double_rocker.toml").info()
    (fb,) = data["fourbars"]
    assert fb["grashof"] == "double rocker"
    # r1 = 60, r2 = 50, r3 = 20, r4 = 45: the crank stops where B-O4 = r3 + r4 = 65 or |r3 - r4| = 25
    a, b = _cos_angle(60, 50, 65), _cos_angle(60, 50, 25)
    assert [list(r) for r in fb["input_range"]] == [[_approx(-a), _approx(-b)], [_approx(b), _approx(a)]]


def test_info_quick_return_by_hand():
    """loopsolve.kinematics.info.x_info__mutmut_139 lost the angle conversion of the quick-return figures."""
    (qr,) = ls.load(ls.models_dir() / "quick_return.toml").info()["quick_return"]
    # crank r2 = 100 on pivot distance d = 200: the lever's extremes are tangent to the crank circle,
    # crank angle between them 2*acos(r2/d) for the return, the rest for the advance
    ret = math.degrees(2 * math.acos(100 / 200))
    assert qr["return_angle"] == _approx(ret) and qr["advance_angle"] == _approx(360 - ret)
    assert qr["time_ratio"] == _approx((360 - ret) / ret)
    assert qr["rocking_angle"] == _approx(2 * math.degrees(math.asin(100 / 200)))


def test_info_topology_of_a_diagram_model():
    """loopsolve.kinematics.info.x_info__mutmut_89 renamed the joints count of a diagram model's topology."""
    topo = ls.load(ls.models_dir() / "thesis_crank_rocker_diagram.toml").info()["topology"]
    assert (topo["links"], topo["joints"]) == (4, 4)  # ground, crank, coupler, rocker; four pins


def _approx(x):
    return pytest.approx(x, abs=1e-9)


def test_a_warm_disk_cache_is_used_without_deriving(tmp_path, monkeypatch):
    """loopsolve.symbolic.compiled.x__fits__mutmut_17 rejected every good cache file (sympy on every call).
    In-process twin of test_compiled's subprocess test, which mutmut cannot see."""
    import loopsolve.symbolic.derivation
    from loopsolve.symbolic import compiled

    monkeypatch.setattr(compiled, "_MEMO", {})
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(tmp_path))
    mech = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
    mech.compile()
    assert len(list(tmp_path.glob("m_*.py"))) == 1
    compiled._MEMO.clear()

    def no_sympy(*args, **kwargs):
        raise AssertionError("derived again although a valid cache file exists")

    monkeypatch.setattr(loopsolve.symbolic.derivation, "derive", no_sympy)
    ck = mech.compile()
    assert ck.points == ("B", "C") and ck.unknowns == ("theta3", "theta4")


def test_info_table_lines_by_hand(capsys):
    """loopsolve.kinematics.info.x_format_info__mutmut_15/115/165/215 and x__quick_returns__mutmut_156/256:
    the printed ``loopsolve info`` lines of a four-bar and of a crank-shaper (crank 40 on frame 100)."""
    assert main(["info", str(ls.models_dir() / "thesis_crank_rocker.toml")]) == 0
    out = capsys.readouterr().out
    first = out.splitlines()[0]
    assert first.startswith("Crank-rocker four-bar  (") and first.endswith("thesis_crank_rocker.toml)")
    assert "crank-rocker (input r2 25, coupler r3 70, output r4 45, ground r1 60)" in out
    assert f"transmission angle (deg): {_cos_angle(70, 45, 35):.6g} to {_cos_angle(70, 45, 85):.6g}" in out
    assert main(["info", str(ls.models_dir() / "crank_shaper.toml")]) == 0
    out = capsys.readouterr().out
    ret = math.degrees(2 * math.acos(40 / 100))
    assert "crank r_crank = 40, frame d = 100, lever theta_lever, slide s_slot" in out
    assert f"time ratio {(360 - ret) / ret:.6g} (advance {360 - ret:.6g}, return {ret:.6g} deg)" in out
    assert f"lever swing {2 * math.degrees(math.asin(0.4)):.6g} deg" in out
    (qr,) = ls.load(ls.models_dir() / "crank_shaper.toml").info()["quick_return"]
    (ram,) = qr["rams"]
    # the ram's extremes are at the lever's (rod term even in the lever angle): stroke = 2 |O4 D| sin(swing/2)
    lever = math.hypot(74.278135, 185.695338)
    assert ram["max"] - ram["min"] == pytest.approx(2 * lever * 0.4, rel=1e-8)
    assert f"({ram['min']:.6g} to {ram['max']:.6g})" in out
    assert ram["advance_angle"] + ram["return_angle"] == _approx(360)


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


def test_info_table_of_a_model_without_a_file():
    """loopsolve.kinematics.info.x_format_info__mutmut_15 printed garbage after the name of a Python-built model."""
    from loopsolve.kinematics.info import format_info

    mech = ls.fourbar(60, 25, 70, 45)
    assert format_info(mech.info()).splitlines()[0] == mech.name


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


def test_angle_literals_with_a_unit_in_expressions():
    """loopsolve.symbolic.derivation.x_to_sympy__mutmut_12 / x__angle_const__mutmut_1 (no test used a literal
    such as ``30deg`` inside an expression): in a radian model ``theta2 + 30deg`` is theta2 + pi/6,
    in a degree model ``theta2 + 0.5rad`` is theta2 + 28.6479 deg."""
    from test_cache_key import assert_is_a_closure, fourbar_positions, model, solve_rad

    deg = math.pi / 180
    rad_model = model(angle="rad", ab_angle="theta2 + 30deg", guesses=(0.7, 1.0, 1.7))
    assert_is_a_closure(*solve_rad(rad_model, 0.7), fourbar_positions(20, 66, 56, 80, 10.0, 0.7 + math.pi / 6))
    deg_model = model(ab_angle="theta2 + 0.5rad")
    assert_is_a_closure(*solve_rad(deg_model, 40.0), fourbar_positions(20, 66, 56, 80, 10 * deg, 40 * deg + 0.5))
