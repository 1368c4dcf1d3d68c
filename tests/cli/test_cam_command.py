"""``loopsolve cam``: the report's JSON contract, the profile written and read back, bad cams exit 2."""

import csv
import json
import math
import subprocess
import sys

import numpy as np
import pytest

CAM = """
name = "cam"
units = { length = "mm", angle = "deg" }
[variables]
theta2 = { input = true, guess = 0 }
s = { guess = 0 }
[cams.c1]
cam = "theta2"
follower = "s"
kind = "translating"
contact = "roller"
roller = "ROLLER"
base = "40mm"
offset = "5mm"
law = [ { to = 90, rise = "25mm", curve = "cycloidal" }, { to = 150, dwell = true },
        { to = 270, rise = "-25mm", curve = "harmonic" }, { to = 360, dwell = true } ]
"""


def run(*args):
    return subprocess.run([sys.executable, "-m", "loopsolve", *map(str, args)], capture_output=True, text=True)


@pytest.fixture
def model(tmp_path):
    path = tmp_path / "cam.toml"
    path.write_text(CAM.replace("ROLLER", "8mm"))
    return path


def test_json_contract(model):
    proc = run("cam", model, "c1", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    rep = json.loads(proc.stdout)
    assert rep["cam"] == "c1" and rep["undercut"] is False
    assert set(rep["rows"][0]) == {"angle", "s", "v", "a", "j", "pressure_angle", "curvature_radius"}
    assert len(rep["rows"]) == 360 and rep["rows"][90]["angle"] == pytest.approx(90)
    assert rep["rows"][90]["s"] == pytest.approx(25)
    assert rep["units"]["s"] == "mm" and rep["units"]["pressure_angle"] == "deg"
    phis = [r["pressure_angle"] for r in rep["rows"]]
    assert rep["extremes"]["pressure_angle"] == pytest.approx([min(phis), max(phis)])
    # the harmonic return's acceleration jumps at both of its ends
    assert sorted(d["angle"] for d in rep["discontinuities"]) == pytest.approx([150, 270])


def test_table_with_svaj_rows(model):
    proc = run("cam", model, "c1", "--svaj", "--step", "30")
    assert proc.returncode == 0, proc.stderr
    assert "pressure angle" in proc.stdout and "undercut: no" in proc.stdout
    assert len([ln for ln in proc.stdout.splitlines() if ln.strip() and ln.strip()[0].isdigit()]) == 12


def test_profile_dxf_has_the_layers_of_draw(model, tmp_path):
    ezdxf = pytest.importorskip("ezdxf")
    out = tmp_path / "profile.dxf"
    proc = run("cam", model, "c1", "-o", out)
    assert proc.returncode == 0, proc.stderr
    doc = ezdxf.readfile(out)
    layers = {e.dxf.layer for e in doc.modelspace()}
    assert {"LINKS", "CURVES", "GROUND", "PINS", "SLIDERS"} <= layers
    (profile,) = [e for e in doc.modelspace().query("LWPOLYLINE") if e.dxf.layer == "LINKS"]
    pts = np.array([p[:2] for p in profile.get_points()])
    # at cam angle 0 the roller (radius 8) touches the base circle (40) on the follower's line x = 5
    assert np.linalg.norm(pts, axis=1).min() == pytest.approx(40, abs=1e-6)
    assert pts[0] == pytest.approx([5 * 40 / 48, math.sqrt(48**2 - 25) * 40 / 48], abs=1e-9)


def test_profile_csv_and_svg(model, tmp_path):
    out = tmp_path / "profile.csv"
    assert run("cam", model, "c1", "-o", out).returncode == 0
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 360
    p = np.array([[float(r["pitch_x"]), float(r["pitch_y"])] for r in rows])
    x = np.array([[float(r["x"]), float(r["y"])] for r in rows])
    assert np.allclose(np.linalg.norm(p - x, axis=1), 8.0)  # the profile is the pitch curve offset by the roller
    svg = tmp_path / "profile.svg"
    assert run("cam", model, "c1", "-o", svg).returncode == 0
    text = svg.read_text()
    assert '<g id="LINKS"' in text and "<polygon" in text


def test_undercut_cam_is_reported_and_exits_2(tmp_path):
    path = tmp_path / "under.toml"
    path.write_text(CAM.replace("ROLLER", "30mm").replace('"40mm"', '"10mm"').replace('"5mm"', '"0mm"')
                    .replace("to = 90,", "to = 30,"))
    proc = run("cam", path, "c1", "--format", "json")
    assert proc.returncode == 2
    assert json.loads(proc.stdout)["undercut"] is True
    assert len(proc.stderr.strip().splitlines()) == 1 and "cams.c1.roller" in proc.stderr
    proc = run("solve", path, "--at", "10")
    assert proc.returncode == 2 and "cams.c1.roller" in proc.stderr


@pytest.mark.parametrize("edit, key", [
    (("to = 360, dwell", "to = 300, dwell"), "cams.c1.law"),
    (('rise = "-25mm"', 'rise = "-20mm"'), "cams.c1.law"),
    (('cam = "theta2"', 'cam = "theta9"'), "cams.c1.cam"),
    (('kind = "translating"', 'kind = "swinging"'), "cams.c1.kind"),
])
def test_bad_cams_exit_2_naming_the_key(tmp_path, edit, key):
    path = tmp_path / "bad.toml"
    path.write_text(CAM.replace("ROLLER", "8mm").replace(*edit))
    for cmd in (["cam", path, "c1"], ["info", path]):
        proc = run(*cmd)
        assert proc.returncode == 2
        assert len(proc.stderr.strip().splitlines()) == 1 and key in proc.stderr


def test_unknown_cam_name(model):
    proc = run("cam", model, "c2")
    assert proc.returncode == 2 and "c1" in proc.stderr
