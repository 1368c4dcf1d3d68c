"""[gears]: Willis' formula, geared linkages against independent solutions, the mesh check."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest
from scipy.optimize import fsolve

import loopsolve as ls

from support.models import FIVEBAR, fivebar, PLANETARY


def planetary(drive: str, held: str) -> ls.Mechanism:
    marks = {k: ("input = true, " if "theta_" + k == drive else "") for k in "scr"}
    return ls.loads(PLANETARY.format(held=held, value=30 if held == "theta_r" else 20 if held == "theta_c" else 10,
                                     **marks))


@pytest.mark.parametrize("drive, held", [("theta_s", "theta_r"), ("theta_s", "theta_c"), ("theta_c", "theta_s"),
                                         ("theta_r", "theta_s"), ("theta_c", "theta_r"), ("theta_r", "theta_c")])
def test_willis_for_each_member_held(drive, held):
    """(ω_s − ω_c)/(ω_r − ω_c) = −N_r/N_s with the third member held; the planet (ω_p − ω_c) = −(N_s/N_p)(ω_s − ω_c)."""
    mech = planetary(drive, held)
    sw = mech.sweep(0, 90, 15, speed=2.0, accel=0.5)
    w = {k: np.asarray(sw[f"theta_{k}_vel"]) for k in "scpr"}
    a = {k: np.asarray(sw[f"theta_{k}_acc"]) for k in "scpr"}
    assert np.allclose(w[held[-1]], 0.0) and np.allclose(w[drive[-1]], 2.0)
    # Willis' formula on the speeds and on the accelerations
    for r in (w, a):
        assert np.allclose(r["s"] - r["c"], -(96 / 24) * (r["r"] - r["c"]), atol=1e-12)
        assert np.allclose(r["p"] - r["c"], -(24 / 36) * (r["s"] - r["c"]), atol=1e-12)
    # the textbook ratios of the three classic arrangements
    ratio = {("theta_s", "theta_r"): ("c", 24 / 120), ("theta_s", "theta_c"): ("r", -24 / 96),
             ("theta_c", "theta_s"): ("r", 120 / 96)}
    if (drive, held) in ratio:
        out, value = ratio[(drive, held)]
        assert np.allclose(w[out] / w[drive[-1]], value)
    # and on the angles themselves, from the guessed (meshing) pose
    th = {k: np.radians(np.asarray(sw[f"theta_{k}"])) for k in "scpr"}
    g = {k: math.radians(v) for k, v in zip("scpr", (10, 20, -5, 30))}
    d = {k: th[k] - g[k] for k in "scpr"}
    turn = 2 * math.pi
    willis = (d["s"] - d["c"]) + 4 * (d["r"] - d["c"])
    assert np.allclose((willis + math.pi) % turn - math.pi, 0.0, atol=1e-9)


def test_planetary_mobility_and_the_carrier_row_in_latex():
    mech = planetary("theta_s", "theta_r")
    assert mech.info()["mobility"] == 1
    assert "gears.ring\\_planet" in mech.to_latex()


def test_teeth_vary_as_parameters():
    mech = planetary("theta_s", "theta_r").with_parameters(Ns=30, Np=33)
    s = mech.solve(40, speed=1.0)
    assert s["theta_c_vel"] == pytest.approx(30 / (30 + 96))


GEARED = '[gears]\ng = { gear = "theta2", mate = "theta5", radii = [12, 18] }'


def _independent_geared_fivebar(t2, guess):
    """The loop (x, y) and the mesh, written out and solved with scipy's fsolve (radians)."""
    def eqs(u):
        t3, t4, t5 = u
        return [20 * math.cos(t2) + 50 * math.cos(t3) - 30 - 20 * math.cos(t5) - 50 * math.cos(t4),
                20 * math.sin(t2) + 50 * math.sin(t3) - 20 * math.sin(t5) - 50 * math.sin(t4),
                (t5 - math.pi / 2) + (12 / 18) * (t2 - math.pi / 2)]
    sol = fsolve(eqs, guess, xtol=1e-13)
    assert max(abs(r) for r in eqs(sol)) < 1e-10
    return sol


def test_geared_five_bar_against_an_independent_solve():
    """One input drives both cranks through the gears (12 and 18 mm, centres 30 mm apart)."""
    mech = fivebar(GEARED, r1=30)
    assert mech.info()["mobility"] == 1
    sw = mech.sweep(40, 140, 5)
    guess = np.radians([66.42, 113.58, 90.0])
    for row in sw.rows:
        t2 = math.radians(row["theta2"])
        guess = _independent_geared_fivebar(t2, guess)
        t3, t4, t5 = np.degrees(guess)
        assert row["theta3"] == pytest.approx(t3, abs=1e-8)
        assert row["theta4"] == pytest.approx(t4, abs=1e-8)
        assert row["theta5"] == pytest.approx(t5, abs=1e-8)
        assert row["P_x"] == pytest.approx(20 * math.cos(t2) + 50 * math.cos(guess[0]), abs=1e-8)
        assert row["theta5_vel"] == pytest.approx(-12 / 18)
    # velocities of the independent solution by central differences
    x0, h = math.radians(75), 1e-6
    up = _independent_geared_fivebar(x0 + h, guess)
    dn = _independent_geared_fivebar(x0 - h, guess)
    s = mech.solve(75, speed=1.0)
    assert [s["theta3_vel"], s["theta4_vel"]] == pytest.approx(list((up - dn)[:2] / (2 * h)), rel=1e-6)


