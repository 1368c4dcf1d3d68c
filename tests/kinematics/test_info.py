"""`loopsolve info` on models placed in general positions, against values worked out by hand.

Written for the surviving mutants of ``loopsolve.kinematics.info`` (issue 13; ``mutmut show NAME`` prints a
diff). Each test names the mutants it kills. The models are written here: four-bars whose frame is
tilted and whose pivots are off the origin, a crank whose vector turns against its variable, a
Watt II six-bar drawn anywhere, quick returns in metres and with extra loops. The expected numbers
come from the law of cosines on the four-bar's diagonal, from S + L against P + Q, and from the
quick-return closed forms (return angle 2 acos(r2/d), lever swing 2 asin(r2/d)).
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.cli import main
from loopsolve.errors import LoopsolveWarning


def _write(tmp_path, name, text):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def _law(a, b, opposite):
    """Angle [deg] between sides a and b of a triangle, from the side opposite it (law of cosines)."""
    return math.degrees(math.acos((a * a + b * b - opposite * opposite) / (2 * a * b)))


def _info_json(capsys, path):
    assert main(["info", str(path), "--format", "json"]) == 0
    return json.loads(capsys.readouterr().out)


def _info_text(capsys, path):
    assert main(["info", str(path)]) == 0
    return capsys.readouterr().out.splitlines()


# ---------------------------------------------------------------------------------------------
# A non-Grashof four-bar written as a vector loop, its frame tilted by 30 deg: the crank rocks
# from the folded position (diagonal B-O4 = r4 - r3) round through 180 deg to the other one.

G, A, B, C = 4.4, 3.3, 3.85, 5.5  # ground, crank, coupler, rocker: 3.3 + 5.5 > 4.4 + 3.85
TILT = 30.0


def _triple_rocker(crank_angle="theta2", theta2=90.0):
    """The triple rocker as a model file; the crank vector's angle is ``crank_angle``."""
    sign = -1.0 if crank_angle.startswith("-") else 1.0
    t = math.radians(TILT)
    frame = np.array([G * math.cos(t), G * math.sin(t)])
    pin = A * np.array([math.cos(sign * math.radians(theta2)), math.sin(sign * math.radians(theta2))])
    diag = frame - pin  # B -> O4; the coupler end C is where circles about B (r3) and O4 (r4) meet
    d = float(np.linalg.norm(diag))
    along = (B * B - C * C + d * d) / (2 * d)
    u = diag / d
    cpt = pin + along * u + math.sqrt(B * B - along * along) * np.array([-u[1], u[0]])
    t3 = math.degrees(math.atan2(*(cpt - pin)[::-1]))
    t4 = math.degrees(math.atan2(*(cpt - frame)[::-1]))
    return f"""
name = "Tilted triple rocker"
units = {{ length = "mm", angle = "deg" }}

[parameters]
r1 = {G}
r2 = {A}
r3 = {B}
r4 = {C}
tilt = {TILT}

[variables]
theta2 = {{ input = true, guess = {theta2} }}
theta3 = {{ guess = {t3!r} }}
theta4 = {{ guess = {t4!r} }}

[vectors]
r1 = {{ length = "r1", angle = "tilt" }}
r2 = {{ length = "r2", angle = "{crank_angle}" }}
r3 = {{ length = "r3", angle = "theta3" }}
r4 = {{ length = "r4", angle = "theta4" }}

[[loops]]
equation = "r2 + r3 = r1 + r4"

[points]
B = "r2"

[modes]
open = "-"
crossed = "+"
"""


# the crank's angle at O2 from the frame where the diagonal B-O4 is r4 - r3 (folded); never stretched
INNER = _law(G, A, C - B)
MU_MAX = _law(B, C, G + A)  # the transmission angle with the crank pointing away from O4 (phi = 180)


