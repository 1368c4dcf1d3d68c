"""Kinematic-diagram models: generated vectors/loops/guesses, both front doors, round trip, info."""

from __future__ import annotations

import json
import math
import tomllib

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import classic
from loopsolve.model import diagram
from loopsolve.cli import main
from loopsolve.errors import ModelError, ModelFileError, TopologyError
from loopsolve.model.topology import Link, PrismaticJoint, RevoluteJoint

MODELS = ls.models_dir()
THESIS_DIAGRAM = MODELS / "thesis_crank_rocker_diagram.toml"
DIAGRAM_MODELS = ["thesis_crank_rocker_diagram", "watt2_sixbar", "stephenson3_sixbar", "whitworth_quick_return",
                  "crank_shaper", "fivebar_two_inputs"]


def drawn(path):
    """Joint coordinates as written in a diagram file."""
    data = tomllib.loads(path.read_text())
    return {k: np.array(v["at"], dtype=float) for k, v in data["joints"].items()}


def angle(v):
    return math.atan2(v[1], v[0])


class TestGeneration:
    def test_thesis_diagram_generated_model(self):
        mech = ls.load(THESIS_DIAGRAM)
        spec = mech.spec
        J = drawn(THESIS_DIAGRAM)
        assert list(spec["variables"]) == ["theta_crank", "theta_coupler", "theta_rocker"]
        assert spec["variables"]["theta_crank"] == {"input": True, "guess": 90}
        # guesses are the drawn pose: theta_<link> is the direction first joint -> second joint
        assert spec["variables"]["theta_coupler"]["guess"] == pytest.approx(math.degrees(angle(J["C"] - J["B"])))
        assert spec["variables"]["theta_rocker"]["guess"] == pytest.approx(math.degrees(angle(J["O4"] - J["C"])))
        assert spec["parameters"]["r_coupler"] == pytest.approx(np.linalg.norm(J["C"] - J["B"]), rel=1e-11)
        assert spec["vectors"]["r_ground_O4"] == {"length": "r_ground_O4", "angle": 0}
        assert [lp.text for lp in mech.loops] == ["r_crank + r_coupler + r_rocker = r_ground_O4"]
        assert [p.name for p in mech.points] == ["O2", "B", "C", "O4"]
        assert mech.inputs == ("theta_crank",)

    def test_drawn_pose_is_the_start(self):
        for name in DIAGRAM_MODELS:
            path = MODELS / f"{name}.toml"
            mech = ls.load(path)
            st = mech.solve()
            assert st.n_iter <= 2 * len(st.compiled.blocks)  # the guesses already close the loops
            for j, xy in drawn(path).items():
                assert st[f"{j}_x"] == pytest.approx(xy[0], abs=1e-9)
                assert st[f"{j}_y"] == pytest.approx(xy[1], abs=1e-9)

    def test_drawn_pose_fixes_the_mode(self):
        """Mirroring the coupler-rocker pin about the line B-O4 draws the other assembly mode."""
        J = drawn(THESIS_DIAGRAM)
        b, o4 = J["B"], J["O4"]
        e = (o4 - b) / np.linalg.norm(o4 - b)
        c = J["C"] - b
        mirrored = b + 2 * np.dot(c, e) * e - c
        data = tomllib.loads(THESIS_DIAGRAM.read_text())
        data["joints"]["C"]["at"] = [float(mirrored[0]), float(mirrored[1])]
        other = ls.build_mechanism(diagram.diagram_to_spec(data))
        mech = ls.load(THESIS_DIAGRAM)
        s1, s2 = mech.solve(120), other.solve(120)
        assert s1.mode != s2.mode
        assert s1["C_y"] > s2["C_y"]
        # the two drawings are the two assembly modes of one linkage: C is where the circles about
        # B (radius r3) and O4 (radius r4) meet, on opposite sides of the line B-O4
        r3, r4 = np.linalg.norm(c), np.linalg.norm(J["C"] - o4)
        t2 = math.radians(120)
        bb, o4p = np.array([25 * math.cos(t2), 25 * math.sin(t2)]), np.array([60.0, 0.0])
        dist = np.linalg.norm(o4p - bb)
        along = (r3 ** 2 - r4 ** 2 + dist ** 2) / (2 * dist)
        u = (o4p - bb) / dist
        n = np.array([-u[1], u[0]])
        left = bb + along * u + math.sqrt(r3 ** 2 - along ** 2) * n
        right = bb + along * u - math.sqrt(r3 ** 2 - along ** 2) * n
        got = [np.array([st["C_x"], st["C_y"]]) for st in (s1, s2)]
        # the drawn C lies left of B->O4 (positive cross product), so the drawing solves to `left`
        (ux, uy), (vx, vy) = J["O4"] - J["B"], J["C"] - J["B"]
        assert ux * vy - uy * vx > 0
        np.testing.assert_allclose(got[0], left, atol=1e-9)
        np.testing.assert_allclose(got[1], right, atol=1e-9)
        assert mech.solve(120)["C_x"] != pytest.approx(other.solve(120)["C_x"], abs=1e-3)

    def test_slider_crank_diagram_against_closed_form(self):
        """An offset slider-crank as a diagram: s_<joint> is the slider's x, checked over a turn."""
        r2, r3, e = 30.0, 80.0, 12.0
        t2 = math.radians(40)
        b = np.array([r2 * math.cos(t2), r2 * math.sin(t2)])
        x0, _ = classic.slider_crank_position(r2, r3, t2, offset=e, mode=+1)
        data = {"name": "offset slider-crank", "units": {"length": "mm", "angle": "deg"},
                "joints": {"O2": {"at": [0, 0]}, "B": {"at": b.tolist()}, "C": {"at": [float(x0), e]},
                           "S": {"at": [float(x0), e], "type": "P", "axis": [1, 0]}},
                "links": {"ground": ["O2", "S"], "crank": ["O2", "B"], "rod": ["B", "C"], "slider": ["C", "S"]},
                "input": {"joint": "O2"}}
        mech = ls.build_mechanism(diagram.diagram_to_spec(data))
        assert set(mech.spec["variables"]) == {"theta_crank", "theta_rod", "s_S"}
        assert mech.spec["variables"]["s_S"]["guess"] == pytest.approx(float(x0))
        sw = mech.sweep(0, 360, 15, speed=1)
        assert len(sw) == 25 and not sw.events
        th = np.radians(sw["theta_crank"])
        x, t3 = classic.slider_crank_position(r2, r3, th, offset=e, mode=+1)
        np.testing.assert_allclose(sw["s_S"], x, atol=1e-9)
        np.testing.assert_allclose(sw["C_x"], x, atol=1e-9)
        np.testing.assert_allclose(sw["C_y"], e, atol=1e-9)
        v, _ = classic.slider_crank_velocity(r2, r3, th, t3, 1.0)
        np.testing.assert_allclose(sw["s_S_vel"], v, atol=1e-9)

    def test_python_declarations_equal_the_file(self):
        J = drawn(THESIS_DIAGRAM)
        joints = [RevoluteJoint(n, tuple(xy)) for n, xy in J.items()]
        links = [Link("ground", ["O2", "O4"]), Link("crank", ["O2", "B"]), Link("coupler", ["B", "C"]),
                 Link("rocker", ["C", "O4"])]
        file_mech = ls.load(THESIS_DIAGRAM)
        py = diagram.from_declarations(joints, links, input="O2", name=file_mech.name)
        b = ls.MechanismBuilder(file_mech.name)
        for n, xy in J.items():
            b = b.revolute(n, xy)
        for lk in links:
            b = b.link(lk.name, lk.joints)
        built = b.drive(joint="O2").build()
        for other in (py, built):
            assert other.parameters == file_mech.parameters
            assert other.variables == file_mech.variables
            assert other.vectors == file_mech.vectors
            assert other.loops == file_mech.loops
            assert other.points == file_mech.points
        assert built.solve(33).row() == file_mech.solve(33).row()

    def test_builder_refuses_mixing_layouts(self):
        b = ls.MechanismBuilder("mixed").revolute("O2", (0, 0)).variable("theta2", input=True)
        with pytest.raises(ModelError, match="either by joints and links"):
            b.build()
        with pytest.raises(ModelError, match="declared twice"):
            ls.MechanismBuilder().revolute("A", (0, 0)).revolute("A", (1, 0))

    def test_prismatic_declaration_and_guide(self):
        data = diagram.diagram_data(
            [RevoluteJoint("O2", (0, 0)), RevoluteJoint("B", (20, 30)), RevoluteJoint("C", (80, 10)),
             PrismaticJoint("S", (80, 10), (3, 0), guide="ground")],
            [Link("ground", ["O2", "S"]), Link("crank", ["O2", "B"]), Link("rod", ["B", "C"]),
             Link("slider", ["C", "S"])], input="O2", speed="10rpm")
        assert data["joints"]["S"] == {"at": [80.0, 10.0], "type": "P", "axis": [1.0, 0.0], "guide": "ground"}
        assert data["input"] == {"joint": "O2", "speed": "10rpm"}
        mech = ls.build_mechanism(diagram.diagram_to_spec(data))
        assert mech.variable("theta_crank").speed == pytest.approx(2 * math.pi / 6)
        # the ground vector to the foot of the perpendicular from the origin, then the slide
        assert mech.spec["vectors"]["r_ground_S"] == {"length": "r_ground_S", "angle": 90}
        assert mech.spec["vectors"]["r_S"] == {"length": "s_S", "angle": 0}

    def test_axis_as_angle_and_guided_moving_link(self):
        mech = ls.load(MODELS / "whitworth_quick_return.toml")
        J = drawn(MODELS / "whitworth_quick_return.toml")
        spec = mech.spec
        # the lever guides the slot; the block turns with it (no theta_block); s_slot = O4A
        assert "theta_block" not in spec["variables"]
        assert spec["variables"]["s_slot"]["guess"] == pytest.approx(np.linalg.norm(J["A"] - J["O4"]))
        assert spec["vectors"]["r_slot"] == {"length": "s_slot", "angle": "theta_lever"}
        assert spec["vectors"]["r_lever_D"]["offset"] == pytest.approx(180.0, abs=1e-4) or \
            spec["vectors"]["r_lever_D"]["offset"] == pytest.approx(-180.0, abs=1e-4)
        data = tomllib.loads((MODELS / "whitworth_quick_return.toml").read_text())
        data["joints"]["slot"]["axis"] = f"{math.degrees(angle(J['A'])):.12f}deg"
        again = ls.build_mechanism(diagram.diagram_to_spec(data))
        assert again.solve(100)["E_x"] == pytest.approx(mech.solve(100)["E_x"], abs=1e-7)

    def test_length_overrides(self):
        data = tomllib.loads(THESIS_DIAGRAM.read_text())
        data["parameters"] = {"r_coupler": 70, "r_rocker": 45}
        mech = ls.build_mechanism(diagram.diagram_to_spec(data))
        ref = ls.load(MODELS / "thesis_crank_rocker.toml")
        for x in (0, 90, 200, 300):
            a, b = mech.solve(x, speed=1), ref.solve(x, speed=1)
            assert a["C_x"] == pytest.approx(b["C_x"], abs=1e-9)
            assert a["theta_rocker_vel"] == pytest.approx(b["theta4_vel"], abs=1e-12)
        data["parameters"] = {"coupler": 70}
        with pytest.raises(TopologyError, match="parameters.coupler: not a generated length"):
            diagram.diagram_to_spec(data)


