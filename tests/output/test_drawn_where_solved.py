"""Every picture puts the linkage where ``solve`` puts it, wherever the model places its frame.

For every shipped model and a copy of it translated by (137.25, −48.5) and turned by 33° (see
``support/moved.py``: a frame vector in front of every point and every vector turned, or a
diagram's joints moved, so any model can be moved, with or without frame parameters):

* the DXF written by ``export_cad``/``loopsolve draw -o x.dxf`` and read back with ezdxf: every
  point of the solve is the centre of a pin (``PINS``) or of a tracer (``POINTS``) to 1e-9 in the
  model's length unit (the one ``$INSUNITS`` names), every tracer is a point of the solve, every
  link line ends at a pin or a tracer, and the moved copy's drawing is the first one moved;
* the page of ``loopsolve view`` rendered in headless Chromium (one browser for all the pages):
  at several rows every ``[data-point]`` circle is at the sweep's point, every pin of the solve
  has a joint circle on it, every link bar and outline ends at a joint circle or a point, and
  the moved copy's page is the first one moved;
* blocks lie along their guides (and along the motion of their pin on a fixed guide); circles in
  the DXF have the radius the drawing gives them (as in the SVG); the header's unit is the model's;
* the figure (``draw``) and ``SynthesisResult.plot()`` put their pins on the solve's points.

The references are the solve's numbers (``State``, or ``loopsolve solve --format json``) and the
rotation written here; nothing is recomputed by the drawing code under test.
"""

from __future__ import annotations

import json
import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.cli import main

from support.moved import move_xy, moved, moved_text
from support.pages import cli_sweep, open_page
ezdxf = pytest.importorskip("ezdxf")

MODELS = sorted(ls.models_dir().glob("*.toml"))
MOVE = (137.25, -48.5, 33.0)  # dx, dy (model length unit), rotation (degrees)
TOL = 1e-9


def is_diagram(path) -> bool:
    return "joints" in ls.load(path).spec


_MECHS: dict = {}


def mechanism(path, shifted):
    """The model (``shifted`` False), its moved copy (True, "front"), or the copy with the frame vector
    written at the end of every sum ("end")."""
    key = (path, shifted)
    if key not in _MECHS:
        _MECHS[key] = moved(path, *MOVE, frame_last=shifted == "end") if shifted else ls.load(path)
    return _MECHS[key]


def solve_points(state) -> dict:
    """The points as the solve reports them: ``{name: (x, y)}`` from the state's row."""
    return {p: (state[f"{p}_x"], state[f"{p}_y"]) for p in state.compiled.points}


def near_any(p, cands, tol=TOL) -> bool:
    return any(math.dist(p, q) <= tol for q in cands)


# ------------------------------------------------------------------------------ the DXF read back
def read_dxf(path) -> dict:
    doc = ezdxf.readfile(path)
    msp = doc.modelspace()
    out = {"header": doc.header, "circles": {}, "lines": {}, "polys": {}, "texts": []}
    for e in msp:
        layer = e.dxf.layer
        if e.dxftype() == "CIRCLE":
            out["circles"].setdefault(layer, []).append((tuple(e.dxf.center)[:2], float(e.dxf.radius)))
        elif e.dxftype() == "LINE":
            out["lines"].setdefault(layer, []).append((tuple(e.dxf.start)[:2], tuple(e.dxf.end)[:2]))
        elif e.dxftype() == "LWPOLYLINE":
            out["polys"].setdefault(layer, []).append(([tuple(map(float, v)) for v in e.get_points("xy")],
                                                       bool(e.closed)))
        elif e.dxftype() == "TEXT":
            out["texts"].append(e.dxf.text)
    return out


def centres(d, layer) -> list:
    return [c for c, _ in d["circles"].get(layer, [])]


def assert_header_unit(d, unit: str) -> None:
    """The DXF header's ``$INSUNITS`` is a unit of the size of ``unit`` (by ezdxf's own table of the
    codes and pint's size of ``unit``), or 0 (unitless) for a display-only name; ``$MEASUREMENT`` is
    0 (imperial) for inch-based units, else 1."""
    import pint

    code = d["header"]["$INSUNITS"]
    if unit == "units":
        assert code == 0
        return
    metres = pint.UnitRegistry().Quantity(1, unit).to("m").magnitude
    assert code != 0 and ezdxf.units.conversion_factor(code, ezdxf.units.M) == pytest.approx(metres, rel=1e-9), \
        (unit, code)
    assert d["header"]["$MEASUREMENT"] == (0 if unit in ("in", "inch", "ft", "yd", "mi") else 1), unit