def test_vector_triple_rocker_summary(tmp_path, capsys):
    """loopsolve.kinematics.info.x_info__mutmut_28 (mobility counted 3 per loop), x_info__mutmut_58 (length
    parameters converted to degrees), x_info__mutmut_68 / x_info__mutmut_108 (points and
    mobility_rank keys renamed), x__vector_candidates__mutmut_157 / x__fourbars__mutmut_99 (the
    declared lengths replaced by their round trip through the pose), x__fourbars__mutmut_159 /
    x__fourbars__mutmut_269 (driven_by lost), x__transmission__mutmut_21 (an input range through
    phi = 180 deg not seen), x__transmission__mutmut_61 (the folded limit not snapped to mu = 0),
    x__fourbars__mutmut_219 (the input's start value added instead of subtracted)."""
    path = _write(tmp_path, "triple", _triple_rocker())
    d = _info_json(capsys, path)
    assert d["mobility"] == 1 and d["mobility_rank"] == 1  # 3 joint variables - 2 x 1 loop
    assert d["points"] == ["B"]
    assert d["parameters"] == {"r1": G, "r2": A, "r3": B, "r4": C, "tilt": pytest.approx(TILT, abs=1e-12)}
    (fb,) = d["fourbars"]
    assert fb["lengths"] == {"ground": G, "input": A, "coupler": B, "output": C}  # exactly as declared
    assert (fb["input"], fb["output"], fb["driven_by"]) == ("theta2", "theta4", "input")
    assert (fb["grashof"], fb["input_motion"]) == ("triple rocker", "rocks")
    # theta2 = tilt + phi with phi in [INNER, 360 - INNER]: shown starting in [-180, 180)
    np.testing.assert_allclose(fb["input_range"], [[TILT + INNER, TILT + 360 - INNER]], atol=1e-9)
    # mu = 0 where folded (a limit of the crank), largest with the crank at phi = 180
    lo, hi = fb["transmission_angle_range"]
    assert lo == 0.0 and hi == pytest.approx(MU_MAX, abs=1e-9)


def test_vector_triple_rocker_text(tmp_path, capsys):
    """loopsolve.kinematics.info.x_format_info__mutmut_33 (text after the mobility of a model without a
    diagram), x_format_info__mutmut_53 / x_format_info__mutmut_63 (the loops and solve-order
    labels), x_format_info__mutmut_83 (mode names not printed), x_format_info__mutmut_143 (the
    input range printed as None), x__transmission__mutmut_61 ("0 to" at the folded limit)."""
    lines = _info_text(capsys, _write(tmp_path, "triple", _triple_rocker()))
    assert lines[0].startswith("Tilted triple rocker  (") and lines[0].endswith("triple.toml)")
    assert "  mobility: 1; Jacobian rank at the start pose leaves 1" in lines
    assert "  loops: loop1: r2 + r3 = r1 + r4" in lines
    assert "  solve order (blocks): (theta3, theta4)" in lines
    assert "  mode names: open = -, crossed = +" in lines
    assert (f"  four-bar loop loop1: triple rocker (input r2 {A:.6g}, coupler r3 {B:.6g}, output r4 {C:.6g}, "
            f"ground r1 {G:.6g})") in lines
    assert f"    input theta2 rocks: range (deg) [{TILT + INNER:.6g}, {TILT + 360 - INNER:.6g}]" in lines
    assert f"    transmission angle (deg): 0 to {MU_MAX:.6g}" in lines


def test_vector_crank_turning_against_its_variable(tmp_path, capsys):
    """loopsolve.kinematics.info.x__vector_candidates__mutmut_117: a crank vector at angle -theta2 turns
    against theta2; its input range is the mirror image, theta2 = -(tilt + phi)."""
    d = _info_json(capsys, _write(tmp_path, "mirrored", _triple_rocker("-theta2", theta2=-120.0)))
    (fb,) = d["fourbars"]
    lo, hi = -(TILT + 360 - INNER), -(TILT + INNER)  # [-371.4, -48.6]: moved by a turn to start in [-180, 180)
    np.testing.assert_allclose(fb["input_range"], [[lo + 360, hi + 360]], atol=1e-9)
    assert fb["input_motion"] == "rocks" and fb["grashof"] == "triple rocker"


def test_transmission_angle_of_a_crank_turning_against_its_variable(tmp_path, capsys):
    """Real bug found with x__vector_candidates__mutmut_117: with the crank vector at -theta2 the
    interval of the crank angle came out reversed, and the transmission angle was reported as
    0 to 0 instead of 0 to 109.6 deg (the crank passes phi = 180 deg)."""
    d = _info_json(capsys, _write(tmp_path, "mirrored", _triple_rocker("-theta2", theta2=-120.0)))
    (fb,) = d["fourbars"]
    lo, hi = fb["transmission_angle_range"]
    assert lo == 0.0 and hi == pytest.approx(MU_MAX, abs=1e-9)


