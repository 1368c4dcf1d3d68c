"""What a user takes away from ``synthesize``: the written design keeps the user's names, the classical
candidates are ranked by the stated rule, ``--crank`` steers the search, report fields have one unit and
sign, the JSON is strict, a poor fit is flagged, certificates agree with their defects.

Every reference is written here: Freudenstein's constants by Cramer's rule, the four-bar by circle
intersection and the law of cosines, the planted linkages' poses (``test_burmester.planted_pose``),
the score of the ranking rule from the candidates' pivots and lengths.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.errors import ModelError, SynthesisError

from support.cli import one_line_error, run
from support.models import fourbar_angles, fourbar_point, O2 as PO2, O4 as PO4, planted_pose
from support.synthesis import freudenstein_K, log10_targets

MODELS = ls.models_dir()
PATHMODEL = MODELS / "fourbar_path_synthesis.toml"
POSE_INPUTS = (20, 70, 120, 170, 220)

# a user's four-bar with its own point names: A is the crank pin, B the coupler-output pin
USER_FOURBAR = """\
name = "user four-bar"
units = { length = "mm", angle = "deg" }

[parameters]
r1 = 60
r2 = 25
r3 = 70
r4 = 45

[variables]
theta2 = { input = true, guess = 90.0, speed = "10rpm" }
theta3 = { guess = 16.1 }
theta4 = { guess = 80.7 }

[vectors]
r1 = { length = "r1", angle = 0 }
r2 = { length = "r2", angle = "theta2" }
r3 = { length = "r3", angle = "theta3" }
r4 = { length = "r4", angle = "theta4" }

[[loops]]
equation = "r2 + r3 = r1 + r4"