_DXF: dict = {}


def dxf_of(path, shifted, tmp_path_factory):
    """(state, DXF read back) of the model at its default input (the guesses' pose)."""
    key = (path, shifted)
    if key not in _DXF:
        mech = mechanism(path, shifted)
        out = tmp_path_factory.mktemp("dxf") / f"{path.stem}{'-moved' if shifted else ''}.dxf"
        ls.export_cad(mech, out)
        _DXF[key] = (mech.solve(), read_dxf(out))
    return _DXF[key]


CASES = [pytest.param(p, s, id=f"{p.stem}{'-moved' if s else ''}") for p in MODELS for s in (False, True)]
#: the moved copies with the frame vector at the end of every sum (a vector model's; a diagram has none)
CASES_END = [pytest.param(p, "end", id=f"{p.stem}-moved-end") for p in MODELS if not is_diagram(p)]


@pytest.mark.parametrize("path, shifted", CASES + CASES_END)
def test_dxf_pins_and_points_are_the_solve_s_points(path, shifted, tmp_path_factory):
    state, d = dxf_of(path, shifted, tmp_path_factory)
    pts = solve_points(state)
    pins, dots = centres(d, "PINS"), centres(d, "POINTS")
    assert_header_unit(d, state.mechanism.units.length)  # the coordinates below are in this unit
    for name, xy in pts.items():  # every point of the solve is drawn, as a pin or as a tracer
        assert near_any(xy, pins + dots), (name, xy, pins, dots)
    for c in dots:  # a tracer is a point of the solve
        assert near_any(c, pts.values()), (c, pts)
    ends = pins + dots
    blocks = [tuple(np.mean(verts, axis=0)) for verts, _ in d["polys"].get("SLIDERS", [])]
    for a, b in d["lines"].get("LINKS", []):  # a bar joins two joints (or a joint and its tracer point) ...
        if not (near_any(a, ends) and near_any(b, ends)):  # ... or is a slotted lever through its block
            assert near_any(a, ends) and any(_on_line(c, a, b, 1e-7 * state.compiled.scale) for c in blocks), (a, b)
    for verts, closed in d["polys"].get("LINKS", []):  # the outline of a plate: through its joints
        assert closed and all(near_any(v, ends) for v in verts), verts
    for c in blocks:  # a block around its pin
        assert near_any(c, pins, 1e-7 * state.compiled.scale), c
    labels = {t for text in d["texts"] for t in text.split(", ")}
    for name, xy in pts.items():  # named (one name a place: a slider's pin names its block)
        assert any(math.dist(xy, pts[other]) <= TOL for other in labels & set(pts)), name
    # every tracer that moves has its curve (the path over the default sweep), passing by the pose; a
    # point at rest at the pose may still move (a cam's follower in a dwell, or at the start of a rise
    # where its velocity and acceleration vanish): it moves if any of its rates at the pose is nonzero
    curves = [verts for verts, _ in d["polys"].get("CURVES", [])]
    moving = [xy for name, xy in pts.items() if near_any(xy, dots) and not near_any(xy, pins)
              and any(math.hypot(state[f"{name}_x_{r}"], state[f"{name}_y_{r}"]) > 0 for r in ("vel", "acc", "jerk"))]
    assert len(curves) == len(moving)
    for xy in moving:
        assert any(_polyline_distance(xy, verts) < 1e-3 * state.compiled.scale for verts in curves), xy


def _has_pairs(path) -> bool:
    pairs = ls.load(path).pairs
    return pairs is not None and bool(pairs.gears or pairs.cams)


def _length(mech, node) -> float:
    """A length (or a tooth number) of the declaration, in model units (its parameters' values)."""
    from loopsolve.model import expr as lexpr

    env = {p.name: p.value for p in mech.parameters if p.kind.name != "ANGLE"}
    return float(lexpr.evaluate(node, env))


