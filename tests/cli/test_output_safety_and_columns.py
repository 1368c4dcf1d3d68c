"""Outputs keep data safe and say what they mean (issue 9: critical 6, outputs, CLI messages; issue 13).

* ``-o`` never replaces an input (also through a symlink or a hard link), and a failed write
  (missing directory, directory, read-only place, full disk, size limit) is exit 2 with one line
  and leaves the model and any old output intact.
* CSV and text-table columns are checked by value, column by column, against the State/Sweep
  values and units, and against a four-bar closed form written here (a swapped velocity and
  acceleration column is caught).
* Tables print 0 for round-off noise and inputs in fixed notation; rows through limits state
  their own mode; long CSV/JSON is streamed; names with control characters round-trip through
  TOML; warnings and unexpected errors are one line each.
"""

from __future__ import annotations

import csv
import hashlib
import importlib
import io
import json
import math
import os
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import export
from loopsolve.cli import main
from support.models import fourbar_open_angles

THESIS = ls.models_dir() / "thesis_crank_rocker.toml"
DOUBLE_ROCKER = ls.models_dir() / "double_rocker.toml"
R1, R2, R3, R4 = 60.0, 25.0, 70.0, 45.0
OMEGA = 10 * 2 * math.pi / 60  # the model's 10 rpm


def call(capsys, *args):
    status = main([str(a) for a in args])
    out = capsys.readouterr()
    return status, out.out, out.err


def digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def model(tmp_path):
    p = tmp_path / "m.toml"
    p.write_bytes(THESIS.read_bytes())
    return p


# ----------------------------------------------------------------------------- -o never destroys data

WRITERS = [
    ["solve", "{m}", "--at", "90", "-o", "{o}"],
    ["solve", "{m}", "--at", "90", "--format", "json", "-o", "{o}"],
    ["sweep", "{m}", "--from", "0", "--to", "90", "--step", "30", "-q", "-o", "{o}"],
    ["sweep", "{m}", "--from", "0", "--to", "90", "--step", "30", "-q", "--format", "csv", "-o", "{o}"],
    ["latex", "{m}", "-o", "{o}"],
    ["latex", "{m}", "--pdf", "-o", "{o}"],
    ["vectors", "{m}", "-o", "{o}"],
    ["plot", "{m}", "--from", "0", "--to", "90", "--step", "30", "-q", "-o", "{o}.png"],
    ["draw", "{m}", "--at", "90", "-o", "{o}.svg"],
    ["animate", "{m}", "--from", "0", "--to", "90", "--step", "30", "-q", "-o", "{o}.gif"],
]


def argv(template, m, o):
    return [a.format(m=m, o=o) for a in template]


@pytest.mark.parametrize("how", ["same", "symlink", "hardlink", "dotted"])
@pytest.mark.parametrize("template", WRITERS[:7], ids=lambda t: "-".join(t[:1] + [t[-3]]))
def test_output_onto_the_model_is_refused(capsys, model, tmp_path, how, template):
    before = digest(model)
    target = {"same": model, "dotted": tmp_path / "." / "m.toml"}.get(how)
    if how == "symlink":
        target = tmp_path / "link.toml"
        target.symlink_to(model)
    elif how == "hardlink":
        target = tmp_path / "hard.toml"
        os.link(model, target)
    status, out, err = call(capsys, *argv(template, model, target))
    assert status == 2
    assert len(err.splitlines()) == 1 and "input file" in err, err
    assert digest(model) == before


@pytest.mark.parametrize("template", WRITERS[7:], ids=lambda t: t[0])
def test_picture_onto_the_model_is_refused(capsys, tmp_path, template):
    pytest.importorskip("matplotlib")
    model = tmp_path / "m.toml"
    model.write_bytes(THESIS.read_bytes())
    link = tmp_path / "pic"
    suffix = template[-1].split("}")[-1]
    os.symlink(model, str(link) + suffix)
    status, out, err = call(capsys, *argv(template, model, link))
    assert status == 2 and "input file" in err and len(err.splitlines()) == 1, err
    assert model.read_bytes() == THESIS.read_bytes()


