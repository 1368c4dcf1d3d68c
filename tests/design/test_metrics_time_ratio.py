"""``time_ratio()`` of the crank and slotted lever quick-return against its closed form.

The lever's extremes are where it is tangent to the crank circle: half the angle between them
is asin(r2/d), so the crank turns 180° + 2 asin(r2/d) on one stroke and 180° − 2 asin(r2/d)
on the other. With r2 = 100, d = 200 the extremes are at θ2 = 210° and 330° (rows of a 10°
grid) and the ratio is exactly 2. Both ways of finding the extremes are checked: the roots of
the velocity (rates computed) and the extreme rows of the position (``derivatives=1``: no acceleration column, the
fallback; mutation testing found it unchecked).
"""

from __future__ import annotations

import math

import pytest

import loopsolve as ls

pytest.importorskip("xarray")

QR = ls.models_dir() / "quick_return.toml"


def closed_form(r2, d=200.0):
    a = math.degrees(math.asin(r2 / d))
    return (180 + 2 * a) / (180 - 2 * a)


def test_time_ratio_on_grid_extremes():
    ds = ls.study(ls.load(QR), {"r2": [100.0]}, 0, 360, 10, metrics={"q": "time_ratio(theta4)"}, progress=False)
    assert float(ds.q.values[0]) == pytest.approx(2.0, abs=1e-9)


@pytest.mark.parametrize("r2", [100.0, 80.0])
def test_time_ratio_from_the_velocity_roots_and_from_the_rows(r2):
    """From the velocity's roots (rates computed) to 1e-6 on a 1° grid; from the extreme rows
    refined by a parabola (``derivatives=1``: no acceleration column) to 1e-2."""
    want = closed_form(r2)
    kw = dict(metrics={"q": "time_ratio(theta4)"}, progress=False)
    roots = ls.study(ls.load(QR), {"r2": [r2]}, 0, 360, 1, **kw)
    assert float(roots.q.values[0]) == pytest.approx(want, abs=1e-6)
    rows = ls.study(ls.load(QR), {"r2": [r2]}, 0, 360, 1, derivatives=1, **kw)
    assert "theta4_acc" not in rows
    assert float(rows.q.values[0]) == pytest.approx(want, abs=1e-2)


def test_closed_form_value():
    assert closed_form(80.0) == pytest.approx(1.70995, abs=1e-5) and closed_form(100.0) == pytest.approx(2.0)
