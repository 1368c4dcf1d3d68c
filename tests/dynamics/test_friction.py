"""Coulomb friction: inclined planes and a journal-bearing crank against the textbook closed forms,
self-locking included."""

import math
import subprocess
import sys

import numpy as np
import pytest

import loopsolve as ls

INCLINE = """
name = "block on an incline"
units = { length = "mm", angle = "deg" }
gravity = [0, "-9.81m/s^2"]
[parameters]
alpha = ALPHA
[variables]
x = { input = true, guess = 50 }
h = { guess = 10, kind = "length" }
[vectors]
rb = { length = "x", angle = "alpha" }
[points]
B = "rb"
[constraints]
height = "h = x*sin(alpha)"
[bodies]
block = { mass = "2kg", com = "B", guide = "rb", joints = [] }
[friction]
block = { mu = 0.3 }
"""


@pytest.mark.parametrize("alpha", [10, 30, 60])
def test_block_pushed_along_the_incline(alpha):
    """P = W (sin α ± μ cos α) moving up (down); the friction force μ W cos α dissipates μ W cos α |ẋ|."""
    mech = ls.loads(INCLINE.replace("ALPHA", str(alpha)))
    a, W = math.radians(alpha), 2 * 9.81
    up = ls.forces(mech, 50, speed=0.2)
    assert up["input_force"] == pytest.approx(W * (math.sin(a) + 0.3 * math.cos(a)), rel=1e-12)
    assert up["power_lost_block"] == pytest.approx(0.3 * W * math.cos(a) * 0.2e-3, rel=1e-12)
    assert up["power_residual"] == pytest.approx(0, abs=1e-12)
    down = ls.forces(mech, 50, speed=-0.2)
    assert down["input_force"] == pytest.approx(W * (math.sin(a) - 0.3 * math.cos(a)), rel=1e-12)
    # at rest friction is undetermined: none is applied
    assert ls.forces(mech, 50, speed=0.0)["input_force"] == pytest.approx(W * math.sin(a), rel=1e-12)


WEDGE = """
name = "block pushed up an incline by a horizontal pusher"
units = { length = "mm", angle = "deg" }
gravity = [0, "-9.81m/s^2"]
[parameters]
alpha = ALPHA
[variables]
x = { input = true, guess = 50 }
s = { guess = 100 }
[vectors]
rp = { length = "x", angle = 0 }
rb = { length = "s", angle = "alpha" }
rs = { length = 10, angle = 90 }
[points]
Px = "rp"
B = "rb"
[slots]
push = { point = "B", link = "pusher", line = "rs", through = "Px" }
[bodies]
pusher = { mass = "1e-6kg", com = "Px", guide = "rp", joints = [] }
block = { mass = "2kg", com = "B", guide = "rb", joints = ["B"] }
[friction]
block = { mu = 0.3 }
"""


@pytest.mark.parametrize("alpha", [20, 45, 70, 80])
def test_horizontal_force_on_an_incline_and_self_locking(alpha):
    """P = W (sin α + μ cos α)/(cos α − μ sin α) up the incline; for μ ≥ cot α no force moves it: self-locking.
    Down the incline P = W (sin α − μ cos α)/(cos α + μ sin α)."""
    mech = ls.loads(WEDGE.replace("ALPHA", str(alpha)))
    a, W, mu = math.radians(alpha), 2 * 9.81, 0.3
    up = ls.forces(mech, 50, speed=1e-4)
    down = ls.forces(mech, 50, speed=-1e-4)
    assert down["input_force"] == pytest.approx(W * (math.sin(a) - mu * math.cos(a)) / (math.cos(a) + mu * math.sin(a)),
                                                rel=1e-6)
    if mu < 1 / math.tan(a):
        assert up["input_force"] == pytest.approx(W * (math.sin(a) + mu * math.cos(a)) / (math.cos(a) - mu * math.sin(a)),
                                                  rel=1e-6)
        assert not any(e.kind.value == "self-locking" for e in up.events)
    else:
        assert math.isnan(up["input_force"])
        assert [e.kind.value for e in up.events] == ["self-locking"]


def test_self_locking_is_an_event_not_a_failure(tmp_path):
    import json

    path = tmp_path / "wedge.toml"
    path.write_text(WEDGE.replace("ALPHA", "80"))
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "forces", str(path), "--from", "40", "--to", "60",
                           "--step", "10", "--speed", "0.001", "--format", "json"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    data = json.loads(proc.stdout)
    assert [e["kind"] for e in data["events"]] == ["self-locking"] * 3
    assert all(r["input_force"] is None for r in data["rows"])


