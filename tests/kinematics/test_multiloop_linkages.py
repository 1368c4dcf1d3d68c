"""Multi-loop linkages (six-bars, quick returns, a two-input five-bar) over full input cycles.

Positions are checked against an independent computation written here: each dyad is solved in
closed form, loop by loop, as the intersection of two circles (or a circle and a line), on the
side of the drawn pose. Velocities and accelerations are checked against central finite
differences of positions solved at neighbouring inputs.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.kinematics import classic

MODELS = ls.models_dir()


def drawn(name):
    data = tomllib.loads((MODELS / f"{name}.toml").read_text())
    return {k: np.array(v["at"], dtype=float) for k, v in data["joints"].items()}


def e(a):
    return np.array([math.cos(a), math.sin(a)])


def ang(v):
    return math.atan2(v[1], v[0])


def cross(a, b):
    return a[0] * b[1] - a[1] * b[0]


def circles(p, rp, q, rq, side):
    """The intersection X of circles (p, rp), (q, rq) with sign(cross(q - p, X - p)) == side."""
    d = q - p
    dist = np.linalg.norm(d)
    a = (rp**2 - rq**2 + dist**2) / (2 * dist)
    h = math.sqrt(rp**2 - a**2)
    u = d / dist
    n = np.array([-u[1], u[0]])
    return p + a * u + side * h * n


def side(p, q, x):
    return 1.0 if cross(q - p, x - p) > 0 else -1.0


def rigid(p_from, q_from, x_from, p_to, q_to):
    """Where point x of a rigid body goes when its points p, q move to p_to, q_to."""
    rot = ang(q_to - p_to) - ang(q_from - p_from)
    c, s = math.cos(rot), math.sin(rot)
    return p_to + np.array([[c, -s], [s, c]]) @ (x_from - p_from)


# ----------------------------------------------------------------------------- independent solutions
def watt_positions(theta):
    J = drawn("watt2_sixbar")
    o2, o4, o6 = J["O2"], J["O4"], J["O6"]
    a = o2 + np.linalg.norm(J["A"] - o2) * e(theta)
    b = circles(a, np.linalg.norm(J["B"] - J["A"]), o4, np.linalg.norm(J["B"] - o4), side(J["A"], o4, J["B"]))
    c = rigid(o4, J["B"], J["C"], o4, b)  # the ternary rocker O4-B-C turns as a body
    d = circles(c, np.linalg.norm(J["D"] - J["C"]), o6, np.linalg.norm(J["D"] - o6), side(J["C"], o6, J["D"]))
    return {"A": a, "B": b, "C": c, "D": d}


def stephenson_positions(theta):
    J = drawn("stephenson3_sixbar")
    o2, o4, o6 = J["O2"], J["O4"], J["O6"]
    a = o2 + np.linalg.norm(J["A"] - o2) * e(theta)
    b = circles(a, np.linalg.norm(J["B"] - J["A"]), o4, np.linalg.norm(J["B"] - o4), side(J["A"], o4, J["B"]))
    c = rigid(J["A"], J["B"], J["C"], a, b)  # coupler point of the ternary coupler A-B-C
    d = circles(c, np.linalg.norm(J["D"] - J["C"]), o6, np.linalg.norm(J["D"] - o6), side(J["C"], o6, J["D"]))
    return {"A": a, "B": b, "C": c, "D": d}


def quick_return_positions(name, theta):
    """Crank pin A, lever tip D (rigid with the slot line O4A), ram pin E on the horizontal way."""
    J = drawn(name)
    o2, o4 = J["O2"], J["O4"]
    a = o2 + np.linalg.norm(J["A"] - o2) * e(theta)
    d = rigid(o4, J["A"], J["D"], o4, a)
    rod = np.linalg.norm(J["E"] - J["D"])
    y = J["E"][1]
    sgn = 1.0 if J["E"][0] > J["D"][0] else -1.0
    ex = d[0] + sgn * math.sqrt(rod**2 - (y - d[1]) ** 2)
    return {"A": a, "D": d, "E": np.array([ex, y]), "s_slot": np.linalg.norm(a - o4), "s_way": ex}


def fivebar_positions(theta_a, theta_b):
    J = drawn("fivebar_two_inputs")
    a = J["O1"] + np.linalg.norm(J["A"] - J["O1"]) * e(theta_a)
    b = J["O5"] + np.linalg.norm(J["B"] - J["O5"]) * e(theta_b)
    p = circles(a, np.linalg.norm(J["P"] - J["A"]), b, np.linalg.norm(J["P"] - J["B"]), side(J["A"], J["B"], J["P"]))
    return {"A": a, "B": b, "P": p}


INDEPENDENT = {
    "watt2_sixbar": watt_positions,
    "stephenson3_sixbar": stephenson_positions,
    "whitworth_quick_return": lambda t: quick_return_positions("whitworth_quick_return", t),
    "crank_shaper": lambda t: quick_return_positions("crank_shaper", t),
}


# ----------------------------------------------------------------------------- tests
@pytest.mark.parametrize("model", list(INDEPENDENT))
def test_positions_over_a_full_turn(model):
    mech = ls.load(MODELS / f"{model}.toml")
    sw = mech.sweep(0, 360, 5, speed=1)
    assert len(sw) == 73 and not sw.events
    for st in sw.states:
        ref = INDEPENDENT[model](math.radians(st.input_value))
        for name, value in ref.items():
            # 1e-8 mm on links of ~100 mm: the Newton tolerance, not the model
            if np.ndim(value):
                assert st[f"{name}_x"] == pytest.approx(value[0], abs=1e-8), (name, st.input_value)
                assert st[f"{name}_y"] == pytest.approx(value[1], abs=1e-8), (name, st.input_value)
            else:
                assert st[name] == pytest.approx(value, abs=1e-8), (name, st.input_value)
    # the tracked branch keeps one assembly mode (one sign per block) around the turn
    assert len({st.mode for st in sw.states}) == 1


def _columns(st, names):
    return np.array([st[n] for n in names])


@pytest.mark.parametrize("model", list(INDEPENDENT) + ["fivebar_two_inputs"])
def test_rates_against_finite_differences(model):
    """Velocities and accelerations (kinematic coefficients at 1 rad/s) against central
    differences of positions and velocities solved at x ± h, at inputs around a full turn."""
    mech = ls.load(MODELS / f"{model}.toml")
    ck = mech.compile()
    pts = [f"{p}_{c}" for p in ck.points for c in "xy"]
    lengths = [v for v, k in zip(ck.variables, ck.kinds) if k is ls.units.Kind.LENGTH and v not in ck.inputs]
    angles = [v for v in ck.unknowns if v not in lengths]
    sw = mech.sweep(0, 360, 30, speed=1)
    h = 1e-3  # degrees
    for st in sw.states[:-1]:
        x = st.input_value
        guess = {n: st.z[ck.index(n)] for n in ck.unknowns}
        plus2, plus, minus, minus2 = (mech.solve(x + k * h, speed=1, guess=guess, compiled=ck)
                                      for k in (2, 1, -1, -2))
        hr = math.radians(h)

        def d(f):
            return (8 * (f(plus) - f(minus)) - (f(plus2) - f(minus2))) / (12 * hr)

        pos = lambda s: _columns(s, pts + lengths)  # noqa: E731
        vel = lambda s: _columns(s, [n + "_vel" for n in pts + lengths + angles])  # noqa: E731
        np.testing.assert_allclose(vel(st)[: len(pts + lengths)], d(pos), atol=1e-6 * ck.scale, rtol=1e-6)
        th = lambda s: np.radians(_columns(s, angles))  # noqa: E731
        ang_fd = d(lambda s: np.angle(np.exp(1j * (th(s) - th(st)))))  # change of each angle, wrapped
        np.testing.assert_allclose(vel(st)[len(pts + lengths):], ang_fd, atol=1e-7)
        acc = _columns(st, [n + "_acc" for n in pts + lengths + angles])
        np.testing.assert_allclose(acc, d(vel), atol=1e-5 * ck.scale, rtol=1e-5)


def test_rates_scale_with_input_speed_and_acceleration():
    """q_dot = q' w and q_ddot = q'' w^2 + q' alpha (chain rule) for a six-bar."""
    mech = ls.load(MODELS / "stephenson3_sixbar.toml")
    w, alpha = 2.5, -4.0
    a = mech.solve(77, speed=1, accel=0)
    b = mech.solve(77, speed=w, accel=alpha)
    for n in ("theta_link6", "D_x", "C_y"):
        assert b[n + "_vel"] == pytest.approx(a[n + "_vel"] * w, rel=1e-12, abs=1e-12)
        assert b[n + "_acc"] == pytest.approx(a[n + "_acc"] * w**2 + a[n + "_vel"] * alpha, rel=1e-11, abs=1e-11)


def test_fivebar_two_inputs_sweep_holds_the_second():
    mech = ls.load(MODELS / "fivebar_two_inputs.toml")
    assert mech.inputs == ("theta_crank_a", "theta_crank_b")
    sw = mech.sweep(0, 360, 10)
    assert len(sw) == 37 and not sw.events
    np.testing.assert_allclose(sw["theta_crank_b"], 90.0)
    np.testing.assert_allclose(sw["theta_crank_b_vel"], 0.0)
    for st in sw.states:
        ref = fivebar_positions(math.radians(st.input_value), math.radians(90))
        for name, xy in ref.items():
            assert st[f"{name}_x"] == pytest.approx(xy[0], abs=1e-9)
            assert st[f"{name}_y"] == pytest.approx(xy[1], abs=1e-9)
    # driving the other crank instead (the first is then held at its drawn 90 deg)
    st = mech.solve(60, input="theta_crank_b")
    ref = fivebar_positions(math.radians(90), math.radians(60))
    assert st["P_x"] == pytest.approx(ref["P"][0], abs=1e-9)
    assert st["P_y"] == pytest.approx(ref["P"][1], abs=1e-9)


class TestQuickReturnInfo:
    def test_whitworth_time_ratio_and_stroke(self):
        """Ram extremes when the lever lies along the way: (180 + 2a) / (180 - 2a), a = asin(d / r2)."""
        J = drawn("whitworth_quick_return")
        r2 = np.linalg.norm(J["A"] - J["O2"])
        dist = np.linalg.norm(J["O2"] - J["O4"])
        arm = np.linalg.norm(J["D"] - J["O4"])
        a = math.asin(dist / r2)
        qr, = ls.load(MODELS / "whitworth_quick_return.toml").info()["quick_return"]
        assert qr["type"] == "whitworth" and qr["rocking_angle"] is None
        assert qr["time_ratio"] == pytest.approx((math.pi + 2 * a) / (math.pi - 2 * a), rel=1e-6)
        assert qr["stroke"]["variable"] == "s_way"
        assert qr["stroke"]["value"] == pytest.approx(2 * arm, rel=1e-6)
        assert qr["return_angle"] == pytest.approx(math.degrees(math.pi - 2 * a), abs=1e-4)

    def test_crank_shaper_time_ratio_and_stroke(self):
        """The lever rocks between crank positions perpendicular to it (classic.quick_return);
        the ram's ends are where the lever ends (computed here by the circle-line dyad)."""
        J = drawn("crank_shaper")
        r2 = np.linalg.norm(J["A"] - J["O2"])
        dist = np.linalg.norm(J["O2"] - J["O4"])
        ratio, adv, ret, rock = classic.quick_return(r2, dist)
        qr, = ls.load(MODELS / "crank_shaper.toml").info()["quick_return"]
        assert qr["type"] == "crank-slotted-lever"
        assert qr["time_ratio"] == pytest.approx(float(ratio), rel=1e-12)
        assert qr["rocking_angle"] == pytest.approx(math.degrees(rock), rel=1e-12)
        ram, = qr["rams"]
        assert ram["time_ratio"] == pytest.approx(float(ratio), rel=1e-7)
        # lever extremes: tangent from O4 to the crank circle
        up = ang(J["O2"] - J["O4"])
        tip = np.linalg.norm(J["D"] - J["O4"]) * np.array([e(up + math.asin(r2 / dist)), e(up - math.asin(r2 / dist))])
        off = ang(J["D"] - J["O4"]) - ang(J["A"] - J["O4"])
        assert abs(off) < 1e-6  # the tip lies on the slot line
        rod, y = np.linalg.norm(J["E"] - J["D"]), J["E"][1]
        ends = tip[:, 0] + np.sqrt(rod**2 - (y - tip[:, 1]) ** 2)
        assert ram["stroke"] == pytest.approx(abs(ends[0] - ends[1]), rel=1e-6)
        assert qr["stroke"] == {"variable": "s_way", "value": pytest.approx(ram["stroke"]), "unit": "mm"}
