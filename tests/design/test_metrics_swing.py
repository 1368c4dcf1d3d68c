"""``swing()`` of an output that crosses ±180° (issue 18, row 9), against a hand computation.

The thesis crank-rocker (60, 25, 70, 45) with its frame turned by β = 180° − (the middle of
its rocker's range): the rocker then oscillates across 180°, where an angle written in
(−180°, 180°] jumps by 360°. Its swing is computed here from the closed form (circle
intersection, open branch), with the angles taken in [0°, 360°) where this rocker's range does
not jump; the metric must give the same, from the study and from wrapped columns alike.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.design.metrics import evaluate_metrics, parse_metric

xr = pytest.importorskip("xarray")

R1, R2, R3, R4 = 60.0, 25.0, 70.0, 45.0


def theta4_open(theta2_deg, beta_deg=0.0):
    """θ4 (deg, in [0, 360)) of the open branch (sign of sin(θ3 − θ4) negative), frame tilted by β."""
    b = math.radians(beta_deg)
    t = math.radians(theta2_deg)
    bx, by = R2 * math.cos(t), R2 * math.sin(t)
    ox, oy = R1 * math.cos(b), R1 * math.sin(b)
    dx, dy = ox - bx, oy - by
    d = math.hypot(dx, dy)
    a = (R3 * R3 - R4 * R4 + d * d) / (2 * d)
    h = math.sqrt(R3 * R3 - a * a)
    for s in (1, -1):
        cx, cy = bx + (a * dx - s * h * dy) / d, by + (a * dy + s * h * dx) / d
        th3, th4 = math.atan2(cy - by, cx - bx), math.atan2(cy - oy, cx - ox)
        if math.sin(th3 - th4) < 0:
            return math.degrees(th4) % 360.0
    raise AssertionError


GRID = np.arange(0.0, 360.0 + 1e-9, 2.0)
BASE = np.array([theta4_open(x) for x in GRID])
BETA = 180.0 - 0.5 * (BASE.min() + BASE.max())  # the rocker's range centred on 180°


def model(beta):
    text = (ls.models_dir() / "thesis_crank_rocker.toml").read_text()
    text = text.replace('r1 = { length = "r1", angle = 0 }', 'r1 = { length = "r1", angle = "beta" }')
    beta = float(beta)
    text = text.replace("r4 = 45\n", f"r4 = 45\nbeta = {beta!r}\n")
    text = text.replace("theta4 = { guess = 80 }", f"theta4 = {{ guess = {80 + beta!r} }}")
    return ls.loads(text)


def test_the_output_crosses_180():
    tilted = np.array([theta4_open(x, BETA) for x in GRID])
    assert tilted.min() < 180 < tilted.max() and tilted.max() - tilted.min() < 180
    wrapped = (tilted + 180) % 360 - 180
    assert wrapped.max() - wrapped.min() > 300  # what a swing of wrapped angles would report


def test_swing_of_a_study_output_crossing_180_is_the_hand_swing():
    hand = np.ptp([theta4_open(x, BETA) for x in GRID])
    assert 80 < hand < 82  # 80.8° (the number)
    ds = ls.study(model(BETA), {"r2": [25.0]}, 0, 360, 2, metrics={"sw": "swing(theta4)", "st": "stroke(theta4)"},
                  progress=False)
    assert ds.status.values.tolist() == ["ok"]
    assert float(ds.sw.values[0]) == pytest.approx(hand, abs=1e-8)
    assert float(ds.st.values[0]) == pytest.approx(hand, abs=1e-8)
    # the unturned mechanism (sampled at other crank positions relative to its frame: 2e-4° apart)
    ds0 = ls.study(model(0.0), {"r2": [25.0]}, 0, 360, 2, metrics={"sw": "swing(theta4)"}, progress=False)
    assert float(ds0.sw.values[0]) == pytest.approx(np.ptp(BASE), abs=1e-8)


def test_swing_unwraps_wrapped_angle_columns():
    """The metric itself, on columns written in (−180°, 180°] (two designs: turned and not)."""
    tilted = np.array([theta4_open(x, BETA) for x in GRID])
    cols = {"theta4": np.stack([(tilted + 180) % 360 - 180, BASE])}
    out = evaluate_metrics([parse_metric("sw=swing(theta4)")], cols, {}, GRID, angle_columns=("theta4",))
    np.testing.assert_allclose(out["sw"], [np.ptp(tilted), np.ptp(BASE)], atol=1e-9)