JOURNAL = """
name = "slider-crank driven by its piston, friction in the crank's bearing"
units = { length = "mm", angle = "deg" }
[variables]
x = { input = true, guess = 140 }
theta2 = { guess = 60 }
theta3 = { guess = -17 }
[vectors]
r1 = { length = "x", angle = 0 }
r2 = { length = 40, angle = "theta2" }
r3 = { length = 120, angle = "theta3" }
[[loops]]
equation = "r2 + r3 = r1"
[points]
O2 = "0"
A = "r2"
B = "r1"
[bodies]
crank = { mass = "0.5kg", inertia = "1e-4kg*m^2", com = "O2", angle = "theta2", joints = ["O2", "A"] }
rod = { mass = "1e-6kg", inertia = "1e-12kg*m^2", com = "r2 + 0.5*r3", angle = "theta3", joints = ["A", "B"] }
piston = { mass = "1e-6kg", com = "B", guide = "r1", joints = ["B"] }
[[loads]]
body = "crank"
torque = "2N*m"
[friction]
O2 = { mu = 0.2, radius = "10mm" }
"""


def _rod_geometry(x_mm, theta2_deg):
    t2 = math.radians(theta2_deg)
    A = np.array([0.04 * math.cos(t2), 0.04 * math.sin(t2)])
    B = np.array([x_mm / 1000, 0.0])
    L = float(np.linalg.norm(A - B))
    d = float(A[0] * (A[1] - B[1]) - A[1] * (A[0] - B[0])) / L  # the rod's line from the bearing's centre
    return A, B, L, d


@pytest.mark.filterwarnings("ignore::loopsolve.errors.LoopsolveWarning")  # the range ends by the dead centre
def test_journal_bearing_crank_against_the_friction_circle():
    """The rod (a two-force member) pulls the crank, which turns clockwise against 2 N·m; the bearing's
    friction circle r sin φ adds to the load: F = 2 N·m/(d − r sin φ), P = F (B − A)ₓ/L; the bearing loses
    r sin φ |F| |ω2|; and the rod's line passing inside the friction circle (d < r sin φ) locks the crank."""
    mech = ls.loads(JOURNAL)
    rf = 0.010 * math.sin(math.atan(0.2))
    f = ls.forces(mech, 100, 159.9, 2.5, speed=1e-3)
    for row in f.rows:
        A, B, L, d = _rod_geometry(row["x"], row["theta2"])
        F = 2.0 / (d - rf)
        assert row["input_force"] == pytest.approx(F * (B[0] - A[0]) / L, rel=1e-5)
        assert row["power_lost_O2"] == pytest.approx(rf * F * abs(row["theta2_vel"]), rel=1e-5)
        assert row["power_residual"] == pytest.approx(0, abs=1e-9)
    near = ls.forces(mech, 159.94, 159.995, 0.005, speed=1e-3)
    locked = {round(e.input, 6) for e in near.events if e.kind.value == "self-locking"}
    for row in near.rows:
        _, _, _, d = _rod_geometry(row["x"], row["theta2"])
        assert (round(row["x"], 6) in locked) == (d < rf)
    assert locked  # the dead centre's neighbourhood


def test_journal_friction_against_a_torque_driven_crank():
    """Driven by a torque, a crank never locks: T = (load) + r sin φ |F| whatever the rod's angle."""
    text = JOURNAL.replace('x = { input = true, guess = 140 }', 'x = { guess = 140 }') \
        .replace('theta2 = { guess = 60 }', 'theta2 = { input = true, guess = 60 }') \
        .replace('[[loads]]\nbody = "crank"\ntorque = "2N*m"', '[[loads]]\nat = "B"\nbody = "piston"\nforce = ["-30N", 0]')
    mech = ls.loads(text)
    rf = 0.010 * math.sin(math.atan(0.2))
    f = ls.forces(mech, 0, 350, 10, speed=-1e-3)
    assert not f.events
    for row in f.rows:
        A, B, L, d = _rod_geometry(row["x"], row["theta2"])
        # the rod carries the piston's load: tension F along the rod with F (B − A)ₓ/L = −30 N
        F = -30.0 * L / (B[0] - A[0])
        T_ideal = -F * d  # the rod's moment about the bearing, F pulling from A towards B
        assert row["input_torque"] == pytest.approx(-T_ideal + rf * abs(F) * np.sign(row["theta2_vel"]) * 1.0,
                                                    rel=1e-5, abs=1e-9)


