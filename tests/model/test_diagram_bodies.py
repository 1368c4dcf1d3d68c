"""Bodies, gravity and loads in kinematic-diagram models (issue 10: ``com`` drawn with ``at``).

A diagram model with mass properties must give the same force analysis as the vector-loop model
of the same mechanism written by hand; ``dumps`` must keep ``gravity``, ``[bodies]`` and
``[[loads]]`` so the written file gives the same forces again.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.errors import ModelFileError

MODELS = ls.models_dir()
COLUMNS = ("input_torque", "shaking_force_x", "shaking_force_y", "shaking_moment", "kinetic_energy",
           "potential_energy")


def assert_same_forces(a, b, joints, rtol=1e-9):
    """Every force column of two force sweeps agrees to ``rtol`` of the column's largest value."""
    for col in COLUMNS + tuple(f"F_{j}_{c}" for j in joints for c in "xy"):
        x, y = np.asarray(a[col], dtype=float), np.asarray(b[col], dtype=float)
        scale = max(np.max(np.abs(y)), 1e-300)
        assert np.max(np.abs(x - y)) <= rtol * scale, col


@pytest.fixture(scope="module")
def crank_rocker():
    return (ls.load(MODELS / "thesis_crank_rocker_dynamics_diagram.toml"),
            ls.load(MODELS / "thesis_crank_rocker_dynamics.toml"))


class TestSameForcesAsVectorModel:
    def test_crank_rocker_around_the_cycle(self, crank_rocker):
        diagram, vectors = crank_rocker
        a = ls.forces(diagram, 0, 360, 20)
        b = ls.forces(vectors, 0, 360, 20)
        assert len(a["input_torque"]) == len(b["input_torque"]) == 19
        assert_same_forces(a, b, ["O2", "B", "C", "O4"])

    def test_crank_rocker_with_acceleration(self, crank_rocker):
        diagram, vectors = crank_rocker
        for x in (17.0, 133.0, 251.0):
            a = ls.forces(diagram, x, speed="25rpm", accel="3rad/s^2")
            b = ls.forces(vectors, x, speed="25rpm", accel="3rad/s^2")
            assert_same_forces(a, b, ["O2", "B", "C", "O4"])

    def test_generated_bodies(self, crank_rocker):
        spec = crank_rocker[0].spec
        assert list(spec["bodies"]) == ["crank", "coupler", "rocker"]
        rocker = spec["bodies"]["rocker"]
        assert (rocker["com"], rocker["angle"], rocker["joints"]) == ("G_rocker", "theta_rocker", ["O4", "C"])
        # the com is carried rigidly by the link: midway between its pins at every input
        sol = crank_rocker[0].solve(200.0)
        assert sol["G_rocker_x"] == pytest.approx((sol["C_x"] + sol["O4_x"]) / 2, abs=1e-9)
        assert sol["G_rocker_y"] == pytest.approx((sol["C_y"] + sol["O4_y"]) / 2, abs=1e-9)

    def test_shaper_slider_bodies_get_their_guides(self):
        """crank_shaper.toml plus bodies equals shaper_dynamics.toml (blocks sliding on a lever and the frame)."""
        data = tomllib.loads((MODELS / "crank_shaper.toml").read_text())
        # the drawing has 9 digits: draw D on the slot's line and E on the way to full precision
        u = np.array([40.0, 100.0]) / math.hypot(40.0, 100.0)
        d = 200.0 * u
        e = [d[0] + math.sqrt(60.0**2 - (220.0 - d[1]) ** 2), 220.0]
        data["joints"]["D"]["at"] = [float(d[0]), float(d[1])]
        data["joints"]["E"]["at"] = data["joints"]["way"]["at"] = e
        joints = {k: v["at"] for k, v in data["joints"].items()}
        mid = lambda p, q: [(joints[p][0] + joints[q][0]) / 2, (joints[p][1] + joints[q][1]) / 2]  # noqa: E731
        data["gravity"] = [0, "-9.81m/s^2"]
        data["bodies"] = {
            "crank": {"mass": "0.8kg", "inertia": "3e-4kg*m^2", "at": mid("O2", "A")},
            "block": {"mass": "0.3kg", "inertia": "2e-5kg*m^2", "com": "A"},
            "lever": {"mass": "2.5kg", "inertia": "1.2e-2kg*m^2", "com": {"at": mid("O4", "D")}},
            "rod": {"mass": "0.6kg", "inertia": "2e-4kg*m^2", "at": mid("D", "E")},
            "ram": {"mass": "6kg", "at": joints["E"]},
        }
        data["loads"] = [{"name": "cutting", "at": "E", "body": "ram",
                          "force": ["400*(1 - s_way_vel/sqrt(s_way_vel**2 + 1))/2", 0]}]
        # generated lengths are written to 12 digits: give them as the vector model does
        data["parameters"] = {"r_ground_O2": 100, "r_ground_way": 220, "r_crank": 40, "r_lever_D": 200,
                              "r_rod": 60, "r_crank_G_crank": 20, "r_lever_G_lever": 100, "r_rod_G_rod": 30}
        diagram = ls.build_mechanism(ls.diagram.diagram_to_spec(data))
        bodies = diagram.spec["bodies"]
        assert (bodies["block"]["guide"], bodies["block"]["guide_body"], bodies["block"]["joints"]) == \
            ("r_slot", "lever", ["A"])
        assert (bodies["ram"]["guide"], bodies["ram"]["guide_body"], bodies["ram"]["joints"]) == \
            ("r_way", "frame", ["E"])
        assert "angle" not in bodies["ram"] and bodies["lever"]["joints"] == ["O4", "D"]
        vectors = ls.load(MODELS / "shaper_dynamics.toml")
        a = ls.forces(diagram, 0, 360, 30)
        b = ls.forces(vectors, 0, 360, 30)
        assert_same_forces(a, b, ["O2", "A", "O4", "D", "E"])