# Grashof double rockers (the coupler shortest: 5.01 + 7.45 < 6.2 + 7.13, 2.09 + 9.93 < 8.74 + 3.99):
# the input stops where coupler and output are folded (mu = 0) and stretched (mu = 180 deg).
@pytest.mark.parametrize("lengths, tilt, theta2", [
    ((6.2, 7.13, 5.01, 7.45), -50.0, -128.89893953210877),
    ((9.93, 8.74, 2.09, 3.99), 0.0, 25.0),
])
def test_transmission_angle_exact_at_the_limits(lengths, tilt, theta2, capsys):
    """loopsolve.kinematics.info.x__transmission__mutmut_61 (the folded limit |b - c| not recognised: mu came
    out 1.2e-06 deg on the first model) and a real bug it led to: on the second model the
    unmutated code printed "1.20742e-06 to 180" (b^2 + c^2 - (b - c)^2 over 2 b c rounded below 1)."""
    from loopsolve.kinematics import classic

    g, a, b, c = lengths
    t3, t4 = classic.fourbar_position(g, a, b, c, math.radians(theta2 - tilt), mode=+1)  # guesses only
    mech = ls.build_mechanism({
        "name": "double rocker", "units": {"length": "mm", "angle": "deg"},
        "parameters": {"r1": g, "r2": a, "r3": b, "r4": c},
        "variables": {"theta2": {"input": True, "guess": theta2}, "theta3": {"guess": math.degrees(t3) + tilt},
                      "theta4": {"guess": math.degrees(t4) + tilt}},
        "vectors": {"r1": {"length": "r1", "angle": tilt}, "r2": {"length": "r2", "angle": "theta2"},
                    "r3": {"length": "r3", "angle": "theta3"}, "r4": {"length": "r4", "angle": "theta4"}},
        "loops": [{"equation": "r2 + r3 = r1 + r4"}]})
    d = mech.info()
    (fb,) = d["fourbars"]
    assert (fb["grashof"], fb["input_motion"]) == ("double rocker", "rocks")
    outer, inner = _law(g, a, b + c), _law(g, a, abs(b - c))
    expected = []
    for lo, hi in ((-outer, -inner), (inner, outer)):
        shift = 360 * math.floor((lo + tilt + 180) / 360)
        expected.append([lo + tilt - shift, hi + tilt - shift])
    np.testing.assert_allclose(fb["input_range"], sorted(expected), atol=1e-9)
    assert fb["transmission_angle_range"] == [0.0, 180.0]
    from loopsolve.kinematics.info import format_info

    assert "    transmission angle (deg): 0 to 180" in format_info(d).splitlines()


def test_start_pose_at_a_limit_still_has_a_rank(tmp_path):
    """loopsolve.kinematics.info.x__rank_mobility__mutmut_37: drawn at the crank's limit (coupler and rocker
    folded) the unknowns' Jacobian is singular; the rank of [Phi_q | Phi_x] still leaves 1."""
    g, a, b, c = 4.0, 3.0, 3.5, 5.0
    phi = math.radians(_law(g, a, c - b))
    pin = np.array([a * math.cos(phi), a * math.sin(phi)])
    away = (pin - np.array([g, 0.0])) / (c - b)  # O4 -> B; coupler and rocker both point along it
    t34 = math.degrees(math.atan2(away[1], away[0]))
    mech = ls.build_mechanism({
        "name": "folded", "units": {"length": "mm", "angle": "deg"},
        "parameters": {"r1": g, "r2": a, "r3": b, "r4": c},
        "variables": {"theta2": {"input": True, "guess": math.degrees(phi)}, "theta3": {"guess": t34},
                      "theta4": {"guess": t34}},
        "vectors": {"r1": {"length": "r1", "angle": 0}, "r2": {"length": "r2", "angle": "theta2"},
                    "r3": {"length": "r3", "angle": "theta3"}, "r4": {"length": "r4", "angle": "theta4"}},
        "loops": [{"equation": "r2 + r3 = r1 + r4"}]})
    d = mech.info()
    assert d["mobility_rank"] == 1
    (fb,) = d["fourbars"]
    np.testing.assert_allclose(fb["input_range"], [[math.degrees(phi), 360 - math.degrees(phi)]], atol=1e-9)


def test_info_without_guesses_does_not_warn():
    """loopsolve.kinematics.info.x__start_pose__mutmut_10: `loopsolve info` on a model without guesses for
    its unknowns printed the solver's "no guess" warning (info only looks at the start pose)."""
    mech = ls.build_mechanism({
        "name": "no guesses", "units": {"length": "mm", "angle": "deg"},
        "parameters": {"r1": 60, "r2": 25, "r3": 70, "r4": 45},
        "variables": {"theta2": {"input": True, "guess": 60}, "theta3": {}, "theta4": {}},
        "vectors": {"r1": {"length": "r1", "angle": 0}, "r2": {"length": "r2", "angle": "theta2"},
                    "r3": {"length": "r3", "angle": "theta3"}, "r4": {"length": "r4", "angle": "theta4"}},
        "loops": [{"equation": "r2 + r3 = r1 + r4"}]})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = mech.info()
    assert [w for w in caught if issubclass(w.category, LoopsolveWarning)] == []
    assert d["fourbars"][0]["grashof"] == "crank-rocker"  # 25 + 70 < 60 + 45, the crank shortest


