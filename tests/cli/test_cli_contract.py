"""The command line contract of DESIGN.md: ``loopsolve solve`` formats, exit codes, one-line errors.

Most cases call :func:`loopsolve.cli.main` in-process (fast); a representative set runs the real
``python -m loopsolve.cli`` in a subprocess to check exit statuses and stderr end to end.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import shutil
import subprocess
import sys

import pytest

import loopsolve as ls
from loopsolve.cli import main

from support.modelfiles import BAD, edit, INJECTIONS


MODELS = sorted(ls.models_dir().glob("*.toml"))
SUFFIXES = ("", "_vel", "_acc", "_jerk")


def run(*args, env_extra=None):
    """Run the real command line in a subprocess."""
    env = dict(os.environ)
    env.update(env_extra or {})
    env.pop("LOOPSOLVE_DEBUG", None)
    return subprocess.run([sys.executable, "-m", "loopsolve.cli", *map(str, args)], capture_output=True,
                          text=True, env=env)


def call(capsys, *args):
    """Run :func:`main` in-process; returns (status, stdout, stderr)."""
    status = main([str(a) for a in args])
    out = capsys.readouterr()
    return status, out.out, out.err


# ----------------------------------------------------------------------------- solve: every model, every format


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_solve_json_contract_on_every_model(capsys, path):
    status, out, err = call(capsys, "solve", path, "--format", "json")
    assert status == 0, err
    _check_contract(path, json.loads(out))


@pytest.mark.parametrize("launcher", ["module", "script"])
def test_solve_json_in_a_subprocess(launcher):
    """The real entry points: ``python -m loopsolve.cli`` and the ``loopsolve`` console script."""
    path = ls.models_dir() / "quick_return.toml"
    if launcher == "module":
        proc = run("solve", path, "--format", "json")
    else:
        exe = shutil.which("loopsolve")
        assert exe, "the loopsolve console script is installed with the package (pip install -e .)"
        proc = subprocess.run([exe, "solve", str(path), "--format", "json"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    doc = json.loads(proc.stdout)
    _check_contract(path, doc)
    assert "acceleration_components" in doc  # the sliding block's Coriolis split travels with the JSON


def _check_contract(path, doc):
    assert {"mechanism", "input", "units", "rows", "events"} <= set(doc)
    mech = ls.load(path)
    ck = mech.compile()
    assert doc["mechanism"] == mech.name
    assert doc["input"] == mech.inputs[0]
    assert doc["events"] == []
    assert len(doc["rows"]) == 1
    row = doc["rows"][0]
    assert next(iter(row)) == doc["input"]  # the input comes first
    for q in (doc["input"],) + ck.unknowns:
        for s in SUFFIXES:
            assert isinstance(row[q + s], float), q + s
            assert doc["units"][q + s]
    for p in ck.points:
        for c in "xy":
            for s in SUFFIXES:
                assert isinstance(row[f"{p}_{c}{s}"], float)
                assert doc["units"][f"{p}_{c}{s}"]
    # the numbers are the library's
    state = mech.solve()
    for key, value in state.row().items():
        assert row[key] == pytest.approx(value, rel=1e-12, abs=1e-12)


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_solve_table_and_csv_on_every_model(capsys, path):
    mech = ls.load(path)
    units = mech.units
    status, out, err = call(capsys, "solve", path)
    assert status == 0 and err == ""
    assert f"position [{units.angle}]" in out and "velocity [rad/s]" in out and "acceleration [rad/s^2]" in out
    for name in mech.compile().unknowns:
        assert name in out
    status, out, err = call(capsys, "solve", path, "--format", "csv")
    assert status == 0
    rows = list(csv.reader(io.StringIO(out)))
    assert len(rows) == 2
    header = rows[0]
    assert header[0] == f"{mech.inputs[0]} [{units.angle if mech.variable(mech.inputs[0]).kind.name == 'ANGLE' else units.length}]"
    assert all(h.endswith("]") and " [" in h for h in header)
    assert all(math.isfinite(float(v)) for v in rows[1])


def test_units_in_headers(capsys):
    path = ls.models_dir() / "prob2_offset_slider_crank.toml"
    _, out, _ = call(capsys, "solve", path, "--format", "csv")
    header = next(csv.reader(io.StringIO(out)))
    for col in ("theta2 [deg]", "theta3_vel [rad/s]", "theta3_acc [rad/s^2]", "theta3_jerk [rad/s^3]",
                "x [mm]", "x_vel [mm/s]", "x_acc [mm/s^2]", "B_x [mm]", "B_y_jerk [mm/s^3]"):
        assert col in header
    _, out, _ = call(capsys, "solve", path)
    for label in ("position [deg]", "velocity [rad/s]", "position [mm]", "velocity [mm/s]", "x [mm]", "a_x [mm/s^2]"):
        assert label in out
    _, out, _ = call(capsys, "solve", path, "--format", "json")
    units = json.loads(out)["units"]
    assert units["length"] == "mm" and units["angle"] == "deg"
    assert units["x_acc"] == "mm/s^2" and units["theta3_jerk"] == "rad/s^3"


def test_sweep_table_title_counts_rows(capsys):
    # a one-row sweep said "(1 rows, ...)"
    path = ls.models_dir() / "thesis_crank_rocker.toml"
    for to, title in (("0", "(1 row, mode - (open))"), ("30", "(2 rows, mode - (open))")):
        _, out, _ = call(capsys, "sweep", path, "--from", "0", "--to", to, "--step", "30")
        assert out.splitlines()[0] == f"Crank-rocker four-bar: sweep of theta2 {title}"


def test_solve_options(capsys):
    path = ls.models_dir() / "thesis_crank_rocker.toml"
    _, out, _ = call(capsys, "solve", path, "--at", "1.2rad", "--speed", "2rad/s", "--accel", "0.5", "--format", "json")
    row = json.loads(out)["rows"][0]
    assert row["theta2"] == pytest.approx(math.degrees(1.2))
    assert (row["theta2_vel"], row["theta2_acc"]) == (2.0, 0.5)
    s = ls.load(path).solve("1.2rad", speed=2.0, accel=0.5)
    assert row["theta4_acc"] == pytest.approx(s["theta4_acc"], rel=1e-12)
    _, out, _ = call(capsys, "solve", path, "--at", "30", "--speed", "10rpm", "--format", "json")
    assert json.loads(out)["rows"][0]["theta2_vel"] == pytest.approx(2 * math.pi / 6)


def test_input_switch_inversion(capsys):
    """--input r1 drives Example #1 by the slider position (the notes' case ii)."""
    path = ls.models_dir() / "example1_slider_crank.toml"
    r1 = 5 / math.sqrt(2) + math.sqrt(64 - 12.5)
    proc = run("solve", path, "--input", "r1", "--at", repr(r1), "--speed", "1", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(proc.stdout)
    assert doc["input"] == "r1"
    row = doc["rows"][0]
    assert row["theta2"] == pytest.approx(45.0, abs=1e-9)
    assert list(row)[:4] == ["r1", "r1_vel", "r1_acc", "r1_jerk"]
    assert doc["units"]["r1"] == "in" and doc["units"]["theta2_vel"] == "rad/s"


def test_sweep_json_has_rows_for_every_step(capsys):
    path = ls.models_dir() / "thesis_crank_rocker.toml"
    status, out, _ = call(capsys, "sweep", path, "--from", "0", "--to", "360", "--step", "30", "--format", "json", "-q")
    assert status == 0
    doc = json.loads(out)
    assert [r["theta2"] for r in doc["rows"]] == pytest.approx(list(range(0, 361, 30)))


# ----------------------------------------------------------------------------- errors


def _one_line(err: str) -> str:
    lines = err.strip("\n").split("\n")
    assert len(lines) == 1, err
    assert lines[0].startswith("loopsolve: ")
    return lines[0]


@pytest.mark.parametrize("case_id, text, error, fragments", BAD, ids=[b[0] for b in BAD])
def test_bad_models_exit_2_with_one_line_and_run_nothing(capsys, monkeypatch, tmp_path, case_id, text, error,
                                                          fragments):
    cache = tmp_path / "cache"
    monkeypatch.setenv("LOOPSOLVE_CACHE_DIR", str(cache))
    path = tmp_path / f"{case_id}.toml"
    path.write_text(text)
    for cmd in (["solve", path], ["info", path], ["sweep", path, "--from", "0", "--to", "30", "--step", "10", "-q"]):
        status, out, err = call(capsys, *cmd)
        assert status == 2
        assert out == ""
        line = _one_line(err)
        assert str(path) in line
        assert fragments[0] in line
    assert not cache.exists() or not any(cache.iterdir())  # nothing was derived or compiled


@pytest.mark.parametrize("case_id", ["two-inputs", "duplicate-toml-key"])
def test_bad_models_exit_2_in_a_subprocess(tmp_path, case_id):
    text = {b[0]: b[1] for b in BAD}[case_id]
    path = tmp_path / f"{case_id}.toml"
    path.write_text(text)
    proc = run("solve", path, env_extra={"LOOPSOLVE_CACHE_DIR": str(tmp_path / "cache")})
    assert proc.returncode == 2
    assert proc.stdout == ""
    line = _one_line(proc.stderr)
    assert "ModelFileError" in line and str(path) in line
    assert "Traceback" not in proc.stderr


def test_injection_through_the_cli_runs_nothing(tmp_path, capsys):
    marker = tmp_path / "pwned"
    path = tmp_path / "evil.toml"
    payload = INJECTIONS[0].replace("%s", str(marker))
    path.write_text(edit(('length = "r3"', f'length = "{payload}"')))
    proc = run("solve", path)
    assert proc.returncode == 2, proc.stderr
    assert proc.stdout == "" and "vectors.r3.length" in _one_line(proc.stderr)
    for cmd in ("info", "latex", "modes"):
        status = main([cmd, str(path)])
        assert status == 2
    assert not marker.exists()


def test_not_assemblable_exits_3(tmp_path):
    """A non-Grashof double-rocker at a crank angle it cannot reach: exit 3, cause named."""
    mech = ls.fourbar(4, 3, 3.5, 5, theta2=180, name="triple rocker")
    path = tmp_path / "rocker.toml"
    path.write_text(ls.dumps(mech))
    proc = run("solve", path, "--at", "0")
    assert proc.returncode == 3
    assert proc.stdout == ""
    line = _one_line(proc.stderr)
    assert "AssemblyError" in line and "cannot be assembled" in line and "theta2 = 0" in line
    assert main(["solve", str(path), "--at", "180", "--format", "json"]) == 0


def test_singular_position_exits_3(tmp_path, capsys):
    """At a toggle of the same rocker the position exists but the rates do not: exit 3."""
    from loopsolve.kinematics import classic

    mech = ls.fourbar(4, 3, 3.5, 5, theta2=180, name="triple rocker")
    path = tmp_path / "rocker.toml"
    path.write_text(ls.dumps(mech))
    (lo, _), = classic.fourbar_input_range(4, 3, 3.5, 5)
    status, out, err = call(capsys, "solve", path, "--at", repr(math.degrees(lo)))
    assert status == 3 and out == ""
    assert "SingularPositionError" in _one_line(err)


@pytest.mark.parametrize("args, fragment", [
    (["solve"], "the following arguments are required"),
    (["solve", "MODEL", "--format", "xml"], "invalid choice"),
    (["frobnicate"], "invalid choice"),
    (["solve", "MODEL", "--at", "abc"], "abc"),
    (["solve", "MODEL", "--input", "nope"], "nope"),
    (["solve", "MODEL", "--speed", "10mm/s"], "10mm/s"),
])
def test_usage_errors_exit_2(capsys, args, fragment):
    path = ls.models_dir() / "thesis_crank_rocker.toml"
    argv = [str(path) if a == "MODEL" else a for a in args]
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse errors leave through SystemExit
        status = exc.code
    out = capsys.readouterr()
    assert status == 2
    assert out.out == ""
    assert fragment in _one_line(out.err)


def test_usage_error_in_a_subprocess():
    proc = run("solve", ls.models_dir() / "thesis_crank_rocker.toml", "--format", "xml")
    assert proc.returncode == 2 and proc.stdout == ""
    assert "invalid choice" in _one_line(proc.stderr)


def test_missing_model_file_exits_2(tmp_path, capsys):
    status, out, err = call(capsys, "solve", tmp_path / "absent.toml")
    assert status == 2 and out == ""
    assert "no such model file" in _one_line(err)
