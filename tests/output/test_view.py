"""The interactive page (DESIGN.md, "Interactive page"): ``loopsolve view`` and ``Sweep.to_html``.

The page is opened from a ``file://`` URL in headless Chromium (Debian's ``chromium`` and
``chromium-driver``, driven by selenium) with the network switched off; the browser's log must
hold no error and its network log no request other than the page itself. Moving the
``#loopsolve-input`` slider (value + ``input`` event, as a user's hand does) must put every
``[data-point]`` circle at that row's coordinates of the sweep, and a screenshot must show a
picture. One browser serves the whole module. Without chromium/chromedriver the browser tests
skip, unless ``LOOPSOLVE_REQUIRE_BROWSER`` is set (CI), when they fail.
"""

from __future__ import annotations

import io
import json
import math
import os
import re
import subprocess
import sys

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.cli import _sweep_for, build_parser
from loopsolve.errors import ModelError
from loopsolve.output.view import page_data, to_html

from support.pages import cli_sweep, open_page

MODELS = sorted(ls.models_dir().glob("*.toml"))


_SWEEPS: dict = {}


def sweep_of(path):
    if path not in _SWEEPS:
        _SWEEPS[path] = cli_sweep(path)
    return _SWEEPS[path]


# ------------------------------------------------------------------------------ the page as text
@pytest.mark.parametrize("model, vars", [("crank_shaper", ["theta_lever", "E"]), ("quick_return", ["s"])])
def test_cli_page_equals_to_html(tmp_path, model, vars):
    """``loopsolve view`` (a separate process, another hash seed) writes exactly ``sweep.to_html()``.

    The drawing code lists some shapes in set order, which differs between processes; the page
    must not (a diagram model and a vector-loop model with a slotted lever).
    """
    path = ls.models_dir() / f"{model}.toml"
    out = tmp_path / "page.html"
    env = dict(os.environ, PYTHONHASHSEED="12345")
    env.pop("LOOPSOLVE_DEBUG", None)
    proc = subprocess.run([sys.executable, "-m", "loopsolve.cli", "view", str(path), "--from", "0", "--to", "360",
                           "--step", "15", "--vars", *vars, "-q", "-o", str(out)],
                          capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.strip() == f"wrote {out}"
    sw = ls.load(path).sweep("0", "360", "15")  # as the command line passes them (15 and "15" round differently)
    assert out.read_text(encoding="utf-8") == sw.to_html(vars)


def test_cli_default_range_page_equals_to_html(tmp_path):
    """A through-limits model with the default range: the in-process CLI writes the same bytes."""
    from loopsolve.cli import main

    path = ls.models_dir() / "double_rocker.toml"
    out = tmp_path / "rocker.html"
    assert main(["view", str(path), "--step", "10", "-q", "-o", str(out)]) == 0
    assert out.read_text(encoding="utf-8") == sweep_of(path).to_html()


def test_page_is_self_contained_and_deterministic():
    sw = sweep_of(ls.models_dir() / "thesis_crank_rocker.toml")
    page = sw.to_html()
    assert page == sw.to_html()
    # no external resource of any kind: no src/href attributes, no <link>, url() only of the page's own fragments
    assert not re.search(r"""\b(src|href|srcset|xlink:href)\s*=""", page, re.I)
    assert "<link" not in page.lower() and "@import" not in page
    assert all(u.startswith("#") for u in re.findall(r"url\(([^)]*)\)", page))  # fragments of the page only
    assert page.count('<input type="range" id="loopsolve-input"') == 1
    n = len(sw)
    assert f'min="0" max="{n - 1}"' in page


def test_page_data_contents():
    """Series against the input, the events at the rows where the input is nearest, modes per row."""
    sw = sweep_of(ls.models_dir() / "double_rocker.toml")
    data = page_data(sw)
    assert [s["name"] for s in data["series"]] == ["theta3", "theta4"]
    assert data["rows"] == len(sw)
    x = sw["theta2"]
    kinds = [e["kind"] for e in data["events"]]
    assert "limit" in kinds and data["modes"]["changes"]
    for ev in data["events"]:
        assert abs(x[ev["row"]] - ev["input"]) <= np.nanmin(np.abs(x - ev["input"])) + 10.0
    # modes: runs cover every row once, with the sweep's signature
    runs = data["modes"]["runs"]
    covered = [i for a, b, _ in runs for i in range(a, b + 1)]
    assert covered == list(range(len(sw)))
    assert all(sw.modes[i] == m for a, b, m in runs for i in range(a, b + 1))
    # θ3 is plotted and read out as the table gives it (continuous along the rows): no re-wrapping
    th3 = np.array(data["series"][0]["q"][0], dtype=float)
    assert np.allclose(th3, sw["theta3"], atol=1e-8)
    assert data["series"][0]["wrap"] == 0


def test_extra_series_and_errors():
    sw = sweep_of(ls.models_dir() / "thesis_crank_rocker.toml")
    tau = np.cos(np.radians(sw["theta2"]))
    data = page_data(sw, ["C"], extra_series={"input_torque [N*m]": tau})
    assert [s["name"] for s in data["series"]] == ["C_x", "C_y"]
    assert data["extra"][0]["name"] == "input_torque" and data["extra"][0]["unit"] == "N·m"
    assert np.allclose(data["extra"][0]["q"][0], tau)
    with pytest.raises(ModelError, match="input_torque.*rows"):
        to_html(sw, extra_series={"input_torque [N*m]": tau[:-1]})
    with pytest.raises(ModelError, match="cannot plot 'nope'"):
        sw.to_html(["nope"])
    with pytest.raises(ModelError, match="empty sweep"):
        ls.Sweep(sw.compiled).to_html()


def test_models_with_bodies_plot_the_driving_torque(tmp_path):
    """With [bodies] the page carries the driving torque of the force analysis, row by row."""
    mech = ls.load(ls.models_dir() / "thesis_crank_rocker_dynamics.toml")
    sw = mech.sweep(0, 360, 30)
    extra = page_data(sw)["extra"]
    assert [(e["name"], e["unit"]) for e in extra] == [("input_torque", "N·m")]
    assert np.allclose(extra[0]["q"][0], ls.forces(mech, 0, 360, 30).drive, rtol=1e-10, atol=0)  # 12 digits
    assert page_data(sw, extra_series={})["extra"] == []          # opt out
    assert page_data(sweep_of(ls.models_dir() / "thesis_crank_rocker.toml"))["extra"] == []  # no bodies: none
    out = tmp_path / "dyn.html"
    args = build_parser().parse_args(["view", str(ls.models_dir() / "thesis_crank_rocker_dynamics.toml"),
                                      "--from", "0", "--to", "360", "--step", "30", "-q", "-o", str(out)])
    same = mech.sweep("0", "360", "30")  # the command line passes strings (see test_cli_page_equals_to_html)
    assert to_html(_sweep_for(args)) == to_html(same) and "input_torque" in to_html(same)


def test_cli_errors(tmp_path):
    from loopsolve.cli import main

    path = ls.models_dir() / "thesis_crank_rocker.toml"
    assert main(["view", str(path), "-q", "-o", str(tmp_path / "page.png")]) == 2
    assert not (tmp_path / "page.png").exists()
    assert main(["view", str(path), "-q", "--vars", "nope", "-o", str(tmp_path / "p.html")]) == 2


def test_view_and_repr_html(tmp_path):
    sw = sweep_of(ls.models_dir() / "example1_slider_crank.toml")
    page = sw.view()
    assert page.html == sw.to_html()
    frame = page._repr_html_()
    assert frame.startswith("<iframe srcdoc=\"") and 'sandbox="allow-scripts"' in frame
    assert "<script" not in frame  # the page is escaped inside the attribute
    assert sw._repr_html_() == frame
    assert ls.Sweep(sw.compiled)._repr_html_() is None  # an empty sweep shows as text
    out = page.save(tmp_path / "slider.html")
    assert out.read_text(encoding="utf-8") == page.html
    with pytest.raises(ModelError, match=r"\.html"):
        page.save(tmp_path / "slider.txt")


# ------------------------------------------------------------------------------ in a browser
@pytest.fixture(scope="module")
def browser(chromium):
    with chromium(window=(1280, 860), offline=True, performance=True) as driver:
        yield driver


def _requests(driver) -> list[str]:
    urls = []
    for entry in driver.get_log("performance"):
        msg = json.loads(entry["message"])["message"]
        if msg.get("method") == "Network.requestWillBeSent":
            urls.append(msg["params"]["request"]["url"])
    return urls


_POINTS_JS = """
var s = document.getElementById('loopsolve-input');
s.value = arguments[0];
s.dispatchEvent(new Event('input', {bubbles: true}));
return [s.value, Array.prototype.map.call(document.querySelectorAll('[data-point]'), function (e) {
  return [e.getAttribute('data-point'), e.getAttribute('cx'), e.getAttribute('cy'),
          e.getAttribute('visibility'), e.ownerSVGElement !== null];
})];
"""


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_page_in_browser(browser, tmp_path, path):
    sw = sweep_of(path)
    page = tmp_path / f"{path.stem}.html"
    page.write_text(sw.to_html(), encoding="utf-8")
    open_page(browser, page)
    assert _requests(browser) == [page.as_uri()]
    n = len(sw)
    names = sw.compiled.points
    assert browser.execute_script("var s = document.getElementById('loopsolve-input'); "
                                  "return [s.type, s.min, s.max, s.value]") == ["range", "0", str(n - 1), "0"]
    for r in sorted({0, n // 3, (2 * n) // 3, n - 1}):
        value, found = browser.execute_script(_POINTS_JS, r)
        assert value == str(r)
        assert sorted(f[0] for f in found) == sorted(names)
        for name, cx, cy, visibility, in_svg in found:
            assert in_svg
            x, y = sw[f"{name}_x"][r], sw[f"{name}_y"][r]
            if not (math.isfinite(x) and math.isfinite(y)):
                assert visibility == "hidden"
                continue
            assert visibility != "hidden"
            assert abs(float(cx) - x) <= 1e-6 and abs(float(cy) - y) <= 1e-6, (name, r, cx, cy, x, y)
    # the y-up flip is a parent transform: a point higher in the model is higher on the screen
    flips = browser.execute_script("var g = document.querySelector('[data-point]').parentNode;"
                                   "while (g && !(g.getAttribute && g.getAttribute('transform'))) g = g.parentNode;"
                                   "return g ? g.getAttribute('transform') : null")
    assert flips == "scale(1,-1)"
    from PIL import Image

    shot = Image.open(io.BytesIO(browser.get_screenshot_as_png())).convert("RGB")
    rect = browser.execute_script("var r = document.getElementById('ls-diagram').getBoundingClientRect();"
                                  "return [r.left, r.top, r.right, r.bottom, window.devicePixelRatio]")
    k = rect[4]
    diagram = shot.crop(tuple(int(v * k) for v in rect[:4]))
    assert diagram.width > 200 and diagram.height > 200
    colours = diagram.getcolors(maxcolors=1 << 20)
    assert len(colours) >= 12, "the diagram is blank"
    # more than the background: at least 3 % of the diagram's pixels are drawn
    background = max(colours)[0]
    assert 1 - background / (diagram.width * diagram.height) > 0.03
    errors = [e for e in browser.get_log("browser") if e["level"] in ("SEVERE", "WARNING")]
    assert not errors, errors
    assert _requests(browser) == []


def test_keyboard_and_play(browser, tmp_path):
    """Arrow keys step the rows; play moves the slider by itself; the plots follow."""
    from selenium.webdriver.common.by import By
    from selenium.webdriver.common.keys import Keys

    sw = sweep_of(ls.models_dir() / "double_rocker.toml")
    page = tmp_path / "rocker.html"
    page.write_text(sw.to_html(extra_series={"input_torque [N*m]": np.sin(np.radians(sw["theta2"]))}),
                    encoding="utf-8")
    open_page(browser, page)
    body = browser.find_element(By.TAG_NAME, "body")
    body.send_keys(Keys.ARROW_RIGHT, Keys.ARROW_RIGHT, Keys.ARROW_RIGHT)
    assert browser.execute_script("return document.getElementById('loopsolve-input').value") == "3"
    body.send_keys(Keys.END)
    assert browser.execute_script("return document.getElementById('loopsolve-input').value") == str(len(sw) - 1)
    # the sweep went around its limit onto the other mode: the page says which mode this row is on
    last = sw.modes[-1]
    alias = {v: k for k, v in sw.mechanism.mode_aliases.items()}[last]
    assert last != sw.modes[0]
    assert f"mode {last} ({alias})" in browser.execute_script("return document.getElementById('ls-status').textContent")
    assert browser.execute_script("return document.querySelectorAll('#ls-marks rect').length") == 2  # mode band
    body.send_keys(Keys.HOME)
    # two panels: the two angles share one (same unit), the extra series has its own
    assert browser.execute_script("return document.querySelectorAll('.ls-panel').length") == 2
    assert "input torque" in browser.execute_script("return document.getElementById('ls-values').textContent")
    # events are marked on the slider (one mark per event)
    assert browser.execute_script("return document.querySelectorAll('#ls-marks path').length") == len(sw.events)
    browser.find_element(By.ID, "ls-play").click()
    browser.set_script_timeout(5)
    moved = browser.execute_async_script(
        "var done = arguments[arguments.length - 1], s = document.getElementById('loopsolve-input');"
        "setTimeout(function () { done(s.value); }, 700);")
    assert int(moved) > 0
    browser.find_element(By.ID, "ls-play").click()
    errors = [e for e in browser.get_log("browser") if e["level"] in ("SEVERE", "WARNING")]
    assert not errors, errors


def test_three_thousand_rows_in_browser(browser, tmp_path):
    """A dense sweep (3001 rows): the page stays small and every row is reachable."""
    sw = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").sweep(0, 360, 0.12)
    assert len(sw) == 3001
    text = sw.to_html()
    assert len(text.encode()) < 1_500_000  # about 180 bytes a row
    page = tmp_path / "dense.html"
    page.write_text(text, encoding="utf-8")
    open_page(browser, page)
    for r in (1, 1500, 2999, 3000):
        value, found = browser.execute_script(_POINTS_JS, r)
        assert value == str(r)
        for name, cx, cy, _, _ in found:
            assert abs(float(cx) - sw[f"{name}_x"][r]) <= 1e-6 and abs(float(cy) - sw[f"{name}_y"][r]) <= 1e-6
    errors = [e for e in browser.get_log("browser") if e["level"] in ("SEVERE", "WARNING")]
    assert not errors, errors


def test_the_slider_guide_axis_spans_the_slider_travel(tmp_path):
    """The page draws a slider's guide axis along the line of sliding over the whole travel:
    example 1's slider C moves on the x axis between r3 − r2 = 3 in and r2 + r3 = 13 in (the
    crank at 180° and 0°). Written for loopsolve.output.view.x__scene__mutmut_204 (the axis
    drawn from ref + d·lo to ref − d·hi, i.e. pointing the wrong way past the pivot)."""
    from loopsolve.output.view import _scene

    sw = ls.load(ls.models_dir() / "example1_slider_crank.toml").sweep(0, 360, 30)
    (axis,) = [s["p"] for s in _scene(sw)["static"] if s["c"] == "axis"]
    x0, y0, x1, y1 = axis
    assert y0 == pytest.approx(0, abs=1e-12) and y1 == pytest.approx(0, abs=1e-12)
    assert min(x0, x1) <= 3 and max(x0, x1) >= 13


def test_write_html_returns_the_path_it_wrote(tmp_path):
    """``write_html`` returns the file it wrote, holding the page ``to_html`` gives (the doctest shows
    it; this is the test mutmut's test selection sees: loopsolve.output.view.x_write_html__mutmut_17)."""
    from loopsolve.output.view import write_html

    sw = ls.load(ls.models_dir() / "example1_slider_crank.toml").sweep(0, 360, 90)
    target = tmp_path / "slider.html"
    out = write_html(sw, target)
    assert out == target and out.read_text(encoding="utf-8") == to_html(sw)