@pytest.mark.parametrize("entry, key, words", [
    ('O9 = { mu = 0.1, radius = "5mm" }', "friction.O9", "not a joint of the bodies"),
    ('O2 = { mu = 0.1 }', "friction.O2", "needs `radius`"),
    ('O2 = { mu = -0.1, radius = "5mm" }', "friction.O2.mu", "≥ 0"),
    ('piston = { mu = 0.1, radius = "5mm" }', "friction.piston.radius", "revolute"),
])
def test_bad_friction_declarations(tmp_path, entry, key, words):
    path = tmp_path / "bad.toml"
    path.write_text(JOURNAL.split("[friction]")[0] + "[friction]\n" + entry + "\n")
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "info", str(path)], capture_output=True, text=True)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    assert key in proc.stderr and words in proc.stderr


def test_simulation_spins_down_against_the_journal_friction():
    """A balanced wheel of 2 kg on a 20 mm journal (μ = 0.2) spins down at the constant rate
    α = −r sin φ · m g / I, tan φ = μ: the equation of motion with friction, against the closed form."""
    from pathlib import Path

    mech = ls.load(Path(__file__).parent.parent / "data" / "journal_wheel.toml")
    sim = ls.simulate(mech, 1.0, step=0.1, speed0=10)
    alpha = -0.020 * math.sin(math.atan(0.2)) * 2 * 9.81 / 0.01
    t = np.asarray(sim.t)
    assert np.allclose(sim.xd, 10 + alpha * t, rtol=1e-9)
    assert np.allclose(np.radians(sim.x), 10 * t + 0.5 * alpha * t**2, atol=1e-9)
    f = ls.forces(mech, 30, speed=10.0, accel=alpha)  # coasting: no driving torque, all lost in the bearing
    assert f["input_torque"] == pytest.approx(0.0, abs=1e-12)
    assert f["power_lost_O"] == pytest.approx(-alpha * 0.01 * 10.0, rel=1e-12)


def _latex(tmp_path, text, at):
    path = tmp_path / "m.toml"
    path.write_text(text)
    out = tmp_path / "m.tex"
    proc = subprocess.run([sys.executable, "-m", "loopsolve", "latex", str(path), "--at", str(at), "-o", str(out)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return out.read_text()


def _value(tex, head):
    """The number of the aligned line that starts with ``head`` (``head &= 0.0769\\,\\mathrm{N\\,m}``)."""
    line = next(ln for ln in tex.splitlines() if ln.startswith(head) and "&=" in ln)
    return float(line.split("&=")[1].split("\\,")[0].strip())


def test_latex_equation_of_motion_carries_the_friction(tmp_path):
    """With [friction] the printed equation of motion has the friction's generalized force Q_f and the
    document's T at an input is the exact one with friction: for a wheel on its journal turning at
    1 rad/s without acceleration, T = Q_f = r sin(atan μ) m g (the friction circle), not 0."""
    from pathlib import Path

    text = (Path(__file__).parents[1] / "data" / "journal_wheel.toml").read_text()
    tex = _latex(tmp_path, text, 30)
    c = 0.020 * 0.2 / math.sqrt(1 + 0.2**2)
    assert r"&= Q + T - Q_\mathrm{f}" in tex
    assert "revolute (journal)" in tex
    assert _value(tex, r"P_\mathrm{lost}") == pytest.approx(c * 2 * 9.81, rel=1e-5)
    assert _value(tex, r"Q_\mathrm{f}") == pytest.approx(c * 2 * 9.81, rel=1e-5)
    assert _value(tex, r"T = M") == pytest.approx(c * 2 * 9.81, rel=1e-5)
    # without friction neither the term nor the lost power is printed, and T is the frictionless one (0)
    plain = _latex(tmp_path, text.split("[friction]")[0], 30)
    assert "Q_\\mathrm{f}" not in plain and "P_\\mathrm{lost}" not in plain
    assert _value(plain, r"T = M") == 0.0


@pytest.mark.parametrize("alpha", [30, 80])
def test_latex_friction_on_an_incline_and_its_self_locking(tmp_path, alpha):
    """The wedge pushed up at 1 mm/s: P = W (sin α + μ cos α)/(cos α − μ sin α) below self-locking; above it
    the document says the mechanism self-locks instead of printing a force."""
    tex = _latex(tmp_path, WEDGE.replace("ALPHA", str(alpha)), 50)
    a, W, mu = math.radians(alpha), 2 * 9.81, 0.3
    assert "prismatic guide" in tex
    if mu < 1 / math.tan(a):
        assert _value(tex, r"T = M") == pytest.approx(
            W * (math.sin(a) + mu * math.cos(a)) / (math.cos(a) - mu * math.sin(a)), rel=1e-6)
        assert "self-locks here" not in tex
    else:
        assert "self-locks here" in tex
        assert not any(ln.startswith(r"T = M") for ln in tex.splitlines())
