"""Higher-pair declarations: written back to a model file unchanged, rows named in order, kinds inferred."""

from pathlib import Path

import pytest

import loopsolve as ls

DATA = Path(__file__).parent.parent / "data"


@pytest.mark.parametrize("name", ["cam_follower.toml", "planetary_crank.toml", "journal_wheel.toml"])
def test_model_files_with_higher_pairs_round_trip(name):
    mech = ls.load(DATA / name)
    again = ls.loads(ls.dumps(mech))
    assert again.pairs == mech.pairs
    assert again.equation_names == mech.equation_names


def test_rows_of_phi_are_named_loops_then_pairs():
    mech = ls.load(DATA / "planetary_crank.toml")
    assert mech.equation_names == ("loop1.x", "loop1.y", "gears.sun_planet", "gears.ring_planet")
    assert mech.n_equations == 4 and mech.derive().phi.rows == 4


def test_kinds_come_from_the_pairs():
    """θ of a gear is an angle, a rack's travel a length, and a constraint's term takes its partner's kind."""
    text = """
name = "kinds"
units = { length = "mm", angle = "deg" }
[variables]
theta = { input = true, guess = 0 }
x = { guess = 0 }
beta = { guess = 0 }
y = { guess = 0 }
[gears]
drive = { gear = "theta", rack = "x", radius = 10 }
[constraints]
a = "beta = 2*theta + 30"
b = "y = x + 5mm"
"""
    mech = ls.loads(text)
    kinds = {v.name: v.kind.value for v in mech.variables}
    assert kinds == {"theta": "angle", "x": "length", "beta": "angle", "y": "length"}
    s = mech.solve(10)
    assert s["beta"] == pytest.approx(50) and s["y"] == pytest.approx(s["x"] + 5)
