"""Assembly modes: every real solution at one input, their names, and picking one for solve/sweep."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import loopsolve as ls
from loopsolve.kinematics import classic as C
from loopsolve.cli import main
from loopsolve.kinematics.modes import (Mode, _dyad_roots, all_solutions, assembly_modes, format_modes, modes_to_json,
                             select_mode)
from loopsolve.kinematics.solve import initial_z

from support.models import watt_sixbar

#: every test here runs with the pure-Python tracer and with the compiled fast lane (conftest.py)
pytestmark = pytest.mark.usefixtures("both_engines")

TWO_PI = 2 * math.pi


def wrap(a):
    return (np.asarray(a) + math.pi) % TWO_PI - math.pi


THESIS = ls.load(ls.models_dir() / "thesis_crank_rocker.toml")
SLIDER = ls.load(ls.models_dir() / "example1_slider_crank.toml")
QUICK = ls.load(ls.models_dir() / "quick_return.toml")
FOURBAR = ls.fourbar(60, 25, 70, 45)


class TestFourbar:
    def test_two_modes_with_aliases_match_the_half_angle_solution(self):
        modes = THESIS.modes(90)
        assert [m.signature for m in modes] == ["+", "-"]
        assert [m.aliases for m in modes] == [("crossed",), ("open",)]
        for m, cm in zip(modes, (-1, 1)):
            t3, t4 = C.fourbar_position(60, 25, 70, 45, math.radians(90), cm)
            assert abs(wrap(math.radians(m.positions["theta3"]) - t3)) < 1e-12
            assert abs(wrap(math.radians(m.positions["theta4"]) - t4)) < 1e-12
            assert m.residual < 1e-12
            assert m.positions["theta2"] == 90

    @settings(max_examples=25, deadline=None)
    @given(r12=st.tuples(st.floats(0.5, 5.0), st.floats(0.5, 5.0)), r3=st.floats(0.5, 5.0),
           t2=st.floats(-180, 180), t3=st.floats(-180, 180))
    def test_random_fourbars_have_the_closed_form_modes(self, r12, r3, t2, t3):
        # built around an assembled pose: C = B + r3 e^{i t3}, r4 = |C - O4|; so every example
        # has two real modes, one of them the pose it was built from
        r1, r2 = r12
        b = complex(r2 * math.cos(math.radians(t2)), r2 * math.sin(math.radians(t2)))
        c = b + r3 * complex(math.cos(math.radians(t3)), math.sin(math.radians(t3)))
        r4 = abs(c - r1)
        assume(r4 > 0.2)
        bd = abs(r1 - b)
        margin = min(r3 + r4 - bd, bd - abs(r3 - r4))
        assume(margin > 1e-6 * (r1 + r2 + r3 + r4))  # at a toggle the two modes coincide
        ck = FOURBAR.compile()
        mech = FOURBAR.with_parameters(r1=r1, r2=r2, r3=r3, r4=r4)
        modes = assembly_modes(mech, t2, compiled=mech.compile())
        assert [m.signature for m in modes] == ["+", "-"]
        for m, cm in zip(modes, (-1, 1)):
            t3c, t4c = C.fourbar_position(r1, r2, r3, r4, math.radians(t2), cm)
            assert abs(wrap(math.radians(m.positions["theta3"]) - t3c)) < 1e-9
            assert abs(wrap(math.radians(m.positions["theta4"]) - t4c)) < 1e-9
        assert min(abs(wrap(math.radians(m.positions["theta3"] - t3))) for m in modes) < 1e-9
        assert ck.module is mech.compile().module  # one compiled module per structure

    @settings(max_examples=25, deadline=None)
    @given(r12=st.tuples(st.floats(0.5, 5.0), st.floats(0.5, 5.0)), r3=st.floats(0.5, 5.0),
           t2=st.floats(-180, 180), extra=st.floats(1e-7, 2.0), short=st.booleans())
    def test_beyond_the_triangle_inequality_there_is_no_mode(self, r12, r3, t2, extra, short):
        # r4 just too long (r4 > r3 + |BO4|) or too short (r4 < |BO4| - r3): no real mode
        r1, r2 = r12
        bd = abs(r1 - r2 * complex(math.cos(math.radians(t2)), math.sin(math.radians(t2))))
        r4 = bd - r3 - extra if short else r3 + bd + extra
        assume(r4 > 0.1)
        mech = FOURBAR.with_parameters(r1=r1, r2=r2, r3=r3, r4=r4)
        assert assembly_modes(mech, t2, compiled=mech.compile()) == ()

    def test_not_assemblable_gives_no_mode(self):
        assert ls.fourbar(4, 3, 3.5, 5).modes(0) == ()
        assert "cannot be assembled" in format_modes(())


class TestOtherForms:
    def test_slider_crank_circle_line(self):
        modes = SLIDER.modes(45)
        assert [m.signature for m in modes] == ["+-", "--"]
        for m, cm in zip(modes, (1, -1)):
            r1, t3 = C.slider_crank_position(5, 8, math.radians(45), 0.0, cm)
            assert m.positions["r1"] == pytest.approx(float(r1), abs=1e-12)
            assert abs(wrap(math.radians(m.positions["theta3"]) - t3)) < 1e-12

    def test_slider_position_as_input(self):
        modes = SLIDER.modes(10, input="r1")
        assert len(modes) == 2
        angles = sorted(m.positions["theta2"] for m in modes)
        # r3^2 = r1^2 + r2^2 - 2 r1 r2 cos(theta2)
        expected = math.degrees(math.acos((10**2 + 5**2 - 8**2) / (2 * 10 * 5)))
        assert angles == pytest.approx([-expected, expected], abs=1e-10)

    def test_polar_vector_has_both_signs_of_its_length(self):
        modes = QUICK.modes(0)
        s = sorted(m.positions["s"] for m in modes)
        assert s == pytest.approx([-math.hypot(100, 200), math.hypot(100, 200)], rel=1e-12)

    def test_sixbar_has_four_modes(self):
        mech = watt_sixbar()
        modes = mech.modes(60)
        assert sorted(m.signature for m in modes) == ["++", "+-", "-+", "--"]
        ck = mech.compile()
        for m in modes:
            assert np.max(np.abs(ck.phi(m.z))) < 1e-10
            assert ck.signature(m.z) == m.signature
        open_ = next(m for m in modes if m.signature == "--")
        assert open_.positions["theta6"] == pytest.approx(-170.857, abs=1e-3)

    def test_non_dyad_block_is_solved_by_multistart(self):
        # theta3 enters twice (r3 and r5 at 2*theta3): not a dyad, so deduplicated multi-start Newton
        b = ls.MechanismBuilder("non-dyad")
        for k, v in dict(r1=4, r2=1, r3=3, r4=3, r5=0.5).items():
            b.parameter(k, v)
        b.variable("theta2", input=True, guess=30).variable("theta3", guess=40).variable("theta4", guess=100)
        b.vector("r1", length="r1", angle=0).vector("r2", length="r2", angle="theta2")
        b.vector("r3", length="r3", angle="theta3").vector("r5", length="r5", angle="2*theta3")
        b.vector("r4", length="r4", angle="theta4")
        b.loop("r2 + r3 + r5 = r1 + r4")
        mech = b.build()
        ck = mech.compile()
        z0 = initial_z(ck)
        assert _dyad_roots(ck, z0, ck.blocks[0]) is None
        sols = all_solutions(ck, z0)
        assert len(sols) >= 2
        for z in sols:
            assert np.max(np.abs(ck.phi(z))) < 1e-10
        # distinct (angles modulo 2 pi)
        for i in range(len(sols)):
            for j in range(i):
                assert np.max(np.abs(wrap(sols[i][1:] - sols[j][1:]))) > 1e-6
        # every solution of a fine scan of theta3 is among them
        t3 = np.linspace(-math.pi, math.pi, 20001)
        bx = 1 * math.cos(math.radians(30)) + 3 * np.cos(t3) + 0.5 * np.cos(2 * t3) - 4
        by = 1 * math.sin(math.radians(30)) + 3 * np.sin(t3) + 0.5 * np.sin(2 * t3)
        g = np.hypot(bx, by) - 3
        n_roots = int(np.sum(np.sign(g[1:]) != np.sign(g[:-1])))
        assert len(sols) == n_roots


class TestSelectMode:
    def test_alias_and_signature_pick_the_same(self):
        ck = THESIS.compile()
        za = select_mode(THESIS, math.radians(90), "crossed", compiled=ck)
        zs = select_mode(THESIS, math.radians(90), "+", compiled=ck)
        assert np.allclose(za, zs)
        assert ck.signature(za) == "+"

    def test_solve_and_sweep_in_the_chosen_mode_regardless_of_guesses(self):
        s = THESIS.solve(90, mode="crossed")
        t3, t4 = C.fourbar_position(60, 25, 70, 45, math.radians(90), -1)
        assert abs(wrap(math.radians(s["theta4"]) - t4)) < 1e-12
        sw = THESIS.sweep(0, 360, 30, mode="+")
        assert set(sw.modes) == {"+"} and sw.mode == "+"

    def test_unknown_mode_lists_the_available_ones(self):
        with pytest.raises(ls.ModelError, match=r"open = -.*\+ \(crossed\), - \(open\)"):
            THESIS.solve(90, mode="sideways")
        with pytest.raises(ls.ModelError, match="2 sign"):
            watt_sixbar().solve(60, mode="+")

    def test_missing_combination_is_a_mode_error(self):
        # with a shorter second coupler the second loop only closes on the first loop's crossed mode
        mech = watt_sixbar().with_parameters(r5=40)
        ck = mech.compile()
        assert sorted(m.signature for m in assembly_modes(mech, 60, compiled=ck)) == ["++", "+-"]
        with pytest.raises(ls.ModeError, match=r"does not exist at theta2 = 60.*\+\+, \+-") as exc:
            select_mode(mech, math.radians(60), "--", compiled=ck)
        assert exc.value.mode == "--" and sorted(exc.value.modes) == ["++", "+-"]
        z = select_mode(mech, math.radians(60), "+-", compiled=ck)
        assert ck.signature(z) == "+-"

    def test_not_assemblable_names_the_nearest_inputs(self):
        mech = ls.fourbar(4, 3, 3.5, 5)
        with pytest.raises(ls.AssemblyError) as exc:
            mech.solve(0, mode="open")
        tog = math.degrees(C.fourbar_toggle_angles(4, 3, 3.5, 5)[1])
        assert exc.value.nearest == pytest.approx((-tog, tog), abs=1e-8)
        assert "nearest assemblable" in str(exc.value)


class TestOutput:
    def test_format_and_json(self):
        modes = THESIS.modes(90)
        text = format_modes(modes)
        assert text.splitlines()[0].split() == ["mode", "theta2", "[deg]", "theta3", "[deg]", "theta4", "[deg]"]
        assert "- (open)" in text and "+ (crossed)" in text
        data = json.loads(modes_to_json(modes))
        assert [d["signature"] for d in data] == ["+", "-"]
        assert data[1]["aliases"] == ["open"]
        assert data[1]["positions"]["theta4"] == pytest.approx(80.7225, abs=1e-4)
        assert data[1]["units"]["theta4"] == "deg"
        assert isinstance(modes[0], Mode)

    def test_cli_modes(self, capsys):
        path = str(ls.models_dir() / "thesis_crank_rocker.toml")
        assert main(["modes", path, "--at", "90", "--format", "json"]) == 0
        data = json.loads(capsys.readouterr().out)
        assert [d["signature"] for d in data] == ["+", "-"]
        assert main(["modes", path, "--at", "90"]) == 0
        assert "crossed" in capsys.readouterr().out

    def test_cli_solve_with_mode(self, capsys):
        path = str(ls.models_dir() / "thesis_crank_rocker.toml")
        assert main(["solve", path, "--at", "90", "--mode", "crossed", "--format", "json"]) == 0
        row = json.loads(capsys.readouterr().out)["rows"][0]
        t3, t4 = C.fourbar_position(60, 25, 70, 45, math.radians(90), -1)
        assert abs(wrap(math.radians(row["theta4"]) - t4)) < 1e-12