@pytest.mark.parametrize("path, shifted", [c for c in CASES + CASES_END if _has_pairs(c.values[0])])
def test_dxf_gears_and_cams_are_where_solve_puts_them(path, shifted, tmp_path_factory):
    """On ``PAIRS``: every gear's pitch circle (radius m·N/2 or the declared radius) about a joint of the
    solve, the two of a pair touching (centre distance the sum of the radii, the difference inside a
    ring); a cam's roller about a point of the solve (the shipped models name the roller's centre)
    and touching the cam's profile, which turns about a joint."""
    state, d = dxf_of(path, shifted, tmp_path_factory)
    mech = state.mechanism
    scale = state.compiled.scale
    tol = TOL * max(1.0, scale)
    joints = centres(d, "PINS")
    drawn = d["circles"].get("PAIRS", [])
    for g in mech.pairs.gears:
        if g.kind == "rack":
            continue
        if g.radii is not None:
            radii = [_length(mech, r) for r in g.radii]
        else:
            radii = [_length(mech, g.module) * _length(mech, n) / 2 for n in g.teeth]
        found = [[c for c, r in drawn if abs(r - want) <= 1e-12 * want] for want in radii]
        assert all(found), (g.key, radii, drawn)
        for cs in found:
            assert all(near_any(c, joints, tol) for c in cs), (g.key, cs)  # a gear turns about a pivot
        want = abs(radii[0] - radii[1]) if g.kind == "internal" else radii[0] + radii[1]
        assert any(abs(math.dist(a, b) - want) <= tol for a in found[0] for b in found[1]), (g.key, want)
    profiles = sorted((verts for verts, _ in d["polys"].get("PAIRS", [])), key=len)
    for cam in mech.pairs.cams:
        profile = np.asarray(profiles.pop(), dtype=float)  # the profiles have the most vertices
        assert len(profile) >= 100
        if cam.contact != "roller":
            continue
        rr = _length(mech, cam.roller)
        rollers = [c for c, r in drawn if abs(r - rr) <= 1e-12 * rr and near_any(c, list(solve_points(state).values()),
                                                                                  tol)]
        assert rollers, (cam.key, rr)
        # touching: the nearest vertex of the profile (a polyline of 360 samples) is a roller's radius away
        gaps = [float(np.min(np.hypot(*(profile - np.asarray(c)).T))) - rr for c in rollers]
        assert min(abs(g) for g in gaps) <= 2e-3 * scale, (cam.key, gaps)


def _on_line(c, a, b, tol) -> bool:
    """``c`` on the segment a–b (within ``tol``)."""
    a, b, c = (np.asarray(v, dtype=float) for v in (a, b, c))
    ab = b - a
    t = float(np.clip((c - a) @ ab / (ab @ ab), 0.0, 1.0))
    return float(np.hypot(*(c - a - t * ab))) <= tol


def _polyline_distance(p, verts) -> float:
    p, v = np.asarray(p, dtype=float), np.asarray(verts, dtype=float)
    a, ab = v[:-1], np.diff(v, axis=0)
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
    return float(np.min(np.hypot(*(p - a - t[:, None] * ab).T)))


def _link_lines(d) -> list:
    """Link bars whose both ends are joints or tracers (a slotted lever's open end is left out)."""
    ends = centres(d, "PINS") + centres(d, "POINTS")
    return [(a, b) for a, b in d["lines"].get("LINKS", []) if near_any(a, ends) and near_any(b, ends)]