class TestSameAsVectors:
    """A four-bar given as a diagram and as vectors: identical joint coordinates and angle rates."""

    def vector_model(self):
        J = drawn(THESIS_DIAGRAM)
        b = ls.MechanismBuilder("four-bar vectors")
        lengths = dict(r1=60, r2=25, r3=float(np.linalg.norm(J["C"] - J["B"])),
                       r4=float(np.linalg.norm(J["C"] - J["O4"])))
        for k, v in lengths.items():
            b = b.parameter(k, v)
        b = b.variable("theta2", input=True, guess=90).variable("theta3", guess=16).variable("theta4", guess=80)
        for k in lengths:
            b = b.vector(k, length=k, angle=0 if k == "r1" else "theta" + k[1])
        return b.loop("r2 + r3 = r1 + r4").point("B", "r2").point("C", "r2 + r3").build()

    def test_identical_over_a_turn(self):
        vec = self.vector_model()
        dia = ls.load(THESIS_DIAGRAM)
        kw = dict(speed="10rpm", accel=2.0)
        a, b = dia.sweep(0, 360, 10, **kw), vec.sweep(0, 360, 10, **kw)
        assert len(a) == len(b) == 37
        for col in ("B_x", "B_y", "C_x", "C_y", "C_x_vel", "C_y_vel", "C_x_acc", "C_y_acc", "C_y_jerk"):
            np.testing.assert_allclose(a[col], b[col], atol=1e-9, err_msg=col)
        # angles differ by a zero reference (the rocker points C -> O4 in the diagram), rates do not
        for d_name, v_name in (("theta_coupler", "theta3"), ("theta_rocker", "theta4")):
            for suffix in ("_vel", "_acc", "_jerk"):
                np.testing.assert_allclose(a[d_name + suffix], b[v_name + suffix], atol=1e-9)
        np.testing.assert_allclose(np.cos(np.radians(a["theta_rocker"] - b["theta4"])), -1.0, atol=1e-12)

    def test_matches_the_thesis_model_to_drawing_precision(self):
        """Coordinates drawn to 0.001 mm give the thesis crank-rocker (r3 = 70, r4 = 45) to ~1e-3."""
        dia, ref = ls.load(THESIS_DIAGRAM), ls.load(MODELS / "thesis_crank_rocker.toml")
        a, b = dia.sweep(0, 360, 30, speed=1), ref.sweep(0, 360, 30, speed=1)
        np.testing.assert_allclose(a["C_x"], b["C_x"], atol=2e-3)
        np.testing.assert_allclose(a["theta_rocker_vel"], b["theta4_vel"], atol=1e-4)

    def test_round_trip_vector_file(self, tmp_path):
        dia = ls.load(MODELS / "stephenson3_sixbar.toml")
        text = diagram.to_vector_model(MODELS / "stephenson3_sixbar.toml")
        assert "[joints]" not in text and "[[loops]]" in text
        path = tmp_path / "generated.toml"
        path.write_text(text)
        vec = ls.load(path)
        assert "joints" not in vec.spec
        for field in ("parameters", "variables", "vectors", "loops", "points", "units", "name"):
            assert getattr(vec, field) == getattr(dia, field), field
        assert diagram.topology_of(vec) is None
        a, b = dia.solve(123.0), vec.solve(123.0)
        assert a.row() == b.row()
        # and once more: writing the vector model again gives the same text (minus the header)
        assert ls.dumps(vec) == text.split("\n", 3)[3]