[points]
A = "r2"
B = "r2 + r3"
"""


def wrap(a, period=360.0):
    return (np.asarray(a, dtype=float) + period / 2) % period - period / 2


def check_certificate(cert, *, transmission=None):
    """Every flag of a certificate agrees with its list of defects (one meaning for every method)."""
    d = set(cert["defects"])
    assert cert["assembles"] == ("assembly" not in d), cert
    assert cert["one_circuit"] == (not ({"circuit", "branch", "assembly"} & d)), cert
    assert cert["order"] == ("order" not in d), cert
    if "crank" in cert and "crank" in d:
        assert cert["crank"] is False, cert
    if transmission is not None and cert.get("transmission") is not None and "transmission" not in d:
        assert transmission[0] <= cert["transmission"][0] and cert["transmission"][1] <= transmission[1]


def poses_csv(path, inputs, shift=None):
    rows = [planted_pose(t)[0] for t in inputs]
    if shift is not None:  # angles written in another turn
        rows = [(x, y, a + s) for (x, y, a), s in zip(rows, shift)]
    path.write_text("x,y,angle\n" + "".join(f"{x!r},{y!r},{a!r}\n" for x, y, a in rows))
    return path


# -- names kept -------------------------------------------------------------------------------------------------

def test_freudenstein_design_is_the_users_model_with_its_names(tmp_path):
    model = tmp_path / "user.toml"
    model.write_text(USER_FOURBAR)
    rows = log10_targets()
    tg = tmp_path / "log10.csv"
    tg.write_text("input,output\n" + "".join(f"{a!r},{b!r}\n" for a, b in rows))
    out, rep_path = tmp_path / "design.toml", tmp_path / "r.json"
    p = run("synthesize", model, "--method", "freudenstein", "--function", "theta4", "--targets", tg, "-o", out,
            "--report", rep_path, "-q")
    assert p.returncode == 0, p.stderr
    rep = json.loads(rep_path.read_text())
    design = ls.load(out)
    user = ls.load(model)
    # every name of the user's model, with the same meaning (the same vectors in the same loop and points)
    assert [pt.name for pt in design.points] == ["A", "B"]
    assert [(pt.name, pt.text) for pt in design.points] == [(pt.name, pt.text) for pt in user.points]
    assert [v.name for v in design.variables] == [v.name for v in user.variables]
    assert [pr.name for pr in design.parameters] == [pr.name for pr in user.parameters]
    assert [lp.text for lp in design.loops] == [lp.text for lp in user.loops]
    assert design.variable("theta2").speed == pytest.approx(user.variable("theta2").speed)
    assert sorted(rep["parameters"]) == ["r1", "r2", "r3", "r4"]
    # the classical design by hand: K by Cramer's rule, the ground kept at the model's r1 = 60
    k1, k2, k3 = freudenstein_K(rows)
    r1 = 60.0
    r2s, r4s = r1 / k1, r1 / k2
    r3 = math.sqrt(r1 * r1 + r2s * r2s + r4s * r4s - 2 * r2s * r4s * k3)
    assert (rep["parameters"]["r2"], rep["parameters"]["r3"], rep["parameters"]["r4"]) == \
        pytest.approx((abs(r2s), r3, abs(r4s)), rel=1e-9)
    for (x, y), t in zip(rows, rep["targets"]):
        s = design.solve(t["input"], mode=rep["mode"])
        A = r2s * np.array([math.cos(math.radians(x)), math.sin(math.radians(x))])  # crank pin
        B = np.array([r1, 0.0]) + r4s * np.array([math.cos(math.radians(y)), math.sin(math.radians(y))])
        assert (s["A_x"], s["A_y"]) == pytest.approx(tuple(A), abs=1e-7)
        assert (s["B_x"], s["B_y"]) == pytest.approx(tuple(B), abs=1e-7)
        assert float(wrap(s["theta4"] - y)) == pytest.approx(0, abs=1e-7)


def test_burmester_design_is_the_users_model_with_its_names(tmp_path):
    tg = poses_csv(tmp_path / "poses.csv", POSE_INPUTS)
    out, rep_path = tmp_path / "design.toml", tmp_path / "r.json"
    p = run("synthesize", PATHMODEL, "--method", "burmester", "--motion", "P", "--link", "theta3", "--targets", tg,
            "-o", out, "--report", rep_path, "-q")
    assert p.returncode == 0, p.stderr
    rep = json.loads(rep_path.read_text())
    design, user = ls.load(out), ls.load(PATHMODEL)
    assert [(pt.name, pt.text) for pt in design.points] == [(pt.name, pt.text) for pt in user.points]
    assert [lp.text for lp in design.loops] == [lp.text for lp in user.loops]
    assert sorted(rep["parameters"]) == sorted(pr.name for pr in user.parameters)
    # the planted crank-rocker is the best by the ranking rule: its joints are the design's points
    for t, target in zip(POSE_INPUTS, rep["targets"]):
        s = design.solve(target["input"], mode=rep["mode"])
        (x, y, a), A, B = planted_pose(t)
        for name, want in (("O2", PO2), ("A", A), ("B", B), ("O4", PO4), ("P", (x, y))):
            assert (s[f"{name}_x"], s[f"{name}_y"]) == pytest.approx(tuple(want), abs=1e-7), name
        assert float(wrap(s["theta3"] - a)) == pytest.approx(0, abs=1e-7)
        assert target["target"] == pytest.approx([x, y, a]) and target["error"] < 1e-7


def test_a_model_that_cannot_hold_the_burmester_design_is_refused_with_the_reason(tmp_path):
    model = tmp_path / "user.toml"
    model.write_text(USER_FOURBAR)  # its ground pivot is fixed at the origin, B is a joint
    tg = poses_csv(tmp_path / "poses.csv", POSE_INPUTS)
    out = tmp_path / "design.toml"
    p = run("synthesize", model, "--method", "burmester", "--motion", "B", "--link", "theta3", "--targets", tg,
            "-o", out)
    err = one_line_error(p, code=3)
    assert "cannot hold" in err and "frame" in err and not out.exists()


def test_function_and_link_must_be_the_links_the_methods_relate(tmp_path):
    mech = ls.loads(USER_FOURBAR)
    with pytest.raises(ModelError, match="output link's angle .* 'theta4'"):
        ls.synthesize(mech, method="freudenstein", function="theta3", targets="input,output\n1,2\n3,4\n5,6\n")
    with pytest.raises(ModelError, match="guides the coupler.*'theta3'"):
        ls.synthesize(ls.load(PATHMODEL), method="burmester", motion="P", link="theta4",
                      targets=poses_csv(tmp_path / "p.csv", POSE_INPUTS))


# -- Burmester: the ranking rule, three to five poses ----------------------------------------------------------

def score_by_hand(c, poses, crank=False):
    """The report's rule recomputed from a candidate's pivots, lengths and crank angles (law of cosines)."""
    P = np.array([p[:2] for p in poses], dtype=float)
    span = max(math.dist(a, b) for a in P for b in P)
    centre = P.mean(axis=0)
    O2, O4 = np.array(c["pivots"]["O2"]), np.array(c["pivots"]["O4"])
    r1, r2, r3, r4 = c["lengths"]
    size = max(r1, r2, r3, r4, float(np.linalg.norm(O2 - centre)), float(np.linalg.norm(O4 - centre))) / span
    ins, d = c["inputs"], c["direction"]
    total = sum((d * (b - a)) % 360.0 for a, b in zip(ins, ins[1:]))
    th = ins[0] + d * np.linspace(0.0, 360.0 if crank else total, 20001)
    A = O2[:, None] + r2 * np.array([np.cos(np.radians(th)), np.sin(np.radians(th))])
    dd = np.sum((A - O4[:, None]) ** 2, axis=0)
    mu = np.degrees(np.arccos(np.clip((r3 * r3 + r4 * r4 - dd) / (2 * r3 * r4), -1, 1)))
    worst = float(np.min(np.minimum(mu, 180 - mu)))
    return size / math.sin(math.radians(worst)), size, worst


@pytest.mark.parametrize("inputs", [POSE_INPUTS, POSE_INPUTS[:4], (20, 70, 120)], ids=["five", "four", "three"])
def test_burmester_from_the_command_line_writes_the_best_ranked_certified_design(tmp_path, inputs):
    tg = poses_csv(tmp_path / "poses.csv", inputs)
    out, rep_path = tmp_path / "design.toml", tmp_path / "r.json"
    p = run("synthesize", PATHMODEL, "--method", "burmester", "--motion", "P", "--link", "theta3", "--targets", tg,
            "-o", out, "--report", rep_path, "-q")
    assert p.returncode == 0, p.stderr
    assert "best of" in p.stderr and "ranking rule" in p.stderr
    rep = json.loads(rep_path.read_text(), parse_constant=lambda c: pytest.fail(f"{c} in the JSON report"))
    assert "size" in rep["ranking"]["rule"] and "transmission" in rep["ranking"]["rule"]
    poses = [planted_pose(t)[0] for t in inputs]
    certified = [c for c in rep["candidates"] if c["certified"]]
    assert certified and [c["rank"] for c in certified] == list(range(1, len(certified) + 1))
    scores = []
    for c in certified:
        s, size, worst = score_by_hand(c, poses)
        assert c["size"] == pytest.approx(size, rel=1e-9)
        assert c["worst_transmission"] == pytest.approx(worst, abs=0.2)
        assert c["score"] == pytest.approx(s, rel=2e-2)
        scores.append(s)
    assert scores == sorted(scores) or max(np.diff(scores)) > -0.02 * max(scores)  # best first (to the rule)
    best = certified[0]
    assert rep["certificate"]["defects"] == [] and rep["fit"]["verdict"] == "exact"
    design = ls.load(out)
    p_ = rep["parameters"]
    assert [p_["r1"], p_["r2"], p_["r3"], p_["r4"]] == pytest.approx(best["lengths"], rel=1e-7)
    # the design meets every pose; its pins keep their distances to the pivots (a four-bar)
    for (x, y, a), target in zip(poses, rep["targets"]):
        s = design.solve(target["input"], mode=rep["mode"])
        assert (s["P_x"], s["P_y"]) == pytest.approx((x, y), abs=1e-7)
        assert float(wrap(s["theta3"] - a)) == pytest.approx(0, abs=1e-7)
        assert math.dist((s["A_x"], s["A_y"]), best["pivots"]["O2"]) == pytest.approx(best["lengths"][1], rel=1e-9)
        assert math.dist((s["B_x"], s["B_y"]), best["pivots"]["O4"]) == pytest.approx(best["lengths"][3], rel=1e-9)
    for c in rep["candidates"]:
        check_certificate(c["certificate"])
    check_certificate(rep["certificate"])


def test_burmester_with_crank_ranks_only_linkages_whose_input_turns_fully(tmp_path):
    tg = poses_csv(tmp_path / "poses.csv", POSE_INPUTS[:4])
    res = ls.synthesize(ls.load(PATHMODEL), method="burmester", motion="P", link="theta3", targets=tg, crank=True)
    rep = res.report
    for c in rep["candidates"]:
        if c["certified"]:  # the crank turns fully: r1 - r2 and r1 + r2 within |r3 - r4| .. r3 + r4 (closed form)
            r1, r2, r3, r4 = c["lengths"]
            assert abs(r1 - r2) >= abs(r3 - r4) - 1e-9 and r1 + r2 <= r3 + r4 + 1e-9
            s, _, worst = score_by_hand(c, [planted_pose(t)[0] for t in POSE_INPUTS[:4]], crank=True)
            assert c["score"] == pytest.approx(s, rel=2e-2)
    assert rep["certificate"]["crank"] is True and rep["certificate"]["defects"] == []


# -- --crank steers the general search -------------------------------------------------------------------------

def crank_turns(p, n=7200):
    """Whether the crank of the synthesis four-bar turns fully: the circle intersection exists all round."""
    t = np.radians(np.linspace(0, 360, n))
    a = t + math.radians(p.get("phi", 0.0) + p.get("theta0", 0.0))
    O4 = p["r1"] * np.array([math.cos(math.radians(p.get("theta0", 0.0))), math.sin(math.radians(p.get("theta0", 0.0)))])
    d = np.hypot(p["r2"] * np.cos(a) - O4[0], p["r2"] * np.sin(a) - O4[1])
    return bool(np.all((d <= p["r3"] + p["r4"]) & (d >= abs(p["r3"] - p["r4"]))))


def test_crank_finds_a_certified_crank_when_the_best_fit_is_not_one():
    # the targets: a triple rocker's coupler point (r2 = 2.8: s + l = 6.8 > p + q = 6.5) at five crank angles.
    # Unconstrained, the search finds it (exact); with --crank it must return a crank design that fits well.
    plant = {"r1": 4.0, "r2": 2.8, "r3": 3.5, "r4": 3.0, "rcx": 1.5, "rcy": 1.0}
    xs = [40, 55, 70, 85, 100]
    pts = [fourbar_point(plant, x, 1) for x in xs]
    assert not crank_turns(plant)
    targets = {"x": [q[0] for q in pts], "y": [q[1] for q in pts]}
    vary = {"r2": (0.3, 3.2), "r3": (1.0, 6.0), "r4": (1.0, 5.0)}
    mech = ls.load(PATHMODEL)
    free = ls.synthesize(mech, path="P", targets=targets, inputs=xs, vary=vary, progress=False, popsize=8)
    assert free.report["objective"] < 1e-20 and not crank_turns({**plant, **free.report["parameters"]})
    res = ls.synthesize(mech, path="P", targets=targets, inputs=xs, vary=vary, crank=True, progress=False, popsize=8)
    rep = res.report
    p = {**plant, **rep["parameters"]}
    assert rep["certificate"]["defects"] == [] and rep["certificate"]["crank"] is True
    assert crank_turns(p)  # the certificate by hand: the loop closes all the way round
    s = p["r1"], p["r2"], p["r3"], p["r4"]
    assert min(s) == p["r2"] and min(s) + max(s) <= sum(s) - min(s) - max(s)  # Grashof, the crank shortest
    # a good fit, and the report's values are the design's (closed form, in the design's mode)
    sign = 1 if rep["mode"] == "+" else -1
    for x, t in zip(xs, rep["targets"]):
        q = fourbar_point(p, x, sign)
        assert t["value"] == pytest.approx(list(q), abs=1e-7)
        assert t["error"] == pytest.approx(math.dist(q, t["target"]), abs=1e-9)
    assert rep["objective"] < 0.05 and rep["fit"]["verdict"] in ("close", "approximate")
    check_certificate(rep["certificate"])


# -- function generation: one unit, signed, design minus target ------------------------------------------------

RAD_FOURBAR = USER_FOURBAR.replace('angle = "deg"', 'angle = "rad"').replace(
    'guess = 90.0, speed = "10rpm"', 'guess = 1.5707963').replace("guess = 16.1", "guess = 0.281").replace(
    "guess = 80.7", "guess = 1.4085")


@pytest.mark.parametrize("unit", ["deg", "rad"])
def test_function_report_errors_are_signed_design_minus_target_in_the_model_unit(tmp_path, unit):
    x = np.linspace(1.6, 9.4, 7)
    a, b = 45 + 60 * (x - 1) / 9, 135 + 90 * np.log10(x)
    conv = (lambda v: v) if unit == "deg" else np.radians
    period = 360.0 if unit == "deg" else 2 * math.pi
    targets = {"input": conv(a), "output": conv(b)}
    mech = ls.loads(USER_FOURBAR if unit == "deg" else RAD_FOURBAR)
    reports = [ls.synthesize(mech, method="freudenstein", function="theta4", targets=targets).report]
    general = ls.synthesize(ls.loads(USER_FOURBAR if unit == "deg" else RAD_FOURBAR), function="theta4",
                            targets=targets, vary={"r2": (10, 60), "r3": (50, 200), "r4": (30, 150)}, mode=None,
                            popsize=8, maxiter=30, progress=False)
    reports.append(general.report)
    for rep in reports:
        total = 0.0
        for t, xi, yi in zip(rep["targets"], targets["input"], targets["output"]):
            assert t["input"] == pytest.approx(xi) and t["target"] == pytest.approx(yi)
            assert t["error"] == pytest.approx(float(wrap(t["value"] - yi, period)), abs=1e-12)
            total += (t["error"] if unit == "rad" else math.radians(t["error"])) ** 2
        assert rep["objective"] == pytest.approx(total, rel=1e-9)  # the contract's objective: radians squared
        errs = [t["error"] for t in rep["targets"]]
        assert min(errs) < 0 < max(errs)  # signed: a least-squares fit is on both sides
        if unit == "rad" and rep.get("method") == "freudenstein":  # in radians: each error below a tenth of one
            assert max(abs(e) for e in errs) < 0.1  # (the least-squares fit is within ~1.1 degrees)
        se = rep["structural_error"]
        assert se["max"] == pytest.approx(abs(se["signed"])) and se["max"] >= max(abs(e) for e in errs) - 1e-9


def test_freudenstein_report_values_are_the_written_designs(tmp_path):
    # seven targets, least squares: the value at each target is the written design's output there
    x = np.linspace(1.6, 9.4, 7)
    a, b = 45 + 60 * (x - 1) / 9, 135 + 90 * np.log10(x)
    res = ls.synthesize(ls.loads(USER_FOURBAR), method="freudenstein", function="theta4",
                        targets={"input": a, "output": b})
    rep = res.report
    design = ls.loads(res.to_toml())
    p = rep["parameters"]
    # the output by circle intersection from the written lengths (and the written offset of r4)
    off4 = math.radians(design.spec["vectors"]["r4"].get("offset", 0.0))
    for t in rep["targets"]:
        x2 = math.radians(t["input"])
        A = p["r2"] * np.array([math.cos(x2), math.sin(x2)])
        O4 = np.array([p["r1"], 0.0])
        outs = []
        for side in (1, -1):
            d = A - O4
            L = float(np.hypot(*d))
            along = (p["r4"] ** 2 - p["r3"] ** 2 + L * L) / (2 * L)
            h = math.sqrt(max(p["r4"] ** 2 - along ** 2, 0.0))
            B = O4 + along * d / L + side * h * np.array([-d[1], d[0]]) / L
            outs.append(math.degrees(math.atan2(B[1], B[0] - p["r1"]) - off4))
        v = min(outs, key=lambda o: abs(float(wrap(o - t["value"]))))
        assert float(wrap(v - t["value"])) == pytest.approx(0, abs=1e-7)
    # the certificate's Grashof margin: p + q - s - l of the design's lengths (positive: Grashof)
    s_ = sorted((p["r1"], p["r2"], p["r3"], p["r4"]))
    assert rep["certificate"]["grashof_margin"] == pytest.approx(s_[1] + s_[2] - s_[0] - s_[3], rel=1e-9)
    assert (rep["certificate"]["grashof_margin"] > 0) == (rep["certificate"]["grashof"] != "triple rocker")
    # and its Grashof class from the same lengths by the textbook table (shortest link: frame, input, coupler, output)
    lengths = [abs(p[k]) for k in ("r1", "r2", "r3", "r4")]
    ordered = sorted(lengths)
    expected = ("triple rocker" if ordered[0] + ordered[3] > ordered[1] + ordered[2] else
                ("double crank", "crank-rocker", "double rocker", "rocker-crank")[lengths.index(ordered[0])])
    assert rep["certificate"]["grashof"] == expected
    # the method's own precision points hold the targets, never the linkage's outputs
    for pr, (ai, bi) in zip(rep["design"]["precision"], zip(a, b)):
        assert (pr["input"], pr["output"]) == pytest.approx((ai, bi))
        assert pr["error"] == pytest.approx(pr["design_output"] - bi, abs=1e-12) and abs(pr["error"]) < 5
    check_certificate(rep["certificate"])


def test_freudenstein_max_errors_against_the_closed_form():
    # y = x^1.6 on 1..4, input 30..120 deg, output 90..180 deg: three Chebyshev points
    def f(v):
        return np.asarray(v, dtype=float) ** 1.6

    d = ls.freudenstein(f, (1, 4), (30, 120), (90, 180))
    k1, k2, k3 = d.K
    x = np.linspace(1, 4, 20001)
    t2 = np.radians(30 + 90 * (x - 1) / 3)
    want = 90 + 90 * (f(x) - 1) / (f(4) - 1)
    A, B, C = k1 - np.cos(t2), -np.sin(t2), k3 - k2 * np.cos(t2)
    base, half = np.arctan2(B, A), np.arccos(np.clip(-C / np.hypot(A, B), -1, 1))
    t4 = min((np.degrees(base + s * half) for s in (1, -1)), key=lambda v: abs(float(wrap(v[0] - want[0]))))
    err = wrap(t4 - want)
    assert d.max_error == pytest.approx(np.abs(err).max(), rel=1e-3)
    # in the function's units: degrees of output times (y1 - y0) / (output span)
    assert d.max_error_y == pytest.approx(np.abs(err).max() * (f(4) - 1) / 90, rel=1e-3)
    # targets only (least squares through seven angle pairs): the largest |output - wanted| at the targets
    from loopsolve.design.synthesis.classical.freudenstein import freudenstein_points

    xs = np.linspace(1, 4, 7)
    a, b = 30 + 90 * (xs - 1) / 3, 90 + 90 * (f(xs) - 1) / (f(4) - 1)
    dp = freudenstein_points(a, b, fit="least-squares")
    k1, k2, k3 = dp.K
    t2 = np.radians(a)
    A, B, C = k1 - np.cos(t2), -np.sin(t2), k3 - k2 * np.cos(t2)
    base, half = np.arctan2(B, A), np.arccos(np.clip(-C / np.hypot(A, B), -1, 1))
    t4 = min((np.degrees(base + s * half) for s in (1, -1)), key=lambda v: float(np.abs(wrap(v - b)).sum()))
    assert dp.max_error == pytest.approx(float(np.abs(wrap(t4 - b)).max()), rel=1e-9)
    assert dp.max_error_y == pytest.approx(dp.max_error, rel=1e-12)  # angles are the function here
    assert [pr[3] for pr in dp.precision] == pytest.approx(list(b))  # the targets, not the linkage's outputs


# -- strict JSON, poor fits -------------------------------------------------------------------------------------

def test_freudenstein_with_a_range_defect_writes_strict_json_with_the_errors(tmp_path):
    rows = log10_targets()
    tg = tmp_path / "log10.csv"
    tg.write_text("input,output\n" + "".join(f"{a!r},{b!r}\n" for a, b in rows))
    rep_path = tmp_path / "r.json"
    p = run("synthesize", MODELS / "prob1_fourbar.toml", "--method", "freudenstein", "--function", "theta4",
            "--targets", tg, "--range", "45:105", "--report", rep_path)
    one_line_error(p, 3)
    rep = json.loads(rep_path.read_text(), parse_constant=lambda c: pytest.fail(f"{c} in the JSON report"))
    assert rep["certificate"]["defects"] == ["range"]
    check_certificate(rep["certificate"])
    errs = [t["error"] for t in rep["targets"]]
    assert all(isinstance(e, float) and abs(e) < 1e-7 for e in errs)  # three points met exactly
    assert rep["objective"] == pytest.approx(sum(math.radians(e) ** 2 for e in errs), abs=1e-30)


def test_to_json_refuses_a_nan():
    res = ls.synthesize(ls.loads(USER_FOURBAR), method="freudenstein", function="theta4",
                        targets={"input": [r[0] for r in log10_targets()], "output": [r[1] for r in log10_targets()]})
    json.loads(json.dumps(res.report, allow_nan=False))
    res.report["objective"] = float("nan")
    with pytest.raises(ValueError):
        json.dumps(res.report, allow_nan=False)
    from loopsolve.design.synthesis.run import SynthesisResult

    fake = SynthesisResult.__new__(SynthesisResult)
    fake.report = {"objective": float("nan")}
    with pytest.raises(ValueError):
        fake.to_json()


def test_a_certified_design_far_from_every_target_is_a_poor_fit(tmp_path):
    # prob1's own coupler-output pin C at five inputs, moved 1000 mm: no crank length brings it there
    mech = ls.load(MODELS / "prob1_fourbar.toml")
    xs = [30, 45, 60, 75, 90]
    pts = [(mech.solve(x)["C_x"] + 1000.0, mech.solve(x)["C_y"]) for x in xs]
    tg = tmp_path / "far.csv"
    tg.write_text("x,y,input\n" + "".join(f"{x!r},{y!r},{i}\n" for (x, y), i in zip(pts, xs)))
    rep_path = tmp_path / "r.json"
    p = run("synthesize", MODELS / "prob1_fourbar.toml", "--path", "C", "--targets", tg, "--vary", "AB=15:25",
            "--mode", "guesses", "--popsize", "6", "--maxiter", "10", "--report", rep_path, "-q")
    assert p.returncode == 0, p.stderr
    rep = json.loads(rep_path.read_text())
    assert rep["certificate"]["defects"] == []  # it moves through the targets' inputs...
    fit = rep["fit"]  # ...but nowhere near them
    span = max(math.dist(a, b) for a in pts for b in pts)
    assert fit["scale"] == pytest.approx(span) and fit["max"] == pytest.approx(max(t["error"] for t in rep["targets"]))
    assert fit["relative"] == pytest.approx(fit["max"] / span) and fit["relative"] > 10
    assert fit["verdict"] == "poor"
    assert "poor fit" in p.stderr and "certified" in p.stderr


# -- planted-bug classes ----------------------------------------------------------------------------------------

def test_motion_targets_in_another_turn_give_the_same_design(tmp_path):
    plant = {"r1": 4.0, "r2": 1.0, "r3": 3.5, "r4": 3.0, "rcx": 1.5, "rcy": 1.0}
    xs = [30, 60, 90, 120]
    pts = [fourbar_point(plant, x, -1) for x in xs]  # the mode the model's guesses name
    ang = [fourbar_angles(plant, x, -1)[0] for x in xs]
    mech = ls.load(PATHMODEL)
    kw = dict(inputs=xs, vary={"r2": (0.5, 2.0), "rcx": (0.0, 3.0)}, mode="guesses", popsize=8, maxiter=20,
              progress=False)
    base = ls.synthesize(mech, motion="P", link="theta3",
                         targets={"x": [q[0] for q in pts], "y": [q[1] for q in pts], "angle": ang}, **kw)
    turned = ls.synthesize(mech, motion="P", link="theta3",
                           targets={"x": [q[0] for q in pts], "y": [q[1] for q in pts],
                                    "angle": [a + s for a, s in zip(ang, (360, 0, -360, 720))]}, **kw)
    for rep in (base.report, turned.report):
        assert rep["parameters"] == pytest.approx({"r2": 1.0, "rcx": 1.5}, abs=1e-8)
        assert rep["objective"] < 1e-20 and rep["certificate"]["defects"] == []
        for t in rep["targets"]:
            assert abs(t["dangle"]) < 1e-7 and t["value"][2] == pytest.approx(t["target"][2], abs=1e-7)
    # Burmester: the same poses with angles a turn off give the same design
    plain = ls.synthesize(ls.load(PATHMODEL), method="burmester", motion="P", link="theta3",
                          targets=poses_csv(tmp_path / "a.csv", POSE_INPUTS))
    off = ls.synthesize(ls.load(PATHMODEL), method="burmester", motion="P", link="theta3",
                        targets=poses_csv(tmp_path / "b.csv", POSE_INPUTS, shift=(360, -360, 0, 720, 360)))
    assert off.report["parameters"] == pytest.approx(plain.report["parameters"], abs=1e-7)
    assert off.report["objective"] < 1e-18


RAD_PATHMODEL = PATHMODEL.read_text().replace('angle = "deg"', 'angle = "rad"').replace(
    "guess = 60 }", "guess = 1.0471975511965976 }").replace("guess = 36 }", "guess = 0.6283185307179586 }").replace(
    "guess = 103 }", "guess = 1.7976891295541593 }").replace("offset = 90 }", 'offset = "pi/2" }')


def test_burmester_on_a_radian_model_reads_and_reports_radians(tmp_path):
    mech = ls.loads(RAD_PATHMODEL)
    assert mech.units.angle == "rad"
    rows = [planted_pose(t)[0] for t in POSE_INPUTS]
    tg = tmp_path / "poses.csv"
    tg.write_text("x,y,angle\n" + "".join(f"{x!r},{y!r},{math.radians(a)!r}\n" for x, y, a in rows))
    res = ls.synthesize(mech, method="burmester", motion="P", link="theta3", targets=tg)
    rep = res.report
    design = ls.loads(res.to_toml())
    for (x, y, a), t in zip(rows, rep["targets"]):
        s = design.solve(t["input"], mode=rep["mode"])  # the report's input is in radians: solve takes it so
        assert (s["P_x"], s["P_y"]) == pytest.approx((x, y), abs=1e-7)
        assert float(wrap(s["theta3"] - math.radians(a), 2 * math.pi)) == pytest.approx(0, abs=1e-9)
        assert t["target"][2] == pytest.approx(math.radians(a)) and abs(t["dangle"]) < 1e-9
    assert rep["parameters"]["theta0"] == pytest.approx(math.radians(10.0))  # the planted ground angle, radians
    # the candidates' crank angles are in radians too: the crank's direction is the input plus the ground angle
    best = next(c for c in rep["candidates"] if c["rank"] == 1)
    for i, t in zip(best["inputs"], rep["targets"]):
        assert float(wrap(i - t["input"] - math.radians(10.0), 2 * math.pi)) == pytest.approx(0, abs=1e-7)
    check_certificate(rep["certificate"])


def test_targets_as_rows_of_numbers_take_the_input_from_the_last_column():
    plant = {"r1": 4.0, "r2": 1.0, "r3": 3.5, "r4": 3.0, "rcx": 1.5, "rcy": 1.0}
    xs = [30.0, 50.0, 70.0, 90.0]
    rows = [[*fourbar_point(plant, x, -1), x] for x in xs]  # the mode the model's guesses name
    res = ls.synthesize(ls.load(PATHMODEL), path="P", targets=rows, vary={"r2": (0.5, 2.0)}, mode="guesses",
                        popsize=6, maxiter=10, progress=False)
    rep = res.report
    assert [t["input"] for t in rep["targets"]] == pytest.approx(xs)
    assert rep["parameters"]["r2"] == pytest.approx(1.0, abs=1e-9) and rep["objective"] < 1e-20
    for t, r in zip(rep["targets"], rows):
        assert t["target"] == pytest.approx(r[:2]) and t["value"] == pytest.approx(r[:2], abs=1e-9)


def test_every_certificate_agrees_with_its_defects(tmp_path):
    # Burmester with an order defect in every candidate, and the general method's certified design
    shuffled = poses_csv(tmp_path / "s.csv", (20, 120, 70, 170, 220))
    with pytest.raises(SynthesisError) as exc:
        ls.synthesize(ls.load(PATHMODEL), method="burmester", motion="P", link="theta3", targets=shuffled)
    rep = exc.value.report
    assert "order" in rep["certificate"]["defects"]
    check_certificate(rep["certificate"])
    for c in rep["candidates"]:
        check_certificate(c["certificate"])
        assert not c["certified"] and c["rank"] is None
    # the general method through a limit position: the certificate's flags follow its defects
    from loopsolve.design.synthesis.certificate import certify

    m = ls.load(MODELS / "double_rocker.toml")
    c = certify(m, np.radians([20.0, 40.0, 60.0, 80.0]), crank=True, transmission=(60, 120))
    check_certificate(c, transmission=(60, 120))
    assert "crank" in c["defects"]
    # a triple rocker (one circuit) asked to reach the other assembly at the next target: a branch defect
    tri = ls.load(PATHMODEL).with_parameters(r2=2.8)
    z1 = np.array([m_.z for m_ in tri.modes(100)][0], dtype=float)
    z2 = [np.array(m_.z, dtype=float) for m_ in tri.modes(120)]
    z2 = max(z2, key=lambda z: abs(math.remainder(z[2] - z1[2], 2 * math.pi)))  # the other assembly
    c = certify(tri, np.radians([100.0, 120.0]), poses=np.column_stack([z1, z2]))
    assert c["defects"] and set(c["defects"]) <= {"branch", "circuit"}
    check_certificate(c)
