"""``loopsolve view`` of a rocking input has rows at its located limit positions, as ``plot`` has.

The double rocker (r1 = 60, r2 = 50, r3 = 20, r4 = 45) reaches its limits where the coupler r3
and the rocker r4 are collinear: |B − O4| = r4 ∓ r3 with B = r2 e^{iθ2}, O4 = (r1, 0), so by the
law of cosines cos θ2 = (r1² + r2² − (r4 ∓ r3)²) / (2 r1 r2) — computed here, independently of
the solver. At the folded limit (r4 − r3) B, C and O4 are on one line with C beyond B: θ3 = θ4 =
the direction of B − O4.
"""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys

import loopsolve as ls

R1, R2, R3, R4 = 60.0, 50.0, 20.0, 45.0


def limit_input(d):
    return math.degrees(math.acos((R1 * R1 + R2 * R2 - d * d) / (2 * R1 * R2)))


def page_json(path):
    text = path.read_text(encoding="utf-8")
    m = re.search(r'<script type="application/json" id="ls-data">(.*?)</script>', text, re.S)
    return json.loads(m.group(1))


def test_view_page_has_rows_at_the_limits(tmp_path):
    out = tmp_path / "rocker.html"
    env = dict(os.environ)
    env.pop("LOOPSOLVE_DEBUG", None)
    proc = subprocess.run([sys.executable, "-m", "loopsolve.cli", "view", str(ls.models_dir() / "double_rocker.toml"),
                           "--step", "1", "-q", "-o", str(out)], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    data = page_json(out)
    x = data["input"]["x"]
    inner, outer = limit_input(R4 - R3), limit_input(R4 + R3)  # 24.1468..., 71.7900...
    assert abs(inner - 24.1468479965) < 1e-8 and abs(outer - 71.7900431357) < 1e-8
    # the page starts and ends (the circuit closes) on the located limit, not one step inside it
    assert abs(x[0] - inner) < 1e-7 and abs(x[-1] - inner) < 1e-7, (x[0], x[-1])
    far = [i for i, v in enumerate(x) if abs(v - outer) < 1e-7]
    assert len(far) >= 1, max(x)
    assert max(x) <= outer + 1e-7
    limits = [e for e in data["events"] if e["kind"] == "limit"]
    assert sorted(e["row"] for e in limits)[0] == 0
    for e in limits:  # each limit event is marked at a row whose input is that limit
        assert abs(x[e["row"]] - e["input"]) < 1e-7
    # the positions at the inner limit: theta3 = theta4 = direction of B - O4; rates undefined there
    series = {s["name"]: s for s in data["series"]}
    b = (R2 * math.cos(math.radians(inner)), R2 * math.sin(math.radians(inner)))
    direction = math.degrees(math.atan2(b[1], b[0] - R1))
    for name in ("theta3", "theta4"):
        pos, vel = series[name]["q"][0][0], series[name]["q"][1][0]
        assert abs((pos - direction + 180) % 360 - 180) < 1e-5, (name, pos, direction)
        assert vel is None
    # the drawn points at row 0: B at the crank's tip, C at r4 from O4 along the same line
    scene = data["scene"]
    pts = {p["name"]: scene["traj"][p["t"]] for p in scene["points"]}
    ux, uy = math.cos(math.radians(direction)), math.sin(math.radians(direction))
    for name, ref in (("B", b), ("C", (R1 + R4 * ux, R4 * uy))):
        xy = pts[name][:2]
        assert math.hypot(xy[0] - ref[0], xy[1] - ref[1]) < 1e-6, (name, xy, ref)
