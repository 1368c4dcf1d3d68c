"""Kinematic-diagram models: generated vectors/loops/guesses, both front doors, round trip, info."""

from __future__ import annotations

import json
import math
import tomllib

import numpy as np
import pytest

import loopsolve as ls
from loopsolve import classic, diagram
from loopsolve.cli import main
from loopsolve.errors import ModelError, ModelFileError, TopologyError
from loopsolve.topology import Link, PrismaticJoint, RevoluteJoint

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
        # the mirrored drawing is the crossed mode of the same linkage: the classic closed form agrees
        r = dict(r1=60, r2=25, r3=np.linalg.norm(c), r4=np.linalg.norm(J["C"] - o4))
        for st, sign in ((s1, +1), (s2, -1)):
            t3, t4 = classic.fourbar_position(r["r1"], r["r2"], r["r3"], r["r4"], math.radians(120), mode=sign)
            cx = 25 * math.cos(math.radians(120)) + r["r3"] * math.cos(t3)
            if abs(cx - st["C_x"]) > 1e-6:
                t3, t4 = classic.fourbar_position(r["r1"], r["r2"], r["r3"], r["r4"], math.radians(120), mode=-sign)
                cx = 25 * math.cos(math.radians(120)) + r["r3"] * math.cos(t3)
            assert cx == pytest.approx(st["C_x"], abs=1e-9)
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
        (lambda d: d["joints"]["B"].update(at=[0, "25 furlongs"]), "joints.B.at", "unknown unit 'furlongs'"),
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
        assert [fb["links"]["crank"] for fb in d["fourbars"]] == ["crank", "rocker"]
        J = drawn(MODELS / "watt2_sixbar.toml")
        for fb in d["fourbars"]:
            jn = fb["joints"]
            r = [np.linalg.norm(J[a] - J[b]) for a, b in ((jn["crank_pivot"], jn["rocker_pivot"]),
                                                           (jn["crank_pivot"], jn["crank_pin"]),
                                                           (jn["crank_pin"], jn["rocker_pin"]),
                                                           (jn["rocker_pin"], jn["rocker_pivot"]))]
            lengths = fb["lengths"]
            np.testing.assert_allclose([lengths[k] for k in ("ground", "crank", "coupler", "rocker")], r,
                                       rtol=1e-9)
            assert fb["grashof"] == classic.grashof(*r).value
            mu = classic.transmission_angle_range(*r)
            np.testing.assert_allclose(fb["transmission_angle_range"], np.degrees(mu), atol=1e-9)
            assert fb["input_range"] == [[-180.0, 180.0]]

    def test_info_input_range_in_the_crank_variable(self, capsys):
        """A double rocker drawn with a tilted frame: its input range is in theta_crank itself."""
        tilt = math.radians(30)
        rot = np.array([[math.cos(tilt), -math.sin(tilt)], [math.sin(tilt), math.cos(tilt)]])
        r1, r2, r3, r4 = 4.0, 3.0, 3.5, 5.0  # non-Grashof: the crank rocks
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
        (lo, hi), = classic.fourbar_input_range(r1, r2, r3, r4)
        np.testing.assert_allclose(fb["input_range"], [[math.degrees(lo + tilt), math.degrees(hi + tilt)]],
                                   atol=1e-6)
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