@pytest.mark.parametrize("where", ["missing-dir", "directory", "empty"])
def test_unwritable_targets_are_one_line_exit_2(capsys, model, tmp_path, where):
    target = {"missing-dir": tmp_path / "no" / "such" / "out.csv", "directory": tmp_path, "empty": ""}[where]
    status, out, err = call(capsys, "solve", model, "--at", "90", "-o", target)
    assert status == 2 and len(err.splitlines()) == 1, err
    assert "Traceback" not in err


@pytest.mark.parametrize("template", WRITERS, ids=lambda t: "-".join(t[:1] + t[-1:]))
def test_every_writer_writes_atomically(capsys, model, tmp_path, template):
    """A good write replaces the old file and leaves no temporary file behind."""
    if template[0] in ("plot", "draw", "animate"):
        pytest.importorskip("matplotlib")
    if "--pdf" in template:
        import shutil

        if not (shutil.which("pdflatex") or shutil.which("latexmk")):
            pytest.skip("no pdflatex/latexmk installed: --pdf cannot run")
    out = tmp_path / "out"
    args = argv(template, model, out)
    target = tmp_path / os.path.basename(args[-1])
    target.write_text("old\n", encoding="utf-8")
    status, _, err = call(capsys, *args)
    assert status == 0, err
    assert target.read_bytes() != b"old\n" and target.stat().st_size > 0
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["m.toml", target.name])


def test_full_disk_keeps_the_old_output_and_the_model(capsys, tiny_fs, filler):
    """The model and the old output are written first; then the disk is filled."""
    model = tiny_fs / "m.toml"
    model.write_bytes(THESIS.read_bytes())
    old = tiny_fs / "old.csv"
    old.write_text("theta2 [deg]\n1.0\n", encoding="utf-8")
    filler(tiny_fs)
    status, out, err = call(capsys, "sweep", model, "--from", "0", "--to", "360", "--step", "1", "-q", "--format",
                            "csv", "-o", old)
    assert status == 2, err
    assert len(err.splitlines()) == 1 and "no space left" in err, err
    assert old.read_text(encoding="utf-8") == "theta2 [deg]\n1.0\n"
    assert model.read_bytes() == THESIS.read_bytes()
    assert sorted(p.name for p in tiny_fs.iterdir()) == ["filler", "m.toml", "old.csv"]


def test_read_only_place_is_exit_2(capsys, read_only_fs):
    status, out, err = call(capsys, "solve", THESIS, "--at", "90", "-o", read_only_fs / "out.txt")
    assert status == 2 and len(err.splitlines()) == 1 and "read-only" in err.lower(), err


def test_size_limited_output_keeps_the_old_file(tmp_path):
    """RLIMIT_FSIZE in a subprocess (no root needed): EFBIG is exit 2, the old output stays."""
    old = tmp_path / "out.csv"
    old.write_text("old\n", encoding="utf-8")
    code = (
        "import resource, signal, sys\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "import loopsolve as ls\n"
        f"ls.load({str(THESIS)!r}).compile()\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (4096, 4096))\n"
        "from loopsolve.cli import main\n"
        f"sys.exit(main(['sweep', {str(THESIS)!r}, '--from', '0', '--to', '360', '--step', '1', '-q',"
        f" '--format', 'csv', '-o', {str(old)!r}]))\n"
    )
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    env.pop("LOOPSOLVE_DEBUG", None)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.splitlines()) == 1, proc.stderr
    assert old.read_text(encoding="utf-8") == "old\n"
    assert [p.name for p in tmp_path.iterdir()] == ["out.csv"]


# ----------------------------------------------------------------------------- columns by value


def closed_form(t2):
    """Open-mode θ3, θ4 of the thesis four-bar (circle intersection), radians."""
    return fourbar_open_angles(t2, R1, R2, R3, R4)


