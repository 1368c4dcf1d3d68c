"""The guesses name the mode (issue 17, item 5; DESIGN.md, Conventions).

The mode asked for is the signature of Φ_q's diagonal blocks evaluated *at the guesses* (or
``--mode``); solve, sweep, study and forces return the solution with that signature — not the
one Newton happens to converge to — or a ``ModeError`` naming the modes that exist.

For the four-bar ``r2 + r3 = r1 + r4`` the loop residual is
``f = r2 e^{iθ2} + r3 e^{iθ3} − r1 − r4 e^{iθ4}``, so ``∂f/∂θ3 = i r3 e^{iθ3}``,
``∂f/∂θ4 = −i r4 e^{iθ4}`` and the determinant of the 2×2 block (real and imaginary rows) is
``r3 r4 sin(θ3 − θ4)``: the signature is ``sign(sin(θ3 − θ4))`` ("-" is the open four-bar of
the guesses θ3 = 20°, θ4 = 80°). The positions are the textbook half-angle solution (seed notes
000: A1 cos θ4 + B1 sin θ4 + C1 = 0, tan(θ4/2) from a quadratic, θ3 from the loop), written here.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import loopsolve as ls

from support.models import watt_sixbar

REPRO = Path(__file__).resolve().parents[3] / "shared" / "repro" / "study_mode_98.toml"
REPRO_TEXT = """
name = "Crank-rocker four-bar"
units = { length = "mm", angle = "deg" }

[parameters]
r1 = 72.23
r2 = 14.2
r3 = 27.48
r4 = 79.56

[variables]
theta2 = { input = true, guess = 90, speed = "10rpm" }
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

[modes]
open = "-"
crossed = "+"
"""
BODIES = """
[bodies]
crank   = { mass = "0.1kg", inertia = "2e-6kg*m^2", com = "0.5*r2", angle = "theta2", joints = ["O2", "B"] }
coupler = { mass = "0.2kg", inertia = "1.3e-5kg*m^2", com = "r2 + 0.5*r3", angle = "theta3", joints = ["B", "C"] }
rocker  = { mass = "0.5kg", inertia = "2.6e-4kg*m^2", com = "r1 + 0.5*r4", angle = "theta4", joints = ["C", "O4"] }
"""


def fourbar_text(r1, r2, r3, r4, g2, g3, g4) -> str:
    """A four-bar model with these lengths and guesses (degrees)."""
    return f"""
