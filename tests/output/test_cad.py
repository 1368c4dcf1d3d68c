"""CAD export: the DXF read back with ezdxf, the SVG read back as XML, coordinates equal to the solve's."""

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.cli import main

from support.models import G2, G4, L2, O2, O4, pose, POSES5

ezdxf = pytest.importorskip("ezdxf")

COUPLER = ls.models_dir() / "fourbar_coupler_curve.toml"
JOINTS = ("O2", "A", "B", "O4")


def call(capsys, *argv):
    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


@pytest.fixture(scope="module")
def solved():
    mech = ls.load(COUPLER)
    s = mech.solve(60)
    xy = {n: (s[f"{n}_x"], s[f"{n}_y"]) for n in JOINTS + ("P",)}
    # the thesis four-bar by hand at 60°: A = 25∠60°
    assert xy["A"] == pytest.approx((12.5, 25 * math.sqrt(3) / 2), abs=1e-9)
    return mech, xy


def near(p, q, tol=1e-9):
    return math.dist(p, q) < tol


def test_dxf_round_trip(solved, tmp_path, capsys):
    mech, xy = solved
    out = tmp_path / "design.dxf"
    status, _, err = call(capsys, "draw", COUPLER, "--at", "60", "-o", out)
    assert status == 0 and "wrote" in err
    doc = ezdxf.readfile(out)
    assert doc.header["$INSUNITS"] == 4  # millimetres
    layers = {layer.dxf.name for layer in doc.layers}
    assert {"LINKS", "PINS", "GROUND", "POINTS", "CURVES", "LABELS"} <= layers
    msp = doc.modelspace()
    lines = [(tuple(e.dxf.start)[:2], tuple(e.dxf.end)[:2]) for e in msp.query("LINE[layer=='LINKS']")]
    # crank O2-A, rocker O4-B, and the coupler triangle A-B-P: each a line between solved joints
    for a, b in (("O2", "A"), ("A", "B"), ("O4", "B"), ("A", "P"), ("B", "P")):
        assert any((near(p, xy[a]) and near(q, xy[b])) or (near(p, xy[b]) and near(q, xy[a])) for p, q in lines), (a, b)
    pins = [tuple(e.dxf.center)[:2] for e in msp.query("CIRCLE[layer=='PINS']")]
    assert len(pins) == 4 and all(any(near(p, xy[j]) for p in pins) for j in JOINTS)
    [tracer] = [tuple(e.dxf.center)[:2] for e in msp.query("CIRCLE[layer=='POINTS']")]
    assert near(tracer, xy["P"])
    ground = msp.query("LWPOLYLINE[layer=='GROUND']")
    apexes = [tuple(map(float, e.get_points("xy")[0])) for e in ground]
    assert np.allclose(sorted(apexes), sorted([xy["O2"], xy["O4"]]), atol=1e-9)
    texts = {e.dxf.text for e in msp.query("TEXT[layer=='LABELS']")}
    assert set(JOINTS) | {"P"} <= texts
    # the coupler curve: P over a full crank turn, vertex by vertex against the sweep
    [curve] = msp.query("LWPOLYLINE[layer=='CURVES']")
    verts = np.array([tuple(v) for v in curve.get_points("xy")])
    sw = mech.sweep(0, 360, 1)
    assert verts.shape == (len(sw), 2)
    assert np.allclose(verts, np.column_stack([sw["P_x"], sw["P_y"]]), atol=1e-9)
    assert any(np.hypot(*(verts - xy["P"]).T) < 1e-9)  # the pose lies on its curve


def test_svg_round_trip(solved, tmp_path, capsys):
    _, xy = solved
    out = tmp_path / "design.svg"
    status, _, _ = call(capsys, "draw", COUPLER, "--at", "60", "--cad", "-o", out)
    assert status == 0
    root = ET.parse(out).getroot()
    ns = {"s": "http://www.w3.org/2000/svg"}
    groups = {g.get("id"): g for g in root.findall("s:g", ns)}
    assert {"LINKS", "PINS", "GROUND", "CURVES"} <= set(groups)
    assert root.get("width").endswith("mm")
    lines = [((float(e.get("x1")), float(e.get("y1"))), (float(e.get("x2")), float(e.get("y2"))))
             for e in groups["LINKS"].findall("s:line", ns)]
    assert any(near(p, xy["O2"]) and near(q, xy["A"]) for p, q in lines)
    pins = [(float(c.get("cx")), float(c.get("cy"))) for c in groups["PINS"].findall("s:circle", ns)]
    assert all(any(near(p, xy[j]) for p in pins) for j in JOINTS)
    [poly] = groups["CURVES"].findall("s:polyline", ns)
    verts = [tuple(map(float, v.split(","))) for v in poly.get("points").split()]
    assert len(verts) == 361