@pytest.mark.parametrize("path, shifted", [c for c in CASES if c.values[1]] + CASES_END)
def test_dxf_of_the_moved_copy_is_the_drawing_moved(path, shifted, tmp_path_factory):
    """Pins, tracers, bars, blocks: the moved model's DXF is the original's, translated and turned
    (this covers the joints that are no named point, such as a vector model's ground pivots), with
    the frame vector written first or last in the points' sums."""
    s0, d0 = dxf_of(path, False, tmp_path_factory)
    s1, d1 = dxf_of(path, shifted, tmp_path_factory)
    tol = 1e-9 * max(1.0, s0.compiled.scale)  # a diagram's generated lengths are rounded to 12 digits
    # the solve itself moved (the copy is what it should be)
    p0, p1 = solve_points(s0), solve_points(s1)
    for name in p0:
        assert math.dist(move_xy(p0[name], *MOVE), p1[name]) <= tol, name
    for layer in ("PINS", "POINTS"):
        a, b = centres(d0, layer), centres(d1, layer)
        assert len(a) == len(b), layer
        for c in a:
            assert near_any(tuple(move_xy(c, *MOVE)), b, tol), (layer, c)
    bars0, bars1 = _link_lines(d0), _link_lines(d1)
    assert len(bars0) == len(bars1)
    for a, b in bars0:
        ma, mb = tuple(move_xy(a, *MOVE)), tuple(move_xy(b, *MOVE))
        assert any((math.dist(ma, p) <= tol and math.dist(mb, q) <= tol) or
                   (math.dist(ma, q) <= tol and math.dist(mb, p) <= tol) for p, q in bars1), (a, b)
    # the higher pairs: pitch circles, a cam's profile and follower (turned with the cam's frame)
    for (c, r) in d0["circles"].get("PAIRS", []):
        assert any(abs(r - r1) <= tol and math.dist(move_xy(c, *MOVE), c1) <= tol
                   for c1, r1 in d1["circles"].get("PAIRS", [])), ("PAIRS", c, r)
    polys1 = d1["polys"].get("PAIRS", [])
    for verts, _ in d0["polys"].get("PAIRS", []):
        moved_verts = move_xy(verts, *MOVE)
        assert any(len(v1) == len(verts) and np.max(np.hypot(*(moved_verts - np.asarray(v1)).T)) <= tol
                   for v1, _ in polys1), ("PAIRS polyline", verts[0])
    blocks0 = [np.mean(v, axis=0) for v, _ in d0["polys"].get("SLIDERS", [])]
    blocks1 = [tuple(np.mean(v, axis=0)) for v, _ in d1["polys"].get("SLIDERS", [])]
    assert len(blocks0) == len(blocks1)
    for c in blocks0:
        assert near_any(tuple(move_xy(c, *MOVE)), blocks1, 1e-6 * s0.compiled.scale)


def _long_axis(verts) -> np.ndarray:
    v = np.asarray(verts, dtype=float)
    edges = np.roll(v, -1, axis=0) - v
    e = edges[np.argmax(np.hypot(*edges.T))]
    return e / np.hypot(*e)


def _parallel(u, w, tol=1e-7) -> bool:
    w = np.asarray(w, dtype=float)
    n = np.hypot(*w)
    return n > 0 and abs(u[0] * w[1] - u[1] * w[0]) / n <= tol


@pytest.mark.parametrize("path, shifted", CASES)
def test_blocks_lie_along_their_guides(path, shifted, tmp_path_factory):
    """A block's long side runs along its guide line; on a fixed guide, along the motion of its pin
    (the velocity the solve gives the point at the block). A model with no sliding variable has no block."""
    state, d = dxf_of(path, shifted, tmp_path_factory)
    ck = state.compiled
    blocks = d["polys"].get("SLIDERS", [])
    sliding = [v for v, k in zip(ck.variables, ck.kinds) if k.name == "LENGTH"]
    assert bool(blocks) == bool(sliding)
    pts = solve_points(state)
    guides = [(np.asarray(a), np.asarray(b), layer) for layer in ("GROUND", "SLIDERS", "LINKS")
              for a, b in d["lines"].get(layer, [])]
    for verts, _ in blocks:
        u = _long_axis(verts)
        c = np.mean(verts, axis=0)
        through = [layer for a, b, layer in guides if _parallel(u, b - a) and _on_line(c, a, b, 1e-7 * ck.scale)]
        assert through, f"no guide along the block at {c}"
        if "GROUND" in through:  # a fixed guide: the pin slides along it
            names = [n for n, xy in pts.items() if math.dist(xy, c) < 1e-7 * ck.scale]
            assert names, c
            v = np.array([state[f"{names[0]}_x_vel"], state[f"{names[0]}_y_vel"]])
            if np.hypot(*v) > 1e-9 * ck.scale:
                assert _parallel(u, v, 1e-6), (names, u, v)


@pytest.mark.parametrize("path", [ls.models_dir() / n for n in ("crank_shaper.toml", "fourbar_path_synthesis.toml")],
                         ids=lambda p: p.stem)