# ---------------------------------------------------------------------------------------------
# A Watt II six-bar drawn off the origin with a tilted frame: loop 1 (O2 A B O4, 60/20/58/25) is a
# crank-rocker whose rocker swings close to the frame line (22 deg at its folded limit); the
# ternary rocker's arm O4C is the crank of loop 2 (O4 C D O6, 70/20/60/45).

WATT2 = {  # the rocker 27 deg from the frame line O4 -> O2 (5 deg past its folded limit)
    "near": {"O2": (10.0, 20.0), "A": (-7.320508, 10.0), "B": (49.384394, 22.188275), "O4": (66.381557, 40.521209),
             "C": (83.18631, 29.676843), "D": (140.136717, 48.562053), "O6": (127.003336, 5.521209)},
    # the same linkage drawn with the crank 80 deg further on: the rocker at 85 deg
    "far": {"O2": (10.0, 20.0), "A": (16.840403, 1.206148), "B": (72.82424, 16.365633), "O4": (66.381557, 40.521209),
            "C": (84.517428, 48.952709), "D": (144.485208, 46.986666), "O6": (127.003336, 5.521209)},
}


def _watt2_file(tmp_path, pose):
    joints = "\n".join(f"{k} = {{ at = [{x!r}, {y!r}] }}" for k, (x, y) in WATT2[pose].items())
    return _write(tmp_path, "watt2_shifted", f"""
name = "Shifted Watt II"
units = {{ length = "mm", angle = "deg" }}

[joints]
{joints}

[links]
ground   = ["O2", "O4", "O6"]
crank    = ["O2", "A"]
coupler  = ["A", "B"]
rocker   = ["O4", "B", "C"]
coupler2 = ["C", "D"]
output   = ["O6", "D"]

[input]
joint = "O2"
""")


def _watt2_by_hand(pose):
    J = WATT2[pose]

    def _dist(p, q):
        return math.dist(J[p], J[q])

    def _dir(p, q):
        """Direction [deg] of the drawn line p -> q."""
        return math.degrees(math.atan2(J[q][1] - J[p][1], J[q][0] - J[p][0]))

    g1, a1, b1, c1 = _dist("O2", "O4"), _dist("O2", "A"), _dist("A", "B"), _dist("O4", "B")
    g2, a2, b2, c2 = _dist("O4", "O6"), _dist("O4", "C"), _dist("C", "D"), _dist("O6", "D")
    # the rocker O4B swings between the folded (B-O2 = b1 - a1) and stretched (a1 + b1) positions,
    # on the drawn side of O4 -> O2 (counterclockwise from it: B is left of the line O4 -> O2)
    ob, oo = np.subtract(J["B"], J["O4"]), np.subtract(J["O2"], J["O4"])
    assert oo[0] * ob[1] - oo[1] * ob[0] > 0
    frame = _dir("O4", "O2")
    lo, hi = frame + _law(g1, c1, b1 - a1), frame + _law(g1, c1, a1 + b1)
    shift = 360 * math.floor((lo + 180) / 360)
    swing = (lo - shift, hi - shift)  # theta_rocker is the direction O4 -> B
    # loop 2's crank angle at O4 from O4 -> O6 over the swing; mu from the diagonal C-O6
    offset = _dir("O4", "C") - _dir("O4", "B") - _dir("O4", "O6")
    phi = np.radians(np.linspace(swing[0], swing[1], 200001) + offset)
    diag2 = g2 * g2 + a2 * a2 - 2 * g2 * a2 * np.cos(phi)
    mu2 = np.degrees(np.arccos((b2 * b2 + c2 * c2 - diag2) / (2 * b2 * c2)))
    return {"lengths1": (g1, a1, b1, c1), "lengths2": (g2, a2, b2, c2), "swing": swing,
            "mu1": (_law(b1, c1, g1 - a1), _law(b1, c1, g1 + a1)), "mu2": (mu2.min(), mu2.max())}