name = "random four-bar"
units = {{ length = "mm", angle = "deg" }}
[parameters]
r1 = {r1!r}
r2 = {r2!r}
r3 = {r3!r}
r4 = {r4!r}
[variables]
theta2 = {{ input = true, guess = {g2!r} }}
theta3 = {{ guess = {g3!r} }}
theta4 = {{ guess = {g4!r} }}
[vectors]
r1 = {{ length = "r1", angle = 0 }}
r2 = {{ length = "r2", angle = "theta2" }}
r3 = {{ length = "r3", angle = "theta3" }}
r4 = {{ length = "r4", angle = "theta4" }}
[[loops]]
equation = "r2 + r3 = r1 + r4"
"""


def wrap(a):
    return (np.asarray(a) + math.pi) % (2 * math.pi) - math.pi


def half_angle(r1, r2, r3, r4, t2):
    """Both (θ3, θ4) of the four-bar at crank angle t2 (radians), [] if it cannot be assembled."""
    a1 = 2 * r1 * r4 - 2 * r2 * r4 * math.cos(t2)
    b1 = -2 * r2 * r4 * math.sin(t2)
    c1 = r1 * r1 + r2 * r2 + r4 * r4 - r3 * r3 - 2 * r1 * r2 * math.cos(t2)
    qa, qb, qc = c1 - a1, 2 * b1, c1 + a1
    disc = qb * qb - 4 * qa * qc
    if disc < 0 or abs(qa) < 1e-12:
        return []
    out = []
    for s in (1, -1):
        t4 = 2 * math.atan((-qb + s * math.sqrt(disc)) / (2 * qa))
        t3 = math.atan2(r4 * math.sin(t4) - r2 * math.sin(t2), r1 + r4 * math.cos(t4) - r2 * math.cos(t2))
        out.append((t3, t4))
    return out


def sign_name(v: float) -> str:
    return "+" if v > 0 else "-"


def expected(r, t2, g3, g4):
    """(signature the guesses name, the closed-form (θ3, θ4) in it or None, the signatures at t2)."""
    want = sign_name(math.sin(g3 - g4))
    roots = half_angle(*r, t2)
    there = {sign_name(math.sin(t3 - t4)): (t3, t4) for t3, t4 in roots}
    return want, there.get(want), sorted(there)


def ill_posed(r, t2, g3, g4) -> bool:
    """Close to a toggle at t2 (the two modes nearly meet) or guesses nearly singular: not a fair case."""
    roots = half_angle(*r, t2)
    return abs(math.sin(g3 - g4)) < 1e-3 or any(abs(math.sin(a - b)) < 1e-3 for a, b in roots)


# ----------------------------------------------------------------------------- the reproducer


class TestRepro:
    """study_mode_98: guesses θ3 = 20°, θ4 = 80° name "-" (open); Newton from them at 90° fell into "+"."""

    R = (72.23, 14.2, 27.48, 79.56)

    def open_at(self, deg):
        want, root, _ = expected(self.R, math.radians(deg), math.radians(20), math.radians(80))
        assert want == "-"
        return np.degrees(root)

    def test_solve(self, tmp_path):
        mech = ls.loads(REPRO_TEXT)
        s = mech.solve(90)
        t3, t4 = self.open_at(90)
        assert s.mode == "-"
        assert abs(wrap(math.radians(s["theta3"] - t3))) < 1e-10 and abs(wrap(math.radians(s["theta4"] - t4))) < 1e-10
        if REPRO.exists():  # the shared reproducer file itself, from the command line
            out = subprocess.run([sys.executable, "-m", "loopsolve.cli", "solve", str(REPRO), "--at", "90",
                                  "--format", "json"], capture_output=True, text=True)
            assert out.returncode == 0, out.stderr
            doc = json.loads(out.stdout)
            assert doc["mode"] == "-" and doc["rows"][0]["theta4"] == pytest.approx(t4, abs=1e-8)

    def test_sweep(self):
        sw = ls.loads(REPRO_TEXT).sweep(0, 360, 30)
        assert sw.mode == "-" and set(sw.modes) == {"-"}
        for x, t3, t4 in zip(sw["theta2"], sw["theta3"], sw["theta4"]):
            e3, e4 = self.open_at(x)
            assert abs(wrap(math.radians(t3 - e3))) < 1e-9 and abs(wrap(math.radians(t4 - e4))) < 1e-9

    def test_study(self):
        pytest.importorskip("xarray")
        mech = ls.loads(REPRO_TEXT)
        r2s = [12.0, 14.2, 16.0]
        ds = ls.study(mech, {"r2": r2s}, 90, 90, 1, progress=False)
        assert list(ds["mode"].values) == ["-"] * 3 and list(ds["status"].values) == ["ok"] * 3
        for j, r2 in enumerate(r2s):
            (e3, e4) = expected((72.23, r2, 27.48, 79.56), math.radians(90), math.radians(20), math.radians(80))[1]
            assert abs(wrap(math.radians(float(ds["theta4"].values[j, 0])) - e4)) < 1e-9
            assert abs(wrap(math.radians(float(ds["theta3"].values[j, 0])) - e3)) < 1e-9

    def test_forces(self):
        mech = ls.loads(REPRO_TEXT + BODIES)
        fs = ls.forces(mech, 90)
        assert fs.mode == "-"
        t3, t4 = self.open_at(90)
        assert float(np.ravel(fs.sweep["theta4"])[0]) == pytest.approx(t4, abs=1e-8)
        fs = ls.forces(mech, 0, 90, 30)
        assert fs.mode == "-" and set(fs.sweep.modes) == {"-"}

    def test_explicit_mode_still_wins(self):
        s = ls.loads(REPRO_TEXT).solve(90, mode="crossed")
        want, root, _ = expected(self.R, math.radians(90), math.radians(80), math.radians(20))
        assert s.mode == "+" == want and abs(wrap(math.radians(s["theta4"]) - root[1])) < 1e-10


# ----------------------------------------------------------------------------- property test


def _cases(n, seed, *, max_unassemblable):
    """Random four-bars (lengths 10..100), guesses and inputs (degrees); at most ``max_unassemblable``
    of them cannot be assembled at their input (each of those costs the search for the nearest
    assemblable inputs that the error names)."""
    rng = np.random.default_rng(seed)
    out, bad = [], 0
    while len(out) < n:
        r = tuple(float(v) for v in np.round(rng.uniform(10, 100, 4), 3))
        g2, g3, g4 = (float(v) for v in np.round(rng.uniform(-180, 180, 3), 3))
        at = g2 if rng.random() < 0.3 else float(np.round(rng.uniform(-180, 180), 3))
        if ill_posed(r, math.radians(at), math.radians(g3), math.radians(g4)):
            continue
        if not half_angle(*r, math.radians(at)):
            if bad >= max_unassemblable:
                continue
            bad += 1
        out.append((r, g2, g3, g4, at))
    return out


def test_solve_returns_the_mode_the_guesses_name_300_random_fourbars():
    """300 random four-bars, random guesses and inputs: the mode of sign(sin(θ3 − θ4)) at the guesses,
    at the closed-form position, or a ModeError/AssemblyError when that mode does not exist there."""
    n_ok = n_none = 0
    for r, g2, g3, g4, at in _cases(300, 20261125, max_unassemblable=15):
        mech = ls.loads(fourbar_text(*r, g2, g3, g4))
        want, root, there = expected(r, math.radians(at), math.radians(g3), math.radians(g4))
        if root is None:
            with pytest.raises(ls.AssemblyError) as exc:
                mech.solve(at)
            if there:  # assemblable, not in that mode
                assert isinstance(exc.value, ls.ModeError) and sorted(exc.value.modes) == there
            n_none += 1
            continue
        s = mech.solve(at)
        assert s.mode == want, (r, g2, g3, g4, at)
        assert abs(wrap(math.radians(s["theta3"]) - root[0])) < 1e-8, (r, g2, g3, g4, at)
        assert abs(wrap(math.radians(s["theta4"]) - root[1])) < 1e-8, (r, g2, g3, g4, at)
        n_ok += 1
    assert n_ok >= 285 and n_none == 15  # both outcomes are exercised


def test_study_keeps_the_mode_the_guesses_name_for_every_design():
    """10 studies of 30 random designs each (300 designs), each study with its own random guesses and
    input: every design in the mode its guesses name (evaluated with its own lengths)."""
    pytest.importorskip("xarray")
    from loopsolve.design.designs import Designs

    rng = np.random.default_rng(1711)
    checked = unassemblable = 0
    for k in range(10):
        g2, g3, g4, at = (float(v) for v in np.round(rng.uniform(-180, 180, 4), 3))
        if abs(math.sin(math.radians(g3 - g4))) < 1e-3:
            continue
        designs = []
        while len(designs) < 30:
            r = tuple(float(v) for v in np.round(rng.uniform(10, 100, 4), 3))
            if ill_posed(r, math.radians(at), math.radians(g3), math.radians(g4)):
                continue
            if not half_angle(*r, math.radians(at)) and len(designs) % 15:  # a few unassemblable ones only
                continue
            designs.append(r)
        mech = ls.loads(fourbar_text(*designs[0], g2, g3, g4))
        table = np.array(designs)
        ds = ls.study(mech, Designs(("r1", "r2", "r3", "r4"), {n: table[:, i] for i, n in enumerate(("r1", "r2", "r3", "r4"))}),
                      at, at, 1, progress=False)
        for j, r in enumerate(designs):
            assert tuple(float(ds[n].values[j]) for n in ("r1", "r2", "r3", "r4")) == r
            want, root, there = expected(r, math.radians(at), math.radians(g3), math.radians(g4))
            status = str(ds["status"].values[j])
            if root is None:
                assert status == "not-assemblable", (r, g2, g3, g4, at, status)
                unassemblable += 1
                continue
            # ("limit": a one-row sweep reports a limit beyond its range where one is near; the row is there)
            assert status in ("ok", "limit") and str(ds["mode"].values[j]) == want, (r, g2, g3, g4, at, status)
            assert abs(wrap(math.radians(float(ds["theta3"].values[j, 0])) - root[0])) < 1e-8
            assert abs(wrap(math.radians(float(ds["theta4"].values[j, 0])) - root[1])) < 1e-8
            checked += 1
    assert checked + unassemblable == 300 and checked >= 270 and unassemblable >= 1


# ----------------------------------------------------------------------------- edges of the contract


def test_mode_that_does_not_exist_is_a_mode_error_exit_3(tmp_path, capsys):
    from loopsolve.cli import main

    mech = watt_sixbar().with_parameters(r5=40)  # at 60° only ++ and +- assemble
    path = tmp_path / "w.toml"
    path.write_text(ls.dumps(mech))
    assert main(["solve", str(path), "--at", "60", "--mode=--"]) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "ModeError" in err and "++, +-" in err


def test_guesses_on_a_singular_configuration_name_no_mode():
    """θ3 = θ4 at the guesses (coupler and rocker collinear): the block is singular, no sign is named;
    the solve takes the solution Newton reaches and says so (a LoopsolveWarning)."""
    mech = ls.loads(fourbar_text(60.0, 25.0, 70.0, 45.0, 90.0, 40.0, 40.0))
    from loopsolve.kinematics.solve import guessed_mode

    assert guessed_mode(mech.compile()) == "0"
    with pytest.warns(ls.LoopsolveWarning, match="singular configuration.*--mode"):
        s = mech.solve(90)
    roots = half_angle(60, 25, 70, 45, math.radians(90))
    assert any(abs(wrap(math.radians(s["theta4"]) - t4)) < 1e-10 for _, t4 in roots)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert mech.solve(90, mode="+").mode == "+"  # an explicit mode needs no guesses


def test_cli_modes_says_which_mode_the_guesses_name(capsys):
    from loopsolve.cli import main

    path = str(ls.models_dir() / "thesis_crank_rocker.toml")  # θ3 = 20°, θ4 = 80°: sin(θ3 − θ4) < 0
    assert main(["modes", path, "--at", "90"]) == 0
    assert capsys.readouterr().out.splitlines()[-1].startswith("the guesses name mode - (open)")
    assert ls.guessed_mode(ls.load(path)) == "-"


def test_a_start_newton_ran_turns_away_from_is_reduced_and_exact():
    """Newton from the factory's guesses at θ2 = 0 lands on this crank-rocker's pose at θ2 ≈ 100°
    98 turns away (θ3 ≈ 616 rad), where the last digits are gone; the start is reduced to
    (−π, π] and polished: the loops close to round-off of O(1) numbers and θ3 matches the
    half-angle closed form (found by the tracker's finite-difference property test)."""
    r = (1.8125, 1.466796875, 3.4375, 3.091806875)
    mech = ls.fourbar(*r, theta2=0.0, mode="open")
    st = mech.solve(100 - 2e-3)
    assert st.mode == "-"
    ck = mech.compile()
    z = np.array(st.z, dtype=float)
    assert np.all(np.abs(z[ck.unknown_idx]) <= np.pi)
    assert np.max(np.abs(ck.phi(z))) <= 1e-15 * max(r)
    t2 = np.radians(100 - 2e-3)
    r1, r2, r3, r4 = r
    # circle intersection: C on the circle about B = r2·e^{iθ2} of radius r3 and about O4 = r1 of radius r4
    B, O4 = r2 * np.exp(1j * t2), complex(r1, 0)
    d = abs(O4 - B)
    along = (r3**2 - r4**2 + d**2) / (2 * d)
    h = math.sqrt(r3**2 - along**2)
    u = (O4 - B) / d
    sols = []
    for sgn in (1, -1):
        C = B + along * u + sgn * h * 1j * u
        th3, th4 = np.angle(C - B), np.angle(C - O4)
        if np.sin(th4 - th3) > 0:  # mode "-": det Φ_q = r3·r4·sin(θ3 − θ4) < 0
            sols.append((th3, th4))
    assert len(sols) == 1
    for name, want in zip(("theta3", "theta4"), sols[0]):
        got = np.radians(st[name])
        assert abs((got - want + np.pi) % (2 * np.pi) - np.pi) < 1e-12