def test_dxf_circles_have_the_drawing_s_radius(path, tmp_path):
    """The DXF and the SVG of one drawing hold the same circles (a DXF circle's radius is a radius)."""
    mech = moved(path, *MOVE)
    ents = ls.export_cad(mech, tmp_path / "d.dxf")
    ls.export_cad(mech, tmp_path / "d.svg")
    d = read_dxf(tmp_path / "d.dxf")
    ns = {"s": "http://www.w3.org/2000/svg"}
    root = ET.parse(tmp_path / "d.svg").getroot()
    for layer in ("PINS", "POINTS"):
        want = sorted((e.points[0], e.size) for e in ents if e.layer == layer and e.kind == "circle")
        svg = sorted(((float(c.get("cx")), float(c.get("cy"))), float(c.get("r")))
                     for g in root.findall("s:g", ns) if g.get("id") == layer for c in g.findall("s:circle", ns))
        got = sorted(d["circles"].get(layer, []))
        assert len(want) == len(svg) == len(got), layer
        for (cw, rw), (cs, rs), (cg, rg) in zip(want, svg, got):
            assert math.dist(cw, cg) <= TOL and math.dist(cs, cg) <= TOL
            assert rg == pytest.approx(rw, rel=1e-12) and rs == pytest.approx(rg, rel=1e-12)
    # and the pins are small beside the links: no pin reaches another joint
    pins = centres(d, "PINS")
    r = d["circles"]["PINS"][0][1]
    assert min(math.dist(a, b) for i, a in enumerate(pins) for b in pins[i + 1:]) > 2 * r


@pytest.mark.parametrize("unit", ["mm", "cm", "m", "in", "ft", "um", "km", "units"])
def test_dxf_header_names_the_model_s_length_unit(unit, tmp_path):
    """``$INSUNITS`` is the DXF code of a unit of the model's length, ``$MEASUREMENT`` 0 for
    inch-based units, else 1; the coordinates are the solve's numbers in that unit."""
    text = (ls.models_dir() / "thesis_crank_rocker.toml").read_text()
    text = text.replace('length = "mm"', f'length = "{unit}"')
    assert f'length = "{unit}"' in text
    path = tmp_path / "m.toml"
    path.write_text(text)
    mech = ls.load(path)
    ls.export_cad(mech, tmp_path / "m.dxf", 60)
    d = read_dxf(tmp_path / "m.dxf")
    assert_header_unit(d, unit)
    pts = solve_points(mech.solve(60))
    assert all(near_any(xy, centres(d, "PINS")) for xy in pts.values())


# ------------------------------------------------------------------------------ the command line
def test_cli_draw_of_a_frame_placed_model_is_where_solve_says(tmp_path, capsys):
    """The issue's case: the path-synthesis four-bar with its frame at (50, 20), then also turned."""
    src = (ls.models_dir() / "fourbar_path_synthesis.toml").read_text()
    shifted = src.replace("\nx0 = 0\n", "\nx0 = 50\n").replace("\ny0 = 0\n", "\ny0 = 20\n")
    assert shifted.count("= 50\n") == 1 and shifted.count("= 20\n") == 1
    (tmp_path / "shifted.toml").write_text(shifted)
    (tmp_path / "turned.toml").write_text(moved_text(tmp_path / "shifted.toml", 0.0, 0.0, 33.0))
    for name in ("shifted.toml", "turned.toml"):
        model = tmp_path / name
        assert main(["solve", str(model), "--at", "60", "--format", "json"]) == 0
        row = json.loads(capsys.readouterr().out)["rows"][0]
        pts = {p: (row[f"{p}_x"], row[f"{p}_y"]) for p in ("O2", "A", "B", "O4", "P")}
        if name == "shifted.toml":
            assert pts["O2"] == (50.0, 20.0) and math.dist(pts["O4"], (54.0, 20.0)) < 1e-12
        out = tmp_path / (name + ".dxf")
        assert main(["draw", str(model), "--at", "60", "-o", str(out)]) == 0
        d = read_dxf(out)
        pins = centres(d, "PINS")
        assert len(pins) == 4 and all(near_any(pts[j], pins) for j in ("O2", "A", "B", "O4"))
        assert centres(d, "POINTS") and math.dist(centres(d, "POINTS")[0], pts["P"]) <= TOL  # the coupler point
        [curve] = d["polys"]["CURVES"]  # P's path over a crank turn passes through the pose (60° is a row)
        assert min(math.dist(v, pts["P"]) for v in curve[0]) <= TOL
        apexes = sorted(verts[0] for verts, _ in d["polys"]["GROUND"])
        assert np.allclose(apexes, sorted([pts["O2"], pts["O4"]]), atol=TOL)
        for a, b in (("O2", "A"), ("A", "B"), ("O4", "B"), ("A", "P"), ("B", "P")):
            assert any({near_any(p, [pts[a]]), near_any(q, [pts[b]])} == {True} or
                       {near_any(p, [pts[b]]), near_any(q, [pts[a]])} == {True}
                       for p, q in d["lines"]["LINKS"]), (name, a, b)
        svg = tmp_path / (name + ".svg")
        assert main(["draw", str(model), "--at", "60", "--cad", "-o", str(svg)]) == 0
        ns = {"s": "http://www.w3.org/2000/svg"}
        groups = {g.get("id"): g for g in ET.parse(svg).getroot().findall("s:g", ns)}
        svg_pins = [(float(c.get("cx")), float(c.get("cy"))) for c in groups["PINS"].findall("s:circle", ns)]
        assert all(near_any(pts[j], svg_pins) for j in ("O2", "A", "B", "O4"))
        [dot] = groups["POINTS"].findall("s:circle", ns)
        assert math.dist((float(dot.get("cx")), float(dot.get("cy"))), pts["P"]) <= TOL
        capsys.readouterr()