def closed_rates(t2_deg):
    """θ3, θ4 (deg) and their time rates at 10 rpm (rad/s, rad/s²) by central differences."""
    h = 1e-4
    t2 = math.radians(t2_deg)
    f = [np.array(closed_form(t2 + k * h)) for k in (-1, 0, 1)]
    pos = np.degrees(f[1])
    d = np.unwrap([f[0], f[1], f[2]], axis=0)
    vel = (d[2] - d[0]) / (2 * h) * OMEGA
    acc = (d[2] - 2 * d[1] + d[0]) / h**2 * OMEGA**2
    return pos, vel, acc


def _csv_table(text):
    rows = list(csv.reader(io.StringIO(text)))
    head = rows[0]
    names = [h.split(" [")[0] for h in head]
    units = {h.split(" [")[0]: h.split(" [")[1].rstrip("]") for h in head if " [" in h}
    return names, units, rows[1:]


def test_csv_columns_by_value_and_unit(capsys):
    status, out, err = call(capsys, "sweep", THESIS, "--from", "0", "--to", "350", "--step", "50", "-q", "--format",
                            "csv")
    assert status == 0, err
    names, units, rows = _csv_table(out)
    sw = ls.load(THESIS).sweep(0, 350, 50, progress=False)
    assert units == sw.units() or all(units[k] == sw.units()[k] for k in units)
    assert units["theta3_vel"] == "rad/s" and units["theta3_acc"] == "rad/s^2" and units["C_x_vel"] == "mm/s"
    assert len(rows) == len(sw) == 8
    for j, name in enumerate(names):
        col = np.array([float(r[j]) for r in rows])
        np.testing.assert_allclose(col, sw[name], rtol=1e-14, atol=1e-12, err_msg=name)
    for i, r in enumerate(rows):
        t2 = float(r[names.index("theta2")])
        pos, vel, acc = closed_rates(t2)
        got = {n: float(r[names.index(n)]) for n in ("theta3", "theta4", "theta3_vel", "theta4_vel", "theta3_acc",
                                                      "theta4_acc")}
        assert got["theta3"] == pytest.approx(pos[0], abs=1e-9)
        assert got["theta4"] == pytest.approx(pos[1], abs=1e-9)
        assert got["theta3_vel"] == pytest.approx(vel[0], abs=1e-6)
        assert got["theta4_vel"] == pytest.approx(vel[1], abs=1e-6)
        assert got["theta3_acc"] == pytest.approx(acc[0], abs=1e-4)
        assert got["theta4_acc"] == pytest.approx(acc[1], abs=1e-4)


def test_csv_of_a_state_matches_the_state(capsys):
    status, out, err = call(capsys, "solve", THESIS, "--at", "130", "--format", "csv")
    names, units, rows = _csv_table(out)
    state = ls.load(THESIS).solve(130)
    assert units == state.units()
    for j, name in enumerate(names):
        assert float(rows[0][j]) == pytest.approx(state[name], rel=1e-14, abs=1e-12), name
    pos, vel, acc = closed_rates(130)
    assert state["theta4_vel"] == pytest.approx(vel[1], abs=1e-6)
    assert state["theta4_acc"] == pytest.approx(acc[1], abs=1e-4)


def _parse_table(text):
    lines = text.splitlines()
    head = lines[1]
    cells = [c for c in head.split("  ") if c.strip()]
    names = [c.strip().split(" [")[0] for c in cells]
    units = [c.strip().split(" [")[1].rstrip("]") for c in cells]
    rows = [ln.split() for ln in lines[3:] if ln.strip() and ln[0] in "-0123456789"]
    return names, units, rows


def test_sweep_table_columns_by_value_and_unit(capsys):
    status, out, err = call(capsys, "sweep", THESIS, "--from", "10", "--to", "340", "--step", "55", "-q")
    names, units, rows = _parse_table(out)
    sw = ls.load(THESIS).sweep(10, 340, 55, progress=False)
    assert names == ["theta2", "theta3", "theta3_vel", "theta3_acc", "theta4", "theta4_vel", "theta4_acc"]
    assert units == [sw.units()[n] for n in names]
    assert len(rows) == len(sw)
    for j, name in enumerate(names):
        np.testing.assert_allclose([float(r[j]) for r in rows], sw[name], rtol=5e-6, atol=1e-9, err_msg=name)
    for r in rows:
        pos, vel, acc = closed_rates(float(r[0]))
        assert float(r[2]) == pytest.approx(vel[0], rel=1e-5, abs=1e-6)  # theta3_vel, not its acceleration
        assert float(r[3]) == pytest.approx(acc[0], rel=1e-5, abs=1e-4)


