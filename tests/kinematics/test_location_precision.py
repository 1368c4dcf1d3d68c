"""Limits and change points are located as precisely as the docs promise.

docs/reference/limitations.md and docs/howto/limit_positions.md: a sweep that reaches a limit position stops there "located to 1e-9 in the input", and
"change points are located to about 1e-8 in the input". The expected positions are written here in
closed form: toggle positions from the law of cosines (the coupler and the output link, or the crank
and the rod, in line), change points of Grashof linkages with S + L = P + Q (every pivot in line).
Both the Python sweep (``mech.sweep``: ``events`` with ``kind`` and ``input``) and the command line's
JSON events are checked, with the tracked and the batched methods.
"""

from __future__ import annotations

import json
import math

import pytest

import loopsolve as ls
from loopsolve.cli import main

#: every test here runs with the pure-Python tracer and with the compiled fast lane (conftest.py)
pytestmark = pytest.mark.usefixtures("both_engines")

LIMIT_TOL = 1e-9  # in the input's display unit (degrees, or the model's length unit)
CHANGE_TOL = 5e-8  # "about 1e-8": measured 2e-8..3e-8 on the batched path


def fourbar_toggles(r1, r2, r3, r4):
    """Crank angles [deg, in [0, 360)] where B is r3 + r4 or |r3 - r4| from O4 (law of cosines)."""
    out = []
    for d in (r3 + r4, abs(r3 - r4)):
        c = (r1 * r1 + r2 * r2 - d * d) / (2 * r1 * r2)
        if -1 < c < 1:
            a = math.degrees(math.acos(c))
            out += [a, 360 - a]
    return sorted(out)


def slider_crank_crank_toggles(r2, r3, e):
    """Crank angles [deg, in [0, 360)] where the rod is perpendicular to the line of sliding:
    r2·sin(theta2) - e = ±r3 (crank longer than the rod, so the crank cannot turn fully)."""
    out = []
    for s in (1, -1):
        v = (e + s * r3) / r2
        if -1 < v < 1:
            a = math.degrees(math.asin(v))
            out += [a % 360, (180 - a) % 360]
    return sorted(out)


def slider_position_toggles(r2, r3, e):
    """Slider positions where crank and rod are in line: x = ±sqrt((r3 ± r2)² - e²)."""
    return sorted({s * math.sqrt((r3 + k * r2) ** 2 - e * e) for s in (1, -1) for k in (1, -1)})


def events(sw, kind):
    return [e.input for e in sw.events if e.kind.value == kind]


def assert_located(found, expected, tol, *, period=None):
    assert found, "no event"
    for x in found:
        errs = [abs(math.remainder(x - e, period)) if period else abs(x - e) for e in expected]
        assert min(errs) <= tol, f"event at {x!r}: nearest closed form off by {min(errs):.3g} (> {tol:g})"


# ----------------------------------------------------------------------------- limits (toggle positions)

TRIPLE_ROCKERS = [  # non-Grashof four-bars (S + L > P + Q): the crank rocks between two toggles
    (4, 3, 3.5, 5, 300),
    (6, 4, 3, 4.5, 0),
    (7, 3, 4, 4.5, 0),
]


@pytest.mark.parametrize("method", ["tracked", "batched"])
@pytest.mark.parametrize("r1, r2, r3, r4, start", TRIPLE_ROCKERS)
def test_fourbar_limit_is_the_toggle_to_1e_9(r1, r2, r3, r4, start, method):
    mech = ls.fourbar(r1, r2, r3, r4, theta2=start)
    toggles = fourbar_toggles(r1, r2, r3, r4)
    for stop in (start + 359, start - 359):
        sw = mech.sweep(start, stop, 1, method=method, progress=False)  # the direction is from start to stop
        assert_located(events(sw, "limit"), toggles, LIMIT_TOL, period=360)


@pytest.mark.parametrize("method", ["tracked", "batched"])
@pytest.mark.parametrize("r1, r2, r3, r4, start", TRIPLE_ROCKERS[:2])
def test_through_limits_every_fold_is_a_toggle(r1, r2, r3, r4, start, method):
    mech = ls.fourbar(r1, r2, r3, r4, theta2=start)
    sw = mech.sweep(start, start + 720, 5, through_limits=True, method=method, progress=False)
    found = events(sw, "limit")
    assert len(found) >= 2
    assert_located(found, fourbar_toggles(r1, r2, r3, r4), LIMIT_TOL, period=360)


CRANK_LONGER = [(5, 3, 0.0), (6, 4, 1.0), (4, 3.5, -0.3)]


@pytest.mark.parametrize("r2, r3, e", CRANK_LONGER)
def test_slider_crank_crank_toggle_located_to_1e_9(r2, r3, e):
    """Crank longer than the rod: the crank rocks between the positions where the rod is vertical.
    The sweep stops at that position (whatever the event is called: see the next test)."""
    t0 = math.degrees(math.asin(e / r2))  # rod horizontal: certainly assemblable
    mech = ls.slider_crank(r2, r3, offset=e, theta2=t0)
    toggles = slider_crank_crank_toggles(r2, r3, e)
    for stop in (t0 + 179, t0 - 179):
        sw = mech.sweep(t0, stop, 1, progress=False)
        assert_located([ev.input for ev in sw.events], toggles, LIMIT_TOL, period=360)


