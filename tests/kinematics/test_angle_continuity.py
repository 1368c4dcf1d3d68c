"""Angles of the unknowns are continuous along a sweep (issue 17, item 8; DESIGN.md, Conventions).

The first row is in (−180°, 180°], later rows follow the motion — in the Python arrays, the
states, the table, CSV, JSON, plots, the page and studies alike. References: the half-angle
closed form of the four-bar (seed notes 000), written here, compared modulo 360°; continuity is
checked on the rows themselves (consecutive rows of a 20° grid differ by far less than 180°).
"""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.cli import main

DRAG = (20.0, 60.0, 50.0, 70.0)  # r1 (ground, shortest) ... : a drag link, every link turns fully


def closed_form(r1, r2, r3, r4, t2, sign):
    """(θ3, θ4) radians of the four-bar r2 + r3 = r1 + r4 in the mode sign(sin(θ3 − θ4)) = sign."""
    a1 = 2 * r1 * r4 - 2 * r2 * r4 * math.cos(t2)
    b1 = -2 * r2 * r4 * math.sin(t2)
    c1 = r1 * r1 + r2 * r2 + r4 * r4 - r3 * r3 - 2 * r1 * r2 * math.cos(t2)
    qa, qb, qc = c1 - a1, 2 * b1, c1 + a1
    disc = qb * qb - 4 * qa * qc
    for s in (1, -1):
        t4 = 2 * math.atan((-qb + s * math.sqrt(disc)) / (2 * qa))
        t3 = math.atan2(r4 * math.sin(t4) - r2 * math.sin(t2), r1 + r4 * math.cos(t4) - r2 * math.cos(t2))
        if math.sin(t3 - t4) * sign > 0:
            return t3, t4
    raise AssertionError("no root in that mode")


def off_by_turns(a_deg, b_deg):
    """Largest distance of a − b from a whole number of turns (degrees)."""
    d = np.asarray(a_deg, dtype=float) - np.asarray(b_deg, dtype=float)
    return float(np.max(np.abs((d + 180) % 360 - 180)))


def assert_continuous(values, first_in_range=True, max_step=90.0):
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if first_in_range:
        assert -180 < v[0] <= 180
    assert np.max(np.abs(np.diff(v))) < max_step


@pytest.fixture(scope="module")
def drag():
    return ls.fourbar(*DRAG)


def test_drag_link_rows_are_continuous_and_right(drag):
    sw = drag.sweep(-10, 370, 20)
    t2 = np.asarray(sw["theta2"])
    assert t2[0] == -10 and t2[-1] == 370  # the input as given, not wrapped
    sign = 1 if sw.mode == "+" else -1
    ref = np.array([closed_form(*DRAG, math.radians(x), sign) for x in t2])
    for k, name in enumerate(("theta3", "theta4")):
        col = np.asarray(sw[name])
        assert_continuous(col)
        assert np.ptp(col) > 300  # they turn fully: no wrapping back
        assert off_by_turns(col, np.degrees(ref[:, k])) < 1e-9
        # a whole turn of the crank later the coupler and follower are a whole turn further
        assert col[-1] - col[1] == pytest.approx(360.0 * round((col[-1] - col[1]) / 360.0), abs=1e-9)
        assert abs(col[-1] - col[1]) == pytest.approx(360.0, abs=1e-9)


def test_table_csv_json_states_and_arrays_agree(drag, tmp_path, capsys):
    sw = drag.sweep(-10, 370, 20)
    doc = json.loads(sw.to_json())
    rows = list(csv.reader(io.StringIO(sw.to_csv())))
    head = [h.split(" [")[0] for h in rows[0]]
    for name in ("theta3", "theta4"):
        arr = np.asarray(sw[name])
        assert [r[name] for r in doc["rows"]] == pytest.approx(arr, abs=0, rel=0)
        assert [float(r[head.index(name)]) for r in rows[1:]] == pytest.approx(arr, abs=0, rel=0)
        assert [s[name] for s in sw.states] == pytest.approx(arr, abs=0, rel=0)
        assert [r[name] for r in sw.rows] == pytest.approx(arr, abs=0, rel=0)
    # and the command line, in the table format (6 significant digits)
    path = tmp_path / "drag.toml"
    path.write_text(ls.dumps(drag))
    assert main(["sweep", str(path), "--from", "-10", "--to", "370", "--step", "20"]) == 0
    out = capsys.readouterr().out.splitlines()
    cols = [h.split(" [")[0] for h in out[1].split("  ") if h.strip()]
    table = [[float(v) for v in ln.split()] for ln in out[3:] if ln.strip()]
    for name in ("theta3", "theta4"):
        printed = [r[cols.index(name)] for r in table]
        assert printed == pytest.approx(np.asarray(sw[name]), rel=1e-5)
    assert main(["sweep", str(path), "--from", "-10", "--to", "370", "--step", "20", "--format", "json"]) == 0
    cli_rows = json.loads(capsys.readouterr().out)["rows"]
    assert [r["theta4"] for r in cli_rows] == pytest.approx(np.asarray(sw["theta4"]), abs=1e-12)


def test_long_csv_stays_continuous_across_chunks(drag):
    """CSV/JSON are written in chunks of rows: the angles continue across the chunk boundaries."""
    sw = drag.sweep(-10, 730, 1)  # 741 rows, two turns
    rows = list(csv.reader(io.StringIO(sw.to_csv())))
    head = [h.split(" [")[0] for h in rows[0]]
    t4 = np.array([float(r[head.index("theta4")]) for r in rows[1:]])
    assert_continuous(t4, max_step=10)
    assert np.array_equal(t4, np.asarray(sw["theta4"]))
    assert np.ptp(t4) > 700


def test_through_limits_rows_follow_the_motion():
    mech = ls.load(ls.models_dir() / "double_rocker.toml")
    sw = mech.sweep(30, 390, 5, through_limits=True, progress=False)
    assert len(set(sw.modes)) == 2  # it went around a fold
    for name in ("theta3", "theta4"):
        assert_continuous(sw[name], max_step=60)


def test_input_driven_past_a_turn_is_as_given(drag):
    sw = drag.sweep(0, 720, 30, input="theta4")
    assert np.asarray(sw["theta4"]).tolist() == [float(v) for v in range(0, 721, 30)]
    assert_continuous(sw["theta2"])
    assert_continuous(sw["theta3"])


def test_study_rows_are_continuous_per_design(drag):
    pytest.importorskip("xarray")
    ds = ls.study(drag, {"r2": [55.0, 60.0, 65.0]}, -10, 370, 20, progress=False)
    for j in range(3):
        for name in ("theta3", "theta4"):
            col = ds[name].values[j]
            assert_continuous(col)
            assert np.ptp(col) > 300
    sw = drag.sweep(-10, 370, 20)
    assert np.asarray(ds["theta4"].values[1]) == pytest.approx(np.asarray(sw["theta4"]), abs=1e-9)


def test_plot_and_page_show_the_table(drag):
    pytest.importorskip("matplotlib")
    from loopsolve.output.view import page_data

    sw = drag.sweep(-10, 370, 20)
    top = sw.plot(["theta4"]).axes[0]
    y = [ln for ln in top.get_lines() if ln.get_label() == r"$\theta_{4}$"][0].get_ydata()
    assert np.array_equal(np.asarray(y, dtype=float), np.asarray(sw["theta4"]))
    series = page_data(sw, ["theta4"])["series"][0]
    assert np.asarray(series["q"][0], dtype=float) == pytest.approx(np.asarray(sw["theta4"]), abs=1e-9)
    assert series["wrap"] == 0  # the page's readout does not re-wrap the value
