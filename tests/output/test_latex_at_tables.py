"""The LaTeX document's numeric tables at one input (``loopsolve latex MODEL --at X``) say what ``solve`` says.

Read from the written ``.tex`` (its ``tabular`` rows and the sentence before them) and compared with
``loopsolve solve MODEL --at X --format json`` run as a user would, for every shipped model with
one input and for a model in radians:

* the kinematics table ("Numeric solution"): every variable's and point coordinate's position,
  velocity, acceleration and jerk, each with the unit ``solve`` gives it (an angle in degrees with
  a degree sign, in radians with "rad");
* the dynamics table ("Equation of motion at the given input", models with ``[bodies]``): the
  kinematic coefficients q′ = dq/dx and q″ = d²q/dx² of every unknown, which are ``solve``'s
  velocity and acceleration at an input speed of 1 rad/s and no input acceleration, and the
  input value the sentence above the table names, in the model's angle unit.
"""

from __future__ import annotations

import json
import math
import re

import pytest

import loopsolve as ls
from loopsolve.cli import main

MODELS = [p for p in sorted(ls.models_dir().glob("*.toml")) if len(ls.load(p).inputs) == 1]
DYNAMIC = [p for p in MODELS if ls.load(p).dynamics is not None and ls.load(p).dynamics.bodies]

_NUMBER = re.compile(r"^(-?[0-9.]+(?:e[-+]?\d+)?)(?: \\times 10\^\{(-?\d+)\})?")


def number_and_unit(cell: str):
    """``-1.37873 \\times 10^{-5}\\,\\mathrm{kg}`` → (-1.37873e-5, "kg"); ``60^{\\circ}`` → (60.0, "deg")."""
    cell = cell.strip().strip("$").strip()
    if cell.startswith(r"\text{--}"):
        return None, cell[len(r"\text{--}"):]
    m = _NUMBER.match(cell)
    assert m, cell
    value = float(m.group(1)) * (10.0 ** int(m.group(2)) if m.group(2) else 1.0)
    rest = cell[m.end():]
    if rest == r"^{\circ}":
        unit = "deg"
    elif rest.startswith(r"\,\mathrm{") and rest.endswith("}"):
        unit = re.sub(r"\^\{(\d)\}", r"^\1", rest[len(r"\,\mathrm{"):-1])
    else:
        assert rest == "", cell
        unit = ""
    return value, unit


def tables(tex: str) -> list[tuple[list[str], list[list[str]]]]:
    """Every ``tabular`` of the document: (header cells, rows of cells)."""
    out = []
    for body in re.findall(r"\\begin\{tabular\}\{[^}]*\}\n(.*?)\\end\{tabular\}", tex, re.S):
        lines = [ln.strip() for ln in body.splitlines() if ln.strip() and ln.strip() != r"\hline"]
        cells = [[c.strip() for c in ln.rstrip("\\").strip().split("&")] for ln in lines]
        out.append((cells[0], cells[1:]))
    return out


def solve_json(capsys, path, at, *extra):
    assert main(["solve", str(path), "--at", str(at), "--format", "json", *extra]) == 0
    data = json.loads(capsys.readouterr().out)
    return data["rows"][0], data["units"]


def latex_text(capsys, path, at, tmp_path) -> str:
    out = tmp_path / "doc.tex"
    assert main(["latex", str(path), "--at", str(at), "-o", str(out)]) == 0
    capsys.readouterr()
    return out.read_text(encoding="utf-8")


def close(got, want, scale) -> bool:
    """Six significant digits as printed; round-off (1e-11 of the row's size) printed as 0."""
    if want is None or not math.isfinite(want):
        return got is None
    return got is not None and abs(got - want) <= 6e-6 * abs(want) + 1e-10 * scale


def radian_model(tmp_path):
    """The thesis crank-rocker with bodies, written in radians (guesses and the angle unit)."""
    text = (ls.models_dir() / "thesis_crank_rocker_dynamics.toml").read_text()
    for old, new in (('angle = "deg"', 'angle = "rad"'), ("guess = 90,", "guess = 1.5707963267948966,"),
                     ("guess = 20 }", "guess = 0.3490658503988659 }"), ("guess = 80 }", "guess = 1.3962634015954636 }")):
        assert text.count(old) == 1, old
        text = text.replace(old, new)
    path = tmp_path / "rad.toml"
    path.write_text(text)
    return path


