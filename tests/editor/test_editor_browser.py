"""The editor's page in headless Chromium (issue 34), one browser session for every check, in order.

The editor is opened on a copy of the shipped ``thesis_crank_rocker_diagram.toml`` (ground 60,
crank 25, coupler and rocker from the drawn pose, open mode). With real pointer events
(selenium's ActionChains) a ground pivot is dragged; the new link lengths and the re-solved
positions are checked against the four-bar's closed form written here (circle intersection,
same side of B-O4 as before: the mode kept). The input slider is moved and the values panel
read. A curve is drawn with the mouse on the diagram and the synthesis panel gives a certified
candidate, which becomes the edited mechanism. The model is saved (the confirm dialog answered)
and the file compared with the expected TOML; the share URL is opened in the same and in another
``loopsolve edit``, giving the same design.
"""

from __future__ import annotations

import math
import shutil
import time
import tomllib

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.model.modelfile import dumps

from support.editor import EditorServer
from support.pages import js_fmt
from support.synthesis import candidate_curve, distance, traced

pytest.importorskip("starlette")
MODEL = ls.models_dir() / "thesis_crank_rocker_diagram.toml"


@pytest.fixture(scope="module")
def browser(chromium):
    with chromium(window=(1400, 950), script_timeout=60) as driver:
        yield driver


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    d = tmp_path_factory.mktemp("edit-browser")
    shutil.copy(MODEL, d / "fourbar.toml")
    return d


@pytest.fixture(scope="module")
def server(workdir):
    srv = EditorServer(workdir / "fourbar.toml", cwd=workdir)
    try:
        yield srv
    finally:
        srv.stop()


def version(driver) -> int:
    return int(driver.execute_script("return +(document.body.getAttribute('data-version') || 0)"))


def wait_version(driver, old: int, timeout: float = 600) -> int:
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        v = version(driver)
        if v > old:
            return v
        time.sleep(0.1)
    raise AssertionError(f"the page did not update: {driver.find_element('id', 'le-message').text}")


def no_errors(driver):
    """No error in the browser's log but the save protocol's 409 (the page then asks the user)."""
    errors = [e for e in driver.get_log("browser") if e["level"] in ("SEVERE", "WARNING")
              and not (e["source"] == "network" and "/api/save" in e["message"] and "409" in e["message"])]
    assert not errors, errors


def set_row(driver, row: int) -> None:
    driver.execute_script("var s = document.getElementById('loopsolve-input'); s.value = arguments[0];"
                          "s.dispatchEvent(new Event('input', {bubbles: true}));", row)


def screen_of(driver, x, y):
    """Viewport pixel coordinates of the model point (x, y) (the world group's screen transform)."""
    return driver.execute_script(
        "var w = document.getElementById('ls-world'), m = w.getScreenCTM(), p = w.ownerSVGElement.createSVGPoint();"
        "p.x = arguments[0]; p.y = arguments[1]; p = p.matrixTransform(m); return [p.x, p.y];", x, y)


def model_of(driver, px, py):
    return driver.execute_script(
        "var w = document.getElementById('ls-world'), m = w.getScreenCTM().inverse(), "
        "p = w.ownerSVGElement.createSVGPoint(); p.x = arguments[0]; p.y = arguments[1]; p = p.matrixTransform(m);"
        "return [p.x, p.y];", px, py)


def point_xy(driver, name):
    return driver.execute_script(
        "var c = document.querySelector('[data-point=\"' + arguments[0] + '\"]');"
        "return [+c.getAttribute('cx'), +c.getAttribute('cy')];", name)


def fourbar_pose(o2, o4, r2, r3, r4, th2_deg, side):
    """Closed form: B on the crank circle, C the intersection of the circles (B, r3) and (O4, r4) on ``side``
    (+1: left of B→O4)."""
    t = math.radians(th2_deg)
    b = np.array(o2, dtype=float) + r2 * np.array([math.cos(t), math.sin(t)])
    o4 = np.array(o4, dtype=float)
    d = float(np.linalg.norm(o4 - b))
    a = (r3 * r3 - r4 * r4 + d * d) / (2 * d)
    h = math.sqrt(max(r3 * r3 - a * a, 0.0))
    u = (o4 - b) / d
    n = np.array([-u[1], u[0]])
    return b, b + a * u + side * h * n