class TestFormatErrors:
    @pytest.mark.parametrize("edit, key, message", [
        (lambda d: d["joints"]["B"].pop("at"), "joints.B.at", "expected the drawn position [x, y]"),
        (lambda d: d["joints"]["B"].update(at=[0, "25 blargs"]), "joints.B.at", "unknown unit 'blargs'"),
        (lambda d: d["joints"]["B"].update(type="Q"), "joints.B.type", "expected \"R\" (revolute) or \"P\""),
        (lambda d: d["joints"]["B"].update(type="P"), "joints.B", "a prismatic joint needs `axis`"),
        (lambda d: d["joints"]["B"].update(axis=[1, 0]), "joints.B.axis", "`axis` is for a prismatic joint"),
        (lambda d: d["links"].update(crank="O2"), "links.crank", "expected the list of joints"),
        (lambda d: d.update(input={"drive": "O2"}), "input", "unknown key(s) ['drive']"),
        (lambda d: d.update(vectors={"r1": {"x": 1, "y": 2}}), "vectors", "generates its vectors"),
        (lambda d: d.update(colour="red"), "colour", "unknown key 'colour'"),
        (lambda d: d["joints"].update({"2X": {"at": [0, 0]}}), "joints.2X", "is not a valid name"),
    ])
    def test_format_problem_names_file_and_key(self, edit, key, message):
        data = tomllib.loads(THESIS_DIAGRAM.read_text())
        edit(data)
        with pytest.raises(ModelFileError) as exc:
            diagram.diagram_to_spec(data, source="bad.toml")
        assert exc.value.path == "bad.toml"
        assert key in str(exc.value) and message in str(exc.value)

    def test_file_with_both_layouts(self):
        text = THESIS_DIAGRAM.read_text() + '\n[vectors]\nr1 = { length = 1, angle = 0 }\n'
        with pytest.raises(ModelFileError, match="either"):
            ls.loads(text, source="both.toml")