def test_figure_svg_unchanged_without_cad(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    out = tmp_path / "figure.svg"
    assert call(capsys, "draw", COUPLER, "--at", "60", "-o", out)[0] == 0
    root = ET.parse(out).getroot()
    assert root.find("{http://www.w3.org/2000/svg}g[@id='LINKS']") is None  # a matplotlib figure


def test_synthesized_design_exports_the_same_way(tmp_path):
    # a Freudenstein generator (the log10 points as angles): pivots at (0, 0) and (r1, 0), the curve asked for
    from loopsolve.output.cad import export_cad
    from loopsolve.design.synthesis.classical.freudenstein import freudenstein_points

    d = freudenstein_points([49.019, 75.0, 100.981], [153.441, 201.633, 222.570])

    out = tmp_path / "gen.dxf"
    export_cad(d.mechanism, out, 75, curves=["B"])
    msp = ezdxf.readfile(out).modelspace()
    apexes = sorted(tuple(map(float, e.get_points("xy")[0])) for e in msp.query("LWPOLYLINE[layer=='GROUND']"))
    assert np.allclose(apexes, [(0, 0), (d.lengths[0], 0)], atol=1e-9)
    [curve] = msp.query("LWPOLYLINE[layer=='CURVES']")
    r = [math.hypot(x, y) for x, y in curve.get_points("xy")]
    assert r == pytest.approx([d.lengths[1]] * len(r), rel=1e-9)  # the crank pin's path: a circle arc


@pytest.mark.parametrize("argv, text", [
    (["--at", "60", "--curve", "Q", "-o", "{o}.dxf"], "'Q'"),
    (["--at", "60", "--cad", "-o", "{o}.png"], ".dxf or .svg"),
    (["--at", "60", "--curve", "P", "-o", "{o}.png"], "CAD drawings"),
    (["--at", "60", "--vectors", "-o", "{o}.dxf"], "--vectors"),
    (["--at", "400x", "-o", "{o}.dxf"], "400x"),
])
def test_cli_errors_one_line(capsys, tmp_path, argv, text):
    status, out, err = call(capsys, "draw", COUPLER, *[a.format(o=tmp_path / "x") for a in argv])
    assert status == 2 and len(err.strip().splitlines()) == 1 and text in err, err
    assert not list(tmp_path.iterdir())


def test_burmester_design_dxf_passes_through_the_poses(tmp_path):
    res = ls.burmester(POSES5)
    [c] = [c for c in res.candidates if np.allclose(c.lengths, (60, 25, 70, 45), atol=1e-8)]
    out = tmp_path / "motion.dxf"
    ls.export_cad(c.mechanism, out, 20)
    msp = ezdxf.readfile(out).modelspace()
    apexes = sorted(tuple(map(float, e.get_points("xy")[0])) for e in msp.query("LWPOLYLINE[layer=='GROUND']"))
    assert np.allclose(apexes, sorted([tuple(O2), tuple(O4)]), atol=1e-9)
    [curve] = msp.query("LWPOLYLINE[layer=='CURVES']")  # the coupler point P over a crank turn
    verts = np.array([tuple(v) for v in curve.get_points("xy")])
    for x, y, _ in POSES5:  # the crank angles 20°, 70°, ... are rows of the 1° sweep
        assert np.min(np.hypot(verts[:, 0] - x, verts[:, 1] - y)) < 1e-9


def test_dxf_without_ezdxf_is_a_one_line_error(capsys, tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "ezdxf", None)  # import ezdxf now raises ImportError
    status, _, err = call(capsys, "draw", COUPLER, "--at", "60", "-o", tmp_path / "x.dxf")
    assert status == 2 and len(err.strip().splitlines()) == 1 and "loopsolve[cad]" in err, err
    assert not list(tmp_path.iterdir())


def test_entities_read_as_a_summary(tmp_path):
    # ls.export_cad returns the entities; at a prompt a 361-vertex curve printed every vertex
    ents = ls.export_cad(ls.load(COUPLER), tmp_path / "d.svg", 60, step=1)
    curve = next(e for e in ents if e.layer == "CURVES")
    assert len(curve.points) == 361  # the full turn at 1°, both ends
    text = repr(curve)
    assert "<361 points from (" in text and len(text) < 150 and "name='P'" in text
    pin = next(e for e in ents if e.layer == "PINS")
    assert repr(pin).startswith("Entity(layer='PINS', kind='circle', points=((0.0, 0.0),), size=")


def test_cli_synthesized_design_file_draws_to_dxf_at_the_solve(tmp_path, capsys):
    # loopsolve synthesize ... -o design.toml, then loopsolve draw design.toml --at X -o design.dxf
    # model): its frame placement and coupler point are parameters
    base = tmp_path / "fourbar.toml"
    base.write_text((Path(__file__).resolve().parents[2] / "models" / "fourbar_path_synthesis.toml").read_text())
    poses = tmp_path / "poses.csv"
    poses.write_text("x,y,angle\n" + "".join(f"{x!r},{y!r},{a!r}\n" for x, y, a in map(pose, (10, 70, 130, 190, 250))))
    design, out = tmp_path / "design.toml", tmp_path / "design.dxf"
    report = tmp_path / "report.json"
    status, _, err = call(capsys, "synthesize", base, "--method", "burmester", "--motion", "P", "--link", "theta3",
                          "--targets", poses, "-o", design, "--report", report, "-q")
    assert status == 0, err
    # the model's input is the crank's angle from its ground line: the design's own input at the third pose
    rep = json.loads(report.read_text())
    at = rep["targets"][2]["input"]
    status, _, err = call(capsys, "draw", design, "--at", repr(at), "-o", out)
    assert status == 0 and "wrote" in err
    s = ls.load(design).solve(at, mode=rep["mode"])
    xy = {n: (s[f"{n}_x"], s[f"{n}_y"]) for n in JOINTS + ("P",)}
    # the solve against the planted crank-rocker by hand: pivots, crank pin, the pose's coupler point
    assert near(xy["O2"], G2) and near(xy["O4"], G4)
    assert near(xy["A"], G2 + L2 * np.array([math.cos(math.radians(130)), math.sin(math.radians(130))]))
    assert near(xy["P"], pose(130)[:2], 1e-7)
    msp = ezdxf.readfile(out).modelspace()
    pins = [tuple(e.dxf.center)[:2] for e in msp.query("CIRCLE[layer=='PINS']")]
    assert len(pins) == 4 and all(any(near(p, xy[j]) for p in pins) for j in JOINTS)
    [tracer] = [tuple(e.dxf.center)[:2] for e in msp.query("CIRCLE[layer=='POINTS']")]
    assert near(tracer, xy["P"])
    lines = [(tuple(e.dxf.start)[:2], tuple(e.dxf.end)[:2]) for e in msp.query("LINE[layer=='LINKS']")]
    for a, b in (("O2", "A"), ("A", "B"), ("O4", "B")):
        assert any((near(p, xy[a]) and near(q, xy[b])) or (near(p, xy[b]) and near(q, xy[a])) for p, q in lines), (a, b)
    apexes = sorted(tuple(map(float, e.get_points("xy")[0])) for e in msp.query("LWPOLYLINE[layer=='GROUND']"))
    assert np.allclose(apexes, sorted([tuple(G2), tuple(G4)]), atol=1e-9)
    [curve] = msp.query("LWPOLYLINE[layer=='CURVES']")  # the coupler curve passes through every pose
    verts = np.array([tuple(v) for v in curve.get_points("xy")])
    for t in (10, 70, 130, 190, 250):
        assert np.min(np.hypot(*(verts - pose(t)[:2]).T)) < 1e-7