@pytest.mark.parametrize("pose", ["near", "far"])
def test_watt2_off_the_origin(tmp_path, capsys, pose):
    """loopsolve.kinematics.info.x__fourbars__mutmut_69 (two four-bars sorted by their dicts: TypeError),
    x__fourbars__mutmut_89 (the crank length measured from the origin, not from its pivot O2),
    x__fourbars__mutmut_159 / x__fourbars__mutmut_269 (driven_by), x__fourbars__mutmut_169 (the
    second loop's range intersected with None), x__fourbars__mutmut_179 (the first loop's output
    range offset divided by psi0), x__fourbars__mutmut_199 (the rocker's mirrored swing, 44 deg away,
    counted as reachable: "near"), x__fourbars__mutmut_209 (the swing's start moved by other whole
    turns than its end: "far"), x__fourbars__mutmut_319 (the joints' output_pin key)."""
    d = _info_json(capsys, _watt2_file(tmp_path, pose))
    want = _watt2_by_hand(pose)
    fb1, fb2 = d["fourbars"]
    assert fb1["links"] == {"ground": "ground", "input": "crank", "coupler": "coupler", "output": "rocker"}
    assert fb2["links"] == {"ground": "ground", "input": "rocker", "coupler": "coupler2", "output": "output"}
    for fb, lengths in ((fb1, want["lengths1"]), (fb2, want["lengths2"])):
        np.testing.assert_allclose([fb["lengths"][k] for k in ("ground", "input", "coupler", "output")], lengths,
                                   rtol=1e-9)
    # loop 1: S + L = 20 + 60 < 58 + 25 with the crank shortest; loop 2: 20 + 70 < 60 + 45, O4C shortest
    assert (fb1["grashof"], fb1["input_motion"], fb1["driven_by"]) == ("crank-rocker", "turns fully", "input")
    assert fb1["input_range"] == [[-180.0, 180.0]]
    assert fb1["joints"] == {"input_pivot": "O2", "input_pin": "A", "output_pin": "B", "output_pivot": "O4"}
    np.testing.assert_allclose(fb1["transmission_angle_range"], want["mu1"], atol=1e-9)
    assert (fb2["grashof"], fb2["input"], fb2["input_motion"], fb2["driven_by"]) == \
        ("crank-rocker", "theta_rocker", "rocks", "loop1")
    assert fb2["joints"] == {"input_pivot": "O4", "input_pin": "C", "output_pin": "D", "output_pivot": "O6"}
    np.testing.assert_allclose(fb2["input_range"], [want["swing"]], atol=1e-9)
    np.testing.assert_allclose(fb2["transmission_angle_range"], want["mu2"], atol=1e-6)


def test_watt2_text(tmp_path, capsys):
    """loopsolve.kinematics.info.x_format_info__mutmut_153: the second loop's line must say what drives it."""
    lines = _info_text(capsys, _watt2_file(tmp_path, "near"))
    lo, hi = _watt2_by_hand("near")["swing"]
    assert f"    input theta_rocker rocks, driven by loop1: range (deg) [{lo:.6g}, {hi:.6g}]" in lines
    assert "    input theta_crank turns fully: range (deg) [-180, 180]" in lines


def test_second_fourbar_drawn_straight_cannot_move(capsys):
    """loopsolve.kinematics.info.x__fourbars__mutmut_289: a second four-bar whose frame is as long as its
    other three links together (75 = 20 + 30 + 25) only closes stretched out straight: its input,
    the first loop's rocker, cannot move (the mutant said "rocks")."""
    from loopsolve.kinematics.info import format_info

    fb1 = {"r1": {"length": "r1", "angle": 0}, "r2": {"length": "r2", "angle": "theta2"},
           "r3": {"length": "r3", "angle": "theta3"}, "r4": {"length": "r4", "angle": "theta4"}}
    base = {"r1": 60, "r2": 25, "r3": 70, "r4": 45}
    pose = ls.build_mechanism({"name": "fourbar", "units": {"length": "mm", "angle": "deg"}, "parameters": base,
                               "variables": {"theta2": {"input": True, "guess": 60}, "theta3": {"guess": 20},
                                             "theta4": {"guess": 80}},
                               "vectors": fb1, "loops": [{"equation": "r2 + r3 = r1 + r4"}]}).solve(60)
    line = pose["theta4"] + 100  # the arm O4C (100 deg on from O4B), coupler2 and O4O6 all along it
    mech = ls.build_mechanism({
        "name": "locked", "units": {"length": "mm", "angle": "deg"},
        "parameters": dict(base, a2=20, b2=30, c2=25, g2=75, frame2=line),
        "variables": {"theta2": {"input": True, "guess": 60}, "theta3": {"guess": pose["theta3"]},
                      "theta4": {"guess": pose["theta4"]}, "theta5": {"guess": line},
                      "theta6": {"guess": line + 180}},
        "vectors": dict(fb1, r7={"length": "a2", "angle": "theta4 + 100"}, r5={"length": "b2", "angle": "theta5"},
                        r6={"length": "c2", "angle": "theta6"}, r8={"length": "g2", "angle": "frame2"}),
        "loops": [{"equation": "r2 + r3 = r1 + r4"}, {"equation": "r7 + r5 = r8 + r6"}]})
    d = mech.info()
    fb1, fb2 = d["fourbars"]
    assert (fb1["input_motion"], fb1["input_range"]) == ("turns fully", [[-180.0, 180.0]])
    assert (fb2["input"], fb2["driven_by"], fb2["input_motion"], fb2["input_range"]) == \
        ("theta4", "loop1", "cannot move", [])
    assert "    input theta4 cannot move, driven by loop1: range (deg) none" in format_info(d).splitlines()