class TestInfo:
    def run_info(self, capsys, name):
        assert main(["info", str(MODELS / f"{name}.toml"), "--format", "json"]) == 0
        return json.loads(capsys.readouterr().out)

    def test_info_json_sixbar(self, capsys):
        d = self.run_info(capsys, "watt2_sixbar")
        assert d["mobility"] == 1 and d["mobility_rank"] == 1
        assert d["inputs"] == ["theta_crank"]
        assert d["unknowns"] == ["theta_coupler", "theta_rocker", "theta_coupler2", "theta_output"]
        assert len(d["loops"]) == 2
        assert d["blocks"] == [["theta_coupler", "theta_rocker"], ["theta_coupler2", "theta_output"]]
        assert d["topology"]["formula"] == "M = 3(6 - 1) - 2*7 = 1"
        fb1, fb2 = d["fourbars"]
        J = drawn(MODELS / "watt2_sixbar.toml")
        dist = {k: float(np.linalg.norm(J[k[0]] - J[k[1]])) for k in
                (("O2", "O4"), ("O2", "A"), ("A", "B"), ("B", "O4"), ("O4", "O6"), ("O4", "C"), ("C", "D"),
                 ("D", "O6"))}
        assert fb1["links"] == {"ground": "ground", "input": "crank", "coupler": "coupler", "output": "rocker"}
        assert fb2["links"] == {"ground": "ground", "input": "rocker", "coupler": "coupler2", "output": "output"}
        np.testing.assert_allclose([fb1["lengths"][k] for k in ("ground", "input", "coupler", "output")],
                                   [dist["O2", "O4"], dist["O2", "A"], dist["A", "B"], dist["B", "O4"]], rtol=1e-9)
        np.testing.assert_allclose([fb2["lengths"][k] for k in ("ground", "input", "coupler", "output")],
                                   [dist["O4", "O6"], dist["O4", "C"], dist["C", "D"], dist["D", "O6"]], rtol=1e-9)
        # loop 1: 25 + 70 < 60 + 45 with the crank shortest: a crank-rocker whose crank turns fully
        assert (fb1["grashof"], fb1["input_motion"], fb1["input_range"]) == ("crank-rocker", "turns fully",
                                                                            [[-180.0, 180.0]])
        # loop 2 as a four-bar is a crank-rocker too (O4C = 25 shortest, 25 + 74.3 < 65 + 55), but its
        # input is the rocker of loop 1: it only swings between the rocker's limits, where crank and
        # coupler of loop 1 are collinear (O2B = 70 +- 25); theta_rocker is the direction O4 -> B
        assert (fb2["grashof"], fb2["input"], fb2["input_motion"], fb2["driven_by"]) == \
            ("crank-rocker", "theta_rocker", "rocks", "loop1")
        psi = [math.degrees(math.acos((60 ** 2 + 45 ** 2 - diag ** 2) / (2 * 60 * 45))) for diag in (95, 45)]
        np.testing.assert_allclose(fb2["input_range"], [[180 - psi[0], 180 - psi[1]]], atol=1e-6)
        # its transmission angle (between coupler2 and output) over a crank turn, from the solver
        sw = ls.load(MODELS / "watt2_sixbar.toml").sweep(0, 360, 0.5)
        mu = np.abs((sw["theta_output"] - sw["theta_coupler2"] + 180) % 360 - 180)
        np.testing.assert_allclose(fb2["transmission_angle_range"], [mu.min(), mu.max()], atol=0.01)

    # Four-bars written as vector loops, driven by either side: the link roles, Grashof class
    # (S + L against P + Q, and which link is the shortest) written by hand; the input ranges from
    # the law of cosines on the diagonal from the input's pin to the other pivot, which is the sum
    # or the difference of the two far links where they are collinear (the limits).
    # (lengths r1..r4, input, equation, roles input/coupler/output, class, rocks?, frame direction
    # at the input's pivot: 0 at O2 (towards O4), 180 at O4 (towards O2))
    TABLE = [
        # thesis: S = r2 = 25, 25 + 70 = 95 < 60 + 45: crank-rocker from r2, rocker-crank from r4
        ((60, 25, 70, 45), "theta2", "r2 + r3 = r1 + r4", ("r2", "r3", "r4"), "crank-rocker", None, 0),
        ((60, 25, 70, 45), "theta4", "r2 + r3 = r1 + r4", ("r4", "r3", "r2"), "rocker-crank", "rocks", 180),
        ((60, 25, 70, 45), "theta4", "r1 + r4 = r2 + r3", ("r4", "r3", "r2"), "rocker-crank", "rocks", 180),
        ((60, 25, 70, 45), "theta4", "r2 + r3 - r4 - r1 = 0", ("r4", "r3", "r2"), "rocker-crank", "rocks", 180),
        # S = r3 = 20 (the coupler), 20 + 60 = 80 < 50 + 45: Grashof double rocker either way round
        ((60, 50, 20, 45), "theta2", "r2 + r3 = r1 + r4", ("r2", "r3", "r4"), "double rocker", "rocks", 0),
        ((60, 50, 20, 45), "theta4", "r2 + r3 = r1 + r4", ("r4", "r3", "r2"), "double rocker", "rocks", 180),
        # 3 + 5 = 8 > 4 + 3.5: triple rocker (non-Grashof)
        ((4, 3, 3.5, 5), "theta2", "r2 + r3 = r1 + r4", ("r2", "r3", "r4"), "triple rocker", "rocks", 0),
        # S = r1 = 20 (the frame), 20 + 60 = 80 < 50 + 60: double crank
        ((20, 60, 50, 60), "theta2", "r2 + r3 = r1 + r4", ("r2", "r3", "r4"), "double crank", None, 0),
        # S = r4 = 2 (the output), 2 + 5 = 7 < 4 + 4.5: rocker-crank driven by r2, crank-rocker by r4
        ((4, 5, 4.5, 2), "theta2", "r2 + r3 = r1 + r4", ("r2", "r3", "r4"), "rocker-crank", "rocks", 0),
        ((4, 5, 4.5, 2), "theta4", "r2 + r3 = r1 + r4", ("r4", "r3", "r2"), "crank-rocker", None, 180),
    ]

    @pytest.mark.parametrize("lengths, inp, equation, roles, grashof, rocks, frame_dir", TABLE)
    def test_info_fourbar_table(self, lengths, inp, equation, roles, grashof, rocks, frame_dir):
        r = dict(zip(("r1", "r2", "r3", "r4"), lengths))
        # guesses: a pose of the open circuit, from the drawn crank angle (any assembled pose will do)
        t2 = {(60, 50, 20, 45): 50.0, (4, 3, 3.5, 5): 90.0, (4, 5, 4.5, 2): 60.0}.get(lengths, 60.0)
        t3, t4 = classic.fourbar_position(*lengths, math.radians(t2), mode=+1)
        mech = ls.build_mechanism({
            "name": "table", "units": {"length": "mm", "angle": "deg"}, "parameters": r,
            "variables": {"theta2": {"input": True, "guess": t2}, "theta3": {"guess": math.degrees(t3)},
                          "theta4": {"guess": math.degrees(t4)}},
            "vectors": {"r1": {"length": "r1", "angle": 0}, "r2": {"length": "r2", "angle": "theta2"},
                        "r3": {"length": "r3", "angle": "theta3"}, "r4": {"length": "r4", "angle": "theta4"}},
            "loops": [{"equation": equation}]})
        fb, = mech.info(input=inp)["fourbars"]
        assert fb["links"] == {"ground": "r1", "input": roles[0], "coupler": roles[1], "output": roles[2]}
        assert fb["lengths"] == {"ground": r["r1"], "input": r[roles[0]], "coupler": r[roles[1]],
                                 "output": r[roles[2]]}
        assert fb["grashof"] == grashof and fb["input"] == inp
        assert fb["input_motion"] == (rocks or "turns fully")
        g, a, b, c = r["r1"], r[roles[0]], r[roles[1]], r[roles[2]]

        def limit(diag):  # input angle at its pivot, from the frame, where the diagonal is `diag`
            cos = (g * g + a * a - diag * diag) / (2 * g * a)
            return math.degrees(math.acos(cos)) if -1 <= cos <= 1 else None

        outer, inner = limit(b + c), limit(abs(b - c))
        if rocks is None:
            expected = [[-180.0, 180.0]]
        elif outer is None:  # never stretched: |phi| from the inner limit round through 180
            expected = [[inner, 360 - inner]]
        elif inner is None:
            expected = [[-outer, outer]]
        else:
            expected = [[-outer, -inner], [inner, outer]]
        if rocks is not None and frame_dir == 180:  # measured from O4 -> O2: theta4 = 180 - phi
            moved = []
            for lo, hi in expected:
                lo, hi = 180 - hi, 180 - lo
                shift = 360 * math.floor((lo + 180) / 360)  # shown starting in [-180, 180)
                moved.append([lo - shift, hi - shift])
            expected = sorted(moved)
        np.testing.assert_allclose(fb["input_range"], expected, atol=1e-7)
        if rocks is not None:  # inside a range the linkage assembles, just outside it does not
            for lo, hi in fb["input_range"]:
                mech.solve((lo + hi) / 2, input=inp)
                with pytest.raises(ls.SolveError):
                    mech.solve(lo - 0.01, input=inp)

    def test_info_input_range_in_the_crank_variable(self, capsys):
        """A triple rocker drawn with a tilted frame: its input range is in theta_crank itself."""
        tilt = math.radians(30)
        rot = np.array([[math.cos(tilt), -math.sin(tilt)], [math.sin(tilt), math.cos(tilt)]])
        r1, r2, r3, r4 = 4.0, 3.0, 3.5, 5.0  # 3 + 5 > 4 + 3.5: non-Grashof, the crank rocks
        t2 = math.radians(90)
        t3, t4 = classic.fourbar_position(r1, r2, r3, r4, t2, mode=+1)
        pts = {"O2": (0, 0), "B": (r2 * math.cos(t2), r2 * math.sin(t2)),
               "C": (r1 + r4 * math.cos(t4), r4 * math.sin(t4)), "O4": (r1, 0)}
        data = {"name": "tilted", "units": {"length": "mm", "angle": "deg"},
                "joints": {k: {"at": (rot @ np.array(v)).tolist()} for k, v in pts.items()},
                "links": {"ground": ["O2", "O4"], "crank": ["O2", "B"], "coupler": ["B", "C"],
                          "rocker": ["O4", "C"]}, "input": {"joint": "O2"}}
        mech = ls.build_mechanism(diagram.diagram_to_spec(data))
        fb = mech.info()["fourbars"][0]
        assert fb["grashof"] == "triple rocker"
        # never stretched (3 + 4 < 3.5 + 5); folds where the diagonal B-O4 is r4 - r3 = 1.5
        lo = math.degrees(math.acos((r1 ** 2 + r2 ** 2 - (r4 - r3) ** 2) / (2 * r1 * r2)))
        np.testing.assert_allclose(fb["input_range"], [[lo + 30, 360 - lo + 30]], atol=1e-6)
        for x in (fb["input_range"][0][0] + 0.5, fb["input_range"][0][1] - 0.5):
            mech.solve(x)  # inside: assembles
        with pytest.raises(ls.AssemblyError):
            mech.solve(fb["input_range"][0][0] - 1.0)

    def test_info_quick_returns(self, capsys):
        d = self.run_info(capsys, "quick_return")  # the vector-loop crank and slotted lever
        qr, = d["quick_return"]
        assert qr["type"] == "crank-slotted-lever"
        ratio, adv, ret, rock = classic.quick_return(100, 200)
        assert qr["time_ratio"] == pytest.approx(float(ratio))
        assert qr["rocking_angle"] == pytest.approx(math.degrees(rock))
        assert qr["stroke"] == {"variable": "theta4", "value": pytest.approx(math.degrees(rock)), "unit": "deg"}
        d = self.run_info(capsys, "example1_slider_crank")
        assert d["quick_return"] == []

    def test_info_text(self, capsys):
        assert main(["info", str(MODELS / "crank_shaper.toml")]) == 0
        out = capsys.readouterr().out
        assert "mobility: 1 (M = 3(6 - 1) - 2*7 = 1)" in out
        assert "solve order (blocks): (theta_lever, s_slot) -> (theta_rod) -> (s_way)" in out
        assert "quick return (crank-slotted-lever)" in out and "stroke of s_way" in out


