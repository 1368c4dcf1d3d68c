"""The input's motion is never ignored, whichever way it is given.

Rates of every output follow from the kinematic coefficients q′ = dq/dx, q″, q‴ by the chain rule

    q̇ = q′ẋ,   q̈ = q″ẋ² + q′ẍ,   q⃛ = q‴ẋ³ + 3q″ẋẍ + q′x⃛.

The coefficients are computed here independently of loopsolve, by finite differences of closed-form
positions (the four-bar's circle intersection, the slider-crank's piston formula), and compared with
the rates loopsolve reports when the input's speed/accel/jerk come from the model file, from the
command line (``solve``, ``sweep``, ``plot``, ``animate``) or from the Python arguments.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.output import plotting
from loopsolve.cli import main

# crank-rocker four-bar: ground r1 = 60 along x, crank r2 = 25, coupler r3 = 70, rocker r4 = 45
FOURBAR = """
name = "rates probe four-bar"
units = {{ length = "mm", angle = "deg" }}

[parameters]
r1 = 60
r2 = 25
r3 = 70
r4 = 45

[variables]
theta2 = {{ input = true, guess = 50{rates} }}
theta3 = {{ guess = 20 }}
theta4 = {{ guess = 80 }}

[vectors]
r1 = {{ length = "r1", angle = 0 }}
r2 = {{ length = "r2", angle = "theta2" }}
r3 = {{ length = "r3", angle = "theta3" }}
r4 = {{ length = "r4", angle = "theta4" }}

[[loops]]
equation = "r2 + r3 = r1 + r4"

[points]
C = "r2 + r3"
"""

# in-line slider-crank, inches: crank r2 = 5, rod r3 = 8, slider at x = r1 on the x axis
SLIDER = """
name = "rates probe slider-crank"
units = {{ length = "in", angle = "deg" }}

[parameters]
r2 = 5
r3 = 8

[variables]
theta2 = {{ input = true, guess = 50{rates} }}
theta3 = {{ guess = -26 }}
r1 = {{ guess = 11 }}

[vectors]
r1 = {{ length = "r1", angle = 0 }}
r2 = {{ length = "r2", angle = "theta2" }}
r3 = {{ length = "r3", angle = "theta3" }}