def test_table_prints_zero_for_round_off_and_fixed_inputs(capsys):
    status, out, err = call(capsys, "solve", THESIS, "--at", "90")
    body = "\n".join(out.splitlines()[1:])  # the header states the residual, 1.8e-15
    assert "e-15" not in body and "e-16" not in body and "e-17" not in body
    b = next(ln for ln in out.splitlines() if ln.startswith("B "))
    assert b.split()[1] == "0"  # B_x = 25 cos 90° is 1.5e-15 in floating point
    status, out, err = call(capsys, "sweep", THESIS, "--from", "999990", "--to", "1000000", "--step", "5", "-q")
    assert status == 0, err
    inputs = [ln.split()[0] for ln in out.splitlines()[3:] if ln[:1].isdigit()]
    assert inputs == ["999990", "999995", "1000000"]
    assert "e+06" not in out
    assert export.fixed(1e6) == "1000000" and export.fixed(27.4) == "27.4"


def test_rows_through_limits_state_their_mode(capsys):
    mech = ls.load(DOUBLE_ROCKER)
    sw = mech.sweep(60, 180, 10, through_limits=True, progress=False)
    assert len(set(sw.modes)) == 2
    assert list(sw["mode"]) == list(sw.modes)
    assert [r["mode"] for r in sw.rows] == list(sw.modes)
    labels = [export.mode_label(mech, m) for m in sw.modes]
    doc = json.loads(export.to_json(sw))
    assert [r["mode"] for r in doc["rows"]] == labels
    args = ["sweep", DOUBLE_ROCKER, "--from", "60", "--to", "180", "--step", "10", "--through-limits", "-q"]
    status, out, err = call(capsys, *args, "--format", "csv")
    names, units, rows = _csv_table(out)
    assert names[-1] == "mode" and [r[-1] for r in rows] == labels
    status, out, err = call(capsys, *args)
    table_rows = [ln for ln in out.splitlines()[3:] if ln[:1].isdigit()]
    assert [ln.split("  ")[-1].strip() for ln in table_rows] == labels
    # one mode: no mode column (the header states it)
    assert "mode" not in mech.sweep(30, 60, 10, progress=False).columns


