"""``synthesize --method freudenstein|burmester`` and the structural error of function generators.

References are written here: the log10 generator's limit from the law of cosines, a planted
crank-rocker's poses from the circle intersection, the designs' outputs over the whole range from
the four-bar's closed form.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.errors import ModelError, SynthesisError

from support.cli import one_line_error, run
from support.models import G2, G4, intersect, L1, L2, L3, L4, pose
from support.synthesis import freudenstein_K, log10_targets

MODELS = Path(__file__).resolve().parents[2] / "models"
FOURBAR = MODELS / "prob1_fourbar.toml"
PATHMODEL = MODELS / "fourbar_path_synthesis.toml"  # frame and coupler point are parameters: holds any four-bar


# -- Freudenstein: y = log10 x on 1..10, input 45..105 deg, output 135..225 deg ---------------------------


@pytest.fixture
def log10_csv(tmp_path):
    p = tmp_path / "log10.csv"
    p.write_text("input,output\n" + "".join(f"{a!r},{b!r}\n" for a, b in log10_targets()))
    return p


def test_cli_freudenstein_reports_the_range_defect_at_the_law_of_cosines_limit(log10_csv, tmp_path):
    rep_path, out = tmp_path / "r.json", tmp_path / "d.toml"
    p = run("synthesize", FOURBAR, "--method", "freudenstein", "--function", "theta4", "--targets", log10_csv,
            "--range", "45:105", "--report", rep_path, "-o", out, "-q")
    err = one_line_error(p, 3)  # no usable design: exit 3, the report still written, no model file
    assert "range" in err and "48.95" in err
    assert not out.exists()
    rep = json.loads(rep_path.read_text())
    k1, k2, k3 = freudenstein_K(log10_targets())
    assert rep["K"] == pytest.approx([k1, k2, k3], rel=1e-9)
    assert rep["K"] == pytest.approx([2.00276, -0.69862, 1.08420], abs=1e-5)  # the textbook's values
    # links for r1 = 1: r2 = 1/K1, r4 = 1/K2, r3^2 = 1 + r2^2 + r4^2 - 2 r2 r4 K3; the input limit is where
    # the coupler and the output link are in line: |O2 O4 - crank pin| = r3 + r4 or |r3 - r4|
    r2, r4 = 1 / k1, abs(1 / k2)
    r3 = math.sqrt(1 + r2 * r2 + r4 * r4 - 2 * r2 * (1 / k2) * k3)
    limits = []
    for d in (r3 + r4, abs(r3 - r4)):
        c = (1 + r2 * r2 - d * d) / (2 * r2)  # law of cosines: d^2 = 1 + r2^2 - 2 r2 cos t2
        if abs(c) <= 1:
            limits.append(math.degrees(math.acos(c)))
    limit = min(limits, key=lambda t: abs(t - 49))
    assert limit == pytest.approx(48.95, abs=0.01)
    assert rep["certificate"]["defects"] == ["range"]
    (rng,) = [d for d in rep["design"]["defects"] if d["kind"] == "range"]
    assert rng["input"] == pytest.approx(limit, abs=1e-3)
    se = rep["structural_error"]
    assert se["range"] == [45.0, 105.0]
    assert se["reached"][0] == pytest.approx(limit, abs=0.05) and se["reached"][1] == pytest.approx(105)


def test_python_freudenstein_method_raises_with_the_report(log10_csv):
    with pytest.raises(SynthesisError) as exc:
        ls.synthesize(ls.load(FOURBAR), method="freudenstein", function="theta4", targets=log10_csv,
                      input_range=(45, 105))
    assert exc.value.report["certificate"]["defects"] == ["range"]
    # within the targets' own span the same design is usable and meets them
    res = ls.synthesize(ls.load(FOURBAR), method="freudenstein", function="theta4", targets=log10_csv)
    assert res.report["certificate"]["defects"] == []
    assert max(abs(t["error"]) for t in res.report["targets"]) < 1e-9


# -- Burmester: five poses of a planted crank-rocker ----------------------------------------------------------


INPUTS = (10, 70, 130, 190, 250)


@pytest.fixture
def fourbar_file(tmp_path):
    p = tmp_path / "fourbar.toml"
    p.write_text(ls.dumps(ls.fourbar(60, 25, 70, 45)))
    return p


@pytest.fixture
def poses_csv(tmp_path):
    p = tmp_path / "poses.csv"
    p.write_text("x,y,angle\n" + "".join(f"{x!r},{y!r},{a!r}\n" for x, y, a in map(pose, INPUTS)))
    return p


def test_cli_burmester_returns_the_planted_crank_rocker(poses_csv, tmp_path):
    rep_path, out = tmp_path / "r.json", tmp_path / "d.toml"
    p = run("synthesize", PATHMODEL, "--method", "burmester", "--motion", "P", "--link", "theta3",
            "--targets", poses_csv, "--report", rep_path, "-o", out, "-q")
    assert p.returncode == 0, p.stderr
    rep = json.loads(rep_path.read_text())
    assert rep["method"] == "burmester" and rep["certificate"]["defects"] == []
    # the planted dyads are among the Ball-Burmester points: centres at the ground pivots, radii the links
    centers = [(np.array(d["center"]), d["radius"]) for d in rep["dyads"]]
    for g, r in ((G2, L2), (G4, L4)):
        assert any(np.allclose(c, g, atol=1e-6) and abs(rad - r) < 1e-6 for c, rad in centers), (g, centers)
    planted = [c for c in rep["candidates"] if sorted(c["lengths"]) == pytest.approx(sorted((L1, L2, L3, L4)))]
    assert planted and any(c["certified"] for c in planted)
    # the written model meets every pose (circle intersection above) at the reported inputs
    mech = ls.load(out)
    for t, target in zip(INPUTS, rep["targets"]):
        s = mech.solve(target["input"], mode=rep["mode"])
        x, y, a = pose(t)
        assert (s["P_x"], s["P_y"]) == pytest.approx((x, y), abs=1e-7)
        assert (s["theta3"] - a + 180) % 360 - 180 == pytest.approx(0, abs=1e-7)


# The hand-built motion problem with an order defect: the planted crank-rocker's poses listed in the crank order
# 10°, 130°, 70°, 190°, 250°. Every exact four-bar (Burmester's six) meets them, none in the given order. For the
# planted crank-rocker, by hand: the crank steps +120, -60, +120, +60 degrees, so visiting the poses in this order
# turns it 120 + 300 + 120 + 60 = 600 degrees one way (840 the other), more than one turn: an order defect.
SHUFFLED = (10, 130, 70, 190, 250)


@pytest.fixture
def shuffled_csv(tmp_path):
    p = tmp_path / "shuffled.csv"
    p.write_text("x,y,angle\n" + "".join(f"{x!r},{y!r},{a!r}\n" for x, y, a in map(pose, SHUFFLED)))
    return p


def test_cli_burmester_flags_the_order_defect_of_the_only_exact_four_bars(fourbar_file, shuffled_csv, tmp_path):
    steps = [(b - a + 180) % 360 - 180 for a, b in zip(SHUFFLED, SHUFFLED[1:])]
    turn = min(sum((d * s) % 360 for s in steps) for d in (1, -1))
    assert turn == 600  # the hand count above
    rep_path, out = tmp_path / "r.json", tmp_path / "d.toml"
    p = run("synthesize", fourbar_file, "--method", "burmester", "--motion", "C", "--link", "theta3",
            "--targets", shuffled_csv, "--report", rep_path, "-o", out)
    err = one_line_error(p, code=3)
    assert "Burmester" in err and "order" in err
    assert not out.exists()  # a defective design is not written
    rep = json.loads(rep_path.read_text(), parse_constant=lambda c: pytest.fail(f"{c} in the JSON report"))
    assert rep["method"] == "burmester" and rep["certificate"]["defects"] == ["order"]
    assert rep["candidates"] and all(not c["certified"] and [d["kind"] for d in c["defects"]] == ["order"]
                                     for c in rep["candidates"])
    [planted] = [c for c in rep["candidates"] if sorted(c["lengths"]) == pytest.approx(sorted((L1, L2, L3, L4)))]
    assert [(x - t + 180) % 360 - 180 for x, t in zip(planted["inputs"], SHUFFLED)] == pytest.approx([0] * 5, abs=1e-7)
    assert f"{turn:.1f}" in planted["defects"][0]["message"]


def test_python_burmester_flags_the_order_defect(fourbar_file, shuffled_csv):
    with pytest.raises(SynthesisError) as exc:
        ls.synthesize(ls.load(fourbar_file), method="burmester", motion="C", link="theta3", targets=shuffled_csv)
    assert exc.value.report["certificate"]["defects"] == ["order"]
    # the same poses in the crank's order are met by a certified design
    ordered = shuffled_csv.parent / "ordered.csv"
    ordered.write_text("x,y,angle\n" + "".join(f"{x!r},{y!r},{a!r}\n" for x, y, a in map(pose, sorted(SHUFFLED))))
    res = ls.synthesize(ls.load(PATHMODEL), method="burmester", motion="P", link="theta3", targets=ordered)
    assert res.report["certificate"]["defects"] == []


# -- one-line errors, exit 2 -----------------------------------------------------------------------------------

def test_cli_malformed_pose_file(fourbar_file, tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y,angle\n1,2,30\n3,four,40\n")
    err = one_line_error(run("synthesize", fourbar_file, "--method", "burmester", "--motion", "C", "--link",
                             "theta3", "--targets", bad))
    assert "line 3" in err and "'four'" in err


def test_cli_unknown_link(fourbar_file, poses_csv):
    err = one_line_error(run("synthesize", fourbar_file, "--method", "burmester", "--motion", "C", "--link",
                             "theta9", "--targets", poses_csv))
    assert "theta9" in err and "theta3" in err


def test_cli_too_few_poses(fourbar_file, tmp_path):
    two = tmp_path / "two.csv"
    two.write_text("x,y,angle\n" + "".join(f"{x!r},{y!r},{a!r}\n" for x, y, a in map(pose, INPUTS[:2])))
    err = one_line_error(run("synthesize", fourbar_file, "--method", "burmester", "--motion", "C", "--link",
                             "theta3", "--targets", two))
    assert "too few poses" in err and "2" in err


def test_cli_method_on_a_non_fourbar(poses_csv):
    err = one_line_error(run("synthesize", MODELS / "watt1_sixbar.toml", "--method", "burmester", "--motion", "C",
                             "--link", "theta3", "--targets", poses_csv))
    assert "four-bar" in err and "general method" in err


def test_cli_general_needs_vary_and_classical_refuses_it(fourbar_file, poses_csv):
    err = one_line_error(run("synthesize", fourbar_file, "--function", "theta4", "--targets", poses_csv))
    assert "--vary" in err
    err = one_line_error(run("synthesize", fourbar_file, "--method", "burmester", "--motion", "C", "--link",
                             "theta3", "--targets", poses_csv, "--vary", "r2=1:2"))
    assert "--vary" in err and "general method" in err


# -- structural error over the whole input range ---------------------------------------------------------------

def test_structural_error_of_a_general_function_design_against_the_closed_form(tmp_path):
    # targets: the output angle of a known four-bar (r1..r4 = 60, 25, 70, 45) at four inputs; the design
    # varies the crank only, so between the targets its output differs from the PCHIP through them.
    from scipy.interpolate import PchipInterpolator

    def theta4(t2_deg, r1=60.0, r2=25.0, r3=70.0, r4=45.0):
        t2 = np.radians(t2_deg)
        A = np.stack([r2 * np.cos(t2), r2 * np.sin(t2)], axis=-1)
        out = []
        for a in np.atleast_2d(A):
            B = intersect(a, r3, np.array([r1, 0.0]), r4)
            out.append(math.degrees(math.atan2(B[1], B[0] - r1)))
        return np.array(out)

    xs = np.array([20.0, 60.0, 100.0, 140.0])
    ys = theta4(xs)
    mech = ls.fourbar(60, 25, 70, 45)
    targets = {"input": xs, "output": ys + np.array([0.0, 0.3, -0.2, 0.0])}  # not exactly reachable
    res = ls.synthesize(mech, function="theta4", targets=targets, vary={"r2": (20, 30)}, popsize=6, maxiter=20,
                        restarts=1, progress=False)
    se = res.report["structural_error"]
    r2 = res.report["parameters"]["r2"]
    assert se["range"] == [20.0, 140.0] and se["reached"] == pytest.approx([20.0, 140.0])
    dense = np.linspace(20, 140, 4001)
    ref = PchipInterpolator(xs, targets["output"])(dense)
    e = np.abs(theta4(dense, r2=r2) - ref)
    assert se["max"] == pytest.approx(e.max(), rel=1e-3, abs=1e-4)
    assert se["at"] == pytest.approx(dense[np.argmax(e)], abs=0.5)


def test_structural_error_of_the_freudenstein_design_against_the_closed_form(log10_csv):
    # the three-point log10 design over its reachable span of targets, against y = log10 x itself: the output
    # from Freudenstein's equation (K1 - cos t2) cos t4 - sin t2 sin t4 = K2 cos t2 - K3, solved here
    def wanted(t2):
        return 135 + 90 * np.log10(1 + 9 * (np.asarray(t2) - 45) / 60)

    rows = log10_targets()
    res = ls.synthesize(ls.load(FOURBAR), method="freudenstein", function="theta4", targets=log10_csv,
                        desired=wanted)
    se = res.report["structural_error"]
    assert se["reference"] == "function" and se["range"] == pytest.approx([rows[0][0], rows[-1][0]])
    k1, k2, k3 = freudenstein_K(rows)
    t2 = np.radians(np.linspace(rows[0][0], rows[-1][0], 20001))
    a, b, c = k1 - np.cos(t2), -np.sin(t2), k2 * np.cos(t2) - k3
    base, half = np.arctan2(b, a), np.arccos(np.clip(c / np.hypot(a, b), -1, 1))
    branches = [np.degrees(base + s * half) for s in (1, -1)]
    t4 = min(branches, key=lambda t: abs((t[0] - rows[0][1] + 180) % 360 - 180))
    e = (t4 - wanted(np.degrees(t2)) + 180) % 360 - 180
    assert abs(e[0]) < 1e-6 and abs(e[-1]) < 1e-6  # the end targets are met
    assert se["max"] == pytest.approx(np.abs(e).max(), rel=1e-3)
    assert se["at"] == pytest.approx(np.degrees(t2[np.argmax(np.abs(e))]), abs=0.5)
    # sampled as the reference says: 1001 points over the range (here from its low end, the first target),
    # so the worst input is one of lo + k (hi - lo) / 1000
    lo, hi = rows[0][0], rows[-1][0]
    assert se["points"] == 1001
    k = (se["at"] - lo) / ((hi - lo) / 1000)
    assert k == pytest.approx(round(k), abs=1e-6)


def test_cli_general_function_report_has_the_structural_error_over_range(tmp_path):
    # targets on the model's own four-bar (prob1: AB=20, BC=66, CD=56, AD=80, open mode), crank length varied
    def theta4(t2_deg):
        a = np.array([20 * math.cos(math.radians(t2_deg)), 20 * math.sin(math.radians(t2_deg))])
        B = intersect(a, 66.0, np.array([80.0, 0.0]), 56.0)
        return math.degrees(math.atan2(B[1], B[0] - 80.0))

    t = tmp_path / "f.csv"
    t.write_text("input,output\n" + "".join(f"{x},{theta4(x)!r}\n" for x in (30, 60, 90, 120)))
    rep_path = tmp_path / "r.json"
    p = run("synthesize", FOURBAR, "--function", "theta4", "--targets", t, "--vary", "AB=15:25", "--range",
            "20:130", "--popsize", "6", "--maxiter", "15", "--restarts", "1", "--report", rep_path, "-q")
    if p.returncode != 0:
        pytest.fail(p.stderr)
    rep = json.loads(rep_path.read_text())
    se = rep["structural_error"]
    assert rep["parameters"]["AB"] == pytest.approx(20, abs=1e-6)
    assert se["range"] == [20.0, 130.0] and se["reached"] == pytest.approx([20.0, 130.0])
    assert se["reference"] == "pchip through the targets"
    from scipy.interpolate import PchipInterpolator

    dense = np.linspace(20, 130, 2201)
    ref = PchipInterpolator([30, 60, 90, 120], [theta4(x) for x in (30, 60, 90, 120)])(dense)
    e = np.abs(np.array([theta4(x) for x in dense]) - ref)
    assert se["max"] == pytest.approx(e.max(), rel=1e-2)


def test_least_squares_freudenstein_is_polished_by_the_general_method(tmp_path):
    # seven uniform points of the log10 generator: linear least squares on K (computed here with numpy), then the
    # general method's polish of r2, r3, r4 (r1 = 100). Reference: the four-bar's closed form written here.
    x = np.linspace(1.6, 9.4, 7)
    a, b = 45 + 60 * (x - 1) / 9, 135 + 90 * np.log10(x)
    t = tmp_path / "seven.csv"
    t.write_text("input,output\n" + "".join(f"{float(u)!r},{float(v)!r}\n" for u, v in zip(a, b)))
    ta, tb = np.radians(a), np.radians(b)
    K = np.linalg.lstsq(np.c_[np.cos(tb), -np.cos(ta), np.ones_like(ta)], np.cos(ta - tb), rcond=None)[0]

    def outputs(r1, r2, r3, r4, s2, s4):
        # crank pin at s2*r2∠t2, rocker pin at O4 + s4*r4∠t4 (s = -1: a negative Freudenstein length)
        out = []
        for t2, want in zip(ta, tb):
            A = s2 * r2 * np.array([math.cos(t2), math.sin(t2)])
            cands = []
            for side in (1, -1):
                d = A - np.array([r1, 0.0])
                L = float(np.hypot(*d))
                xx = (r4 * r4 - r3 * r3 + L * L) / (2 * L)
                h = math.sqrt(max(r4 * r4 - xx * xx, 0.0))
                C = np.array([r1, 0.0]) + xx * d / L + side * h * np.array([-d[1], d[0]]) / L
                ang = math.atan2(C[1], C[0] - r1) - (0 if s4 > 0 else math.pi)
                cands.append((ang - want + math.pi) % (2 * math.pi) - math.pi)
            out.append(min(cands, key=abs))
        return np.array(out)

    s2, s4 = (1 if K[0] > 0 else -1), (1 if K[1] > 0 else -1)
    r2, r4 = 100 / abs(K[0]), 100 / abs(K[1])
    r3 = math.sqrt(100 ** 2 + r2 ** 2 + r4 ** 2 - 2 * (100 / K[0]) * (100 / K[1]) * K[2])
    f_linear = float(np.sum(outputs(100, r2, r3, r4, s2, s4) ** 2))
    res = ls.synthesize(ls.load(FOURBAR), method="freudenstein", function="theta4", targets=t)
    rep = res.report
    assert rep["polish"]["used"] and rep["polish"]["objective_before"] == pytest.approx(f_linear, rel=1e-6)
    p = rep["parameters"]  # the model's own names: AD ground, AB input, BC coupler, CD output
    p = {"r1": p["AD"], "r2": p["AB"], "r3": p["BC"], "r4": p["CD"]}
    e = outputs(p["r1"], p["r2"], p["r3"], p["r4"], s2, s4)
    f = float(np.sum(e ** 2))
    assert rep["objective"] == pytest.approx(f, rel=1e-6) and f < 0.5 * f_linear
    # the errors at the targets: design minus target, in the model's angle unit (degrees)
    assert [t_["error"] for t_ in rep["targets"]] == pytest.approx(list(np.degrees(e)), abs=1e-7)
    # a local minimum of the closed-form objective: along r2, r3, r4 both neighbours are higher and the parabola
    # through the three values has its vertex within 5 % of the step from the polished value
    for k in ("r2", "r3", "r4"):
        q = dict(p)
        h = 1e-4 * p[k]
        q[k] = p[k] + h
        fp = float(np.sum(outputs(q["r1"], q["r2"], q["r3"], q["r4"], s2, s4) ** 2))
        q[k] = p[k] - h
        fm = float(np.sum(outputs(q["r1"], q["r2"], q["r3"], q["r4"], s2, s4) ** 2))
        assert f <= min(fp, fm)
        assert abs(h * (fm - fp) / (2 * (fp + fm - 2 * f))) < 0.05 * h
    assert rep["certificate"]["defects"] == []
