"""Pictures: sweep plots, kinematic diagrams and animations (loopsolve.output.plotting and the CLI).

Every shipped model goes through each picture command of the command line in a subprocess
(the console script as a user runs it); a few more go through ``cli.main`` in-process, which
is the same code without the interpreter start-up. The console runs rotate the figure format over the models, so each command
writes every format several times. The images are checked for being
real pictures: the requested format, not blank (many colours / many drawn paths), and for
the GIF one frame per output row of the sweep.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import loopsolve as ls
from loopsolve import cli
from loopsolve.output import drawstyle, geometry, plotting, skeleton
from loopsolve.errors import MissingDependencyError, ModelError
from loopsolve.kinematics.results import Event, EventKind, Sweep

PIL = pytest.importorskip("PIL", reason="the plot extra (Pillow) is not installed")
pytest.importorskip("matplotlib", reason="the plot extra (matplotlib) is not installed")
from PIL import Image  # noqa: E402

MODELS = sorted(ls.models_dir().glob("*.toml"))
MODEL_IDS = [p.stem for p in MODELS]
FIGURE_FORMATS = ("png", "svg", "pdf")
STEP = "45"  # coarse sweeps keep the suite fast (9 rows over a turn)


# ----------------------------------------------------------------------------- image checks
def assert_picture(path: Path, fmt: str) -> None:
    """``path`` holds a non-blank picture in format ``fmt``."""
    assert path.is_file() and path.stat().st_size > 0, f"{path} was not written"
    data = path.read_bytes()
    if fmt == "png":
        assert data[:8] == b"\x89PNG\r\n\x1a\n"
        _assert_colourful(Image.open(path))
    elif fmt == "gif":
        assert data[:6] in (b"GIF87a", b"GIF89a")
        _assert_colourful(Image.open(path))
    elif fmt == "svg":
        root = ET.fromstring(data)
        assert root.tag.endswith("svg")
        paths = [e for e in root.iter() if e.tag.endswith("path")]
        assert len(paths) > 20, f"{path}: only {len(paths)} <path> elements"
    elif fmt == "pdf":
        assert data[:5] == b"%PDF-" and data.rstrip().endswith(b"%%EOF")
        assert len(data) > 8000, f"{path}: {len(data)} bytes is too small for a drawing"
    else:  # pragma: no cover - a bad parametrization
        raise AssertionError(fmt)


def _assert_colourful(im) -> None:
    rgb = im.convert("RGB")
    colours = rgb.getcolors(maxcolors=1 << 20)  # [(count, colour)], counted by Pillow in C
    assert len(colours) > 16, f"only {len(colours)} colours: a blank picture"
    background = max(colours)[0] / (rgb.width * rgb.height)
    assert background < 0.97, f"{background:.1%} of the pixels are the background colour"


def expected_frames(model: Path) -> tuple[int, int]:
    """Frames of the default animation at STEP = 45, worked out by hand: ``(least, most)``.

    Every shipped model but the double rocker assembles at 0, so the default range is a full
    turn: 0, 45, ..., 360 is 9 rows. The double rocker (r = 60, 50, 20, 45) assembles only for
    24.15 <= |theta2| <= 71.79 (the law of cosines: O4B = r3 + r4 and |r3 - r4|); its default
    sweep traces that arc there and back: at least the two grid points 45 (one per mode), at
    most every 45-degree grid point in the arc, the two limits and the start, on both passes.
    """
    if model.stem != "double_rocker":
        return 9, 9
    r1, r2, r3, r4 = 60, 50, 20, 45
    lo, hi = (math.degrees(math.acos((r1 ** 2 + r2 ** 2 - d ** 2) / (2 * r1 * r2))) for d in (r4 - r3, r4 + r3))
    assert (round(lo, 2), round(hi, 2)) == (24.15, 71.79)
    grid = math.floor(hi / 45) - math.ceil(lo / 45) + 1  # 45 only
    return 2, 2 * (grid + 3)


# ------------------------------------------------------------------- the console script
def _commands(tmp: Path):
    """One subprocess per model and command; the figure format rotates over the models."""
    jobs = []
    for i, model in enumerate(MODELS):
        fmt = FIGURE_FORMATS[i % 3]
        jobs.append(("plot", model, fmt, ["plot", str(model), "--step", STEP, "-q"]))
        jobs.append(("draw", model, FIGURE_FORMATS[(i + 1) % 3], ["draw", str(model), "--vectors"]))
        jobs.append(("animate", model, "gif", ["animate", str(model), "--step", STEP, "--fps", "8", "-q"]))
    out = []
    for command, model, fmt, argv in jobs:
        target = tmp / f"{model.stem}-{command}.{fmt}"
        out.append((command, model, fmt, target, argv + ["-o", str(target)]))
    return out


@pytest.fixture(scope="module")
def console_runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cli")
    jobs = _commands(tmp)
    exe = shutil.which("loopsolve")
    env = dict(os.environ, MPLBACKEND="Agg")

    def run(job):
        command, model, fmt, target, argv = job
        cmd = [exe, *argv] if exe else [sys.executable, "-m", "loopsolve.cli", *argv]
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env)
        return (command, model.stem), (proc, fmt, target, model)

    with ThreadPoolExecutor(max_workers=max(2, os.cpu_count() or 2)) as pool:
        return dict(pool.map(run, jobs))


@pytest.mark.parametrize("command", ["plot", "draw", "animate"])
@pytest.mark.parametrize("model", MODEL_IDS)
def test_console_command_writes_picture(console_runs, command, model):
    proc, fmt, target, path = console_runs[(command, model)]
    assert proc.returncode == 0, proc.stderr
    assert f"wrote {target}" in proc.stderr
    assert_picture(target, fmt)
    if command == "animate":
        least, most = expected_frames(path)
        with Image.open(target) as im:
            assert least <= im.n_frames <= most


# ------------------------------------------- every format, in-process (same code, no start-up)
@pytest.mark.parametrize("fmt", FIGURE_FORMATS)
@pytest.mark.parametrize("model", ["thesis_crank_rocker", "crank_shaper"])
def test_cli_draw_every_format(model, fmt, tmp_path, capsys):
    out = tmp_path / f"d.{fmt}"
    assert cli.main(["draw", str(ls.models_dir() / f"{model}.toml"), "--at", "30", "-o", str(out)]) == 0
    assert_picture(out, fmt)


@pytest.mark.parametrize("fmt", FIGURE_FORMATS)
def test_cli_plot_every_format(fmt, tmp_path, capsys):
    out = tmp_path / f"p.{fmt}"
    model = ls.models_dir() / "example1_slider_crank.toml"
    assert cli.main(["plot", str(model), "--step", "30", "-q", "--vars", "theta3", "r1", "C", "-o", str(out)]) == 0
    assert_picture(out, fmt)


def test_cli_animate_inverted_input(tmp_path, capsys):
    """Driving the slider of Example #1 (--input r1): one frame per row of that sweep."""
    model = ls.models_dir() / "example1_slider_crank.toml"
    out = tmp_path / "inv.gif"
    argv = ["animate", str(model), "--input", "r1", "--mode", "-", "--from", "4", "--to", "12", "--step", "1",
            "-q", "-o", str(out)]
    assert cli.main(argv) == 0
    sw = ls.load(model).sweep(4, 12, 1, input="r1", mode="-")
    with Image.open(out) as im:
        assert im.n_frames == len(sw) == 9
    assert_picture(out, "gif")