def test_slider_crank_coupler_point_is_a_tracer(tmp_path):
    mech = ls.load(ls.models_dir() / "slider_crank_path_synthesis.toml")
    ls.export_cad(mech, tmp_path / "s.dxf", 60)
    d = read_dxf(tmp_path / "s.dxf")
    pts = solve_points(mech.solve(60))
    [dot] = centres(d, "POINTS")
    assert math.dist(dot, pts["P"]) <= TOL and not near_any(pts["P"], centres(d, "PINS"), 1e-6)
    assert len(d["polys"]["CURVES"]) == 1


# ------------------------------------------------------------------------------ figures
def _figure_pins(fig) -> list:
    """Centres of the joint circles (white circles) and tracer dots (black) of a diagram figure."""
    from matplotlib.patches import Circle

    return [(tuple(map(float, p.center)), p.get_facecolor()[:3] == (1.0, 1.0, 1.0))
            for ax in fig.axes for p in ax.patches if isinstance(p, Circle)]


@pytest.mark.parametrize("path", [ls.models_dir() / n for n in ("fourbar_path_synthesis.toml",
                                                                 "slider_crank_path_synthesis.toml",
                                                                 "crank_shaper.toml", "quick_return.toml")],
                         ids=lambda p: p.stem)
def test_figure_pins_are_the_solve_s_points(path, tmp_path_factory):
    """``draw``: every point of the solve is a joint circle or a tracer dot, the blocks are the
    DXF's blocks (checked along their guides above), and the moved model's figure has its circles
    where the original's are, moved."""
    pytest.importorskip("matplotlib")
    from matplotlib.patches import Polygon

    from loopsolve.output.plotting import draw

    figs = {}
    for shifted in (False, True):
        state, d = dxf_of(path, shifted, tmp_path_factory)
        fig = draw(state)
        circles = [c for c, _ in _figure_pins(fig)]
        for name, xy in solve_points(state).items():
            assert near_any(xy, circles), (name, shifted)
        figs[shifted] = circles
        yellow = [p.get_xy()[:4] for ax in fig.axes for p in ax.patches
                  if isinstance(p, Polygon) and p.get_facecolor()[:3] == pytest.approx((0xf4 / 255, 0xd0 / 255, 0x3f / 255))]
        dxf_blocks = [v for v, _ in d["polys"].get("SLIDERS", [])]
        assert len(yellow) == len(dxf_blocks)
        for corners in yellow:  # the same rectangle (one pose, one symbol size)
            assert any(all(near_any(tuple(c), [tuple(w) for w in other], 1e-9 * state.compiled.scale) for c in corners)
                       for other in dxf_blocks), corners
        import matplotlib.pyplot as plt

        plt.close(fig)
    tol = 1e-9 * max(1.0, mechanism(path, False).compile().scale)
    assert len(figs[False]) == len(figs[True])
    for c in figs[False]:
        assert near_any(tuple(move_xy(c, *MOVE)), figs[True], tol), c


