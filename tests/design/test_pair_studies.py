"""Studies and synthesis with higher pairs: tooth numbers vary over the integers, law parameters like any."""

import math
from pathlib import Path

import numpy as np
import pytest

import loopsolve as ls

PLANETARY_CRANK = Path(__file__).parent.parent / "data" / "planetary_crank.toml"


def test_study_rounds_tooth_numbers_and_follows_willis():
    """A study of the sun's teeth: the values become whole numbers (repeats dropped); every design's crank
    (the carrier, ring fixed) turns at N_s/(N_s + N_r) of the sun's speed."""
    pytest.importorskip("xarray")
    mech = ls.load(PLANETARY_CRANK)
    ds = ls.study(mech, {"Ns": [20, 22.5, 22.4, 25, 30]}, 0, 90, 30)
    ns = ds.Ns.values
    assert ns.tolist() == [20.0, 22.0, 25.0, 30.0]
    ratio = np.asarray(ds.theta2_vel.values)
    assert np.allclose(ratio, (ns / (ns + 96))[:, None])


def test_design_problems_refuse_fractional_teeth():
    from loopsolve.design.designs import design_problems

    mech = ls.load(PLANETARY_CRANK)
    why = design_problems(mech, ("Ns",), np.array([[24.0], [24.5], [0.0]]))
    assert why[0] == "" and "whole number" in why[1] and "whole number" in why[2]


def test_synthesis_varies_tooth_numbers_as_integers():
    """Function generation of the rocker against the sun's angle: the teeth (an integer) and the crank
    (continuous) of the design the targets came from are found."""
    mech = ls.load(PLANETARY_CRANK)
    xs = [0, 60, 120, 180, 240, 300]
    targets = {"input": xs, "output": [mech.solve(x)["theta4"] for x in xs]}
    start = mech.with_parameters(r2=22, Ns=25)
    res = ls.synthesize(start, function="theta4", targets=targets, vary={"Ns": (23, 25), "r2": (20, 30)},
                        popsize=8, maxiter=20, restarts=1, progress=False, mode=None)
    assert res.report["parameters"]["Ns"] == 24.0
    assert res.report["parameters"]["r2"] == pytest.approx(25.0, abs=1e-6)
    again = ls.loads(res.to_toml())
    assert again.pairs.gears[1].kind == "internal"
    assert again.solve(120)["theta4"] == pytest.approx(mech.solve(120)["theta4"], abs=1e-6)


def test_cam_law_parameters_vary_in_a_study():
    """A rise height as a parameter: every design's follower follows its own law."""
    pytest.importorskip("xarray")
    text = """
name = "cam study"
units = { length = "mm", angle = "deg" }
[parameters]
h = 20
[variables]
theta2 = { input = true, guess = 0 }
s = { guess = 0 }
[cams.c1]
cam = "theta2"
follower = "s"
contact = "knife"
base = "40mm"
law = [ { to = 120, rise = "h", curve = "cycloidal" }, { to = 360, return = "h", curve = "cycloidal" } ]
"""
    mech = ls.loads(text)
    ds = ls.study(mech, {"h": [10, 20, 30]}, 60, 60, 1)
    assert np.allclose(ds.s.values[:, 0], [5, 10, 15])  # half the rise at the middle of a cycloidal rise
