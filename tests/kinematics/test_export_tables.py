"""Tables, CSV and JSON of states and sweeps show what they should (written for mutants of
loopsolve.kinematics.export and loopsolve.kinematics.solve that survived ``tools/mutation.sh``, issue 13): the numbers in the heading of a state table, the
section headings, the input column and the mode column of a sweep table, the event lines, the
empty CSV cells of undefined rates, the JSON layout, the message of overflowing rates and the
error at a limit position. Every expected number is computed here by hand (closed forms of the
slider-crank and the four-bar, law of cosines); the triage of the other survivors is in
``tools/mutation_triage/{export,solve,newton}.txt``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import export
from loopsolve.cli import main

MODELS = ls.models_dir()
EXAMPLE1 = MODELS / "example1_slider_crank.toml"  # r2 = 5 in, r3 = 8 in, no offset, 10 rad/s
THESIS = MODELS / "thesis_crank_rocker.toml"  # 60, 25, 70, 45 mm, open, 10 rpm
DOUBLE_ROCKER = MODELS / "double_rocker.toml"  # 60, 50, 20, 45 mm, open = "-", crossed = "+"


def _cells(line: str) -> list[str]:
    """The cells of one line of a text table (columns are separated by at least two spaces)."""
    return re.split(r"\s{2,}", line.strip())


def _section(text: str, first_header: str) -> tuple[list[str], list[list[str]]]:
    """Header cells and row cells of the table section whose header starts with ``first_header``."""
    lines = text.splitlines()
    i = next(k for k, ln in enumerate(lines) if ln.startswith(first_header + " "))
    rows = []
    for ln in lines[i + 2:]:
        if not ln.strip():
            break
        rows.append(_cells(ln))
    return _cells(lines[i]), rows


def _slider(t2_deg, omega=10.0, r2=5.0, r3=8.0):
    """Slider-crank without offset: r1, dr1/dt [in, in/s] and theta3 [deg] at the crank angle."""
    t = math.radians(t2_deg)
    s, c = math.sin(t), math.cos(t)
    root = math.sqrt(r3 * r3 - r2 * r2 * s * s)
    r1 = r2 * c + root
    r1_vel = omega * (-r2 * s - r2 * r2 * s * c / root)
    theta3 = math.degrees(math.atan2(-r2 * s, root))
    return r1, r1_vel, theta3


def _theta4(t2_deg, branch, r1, r2, r3, r4):
    """theta4 [deg, (-180, 180]] of a four-bar (r2 + r3 = r1 + r4) by the law of cosines.

    ``branch`` +1 is the open assembly (the rocker turned clockwise from the pivot-to-crank-pin
    line), -1 the crossed one."""
    t = math.radians(t2_deg)
    bx, by = r2 * math.cos(t), r2 * math.sin(t)
    d = math.hypot(bx - r1, by)
    gamma = math.acos((r4 * r4 + d * d - r3 * r3) / (2 * r4 * d))
    return math.degrees(math.remainder(math.atan2(by, bx - r1) - branch * gamma, 2 * math.pi))


def _same_angle(a, b, tol):
    return abs(math.remainder(a - b, 360.0)) <= tol


# ----------------------------------------------------------------------------- state tables


def test_state_table_heading_and_sections_by_hand(capsys):
    """The heading states the input as given (fixed notation, 9 decimals) and every section is headed
    by its own words; the length and point rows are the slider-crank's closed form.

    Kills loopsolve.kinematics.export.x_fixed__mutmut_11 (every input printed as 9),
    x_state_table__mutmut_7 (input printed as nan), x_state_table__mutmut_67 ("length" heading
    garbled) and x_state_table__mutmut_97 ("point" heading garbled)."""
    at = 12.345678901
    assert main(["solve", str(EXAMPLE1), "--at", str(at)]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].startswith(
        "Example 1 slider-crank: theta2 = 12.345678901 deg, input speed 10 rad/s, accel 0 rad/s^2  (mode ")
    r1, r1_vel, theta3 = _slider(at)
    head, rows = _section(out, "angle")
    assert head == ["angle", "position [deg]", "velocity [rad/s]", "acceleration [rad/s^2]", "jerk [rad/s^3]"]
    assert rows[0][:3] == ["theta2 (input)", "12.3457", "10"]
    assert rows[1][0] == "theta3" and float(rows[1][1]) == pytest.approx(theta3, rel=1e-5)
    head, rows = _section(out, "length")
    assert head == ["length", "position [in]", "velocity [in/s]", "acceleration [in/s^2]", "jerk [in/s^3]"]
    assert [r[0] for r in rows] == ["r1"]
    assert float(rows[0][1]) == pytest.approx(r1, rel=1e-5)
    assert float(rows[0][2]) == pytest.approx(r1_vel, rel=1e-5)
    head, rows = _section(out, "point")
    assert head == ["point", "x [in]", "y [in]", "v_x [in/s]", "v_y [in/s]", "a_x [in/s^2]", "a_y [in/s^2]",
                    "j_x [in/s^3]", "j_y [in/s^3]"]
    assert [r[0] for r in rows] == ["B", "C"]
    t = math.radians(at)
    assert float(rows[0][1]) == pytest.approx(5 * math.cos(t), rel=1e-5)
    assert float(rows[0][2]) == pytest.approx(5 * math.sin(t), rel=1e-5)
    assert float(rows[1][1]) == pytest.approx(r1, rel=1e-5) and rows[1][2] == "0"
    assert float(rows[1][3]) == pytest.approx(r1_vel, rel=1e-5)


def test_state_heading_of_minus_zero_and_large_inputs():
    """An input of -0 is 0 in the heading, a large one is written out in fixed notation.

    Kills loopsolve.kinematics.export.x_fixed__mutmut_21 (-0.0 - 0.0 printed "-0")."""
    mech = ls.load(EXAMPLE1)
    for at, shown in ((-0.0, "0"), (720.5, "720.5"), (-1234567.25, "-1234567.25")):
        first = export.to_table(mech.solve(at)).splitlines()[0]
        assert first.startswith(f"Example 1 slider-crank: theta2 = {shown} deg, input speed 10 rad/s"), first


def test_fixed_notation_of_values_that_are_not_numbers():
    """``fixed`` (public) prints nan for a missing or non-finite value instead of raising or "inf".

    Kills loopsolve.kinematics.export.x_fixed__mutmut_1 (None raised TypeError, infinities printed inf)."""
    for v in (None, math.inf, -math.inf, math.nan):
        assert export.fixed(v) == "nan", v
    assert export.fixed(2.5e-10) == "0" and export.fixed(-7.0000000004) == "-7"


def test_rates_not_computed_are_nan_in_a_table_and_empty_in_csv():
    """A sweep with derivatives=1 has no accelerations or jerks: the table of one of its states
    prints nan for them, the CSV leaves the cells empty, the JSON has null; the numbers that are
    there are the slider-crank's closed form.

    Kills loopsolve.kinematics.export.x__column__mutmut_3 (a missing value raised TypeError in the table) and
    x_iter_csv__mutmut_27 (missing values written as XXXX)."""
    mech = ls.load(EXAMPLE1)
    sw = mech.sweep(0, 90, 45, derivatives=1, progress=False)
    r1, r1_vel, theta3 = _slider(45)
    table = export.to_table(sw.states[1])
    head, rows = _section(table, "length")
    assert rows[0][0] == "r1" and rows[0][3:] == ["nan", "nan"]
    assert float(rows[0][1]) == pytest.approx(r1, rel=1e-5)
    assert float(rows[0][2]) == pytest.approx(r1_vel, rel=1e-5)
    head, rows = _section(table, "angle")
    assert rows[1][0] == "theta3" and rows[1][3:] == ["nan", "nan"]

    lines = list(csv.reader(io.StringIO(export.to_csv(sw))))
    names = [h.split(" [")[0] for h in lines[0]]
    assert len(lines) == 4
    for k, t2 in enumerate((0, 45, 90)):
        row = dict(zip(names, lines[k + 1]))
        r1, r1_vel, theta3 = _slider(t2)
        assert float(row["theta2"]) == t2
        assert float(row["r1"]) == pytest.approx(r1, abs=1e-12)
        assert float(row["r1_vel"]) == pytest.approx(r1_vel, abs=1e-9)
        assert float(row["theta3"]) == pytest.approx(theta3, abs=1e-9)
        for name in ("r1_acc", "r1_jerk", "theta3_acc", "theta3_jerk", "C_x_acc", "C_x_jerk"):
            assert row[name] == "", name
        assert float(row["B_x_acc"]) == pytest.approx(-5 * 100 * math.cos(math.radians(t2)), abs=1e-9)
    doc = json.loads(export.to_json(sw))
    assert [r["r1_acc"] for r in doc["rows"]] == [None, None, None]


# ----------------------------------------------------------------------------- sweep tables


def test_sweep_table_of_one_mode_prints_the_inputs_as_given():
    """One mode: the heading names it, there is no mode column, the input column is the grid in
    fixed notation (100.0625, not 100.062) and theta4 is the law of cosines' open branch.

    Kills loopsolve.kinematics.export.x_sweep_table__mutmut_16 (a mode column for one mode),
    x_sweep_table__mutmut_26 (inputs printed with 6 digits) and x_sweep_table__mutmut_46 (the
    heading's mode printed as None)."""
    sw = ls.load(THESIS).sweep(100.0625, 100.25, 0.0625, progress=False)
    lines = export.to_table(sw).splitlines()
    assert lines[0] == "Crank-rocker four-bar: sweep of theta2 (4 rows, mode - (open))"
    head = _cells(lines[1])
    assert head == ["theta2 [deg]", "theta3 [deg]", "theta3_vel [rad/s]", "theta3_acc [rad/s^2]", "theta4 [deg]",
                    "theta4_vel [rad/s]", "theta4_acc [rad/s^2]"]
    rows = [_cells(ln) for ln in lines[3:]]
    assert [r[0] for r in rows] == ["100.0625", "100.125", "100.1875", "100.25"]
    for r in rows:
        assert len(r) == len(head)
        assert _same_angle(float(r[4]), _theta4(float(r[0]), +1, 60, 25, 70, 45), 1e-3)


def test_sweep_table_through_limits_states_modes_and_events():
    """Through the double rocker's toggle at theta2 = acos(5/16) (coupler and rocker in line,
    |O4 B| = 20 + 45): every row carries its mode's label, each row's theta4 is its branch's
    law-of-cosines value, and the events are printed with their messages.

    Kills loopsolve.kinematics.export.x_sweep_table__mutmut_36 (no mode column: TypeError) and
    x_sweep_table__mutmut_56 (event messages printed as None)."""
    sw = ls.load(DOUBLE_ROCKER).sweep(60, 180, 10, through_limits=True, progress=False)
    lines = export.to_table(sw).splitlines()
    assert lines[0] == "Double rocker: sweep of theta2 (4 rows, mode - (open))"
    head = _cells(lines[1])
    assert head[0] == "theta2 [deg]" and head[4] == "theta4 [deg]" and head[-1] == "mode"
    rows = [_cells(ln) for ln in lines[3:7]]
    assert [r[0] for r in rows] == ["60", "70", "70", "60"]
    assert [r[-1] for r in rows] == ["- (open)", "- (open)", "+ (crossed)", "+ (crossed)"]
    for r in rows:
        branch = +1 if r[-1] == "- (open)" else -1
        assert _same_angle(float(r[4]), _theta4(float(r[0]), branch, 60, 50, 20, 45), 1e-3), r
    toggle = math.degrees(math.acos((50 ** 2 + 60 ** 2 - 65 ** 2) / (2 * 50 * 60)))
    events = lines[7:]
    assert len(events) == 2
    m = re.fullmatch(r"limit at theta2 = (\S+): (.*)", events[0])
    assert m and float(m.group(1)) == pytest.approx(toggle, abs=1e-7)
    assert "limit position" in m.group(2) and m.group(2).endswith("on mode - (open)")
    m = re.fullmatch(r"mode-change at theta2 = (\S+): (.*)", events[1])
    assert m and float(m.group(1)) == pytest.approx(toggle, abs=1e-7)
    assert "onto mode + (crossed)" in m.group(2)


# ----------------------------------------------------------------------------- JSON layout


def test_json_layout_with_and_without_indent():
    """The JSON of a sweep: by default one key or row per line (no trailing blanks), with
    ``indent`` the given indentation, with ``indent=None`` exactly what json.dumps writes of the
    same document on one line; the values are the four-bar's law of cosines.

    Kills loopsolve.kinematics.export.x_to_json__mutmut_5 (indent ignored: always one line) and
    x_iter_json__mutmut_26 (", " and "," swapped: trailing blanks with an indent, "," without)."""
    sw = ls.load(THESIS).sweep(0, 300, 100, progress=False)
    text = export.to_json(sw)
    doc = json.loads(text)
    assert list(doc) == ["mechanism", "input", "units", "mode", "rows", "events"]
    assert doc["mechanism"] == "Crank-rocker four-bar" and doc["input"] == "theta2" and doc["mode"] == "-"
    assert [r["theta2"] for r in doc["rows"]] == [0, 100, 200, 300]
    for r in doc["rows"]:
        assert _same_angle(r["theta4"], _theta4(r["theta2"], +1, 60, 25, 70, 45), 1e-9)
        assert r["theta2_vel"] == pytest.approx(2 * math.pi * 10 / 60, rel=1e-12)
    lines = text.splitlines()
    assert all(ln == ln.rstrip() for ln in lines)
    assert lines[:3] == ["{", ' "mechanism": "Crank-rocker four-bar",', ' "input": "theta2",']
    assert sum(ln.startswith('  {"theta2": ') for ln in lines) == 4
    assert lines[-1] == "}" and lines[-2] == ' "events": []'
    wide = export.to_json(sw, indent=4)
    assert json.loads(wide) == doc
    assert sum(ln.startswith(8 * " " + '{"theta2": ') for ln in wide.splitlines()) == 4
    compact = export.to_json(sw, indent=None)
    assert compact == json.dumps(doc)


# ----------------------------------------------------------------------------- solve


def test_overflowing_rates_name_the_file_and_the_speed(tmp_path, capsys):
    """Rates that overflow floating point are a ModelError naming the model file, the speed and
    the option to change (CLI: one line, exit 2).

    Kills loopsolve.kinematics.solve.x_solve_rates__mutmut_148 (the message was None) and
    x_solve_rates__mutmut_158 (the rates' unit given as deg/s)."""
    path = tmp_path / "huge.toml"
    text = THESIS.read_text(encoding="utf-8")
    for name, value in (("r1", 60), ("r2", 25), ("r3", 70), ("r4", 45)):
        text = text.replace(f"{name} = {value}\n", f"{name} = {value}e9\n")
    path.write_text(text, encoding="utf-8")
    # the rocker's jerk is of order speed^3 = 1e300 rad/s^3, the point C's 45e9 times that: inf
    mech = ls.load(path)
    with pytest.raises(ls.ModelError) as info:
        mech.solve(30, speed=1e100)
    msg = str(info.value)
    assert str(path) in msg or "huge.toml" in msg
    assert "speed 1e+100" in msg and "--speed" in msg
    assert "(rad/s based)" in msg  # the rates of a degree model are per radian, not per degree
    assert main(["solve", str(path), "--at", "30", "--speed", "1e100"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "huge.toml" in err[0] and "speed 1e+100" in err[0]


INCLINED = """
name = "inclined short-rod slider-crank"
units = { length = "mm", angle = "deg" }
[parameters]
r2 = 30
r3 = 25
e = 10
[variables]
theta2 = { input = true, guess = 0 }
theta3 = { guess = -60 }
s = { guess = 26 }
[vectors]
r2 = { length = "r2", angle = "theta2" }
r3 = { length = "r3", angle = "theta3" }
rs = { length = "s", angle = 30 }
re = { length = "e", angle = 120 }
[[loops]]
equation = "r2 + r3 = rs + re"
"""


def test_limit_position_from_guesses_where_newton_stalls():
    """At theta2 = 0 the crank pin is 30 cos(120°) - 10 = -25 from the slide: the rod (25) is normal
    to it, a limit position. From these guesses Newton stalls; the two modes meet there, so the
    answer is a singular position with the rod at 120° and the slider at the pin's projection on
    the slide, s = 30 cos 30° = 15√3, not a crash.

    Kills loopsolve.kinematics.solve.x__coincide__mutmut_21 (TypeError for a length variable) and
    x_start_position__mutmut_63/73 (TypeError in that branch)."""
    mech = ls.loads(INCLINED, source="inclined.toml")
    with pytest.raises(ls.SingularPositionError) as info:
        mech.solve(0)
    t3 = math.degrees(info.value.result[1])
    assert _same_angle(t3, 120.0, 1e-6)
    assert info.value.result[2] == pytest.approx(15 * math.sqrt(3), abs=1e-7)


@pytest.mark.parametrize("factor", [1e-6, 1e6, 1e8])
def test_a_regular_pose_of_a_large_slider_crank_is_not_singular(factor):
    """Example 1's slider-crank with every length `factor` times larger (the same mechanism in a
    unit that many times smaller) solves at 30° to the closed form scaled by `factor`, like its sweep.

    Real bug found while writing the overflow test: the singularity test of solve_rates compared
    the slider's column of Φ_q (1) with the crank's and rod's (of the order of the links), so from
    about 1e6 units a regular pose was a SingularPositionError while the sweep solved it."""
    text = EXAMPLE1.read_text(encoding="utf-8")
    text = text.replace("r2 = 5\n", f"r2 = {5 * factor!r}\n").replace("r3 = 8\n", f"r3 = {8 * factor!r}\n")
    text = text.replace("r1 = { guess = 10.7 }", f"r1 = {{ guess = {10.7 * factor!r} }}")
    mech = ls.loads(text, source="scaled.toml")
    r1, r1_vel, theta3 = _slider(30)
    s = mech.solve(30)
    assert s["r1"] == pytest.approx(r1 * factor, rel=1e-12)
    assert s["r1_vel"] == pytest.approx(r1_vel * factor, rel=1e-9)
    assert s["theta3"] == pytest.approx(theta3, abs=1e-9)
    sw = mech.sweep(0, 60, 30, progress=False)
    assert sw["r1"][1] == pytest.approx(s["r1"], rel=1e-12) and not sw.events


def test_a_few_ulps_beyond_the_limit_of_a_large_model_is_at_the_limit():
    """Example 1's slider-crank a million times larger, driven by its slider r1: the limit is r1 =
    r2 + r3 = 13e6 (crank and rod in line). An input 4 ulps (7.5e-9, 6e-16 relative) beyond it is
    the limit position within floating point (singular, rod along the slide); 2e-7 beyond it is an
    input outside the range (AssemblyError naming 13e6).

    Kills loopsolve.kinematics.solve.x_solve__mutmut_89 (the relative tolerance 1e-15·|x| turned into 1e-15/|x|)."""
    text = EXAMPLE1.read_text(encoding="utf-8")
    text = text.replace("r2 = 5\n", "r2 = 5e6\n").replace("r3 = 8\n", "r3 = 8e6\n")
    text = text.replace("r1 = { guess = 10.7 }", "r1 = { guess = 10.7e6 }")
    mech = ls.loads(text, source="large.toml")
    x = 13e6
    for _ in range(4):
        x = math.nextafter(x, math.inf)
    with pytest.raises(ls.SingularPositionError) as info:
        mech.solve(x, input="r1")
    t2, t3 = (math.degrees(v) for v in info.value.result[:2])  # theta2, theta3 (r1 is the input)
    assert _same_angle(t2, 0.0, 1e-3) and _same_angle(t3, 0.0, 1e-3)
    with pytest.raises(ls.AssemblyError) as info:
        mech.solve(13e6 + 2e-7, input="r1")
    assert not isinstance(info.value, ls.SingularPositionError)
    assert info.value.nearest == pytest.approx((13e6,), abs=1e-6)


def test_errors_of_a_radian_model_give_the_input_in_radians():
    """The double rocker in radians: at its toggle theta2 = acos(5/16) (|O4 B| = 20 + 45) the
    singular-position error states the input in rad, with the coupler and rocker in line
    (theta4 towards B from O4, theta3 opposite).

    Kills loopsolve.kinematics.solve.x_input_unit__mutmut_7 (every angle input labelled deg)."""
    text = DOUBLE_ROCKER.read_text(encoding="utf-8").replace('angle = "deg"', 'angle = "rad"')
    text = text.replace("guess = 60,", "guess = 1.0472,").replace("guess = -2.5", "guess = -0.0436")
    text = text.replace("guess = 109.5", "guess = 1.911")
    mech = ls.loads(text, source="double_rocker_rad.toml")
    toggle = math.acos((50 ** 2 + 60 ** 2 - 65 ** 2) / (2 * 50 * 60))
    with pytest.raises(ls.SingularPositionError) as info:
        mech.solve(toggle)
    msg = str(info.value)
    assert f"singular position at theta2 = {toggle:g} rad (" in msg and " deg" not in msg
    theta4 = math.atan2(50 * math.sin(toggle), 50 * math.cos(toggle) - 60)
    t3, t4 = info.value.result[1:]
    assert abs(math.remainder(t4 - theta4, 2 * math.pi)) < 1e-6
    assert abs(math.remainder(t3 - theta4 - math.pi, 2 * math.pi)) < 1e-6


def test_the_guesses_mode_holds_in_the_other_range_of_a_double_rocker():
    """The double rocker assembles for theta2 in [24.15°, 71.79°] and in [-71.79°, -24.15°]. Its
    guesses describe the open mode at theta2 = 60° (theta4 = 109.5°); solved in the other range
    (-60°, 300°, 310°, -40°) it keeps that mode: theta4 is the law of cosines' open branch there,
    though Newton from the raw guesses lands on the crossed one. Guesses of the crossed mode
    (theta3 = -99.6°, theta4 = 148.4° at 60°) keep the crossed mode there.

    Kills loopsolve.kinematics.solve.x__guessed_mode__mutmut_34 and x__guessed_mode__mutmut_1 (the guessed mode
    dropped; test_solve's four-bar test of the guesses' mode does not kill them)."""
    text = DOUBLE_ROCKER.read_text(encoding="utf-8")
    open_ = ls.loads(text, source="double_rocker.toml")
    crossed = ls.loads(text.replace("guess = -2.5", "guess = -99.6").replace("guess = 109.5", "guess = 148.4"),
                       source="double_rocker_crossed.toml")
    for mech, branch, mode in ((open_, +1, "-"), (crossed, -1, "+")):
        for at in (-60.0, 300.0, 310.0, -40.0, 60.0):
            s = mech.solve(at)
            assert s.mode == mode, (mech.source, at)
            assert _same_angle(s["theta4"], _theta4(at, branch, 60, 50, 20, 45), 1e-9), (mech.source, at)


# ----------------------------------------------------------------------------- newton


def _sqrt2():
    return (lambda x: np.array([x[0] ** 2 - 2.0]), lambda x: np.array([[2.0 * x[0]]]))


def test_newton_from_a_nan_start_reports_not_finite():
    """A NaN guess: newton says NOT_FINITE after 0 iterations and a solve is a ConvergenceError
    naming the input value, not a bare TypeError.

    Kills loopsolve.kinematics.newton.x__newton__mutmut_22 (the result built without its iteration count)."""
    from loopsolve.kinematics.newton import NewtonStatus, newton

    r = newton(*_sqrt2(), np.array([math.nan]))
    assert r.status is NewtonStatus.NOT_FINITE and r.n_iter == 0 and math.isnan(r.residual)
    mech = ls.load(THESIS)
    with pytest.raises(ls.ConvergenceError) as info:
        mech.solve(30, guess={"theta3": math.nan})
    assert "theta2 = 30 deg" in str(info.value)


def test_newton_converging_on_its_last_iteration_reports_its_residual():
    """x² = 2 from 1 with a tolerance of 1e-11 (atol 1e-12 times scale 10): the iterates are 1.5,
    1.41667, 1.414216, 1.41421356237469 (residual 4.5e-12 <= 1e-11, reached on iteration 4 with a
    step of 2e-6, so a polishing step would follow). With max_iter = 4 that is converged, with its
    residual; a solve whose last allowed iteration converges is a state.

    Kills loopsolve.kinematics.newton.x__newton__mutmut_162 (the residual of that result was None)."""
    from loopsolve.kinematics.newton import Newton, NewtonStatus, newton

    r = newton(*_sqrt2(), np.array([1.0]), scale=10.0, settings=Newton(max_iter=4))
    assert r.status is NewtonStatus.CONVERGED and r.n_iter == 4
    x = 1.0
    for _ in range(4):
        x = x - (x * x - 2) / (2 * x)
    assert float(r.x[0]) == pytest.approx(x, rel=1e-15)
    assert r.residual == pytest.approx(abs(x * x - 2), rel=1e-3, abs=0) and 1e-12 < r.residual <= 1e-11


def test_newton_line_search_keeps_arctan_from_diverging():
    """arctan(x) = 0 from x = 10: the full Newton step goes to 10 - 101·atan(10) = -138.6 and
    diverges; the backtracking line search (on the 2-norm of f) converges to 0.

    Kills loopsolve.kinematics.newton.x__norm2__mutmut_16 (the norm 0 for every nonzero f: no line search)."""
    from loopsolve.kinematics.newton import NewtonStatus, newton

    r = newton(lambda x: np.arctan(x), lambda x: np.array([[1.0 / (1.0 + x[0] ** 2)]]), np.array([10.0]))
    assert r.status is NewtonStatus.CONVERGED and abs(float(r.x[0])) < 1e-12


def test_newton_stops_once_the_step_is_at_round_off():
    """x² = 2 from 1 (tolerance 1e-12): Newton's errors are 8.6e-2, 2.5e-3, 2.1e-6, 1.6e-12 and then
    round-off. On the 5th iteration the residual is below the tolerance and the step (1.6e-12) below
    rtol·(1 + x) = 2.4e-12: converged there, without a further polishing iteration. On the 4th
    the residual 4.5e-12 is still above the tolerance.

    Kills loopsolve.kinematics.newton.x__newton__mutmut_142 (a polishing iteration always added)."""
    from loopsolve.kinematics.newton import NewtonStatus, newton

    x, steps = 1.0, []
    for _ in range(5):
        nxt = x - (x * x - 2) / (2 * x)
        steps.append(abs(nxt - x))
        x = nxt
    assert steps[3] > 1e-6 and steps[4] < 1e-12 * (1 + x)  # the 4th step is not at round-off, the 5th is
    r = newton(*_sqrt2(), np.array([1.0]))
    assert r.status is NewtonStatus.CONVERGED and r.n_iter == 5
    assert abs(float(r.x[0]) - math.sqrt(2)) <= 4.5e-16


def test_newton_with_a_jacobian_that_is_not_finite_reports_not_finite():
    """f(x) = x - 1 from 3 with an infinite Jacobian (a derivative blowing up at the start): no
    step can be taken; newton returns NOT_FINITE at the start point, residual 2, iteration 1.

    Kills loopsolve.kinematics.newton.x__newton__mutmut_72 (that result built without x: TypeError)."""
    from loopsolve.kinematics.newton import NewtonStatus, newton

    r = newton(lambda x: np.array([x[0] - 1.0]), lambda x: np.array([[np.inf]]), np.array([3.0]))
    assert r.status is NewtonStatus.NOT_FINITE and not r.success
    assert r.n_iter == 1 and r.residual == 2.0 and float(r.x[0]) == 3.0


# ----------------------------------------------------------------------------- solve: inputs and guesses


def _fourbar_rates(t2_deg, omega2, r1=60.0, r2=25.0, r3=70.0, r4=45.0):
    """theta4 [deg] (open) and the coupler's and rocker's angular velocities [rad/s] of a four-bar
    (velocity loop: r2 w2 e2' + r3 w3 e3' = r4 w4 e4', solved by Cramer's rule)."""
    t4 = math.radians(_theta4(t2_deg, +1, r1, r2, r3, r4))
    t2 = math.radians(t2_deg)
    cx, cy = r1 + r4 * math.cos(t4), r4 * math.sin(t4)
    t3 = math.atan2(cy - r2 * math.sin(t2), cx - r2 * math.cos(t2))
    w3 = omega2 * r2 * math.sin(t4 - t2) / (r3 * math.sin(t3 - t4))
    w4 = omega2 * r2 * math.sin(t3 - t2) / (r4 * math.sin(t3 - t4))
    return math.degrees(t4), w3, w4


def test_input_rates_with_units_and_their_errors():
    """--speed "30rpm" on the thesis crank-rocker is pi rad/s, and theta4's rate is the velocity
    loop's; a speed in a length unit or an input in a length unit is refused naming the option or
    the input.

    Kills loopsolve.kinematics.solve.x_input_rates__mutmut_9 (angle and length rate kinds swapped),
    x_input_rates__mutmut_29 (the option's name dropped from the message) and
    x_input_value__mutmut_19 (the input's name dropped from the message)."""
    mech = ls.load(THESIS)
    s = mech.solve(100, speed="30rpm", accel="2 rad/s^2")
    t4, w3, w4 = _fourbar_rates(100, math.pi)
    assert s["theta2_vel"] == pytest.approx(math.pi, rel=1e-15) and s["theta2_acc"] == 2.0
    assert _same_angle(s["theta4"], t4, 1e-9)
    assert s["theta3_vel"] == pytest.approx(w3, rel=1e-9) and s["theta4_vel"] == pytest.approx(w4, rel=1e-9)
    for kw, name in ((dict(speed="10 mm/s"), "--speed"), (dict(accel="3 deg"), "--accel"),
                     (dict(jerk="1 rpm"), "--jerk")):
        with pytest.raises(ls.units.UnitError) as info:
            mech.solve(100, **kw)
        assert str(info.value).startswith(name + ":"), str(info.value)
    with pytest.raises(ls.units.UnitError) as info:
        mech.solve("10 mm")
    assert str(info.value).startswith("input theta2:") and "'10 mm'" in str(info.value)


def test_an_input_without_a_guess_solves_without_warning():
    """The thesis crank-rocker with no guess for theta2 (theta3 and theta4 still guessed) solves at
    100° to the open theta4 of the law of cosines, and a model whose every variable has a guess
    solves without any warning.

    Kills loopsolve.kinematics.solve.x__guessed_mode__mutmut_4 (TypeError for an input without a guess) and
    x_initial_z__mutmut_23 (the "no guess for ..." warning on every solve)."""
    import warnings

    text = THESIS.read_text(encoding="utf-8").replace("guess = 90, ", "")
    assert "guess = 90" not in text
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = ls.loads(text, source="no_input_guess.toml").solve(100)
        assert _same_angle(s["theta4"], _theta4(100, +1, 60, 25, 70, 45), 1e-9)
        s = ls.load(THESIS).solve(250)
        assert _same_angle(s["theta4"], _theta4(250, +1, 60, 25, 70, 45), 1e-9)


def test_driving_the_slider_keeps_the_guesses_mode():
    """Example 1 driven by its slider (input r1, guessed 10.7 in with theta2 = 45°): at r1 = 12, 6 and 4
    the crank angle is the law of cosines' (8² = r1² + 5² - 2·5·r1·cos theta2) on the guesses' side
    (theta2 > 0), also at r1 = 4 where Newton from the raw guesses lands on theta2 < 0.

    Kills loopsolve.kinematics.solve.x_start_position__mutmut_33 (the guessed mode looked up in the model
    compiled for its declared input theta2, so r1 = 12 was read as theta2 = 12)."""
    mech = ls.load(EXAMPLE1)
    for r1 in (12.0, 6.0, 10.7, 4.0):
        s = mech.solve(r1, input="r1")
        assert s["r1"] == pytest.approx(r1, abs=1e-12)
        t2 = math.degrees(math.acos((r1 * r1 + 25 - 64) / (10 * r1)))
        assert s["theta2"] == pytest.approx(t2, abs=1e-9)
        assert s["theta3"] == pytest.approx(-math.degrees(math.asin(5 * math.sin(math.radians(t2)) / 8)), abs=1e-9)


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