def test_watt1_has_one_fourbar():
    """loopsolve.kinematics.info.x__diagram_candidates__mutmut_26: the Watt I's second loop (crank, coupler,
    link6, link5) does not contain the frame: it is no four-bar on the ground."""
    d = ls.load(ls.models_dir() / "watt1_sixbar.toml").info()
    assert [fb["loop"] for fb in d["fourbars"]] == ["loop1"]
    assert d["fourbars"][0]["links"]["ground"] == "ground"


# ---------------------------------------------------------------------------------------------
# Quick returns written as vector loops.

def _slotted_lever(d, r2, frame_angle, length_unit, theta2=0.0):
    """A crank (r2, theta2) on a frame vector d at frame_angle; the lever r4 = (s, theta4) through the pin."""
    t = math.radians(frame_angle)
    pin = (d * math.cos(t) + r2 * math.cos(math.radians(theta2)), d * math.sin(t) + r2 * math.sin(math.radians(theta2)))
    return f"""
name = "Slotted lever"
units = {{ length = "{length_unit}", angle = "deg" }}

[parameters]
d = {d}
r2 = {r2}

[variables]
theta2 = {{ input = true, guess = {theta2} }}
theta4 = {{ guess = {math.degrees(math.atan2(pin[1], pin[0]))!r} }}
s = {{ guess = {math.hypot(*pin)!r} }}

[vectors]
r1 = {{ length = "d", angle = {frame_angle} }}
r2 = {{ length = "r2", angle = "theta2" }}
r4 = {{ length = "s", angle = "theta4" }}

[[loops]]
equation = "r1 + r2 = r4"
"""


def test_quick_return_in_metres(tmp_path, capsys):
    """loopsolve.kinematics.info.x_info__mutmut_48 (a length variable's kind), x__quick_returns__mutmut_99
    (frames shorter than 1 skipped: 0.2 m), x__quick_returns__mutmut_129 (always "whitworth"),
    x__quick_returns__mutmut_139 (the advance_angle key), x__quick_returns__mutmut_169 /
    x__quick_returns__mutmut_179 (the lever swing as the output stroke, with its unit)."""
    d = _info_json(capsys, _write(tmp_path, "metres", _slotted_lever(0.2, 0.08, 100, "m")))
    assert [(v["name"], v["kind"], v["input"]) for v in d["variables"]] == [
        ("theta2", "angle", True), ("theta4", "angle", False), ("s", "length", False)]
    (qr,) = d["quick_return"]
    assert set(qr) == {"loop", "crank", "lever", "slider", "r2", "d", "type", "time_ratio", "advance_angle",
                       "return_angle", "rocking_angle", "stroke", "rams"}
    assert (qr["type"], qr["crank"], qr["lever"], qr["slider"]) == ("crank-slotted-lever", "r2", "theta4", "s")
    assert (qr["d"], qr["r2"]) == (pytest.approx(0.2, abs=1e-15), pytest.approx(0.08, abs=1e-15))
    ret = math.degrees(2 * math.acos(0.08 / 0.2))  # the crank turns this far while the lever returns
    swing = math.degrees(2 * math.asin(0.08 / 0.2))
    assert qr["return_angle"] == pytest.approx(ret, abs=1e-9)
    assert qr["advance_angle"] == pytest.approx(360 - ret, abs=1e-9)
    assert qr["time_ratio"] == pytest.approx((360 - ret) / ret, abs=1e-12)
    assert qr["rocking_angle"] == pytest.approx(swing, abs=1e-9)
    assert qr["stroke"] == {"variable": "theta4", "value": pytest.approx(swing, abs=1e-9), "unit": "deg"}
    assert qr["rams"] == []


def test_quick_return_after_a_loop_that_is_none(tmp_path):
    """loopsolve.kinematics.info.x__quick_returns__mutmut_109: a first loop with a crank and a sliding vector
    but no frame (its two fixed vectors cancel: d = 0) stopped the search before the real quick
    return in the second loop."""
    text = _slotted_lever(200, 100, 90, "mm").replace(
        'equation = "r1 + r2 = r4"',
        'equation = "ra + r2 = r5 + rb"\n\n[[loops]]\nequation = "r1 + r2 = r4"').replace(
        "[vectors]", '[vectors]\nra = { length = 30, angle = 45 }\nrb = { length = 30, angle = 45 }\n'
                     'r5 = { length = "s5", angle = "theta5" }').replace(
        "[variables]", "[variables]\ns5 = { guess = 100 }\ntheta5 = { guess = 1 }")
    d = ls.loads(text, source="two_loops.toml").info()
    (qr,) = d["quick_return"]
    assert (qr["loop"], qr["type"], qr["slider"]) == ("loop2", "crank-slotted-lever", "s")
    assert qr["time_ratio"] == pytest.approx(2.0, abs=1e-12)  # d = 2 r2: return angle 2 acos(1/2) = 120


