"""The model-file reference (docs/reference/model_file.md) lists exactly the keys the reader accepts.

Each table of keys on the page is marked ``<!-- keys: SECTION -->``. The keys the reader accepts
are taken from the reader itself — a model with an unknown key in that place is refused with a
message that lists the keys allowed there — so a key added to the code and not to the page (or
the other way round) fails here.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import loopsolve as ls

PAGE = Path(__file__).resolve().parents[2] / "docs" / "reference" / "model_file.md"

FOURBAR = """
[parameters]
r1 = 60
r2 = 25
r3 = 70
r4 = 45
[variables]
theta2 = { input = true, guess = 90 }
theta3 = { guess = 20 }
theta4 = { guess = 80 }
[vectors]
r1 = { length = "r1", angle = 0 }
r2 = { length = "r2", angle = "theta2" }
r3 = { length = "r3", angle = "theta3" }
r4 = { length = "r4", angle = "theta4" }
[[loops]]
equation = "r2 + r3 = r1 + r4"
[points]
O2 = "0"
B = "r2"
C = "r2 + r3"
O4 = "r1"
"""

DIAGRAM = """
[joints]
O2 = { at = [0, 0] }
B = { at = [0, 25] }
C = { at = [67.255, 44.411] }
O4 = { at = [60, 0] }
[links]
ground = ["O2", "O4"]
crank = ["O2", "B"]
coupler = ["B", "C"]
rocker = ["C", "O4"]
[input]
joint = "O2"
"""

BODIES = """
[bodies]
crank = { mass = "0.3kg", inertia = "2.5e-4kg*m^2", com = "0.5*r2", angle = "theta2", joints = ["O2", "B"] }
coupler = { mass = "0.8kg", inertia = "3.3e-3kg*m^2", com = "r2 + 0.5*r3", angle = "theta3", joints = ["B", "C"] }
rocker = { mass = "0.5kg", inertia = "8.4e-4kg*m^2", com = "r1 + 0.5*r4", angle = "theta4", joints = ["C", "O4"] }
"""


def documented(section: str) -> set[str]:
    text = PAGE.read_text(encoding="utf-8")
    m = re.search(rf"<!-- keys: {re.escape(section)} -->\n(.*?)(?:\n\n|\Z)", text, re.S)
    assert m, f"no table marked keys: {section}"
    keys = set()
    for row in m.group(1).splitlines()[2:]:
        first = row.split("|")[1]
        keys |= set(re.findall(r"`([a-z_]+)`", first))
    return keys


def refused(text: str) -> str:
    with pytest.raises(ls.ModelError) as info:
        ls.loads(text)
    return str(info.value)


def listed(message: str, lead: str) -> set[str]:
    m = re.search(re.escape(lead) + r"\s*([^)\n]*)", message)
    assert m, message
    return set(re.findall(r"[a-z_]+", m.group(1))) - {"or"}


def test_top_level_keys():
    accepted = listed(refused("zzz = 1\n" + FOURBAR), "expected one of:")
    assert documented("top") == accepted


def test_variable_keys():
    text = FOURBAR.replace("theta3 = { guess = 20 }", "theta3 = { guess = 20, zzz = 1 }")
    assert documented("variables") == listed(refused(text), "allowed:")


def test_vector_keys():
    text = FOURBAR.replace('r1 = { length = "r1", angle = 0 }', 'r1 = { length = "r1", angle = 0, zzz = 1 }')
    assert documented("vectors") == listed(refused(text), "allowed:")


def test_loop_keys():
    text = FOURBAR.replace('equation = "r2 + r3 = r1 + r4"', 'equation = "r2 + r3 = r1 + r4"\nzzz = 1')
    assert documented("loops") == listed(refused(text), "allowed:")


def test_joint_and_input_keys():
    assert documented("joints") == listed(refused(DIAGRAM.replace("O4 = { at = [60, 0] }",
                                                                  "O4 = { at = [60, 0], zzz = 1 }")), "allowed:")
    assert documented("input") == listed(refused(DIAGRAM + "zzz = 1\n"), "allowed:")


def test_body_keys():
    text = FOURBAR + BODIES.replace('joints = ["C", "O4"] }', 'joints = ["C", "O4"], zzz = 1 }')
    assert documented("bodies") == listed(refused(text), "allowed:")
    diagram = DIAGRAM + '[bodies]\ncrank = { mass = "0.3kg", inertia = "2.5e-4kg*m^2", at = [0, 12.5], zzz = 1 }\n'
    assert documented("diagram-bodies") == listed(refused(diagram), "allowed:")


def test_load_keys():
    text = FOURBAR + BODIES + '[[loads]]\nbody = "rocker"\ntorque = "-2N*m"\nzzz = 1\n'
    assert documented("loads") == listed(refused(text), "a load's keys are")


CAM = """
[variables]
theta2 = { input = true, guess = 0 }
s = { guess = 0 }
[cams.c1]
cam = "theta2"
follower = "s"
kind = "translating"
contact = "knife"
base = "40mm"
law = [ { to = 180, rise = "10mm", curve = "cycloidal" }, { to = 360, return = "10mm", curve = "cycloidal" } ]
"""


def test_higher_pair_keys():
    pairs = {
        "gears": '[gears]\ng1 = { gear = "theta2", mate = "theta4", teeth = [20, 30], zzz = 1 }\n',
        "slots": '[slots]\ns1 = { point = "C", link = "theta4", line = "r4", zzz = 1 }\n',
        "rolling": '[rolling]\nw = { angle = "theta2", radius = 5, on = "r1", zzz = 1 }\n',
    }
    for section, table in pairs.items():
        assert documented(section) == listed(refused(FOURBAR + table), "allowed:"), section
    friction = FOURBAR + BODIES + '[friction]\nO2 = { mu = 0.1, radius = "6mm", zzz = 1 }\n'
    assert documented("friction") == listed(refused(friction), "allowed:")


def test_cam_keys():
    assert documented("cams") == listed(refused(CAM + "zzz = 1\n"), "allowed:")
    segment = CAM.replace('curve = "cycloidal" },', 'curve = "cycloidal", zzz = 1 },', 1)
    assert documented("cam-law") == listed(refused(segment), "allowed:")
