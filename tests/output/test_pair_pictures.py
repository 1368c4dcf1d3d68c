"""Gears, cams and slots in draw, animate, view and DXF: what is drawn, read back against the geometry."""

import json
import math
import re

import numpy as np
import pytest

import loopsolve as ls

from support.models import CAM_FOLLOWER, GEAR_TRAIN, PLANETARY, SLOTTED
from support.pages import open_page

GEARS = GEAR_TRAIN.format(d=30, rg=12, rm=18, load=2.0, extra="pressure_angle = 20")


def _circles(ax):
    from matplotlib.patches import Circle

    return [(tuple(np.round(p.center, 9)), round(p.radius, 9)) for p in ax.patches if isinstance(p, Circle)]


def test_draw_shows_pitch_circles_cam_profile_and_slot():
    from matplotlib.patches import Polygon

    from loopsolve.model.cams import cam_report
    from loopsolve.model.pairs import evaluator

    fig = ls.loads(GEARS).draw(40)
    circles = _circles(fig.axes[0])
    assert ((0.0, 0.0), 12.0) in circles and ((30.0, 0.0), 18.0) in circles

    cam = ls.loads(CAM_FOLLOWER)
    fig = cam.draw(40)
    polys = [p for p in fig.axes[0].patches if isinstance(p, Polygon) and len(p.get_xy()) > 100]
    assert len(polys) == 1
    c = cam.pairs.cams[0]
    prof = cam_report(c, evaluator(cam), n=360)["profile"]
    t = math.radians(40)
    turned = prof @ np.array([[math.cos(t), math.sin(t)], [-math.sin(t), math.cos(t)]])
    assert np.allclose(polys[0].get_xy()[:360], turned, atol=1e-9)
    # the roller (radius 8) sits on the follower's line x = 5 at its pitch point
    s = cam.solve(40)
    assert ((5.0, round(math.sqrt(48**2 - 25) + s["s"], 9)), 8.0) in _circles(fig.axes[0])

    fig = ls.loads(SLOTTED).draw(40)
    slot = [p for p in fig.axes[0].patches if isinstance(p, Polygon) and len(p.get_xy()) in (4, 5)]
    assert slot  # the slot along the lever


def test_dxf_of_a_geared_pose(tmp_path):
    ezdxf = pytest.importorskip("ezdxf")
    from loopsolve.output.cad import export_cad

    out = tmp_path / "gears.dxf"
    export_cad(ls.loads(GEARS), out, 40, curves=[])
    circles = {(round(e.dxf.center[0], 9), round(e.dxf.center[1], 9), round(e.dxf.radius, 9), e.dxf.layer)
               for e in ezdxf.readfile(out).modelspace().query("CIRCLE")}
    assert (0.0, 0.0, 12.0, "PAIRS") in circles and (30.0, 0.0, 18.0, "PAIRS") in circles


def test_dxf_of_a_cam_pose(tmp_path):
    ezdxf = pytest.importorskip("ezdxf")
    from loopsolve.output.cad import export_cad

    out = tmp_path / "cam.dxf"
    export_cad(ls.loads(CAM_FOLLOWER), out, 0, curves=[])
    msp = ezdxf.readfile(out).modelspace()
    profiles = [e for e in msp.query("LWPOLYLINE") if e.dxf.layer == "PAIRS" and len(e) > 100]
    assert len(profiles) == 1
    pts = np.array([p[:2] for p in profiles[0].get_points()])
    assert np.linalg.norm(pts, axis=1).min() == pytest.approx(40, abs=1e-6)  # the base circle
    # on PAIRS with the profile: the cam's centre mark (at the origin) and the roller
    rollers = [e for e in msp.query("CIRCLE") if e.dxf.layer == "PAIRS" and math.hypot(e.dxf.center.x, e.dxf.center.y) > 1e-9]
    assert [round(e.dxf.radius, 9) for e in rollers] == [8.0]


def test_animation_of_a_cam(tmp_path):
    pytest.importorskip("PIL")
    from PIL import Image

    sw = ls.loads(CAM_FOLLOWER).sweep(0, 360, 30)
    out = sw.animate(output=tmp_path / "cam.gif", fps=5)
    assert Image.open(out).n_frames == len(sw)


def _scene(html):
    data = re.search(r'<script type="application/json" id="ls-data">(.*?)</script>', html, re.S).group(1)
    return json.loads(data)["scene"]


def test_page_carries_the_pairs():
    sw = ls.loads(GEARS).sweep(0, 90, 30)
    pairs = _scene(sw.to_html())["pairs"]
    assert sorted(p["r"] for p in pairs if p["k"] == "circle") == [12.0, 18.0]
    sw = ls.loads(CAM_FOLLOWER).sweep(0, 90, 30)
    scene = _scene(sw.to_html())
    (rot,) = [p for p in scene["pairs"] if p["k"] == "rot"]
    angles = scene["angles"][rot["a"]]
    assert np.allclose(np.degrees(angles), [0, 30, 60, 90])
    reach = np.max(np.hypot(rot["p"][0::2], rot["p"][1::2]))
    assert scene["extent"][2] >= reach  # the page's view holds the whole cam


@pytest.fixture(scope="module")
def browser(chromium):
    """This module's headless Chromium, offline, its console and network logs kept (as test_view's)."""
    with chromium(window=(1280, 860), offline=True, performance=True) as driver:
        yield driver


_CAM_JS = """
var s = document.getElementById('loopsolve-input');
s.value = arguments[0];
s.dispatchEvent(new Event('input', {bubbles: true}));
var p = document.querySelector('polygon.pair-cam'), c = document.querySelectorAll('circle.pair-follower');
return [p.getAttribute('points'), c.length ? [c[0].getAttribute('cx'), c[0].getAttribute('cy')] : null];
"""


def test_cam_page_in_a_browser(browser, tmp_path):
    mech = ls.loads(CAM_FOLLOWER)
    sw = mech.sweep(0, 90, 30)
    page = tmp_path / "cam.html"
    page.write_text(sw.to_html(), encoding="utf-8")
    open_page(browser, page)
    scene = _scene(page.read_text())
    (rot,) = [p for p in scene["pairs"] if p["k"] == "rot"]
    local = np.array(rot["p"]).reshape(-1, 2)
    for r in range(len(sw)):
        pts, roller = browser.execute_script(_CAM_JS, r)
        xy = np.array([[float(v) for v in q.split(",")] for q in pts.split()])
        t = math.radians(sw["theta2"][r])
        turned = local @ np.array([[math.cos(t), math.sin(t)], [-math.sin(t), math.cos(t)]])
        assert np.allclose(xy, turned, atol=1e-6)
        assert float(roller[0]) == pytest.approx(5.0) and float(roller[1]) == pytest.approx(
            math.sqrt(48**2 - 25) + sw["s"][r], abs=1e-6)


def test_a_model_of_angles_alone_has_nothing_to_draw():
    mech = ls.loads(PLANETARY.format(held="theta_r", value=30, s="input = true, ", c="", r=""))
    with pytest.raises(ls.ModelError, match="nothing to draw"):
        mech.draw(10)