@pytest.mark.parametrize("command, name", [("plot", "x.jpg"), ("draw", "x.gif"), ("animate", "x.png")])
def test_cli_rejects_bad_suffix_before_solving(command, name, tmp_path, capsys):
    model = ls.models_dir() / "thesis_crank_rocker.toml"
    assert cli.main([command, str(model), "-o", str(tmp_path / name)]) == 2
    err = capsys.readouterr().err
    assert "ModelError" in err and name in err
    assert not (tmp_path / name).exists()


def test_cli_missing_directory_is_one_line_error(tmp_path, capsys):
    model = ls.models_dir() / "thesis_crank_rocker.toml"
    assert cli.main(["draw", str(model), "-o", str(tmp_path / "no" / "such" / "d.png")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "cannot write" in err


# --------------------------------------------------------------------------- plot_sweep
@pytest.fixture(scope="module")
def thesis():
    return ls.load(ls.models_dir() / "thesis_crank_rocker.toml")


def test_plot_panels_units_and_lines(thesis):
    sw = thesis.sweep(0, 360, 10)
    fig = plotting.plot_sweep(sw, ["theta3", "theta4"])
    axes = fig.axes
    assert [ax.get_ylabel() for ax in axes] == ["angle [deg]", "angular velocity [rad/s]",
                                              "angular acceleration [rad/s²]"]
    assert axes[-1].get_xlabel() == r"$\theta_{2}$ [deg]"
    for ax, col in zip(axes, ("theta4", "theta4_vel", "theta4_acc")):
        lines = [ln for ln in ax.get_lines() if ln.get_label() == r"$\theta_{4}$"]
        assert len(lines) == 1
        np.testing.assert_allclose(lines[0].get_ydata(), sw[col])
    assert "open" in fig.get_suptitle()


def test_plot_groups_by_unit_and_unwraps_angles():
    mech = ls.load(ls.models_dir() / "example1_slider_crank.toml")
    sw = mech.sweep(0, 360, 15)
    fig = sw.plot(["theta3", "r1", "C"])
    labels = sorted(ax.get_ylabel() for ax in fig.axes)
    assert labels == sorted(["angle [deg]", "angular velocity [rad/s]", "angular acceleration [rad/s²]",
                             "position [in]", "velocity [in/s]", "acceleration [in/s²]"])
    length_top = next(ax for ax in fig.axes if ax.get_ylabel() == "position [in]")
    assert [ln.get_label() for ln in length_top.get_lines() if not ln.get_label().startswith("_")] == \
        ["$r_{1}$", "$C_{x}$", "$C_{y}$"]
    # an output that turns fully (a drag link): the table follows the motion and the plot draws the table
    drag = ls.fourbar(20, 60, 50, 60).sweep(0, 360, 10)
    assert np.max(np.abs(np.diff(drag["theta4"]))) < 30 and np.ptp(drag["theta4"]) > 300
    top = drag.plot(["theta4"]).axes[0]
    y = [ln for ln in top.get_lines() if ln.get_label() == r"$\theta_{4}$"][0].get_ydata()
    np.testing.assert_array_equal(y, drag["theta4"])


def test_plot_marks_events(thesis):
    sw = thesis.sweep(0, 180, 30)
    marked = Sweep(sw.compiled, sw.states, (Event(EventKind.LIMIT, 95.0, "a limit"),
                                           Event(EventKind.SINGULAR, 125.0, "dead centre")), sw.mode)
    fig = plotting.plot_sweep(marked)
    for ax in fig.axes:
        xs = sorted(ln.get_xdata()[0] for ln in ax.get_lines() if ln.get_xdata()[0] == ln.get_xdata()[-1]
                    and len(ln.get_xdata()) == 2)
        assert xs == [95.0, 125.0]
    legend = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert "limit at 95" in legend and "singular at 125" in legend


def test_plot_rejects_unknown_variable(thesis):
    with pytest.raises(ModelError, match="theta9.*theta3"):
        plotting.plot_sweep(thesis.sweep(0, 60, 30), ["theta9"])


# -------------------------------------------------------------------------------- draw
def _texts(fig):
    return {t.get_text() for ax in fig.axes for t in ax.texts}


def _hatched(fig):
    return [p for p in fig.axes[0].patches if p.get_hatch()]


def test_draw_fourbar(thesis):
    fig = thesis.draw(90, vectors=True)
    ax = fig.axes[0]
    assert ax.get_aspect() == 1.0
    assert {"B", "C", "O2", "O4"} <= _texts(fig)
    assert {"$r_{1}$", "$r_{2}$", "$r_{3}$", "$r_{4}$"} <= _texts(fig)
    assert len(_hatched(fig)) == 2  # two ground pivots
    assert ax.get_xlabel() == "x [mm]" and ax.get_ylabel() == "y [mm]"
    # the joint circles sit on the solved points
    state = thesis.solve(90)
    centres = {tuple(np.round(p.center, 9)) for p in ax.patches if hasattr(p, "center")}
    for name in ("B", "C"):
        assert (round(state[name + "_x"], 9), round(state[name + "_y"], 9)) in centres


def test_draw_slider_blocks_and_guides():
    prob2 = ls.load(ls.models_dir() / "prob2_offset_slider_crank.toml")
    state = prob2.solve(40)
    fig = plotting.draw(state)
    ax = fig.axes[0]
    blocks = [p for p in ax.patches if p.get_facecolor()[:3] == pytest.approx((0xF4 / 255, 0xD0 / 255, 0x3F / 255))]
    assert len(blocks) == 1
    centre = blocks[0].get_xy()[:4].mean(axis=0)
    # the block sits at the slider pin B (on the offset line y = e), not at the tip of r1
    np.testing.assert_allclose(centre, [state["B_x"], state["B_y"]], atol=1e-9)
    assert len(_hatched(fig)) == 2  # the crank pivot and the fixed guide
    assert {"O2", "A", "B"} <= _texts(fig)


def test_draw_ternary_link_is_a_triangle():
    spec = {
        "name": "four-bar with a coupler point", "units": {"length": "mm", "angle": "deg"},
        "parameters": {"r1": 60, "r2": 25, "r3": 70, "r4": 45, "r5": 40},
        "variables": {"theta2": {"input": True, "guess": 90}, "theta3": {"guess": 20}, "theta4": {"guess": 80}},
        "vectors": {"r1": {"length": "r1", "angle": 0}, "r2": {"length": "r2", "angle": "theta2"},
                    "r3": {"length": "r3", "angle": "theta3"}, "r4": {"length": "r4", "angle": "theta4"},
                    "r5": {"length": "r5", "angle": "theta3", "offset": 40}},
        "loops": [{"equation": "r2 + r3 = r1 + r4"}],
        "points": {"B": "r2", "C": "r2 + r3", "P": "r2 + r5"},
    }
    mech = ls.build_mechanism(spec)
    fig = mech.draw(60)
    state = mech.solve(60)
    from matplotlib.patches import Polygon

    polys = [p for p in fig.axes[0].patches if isinstance(p, Polygon) and not p.get_hatch()
             and len(p.get_xy()) == 4 and p.get_alpha() == pytest.approx(0.35)]
    assert len(polys) == 1  # the coupler B-C-P (closed polygon: 3 corners + repeat)
    corners = {tuple(np.round(c, 6)) for c in polys[0].get_xy()[:3]}
    assert corners == {tuple(np.round([state[f"{n}_x"], state[f"{n}_y"]], 6)) for n in "BCP"}
    assert "P" in _texts(fig)


def test_draw_second_loop_anchored_on_shared_vector():
    """A loop starting at O4 (not the origin) is placed from the vector it shares with loop 1."""
    spec = {
        "name": "two loops", "units": {"length": "mm", "angle": "deg"},
        "parameters": {"r1": 60, "r2": 25, "r3": 70, "r4": 45, "r5": 50, "r6": 40, "r7": 60},
        "variables": {"theta2": {"input": True, "guess": 90}, "theta3": {"guess": 20}, "theta4": {"guess": 80},
                      "theta5": {"guess": 10}, "theta7": {"guess": 75}},
        "vectors": {"r1": {"length": "r1", "angle": 0}, "r2": {"length": "r2", "angle": "theta2"},
                    "r3": {"length": "r3", "angle": "theta3"}, "r4": {"length": "r4", "angle": "theta4"},
                    "r5": {"length": "r5", "angle": "theta5"}, "r6": {"length": "r6", "angle": 0},
                    "r7": {"length": "r7", "angle": "theta7"}},
        "loops": [{"equation": "r2 + r3 = r1 + r4"}, {"equation": "r4 + r5 = r6 + r7"}],
        "points": {"C": "r2 + r3", "E": "r1 + r4 + r5", "F": "r1 + r6"},
    }
    mech = ls.build_mechanism(spec)
    state = mech.solve(90)
    st = skeleton.diagram_structure(state.compiled, [state])
    pos, _ = skeleton.node_positions(st, state.compiled, state)
    for name, node in st.point_node.items():
        np.testing.assert_allclose(pos[node], [state[name + "_x"], state[name + "_y"]], atol=1e-9)
    assert st.point_node["F"] in st.fixed  # O4 + r6 is a ground pivot
    fig = mech.draw(90)
    assert len(_hatched(fig)) == 3


@pytest.mark.parametrize("model", MODELS, ids=MODEL_IDS)
def test_geometry_matches_solved_points(model):
    mech = ls.load(model)
    state = mech.solve()
    st = skeleton.diagram_structure(state.compiled, [state])
    pos, disp = skeleton.node_positions(st, state.compiled, state)
    tails = {v: pos[st.node_of[("tail", v)]] for v in st.vectors}
    for name, node in st.point_node.items():
        np.testing.assert_allclose(pos[node], [state[name + "_x"], state[name + "_y"]], atol=1e-8)
    for loop in mech.loops:  # walking each loop from its start meets every vector where it was placed
        seq = skeleton._walk_sequence(loop)
        sign, first = seq[0]
        start = tails[first] if sign > 0 else tails[first] + disp[first]
        cur = start.copy()
        for sign, v in seq:
            if sign > 0:
                np.testing.assert_allclose(tails[v], cur, atol=1e-8)
                cur = cur + disp[v]
            else:
                cur = cur - disp[v]
                np.testing.assert_allclose(tails[v], cur, atol=1e-8)
        np.testing.assert_allclose(cur, start, atol=1e-8)


def test_draw_into_given_axes(thesis):
    import matplotlib.figure

    fig = matplotlib.figure.Figure()
    axes = fig.subplots(1, 2)
    assert thesis.draw(0, ax=axes[1]) is fig
    assert axes[1].get_title().startswith("Crank-rocker") and not axes[0].get_title()


# ------------------------------------------------------------------------------ animate
def test_animate_frames_traces_and_progress(thesis, tmp_path, capsys):
    sw = thesis.sweep(0, 360, 30)
    out = plotting.animate(sw, output=tmp_path / "a.gif", fps=10, progress=True)
    assert out == tmp_path / "a.gif"
    with Image.open(out) as im:
        assert im.n_frames == len(sw) == 13
        assert im.info["duration"] == 100
        frames = []
        for k in (0, 6):
            im.seek(k)
            frames.append(np.asarray(im.convert("RGB")).astype(int))
    assert np.abs(frames[0] - frames[1]).sum() > 0  # the linkage moves
    assert "rendering" in capsys.readouterr().err  # the tqdm bar


def test_animate_rejects_bad_arguments(thesis, tmp_path):
    sw = thesis.sweep(0, 60, 30)
    with pytest.raises(ModelError, match=r"\.gif, \.mp4"):
        plotting.animate(sw, output=tmp_path / "a.avi")
    with pytest.raises(ModelError, match="fps"):
        plotting.animate(sw, output=tmp_path / "a.gif", fps=0)
    with pytest.raises(ModelError, match="empty"):
        plotting.animate(Sweep(sw.compiled, ()), output=tmp_path / "a.gif")


def test_mp4_needs_ffmpeg(thesis, tmp_path, monkeypatch):
    monkeypatch.setattr(plotting.shutil, "which", lambda name: None)
    with pytest.raises(MissingDependencyError, match="ffmpeg"):
        plotting.animate(thesis.sweep(0, 60, 30), output=tmp_path / "a.mp4")
    assert not (tmp_path / "a.mp4").exists()


@pytest.mark.skipif(shutil.which("ffmpeg") is None and not (os.environ.get("LOOPSOLVE_REQUIRE_TEX")
                                                           or os.environ.get("CI")),
                    reason="environment: the ffmpeg program is not installed (in CI, where LOOPSOLVE_REQUIRE_TEX "
                    "or CI is set, this test runs and fails without it)")
def test_mp4_with_ffmpeg(thesis, tmp_path):
    out = plotting.animate(thesis.sweep(0, 360, 30), output=tmp_path / "a.mp4", fps=10)
    data = out.read_bytes()
    assert data[4:8] == b"ftyp" and len(data) > 5000


# ----------------------------------------------------------------- missing plot extra
@pytest.mark.parametrize("missing", ["matplotlib", "PIL"])
def test_missing_extra_names_it(missing, thesis, monkeypatch, tmp_path, capsys):
    for name in list(sys.modules):
        if name == missing or name.startswith(missing + "."):
            monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, missing, None)  # `import missing` now raises ImportError
    with pytest.raises(MissingDependencyError, match=r"loopsolve\[plot\]"):
        thesis.draw(90)
    with pytest.raises(ImportError):  # also an ImportError, for callers that catch that
        plotting.plot_sweep(thesis.sweep(0, 60, 30))
    code = cli.main(["draw", str(ls.models_dir() / "thesis_crank_rocker.toml"), "-o", str(tmp_path / "d.png")])
    assert code == 2
    assert "loopsolve[plot]" in capsys.readouterr().err


# ----------------------------------------------------------- branches meet at a limit (issue 9)
@pytest.fixture(scope="module")
def double_rocker_sweep():
    mech = ls.load(ls.models_dir() / "double_rocker.toml")
    return mech, mech.sweep(28, 72, 4, through_limits=True)


def _line(fig, name=r"$\theta_{4}$", panel=0):
    return next(ln for ln in fig.axes[panel].get_lines() if ln.get_label() == name)


def _joined_pairs(x, y):
    """Consecutive plotted points that a line segment joins (NaN lifts the pen)."""
    return [(i, i + 1) for i in range(len(x) - 1) if np.isfinite([x[i], y[i], x[i + 1], y[i + 1]]).all()]


def test_plot_never_joins_two_modes_without_the_limit_row(double_rocker_sweep):
    """The rows on both modes: the lines of each mode end at 68 and 68, and nothing joins them."""
    _, sw = double_rocker_sweep
    modes = list(sw.modes)
    assert set(modes) == {"-", "+"}
    fig = plotting.plot_sweep(sw, ["theta4"])
    line = _line(fig)
    x, y = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
    limit = sw.events[0].input
    assert limit == pytest.approx(71.79004, abs=1e-4)
    at_limit = [abs(v - limit) < 1e-6 for v in sw[sw.compiled.inputs[0]]]
    rows = iter(range(len(sw)))
    index = [next(rows) if np.isfinite(v) else None for v in x]  # plotted point -> row
    for i, j in _joined_pairs(x, y):
        a, b = index[i], index[j]
        assert modes[a] == modes[b] or at_limit[a] or at_limit[b], (x[i], x[j])


def test_plot_branches_meet_at_the_limit_row(double_rocker_sweep):
    """With a row at the located limit, both branches run into it; its rates are left blank."""
    mech, sw = double_rocker_sweep
    states = list(sw.states)
    k = next(i for i in range(len(states) - 1) if states[i].mode != states[i + 1].mode)
    limit = sw.events[0].input
    # the toggle: coupler and rocker in line, O2-C = ... the rocker pin C on the circle about B;
    # theta4 where O4C meets B at r3 + r4 (law of cosines in triangle O2 O4 B)
    t2 = math.radians(limit)
    bx, by = 50 * math.cos(t2), 50 * math.sin(t2)
    d = math.hypot(bx - 60, by)
    assert d == pytest.approx(20 + 45, abs=1e-6)  # stretched: the limit position
    theta4_limit = math.degrees(math.atan2(by, bx - 60))
    row = mech.solve(limit - 1e-9, mode=states[k].mode)
    assert row["theta4"] == pytest.approx(theta4_limit, abs=1e-3)
    events = tuple(type(e)(e.kind, row.input_value, e.message) for e in sw.events)
    with_limit = Sweep(sw.compiled, states[:k + 1] + [row] + states[k + 1:], events, sw.mode)
    fig = plotting.plot_sweep(with_limit, ["theta4"])
    x = np.asarray(_line(fig).get_xdata(), float)
    y = np.asarray(_line(fig).get_ydata(), float)
    assert np.isfinite(y).all() and len(y) == len(with_limit)  # one unbroken line through the limit
    assert x.max() == pytest.approx(limit, abs=1e-6)
    vel = np.asarray(_line(fig, panel=1).get_ydata(), float)
    assert np.isnan(vel[k + 1]) and np.isfinite(np.delete(vel, k + 1)).all()


# ------------------------------------------------------------ vectors on a Watt I (issue 9)
def test_watt1_vectors_tip_to_tail_on_the_joints():
    """Every loop vector of a diagram runs from one joint (or the origin) to another joint."""
    mech = ls.load(ls.models_dir() / "watt1_sixbar.toml")
    assert mech.loops[1].text == "r_crank + r_coupler_F = r_crank_E + r_link5 + r_link6"
    state = mech.solve(60)
    frames, _ = geometry.pose_frames([state], vectors=True)
    joints = {n: np.array([state[n + "_x"], state[n + "_y"]]) for n in ("O2", "A", "B", "O4", "E", "F", "G")}
    ends = {"r_crank": ("O2", "A"), "r_crank_E": ("O2", "E"), "r_coupler": ("A", "B"), "r_coupler_F": ("A", "F"),
            "r_rocker": ("O4", "B"), "r_link5": ("E", "G"), "r_link6": ("G", "F"), "r_ground_O4": ("O2", "O4")}
    arrows = {name: (tail, head) for tail, head, name in frames[0].arrows}
    assert set(arrows) == set(ends)
    for name, (a, b) in ends.items():
        np.testing.assert_allclose(arrows[name][0], joints[a], atol=1e-9, err_msg=name)
        np.testing.assert_allclose(arrows[name][1], joints[b], atol=1e-9, err_msg=name)


@pytest.mark.parametrize("model", ["watt1_sixbar", "thesis_crank_rocker", "fourbar_coupler_curve"])
def test_vector_names_beside_their_arrows_clear_of_the_links(model):
    """A vector's name sits off the arrow's side that is clear of bars and outside plates."""
    mech = ls.load(ls.models_dir() / f"{model}.toml")
    frames, _ = geometry.pose_frames([mech.solve()], vectors=True)
    style = drawstyle.drawing_style(frames)
    f = frames[0]
    sides = drawstyle.arrow_label_sides(f, style)
    plates = [np.asarray(xy, float)[geometry.hull_order(np.asarray(xy, float))] for _, xy, _ in f.links
              if len(xy) >= 3]
    bars = [(np.asarray(xy[0], float), np.asarray(xy[1], float)) for _, xy, _ in f.links if len(xy) == 2]
    for (tail, head, name), (mid, n) in zip(f.arrows, sides):
        d = (np.asarray(head) - tail) / np.linalg.norm(np.asarray(head) - tail)
        assert abs(float(n @ d)) < 1e-12 and np.linalg.norm(n) == pytest.approx(1.0)  # perpendicular
        label = mid + n * 0.9 * style.size
        for a, b in bars:
            t = np.clip((label - a) @ (b - a) / ((b - a) @ (b - a)), 0, 1)
            assert np.linalg.norm(label - a - t * (b - a)) > 0.5 * style.size, (name, a, b)
        other = mid - n * 0.9 * style.size  # a chord across a plate has the plate on both sides
        if any(drawstyle._inside(label, poly) for poly in plates):
            assert any(drawstyle._inside(other, poly) for poly in plates), name


# ------------------------------------------------------------------- frame cap (issue 9)
def test_animate_step_0001_is_refused_before_any_sweep(tmp_path, capsys):
    out = tmp_path / "a.gif"
    model = ls.models_dir() / "thesis_crank_rocker.toml"
    assert cli.main(["animate", str(model), "--step", "0.001", "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "360001 frames" in err and "--max-frames" in err
    assert not out.exists()
    # a range given explicitly is counted the same way: 0, 0.5, ..., 10 is 21 frames
    assert cli.main(["animate", str(model), "--from", "0", "--to", "10", "--step", "0.5", "--max-frames", "20",
                     "-o", str(out)]) == 2
    assert "21 frames" in capsys.readouterr().err and not out.exists()


def test_animate_caps_frames_before_rendering(thesis, tmp_path):
    sw = thesis.sweep(0, 60, 10)  # 7 rows
    with pytest.raises(ModelError, match=r"7 frames.*cap of 6.*--max-frames"):
        plotting.animate(sw, output=tmp_path / "a.gif", max_frames=6)
    assert not (tmp_path / "a.gif").exists()
    assert plotting.frames_before_sweep(thesis, None, None, "0.001") == 360001
    assert plotting.frames_before_sweep(thesis, "0", "1rad", "1") == 58  # 57.3 deg by 1 deg


# --------------------------------------------------------- tracer point on a diagram (issue 9)
def test_coupler_point_is_drawn_as_a_point_and_traced(tmp_path):
    mech = ls.load(ls.models_dir() / "fourbar_coupler_curve.toml")
    state = mech.solve(60)
    frames, _ = geometry.pose_frames([state], vectors=False)
    f = frames[0]
    p = np.array([state["P_x"], state["P_y"]])
    assert any(np.allclose(q, p) for q, _ in f.points)  # a dot, not a pin
    assert not any(np.allclose(q, p) for q in f.joints)
    coupler = next(xy for key, xy, _ in f.links if key == "coupler")
    assert any(np.allclose(q, p) for q in coupler)  # part of the coupler plate
    fig = plotting.draw(state)
    assert "P" in _texts(fig)


@pytest.mark.parametrize("model", ["quick_return", "thesis_crank_rocker", "prob2_offset_slider_crank"])
def test_drawing_does_not_depend_on_the_hash_seed(tmp_path, model):
    """Pivots, joints and labels are drawn in a fixed order: the same SVG under two hash seeds."""
    code = ("import matplotlib; matplotlib.rcParams['svg.hashsalt'] = 'loopsolve'\n"
            "import loopsolve as ls, sys\n"
            f"ls.load(ls.models_dir() / '{model}.toml').draw(None, vectors=True, output=sys.argv[1])\n")
    outs = []
    for seed in ("0", "1"):
        out = tmp_path / f"{seed}.svg"
        env = dict(os.environ, PYTHONHASHSEED=seed, SOURCE_DATE_EPOCH="0", MPLBACKEND="Agg")
        subprocess.run([sys.executable, "-c", code, str(out)], check=True, env=env, capture_output=True)
        outs.append(out.read_bytes())
    assert outs[0] == outs[1]
