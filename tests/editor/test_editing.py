"""Edits of kinematic-diagram models (loopsolve/editor/editing.py, document.apply_op), without a server.

Each edit's result is read back as a model file would be and checked against what a designer
expects, by hand or closed form: a moved joint changes exactly the lengths it defines, a typed
dimension gives that length and keeps the mode, the pose is re-drawn at the current input,
sliders and links added build a slider-crank whose stroke is the textbook one, deletes take what
they leave dangling with them, and a saved diagram comes back key for key.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.editor import editing
from loopsolve.editor.analysis import analyze, build
from loopsolve.editor.document import Document, SaveConflict, apply_op, check_save_name, model_from_text
from loopsolve.errors import ModelError, ModeError
from loopsolve.model.modelfile import dumps

DIAGRAMS = [p for p in sorted(ls.models_dir().glob("*.toml")) if "[joints]" in p.read_text()]


@pytest.mark.parametrize("path", DIAGRAMS, ids=lambda p: p.stem)
def test_diagram_models_round_trip_through_the_writer(path):
    data = tomllib.loads(path.read_text())
    text = dumps(data)
    assert tomllib.loads(text) == data
    assert dumps(tomllib.loads(text)) == text
    a, b = ls.load(path), ls.loads(text)
    assert a.spec["parameters"] == b.spec["parameters"] and a.spec["loops"] == b.spec["loops"]


def _dims(data):
    return dict(build(data).spec["parameters"])


def test_template_is_the_crank_rocker():
    data = editing.template()
    dims = _dims(data)
    assert dims == {"r_ground_O4": 60, "r_crank": 25, "r_coupler": 70, "r_rocker": 45}
    a = analyze(data)
    assert a["ok"] and a["info"]["fourbars"][0]["grashof"] == "crank-rocker" and a["mode"]["signature"] == "-"


def test_move_a_joint_changes_the_lengths_it_defines():
    data = editing.template()
    out = apply_op(data, {"op": "move", "joint": "C", "to": [70, 40], "at": 90})["data"]
    dims = _dims(out)
    assert dims["r_crank"] == 25 and dims["r_ground_O4"] == 60
    assert dims["r_coupler"] == pytest.approx(math.dist((0, 25), (70, 40)), abs=1e-9)
    assert dims["r_rocker"] == pytest.approx(math.dist((70, 40), (60, 0)), abs=1e-9)
    # at another input: the pose there is re-drawn (crank at 30°), the moved joint where it was put
    out = apply_op(data, {"op": "move", "joint": "O4", "to": [65, 5], "at": 30})["data"]
    b = out["joints"]["B"]["at"]
    assert b == pytest.approx([25 * math.cos(math.radians(30)), 25 * math.sin(math.radians(30))], abs=1e-12)
    assert out["joints"]["O4"]["at"] == [65, 5]
    mech = build(out)
    assert mech.variable("theta_crank").guess == pytest.approx(math.radians(30))  # internal units
    assert ls.guessed_mode(mech) == "-"


def test_typed_dimension_with_units_keeps_the_mode():
    data = editing.template()
    out = apply_op(data, {"op": "dimension", "name": "r_coupler", "value": "2.9in", "at": 120, "mode": "-"})
    new = out["data"]
    assert "parameters" not in new  # the pose generates the value: no override left in the file
    assert _dims(new)["r_coupler"] == pytest.approx(2.9 * 25.4, abs=1e-9)
    assert out["analysis"]["mode"]["signature"] == "-"
    st = build(new).solve(120)
    # closed form: C on the circles (B, 73.66) and (O4, 45), the open side
    b = np.array([25 * math.cos(math.radians(120)), 25 * math.sin(math.radians(120))])
    o4 = np.array([60.0, 0.0])
    d = np.linalg.norm(o4 - b)
    a = (73.66 ** 2 - 45 ** 2 + d * d) / (2 * d)
    h = math.sqrt(73.66 ** 2 - a * a)
    u = (o4 - b) / d
    c = b + a * u + h * np.array([-u[1], u[0]])
    assert [st["C_x"], st["C_y"]] == pytest.approx(list(c), abs=1e-9)
    with pytest.raises(ModelError, match="positive"):
        apply_op(data, {"op": "dimension", "name": "r_coupler", "value": -3, "at": 90})
    with pytest.raises(ModelError, match="no dimension"):
        apply_op(data, {"op": "dimension", "name": "r_nope", "value": 3, "at": 90})


def test_a_drag_that_flips_the_mode_is_refused():
    data = editing.template()
    with pytest.raises(ModeError, match="from - to \\+"):
        apply_op(data, {"op": "move", "joint": "C", "to": [30, -10], "at": 90})


def test_build_a_slider_crank_from_links_and_a_slider():
    """Ground pivot, crank, connecting rod and a block on the ground: the stroke is 2 × crank."""
    data = {"name": "slider-crank", "units": {"length": "mm", "angle": "deg"},
            "joints": {"O2": {"at": [0, 0]}}, "links": {"ground": ["O2"]}}
    data = editing.add_link(data, ["O2", "J1"], {"J1": [20, 0]}, name="crank")
    data = editing.add_link(data, ["J1", "J2"], {"J2": [80, 0]}, name="rod")
    data = editing.add_slider(data, "J2", "ground", [1, 0])
    data = editing.set_input(data, joint="O2")
    assert data["links"] == {"ground": ["O2", "S1"], "crank": ["O2", "J1"], "rod": ["J1", "J2"],
                             "block1": ["J2", "S1"]}
    data = apply_op(data, {"op": "move", "joint": "J1", "to": [0, 20], "at": 0})["data"]  # draw it at 90°
    a = analyze(data)
    assert a["ok"], a.get("error")
    sw = build(data).sweep(0, 360, 1)
    xs = sw["J2_x"]
    rod = math.dist((0, 20), (80, 0))
    assert math.dist(data["joints"]["J1"]["at"], data["joints"]["J2"]["at"]) == pytest.approx(rod, abs=1e-9)
    # x_C = r cos θ + sqrt(L² − r² sin² θ): the stroke is 2r
    th = np.radians(sw["theta_crank"])
    assert np.allclose(xs, 20 * np.cos(th) + np.sqrt(rod ** 2 - (20 * np.sin(th)) ** 2), atol=1e-8)
    assert float(xs.max() - xs.min()) == pytest.approx(40, abs=1e-6)


def test_points_and_deletes():
    data = editing.template()
    out = apply_op(data, {"op": "add_point", "link": "coupler", "to": [40, 60], "at": 90})["data"]
    assert out["links"]["coupler"] == ["B", "C", "P1"]
    sw = build(out).sweep(0, 360, 30)
    assert sw["P1_x"][3] == pytest.approx(40, abs=1e-9) and sw["P1_y"][3] == pytest.approx(60, abs=1e-9)
    gone = editing.delete(out, link="coupler")
    assert "coupler" not in gone["links"] and "P1" not in gone["joints"]
    assert set(gone["joints"]) == {"O2", "B", "C", "O4"}  # B and C are still on the crank and rocker
    a = analyze(gone)
    assert not a["ok"] and "joint 'B' is only on link 'crank'" in a["error"] and a["joints"]  # drawn as declared
    nojoint = editing.delete(data, joint="O2")
    assert "input" not in nojoint and "crank" not in nojoint["links"]
    with pytest.raises(ModelError, match="ground"):
        editing.delete(data, link="ground")


def test_masses_loads_and_forces():
    data = editing.template()
    data = editing.set_body(data, "crank", {"mass": "0.3kg", "inertia": "2.5e-4kg*m^2", "at": [0, 12.5]})
    data = editing.set_body(data, "coupler", {"mass": "0.8kg", "inertia": "3.3e-3kg*m^2", "com": "B"})
    a = analyze(data)  # a body next to a link without mass properties: the declaration check says so
    assert not a["ok"] and "'C' is named by 'coupler' only" in a["error"]
    data = editing.set_body(data, "rocker", {"mass": "0.5kg", "inertia": "8.4e-4kg*m^2", "at": [63.6, 22.2]})
    data = editing.set_loads(data, [{"body": "coupler", "torque": "-2N*m"}])
    data = editing.set_gravity(data, [0, "-9.81m/s^2"])
    a = analyze(data)
    assert a["ok"], a.get("error")
    fs = build(data).forces(0, 360, 2)
    assert a["forces"]["columns"]["input_torque"] == pytest.approx(list(fs.drive), rel=1e-12, abs=1e-12)
    with pytest.raises(ModelError, match="moving link"):
        editing.set_body(data, "ground", {"mass": 1})
    # a body's centre of mass drawn with `at` moves with its link when the pose is re-drawn
    out = apply_op(data, {"op": "move", "joint": "O4", "to": [62, 0], "at": 0})["data"]
    assert out["bodies"]["crank"]["at"] == pytest.approx([12.5, 0], abs=1e-9)


def test_save_names_and_model_text(tmp_path):
    (tmp_path / "sub").mkdir()
    assert check_save_name("sub/a.toml", tmp_path) == (tmp_path / "sub" / "a.toml").resolve()
    for bad in ("../a.toml", "/abs.toml", "a.TXT", "sub/../../a.toml", "x/a.toml", "a\nb.toml"):
        with pytest.raises(ModelError):
            check_save_name(bad, tmp_path)
    doc = Document(editing.template(), None, base=tmp_path)
    with pytest.raises(SaveConflict) as exc:
        doc.save()
    assert exc.value.need == "name"
    path = doc.save("sub/a.toml")
    assert tomllib.loads(path.read_text()) == editing.template() and not doc.dirty
    with pytest.raises(SaveConflict):
        doc.save("sub/a.toml")
    with pytest.raises(ModelError, match="too large"):
        model_from_text("#" * 300_000)
    doc.push(editing.set_gravity(doc.data, [0, -9.81]), None)
    assert doc.dirty and doc.undo() and not doc.dirty and doc.redo() and doc.dirty