def test_synthesis_plot_draws_the_design_where_it_is(tmp_path):
    """``SynthesisResult.plot()`` of a design whose frame is away from the origin: every linkage
    drawn at the targets has its pins on the design's solved points."""
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    base = ls.load(ls.models_dir() / "fourbar_path_synthesis.toml").with_parameters(x0=50, y0=20, theta0=15)
    planted = dict(r1=4.0, r2=1.5, r3=3.5, r4=3.2, rcx=1.2, rcy=0.8)
    inputs = [20, 45, 70, 95, 120, 145]
    truth = base.with_parameters(**planted)
    targets = np.array([[truth.solve(x)["P_x"], truth.solve(x)["P_y"]] for x in inputs])
    vary = {"r1": (2, 6), "r2": (0.5, 3), "r3": (2, 6), "r4": (2, 6), "rcx": (-3, 3), "rcy": (-3, 3)}
    res = ls.synthesize(base, path="P", targets={"x": targets[:, 0], "y": targets[:, 1]}, inputs=inputs, vary=vary,
                        seed=3, popsize=12, maxiter=120, restarts=1, progress=False)
    fig = res.plot()
    circles = [c for c, white in _figure_pins(fig) if white]
    assert len(circles) == 4 * len(inputs)  # four pins at each target
    want = []
    for x in inputs:
        s = res.mechanism.solve(x, mode=res.report["mode"])
        want += [(s[f"{p}_x"], s[f"{p}_y"]) for p in ("O2", "A", "B", "O4")]
    for c in circles:
        assert near_any(c, want, 1e-9), c
    for w in want:
        assert near_any(w, circles, 1e-9)
    plt.close(fig)


# ------------------------------------------------------------------------------ the page in Chromium
@pytest.fixture(scope="module")
def browser(chromium):
    """This module's headless Chromium, offline, its console and network logs kept (as test_view's)."""
    with chromium(window=(1280, 860), offline=True, performance=True) as driver:
        yield driver


_PAGE_JS = """
var s = document.getElementById('loopsolve-input');
s.value = arguments[0];
s.dispatchEvent(new Event('input', {bubbles: true}));
function vis(e) { return e.getAttribute('visibility') !== 'hidden'; }
function num(e, k) { return parseFloat(e.getAttribute(k)); }
var q = function (sel) { return Array.prototype.slice.call(document.querySelectorAll(sel)); };
return {
  value: s.value,
  points: q('[data-point]').map(function (e) {
    return [e.getAttribute('data-point'), num(e, 'cx'), num(e, 'cy'), e.getAttribute('class'), vis(e)]; }),
  joints: q('#ls-world circle.joint').filter(vis).map(function (e) { return [num(e, 'cx'), num(e, 'cy')]; }),
  bars: q('#ls-world line.link-bar').filter(vis).map(function (e) {
    return [num(e, 'x1'), num(e, 'y1'), num(e, 'x2'), num(e, 'y2')]; }),
  polys: q('#ls-world polygon.link-poly').filter(vis).map(function (e) {
    return e.getAttribute('points').trim().split(/\\s+/).map(function (p) { return p.split(',').map(parseFloat); }); }),
  blocks: q('#ls-world polygon.block').filter(vis).map(function (e) {
    return e.getAttribute('points').trim().split(/\\s+/).map(function (p) { return p.split(',').map(parseFloat); }); }),
  guides: q('#ls-world line.axis, #ls-world line.mguide, #ls-world line.lever').filter(vis).map(function (e) {
    return [e.getAttribute('class'), num(e, 'x1'), num(e, 'y1'), num(e, 'x2'), num(e, 'y2')]; })
};
"""