def test_two_sliding_vectors_are_no_slotted_lever(tmp_path):
    """loopsolve.kinematics.info.x__quick_returns__mutmut_69: a loop with one crank and two sliding vectors
    (r1 + r2 = r4 + r5, r5 fixed by a second loop) is no crank-and-slotted-lever of frame |r1|."""
    text = _slotted_lever(200, 100, 90, "mm").replace(
        'equation = "r1 + r2 = r4"',
        'equation = "r1 + r2 = r4 + r5"\n\n[[loops]]\nequation = "r5 = r8"').replace(
        "[vectors]", '[vectors]\nr5 = { length = "s5", angle = "theta5" }\nr8 = { x = 30, y = 40 }').replace(
        "[variables]", "[variables]\ns5 = { guess = 50 }\ntheta5 = { guess = 53 }")
    mech = ls.loads(text, source="two_slides.toml")
    assert mech.solve(0)["s5"] == pytest.approx(50, abs=1e-9)  # it assembles
    assert mech.info()["quick_return"] == []


def test_whitworth_ram(capsys):
    """loopsolve.kinematics.info.x__quick_returns__mutmut_209 / x__quick_returns__mutmut_229 (the ram's
    variable and the stroke's value key), x__quick_returns__mutmut_239 (the Whitworth's advance
    angle), x__stroke__mutmut_90 / x__stroke__mutmut_120 (the ram's time ratio),
    x_format_info__mutmut_233 (the time ratio on the ram's line)."""
    path = ls.models_dir() / "whitworth_quick_return.toml"
    J = {"O2": (0, 30), "O4": (0, 0), "A": (51.961524, 60), "D": (-26.186147, -30.237158), "E": (89.941861, 0)}
    r2, d = math.dist(J["O2"], J["A"]), math.dist(J["O2"], J["O4"])
    arm, rod = math.dist(J["O4"], J["D"]), math.dist(J["D"], J["E"])
    # the ram (on the line through O4) is farthest with the lever arm O4D along +x, the slot and the
    # pin A on the -x side of O4: crank angle 180 + asin(d / r2); nearest 180 deg of lever later,
    # crank angle -asin(d / r2). From nearest to farthest the crank turns 180 + 2 asin(d / r2).
    advance = 180 + 2 * math.degrees(math.asin(d / r2))
    data = _info_json(capsys, path)
    (qr,) = data["quick_return"]
    assert (qr["type"], qr["r2"], qr["d"]) == ("whitworth", pytest.approx(r2, abs=1e-9), pytest.approx(d, abs=1e-9))
    assert qr["advance_angle"] == pytest.approx(advance, abs=1e-6)
    assert qr["return_angle"] == pytest.approx(360 - advance, abs=1e-6)
    assert qr["time_ratio"] == pytest.approx(advance / (360 - advance), abs=1e-8)
    assert qr["stroke"] == {"variable": "s_way", "value": pytest.approx(2 * arm, abs=1e-6), "unit": "mm"}
    (ram,) = qr["rams"]
    assert ram["variable"] == "s_way"
    assert (ram["min"], ram["max"]) == (pytest.approx(rod - arm, abs=1e-6), pytest.approx(rod + arm, abs=1e-6))
    assert ram["time_ratio"] == pytest.approx(advance / (360 - advance), abs=1e-8)
    lines = _info_text(capsys, path)
    assert (f"    stroke of s_way: {ram['stroke']:.6g} mm ({ram['min']:.6g} to {ram['max']:.6g}), "
            f"time ratio {advance / (360 - advance):.6g}") in lines
    assert (f"    time ratio {advance / (360 - advance):.6g} (advance {advance:.6g}, "
            f"return {360 - advance:.6g} deg)") in lines


def _cos_angle(a, b, opposite):
    """Angle [deg] between sides a and b of a triangle, from the side opposite it (law of cosines)."""
    return math.degrees(math.acos((a * a + b * b - opposite * opposite) / (2 * a * b)))



