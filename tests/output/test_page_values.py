"""The page's numbers against the sweep, exactly (issue 18, rows 10–12).

- ``page_data``: every series' position, velocity and acceleration, the input's rows and the
  extra (driving torque) series are the sweep's columns row for row (the page keeps 12
  significant digits); each event is marked at the first row, from the previous event's row
  on, whose input is nearest the event's (the hand-made cases name the row);
- in headless Chromium: after moving the slider to a row, the values table shows that row's
  numbers as the page formats them (6 significant digits, written out here after
  ``Number.prototype.toFixed``/``toExponential``), the velocity and acceleration tabs plot the
  velocity and the acceleration (each drawn path is an affine image of its column, and not of
  the other one), and the status line names exactly the events marked at that row.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.output.view import page_data

from support.pages import js_fmt


def page_number(v):
    """A number as the page stores it: 12 significant digits, None for NaN."""
    v = float(v)
    return None if not math.isfinite(v) else float(format(v, ".12g"))


def test_js_fmt_examples():
    assert [js_fmt(v) for v in (90.0, -177.2817, 1.0471975511965976, 0.5, 1234567.0, 3.2e-5, -0.00012345678)] == \
        ["90", "-177.282", "1.0472", "0.5", "1.2346e6", "3.2000e-5", "-0.000123457"]


def expected_event_rows(x, events):
    """For each event (in order): the first row, from the previous event's row on, at the least
    distance |x − input| (rows without an input value are skipped)."""
    rows, start = [], 0
    for ev in events:
        d = [abs(x[i] - ev.input) if math.isfinite(x[i]) else math.inf for i in range(start, len(x))]
        best = min(d)
        row = start + next(i for i, v in enumerate(d) if v <= best + 1e-9 * max(1.0, abs(ev.input)))
        rows.append(row)
        start = row
    return rows


# ------------------------------------------------------------------------------ page_data
PAGES = [("thesis_crank_rocker_dynamics", (0, 360, 15), False),
         ("quick_return", (0, 360, 20), False),
         ("double_rocker", (60, 180, 10), True),
         ("double_rocker", (30, 80, 7), True)]


def sweep_of(model, rng, through):
    return ls.load(ls.models_dir() / f"{model}.toml").sweep(*rng, through_limits=through)


@pytest.mark.parametrize("model, rng, through", PAGES)
def test_page_data_series_are_the_sweep_columns(model, rng, through):
    sw = sweep_of(model, rng, through)
    data = page_data(sw)
    inp = sw.compiled.inputs[0]
    assert data["input"]["x"] == [page_number(v) for v in sw[inp]]
    assert data["input"]["vel"] == [page_number(v) for v in sw[inp + "_vel"]]
    assert data["input"]["acc"] == [page_number(v) for v in sw[inp + "_acc"]]
    assert data["series"]
    for s in data["series"]:
        name = s["name"]
        vel, acc = [page_number(v) for v in sw[name + "_vel"]], [page_number(v) for v in sw[name + "_acc"]]
        assert s["q"][1] == vel, name  # the velocity, not the acceleration
        assert s["q"][2] == acc, name
        assert vel != acc
        pos = np.array(s["q"][0], dtype=float)
        if s["wrap"]:  # angles are drawn continuously: the same angle modulo a turn
            assert np.allclose(np.mod(pos - sw[name] + 180, 360) - 180, 0, atol=1e-9), name
        else:
            assert s["q"][0] == [page_number(v) for v in sw[name]], name
    if model.endswith("dynamics"):
        drive = ls.forces(sw.mechanism, *rng).drive
        assert [e["name"] for e in data["extra"]] == ["input_torque"]
        np.testing.assert_allclose(data["extra"][0]["q"][0], drive, rtol=1e-11, atol=0)


def test_event_rows_hand_cases():
    """The double rocker from 60° by 10° through its limit at 71.79°: rows 60, 70, 70, 60, ...
    (the second 70 on the other branch): the limit and the mode change belong to row 1 (70°,
    the last row before the limit); from 30° by 7° (30, 37, ... 65, 65, ...) to row 5 (65°)."""
    for rng, x_at in (((60, 180, 10), 70.0), ((30, 80, 7), 65.0)):
        sw = sweep_of("double_rocker", rng, True)
        x = sw["theta2"]
        data = page_data(sw)
        kinds = [(e["kind"], e["row"]) for e in data["events"]]
        limit_rows = [r for k, r in kinds if k == "limit" and abs(x[r] - x_at) < 1e-9]
        assert limit_rows, (kinds, x[:8])
        first = limit_rows[0]
        assert x[first] == pytest.approx(x_at) and x[first + 1] == pytest.approx(x_at)
        assert first == int(np.flatnonzero(np.isclose(x, x_at))[0])  # the first of the two rows
        assert sw.modes[first] != sw.modes[first + 1]
        assert ("mode-change", first) in kinds


@pytest.mark.parametrize("model, rng, through", PAGES)
def test_event_rows_are_the_nearest_rows(model, rng, through):
    sw = sweep_of(model, rng, through)
    x = sw[sw.compiled.inputs[0]]
    data = page_data(sw)
    assert [e["row"] for e in data["events"]] == expected_event_rows(x, sw.events)
    assert [(e["kind"], e["input"]) for e in data["events"]] == [(e.kind.value, page_number(e.input))
                                                                  for e in sw.events]


# ------------------------------------------------------------------------------ in a browser
@pytest.fixture(scope="module")
def browser(chromium):
    with chromium(window=(1280, 860)) as driver:
        yield driver


def _open(driver, sw, tmp_path, name):
    page = tmp_path / f"{name}.html"
    page.write_text(sw.to_html(), encoding="utf-8")
    driver.get_log("browser")
    driver.get(page.as_uri())
    assert driver.execute_script("return document.readyState") == "complete"
    errors = [e for e in driver.get_log("browser") if e["level"] in ("SEVERE", "WARNING")]
    assert not errors, errors


def test_js_fmt_matches_the_browsers_number_formatting(browser):
    """The rounding of toFixed/toExponential (ties away from zero on the exact binary value)."""
    rng = np.random.default_rng(7)
    values = np.concatenate([rng.normal(0, 1, 150) * 10.0 ** rng.integers(-6, 8, 150), [0.125, 2.5, -1e-5, 999999.5]])
    got = browser.execute_script(
        "return arguments[0].map(function (v) { var a = Math.abs(v);"
        " if (a >= 1e6 || a < 1e-4) return v.toExponential(4).replace('e+', 'e');"
        " var s = v.toFixed(Math.max(0, 5 - Math.floor(Math.log10(a))));"
        " return s.indexOf('.') >= 0 ? s.replace(/0+$/, '').replace(/\\.$/, '') : s; });", values.tolist())
    assert got == [js_fmt(float(v)) for v in values]


_TABLE_AT_ROW_JS = """
var s = document.getElementById('loopsolve-input');
s.value = arguments[0];
s.dispatchEvent(new Event('input', {bubbles: true}));
var rows = document.querySelectorAll('#ls-values tbody tr');
return [document.getElementById('ls-status').textContent,
  Array.prototype.map.call(rows, function (tr) {
    return Array.prototype.map.call(tr.querySelectorAll('td'), function (td, k) {
      if (k === 0) return td.textContent;
      var v = td.querySelector('span');
      return v ? v.textContent : null;
    });
  })];