def test_rack_and_pinion():
    """A rack's travel x = R θ + phase, with R from the module and the teeth (m N / 2)."""
    text = """
name = "rack"
units = { length = "mm", angle = "deg" }
[variables]
theta = { input = true, guess = 0 }
x = { guess = 5 }
[gears]
drive = { gear = "theta", rack = "x", teeth = [20], module = "2mm" }
"""
    mech = ls.loads(text)
    s = mech.solve(90, speed=3.0)
    assert s["x"] == pytest.approx(5 + 20 * math.pi / 2)
    assert s["x_vel"] == pytest.approx(20 * 3.0)
    explicit = ls.loads(text.replace('module = "2mm"', 'module = "2mm", phase = -1'))
    assert explicit.solve(0)["x"] == pytest.approx(-1.0)


def test_explicit_phase_in_degrees():
    mech = fivebar('[gears]\ng = { gear = "theta2", mate = "theta5", radii = [12, 18], phase = 150 }', r1=30)
    s = mech.solve(90)
    # θ5 = −(12/18) θ2 + 150°
    assert s["theta5"] == pytest.approx(-(12 / 18) * 90 + 150)


@pytest.mark.parametrize("extra, words", [
    # centres 30 mm apart, pitch radii 12 + 20
    ('[gears]\ng = { gear = "theta2", mate = "theta5", radii = [12, 20] }', "12 + 20 = 32"),
    # the coupler turns about no fixed point of the frame: its instant centre drifts
    ('[gears]\ng = { gear = "theta2", mate = "theta3", teeth = [20, 30] }', "does not turn about a fixed centre"),
])
def test_gears_whose_centres_do_not_stay_in_mesh(extra, words):
    mech = fivebar(extra, r1=30)
    with pytest.raises(ls.ModelError) as err:
        mech.sweep(60, 120, 10)
    assert "gears.g" in str(err.value) and words in str(err.value)
    with pytest.raises(ls.ModelError, match="gears.g"):
        mech.solve(75)


def test_drifting_centres_exit_2_on_one_line(tmp_path):
    path = tmp_path / "drift.toml"
    path.write_text(FIVEBAR.format(extra='[gears]\ng = { gear = "theta2", mate = "theta3", teeth = [20, 30] }')
                    .replace("r1 = 40", "r1 = 30"))
    for cmd in (["solve", "--at", "80"], ["sweep", "--from", "60", "--to", "100", "--step", "10"], ["info"]):
        proc = subprocess.run([sys.executable, "-m", "loopsolve", cmd[0], str(path)] + cmd[1:], capture_output=True,
                              text=True)
        assert proc.returncode == 2
        assert len(proc.stderr.strip().splitlines()) == 1 and "gears.g" in proc.stderr


@pytest.mark.parametrize("entry, key, words", [
    ('{ gear = "theta2", mate = "theta5", teeth = [20.5, 30] }', "gears.g.teeth[0]", "whole numbers"),
    ('{ gear = "theta2", mate = "theta5", teeth = [20, 30], radii = [10, 10] }', "gears.g", "ratio of the teeth"),
    ('{ gear = "theta2", mate = "theta9", teeth = [20, 30] }', "gears.g.mate", "not a declared variable"),
    ('{ gear = "theta2", teeth = [20, 30] }', "gears.g", "missing key 'mate'"),
    ('{ gear = "theta2", mate = "theta2", teeth = [20, 30] }', "gears.g", "cannot mesh with itself"),
    ('{ gear = "theta2", mate = "theta5", teeth = [20, 30], carrier = "theta5" }', "gears.g.carrier", "member"),
    ('{ gear = "theta2", mate = "theta5", teeth = [20, 30], spin = 1 }', "gears.g", "unknown key"),
    ('{ gear = "theta2", mate = "theta5" }', "gears.g", "give `teeth`"),
    ('{ gear = "theta2", mate = "theta5", teeth = [30, 30], internal = true }', "gears.g.teeth", "more teeth"),
])
def test_bad_gear_declarations_name_the_key(tmp_path, entry, key, words):
    path = tmp_path / "bad.toml"
    path.write_text(FIVEBAR.format(extra=f"[gears]\ng = {entry}"))
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "info", str(path)], capture_output=True, text=True)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1
    assert key in proc.stderr and words in proc.stderr


def test_info_json_lists_the_pairs(tmp_path):
    path = tmp_path / "g.toml"
    path.write_text(FIVEBAR.format(extra=GEARED).replace("r1 = 40", "r1 = 30"))
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "info", str(path), "--format", "json"],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert data["mobility"] == 1 and [p["name"] for p in data["pairs"]] == ["gears.g"]