def test_editor_in_chromium(browser, server, workdir):
    d = browser
    d.get(server.url)
    wait_version(d, 0)
    no_errors(d)
    original = tomllib.loads(MODEL.read_text())
    # the page's hooks: draggable joints, points in model coordinates, the slider's value
    joints = d.execute_script("return Array.prototype.map.call(document.querySelectorAll('[data-joint]'),"
                              " function (c) { return c.getAttribute('data-joint'); })")
    assert sorted(joints) == ["B", "C", "O2", "O4"]
    at = {k: v["at"] for k, v in original["joints"].items()}
    r2 = math.dist(at["O2"], at["B"])
    r3 = math.dist(at["B"], at["C"])
    r4 = math.dist(at["C"], at["O4"])
    # the open mode: C left of B→O4 at the drawn pose
    u, v = np.subtract(at["O4"], at["B"]), np.subtract(at["C"], at["B"])
    side = 1 if u[0] * v[1] - u[1] * v[0] > 0 else -1

    # ---- the input slider and the values panel
    row = 30  # 60°: rows every 2° from 0
    set_row(d, row)
    assert float(d.find_element("id", "loopsolve-input").get_attribute("data-value")) == pytest.approx(60.0)
    b, c = fourbar_pose(at["O2"], at["O4"], r2, r3, r4, 60.0, side)
    assert point_xy(d, "C") == pytest.approx(list(c), abs=1e-8)
    cells = d.execute_script(
        "return Array.prototype.map.call(document.querySelectorAll('#ls-values tbody tr'), function (tr) {"
        " return Array.prototype.map.call(tr.querySelectorAll('td'), function (td, k) {"
        "  if (k === 0) return td.textContent; var v = td.querySelector('span'); return v ? v.textContent : null; }); });")
    th3 = math.degrees(math.atan2(c[1] - b[1], c[0] - b[0]))
    th4 = math.degrees(math.atan2(at["O4"][1] - c[1], at["O4"][0] - c[0]))  # rocker listed C, O4: C→O4
    assert cells[0][1] == "60"
    assert cells[1][1] == js_fmt(th3), cells[1]
    assert cells[2][1] == js_fmt(th4), cells[2]

    # ---- drag the ground pivot O4 with the pointer
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.support.ui import Select

    handle = d.find_element("css selector", '[data-joint="O4"]')
    sx, sy = screen_of(d, *at["O4"])
    dx, dy = 37, -23  # pixels: right and up
    want = model_of(d, sx + dx, sy + dy)  # where the pointer lets go, in the drawing's scale before the drag
    size_per_px = math.dist(model_of(d, 0, 0), model_of(d, 1, 0))
    old = version(d)
    ActionChains(d).move_to_element(handle).click_and_hold().move_by_offset(10, -5).move_by_offset(dx - 10, dy + 5) \
        .release().perform()
    wait_version(d, old)
    msg = d.find_element("id", "le-message").text
    assert "error" not in (d.find_element("id", "le-message").get_attribute("class") or ""), msg
    new = server.model()
    o4 = new["joints"]["O4"]["at"]
    assert math.dist(o4, want) < 3 * size_per_px + 1e-6, (o4, want)
    assert new["joints"]["O2"]["at"] == at["O2"]
    # B and C stayed where they were at 60°; the crank and coupler keep their lengths, the rocker and the ground change
    bn, cn = new["joints"]["B"]["at"], new["joints"]["C"]["at"]
    assert bn == pytest.approx(list(b), abs=1e-9) and cn == pytest.approx(list(c), abs=1e-9)
    status, body, _ = server.get("/api/state")
    dims = {x["name"]: x["value"] for x in body["analysis"]["dimensions"]}
    assert dims["r_ground_O4"] == pytest.approx(math.dist(at["O2"], o4), abs=1e-9)
    assert dims["r_crank"] == pytest.approx(r2, abs=1e-9)
    assert dims["r_coupler"] == pytest.approx(r3, abs=1e-9)
    r4n = math.dist(c, o4)
    assert dims["r_rocker"] == pytest.approx(r4n, abs=1e-9)
    # the re-solved positions: the closed form with the new lengths, the same side (mode kept)
    for row, th in ((0, 0.0), (45, 90.0), (100, 200.0), (150, 300.0)):
        set_row(d, row)
        assert float(d.find_element("id", "loopsolve-input").get_attribute("data-value")) == pytest.approx(th)
        bw, cw = fourbar_pose(at["O2"], o4, r2, r3, r4n, th, side)
        assert point_xy(d, "B") == pytest.approx(list(bw), abs=1e-8)
        assert point_xy(d, "C") == pytest.approx(list(cw), abs=1e-8), (row, th)
        handle_xy = d.execute_script("var c = document.querySelector('[data-joint=\"C\"]');"
                                     "return [+c.getAttribute('cx'), +c.getAttribute('cy')];")
        assert handle_xy == pytest.approx(list(cw), abs=1e-8)
    no_errors(d)

    # ---- draw a curve with the mouse and get a certified candidate
    d.find_element("css selector", '#le-panels [data-panel="synthesis"]').click()
    rows = list(range(0, 76, 5))  # C's path from 0° to 150°: an arc, drawn through the page's own points
    pts = []
    for r in rows:
        set_row(d, r)
        pts.append(point_xy(d, "C"))
    set_row(d, 0)
    screen = [screen_of(d, *p) for p in pts]
    d.find_element("id", "le-draw").click()
    diagram = d.find_element("id", "ls-diagram")
    rect = d.execute_script("var r = arguments[0].getBoundingClientRect(); return [r.left, r.top, r.width, r.height];",
                            diagram)
    cx0, cy0 = rect[0] + rect[2] / 2, rect[1] + rect[3] / 2
    chain = ActionChains(d).move_to_element_with_offset(diagram, int(round(screen[0][0] - cx0)),
                                                        int(round(screen[0][1] - cy0))).click_and_hold()
    last = [round(screen[0][0]), round(screen[0][1])]
    for p in screen[1:]:
        step = [round(p[0]) - last[0], round(p[1]) - last[1]]
        chain = chain.move_by_offset(*step)
        last = [last[0] + step[0], last[1] + step[1]]
    chain.release().perform()
    drawn = d.find_element("id", "le-synth-points").get_attribute("value").strip().splitlines()
    assert len(drawn) >= len(rows)
    # shape synthesis is the default for a drawn curve; this test picks the path method (points met in order, one
    # seeded run: no atlas to build in the user's cache — the shape method is tested through the server and in
    # test_synthpanel_shape.py with a small atlas)
    method = d.find_element("id", "le-synth-method")
    assert method.get_attribute("value") == "shape"
    assert d.find_element("id", "le-synth-closed").is_displayed()
    assert not d.find_element("id", "le-synth-n").is_displayed()
    Select(method).select_by_value("path")
    assert d.find_element("id", "le-synth-n").is_displayed()
    assert not d.find_element("id", "le-synth-closed").is_displayed()
    n = d.find_element("id", "le-synth-n")
    n.clear()
    n.send_keys("5")
    runs = d.find_element("id", "le-synth-runs")
    runs.clear()
    runs.send_keys("1")
    d.find_element("id", "le-synth-go").click()
    t0 = time.monotonic()
    while time.monotonic() - t0 < 1500:
        st = d.find_element("id", "le-synth-status").get_attribute("data-state")
        if st in ("done", "failed", "cancelled"):
            break
        time.sleep(0.5)
    assert st == "done", d.find_element("id", "le-synth-status").text
    cands = d.find_elements("css selector", "#le-candidates li.le-candidate")
    assert cands and "certified" in cands[0].text
    assert "defects" not in cands[0].text
    old = version(d)
    cands[0].find_element("css selector", "button[data-use]").click()
    wait_version(d, old)
    chosen = server.model()
    assert set(chosen["joints"]) == {"O2", "A", "B", "O4", "P"}
    # the candidate's coupler point passes through the drawn targets (traced here by loopsolve)
    targets = np.array([[float(v) for v in line.split(",")] for line in drawn])
    mech = ls.loads(dumps(chosen))
    sw = mech.sweep(0, 360, 0.25, progress=False)
    curve = np.column_stack([sw["P_x"], sw["P_y"]])
    span = float(np.ptp(targets, axis=0).max())
    for tpt in targets[[0, len(targets) // 2, -1]]:
        assert np.min(np.hypot(*(curve - tpt).T)) < 0.02 * span, tpt
    no_errors(d)

    # ---- undo returns to the dragged four-bar; save it and compare the file with the expected TOML
    old = version(d)
    d.find_element("id", "le-undo").click()
    wait_version(d, old)
    assert server.model() == new
    d.find_element("id", "le-save").click()
    WebDriverWait_dialog(d)
    assert "exists" in d.find_element("id", "le-dialog-text").text
    d.find_element("id", "le-dialog-ok").click()
    t0 = time.monotonic()
    while "saved" not in d.find_element("id", "le-message").text and time.monotonic() - t0 < 60:
        time.sleep(0.1)
    saved = (workdir / "fourbar.toml").read_text()
    expected = dict(original)
    expected["joints"] = {"O2": {"at": at["O2"]}, "B": {"at": list(b)}, "C": {"at": list(c)}, "O4": {"at": o4}}
    got = tomllib.loads(saved)
    assert {k: v for k, v in got.items() if k != "joints"} == {k: v for k, v in expected.items() if k != "joints"}
    for j in ("O2", "B", "C", "O4"):
        assert got["joints"][j]["at"] == pytest.approx(expected["joints"][j]["at"], abs=1e-9), j
    assert saved == dumps(got) == dumps(new)
    assert saved.startswith('name = "Crank-rocker four-bar (diagram)"\nunits = { length = "mm", angle = "deg" }\n\n'
                            "[joints]\nO2 = { at = [0, 0] }\nB = { at = [")
    assert "\n[links]\nground = [\"O2\", \"O4\"]\ncrank = [\"O2\", \"B\"]\ncoupler = [\"B\", \"C\"]\n" \
           "rocker = [\"C\", \"O4\"]\n\n[input]\njoint = \"O2\"\n" in saved
    # save as a new name through the dialog
    d.find_element("id", "le-saveas").click()
    WebDriverWait_dialog(d)
    box = d.find_element("id", "le-dialog-input")
    box.clear()
    box.send_keys("copy.toml")
    d.find_element("id", "le-dialog-ok").click()
    t0 = time.monotonic()
    while not (workdir / "copy.toml").exists() and time.monotonic() - t0 < 60:
        time.sleep(0.1)
    assert (workdir / "copy.toml").read_text() == saved

    # ---- the share link: this page's URL with the model in its fragment
    share = d.current_url
    assert "#model=" in share
    d.get("about:blank")
    d.get(share)
    wait_version(d, 0)
    assert server.model() == new
    other = EditorServer(None, cwd=workdir)  # another loopsolve edit (the template four-bar)
    try:
        assert other.model() != new
        d.get(other.url + "#" + share.split("#", 1)[1])
        wait_version(d, 0)
        assert other.model() == new
        assert float(d.find_element("id", "loopsolve-input").get_attribute("max")) > 100
    finally:
        other.stop()
    no_errors(d)


def WebDriverWait_dialog(d, timeout=60):
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        if d.execute_script("return !document.getElementById('le-dialog').hidden"):
            return
        time.sleep(0.1)
    raise AssertionError("no dialog")


def test_shape_synthesis_in_chromium(browser, workdir, tmp_path):
    """The panel's default method on pasted points of a closed coupler curve (a known four-bar's, turned and
    scaled): the first-use atlas build shows in the status line, the candidates are certified, and Use makes the
    first the edited mechanism, whose coupler curve (solved here) passes through every pasted point. A small
    default atlas in a fresh cache (LOOPSOLVE_ATLAS_SIZE, LOOPSOLVE_CACHE_DIR) keeps it quick."""
    pytest.importorskip("zarr", reason="atlases need zarr (the study extra)")
    shutil.copy(MODEL, workdir / "shape.toml")
    srv = EditorServer(workdir / "shape.toml", cwd=workdir,
                       env={"LOOPSOLVE_CACHE_DIR": str(tmp_path / "cache"), "LOOPSOLVE_ATLAS_SIZE": "4096"})
    try:
        d = browser
        d.get(srv.url)
        wait_version(d, 0)
        d.find_element("css selector", '#le-panels [data-panel="synthesis"]').click()
        targets = traced(1.2, 4.5, 3.8, 1.0, 2.5, stop=354, step=6, turn=-40, scale=12.0, shift=(30.0, 90.0))
        d.execute_script("var t = document.getElementById('le-synth-points'); t.value = arguments[0];"
                         "t.dispatchEvent(new Event('change', {bubbles: true}));",
                         "\n".join(f"{float(x)!r}, {float(y)!r}" for x, y in targets))
        assert d.find_element("id", "le-synth-method").get_attribute("value") == "shape"
        top = d.find_element("id", "le-synth-top")
        top.clear()
        top.send_keys("2")
        d.find_element("id", "le-synth-go").click()
        seen = set()
        t0 = time.monotonic()
        while time.monotonic() - t0 < 1500:
            status = d.find_element("id", "le-synth-status")
            st = status.get_attribute("data-state")
            seen.add(status.text)
            if st in ("done", "failed", "cancelled"):
                break
            assert st or time.monotonic() - t0 < 60, d.find_element("id", "le-message").text  # it never started
            time.sleep(0.2)
        assert st == "done", status.text
        assert any("building the default four-bar atlas" in t for t in seen), seen
        notes = [e.text for e in d.find_elements("css selector", "#le-candidates li.le-note")]
        assert any(n.startswith("closed curve") for n in notes), notes
        cands = d.find_elements("css selector", "#le-candidates li.le-candidate")
        assert 1 <= len(cands) <= 2 and all("certified" in c.text and "defects" not in c.text for c in cands)
        old = version(d)
        cands[0].find_element("css selector", "button[data-use]").click()
        wait_version(d, old)
        chosen = srv.model()
        assert set(chosen["joints"]) == {"O2", "A", "B", "O4", "P"}
        dist = distance(targets, candidate_curve(dumps(chosen), True))
        assert dist.max() < 5e-3 * float(np.ptp(targets, axis=0).max()), dist.max()
        no_errors(d)
    finally:
        srv.stop()