def _at_value(path) -> str:
    """An input value away from the guess where the linkage assembles (not the model's drawn pose)."""
    mech = ls.load(path)
    guess = mech.solve().input_value
    step = 17.0 if mech.units.angle == "deg" else 0.3
    for at in (guess + step, guess - step, guess + step / 4, guess - step / 4):
        try:
            mech.solve(round(at, 6))
        except ls.SolveError:
            continue
        return repr(round(at, 6))
    return repr(guess)


@pytest.mark.parametrize("path", MODELS + ["radians"], ids=lambda p: p if isinstance(p, str) else p.stem)
def test_kinematics_table_is_the_solve(path, tmp_path, capsys):
    path = radian_model(tmp_path) if path == "radians" else path
    at = _at_value(path)
    row, units = solve_json(capsys, path, at)
    tex = latex_text(capsys, path, at, tmp_path)
    [(header, rows)] = [t for t in tables(tex) if "Position" in " ".join(t[0])]
    assert header[1:] == [r"\textbf{Position}", r"\textbf{Velocity}", r"\textbf{Acceleration}", r"\textbf{Jerk}"]
    ck = ls.load(path).compile()
    names = list(ck.inputs) + list(ck.unknowns) + [f"{p}_{c}" for p in ck.points for c in "xy"]
    assert len(rows) == len(names)
    for name, cells in zip(names, rows):
        scale = max([abs(row[name + s]) for s in ("", "_vel", "_acc", "_jerk") if row[name + s] is not None]
                    + [ck.scale])
        for cell, suffix in zip(cells[1:], ("", "_vel", "_acc", "_jerk")):
            value, unit = number_and_unit(cell)
            assert unit == units[name + suffix], (name + suffix, cell, units[name + suffix])
            assert close(value, row[name + suffix], scale), (name + suffix, cell, row[name + suffix])
    # the sentence above the table: the input, its speed and acceleration as solve has them
    inp = ck.inputs[0]
    sentence = tex[tex.index(r"At $"):tex.index("Assembly mode")]
    printed = [number_and_unit(c.split(" = ", 1)[1]) for c in re.findall(r"\$([^$]*)\$", sentence)]
    for (value, unit), suffix in zip(printed, ("", "_vel", "_acc")):
        assert unit == units[inp + suffix] and close(value, row[inp + suffix], max(1.0, abs(row[inp + suffix])))


@pytest.mark.parametrize("path", DYNAMIC + ["radians"], ids=lambda p: p if isinstance(p, str) else p.stem)
def test_equation_of_motion_table_is_the_solve(path, tmp_path, capsys):
    path = radian_model(tmp_path) if path == "radians" else path
    mech = ls.load(path)
    ck = mech.compile()
    at = _at_value(path)
    tex = latex_text(capsys, path, at, tmp_path)
    # q' and q'': the rates at a unit input speed with no input acceleration
    rates, units = solve_json(capsys, path, at, "--speed", "1rad/s", "--accel", "0rad/s^2")
    [(header, rows)] = [t for t in tables(tex) if "q'" in " ".join(t[0])]
    assert header[1:] == [r"\textbf{$q'$}", r"\textbf{$q''$}"]
    assert len(rows) == len(ck.unknowns)
    length = mech.units.length
    for name, cells in zip(ck.unknowns, rows):
        d1, u1 = number_and_unit(cells[1])
        d2, u2 = number_and_unit(cells[2])
        vel, acc = rates[name + "_vel"], rates[name + "_acc"]
        assert close(d1, vel, ck.scale) and close(d2, acc, ck.scale), (name, cells, vel, acc)
        angular = units[name] in ("deg", "rad")
        assert (u1, u2) == (("", "") if angular else (f"{length}/rad", f"{length}/rad^2")), (name, cells)
    # "At θ = … with θ̇ = … and θ̈ = … (SI)": the input in the model's angle unit, the model's own speed
    row, units = solve_json(capsys, path, at)
    inp = ck.inputs[0]
    sentence = tex[tex.index("Equation of motion at the given input"):]
    sentence = sentence[sentence.index("At $"):sentence.index("(SI)")]
    (value, unit), (speed, speed_unit), (accel, _) = [number_and_unit(c.split(" = ", 1)[1])
                                                      for c in re.findall(r"\$([^$]*)\$", sentence)]
    assert unit == mech.units.angle and close(value, float(at), 1.0), (sentence, at)
    assert speed_unit == "rad/s" and close(speed, row[inp + "_vel"], 1.0) and close(accel, row[inp + "_acc"], 1.0)