def test_topology_of_needs_a_diagram():
    assert diagram.topology_of(ls.load(MODELS / "thesis_crank_rocker.toml")) is None
    top = diagram.topology_of(ls.load(MODELS / "watt2_sixbar.toml"))
    assert [lk.name for lk in top.links] == ["ground", "crank", "coupler", "rocker", "coupler2", "output"]


@pytest.mark.parametrize("name", ["thesis_crank_rocker_diagram.toml", "stephenson3_sixbar.toml"])
def test_cli_vectors_round_trip(tmp_path, name):
    """`loopsolve vectors` writes the generated vector-loop file; it solves to the same numbers."""
    src = ls.models_dir() / name
    out = tmp_path / "vectors.toml"
    assert main(["vectors", str(src), "-o", str(out)]) == 0
    text = out.read_text()
    assert "[[loops]]" in text and "[joints]" not in text
    a, b = ls.load(src).solve(30), ls.load(out).solve(30)
    assert a.row().keys() == b.row().keys()
    for k, v in a.row().items():
        assert b.row()[k] == pytest.approx(v, abs=1e-9), k


class TestTracerPoints:
    """A joint named by one link only is a point of that link (issue 9): the coupler curve."""

    def test_coupler_point_against_the_closed_form(self):
        mech = ls.load(MODELS / "fourbar_coupler_curve.toml")
        assert mech.spec["points"]["P"] == "r_crank + r_coupler_P"
        assert "P" not in "".join(lp.text for lp in mech.loops)  # a point, not in any loop
        J = drawn(MODELS / "fourbar_coupler_curve.toml")
        ab, ap = J["B"] - J["A"], J["P"] - J["A"]
        gamma = angle(ap) - angle(ab)  # P's angle on the coupler, from the line A-B
        r2, r3, r4, r1, rp = (np.linalg.norm(v) for v in (J["A"] - J["O2"], ab, J["B"] - J["O4"],
                                                         J["O4"] - J["O2"], ap))
        sw = mech.sweep(0, 360, 30)
        for st in sw.states:
            t2 = math.radians(st.input_value)
            a = np.array([r2 * math.cos(t2), r2 * math.sin(t2)])
            # B where the circles about A (r3) and O4 (r4) meet, on the drawn side of A -> O4
            o4 = np.array([r1, 0.0])
            d = np.linalg.norm(o4 - a)
            along = (r3 ** 2 - r4 ** 2 + d ** 2) / (2 * d)
            u = (o4 - a) / d
            n = np.array([-u[1], u[0]])
            b = a + along * u + math.sqrt(r3 ** 2 - along ** 2) * n  # the drawing has B left of A -> O4
            t3 = angle(b - a)
            p = a + rp * np.array([math.cos(t3 + gamma), math.sin(t3 + gamma)])
            np.testing.assert_allclose([st["B_x"], st["B_y"]], b, atol=1e-8)
            np.testing.assert_allclose([st["P_x"], st["P_y"]], p, atol=1e-8)

    def test_point_listed_first_and_on_the_ground(self):
        data = tomllib.loads((MODELS / "fourbar_coupler_curve.toml").read_text())
        data["links"]["coupler"] = ["P", "A", "B"]  # the point first: theta_coupler is still A -> B
        data["joints"]["Q"] = {"at": [30, -10]}
        data["links"]["ground"] = ["O2", "O4", "Q"]  # a fixed point of the frame
        mech = ls.build_mechanism(diagram.diagram_to_spec(data))
        ref = ls.load(MODELS / "fourbar_coupler_curve.toml")
        a, b = mech.solve(100), ref.solve(100)
        for col in ("theta_coupler", "theta_rocker", "P_x", "P_y"):
            assert a[col] == pytest.approx(b[col], abs=1e-9)
        assert (a["Q_x"], a["Q_y"], a["Q_x_vel"]) == (pytest.approx(30), pytest.approx(-10), 0)

    def test_a_forgotten_joint_still_says_so(self):
        data = tomllib.loads(THESIS_DIAGRAM.read_text())
        data["links"]["rocker"] = ["O4"]  # C now on the coupler only, and the rocker has one joint
        with pytest.raises(TopologyError, match="joint 'C' is only on link 'coupler'"):
            diagram.diagram_to_spec(data)
        # a Watt I whose ternary crank and coupler name their shared pin differently: two points,
        # and the mobility check says why it came out as 3
        data = tomllib.loads((MODELS / "watt1_sixbar.toml").read_text())
        data["joints"]["A2"] = {"at": data["joints"]["A"]["at"]}
        data["links"]["coupler"] = ["A2", "B", "F"]
        with pytest.raises(TopologyError, match=r"mobility is 3 .*A, A2 named by one link only are points"):
            diagram.diagram_to_spec(data)