"""


@pytest.mark.parametrize("model, rng, through", [PAGES[0], PAGES[2]], ids=["crank_rocker_dyn", "double_rocker"])
def test_values_table_and_status_in_browser(browser, tmp_path, model, rng, through):
    sw = sweep_of(model, rng, through)
    data = page_data(sw)
    inp = sw.compiled.inputs[0]
    x = sw[inp]
    _open(browser, sw, tmp_path, model)
    extra = {e["name"]: e["q"][0] for e in data["extra"]}
    event_rows = expected_event_rows(x, sw.events)
    for r in range(len(sw)):
        status, table = browser.execute_script(_TABLE_AT_ROW_JS, r)
        # the input row
        assert table[0][1:] == [js_fmt(page_number(sw[inp + s][r])) for s in ("", "_vel", "_acc")], (r, table[0])
        body = table[1:1 + len(data["series"])]
        for s, cells in zip(data["series"], body):
            name = s["name"]
            assert cells[2:] == [js_fmt(page_number(sw[name + "_vel"][r])), js_fmt(page_number(sw[name + "_acc"][r]))], \
                (r, name, cells)
            shown = float(cells[1])
            want = sw[name][r]
            if s["wrap"]:  # an angle: the same modulo a turn, to the 6 digits shown
                assert abs((shown - want + 180) % 360 - 180) <= 5e-6 * max(1.0, abs(want)), (r, name, shown, want)
            else:
                assert cells[1] == js_fmt(page_number(want)), (r, name, cells)
        for cells in table[1 + len(data["series"]):]:
            label = re.sub(r"\s+", "", cells[0])
            for name, q in extra.items():
                if label == name.replace("_", ""):  # "input torque" is printed with a subscript
                    assert cells[1] == js_fmt(q[r]), (r, name, cells)
        # the status line names exactly the events of this row ("limit", "mode-change")
        kinds = sorted(ev.kind.value for ev, er in zip(sw.events, event_rows) if er == r)
        tail = status.split("·")[-1].strip() if kinds else ""
        if kinds:
            assert sorted(k.strip() for k in tail.split(",")) == kinds, (r, status)
        else:
            assert not any(k in status for k in ("limit", "mode-change", "singular", "not-assemblable")), (r, status)
    if sw.events:
        listed = browser.execute_script(
            "return Array.prototype.map.call(document.querySelectorAll('#ls-events li'), function (li) {"
            " return li.textContent; })")
        assert [int(re.search(r"\(row (\d+)\)", t).group(1)) - 1 for t in listed] == event_rows


_PATHS_JS = """
var tab = document.querySelectorAll('#ls-tabs button')[arguments[0]];
tab.click();
var p = document.querySelector('.ls-panel');
return [p.querySelector('.ls-title').textContent,
        Array.prototype.map.call(p.querySelectorAll('g[clip-path] path'), function (e) { return e.getAttribute('d'); })];
