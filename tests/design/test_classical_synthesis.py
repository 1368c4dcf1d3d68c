"""The ``synthesize --method freudenstein|burmester`` door: targets files, checks, reports, model files."""

import math

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.design.synthesis.classical.run import classic_synthesize
from loopsolve.design.synthesis.targets import read_table
from loopsolve.errors import ModelError

from support.models import planted_pose, R1, R2, R3, R4

@pytest.fixture
def poses_file(tmp_path):
    p = tmp_path / "poses.csv"
    rows = [planted_pose(t)[0] for t in (20, 70, 120, 170, 220)]
    p.write_text("x,y,angle\n" + "".join(f"{x!r},{y!r},{a!r}\n" for x, y, a in rows))
    return p


MECH = ls.fourbar(60, 25, 70, 45)
# a four-bar whose frame (x0, y0, theta0) and coupler point (rcx, rcy) are parameters: it can hold any
# Burmester four-bar of poses of P and of the coupler line's angle theta3
PATHMECH = ls.load(ls.models_dir() / "fourbar_path_synthesis.toml")


def test_burmester_door_recovers_and_writes_a_loadable_model(poses_file):
    r = classic_synthesize(PATHMECH, method="burmester", motion="P", link="theta3", targets=poses_file)
    rep = r.report
    assert rep["task"] == "motion" and rep["method"] == "burmester"
    assert rep["certificate"]["defects"] == [] and rep["objective"] <= 1e-20
    assert len(rep["candidates"]) >= 1
    mech = ls.loads(r.to_toml())
    # the written model meets every pose at the reported inputs (closed form: planted_pose)
    for t, target in zip((20, 70, 120, 170, 220), rep["targets"]):
        s = mech.solve(target["input"], mode=rep["mode"])
        want = planted_pose(t)[0]
        assert (s["P_x"], s["P_y"]) == pytest.approx(want[:2], abs=1e-8)
        assert (s["theta3"] - want[2] + 180) % 360 - 180 == pytest.approx(0, abs=1e-8)
    p = rep["parameters"]
    assert sorted((p["r1"], p["r2"], p["r3"], p["r4"])) == pytest.approx(sorted((R1, R2, R3, R4)))


def test_freudenstein_door_meets_the_targets():
    # the log10 generator's three Chebyshev points (x = 1.6029, 5.5, 9.3971) as angles
    xs = [5.5 - 4.5 * math.sqrt(3) / 2, 5.5, 5.5 + 4.5 * math.sqrt(3) / 2]
    text = "input,output\n" + "".join(f"{45 + 60 * (x - 1) / 9!r},{135 + 90 * math.log10(x)!r}\n" for x in xs)
    r = classic_synthesize(MECH, method="freudenstein", function="theta4", targets=text)
    assert r.report["K"] == pytest.approx([2.00276, -0.69862, 1.08420], abs=5e-6)
    assert r.report["objective"] < 1e-20 and r.report["certificate"]["defects"] == []


@pytest.mark.parametrize("text, match", [
    ("x,y\n1,2\n", "lacks the column"),
    ("x,y,angle\n1,2,abc\n1,2,3\n1,2,3\n1,2,3\n1,2,3\n", "line 2, column angle: 'abc' is not a number"),
    ("x,y,angle\n1,2\n", "line 2: 2 fields"),
    ("x,y,angle\n1,2,inf\n", "not a finite number"),
    ("", "empty"),
    ("x,y,angle\n", "no poses rows"),
    ("x,y,angle\n0,0,0\n1,0,10\n", "too few poses for Burmester: 2"),
    ("x,y,angle\n" + "0,0,0\n1,0,10\n2,1,20\n3,3,40\n4,4,50\n5,5,60\n", "too many poses for Burmester: 6"),
])
def test_malformed_or_too_few_poses(tmp_path, text, match):
    p = tmp_path / "poses.csv"
    p.write_text(text)
    with pytest.raises(ModelError, match=match) as exc:
        classic_synthesize(MECH, method="burmester", motion="C", link="theta3", targets=p)
    assert "\n" not in str(exc.value) and str(p) in str(exc.value) or "too few" in str(exc.value) \
        or "too many" in str(exc.value)
    assert exc.value.exit_code == 2


@pytest.mark.parametrize("kwargs, match", [
    (dict(method="burmester", motion="C", link="theta9"), "--link 'theta9': not a variable"),
    (dict(method="burmester", motion="Q", link="theta3"), "--motion 'Q': not a point"),
    (dict(method="freudenstein", function="theta7"), "--function 'theta7'"),
    (dict(method="freudenstein", function="theta2"), "not an unknown"),
    (dict(method="ruler"), "--method 'ruler'"),
])
def test_unknown_names(poses_file, kwargs, match):
    with pytest.raises(ModelError, match=match):
        classic_synthesize(MECH, targets=poses_file, **kwargs)


def test_not_a_fourbar(poses_file):
    six = ls.load(ls.models_dir() / "watt1_sixbar.toml")
    with pytest.raises(ModelError, match="four-bar models"):
        classic_synthesize(six, method="burmester", motion="C", link="theta3", targets=poses_file)


def test_read_table_text():
    assert read_table("input,output\n1,2\n# note\n3,4\n", ("input", "output")).tolist() == [[1, 2], [3, 4]]
    assert np.isfinite(read_table("x,y,angle\n1,2,3\n", ("x", "y", "angle"))).all()


def test_read_table_rows():
    assert read_table([[1, 2, 3]], ("x", "y", "angle")).shape == (1, 3)
    with pytest.raises(ModelError, match="rows of 3 numbers"):
        read_table([[1, 2]], ("x", "y", "angle"))
    with pytest.raises(ModelError, match="finite"):
        read_table([[1, 2, float("inf")]], ("x", "y", "angle"))


def test_burmester_candidates_report_their_crank_angles_at_the_poses_in_the_model_unit(poses_file):
    """Every candidate's ``inputs`` are the angle of its crank O2→A at each pose, in the model's unit (degrees
    here): A is carried from the first pose by the coupler's rigid motion (the poses' own x, y, angle)."""
    r = classic_synthesize(PATHMECH, method="burmester", motion="P", link="theta3", targets=poses_file)
    poses = [planted_pose(t)[0] for t in (20, 70, 120, 170, 220)]
    x0, y0, a0 = poses[0]
    assert r.report["candidates"]
    for c in r.report["candidates"]:
        if not c["inputs"]:
            continue
        O2, A0 = np.array(c["pivots"]["O2"]), np.array(c["pins"]["A"])
        for (x, y, a), got in zip(poses, c["inputs"]):
            t = math.radians(a - a0)
            Ak = np.array([x, y]) + np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]]) @ (A0 - [x0, y0])
            want = math.degrees(math.atan2(Ak[1] - O2[1], Ak[0] - O2[0]))
            assert (got - want + 180) % 360 - 180 == pytest.approx(0, abs=1e-7)