def _page_rows(browser, tmp_path, model_path, name):
    sw = cli_sweep(model_path)
    page = tmp_path / f"{name}.html"
    page.write_text(sw.to_html(), encoding="utf-8")
    open_page(browser, page)
    n = len(sw)
    rows = sorted({0, n // 3, (2 * n) // 3, n - 1})
    return sw, {r: browser.execute_script(_PAGE_JS, r) for r in rows}


def _check_page_against_sweep(sw, seen):
    for r, got in seen.items():
        assert got["value"] == str(r)
        pts = {}
        for name, cx, cy, cls, visible in got["points"]:
            x, y = sw[f"{name}_x"][r], sw[f"{name}_y"][r]
            if not (math.isfinite(x) and math.isfinite(y)):
                assert not visible
                continue
            assert visible and abs(cx - x) <= TOL and abs(cy - y) <= TOL, (name, r, cx, cy, x, y)
            pts[name] = ((cx, cy), cls)
        joints = [tuple(j) for j in got["joints"]]
        for name, (xy, cls) in pts.items():  # a pin of the solve is a joint circle of the drawing
            if cls == "pin":
                assert near_any(xy, joints), (name, r, xy, joints)
        ends = joints + [xy for xy, _ in pts.values()]
        for x1, y1, x2, y2 in got["bars"]:
            assert near_any((x1, y1), ends) and near_any((x2, y2), ends), (r, x1, y1, x2, y2)
        for poly in got["polys"]:
            assert all(near_any(tuple(v), ends) for v in poly), (r, poly)
        for block in got["blocks"]:
            c = tuple(np.mean(block, axis=0))
            assert near_any(c, joints, 1e-7 * sw.compiled.scale), (r, c)
            u = _long_axis(block)  # along a line through it: a fixed guide's axis, a moving guide, a lever, a bar
            lines = [g[1:] for g in got["guides"]] + got["bars"]
            assert any(_parallel(u, (x2 - x1, y2 - y1)) and _on_line(c, (x1, y1), (x2, y2), 1e-7 * sw.compiled.scale)
                       for x1, y1, x2, y2 in lines), (r, c)
    # a block on a fixed guide (its axis drawn once) moves along its long side from row to row
    rows = sorted(seen)
    for r0, r1 in zip(rows, rows[1:]):
        b0, b1 = seen[r0]["blocks"], seen[r1]["blocks"]
        if len(b0) != len(b1):
            continue
        for p, q in zip(b0, b1):
            c0, c1 = np.mean(p, axis=0), np.mean(q, axis=0)
            fixed = [g for g in seen[r0]["guides"] if g[0] == "axis" and _on_line(c0, g[1:3], g[3:5], 1e-7 * sw.compiled.scale)
                     and _on_line(c1, g[1:3], g[3:5], 1e-7 * sw.compiled.scale)]
            if fixed and np.hypot(*(c1 - c0)) > 1e-6 * sw.compiled.scale:
                assert _parallel(_long_axis(p), c1 - c0, 1e-6), (r0, r1, c0, c1)


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_page_in_chromium_draws_where_the_sweep_is(browser, tmp_path, path):
    sw0, seen0 = _page_rows(browser, tmp_path, path, "original")
    _check_page_against_sweep(sw0, seen0)
    moved_path = tmp_path / f"{path.stem}-moved.toml"
    moved_path.write_text(moved_text(path, *MOVE))
    sw1, seen1 = _page_rows(browser, tmp_path, moved_path, "moved")
    _check_page_against_sweep(sw1, seen1)
    if is_diagram(path):
        return  # every joint of a diagram is a point of the solve: checked above
    # a vector model moved is the same motion moved (same rows): so is everything drawn
    tol = 1e-9 * max(1.0, sw0.compiled.scale)
    assert len(sw0) == len(sw1)
    for r in seen0:
        a, b = seen0[r], seen1[r]
        for key in ("joints",):
            assert len(a[key]) == len(b[key])
            for j in a[key]:
                assert near_any(tuple(move_xy(j, *MOVE)), [tuple(k) for k in b[key]], tol), (r, key, j)
        bars1 = [((x1, y1), (x2, y2)) for x1, y1, x2, y2 in b["bars"]]
        assert len(a["bars"]) == len(bars1)
        for x1, y1, x2, y2 in a["bars"]:
            p, q = tuple(move_xy((x1, y1), *MOVE)), tuple(move_xy((x2, y2), *MOVE))
            assert any((math.dist(p, u) <= tol and math.dist(q, w) <= tol) for u, w in bars1), (r, p, q)
        assert len(a["polys"]) == len(b["polys"])
        for poly in a["polys"]:
            assert any(all(near_any(tuple(move_xy(v, *MOVE)), [tuple(w) for w in other], tol) for v in poly)
                       for other in b["polys"])