def test_loop_equations_follow_the_walk():
    """The generated loop is written in walking order (left side forward, right side backward)."""
    mech = ls.load(MODELS / "watt1_sixbar.toml")
    vals = mech.solve(60)
    J = {n: np.array([vals[n + "_x"], vals[n + "_y"]]) for n in ("O2", "A", "E", "F", "G")}
    # loop 2 walks O2 -> A -> F (left) and O2 -> E -> G -> F (right): each partial sum is a joint
    left, right = mech.loops[1].text.split(" = ")
    for side, stops in ((left, ("A", "F")), (right, ("E", "G", "F"))):
        pos = np.zeros(2)
        for name, stop in zip(side.split(" + "), stops):
            pos = pos + _vector_xy(mech, vals, name)
            np.testing.assert_allclose(pos, J[stop], atol=1e-9, err_msg=name)


def _vector_xy(mech, state, name):
    ck = state.compiled
    length, ang = ck.vector_values(0, state.z)[ck.vectors.index(name)]
    return np.array([length * math.cos(ang), length * math.sin(ang)])


class TestInfoSpeed:
    """Large models stay polynomial: a chain of many four-bars (generated here)."""

    @staticmethod
    def chain(n):
        """n four-bars in series: the rocker of loop k carries the crank pin of loop k + 1."""
        joints, links = {"O0": [0.0, 0.0]}, {"ground": ["O0"]}
        t = math.radians(60)
        joints["A0"] = [25 * math.cos(t), 25 * math.sin(t)]
        links["crank"] = ["O0", "A0"]
        pin = "A0"
        for k in range(n):
            ox = 60.0 * (k + 1)
            joints[f"O{k + 1}"] = [ox, 0.0]
            links["ground"].append(f"O{k + 1}")
            px, py = joints[pin]
            t2 = math.atan2(py, px - 60.0 * k)
            t3, t4 = classic.fourbar_position(60, 25, 70, 45, t2, mode=+1)
            joints[f"B{k}"] = [ox + 45 * math.cos(t4), 45 * math.sin(t4)]
            links[f"coupler{k}"] = [pin, f"B{k}"]
            links[f"rocker{k}"] = [f"O{k + 1}", f"B{k}"]
            if k < n - 1:
                joints[f"A{k + 1}"] = [ox + 25 * math.cos(t4), 25 * math.sin(t4)]
                links[f"rocker{k}"].append(f"A{k + 1}")
                pin = f"A{k + 1}"
        return {"name": f"chain {n}", "units": {"length": "mm", "angle": "deg"},
                "joints": {j: {"at": xy} for j, xy in joints.items()}, "links": links, "input": {"joint": "O0"}}

    def test_chain_of_300_four_bars_has_300_short_loops(self):
        spec = diagram.diagram_to_spec(self.chain(300))  # was: "more than 20000 cycles" after 26 s
        assert len(spec["loops"]) == 300
        # each loop is one four-bar: frame, crank (or the previous rocker's arm), coupler, rocker
        assert spec["loops"][0]["equation"] == "r_crank + r_coupler0 = r_ground_O1 + r_rocker0"
        for k, lp in enumerate(spec["loops"][1:], start=1):  # ground vectors start at the origin O0
            assert lp["equation"] == (f"r_ground_O{k} + r_rocker{k - 1}_A{k} + r_coupler{k} = "
                                      f"r_ground_O{k + 1} + r_rocker{k}")
