"""``loopsolve atlas build`` and ``loopsolve synthesize --shape``: the report's contract, the design written in the
target's coordinates, the default atlas built once into the cache, and bad input — one line on stderr, exit 2,
nothing of the user's overwritten."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.cli import main

pytest.importorskip("zarr", reason="atlases need zarr (the study extra)")

FOURBAR = ls.models_dir() / "fourbar_path_synthesis.toml"
BOX = ["--vary", "r2=0.4:4", "--vary", "r3=1.6:16", "--vary", "r4=1.6:16", "--vary", "rcx=-8:16",
       "--vary", "rcy=-12:12"]


def call(capsys, *args):
    status = main([str(a) for a in args])
    out = capsys.readouterr()
    return status, out.out, out.err


def write_curve(path, xy, header="x,y"):
    path.write_text(header + "\n" + "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in xy))
    return path


@pytest.fixture(scope="module")
def atlas(tmp_path_factory):
    path = tmp_path_factory.mktemp("cli") / "fb.zarr"
    status = main(["atlas", "build", str(FOURBAR), "--point", "P", *BOX, "--size", "1024", "--chunk", "512",
                   "-o", str(path), "-q"])
    assert status == 0
    return path


@pytest.fixture(scope="module")
def curve():
    m = ls.load(FOURBAR).with_parameters(r2=1.2, r3=4.5, r4=3.8, rcx=1.0, rcy=2.5)
    sw = m.sweep(0, 360, 8, progress=False)
    xy = np.stack([sw.columns["P_x"], sw.columns["P_y"]], axis=1)[:-1] * 3.0 + [10.0, 20.0]
    return xy + np.random.default_rng(2).normal(0, 0.01, xy.shape)


def test_atlas_build_and_info(capsys, atlas):
    status, out, err = call(capsys, "atlas", "info", atlas)
    assert status == 0, err
    info = json.loads(out)
    assert info["size"] == 1024 and info["certified"] > 500 and info["crank"] > 100
    assert info["vary"]["r2"] == [0.4, 4.0] and info["point"] == "P"


def test_shape_report_contract_and_the_written_design(capsys, atlas, curve, tmp_path):
    targets = write_curve(tmp_path / "curve.csv", curve)
    rep, out = tmp_path / "r.json", tmp_path / "d.toml"
    status, _, err = call(capsys, "synthesize", FOURBAR, "--shape", "P", "--targets", targets, "--atlas", atlas,
                          "--top", "3", "--crank", "--transmission", "20:160", "--report", rep, "-o", out, "-q")
    assert status == 0, err
    assert "certified design" in err and err.count("\n") == 3  # wrote R, wrote D, the summary
    r = json.loads(rep.read_text())
    for key in ("task", "objective", "parameters", "runs", "seconds", "mode", "direction", "targets", "certificate",
                "candidates"):
        assert key in r
    assert r["task"] == "shape" and 1 <= len(r["candidates"]) <= 3
    for c in r["candidates"]:
        assert set(c) >= {"parameters", "placement", "shape_error", "grashof", "mode", "transmission", "certificate"}
        assert set(c["placement"]) >= {"x", "y", "angle", "scale"}
        assert set(c["shape_error"]) == {"rms", "max"}
        assert c["certificate"]["defects"] == [] and c["certificate"]["crank"] is True
        assert 20 <= c["transmission"][0] <= c["transmission"][1] <= 160
        assert c["grashof"] in ("crank-rocker", "double crank")
    rms = [c["shape_error"]["rms"] for c in r["candidates"]]
    assert rms == sorted(rms) and rms[0] < 0.05
    assert len(r["targets"]) == len(curve)
    # -o: the best design, in the target's coordinates: its curve passes within the reported max of every target
    m = ls.load(out)
    sw = m.sweep(0, 360, 0.1, progress=False)
    z = np.asarray(sw.columns["P_x"]) + 1j * np.asarray(sw.columns["P_y"])
    q = curve[:, 0] + 1j * curve[:, 1]
    d = np.min(np.abs(q[:, None] - z[None, :]), axis=1)
    assert np.max(d) <= r["candidates"][0]["shape_error"]["max"] + 0.01
    assert r["parameters"] == r["candidates"][0]["parameters"]


def test_open_shape_from_the_command_line(capsys, atlas, curve, tmp_path):
    targets = write_curve(tmp_path / "open.csv", curve[3:14])
    rep = tmp_path / "o.json"
    status, _, err = call(capsys, "synthesize", FOURBAR, "--shape", "P", "--targets", targets, "--open", "--atlas",
                          atlas, "--top", "2", "--report", rep, "-q")
    assert status == 0, err
    r = json.loads(rep.read_text())
    assert r["closed"] is False and r["candidates"][0]["shape_error"]["max"] < 0.1


# ----------------------------------------------------------------------------- bad input


def _bad(capsys, tmp_path, *extra, targets=None, rows=None):
    """Run a failing shape synthesis with an existing report and output: exit 2, one line, both untouched."""
    rep, out = tmp_path / "keep.json", tmp_path / "keep.toml"
    rep.write_text("old report")
    out.write_text("old design")
    if targets is None:
        targets = tmp_path / "bad.csv"
        targets.write_text("x,y\n" + "".join(f"{r}\n" for r in rows))
    status, stdout, err = call(capsys, "synthesize", FOURBAR, "--shape", "P", "--targets", targets, *extra,
                               "--report", rep, "-o", out, "-q")
    assert status == 2, err
    assert err.startswith("loopsolve: ") and err.count("\n") == 1, err
    assert rep.read_text() == "old report" and out.read_text() == "old design"
    return err


@pytest.mark.parametrize("rows,message", [
    (["0,0", "1,0", "1,1", "0,1"], "at least 5"),
    (["0,0", "1,0", "nan,1", "0,1", "0,2", "1,3"], "not a finite number"),
    (["0,0", "1,0", "1,0", "0,1", "0,2", "1,3"], "points 2 and 3 are the same"),
    (["2,2"] * 7, "every point is the same"),
    (["0,0,10", "1,0,20", "1,1,30", "0,1,40", "0,2,50"], "timing"),
])
def test_bad_curves_exit_2_with_one_line(capsys, atlas, tmp_path, rows, message):
    if message == "timing":
        targets = tmp_path / "timed.csv"
        targets.write_text("x,y,input\n" + "".join(f"{r}\n" for r in rows))
        err = _bad(capsys, tmp_path, "--atlas", atlas, targets=targets)
    else:
        err = _bad(capsys, tmp_path, "--atlas", atlas, rows=rows)
    assert message in err


def _good_rows():
    return [f"{float(np.cos(t))!r},{float(np.sin(t))!r}" for t in np.linspace(0, 6, 12)]


def test_an_atlas_of_another_model_exits_2(capsys, tmp_path):
    other = tmp_path / "st.zarr"
    assert main(["atlas", "build", str(ls.models_dir() / "thesis_crank_rocker.toml"), "--point", "B", "--vary",
                 "r2=20:30", "--size", "64", "--chunk", "64", "-o", str(other), "-q"]) == 0
    capsys.readouterr()
    err = _bad(capsys, tmp_path, "--atlas", other, rows=_good_rows())
    assert "not of 'Four-bar path synthesis'" in err


def test_a_damaged_atlas_exits_2(capsys, atlas, tmp_path):
    bad = tmp_path / "bad.zarr"
    shutil.copytree(atlas, bad)
    chunk = bad / "curve" / "c" / "0" / "0" / "0"
    chunk.write_bytes(chunk.read_bytes()[:-20])
    err = _bad(capsys, tmp_path, "--atlas", bad, rows=_good_rows())
    assert "damaged" in err


@pytest.mark.skipif(not hasattr(os, "getuid") or os.getuid() != 0, reason="changing a file's owner needs root")
def test_a_foreign_owned_atlas_exits_2(capsys, atlas, tmp_path):
    bad = tmp_path / "foreign.zarr"
    shutil.copytree(atlas, bad)
    os.chown(bad, 4242, -1)
    err = _bad(capsys, tmp_path, "--atlas", bad, rows=_good_rows())
    assert "belongs to another user" in err


def test_a_missing_atlas_and_a_file_as_atlas_exit_2(capsys, tmp_path):
    err = _bad(capsys, tmp_path, "--atlas", tmp_path / "none.zarr", rows=_good_rows())
    assert "no such atlas" in err
    f = tmp_path / "file.zarr"
    f.write_text("x")
    err = _bad(capsys, tmp_path, "--atlas", f, rows=_good_rows())
    assert "not an atlas" in err


def test_atlas_build_refuses_to_replace_a_file_or_another_atlas(capsys, atlas, tmp_path):
    f = tmp_path / "a.zarr"
    f.write_text("mine")
    status, _, err = call(capsys, "atlas", "build", FOURBAR, "--point", "P", *BOX, "--size", "10", "-o", f)
    assert status == 2 and err.count("\n") == 1 and f.read_text() == "mine"
    status, _, err = call(capsys, "atlas", "build", FOURBAR, "--point", "P", "--vary", "r2=0.5:4", "--size", "1024",
                          "--chunk", "512", "-o", atlas)
    assert status == 2 and "holds another atlas" in err
    status, _, err = call(capsys, "atlas", "build", FOURBAR, "--point", "P", *BOX, "--size", "5000",
                          "--max-size", "4000", "-o", tmp_path / "big.zarr")
    assert status == 2 and "--max-size 4000" in err and not (tmp_path / "big.zarr").exists()


def test_shape_options_are_refused_for_other_tasks(capsys, tmp_path):
    t = tmp_path / "t.csv"
    t.write_text("x,y\n1,2\n3,4\n")
    status, _, err = call(capsys, "synthesize", FOURBAR, "--path", "P", "--targets", t, "--vary", "r2=1:2",
                          "--top", "3")
    assert status == 2 and "--top is for shape synthesis" in err


# ----------------------------------------------------------------------------- the default atlas


def test_the_default_atlas_is_built_once_into_the_cache(tmp_path, curve):
    """No --atlas: the default atlas of the model is built into the cache (the real code, with a small size set
    by LOOPSOLVE_ATLAS_SIZE) on first use, then opened from there."""
    cache = tmp_path / "cache"
    env = dict(os.environ, LOOPSOLVE_CACHE_DIR=str(cache), LOOPSOLVE_ATLAS_SIZE="4096", LOOPSOLVE_ATLAS_WORKERS="1")
    env.pop("LOOPSOLVE_DEBUG", None)
    targets = write_curve(tmp_path / "c.csv", curve)

    def run():
        return subprocess.run([sys.executable, "-m", "loopsolve.cli", "synthesize", str(FOURBAR), "--shape", "P",
                               "--targets", str(targets), "--top", "2", "--report", str(tmp_path / "r.json")],
                              capture_output=True, text=True, env=env)

    first = run()
    assert first.returncode == 0, first.stderr
    stores = list((cache / "atlas").glob("fourbar-*-4096.zarr"))
    assert len(stores) == 1
    stamp = (stores[0] / "filled" / "zarr.json").stat().st_mtime_ns
    second = run()
    assert second.returncode == 0, second.stderr
    assert (stores[0] / "filled" / "zarr.json").stat().st_mtime_ns == stamp  # opened, not built again
    r = json.loads((tmp_path / "r.json").read_text())
    assert r["statistics"]["atlas"]["size"] == 4096 and r["statistics"]["atlas"]["path"] == str(stores[0])
    assert r["candidates"][0]["shape_error"]["rms"] < 0.05