[[loops]]
equation = "r2 + r3 = r1"
"""


def fourbar_closed(t2, branch):
    """theta3, theta4 [rad] and C_x [mm] of the four-bar at crank angle t2 [rad], on one branch."""
    bx, by = 25 * math.cos(t2), 25 * math.sin(t2)
    ux, uy = 60 - bx, -by
    L = math.hypot(ux, uy)
    ux, uy = ux / L, uy / L
    h = (70 ** 2 - 45 ** 2 + L * L) / (2 * L)
    k = branch * math.sqrt(70 ** 2 - h * h)
    cx, cy = bx + h * ux - k * uy, by + h * uy + k * ux
    return {"theta3": math.atan2(cy - by, cx - bx), "theta4": math.atan2(cy, cx - 60), "C_x": cx}


def slider_closed(t2, branch=1):
    """theta3 [rad] and r1 [in] of the in-line slider-crank at crank angle t2 [rad]."""
    s = 5 * math.sin(t2)
    return {"theta3": math.asin(-s / 8), "r1": 5 * math.cos(t2) + math.sqrt(64 - s * s)}


ANGLES = {"theta3", "theta4"}


def coefficients(closed, t2, branch, name, h=5e-3):
    """q, q′, q″, q‴ of ``name`` at ``t2`` [rad] by 7-point central differences (error O(h⁴))."""
    f = np.array([closed(t2 + i * h, branch)[name] for i in range(-3, 4)])
    if name in ANGLES:
        f = np.unwrap(f)
    fm3, fm2, fm1, f0, f1, f2, f3 = f
    d1 = (-f2 + 8 * f1 - 8 * fm1 + fm2) / (12 * h)
    d2 = (-f2 + 16 * f1 - 30 * f0 + 16 * fm1 - fm2) / (12 * h * h)
    d3 = (-f3 + 8 * f2 - 13 * f1 + 13 * fm1 - 8 * fm2 + fm3) / (8 * h ** 3)
    return f0, d1, d2, d3


def expected_rates(closed, t2, branch, name, xd, xdd, xddd):
    _, d1, d2, d3 = coefficients(closed, t2, branch, name)
    return (d1 * xd,
            d2 * xd ** 2 + d1 * xdd,
            d3 * xd ** 3 + 3 * d2 * xd * xdd + d1 * xddd)


def branch_of(closed, t2, row, name):
    """The closed-form branch that the reported position lies on (the rates are then checked on it)."""
    for b in (1, -1):
        q = closed(t2, b)[name]
        value = math.radians(row[name]) if name in ANGLES else row[name]
        if abs(math.remainder(value - q, 2 * math.pi) if name in ANGLES else value - q) < 1e-9:
            return b
    raise AssertionError(f"{name} = {row[name]} is on no closed-form branch at {math.degrees(t2)} deg")


def check_row(row, closed, names, xd, xdd, xddd):
    """Every rate of ``names`` in one output row (dict of display values) obeys the chain rule."""
    t2 = math.radians(row["theta2"])
    assert (row["theta2_vel"], row["theta2_acc"], row["theta2_jerk"]) == pytest.approx((xd, xdd, xddd), abs=1e-12)
    for name in names:
        b = branch_of(closed, t2, row, name)
        exp = expected_rates(closed, t2, b, name, xd, xdd, xddd)
        got = (row[f"{name}_vel"], row[f"{name}_acc"], row[f"{name}_jerk"])
        scale = max(1.0, *map(abs, exp))
        for g, e, what in zip(got, exp, ("vel", "acc", "jerk")):
            assert abs(g - e) < 1e-6 * scale, f"{name}_{what} at theta2={row['theta2']}: {g} != {e}"


def check_rows(rows, closed, names, rates):
    assert rows
    for row in rows:
        check_row(row, closed, names, *rates)


FOURBAR_NAMES = ("theta3", "theta4", "C_x")
SLIDER_NAMES = ("theta3", "r1")

# (text in [variables], rates in rad/s, rad/s², rad/s³)
DECLARED = ', speed = "30rpm", accel = "2rad/s^2", jerk = "-3rad/s^3"'
DECLARED_RATES = (math.pi, 2.0, -3.0)
FLAGS = ("--speed", "3", "--accel", "-1.5", "--jerk", "7")
FLAG_RATES = (3.0, -1.5, 7.0)


@pytest.fixture
def fourbar_file(tmp_path):
    path = tmp_path / "fourbar.toml"
    path.write_text(FOURBAR.format(rates=DECLARED))
    return path


@pytest.fixture
def slider_file(tmp_path):
    path = tmp_path / "slider.toml"
    path.write_text(SLIDER.format(rates=DECLARED))
    return path


def _cli_json(capsys, *args):
    status = main([str(a) for a in args])
    out = capsys.readouterr()
    assert status == 0, out.err
    return json.loads(out.out)


# ----------------------------------------------------------------------------- the model file's rates


@pytest.mark.parametrize("kind", ["fourbar", "slider"])
def test_declared_speed_accel_jerk_in_python_solve_and_sweep(kind, fourbar_file, slider_file):
    path, closed, names = ((fourbar_file, fourbar_closed, FOURBAR_NAMES) if kind == "fourbar"
                           else (slider_file, slider_closed, SLIDER_NAMES))
    mech = ls.load(path)
    for at in (0, 50, 137, 250):
        check_row(mech.solve(at).row(), closed, names, *DECLARED_RATES)
    check_rows(mech.sweep(0, 330, 30, progress=False).rows, closed, names, DECLARED_RATES)


def test_declared_rates_on_the_command_line(capsys, fourbar_file):
    data = _cli_json(capsys, "solve", fourbar_file, "--at", "137", "--format", "json")
    check_rows(data["rows"], fourbar_closed, FOURBAR_NAMES, DECLARED_RATES)
    data = _cli_json(capsys, "sweep", fourbar_file, "--from", "0", "--to", "330", "--step", "30", "-q",
                     "--format", "json")
    check_rows(data["rows"], fourbar_closed, FOURBAR_NAMES, DECLARED_RATES)


def test_only_a_declared_jerk(tmp_path):
    """A jerk alone: speed defaults to 1 (rates are coefficients), accel to 0, the jerk is used."""
    path = tmp_path / "jerk.toml"
    path.write_text(FOURBAR.format(rates=', jerk = "5rad/s^3"'))
    check_rows(ls.load(path).sweep(10, 310, 60, progress=False).rows, fourbar_closed, FOURBAR_NAMES,
               (1.0, 0.0, 5.0))


# ----------------------------------------------------------------------------- command-line flags


@pytest.mark.parametrize("command", ["solve", "sweep"])
def test_flags_override_the_model_in_json_output(capsys, fourbar_file, slider_file, command):
    where = ("--at", "200") if command == "solve" else ("--from", "15", "--to", "345", "--step", "55", "-q")
    for path, closed, names in ((fourbar_file, fourbar_closed, FOURBAR_NAMES),
                                (slider_file, slider_closed, SLIDER_NAMES)):
        data = _cli_json(capsys, command, path, *where, *FLAGS, "--format", "json")
        check_rows(data["rows"], closed, names, FLAG_RATES)


def test_each_flag_alone_overrides_only_its_own_rate(capsys, fourbar_file):
    for flag, value, rates in (("--speed", "2rad/s", (2.0, 2.0, -3.0)), ("--accel", "0", (math.pi, 0.0, -3.0)),
                               ("--jerk", "4", (math.pi, 2.0, 4.0)), ("--speed", "60rpm", (2 * math.pi, 2.0, -3.0))):
        data = _cli_json(capsys, "sweep", fourbar_file, "--from", "40", "--to", "340", "--step", "100", "-q",
                         flag, value, "--format", "json")
        check_rows(data["rows"], fourbar_closed, FOURBAR_NAMES, rates)


@pytest.fixture
def captured(monkeypatch):
    """Replace the picture writers by recorders of the sweep the command built."""
    got = {}

    def plot_sweep(sweep, vars=None, *, output=None):
        got["sweep"], got["vars"] = sweep, vars

    def animate(sweep, *, output, fps=20, progress=None, **kwargs):
        got["sweep"] = sweep

    monkeypatch.setattr(plotting, "plot_sweep", plot_sweep)
    monkeypatch.setattr(plotting, "animate", animate)
    monkeypatch.setattr(plotting, "check_output", lambda *a, **k: None)
    return got


@pytest.mark.parametrize("command", ["plot", "animate"])
def test_plot_and_animate_sweep_with_the_flags(command, captured, tmp_path, fourbar_file, capsys):
    out = tmp_path / ("p.png" if command == "plot" else "a.gif")
    extra = ("--vars", "theta4") if command == "plot" else ()
    status = main([command, str(fourbar_file), "--from", "20", "--to", "320", "--step", "60", "-q", *FLAGS,
                   *extra, "-o", str(out)])
    assert status == 0, capsys.readouterr().err
    check_rows(captured["sweep"].rows, fourbar_closed, FOURBAR_NAMES, FLAG_RATES)


@pytest.mark.parametrize("command", ["plot", "animate"])
def test_plot_and_animate_default_range_sweep_uses_the_declared_rates(command, captured, tmp_path, fourbar_file,
                                                                     capsys):
    out = tmp_path / ("p.png" if command == "plot" else "a.gif")
    status = main([command, str(fourbar_file), "--step", "45", "-q", "-o", str(out)])
    assert status == 0, capsys.readouterr().err
    rows = captured["sweep"].rows
    assert len(rows) >= 8  # a crank: the default range is a full turn
    check_rows(rows, fourbar_closed, FOURBAR_NAMES, DECLARED_RATES)


def test_plotted_acceleration_is_the_chain_rule(tmp_path, fourbar_file):
    """The data drawn by ``plot --vars theta4_acc`` (read back from the figure) obey the chain rule."""
    import matplotlib

    matplotlib.use("Agg")
    sweep = ls.load(fourbar_file).sweep(20, 320, 60, speed=3, accel=-1.5, jerk=7, progress=False)
    fig = plotting.plot_sweep(sweep, ["theta4"])
    try:
        ys = [line.get_ydata() for ax in fig.axes for line in ax.get_lines() if len(line.get_ydata()) == len(sweep)]
    finally:
        import matplotlib.pyplot as plt

        plt.close(fig)
    acc = np.array([expected_rates(fourbar_closed, math.radians(r["theta2"]),
                                   branch_of(fourbar_closed, math.radians(r["theta2"]), r, "theta4"),
                                   "theta4", *FLAG_RATES)[1] for r in sweep.rows])
    assert any(np.allclose(y, acc, rtol=1e-6, atol=1e-6) for y in ys), "no plotted curve is theta4's acceleration"


# ----------------------------------------------------------------------------- Python arguments


@pytest.mark.parametrize("kind", ["fourbar", "slider"])
def test_python_arguments_override_the_model(kind, fourbar_file, slider_file):
    path, closed, names = ((fourbar_file, fourbar_closed, FOURBAR_NAMES) if kind == "fourbar"
                           else (slider_file, slider_closed, SLIDER_NAMES))
    mech = ls.load(path)
    for speed, accel, jerk, rates in ((3, -1.5, 7, FLAG_RATES), ("120rpm", "1rad/s^2", 0, (4 * math.pi, 1.0, 0.0)),
                                      (None, None, 2.5, (math.pi, 2.0, 2.5))):
        check_row(mech.solve(77, speed=speed, accel=accel, jerk=jerk).row(), closed, names, *rates)
        check_rows(mech.sweep(5, 365, 60, speed=speed, accel=accel, jerk=jerk, progress=False).rows, closed,
                   names, rates)


def test_without_any_rates_the_outputs_are_the_kinematic_coefficients(tmp_path):
    path = tmp_path / "plain.toml"
    path.write_text(FOURBAR.format(rates=""))
    mech = ls.load(path)
    check_rows(mech.sweep(0, 300, 75, progress=False).rows, fourbar_closed, FOURBAR_NAMES, (1.0, 0.0, 0.0))
    for method in ("tracked", "batched"):
        check_rows(mech.sweep(0, 350, 10, accel=0.5, jerk=-2, progress=False, method=method).rows,
                   fourbar_closed, FOURBAR_NAMES, (1.0, 0.5, -2.0))