def test_long_csv_and_json_are_streamed(tmp_path):
    """Memory while writing does not grow with the rows: peak far below the output's size."""
    from loopsolve.model.files import write_text

    ck = ls.load(THESIS).compile()
    n = 6000
    t2 = np.linspace(0, 2 * np.pi, n)
    z = np.column_stack([t2, np.full(n, 0.3), np.full(n, 1.4)])
    sw = ls.Sweep.from_arrays(ck, z, z * 0.1, z * 0.01, z * 0.001, modes=("-",) * n, mode="-")
    def peak_of(sweep, fmt, it):
        out = tmp_path / f"big.{fmt}"
        tracemalloc.start()
        write_text(out, it(sweep))
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        return peak, out.stat().st_size

    third = ls.Sweep.from_arrays(ck, z[: n // 3], z[: n // 3] * 0.1, z[: n // 3] * 0.01, z[: n // 3] * 0.001,
                                 modes=("-",) * (n // 3), mode="-")
    for fmt, it in (("csv", export.iter_csv), ("json", export.iter_json)):
        small, _ = peak_of(third, fmt, it)
        peak, size = peak_of(sw, fmt, it)
        assert size > 2_000_000
        assert peak < size / 2, (fmt, peak, size)
        assert peak < 1.5 * small, (fmt, small, peak)  # three times the rows, about the same memory
    doc = json.loads((tmp_path / "big.json").read_text(encoding="utf-8"))
    assert list(doc) == ["mechanism", "input", "units", "mode", "rows", "events"] and len(doc["rows"]) == n
    assert doc["rows"][-1]["theta2"] == pytest.approx(360.0)
    with open(tmp_path / "big.csv", encoding="utf-8") as f:
        assert sum(1 for _ in f) == n + 1


# ----------------------------------------------------------------------------- names and TOML


@pytest.mark.parametrize("ch", ["\n", "\r", "\x1b", "\x00", "\x7f", '"', "\\", "\t", "\u0085"])
def test_dumps_escapes_control_characters_and_round_trips(ch):
    mech = ls.fourbar(r1=60, r2=25, r3=70, r4=45)
    spec = dict(mech.spec)
    spec["name"] = f"four{ch}bar"
    text = ls.dumps(spec)
    assert all(c == "\n" or c >= " " and c != "\x7f" for c in text)
    import tomllib

    assert tomllib.loads(text)["name"] == f"four{ch}bar"


@pytest.mark.parametrize("where", ["name", "loop", "alias"])
def test_control_characters_in_names_are_refused_at_load(capsys, tmp_path, where):
    text = THESIS.read_text(encoding="utf-8")
    if where == "name":
        text = text.replace('name = "', 'name = "\\u001b[31mred ', 1)
    elif where == "loop":
        text = text.replace("[[loops]]", '[[loops]]\nname = "loop\\r1"', 1)
    else:
        text = text.replace("[modes]", '[modes]\n"op\\u001ben" = "+"', 1)
    p = tmp_path / "m.toml"
    p.write_text(text, encoding="utf-8")
    status, out, err = call(capsys, "solve", p)
    assert status == 2 and "\x1b" not in err and "\r" not in err and len(err.splitlines()) == 1, err
    assert "control character" in err


def test_latex_snippet_comment_has_no_control_characters():
    mech = ls.fourbar(r1=60, r2=25, r3=70, r4=45)
    spec = dict(mech.spec)
    spec["name"] = "four\r\nbar\x1b"
    from loopsolve.model.spec import build_mechanism

    m = build_mechanism(spec)  # Python-built names may hold them (model files refuse them at load)
    tex = m.to_latex(snippet=True)
    first = tex.splitlines()[0]
    assert first.startswith("% loopsolve:") and "\r" not in tex.split("\n")[0] and "\x1b" not in first
    assert tex.splitlines()[1][:1] != "b"  # the name did not spill onto a line of its own


def test_bom_is_accepted(tmp_path):
    p = tmp_path / "m.toml"
    p.write_bytes(b"\xef\xbb\xbf" + THESIS.read_bytes())
    assert ls.load(p).solve(90)["theta4"] == pytest.approx(math.degrees(closed_form(math.pi / 2)[1]), abs=1e-9)


# ----------------------------------------------------------------------------- messages


def test_warnings_are_one_line(capsys, tmp_path):
    p = tmp_path / "m.toml"
    p.write_text(THESIS.read_text(encoding="utf-8").replace("theta3 = { guess = 20 }", "theta3 = {}"),
                 encoding="utf-8")
    status, out, err = call(capsys, "solve", p, "--at", "90")
    lines = err.splitlines()
    assert status in (0, 3)
    warn = [ln for ln in lines if "warning" in ln]
    assert warn and all(ln.startswith("loopsolve: warning: ") for ln in warn), lines
    assert not any(ln.startswith(" ") for ln in lines), lines  # no source line


def test_at_values_that_look_like_options(capsys):
    status, out, err = call(capsys, "solve", THESIS, "--at", "-90", "--format", "json")
    assert status == 0 and json.loads(out)["rows"][0]["theta2"] == -90
    status, out, err = call(capsys, "solve", THESIS, "--at=-90", "--format", "json")
    assert status == 0 and json.loads(out)["rows"][0]["theta2"] == -90
    status, out, err = call(capsys, "solve", THESIS, "--at=--")
    assert status == 2 and "list" not in err and "'--'" in err and len(err.splitlines()) == 1, err
    with pytest.raises(SystemExit) as exc:
        main(["solve", str(THESIS), "--at", "--"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1 and "--at" in err


@pytest.mark.parametrize("exc,code", [(MemoryError(), 2), (RecursionError("deep"), 2),
                                      (OverflowError("math range error"), 3), (TypeError("bad"), 3),
                                      (KeyError("x"), 3), (PermissionError(13, "Permission denied", "f"), 2)])
def test_unexpected_exceptions_end_as_one_line(capsys, monkeypatch, exc, code):
    solve_mod = importlib.import_module("loopsolve.kinematics.solve")  # the module (ls.solve is the function)

    def boom(*a, **k):
        raise exc

    monkeypatch.delenv("LOOPSOLVE_DEBUG", raising=False)
    monkeypatch.setattr(solve_mod, "solve", boom)
    status, out, err = call(capsys, "solve", THESIS, "--at", "90")
    assert status == code
    assert len(err.splitlines()) == 1 and err.startswith("loopsolve: ") and "Traceback" not in err, err


def test_debug_keeps_the_traceback(monkeypatch):
    solve_mod = importlib.import_module("loopsolve.kinematics.solve")  # the module (ls.solve is the function)

    monkeypatch.setenv("LOOPSOLVE_DEBUG", "1")
    monkeypatch.setattr(solve_mod, "solve", lambda *a, **k: (_ for _ in ()).throw(TypeError("bad")))
    with pytest.raises(TypeError):
        main(["solve", str(THESIS)])


def test_closed_form_self_check():
    """The test's closed form closes the loop (independent of loopsolve)."""
    t3, t4 = closed_form(1.0)
    x = R2 * math.cos(1.0) + R3 * math.cos(t3) - R1 - R4 * math.cos(t4)
    y = R2 * math.sin(1.0) + R3 * math.sin(t3) - R4 * math.sin(t4)
    assert abs(x) < 1e-9 and abs(y) < 1e-9


def test_numpy_and_multi_line_warnings_are_one_line_each(capsys, monkeypatch):
    """A RuntimeWarning from generated code or numpy prints no source line (``c5 = v_0**3``)."""
    import warnings

    import numpy as np

    solve_mod = importlib.import_module("loopsolve.kinematics.solve")  # the module (ls.solve is the function)

    real = solve_mod.solve

    def noisy(*a, **k):
        with np.errstate(over="warn"):
            np.float64(1e308) * np.float64(10)
        warnings.warn("first line\n  second line", ls.LoopsolveWarning)
        return real(*a, **k)

    monkeypatch.setattr(solve_mod, "solve", noisy)
    status, out, err = call(capsys, "solve", THESIS, "--at", "90")
    assert status == 0
    lines = err.splitlines()
    assert len(lines) == 2, lines
    assert lines[0].startswith("loopsolve: warning: overflow encountered")
    assert lines[1] == "loopsolve: warning: first line; second line"


def test_vectors_of_a_diagram_with_control_characters_round_trips():
    import tomllib

    from loopsolve.model.diagram import to_vector_model

    diagram = tomllib.loads((ls.models_dir() / "thesis_crank_rocker_diagram.toml").read_text(encoding="utf-8"))
    diagram["name"] = "four\x1b[31m\r\nbar\x00\x7f"
    text = to_vector_model(diagram)
    assert not any(c in text for c in "\x1b\r\x00\x7f")
    assert tomllib.loads(text)["name"] == diagram["name"]


def test_a_character_device_is_written_in_place(capsys):
    """``-o /dev/null`` (timing a command) works and leaves the device a device; /dev/full is one line, exit 2."""
    import stat

    from loopsolve.cli import main

    model = str(ls.models_dir() / "thesis_crank_rocker.toml")
    assert main(["sweep", model, "--from", "0", "--to", "90", "--step", "30", "-q", "-o", "/dev/null"]) == 0
    assert stat.S_ISCHR(os.stat("/dev/null").st_mode)
    capsys.readouterr()
    assert main(["solve", model, "--at", "30", "-o", "/dev/full"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.count("cannot write") == 1 and "/dev/full" in err
