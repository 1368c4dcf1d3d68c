"""Model files: the DESIGN.md example loads as written; bad files are rejected with clear errors.

Every bad file is a small edit of a good four-bar file. Each must raise the expected error
class with a message naming the file, the key and the offending text, and never run anything
(code-injection attempts included: the expression language is parsed, never evaluated).
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

import loopsolve as ls
from loopsolve.errors import ModelError, ModelFileError
from loopsolve.model.modelfile import MAX_FILE_SIZE

from support.modelfiles import BAD, edit, GOOD, INJECTIONS

DATA = Path(__file__).parents[1] / "data"


@pytest.mark.parametrize("case_id, text, error, fragments", BAD, ids=[b[0] for b in BAD])
def test_bad_model_file_is_rejected(tmp_path, case_id, text, error, fragments):
    path = tmp_path / f"{case_id}.toml"
    path.write_text(text)
    with pytest.raises(error) as info:
        ls.load(path)
    msg = str(info.value)
    assert str(path) in msg
    for frag in fragments:
        assert frag in msg, (frag, msg)
    assert info.value.path == str(path)
    assert isinstance(info.value, ValueError)  # every ModelError is also a ValueError


def test_the_good_base_file_loads():
    """The table above edits a file that is itself valid (so each case tests one thing)."""
    mech = ls.loads(GOOD, source="good.toml")
    assert round(mech.solve(90)["theta4"], 2) == 80.72


@pytest.mark.parametrize("template", INJECTIONS)
@pytest.mark.parametrize("where", ["vector length", "vector angle", "parameter", "loop", "point", "guess"])
def test_code_injection_is_rejected_and_never_runs(tmp_path, template, where):
    marker = tmp_path / "pwned"
    payload = template.replace("%s", str(marker)) if "%s" in template else template
    quoted = '"' + payload.replace("\\", "\\\\").replace('"', '\\"') + '"'
    text = {
        "vector length": edit(('length = "r3"', f"length = {quoted}")),
        "vector angle": edit(('angle = "theta3"', f"angle = {quoted}")),
        "parameter": edit(("r2 = 25", f"r2 = {quoted}")),
        "loop": edit(('equation = "r2 + r3 = r1 + r4"', f"equation = {quoted}")),
        "point": edit(('C = "r2 + r3"', f"C = {quoted}")),
        "guess": edit(("guess = 20", f"guess = {quoted}")),
    }[where]
    path = tmp_path / "evil.toml"
    path.write_text(text)
    with pytest.raises(ModelFileError) as info:
        ls.load(path)
    key = {"vector length": "vectors.r3.length", "vector angle": "vectors.r3.angle", "parameter": "parameters.r2",
           "loop": "loops[0].equation", "point": "points.C", "guess": "variables.theta3.guess"}[where]
    assert f"{path}: {key}:" in str(info.value)
    assert not marker.exists()


def test_code_injection_marker_would_be_detected(tmp_path):
    """The marker check above can fail: running the payload really creates the file."""
    import os

    marker = tmp_path / "pwned"
    os.system(f"touch {marker}")  # the payload of INJECTIONS[0], run deliberately
    assert marker.exists()


def test_all_problems_of_a_file_are_reported_at_once(tmp_path):
    text = edit(('length = "r3"', 'length = "r33"'), ("r2 = 25", 'r2 = "x"'),
                ('"r2 + r3 = r1 + r4"', '"r2 + r3 = r1 + r5"'), ("guess = 20", 'guess = "abc"'))
    path = tmp_path / "many.toml"
    path.write_text(text)
    with pytest.raises(ModelFileError) as info:
        ls.load(path)
    exc = info.value
    assert len(exc.problems) == 4
    msg = str(exc)
    assert msg.startswith(f"4 problems in {path}")
    for key in ("vectors.r3.length", "parameters.r2", "loops[0].equation", "variables.theta3.guess"):
        assert key in msg
    assert all(str(path) in line for line in exc.problems)


def test_unknown_count_is_reported_with_the_other_problems(tmp_path):
    """A wrong number of unknowns is one more problem of the list, not hidden behind the others."""
    text = edit(("theta4 = { guess = 80 }", "theta4 = { guess = 80 }\ntheta5 = { guess = 1 }"),
                ("r2 = 25", 'r2 = "x"'))
    path = tmp_path / "count.toml"
    path.write_text(text)
    with pytest.raises(ModelFileError) as info:
        ls.load(path)
    msg = str(info.value)
    assert "parameters.r2" in msg
    assert "3 unknown variable(s) (theta3, theta4, theta5) but 2 scalar loop equations" in msg


def test_misspelt_section_suggests_the_name_and_lists_no_empty_vectors(tmp_path):
    # a new user's `[vector]` gave "unknown key 'vector'" and then, for every loop term and point,
    # "... names the undeclared vector 'r2'; declared vectors: " with nothing after the colon
    path = tmp_path / "typo.toml"
    path.write_text(edit(("[vectors]", "[vector]")))
    with pytest.raises(ModelFileError) as info:
        ls.load(path)
    problems = info.value.problems
    assert "unknown key 'vector' (did you mean 'vectors'? expected one of:" in problems[0]
    undeclared = [p for p in problems if "undeclared vector" in p]
    assert len(undeclared) == 6  # r2, r3, r1, r4 in the loop; r2, r3 in the point C
    assert all(p.endswith("no vectors are declared ([vectors] table)") for p in undeclared)
    path.write_text(edit(('"r2 + r3 = r1 + r4"', '"r2 + r3 = r1 + r5"'), ("[points]", "[pionts]")))
    with pytest.raises(ModelFileError) as info:
        ls.load(path)
    msg = str(info.value)
    assert "did you mean 'points'?" in msg and "declared vectors: r1, r2, r3, r4" in msg


def test_huge_file_is_refused_before_parsing(tmp_path):
    path = tmp_path / "huge.toml"
    path.write_text(GOOD + "# " + "x" * (MAX_FILE_SIZE + 10) + "\n")
    with pytest.raises(ModelFileError, match="too large") as info:
        ls.load(path)
    assert str(path) in str(info.value)


def test_overlong_expression_is_refused(tmp_path):
    path = tmp_path / "long.toml"
    path.write_text(edit(('length = "r3"', 'length = "' + "+".join(["r3"] * 2000) + '"')))
    with pytest.raises(ModelFileError, match="too long"):
        ls.load(path)


def test_missing_and_unreadable_files(tmp_path):
    with pytest.raises(ModelFileError, match="no such model file"):
        ls.load(tmp_path / "nope.toml")
    with pytest.raises(ModelFileError, match="is a directory"):
        ls.load(tmp_path)
    p = tmp_path / "latin1.toml"
    p.write_bytes(GOOD.replace("four-bar", "vier-stäbe").encode("latin-1"))
    with pytest.raises(ModelFileError, match="not UTF-8"):
        ls.load(p)


def test_python_builder_errors_are_model_errors_without_a_path():
    b = ls.MechanismBuilder("b").parameter("r1", 60).variable("theta2", input=True, guess=0)
    b = b.vector("r1", length="r1", angle=0).vector("r2", length="rr", angle="theta2").loop("r1 = r2")
    with pytest.raises(ModelError) as info:
        b.build()
    assert not isinstance(info.value, ModelFileError)
    assert "<python>" in str(info.value) and "unknown name 'rr'" in str(info.value)
    with pytest.raises(ModelError, match="declared twice"):
        ls.MechanismBuilder("b").parameter("a", 1).parameter("a", 2)


# ----------------------------------------------------------------------------- the DESIGN.md example


def test_design_example_loads_exactly_as_written():
    """tests/data/design_example.toml is the DESIGN.md model-file block, verbatim."""
    path = DATA / "design_example.toml"
    design = Path(__file__).resolve().parents[3] / "shared" / "DESIGN.md"
    if design.exists():  # the shared notes sit beside the repository in the project workspace
        blocks = re.findall(r"```toml\n(.*?)```", design.read_text(), re.S)
        assert blocks[0] == path.read_text()
    mech = ls.load(path)
    assert mech.name == "Crank-rocker four-bar"
    assert (mech.units.length, mech.units.angle) == ("mm", "deg")
    assert [p.name for p in mech.parameters] == ["r1", "r2", "r3", "r4"]
    assert mech.inputs == ("theta2",) and mech.unknowns() == ("theta3", "theta4")
    assert mech.variable("theta2").speed == pytest.approx(2 * math.pi * 10 / 60)
    assert mech.variable("theta3").guess == pytest.approx(math.radians(20))
    assert [p.name for p in mech.points] == ["B", "C"]
    s = mech.solve()
    assert (round(s["theta3"], 2), round(s["theta4"], 2)) == (16.1, 80.72)


def test_design_example_also_allowed_forms():
    """The commented alternatives of the DESIGN.md block: rigid offset, Cartesian vector, slider."""
    text = (DATA / "design_example.toml").read_text()
    text = text.replace('r4 = { length = "r4", angle = "theta4" }',
                        'r4 = { length = "r4", angle = "theta4" }\n'
                        'r4d = { length = 100, angle = "theta4", offset = -30 }\nr7  = { x = 60, y = 20 }')
    text = text.replace('C = "r2 + r3"', 'C = "r2 + r3"\nE = "r1 + r4d"\nF = "r7"')
    s = ls.loads(text, source="alt.toml").solve()
    th = math.radians(s["theta4"] - 30)
    assert (s["E_x"], s["E_y"]) == (pytest.approx(60 + 100 * math.cos(th)), pytest.approx(100 * math.sin(th)))
    assert (s["F_x"], s["F_y"]) == (60.0, 20.0)
    slider = ls.loads(
        'name = "s"\n[parameters]\nr2 = 5\nr3 = 8\n[variables]\ntheta2 = { input = true, guess = 45 }\n'
        'theta3 = { guess = -26 }\nx = { guess = 10 }\n[vectors]\nr1 = { length = "x", angle = 0 }\n'
        'r2 = { length = "r2", angle = "theta2" }\nr3 = { length = "r3", angle = "theta3" }\n'
        '[[loops]]\nequation = "r2 + r3 - r1"\n', source="slider.toml")
    assert slider.solve(45)["x"] == pytest.approx(5 / math.sqrt(2) + math.sqrt(64 - 12.5))


def test_dumps_round_trip_gives_the_same_mechanism():
    mech = ls.load(DATA / "design_example.toml")
    again = ls.loads(ls.dumps(mech), source="again.toml")
    assert (again.parameters, again.variables, again.vectors, again.loops, again.points) == (
        mech.parameters, mech.variables, mech.vectors, mech.loops, mech.points)
