"""``loopsolve cam`` and ``solve`` on a cam declared by its pitch curve: the report, and bad files refused
with one line naming the file and the key (exit 2)."""

import json
import math
import subprocess
import sys

import numpy as np
import pytest

CAM = """
name = "profile cam"
units = { length = "mm", angle = "deg" }
[parameters]
eps = 5
[variables]
theta2 = { input = true, guess = 0 }
s = { guess = 0 }
[cams.c1]
cam = "theta2"
follower = "s"
kind = "translating"
contact = "roller"
roller = "8mm"
offset = "5mm"
profile = "pitch.csv"
"""


def run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "loopsolve", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd)


def circle(n=72, R=50.0, e=10.0):
    t = np.linspace(0, 2 * math.pi, n, endpoint=False)
    return "x,y\n" + "".join(f"{R * math.cos(a)!r},{e + R * math.sin(a)!r}\n" for a in t)


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "models").mkdir()
    (tmp_path / "models" / "cam.toml").write_text(CAM)
    return tmp_path


def test_report_of_a_profile_cam(folder):
    """An eccentric circle (R = 50, centre e = 10 from the cam centre, on +y at θ = 0) under a roller
    follower offset ε = 5: the centre turns to (−e sin θ, e cos θ), so the roller centre on x = ε is at
    y = e cos θ + √(R² − (ε + e sin θ)²); s is that less its least value."""
    (folder / "models" / "pitch.csv").write_text(circle())
    proc = run("cam", folder / "models" / "cam.toml", "c1", "--format", "json", cwd=folder)  # relative to the model
    assert proc.returncode == 0, proc.stderr
    rep = json.loads(proc.stdout)

    def y(th):
        return 10 * np.cos(th) + np.sqrt(50**2 - (5 + 10 * np.sin(th)) ** 2)

    low = y(np.linspace(0, 2 * math.pi, 200_001)).min()
    th = np.radians([r["angle"] for r in rep["rows"]])
    assert np.allclose([r["s"] for r in rep["rows"]], y(th) - low, atol=1e-5)
    assert rep["undercut"] is False and rep["extremes"]["curvature_radius"] == pytest.approx([50, 50], rel=1e-4)
    proc = run("solve", folder / "models" / "cam.toml", "--at", "30", "--format", "json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["rows"][0]["s"] == pytest.approx(y(math.radians(30)) - low, abs=1e-5)


def _write_many(path):
    with open(path, "w") as fh:
        fh.write("x,y\n")
        line = "1.000000000000000000,2.000000000000000000\n"
        fh.write(line * (5_000_000 // len(line)))


@pytest.mark.parametrize("content, words", [
    (None, "cannot read the profile"),
    ("x,y\n1,0\n0,1\n-1,0\n0,-1\n", "at least 8"),
    (circle().replace("x,y", "a,b"), "header x,y"),
    (circle().replace("50.0,10.0", "nan,10.0"), "not a finite number"),
    (circle() + "__import__('os').system('true'),1\n", "is not a number"),
    (circle(e=80.0), "not once"),  # the cam centre lies outside the circle
    (circle() + "1,2,3\n", "two values"),
    (_write_many, "more than"),
])
def test_bad_profile_files_exit_2_naming_file_and_key(folder, content, words):
    path = folder / "models" / "pitch.csv"
    if callable(content):
        content(path)
    elif content is not None:
        path.write_text(content)
    for cmd in (["cam", folder / "models" / "cam.toml", "c1"], ["info", folder / "models" / "cam.toml"]):
        proc = run(*cmd)
        assert proc.returncode == 2, proc.stderr
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and "cams.c1.profile" in lines[0] and "pitch.csv" in lines[0] and words in lines[0]


def test_star_shaped_about_the_cam_centre(folder):
    """A curve whose rays from the cam centre meet it more than once (a five-pointed star's outline with
    deep notches, turned about the centre) is refused for a radial follower."""
    t = np.linspace(0, 2 * math.pi, 400, endpoint=False)
    r = 40 + 25 * np.cos(5 * t)
    t2 = t + 0.6 * np.sin(5 * t)  # the notches lean over: a ray meets the curve three times
    (folder / "models" / "pitch.csv").write_text("x,y\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in
                                                                 zip(r * np.cos(t2), r * np.sin(t2))))
    (folder / "models" / "cam.toml").write_text(CAM.replace('offset = "5mm"\n', "").replace('"roller"', '"knife"')
                                                .replace('roller = "8mm"\n', ""))
    proc = run("cam", folder / "models" / "cam.toml", "c1")
    assert proc.returncode == 2 and "cams.c1.profile" in proc.stderr and "not once" in proc.stderr


@pytest.mark.parametrize("edit, key, words", [
    (('profile = "pitch.csv"', 'profile = "pitch.csv"\nbase = "40mm"'), "cams.c1.base", "has no `base`"),
    (('profile = "pitch.csv"', 'law = [ { to = 360, dwell = true } ]\nprofile = "pitch.csv"'), "cams.c1",
     "exactly one of `law`"),
    (('profile = "pitch.csv"', ""), "cams.c1", "exactly one of `law`"),
    (('offset = "5mm"', 'offset = "eps"'), "cams.c1.offset", "not a parameter"),
    (('profile = "pitch.csv"', "profile = 3"), "cams.c1.profile", "path of a CSV file"),
])
def test_bad_profile_declarations(folder, edit, key, words):
    (folder / "models" / "pitch.csv").write_text(circle())
    (folder / "models" / "cam.toml").write_text(CAM.replace(*edit))
    proc = run("cam", folder / "models" / "cam.toml", "c1")
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"{key}:" in lines[0] and words in lines[0]