"""


def _affine_residual(px, values):
    """Largest residual (pixels) of the best affine fit px ≈ a + b·values."""
    A = np.column_stack([np.ones_like(values), values])
    coef, *_ = np.linalg.lstsq(A, px, rcond=None)
    return float(np.max(np.abs(A @ coef - px))), coef


def test_velocity_and_acceleration_tabs_plot_their_columns(browser, tmp_path):
    sw = sweep_of("thesis_crank_rocker_dynamics", (0, 360, 15), False)
    data = page_data(sw)
    names = [s["name"] for s in data["series"]]
    _open(browser, sw, tmp_path, "tabs")
    x = sw["theta2"]
    for tab, (suffix, other, word) in enumerate([("", None, "angle"), ("_vel", "_acc", "velocity"),
                                                 ("_acc", "_vel", "acceleration")]):
        title, paths = browser.execute_script(_PATHS_JS, tab)
        assert word in title, title
        assert len(paths) == len(names)
        for name, d in zip(names, paths):
            pts = np.array([[float(a), float(b)] for a, b in re.findall(r"[ML]([-\d.]+) ([-\d.]+)", d)])
            assert len(pts) == len(sw)
            res_x, cx = _affine_residual(pts[:, 0], x)
            assert res_x < 0.02 and cx[1] > 0
            want = sw[name + suffix] if suffix else data["series"][names.index(name)]["q"][0]
            res, c = _affine_residual(pts[:, 1], np.asarray(want, dtype=float))
            assert res < 0.02 and c[1] < 0, (name, suffix, res)  # y grows downwards on the screen
            if other:
                wrong, _ = _affine_residual(pts[:, 1], sw[name + other])
                assert wrong > 1.0, (name, suffix)  # the other quantity does not fit


@pytest.mark.parametrize("model, rng, through, runs", [("thesis_crank_rocker_dynamics", (0, 360, 15), False, 1),
                                                        ("double_rocker", (60, 180, 10), True, 2)])
def test_mode_band_only_when_the_mode_changes(browser, tmp_path, model, rng, through, runs):
    """The slider's mode band (one coloured run per mode) is drawn only for a sweep that changes mode."""
    sw = sweep_of(model, rng, through)
    data = page_data(sw)
    changes = sum(1 for i in range(1, len(sw)) if sw.modes[i] != sw.modes[i - 1])
    assert len(data["modes"]["runs"]) == runs == changes + 1
    assert data["modes"]["changes"] is (changes > 0)
    _open(browser, sw, tmp_path, f"band-{model}")
    rects = browser.execute_script("return document.querySelectorAll('#ls-marks rect').length")
    assert rects == (runs if changes else 0)
