"""Bounded work and clear errors of ``synthesize`` (issue 29), each case as the issue states it.

Every case runs the command line (``loopsolve.cli.main``, and the headline case in a real
subprocess) and must end in one line naming the option, value or file, exit status 2. "Before any
heavy work" is checked without a clock: the search, the multistart and the classical solvers are
replaced by functions that fail the test if they are ever called, so a refusal that came after
starting the work would show as that failure instead. The same checks hold from Python
(``ls.synthesize``), and the files the checks accept (a UTF-8 byte-order mark) still synthesize.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

import loopsolve as ls
from loopsolve.cli import main
from loopsolve.design.synthesis.classical import burmester as burmester_mod
from loopsolve.design.synthesis.classical import burmester_search as burmester_search_mod
from loopsolve.design.synthesis.classical import freudenstein as freudenstein_mod
from loopsolve.design.synthesis import run as synthesis_run

MODELS = ls.models_dir()
PATHSYN = MODELS / "fourbar_path_synthesis.toml"
THREE = "x,y\n1.247635,2.261923\n1.125070,2.556968\n0.759129,2.635152\n"  # the model's P at 30, 60, 90


@pytest.fixture
def no_work(monkeypatch):
    """Any search, multistart or classical solve fails the test: the refusal must come first."""
    def forbidden(*args, **kwargs):
        raise AssertionError("heavy work started before the refusal")

    monkeypatch.setattr(synthesis_run, "one_run", forbidden)
    monkeypatch.setattr(synthesis_run, "_dask_runs", forbidden)
    monkeypatch.setattr(burmester_mod, "pose_dyads", forbidden)
    # (burmester_search binds pose_dyads at its import: patched there too, or a first import of it during
    # this fixture kept the forbidden function for every later test of the process)
    monkeypatch.setattr(burmester_search_mod, "pose_dyads", forbidden)
    monkeypatch.setattr(freudenstein_mod, "freudenstein_constants", forbidden)


@pytest.fixture
def files(tmp_path):
    def write(name, text, mode="w"):
        p = tmp_path / name
        if mode == "wb":
            p.write_bytes(text)
        else:
            p.write_text(text, encoding="utf-8")
        return p
    return write


def refused(capsys, argv, words):
    status = main([str(a) for a in argv])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert status == 2, err
    assert len(lines) == 1 and lines[0].startswith("loopsolve: ") and "internal error" not in err, err
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def general(targets, *extra):
    return ["synthesize", PATHSYN, "--path", "P", "--targets", targets, "--vary", "r2=0.5:2", "-q", *extra]


@pytest.mark.parametrize("extra, words", [
    (["--runs", "1000000000"], ["--runs 1000000000", "--max-cells", "100,000,000"]),
    (["--runs", "0"], ["--runs 0", "at least 1"]),
    (["--workers", "-1"], ["--workers -1"]),
    (["--workers", "0"], ["--workers 0"]),
    (["--workers", "1000000"], ["--workers 1000000", "CPU"]),
    (["--seed", "-1"], ["--seed -1", "at least 0"]),
    (["--starts", "-1"], ["--starts -1", "at least 0"]),
    (["--restarts", "1000000"], ["--restarts 1000000", "256", "--runs"]),
    (["--restarts", "0"], ["--restarts 0", "at least 1"]),
    (["--popsize", "0"], ["--popsize 0", "at least 1"]),
    (["--maxiter", "-1"], ["--maxiter -1", "at least 0"]),
    (["--popsize", "1000000"], ["--popsize", "--max-cells"]),
    (["--maxiter", "100000000"], ["--maxiter", "--max-cells"]),
    (["--max-cells", "0"], ["--max-cells 0"]),
    (["--max-targets", "0"], ["--max-targets 0"]),
    (["--max-targets", "2"], ["3 targets", "--max-targets"]),
])
def test_options_out_of_bounds_are_refused_before_any_work(capsys, files, no_work, extra, words):
    t = files("t.csv", THREE)
    refused(capsys, general(t, "--inputs", "30,60,90", *extra), words)


def test_runs_1e9_is_refused_from_the_real_command_line(files):
    t = files("t.csv", THREE)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    env.pop("LOOPSOLVE_DEBUG", None)
    p = subprocess.run([sys.executable, "-m", "loopsolve.cli", *map(str, general(t, "--inputs", "30,60,90", "--runs",
                                                                             "1000000000"))],
                       capture_output=True, text=True, env=env)
    assert p.returncode == 2 and p.stdout == "", p.stderr
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "--runs 1000000000" in lines[0] and "--max-cells" in lines[0], p.stderr


def test_100000_free_timing_targets_are_refused(capsys, files, no_work):
    rows = "".join(f"{math.cos(i * 1e-4):.9f},{math.sin(i * 1e-4):.9f}\n" for i in range(100_000))
    t = files("free.csv", "x,y\n" + rows)
    refused(capsys, general(t), ["free.csv", "100,000 targets", "--max-targets"])
    # raising the target limit does not lift the memory bound of one batch
    refused(capsys, general(t, "--max-targets", "200000"), ["--popsize", "400 MB"])


def test_free_timing_polish_beyond_memory_names_starts_and_the_way_out(capsys, files, no_work):
    rows = "".join(f"{math.cos(i * 1e-2):.9f},{math.sin(i * 1e-2):.9f}\n" for i in range(800))
    t = files("free800.csv", "x,y\n" + rows)
    refused(capsys, general(t), ["--starts", "800 targets", "--inputs"])


def test_inputs_1e300_are_refused_at_once(capsys, files, no_work):
    t = files("t5.csv", "x,y\n1,2\n1.1,2\n1.2,2\n1.3,2\n1.4,2\n")
    refused(capsys, general(t, "--inputs", "1e300,0,1,2,3"), ["--inputs", "turns", "1e+300"])


def test_a_slider_input_travelling_far_is_refused_by_the_work_bound(capsys, tmp_path, files, no_work):
    text = (MODELS / "example1_slider_crank.toml").read_text(encoding="utf-8")
    text = text.replace('theta2 = { input = true, guess = 45, speed = "10rad/s", accel = 0 }', "theta2 = { guess = 45 }")
    text = text.replace("r1 = { guess = 10.7 }", "r1 = { input = true, guess = 10.7 }")
    model = tmp_path / "slider_input.toml"
    model.write_text(text, encoding="utf-8")
    t = files("s.csv", "x,y\n3,3\n4,3\n")
    refused(capsys, ["synthesize", model, "--path", "B", "--targets", t, "--inputs", "10,1e12", "--vary", "r2=4:6",
                     "-q"], ["--inputs", "trace steps", "--max-cells"])


@pytest.mark.parametrize("rows, extra, words", [
    ("1,2\n1.5,2\n1.5,2\n3,4\n", [], ["rep.csv", "targets 2 and 3", "same point"]),
    ("1,2\n1.5,2\n1.7,2\n3,4\n", ["--inputs", "10,20,30,20"], ["--inputs", "targets 2 and 4", "(20)"]),
])
def test_repeated_targets_are_refused_by_name(capsys, files, no_work, rows, extra, words):
    t = files("rep.csv", "x,y\n" + rows)
    refused(capsys, general(t, *extra), words)


def test_repeated_inputs_of_the_input_column_are_refused_by_name(capsys, files, no_work):
    t = files("col.csv", "x,y,input\n1,2,30\n1.5,2,30\n3,4,60\n")
    refused(capsys, general(t), ["col.csv", "input column", "targets 1 and 2"])


def test_repeated_motion_poses_a_turn_apart_are_the_same_pose(capsys, files, no_work):
    t = files("m.csv", "x,y,angle\n1,2,10\n1,2,370\n3,4,40\n")
    refused(capsys, ["synthesize", PATHSYN, "--motion", "P", "--link", "theta3", "--targets", t, "--vary",
                     "r2=0.5:2", "-q"], ["m.csv", "targets 1 and 2", "same pose"])


# -- the classical methods ---------------------------------------------------------------------------


@pytest.fixture
def fourbar(tmp_path):
    p = tmp_path / "fourbar.toml"
    p.write_text(ls.dumps(ls.fourbar(60, 25, 70, 45)), encoding="utf-8")
    return p


def test_burmester_with_one_pose_repeated_is_refused_by_name(capsys, files, fourbar, no_work):
    poses = files("poses.csv", "x,y,angle\n10,20,5\n30,25,20\n30,25,20\n50,40,60\n45,70,90\n")
    refused(capsys, ["synthesize", fourbar, "--method", "burmester", "--motion", "C", "--link", "theta3", "--targets",
                     poses, "-q"], ["poses 2 and 3", "same pose"])


def test_burmester_poses_a_turn_apart_are_refused_from_python(no_work):
    with pytest.raises(ls.ModelError, match="poses 1 and 4"):
        ls.burmester([(0, 0, 0), (1, 0.2, 10), (1.8, 0.7, 25), (0, 0, 360), (2.3, 2.4, 70)])


@pytest.mark.parametrize("rows, words", [
    ("40,100\n60,120\n60,120\n90,140\n", ["targets 2 and 3", "same input angle"]),
    ("40,100\n60,120\n400,130\n", ["targets 1 and 3", "turns apart"]),
])
def test_freudenstein_repeated_inputs_are_refused_by_name(capsys, files, fourbar, no_work, rows, words):
    t = files("fr.csv", "input,output\n" + rows)
    refused(capsys, ["synthesize", fourbar, "--method", "freudenstein", "--function", "theta4", "--targets", t, "-q"],
            words)


def test_freudenstein_targets_are_bounded_too(capsys, files, fourbar, no_work):
    rows = "".join(f"{10 + i * 0.05!r},{100 + i * 0.03!r}\n" for i in range(1001))
    t = files("many.csv", "input,output\n" + rows)
    refused(capsys, ["synthesize", fourbar, "--method", "freudenstein", "--function", "theta4", "--targets", t, "-q"],
            ["many.csv", "1,001 targets", "--max-targets"])


@pytest.mark.parametrize("flag, value", [("--workers", "0"), ("--workers", "2"), ("--scheduler", "tcp://x:1")])
def test_classical_methods_refuse_general_options_even_when_zero(capsys, files, fourbar, flag, value):
    t = files("fr.csv", "input,output\n40,100\n60,120\n90,140\n")
    refused(capsys, ["synthesize", fourbar, "--method", "freudenstein", "--function", "theta4", "--targets", t, flag,
                     value, "-q"], [flag, "not used"])


# -- targets and poses files ---------------------------------------------------------------------------


BIG = "x,y\n1,2\n3," + "4" * 200_000 + "\n"


@pytest.mark.parametrize("kind", ["general", "burmester"])
def test_a_field_over_the_csv_limit_names_the_file_and_line(capsys, files, fourbar, no_work, kind):
    if kind == "general":
        t = files("big.csv", BIG)
        argv = general(t, "--inputs", "30,60")
    else:
        t = files("big.csv", "x,y,angle\n1,2,3\n4," + "5" * 200_000 + ",6\n")
        argv = ["synthesize", fourbar, "--method", "burmester", "--motion", "C", "--link", "theta3", "--targets", t,
                "-q"]
    refused(capsys, argv, ["big.csv", "line 3", "131,072"])


@pytest.mark.parametrize("kind", ["general", "freudenstein"])
def test_bytes_that_are_not_utf8_name_the_file_and_line(capsys, files, fourbar, no_work, kind):
    head = b"x,y\n" if kind == "general" else b"input,output\n"
    t = files("latin1.csv", head + b"1,2\n3,\xff\n", mode="wb")
    argv = general(t, "--inputs", "30,60") if kind == "general" else [
        "synthesize", fourbar, "--method", "freudenstein", "--function", "theta4", "--targets", t, "-q"]
    refused(capsys, argv, ["latin1.csv", "line 3", "UTF-8"])


def test_a_byte_order_mark_is_accepted_by_the_general_method(capsys, files, tmp_path):
    plain, bom = files("plain.csv", THREE), files("bom.csv", b"\xef\xbb\xbf" + THREE.encode(), mode="wb")
    reports = []
    for t in (plain, bom):
        rep = tmp_path / f"{t.stem}.json"
        status = main([str(a) for a in ["synthesize", PATHSYN, "--path", "P", "--targets", t, "--inputs", "30,60,90",
                                        "--vary", "r2=0.5:2", "--vary", "rcx=0:3", "--popsize", "4", "--maxiter", "5",
                                        "--starts", "5", "--report", rep, "-q"]])
        assert status == 0, capsys.readouterr().err
        reports.append(json.loads(rep.read_text(encoding="utf-8")))
    assert reports[1]["parameters"] == reports[0]["parameters"]
    # the targets as read: the model's own coupler point (r2 = 1, rcx = 1.5) meets all three
    assert reports[1]["parameters"]["r2"] == pytest.approx(1.0, abs=1e-6)


def test_a_byte_order_mark_is_accepted_by_the_classical_reader(tmp_path):
    from loopsolve.design.synthesis.targets import read_table
    from loopsolve.design.synthesis.targets import read_targets

    p = tmp_path / "bom.csv"
    p.write_bytes(b"\xef\xbb\xbfx,y,angle\n1,2,30\n3,4,45\n")
    assert read_table(p, ("x", "y", "angle")).tolist() == [[1.0, 2.0, 30.0], [3.0, 4.0, 45.0]]
    assert read_table("\ufeffx,y,angle\n1,2,30\n", ("x", "y", "angle")).tolist() == [[1.0, 2.0, 30.0]]
    cols = read_targets("\ufeffx,y\n1,2\n3,4\n")
    assert cols["x"].tolist() == [1.0, 3.0] and cols["y"].tolist() == [2.0, 4.0]


def test_a_targets_fifo_is_refused_without_blocking(tmp_path, capsys, no_work):
    fifo = tmp_path / "t.csv"
    os.mkfifo(fifo)
    refused(capsys, general(fifo, "--inputs", "30,60"), ["t.csv", "not a regular file"])


# -- the same checks from Python --------------------------------------------------------------------------


@pytest.mark.parametrize("kwargs, words", [
    ({"runs": 10**9}, ["--runs 1000000000", "max_cells"]),
    ({"runs": 2.5}, ["--runs 2.5", "whole number"]),
    ({"seed": -1}, ["--seed -1"]),
    ({"seed": True}, ["--seed True"]),
    ({"starts": -1}, ["--starts -1"]),
    ({"restarts": 10**6}, ["--restarts 1000000"]),
    ({"restarts": 0}, ["--restarts 0"]),
    ({"popsize": 0}, ["--popsize 0"]),
    ({"maxiter": -1}, ["--maxiter -1"]),
    ({"workers": 0}, ["--workers 0"]),
    ({"workers": -1}, ["--workers -1"]),
    ({"tol": float("nan")}, ["tol=nan"]),
    ({"strategy": "best9bin"}, ["strategy='best9bin'"]),
    ({"de_starts": 0}, ["de_starts=0"]),
    ({"max_cells": 0}, ["--max-cells 0"]),
])
def test_python_api_applies_the_same_checks(no_work, kwargs, words):
    mech = ls.load(PATHSYN)
    targets = {"x": [1.247635, 1.125070, 0.759129], "y": [2.261923, 2.556968, 2.635152]}
    with pytest.raises(ls.ModelError) as e:
        ls.synthesize(mech, path="P", targets=targets, inputs=[30, 60, 90], vary={"r2": (0.5, 2)}, progress=False,
                      **kwargs)
    for w in words:
        assert w in str(e.value), str(e.value)


def test_python_api_bounds_targets_and_inputs(no_work):
    mech = ls.load(PATHSYN)
    x = np.cos(np.arange(1001) * 1e-3)
    with pytest.raises(ls.ModelError, match="1,001 targets"):
        ls.synthesize(mech, path="P", targets={"x": x, "y": np.sin(np.arange(1001) * 1e-3)}, vary={"r2": (0.5, 2)},
                      progress=False)
    with pytest.raises(ls.ModelError, match="turns"):
        ls.synthesize(mech, path="P", targets={"x": [1, 2], "y": [1, 2]}, inputs=[0, 720], vary={"r2": (0.5, 2)},
                      progress=False)


def test_the_work_estimate_counts_what_a_run_evaluates():
    """The estimate is an upper bound of a real run's design evaluations (the report's statistics)."""
    from loopsolve.design.synthesis.problem import define
    from loopsolve.design.synthesis.limits import work_estimate

    mech = ls.load(PATHSYN)
    targets = {"x": [1.247635, 1.125070, 0.759129], "y": [2.261923, 2.556968, 2.635152]}
    kw = dict(popsize=4, maxiter=5, restarts=1, starts=5)
    res = ls.synthesize(mech, path="P", targets=targets, inputs=[30, 60, 90], vary={"r2": (0.5, 2), "rcx": (0, 3)},
                        progress=False, **kw)
    problem = define(mech, path="P", targets=targets, inputs=[30, 60, 90], vary={"r2": (0.5, 2), "rcx": (0, 3)})
    w = work_estimate(problem, runs=1, de_starts=10, lm_iters=60, **kw)
    counted = res.report["statistics"]["evaluations"]  # DE generations and multistart samples (not the LM's)
    lm = w["lm_starts"] * 60
    assert w["modes"] == 2 and w["lm_starts"] == 2 * 10 + 5
    assert 0 < counted <= w["evaluations"] - lm
    assert w["steps"] == 1 + 3 + 3  # 30 -> 60 -> 90 in steps of at most 10 degrees, plus the start