def test_info_fourbar_values_by_hand():
    """loopsolve.kinematics.info.x_info__mutmut_39/189/239 renamed the variables' key, dropped the crank length
    from the input range and reported the transmission angle's maximum twice."""
    data = ls.load(ls.models_dir() / "thesis_crank_rocker.toml").info()
    assert [(v["name"], v["kind"], v["input"]) for v in data["variables"]] == [
        ("theta2", "angle", True), ("theta3", "angle", False), ("theta4", "angle", False)]
    (fb,) = data["fourbars"]
    assert fb["links"] == {"ground": "r1", "input": "r2", "coupler": "r3", "output": "r4"}
    assert (fb["grashof"], fb["input_motion"]) == ("crank-rocker", "turns fully")
    # transmission angle (coupler r3 = 70 to rocker r4 = 45) is extreme with the crank along the ground:
    # the diagonal B-O4 is then r1 - r2 = 35 or r1 + r2 = 85
    lo, hi = fb["transmission_angle_range"]
    assert lo == _approx(_cos_angle(70, 45, 35)) and hi == _approx(_cos_angle(70, 45, 85))
    data = ls.load(ls.models_dir() / "double_rocker.toml").info()
    (fb,) = data["fourbars"]
    assert fb["grashof"] == "double rocker"
    # r1 = 60, r2 = 50, r3 = 20, r4 = 45: the crank stops where B-O4 = r3 + r4 = 65 or |r3 - r4| = 25
    a, b = _cos_angle(60, 50, 65), _cos_angle(60, 50, 25)
    assert [list(r) for r in fb["input_range"]] == [[_approx(-a), _approx(-b)], [_approx(b), _approx(a)]]



def test_info_quick_return_by_hand():
    """loopsolve.kinematics.info.x_info__mutmut_139 lost the angle conversion of the quick-return figures."""
    (qr,) = ls.load(ls.models_dir() / "quick_return.toml").info()["quick_return"]
    # crank r2 = 100 on pivot distance d = 200: the lever's extremes are tangent to the crank circle,
    # crank angle between them 2*acos(r2/d) for the return, the rest for the advance
    ret = math.degrees(2 * math.acos(100 / 200))
    assert qr["return_angle"] == _approx(ret) and qr["advance_angle"] == _approx(360 - ret)
    assert qr["time_ratio"] == _approx((360 - ret) / ret)
    assert qr["rocking_angle"] == _approx(2 * math.degrees(math.asin(100 / 200)))



def test_info_topology_of_a_diagram_model():
    """loopsolve.kinematics.info.x_info__mutmut_89 renamed the joints count of a diagram model's topology."""
    topo = ls.load(ls.models_dir() / "thesis_crank_rocker_diagram.toml").info()["topology"]
    assert (topo["links"], topo["joints"]) == (4, 4)  # ground, crank, coupler, rocker; four pins



def _approx(x):
    return pytest.approx(x, abs=1e-9)



def test_info_table_lines_by_hand(capsys):
    """loopsolve.kinematics.info.x_format_info__mutmut_15/115/165/215 and x__quick_returns__mutmut_156/256:
    the printed ``loopsolve info`` lines of a four-bar and of a crank-shaper (crank 40 on frame 100)."""
    assert main(["info", str(ls.models_dir() / "thesis_crank_rocker.toml")]) == 0
    out = capsys.readouterr().out
    first = out.splitlines()[0]
    assert first.startswith("Crank-rocker four-bar  (") and first.endswith("thesis_crank_rocker.toml)")
    assert "crank-rocker (input r2 25, coupler r3 70, output r4 45, ground r1 60)" in out
    assert f"transmission angle (deg): {_cos_angle(70, 45, 35):.6g} to {_cos_angle(70, 45, 85):.6g}" in out
    assert main(["info", str(ls.models_dir() / "crank_shaper.toml")]) == 0
    out = capsys.readouterr().out
    ret = math.degrees(2 * math.acos(40 / 100))
    assert "crank r_crank = 40, frame d = 100, lever theta_lever, slide s_slot" in out
    assert f"time ratio {(360 - ret) / ret:.6g} (advance {360 - ret:.6g}, return {ret:.6g} deg)" in out
    assert f"lever swing {2 * math.degrees(math.asin(0.4)):.6g} deg" in out
    (qr,) = ls.load(ls.models_dir() / "crank_shaper.toml").info()["quick_return"]
    (ram,) = qr["rams"]
    # the ram's extremes are at the lever's (rod term even in the lever angle): stroke = 2 |O4 D| sin(swing/2)
    lever = math.hypot(74.278135, 185.695338)
    assert ram["max"] - ram["min"] == pytest.approx(2 * lever * 0.4, rel=1e-8)
    assert f"({ram['min']:.6g} to {ram['max']:.6g})" in out
    assert ram["advance_angle"] + ram["return_angle"] == _approx(360)



def test_info_table_of_a_model_without_a_file():
    """loopsolve.kinematics.info.x_format_info__mutmut_15 printed garbage after the name of a Python-built model."""
    from loopsolve.kinematics.info import format_info

    mech = ls.fourbar(60, 25, 70, 45)
    assert format_info(mech.info()).splitlines()[0] == mech.name