@pytest.mark.parametrize("r2, r3, e", CRANK_LONGER[:1])
def test_slider_crank_crank_toggle_is_a_limit(r2, r3, e):
    mech = ls.slider_crank(r2, r3, offset=e, theta2=0)
    sw = mech.sweep(0, 179, 1, progress=False)
    assert [ev.kind.value for ev in sw.events] == ["limit"]


@pytest.mark.parametrize("r2, r3, e", [(3, 8, 0.0), (2, 5, 1.0), (4.8, 16, 1.0)])
def test_slider_driven_limit_to_1e_9(r2, r3, e):
    """Driving the slider: it stops where crank and rod are in line, x = sqrt((r3 ± r2)² - e²)."""
    mech = ls.slider_crank(r2, r3, offset=e, theta2=30)
    x0 = mech.solve(30)["x"]
    toggles = slider_position_toggles(r2, r3, e)
    for stop in (toggles[-1] + 1, toggles[2] - 1):
        step = abs(stop - x0) / 20
        sw = mech.sweep(x0, stop, step, input="x", progress=False)
        assert_located(events(sw, "limit"), toggles, LIMIT_TOL)


def test_cli_json_limit_events_to_1e_9(tmp_path, capsys):
    path = tmp_path / "tr.toml"
    path.write_text(ls.dumps(ls.fourbar(6, 4, 3, 4.5, theta2=0)))
    toggles = fourbar_toggles(6, 4, 3, 4.5)
    for method in ("tracked", "batched"):
        assert main(["sweep", str(path), "--from", "0", "--to", "360", "--step", "2", "--through-limits",
                     "--method", method, "-q", "--format", "json"]) == 0
        doc = json.loads(capsys.readouterr().out)
        found = [e["input"] for e in doc["events"] if e["kind"] == "limit"]
        assert len(found) >= 2
        assert_located(found, toggles, LIMIT_TOL, period=360)


def test_cli_json_slider_limit_to_1e_9(tmp_path, capsys):
    path = tmp_path / "sc.toml"
    path.write_text(ls.dumps(ls.slider_crank(3, 8, theta2=30)))
    assert main(["sweep", str(path), "--input", "x", "--from", "6", "--to", "12", "--step", "0.5", "-q",
                 "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert_located([e["input"] for e in doc["events"] if e["kind"] == "limit"], [11.0], LIMIT_TOL)


# ----------------------------------------------------------------------------- change points

# Grashof linkages on the boundary S + L = P + Q: every pivot in line at the change point(s)
CHANGE_POINTS = [
    pytest.param((5, 2, 4, 3), [180.0], id="5-2-4-3"),         # 2 + 5 = 4 + 3, O2-B-O4-C in line at theta2 = 180
    pytest.param((6, 2, 3, 5), [180.0], id="6-2-3-5"),         # 2 + 6 = 3 + 5
    pytest.param((4, 2, 4, 2), [180.0, 360.0], id="parallelogram"),  # a parallelogram: two change points
    pytest.param((7, 3, 6, 4), [180.0], id="7-3-6-4"),         # 3 + 7 = 6 + 4
]


@pytest.mark.parametrize("method", ["tracked", "batched"])
@pytest.mark.parametrize("links, expected", CHANGE_POINTS)
def test_fourbar_change_points_to_1e_8(links, expected, method):
    r1, r2, r3, r4 = links
    assert min(links) + max(links) == sum(links) - min(links) - max(links)
    sw = ls.fourbar(*links, theta2=10).sweep(10, 370, 10, method=method, progress=False)
    found = events(sw, "singular")
    assert len(found) == len(expected)
    assert_located(found, expected, CHANGE_TOL, period=360)


def test_isosceles_slider_crank_change_points_to_1e_8():
    """Crank = rod, no offset: the slider passes through the crank pivot at theta2 = 90 and 270."""
    sw = ls.slider_crank(3, 3, theta2=10).sweep(10, 370, 10, progress=False)
    found = events(sw, "singular")
    assert len(found) == 2
    assert_located(found, [90.0, 270.0], CHANGE_TOL, period=360)


def test_cli_json_change_point_to_1e_8(tmp_path, capsys):
    path = tmp_path / "cp.toml"
    path.write_text(ls.dumps(ls.fourbar(7, 3, 6, 4, theta2=10)))
    assert main(["sweep", str(path), "--from", "10", "--to", "370", "--step", "10", "-q", "--format", "json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    found = [e["input"] for e in doc["events"] if e["kind"] == "singular"]
    assert len(found) == 1
    assert_located(found, [180.0], CHANGE_TOL, period=360)