class TestRoundTrip:
    @pytest.mark.parametrize("name", ["thesis_crank_rocker_dynamics_diagram", "engine_slider_crank"])
    def test_dumps_loads_same_forces(self, name):
        mech = ls.load(MODELS / f"{name}.toml")
        text = ls.dumps(mech)
        assert "gravity = " in text and "[bodies]" in text and "[[loads]]" in text
        again = ls.loads(text)
        a = ls.forces(mech, 0, 360, 45)
        b = ls.forces(again, 0, 360, 45)
        joints = sorted({j for body in mech.spec["bodies"].values() for j in body["joints"]})
        assert_same_forces(a, b, joints, rtol=0.0)

    def test_to_vector_model_keeps_forces(self, crank_rocker):
        text = ls.diagram.to_vector_model(crank_rocker[0])
        again = ls.loads(text)
        assert "joints" not in again.spec
        assert_same_forces(ls.forces(again, 0, 360, 90), ls.forces(crank_rocker[1], 0, 360, 90),
                           ["O2", "B", "C", "O4"])


BASE = (MODELS / "thesis_crank_rocker_dynamics_diagram.toml").read_text().split("[bodies]")[0]


class TestBadBodies:
    @pytest.mark.parametrize("body, key", [
        ('follower = { mass = 1, inertia = "0.1kg*m^2", at = [0, 1] }', "bodies.follower"),
        ('crank = { mass = 1, inertia = "0.1kg*m^2", at = [0, "x"] }', "bodies.crank.at"),
        ('crank = { mass = 1, inertia = "0.1kg*m^2", at = [1, 2, 3] }', "bodies.crank.at"),
        ('crank = { mass = 1, inertia = "0.1kg*m^2", com = { at = 5 } }', "bodies.crank.com.at"),
        ('crank = { mass = 1, inertia = "0.1kg*m^2", com = "C" }', "bodies.crank.com"),
        ('crank = { mass = 0, inertia = "0.1kg*m^2", at = [0, 1] }', "bodies.crank.mass"),
        ('crank = { mass = "-2kg", inertia = "0.1kg*m^2", at = [0, 1] }', "bodies.crank.mass"),
        ('crank = { mass = 1, inertia = "0.1kg*m^2" }', "bodies.crank"),
        ('crank = { mass = 1, inertia = "0.1kg*m^2", at = [0, 1], angle = "theta_crank" }', "bodies.crank"),
        ('ground = { mass = 1, inertia = "0.1kg*m^2", at = [0, 1] }', "bodies.ground"),
    ])
    def test_one_line_error_naming_the_key(self, body, key):
        with pytest.raises(ModelFileError) as exc:
            ls.loads(BASE + "[bodies]\n" + body + "\n", source="bad.toml")
        msg = str(exc.value)
        assert "\n" not in msg
        assert msg.startswith(f"bad.toml: {key}: "), msg


def test_cli_forces_at_30(capsys):
    from loopsolve.cli import main

    code = main(["forces", str(MODELS / "thesis_crank_rocker_dynamics_diagram.toml"), "--at", "30",
                 "--format", "json"])
    out = capsys.readouterr()
    assert code == 0, out.err
    import json

    row = json.loads(out.out)["rows"][0]
    vec = ls.forces(ls.load(MODELS / "thesis_crank_rocker_dynamics.toml"), 30.0)
    assert row["input_torque"] == pytest.approx(float(np.asarray(vec["input_torque"]).ravel()[0]), rel=1e-9)
    assert math.isfinite(row["F_O2_x"])
